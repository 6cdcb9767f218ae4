"""Walking a log into a Rerun recording: ``build_view``, ``save_view`` and ``stream_view``.

``ViewBuilder`` reads every message of a log once and hands it by type to the drawer of its kind
(scans, clouds, TF, trajectories, plans, goals, grids, collision-monitor polygons, time series,
events); bulk sensors are sent in batches as they are read, the rest when the log is done
(``finish``), in a fixed order, followed by the top-down view, the robot, the orphan-frame links
and the blueprint.

The timeline ``sim_time`` is a duration: the log time itself for simulator logs (sim time in
nanoseconds), the time since the first message for bags recorded with wall-clock receive times.
Topics of other types are counted as stored but not drawn.

``save_view`` writes an ``.rrd`` under a temporary name and renames it when complete.
"""

from __future__ import annotations

import hashlib
import logging
import os
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Literal

from navlog.analysis.view.blueprint import make_blueprint
from navlog.analysis.view.clouds import Clouds
from navlog.analysis.view.context import TIMELINE, ViewContext
from navlog.analysis.view.events import Events
from navlog.analysis.view.goals import Goals
from navlog.analysis.view.grids import Grids
from navlog.analysis.view.options import ViewOptions, ViewSummary
from navlog.analysis.view.plans import Plans
from navlog.analysis.view.polygons import Polygons
from navlog.analysis.view.replay_outputs import REPLAY_PREFIX, add_replay_dir, replay_tf_children
from navlog.analysis.view.robot import send_robot
from navlog.analysis.view.scans import Scans
from navlog.analysis.view.tf import TfTree
from navlog.analysis.view.timeseries import TimeSeries
from navlog.analysis.view.topdown import GO2_FOOTPRINT, robot_footprint, send_top
from navlog.analysis.view.trajectories import Trajectories
from navlog.errors import LogError, NavlogError
from navlog.replay import messages
from navlog.replay.io import LogReader, open_log
from navlog.replay.io.atomic import hold_output, output_failure, temp_path

log = logging.getLogger("navlog")

VIEWER_BIND = "127.0.0.1"  # the address a spawned viewer listens on: this machine only
VIEWER_PORT = 9876  # Rerun's default port

# A log whose first message is later than this (about three years after 1970) was stamped with
# wall-clock receive times; its timeline then starts at zero.
WALL_CLOCK_NS = 100_000_000_000_000_000
POSE_ARRAY = "geometry_msgs/msg/PoseArray"
POSE_COV_STAMPED = "geometry_msgs/msg/PoseWithCovarianceStamped"
STRING = "std_msgs/msg/String"
ROSOUT = "rcl_interfaces/msg/Log"
POLYGON_STAMPED = "geometry_msgs/msg/PolygonStamped"


