"""move_base: the state machine linking global planner, local planner and recovery behaviours."""
