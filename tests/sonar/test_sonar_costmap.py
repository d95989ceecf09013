"""The sonar ring's echoes in the local costmap (master_side/costmap's obstacle layer): an echo behind the robot
marks, a sonar without echo and each cone heard empty clear, an echo explained by marks near it adds nothing,
and footprint clearing keeps what the robot's flank and corners meet."""

from __future__ import annotations

import dataclasses
import math
import sys
from pathlib import Path

import numpy as np
import pytest

from common.geometry import Pose2D
from master_side.costmap.cost_values import FREE_SPACE, LETHAL, NO_INFORMATION
from master_side.costmap.costmap2d import Costmap2D
from master_side.costmap.footprint import pad_footprint
from master_side.costmap.layer_params import ObservationSourceParams, ObstacleLayerParams, VoxelLayerParams
from master_side.costmap.layered import LayeredCostmap
from master_side.costmap.obstacle_layer import ObstacleLayer
from master_side.costmap.voxel_layer import VoxelLayer
from robot_side.sonar.geometry import SonarRingParams, cone_points, sonar_points

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "costmap"))
from costmap_helpers import obstacle_layer  # noqa: E402

RING = SonarRingParams()  # the P3-AT's 16 sonars, 15 deg cones, 5 m
# zenav's local costmap while mapping, in short: a laser source and the sonar source filling in
LASER = ObservationSourceParams(data_type="LaserScan", obstacle_range=2.5, raytrace_range=3.0, min_obstacle_height=-1.0)
SONAR = ObservationSourceParams(data_type="PointCloud", obstacle_range=1.5, raytrace_range=3.0, min_obstacle_height=0.0,
                                min_mark_separation=0.2)


def laser_and_sonar(footprint: np.ndarray | None = None,
                    sonar: ObservationSourceParams = SONAR) -> tuple[LayeredCostmap, ObstacleLayer]:
    """A 4 m rolling costmap at 0.025 m with one obstacle layer over LASER and ``sonar``; footprint clearing
    when a footprint is given."""
    lc = LayeredCostmap(Costmap2D(160, 160, 0.025, -2.0, -2.0), rolling_window=True, footprint=footprint)
    params = ObstacleLayerParams(footprint_clearing_enabled=footprint is not None)
    return lc, lc.add_layer(ObstacleLayer("obstacles", params, {"laser": LASER, "sonar": sonar}))


def test_an_echo_behind_marks_the_costmap_and_a_sonar_without_echo_clears_along_its_axis():
    lc = LayeredCostmap(Costmap2D(160, 160, 0.025, -2.0, -2.0), rolling_window=True)
    layer = obstacle_layer(lc, data_type="PointCloud", obstacle_range=1.5, raytrace_range=3.0,
                           min_obstacle_height=0.0)
    robot = Pose2D(0.0, 0.0, 0.0)
    ranges = [RING.range_max] * 16
    ranges[11] = 0.6
    pts = sonar_points(RING, ranges, z=0.2, max_range=RING.range_max * 1.001).astype(float)
    layer.add_observation("scan", pts, np.array([0.0, 0.0, 0.2]), 0.0)
    lc.update_map(robot)
    hit = pts[np.argmin(np.hypot(pts[:, 0] + 0.8, pts[:, 1]))]
    assert lc.master.get_cost(hit[0], hit[1]) == LETHAL
    far = [p for p in pts if np.hypot(p[0], p[1]) > 4.0]  # the 15 sonars without echo: beyond obstacle_range
    assert len(far) == 15 and all(lc.master.get_cost(p[0] * 0.35, p[1] * 0.35) != LETHAL for p in far)
    # the obstacle goes: sonar 11 hears nothing, and its axis is cleared
    ranges[11] = RING.range_max
    pts = sonar_points(RING, ranges, z=0.2, max_range=RING.range_max * 1.001).astype(float)
    layer.add_observation("scan", pts, np.array([0.0, 0.0, 0.2]), 1.0)
    lc.update_map(robot)
    assert lc.master.get_cost(hit[0], hit[1]) == FREE_SPACE


