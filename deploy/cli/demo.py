"""``zenav demo``: the whole system in one command, on the simulator."""

from __future__ import annotations

import argparse
import math
import os
import sys
import time

from common.argtypes import nonneg_int, port, positive

DESCRIPTION = """\
Run the reference tutorial's scenario on this machine: the simulated Pioneer 3-AT (robot agent),
navigation on the world's known map (master agent: map server, global + local costmaps, move_base
with navfn and the DWA or trajectory-rollout planner) and the Rerun monitor, as separate processes
talking over a private loopback Zenoh network. It drives the goals of the room world (one wooden
obstacle in the middle) and of the corridor world, prints progress, and exits 0 when every goal is
reached without a collision (1 otherwise, with the reason).

Watching: with a display the Rerun viewer opens (--spawn); without one the run is saved to
zenav-demo.rrd (open it with `rerun zenav-demo.rrd`, or serve it to a browser with
`rerun --serve-web zenav-demo.rrd`). --serve-web PORT shows it live in a browser instead.

--explore [ENV]: instead, the robot maps a building by itself: the P3-AT with its planar laser (or its
Kinect, --sensor kinect) starts in MRPB's office02 (or ENV: shopping_mall, room02, ...) with gmapping and
no map, and `zenav explore` drives it to frontiers until nothing is left; the monitor shows the map
growing, the frontiers and the chosen target. Exits 0 when exploration ends by itself with 95 % of the
reachable free area known and no collision. With --engine mujoco the robot's odometry and DWA are told where
the skid-steered P3-AT turns about on physics (deploy/stack/physics_sets.py), as bench/explore.py does.

Bus: --robot names the robot (default "demo"); --connect / --listen / --mode / --no-multicast are refused
(the network is private). The demo prints its endpoint, e.g. for `zenav --robot demo --no-multicast
--connect tcp/127.0.0.1:PORT topic hz scan` in another terminal.
"""


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser("demo", help="run the whole system on the simulator (tutorial scenario)",
                              description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--world", action="append", choices=("room", "corridor"),
                   help="world(s) to run (repeatable; default: room then corridor)")
    p.add_argument("--planner", choices=("dwa", "trajectory"), default="dwa", help="local planner")
    p.add_argument("--slam", nargs="?", const="gmapping", choices=("gmapping", "hector"),
                   help="no known map: map the world with SLAM while navigating (tutorial section 3.6); "
                        "gmapping (default) or hector (hector_mapping: the scan alone, no odometry; the P3-AT then "
                        "carries a 180-degree planar laser, robot_side/config/p3at_sim_laser.yaml, instead of the "
                        "Kinect, whose 57-degree scan of a plain wall leaves hector lost; see the README)")
    p.add_argument("--amcl", action="store_true",
                   help="known map, localised with AMCL (master_side/config/p3at_amcl.yaml) instead of "
                        "the simulator's ground truth")
    p.add_argument("--engine", choices=("kinematic", "mujoco"), default="kinematic",
                   help="simulator engine: kinematic (exact arcs, no slip) or mujoco (rigid-body physics: the "
                        "skid-steered P3-AT with inertia, slip and torque limits)")
    p.add_argument("--explore", nargs="?", const="office02", metavar="ENV",
                   help="explore an MRPB building with SLAM and `zenav explore` instead (default office02)")
    p.add_argument("--sensor", choices=("laser", "kinect"), default="laser",
                   help="with --explore: the P3-AT's planar laser (default) or its Kinect")
    p.add_argument("--goals", type=nonneg_int, default=0, help="at most this many goals per world (0 = all)")
    p.add_argument("--speed", type=positive, default=1.0, help="simulated time / real time")
    p.add_argument("--goal-timeout", type=positive, default=180.0, help="seconds allowed per goal")
    out = p.add_mutually_exclusive_group()
    out.add_argument("--spawn", action="store_true", help="open the native Rerun viewer")
    out.add_argument("--serve-web", type=port, metavar="PORT", help="serve the web viewer on PORT")
    out.add_argument("--save", metavar="FILE", help="save the recording (default without a display)")
    out.add_argument("--no-monitor", action="store_true", help="run without the monitor")
    p.add_argument("--workdir", help="folder for logs and generated configs (default: a temp folder)")
    p.set_defaults(func=run)
    return p


