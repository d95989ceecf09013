"""MRPB 1.0 (Wen et al., ICRA 2021) as a benchmark of the whole stack: ``cases`` (its environments and
start/goal tests from ``../shared/datasets/mrpb``), ``metrics`` (its safety, efficiency and smoothness
metrics over a run's ground truth), ``inproc`` (a case in one process) and ``bus`` (a case over the bus, as
a user runs it). ``bench/mrpb.py`` runs them."""
