"""Nav2's reading of a parameter section: config's one reader, told how Nav2 differs."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

import pytest

from navlog.replay.config import ParamReader
from navlog.replay.nav2 import parse_nav2_text
from navlog.replay.nav2.schema import ERROR, NOTE, WARNING, SectionReader, param


@dataclass(frozen=True)
class Layer:
    enabled: bool = True
    radius: float = param(0.5, ge=0.0)
    sources: tuple[str, ...] = ()
    limits: tuple[float, ...] = (1.0, 2.0)
    points: str = "[]"
    footprint: str = "[]"
    sections: dict[str, float] = field(default_factory=dict)
    READ_ONLY: ClassVar[tuple[str, ...]] = ("publish",)


def _read(data, lines=None):
    r = SectionReader(lines or {})
    out = r.read(Layer, data, ("cm", "layer"))
    return out, [(p.severity, p.path, p.message) for p in r.problems]


def test_is_the_config_reader_collecting_every_problem():
    assert issubclass(SectionReader, ParamReader) and not SectionReader.strict
    out, problems = _read({"radius": -1, "enabled": "yes", "limits": [1, 2]})
    assert out == Layer(limits=(1.0, 2.0))
    assert problems == [
        (ERROR, "cm.layer.radius", "-1.0 is out of range: must be >= 0.0"),
        (ERROR, "cm.layer.enabled", "expected true or false, got 'yes'; Nav2 would refuse it (default used)"),
    ]


def test_a_wrong_item_refuses_the_whole_parameter():
    out, problems = _read({"limits": [1, "a", 3]})
    assert out.limits == (1.0, 2.0)
    assert problems == [
        (ERROR, "cm.layer.limits", "expected a list of numbers, got [1, 'a', 3]; Nav2 would refuse it (default used)")
    ]


def test_ros_spellings_of_values():
    out, problems = _read({"sources": "scan cloud", "points": [0.5, 0.5, 0.5, -0.5, -0.5, 0]})
    assert problems == []
    assert out.sources == ("scan", "cloud")  # a list of names as one string
    assert out.points == "[[0.5, 0.5], [0.5, -0.5], [-0.5, 0.0]]"  # Humble's flat polygon
    out, problems = _read({"footprint": [[0.2, 0.2], [0.2, -0.2]], "points": [0.5, 0.5, 0.5]})
    assert out.footprint == out.points == "[]"
    assert [p[1] for p in problems] == ["cm.layer.footprint", "cm.layer.points"]
    assert all("quote it" in p[2] for p in problems)


@pytest.mark.parametrize(
    "key, severity, message",
    [
        (
            "raytrace_range",
            ERROR,
            "'raytrace_range' was renamed to 'raytrace_max_range' in Nav2; the old name is ignored",
        ),
        ("radios", ERROR, "unknown parameter 'radios' (did you mean 'radius'?); Nav2 would ignore it silently"),
        ("colour", WARNING, "unknown parameter 'colour': Nav2 does not declare it and ignores it"),
        # a mapping field is filled by the node's reader, never from a key of its name
        ("sections", WARNING, "unknown parameter 'sections': Nav2 does not declare it and ignores it"),
        ("publish", NOTE, "read, not implemented by navlog"),
    ],
)
def test_keys_nav2_does_not_read(key, severity, message):
    out, problems = _read({key: 1.0})
    assert out == Layer()
    assert problems == [(severity, f"cm.layer.{key}", message)]


def test_problems_carry_the_line_of_their_key():
    r = SectionReader({("cm",): 1, ("cm", "layer"): 4, ("cm", "layer", "radius"): 6})
    r.read(Layer, {"radius": "x", "radios": 1}, ("cm", "layer"))
    assert [(p.path, p.line) for p in r.problems] == [("cm.layer.radius", 6), ("cm.layer.radios", 4)]


def test_an_integer_choice_is_reported_with_its_choices():
    p = parse_nav2_text(
        "controller_server:\n  ros__parameters:\n    FollowPath:\n      plugin: nav2_mppi_controller::MPPIController\n"
        "      critics: [PathAngleCritic]\n      PathAngleCritic:\n        mode: 3\n"
    )
    assert [(q.path, q.message, q.line) for q in p.errors] == [
        ("controller_server.ros__parameters.FollowPath.PathAngleCritic.mode", "3 is not one of 0, 1, 2", 7)
    ]
    assert p.controller_server.controllers["FollowPath"].critic_params["PathAngleCritic"].mode == 0
