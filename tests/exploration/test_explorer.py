"""The choice of the next target (master_side/exploration/explorer.py): new targets, progress timeouts
and move_base failures blacklist, the end when nothing is left."""

from __future__ import annotations

import numpy as np

from master_side.exploration.explorer import ExploreParams, Explorer
from master_side.exploration.frontiers import Frontier


def _f(x: float, y: float, cost: float, dist: float = 2.0) -> Frontier:
    return Frontier(10, 1.0, (x, y), (x - 0.5, y), dist, cost, np.zeros((0, 2)), (x, y))


def test_a_new_target_is_sent_and_the_same_one_kept_while_it_gets_nearer():
    ex = Explorer(ExploreParams(progress_timeout=30.0))
    d = ex.plan([_f(3, 0, -2.0), _f(-3, 0, -1.0)], now=0.0)
    assert (d.action, d.target) == ("send", (3, 0))
    assert ex.plan([_f(3, 0, -2.0, dist=1.5)], now=20.0).action == "keep"
    assert ex.plan([_f(3, 0, -2.0, dist=1.0)], now=45.0).action == "keep"  # nearer at 45 s: progress


def test_no_progress_for_progress_timeout_blacklists_the_target_and_takes_the_next():
    ex = Explorer(ExploreParams(progress_timeout=30.0))
    fs = [_f(3, 0, -2.0), _f(-3, 0, -1.0)]
    ex.plan(fs, now=0.0)
    assert ex.plan(fs, now=29.0).action == "keep"
    d = ex.plan(fs, now=31.0)  # 31 s at the same distance
    assert (d.action, d.target) == ("send", (-3, 0))
    assert ex.blacklisted((3.2, 0.1)) and not ex.blacklisted((3.6, 0.0))  # within blacklist_radius 0.5 m
    assert ex.take_blacklisted() == [((3, 0), "no nearer for 30 s (still 2.0 m away)")]  # said once
    assert ex.take_blacklisted() == []


def test_a_failed_goal_is_never_chosen_again_and_all_blacklisted_is_the_end():
    ex = Explorer()
    fs = [_f(3, 0, -2.0), _f(-3, 0, -1.0)]
    assert ex.plan(fs, 0.0).target == (3, 0)
    ex.goal_failed((3, 0))
    assert ex.plan(fs, 1.0).target == (-3, 0)
    ex.goal_failed((-3, 0))
    d = ex.plan(fs, 2.0)
    assert d.action == "wait" and d.why == "all 2 frontiers blacklisted"
    d = ex.plan(fs, 2.0 + ex.params.done_timeout)
    assert d.action == "done" and d.why == "all 2 frontiers blacklisted"
    assert Explorer(ExploreParams(done_timeout=0.0)).plan([], 0.0).why == "no frontier left"


def test_the_end_needs_nothing_to_go_to_for_done_timeout_and_a_new_frontier_meanwhile_restarts_the_wait():
    """The mall: one frontier in view early on, blacklisted, and explore_lite's rule (the end on one search)
    ended the run at 2.5 % known. Now nothing to go to must last ``done_timeout`` s of the robot's clock."""
    ex = Explorer(ExploreParams(done_timeout=15.0))
    assert ex.plan([], 0.0).action == "wait"
    assert ex.plan([], 14.0).action == "wait"
    assert ex.plan([_f(3, 0, -2.0)], 14.5).action == "send"  # the map grew while waiting
    ex.goal_failed((3, 0))
    assert ex.plan([_f(3, 0, -2.0)], 20.0).action == "wait"  # a new wait, from 20 s
    assert ex.plan([], 34.0).action == "wait"
    d = ex.plan([], 35.0)
    assert (d.action, d.why) == ("done", "no frontier left")


