"""Bumpers: which segment a contact presses (the simulator) and pressed segments as points for a costmap."""
