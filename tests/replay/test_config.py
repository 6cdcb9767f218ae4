"""Typed configuration: keys, types, limits, suggestions, overrides; the reader that collects every problem."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import pytest

from navlog.errors import ConfigError
from navlog.replay.config import (
    ERROR,
    Item,
    ParamReader,
    Problem,
    apply_overrides,
    config_hash,
    describe,
    from_mapping,
    key_path,
    load_config,
    param,
)


@dataclass(frozen=True)
class Inner:
    rate: float = 10.0
    mode: Literal["fast", "exact"] = "exact"


@dataclass(frozen=True)
class Outer:
    name: str
    inner: Inner = field(default_factory=Inner)
    values: tuple[float, float] = (0.0, 1.0)
    items: list[int] = field(default_factory=list)


def test_builds_nested_dataclasses_and_converts_ints_to_floats():
    o = from_mapping(Outer, {"name": "a", "inner": {"rate": 5}, "values": [1, 2], "items": [3]})
    assert o == Outer("a", Inner(5.0), (1.0, 2.0), [3])
    assert isinstance(o.inner.rate, float)


@pytest.mark.parametrize(
    "data, message",
    [
        ({"name": "a", "innr": {}}, "innr: unknown key (did you mean 'inner'?)"),
        ({"name": "a", "inner": {"rat": 1}}, "inner.rat: unknown key (did you mean 'rate'?)"),
        ({"name": "a", "inner": {"rate": "x"}}, "inner.rate: expected a number"),
        ({"name": "a", "inner": {"mode": "fst"}}, "did you mean 'fast'?"),
        ({"name": "a", "values": [1]}, "values: expected 2 values, got 1"),
        ({}, "name: required key is missing"),
        ({"name": "a", "items": [1.5]}, "items[0]: expected an integer"),
    ],
)
def test_errors_name_the_key_and_suggest(data, message):
    with pytest.raises(ConfigError) as exc:
        from_mapping(Outer, data)
    assert message in str(exc.value)


def test_file_errors_name_the_file_and_line(tmp_path):
    p = tmp_path / "c.yaml"
    p.write_text("name: a\ninner:\n  rate: [1,\n")
    with pytest.raises(ConfigError, match=r"c.yaml: line \d+"):
        load_config(Outer, p)
    p.write_text("name: a\ninner: {rate: 2}\n")
    assert load_config(Outer, p, ["inner.rate=3.5", "inner.mode=fast"]).inner == Inner(3.5, "fast")
    with pytest.raises(ConfigError, match="expected KEY=VALUE"):
        load_config(Outer, p, ["inner.rate"])


def test_an_invalid_override_is_named_not_the_valid_file(tmp_path):
    p = tmp_path / "c.yaml"
    p.write_text("name: a\ninner: {rate: 2}\n")
    with pytest.raises(ConfigError) as exc:
        load_config(Outer, p, ["inner.rate=3", "inner.mode=slow", "inner.rate=4"])
    assert str(exc.value).startswith(f"override 'inner.mode=slow' (over {p}): inner.mode: ")
    with pytest.raises(ConfigError) as exc:  # an override set right again is not what the error is about
        load_config(Outer, p, ["inner.mode=slow", "inner.mode=fast", "inner.rate=x"])
    assert str(exc.value).startswith(f"override 'inner.rate=x' (over {p}): inner.rate: ")
    p.write_text("name: a\ninner: {mode: slow}\n")  # the file is wrong: an override elsewhere is not blamed
    with pytest.raises(ConfigError) as exc:
        load_config(Outer, p, ["inner.rate=3"])
    assert str(exc.value).startswith(f"{p}: inner.mode: ")
    with pytest.raises(ConfigError) as exc:  # ... but one that is wrong too is, once the file is set right
        load_config(Outer, p, ["inner.mode=fast", "inner.rate=x"])
    assert str(exc.value).startswith(f"override 'inner.rate=x' (over {p}): inner.rate: ")


def test_overrides_copy_and_hash_is_stable():
    base = {"a": {"b": 1}}
    out = apply_overrides(base, ["a.b=2", "a.c=[1, 2]"])
    assert base == {"a": {"b": 1}} and out == {"a": {"b": 2, "c": [1, 2]}}
    assert config_hash(Outer("x")) == config_hash(Outer("x")) != config_hash(Outer("y"))


def test_a_map_image_where_yaml_is_expected_names_the_yaml_that_holds_it(tmp_path):
    from navlog.replay.config import load_yaml

    (tmp_path / "room.pgm").write_bytes(b"P5\n2 2\n255\n\xfe\x00\xcd\xfe")
    (tmp_path / "room.yaml").write_text("image: room.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n")
    with pytest.raises(ConfigError) as err:
        load_yaml(tmp_path / "room.pgm")
    assert str(err.value) == (
        f"{tmp_path / 'room.pgm'}: not a YAML text file (binary content): this is a map image; give the map's "
        f"YAML (map_server's map.yaml, which names the image); {tmp_path / 'room.yaml'} names this image"
    )


@dataclass(frozen=True)
class Limited:
    rate: float = param(10.0, gt=0.0, le=100.0)
    mode: str = param("a", choices=("a", "b"))
    level: int = param(1, choices=(0, 1, 2))
    offset: float | None = None
    pose: tuple[float, float, float] = (0.0, 0.0, 0.0)


@pytest.mark.parametrize(
    "data, message",
    [
        ({"rate": 0}, "rate: 0.0 is out of range: must be > 0.0"),
        ({"rate": 100.5}, "rate: 100.5 is out of range: must be <= 100.0"),
        ({"mode": "bb"}, "mode: 'bb' is not one of a, b (did you mean 'b'?)"),
        ({"level": 3}, "level: 3 is not one of 0, 1, 2"),
        ({"offset": "x"}, "offset: expected a number, got 'x'"),
        ({"pose": 1}, "pose: expected a list of 3 numbers, got 1"),
        ({"pose": [0, 0, True]}, "pose[2]: expected a number, got True"),
        ("x", "Limited: expected a mapping of parameters, got 'x'"),
    ],
)
def test_param_limits_and_types_are_checked_in_plain_configs(data, message):
    with pytest.raises(ConfigError) as exc:
        from_mapping(Limited, data)
    assert str(exc.value) == message
    assert from_mapping(Limited, {"rate": 100, "level": 0, "offset": None, "pose": [1, 2, 3]}) == Limited(
        100.0, "a", 0, None, (1.0, 2.0, 3.0)
    )


def test_the_first_problem_in_file_order_is_reported():
    with pytest.raises(ConfigError, match=r"^values: expected 2 values, got 3$"):
        from_mapping(Outer, {"name": "a", "values": [1, 2, 3], "innr": {}})
    with pytest.raises(ConfigError, match=r"^innr: unknown key \(did you mean 'inner'\?\); allowed: name, inner"):
        from_mapping(Outer, {"innr": {}, "values": [1, 2, 3]})


class Collecting(ParamReader):
    strict = False


def test_a_collecting_reader_reports_every_problem_with_its_line_and_keeps_defaults():
    r = Collecting({("rate",): 3, ("pose",): 5, ("extra",): 6})
    out = r.read(Limited, {"rate": -1, "mode": "b", "pose": [1, "y", 2], "extra": 1})
    assert out == Limited(mode="b")  # rate and pose refused: their defaults stay
    assert [(p.severity, p.path, p.line) for p in r.problems] == [
        (ERROR, "rate", 3),
        (ERROR, "pose[1]", 5),
        (ERROR, "extra", 6),
    ]
    assert r.problems[0].format("f.yaml") == "f.yaml:3: error: rate: -1.0 is out of range: must be > 0.0"
    assert r.problems[2].message == "unknown key; allowed: rate, mode, level, offset, pose"
    ok, value = r.convert(7, float, ("x",))
    assert (ok, value, type(value)) == (True, 7.0, float)
    assert r.convert("7", float, ("x",)) == (False, None)
    assert r.problems[-1] == Problem(ERROR, "x", "expected a number, got '7'")


def test_key_paths_and_type_names():
    assert key_path(("parts", Item(2), "size", Item(0))) == "parts[2].size[0]"
    assert key_path(("a", 1, "b")) == "a.1.b"  # a YAML key that is a number stays a key
    assert describe(tuple[str, ...]) == "a list of strings"
    assert describe(tuple[float, float]) == "a list of 2 numbers"
    assert describe(tuple[float, str]) == "a list of 2 values"
    assert describe(list[int] | None) == "a list of integers"
    assert describe(Inner) == "a mapping of parameters"


# ------------------------------------------------------------ YAML within bounds
def _alias_bomb(levels: int) -> str:
    """The 'billion laughs': each level a list of nine aliases of the level below (9**levels values)."""
    lines = ['l0: &l0 ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]']
    lines += [f"l{i}: &l{i} [{', '.join([f'*l{i - 1}'] * 9)}]" for i in range(1, levels)]
    return "\n".join(lines) + "\n"


def test_an_alias_bomb_is_refused_before_it_is_built():
    from navlog.replay.config import parse_yaml

    with pytest.raises(ConfigError, match=r"bomb.yaml: malformed YAML: more than 200,000 values once its aliases"):
        parse_yaml(_alias_bomb(9), "bomb.yaml")  # 387 million values if built
    small = parse_yaml(_alias_bomb(4), "small.yaml")  # 6,561 values: a document may share its nodes
    assert len(small["l3"]) == 9 and small["l3"][0][0][0] == ["lol"] * 9


def test_nesting_beyond_the_depth_bound_is_a_clear_error_not_a_recursion_error():
    from navlog.replay.config import MAX_YAML_DEPTH, parse_yaml

    with pytest.raises(
        ConfigError, match=rf"deep.yaml: line 1, column \d+: malformed YAML: nested deeper than {MAX_YAML_DEPTH}"
    ):
        parse_yaml("a: " + "[" * 20_000 + "]" * 20_000, "deep.yaml")
    doc = parse_yaml("a: " + "[" * 50 + "1" + "]" * 50, "ok.yaml")["a"]
    for _ in range(49):
        (doc,) = doc
    assert doc == [1]


def test_an_alias_inside_its_own_anchor_is_refused():
    from navlog.replay.config import parse_yaml

    with pytest.raises(ConfigError, match="an alias refers to a node that contains it"):
        parse_yaml("a: &x [1, {b: *x}]\n", "cycle.yaml")


def test_every_reader_of_yaml_uses_the_bounded_loader(tmp_path):
    from navlog.replay.nav2.costmap.footprint import parse_footprint
    from navlog.replay.nav2.overrides import apply_nav2_overrides

    with pytest.raises(ValueError, match="footprint"):
        parse_footprint("&a [*a]")
    with pytest.raises(ConfigError, match=r"--set .*more than 200,000 values"):
        apply_nav2_overrides({"a": {"b": 1}}, ["a.b=" + _alias_bomb(9).replace("\n", ", ").join("{}")])
    world = tmp_path / "bomb.yaml"
    world.write_text(_alias_bomb(9))
    from navlog.recorder.world import load_world

    with pytest.raises(ConfigError, match=r"bomb.yaml: malformed YAML: more than"):
        load_world(str(world))


def test_unprintable_characters_are_a_clear_error():
    """PyYAML's reader refuses them while the loader is made: a ConfigError naming the file, not a traceback."""
    from navlog.replay.config import parse_yaml

    with pytest.raises(ConfigError, match=r"^x.yaml: malformed YAML: unacceptable character #x001b"):
        parse_yaml("\x1b[31m a: 1\n", "x.yaml")


