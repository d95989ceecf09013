"""Rigs shared by the tests and the benchmarks (not part of the installed package): a user-space network
link with delay, loss and partitions between namespaces (``linkem``), and the bus peers the reconnect
benchmark runs on each side of it."""

import common  # noqa: F401  (first: one BLAS thread per process, see common/__init__.py)
