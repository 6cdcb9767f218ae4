"""Each reader decodes with its own type store: one log's type definitions never reach another."""

from __future__ import annotations

from pathlib import Path

import pytest
from mcap.writer import Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from navlog.replay import messages
from navlog.replay.io import LogTypestore, open_log, types_from_schema

BAR = "foo_msgs/msg/Bar"
BAR_A = "int32 count\nstring name\n"
BAR_B = "float64 x\nfloat64 y\nfoo_msgs/Baz baz\n"
BAZ = "uint8 level\n"
SCHEMA_B = BAR_B + "=" * 80 + "\nMSG: foo_msgs/Baz\n" + BAZ


def _store(*defs: tuple[str, str]):
    store = get_typestore(Stores.EMPTY)
    for name, text in defs:
        store.register(get_types_from_msg(text, name))
    return store


def _bar_a():
    store = _store((BAR, BAR_A))
    return store, store.types[BAR](count=7, name="seven")


def _bar_b():
    store = _store(("foo_msgs/msg/Baz", BAZ), (BAR, BAR_B))
    return store, store.types[BAR](x=1.5, y=-2.0, baz=store.types["foo_msgs/msg/Baz"](level=3))


def write_mcap(path: Path, schema: str, store, msg) -> Path:
    with open(path, "wb") as f:
        w = Writer(f)
        w.start(profile="ros2", library="test")
        sid = w.register_schema(BAR, "ros2msg", schema.encode())
        cid = w.register_channel("/bar", "cdr", sid)
        w.add_message(cid, log_time=1_000, publish_time=1_000, data=store.serialize_cdr(msg, BAR), sequence=0)
        w.finish()
    return path


def write_bag(path: Path, store, msg) -> Path:
    from rosbags.rosbag2 import StoragePlugin
    from rosbags.rosbag2 import Writer as BagWriter

    with BagWriter(path, version=8, storage_plugin=StoragePlugin.SQLITE3) as w:
        conn = w.add_connection("/bar", BAR, typestore=store)
        w.write(conn, 1_000, store.serialize_cdr(msg, BAR))
    return path


def _log(kind: str, tmp_path: Path, which: str) -> Path:
    store, msg = _bar_a() if which == "a" else _bar_b()
    if kind == "mcap":
        return write_mcap(tmp_path / f"{which}.mcap", BAR_A if which == "a" else SCHEMA_B, store, msg)
    return write_bag(tmp_path / f"bag_{which}", store, msg)


@pytest.mark.parametrize("kind", ["mcap", "rosbag2"])
def test_two_logs_defining_the_same_type_differently_each_decode_with_their_own(tmp_path, kind):
    base = messages.typestore()
    log_a, log_b = _log(kind, tmp_path, "a"), _log(kind, tmp_path, "b")
    with open_log(log_a) as ra:
        assert ra.topics["/bar"].known and ra.unknown_types == {}
        (env,) = list(ra.messages(["/bar"]))
        assert (env.msg.count, env.msg.name) == (7, "seven")
        assert ra.typestore is not base and BAR in ra.typestore.types
    with open_log(log_b) as rb:
        (env,) = list(rb.messages(["/bar"]))
        assert (env.msg.x, env.msg.y, env.msg.baz.level) == (1.5, -2.0, 3)
        assert not hasattr(env.msg, "count")
        assert rb.typestore is not ra.typestore
    # and the first log again, after the second: still its own definition
    with open_log(log_a) as ra2:
        (env,) = list(ra2.messages(["/bar"]))
        assert (env.msg.count, env.msg.name) == (7, "seven")
    assert BAR not in base.types and "foo_msgs/msg/Baz" not in base.types
    assert base is messages.typestore()


def test_a_log_of_known_types_decodes_with_the_shared_base_store(teleop_log):
    with open_log(teleop_log) as r:
        assert r.typestore is messages.typestore()
        assert r.unknown_types == {}


def test_types_from_schema_reads_the_root_and_every_msg_section():
    types = types_from_schema(BAR, SCHEMA_B)
    assert set(types) == {BAR, "foo_msgs/msg/Baz"}


def test_an_unparsable_schema_leaves_the_type_unknown_and_the_base_store_untouched():
    types = LogTypestore()
    assert types.store is messages.typestore() and not types.own
    assert types.add_schema(messages.ODOMETRY, "not parsed: the type is known")
    assert types.store is messages.typestore()
    assert not types.add_schema(BAR, "int32[ count\n")
    assert BAR not in messages.typestore().types
    assert types.add_schema(BAR, BAR_A) and types.own
    assert BAR in types.store.types and BAR not in messages.typestore().types