def test_an_exponent_without_a_dot_or_a_sign_is_a_number_as_ros_2_reads_it(tmp_path):
    """yaml-cpp (ROS 2's parameter files, map_server's map YAML) reads 5e-2 and 1.0e300 as numbers, where
    PyYAML's YAML 1.1 rules read them as text: navlog reads them as ROS 2 does, and text stays text."""
    from navlog.replay.config import dump_yaml, parse_yaml
    from navlog.replay.io.map_server import load_map
    from navlog.replay.nav2 import parse_nav2_text

    doc = parse_yaml("a: 5e-2\nb: 1.0e300\nc: .5E3\nd: -1e+2\ne: 5\nf: 1e\ng: '5e-2'\nh: e5\n", "t.yaml")
    assert doc == {"a": 0.05, "b": 1e300, "c": 500.0, "d": -100.0, "e": 5, "f": "1e", "g": "5e-2", "h": "e5"}
    assert type(doc["e"]) is int
    assert parse_yaml("a: 1_000e3\n", "t.yaml") == {"a": "1_000e3"}  # (ROS 2 reads it as text too)
    # what navlog writes reads back the same: text that looks like such a number is quoted
    written = {"version": "1e5", "scale": 1e5, "names": ["2e3", "x"]}
    assert "'1e5'" in dump_yaml(written) and parse_yaml(dump_yaml(written), "w.yaml") == written
    nav2 = parse_nav2_text(
        "controller_server:\n  ros__parameters:\n    goal_checker:\n      xy_goal_tolerance: 25e-2\n"
    )
    assert not nav2.errors and nav2.controller_server.goal_checkers["goal_checker"].xy_goal_tolerance == 0.25
    (tmp_path / "m.pgm").write_bytes(b"P5\n2 2\n255\n" + bytes([0, 254, 254, 254]))
    (tmp_path / "m.yaml").write_text(
        "image: m.pgm\nresolution: 5e-2\norigin: [-1e1, 0, 0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.25\n"
    )
    grid = load_map(tmp_path / "m.yaml")
    assert grid.resolution == 0.05 and grid.origin[0] == -10.0


def test_a_key_written_twice_in_one_mapping_is_refused_with_both_lines():
    """PyYAML keeps the last of two equal keys without a word: a campaign's second `seeds:` silently replaced
    the first, a suite case's second `checks:` dropped the first list. Aliases and merge keys still work."""
    from navlog.replay.config import parse_yaml

    with pytest.raises(
        ConfigError, match=r"c.yaml: line 4: key 'seeds' appears twice in one mapping \(first at line 2\)"
    ):
        parse_yaml("name: c\nseeds: [0, 1]\nrobots: [go2]\nseeds: [2]\n", "c.yaml")
    assert parse_yaml("a: &x {k: 1}\nb: *x\nc: {<<: *x, j: 2}\n", "ok.yaml") == {
        "a": {"k": 1},
        "b": {"k": 1},
        "c": {"k": 1, "j": 2},
    }
