"""Exploration (explore_lite's role): frontiers between known free space and unknown space on the global
costmap (``frontiers``), and the choice of where to go next, with blacklisting and progress timeouts
(``explorer``). Pure: numpy arrays in, decisions out; ``zenav explore``'s node adapts them to the bus."""
