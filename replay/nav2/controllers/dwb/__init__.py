"""DWB, Nav2's Dynamic Window local planner (``dwb_core::DWBLocalPlanner``), the Humble default controller.

- ``params``: ``DWBParams`` (planner, kinematics, trajectory generator, and each critic's
  parameters from the controller's section, as Nav2 declares them) and ``kinematics_problems``;
- ``trajectories``: the velocity window's samples and the simulated trajectories (Standard and
  LimitedAccel generators);
- ``critics``: the ``dwb_critics`` scoring functions, vectorised over a cycle's trajectories;
- ``planner``: ``DWBController``, the controller cycle (plan transform and pruning, critics, the
  lowest legal total, ``NoValidControl`` when none is legal).
"""

from __future__ import annotations

from navlog.replay.nav2.controllers.dwb.params import CriticParams, DWBParams, kinematics_problems
from navlog.replay.nav2.controllers.dwb.planner import DWBController

__all__ = ["CriticParams", "DWBController", "DWBParams", "kinematics_problems"]
