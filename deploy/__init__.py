"""zenav deployment: everything that runs whole systems on real machines, by part.

- ``deploy.cli``: the ``zenav`` command, one thin module per subcommand (argument parsing and printing).
- ``deploy.stack``: a robot and its master on this machine — the agents as processes (``process_group``),
  the same nodes in one process (``inproc``), the demo, world maps and the SLAM map check.
- ``deploy.barn``: the BARN challenge harness (rules and verdict, bus and in-process runners).
- ``deploy.monitor``: the Rerun monitor (our rviz). ``deploy.logs``: record and play.
- ``deploy.fleet``: several hosts from one inventory. ``deploy.doctor``: the checks of ``zenav doctor``.
- ``deploy.zenohconf``: Zenoh configuration files (auth, TLS, ACL). ``deploy.hosts``: data files only
  (systemd units, udev rule, install script, example inventory).
"""

import common  # noqa: F401  (first: one BLAS thread per process, see common/__init__.py)
