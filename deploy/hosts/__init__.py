"""Data files for a robot or master PC: systemd units, the udev rule, the environment file, the example
fleet inventory and ``install-robot.sh`` (read as package data; no code here)."""
