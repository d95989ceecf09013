"""Localisation on a known map: AMCL (adaptive Monte Carlo localisation, as ROS's ``amcl``)."""
