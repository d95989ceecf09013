"""zenav robot side: drivers, sensors, depth conversion, the simulator, the robot agent."""

import common  # noqa: F401  (first: one BLAS thread per process, see common/__init__.py)