class ViewBuilder:
    """Streams logs into a RecordingStream; call ``add_log`` (and ``add_replay_dir``), then ``finish``."""

    def __init__(self, rec: Any, options: ViewOptions | None = None) -> None:
        self.ctx = ViewContext(rec, (options or ViewOptions()).validate())
        self.tf = TfTree(self.ctx)
        self.scans = Scans(self.ctx)
        self.clouds = Clouds(self.ctx)
        self.trajectories = Trajectories(self.ctx)
        self.plans = Plans(self.ctx)
        self.polygons = Polygons(self.ctx)
        self.goals = Goals(self.ctx)
        self.grids = Grids(self.ctx)
        self.series = TimeSeries(self.ctx)
        self.events = Events(self.ctx)
        self.footprint: tuple[tuple[float, float], ...] = self.ctx.opt.footprint or GO2_FOOTPRINT
        # type -> handler(topic, log time, message)
        self.handlers = {
            messages.LASER_SCAN: self.scans.on_scan,
            messages.POINT_CLOUD2: self.clouds.on_cloud,
            messages.TF_MESSAGE: self.tf.on_tf,
            messages.ODOMETRY: self.trajectories.on_odom,
            messages.PATH: self._on_path,
            messages.TWIST: self.series.on_twist,
            messages.TWIST_STAMPED: self.series.on_twist,
            messages.OCCUPANCY_GRID: self.grids.on_grid,
            messages.POSE_STAMPED: self.goals.on_goal,
            POSE_COV_STAMPED: self._on_pose_with_covariance,
            POSE_ARRAY: self.goals.on_waypoints,
            messages.EVENT_TYPE: self._on_event,
            POLYGON_STAMPED: self.polygons.on_polygon,
            messages.IMU: self.series.on_imu,
            STRING: self.events.on_text,
            ROSOUT: self.events.on_text,
        }

    @property
    def summary(self) -> ViewSummary:
        return self.ctx.summary

    def _on_path(self, topic: str, t: int, msg: Any) -> None:
        self.goals.on_path(topic, t, msg)
        self.plans.on_path(topic, t, msg)

    def _on_pose_with_covariance(self, topic: str, t: int, msg: Any) -> None:
        """/initialpose and goals are goals; any other pose with covariance (AMCL's /amcl_pose, the SLAM's /pose)
        is an estimate, drawn as a trajectory."""
        if "initialpose" in topic or "goal" in topic.lower():
            self.goals.on_goal(topic, t, msg)
        else:
            self.trajectories.on_pose(topic, t, msg)

    def _on_event(self, topic: str, t: int, msg: Any) -> None:
        self.events.on_event(topic, t, msg)
        self.polygons.on_event(topic, t, msg)

    def _start(self, reader: LogReader) -> None:
        """The first log sets the footprint and the time offset."""
        ctx = self.ctx
        self.footprint = ctx.opt.footprint or robot_footprint(reader.metadata)
        wall = reader.start_ns >= WALL_CLOCK_NS
        ctx.offset_ns = reader.start_ns if wall else 0
        ctx.start_ns = reader.start_ns
        ctx.summary.wall_clock = wall
        ctx.summary.time_offset_ns = ctx.offset_ns
        if wall:
            ctx.summary.warnings.append(
                f"{reader.path.name}: receive times are wall-clock; sim_time counts from the first message"
            )

    def add_log(self, reader: LogReader, prefix: str = "") -> None:
        """Read every message of a log once and collect (bulk sensors are sent in batches as read)."""
        summary = self.ctx.summary
        if self.ctx.offset_ns is None:
            self._start(reader)
        for t in sorted(reader.topics.values(), key=lambda t: t.name):
            if not t.known:  # the type, or why its schema was refused
                summary.unknown_types[(prefix + t.name) if prefix else t.name] = t.why or t.typename
        if reader.unknown_types:
            log.warning("%s: skipping topics of unknown types: %s", reader.path, reader.unknown_listed)
        handlers = self.handlers
        wanted = []
        for t in sorted(reader.topics.values(), key=lambda t: t.name):
            if not t.known:
                continue
            if t.typename in handlers:
                wanted.append(t.name)
            elif t.typename != messages.CLOCK:
                summary.not_drawn[(prefix + t.name) if prefix else t.name] = t.typename
        from navlog.replay.runtime.progress import Progress

        prog = Progress(reader.duration_ns / 1e9, f"view {reader.path.name}", enabled=log.isEnabledFor(logging.WARNING))
        n = 0
        on_timeline = self.ctx.on_timeline
        for env in reader.messages(wanted):
            key = f"{prefix}{env.topic}" if prefix else env.topic
            if not on_timeline(env.time_ns):
                summary.skipped[
                    f"{key}: log time past the year 2262 or 292 years from the first message (not drawn)"
                ] += 1
                continue
            try:
                handlers[env.typename](key, env.time_ns, env.msg)
            except (AttributeError, ValueError, KeyError, IndexError, TypeError) as exc:
                summary.skipped[f"unreadable {env.typename} on {key} ({type(exc).__name__})"] += 1
            n += 1
            if n % 2000 == 0:
                prog.update((env.time_ns - reader.start_ns) / 1e9)
        prog.update(reader.duration_ns / 1e9)
        prog.close()
        summary.messages += n
        for reason, count in reader.report.skipped.items():
            summary.skipped[reason] += count
        self._flush_bulk()

    def add_replay_dir(self, out: Path) -> None:
        """Draw a replay output folder: replay.mcap topics, map.yaml/pgm, map.pcd, trajectory.tum."""
        add_replay_dir(out, self.ctx, self.grids, self.trajectories, self.add_log)

    def _flush_bulk(self) -> None:
        self.scans.flush()
        self.clouds.flush()

    def finish(self) -> ViewSummary:
        """Send everything collected, choose the fixed frame and send the blueprint."""
        self._flush_bulk()
        self.tf.choose_fixed_frame()
        self.tf.send()
        self.trajectories.send()
        self.plans.send()
        self.polygons.send()
        self.goals.send(self.events.events)
        self.grids.send()
        base, poses = send_top(self.ctx, self.tf, self.scans, self.trajectories, self.plans, self.grids, self.footprint)
        send_robot(self.ctx, self.tf, base, poses, self.footprint)
        self.series.send(self.trajectories.topics)
        self.events.send()
        self.tf.link_orphan_frames()
        self.ctx.rec.send_blueprint(make_blueprint(self.summary, self.ctx.opt), make_active=True, make_default=True)
        return self.summary


# ---------------------------------------------------------------- entry points


