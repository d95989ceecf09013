"""Two-machine deployment: Zenoh config generation (``zenohconf``), host templates (systemd units,
udev rule, env file) and ``install-robot.sh``. Used by ``zenav zenoh`` and ``zenav doctor``."""