def test_cone_points_span_each_cone_just_short_of_its_reading():
    ranges = [RING.range_max] * 16
    ranges[11] = 0.6
    pts = cone_points(RING, ranges, use=(10, 11), rays=5, z=0.2)
    assert pts.dtype == np.float32 and pts.shape == (10, 3)
    x, y, h = RING.units[11]
    mine = pts[5:]  # sonar 11's, after sonar 10's
    d = np.hypot(mine[:, 0] - x, mine[:, 1] - y)
    assert np.allclose(d, 0.55, atol=1e-5)  # 0.05 m short of the echo
    bearings = np.arctan2(mine[:, 1] - y, mine[:, 0] - x)
    spread = np.angle(np.exp(1j * (bearings - h)))
    assert np.allclose(np.sort(spread), np.linspace(-RING.fov / 2, RING.fov / 2, 5), atol=1e-5)
    assert np.allclose(np.hypot(pts[:5, 0] - RING.units[10][0], pts[:5, 1] - RING.units[10][1]), RING.range_max - 0.05,
                       atol=1e-5)  # no echo: out to the ring's range
    assert len(cone_points(RING, [math.nan, 0.03] + [1.0] * 14, use=(0, 1))) == 0  # unusable, or nearer than short


def test_with_unknown_tracked_a_cone_heard_empty_is_known_free_across_not_only_on_its_axis():
    lc = LayeredCostmap(Costmap2D(160, 160, 0.025, -2.0, -2.0), rolling_window=True, track_unknown_space=True)
    cone_src = ObservationSourceParams(data_type="PointCloud", obstacle_range=1.5, raytrace_range=3.0,
                                       min_obstacle_height=0.0, marking=False, clearing=True)
    layer = lc.add_layer(ObstacleLayer("obstacles", ObstacleLayerParams(track_unknown_space=True),
                                       {"sonar": dataclasses.replace(SONAR, clearing=True), "cone": cone_src}))
    ranges = [RING.range_max] * 16
    ranges[11] = 1.0
    robot = Pose2D(0.0, 0.0, 0.0)
    origin = np.array([0.0, 0.0, 0.2])
    x, y, h = RING.units[11]
    # the cone's cells from 0.3 m to 0.9 m out, off its axis (more than 2 deg from it)
    d, a = np.meshgrid(np.linspace(0.3, 0.9, 25), np.radians(np.linspace(-7.0, 7.0, 29)))
    off = np.abs(a) > np.radians(2.0)
    sector = np.column_stack((x + d[off] * np.cos(h + a[off]), y + d[off] * np.sin(h + a[off])))

    def free_share() -> float:
        return float(np.mean([lc.master.get_cost(px, py) == FREE_SPACE for px, py in sector]))

    layer.add_observation("sonar", sonar_points(RING, ranges, use=(11,), z=0.2).astype(float), origin, 0.0)
    lc.update_map(robot)
    axis_only = free_share()
    assert axis_only < 0.2  # the axis alone leaves the cone unknown
    layer.add_observation("cone", cone_points(RING, ranges, use=(11,), rays=16, z=0.2).astype(float), origin, 1.0)
    lc.update_map(robot)
    assert free_share() > 0.9
    assert lc.master.get_cost(x + 1.0 * math.cos(h), y + 1.0 * math.sin(h)) == LETHAL  # the echo itself stays
    assert lc.master.get_cost(1.5, 1.5) == NO_INFORMATION  # where no sonar looked