def test_the_target_is_followed_until_reached_though_a_cheaper_frontier_shows_up():
    """explore_lite takes the cheapest frontier every cycle: near-equal frontiers traded places as the map grew
    and the robot went back and forth. Here the followed frontier stays the target while it is there; a new
    goal goes out only when its frontier moved on by more than commit_radius; after goal_reached the cheapest
    is chosen; a frontier that is gone (explored) ends the commitment too."""
    ex = Explorer(ExploreParams(progress_timeout=30.0, commit_radius=1.0))
    assert ex.plan([_f(3, 0, -2.0)], now=0.0).action == "send"
    d = ex.plan([_f(-3, 0, -9.0), _f(3.3, 0, -2.0, dist=1.5)], now=1.0)  # cheapest first, as search gives them
    assert (d.action, d.target) == ("keep", (3.3, 0))  # followed, not the cheaper one
    grown = Frontier(27, 2.7, (4.5, 0), (3.2, 0), 1.4, -2.0, np.column_stack((np.linspace(3.2, 5.8, 27), np.zeros(27))),
                     (4.5, 0))  # the same frontier, grown: a cell 0.2 m from the goal sent, its own goal 1.5 m on
    d = ex.plan([_f(-3, 0, -9.0), grown], now=2.0)
    assert (d.action, d.target) == ("send", (4.5, 0)) and ex.goal == (4.5, 0)  # moved on: sent again
    ex.goal_reached()
    assert ex.plan([_f(-3, 0, -9.0), grown], now=3.0).target == (-3, 0)
    assert ex.plan([_f(9, 9, -1.0)], now=4.0).target == (9, 9)  # (-3, 0) explored: gone


def test_a_reached_goal_whose_frontier_stays_is_blacklisted_at_its_second_reach():
    """The mall: the robot stood at a goal 0.2 m from its frontier, which stayed (SLAM took no scan of it);
    picked afresh after each 'goal reached', its progress clock was reset and the same goal went out every
    second for good. explore_lite keeps the clock of its previous goal, and so do we; and a goal reached
    twice with its frontier no nearer is not sent a third time (it went out every second for 30 s)."""
    ex = Explorer(ExploreParams(progress_timeout=30.0))
    stays, other = _f(3, 0, -2.0, dist=0.2), _f(-3, 0, -1.0, dist=5.0)
    assert ex.plan([stays, other], now=0.0).target == (3, 0)
    ex.goal_reached()
    assert ex.plan([stays, other], now=1.0).target == (3, 0)  # once more: it may see it this time
    ex.goal_reached()
    d = ex.plan([stays, other], now=2.0)
    assert (d.action, d.target) == ("send", (-3, 0)) and ex.blacklisted((3, 0))
    assert ex.take_blacklisted() == [((3, 0), "its goal reached twice, the frontier still 0.2 m away")]
    # without reaches, the progress clock alone blacklists it
    ex1 = Explorer(ExploreParams(progress_timeout=30.0))
    assert ex1.plan([stays, other], now=0.0).target == (3, 0)
    assert ex1.plan([stays, other], now=20.0).action == "keep"
    assert ex1.plan([stays, other], now=31.0).target == (-3, 0) and ex1.blacklisted((3, 0))
    # a frontier that comes nearer after a reach is progress: its clock starts again
    ex2 = Explorer(ExploreParams(progress_timeout=30.0))
    ex2.plan([_f(3, 0, -2.0, dist=1.0)], now=0.0)
    ex2.goal_reached()
    ex2.plan([_f(3, 0, -2.0, dist=0.5)], now=29.0)
    ex2.goal_reached()
    assert ex2.plan([_f(3, 0, -2.0, dist=0.5)], now=50.0).target == (3, 0)  # 21 s since the progress at 29 s


