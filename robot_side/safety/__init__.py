"""Robot-side safety: the collision monitor between the master\x27s cmd_vel and the base."""
