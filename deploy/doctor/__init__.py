"""The checks of ``zenav doctor``: this host (``host_checks``: serial ports, udev, groups, Zenoh config)
and the bus (``bus_checks``: sessions, scouting, robots' topics and routes)."""
