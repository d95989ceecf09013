"""zenav master side: SLAM, AMCL, map server, costmaps, planners, move_base, the master agent."""

import common  # noqa: F401  (first: one BLAS thread per process, see common/__init__.py)
