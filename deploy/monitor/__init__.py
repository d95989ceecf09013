"""Rerun monitor (our rviz)."""