def test_driving_on_its_way_counts_as_progress_for_a_while_and_standing_does_not():
    """The mall: a shop's door 4 m away by a 12 m path round a wall; the first half of the way leads away
    from it, and 30 s without getting nearer gave the shop up. With ``progress_travel`` a robot that keeps
    getting 1 m from where it last progressed is on its way; one that stands (or rocks in place) is not; and
    a way that never gets nearer ends after 4 progress timeouts."""
    fs = [_f(3, 0, -2.0), _f(-3, 0, -1.0)]
    ex = Explorer(ExploreParams(progress_timeout=30.0, progress_travel=1.0))
    assert ex.plan(fs, 0.0, (0.0, 0.0)).target == (3, 0)
    for t in range(10, 151, 10):  # 1.2 m further along every 10 s, the frontier no nearer
        d = ex.plan(fs, float(t), (0.0, -0.12 * t))
        assert d.action == "keep", (t, d)
    d = ex.plan(fs, 151.0, (0.0, -0.12 * 151))
    assert (d.action, d.target) == ("send", (-3, 0))  # 4 progress timeouts after it last got nearer
    assert ex.take_blacklisted()[0][1].startswith("no nearer for 30 s")
    # rocking back and forth never gets 1 m from where it last progressed
    ex = Explorer(ExploreParams(progress_timeout=30.0, progress_travel=1.0))
    ex.plan(fs, 0.0, (0.0, 0.0))
    for t in range(1, 31):
        assert ex.plan(fs, float(t), (0.4 * (t % 2), 0.0)).action == "keep"
    assert ex.plan(fs, 31.0, (0.0, 0.0)).target == (-3, 0)
    # 0: explore_lite's rule, driving or not
    ex = Explorer(ExploreParams(progress_timeout=30.0, progress_travel=0.0))
    ex.plan(fs, 0.0, (0.0, 0.0))
    ex.plan(fs, 20.0, (0.0, -3.0))
    assert ex.plan(fs, 31.0, (0.0, -6.0)).target == (-3, 0)


def test_goals_failing_in_a_row_where_the_robot_stands_end_exploration_as_stuck_saying_why():
    """office02, the Kinect robot boxed in by its local costmap (2026-12-01): 26 goals failed in a row from one
    place, every frontier was blacklisted and the run ended as if nothing were left. Now the third failure in a
    row from one place (within STUCK_RADIUS) says the robot is stuck, where and why; a failure with the robot
    elsewhere starts the count again, so does a goal reached, and a goal with no plan (out of reach) does not
    count."""
    fs = [_f(x, 0, -float(x)) for x in (3, 4, 5, 6, 7, 8)]
    why = "aborted: controller failed for 16.4 s: all 24 trajectories rejected (after 4 recoveries)"
    ex = Explorer()
    for k, robot in enumerate([(1.0, 1.0), (1.1, 1.0), (2.0, 1.0), (2.05, 1.1)]):  # moved on after the second
        ex.plan(fs, float(k))
        ex.goal_failed(ex.target, robot, why)
    assert ex.stuck == ""
    ex.plan(fs, 5.0)
    ex.goal_failed(ex.target, (2.0, 0.95), "aborted: no plan for 5.2 s: no path (after 4 recoveries)", no_plan=True)
    assert ex.stuck == ""  # a frontier out of reach says nothing of the robot
    ex.plan(fs, 6.0)
    ex.goal_failed(ex.target, (1.95, 1.0), why)
    assert ex.stuck == f"stuck at (1.95, 1.00): 3 goals in a row failed with the robot there, the last: {why}"
    # a goal reached in between starts the count again; stuck_failures 0: never stuck
    ex = Explorer()
    ex.plan(fs, 0.0)
    ex.goal_failed(ex.target, (1.0, 1.0), why)
    ex.plan(fs, 1.0)
    ex.goal_failed(ex.target, (1.0, 1.0), why)
    ex.plan(fs, 2.0)
    ex.goal_reached()
    ex.plan(fs, 3.0)
    ex.goal_failed(ex.target, (1.0, 1.0), why)
    assert ex.stuck == ""
    never = Explorer(ExploreParams(stuck_failures=0))
    for k in range(5):
        never.plan(fs, float(k))
        never.goal_failed(never.target, (1.0, 1.0), why)
    assert never.stuck == ""
