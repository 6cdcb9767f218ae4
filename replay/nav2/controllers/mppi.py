"""MPPI (``nav2_mppi_controller``): its main parameters and critics list (read and checked; not run yet).

MPPI loads each critic in ``critics`` as a plugin whose parameters sit in a section of the same
name inside the controller's section; those sections are read, not checked.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

from navlog.replay.config import suggest
from navlog.replay.nav2.plugins import PluginParams
from navlog.replay.nav2.schema import NOTE, WARNING, SectionReader, param

# sections of MPPI's own parameters, not critics
OWN_SECTIONS = ("TrajectoryVisualizer", "AckermannConstraints")


@dataclass(frozen=True)
class MPPIParams(PluginParams):
    """``nav2_mppi_controller::MPPIController`` main parameters; its critics' sections are read, not checked."""

    plugin: str = "nav2_mppi_controller::MPPIController"
    time_steps: int = param(56, ge=1)
    model_dt: float = param(0.05, gt=0.0)
    batch_size: int = param(1000, ge=1)
    ax_max: float = param(3.0, ge=0.0)
    ax_min: float = param(-3.0, le=0.0)
    ay_max: float = param(3.0, ge=0.0)
    ay_min: float = param(-3.0, le=0.0)
    az_max: float = param(3.5, ge=0.0)
    vx_std: float = param(0.2, ge=0.0)
    vy_std: float = param(0.2, ge=0.0)
    wz_std: float = param(0.2, ge=0.0)
    vx_max: float = param(0.5, ge=0.0)
    vx_min: float = param(-0.35, le=0.0)
    vy_max: float = param(0.5, ge=0.0)
    wz_max: float = param(1.9, ge=0.0)
    iteration_count: int = param(1, ge=1)
    prune_distance: float = param(1.7, gt=0.0)
    transform_tolerance: float = param(0.1, ge=0.0)
    temperature: float = param(0.3, gt=0.0)
    gamma: float = param(0.015, ge=0.0)
    motion_model: str = param("DiffDrive", choices=("DiffDrive", "Omni", "Ackermann"))
    visualize: bool = False
    regenerate_noises: bool = False
    retry_attempt_limit: int = param(1, ge=0)
    enforce_path_inversion: bool = False
    critics: tuple[str, ...] = ()
    READ_ONLY: ClassVar[tuple[str, ...]] = (
        "visualize",
        "regenerate_noises",
        "retry_attempt_limit",
        "enforce_path_inversion",
        "publish_optimal_trajectory",
        "publish_critics_stats",
        "inversion_xy_tolerance",
        "inversion_yaw_tolerance",
        "shift_control_sequence",
        "open_loop",
    )

    @classmethod
    def read_loaded(cls, r: SectionReader, section: Any, path: tuple, plugin: str) -> MPPIParams:
        """The controller's parameters; each critic's section is noted, one not in ``critics`` warned about."""
        critic_sections = tuple(k for k, v in section.items() if isinstance(v, dict))
        obj = r.read(cls, section, path, sections=critic_sections, extra={"plugin": plugin})
        for crit in critic_sections:
            if crit not in obj.critics and crit not in OWN_SECTIONS:
                r.add(
                    WARNING,
                    path + (crit,),
                    f"section '{crit}' is not in critics: MPPI ignores it{suggest(crit, obj.critics)}",
                )
            else:
                r.add(NOTE, path + (crit,), "read, not checked")
        return obj
