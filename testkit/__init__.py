"""Rigs shared by the tests and the benchmarks (not part of the installed package): a user-space network
link with delay, loss and partitions between namespaces (``linkem``), and the bus peers the reconnect
benchmark runs on each side of it."""
