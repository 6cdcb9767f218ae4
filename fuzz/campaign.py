"""A seeded, repeatable fuzz campaign over navlog's inputs: logs, rosbag2 folders, configs, CLI runs.

navlog's promise for bad input is a ``NavlogError`` with a clear message, or a counted, reported skip --
never a traceback and never a hang. Cases are drawn by ``hypothesis`` strategies (one strategy per kind,
see ``KINDS``) as small JSON recipes -- "flip these bits of that seed log", "move record 3 of chunk 2
before record 0 and drop the summary", "set leaf 7 of every /scan message to NaN", "rename key 12 of
this Nav2 file", "run ``navlog replay LOG --remap /scan=/odom``" -- and each recipe is applied to the
unmutated seeds and run as one library call (the function a Python user or the CLI calls) in a worker
process under a time limit. Its outcome is

- ``OK``: the call returned;
- ``CLEAN_ERROR``: it raised a ``NavlogError`` (or the CLI exited non-zero with one line);
- ``COUNTED_SKIP``: it returned, and the reader's report counts skipped messages or a truncation;
- ``TRACEBACK``: any other exception -- a defect;
- ``HANG``: the call outlived ``--timeout`` seconds -- a defect;
- ``CRASH``: the worker process died inside the call (a signal: a segfault, the kernel's out-of-memory
  killer) -- a defect.

Generation is hypothesis's own, in runs of ``BLOCK`` examples seeded with ``@seed`` from the campaign seed
and the block number, without its example database and without shrinking, so the recipe of case ``I``
depends only on the seed, ``I`` and the hypothesis version: a run is repeatable whatever the number of workers, and one case re-runs by itself (``--case I``, which prints the
full traceback). Every TRACEBACK, HANG or CRASH saves a reproducer under ``OUT/repro/``: the mutated files,
``case.json`` (the recipe, the call and its arguments) and the traceback; ``--repro FOLDER`` re-runs it.

    python fuzz/campaign.py --cases 10000 --seed 1 --out /tmp/fuzz-out
    python fuzz/campaign.py --seed 1 --case 4711 --out /tmp/fuzz-out
    python fuzz/campaign.py --repro /tmp/fuzz-out/repro/004711-mcap-bytes-traceback --out /tmp/fuzz-out

The real bags and public Nav2 files among the seeds come from the external data folder (``--shared DIR``;
default ``$NAVLOG_SHARED_DIR``, else ``shared`` beside the repository); without it there are none.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import io
import json
import math
import multiprocessing as mp
import os
import random
import shutil
import signal
import struct
import sys
import tempfile
import time
import traceback
import zlib
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from hypothesis import HealthCheck, Phase, Verbosity, given, settings
from hypothesis import seed as hypothesis_seed
from hypothesis import strategies as st

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the repository: tests.shared_data
from tests.recorder.descriptions import GZ_PLUGIN, MODEL_SDF, POLYLINE_WORLD, ROBOT, WORLD_SDF
from tests.shared_data import REPO, default_shared_dir

OUTCOMES = ("OK", "CLEAN_ERROR", "COUNTED_SKIP", "TRACEBACK", "HANG", "CRASH")
FAILURES = ("TRACEBACK", "HANG", "CRASH")
MCAP_MAGIC = b"\x89MCAP0\r\n"

# A short teleop drive: about 0.5 s of every sensor, recorded once per output folder, and the scenario
# of every `navlog record` case.
TINY_SCENARIO = """\
name: fuzz_seed
kind: teleop
start: [0.0, 0.0, 0.0]
commands:
  - {duration: 0.4, cmd: [0.3, 0.0, 0.2]}
