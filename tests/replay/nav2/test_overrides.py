"""Overrides of a Nav2 parameter document by full or short key paths."""

from __future__ import annotations

from pathlib import Path

import pytest

from navlog.errors import ConfigError
from navlog.replay.nav2 import apply_nav2_overrides, load_nav2_params, resolve_key

DATA = Path(__file__).resolve().parent / "data"
JAZZY_ARTICLE = Path(__file__).resolve().parents[3] / "config" / "nav2" / "simple_robot_jazzy.yaml"  # seed 001's file


def test_overrides_full_and_short_paths():
    doc = load_nav2_params(JAZZY_ARTICLE).raw
    full = "global_costmap.global_costmap.ros__parameters.inflation_layer.inflation_radius"
    out = apply_nav2_overrides(doc, [f"{full}=0.5"])
    assert out["global_costmap"]["global_costmap"]["ros__parameters"]["inflation_layer"]["inflation_radius"] == 0.5
    assert doc["global_costmap"]["global_costmap"]["ros__parameters"]["inflation_layer"]["inflation_radius"] == 0.7
    assert resolve_key(doc, "global_costmap.inflation_layer.inflation_radius") == tuple(full.split("."))
    assert resolve_key(doc, "GridBased.tolerance") == ("planner_server", "ros__parameters", "GridBased", "tolerance")
    with pytest.raises(ConfigError, match="ambiguous"):
        resolve_key(doc, "inflation_layer.inflation_radius")  # global and local
    with pytest.raises(ConfigError, match="did you mean 'inflation_radius'"):
        resolve_key(doc, "global_costmap.inflation_layer.inflation_radios")
    # a parameter not in the file, in an existing section
    out = apply_nav2_overrides(doc, ["GridBased.use_final_approach_orientation=true"])
    assert out["planner_server"]["ros__parameters"]["GridBased"]["use_final_approach_orientation"] is True
