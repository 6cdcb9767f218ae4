"""MPPI (``nav2_mppi_controller::MPPIController``, Jazzy): its parameters, its critics, its optimizer.

One controller cycle reads as Nav2's ``evalControl``:

1. **path handler** (``path_handler``): the global plan is pruned behind the robot, cut at
   ``prune_distance`` of integrated length and at the first pose that leaves the local costmap, and
   moved into the costmap's frame; the goal is the plan's last pose;
2. **optimize** (``optimizer``), ``iteration_count`` times: noise is added to the control sequence,
   the motion model clamps the noised controls to the acceleration limits, the velocities are
   integrated into poses, every critic (``critics``) adds its cost, and the sequence becomes the
   softmax-weighted mean of the noised sequences within the speed and acceleration limits;
3. **fallback**: when every trajectory collides the optimizer resets and retries, then raises
   ``NoValidControl``;
4. the sequence is smoothed (Savitzky-Golay) and its first element (the second when the sequence
   shifts every cycle) is the command.

Nav2 draws noise with its own engine, so Nav2's numbers cannot be reproduced draw for draw; the
optimizer is checked with injected noise (``Optimizer.set_noises``) and the critics with Nav2's
unit-test vectors.

Modules, as Nav2 keeps them: ``params`` (``MPPIParams``: the controller's parameters and each listed
critic's), ``critics`` (one module per critic, ``CRITICS`` by plugin name), ``critic_data``
(``CriticData``, what the critics score), ``optimizer`` (``Optimizer``), ``path_handler``
(``PathHandler``), ``controller`` (``MPPIController``).
"""

from __future__ import annotations

from navlog.replay.nav2.controllers.base import InvalidPath
from navlog.replay.nav2.controllers.mppi.controller import MPPIController
from navlog.replay.nav2.controllers.mppi.critic_data import CriticData
from navlog.replay.nav2.controllers.mppi.critics import (
    CRITICS,
    ConstraintCriticParams,
    CostCriticParams,
    CriticParams,
    GoalAngleCriticParams,
    GoalCriticParams,
    ObstaclesCriticParams,
    PathAlignCriticParams,
    PathAngleCriticParams,
    PathFollowCriticParams,
    PreferForwardCriticParams,
    TwirlingCriticParams,
    VelocityDeadbandCriticParams,
)
from navlog.replay.nav2.controllers.mppi.optimizer import Optimizer
from navlog.replay.nav2.controllers.mppi.params import AckermannConstraintsParams, MPPIParams
from navlog.replay.nav2.controllers.mppi.path_handler import PathHandler

__all__ = [
    "CRITICS",
    "AckermannConstraintsParams",
    "ConstraintCriticParams",
    "CostCriticParams",
    "CriticData",
    "CriticParams",
    "GoalAngleCriticParams",
    "GoalCriticParams",
    "InvalidPath",
    "MPPIController",
    "MPPIParams",
    "ObstaclesCriticParams",
    "Optimizer",
    "PathAlignCriticParams",
    "PathAngleCriticParams",
    "PathFollowCriticParams",
    "PathHandler",
    "PreferForwardCriticParams",
    "TwirlingCriticParams",
    "VelocityDeadbandCriticParams",
]
