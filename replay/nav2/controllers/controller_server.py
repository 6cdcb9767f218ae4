"""Nav2's controller server cycle (``nav2_controller::ControllerServer::computeControl``), pure.

``ControllerServer(params, setup)`` builds the selected controller plugin and goal and progress
checkers from the registry (an id that is not listed, or a plugin navlog does not run, is a
``ConfigError`` with a did-you-mean before anything is simulated). Then, as Nav2's FollowPath
action does:

- ``follow_path(path, now_ns)`` with no goal active starts one: ``set_plan`` and the goal checker's
  ``reset`` (Nav2's ``setPlannerPath``), the progress checker's ``reset``, the patience clock set to
  ``now_ns``. With a goal active it is a pre-emption (the navigator's replan): the path is taken at
  the start of the next cycle, which resets the goal checker again -- so a stateful goal checker's
  latch lasts one plan, as in Nav2 -- but not the progress checker.
- ``cycle(now_ns, pose, odom_twist, ctx)`` is one turn of the loop, in Nav2's order: the pending path;
  the odometry twist thresholded (``|v| <= min_*_velocity_threshold`` -> 0); the goal check BEFORE
  any command (reached: zero command, ``succeeded``); the progress check (``FAILED_TO_MAKE_PROGRESS``);
  the controller. A ``NoValidControl`` with ``failure_tolerance`` > 0 (or -1: forever) gives a zero
  command until ``now - last valid command > failure_tolerance`` (``PATIENCE_EXCEEDED``); with 0 it
  fails at once (``NO_VALID_CONTROL``). Any ``ControllerError`` fails the goal with its code. On
  success and on failure the command is zero and the controller is ``reset``.

FollowPath's error codes are ``FOLLOW_PATH_CODES``. The caller runs ``cycle`` every
1/``controller_frequency`` of sim time (Nav2 uses a wall-clock rate). ``pose`` is the robot in the
local costmap's frame (None: no transform, ``TF_ERROR``); the path is (N, 3) x, y, yaw in the plan
frame, and ``ctx.global_to_local`` takes it into the pose's frame.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, cast

import numpy as np

from navlog.errors import ConfigError
from navlog.replay.config import suggest
from navlog.replay.nav2.controllers.base import (
    ControlContext,
    Controller,
    ControllerError,
    ControllerSetup,
    ControlResult,
    NoValidControl,
    Pose2D,
    Twist2D,
    transform_poses,
)
from navlog.replay.nav2.controllers.checkers import (
    GoalChecker,
    GoalCheckerParams,
    ProgressChecker,
    ProgressCheckerParams,
)
from navlog.replay.nav2.controllers.registry import CONTROLLERS, GOAL_CHECKERS, PROGRESS_CHECKERS
from navlog.replay.nav2.controllers.server import ControllerServerParams
from navlog.replay.nav2.planners.base import path_length

# nav2_msgs/action/FollowPath result codes
UNKNOWN = 100
INVALID_CONTROLLER = 101
TF_ERROR = 102
INVALID_PATH = 103
PATIENCE_EXCEEDED = 104
FAILED_TO_MAKE_PROGRESS = 105
NO_VALID_CONTROL = 106
CONTROLLER_TIMED_OUT = 107
FOLLOW_PATH_CODES = {
    UNKNOWN: "UNKNOWN",
    INVALID_CONTROLLER: "INVALID_CONTROLLER",
    TF_ERROR: "TF_ERROR",
    INVALID_PATH: "INVALID_PATH",
    PATIENCE_EXCEEDED: "PATIENCE_EXCEEDED",
    FAILED_TO_MAKE_PROGRESS: "FAILED_TO_MAKE_PROGRESS",
    NO_VALID_CONTROL: "NO_VALID_CONTROL",
    CONTROLLER_TIMED_OUT: "CONTROLLER_TIMED_OUT",
}

RUNNING = "running"
SUCCEEDED = "succeeded"
FAILED = "failed"
ZERO: Twist2D = (0.0, 0.0, 0.0)


@dataclass
class CycleOutcome:
    """One controller cycle: the command to publish and the goal's state after it."""

    status: str  # "running" | "succeeded" | "failed"
    cmd: Twist2D
    code: int = 0  # FollowPath error code when failed
    message: str = ""
    result: ControlResult | None = None  # the controller's output (local plan, trajectories) when it ran
    distance_to_goal: float = 0.0  # along the plan from its pose nearest the robot (Nav2's feedback)


def _select(kind: str, listed: tuple[str, ...], wanted: str, key: str) -> str:
    """Nav2's find*Id: the named plugin, or the only one when no name is given."""
    if wanted:
        if wanted not in listed:
            raise ConfigError(
                f"controller_server: {kind} '{wanted}' is not in {key} [{', '.join(listed)}]{suggest(wanted, listed)}"
            )
        return wanted
    if len(listed) != 1:
        raise ConfigError(
            f"controller_server: {key} lists {len(listed)} {kind}s [{', '.join(listed)}]; "
            f"Nav2 needs the FollowPath goal to name one: pass its name"
        )
    return listed[0]


def _params_of(kind: str, name: str, found: dict, key: str) -> Any:
    if name not in found:
        raise ConfigError(
            f"controller_server: {kind} '{name}' has no parameters navlog read (its plugin is unknown to navlog "
            f"or read but not implemented); check its '{name}: plugin:' (run `navlog check-config`)"
        )
    return found[name]


