"""The BARN verdict and score on hand-made ground-truth traces (rules of the challenge's run.py)."""

import math

import numpy as np
import pytest

from common.geometry import Pose2D
from common.messages import Collision, Header, Odometry, Twist
from deploy.barn import rules as bench
from robot_side.worlds import barn

SX, SY = barn.START[:2]
DT = 0.02


def straight(v: float, idle: float = 2.0, until: float = 120.0) -> np.ndarray:
    """(t, x, y): at the start for ``idle`` s, then straight at the goal at ``v`` m/s (through it)."""
    t = np.arange(0.0, until, DT)
    y = SY + v * np.clip(t - idle, 0.0, None)
    return np.column_stack((t, np.full_like(t, SX), y))


def reach_time(v: float, idle: float = 2.0) -> float:
    """AT of ``straight``: from 0.1 m moved to 1 m before the goal, on the DT grid."""
    t0 = math.ceil(round((idle + 0.1 / v) / DT, 6)) * DT
    t1 = math.ceil(round((idle + (barn.GOAL[1] - 1.0 - SY) / v) / DT, 6)) * DT
    return t1 - t0


def test_success_times_from_the_start_of_motion_to_1_m_before_the_goal():
    ot = 5.0
    run = bench.judge(3, straight(0.5), optimal_time_s=ot)
    assert (run.success, run.collision, run.timeout, run.status) == (True, False, False, "succeeded")
    assert run.time_s == pytest.approx(reach_time(0.5), abs=1e-9)
    assert run.time_s == pytest.approx(9.0 / 0.5 - 0.1 / 0.5, abs=DT)
    assert run.goal_distance_m <= 1.0
    assert run.goal_distance_m > 1.0 - 0.5 * DT - 1e-9
    assert run.motion_start_s == pytest.approx(2.2, abs=DT)
    assert run.score == pytest.approx(ot / run.time_s)  # 2 OT < AT = 17.8 s < 8 OT
    assert run.world == 3
    # idling longer before moving does not change the time
    later = bench.judge(3, straight(0.5, idle=20.0), optimal_time_s=ot)
    assert later.time_s == pytest.approx(run.time_s, abs=DT + 1e-9)
    assert later.motion_start_s == pytest.approx(20.2, abs=DT)


@pytest.mark.parametrize(("v", "want"), [(2.0, 0.5), (1.0, 0.5), (0.25, None), (0.1, 0.125)])
def test_score_clips_the_time_to_2_and_8_optimal_times(v, want):
    ot = 5.0
    run = bench.judge(1, straight(v, until=110.0), optimal_time_s=ot)
    assert run.success
    at = reach_time(v)
    assert run.time_s == pytest.approx(at)
    assert run.score == pytest.approx(want if want is not None else ot / at)
    assert bench.score(True, at, ot) == run.score


def test_score_function_edges():
    assert bench.score(True, 10.0, 5.0) == pytest.approx(0.5)
    assert bench.score(True, 40.0, 5.0) == pytest.approx(0.125)
    assert bench.score(True, 20.0, 5.0) == pytest.approx(0.25)
    assert bench.score(True, 1.0, 5.0) == pytest.approx(0.5)
    assert bench.score(True, 99.0, 5.0) == pytest.approx(0.125)
    assert bench.score(False, 20.0, 5.0) == 0.0


def test_a_collision_fails_the_run_even_at_the_goal_but_not_after_it():
    tr = straight(0.5)
    hit = bench.judge(1, tr, collisions=[10.0], optimal_time_s=5.0)
    assert (hit.success, hit.collision, hit.timeout, hit.status, hit.score) == (False, True, False, "collided", 0.0)
    assert hit.time_s == pytest.approx(10.0 - hit.motion_start_s)
    at_goal = bench.judge(1, tr, collisions=[2.2 + reach_time(0.5) - 1e-4], optimal_time_s=5.0)
    assert at_goal.collision
    assert not at_goal.success
    after = bench.judge(1, tr, collisions=[60.0], optimal_time_s=5.0)
    assert after.success
    before_motion = bench.judge(1, tr, collisions=[1.0], optimal_time_s=5.0)
    assert before_motion.collision
    assert before_motion.time_s == 0.0


def test_timeout_after_100_s_of_motion_even_when_arriving_then():
    slow = bench.judge(1, straight(0.05, until=200.0), optimal_time_s=5.0)
    assert (slow.success, slow.collision, slow.timeout, slow.status, slow.score) == (False, False, True,
                                                                                     "timeout", 0.0)
    assert slow.time_s == pytest.approx(100.0, abs=DT)
    assert slow.time_s >= 100.0
    assert slow.goal_distance_m > 1.0
    # at the goal exactly 100 s after the start of motion: the clock ran out first (run.py's order)
    def jump(arrive: float) -> np.ndarray:
        return np.array([[0.0, SX, SY], [1.0, SX, SY + 0.2], [1.0 + arrive, *barn.GOAL]])
    edge = bench.judge(1, jump(100.0), optimal_time_s=5.0)
    assert (edge.timeout, edge.success, edge.goal_distance_m) == (True, False, 0.0)
    assert bench.judge(1, jump(99.9), optimal_time_s=5.0).success
    # a collision outranks the timeout
    both = bench.judge(1, straight(0.05, until=200.0), collisions=[150.0], optimal_time_s=5.0)
    assert both.timeout
    assert not both.collision


