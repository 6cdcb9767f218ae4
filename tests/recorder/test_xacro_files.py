"""Xacro files expanded in a bounded child process: the same text as xacro gives, and bombs stopped."""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from navlog.errors import ConfigError
from navlog.recorder import xacro_files
from navlog.recorder.xacro_files import expand, read_description

HEAD = '<?xml version="1.0"?>\n<robot name="b" xmlns:xacro="http://www.ros.org/wiki/xacro">\n'
FORK = (
    HEAD + '  <xacro:macro name="m" params="n">\n'
    '    <xacro:if value="${n > 0}"><xacro:m n="${n-1}"/><xacro:m n="${n-1}"/></xacro:if>\n'
    '    <link name="l${n}"/>\n  </xacro:macro>\n  <xacro:m n="N"/>\n</robot>\n'
)


def test_a_robot_expands_to_the_text_xacro_gives(shared_dir: Path):
    tb4 = shared_dir / "external-data/nav2_sim/nav2_minimal_tb4_description/urdf/standard/turtlebot4.urdf.xacro"
    text = read_description(tb4)
    assert text == expand(tb4, {}, []) and text.count("<link ") == 32


def test_a_macro_that_forks_without_end_is_stopped_at_the_bound(tmp_path, monkeypatch):
    monkeypatch.setattr(xacro_files, "XACRO_SECONDS", 2)
    bomb = tmp_path / "fork.urdf.xacro"
    bomb.write_text(FORK.replace("N", "40"))  # 2^40 links
    start = time.monotonic()
    with pytest.raises(ConfigError, match=r"fork.urdf.xacro: the xacro expansion did not end within 2 s"):
        read_description(bomb)
    assert time.monotonic() - start < 10


def test_an_expansion_larger_than_the_bound_is_an_error(tmp_path, monkeypatch):
    small = tmp_path / "small.urdf.xacro"
    small.write_text(FORK.replace("N", "3"))  # 15 links
    assert read_description(small).count("<link ") == 15
    monkeypatch.setattr(xacro_files, "XACRO_OUTPUT", 200)
    with pytest.raises(ConfigError, match=r"small.urdf.xacro: xacro expands to more than"):
        read_description(small)


def test_an_expression_too_large_for_memory_names_the_file(tmp_path):
    big = tmp_path / "big.urdf.xacro"
    big.write_text(HEAD + "  <link name=\"${'x' * (10**10)}\"/>\n</robot>\n")  # 10 GB of name
    with pytest.raises(
        ConfigError, match=r"big.urdf.xacro: the xacro expansion needs more memory than it may have \(2 GiB\)"
    ):
        read_description(big)


def test_an_expression_no_text_can_hold_is_an_error_naming_the_file(tmp_path):
    odd = tmp_path / "odd.urdf.xacro"
    odd.write_text(HEAD + "  <link name=\"${'\\ud800'}\"/>\n</robot>\n")  # a lone surrogate: no UTF-8 for it
    with pytest.raises(ConfigError, match=r"odd.urdf.xacro: the xacro expansion failed: UnicodeEncodeError"):
        read_description(odd)
