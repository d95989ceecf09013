"""``zenav fleet``: install, start, watch and upgrade robots and masters from one machine over SSH.

inventory   fleet.yaml -> frozen dataclasses (validated: file / key / why)
ssh         the system ssh client via subprocess (commands, file upload, checkout upload)
render      per-host files: env file, Zenoh config (+ users file, ACL), systemd units, udev rule
secured     security.cmd_vel_acl: a Zenoh router per robot / master host, its processes its clients
host_router runs ON a secured host: its router, then the agent (the service's command)
install     copy the checkout, venv, pip install -e, files, service definition (idempotent, --dry-run)
services    systemd when the host runs it, else a pidfile supervisor (supervise.py) under install_dir
probe       runs ON a host: liveliness nodes and topic rates of its robot, as JSON
status      the per-host table with what is wrong and how to fix it
ops         up / down / restart / logs / rolling upgrade
"""


class FleetError(RuntimeError):
    """An operation on a host failed: the message names the host and what to do."""
