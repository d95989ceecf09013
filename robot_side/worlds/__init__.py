"""Simulator worlds (shapes YAML): room.yaml and corridor.yaml reproduce the tutorial section 4.3 tests."""
