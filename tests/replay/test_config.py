"""Typed configuration: keys, types, suggestions, overrides."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import pytest

from navlog.errors import ConfigError
from navlog.replay.config import apply_overrides, config_hash, from_mapping, load_config


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