def recording_id(reader: LogReader) -> str:
    """A recording id that depends on the log's content summary only (same log -> same id)."""
    key = f"{reader.start_ns}:{reader.end_ns}:{reader.message_count}:" + ",".join(
        f"{t.name}={t.typename}#{t.count}" for t in sorted(reader.topics.values(), key=lambda t: t.name)
    )
    return "navlog-" + hashlib.sha256(key.encode()).hexdigest()[:16]


def _check_replay_of(reader: LogReader, replay_dir: Path) -> None:
    """Warn when the replay in ``replay_dir`` was made from another log than ``reader``'s (its manifest lists its
    input's files with their hashes): its transforms would stand in for this log's."""
    import json

    from navlog.replay.identity import input_entries

    try:
        made_from = json.loads((replay_dir / "manifest.json").read_text())["inputs"]
        wanted = [(e["file"], e["sha256"]) for e in made_from]
    except (OSError, ValueError, KeyError, TypeError):
        return  # no manifest to tell: a folder of outputs drawn as they are
    if not Path(reader.path).exists():
        return
    have = [(e["file"], e["sha256"]) for e in input_entries(Path(reader.path))]
    if sorted(h for _, h in have) != sorted(h for _, h in wanted):
        names = ", ".join(name for name, _ in wanted) or "?"
        log.warning(
            "%s: the replay in %s was made from another log (%s); its transforms and outputs are drawn over this one",
            reader.path,
            replay_dir,
            names,
        )


def build_view(
    reader: LogReader, rec: Any, *, replay_dir: Path | None = None, options: ViewOptions | None = None
) -> ViewSummary:
    """Draw a log (and a replay output folder) into a RecordingStream whose sink is already set."""
    rec.set_log_time_enabled(False) if hasattr(rec, "set_log_time_enabled") else None
    rec.set_log_tick_enabled(False) if hasattr(rec, "set_log_tick_enabled") else None
    b = ViewBuilder(rec, options)
    if replay_dir is not None:
        _check_replay_of(reader, Path(replay_dir))
    if replay_dir is not None:  # the frames whose parent the replay published: its transforms, not the log's
        b.tf.replaced = {b.ctx.frame(f) for f in replay_tf_children(Path(replay_dir))}
        b.tf.replay_prefix = REPLAY_PREFIX + "/"
    b.add_log(reader)
    if replay_dir is not None:
        b.add_replay_dir(Path(replay_dir))
    if b.summary.messages == 0 and not b.summary.entities:
        have = ", ".join(f"{t.name} ({t.typename})" for t in reader.topics.values()) or "no topics"
        skipped = "".join(f"; {reason} x{n}" for reason, n in b.summary.skipped.most_common(3))
        raise LogError(f"{reader.path}: nothing to draw: the log has {have}{skipped}")
    return b.finish()


def new_recording(reader: LogReader):
    """A RecordingStream for a log, with the log's ``recording_id``."""
    import rerun as rr

    return rr.RecordingStream("navlog", recording_id=recording_id(reader))


def save_view(
    log_path: Path | str,
    out: Path | str,
    *,
    replay_dir: Path | str | None = None,
    options: ViewOptions | None = None,
    force: bool = False,
    recover: bool = False,
) -> ViewSummary:
    """Convert a log to an .rrd file; the file appears under its name only when complete, and one run
    writes it at a time (``hold_output``)."""
    out = Path(out)
    if out.parent.is_dir():
        with hold_output(out):
            return _save_view(log_path, out, replay_dir, options, force, recover)
    return _save_view(log_path, out, replay_dir, options, force, recover)


def _save_view(
    log_path: Path | str,
    out: Path,
    replay_dir: Path | str | None,
    options: ViewOptions | None,
    force: bool,
    recover: bool,
) -> ViewSummary:
    if out.suffix != ".rrd":
        raise NavlogError(f"{out}: the output must end in .rrd")
    if out.is_dir() and not out.is_symlink():
        raise NavlogError(
            f"{out}: is a folder; --save takes the path of an .rrd file to write, e.g. {out / 'view.rrd'}"
        )
    if out.exists() and not force:
        raise NavlogError(f"{out}: already exists; choose another name or pass --force to overwrite it")
    if not out.parent.is_dir():
        raise NavlogError(f"{out.parent}: output folder does not exist")
    tmp = temp_path(out)  # what killed runs left beside ``out`` is removed first
    rec = None
    try:
        with open_log(log_path, recover=recover) as reader:
            rec = new_recording(reader)
            rec.save(str(tmp))
            summary = build_view(reader, rec, replay_dir=Path(replay_dir) if replay_dir else None, options=options)
        try:
            rec.flush()
            rec.disconnect()
        except RuntimeError as exc:  # Rerun's file writer stopped: a read-only folder, a full disk, a size limit
            failure = output_failure(out, exc)
            raise (failure or exc) from None
        rec = None
        if not tmp.is_file() or tmp.stat().st_size == 0:
            raise NavlogError(f"{out}: Rerun wrote nothing")
        os.replace(tmp, out)
        return summary
    finally:
        if rec is not None:
            try:
                rec.disconnect()
            except Exception:
                pass
        tmp.unlink(missing_ok=True)


