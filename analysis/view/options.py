"""What a view draws and how (``ViewOptions``), and what it drew (``ViewSummary``)."""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from typing import Any, Literal

from navlog.errors import NavlogError
from navlog.replay.limits import MAX_PERIOD_S  # (a thinning period)

__all__ = ["PLAY_STATES", "PlayState", "ViewOptions", "ViewSummary"]

PLAY_STATES = ("", "paused", "playing")
MAX_MARGIN_M = 1e4  # a grid's margin around its known cells
PlayState = Literal["", "paused", "playing"]


@dataclass(frozen=True)
class ViewOptions:
    """What to draw and how; validated once by ``validate``."""

    fixed_frame: str = ""  # "" : "map" if the TF tree has it, else the root of the largest TF tree
    frame_prefix: str = ""  # stripped from every frame name (e.g. "simple_robot/")
    footprint: tuple[tuple[float, float], ...] | None = None  # None: the log's robot radius, else the Go2 outline
    grid_period_s: float = 1.0  # grids faster than this are thinned to one per period
    cloud_stride: int = 1  # keep every n-th point of each cloud
    cloud_period_s: float = 0.5  # 3D LiDAR clouds: at most one per period per topic (0: every cloud)
    grid_margin_m: float = 2.0  # grids are cropped to their known cells plus this margin
    follow: bool = False  # the 3D camera tracks the robot as time plays
    play_state: PlayState = ""  # "paused" or "playing" when the viewer opens ("": the viewer's default)
    batch_rows: int = 64  # messages per send_columns batch for clouds and scans
    max_canvas_px: int = 4000  # the top-down canvas is at most this many pixels on a side

    def validate(self) -> ViewOptions:
        if self.footprint is not None and len(self.footprint) < 3:
            raise NavlogError(f"footprint: needs at least 3 points, got {len(self.footprint)}")
        for name, value, most in (
            ("grid_period_s", self.grid_period_s, MAX_PERIOD_S),
            ("cloud_period_s", self.cloud_period_s, MAX_PERIOD_S),
            ("grid_margin_m", self.grid_margin_m, MAX_MARGIN_M),
        ):
            if not 0 <= value <= most:  # (NaN fails both)
                raise NavlogError(f"{name}: must be from 0 to {most:g}, got {value}")
        if self.play_state not in PLAY_STATES:
            raise NavlogError(f"play_state: expected one of {', '.join(PLAY_STATES)}, got {self.play_state!r}")
        if self.cloud_stride < 1 or self.batch_rows < 1 or self.max_canvas_px < 16:
            raise NavlogError("cloud_stride and batch_rows must be >= 1, max_canvas_px >= 16")
        return self


@dataclass
class ViewSummary:
    """What the recording holds: entities, the topics drawn and not drawn, what was skipped."""

    fixed_frame: str = ""
    time_offset_ns: int = 0
    wall_clock: bool = False
    entities: set[str] = field(default_factory=set)
    drawn: dict[str, str] = field(default_factory=dict)  # topic -> entity
    not_drawn: dict[str, str] = field(default_factory=dict)  # topic -> type
    unknown_types: dict[str, str] = field(default_factory=dict)
    skipped: Counter = field(default_factory=Counter)
    thinned: Counter = field(default_factory=Counter)  # what the view leaves out on purpose, by reason
    warnings: list[str] = field(default_factory=list)
    messages: int = 0
    points: int = 0
    has_top: bool = False
    grid_source: str = ""
    # the robot's first pose in the fixed frame (x, y, z, yaw), where the 3D camera starts; None: unknown
    robot_start: tuple[float, float, float, float] | None = None
    top_bounds: tuple[float, float, float, float] | None = None  # 2D view's first bounds: u0, u1, v0, v1 (px)
    robot_entity: str = ""  # the entity drawn in the robot's base frame (the 3D camera can follow it)
    plot_ranges: dict[str, tuple[float, float]] = field(default_factory=dict)  # plot origin -> y range

    def as_dict(self) -> dict[str, Any]:
        return {
            "fixed_frame": self.fixed_frame,
            "time_offset_ns": self.time_offset_ns,
            "wall_clock": self.wall_clock,
            "messages": self.messages,
            "points": self.points,
            "entities": sorted(self.entities),
            "drawn": dict(sorted(self.drawn.items())),
            "not_drawn": dict(sorted(self.not_drawn.items())),
            "unknown_types": dict(sorted(self.unknown_types.items())),
            "skipped": dict(sorted(self.skipped.items())),
            "thinned": dict(sorted(self.thinned.items())),
            "warnings": list(self.warnings),
            "grid_source": self.grid_source,
            "robot_start": list(self.robot_start) if self.robot_start else None,
        }