def test_cleared_from_the_base_centre_a_side_sonar_erases_a_corner_outside_its_cone():
    """Sonar 8 (right flank, facing -90 deg) hears a wall 0.3 m out on its axis. A wall corner 8 cm beside the
    body, 16 deg off that axis, is outside its 15 deg cone: cleared from the sonar's own position it stays;
    cleared from the base's centre, the line to a cone point crosses it (what struck office02's door jamb)."""
    x8, y8, h8 = RING.units[8]
    ranges = [RING.range_max] * 16
    ranges[8] = 0.3
    cone = cone_points(RING, ranges, (8,), rays=16, z=0.2)
    corner = (-0.09, -0.33)  # 8 cm right of the body (half width 0.254), ahead of sonar 8's axis (x = -0.144)
    bearing = math.degrees(math.atan2(corner[1] - y8, corner[0] - x8)) - math.degrees(h8)
    assert abs(bearing) > 7.5  # outside the cone
    cone_source = dataclasses.replace(SONAR, marking=False, clearing=True, min_mark_separation=0.0)
    for origin, kept in (((x8, y8), True), ((0.0, 0.0), False)):
        lc = LayeredCostmap(Costmap2D(160, 160, 0.025, -2.0, -2.0), rolling_window=True)
        layer = lc.add_layer(ObstacleLayer("obstacles", ObstacleLayerParams(footprint_clearing_enabled=False),
                                           {"laser": LASER, "cone": cone_source}))
        layer.add_observation("laser", np.array([[corner[0], corner[1], 0.3]]), np.array([0.2, 0.0, 0.3]), 0.0)
        lc.update_map(Pose2D(0.0, 0.0, 0.0))
        assert lc.master.get_cost(*corner) == LETHAL
        layer.add_observation("laser", np.zeros((0, 3)), np.array([0.2, 0.0, 0.3]), 1.0)
        layer.add_observation("cone", cone, np.array([origin[0], origin[1], 0.2]), 1.0)
        lc.update_map(Pose2D(0.0, 0.0, 0.0))
        assert (lc.master.get_cost(*corner) == LETHAL) == kept, origin


@pytest.mark.parametrize("fov", [0.0, math.radians(15.0)])
def test_a_sonar_echo_marks_only_what_the_marks_near_it_do_not_explain(fov):
    """min_mark_separation: an echo of a wall the laser has marked adds nothing, also one placed on the sonar's
    axis in front of an oblique wall (a displaced second wall narrowed office02's passages until no trajectory
    was left: the wall's marks in the window, its nearest point in the cone among them, lie no farther than
    the echo); an echo where nothing is marked does, and so does one nearer than every mark around it by more
    than a cell (the wall was marked before the odometry slipped: on physics, office02's rear corners struck
    walls marked 3-7 cm farther than they were); one a cell nearer does not (a sonar's noise)."""
    lc, layer = laser_and_sonar(sonar=dataclasses.replace(SONAR, min_mark_separation_fov=fov))
    wall = np.column_stack((np.full(41, 0.5), np.linspace(-0.5, 0.5, 41), np.zeros(41)))  # x = 0.5, y -0.5..0.5
    # an oblique wall behind the robot: from (-0.3, -0.9) to (-0.9, -0.3), at 45 deg to the sonar's axis below
    oblique = np.column_stack((np.linspace(-0.3, -0.9, 41), np.linspace(-0.9, -0.3, 41), np.zeros(41)))
    layer.add_observation("laser", np.vstack((wall, oblique)), np.array([0.0, 0.0, 0.3]), 0.0)
    origin = np.array([0.0, 0.0, 0.2])
    # the oblique wall's nearest point within 7.5 deg of the axis at -105 deg (its normal is at -135 deg, 0.85 m)
    axis, normal, d = math.radians(-105.0), math.radians(-135.0), 1.2 / math.sqrt(2.0)
    r = d / math.cos(normal - axis + math.radians(7.5))
    on_axis = [r * math.cos(axis), r * math.sin(axis)]
    echoes = np.array([[0.495, 0.2, 0.2],  # the laser's wall, 5 mm short (sonar noise)
                       [*on_axis, 0.2],   # in front of the oblique wall, on the axis: its nearest point explains it
                       [-0.6, 0.3, 0.2],  # nothing else saw it
                       [0.44, -0.05, 0.2],  # 6 cm nearer than the laser's wall: it is nearer now
                       [0.49, 0.0, 0.2]])  # head-on, the cell in front of the wall's (one cell nearer): noise
    layer.add_observation("sonar", echoes, origin, 0.0)
    lc.update_map(Pose2D(0.0, 0.0, 0.0))
    assert lc.master.get_cost(0.5, 0.2) == LETHAL  # the laser's wall
    assert lc.master.get_cost(0.495, 0.2) != LETHAL  # no second wall in the cell in front of it
    assert d - r * math.cos(normal - axis) > 0.05  # the axis point lies 5 cm in front of the wall
    assert lc.master.get_cost(*on_axis) != LETHAL
    assert lc.master.get_cost(-0.6, 0.3) == LETHAL  # the echo nothing else saw
    assert lc.master.get_cost(0.44, -0.05) == LETHAL  # nearer than the marks: marked
    assert lc.master.get_cost(0.49, 0.0) != LETHAL  # one cell nearer (centre to centre): not
    with pytest.raises(ValueError, match="min_mark_separation"):
        VoxelLayer("voxels", VoxelLayerParams(), {"sonar": SONAR})


