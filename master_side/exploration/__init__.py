"""Exploration (explore_lite's role): frontiers between known free space and unknown space on a map or
costmap (``frontiers``), and the choice of where to go next, with blacklisting and progress timeouts
(``explorer``). Pure: numpy arrays in, decisions out; ``zenav explore`` (deploy/stack/explore.py) runs
them over the bus."""
