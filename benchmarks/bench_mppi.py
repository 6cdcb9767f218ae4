"""MPPI controller cycle time: batch x time_steps at model_dt 0.05 against the 50 ms budget of 20 Hz.

Runs the Jazzy bringup's MPPI (its critics and weights; ``batch_size`` set per run) on a 3 x 3 m
local costmap at 0.05 m with an inflated box beside a straight plan, robot and plan fixed, and
prints per configuration the median cycle CPU time of N cycles (after 3 warm-up cycles), its ratio to
the 50 ms period, the cycle's share per stage (noise, rollouts: noised controls + predict + integrate,
critics, update), and the load average, alternately with the numba kernels and with their NumPy
forms (the tests' oracles, ``tests/replay/nav2/controllers/mppi/oracles.py``: the arithmetic of the
code before the kernels), ``--rounds`` times, and the ratio of the medians. One process, one thread
each (set OMP/BLAS threads to 1 before NumPy loads); the noise is drawn in the cycle (no background
runner); nothing is asserted.

    .venv/bin/python benchmarks/bench_mppi.py [--batch 1000 2000] [--cycles 40] [--rounds 2] [--shared DIR]

The bringup file is read from the external data folder (``--shared``; default ``$NAVLOG_SHARED_DIR``,
else ``shared`` beside the repository), else the copy of the article's file under tests/.
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import argparse
import dataclasses
import statistics
import sys
import time
from pathlib import Path

import numpy as np

from navlog.replay.nav2 import load_nav2_params
from navlog.replay.nav2.controllers.base import ControlContext, ControllerSetup
from navlog.replay.nav2.controllers.mppi import MPPIController, MPPIParams
from navlog.replay.nav2.costmap.grid import CostmapGrid, CostmapParams
from navlog.replay.nav2.costmap.inflation_layer import inflation_costs

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the repository: tests.shared_data, the oracle
from tests.replay.nav2.controllers.mppi.oracles import oracle_factories
from tests.shared_data import REPO, default_shared_dir

BRINGUP = Path("external-data") / "params" / "nav2_bringup_jazzy_nav2_params.yaml"  # inside the shared folder
SEED_001 = REPO / "tests" / "replay" / "nav2" / "data" / "jazzy_article_nav2_params.yaml"
BUDGET = 0.050  # s: one period at 20 Hz


class _Tolerance:
    xy_goal_tolerance = 0.25
    yaw_goal_tolerance = 0.25


def _params(shared: Path) -> MPPIParams:
    path = shared / BRINGUP if (shared / BRINGUP).exists() else SEED_001
    p = load_nav2_params(path).controller_server.controllers["FollowPath"]
    assert isinstance(p, MPPIParams)
    return p


def _costmap() -> CostmapGrid:
    cm = CostmapGrid(CostmapParams(width=3, height=3, resolution=0.05, origin_x=-1.5, origin_y=-1.5, robot_radius=0.22))
    yy, xx = np.mgrid[0 : cm.size_y, 0 : cm.size_x]
    d = np.hypot(xx - 40, yy - 36)  # a lethal cell at (0.5, 0.3) inflated to 0.7 m
    costs = inflation_costs(d, cm.resolution, 0.22, 3.0)
    costs[d * cm.resolution > 0.7] = 0
    cm.costs[:] = costs
    return cm


def measure(base: MPPIParams, batch: int, cycles: int) -> tuple[float, dict[str, float]]:
    params = dataclasses.replace(base, batch_size=batch, time_steps=56, model_dt=0.05)
    ctl = MPPIController(params, ControllerSetup(controller_frequency=20.0, seed=1, robot_radius=0.22))
    ctl.set_plan(np.column_stack([np.arange(-1.0, 1.5, 0.05), np.zeros(50), np.zeros(50)]))
    ctx = ControlContext(0, _costmap(), np.eye(3), _Tolerance())
    opt = ctl.optimizer
    stages = {"noise": 0.0, "rollouts": 0.0, "critics": 0.0, "update": 0.0}
    real_noised, real_update, real_draw = opt._noised_controls, opt._update_control_sequence, opt._draw_noises
    critic_scores = [c.score for c in ctl.critics]

    def timed(fn, stage):
        def run(*a):
            t0 = time.process_time()
            out = fn(*a)
            stages[stage] += time.process_time() - t0
            return out

        return run

    opt._draw_noises = timed(real_draw, "noise")  # type: ignore[method-assign]
    opt._noised_controls = timed(real_noised, "rollouts")  # type: ignore[method-assign]
    opt._update_control_sequence = timed(real_update, "update")  # type: ignore[method-assign]
    for c, score in zip(ctl.critics, critic_scores, strict=True):
        c.score = timed(score, "critics")  # type: ignore[method-assign]
    times = []
    for i in range(cycles + 3):
        if i == 3:
            stages = dict.fromkeys(stages, 0.0)
        t0 = time.process_time()
        ctl.compute_velocity_commands((0.0, 0.0, 0.0), (0.2, 0.0, 0.0), ctx)
        if i >= 3:
            times.append(time.process_time() - t0)
    total = sum(times)
    stages["rollouts"] -= stages["noise"]  # the noise is drawn inside the rollouts' call
    return statistics.median(times), {k: v / total for k, v in stages.items()}


def with_oracles(run):
    """``run()`` with every MPPI kernel's factory giving its NumPy oracle instead."""
    saved = [(module, name, getattr(module, name)) for module, name, _ in oracle_factories()]
    for module, name, factory in oracle_factories():
        setattr(module, name, factory)
    try:
        return run()
    finally:
        for module, name, original in saved:
            setattr(module, name, original)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--batch", type=int, nargs="+", default=[1000, 2000])
    ap.add_argument("--cycles", type=int, default=40)
    ap.add_argument("--rounds", type=int, default=2, help="alternations of kernels and NumPy")
    ap.add_argument("--shared", type=Path, default=default_shared_dir(), help="the external data folder")
    args = ap.parse_args()
    base = _params(args.shared)
    print(f"MPPI cycle, time_steps 56, model_dt 0.05, bringup critics  (load average {os.getloadavg()[0]:.2f})")
    for batch in args.batch:
        kernels, plain = [], []
        for _ in range(args.rounds):
            median, share = measure(base, batch, args.cycles)
            kernels.append(median)
            parts = ", ".join(f"{k} {v:.0%}" for k, v in share.items())
            print(
                f"batch {batch:5d} x 56, numba: median {median * 1000:6.1f} ms of {args.cycles} cycles, "
                f"{median / BUDGET:.2f} of the 50 ms budget ({parts})  (load average {os.getloadavg()[0]:.2f})"
            )
            median, share = with_oracles(lambda: measure(base, batch, args.cycles))
            plain.append(median)
            parts = ", ".join(f"{k} {v:.0%}" for k, v in share.items())
            print(
                f"batch {batch:5d} x 56, NumPy: median {median * 1000:6.1f} ms ({parts})  "
                f"(load average {os.getloadavg()[0]:.2f})"
            )
        k, p = statistics.median(kernels), statistics.median(plain)
        print(f"batch {batch:5d} x 56: numba {k * 1000:.1f} ms, NumPy {p * 1000:.1f} ms, NumPy / numba = {p / k:.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