hold: 0.1
"""

# kind -> relative weight of the kind among the cases
KINDS: dict[str, int] = {
    "mcap-bytes": 22,
    "mcap-chunk": 8,
    "mcap-semantic": 12,
    "mcap-message": 8,
    "rosbag2": 10,
    "config-worlds": 3,
    "config-robots": 3,
    "config-scenarios": 3,
    "config-pipelines": 3,
    "config-nav2": 6,
    "config-suites": 4,
    "config-goals": 2,
    "config-campaigns": 3,
    "cli": 8,
    "cli-record": 5,
    "cli-replay": 5,
    "params-extreme": 4,
    "outputs-special": 3,
    # log times, chunk claims and CRCs, compressed bit flips, crafted schemas, YAML bombs, two writers
    "mcap-times": 6,
    "mcap-claims": 6,
    "mcap-crc": 3,
    "mcap-compressed": 4,
    "schema-crafted": 6,
    "yaml-bomb": 3,
    "two-writers": 3,
    # robot description files (URDF, SDF, xacro), map_server maps
    "description": 6,
    "map": 4,
    # a SLAM replay's output folder, one of its files mutated, drawn by `navlog view LOG --replay`
    "replay-folder": 4,
}


class Hang(Exception):
    """Raised in a worker by the per-case alarm."""


@dataclass
class Case:
    """One drawn recipe (JSON data) and its place in the campaign."""

    index: int
    kind: str
    recipe: dict[str, Any]


@dataclass
class Built:
    """A recipe applied to the seeds: files to write into a fresh folder, and the call to make on them."""

    mutation: str  # what was done, e.g. "seed_zstd:truncate@record0x06"
    call: str  # the oracle entry point, see ``call_case``
    args: dict[str, Any] = field(default_factory=dict)  # paths are relative to the case folder
    files: dict[str, bytes] = field(default_factory=dict)
    links: dict[str, str] = field(default_factory=dict)  # name -> seed file copied as is


# ----------------------------------------------------------------------------------------- seeds


@dataclass
class Seeds:
    """The unmutated inputs every case starts from (read once per process)."""

    folder: Path
    logs: dict[str, bytes]  # name -> MCAP bytes
    records: dict[str, list[tuple[int, int, int]]]  # name -> (offset, opcode, length) of top-level records
    parsed: dict[str, Any]  # name -> (schemas, channels, messages) of the small log
    bags: dict[str, Path]  # rosbag2 folders
    configs: dict[str, list[Path]]  # kind -> YAML files
    map_yaml: Path
    # name -> (file name, XML text, package or resource folders, --drive or "world") of the description files
    descriptions: dict[str, tuple[str, str, list[str], str]] = field(default_factory=dict)


def build_seed_log(folder: Path) -> Path:
    """Record the tiny drive and rewrite it small: one 3D cloud, 16 KiB chunks (many records to cut), zstd,
    uncompressed and lz4."""
    from mcap.reader import make_reader
    from mcap.writer import CompressionType, Writer

    from navlog.cli import main

    folder.mkdir(parents=True, exist_ok=True)
    names = ("seed_zstd.mcap", "seed_none.mcap", "seed_lz4.mcap", "map.yaml", "slam.mcap", "slam/pose_graph.json")
    if all((folder / name).exists() for name in names):
        return folder
    scenario = folder / "fuzz_seed.yaml"
    scenario.write_text(TINY_SCENARIO)
    raw = folder / "raw.mcap"
    with contextlib.redirect_stdout(io.StringIO()):
        main(["-q", "record", "--scenario", str(scenario), "-o", str(raw), "--force"])
        main(["-q", "world-map", "indoor_room", "-o", str(folder / "map.yaml"), "--force"])
        # the drive without its perfect localiser, mapped by the SLAM: the seed of the replay-folder kind
        main(["-q", "record", "--scenario", str(scenario), "--localization", "none", "-o", str(folder / "slam.mcap")])
        slam_args = ["--pipeline", "mapping", "--set", "pose_source=slam", "--set", "lidar_mapper=off"]
        main(["-q", "replay", str(folder / "slam.mcap"), *slam_args, "-o", str(folder / "slam"), "--force"])
    seeds = (
        ("seed_zstd.mcap", CompressionType.ZSTD),
        ("seed_none.mcap", CompressionType.NONE),
        ("seed_lz4.mcap", CompressionType.LZ4),
    )
    for name, comp in seeds:
        with open(raw, "rb") as f, open(folder / name, "wb") as out:
            reader = make_reader(f)
            writer = Writer(out, compression=comp, chunk_size=16 << 10)
            writer.start(profile="ros2", library="navlog fuzz seed")
            clouds = 0
            sids: dict[int, int] = {}
            cids: dict[int, int] = {}
            for schema, channel, message in reader.iter_messages():
                if channel.topic == "/livox/lidar":
                    clouds += 1
                    if clouds > 1:
                        continue
                if schema is not None and schema.id not in sids:
                    sids[schema.id] = writer.register_schema(schema.name, schema.encoding, schema.data)
                if channel.id not in cids:
                    sid = sids[schema.id] if schema is not None else 0
                    cids[channel.id] = writer.register_channel(
                        channel.topic, channel.message_encoding, sid, dict(channel.metadata)
                    )
                writer.add_message(
                    cids[channel.id], message.log_time, message.data, message.publish_time, message.sequence
                )
            for md in reader.iter_metadata():
                writer.add_metadata(md.name, dict(md.metadata))
            writer.finish()
    raw.unlink()
    return folder


def split_records(data: bytes, pos: int) -> list[tuple[int, int, int]]:
    """(offset, opcode, content length) of each MCAP record from ``pos`` on, up to the footer."""
    out = []
    while pos + 9 <= len(data):
        op = data[pos]
        (length,) = struct.unpack_from("<Q", data, pos + 1)
        out.append((pos, op, length))
        pos += 9 + length
        if op == 0x02:  # footer: the trailing magic follows
            break
    return out


def top_records(data: bytes) -> list[tuple[int, int, int]]:
    """(offset, opcode, content length) of each top-level MCAP record after the leading magic."""
    return split_records(data, 8)


def parse_log(data: bytes) -> tuple[list[Any], list[Any], list[Any]]:
    from mcap.reader import make_reader

    reader = make_reader(io.BytesIO(data))
    schemas: dict[int, Any] = {}
    channels: dict[int, Any] = {}
    messages = []
    for schema, channel, message in reader.iter_messages():
        if schema is not None:
            schemas[schema.id] = schema
        channels[channel.id] = channel
        messages.append(message)
    return list(schemas.values()), list(channels.values()), messages


def load_seeds(folder: Path, shared: Path) -> Seeds:
    """The seeds: the tiny drive recorded into ``folder``, the shipped configs, and what ``shared`` holds.

    From ``shared`` (the external data folder) come the rosbag2 folders of ``external-data/bags`` and the
    Nav2 files of ``external-data/params``; an absent folder gives no such seeds, so the drawn recipes
    depend on it.
    """
    external = shared / "external-data"
    build_seed_log(folder)
    logs = {p.stem: p.read_bytes() for p in sorted(folder.glob("seed_*.mcap"))}
    talker = external / "bags/rosbag2_talker_mcap/talker.mcap"
    if talker.is_file():
        logs["talker"] = talker.read_bytes()
    bags = {p.name: p for p in sorted((external / "bags").glob("*")) if p.is_dir() and p.name != "tb3_gazebo_walker"}
    configs = {
        kind: sorted((REPO / "config" / kind).glob("*.yaml"))
        for kind in ("worlds", "robots", "scenarios", "pipelines", "suites")
    }
    configs["suites"] = [p for p in configs["suites"] if "cases:" in p.read_text()]  # a suite, not its params
    configs["goals"] = sorted((REPO / "config" / "goals").glob("*.yaml"))
    configs["campaigns"] = sorted((REPO / "examples" / "campaigns").glob("*.yaml"))
    configs["nav2"] = sorted(
        [
            *(REPO / "tests/replay/nav2/data").glob("*.yaml"),
            *(REPO / "config/nav2").glob("*.yaml"),
            *(external / "params").glob("*.yaml"),
            REPO / "tests/replay/mapping/data/mapper_params_online_async.yaml",  # a slam_toolbox block
        ]
    )
    descriptions = {
        "world": ("world.sdf", WORLD_SDF, ["models"], "world"),
        "world-polyline": ("world.sdf", POLYLINE_WORLD, ["models"], "world"),
        "urdf": ("robot.urdf", ROBOT.replace("PLUGIN", GZ_PLUGIN), [], ""),
        "sdf": ("robot.sdf", ROBOT_SDF, [], ""),
        "xacro": ("robot.urdf.xacro", ROBOT_XACRO, [], ""),
    }
    nav2_sim = external / "nav2_sim"
    waffle = nav2_sim / "nav2_minimal_tb3_sim/urdf/turtlebot3_waffle.urdf"
    if waffle.is_file():
        descriptions["waffle"] = ("turtlebot3_waffle.urdf", waffle.read_text(), [str(nav2_sim)], "diff_drive")
    return Seeds(
        folder=folder,
        logs=logs,
        records={k: top_records(v) for k, v in logs.items()},
        parsed={"seed_none": parse_log(logs["seed_none"])},
        bags=bags,
        configs=configs,
        map_yaml=folder / "map.yaml",
        descriptions=descriptions,
    )


# ------------------------------------------------------------------------------------ strategies
#
# A strategy draws a recipe: plain JSON data naming the seed, the mutation and its parameters. Places in
# a file are drawn as 32-bit fractions of its length (``at``), so hypothesis's simplest value is the start.

AT = st.integers(0, 2**32 - 1)
INDEX = st.integers(0, 2**20)  # an item of a list whose length is known only when the recipe is applied
SPECIAL_FLOATS = [math.nan, math.inf, -math.inf, 1e308, -1e308, -0.0, 3.4e38, 5e-324]
FLOATS = st.one_of(st.sampled_from(SPECIAL_FLOATS), st.floats())
ARGV_TEXT = st.text(st.characters(blacklist_categories=("Cs",), blacklist_characters="\x00"), max_size=8)

BYTE_OPS = [
    "bitflip",
    "bitflip@summary",
    "truncate@random",
    "truncate@record",
    "length",
    "chunk-field",
    "duplicate-bytes",
    "drop-bytes",
    "duplicate-record",
    "swap-records",
    "drop-record",
    "zero-run",
]
RECORD_CUTS = ["start", "opcode", "length", "half", "end-1", "end"]
LENGTHS: list[int | str] = ["-1", "+1", "+8", 0, 1, 2**31, 2**63 - 1, 2**64 - 1]
CHUNK_FIELDS = {"start": (0, "<Q"), "end": (8, "<Q"), "size": (16, "<Q"), "crc": (24, "<I")}


def chunks_of(records: list[tuple[int, int, int]]) -> list[tuple[int, int, int]]:
    return [r for r in records if r[1] == 0x06] or records


@st.composite
def mcap_bytes(draw: Any, seeds: Seeds) -> dict[str, Any]:
    """Bit flips, truncations at random places and record boundaries, corrupted record lengths and chunk
    fields, duplicated, dropped or swapped bytes and records."""
    log = draw(st.sampled_from(sorted(seeds.logs)))
    records = st.integers(0, len(seeds.records[log]) - 1)
    op = draw(st.sampled_from(BYTE_OPS))
    r: dict[str, Any] = {"log": log, "op": op}
    if op.startswith("bitflip"):
        r["flips"] = draw(st.lists(st.tuples(AT, st.integers(0, 7)), min_size=1, max_size=16))
    elif op == "truncate@random":
        r["at"] = draw(AT)
    elif op == "truncate@record":
        r["record"], r["cut"] = draw(records), draw(st.sampled_from(RECORD_CUTS))
    elif op == "length":
        r["record"] = draw(records)
        r["value"] = draw(st.one_of(st.sampled_from(LENGTHS), st.integers(0, 2**64 - 1)))
    elif op == "chunk-field":
        r["chunk"] = draw(st.integers(0, len(chunks_of(seeds.records[log])) - 1))
        r["field"] = draw(st.sampled_from(sorted(CHUNK_FIELDS)))
        r["value"] = draw(st.one_of(st.sampled_from([0, 1, 0xFFFFFFFF, 2**63 - 1, 2**64 - 1]), st.integers(0, 2**32)))
        r["delta"] = draw(st.one_of(st.none(), st.integers(-64, 64)))
    elif op in ("duplicate-bytes", "drop-bytes", "zero-run"):
        r["at"], r["size"] = draw(AT), draw(st.integers(1, 4096))
    elif op in ("duplicate-record", "drop-record"):
        r["record"] = draw(records)
    else:
        r["record"], r["other"] = draw(records), draw(records)
    r["call"] = draw(st.sampled_from(["read", "read", "read-recover", "check", "cli-info", "recover"]))
    return r


CHUNK_OPS = ["swap", "reverse", "shuffle", "duplicate", "drop", "first", "last"]


@st.composite
def mcap_chunk(draw: Any, seeds: Seeds) -> dict[str, Any]:
    """Records reordered, duplicated or dropped inside a (compressed) chunk, which is recompressed; its CRC
    fixed or left stale; the summary kept (stale offsets) or removed (readers must stream)."""
    log = draw(st.sampled_from(["seed_zstd", "seed_zstd", "seed_none"]))
    return {
        "log": log,
        "chunk": draw(st.integers(0, len(chunks_of(seeds.records[log])) - 1)),
        "op": draw(st.sampled_from(CHUNK_OPS)),
        "i": draw(INDEX),
        "j": draw(INDEX),
        "order": draw(st.integers(0, 2**32 - 1)),
        "crc": draw(st.sampled_from(["fixed", "fixed", "stale", "zero"])),
        "summary": draw(st.sampled_from(["kept", "none"])),
        "call": draw(st.sampled_from(["read", "read", "read-recover", "check", "recover"])),
    }


SCHEMA_TOKENS = ["float64", "float32", "uint8[]", "string", "int32", "builtin_interfaces/Time", "std_msgs/Header"]
SCHEMA_GARBAGE = ["%%%", "uint8[ data", "foo/Bar x", "int32 = 3", "string<=", "\x00\xff", "a b c d"]
SCHEMA_SEPARATORS = ["=" * 80, "MSG: ", "MSG: nonexistent/msg/Type", "=" * 80 + "\nMSG: a/b"]
SCHEMA_NAMES = ["", "foo", "a/b", "sensor_msgs/msg/Imu", "nav_msgs/msg/Nope", "x/msg/Y/Z", "sensor_msgs/Imu"]
SEMANTIC_OPS = ["schema-text", "schema-name", "encoding", "cdr", "nan-inf", "times", "order", "no-messages", "dangling"]
CDR_FORMS = ["truncate", "extend", "random", "empty", "header", "flip"]
TIME_FORMS = ["backwards", "zero", "max", "future", "duplicate", "jump"]


@st.composite
def mcap_semantic(draw: Any, seeds: Seeds) -> dict[str, Any]:
    """The small log re-encoded with wrong schema text or names, foreign encodings, CDR that does not
    match its schema, NaN/inf written into payloads, times backwards or far away, messages out of order."""
    _, channels, _ = seeds.parsed["seed_none"]
    op = draw(st.sampled_from(SEMANTIC_OPS))
    r: dict[str, Any] = {"op": op, "channel": draw(st.integers(0, len(channels) - 1))}
    if op == "schema-text":
        r["form"] = draw(st.sampled_from(["drop-line", "swap-type", "garbage", "empty", "duplicate-line", "separator"]))
        r["line"] = draw(INDEX)
        r["token"] = draw(st.sampled_from(SCHEMA_TOKENS + SCHEMA_GARBAGE + SCHEMA_SEPARATORS))
    elif op == "schema-name":
        r["name"] = draw(st.one_of(st.sampled_from(SCHEMA_NAMES), st.text(max_size=12)))
    elif op == "encoding":
        r["on"] = draw(st.sampled_from(["channel", "schema"]))
        r["value"] = draw(st.sampled_from(["json", "ros1", "", "protobuf", "jsonschema", "ros2idl", "ros1msg"]))
    elif op in ("cdr", "nan-inf"):
        r["first"] = draw(st.one_of(st.none(), st.integers(1, 3)))  # None: every message of the channel
        if op == "cdr":
            r["form"] = draw(st.sampled_from(CDR_FORMS))
            r["at"] = draw(AT)
            r["bytes"] = draw(st.binary(min_size=1, max_size=64)).hex()
            r["flips"] = draw(st.lists(st.tuples(AT, st.integers(0, 7)), min_size=1, max_size=8))
        else:
            r["floats"] = draw(st.lists(st.tuples(st.sampled_from([4, 8]), AT, FLOATS), min_size=1, max_size=8))
    elif op == "times":
        r["form"] = draw(st.sampled_from(TIME_FORMS))
    elif op == "order":
        r["order"], r["repeat"] = draw(st.integers(0, 2**32 - 1)), draw(st.integers(0, 50))
    elif op == "dangling":
        r["schema_id"] = draw(st.sampled_from([0, 999]))
    r["compression"] = draw(st.sampled_from(["zstd", "none"]))
    r["profile"] = draw(st.sampled_from(["ros2", "ros2", "", "ros1"]))
    r["call"] = draw(st.sampled_from(["read", "read", "read-recover", "check", "cli-info", "recover"]))
    return r


STAMP_FORMS = ["backwards", "future", "past", "zero", "nanosec-overflow", "same"]
TEXT_VALUES = ["", "/", "map", "frame with spaces", "é/ü", "../../x", "a" * 300]


@st.composite
def mcap_message(draw: Any, seeds: Seeds) -> dict[str, Any]:
    """Decoded messages with NaN/inf (or huge, or tiny) floats, empty or NaN-filled arrays, changed sizes,
    zero-size clouds, header stamps in the future, the past or going backwards; re-serialized as CDR, read,
    checked and replayed through the mapping and the safety pipelines."""
    _, channels, _ = seeds.parsed["seed_none"]
    leaf = st.fixed_dictionaries(
        {
            "leaf": INDEX,
            "float": FLOATS,
            "int": st.one_of(st.sampled_from([0, 1, 2**31 - 1, 2**32 - 1]), st.integers(0, 2**31 - 1)),
            "array": st.sampled_from(["empty", "nan", "inf", "half", "double"]),
            "text": st.one_of(st.sampled_from(TEXT_VALUES), ARGV_TEXT),
        }
    )
    return {
        "channel": draw(st.integers(0, len(channels) - 1)),
        "first": draw(st.one_of(st.none(), st.integers(1, 3))),
        "leaves": draw(st.lists(leaf, max_size=4)),
        "special": draw(st.sampled_from([None, "zero-cloud", *(f"stamp-{f}" for f in STAMP_FORMS)])),
        "call": draw(
            st.sampled_from(["read", "check", "cli-info", "replay-mapping", "replay-mapping", "replay-safety"])
        ),
    }


ODD_VALUES: list[Any] = ["", "abc", "1.5", "/scan", "indoor_room", "~", "null", "0x10", "1e400", [[0, 0], [1]]]
YAML_SCALARS = st.one_of(
    st.none(), st.booleans(), st.integers(), FLOATS, st.text(max_size=8), st.sampled_from(ODD_VALUES)
)
YAML_VALUES = st.recursive(
    YAML_SCALARS,
    lambda inner: st.one_of(st.lists(inner, max_size=3), st.dictionaries(st.text(max_size=6), inner, max_size=3)),
    max_leaves=6,
)
# values that keep a recorded scenario short: numbers of a few seconds at most
SMALL_VALUES = st.one_of(
    st.none(), st.booleans(), st.integers(-3, 3), st.floats(-2.0, 2.0), st.sampled_from([*ODD_VALUES, math.nan])
)
BAD_YAML = [": :", "[", "{a: ", "- - -", "!!python/object:os.system", "*undefined", "&a", "'", "key: @", "\t"]
TEXT_OPS = ["drop-line", "indent", "garbage", "truncate", "tabs", "binary", "bom", "anchors", "empty"]
TREE_OPS = ["value", "value", "delete", "rename", "wrap", "duplicate"]
RENAMES = ["insert", "drop-char", "upper", "suffix", "number", "empty"]


def yaml_mutation(values: Any = YAML_VALUES) -> Any:
    """Mutated YAML: either its text (syntax, indentation, encoding, anchors) or its tree (keys, types,
    values drawn from ``values``)."""
    text_op = st.fixed_dictionaries(
        {
            "op": st.sampled_from(TEXT_OPS),
            "line": INDEX,
            "at": AT,
            "bad": st.sampled_from(BAD_YAML),
            "junk": st.binary(max_size=64).map(bytes.hex),
            "k": st.integers(1, 4),
        }
    )
    tree_op = st.fixed_dictionaries(
        {"op": st.sampled_from(TREE_OPS), "path": INDEX, "value": values, "rename": st.sampled_from(RENAMES)}
    )
    return st.one_of(
        st.fixed_dictionaries({"text": text_op}),
        st.fixed_dictionaries({"tree": st.lists(tree_op, min_size=1, max_size=3)}),
    )


ROSBAG_OPS = ["metadata", "metadata", "missing-storage", "corrupt-storage", "no-metadata", "empty-dir"]


@st.composite
def rosbag2(draw: Any, seeds: Seeds) -> dict[str, Any]:
    """rosbag2 folders with a mutated or missing ``metadata.yaml``, a missing or corrupt storage file."""
    op = draw(st.sampled_from(ROSBAG_OPS))
    r: dict[str, Any] = {"bag": draw(st.sampled_from(sorted(seeds.bags))), "op": op}
    if op == "metadata":
        r["yaml"] = draw(yaml_mutation())
    elif op in ("missing-storage", "corrupt-storage"):
        r["file"] = draw(INDEX)
        r["form"] = draw(st.sampled_from(["bitflip", "truncate", "page-zero", "header"]))
        r["flips"] = draw(st.lists(st.tuples(AT, st.integers(0, 7)), min_size=1, max_size=16))
        r["at"] = draw(st.one_of(st.sampled_from([0, 100, 4096, 8192, 16384]), AT))
        r["open_file"] = draw(st.booleans())  # open the storage file itself, not the folder
    r["call"] = draw(st.sampled_from(["read", "read", "read-recover", "check", "cli-info"]))
    return r


OVERRIDE_KEYS = ["", "a", "occupancy.grid.resolution", "pose_source", "lidar_mapper", "goals", "robot_radius"]
OVERRIDE_VALUES = ["", "0", "-1", "nan", "x", "[1", "{}", "off", "1e400"]


@st.composite
def config(draw: Any, seeds: Seeds, kind: str) -> dict[str, Any]:
    """A shipped config file of one kind (Nav2 parameters, world, robot, scenario, pipeline, CI suite),
    mutated, loaded by its own loader (Nav2 files also through ``navlog check-config``)."""
    src = draw(st.sampled_from([str(p) for p in seeds.configs[kind]]))
    r: dict[str, Any] = {"config": kind, "file": src, "yaml": draw(yaml_mutation())}
    if kind == "pipelines":
        pairs = st.tuples(st.sampled_from(OVERRIDE_KEYS), st.one_of(st.sampled_from(OVERRIDE_VALUES), ARGV_TEXT))
        r["overrides"] = [f"{k}={v}" for k, v in draw(st.lists(pairs, max_size=2))]
    r["cli"] = kind == "nav2" and draw(st.integers(0, 9)) in (3, 5, 7)
    return r


CLI_VALUES = ["", "x", "-1", "0", "nan", "inf", "1e400", "/scan", "/scan=/odom", "a=b", "1,2", "1,2,3", "-1,0,0"]
CLI_PATHS = ["LOG", "MAP", "PGM", "NAV2", "missing.mcap", "missing.yaml", "EMPTY", "DIR", "TEXT"]
CLI_COMMANDS = ["info", "check", "check-config", "recover", "world-map", "plan", "diff"]


def cli_value(paths: bool = True) -> Any:
    values = st.one_of(st.sampled_from(CLI_VALUES), ARGV_TEXT)
    return st.one_of(st.sampled_from(CLI_PATHS), values) if paths else values


def choice(*options: list[str]) -> Any:
    """One flag (with its value) out of the given argv fragments."""
    return st.sampled_from(list(options))


def flag(name: str, values: Any) -> Any:
    return values.map(lambda v: [name, v])


CLI_FLAGS: dict[str, Any] = {
    "info": choice(["--json"], ["--recover"], []),
    "check": st.one_of(
        flag("--pipeline", st.sampled_from(["mapping", "planner", "safety", "nope", ""])),
        flag("--require", cli_value(False)),
        flag("--frames", st.sampled_from(["map:base_link", "odom:base_footprint", "a:b", ":", "x"])),
        flag("--rate", st.sampled_from(["/scan=10", "/scan=0", "/scan=-1", "/scan=nan", "/imu/data=x", "=", "/x=1"])),
        flag("--rate-tolerance", cli_value(False)),
        flag("--gap-factor", cli_value(False)),
        flag("--max-gap", cli_value(False)),
        st.just(["--json"]),
    ),
    "check-config": choice(["--notes"], []),
    "recover": choice(["--force"], []),
    "world-map": st.one_of(
        flag("--margin", cli_value(False)),
        flag("--resolution", st.sampled_from(["0.05", "0", "-1", "nan", "1e-9", "100", "x"])),
        flag("--z-min", cli_value(False)),
        flag("--z-max", cli_value(False)),
        flag("--height", cli_value(False)),
        st.just(["--force"]),
    ),
    "plan": st.one_of(
        flag("--params", cli_value()),
        flag("--planner", st.sampled_from(["navfn", "smac2d", "x"])),
        flag("--potential", st.sampled_from(["wavefront", "exact"])),
        flag("--set", st.sampled_from(["robot_radius=0.3", "tolerance=-1", "x=1", "=", "inflation_radius=nan"])),
    ),
    "diff": st.one_of(
        flag("--tol", cli_value(False)), flag("--ignore", cli_value(False)), st.just(["--json", "out.json"])
    ),
}
STRAY_FLAGS = ["--nope", "-o", "--json=1", "--"]


@st.composite
def cli(draw: Any, seeds: Seeds) -> dict[str, Any]:
    """Argument vectors of the reading commands (info, check, check-config, recover, world-map, plan, diff)."""
    command = draw(st.sampled_from(CLI_COMMANDS))
    argv: list[str] = [command]
    if command in ("info", "check", "check-config", "recover"):
        inputs = ["NAV2", "NAV2", "LOG"] if command == "check-config" else ["LOG", "LOG", "NAV2"]
        argv.append(draw(st.one_of(st.sampled_from(inputs), cli_value())))
        if command == "recover":
            argv += ["-o", draw(st.sampled_from(["out.mcap", "LOG", "DIR", "", "CUT"]))]
    elif command == "world-map":
        world = draw(st.sampled_from(["indoor_room", "walled_room", "nope", "TEXT", "NAV2"]))
        argv += [world, "-o", draw(st.sampled_from(["m.yaml", "DIR"]))]
    elif command == "plan":
        argv += ["--map", draw(st.sampled_from(["MAP", "MAP", "PGM", "NAV2", "missing.yaml", "EMPTY"]))]
        argv.append("--start=" + draw(st.sampled_from(["0,0,0", "-1,-1,0", "1,2", "a,b,c", "100,100,0", "nan,0,0"])))
        argv.append("--goal=" + draw(st.sampled_from(["1.2,-1,1.571", "-1,1,0", "0,0", "2,1.5,0", "inf,0,0"])))
    else:
        argv += [
            draw(st.sampled_from(["LOG", "LOG", "DIR", "EMPTY", "CUT"])),
            draw(st.sampled_from(["LOG", "CUT", "TEXT"])),
        ]
    for extra in draw(st.lists(CLI_FLAGS[command], max_size=3)):
        argv += extra
    return {"argv": with_stray_flag(draw, argv)}


def with_stray_flag(draw: Any, argv: list[str]) -> list[str]:
    """Now and then an unknown or half-given flag somewhere: argparse's own exit 2."""
    if draw(st.integers(0, 9)) == 7:  # (hypothesis favours 0 and the bounds)
        at = draw(st.integers(1, len(argv)))
        argv = [*argv[:at], draw(st.sampled_from(STRAY_FLAGS)), *argv[at:]]
    return argv


