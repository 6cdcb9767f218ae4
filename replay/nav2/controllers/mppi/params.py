"""``nav2_mppi_controller::MPPIController`` parameters, each listed critic's read into its own dataclass."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any, ClassVar

from navlog.replay.config import suggest
from navlog.replay.limits import MAX_MPPI_ITERATIONS, MAX_MPPI_SAMPLES, budget
from navlog.replay.nav2.controllers.mppi.critics import CRITICS, CostCriticParams, CriticParams, critic_entry
from navlog.replay.nav2.plugins import PluginParams
from navlog.replay.nav2.schema import ERROR, NOTE, WARNING, SectionReader, param

# sections of MPPI's own parameters, not critics
OWN_SECTIONS = ("TrajectoryVisualizer", "AckermannConstraints", "TrajectoryValidator")
# Nav2 after Jazzy: ``motion_model`` names a section whose ``plugin`` is one of these (the model's name before)
MOTION_MODEL_PLUGINS = {
    "mppi::DiffDriveMotionModel": "DiffDrive",
    "mppi::OmniMotionModel": "Omni",
    "mppi::AckermannMotionModel": "Ackermann",
}


@dataclass(frozen=True)
class AckermannConstraintsParams:
    min_turning_r: float = param(0.2, ge=0.0)


@dataclass(frozen=True)
class MPPIParams(PluginParams):
    """``nav2_mppi_controller::MPPIController`` parameters with its critics' (``critic_params``, by name).

    ``max_robot_pose_search_dist`` <= 0 means Nav2's default: half the local costmap's larger side.
    """

    plugin: str = "nav2_mppi_controller::MPPIController"
    time_steps: int = param(56, ge=1)
    model_dt: float = param(0.05, gt=0.0)
    batch_size: int = param(1000, ge=1)
    ax_max: float = param(3.0, ge=0.0)
    ax_min: float = param(-3.0, le=0.0)
    ay_max: float = param(3.0, ge=0.0)
    ay_min: float = param(-3.0, le=0.0)
    az_max: float = param(3.5, ge=0.0)
    vx_std: float = param(0.2, gt=0.0)
    vy_std: float = param(0.2, gt=0.0)
    wz_std: float = param(0.4, gt=0.0)
    vx_max: float = param(0.5, ge=0.0)
    vx_min: float = param(-0.35, le=0.0)
    vy_max: float = param(0.5, ge=0.0)
    wz_max: float = param(1.9, ge=0.0)
    iteration_count: int = param(1, ge=1, le=MAX_MPPI_ITERATIONS)
    prune_distance: float = param(1.5, gt=0.0)
    max_robot_pose_search_dist: float = 0.0
    transform_tolerance: float = param(0.1, ge=0.0)
    temperature: float = param(0.3, gt=0.0)
    gamma: float = param(0.015, ge=0.0)
    motion_model: str = param("DiffDrive", choices=("DiffDrive", "Omni", "Ackermann"))
    visualize: bool = False
    regenerate_noises: bool = False
    retry_attempt_limit: int = param(1, ge=0)
    open_loop: bool = False
    enforce_path_inversion: bool = False
    critics: tuple[str, ...] = ()
    ackermann: AckermannConstraintsParams = field(default_factory=AckermannConstraintsParams)
    critic_params: dict[str, CriticParams] = field(default_factory=dict)
    READ_ONLY: ClassVar[tuple[str, ...]] = (
        "visualize",
        "enforce_path_inversion",
        "publish_optimal_trajectory",
        "publish_critics_stats",
        "inversion_xy_tolerance",
        "inversion_yaw_tolerance",
        "shift_control_sequence",
        "transform_tolerance",
        "model_delay_vx",  # Nav2 after Jazzy: the command's delay is not modelled (navlog has none to model)
        "model_delay_vy",
        "model_delay_wz",
    )

    def __post_init__(self) -> None:
        what = f"batch_size x time_steps ({self.batch_size} x {self.time_steps})"
        budget("batch_size", what, self.batch_size * self.time_steps, MAX_MPPI_SAMPLES, " samples")

    @classmethod
    def read_loaded(cls, r: SectionReader, section: Any, path: tuple, plugin: str) -> MPPIParams:
        """The controller's parameters with each listed critic's section read and checked as its type."""
        section = _motion_model_section(r, section, path) if isinstance(section, dict) else {}
        sections = tuple(k for k, v in section.items() if isinstance(v, dict))
        obj = r.read(cls, section, path, sections=sections, extra={"plugin": plugin})
        ackermann = r.read(
            AckermannConstraintsParams, section.get("AckermannConstraints", {}), path + ("AckermannConstraints",)
        )
        for own in ("TrajectoryVisualizer", "TrajectoryValidator"):
            if own in section:
                r.add(NOTE, path + (own,), "read, not implemented by navlog")
        critic_params: dict[str, CriticParams] = {}
        for crit in obj.critics:
            entry = critic_entry(crit)
            if entry is None:
                r.add(
                    ERROR,
                    path + ("critics",),
                    f"unknown MPPI critic '{crit}'{suggest(crit, list(CRITICS))}; Nav2 fails to load it at launch",
                )
                continue
            critic_params[crit] = r.read(entry[0], section.get(crit, {}), path + (crit,))
        for crit in sections:
            if crit not in obj.critics and crit not in OWN_SECTIONS:
                r.add(
                    WARNING,
                    path + (crit,),
                    f"section '{crit}' is not in critics: MPPI ignores it{suggest(crit, obj.critics)}",
                )
        cc = critic_params.get("CostCritic")
        if isinstance(cc, CostCriticParams) and cc.near_collision_cost > 253:
            r.add(
                WARNING,
                path + ("CostCritic", "near_collision_cost"),
                f"{cc.near_collision_cost} is above 253 (inscribed): no cell reaches it, critical_cost is never added",
            )
        return dataclasses.replace(obj, ackermann=ackermann, critic_params=critic_params)


def _motion_model_section(r: SectionReader, section: dict, path: tuple) -> dict:
    """``section`` with a ``motion_model`` that names a section (Nav2 after Jazzy: ``motion_model: diff_drive``
    and ``diff_drive: {plugin: mppi::DiffDriveMotionModel}``) replaced by the model it names; that section is
    then the model's and not a critic's."""
    name = section.get("motion_model")
    model = section.get(name) if isinstance(name, str) else None
    if not isinstance(model, dict):
        return section
    plugin = model.get("plugin")
    if plugin not in MOTION_MODEL_PLUGINS:
        known = ", ".join(MOTION_MODEL_PLUGINS)
        r.add(ERROR, path + (str(name), "plugin"), f"unknown motion model plugin {plugin!r}; navlog runs {known}")
        return section
    out = {k: v for k, v in section.items() if k != name}
    out["motion_model"] = MOTION_MODEL_PLUGINS[plugin]
    return out
