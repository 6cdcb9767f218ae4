"""Crafted schemas: a type that contains itself, or a schema too large to parse in seconds, is refused with
a reason naming the type; its topic is a counted skip and the log's other topics still work (MCAP, split
rosbag2 MCAP and sqlite3 rosbag2 alike)."""

from __future__ import annotations

import logging
import re
import sqlite3
from pathlib import Path

import pytest
from mcap.writer import Writer
from rosbags.rosbag2 import Writer as BagWriter

from navlog.analysis.info import format_info, summarize
from navlog.errors import LogError
from navlog.replay.io import LogTypestore, open_log, typestore
from navlog.replay.io.typestore import (
    MAX_LOG_SCHEMA_FIELDS,
    MAX_SCHEMA_FIELDS,
    type_cycle,
    type_depth,
    types_from_schema,
)

SEP = "=" * 80 + "\n"
SELF = "int32 a\nx_msgs/Top[] again\n"  # holds itself directly
THROUGH = "int32 a\nx_msgs/Rec child\n" + SEP + "MSG: x_msgs/Rec\nint32 b\nx_msgs/Top[<=3] kids\n"
DIAMOND = "x_msgs/Leaf a\nx_msgs/Leaf b\n" + SEP + "MSG: x_msgs/Leaf\nint8 c\n"  # a type used twice: no cycle
HUGE = "\n".join(f"float64 f{i}" for i in range(300_000))
STRING = "string data"
STRING_HASH = "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"


@pytest.mark.parametrize(
    ("text", "chain"),
    [
        (SELF, "x_msgs/msg/Top holds x_msgs/msg/Top"),
        (THROUGH, "x_msgs/msg/Top holds x_msgs/msg/Rec holds x_msgs/msg/Top"),
    ],
)
def test_a_type_that_contains_itself_is_refused_naming_the_chain(text, chain):
    types = LogTypestore()
    assert types.add_schema("x_msgs/msg/Top", text) is False
    assert types.refused["x_msgs/msg/Top"] == f"schema of x_msgs/msg/Top refused: recursive type ({chain})"
    assert "x_msgs/msg/Top" not in types.store.types


def test_a_type_used_twice_is_not_a_cycle():
    assert type_cycle(types_from_schema("x_msgs/msg/Top", DIAMOND), "x_msgs/msg/Top") == []
    types = LogTypestore()
    assert types.add_schema("x_msgs/msg/Top", DIAMOND) and not types.refused


def test_a_huge_schema_is_refused_before_it_is_parsed(monkeypatch):
    parsed: list[str] = []
    monkeypatch.setattr(typestore, "types_from_schema", lambda name, text: parsed.append(name) or {})
    types = LogTypestore()
    assert types.add_schema("x_msgs/msg/Big", HUGE) is False
    assert types.add_schema("x_msgs/msg/Big", HUGE) is False  # refused once, remembered
    assert parsed == [] and types.refused["x_msgs/msg/Big"].startswith("schema of x_msgs/msg/Big refused: ")
    few = "\n".join(f"float64 f{i}" for i in range(MAX_SCHEMA_FIELDS + 1))
    assert types.add_schema("x_msgs/msg/Few", few) is False
    assert types.refused["x_msgs/msg/Few"].endswith(f"{MAX_SCHEMA_FIELDS + 1} fields, more than {MAX_SCHEMA_FIELDS}")


def test_the_schemas_of_one_log_share_a_budget():
    types = LogTypestore()
    body = "\n".join(f"float64 f{i}" for i in range(MAX_SCHEMA_FIELDS))
    n = MAX_LOG_SCHEMA_FIELDS // MAX_SCHEMA_FIELDS
    assert all(types.add_schema(f"x_msgs/msg/T{k}", body) for k in range(n))
    assert types.add_schema("x_msgs/msg/More", "int8 a\n") is False
    assert "more than 16384 fields in all" in types.refused["x_msgs/msg/More"]