RECORD_FLAGS = st.one_of(
    flag("--world", st.sampled_from(["indoor_room", "walled_room", "nope", "TEXT", "EMPTY", "NAV2", ""])),
    flag("--robot", st.sampled_from(["go2", "kibot", "simple_robot", "nope", "TEXT", "MAP"])),
    flag("--seed", st.one_of(st.sampled_from(["0", "-1", "x", "1e400", "2", str(2**70)]), ARGV_TEXT)),
    flag("--pipeline", st.sampled_from(["mapping", "safety", "planner", "nope"])),
    flag("--params", st.sampled_from(["NAV2", "TEXT", "EMPTY", "PGM", "missing.yaml"])),
    flag("--set", st.sampled_from(["lidar_mapper=off", "pose_source=odom", "x=1", "=", "occupancy.grid.resolution=0"])),
    st.just(["--no-noise"]),
    st.just(["--force"]),
)


@st.composite
def cli_record(draw: Any, seeds: Seeds) -> dict[str, Any]:
    """Short ``navlog record`` runs (the 0.5 s tiny scenario, or a mutated copy with short numbers) with
    drawn worlds, robots, seeds, live pipelines and outputs."""
    scenario = draw(st.sampled_from(["TINY", "TINY", "SCENARIO", "nope", "TEXT", "EMPTY", "DIR"]))
    out = draw(st.sampled_from(["out.mcap", "out.mcap", "LOG", "DIR", "sub/missing/out.mcap", "EMPTY"]))
    argv = ["record", "--scenario", scenario, "-o", out]
    for extra in draw(st.lists(RECORD_FLAGS, max_size=3)):
        argv += extra
    r: dict[str, Any] = {"argv": with_stray_flag(draw, argv)}
    if scenario == "SCENARIO":
        r["yaml"] = draw(yaml_mutation(SMALL_VALUES))
    return r


REMAPS = ["/scan=/odom", "/scann=/scan", "/tf=/tf_missing", "/cmd_vel_nav=/cmd_vel", "/odom=/odom/ground_truth"]
REMAPS += ["/livox/lidar=/scan", "/scan=/livox/lidar", "=", "/scan", "/map=/scan", "/goal_pose=/odom"]
REPLAY_SETS = ["lidar_mapper=off", "pose_source=odom", "pose_source=x", "occupancy.grid.resolution=0.1"]
REPLAY_SETS += ["occupancy.grid.resolution=0", "occupancy.grid.resolution=nan", "goals=indoor_room_waypoints"]
REPLAY_SETS += ["map=MAP", "map=PGM", "x=1", "="]
REPLAY_FLAGS = st.one_of(
    flag("--set", st.one_of(st.sampled_from(REPLAY_SETS), ARGV_TEXT)),
    flag("--remap", st.one_of(st.sampled_from(REMAPS), ARGV_TEXT)),
    flag("--params", st.sampled_from(["NAV2", "TEXT", "EMPTY", "PGM", "MAP", "missing.yaml"])),
    st.just(["--recover"]),
    st.just(["--force"]),
)


@st.composite
def cli_replay(draw: Any, seeds: Seeds) -> dict[str, Any]:
    """Short ``navlog replay`` runs of the seed log (whole or cut), a rosbag2 folder or no log at all,
    through every pipeline, with drawn remaps, parameter overrides, parameter files and outputs."""
    log = draw(st.sampled_from(["LOG", "LOG", "LOG", "CUT", "BAG", "DIR", "EMPTY", "missing.mcap", "TEXT", "PGM"]))
    pipeline = draw(st.sampled_from(["mapping", "mapping", "safety", "planner", "nope", ""]))
    out = draw(st.sampled_from(["out", "out", "DIR", "LOG", "EMPTY", "sub/out"]))
    argv = ["replay", log, "--pipeline", pipeline, "-o", out]
    for extra in draw(st.lists(REPLAY_FLAGS, max_size=3)):
        argv += extra
    return {"argv": with_stray_flag(draw, argv)}


# ------------------------------------------------------- extreme parameters and special outputs

# Nav2 keys bounded by navlog.replay.limits: (node path in the seed Nav2 file, key)
EXTREME_NAV2_KEYS = [
    (("controller_server",), "controller_frequency"),
    (("planner_server",), "expected_planner_frequency"),
    (("local_costmap", "local_costmap"), "update_frequency"),
    (("local_costmap", "local_costmap"), "publish_frequency"),
    (("local_costmap", "local_costmap"), "resolution"),
    (("local_costmap", "local_costmap"), "width"),
    (("global_costmap", "global_costmap"), "resolution"),
    (("amcl",), "max_particles"),
    (("velocity_smoother",), "smoothing_frequency"),
    (("behavior_server",), "cycle_frequency"),
]
EXTREME_VALUES = [0, -1, 1e-12, 1e-3, 0.05, 1000.0, 1000.0001, 1e12, 2**63, float("inf"), float("nan"), 10**8]
EXTREME_SETS = [
    "occupancy.publish_period",
    "slam.map_update_interval",
    "occupancy.grid.resolution",
    "lidar.voxel_size",
]


@st.composite
def params_extreme(draw: Any, seeds: Seeds) -> dict[str, Any]:
    """One bounded parameter at an extreme (0, negative, tiny, at and just past a bound, huge, inf, NaN):
    in a Nav2 file through check-config, or set on a short mapping replay of the seed log."""
    value = draw(st.sampled_from(EXTREME_VALUES))
    if draw(st.booleans()):
        node, key = draw(st.sampled_from(EXTREME_NAV2_KEYS))
        return {"target": "nav2", "node": list(node), "key": key, "value": value}
    return {"target": "replay", "key": draw(st.sampled_from(EXTREME_SETS)), "value": value}


def build_params_extreme(r: dict[str, Any], seeds: Seeds) -> Built:
    if r["target"] == "replay":
        argv = ["replay", "LOG", "--pipeline", "mapping", "-o", "out", "--set", f"{r['key']}={r['value']!r}"]
        return Built(
            f"replay:{r['key']}={r['value']!r}",
            "cli",
            {"argv": argv},
            {},
            {"LOG.mcap": str(seeds.folder / "seed_zstd.mcap")},
        )
    src = seeds.configs["nav2"][0]
    doc = yaml.safe_load(src.read_text())
    section = doc
    for name in r["node"]:
        section = section.setdefault(name, {})
    section.setdefault("ros__parameters", {})[r["key"]] = r["value"]
    data = yaml.safe_dump(doc, sort_keys=False).encode()
    return Built(
        f"{src.name}:{'.'.join(r['node'])}.{r['key']}={r['value']!r}",
        "cli-check-config",
        {"path": src.name},
        {src.name: data},
    )


SPECIAL_OUTPUTS = ["fifo", "socket", "symlink", "in-a-file"]
OUTPUT_COMMANDS = {
    "plan": ["plan", "--map", "MAP", "--start=0,0,0", "--goal=0.5,0,0", "--png", "OUT"],
    "diff-json": ["diff", "LOG", "LOG", "--json", "OUT"],
    "diff-markdown": ["diff", "LOG", "LOG", "--markdown", "OUT"],
    "export-tum": ["export", "LOG", "--to", "tum", "--topic", "/odom", "-o", "OUT"],
    "world-map": ["world-map", "indoor_room", "-o", "OUT"],
    "record": ["record", "--scenario", "TINY", "-o", "OUT"],
    "replay": ["replay", "LOG", "--pipeline", "mapping", "-o", "OUT"],
    "metrics": ["metrics", "LOG", "-o", "OUT"],
}


@st.composite
def outputs_special(draw: Any, seeds: Seeds) -> dict[str, Any]:
    """A command whose output path is a FIFO, a socket, a symlink to a file outside the output, or a path
    under a file; with or without --force."""
    return {
        "command": draw(st.sampled_from(sorted(OUTPUT_COMMANDS))),
        "special": draw(st.sampled_from(SPECIAL_OUTPUTS)),
        "force": draw(st.booleans()),
    }


def build_outputs_special(r: dict[str, Any], seeds: Seeds) -> Built:
    out = "EMPTY/out" if r["special"] == "in-a-file" else "OUT"
    argv = [out if a == "OUT" else a for a in OUTPUT_COMMANDS[r["command"]]] + (["--force"] if r["force"] else [])
    files = {"EMPTY": b"", "TINY.yaml": TINY_SCENARIO.encode(), "precious.txt": b"keep\n"}
    args = {"argv": argv, "special": r["special"]}
    return Built(
        f"{r['command']}:{r['special']}", "cli-output", args, files, {"LOG.mcap": str(seeds.folder / "seed_zstd.mcap")}
    )


def run_special_output(a: dict[str, Any], folder: Path, seeds: Seeds) -> str:
    """Make the special file at OUT, run the command, and check that the node is still there (a FIFO is
    not replaced, a symlink's target not written through); an AssertionError counts as a traceback."""
    import socket
    import stat

    out = folder / "OUT"
    sock = None
    if a["special"] == "fifo":
        os.mkfifo(out)
    elif a["special"] == "socket":
        sock = socket.socket(socket.AF_UNIX)
        sock.bind(str(out))
    elif a["special"] == "symlink":
        out.symlink_to(folder / "precious.txt")
    before = os.lstat(out).st_mode if a["special"] != "in-a-file" else None
    try:
        outcome = run_cli(a["argv"], folder, seeds)
    finally:
        if sock is not None:
            sock.close()
    assert (folder / "precious.txt").read_bytes() == b"keep\n", "an output was written through a symlink"
    if a["special"] in ("fifo", "socket"):
        assert before is not None and stat.S_IFMT(os.lstat(out).st_mode) == stat.S_IFMT(before), "a node was replaced"
    return outcome


# Each kind below is one strategy (drawing its recipe) and one builder (applying it, further down), registered
# in ``MORE_KINDS`` and ``BUILDERS``; a new kind adds its pair there and its weight in ``KINDS``.

LOG_CALLS = ["read", "read", "read-recover", "check", "cli-info", "replay-mapping", "cli-view", "cli-export"]
LOG_TIME_FORMS = ["far-future-one", "far-past-one", "jump-run", "flip-in-file", "flip-in-file-fixed-crc"]


@st.composite
def mcap_times(draw: Any, seeds: Seeds) -> dict[str, Any]:
    """Log times far in the future or the past for one message, a jump for all after one, a log-time bit
    flipped in the file's bytes (its chunk's CRC left stale or recomputed, as a writer that saw it would)."""
    return {
        "form": draw(st.sampled_from(LOG_TIME_FORMS)),
        "message": draw(INDEX),
        "bit": draw(st.integers(30, 63)),
        "call": draw(st.sampled_from(LOG_CALLS)),
    }


CLAIM_FIELDS = [
    "chunk-uncompressed-size",
    "chunk-records-length",
    "index-chunk-length",
    "index-message-index-length",
    "index-compressed-size",
    "index-uncompressed-size",
    "record-length",
]
CLAIM_VALUES = [2**31, 2**31 + 1, 2**36, 2**40, 2**63 - 1, 2**64 - 1]


def _seed_chunk(draw: Any, seeds: Seeds) -> dict[str, Any]:
    """One of the seed logs (each compression) and one of its chunks."""
    log = draw(st.sampled_from(["seed_zstd", "seed_none", "seed_lz4"]))
    return {"log": log, "chunk": draw(st.integers(0, len(chunks_of(seeds.records[log])) - 1))}


@st.composite
def mcap_claims(draw: Any, seeds: Seeds) -> dict[str, Any]:
    """Sizes a chunk, its index entry or a record claim, set to gigabytes or more (or a drawn value)."""
    return {
        **_seed_chunk(draw, seeds),
        "field": draw(st.sampled_from(CLAIM_FIELDS)),
        "value": draw(st.one_of(st.sampled_from(CLAIM_VALUES), st.integers(0, 2**64 - 1))),
        "call": draw(st.sampled_from(["read", "read-recover", "check", "cli-info", "recover", "replay-mapping"])),
    }


