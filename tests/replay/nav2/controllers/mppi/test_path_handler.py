"""The MPPI ``PathHandler``: pruning, the costmap cut, an empty plan."""

from __future__ import annotations

import numpy as np
import pytest

from navlog.replay.nav2.controllers.base import ControlContext, ControllerSetup, InvalidPath
from navlog.replay.nav2.controllers.mppi.controller import MPPIController
from navlog.replay.nav2.controllers.mppi.params import MPPIParams
from tests.replay.nav2.controllers.mppi.unit_setup import Tolerance, local_costmap


def test_path_handler_prunes_and_cuts_at_the_costmap():
    params = MPPIParams(critics=("PathFollowCritic",), batch_size=10, prune_distance=1.45)
    ctl = MPPIController(params, ControllerSetup())
    path = np.column_stack([np.arange(0, 5.0, 0.1), np.zeros(50), np.zeros(50)])
    ctl.set_plan(path)
    ctx = ControlContext(0, local_costmap(), np.eye(3), Tolerance())
    result = ctl.compute_velocity_commands((1.02, 0.1, 0.0), (0.0, 0.0, 0.0), ctx)
    local = result.local_plan
    assert local[0, 0] == pytest.approx(1.0)  # the closest pose
    assert local[-1, 0] == pytest.approx(2.4)  # up to (not with) the first pose beyond prune_distance
    assert ctl.path_handler.plan[0, 0] == pytest.approx(1.0)  # the plan behind the robot is dropped
    # a plan in a frame moved by (-2.5, 0): its poses beyond the costmap (x >= 3) are cut
    shift = np.array([[1.0, 0.0, 2.5], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    ctl.set_plan(path)
    result = ctl.compute_velocity_commands(
        (2.0, 0.0, 0.0), (0.0, 0.0, 0.0), ControlContext(0, local_costmap(), shift, Tolerance())
    )
    assert result.local_plan[-1, 0] < 3.0
    ctl.set_plan(np.zeros((0, 3)))
    with pytest.raises(InvalidPath) as err:
        ctl.compute_velocity_commands((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), ctx)
    assert err.value.code == 103
