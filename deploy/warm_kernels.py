"""Compile every numba kernel once, so no node pays the compile on its first plan or scan.

``python -m deploy.warm_kernels`` (run by ``deploy/install.sh`` and ``zenav fleet install``): small but
real calls through the planners' and SLAM's public entry points, so the kernels are compiled for the
argument types the nodes use and land in numba's on-disk cache (``__pycache__`` beside each module, or
the user's cache when that is read-only). Later processes load them in milliseconds; a cold compile
costs a few seconds per component (the simulator's sonar ring too). Prints one line per component.
(move_base also warms its planners at start, ``master_side.planning.warmup``, so its first control cycle
does not start numba.)
"""

from __future__ import annotations

import sys
import time


def _planners() -> None:
    from master_side.planning.warmup import warm_local_planners, warm_navfn

    warm_navfn()
    warm_local_planners()


def _slam() -> None:
    from master_side.slam.warmup import warm_filter

    warm_filter()


def _simulator() -> None:
    from robot_side.sim.sonar import warm_kernel

    warm_kernel()


COMPONENTS = {"planners (navfn, DWA, trajectory rollout)": _planners, "SLAM (gmapping filter)": _slam,
              "simulator (sonar ring)": _simulator}


def _timed(name: str) -> float:
    t0 = time.monotonic()
    COMPONENTS[name]()
    return time.monotonic() - t0


def main() -> int:
    """The components compile at once, each in its own process (numba compiles on one core; the SLAM
    filter's kernels take the longest): the install waits for the slowest, not the sum."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed

    with ProcessPoolExecutor(len(COMPONENTS), mp_context=multiprocessing.get_context("fork")) as pool:
        jobs = {pool.submit(_timed, name): name for name in COMPONENTS}
        for job in as_completed(jobs):
            print(f"zenav kernels: {jobs[job]} ready ({job.result():.1f} s)", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