@st.composite
def mcap_crc(draw: Any, seeds: Seeds) -> dict[str, Any]:
    """A chunk's CRC flipped, or a bit of its records flipped with the CRC left as written."""
    return {
        **_seed_chunk(draw, seeds),
        "where": draw(st.sampled_from(["crc", "records"])),
        "flips": draw(st.lists(st.tuples(AT, st.integers(0, 7)), min_size=1, max_size=4)),
        "call": draw(st.sampled_from(LOG_CALLS + ["recover"])),
    }


@st.composite
def mcap_compressed(draw: Any, seeds: Seeds) -> dict[str, Any]:
    """Bit flips inside the compressed bytes of zstd and lz4 chunks: the frame header (sizes, flags) or
    anywhere in the frame."""
    log = draw(st.sampled_from(["seed_zstd", "seed_zstd", "seed_lz4"]))
    return {
        "log": log,
        "chunk": draw(st.integers(0, len(chunks_of(seeds.records[log])) - 1)),
        "header": draw(st.booleans()),
        "flips": draw(st.lists(st.tuples(AT, st.integers(0, 7)), min_size=1, max_size=8)),
        "call": draw(st.sampled_from(LOG_CALLS)),
    }


SCHEMA_FORMS = ["self", "self-array", "through", "huge", "deep-chain", "many-sections"]


@st.composite
def schema_crafted(draw: Any, seeds: Seeds) -> dict[str, Any]:
    """A topic whose schema is crafted: a type that contains itself (directly or through a chain of
    others), a huge one (up to 300,000 fields), a deep chain of nested types, many sections."""
    _, channels, _ = seeds.parsed["seed_none"]
    return {
        "channel": draw(st.integers(0, len(channels) - 1)),
        "form": draw(st.sampled_from(SCHEMA_FORMS)),
        "size": draw(st.sampled_from([2, 10, 1000, 5000, 20000, 300_000])),
        "compression": draw(st.sampled_from(["zstd", "none"])),
        "call": draw(st.sampled_from(LOG_CALLS)),
    }


BOMB_FORMS = ["laughs", "deep-flow-list", "deep-flow-map", "deep-block", "self-alias", "wide-alias"]


@st.composite
def yaml_bomb(draw: Any, seeds: Seeds) -> dict[str, Any]:
    """YAML alias bombs (billion laughs) and deep nesting, in place of a config file of any kind."""
    kind = draw(st.sampled_from(["pipelines", "nav2", "scenarios", "worlds", "robots", "suites", "goals", "campaigns"]))
    return {
        "config": kind,
        "file": draw(st.sampled_from([str(p) for p in seeds.configs[kind]])),
        "form": draw(st.sampled_from(BOMB_FORMS)),
        "size": draw(st.sampled_from([9, 50, 101, 1000, 20000])),
        "cli": kind == "nav2" and draw(st.booleans()),
    }


@st.composite
def two_writers(draw: Any, seeds: Seeds) -> dict[str, Any]:
    """A second run writing an output another run holds (its lock taken in the worker first): the runs
    that hold their output (``atomic.hold_output``) must refuse."""
    return {"argv": draw(st.sampled_from(HOLDING_RUNS))}


HOLDING_RUNS = [
    ["replay", "LOG", "--pipeline", "mapping", "--set", "lidar_mapper=off", "-o", "out"],
    ["replay", "LOG", "--pipeline", "safety", "--remap", "/cmd_vel_nav=/cmd_vel", "-o", "out"],
    ["record", "--scenario", "TINY", "-o", "out.mcap"],
    ["export", "LOG", "--to", "rosbag2", "-o", "out"],
    ["view", "LOG", "--save", "out.rrd"],
    ["recover", "LOG", "-o", "out.mcap"],
]


ROBOT_SDF = """<?xml version="1.0"?>
<sdf version="1.9">
  <model name="boxy">
    <link name="base_link">
      <inertial><mass>4.0</mass><inertia><ixx>0.03</ixx><iyy>0.04</iyy><izz>0.05</izz></inertia></inertial>
      <collision name="body"><pose>0 0 0.07 0 0 0</pose><geometry><box><size>0.3 0.24 0.08</size></box></geometry></collision>
    </link>
    <link name="wheel_left">
      <pose>0 0.14 0.05 -1.5708 0 0</pose>
      <inertial><mass>0.3</mass><inertia><ixx>0.0002</ixx><iyy>0.0002</iyy><izz>0.0004</izz></inertia></inertial>
      <collision name="tyre"><geometry><cylinder><radius>0.05</radius><length>0.03</length></cylinder></geometry></collision>
    </link>
    <joint name="wheel_left_joint" type="revolute">
      <parent>base_link</parent><child>wheel_left</child><axis><xyz>0 0 1</xyz></axis>
    </joint>
    <link name="wheel_right">
      <pose>0 -0.14 0.05 -1.5708 0 0</pose>
      <inertial><mass>0.3</mass><inertia><ixx>0.0002</ixx><iyy>0.0002</iyy><izz>0.0004</izz></inertia></inertial>
      <collision name="tyre"><geometry><cylinder><radius>0.05</radius><length>0.03</length></cylinder></geometry></collision>
    </link>
    <joint name="wheel_right_joint" type="revolute">
      <parent>base_link</parent><child>wheel_right</child><axis><xyz>0 0 1</xyz></axis>
    </joint>
    <model name="head">
      <pose>0 0 0.2 0 0 0</pose>
      <link name="scanner">
        <sensor name="lidar" type="gpu_lidar">
          <update_rate>10</update_rate><topic>scan</topic>
          <lidar><scan><horizontal><samples>90</samples><min_angle>-1.5</min_angle><max_angle>1.5</max_angle>
          </horizontal></scan><range><min>0.1</min><max>8.0</max></range></lidar>
        </sensor>
      </link>
    </model>
    <joint name="head_joint" type="fixed"><parent>base_link</parent><child>head::scanner</child></joint>
    <plugin filename="gz-sim-diff-drive-system" name="gz::sim::systems::DiffDrive">
      <left_joint>wheel_left_joint</left_joint><right_joint>wheel_right_joint</right_joint>
      <wheel_separation>0.28</wheel_separation><wheel_radius>0.05</wheel_radius>
    </plugin>
  </model>
</sdf>
"""
ROBOT_XACRO = """<?xml version="1.0"?>
<robot name="xwheely" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:arg name="prefix" default=""/>
  <xacro:property name="radius" value="0.05"/>
  <xacro:property name="track" value="0.28"/>
  <link name="base_link">
    <inertial><mass value="4.0"/><inertia ixx="0.03" iyy="0.04" izz="0.05" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0 0 0.07"/><geometry><box size="0.3 0.24 0.08"/></geometry></collision>
  </link>
  <xacro:macro name="wheel" params="side y">
    <link name="wheel_${side}">
      <inertial><mass value="0.3"/><inertia ixx="0.0002" iyy="0.0002" izz="0.0004" ixy="0" ixz="0" iyz="0"/></inertial>
      <collision><origin rpy="${pi/2} 0 0"/><geometry><cylinder radius="${radius}" length="0.03"/></geometry></collision>
    </link>
    <joint name="wheel_${side}_joint" type="continuous">
      <parent link="base_link"/><child link="wheel_${side}"/><origin xyz="0 ${y} ${radius}"/><axis xyz="0 1 0"/>
    </joint>
  </xacro:macro>
  <xacro:wheel side="left" y="${track/2}"/>
  <xacro:wheel side="right" y="${-track/2}"/>
  <gazebo>
    <plugin filename="libgazebo_ros_diff_drive.so" name="diff_drive">
      <left_joint>wheel_left_joint</left_joint><right_joint>wheel_right_joint</right_joint>
      <wheel_separation>${track}</wheel_separation><wheel_diameter>${2*radius}</wheel_diameter>
    </plugin>
  </gazebo>
</robot>
"""
XML_VALUES = ["nan", "inf", "-inf", "-1", "0", "1e308", "-1e308", "5e-324", "", " ", "abc", "1 2", "0 0 0"]
XML_VALUES += ["1 2 3 4", "${undefined}", "${1/0}", "${10**400}", "package://nope/m.stl", "model://nope", "/dev/zero"]
XML_VALUES += ["../../../../etc/passwd", "base_link", "wheel_left", "head::scanner", "fixed", "floating", "ball"]
XML_TAGS = ["link", "joint", "parent", "child", "origin", "inertial", "inertia", "mass", "collision", "geometry"]
XML_TAGS += ["mesh", "box", "cylinder", "sphere", "plugin", "sensor", "model", "include", "pose", "axis", "uri"]
XML_OPS = ["attribute", "attribute", "text", "text", "delete", "duplicate", "move", "retag", "truncate", "junk"]


@st.composite
def description(draw: Any, seeds: Seeds) -> dict[str, Any]:
    """A description file (a small URDF, SDF or xacro robot, Nav2's TurtleBot3 Waffle URDF, a small Gazebo
    world with nested models, a frame and an include, one of polyline walls) with its XML mutated: an attribute or a text set
    to a drawn value, an element deleted, duplicated, moved under another or renamed, the file cut or junk
    put in; read (``describe``, ``load_world``) or recorded in for 0.5 s."""
    op = st.fixed_dictionaries(
        {
            "op": st.sampled_from(XML_OPS),
            "element": INDEX,
            "other": INDEX,
            "attribute": INDEX,
            "value": st.one_of(st.sampled_from(XML_VALUES), ARGV_TEXT),
            "tag": st.sampled_from(XML_TAGS),
            "at": AT,
            "junk": st.binary(max_size=32).map(bytes.hex),
        }
    )
    return {
        "seed": draw(st.sampled_from(sorted(seeds.descriptions))),
        "ops": draw(st.lists(op, min_size=1, max_size=3)),
        "call": draw(st.sampled_from(["describe", "describe", "record"])),
    }


PGM_HEADERS = ["60000 60000", "11000 11000", "0 0", "1 0", "-5 10", "abc", "100000000 1", "3 3\n0", "3 3\n65535"]
MAP_CALLS = ["load", "load", "cli-record", "cli-plan", "cli-world-map"]


@st.composite
def map_image(draw: Any, seeds: Seeds) -> dict[str, Any]:
    """A map_server map (the seed's YAML and PGM): its YAML mutated, or its image's header given another size
    or maximum, cut, or its bits flipped; loaded, recorded in (``--world map.yaml``), planned on, or read by
    ``world-map``."""
    r: dict[str, Any] = {
        "part": draw(st.sampled_from(["yaml", "header", "cut", "flip"])),
        "call": draw(st.sampled_from(MAP_CALLS)),
    }
    if r["part"] == "yaml":
        r["yaml"] = draw(yaml_mutation())
    elif r["part"] == "header":
        r["header"] = draw(st.one_of(st.sampled_from(PGM_HEADERS), ARGV_TEXT))
    else:
        r["at"] = draw(AT)
        r["flips"] = draw(st.lists(st.tuples(AT, st.integers(0, 7)), min_size=1, max_size=8))
    return r


REPLAY_FILES = ["pose_graph.json", "pose_graph.json", "trajectory.tum", "map.yaml", "replay.mcap"]


@st.composite
def replay_folder(draw: Any, seeds: Seeds) -> dict[str, Any]:
    """A SLAM replay's output folder beside its log, one file mutated: pose_graph.json's JSON (its text, or its
    tree: keys, types, values), trajectory.tum's or map.yaml's text, or replay.mcap cut or its bits flipped;
    drawn by ``view LOG --replay``."""
    name = draw(st.sampled_from(REPLAY_FILES))
    r: dict[str, Any] = {"file": name}
    if name == "replay.mcap":
        r["at"] = draw(AT)
        r["flips"] = draw(st.lists(st.tuples(AT, st.integers(0, 7)), max_size=8))
    else:
        r["mutation"] = draw(yaml_mutation())
    return r


MORE_KINDS: dict[str, Callable[[Seeds], Any]] = {
    "mcap-times": mcap_times,
    "mcap-claims": mcap_claims,
    "mcap-crc": mcap_crc,
    "mcap-compressed": mcap_compressed,
    "schema-crafted": schema_crafted,
    "yaml-bomb": yaml_bomb,
    "two-writers": two_writers,
    "params-extreme": params_extreme,
    "outputs-special": outputs_special,
    "description": description,
    "map": map_image,
    "replay-folder": replay_folder,
}


def kind_strategy(kind: str, seeds: Seeds) -> Any:
    if kind.startswith("config-"):
        return config(seeds, kind.removeprefix("config-"))
    makers: dict[str, Callable[[Seeds], Any]] = {
        **MORE_KINDS,
        "mcap-bytes": mcap_bytes,
        "mcap-chunk": mcap_chunk,
        "mcap-semantic": mcap_semantic,
        "mcap-message": mcap_message,
        "rosbag2": rosbag2,
        "cli": cli,
        "cli-record": cli_record,
        "cli-replay": cli_replay,
    }
    return makers[kind](seeds)


def case_strategy(seeds: Seeds) -> Any:
    """A recipe of any kind, kinds drawn by their weight in ``KINDS``."""
    table = [kind for kind, weight in KINDS.items() for _ in range(weight)]
    by_kind = {kind: kind_strategy(kind, seeds) for kind in KINDS}
    return st.sampled_from(table).flatmap(lambda kind: by_kind[kind].map(lambda r: {"kind": kind, **r}))


BLOCK = 100  # cases per hypothesis run: case I is example I % BLOCK of run I // BLOCK