def crafted_mcap(path: Path, text: str) -> Path:
    with open(path, "wb") as f:
        w = Writer(f)
        w.start(profile="ros2", library="test")
        good = w.register_channel(
            "/chatter", "cdr", w.register_schema("std_msgs/msg/String", "ros2msg", STRING.encode())
        )
        bad = w.register_channel("/crafted", "cdr", w.register_schema("x_msgs/msg/Top", "ros2msg", text.encode()))
        for k in range(10):
            w.add_message(good, k * 100_000_000, b"\x00\x01\x00\x00\x03\x00\x00\x00hi\x00", k * 100_000_000)
            w.add_message(bad, k * 100_000_000, b"\x00\x01\x00\x00" + bytes(8), k * 100_000_000)
        w.finish()
    return path


@pytest.mark.parametrize("text", [SELF, THROUGH, HUGE])
def test_an_mcap_topic_with_a_refused_schema_is_a_counted_skip(tmp_path, text):
    with open_log(crafted_mcap(tmp_path / "x.mcap", text)) as r:
        why = r.topics["/crafted"].why
        assert why.startswith("schema of x_msgs/msg/Top refused: ") and not r.topics["/crafted"].known
        info = summarize(r)
        assert info["refused_schemas"] == {"/crafted": why} and why in format_info(info)
        got = [env.msg.data for env in r.messages()]
        assert got == ["hi"] * 10 and r.report.skipped == {f"{why} on /crafted": 10}


def test_a_split_rosbag2_mcap_folder_refuses_it_too(tmp_path):
    folder = tmp_path / "bag"
    folder.mkdir()
    crafted_mcap(folder / "bag_0.mcap", THROUGH)
    (folder / "metadata.yaml").write_text(
        "rosbag2_bagfile_information:\n  version: 8\n  storage_identifier: mcap\n  relative_file_paths: [bag_0.mcap]\n"
    )
    with open_log(folder) as r:
        assert "recursive type" in r.topics["/crafted"].why
        assert [env.msg.data for env in r.messages()] == ["hi"] * 10
        assert sum(r.report.skipped.values()) == 10


def crafted_bag(folder: Path, text: str, hashes: bool) -> Path:
    with BagWriter(folder, version=8) as w:
        good = w.add_connection("/chatter", "std_msgs/msg/String", msgdef=STRING, rihs01=STRING_HASH)
        bad = w.add_connection("/crafted", "x_msgs/msg/Top", msgdef=text, rihs01="RIHS01_" + "0" * 64)
        for k in range(10):
            w.write(good, k * 100_000_000, b"\x00\x01\x00\x00\x03\x00\x00\x00hi\x00")
            w.write(bad, k * 100_000_000, b"\x00\x01\x00\x00" + bytes(8))
    if not hashes:  # a bag written before ROS 2 Iron: no type hashes
        with sqlite3.connect(next(folder.glob("*.db3"))) as db:
            db.execute("UPDATE topics SET type_description_hash = ''")
        meta = folder / "metadata.yaml"
        meta.write_text(re.sub(r"RIHS01_[0-9a-f]{64}", "", meta.read_text()))
    return folder


@pytest.mark.parametrize("text", [SELF, THROUGH, HUGE])
def test_a_sqlite_rosbag2_topic_with_a_refused_definition_is_a_counted_skip(tmp_path, text):
    with open_log(crafted_bag(tmp_path / "bag", text, hashes=False)) as r:
        assert r.topics["/crafted"].why.startswith("schema of x_msgs/msg/Top refused: ")
        assert [env.msg.data for env in r.messages()] == ["hi"] * 10
        assert sum(r.report.skipped.values()) == 10


def test_a_hashed_sqlite_rosbag2_with_a_refused_definition_is_refused_naming_it(tmp_path):
    with pytest.raises(LogError, match=r"x_msgs/msg/Top refused: recursive type .* type hashes need every definition"):
        open_log(crafted_bag(tmp_path / "bag", THROUGH, hashes=True))


