"""zenav's shared layer: messages and codec, the Zenoh bus, TF, clock, configuration.

One BLAS thread per process. Every zenav node is a process of its own, and numpy's OpenBLAS starts a
thread per core in each one that imports it; idle, those threads spin before they sleep. On a robot PC
running twenty nodes that is CPU taken from the nodes (measured: importing numpy and the bus took 0.28 s
of CPU with the pool, 0.14 s without), and our arrays are small (N x 2 by 2 x 2), so one thread loses
nothing. Set here, before numpy is imported, so every child a node or agent starts inherits it; a value
already in the environment wins. The other top-level packages import this one first for the same reason.
"""

import os as _os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS"):
    _os.environ.setdefault(_var, "1")