def generate(seed: int, count: int, seeds: Seeds, on_case: Callable[[Case], None], *, start: int = 0) -> int:
    """Draw cases ``start .. start+count-1`` of ``seed`` with hypothesis and hand each to ``on_case`` as it is
    drawn; returns the number of cases drawn.

    Hypothesis adapts its search to the number of examples asked for, so the cases come in blocks of
    ``BLOCK``, each one hypothesis run seeded with ``(seed, block)``: case ``I`` depends only on ``seed`` and
    ``I`` (and the hypothesis version), not on how many cases a run asks for.
    """
    strategy = case_strategy(seeds)
    drawn = 0
    for block in range(start // BLOCK, (start + count - 1) // BLOCK + 1 if count > 0 else 0):
        for position, recipe in enumerate(draw_block(strategy, seed * 1_000_003 + block)):
            index = block * BLOCK + position
            if start <= index < start + count:
                on_case(Case(index, recipe["kind"], recipe))
                drawn += 1
    return drawn


@contextlib.contextmanager
def without_local_constants() -> Any:
    """Hypothesis mixes into its draws constants it finds in the source of the project's modules that the
    process has imported. The cases must not depend on which navlog modules a process happened to load (a
    campaign that recorded its seed log, a test run, ``--case``), so generation sees none."""
    from hypothesis.internal.conjecture import providers

    saved = providers._get_local_constants
    providers._get_local_constants = providers.Constants
    providers.CONSTANTS_CACHE.cache.clear()
    try:
        yield
    finally:
        providers._get_local_constants = saved
        providers.CONSTANTS_CACHE.cache.clear()


def draw_block(strategy: Any, block_seed: int) -> list[dict[str, Any]]:
    """The examples of one seeded hypothesis run of ``BLOCK`` examples, in the order drawn."""
    recipes: list[dict[str, Any]] = []

    @settings(
        max_examples=BLOCK,
        database=None,
        deadline=None,
        derandomize=False,
        phases=[Phase.generate],
        suppress_health_check=list(HealthCheck),
        verbosity=Verbosity.quiet,
    )
    @hypothesis_seed(block_seed)
    @given(strategy)
    def each(recipe: dict[str, Any]) -> None:
        recipes.append(recipe)

    with without_local_constants():
        each()
    return recipes


def case_at(seed: int, index: int, seeds: Seeds) -> Case:
    found: list[Case] = []
    generate(seed, 1, seeds, found.append, start=index)
    if not found:
        raise SystemExit(f"seed {seed} has fewer than {index + 1} cases")
    return found[0]


# ---------------------------------------------------------------------------------- applying recipes


def scaled(at: int, n: int) -> int:
    """A 32-bit fraction ``at`` of a length ``n``, as an index in ``range(n)`` (0 when ``n`` is 0)."""
    return (at * n) >> 32


def flip_bits(data: bytes, flips: list[Any], lo: int = 0) -> bytes:
    if len(data) <= lo:
        return data
    buf = bytearray(data)
    for at, bit in flips:
        buf[lo + scaled(at, len(buf) - lo)] ^= 1 << bit
    return bytes(buf)


def mutate_bytes(r: dict[str, Any], data: bytes, records: list[tuple[int, int, int]]) -> tuple[str, bytes]:
    """One structural or random mutation of an MCAP file's bytes."""
    op, n = r["op"], len(data)
    if op == "bitflip":
        return op, flip_bits(data, r["flips"])
    if op == "bitflip@summary":
        return op, flip_bits(data, r["flips"], lo=int(n * 0.9))
    if op == "truncate@random":
        return op, data[: scaled(r["at"], n)]
    if op in ("zero-run", "duplicate-bytes", "drop-bytes"):
        i, k = scaled(r["at"], n), r["size"]
        changed = {
            "zero-run": data[:i] + bytes(min(k, n - i)) + data[i + k :],
            "duplicate-bytes": data[:i] + data[i : i + k] + data[i:],
            "drop-bytes": data[:i] + data[i + k :],
        }[op]
        return op, changed
    if op == "chunk-field":
        off, code, length = chunks_of(records)[r["chunk"]]
        at, fmt = CHUNK_FIELDS[r["field"]]
        body = off + 9
        (old,) = struct.unpack_from(fmt, data, body + at)
        top = 2 ** (8 * struct.calcsize(fmt)) - 1
        value = old + r["delta"] if r["delta"] is not None else r["value"]
        new = struct.pack(fmt, min(max(0, value), top))
        return f"chunk-{r['field']}", data[: body + at] + new + data[body + at + len(new) :]
    off, code, length = records[r["record"]]
    end = off + 9 + length
    if op == "truncate@record":
        cut = {
            "start": 0,
            "opcode": 1,
            "length": 9,
            "half": 9 + length // 2,
            "end-1": 9 + length - 1,
            "end": 9 + length,
        }
        return f"truncate@record{code:#04x}", data[: min(off + cut[r["cut"]], n)]
    if op == "length":
        value = r["value"]
        if isinstance(value, str):
            value = length + int(value)
        return f"length{code:#04x}", data[: off + 1] + struct.pack("<Q", min(max(0, value), 2**64 - 1)) + data[
            off + 9 :
        ]
    if op == "duplicate-record":
        return f"{op}{code:#04x}", data[:end] + data[off:end] + data[end:]
    if op == "drop-record":
        return f"{op}{code:#04x}", data[:off] + data[end:]
    off2, _, length2 = records[r["other"]]
    a, b = sorted([(off, end), (off2, off2 + 9 + length2)])
    if a[1] > b[0]:
        return "swap-records(same)", data
    return "swap-records", data[: a[0]] + data[b[0] : b[1]] + data[a[1] : b[0]] + data[a[0] : a[1]] + data[b[1] :]


def record_bytes(opcode: int, body: bytes) -> bytes:
    return bytes([opcode]) + struct.pack("<Q", len(body)) + body


def mutate_chunk(r: dict[str, Any], data: bytes, records: list[tuple[int, int, int]]) -> tuple[str, bytes]:
    """Reorder, duplicate or drop the records inside one chunk, recompress it and splice it back."""
    import lz4.frame
    import zstandard

    off, _, length = chunks_of(records)[r["chunk"]]
    body = data[off + 9 : off + 9 + length]
    start, end, _, crc = struct.unpack_from("<QQQI", body, 0)
    (clen,) = struct.unpack_from("<I", body, 28)
    compression = body[32 : 32 + clen].decode()
    (rlen,) = struct.unpack_from("<Q", body, 32 + clen)
    packed = body[40 + clen : 40 + clen + rlen]
    if compression == "zstd":
        plain = zstandard.ZstdDecompressor().decompressobj().decompress(packed)
    elif compression == "lz4":
        plain = lz4.frame.decompress(packed)
    else:
        plain = packed
    inner = [plain[o : o + 9 + n] for o, _, n in split_records(plain, 0)]
    op = r["op"]
    if inner:
        i, j = r["i"] % len(inner), r["j"] % len(inner)
        if op == "swap":
            inner[i], inner[j] = inner[j], inner[i]
        elif op == "reverse":
            inner.reverse()
        elif op == "shuffle":
            random.Random(r["order"]).shuffle(inner)
        elif op == "duplicate":
            inner.insert(j, inner[i])
        elif op == "drop":
            del inner[i]
        elif op == "first":
            inner.insert(0, inner.pop(i))
        else:
            inner.append(inner.pop(i))
    plain = b"".join(inner)
    if compression == "zstd":
        packed = zstandard.ZstdCompressor().compress(plain)
    elif compression == "lz4":
        packed = lz4.frame.compress(plain)
    else:
        packed = plain
    crc = {"fixed": zlib.crc32(plain), "stale": crc, "zero": 0}[r["crc"]]
    new_body = struct.pack("<QQQI", start, end, len(plain), crc) + body[28 : 32 + clen]
    chunk = record_bytes(0x06, new_body + struct.pack("<Q", len(packed)) + packed)
    mutated = data[:off] + chunk + data[off + 9 + length :]
    if r["summary"] == "none":  # cut at the data end: a file without summary, which readers must stream
        shift = len(chunk) - (9 + length)
        data_end = [o for o, code, _ in records if code == 0x0F]
        stop = data_end[0] + shift if data_end else len(mutated) - 8
        footer = record_bytes(0x02, struct.pack("<QQI", 0, 0, 0))
        mutated = mutated[:stop] + record_bytes(0x0F, struct.pack("<I", 0)) + footer + MCAP_MAGIC
    return f"chunk-{op}-crc-{r['crc']}-summary-{r['summary']}", mutated


def mutate_schema_text(r: dict[str, Any], text: str) -> str:
    lines = text.splitlines()
    form = r["form"]
    if form == "empty" or not lines:
        return ""
    i = r["line"] % len(lines)
    if form == "drop-line":
        del lines[i]
    elif form == "swap-type":
        words = lines[i].split(" ", 1)
        lines[i] = r["token"] + (" " + words[1] if len(words) > 1 else "")
    elif form == "garbage":
        lines[i] = r["token"]
    elif form == "duplicate-line":
        lines.insert(i, lines[i])
    else:
        lines.insert(i, r["token"])
    return "\n".join(lines)


def inject_floats(data: bytes, floats: list[Any]) -> bytes:
    """Write NaN, +-inf or other floats at aligned offsets of a CDR payload (where floats live)."""
    buf = bytearray(data)
    for width, at, value in floats:
        slots = (len(buf) - 4) // width
        if slots <= 0:
            continue
        i = 4 + width * scaled(at, slots)
        if width == 4 and math.isfinite(value) and abs(value) > 3.4e38:
            value = math.copysign(math.inf, value)
        struct.pack_into("<d" if width == 8 else "<f", buf, i, value)
    return bytes(buf)


def mutate_cdr(r: dict[str, Any], data: bytes) -> bytes:
    form = r["form"]
    extra = bytes.fromhex(r["bytes"])
    if form == "truncate":
        return data[: scaled(r["at"], len(data))]
    if form == "extend":
        return data + extra
    if form == "random":
        return (extra * (len(data) // len(extra) + 1))[: len(data)]
    if form == "empty":
        return b""
    if form == "header":
        return bytes([0, extra[0], 0, 0]) + data[4:]
    return flip_bits(data, r["flips"])


def write_log(
    schemas: list[tuple[int, str, str, bytes]],
    channels: list[tuple[int, str, str, int, dict[str, str]]],
    messages: list[tuple[int, int, int, bytes]],
    *,
    compression: str = "zstd",
    profile: str = "ros2",
) -> bytes:
    """A new MCAP file: schemas (id, name, encoding, text), channels (id, topic, encoding, schema id,
    metadata) and messages (channel id, log time, publish time, data), in the order given."""
    from mcap.writer import CompressionType, Writer

    out = io.BytesIO()
    comp = CompressionType.ZSTD if compression == "zstd" else CompressionType.NONE
    writer = Writer(out, compression=comp, chunk_size=16 << 10)
    writer.start(profile=profile, library="fuzz")
    schema_ids = {sid: writer.register_schema(name, enc, text) for sid, name, enc, text in schemas}
    channel_ids = {
        cid: writer.register_channel(topic, enc, schema_ids.get(sid, sid), meta)
        for cid, topic, enc, sid, meta in channels
    }
    for seq, (cid, t, p, data) in enumerate(messages):
        writer.add_message(channel_ids[cid], min(t, 2**64 - 1), data, min(p, 2**64 - 1), seq % 2**32)
    writer.finish()
    return out.getvalue()


def parts_of(parsed: Any) -> tuple[list[Any], list[Any], list[Any]]:
    schemas, channels, messages = parsed
    return (
        [[s.id, s.name, s.encoding, s.data] for s in schemas],
        [[c.id, c.topic, c.message_encoding, c.schema_id, dict(c.metadata)] for c in channels],
        [[m.channel_id, m.log_time, m.publish_time, m.data] for m in messages],
    )


def picked(r: dict[str, Any], msgs: list[Any], cid: int) -> list[int]:
    """Indexes of the messages of channel ``cid`` the recipe changes (its first few, or all)."""
    on = [i for i, m in enumerate(msgs) if m[0] == cid]
    return on if r["first"] is None else on[: r["first"]]


def rewrite_log(r: dict[str, Any], parsed: Any) -> tuple[str, bytes]:
    """Re-encode the small log with a semantic mutation: schemas, encodings, CDR payloads, times, order."""
    schemas, channels, msgs = parts_of(parsed)
    op = r["op"]
    target = channels[r["channel"]]
    schema = next((s for s in schemas if s[0] == target[3]), None)
    if op == "schema-text" and schema is not None:
        schema[3] = mutate_schema_text(r, schema[3].decode("utf-8", "replace")).encode()
        op = f"schema-text-{r['form']}"
    elif op == "schema-name" and schema is not None:
        schema[1] = r["name"]
    elif op == "encoding":
        if r["on"] == "channel":
            target[2] = r["value"]
        elif schema is not None:
            schema[2] = r["value"]
    elif op == "cdr":
        for i in picked(r, msgs, target[0]):
            msgs[i][3] = mutate_cdr(r, msgs[i][3])
        op = f"cdr-{r['form']}"
    elif op == "nan-inf":
        for i in picked(r, msgs, target[0]):
            msgs[i][3] = inject_floats(msgs[i][3], r["floats"])
    elif op == "times":
        form = r["form"]
        times = [m[1] for m in msgs]
        for i, m in enumerate(msgs):
            m[1] = {
                "backwards": times[-1 - i],
                "zero": 0,
                "max": 2**64 - 1 if i % 7 == 0 else m[1],
                "future": m[1] + 10**18,
                "duplicate": times[0],
                "jump": m[1] + (10**15 if i > len(msgs) // 2 else 0),
            }[form]
        op = f"times-{form}"
    elif op == "order":
        random.Random(r["order"]).shuffle(msgs)
        msgs = msgs + msgs[: r["repeat"]]
    elif op == "no-messages":
        msgs = []
    elif op == "dangling":  # a channel whose schema does not exist
        target[3] = r["schema_id"]
    data = write_log(
        [tuple(s) for s in schemas],  # type: ignore[misc]
        [tuple(c) for c in channels],  # type: ignore[misc]
        [tuple(m) for m in msgs],  # type: ignore[misc]
        compression=r["compression"],
        profile=r["profile"],
    )
    return op, data


def leaves(obj: Any) -> list[tuple[Any, str, str]]:
    """(holder, attribute, kind) of every field of a decoded message, depth first in declaration order;
    kind is float, int, array, list or text. Sequences of messages are entered through their first item."""
    out: list[tuple[Any, str, str]] = []
    for f in dataclasses.fields(obj):
        value = getattr(obj, f.name)
        if dataclasses.is_dataclass(value):
            out += leaves(value)
        elif isinstance(value, np.ndarray):
            out.append((obj, f.name, "array"))
        elif isinstance(value, list):
            out.append((obj, f.name, "list"))
            if value and dataclasses.is_dataclass(value[0]):
                out += leaves(value[0])
        elif isinstance(value, bool):
            continue
        elif isinstance(value, float):
            out.append((obj, f.name, "float"))
        elif isinstance(value, int):
            out.append((obj, f.name, "int"))
        elif isinstance(value, str):
            out.append((obj, f.name, "text"))
    return out


def set_leaf(holder: Any, name: str, kind: str, m: dict[str, Any]) -> None:
    value = getattr(holder, name)
    if kind == "float":
        setattr(holder, name, float(m["float"]))
    elif kind == "int":
        setattr(holder, name, int(m["int"]))
    elif kind == "text":
        setattr(holder, name, m["text"])
    elif kind == "list":
        setattr(holder, name, [] if m["array"] in ("empty", "half") else value * 2)
    elif m["array"] == "empty":
        setattr(holder, name, value[:0])
    elif m["array"] == "half":
        setattr(holder, name, value[: len(value) // 2])
    elif m["array"] == "double":
        setattr(holder, name, np.concatenate([value, value]))
    elif value.dtype.kind == "f":
        setattr(holder, name, np.full_like(value, math.nan if m["array"] == "nan" else math.inf))
    else:
        setattr(holder, name, value[:0])


def set_leaf_checked(store: Any, msg: Any, typename: str, holder: Any, name: str, kind: str, m: dict[str, Any]) -> None:
    """``set_leaf``, or where the field's type cannot hold the new value (a fixed-size array resized, a
    number too large for its bytes) the nearest value it can: the array filled with NaN, the number cut."""
    before = getattr(holder, name)
    set_leaf(holder, name, kind, m)
    try:
        store.serialize_cdr(msg, typename)
        return
    except Exception:
        setattr(holder, name, before)
    if kind == "int":
        setattr(holder, name, int(m["int"]) & 0x7F)
    elif kind == "array" and before.dtype.kind == "f":
        setattr(holder, name, np.full_like(before, math.nan))


def set_stamp(msg: Any, form: str, i: int, n: int) -> None:
    header = getattr(msg, "header", None)
    stamp = getattr(header, "stamp", None)
    if stamp is None:
        return
    if form == "backwards":
        stamp.sec = max(0, stamp.sec - 2 * i)
    elif form == "future":
        stamp.sec = 2**31 - 1
    elif form == "past":
        stamp.sec, stamp.nanosec = 0, 1
    elif form == "zero":
        stamp.sec, stamp.nanosec = 0, 0
    elif form == "nanosec-overflow":
        stamp.nanosec = 2**32 - 1
    else:
        stamp.sec, stamp.nanosec = 100, 0


def mutate_messages(r: dict[str, Any], parsed: Any) -> tuple[str, bytes]:
    """Decode the chosen channel's messages, change their fields, encode them again (CDR of the schema)."""
    from navlog.replay.messages import typestore

    store = typestore()
    schemas, channels, msgs = parts_of(parsed)
    target = channels[r["channel"]]
    typename = next(s[1] for s in schemas if s[0] == target[3])
    chosen = picked(r, msgs, target[0])
    for n, i in enumerate(chosen):
        msg = store.deserialize_cdr(msgs[i][3], typename)
        if r["special"] == "zero-cloud" and hasattr(msg, "point_step"):
            msg.width, msg.row_step, msg.data = 0, 0, msg.data[:0]
        elif r["special"] and r["special"].startswith("stamp-"):
            set_stamp(msg, r["special"].removeprefix("stamp-"), n, len(chosen))
        found = leaves(msg)
        for m in r["leaves"]:
            if found:
                set_leaf_checked(store, msg, typename, *found[m["leaf"] % len(found)], m)
        msgs[i][3] = bytes(store.serialize_cdr(msg, typename))
    kinds = sorted({found_kind(msgs, chosen, store, typename, m) for m in r["leaves"]}) if chosen else []
    data = write_log(
        [tuple(s) for s in schemas],  # type: ignore[misc]
        [tuple(c) for c in channels],  # type: ignore[misc]
        [tuple(m) for m in msgs],  # type: ignore[misc]
    )
    return f"{target[1]}:{r['special'] or 'fields'}:{'+'.join(kinds)}", data


def found_kind(msgs: list[Any], chosen: list[int], store: Any, typename: str, m: dict[str, Any]) -> str:
    found = leaves(store.deserialize_cdr(msgs[chosen[0]][3], typename))
    return found[m["leaf"] % len(found)][2] if found else "none"


def tree_paths(node: Any, prefix: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    out = [prefix]
    if isinstance(node, dict):
        for k, v in node.items():
            out += tree_paths(v, (*prefix, k))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            out += tree_paths(v, (*prefix, i))
    return out


def mutate_tree(m: dict[str, Any], tree: Any) -> tuple[str, Any]:
    paths = [p for p in tree_paths(tree) if p]
    if not paths:
        return "replace-root", m["value"]
    path = paths[m["path"] % len(paths)]
    parent = tree
    for k in path[:-1]:
        parent = parent[k]
    key = path[-1]
    op = m["op"]
    if op == "value":
        parent[key] = m["value"]
    elif op == "delete":
        del parent[key]
    elif op == "rename" and isinstance(parent, dict):
        s = str(key)
        i = len(s) // 2
        new = {
            "insert": s[:i] + "x" + s[i:],
            "drop-char": s[:i] + s[i + 1 :],
            "upper": s.upper(),
            "suffix": s + "_",
            "number": 7,
            "empty": "",
        }[m["rename"]]
        parent[new] = parent.pop(key)
    elif op == "wrap":
        parent[key] = [parent[key]] if m["path"] % 2 else {"value": parent[key]}
    else:
        parent[key] = [parent[key], parent[key]] if not isinstance(parent[key], list) else parent[key][:1] * 3
    return f"tree-{op}", tree


def mutate_text(m: dict[str, Any], text: str) -> tuple[str, bytes]:
    lines = text.splitlines()
    op = m["op"]
    i = m["line"] % max(1, len(lines))
    if op == "drop-line" and lines:
        del lines[i]
    elif op == "indent" and lines:
        lines[i] = " " * m["k"] + lines[i]
    elif op == "garbage" and lines:
        j = scaled(m["at"], len(lines[i]) + 1)
        lines[i] = lines[i][:j] + m["bad"] + lines[i][j:]
    elif op == "truncate":
        return op, text.encode()[: scaled(m["at"], len(text) + 1)]
    elif op == "tabs":
        return op, text.replace("  ", "\t", m["k"]).encode()
    elif op == "binary":
        return op, bytes.fromhex(m["junk"]) + text.encode()
    elif op == "bom":
        return op, b"\xef\xbb\xbf" + text.encode("utf-16")[: len(text)]
    elif op == "anchors":
        return op, b"a: &a [*a]\nb: &b {x: *b}\n" + text.encode()
    elif op == "empty":
        return op, [b"", b"---\n", b"~\n", b"[]\n", b"42\n", b"- a\n- b\n"][m["k"] % 6]
    return f"text-{op}", "\n".join(lines).encode()


def mutate_yaml(r: dict[str, Any], text: str) -> tuple[str, bytes]:
    if "text" in r:
        return mutate_text(r["text"], text)
    tree = yaml.safe_load(text)
    ops = []
    for m in r["tree"]:
        op, tree = mutate_tree(m, tree)
        ops.append(op)
    return "+".join(ops), yaml.safe_dump(tree, sort_keys=False, allow_unicode=True).encode()


CONFIG_CALLS = {
    "worlds": "world",
    "robots": "robot",
    "scenarios": "scenario",
    "pipelines": "pipeline",
    "nav2": "nav2",
    "suites": "suite",
    "goals": "goals",
    "campaigns": "campaign",
}


def build_rosbag(r: dict[str, Any], seeds: Seeds) -> Built:
    src = seeds.bags[r["bag"]]
    storage = sorted(p.name for p in src.iterdir() if p.suffix in (".db3", ".mcap"))
    files: dict[str, bytes] = {}
    links = {f"bag/{p.name}": str(p) for p in src.iterdir()}
    op, target = r["op"], "bag"
    if op == "metadata":
        mutation, files["bag/metadata.yaml"] = mutate_yaml(r["yaml"], (src / "metadata.yaml").read_text())
        op = f"metadata-{mutation}"
    elif op in ("missing-storage", "corrupt-storage"):
        victim = storage[r["file"] % len(storage)]
        del links[f"bag/{victim}"]
        if op == "corrupt-storage":
            data = (src / victim).read_bytes()
            form = r["form"]
            if form == "bitflip":
                data = flip_bits(data, r["flips"])
            elif form == "truncate":
                data = data[: r["at"] if r["at"] <= 16384 else scaled(r["at"], len(data))]
            elif form == "page-zero":
                page = 4096 * scaled(r["at"], max(1, len(data) // 4096))
                data = data[:page] + bytes(4096) + data[page + 4096 :]
            else:
                data = flip_bits(data[:100], r["flips"]) + data[100:]
            files[f"bag/{victim}"] = data
            op = f"corrupt-storage-{form}"
            if r["open_file"]:
                target = f"bag/{victim}"
    elif op == "no-metadata":
        del links["bag/metadata.yaml"]
    else:
        links = {}
        files["bag/.keep"] = b""
    return Built(f"{r['bag']}:{op}", r["call"], {"log": target}, files, links)


def build_config(r: dict[str, Any], seeds: Seeds) -> Built:
    src = Path(r["file"])
    mutation, data = mutate_yaml(r["yaml"], src.read_text())
    args: dict[str, Any] = {"path": src.name, "name": src.stem, "overrides": r.get("overrides", [])}
    links = {}
    if r["config"] == "suites":  # the files a suite names beside it (parameter files)
        links = {p.name: str(p) for p in src.parent.glob("*.yaml") if p != src}
    call = "cli-check-config" if r["cli"] else CONFIG_CALLS[r["config"]]
    return Built(f"{src.name}:{mutation}", call, args, {src.name: data}, links)


def build_cli(r: dict[str, Any], seeds: Seeds, kind: str) -> Built:
    files = {"EMPTY": b"", "TEXT": b"not: [yaml\n", "DIR/.keep": b"", "TINY.yaml": TINY_SCENARIO.encode()}
    seed_log = seeds.folder / "seed_zstd.mcap"
    links = {"LOG.mcap": str(seed_log)}  # a copy: `recover -o LOG` may replace it
    files["CUT.mcap"] = seeds.logs["seed_zstd"][: len(seeds.logs["seed_zstd"]) * 3 // 5]
    if "BAG" in r["argv"]:
        links |= {f"BAG/{p.name}": str(p) for p in seeds.bags["rosbag2_talker_mcap"].iterdir()}
    mutation = r["argv"][0]
    if "yaml" in r:
        change, files["SCENARIO.yaml"] = mutate_yaml(r["yaml"], TINY_SCENARIO)
        mutation += f":scenario-{change}"
    return Built(mutation, "cli", {"argv": r["argv"]}, files, links)


def log_built(name: str, mutation: str, call: str, data: bytes) -> Built:
    return Built(f"{name}:{mutation}", call, {"log": "log.mcap"}, {"log.mcap": data})


def chunk_layout(data: bytes, off: int) -> dict[str, int]:
    """Offsets of a chunk record's fields (``off``: the record's opcode) and of its records' bytes."""
    body = off + 9
    (clen,) = struct.unpack_from("<I", data, body + 28)
    (rlen,) = struct.unpack_from("<Q", data, body + 32 + clen)
    return {
        "body": body,
        "size": body + 16,
        "crc": body + 24,
        "rlen": body + 32 + clen,
        "records": body + 40 + clen,
        "records_end": body + 40 + clen + rlen,
    }


def put(data: bytes, at: int, fmt: str, value: int) -> bytes:
    buf = bytearray(data)
    struct.pack_into(fmt, buf, at, value % 2 ** (8 * struct.calcsize(fmt)))
    return bytes(buf)


def build_times(r: dict[str, Any], seeds: Seeds) -> Built:
    schemas, channels, msgs = parts_of(seeds.parsed["seed_none"])
    i, jump, form = r["message"] % len(msgs), 1 << r["bit"], r["form"]
    if form.startswith("flip-in-file"):  # a Message record's log time in the uncompressed seed's bytes
        data = seeds.logs["seed_none"]
        m = msgs[i]
        at = data.find(struct.pack("<HIQQ", m[0], i % 2**32, m[1], m[2]))
        if at < 0:
            at = data.find(struct.pack("<QQ", m[1], m[2])) - 6
        buf = bytearray(put(data, at + 6, "<Q", m[1] ^ jump))
        if form.endswith("fixed-crc"):
            off = max(o for o, code, _ in seeds.records["seed_none"] if code == 0x06 and o < at)
            lay = chunk_layout(bytes(buf), off)
            struct.pack_into("<I", buf, lay["crc"], zlib.crc32(buf[lay["records"] : lay["records_end"]]))
        return log_built("seed_none", f"times-{form}", r["call"], bytes(buf))
    if form == "far-future-one":
        msgs[i][1] += jump
    elif form == "far-past-one":
        for m in msgs:
            m[1] += 1 << 45  # a month in: room for a time far before the rest
        msgs[i][1] -= min(msgs[i][1], jump)
    else:
        for m in msgs[i:]:
            m[1] += jump
    data = write_log([tuple(x) for x in schemas], [tuple(c) for c in channels], [tuple(m) for m in msgs])  # type: ignore[misc]
    return log_built("seed_none", f"times-{form}", r["call"], data)


def build_claims(r: dict[str, Any], seeds: Seeds) -> Built:
    data, records = seeds.logs[r["log"]], seeds.records[r["log"]]
    off, _, length = chunks_of(records)[r["chunk"]]
    field, value = r["field"], r["value"]
    if field.startswith("chunk-"):
        lay = chunk_layout(data, off)
        at = lay["size"] if field == "chunk-uncompressed-size" else lay["rlen"]
        return log_built(r["log"], f"claim-{field}", r["call"], put(data, at, "<Q", value))
    if field == "record-length":
        return log_built(r["log"], f"claim-{field}", r["call"], put(data, off + 1, "<Q", value))
    index = [o for o, code, _ in records if code == 0x08]  # chunk indexes, in the chunks' order
    if not index:
        return log_built(r["log"], "claim-no-index", r["call"], data)
    body = index[r["chunk"] % len(index)] + 9
    (map_len,) = struct.unpack_from("<I", data, body + 32)
    after_map = body + 36 + map_len
    (clen,) = struct.unpack_from("<I", data, after_map + 8)
    at = {
        "index-chunk-length": body + 24,
        "index-message-index-length": after_map,
        "index-compressed-size": after_map + 12 + clen,
        "index-uncompressed-size": after_map + 20 + clen,
    }[field]
    return log_built(r["log"], f"claim-{field}", r["call"], put(data, at, "<Q", value))


def build_crc(r: dict[str, Any], seeds: Seeds) -> Built:
    data = seeds.logs[r["log"]]
    off, _, _ = chunks_of(seeds.records[r["log"]])[r["chunk"]]
    lay = chunk_layout(data, off)
    lo, hi = (lay["crc"], lay["crc"] + 4) if r["where"] == "crc" else (lay["records"], lay["records_end"])
    part = flip_bits(data[lo:hi], r["flips"])
    return log_built(r["log"], f"crc-{r['where']}", r["call"], data[:lo] + part + data[hi:])


def build_compressed(r: dict[str, Any], seeds: Seeds) -> Built:
    data = seeds.logs[r["log"]]
    off, _, _ = chunks_of(seeds.records[r["log"]])[r["chunk"]]
    lay = chunk_layout(data, off)
    lo = lay["records"]
    hi = min(lo + 16, lay["records_end"]) if r["header"] else lay["records_end"]
    part = flip_bits(data[lo:hi], r["flips"])
    where = "header" if r["header"] else "frame"
    return log_built(r["log"], f"compressed-{where}", r["call"], data[:lo] + part + data[hi:])


def crafted_schema(form: str, n: int) -> str:
    sep = "=" * 80 + "\n"
    if form == "self":
        return "int32 a\nfuzz_msgs/Crafted child\n"
    if form == "self-array":
        return "int32 a\nfuzz_msgs/Crafted[] children\n"
    if form == "through":
        k = min(n, 200)
        return "fuzz_msgs/T0 next\n" + "".join(
            f"{sep}MSG: fuzz_msgs/T{j}\nint8 v\n{'fuzz_msgs/T' + str(j + 1) if j + 1 < k else 'fuzz_msgs/Crafted'} next\n"
            for j in range(k)
        )
    if form == "huge":
        return "\n".join(f"float64 f{j}" for j in range(n))
    if form == "deep-chain":
        k = min(n, 5000)
        return "fuzz_msgs/D0 next\n" + "".join(
            f"{sep}MSG: fuzz_msgs/D{j}\nint8 v\n" + (f"fuzz_msgs/D{j + 1} next\n" if j + 1 < k else "")
            for j in range(k)
        )
    return "".join(f"fuzz_msgs/S{j} s{j}\n" for j in range(min(n, 5000))) + "".join(
        f"{sep}MSG: fuzz_msgs/S{j}\nint8 v\n" for j in range(min(n, 5000))
    )


def build_schema(r: dict[str, Any], seeds: Seeds) -> Built:
    """The chosen channel's schema renamed (a type no store has, so it is parsed) and replaced."""
    schemas, channels, msgs = parts_of(seeds.parsed["seed_none"])
    target = channels[r["channel"]]
    sid = max(s[0] for s in schemas) + 1
    schemas.append([sid, "fuzz_msgs/msg/Crafted", "ros2msg", crafted_schema(r["form"], r["size"]).encode()])
    target[3] = sid
    data = write_log(
        [tuple(x) for x in schemas],  # type: ignore[misc]
        [tuple(c) for c in channels],  # type: ignore[misc]
        [tuple(m) for m in msgs],  # type: ignore[misc]
        compression=r["compression"],
    )
    return log_built("seed_none", f"schema-{r['form']}-{r['size']}", r["call"], data)


def yaml_bomb_text(form: str, n: int) -> str:
    if form == "laughs":
        lines = ['a0: &a0 ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]']
        lines += [f"a{k}: &a{k} [{', '.join([f'*a{k - 1}'] * 9)}]" for k in range(1, min(n, 12))]
        return "\n".join(lines) + "\n"
    if form == "deep-flow-list":
        return "a: " + "[" * n + "]" * n + "\n"
    if form == "deep-flow-map":
        return "a: " + "{a: " * n + "1" + "}" * n + "\n"
    if form == "deep-block":
        return "".join("  " * k + f"k{k}:\n" for k in range(min(n, 5000))) + "  " * min(n, 5000) + "v: 1\n"
    if form == "self-alias":
        return "a: &a [*a]\nb: *a\n"
    return (
        "x: &x "
        + "{"
        + ", ".join(f"k{k}: 1" for k in range(min(n, 2000)))
        + "}\n"
        + "".join(f"y{k}: *x\n" for k in range(min(n, 2000)))
    )


def build_bomb(r: dict[str, Any], seeds: Seeds) -> Built:
    src = Path(r["file"])
    args: dict[str, Any] = {"path": src.name, "name": src.stem, "overrides": []}
    call = "cli-check-config" if r["cli"] else CONFIG_CALLS[r["config"]]
    text = yaml_bomb_text(r["form"], r["size"]).encode()
    return Built(f"{src.name}:bomb-{r['form']}-{r['size']}", call, args, {src.name: text})


def build_two_writers(r: dict[str, Any], seeds: Seeds) -> Built:
    built = build_cli({"argv": r["argv"]}, seeds, "two-writers")
    return Built(f"two-writers:{r['argv'][0]}", "two-writers", {"argv": r["argv"]}, built.files, built.links)


def mutate_xml(ops: list[dict[str, Any]], text: str) -> tuple[str, str]:
    """(what was done, the text) of XML ``text`` with ``ops`` (``description``'s) applied in turn."""
    import xml.etree.ElementTree as ET

    ET.register_namespace("xacro", "http://www.ros.org/wiki/xacro")
    root = ET.fromstring(text)
    done = []
    for o in ops:
        o = {**o, "value": "".join(c for c in o["value"] if c in "\t\n\r" or ord(c) >= 0x20)}  # XML's characters
        elements = list(root.iter())
        parents = {child: parent for parent in elements for child in parent}
        el = elements[o["element"] % len(elements)]
        op = o["op"]
        if op == "attribute" and el.attrib:
            key = sorted(el.attrib)[o["attribute"] % len(el.attrib)]
            el.set(key, o["value"])
            done.append(f"{el.tag}@{key}={o['value']!r}")
        elif op in ("text", "attribute"):
            el.text = o["value"]
            done.append(f"{el.tag}.text={o['value']!r}")
        elif op == "retag":
            done.append(f"retag {el.tag}->{o['tag']}")
            el.tag = o["tag"]
        elif el in parents and op in ("delete", "duplicate", "move"):
            parent = parents[el]
            if op == "delete":
                parent.remove(el)
            elif op == "duplicate":
                parent.append(ET.fromstring(ET.tostring(el)))
            else:
                below = set(el.iter())
                targets = [e for e in elements if e not in below]
                parent.remove(el)
                targets[o["other"] % len(targets)].append(el)
            done.append(f"{op} {el.tag}")
    out = ET.tostring(root, encoding="unicode")
    for o in ops:
        at = o["at"] * len(out) >> 32
        if o["op"] == "truncate":
            out = out[:at]
            done.append(f"truncate@{at}")
        elif o["op"] == "junk":
            out = out[:at] + bytes.fromhex(o["junk"]).decode("latin-1") + out[at:]
            done.append(f"junk@{at}")
    return ";".join(done) or "unchanged", out


def build_description(r: dict[str, Any], seeds: Seeds) -> Built:
    name, text, packages, drive = seeds.descriptions[r["seed"]]
    mutation, data = mutate_xml(r["ops"], text)
    args = {"path": name, "packages": packages, "drive": drive}
    files = {name: data.encode("utf-8", errors="surrogateescape"), "TINY.yaml": TINY_SCENARIO.encode()}
    if drive == "world":
        files["models/crate/model.config"] = b'<model><sdf version="1.9">model.sdf</sdf></model>'
        files["models/crate/model.sdf"] = MODEL_SDF.encode()
    return Built(f"{r['seed']}:{mutation}", f"description-{r['call']}", args, files)


def build_map(r: dict[str, Any], seeds: Seeds) -> Built:
    text = seeds.map_yaml.read_text()
    image = seeds.map_yaml.with_suffix(".pgm").read_bytes()
    mutation = r["part"]
    yaml_bytes = text.encode()
    if r["part"] == "yaml":
        mutation, yaml_bytes = mutate_yaml(r["yaml"], text)
    elif r["part"] == "header":  # P5, its width and height, its maximum; then the pixels as they were
        lines = image.split(b"\n", 3)
        image = b"P5\n" + r["header"].encode("utf-8", errors="surrogateescape") + b"\n255\n" + lines[3]
        mutation = f"header {r['header']!r}"
    elif r["part"] == "cut":
        at = r["at"] * len(image) >> 32
        image, mutation = image[:at], f"cut@{at}"
    else:
        data = bytearray(image)
        for at, bit in r["flips"]:
            data[at * len(data) >> 32] ^= 1 << bit
        image, mutation = bytes(data), f"flip x{len(r['flips'])}"
    name = seeds.map_yaml.name
    files = {name: yaml_bytes, seeds.map_yaml.with_suffix(".pgm").name: image, "TINY.yaml": TINY_SCENARIO.encode()}
    return Built(f"map:{mutation}", f"map-{r['call']}", {"path": name}, files)


def build_replay_folder(r: dict[str, Any], seeds: Seeds) -> Built:
    src = seeds.folder / "slam"
    name = r["file"]
    data = (src / name).read_bytes()
    if name == "replay.mcap":
        buf = bytearray(data[: r["at"] * len(data) >> 32] if not r["flips"] else data)
        for at, bit in r["flips"]:
            buf[at * len(buf) >> 32] ^= 1 << bit
        mutation, data = (f"flip x{len(r['flips'])}" if r["flips"] else f"cut@{len(buf)}"), bytes(buf)
    elif name == "pose_graph.json" and "tree" in r["mutation"]:  # the tree mutated, written back as JSON
        tree = json.loads(data)
        ops = []
        for m in r["mutation"]["tree"]:
            op, tree = mutate_tree(m, tree)
            ops.append(op)
        mutation, data = "+".join(ops), json.dumps(tree, default=str).encode()
    else:  # pose_graph.json's text, trajectory.tum's and map.yaml's text or (read as YAML) tree
        mutation, data = mutate_yaml(r["mutation"], data.decode())
    links = {f"replay/{p.name}": str(p) for p in sorted(src.iterdir()) if p.is_file() and p.name != name}
    links["log.mcap"] = str(seeds.folder / "slam.mcap")
    return Built(f"replay/{name}:{mutation}", "cli-view-replay", {}, {f"replay/{name}": data}, links)


BUILDERS: dict[str, Callable[[dict[str, Any], Seeds], Built]] = {
    "description": build_description,
    "map": build_map,
    "replay-folder": build_replay_folder,
    "mcap-times": build_times,
    "mcap-claims": build_claims,
    "mcap-crc": build_crc,
    "mcap-compressed": build_compressed,
    "schema-crafted": build_schema,
    "yaml-bomb": build_bomb,
    "two-writers": build_two_writers,
    "params-extreme": build_params_extreme,
    "outputs-special": build_outputs_special,
}


def build(case: Case, seeds: Seeds) -> Built:
    """Apply a recipe to the seeds."""
    r, kind = case.recipe, case.kind
    if kind in BUILDERS:
        return BUILDERS[kind](r, seeds)
    if kind == "mcap-bytes":
        mutation, data = mutate_bytes(r, seeds.logs[r["log"]], seeds.records[r["log"]])
        return Built(f"{r['log']}:{mutation}", r["call"], {"log": "log.mcap"}, {"log.mcap": data})
    if kind == "mcap-chunk":
        mutation, data = mutate_chunk(r, seeds.logs[r["log"]], seeds.records[r["log"]])
        return Built(f"{r['log']}:{mutation}", r["call"], {"log": "log.mcap"}, {"log.mcap": data})
    if kind == "mcap-semantic":
        mutation, data = rewrite_log(r, seeds.parsed["seed_none"])
        return Built(f"seed_none:{mutation}", r["call"], {"log": "log.mcap"}, {"log.mcap": data})
    if kind == "mcap-message":
        mutation, data = mutate_messages(r, seeds.parsed["seed_none"])
        return Built(f"seed_none:{mutation}", r["call"], {"log": "log.mcap"}, {"log.mcap": data})
    if kind == "rosbag2":
        return build_rosbag(r, seeds)
    if kind.startswith("config-"):
        return build_config(r, seeds)
    return build_cli(r, seeds, kind)


# --------------------------------------------------------------------------------------- oracle


def materialize(built: Built, folder: Path) -> None:
    for name, src in built.links.items():
        (folder / name).parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(src, folder / name)
    for name, data in built.files.items():
        (folder / name).parent.mkdir(parents=True, exist_ok=True)
        (folder / name).write_bytes(data)


def read_all(path: Path, recover: bool) -> str:
    from navlog.analysis.info import summarize
    from navlog.replay.io.formats import open_log

    with open_log(path, recover=recover) as reader:
        for _ in reader.messages():
            pass
        summarize(reader)
        report = reader.report
    return "COUNTED_SKIP" if report.skipped or report.truncated else "OK"


@contextlib.contextmanager
def config_path(folder: Path) -> Any:
    """The case folder first on navlog's config search path (a mutated file replaces the built-in one)."""
    old = os.environ.get("NAVLOG_CONFIG_PATH")
    os.environ["NAVLOG_CONFIG_PATH"] = str(folder)
    try:
        yield
    finally:
        if old is None:
            os.environ.pop("NAVLOG_CONFIG_PATH")
        else:
            os.environ["NAVLOG_CONFIG_PATH"] = old


def run_cli(argv: list[str], folder: Path, seeds: Seeds) -> str:
    from navlog.cli import main

    places = {
        "LOG": folder / "LOG.mcap",
        "CUT": folder / "CUT.mcap",
        "MAP": seeds.map_yaml,
        "PGM": seeds.map_yaml.with_suffix(".pgm"),
        "NAV2": seeds.configs["nav2"][0],
        "TINY": folder / "TINY.yaml",
        "SCENARIO": folder / "SCENARIO.yaml",
    }

    def place(arg: str) -> str:
        key, eq, value = arg.partition("=")
        if eq and value in places and key.isidentifier():  # --set map=MAP
            return f"{key}={places[value]}"
        return str(places[arg]) if arg in places else str(folder / arg) if (folder / arg).exists() else arg

    cwd = os.getcwd()
    os.chdir(folder)
    try:
        code = main(["-q", *(place(a) for a in argv)])
    except SystemExit as exc:  # argparse refusing the arguments: its usage line and exit 2
        code = exc.code if isinstance(exc.code, int) else 2
    finally:
        os.chdir(cwd)
    return "OK" if code in (0, None) else "CLEAN_ERROR" if code in (1, 2) else f"EXIT{code}"


def call_case(built: Built, folder: Path, seeds: Seeds) -> str:
    """Run the case's entry point; returns OK, COUNTED_SKIP or CLEAN_ERROR (CLI), raises on errors."""
    a = built.args
    if built.call in ("read", "read-recover"):
        return read_all(folder / a["log"], recover=built.call == "read-recover")
    if built.call == "check":
        from navlog.analysis.check import check_log

        check_log(folder / a["log"])
        return "OK"
    if built.call == "recover":
        from navlog.replay.io.recovery import recover_mcap

        recover_mcap(folder / a["log"], folder / "recovered.mcap")
        return read_all(folder / "recovered.mcap", recover=False)
    if built.call == "nav2":
        from navlog.replay.mapping.slam2d.toolbox import TOOLBOX_NODE, read_slam_toolbox
        from navlog.replay.nav2.params import load_nav2_params
        from navlog.replay.pipelines.mapping import slam_toolbox_overrides

        load_nav2_params(folder / a["path"], readers={TOOLBOX_NODE: read_slam_toolbox})
        slam_toolbox_overrides(folder / a["path"])  # a slam_toolbox block as the mapping pipeline takes it
        return "OK"
    if built.call == "world":
        from navlog.recorder.world import load_world

        load_world(str(folder / a["path"]))
        return "OK"
    if built.call == "robot":
        from navlog.recorder.robot import load_robot

        load_robot(str(folder / a["path"]))
        return "OK"
    if built.call == "scenario":
        from navlog.recorder.robot import load_robot
        from navlog.recorder.scenarios import check_scenario, load_scenario
        from navlog.recorder.world import load_world

        scenario = load_scenario(str(folder / a["path"]))
        check_scenario(scenario, load_robot("go2"), load_world(scenario.world or "indoor_room"))
        return "OK"
    if built.call == "goals":
        from navlog.replay.pipelines.planner import load_goals

        load_goals(str(folder / a["path"]))
        return "OK"
    if built.call == "campaign":
        from navlog.campaign.spec import load_campaign

        load_campaign(folder / a["path"])
        return "OK"
    if built.call == "suite":
        from navlog.analysis.ci.suite import load_suite

        load_suite(folder / a["path"])
        return "OK"
    if built.call == "pipeline":
        from navlog.replay.session import pipeline_params

        (folder / "pipelines").mkdir(exist_ok=True)
        shutil.copyfile(folder / a["path"], folder / "pipelines" / a["path"])
        with config_path(folder):
            pipeline_params(a["name"], None, a.get("overrides", ()))
        return "OK"
    if built.call == "cli-info":
        return run_cli(["info", a["log"]], folder, seeds)
    if built.call == "cli-check-config":
        return run_cli(["check-config", a["path"]], folder, seeds)
    if built.call == "replay-mapping":
        return run_cli(["replay", a["log"], "--pipeline", "mapping", "-o", "out"], folder, seeds)
    if built.call == "replay-safety":  # the recorded /cmd_vel as the controller's output
        argv = ["replay", a["log"], "--pipeline", "safety", "--remap", "/cmd_vel_nav=/cmd_vel", "-o", "out"]
        return run_cli(argv, folder, seeds)
    if built.call == "cli":
        return run_cli(a["argv"], folder, seeds)
    if built.call == "cli-output":
        return run_special_output(a, folder, seeds)
    if built.call == "cli-view-replay":
        return run_cli(["view", "log.mcap", "--replay", "replay", "--save", "view.rrd"], folder, seeds)
    if built.call == "cli-view":
        return run_cli(["view", a["log"], "--save", "view.rrd"], folder, seeds)
    if built.call == "cli-export":
        return run_cli(["export", a["log"], "--to", "rosbag2", "-o", "exported"], folder, seeds)
    if built.call == "map-load":
        from navlog.replay.io.map_server import load_map

        load_map(folder / a["path"])
        return "OK"
    if built.call == "map-cli-record":
        argv = ["record", "--world", a["path"], "--robot", "simple_robot", "--scenario", "TINY", "-o", "out.mcap"]
        return run_cli(argv, folder, seeds)
    if built.call == "map-cli-plan":
        return run_cli(
            ["plan", "--map", a["path"], "--start=0,0,0", "--goal=0.5,0,0", "--png", "plan.png"], folder, seeds
        )
    if built.call == "map-cli-world-map":
        return run_cli(["world-map", a["path"], "-o", "copy.yaml"], folder, seeds)
    if built.call == "description-describe" and a["drive"] == "world":
        from navlog.recorder.world import load_world

        load_world(str(folder / a["path"]), resource_paths=[folder / p for p in a["packages"]])
        return "OK"
    if built.call == "description-describe":
        from navlog.recorder.description import describe

        describe(folder / a["path"], package_paths=a["packages"], drive=a["drive"] or None)
        return "OK"
    if built.call == "description-record" and a["drive"] == "world":
        argv = ["record", "--world", a["path"], "--robot", "simple_robot", "--scenario", "TINY", "-o", "out.mcap"]
        return run_cli([*argv, "--resource-path", "models"], folder, seeds)
    if built.call == "description-record":
        argv = ["record", "--robot", a["path"], "--world", "indoor_room", "--scenario", "TINY", "-o", "out.mcap"]
        argv += ["--drive", a["drive"]] if a["drive"] else []
        for package in a["packages"]:
            argv += ["--package-path", package]
        return run_cli(argv, folder, seeds)
    if built.call == "two-writers":  # the output is held, as by a run in another process
        from navlog.replay.io.atomic import hold_output

        argv = a["argv"]
        out = argv[argv.index("-o" if "-o" in argv else "--save") + 1]
        with hold_output(folder / out):
            outcome = run_cli(a["argv"], folder, seeds)
        return "TWO-WRITERS-" + outcome if outcome == "OK" else outcome
    raise ValueError(f"unknown call {built.call}")


def run_case(case: Case, seeds: Seeds, timeout: float) -> tuple[str, str, Built | None]:
    """(outcome, traceback text, the applied recipe) of one case, in a fresh temporary folder, under an alarm."""
    from navlog.errors import NavlogError

    def on_alarm(signum: int, frame: Any) -> None:
        raise Hang(f"no answer after {timeout} s")

    built: Built | None = None
    with tempfile.TemporaryDirectory(prefix="navlog-fuzz-") as tmp:
        folder = Path(tmp)
        old = signal.signal(signal.SIGALRM, on_alarm)
        signal.setitimer(signal.ITIMER_REAL, timeout)
        sink = io.StringIO()
        try:
            built = build(case, seeds)
            materialize(built, folder)
            with contextlib.redirect_stdout(sink), contextlib.redirect_stderr(sink):
                outcome = call_case(built, folder, seeds)
            if outcome.startswith("EXIT"):
                return "TRACEBACK", f"unexpected exit status {outcome[4:]}\n{sink.getvalue()}", built
            if outcome.startswith("TWO-WRITERS"):
                return "TRACEBACK", f"a second run wrote an output another run holds\n{sink.getvalue()}", built
            if "Traceback (most recent call last)" in sink.getvalue():
                return "TRACEBACK", sink.getvalue(), built
            return outcome, "", built
        except Hang:
            return "HANG", traceback.format_exc(), built
        except NavlogError:
            return "CLEAN_ERROR", "", built
        except Exception:
            return "TRACEBACK", traceback.format_exc(), built
        finally:
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, old)


def save_repro(case: Case, built: Built | None, outcome: str, text: str, out: Path, seed: int) -> Path:
    folder = out / "repro" / f"{case.index:06d}-{case.kind}-{outcome.lower()}"
    if folder.exists():
        shutil.rmtree(folder)
    folder.mkdir(parents=True)
    if built is not None:
        materialize(built, folder)
    meta = {
        "seed": seed,
        "index": case.index,
        "kind": case.kind,
        "recipe": case.recipe,
        "mutation": built.mutation if built else None,
        "call": built.call if built else None,
        "args": built.args if built else None,
        "outcome": outcome,
        "rerun": f"python fuzz/campaign.py --seed {seed} --case {case.index} --out {out}",
    }
    (folder / "case.json").write_text(json.dumps(meta, indent=2) + "\n")
    (folder / "traceback.txt").write_text(text)
    return folder


# -------------------------------------------------------------------------------------- workers


def worker(seed: int, seeds_dir: str, shared: str, timeout: float, out: str, conn: Any) -> None:
    seeds = load_seeds(Path(seeds_dir), Path(shared))
    conn.send(("ready", None))
    while True:
        case = conn.recv()
        if case is None:
            return
        outcome, text, built = run_case(case, seeds, timeout)
        if outcome in FAILURES:
            save_repro(case, built, outcome, text, Path(out), seed)
        mutation, call = (built.mutation, built.call) if built else ("?", "?")
        conn.send((case.index, (case.kind, mutation, call, outcome, text.strip().splitlines()[-1:] or [""])))


@dataclass
class Result:
    seed: int
    cases: int
    seconds: float
    by_kind: dict[str, Counter] = field(default_factory=dict)
    failures: list[dict[str, Any]] = field(default_factory=list)

    @property
    def totals(self) -> Counter:
        total: Counter = Counter()
        for c in self.by_kind.values():
            total.update(c)
        return total

    def table(self) -> str:
        head = f"{'kind':18s}" + "".join(f"{o:>14s}" for o in OUTCOMES) + f"{'total':>8s}"
        rows = [head]
        for kind in sorted(self.by_kind):
            c = self.by_kind[kind]
            rows.append(f"{kind:18s}" + "".join(f"{c[o]:14d}" for o in OUTCOMES) + f"{sum(c.values()):8d}")
        t = self.totals
        rows.append(f"{'all':18s}" + "".join(f"{t[o]:14d}" for o in OUTCOMES) + f"{sum(t.values()):8d}")
        rate = self.cases / self.seconds if self.seconds else 0.0
        rows.append(f"{self.cases} cases, seed {self.seed}, {self.seconds:.1f} s ({rate:.1f} cases/s)")
        return "\n".join(rows)


def run_campaign(
    cases: int,
    seed: int,
    out: Path,
    *,
    shared: Path,
    workers: int = 2,
    timeout: float = 20.0,
    start: int = 0,
    progress: bool = False,
) -> Result:
    """Run cases ``start .. start+cases-1`` of ``seed`` on ``workers`` processes; write OUT/summary.json.

    ``shared`` is the external data folder whose bags and Nav2 files join the seeds (see ``load_seeds``).

    Hypothesis draws the cases in this process and each is handed to a free worker as soon as it is drawn.
    """
    out.mkdir(parents=True, exist_ok=True)
    seeds_dir = out / "seeds"
    seeds = load_seeds(seeds_dir, shared)
    ctx = mp.get_context("fork")
    t0 = time.perf_counter()
    result = Result(seed, 0, 0.0)
    procs: dict[int, tuple[Any, Any, Case | None, float]] = {}  # slot -> (process, conn, case, started)

    def spawn(slot: int) -> None:
        parent, child = ctx.Pipe()
        p = ctx.Process(target=worker, args=(seed, str(seeds_dir), str(shared), timeout, str(out), child), daemon=True)
        p.start()
        parent.recv()  # ready
        procs[slot] = (p, parent, None, 0.0)

    def record(index: int, kind: str, mutation: str, call: str, outcome: str, last: list[str]) -> None:
        result.by_kind.setdefault(kind, Counter())[outcome] += 1
        result.cases += 1
        if outcome in FAILURES:
            result.failures.append(
                {"index": index, "kind": kind, "mutation": mutation, "call": call, "outcome": outcome, "error": last[0]}
            )
        if progress and result.cases % 500 == 0:
            print(f"  {result.cases}/{cases} ({time.perf_counter() - t0:.0f} s)", file=sys.stderr, flush=True)

    def poll() -> list[int]:
        """Collect finished cases; kill a worker stuck where the alarm cannot reach; the idle slots."""
        idle = []
        for slot in list(procs):
            p, conn, case, started = procs[slot]
            if case is None:
                idle.append(slot)
            elif conn.poll(0.005):
                try:
                    got, info = conn.recv()
                except EOFError:  # the worker died inside the call (a signal): save, go on
                    p.join()
                    built = build(case, seeds)
                    how = f"worker died (exit code {p.exitcode})"
                    save_repro(case, built, "CRASH", how, out, seed)
                    record(case.index, case.kind, built.mutation, built.call, "CRASH", [how])
                    spawn(slot)
                else:
                    record(got, *info)
                    procs[slot] = (p, conn, None, 0.0)
                idle.append(slot)
            elif time.perf_counter() - started > timeout + 15:  # inside C code: kill, save, go on
                p.kill()
                p.join()
                built = build(case, seeds)
                save_repro(case, built, "HANG", "worker killed after the time limit", out, seed)
                record(case.index, case.kind, built.mutation, built.call, "HANG", ["killed"])
                spawn(slot)
                idle.append(slot)
        return idle

    def dispatch(case: Case) -> None:
        while True:
            idle = poll()
            if idle:
                p, conn, _, _ = procs[idle[0]]
                conn.send(case)
                procs[idle[0]] = (p, conn, case, time.perf_counter())
                return
            time.sleep(0.002)

    for slot in range(max(1, workers)):
        spawn(slot)
    drawn = generate(seed, cases, seeds, dispatch, start=start)
    while any(case is not None for _, _, case, _ in procs.values()):
        poll()
        time.sleep(0.002)
    for p, conn, _, _ in procs.values():
        conn.send(None)
        p.join()
    result.seconds = time.perf_counter() - t0
    result.failures.sort(key=lambda f: f["index"])
    summary = {
        "seed": seed,
        "start": start,
        "cases": result.cases,
        "drawn": drawn,
        "seconds": round(result.seconds, 1),
        "outcomes": dict(sorted(result.totals.items())),
        "by_kind": {k: dict(sorted(v.items())) for k, v in sorted(result.by_kind.items())},
        "failures": result.failures,
    }
    (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    return result


def rerun(case: Case, seeds: Seeds, timeout: float) -> int:
    print(f"case {case.index}: {case.kind} {json.dumps(case.recipe)[:400]}")
    outcome, text, built = run_case(case, seeds, timeout)
    if built is not None:
        print(f"{built.mutation} -> {built.call} {built.args}")
    print(outcome)
    print(text, end="")
    return 1 if outcome in FAILURES else 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--cases", type=int, default=1000, help="number of cases (default 1000)")
    parser.add_argument("--seed", type=int, default=0, help="campaign seed (default 0)")
    parser.add_argument("--start", type=int, default=0, help="index of the first case (default 0)")
    parser.add_argument("--out", type=Path, required=True, help="folder for seeds, summary.json and repro/")
    parser.add_argument(
        "--shared",
        type=Path,
        default=default_shared_dir(),
        help="the external data folder whose bags and Nav2 files join the seeds "
        "(default: $NAVLOG_SHARED_DIR, else shared/ beside the repository)",
    )
    parser.add_argument("--workers", type=int, default=2, help="worker processes (default 2)")
    parser.add_argument("--timeout", type=float, default=20.0, help="seconds per case before it is a HANG")
    parser.add_argument("--case", type=int, help="re-run this one case in-process and print its traceback")
    parser.add_argument("--repro", type=Path, help="re-run a saved reproducer (a folder holding case.json)")
    args = parser.parse_args(argv)
    if args.case is not None or args.repro is not None:
        seeds = load_seeds(args.out / "seeds", args.shared)
        if args.repro is not None:
            meta = json.loads((args.repro / "case.json").read_text())
            case = Case(meta["index"], meta["kind"], meta["recipe"])
        else:
            case = case_at(args.seed, args.case, seeds)
        return rerun(case, seeds, args.timeout)
    result = run_campaign(
        args.cases,
        args.seed,
        args.out,
        shared=args.shared,
        workers=args.workers,
        timeout=args.timeout,
        start=args.start,
        progress=True,
    )
    print(result.table())
    for f in result.failures[:50]:
        print(f"  {f['outcome']} case {f['index']} {f['kind']} {f['mutation']} -> {f['call']}: {f['error']}")
    return 1 if result.failures or result.cases < args.cases else 0


if __name__ == "__main__":
    sys.exit(main())
