"""The MPPI critics, one module per critic as Nav2 keeps them (``nav2_mppi_controller/src/critics``).

Each module holds a critic's parameters (read from the section of its name inside the controller's)
and its ``score``, which adds the critic's cost of every trajectory of the batch to ``CriticData.costs``:

- ``constraint``: ``ConstraintCritic``, speeds beyond the limits;
- ``cost``: ``CostCritic``, the costmap's cost along the trajectories, collisions ruled out;
- ``goal``: ``GoalCritic``, distance to the goal near the goal;
- ``goal_angle``: ``GoalAngleCritic``, heading error to the goal's yaw near the goal;
- ``obstacles``: ``ObstaclesCritic``'s parameters only (read and checked, not run);
- ``path_align``: ``PathAlignCritic``, distance to the path at the same integrated length;
- ``path_angle``: ``PathAngleCritic``, heading towards a path point ahead;
- ``path_follow``: ``PathFollowCritic``, the trajectory's end drawn along the path;
- ``prefer_forward``: ``PreferForwardCritic``, reverse speed;
- ``twirling``: ``TwirlingCritic``, turning speed;
- ``velocity_deadband``: ``VelocityDeadbandCritic``, speeds inside the deadband.

``base`` holds what they share (``CriticParams``, ``Critic``); ``registry`` maps Nav2's plugin names
to them (``CRITICS``) and builds a controller's critics (``build_critics``).
"""

from __future__ import annotations

from navlog.replay.nav2.controllers.mppi.critics.base import Critic, CriticParams
from navlog.replay.nav2.controllers.mppi.critics.constraint import ConstraintCritic, ConstraintCriticParams
from navlog.replay.nav2.controllers.mppi.critics.cost import CostCritic, CostCriticParams
from navlog.replay.nav2.controllers.mppi.critics.goal import GoalCritic, GoalCriticParams
from navlog.replay.nav2.controllers.mppi.critics.goal_angle import GoalAngleCritic, GoalAngleCriticParams
from navlog.replay.nav2.controllers.mppi.critics.obstacles import ObstaclesCriticParams
from navlog.replay.nav2.controllers.mppi.critics.path_align import PathAlignCritic, PathAlignCriticParams
from navlog.replay.nav2.controllers.mppi.critics.path_angle import PathAngleCritic, PathAngleCriticParams
from navlog.replay.nav2.controllers.mppi.critics.path_follow import PathFollowCritic, PathFollowCriticParams
from navlog.replay.nav2.controllers.mppi.critics.prefer_forward import PreferForwardCritic, PreferForwardCriticParams
from navlog.replay.nav2.controllers.mppi.critics.registry import CRITICS, PLUGIN_PREFIX, build_critics, critic_entry
from navlog.replay.nav2.controllers.mppi.critics.twirling import TwirlingCritic, TwirlingCriticParams
from navlog.replay.nav2.controllers.mppi.critics.velocity_deadband import (
    VelocityDeadbandCritic,
    VelocityDeadbandCriticParams,
)

__all__ = [
    "CRITICS",
    "PLUGIN_PREFIX",
    "ConstraintCritic",
    "ConstraintCriticParams",
    "CostCritic",
    "CostCriticParams",
    "Critic",
    "CriticParams",
    "GoalAngleCritic",
    "GoalAngleCriticParams",
    "GoalCritic",
    "GoalCriticParams",
    "ObstaclesCriticParams",
    "PathAlignCritic",
    "PathAlignCriticParams",
    "PathAngleCritic",
    "PathAngleCriticParams",
    "PathFollowCritic",
    "PathFollowCriticParams",
    "PreferForwardCritic",
    "PreferForwardCriticParams",
    "TwirlingCritic",
    "TwirlingCriticParams",
    "VelocityDeadbandCritic",
    "VelocityDeadbandCriticParams",
    "build_critics",
    "critic_entry",
]
