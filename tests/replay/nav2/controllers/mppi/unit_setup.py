"""What the MPPI tests share: Nav2's unit-test batch, costmap and goal checker, and builders of critics and optimizers."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import numpy as np

from navlog.replay.nav2.controllers.base import ControllerSetup
from navlog.replay.nav2.controllers.mppi.critic_data import CriticData
from navlog.replay.nav2.controllers.mppi.critics import CRITICS, Critic
from navlog.replay.nav2.controllers.mppi.optimizer import Optimizer
from navlog.replay.nav2.controllers.mppi.params import MPPIParams
from navlog.replay.nav2.costmap.grid import CostmapGrid, CostmapParams
from navlog.replay.nav2.costmap.inflation_layer import InflationLayerParams

JAZZY_ARTICLE = Path(__file__).resolve().parents[5] / "config" / "nav2" / "simple_robot_jazzy.yaml"  # seed 001's file
B, T, DT = 1000, 30, 0.1  # the critic tests' batch, time steps and model_dt


class Tolerance:
    xy_goal_tolerance = 0.25  # Nav2's TestGoalChecker
    yaw_goal_tolerance = 0.25


def nav2_test_costmap() -> CostmapGrid:
    """Nav2's dummy costmap of the unit tests: 5 x 5 m at 0.1 m, origin (0, 0), free."""
    return CostmapGrid(CostmapParams(width=5, height=5, resolution=0.1))


def critic_data(pose=(0.0, 0.0, 0.0), goal=(0.0, 0.0), path=None, holonomic=False, **arrays) -> CriticData:
    """A (B, T) batch on Nav2's test costmap: the arrays given (vx, vy, wz, x, y, yaw), zeros for the others."""
    zeros = np.zeros((B, T), dtype=np.float32)
    a = {k: arrays.get(k, zeros).astype(np.float32) for k in ("vx", "vy", "wz", "x", "y", "yaw")}
    path = np.zeros((10, 3)) if path is None else path
    return CriticData(
        pose=pose,
        goal=goal,
        path=path,
        model_dt=DT,
        costmap=nav2_test_costmap(),
        goal_xy_tolerance=Tolerance.xy_goal_tolerance,
        holonomic=holonomic,
        **a,
    )


def make_critic(name: str, mppi: MPPIParams | None = None, **params: Any) -> Any:
    """The critic registered as ``name`` with these parameters."""
    ptype, ctype = CRITICS[name]
    assert ctype is not None
    critic: Critic[Any] = ctype(ptype(**params), mppi or MPPIParams(), ControllerSetup())
    return critic


def full(value: float) -> np.ndarray:
    return np.full((B, T), value, dtype=np.float32)


def make_optimizer(freq: float = 30.0, critics=(), **params: Any) -> Optimizer:
    p = MPPIParams(**params)
    setup = ControllerSetup(controller_frequency=freq)
    return Optimizer(p, setup, [make_critic(n, p) for n in critics])


def local_costmap(size: float = 6.0, res: float = 0.05, origin=(-3.0, -3.0)) -> CostmapGrid:
    """A free local costmap centred on the origin with an inflation layer (radius 0.7, scaling 3) declared."""
    params = CostmapParams(
        width=int(size), height=int(size), resolution=res, origin_x=origin[0], origin_y=origin[1], robot_radius=0.22
    )
    params = dataclasses.replace(
        params, layers={"inflation_layer": InflationLayerParams(inflation_radius=0.7, cost_scaling_factor=3.0)}
    )
    return CostmapGrid(params)
