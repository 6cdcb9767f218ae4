"""`navlog metrics` end to end on a hand-built log and replay folder with known answers."""

from __future__ import annotations

import json
import math

import numpy as np
import open3d as o3d
import pytest
from scipy.spatial.transform import Rotation

from navlog.analysis.metrics.report import MetricsOptions, compute_metrics
from navlog.analysis.metrics.trajectory import Trajectory
from navlog.cli import main
from navlog.errors import NavlogError
from navlog.replay import messages as m
from navlog.replay.io.logwriter import McapLogWriter
from navlog.replay.io.map_server import save_map
from navlog.replay.io.tum import write_tum
from navlog.replay.occupancy_map import OccupancyMap
from navlog.replay.runtime.executor import Envelope

RES = 0.05
GT_PERIOD_NS = 20_000_000  # 50 Hz
N_GT = 1000  # 20 s
START_NS = 5_000_000_000
# the mapper's frame: where the world sits in it (est = A * gt)
A_ROT = Rotation.from_euler("z", 0.7)
A_T = np.array([-6.0, 3.0, 0.0])
NOISE_SIGMA = 0.02


def _gt_poses():
    """An ellipse inside the room (semi-axes 1.0 and 0.8 m, 5.7 m long), heading along the path, z = 0.3."""
    s = np.linspace(0.0, 2 * np.pi, N_GT, endpoint=False)
    x, y = 1.0 * np.cos(s), 0.8 * np.sin(s)
    yaw = np.arctan2(np.gradient(y), np.gradient(x))
    pos = np.stack([x, y, np.full_like(x, 0.3)], 1)
    quats = Rotation.from_euler("z", yaw[:, None]).as_quat()
    times = START_NS + np.arange(N_GT, dtype=np.int64) * GT_PERIOD_NS
    return times, pos, quats


def _outline_map(col_shift: int = 0) -> OccupancyMap:
    """A 3 x 3 m room outline (60 x 60 cells, walls 100, inside free, outside unknown)."""
    g = np.full((60, 60), -1, dtype=np.int8)
    lo, hi = 5, 54
    g[lo + 1 : hi, lo + 1 + col_shift : hi + col_shift] = 0
    g[[lo, hi], lo + col_shift : hi + 1 + col_shift] = 100
    g[lo : hi + 1, [lo + col_shift, hi + col_shift]] = 100
    return OccupancyMap(g, RES, origin=(-1.5, -1.5, 0.0))


@pytest.fixture(scope="module")
def world(tmp_path_factory):
    root = tmp_path_factory.mktemp("metrics")
    times, pos, quats = _gt_poses()
    log = root / "run.mcap"
    with McapLogWriter(log) as w:
        for t, p, q in zip(times, pos, quats):
            w.write(
                Envelope(
                    "/odom/ground_truth",
                    m.ODOMETRY,
                    int(t),
                    m.odometry(int(t), "world", "base_link", p, q, (0.2, 0, 0), (0, 0, 0.1)),
                )
            )
            if t % 100_000_000 == 0:
                w.write(Envelope("/clock", m.CLOCK, int(t), m.clock(int(t))))
    # the estimate: every 5th ground-truth pose (10 Hz) stamped 2 ms late, noisy, in the mapper's frame
    idx = np.arange(0, N_GT, 5)
    rng = np.random.default_rng(11)
    noise = rng.normal(0.0, NOISE_SIGMA, (len(idx), 3))
    noise[0] = 0.0  # the mapper starts where it is
    est_world = Trajectory(times[idx] + 2_000_000, pos[idx] + noise, quats[idx])
    est = est_world.transformed(A_ROT.as_matrix(), A_T)

    out = root / "out"
    out.mkdir()
    write_tum(out / "trajectory.tum", est.times_ns, est.positions, est.quaternions)
    save_map(_outline_map(col_shift=1), out / "map.yaml")  # the replayed map: one cell east
    ref_map = root / "gt.yaml"
    save_map(_outline_map(), ref_map)

    mesh = o3d.geometry.TriangleMesh.create_box(2.0, 1.0, 1.0).translate((3.0, -0.5, 0.0))  # x 3..5, y -0.5..0.5
    mesh_path = root / "box.ply"
    o3d.io.write_triangle_mesh(str(mesh_path), mesh)
    offsets = np.array([0.0, 0.01, 0.015, 0.03, 0.04, 0.1, 0.3, 0.001])  # above the top face
    pts_world = np.stack([np.linspace(3.2, 4.8, 8), np.zeros(8), 1.0 + offsets], 1)
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(A_ROT.apply(pts_world) + A_T))
    o3d.io.write_point_cloud(str(out / "map.pcd"), pcd, write_ascii=False)
    return {
        "root": root,
        "log": log,
        "out": out,
        "ref_map": ref_map,
        "mesh": mesh_path,
        "gt_pos": pos[idx],
        "est_pos": est.positions,
        "offsets": offsets,
    }