def test_with_the_cone_only_marks_inside_it_explain_an_echo():
    """min_mark_separation_fov: the echo of a wall's end (a door jamb ahead and to the left) is hidden by the
    marks of the same wall nearer the sonar in the square window, though they lie outside the sonar's 15 deg
    cone and it cannot have heard them; with the cone, only marks inside it count, and the end is marked
    (office02, the Kinect robot: its flank struck that jamb turning round it). A mark inside the cone, nearer
    than the echo, still explains it."""
    wall = np.column_stack((np.arange(-0.3, 0.2001, 0.025), np.full(21, 0.41), np.zeros(21)))  # marked to x = 0.2
    origin = np.array([0.147, 0.136, 0.2])  # sonar 0's place, left front
    echo = np.array([[0.3, 0.41, 0.2]])  # the wall's end, 0.1 m past its marks, 61 deg from the sonar
    for fov, marked in ((0.0, False), (math.radians(15.0), True)):
        lc, layer = laser_and_sonar(sonar=dataclasses.replace(SONAR, min_mark_separation_fov=fov))
        layer.add_observation("laser", wall, np.array([-0.5, 0.0, 0.3]), 0.0)
        layer.add_observation("sonar", echo, origin, 0.0)
        lc.update_map(Pose2D(0.0, 0.0, 0.0))
        assert lc.master.get_cost(0.2, 0.41) == LETHAL  # 0.28 m from the sonar, 18 deg off the echo's line
        assert (lc.master.get_cost(0.3, 0.41) == LETHAL) == marked, fov
    lc, layer = laser_and_sonar(sonar=dataclasses.replace(SONAR, min_mark_separation_fov=math.radians(15.0)))
    layer.add_observation("laser", np.array([[0.27, 0.37, 0.3]]), np.array([-0.5, 0.0, 0.3]), 0.0)  # in the cone
    layer.add_observation("sonar", echo, origin, 0.0)
    lc.update_map(Pose2D(0.0, 0.0, 0.0))
    assert lc.master.get_cost(0.3, 0.41) != LETHAL


def test_marks_under_the_footprint_do_not_hide_an_echo_beside_the_robots_corner():
    """A wall 0.03 m beside the robot lies under its padded footprint, which the layer frees each update; an echo
    of the same wall just behind the rear corner (outside the footprint) must still mark, or nothing stops the
    planner sweeping the corner into it (office02: five rear-corner contacts in 20 s along one wall)."""
    body = np.array([[0.254, 0.254], [-0.254, 0.254], [-0.254, -0.254], [0.254, -0.254]])
    lc, layer = laser_and_sonar(footprint=pad_footprint(body, 0.04))
    beside = np.column_stack((np.linspace(-0.2, 0.2, 17), np.full(17, -0.284), np.zeros(17)))  # 0.03 m off
    layer.add_observation("laser", beside, np.array([0.1, 0.0, 0.3]), 0.0)
    echo = np.array([[-0.32, -0.27, 0.2]])  # sonar 9's echo of that wall, behind the rear right corner
    layer.add_observation("sonar", echo, np.array([0.0, 0.0, 0.2]), 0.0)
    lc.update_map(Pose2D(0.0, 0.0, 0.0))
    assert lc.master.get_cost(0.0, -0.284) == FREE_SPACE  # under the padded footprint: freed (as ROS)
    assert lc.master.get_cost(-0.32, -0.27) == LETHAL  # the echo outside it stays