def monitor_args(args) -> tuple[str, ...]:
    if args.no_monitor:
        return ()
    if args.serve_web:
        return ("--serve-web", str(args.serve_web), "--grpc-port", str(args.serve_web + 1))
    if args.spawn or (not args.save and (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))):
        return ("--spawn",)
    args.save = os.path.abspath(args.save or "zenav-demo.rrd")
    return ("--save", args.save)


def run(args) -> int:
    from deploy.stack.demo import Demo, DemoOptions
    from deploy.stack.process_group import terminate_as_interrupt

    given = [o for o, v in (("--connect", getattr(args, "connect", None)), ("--listen", getattr(args, "listen", None)),
                            ("--mode", getattr(args, "mode", None)),
                            ("--no-multicast", getattr(args, "no_multicast", False))) if v]
    if given:
        print(f"zenav demo: {', '.join(given)} does not apply: the demo runs on its own private loopback network "
              "(multicast off), so it never talks to robots on the LAN; it prints that network's endpoint "
              "for other zenav commands to join", file=sys.stderr)
        return 2
    if args.explore:
        return _explore(args)
    worlds = tuple(args.world or ("room", "corridor"))
    opts = DemoOptions(worlds=worlds, planner=args.planner, max_goals=args.goals, speed=args.speed,
                       goal_timeout=args.goal_timeout, monitor_args=monitor_args(args),
                       workdir=args.workdir or "", slam=args.slam or "", amcl=args.amcl, engine=args.engine,
                       robot=getattr(args, "robot", None) or "demo")
    t0 = time.monotonic()
    demo = Demo(opts, echo=lambda s: print(s, flush=True))
    print(f"[demo] logs and generated configs in {demo.work}", flush=True)
    print(f"[demo] bus: {demo.endpoint} (another terminal can join: zenav --robot {opts.robot} --no-multicast "
          f"--connect {demo.endpoint} topic list)", flush=True)
    ok, error = False, ""
    try:
        with terminate_as_interrupt():  # SIGTERM / SIGHUP as Ctrl-C: the agents are stopped below
            ok = demo.run()
            _summary(opts, args, ok, "", time.monotonic() - t0, demo)
            keep_serving(args)
    except KeyboardInterrupt as e:
        error = f"interrupted ({e})" if str(e) else "interrupted"
    except RuntimeError as e:
        error = str(e)
    finally:
        demo.close()
    if error:
        _summary(opts, args, False, error, time.monotonic() - t0, demo)
        return 1
    return 0 if ok else 1


def keep_serving(args) -> None:
    """With --serve-web, the page stays up after the run (the recording in the viewer, the robot stopped)
    until Ctrl-C: a user who opened it to watch can still look back at the run."""
    if not args.serve_web:
        return
    print(f"[demo] the run is over; the page keeps showing it at http://localhost:{args.serve_web} "
          "until Ctrl-C", flush=True)
    try:
        while True:
            time.sleep(3600)
    except KeyboardInterrupt:
        print("[demo] stopped", flush=True)


def _summary(opts, args, ok: bool, error: str, total: float, demo) -> None:
    print("[demo] ---- summary ----")
    for r in opts.results:
        print(f"[demo] {r.world:<9} {r.name:<22} {'OK  ' if r.ok else 'FAIL'} {r.seconds:6.1f} s  "
              f"error {r.xy_error:.2f} m {math.degrees(r.yaw_error):5.1f} deg")
    if args.save:
        print(f"[demo] recording: {args.save}\n[demo]   view it:  rerun {args.save}\n"
              f"[demo]   or in a browser: rerun --serve-web {args.save}  (then open http://localhost:9090)")
    if ok and not error:
        print(f"[demo] all {len(opts.results)} goals reached in {total:.0f} s", flush=True)
        return
    why = error or next((f"{r.world} '{r.name}': {r.reason}" for r in opts.results if not r.ok), "no goal ran")
    print(f"[demo] FAILED: {why} (logs in {demo.work})", file=sys.stderr, flush=True)