@pytest.mark.slow
def test_every_command_answers_a_log_with_a_huge_and_a_recursive_schema(teleop_log, tmp_path, capsys, caplog):
    """info, check, replay, view and export: exit 0, the other topics used, the crafted ones named as skipped."""
    from mcap.reader import make_reader

    from navlog.cli import main

    caplog.set_level(logging.WARNING)
    log = tmp_path / "crafted.mcap"
    with open(teleop_log, "rb") as f, open(log, "wb") as o:
        reader = make_reader(f)
        w = Writer(o)
        w.start(profile="ros2", library="test")
        huge = w.register_channel("/huge", "cdr", w.register_schema("x_msgs/msg/Big", "ros2msg", HUGE.encode()))
        loop = w.register_channel("/loop", "cdr", w.register_schema("x_msgs/msg/Top", "ros2msg", THROUGH.encode()))
        sids: dict[int, int] = {}
        cids: dict[int, int] = {}
        for schema, channel, m in reader.iter_messages():  # in log-time order
            if m.log_time >= 2_000_000_000:
                break
            if schema.id not in sids:
                sids[schema.id] = w.register_schema(schema.name, schema.encoding, schema.data)
            if channel.id not in cids:
                cids[channel.id] = w.register_channel(channel.topic, "cdr", sids[schema.id], dict(channel.metadata))
            w.add_message(cids[channel.id], m.log_time, m.data, m.publish_time, m.sequence)
            if channel.topic == "/scan":
                for cid in (huge, loop):
                    w.add_message(cid, m.log_time, b"\x00\x01\x00\x00" + bytes(8), m.log_time)
        w.finish()
    runs = {
        "info": ["info", str(log)],
        "check": ["check", str(log)],
        "replay": ["replay", str(log), "--pipeline", "mapping", "--set", "lidar_mapper=off", "-o", str(tmp_path / "r")],
        "view": ["view", str(log), "--save", str(tmp_path / "v.rrd")],
        "export": ["export", str(log), "--to", "rosbag2", "-o", str(tmp_path / "e")],
    }
    for name, argv in runs.items():
        assert main(argv) == 0, name
        out = capsys.readouterr()
        text = out.out + out.err + caplog.text
        caplog.clear()
        if name == "replay":  # its warning, and for good in its manifest's skipped inputs
            text += (tmp_path / "r" / "manifest.json").read_text()
        if name != "check":  # (check lists the topics of unknown type)
            assert "x_msgs/msg/Big refused" in text and "x_msgs/msg/Top refused: recursive type" in text, (name, text)
    assert (tmp_path / "v.rrd").is_file()


def test_types_nested_too_deep_are_refused_and_a_real_depth_is_not():
    chain = "x_msgs/D0 next\n" + "".join(
        f"{SEP}MSG: x_msgs/D{j}\nint8 v\n" + (f"x_msgs/D{j + 1} next\n" if j + 1 < 1000 else "") for j in range(1000)
    )
    types = LogTypestore()
    assert types.add_schema("x_msgs/msg/Deep", chain) is False
    assert types.refused["x_msgs/msg/Deep"] == "schema of x_msgs/msg/Deep refused: types nested 1001 deep, more than 64"
    assert type_depth(types_from_schema("x_msgs/msg/Top", DIAMOND), "x_msgs/msg/Top") == 2


def test_a_chain_built_across_schemas_counts_the_types_registered_before():
    """Each schema a chain of 30 types ending in the previous schema's root, without repeating its section:
    each alone is 31 deep, the third reaches past 64 and is refused."""
    types = LogTypestore()
    previous = ""
    accepted = []
    for k in range(3):
        chain = f"x_msgs/C{k}_0 next\n" + "".join(
            f"{SEP}MSG: x_msgs/C{k}_{j}\nint8 v\n"
            + (f"x_msgs/C{k}_{j + 1} next\n" if j + 1 < 30 else (f"x_msgs/Root{k - 1} prev\n" if previous else ""))
            for j in range(30)
        )
        accepted.append(types.add_schema(f"x_msgs/msg/Root{k}", chain))
        previous = f"x_msgs/msg/Root{k}"
    assert accepted == [True, True, False]
    assert types.refused["x_msgs/msg/Root2"].endswith("types nested 93 deep, more than 64")
