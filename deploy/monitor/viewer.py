"""The viewer side of ``zenav monitor``: where the recording goes (a file, a served page, a viewer) and the
blueprint it shows, refitted when a map first arrives (one robot, or one column per robot)."""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import rerun.blueprint as rrb


def open_recording(args, robot: str, history_limit: str):
    """A Rerun recording stream with the sink the user asked for; returns (rec, description)."""
    import rerun as rr

    from deploy.monitor.layout import blueprint

    rec = rr.RecordingStream(f"zenav_{robot}".replace("*", "all"))
    bp = blueprint(follow=getattr(args, "follow", False)) if "*" not in robot else robots_blueprint({})
    if args.save:
        parent = os.path.dirname(os.path.abspath(args.save))
        if not os.path.isdir(parent) or not os.access(parent, os.W_OK):
            raise ValueError(f"cannot write the recording {args.save}: {parent} is not a writable folder")
        try:
            rec.save(args.save, default_blueprint=bp)
        except RuntimeError as e:  # rerun reports file errors as RuntimeError
            raise ValueError(f"cannot write the recording {args.save}: {e}") from None
        return rec, f"saving to {args.save} (open with: rerun {args.save})"
    if args.serve_web:
        # newest_first: a page opened late gets what is live now ahead of the history it replays
        uri = rec.serve_grpc(grpc_port=args.grpc_port, default_blueprint=bp,
                             server_memory_limit=history_limit, newest_first=True)
        host = args.bind if args.bind not in ("0.0.0.0", "::") else "localhost"
        return rec, f"page at http://{host}:{args.serve_web}/ (recording {uri})"
    if args.connect_viewer:
        rec.connect_grpc(args.connect_viewer, default_blueprint=bp)
        return rec, f"streaming to {args.connect_viewer}"
    rec.spawn(memory_limit=args.memory_limit, default_blueprint=bp)
    return rec, "spawned the Rerun viewer"


Box = tuple[float, float, float, float]  # x0, y0, x1, y1 (metres, map frame)


def map_box(msg) -> Box:
    """The map as it is drawn: its known part (SLAM's 100 m grid is mostly unknown; loggers.known_part)."""
    from deploy.monitor.loggers import known_part

    data, origin = known_part(msg.data, msg.origin, msg.resolution)
    w, h = data.shape[1] * msg.resolution, data.shape[0] * msg.resolution
    return origin.x, origin.y, origin.x + w, origin.y + h  # (map origins are not rotated in practice)


def map_view(box: Box) -> tuple[tuple[float, float], float]:
    """(centre, eye height) of a top-down view fitted to ``box``."""
    from deploy.monitor.layout import fit_height

    return ((box[0] + box[2]) / 2, (box[1] + box[3]) / 2), fit_height(box[2] - box[0], box[3] - box[1])


def needs_fit(fitted: Box | None, box: Box) -> bool:
    """Fit the view again: the first map, a map that outgrew the fitted one (SLAM), or one much smaller than
    it (another world: `zenav demo` switches from the room to the corridor). A map that stays the same, or
    grows inside the view, keeps it: a new blueprint resets the user's camera, and the server keeps each one."""
    if fitted is None:
        return True
    area = (box[2] - box[0]) * (box[3] - box[1])
    grown = box[0] < fitted[0] or box[1] < fitted[1] or box[2] > fitted[2] or box[3] > fitted[3]
    return grown or area < 0.5 * (fitted[2] - fitted[0]) * (fitted[3] - fitted[1])


def fit_view_to_map(rec, args):
    """An observer that sends the blueprint again, the map view fitted to the map, when it first arrives and
    when it no longer fits (needs_fit)."""
    from common.messages import OccupancyGrid
    from deploy.monitor.layout import blueprint

    fitted: list[Box | None] = [None]  # the box the view was last fitted to

    def observe(topic: str, msg) -> None:
        if topic != "map" or not isinstance(msg, OccupancyGrid) or msg.width == 0:
            return
        box = map_box(msg)
        if not needs_fit(fitted[0], box):
            return
        fitted[0] = box
        centre, height = map_view(box)
        rec.send_blueprint(blueprint(follow=getattr(args, "follow", False), centre=centre, height=height),
                           make_active=True)

    return observe


def robots_blueprint(maps: dict[str, tuple]) -> rrb.Blueprint:
    """Side by side, one column per robot (``maps``: robot -> (centre, eye height) of its map view)."""
    import rerun.blueprint as rrb

    from deploy.monitor.layout import top_down

    def column(r: str, centre: tuple, height: float):
        return rrb.Vertical(
            rrb.Spatial3DView(name=f"{r}: map", origin="/", contents=[f"/{r}/world/**", f"/{r}/tf/**"],
                              spatial_information=rrb.SpatialInformation(target_frame=f"{r}/map"),
                              eye_controls=top_down(centre, height, False), line_grid=False),
            rrb.TimeSeriesView(name=f"{r}: plots", origin=f"/{r}/plots"),
            rrb.TextLogView(name=f"{r}: events", origin=f"/{r}/log"), row_shares=[3, 2, 2])

    cols = [column(r, *maps[r]) for r in sorted(maps)] or [rrb.TextDocumentView(name="waiting for robots")]
    from deploy.monitor.layout import live_time_panel

    return rrb.Blueprint(rrb.Horizontal(*cols), live_time_panel(), collapse_panels=True)


def fit_robots_views(rec):
    """For a robot pattern: an observer sending the side-by-side blueprint again when a robot first shows
    up and when its map first arrives or no longer fits (needs_fit; its view fitted to the map)."""
    from common.messages import OccupancyGrid
    from deploy.monitor.layout import DEFAULT_HEIGHT

    maps: dict[str, tuple] = {}
    fitted: dict[str, Box] = {}

    def observe(topic: str, msg) -> None:
        robot, _, topic = topic.partition("/")
        box = map_box(msg) if topic == "map" and isinstance(msg, OccupancyGrid) and msg.width > 0 else None
        fit = box is not None and needs_fit(fitted.get(robot), box)
        if robot in maps and not fit:
            return
        maps[robot] = ((0.0, 0.0), DEFAULT_HEIGHT)
        if fit:
            fitted[robot] = box
            maps[robot] = map_view(box)
        rec.send_blueprint(robots_blueprint(maps), make_active=True)

    return observe