def _explore(args) -> int:
    """``zenav demo --explore``: deploy/mrpb/exploration.py's run, with the monitor, said as it goes."""
    import tempfile
    from pathlib import Path

    from deploy.mrpb.cases import STATIC_ENVS, load_cases, world_map
    from deploy.mrpb.exploration import run_exploration
    from deploy.stack.physics_sets import master_sets, robot_sets
    from deploy.stack.process_group import set_options, terminate_as_interrupt
    from deploy.stack.sensor_sets import slam_sensor_sets

    root = Path(__file__).resolve().parents[2]
    mrpb = root.parent / "shared" / "datasets" / "mrpb" / "map10cm"
    env = args.explore
    if env not in STATIC_ENVS or env.endswith("_partially_unknown"):
        print(f"zenav demo: --explore {env}: not an MRPB building (one of "
              f"{', '.join(e for e in STATIC_ENVS if not e.endswith('_partially_unknown'))})", file=sys.stderr)
        return 2
    if not mrpb.is_dir():
        print(f"zenav demo: --explore needs MRPB's maps in {mrpb} (../shared/datasets/mrpb)", file=sys.stderr)
        return 2
    from common.geometry import Pose2D

    start = Pose2D(*load_cases(mrpb, (env,), (1,))[0].start)
    robot_cfg = root / "robot_side" / "config" / ("p3at_sim_laser.yaml" if args.sensor == "laser" else "p3at_sim.yaml")
    work = Path(args.workdir or tempfile.mkdtemp(prefix="zenav-demo-explore-"))
    print(f"[demo] exploring MRPB {env} from ({start.x:.1f}, {start.y:.1f}) with the P3-AT's {args.sensor}, gmapping "
          f"and `zenav explore` ({'MuJoCo physics' if args.engine == 'mujoco' else 'kinematic engine'}); logs and "
          f"the map in {work}", flush=True)
    robot_args = ("--engine", args.engine, *set_options(robot_sets(args.engine)))

    def summary_then_serve(run) -> None:
        _explore_summary(run, args)
        keep_serving(args)

    with terminate_as_interrupt():
        try:
            r = run_exploration(env, str(world_map(mrpb, env)), start, robot_cfg,
                                root / "master_side" / "config" / "p3at_slam_zenav.yaml", work, args.speed,
                                echo=lambda s: print(f"[demo]{s}", flush=True), monitor_args=monitor_args(args),
                                robot=getattr(args, "robot", None) or "demo", robot_args=robot_args,
                                master_set=(*master_sets(args.engine, amcl=False), *slam_sensor_sets(args.sensor)),
                                before_stop=summary_then_serve if args.serve_web else None)
        except KeyboardInterrupt:
            print("[demo] interrupted", file=sys.stderr)
            return 1
    if not args.serve_web:  # else said before the page was left up
        _explore_summary(r, args)
    ok = r.end == "done" and r.final_share >= 0.95 and r.collisions == 0
    return 0 if ok else 1


def _explore_summary(r, args) -> None:
    from pathlib import Path

    print(f"[demo] exploration {r.end} after {r.sim_s:.0f} s simulated ({r.wall_s:.0f} s): "
          f"{100 * r.final_share:.1f} % of the {r.free_m2:.0f} m² the robot can reach known free, "
          f"walls {100 * r.walls_ok:.1f} % right, free cells {100 * r.free_ok:.1f} % right (the map laid on the "
          f"world {math.degrees(r.offset.theta):+.1f}° and {math.hypot(r.offset.x, r.offset.y):.2f} m from the "
          f"start's frame, where it fits; walls at the start's frame {100 * r.raw_walls_ok:.1f} %), "
          f"{r.path_m:.0f} m driven, "
          f"{r.collisions} collisions"
          + "".join(f" (contact at ({x:.2f}, {y:.2f}) at {t:.0f} s)" for t, x, y in r.contacts)
          + f"; map: {Path(r.log_dir) / 'explored.yaml'}", flush=True)
    if args.save:
        print(f"[demo] recording: {args.save} (rerun {args.save})")