def test_a_robot_that_never_moves_times_out_and_short_traces_raise():
    still = np.column_stack((np.arange(0.0, 101.0, 0.1), np.full(1010, SX), np.full(1010, SY)))
    run = bench.judge(1, still, optimal_time_s=5.0)
    assert run.timeout
    assert math.isnan(run.motion_start_s)
    assert run.time_s == pytest.approx(100.0)
    assert bench.judge(1, still, collisions=[3.0], optimal_time_s=5.0).collision
    with pytest.raises(ValueError, match="never moved"):
        bench.judge(1, still[:500], optimal_time_s=5.0)
    with pytest.raises(ValueError, match="without a verdict"):
        bench.judge(1, straight(0.5, until=10.0), optimal_time_s=5.0)
    with pytest.raises(ValueError, match="decrease"):
        bench.judge(1, straight(0.5)[::-1], optimal_time_s=5.0)


def test_optimal_time_defaults_to_the_reference_length(shared_dir):
    run = bench.judge(1, straight(0.5))
    assert run.optimal_time_s == pytest.approx(bench.reference_length(1) / 2.0)
    assert run.score == pytest.approx(run.optimal_time_s / np.clip(run.time_s, 2 * run.optimal_time_s,
                                                                   8 * run.optimal_time_s))


def test_summary_rates_mean_time_of_successes_and_mean_score():
    ot = 5.0
    runs = [bench.judge(1, straight(0.5), optimal_time_s=ot),
            bench.judge(2, straight(1.0), optimal_time_s=ot),
            bench.judge(3, straight(0.5), collisions=[8.0], optimal_time_s=ot),
            bench.judge(4, straight(0.05, until=200.0), optimal_time_s=ot)]
    s = bench.summarize(runs)
    assert s.runs == 4
    assert (s.success_rate, s.collision_rate, s.timeout_rate) == (0.5, 0.25, 0.25)
    assert s.mean_time_success_s == pytest.approx((runs[0].time_s + runs[1].time_s) / 2)
    assert s.mean_score == pytest.approx((runs[0].score + runs[1].score) / 4)
    assert "success=0.500" in s.line()
    assert s.line().startswith("runs=4 ")
    empty = bench.summarize([])
    assert empty.runs == 0
    assert math.isnan(empty.mean_score)
    none_ok = bench.summarize(runs[2:])
    assert math.isnan(none_ok.mean_time_success_s)
    assert none_ok.mean_score == 0.0


def test_traces_and_collision_times_from_simulator_messages():
    msgs = [Odometry(Header(t, "map"), "base_link", Pose2D(SX, SY + t, 1.57).to_transform(), Twist())
            for t in (0.04, 0.0, 0.02)]
    tr = bench.trace_from_odometry(msgs)
    assert tr[:, 0].tolist() == [0.0, 0.02, 0.04]
    assert tr[:, 2] == pytest.approx([SY, SY + 0.02, SY + 0.04])
    assert tr[:, 1] == pytest.approx([SX] * 3)
    cols = [Collision(Header(5.0, "map"), 2, 0.0, 0.0), Collision(Header(1.0, "map"), 1, 0.0, 0.0),
            Collision(Header(6.0, "map"), 2, 0.0, 0.0)]
    assert bench.collision_times(cols) == [1.0, 5.0]


def test_a_run_that_stopped_short_is_held_where_it_stopped_until_the_time_limit():
    """move_base gave up 1 m out: BARN's run.py would wait out the time limit with the robot standing."""
    t = np.arange(0.0, 12.0, 0.5)
    y = np.clip(t - 2.0, 0.0, 1.0)  # moves from t = 2 s, stops 1 m out at t = 3 s
    trace = np.column_stack((t, np.full_like(t, SX), SY + y))
    held = bench.held_to_time_limit(trace)
    assert held[-1].tolist() == [2.5 + bench.TIME_LIMIT_S, SX, SY + 1.0]  # from the start of motion (0.5 m at 2.5 s)
    run = bench.judge(23, held, [])
    assert run.timeout and not run.success and run.time_s == pytest.approx(bench.TIME_LIMIT_S)
    still = np.column_stack((t, np.full_like(t, SX), np.full_like(t, SY)))  # never moved: from its first sample
    assert bench.held_to_time_limit(still)[-1, 0] == bench.TIME_LIMIT_S
