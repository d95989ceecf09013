"""A robot and its master on this machine: the agents as processes on a private loopback network
(``process_group``), the same nodes in one process on one simulated clock (``inproc``), the tutorial's
demo (``demo``), goals sent and followed (``goals``), maps exported from simulator worlds
(``world_maps``) and a SLAM map measured against its world (``map_check``)."""
