"""gmapping-style Rao-Blackwellised particle filter SLAM (pure algorithm + offline runner + evaluation)."""