def spawn_viewer(rec: Any, *, bind: str = VIEWER_BIND, port: int = VIEWER_PORT) -> None:
    """Start a Rerun viewer whose server listens on ``bind`` (this machine only by default; Rerun's own
    ``spawn`` listens on every interface) and stream ``rec`` to it."""
    import rerun_bindings

    # Rerun's spawn (waits until the viewer listens), with the listening address it does not pass itself
    rerun_bindings.spawn(port=port, extra_args=[f"--bind={bind}"])
    rec.connect_grpc(viewer_url(bind, port))


def display_missing(environ: Mapping[str, str] | None = None, platform: str | None = None) -> str | None:
    """Why a viewer spawned here could not open a window, or None: on Linux and the BSDs a window needs
    an X server (``DISPLAY``) or a Wayland compositor (``WAYLAND_DISPLAY``); macOS and Windows always
    have one."""
    env = os.environ if environ is None else environ
    plat = sys.platform if platform is None else platform
    if plat.startswith(("darwin", "win", "cygwin")) or env.get("DISPLAY") or env.get("WAYLAND_DISPLAY"):
        return None
    return (
        "--spawn needs a display, and neither DISPLAY nor WAYLAND_DISPLAY is set (a headless machine, or SSH "
        "without X forwarding); write the recording with --save FILE.rrd and open it where there is a display "
        "(rerun FILE.rrd), or stream it to a viewer running there with --connect rerun+http://HOST:9876/proxy"
    )


def stream_view(
    log_path: Path | str,
    *,
    spawn: bool = False,
    connect: str | None = None,
    replay_dir: Path | str | None = None,
    options: ViewOptions | None = None,
    recover: bool = False,
    flush_timeout_s: float = 30.0,
    bind: str = VIEWER_BIND,
) -> ViewSummary:
    """Send a log to a viewer: a newly spawned one (listening on ``bind`` only), or one listening at ``connect``.

    Once sent to a spawned viewer (or to any viewer when ``options.play_state`` is set), the viewer's
    time cursor goes to the log's start, paused or playing as ``options.play_state`` says (default:
    playing); a viewer left following the newest data would open at the log's end."""
    opt = options or ViewOptions()
    if spawn and (why := display_missing()) is not None:  # before the log is read, not after a timeout
        raise NavlogError(why)
    with open_log(log_path, recover=recover) as reader:
        rec = new_recording(reader)
        if spawn:
            spawn_viewer(rec, bind=bind)
        else:
            rec.connect_grpc(connect)
        summary = build_view(reader, rec, replay_dir=Path(replay_dir) if replay_dir else None, options=opt)
        start = reader.start_ns - summary.time_offset_ns
    try:
        rec.flush(timeout_sec=flush_timeout_s)
    except Exception as exc:
        rec.disconnect()
        where = "the spawned viewer" if spawn else (connect or "rerun+http://127.0.0.1:9876/proxy")
        raise NavlogError(
            f"no Rerun viewer took the recording at {where} within {flush_timeout_s:g} s ({exc})"
        ) from None
    rec.disconnect()
    if spawn or opt.play_state:
        url = viewer_url(bind, VIEWER_PORT) if spawn else (connect or viewer_url(VIEWER_BIND, VIEWER_PORT))
        rewind_viewer(url, start, opt.play_state or "playing", summary)
    return summary


def viewer_url(bind: str, port: int) -> str:
    """The gRPC URL of a viewer listening on ``bind``:``port``, as reached from this machine."""
    host = f"[{bind}]" if ":" in bind else bind
    return f"rerun+http://{'127.0.0.1' if bind in ('0.0.0.0', '::') else host}:{port}/proxy"


def rewind_viewer(url: str, start_ns: int, play_state: Literal["paused", "playing"], summary: ViewSummary) -> None:
    """Put the viewer's time cursor at ``start_ns`` on ``sim_time``, paused or playing; a viewer that
    cannot be controlled (no control API) is reported in ``summary.warnings``, not an error."""
    import numpy as np

    try:
        from rerun.experimental import ViewerClient

        ViewerClient.connect(url).set_time(
            TIMELINE, duration=np.timedelta64(int(start_ns), "ns"), play_state=play_state
        )
    except Exception as exc:  # the recording is there; only the cursor could not be moved
        summary.warnings.append(f"{url}: could not move the viewer's time cursor to the start ({exc})")