def _kabsch_rmse(ref_pos, est_pos) -> float:
    mr, me = ref_pos.mean(0), est_pos.mean(0)
    rot, _ = Rotation.align_vectors(ref_pos - mr, est_pos - me)
    return float(np.sqrt(np.mean(np.sum((rot.apply(est_pos - me) + mr - ref_pos) ** 2, axis=1))))


def test_all_metrics_with_known_answers(world):
    r = compute_metrics(world["log"], world["out"], reference_map=world["ref_map"], reference_mesh=world["mesh"])
    assert r["skipped"] == []
    t = r["trajectory"]
    assert t["ground_truth_poses"] == N_GT and t["estimate_poses"] == N_GT // 5
    assert t["ate"]["pairs"] == N_GT // 5
    assert t["ate"]["translation_m"]["rmse"] == pytest.approx(_kabsch_rmse(world["gt_pos"], world["est_pos"]), rel=1e-6)
    assert 0.025 < t["ate"]["translation_m"]["rmse"] < 0.04  # 2 cm per axis in the plane and z
    # orientations were only moved rigidly: what is left is the one small rotation the noisy
    # positions give the alignment, the same for every pose
    assert t["ate"]["rotation_deg"]["max"] < 0.5
    assert t["ate"]["rotation_deg"]["max"] - t["ate"]["rotation_deg"]["min"] < 1e-5
    assert t["ate"]["alignment"]["rotation_deg"] == pytest.approx(np.degrees(0.7), abs=0.5)
    assert t["rpe"]["unit"] == "m" and t["rpe"]["pairs"] == 5  # a 5.7 m loop in 1 m steps
    assert t["rpe"]["rotation_deg"]["max"] < 1e-4

    g = r["map_2d"]
    assert (g["precision"], g["recall"], g["f1"]) == (1.0, 1.0, 1.0)  # one cell off, tau = one cell
    assert g["mean_dist_ref_to_est_m"] == pytest.approx(0.025, abs=0.002)  # the two side walls are 1 cell off
    assert g["counts"]["ref_free_reachable"] == 48 * 48
    assert g["coverage"] == pytest.approx(47 / 48)  # the shifted room misses the first inside column

    d = r["map_3d"]
    assert d["frame"] == "first-pose"
    assert d["points"] == 8
    assert d["accuracy"] == {"0.02": pytest.approx(4 / 8), "0.05": pytest.approx(6 / 8)}
    assert d["distance_m"]["max"] == pytest.approx(0.3, abs=1e-5)
    # completeness: rays within +-15 deg from z = 0.3 see the box's sides up to z = 0.84, never its
    # top, where all the map's points are: none of the visible surface is mapped
    v = d["visible"]
    path_len = np.sum(np.linalg.norm(np.diff(_gt_poses()[1], axis=0), axis=1))
    assert v["viewpoints"] == int(path_len // 0.5) + 1
    assert v["samples"] > 100
    assert v["completeness"] == {"0.02": 0.0, "0.05": 0.0}


def test_interpolated_association(world):
    near = compute_metrics(world["log"], world["out"])
    interp = compute_metrics(world["log"], world["out"], options=MetricsOptions(interpolate=True))
    assert interp["parameters"]["interpolate"] is True
    assert interp["trajectory"]["ate"]["pairs"] == N_GT // 5  # the last estimate (at 19.902 s) is inside the span
    # the estimate is 2 ms late: the ground truth is taken a tenth of the way to the next 20 ms pose
    _, pos, _ = _gt_poses()
    idx = np.arange(0, N_GT, 5)
    ref_pos = pos[idx] + 0.1 * (pos[idx + 1] - pos[idx])
    expected = _kabsch_rmse(ref_pos, world["est_pos"])
    assert interp["trajectory"]["ate"]["translation_m"]["rmse"] == pytest.approx(expected, rel=1e-6)
    assert near["trajectory"]["ate"]["translation_m"]["rmse"] != pytest.approx(expected, rel=1e-6)


def test_exact_tolerance_and_as_is_frame(world):
    opts = MetricsOptions(tau=0.0, pcd_frame="as-is", taus_3d=(0.05,))
    r = compute_metrics(
        world["log"], world["out"], reference_map=world["ref_map"], reference_mesh=world["mesh"], options=opts
    )
    g = r["map_2d"]
    # two 50-cell walls coincide minus the end cells, the side walls do not: 2 * 49 of 196 cells
    assert g["precision"] == pytest.approx(98 / 196) and g["recall"] == pytest.approx(98 / 196)
    # the points taken in the mapper's frame are far from the box
    assert r["map_3d"]["accuracy"]["0.05"] == 0.0


def test_cli_prints_table_and_writes_stable_json(world, capsys):
    out_json = world["root"] / "m1.json"
    args = [
        "metrics",
        str(world["log"]),
        "--replay",
        str(world["out"]),
        "--reference-map",
        str(world["ref_map"]),
        "--reference-mesh",
        str(world["mesh"]),
        "--tau",
        "0.05",
        "-o",
        str(out_json),
    ]
    assert main(args) == 0
    table = capsys.readouterr().out
    assert "ATE translation" in table and "accuracy@0.05 m" in table and "precision" in table
    assert "75.00 %" in table  # accuracy@0.05
    data = json.loads(out_json.read_text())
    assert data["map_2d"]["f1"] == 1.0
    again = world["root"] / "m2.json"
    assert main(args[:-1] + [str(again)]) == 0
    assert out_json.read_bytes() == again.read_bytes()
    # an existing -o file needs --force (one rule for every command), and is left as it was without it
    again.write_text("mine")
    assert main(args[:-1] + [str(again)]) == 2
    assert "m2.json: already exists; choose another name or pass --force" in capsys.readouterr().err
    assert again.read_text() == "mine"
    assert main(args[:-1] + [str(again), "--force"]) == 0
    assert out_json.read_bytes() == again.read_bytes()


def test_missing_inputs_are_skipped_with_notes(world, tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    (out / "trajectory.tum").write_text((world["out"] / "trajectory.tum").read_text())
    assert main(["metrics", str(world["log"]), "--replay", str(out)]) == 0
    text = capsys.readouterr().out
    assert "ATE translation" in text
    assert "--reference-map MAP.yaml" in text and "--reference-mesh MESH.ply" in text
    r = compute_metrics(world["log"], out, reference_map=world["ref_map"], reference_mesh=world["mesh"])
    assert "map_2d" not in r and "map_3d" not in r
    assert any("map.yaml (not found)" in s for s in r["skipped"])
    assert any("map.pcd (not found)" in s for s in r["skipped"])


def test_nothing_to_compute_is_an_error(world, tmp_path, capsys):
    empty = tmp_path / "empty"
    empty.mkdir()
    assert main(["metrics", str(world["log"]), "--replay", str(empty), "--gt-topic", "/odom"]) == 2
    err = capsys.readouterr().err
    assert "no metric could be computed" in err and "/odom" in err and "trajectory.tum" in err


def test_bad_inputs_name_the_file(world, tmp_path, capsys):
    assert main(["metrics", str(world["log"]), "--replay", str(tmp_path / "nope")]) == 2
    assert "no such replay output folder" in capsys.readouterr().err
    assert (
        main(["metrics", str(world["log"]), "--replay", str(world["out"]), "--reference-mesh", str(tmp_path / "x.ply")])
        == 2
    )
    assert "x.ply: no such mesh file" in capsys.readouterr().err
    empty = tmp_path / "empty"
    empty.mkdir()
    assert (
        main(["metrics", str(world["log"]), "--replay", str(empty), "--reference-map", str(tmp_path / "m.yaml")]) == 2
    )
    assert "m.yaml: no such map file" in capsys.readouterr().err
    bad = tmp_path / "out"
    bad.mkdir()
    (bad / "trajectory.tum").write_text("1.0 0 0 0 0 0 0 1\n0.5 0 0 0 0 0 0 1\n")
    assert main(["metrics", str(world["log"]), "--replay", str(bad)]) == 2
    assert "trajectory.tum:2: time 0.5 s does not increase" in capsys.readouterr().err
    assert main(["metrics", str(world["log"]), "--replay", str(world["out"]), "--tau", "-1"]) == 2
    assert "tau" in capsys.readouterr().err


def test_timestamps_too_far_apart_are_explained(world, tmp_path):
    out = tmp_path / "late"
    out.mkdir()
    est = Trajectory(np.array([10**15, 10**15 + 10**8, 10**15 + 2 * 10**8]), np.eye(3), np.tile([0, 0, 0, 1.0], (3, 1)))
    write_tum(out / "trajectory.tum", est.times_ns, est.positions, est.quaternions)
    with pytest.raises(NavlogError, match="no metric could be computed.*same clock"):
        compute_metrics(world["log"], out)


def test_table_rows_carry_the_json_numbers(world):
    from navlog.analysis.metrics.report import format_table

    r = compute_metrics(world["log"], world["out"], reference_map=world["ref_map"], reference_mesh=world["mesh"])
    text = format_table(r)
    lines = text.splitlines()
    assert all(line == line.rstrip() for line in lines)

    def row(label: str) -> list[str]:
        (line,) = [ln for ln in lines if ln.strip().startswith(label)]
        return line.split()

    ate = r["trajectory"]["ate"]["translation_m"]
    assert row("ATE translation") == ["ATE", "translation"] + [
        word for k in ("rmse", "mean", "median", "max") for word in (f"{ate[k]:.4f}", "m")
    ]
    rpe = r["trajectory"]["rpe"]
    assert row("RPE translation")[-4:] == [f"{rpe['delta']:g}", f"{rpe['unit']},", str(rpe["pairs"]), "pairs"]
    g, c = r["map_2d"], r["map_2d"]["counts"]
    assert row("precision") == [
        "precision",
        f"{g['precision']:.4f}",
        f"{c['matched_est_occupied']}/{c['est_occupied']}",
        "cells",
    ]
    assert row("free-space coverage")[2:4] == [f"{100 * g['coverage']:.2f}", "%"]
    assert row("accuracy@0.05 m") == ["accuracy@0.05", "m", "75.00", "%"]
    # the numeric columns of the trajectory table are right-aligned: the rows end together
    ate_rows = [ln for ln in lines if ln.strip().startswith(("ATE", "RPE rotation"))]
    assert len({len(ln) for ln in ate_rows}) == 1


def test_metrics_of_a_truncated_log_point_to_an_option_metrics_takes(teleop_log, tmp_path):
    """The truncation error says --recover, and `navlog metrics --recover` reads the complete chunks."""
    import pytest

    from navlog.analysis.metrics.report import compute_metrics
    from navlog.cli import main
    from navlog.errors import TruncatedLogError
    from navlog.replay.session import run_replay

    out = run_replay(teleop_log, "mapping", tmp_path / "out", overrides=["lidar_mapper=off"], progress=False).out_dir
    cut = tmp_path / "cut.mcap"
    data = teleop_log.read_bytes()
    cut.write_bytes(data[: len(data) // 2])
    with pytest.raises(TruncatedLogError, match="--recover"):
        compute_metrics(cut, out)
    recovered = compute_metrics(cut, out, recover=True)["trajectory"]["ate"]["pairs"]
    whole = compute_metrics(teleop_log, out)["trajectory"]["ate"]["pairs"]
    assert 0 < recovered < whole  # only the poses within the readable half have ground truth
    assert main(["metrics", str(cut), "--replay", str(out), "--recover", "--json"]) == 0


def test_map_frame_places_a_shifted_map_on_the_reference(world, capsys):
    # the replayed map lies one cell (0.05 m) east of the reference: at tau 0 its walls miss, until
    # --map-frame says where its frame sits in the reference's
    args = ["metrics", str(world["log"]), "--replay", str(world["out"]), "--reference-map", str(world["ref_map"])]
    assert main([*args, "--tau", "0", "--json"]) == 0
    off = json.loads(capsys.readouterr().out)["map_2d"]
    assert main([*args, "--tau", "0", "--json", "--map-frame", "-0.05", "0", "0"]) == 0
    on = json.loads(capsys.readouterr().out)["map_2d"]
    assert off["f1"] < 0.6
    assert on["f1"] == pytest.approx(1.0)
    with pytest.raises(NavlogError, match="map_frame"):
        MetricsOptions(map_frame=(0.0, float("nan"), 0.0))
    with pytest.raises(NavlogError, match=r"map_frame = \(1e\+308, 0.0, 0.0\): .*within 1e\+07"):
        MetricsOptions(map_frame=(1e308, 0.0, 0.0))  # (it overflowed the grids' cell offsets)


def test_absurd_metrics_options_are_refused_with_their_names(capsys):
    # one viewpoint per 1e-9 m of path filled memory; a NaN or infinite time overflowed the nanoseconds
    with pytest.raises(NavlogError, match="view_spacing = 1e-09: must be 0.01 to 1e"):
        MetricsOptions(view_spacing_m=1e-9)
    with pytest.raises(NavlogError, match="view_range = inf"):
        MetricsOptions(view_range_m=math.inf)
    MetricsOptions(view_spacing_m=0.01, view_range_m=1e7)  # the limits themselves
    for flag in ("--max-diff", "--max-gap"):
        for value in ("nan", "inf", "-1", "1e308"):
            assert main(["metrics", "no-such.mcap", f"{flag}={value}"]) == 2
            assert f"{flag} {float(value)!r}: must be a time in seconds from 0 to 1e+06" in capsys.readouterr().err