def test_a_sonar_echo_within_the_padding_beside_the_flank_survives_footprint_clearing():
    """footprint_clearing: false on the sonar source: an echo 3 cm from the flank (inside the padded footprint,
    outside the robot's own outline) stays marked; one under the body is freed; a laser mark there is freed."""
    body = np.array([[0.254, -0.254], [0.254, 0.254], [-0.254, 0.254], [-0.254, -0.254]])
    padded = pad_footprint(body, 0.04)
    near = np.array([[-0.1, -0.284, 0.2]])  # the right flank, rear half, 3 cm out
    under = np.array([[0.0, -0.2, 0.2]])  # under the body
    for keep in (False, True):
        lc = LayeredCostmap(Costmap2D(160, 160, 0.025, -2.0, -2.0), rolling_window=True, footprint=padded,
                            footprint_padding=0.04)
        sonar = dataclasses.replace(SONAR, footprint_clearing=not keep)
        layer = lc.add_layer(ObstacleLayer("obstacles", ObstacleLayerParams(footprint_clearing_enabled=True),
                                           {"laser": LASER, "sonar": sonar}))
        layer.add_observation("laser", np.array([[0.1, 0.28, 0.3]]), np.array([0.2, 0.0, 0.3]), 0.0)
        layer.add_observation("sonar", np.vstack((near, under)), np.array([0.0, 0.0, 0.2]), 0.0)
        lc.update_map(Pose2D(0.0, 0.0, 0.0))
        assert lc.master.get_cost(-0.1, -0.284) == (LETHAL if keep else FREE_SPACE), keep
        assert lc.master.get_cost(0.0, -0.2) == FREE_SPACE  # the robot is there
        assert lc.master.get_cost(0.1, 0.28) == FREE_SPACE  # the laser's mark within the padding: freed as in ROS


def test_when_no_source_frees_the_padding_a_wall_seen_earlier_beside_the_flank_stays():
    """Every marking source footprint_clearing: false: the layer frees only the cells under the robot's body, so
    a wall the laser marked ahead and the robot then drew level with (3 cm from its flank, in the padding, out
    of the laser's view) stays marked though no reading holds it any more, and so does one touching the other
    flank (its cell crossed by the outline); under the body a mark is freed."""
    body = np.array([[0.254, -0.254], [0.254, 0.254], [-0.254, 0.254], [-0.254, -0.254]])
    lc = LayeredCostmap(Costmap2D(160, 160, 0.025, -2.0, -2.0), rolling_window=True,
                        footprint=pad_footprint(body, 0.04), footprint_padding=0.04)
    laser = dataclasses.replace(LASER, footprint_clearing=False)
    sonar = dataclasses.replace(SONAR, footprint_clearing=False)
    layer = lc.add_layer(ObstacleLayer("obstacles", ObstacleLayerParams(footprint_clearing_enabled=True),
                                       {"laser": laser, "sonar": sonar}))
    wall = np.array([[x, -0.284, 0.3] for x in np.arange(0.4, 1.6, 0.02)])  # ahead, on the right
    touching = np.array([[x, 0.258, 0.3] for x in np.arange(0.4, 1.6, 0.02)])  # on the left, 4 mm off the body
    layer.add_observation("laser", np.vstack((wall, touching)), np.array([0.0, 0.0, 0.3]), 0.0)
    layer.add_observation("sonar", np.zeros((0, 3)), np.array([0.0, 0.0, 0.2]), 0.0)
    lc.update_map(Pose2D(0.0, 0.0, 0.0))
    layer.add_observation("laser", np.zeros((0, 3)), np.array([0.8, 0.0, 0.3]), 1.0)  # nothing seen now
    lc.update_map(Pose2D(0.7, 0.0, 0.0))  # drawn level with the wall
    assert lc.master.get_cost(0.7, -0.284) == LETHAL  # 3 cm from the flank: kept
    assert lc.master.get_cost(1.3, -0.284) == LETHAL
    assert lc.master.get_cost(0.7, 0.258) == LETHAL  # in the cell the outline crosses: the flank touches it
    lc.update_map(Pose2D(0.7, -0.1, 0.0))  # the robot on the wall (as a bad pose would put it)
    assert lc.master.get_cost(0.7, -0.284) == FREE_SPACE  # under the body: freed


def test_the_cone_option_without_the_window_is_refused():
    with pytest.raises(ValueError, match="min_mark_separation_fov needs min_mark_separation"):
        ObservationSourceParams(min_mark_separation_fov=0.26).validate()
