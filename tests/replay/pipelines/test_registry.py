"""Pipelines are registered classes: one per module, asked by name for their parameters, files and facts."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from navlog.errors import ConfigError
from navlog.replay.pipelines import PIPELINES, PipelineSpec, pipeline_names, pipeline_spec, pipeline_specs, register
from navlog.replay.runtime.pipeline import Pipeline
from navlog.replay.session import pipeline_params

REPO = Path(__file__).resolve().parents[3]


def test_every_module_registers_the_pipeline_of_its_name():
    names = pipeline_names()
    assert names == ["localization", "mapping", "navigation", "planner", "safety"]
    specs = pipeline_specs()
    assert [s.name for s in specs] == names
    assert all(issubclass(s, PipelineSpec) and PIPELINES[s.name] is s for s in specs)
    # what the tools around a replay ask of them
    assert [s.name for s in specs if s.scored_by_metrics] == ["mapping"]
    assert {s.name: s.params_file_key for s in specs} == {
        "localization": "nav2_params",
        "mapping": None,
        "navigation": "nav2_params",
        "planner": "nav2_params",
        "safety": "nav2_params",
    }
    assert {s.name: s.world_map_key for s in specs if s.world_map_key} == {"planner": "map"}
    assert sorted(s.name for s in specs if "goals" in s.facts) == ["navigation", "planner"]
    assert all({"events", "no_collision"} <= s.facts for s in specs)


def test_listing_the_pipelines_imports_none():
    code = (
        "import sys; from navlog.replay.pipelines import pipeline_names; pipeline_names(); "
        "print(sorted(m for m in sys.modules if m.startswith('navlog.replay.pipelines.')))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_an_unknown_pipeline_is_refused_with_a_suggestion():
    with pytest.raises(
        ConfigError, match=r"unknown pipeline 'maping' \(did you mean 'mapping'\?\); known: localization"
    ):
        pipeline_spec("maping")


def test_a_name_registered_twice_is_refused():
    class Other(PipelineSpec):
        name = "mapping"

    with pytest.raises(ValueError, match="pipeline 'mapping' is registered twice"):
        register(Other)
    assert PIPELINES["mapping"] is pipeline_spec("mapping")


def test_params_file_fills_the_key_the_pipeline_names():
    nav2 = REPO / "config" / "nav2" / "kibot_safety.yaml"
    safety = pipeline_params("safety", nav2)
    assert safety.nav2_params == str(nav2.resolve())
    assert type(safety) is pipeline_spec("safety").params_class


def test_what_the_parameters_name_maps_goals_and_grid():
    planner, navigation, mapping = pipeline_spec("planner"), pipeline_spec("navigation"), pipeline_spec("mapping")
    a_file = REPO / "config" / "goals" / "indoor_room_waypoints.yaml"
    params = pipeline_params("planner", overrides=["goals=indoor_room_waypoints", f"map={a_file}"])
    assert planner.goal_count(params) == 5  # the five waypoints of the file
    assert planner.static_map(params) == a_file  # any existing file: the CI checks it is a map when it reads it
    assert planner.static_map(pipeline_params("planner", overrides=["map=/no/such.yaml"])) is None
    assert navigation.goal_count(pipeline_params("navigation", overrides=["goals=''"])) is None
    assert mapping.map_resolution(pipeline_params("mapping", overrides=["occupancy.grid.resolution=0.1"])) == 0.1
    assert planner.map_resolution(params) is None and mapping.goal_count(pipeline_params("mapping")) is None


def test_a_built_pipeline_says_nothing_by_default_and_refuses_to_read_what_it_publishes():
    pipe = Pipeline("plain", [], ["/scan"], ["/tf"], ["/map"])
    assert (pipe.write_artifacts(Path(".")), pipe.skipped(), pipe.nothing_produced(), pipe.done(), pipe.report()) == (
        {},
        {},
        None,
        False,
        None,
    )
    with pytest.raises(ValueError, match="both reads and publishes /map"):
        Pipeline("loop", [], ["/map"], [], ["/map"])