def thresholded(twist: Twist2D, params: ControllerServerParams) -> Twist2D:
    """The odometry twist with components at or below the server's ``min_*_velocity_threshold`` set to 0."""
    vx, vy, wz = twist
    return (
        vx if abs(vx) > params.min_x_velocity_threshold else 0.0,
        vy if abs(vy) > params.min_y_velocity_threshold else 0.0,
        wz if abs(wz) > params.min_theta_velocity_threshold else 0.0,
    )


class ControllerServer:
    """The controller server's FollowPath loop over sim time; see the module docstring."""

    def __init__(
        self,
        params: ControllerServerParams,
        setup: ControllerSetup,
        *,
        controller_id: str = "",
        goal_checker_id: str = "",
        progress_checker_id: str = "",
    ) -> None:
        self.params = params
        self.controller_id = _select("controller", params.controller_plugins, controller_id, "controller_plugins")
        self.goal_checker_id = _select(
            "goal checker", params.goal_checker_plugins, goal_checker_id, "goal_checker_plugins"
        )
        self.progress_checker_id = _select(
            "progress checker", params.progress_checker_plugins, progress_checker_id, "progress_checker_plugins"
        )
        cparams = _params_of("controller", self.controller_id, params.controllers, "controller_plugins")
        gparams = _params_of("goal checker", self.goal_checker_id, params.goal_checkers, "goal_checker_plugins")
        pparams = _params_of(
            "progress checker", self.progress_checker_id, params.progress_checkers, "progress_checker_plugins"
        )
        assert isinstance(gparams, GoalCheckerParams) and isinstance(pparams, ProgressCheckerParams)
        self.controller = cast(Controller, CONTROLLERS.create(cparams.plugin, cparams, setup))
        self.goal_checker = cast(GoalChecker, GOAL_CHECKERS.create(gparams.plugin, gparams))
        self.progress_checker = cast(ProgressChecker, PROGRESS_CHECKERS.create(pparams.plugin, pparams))
        self.active = False
        self.path = np.zeros((0, 3))
        self._pending: np.ndarray | None = None
        self._error: tuple[int, str] | None = None
        self._last_valid_ns = 0

    def _set_planner_path(self, path: np.ndarray) -> None:
        if len(path) == 0:
            self._error = (INVALID_PATH, "Path is empty.")
            return
        self.controller.set_plan(path)
        self.path = path
        self.goal_checker.reset()

    def follow_path(self, path: np.ndarray, now_ns: int) -> None:
        """A FollowPath goal: a new goal when none is active, else a pre-emption taken at the next cycle."""
        path = np.asarray(path, dtype=float).reshape(-1, 3)
        if self.active:
            self._pending = path
            return
        self.active = True
        self._pending = None
        self._error = None
        self._set_planner_path(path)
        self.progress_checker.reset()
        self._last_valid_ns = now_ns

    def cancel(self) -> None:
        """End the goal without a result (the navigator halts FollowPath): the controller is reset."""
        if self.active:
            self.active = False
            self.controller.reset()

    def _end(self, status: str, code: int = 0, message: str = "") -> CycleOutcome:
        self.active = False
        self._pending = None
        self.controller.reset()
        return CycleOutcome(status, ZERO, code, message)

    def cycle(self, now_ns: int, pose: Pose2D | None, odom_twist: Twist2D, ctx: ControlContext) -> CycleOutcome:
        """One turn of the loop (Nav2's order, see the module docstring); the goal must be active."""
        if not self.active:
            raise RuntimeError("ControllerServer.cycle without an active FollowPath goal")
        if self._pending is not None:
            path, self._pending = self._pending, None
            self._set_planner_path(path)
        if self._error is not None:
            return self._end(FAILED, *self._error)
        if pose is None:
            return self._end(FAILED, TF_ERROR, "Failed to obtain robot pose")
        velocity = thresholded(odom_twist, self.params)
        end = transform_poses(self.path[-1:], ctx.global_to_local)[0]
        if self.goal_checker.is_goal_reached(pose, (float(end[0]), float(end[1]), float(end[2])), velocity):
            return self._end(SUCCEEDED)
        if not self.progress_checker.check(pose, now_ns):
            return self._end(FAILED, FAILED_TO_MAKE_PROGRESS, "Failed to make progress")
        try:
            result = self.controller.compute_velocity_commands(pose, velocity, ctx)
        except NoValidControl as exc:
            tol = self.params.failure_tolerance
            if not (tol > 0 or tol == -1.0):
                return self._end(FAILED, NO_VALID_CONTROL, str(exc))
            if tol != -1.0 and (now_ns - self._last_valid_ns) / 1e9 > tol:
                return self._end(FAILED, PATIENCE_EXCEEDED, "Controller patience exceeded")
            return CycleOutcome(RUNNING, ZERO, message=str(exc), distance_to_goal=self._distance_to_goal(pose, ctx))
        except ControllerError as exc:
            return self._end(FAILED, exc.code, str(exc))
        self._last_valid_ns = now_ns
        return CycleOutcome(RUNNING, result.cmd, result=result, distance_to_goal=self._distance_to_goal(pose, ctx))

    def _distance_to_goal(self, pose: Pose2D, ctx: ControlContext) -> float:
        local = transform_poses(self.path, ctx.global_to_local)
        i = int(np.argmin(np.hypot(local[:, 0] - pose[0], local[:, 1] - pose[1])))
        return path_length(local[i:])


def follow_path_message(code: int) -> str:
    """'FAILED_TO_MAKE_PROGRESS (105)' for a FollowPath code."""
    return f"{FOLLOW_PATH_CODES.get(code, 'UNKNOWN')} ({code})"
