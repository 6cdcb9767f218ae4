"""navlog check-config and navlog plan through the command line entry point."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from navlog.cli import main
from navlog.replay.io.map_server import save_map
from navlog.replay.occupancy_map import OccupancyMap

DATA = Path(__file__).resolve().parents[1] / "replay" / "nav2" / "data"
JAZZY_ARTICLE = Path(__file__).resolve().parents[2] / "config" / "nav2" / "simple_robot_jazzy.yaml"  # seed 001's file


def test_check_config_exit_codes(capsys):
    assert main(["check-config", str(DATA / "kibot_nav2_fragments.yaml")]) == 1
    out = capsys.readouterr().out
    # the misspelled layer type is named once (its keys are checked once it is fixed)
    assert "did you mean 'nav2_costmap_2d::ObstacleLayer'?" in out and "data_type" not in out
    assert "1 error(s)" in out
    assert main(["check-config", str(DATA / "kibot_nav2_fixed.yaml")]) == 0


def test_plan_command(tmp_path, capsys):
    data = np.zeros((120, 120), dtype=np.int8)
    data[:2, :] = data[-2:, :] = data[:, :2] = data[:, -2:] = 100
    data[50:70, 65:75] = 100
    yaml_path, _ = save_map(OccupancyMap(data, 0.05, (-3.0, -3.0, 0.0)), tmp_path / "room.yaml")
    args = [
        "plan",
        "--map",
        str(yaml_path),
        "--start=-1.5,0,0",
        "--goal",
        "1.5,0,0",
        "--params",
        str(JAZZY_ARTICLE),
    ]
    assert main(args + ["-o", str(tmp_path / "plan.mcap"), "--png", str(tmp_path / "plan.png")]) == 0
    out = capsys.readouterr().out
    assert "planner navfn" in out and "length" in out and (tmp_path / "plan.mcap").is_file()
    assert main(args[:4] + ["--goal", "0.5,0,0"] + args[6:] + ["--set", "GridBased.tolerance=0.0"]) == 2
    assert "goal occupied" in capsys.readouterr().err
    assert main(args[:4] + ["--goal", "9,0,0"] + args[6:]) == 2
    assert "outside the costmap" in capsys.readouterr().err


def test_plan_set_without_params_overrides_nav2_defaults(tmp_path, capsys):
    data = np.zeros((120, 120), dtype=np.int8)
    data[:2, :] = data[-2:, :] = data[:, :2] = data[:, -2:] = 100
    data[50:70, 65:75] = 100  # a block x 0.25 .. 0.75, y -0.5 .. 0.5
    yaml_path, _ = save_map(OccupancyMap(data, 0.05, (-3.0, -3.0, 0.0)), tmp_path / "room.yaml")
    base = ["plan", "--map", str(yaml_path), "--start=-1.5,0,0"]
    # any --set works without --params: the short key resolves in Nav2's default planner (NavFn)
    assert main([*base, "--goal", "0.5,0,0", "--set", "tolerance=0.0"]) == 2
    assert "goal occupied" in capsys.readouterr().err
    assert main([*base, "--goal", "0.5,0,0", "--set", "GridBased.tolerance=0.5"]) == 0
    assert "tolerance moved" in capsys.readouterr().out
    assert main([*base, "--goal", "1.5,0,0", "--set", "global_costmap.inflation_layer.inflation_radius=0.3"]) == 0
    assert main([*base, "--goal", "1.5,0,0", "--set", "tolerence=0.1"]) == 2
    assert "did you mean 'tolerance'" in capsys.readouterr().err


def test_plan_refuses_far_start_or_goal_and_unbounded_inflation_radius_in_one_line(tmp_path, capsys):
    data = np.zeros((120, 120), dtype=np.int8)
    data[:2, :] = data[-2:, :] = data[:, :2] = data[:, -2:] = 100
    yaml_path, _ = save_map(OccupancyMap(data, 0.05, (-3.0, -3.0, 0.0)), tmp_path / "room.yaml")
    base = ["plan", "--map", str(yaml_path)]
    extent = "is outside the costmap x [-3.00, 3.00), y [-3.00, 3.00)"
    assert main([*base, "--start=1e308,0,0", "--goal", "1.5,0,0"]) == 2
    assert f"room.yaml: start (1e+308, 0.00) {extent}\n" in capsys.readouterr().err
    assert main([*base, "--start=-1.5,0,0", "--goal=0,-1e308,0"]) == 2
    assert f"room.yaml: goal (0.00, -1e+308) {extent}\n" in capsys.readouterr().err
    radius = "global_costmap.inflation_layer.inflation_radius"
    for value, message in (
        (".inf", "inf is out of range: must be <= 50.0"),
        ("51", "51.0 is out of range: must be <= 50.0"),
    ):
        assert main([*base, "--start=-1.5,0,0", "--goal", "1.5,0,0", "--set", f"{radius}={value}"]) == 2
        assert f"inflation_layer.inflation_radius: {message}" in capsys.readouterr().err
    assert main([*base, "--start=-1.5,0,0", "--goal", "1.5,0,0", "--set", f"{radius}=50"]) == 0


def test_plan_png_shows_start_and_goal_and_outputs_need_force(tmp_path, capsys):
    from PIL import Image

    data = np.zeros((120, 120), dtype=np.int8)
    data[:2, :] = data[-2:, :] = data[:, :2] = data[:, -2:] = 100
    yaml_path, _ = save_map(OccupancyMap(data, 0.05, (-3.0, -3.0, 0.0)), tmp_path / "room.yaml")
    png = tmp_path / "plan.png"
    args = ["plan", "--map", str(yaml_path), "--start=-1.5,-1,0", "--goal", "1.5,1,1.57", "--png", str(png)]
    assert main(args) == 0
    img = np.asarray(Image.open(png))
    assert img.shape == (120, 120, 3)

    def pixel(x: float, y: float) -> tuple[int, ...]:  # a world point's pixel: row 0 is the map's top
        col, row = int((x + 3.0) / 0.05), int((y + 3.0) / 0.05)
        return tuple(int(v) for v in img[119 - row, col])

    assert pixel(-1.5, -1.0) == (0, 158, 115)  # the start: green
    assert pixel(1.5, 1.0) == (0, 114, 178)  # the goal: blue
    assert pixel(1.5, 1.0 + 0.25) == (0, 114, 178)  # its heading tick points along +y (yaw 1.57)
    assert pixel(1.5 + 0.25, 1.0) != (0, 114, 178)
    assert (img == (220, 30, 30)).all(axis=-1).sum() > 20  # the plan between them: red
    # an existing output needs --force, and nothing is written without it
    before = png.read_bytes()
    png.write_bytes(b"mine")
    assert main(args) == 2
    assert "plan.png: already exists; choose another name or pass --force" in capsys.readouterr().err
    assert png.read_bytes() == b"mine"
    assert main([*args, "--force"]) == 0 and png.read_bytes() == before
    mcap = tmp_path / "plan.mcap"
    mcap.write_bytes(b"mine")
    assert main([*args[:-2], "-o", str(mcap)]) == 2 and mcap.read_bytes() == b"mine"
