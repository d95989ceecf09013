"""The BARN challenge harness: its rules and verdict (``rules``: worlds, time limit, score), a world run
over the bus as a user runs it (``bus``) and in one process, faster than real time (``inproc``).
``bench/barn.py`` drives both."""
