"""A seeded, repeatable fuzz campaign over navlog's inputs: logs, rosbag2 folders, configs, CLI arguments.

navlog's promise for bad input is a ``NavlogError`` with a clear message, or a counted, reported skip --
never a traceback and never a hang. Each case is a mutated input and one library call (the same
function a Python user or the CLI calls), run in a worker process under a time limit. Its outcome is

- ``OK``: the call returned;
- ``CLEAN_ERROR``: it raised a ``NavlogError`` (or the CLI exited non-zero with one line);
- ``COUNTED_SKIP``: it returned, and the reader's report counts skipped messages or a truncation;
- ``TRACEBACK``: any other exception -- a defect;
- ``HANG``: the call outlived ``--timeout`` seconds -- a defect.

Case ``I`` of seed ``S`` is generated from ``numpy.random.default_rng([S, I])`` alone, so a run is
repeatable whatever the number of workers, and one case re-runs by itself (``--case I``, which shows
the full traceback). Every TRACEBACK or HANG saves a reproducer under ``OUT/repro/``: the mutated
files, ``case.json`` (the call and its arguments) and the traceback.

    python fuzz/campaign.py --cases 10000 --seed 1 --out /tmp/fuzz-out
    python fuzz/campaign.py --seed 1 --case 4711 --out /tmp/fuzz-out
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import math
import multiprocessing as mp
import os
import shutil
import signal
import struct
import sys
import tempfile
import time
import traceback
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

REPO = Path(__file__).resolve().parents[1]
EXTERNAL = Path("/work/shared/external-data")
OUTCOMES = ("OK", "CLEAN_ERROR", "COUNTED_SKIP", "TRACEBACK", "HANG")

# A short teleop drive: about 0.5 s of every sensor, recorded once per output folder.
TINY_SCENARIO = """\
name: fuzz_seed
kind: teleop
start: [0.0, 0.0, 0.0]
commands:
  - {duration: 0.4, cmd: [0.3, 0.0, 0.2]}
hold: 0.1
"""


class Hang(Exception):
    """Raised in a worker by the per-case alarm."""


@dataclass
class Case:
    """One generated input: files to write into a fresh folder, and the call to make on them."""

    index: int
    kind: str  # the generator family, e.g. "mcap-bytes", "config-world", "cli"
    mutation: str  # what was done, e.g. "truncate@record"
    call: str  # the oracle entry point, see CALLS
    args: dict[str, Any] = field(default_factory=dict)  # paths are relative to the case folder
    files: dict[str, bytes] = field(default_factory=dict)
    links: dict[str, str] = field(default_factory=dict)  # name -> seed file copied as is


# ----------------------------------------------------------------------------------------- seeds


@dataclass
class Seeds:
    """The unmutated inputs every case starts from (read once per worker)."""

    folder: Path
    logs: dict[str, bytes]  # name -> MCAP bytes
    records: dict[str, list[tuple[int, int, int]]]  # name -> (offset, opcode, length) of top-level records
    parsed: dict[str, Any]  # name -> (schemas, channels, messages) of the small log
    bags: dict[str, Path]  # rosbag2 folders
    configs: dict[str, list[Path]]  # kind -> YAML files
    map_yaml: Path


def build_seed_log(folder: Path) -> Path:
    """Record the tiny drive and rewrite it small: one 3D cloud, 16 KiB chunks (many records to cut)."""
    from mcap.reader import make_reader
    from mcap.writer import CompressionType, Writer

    from navlog.cli import main

    folder.mkdir(parents=True, exist_ok=True)
    small = folder / "seed_zstd.mcap"
    if small.exists() and (folder / "seed_none.mcap").exists() and (folder / "map.yaml").exists():
        return folder
    scenario = folder / "fuzz_seed.yaml"
    scenario.write_text(TINY_SCENARIO)
    raw = folder / "raw.mcap"
    with contextlib.redirect_stdout(io.StringIO()):
        main(["-q", "record", "--scenario", str(scenario), "-o", str(raw), "--force"])
        main(["-q", "world-map", "indoor_room", "-o", str(folder / "map.yaml"), "--force"])
    for name, comp in (("seed_zstd.mcap", CompressionType.ZSTD), ("seed_none.mcap", CompressionType.NONE)):
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


def top_records(data: bytes) -> list[tuple[int, int, int]]:
    """(offset, opcode, content length) of each top-level MCAP record after the leading magic."""
    out = []
    pos = 8
    while pos + 9 <= len(data):
        op = data[pos]
        (length,) = struct.unpack_from("<Q", data, pos + 1)
        out.append((pos, op, length))
        pos += 9 + length
        if op == 0x02:  # footer: the trailing magic follows
            break
    return out


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


def load_seeds(folder: Path) -> Seeds:
    build_seed_log(folder)
    logs = {p.stem: p.read_bytes() for p in sorted(folder.glob("seed_*.mcap"))}
    talker = EXTERNAL / "bags/rosbag2_talker_mcap/talker.mcap"
    if talker.is_file():
        logs["talker"] = talker.read_bytes()
    bags = {p.name: p for p in sorted((EXTERNAL / "bags").glob("*")) if p.is_dir() and p.name != "tb3_gazebo_walker"}
    configs = {
        kind: sorted((REPO / "config" / kind).glob("*.yaml")) for kind in ("worlds", "robots", "scenarios", "pipelines")
    }
    configs["nav2"] = sorted(
        [
            *(REPO / "tests/replay/nav2/data").glob("*.yaml"),
            *(REPO / "config/nav2").glob("*.yaml"),
            *(EXTERNAL / "params").glob("*.yaml"),
        ]
    )
    return Seeds(
        folder=folder,
        logs=logs,
        records={k: top_records(v) for k, v in logs.items()},
        parsed={"seed_none": parse_log(logs["seed_none"])},
        bags=bags,
        configs=configs,
        map_yaml=folder / "map.yaml",
    )


# ------------------------------------------------------------------------------- byte mutations


def pick(rng: np.random.Generator, items: Any) -> Any:
    items = list(items)
    return items[int(rng.integers(len(items)))]


def flip_bits(rng: np.random.Generator, data: bytes, lo: int = 0) -> bytes:
    buf = bytearray(data)
    for _ in range(int(rng.integers(1, 17))):
        i = int(rng.integers(lo, len(buf)))
        buf[i] ^= 1 << int(rng.integers(8))
    return bytes(buf)


def mutate_bytes(rng: np.random.Generator, data: bytes, records: list[tuple[int, int, int]]) -> tuple[str, bytes]:
    """One structural or random mutation of an MCAP file's bytes."""
    op = pick(
        rng,
        [
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
        ],
    )
    n = len(data)
    if op == "bitflip":
        return op, flip_bits(rng, data)
    if op == "bitflip@summary":
        return op, flip_bits(rng, data, lo=int(n * 0.9))
    if op == "truncate@random":
        return op, data[: int(rng.integers(0, n))]
    if op == "zero-run":
        i = int(rng.integers(n))
        k = int(rng.integers(1, 4096))
        return op, data[:i] + bytes(min(k, n - i)) + data[i + k :]
    off, code, length = pick(rng, records)
    if op == "truncate@record":
        cut = off + pick(rng, [0, 1, 9, 9 + length // 2, 9 + length, 9 + length - 1])
        return f"truncate@record{code:#04x}", data[: min(cut, n)]
    if op == "length":
        value = pick(rng, [0, 1, length - 1, length + 1, length + 8, 2**31, 2**63 - 1, 2**64 - 1])
        return f"length{code:#04x}", data[: off + 1] + struct.pack("<Q", max(0, value)) + data[off + 9 :]
    if op == "chunk-field":
        chunks = [r for r in records if r[1] == 0x06] or records
        off, code, length = pick(rng, chunks)
        # chunk: start u64, end u64, uncompressed size u64, crc u32, compression str, records len u64
        field_name, at, fmt = pick(rng, [("size", 16, "<Q"), ("crc", 24, "<I"), ("start", 0, "<Q"), ("end", 8, "<Q")])
        body = off + 9
        values = {"<Q": [0, 1, 2**63 - 1, 2**64 - 1], "<I": [0, 1, 0xFFFFFFFF]}[fmt]
        value = pick(rng, values) if rng.random() < 0.5 else int(rng.integers(0, 2**32))
        if field_name == "crc" or rng.random() < 0.5:
            new = struct.pack(fmt, value)
        else:
            (old,) = struct.unpack_from(fmt, data, body + at)
            new = struct.pack(fmt, max(0, old + int(rng.integers(-64, 65))))
        return f"chunk-{field_name}", data[: body + at] + new + data[body + at + len(new) :]
    end = off + 9 + length
    if op == "duplicate-bytes":
        i, k = int(rng.integers(n)), int(rng.integers(1, 512))
        return op, data[:i] + data[i : i + k] + data[i:]
    if op == "drop-bytes":
        i, k = int(rng.integers(n)), int(rng.integers(1, 512))
        return op, data[:i] + data[i + k :]
    if op == "duplicate-record":
        return f"{op}{code:#04x}", data[:end] + data[off:end] + data[end:]
    if op == "drop-record":
        return f"{op}{code:#04x}", data[:off] + data[end:]
    off2, _, length2 = pick(rng, records)
    a, b = sorted([(off, end), (off2, off2 + 9 + length2)])
    if a[1] > b[0]:
        return "swap-records(same)", data
    return "swap-records", data[: a[0]] + data[b[0] : b[1]] + data[a[1] : b[0]] + data[a[0] : a[1]] + data[b[1] :]


SCHEMA_TOKENS = ["float64", "float32", "uint8[]", "string", "int32", "builtin_interfaces/Time", "std_msgs/Header"]


def mutate_schema_text(rng: np.random.Generator, text: str) -> str:
    lines = text.splitlines()
    op = pick(rng, ["drop-line", "swap-type", "garbage", "empty", "duplicate-line", "bad-separator"])
    if op == "empty" or not lines:
        return ""
    i = int(rng.integers(len(lines)))
    if op == "drop-line":
        del lines[i]
    elif op == "swap-type":
        words = lines[i].split(" ", 1)
        lines[i] = pick(rng, SCHEMA_TOKENS) + (" " + words[1] if len(words) > 1 else "")
    elif op == "garbage":
        lines[i] = pick(rng, ["%%%", "uint8[ data", "foo/Bar x", "int32 = 3", "string<=", "\x00\xff", "a b c d"])
    elif op == "duplicate-line":
        lines.insert(i, lines[i])
    else:
        lines.insert(i, pick(rng, ["=" * 80, "MSG: ", "MSG: nonexistent/msg/Type", "=" * 80 + "\nMSG: a/b"]))
    return "\n".join(lines)


def inject_floats(rng: np.random.Generator, data: bytes) -> bytes:
    """Write NaN, +-inf or huge values at aligned offsets of a CDR payload (where floats live)."""
    buf = bytearray(data)
    for _ in range(int(rng.integers(1, 9))):
        value = pick(rng, [math.nan, math.inf, -math.inf, 1e308, -0.0, 3.4e38])
        if rng.random() < 0.5 and len(buf) >= 12:
            i = 4 + 8 * int(rng.integers((len(buf) - 4) // 8))
            struct.pack_into("<d", buf, i, value)
        elif len(buf) >= 8:
            i = 4 + 4 * int(rng.integers((len(buf) - 4) // 4))
            struct.pack_into("<f", buf, i, value if abs(value) < 3.5e38 or not math.isfinite(value) else math.inf)
    return bytes(buf)


def rewrite_log(rng: np.random.Generator, parsed: tuple[list[Any], list[Any], list[Any]]) -> tuple[str, bytes]:
    """Re-encode the small log with a semantic mutation: schemas, encodings, CDR payloads, times, order."""
    from mcap.writer import CompressionType, Writer

    schemas, channels, messages = parsed
    op = pick(
        rng,
        ["schema-text", "schema-name", "encoding", "cdr", "nan-inf", "times", "order", "no-messages", "dangling"],
    )
    target = pick(rng, channels)
    schema_data = {s.id: s.data for s in schemas}
    schema_name = {s.id: s.name for s in schemas}
    schema_enc = {s.id: s.encoding for s in schemas}
    chan_enc = {c.id: c.message_encoding for c in channels}
    chan_schema = {c.id: c.schema_id for c in channels}
    msgs = [(m.channel_id, m.log_time, m.publish_time, m.data) for m in messages]
    if op == "schema-text":
        sid = target.schema_id
        schema_data[sid] = mutate_schema_text(rng, schema_data[sid].decode("utf-8", "replace")).encode()
    elif op == "schema-name":
        name = pick(rng, ["", "foo", "a/b", "sensor_msgs/msg/Imu", "nav_msgs/msg/Nope", "x/msg/Y/Z", "sensor_msgs/Imu"])
        schema_name[target.schema_id] = name
    elif op == "encoding":
        if rng.random() < 0.5:
            chan_enc[target.id] = pick(rng, ["json", "ros1", "", "protobuf"])
        else:
            schema_enc[target.schema_id] = pick(rng, ["jsonschema", "ros2idl", "", "ros1msg"])
    elif op in ("cdr", "nan-inf"):
        picked = [i for i, m in enumerate(msgs) if m[0] == target.id]
        for i in picked[: int(rng.integers(1, 4))] if rng.random() < 0.5 else picked:
            cid, t, p, data = msgs[i]
            if op == "nan-inf":
                data = inject_floats(rng, data)
            else:
                form = pick(rng, ["truncate", "extend", "random", "empty", "header", "flip"])
                data = {
                    "truncate": lambda d: d[: int(rng.integers(0, max(1, len(d))))],
                    "extend": lambda d: d + rng.bytes(int(rng.integers(1, 64))),
                    "random": lambda d: rng.bytes(len(d)),
                    "empty": lambda d: b"",
                    "header": lambda d: bytes([0, int(rng.integers(256)), 0, 0]) + d[4:],
                    "flip": lambda d: flip_bits(rng, d) if d else d,
                }[form](data)
                op = f"cdr-{form}"
            msgs[i] = (cid, t, p, data)
    elif op == "times":
        form = pick(rng, ["backwards", "zero", "max", "future", "duplicate", "jump"])
        op = f"times-{form}"
        for i, (cid, t, p, data) in enumerate(msgs):
            t = {
                "backwards": msgs[-1 - i][1],
                "zero": 0,
                "max": 2**64 - 1 if i % 7 == 0 else t,
                "future": t + 10**18,
                "duplicate": msgs[0][1],
                "jump": t + (10**15 if i > len(msgs) // 2 else 0),
            }[form]
            msgs[i] = (cid, t, p, data)
    elif op == "order":
        rng.shuffle(msgs)
        msgs = msgs + msgs[: int(rng.integers(0, 50))]
    elif op == "no-messages":
        msgs = []
    else:  # a channel whose schema does not exist
        chan_schema[target.id] = pick(rng, [0, 999])
    out = io.BytesIO()
    writer = Writer(out, compression=pick(rng, [CompressionType.ZSTD, CompressionType.NONE]), chunk_size=16 << 10)
    writer.start(profile=pick(rng, ["ros2", "ros2", "", "ros1"]), library="fuzz")
    for s in schemas:
        writer.register_schema(schema_name[s.id], schema_enc[s.id], schema_data[s.id])
    for c in channels:
        writer.register_channel(c.topic, chan_enc[c.id], chan_schema[c.id], dict(c.metadata))
    for seq, (cid, t, p, data) in enumerate(msgs):
        writer.add_message(cid, t, data, p, seq)
    writer.finish()
    return op, out.getvalue()


# ------------------------------------------------------------------------------ YAML mutations

ODD_VALUES: list[Any] = [
    None,
    "",
    "abc",
    -1,
    0,
    1e308,
    -1e308,
    float("nan"),
    float("inf"),
    True,
    [],
    {},
    [1, 2],
    {"a": 1},
    "1.5",
    2**70,
    [[0, 0], [1]],
    "/scan",
]


def tree_paths(node: Any, prefix: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    out = [prefix]
    if isinstance(node, dict):
        for k, v in node.items():
            out += tree_paths(v, (*prefix, k))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            out += tree_paths(v, (*prefix, i))
    return out


def mutate_tree(rng: np.random.Generator, tree: Any) -> tuple[str, Any]:
    paths = [p for p in tree_paths(tree) if p]
    if not paths:
        return "replace-root", pick(rng, ODD_VALUES)
    path = pick(rng, paths)
    parent = tree
    for k in path[:-1]:
        parent = parent[k]
    key = path[-1]
    op = pick(rng, ["value", "value", "delete", "rename", "wrap", "duplicate-into-list"])
    if op == "value":
        parent[key] = pick(rng, ODD_VALUES)
    elif op == "delete":
        del parent[key]
    elif op == "rename" and isinstance(parent, dict):
        s = str(key)
        i = int(rng.integers(len(s) + 1))
        new = pick(rng, [s[:i] + "x" + s[i:], s[:i] + s[i + 1 :], s.upper(), s + "_", 7, ""])
        parent[new] = parent.pop(key)
    elif op == "wrap":
        parent[key] = [parent[key]] if rng.random() < 0.5 else {"value": parent[key]}
    else:
        parent[key] = [parent[key], parent[key]] if not isinstance(parent[key], list) else parent[key][:1] * 3
    return f"tree-{op}", tree


def mutate_text(rng: np.random.Generator, text: str) -> tuple[str, bytes]:
    lines = text.splitlines()
    op = pick(rng, ["drop-line", "indent", "garbage", "truncate", "tabs", "binary", "bom", "anchors", "empty"])
    i = int(rng.integers(max(1, len(lines))))
    if op == "drop-line" and lines:
        del lines[i]
    elif op == "indent" and lines:
        lines[i] = " " * int(rng.integers(1, 5)) + lines[i]
    elif op == "garbage" and lines:
        bad = pick(rng, [": :", "[", "{a: ", "- - -", "!!python/object:os.system", "*undefined", "&a", "'", "key: @"])
        j = int(rng.integers(len(lines[i]) + 1))
        lines[i] = lines[i][:j] + bad + lines[i][j:]
    elif op == "truncate":
        return op, text.encode()[: int(rng.integers(len(text) + 1))]
    elif op == "tabs":
        return op, text.replace("  ", "\t", int(rng.integers(1, 4))).encode()
    elif op == "binary":
        return op, bytes(rng.integers(0, 256, 64, dtype=np.uint8)) + text.encode()
    elif op == "bom":
        return op, b"\xef\xbb\xbf" + text.encode("utf-16")[: len(text)]
    elif op == "anchors":
        return op, b"a: &a [*a]\nb: &b {x: *b}\n" + text.encode()
    elif op == "empty":
        return op, pick(rng, [b"", b"---\n", b"~\n", b"[]\n", b"42\n", b"- a\n- b\n"])
    return f"text-{op}", "\n".join(lines).encode()


def mutate_yaml(rng: np.random.Generator, text: str) -> tuple[str, bytes]:
    if rng.random() < 0.35:
        return mutate_text(rng, text)
    tree = yaml.safe_load(text)
    ops = []
    for _ in range(int(rng.integers(1, 4))):
        op, tree = mutate_tree(rng, tree)
        ops.append(op)
    return "+".join(ops), yaml.safe_dump(tree, sort_keys=False, allow_unicode=True).encode()


# ----------------------------------------------------------------------------------- generators


def gen_mcap(rng: np.random.Generator, seeds: Seeds, index: int) -> Case:
    call = pick(rng, ["read", "read", "read-recover", "check", "cli-info", "recover"])
    if rng.random() < 0.55:
        name = pick(rng, sorted(seeds.logs))
        mutation, data = mutate_bytes(rng, seeds.logs[name], seeds.records[name])
        kind = "mcap-bytes"
    else:
        name = "seed_none"
        mutation, data = rewrite_log(rng, seeds.parsed[name])
        kind = "mcap-semantic"
    return Case(index, kind, f"{name}:{mutation}", call, {"log": "log.mcap"}, {"log.mcap": data})


def gen_rosbag(rng: np.random.Generator, seeds: Seeds, index: int) -> Case:
    name = pick(rng, sorted(seeds.bags))
    src = seeds.bags[name]
    storage = sorted(p.name for p in src.iterdir() if p.suffix in (".db3", ".mcap"))
    files: dict[str, bytes] = {}
    links = {f"bag/{p.name}": str(p) for p in src.iterdir()}
    op = pick(rng, ["metadata", "metadata", "missing-storage", "corrupt-storage", "no-metadata", "empty-dir"])
    target = "bag"
    if op == "metadata":
        op, files["bag/metadata.yaml"] = mutate_yaml(rng, (src / "metadata.yaml").read_text())
        op = f"metadata-{op}"
    elif op == "missing-storage":
        del links[f"bag/{pick(rng, storage)}"]
    elif op == "corrupt-storage":
        victim = pick(rng, storage)
        del links[f"bag/{victim}"]
        data = (src / victim).read_bytes()
        form = pick(rng, ["bitflip", "truncate", "page-zero", "header"])
        if form == "bitflip":
            data = flip_bits(rng, data)
        elif form == "truncate":
            data = data[: pick(rng, [0, 100, 4096 * int(rng.integers(1, 8)), int(rng.integers(len(data)))])]
        elif form == "page-zero":
            page = 4096 * int(rng.integers(len(data) // 4096))
            data = data[:page] + bytes(4096) + data[page + 4096 :]
        else:
            data = flip_bits(rng, data[:100]) + data[100:]
        files[f"bag/{victim}"] = data
        op = f"corrupt-storage-{form}"
        if rng.random() < 0.3:
            target = f"bag/{victim}"
    elif op == "no-metadata":
        del links["bag/metadata.yaml"]
    else:
        links = {}
        files["bag/.keep"] = b""
    call = pick(rng, ["read", "read", "read-recover", "check", "cli-info"])
    return Case(index, "rosbag2", f"{name}:{op}", call, {"log": target}, files, links)


CONFIG_CALLS = {"worlds": "world", "robots": "robot", "scenarios": "scenario", "pipelines": "pipeline", "nav2": "nav2"}


def gen_config(rng: np.random.Generator, seeds: Seeds, index: int) -> Case:
    kind = pick(rng, ["worlds", "robots", "scenarios", "pipelines", "nav2", "nav2"])
    src = pick(rng, seeds.configs[kind])
    mutation, data = mutate_yaml(rng, src.read_text())
    args: dict[str, Any] = {"path": f"{src.stem}.yaml", "name": src.stem}
    if kind == "pipelines" and rng.random() < 0.5:
        args["overrides"] = [
            f"{pick(rng, ['', 'a', 'occupancy.grid.resolution', 'pose_source'])}={pick(rng, ['', '0', '-1', 'nan', 'x', '[1', '{}'])}"
        ]
    call = CONFIG_CALLS[kind]
    if kind == "nav2" and rng.random() < 0.3:
        call = "cli-check-config"
    return Case(index, f"config-{kind}", f"{src.name}:{mutation}", call, args, {f"{src.stem}.yaml": data})


CLI_VALUES = ["", "x", "-1", "0", "nan", "inf", "1e400", "/scan", "/scan=/odom", "a=b", "1,2", "1,2,3", "-1,0,0"]
CLI_PATHS = ["LOG", "MAP", "PGM", "NAV2", "missing.mcap", "missing.yaml", "EMPTY", "DIR", "TEXT"]


def gen_cli(rng: np.random.Generator, seeds: Seeds, index: int) -> Case:
    def value(paths: bool = True) -> str:
        return pick(rng, CLI_PATHS) if paths and rng.random() < 0.6 else pick(rng, CLI_VALUES)

    command = pick(rng, ["info", "check", "check-config", "recover", "world-map", "plan", "diff"])
    argv: list[str] = [command]
    flags: dict[str, Callable[[], list[str]]] = {
        "info": lambda: pick(rng, [["--json"], ["--recover"], []]),
        "check": lambda: pick(
            rng,
            [
                ["--pipeline", pick(rng, ["mapping", "planner", "safety", "nope", ""])],
                ["--require", value(False)],
                ["--frames", pick(rng, ["map:base_link", "odom:base_footprint", "a:b", ":", "x"])],
                ["--rate", pick(rng, ["/scan=10", "/scan=0", "/scan=-1", "/scan=nan", "/imu/data=x", "=", "/x=1"])],
                ["--rate-tolerance", value(False)],
                ["--gap-factor", value(False)],
                ["--max-gap", value(False)],
                ["--json"],
            ],
        ),
        "check-config": lambda: pick(rng, [["--notes"], []]),
        "recover": lambda: pick(rng, [["--force"], []]),
        "world-map": lambda: pick(
            rng,
            [
                ["--margin", value(False)],
                ["--resolution", pick(rng, ["0.05", "0", "-1", "nan", "1e-9", "100", "x"])],
                ["--z-min", value(False)],
                ["--z-max", value(False)],
                ["--height", value(False)],
                ["--force"],
            ],
        ),
        "plan": lambda: pick(
            rng,
            [
                ["--params", value()],
                ["--planner", pick(rng, ["navfn", "smac2d", "x"])],
                ["--potential", pick(rng, ["wavefront", "exact"])],
                ["--set", pick(rng, ["robot_radius=0.3", "tolerance=-1", "x=1", "=", "inflation_radius=nan"])],
            ],
        ),
        "diff": lambda: pick(rng, [["--tol", value(False)], ["--ignore", value(False)], ["--json", "out.json"]]),
    }
    if command in ("info", "check", "check-config", "recover"):
        argv.append(pick(rng, ["LOG", "LOG", "NAV2"] if command != "check-config" else ["NAV2", "NAV2", "LOG"]))
        if rng.random() < 0.2:
            argv[-1] = value()
        if command == "recover":
            argv += ["-o", pick(rng, ["out.mcap", "LOG", "DIR", ""])]
    elif command == "world-map":
        argv += [pick(rng, ["indoor_room", "walled_room", "nope", "TEXT", "NAV2"]), "-o", pick(rng, ["m.yaml", "DIR"])]
    elif command == "plan":
        argv += ["--map", pick(rng, ["MAP", "MAP", "PGM", "NAV2", "missing.yaml", "EMPTY"])]
        argv += [f"--start={pick(rng, ['0,0,0', '-1,-1,0', '1,2', 'a,b,c', '100,100,0', 'nan,0,0'])}"]
        argv += [f"--goal={pick(rng, ['1.2,-1,1.571', '-1,1,0', '0,0', '2,1.5,0', 'inf,0,0'])}"]
    else:
        argv += [pick(rng, ["LOG", "LOG", "DIR", "EMPTY"]), pick(rng, ["LOG", "missing.mcap", "TEXT"])]
    for _ in range(int(rng.integers(0, 4))):
        argv += flags[command]()
    if rng.random() < 0.1:  # an unknown or half-given flag: argparse's own exit 2
        argv.insert(int(rng.integers(1, len(argv) + 1)), pick(rng, ["--nope", "-o", "--json=1", "--"]))
    files = {"EMPTY": b"", "TEXT": b"not: [yaml\n", "DIR/.keep": b""}
    links = {"LOG.mcap": str(seeds.folder / "seed_zstd.mcap")}  # a copy: `recover -o LOG` may replace it
    return Case(index, "cli", command, "cli", {"argv": argv}, files, links)


GENERATORS: list[tuple[Callable[[np.random.Generator, Seeds, int], Case], float]] = [
    (gen_mcap, 0.40),
    (gen_rosbag, 0.12),
    (gen_config, 0.33),
    (gen_cli, 0.15),
]


def make_case(seed: int, index: int, seeds: Seeds) -> Case:
    rng = np.random.default_rng([seed, index])
    weights = np.array([w for _, w in GENERATORS])
    gen = GENERATORS[int(rng.choice(len(GENERATORS), p=weights / weights.sum()))][0]
    return gen(rng, seeds, index)


# --------------------------------------------------------------------------------------- oracle


def materialize(case: Case, folder: Path) -> None:
    for name, src in case.links.items():
        (folder / name).parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(src, folder / name)
    for name, data in case.files.items():
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


def call_case(case: Case, folder: Path, seeds: Seeds) -> str:
    """Run the case's entry point; returns OK or COUNTED_SKIP, raises on errors."""
    a = case.args
    if case.call in ("read", "read-recover"):
        return read_all(folder / a["log"], recover=case.call == "read-recover")
    if case.call == "check":
        from navlog.analysis.check import check_log

        check_log(folder / a["log"])
        return "OK"
    if case.call == "recover":
        from navlog.replay.io.recovery import recover_mcap

        recover_mcap(folder / a["log"], folder / "recovered.mcap")
        return read_all(folder / "recovered.mcap", recover=False)
    if case.call == "nav2":
        from navlog.replay.nav2.params import load_nav2_params

        load_nav2_params(folder / a["path"])
        return "OK"
    if case.call == "world":
        from navlog.recorder.world import load_world

        load_world(str(folder / a["path"]))
        return "OK"
    if case.call == "robot":
        from navlog.recorder.robot import load_robot

        load_robot(str(folder / a["path"]))
        return "OK"
    if case.call == "scenario":
        from navlog.recorder.robot import load_robot
        from navlog.recorder.scenarios import check_scenario, load_scenario
        from navlog.recorder.world import load_world

        scenario = load_scenario(str(folder / a["path"]))
        check_scenario(scenario, load_robot("go2"), load_world(scenario.world or "indoor_room"))
        return "OK"
    if case.call == "pipeline":
        from navlog.replay.session import pipeline_params

        # the mutated file replaces the built-in one of the same name through the config search path
        (folder / "pipelines").mkdir(exist_ok=True)
        shutil.copyfile(folder / a["path"], folder / "pipelines" / a["path"])
        old = os.environ.get("NAVLOG_CONFIG_PATH")
        os.environ["NAVLOG_CONFIG_PATH"] = str(folder)
        try:
            pipeline_params(a["name"], None, a.get("overrides", ()))
        finally:
            os.environ.pop("NAVLOG_CONFIG_PATH") if old is None else os.environ.__setitem__("NAVLOG_CONFIG_PATH", old)
        return "OK"
    if case.call in ("cli", "cli-info", "cli-check-config"):
        from navlog.cli import main

        if case.call == "cli":
            argv = list(a["argv"])
        elif case.call == "cli-info":
            argv = ["info", a["log"]]
        else:
            argv = ["check-config", a["path"]]
        places = {
            "LOG": folder / "LOG.mcap" if case.call == "cli" else None,
            "MAP": seeds.map_yaml,
            "PGM": seeds.map_yaml.with_suffix(".pgm"),
            "NAV2": seeds.configs["nav2"][0] if case.call == "cli" else None,
        }
        argv = [str(places[x]) if places.get(x) else str(folder / x) if (folder / x).exists() else x for x in argv]
        cwd = os.getcwd()
        os.chdir(folder)
        try:
            code = main(["-q", *argv])
        except SystemExit as exc:  # argparse refusing the arguments: its usage line and exit 2
            code = exc.code if isinstance(exc.code, int) else 2
        finally:
            os.chdir(cwd)
        return "OK" if code in (0, None) else "CLEAN_ERROR" if code in (1, 2) else f"EXIT{code}"
    raise ValueError(f"unknown call {case.call}")


def run_case(case: Case, seeds: Seeds, timeout: float) -> tuple[str, str]:
    """(outcome, traceback text) of one case, in a fresh temporary folder, under an alarm."""
    from navlog.errors import NavlogError

    def on_alarm(signum: int, frame: Any) -> None:
        raise Hang(f"no answer after {timeout} s")

    with tempfile.TemporaryDirectory(prefix="navlog-fuzz-") as tmp:
        folder = Path(tmp)
        materialize(case, folder)
        old = signal.signal(signal.SIGALRM, on_alarm)
        signal.setitimer(signal.ITIMER_REAL, timeout)
        sink = io.StringIO()
        try:
            with contextlib.redirect_stdout(sink), contextlib.redirect_stderr(sink):
                outcome = call_case(case, folder, seeds)
            if outcome.startswith("EXIT"):
                return "TRACEBACK", f"unexpected exit status {outcome[4:]}\n{sink.getvalue()}"
            if case.call.startswith("cli") and "Traceback (most recent call last)" in sink.getvalue():
                return "TRACEBACK", sink.getvalue()
            return outcome, ""
        except Hang:
            return "HANG", traceback.format_exc()
        except NavlogError:
            return "CLEAN_ERROR", ""
        except Exception:
            return "TRACEBACK", traceback.format_exc()
        finally:
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, old)


def save_repro(case: Case, outcome: str, text: str, out: Path, seed: int) -> Path:
    folder = out / "repro" / f"{case.index:06d}-{case.kind}-{outcome.lower()}"
    if folder.exists():
        shutil.rmtree(folder)
    folder.mkdir(parents=True)
    materialize(case, folder)
    meta = {
        "seed": seed,
        "index": case.index,
        "kind": case.kind,
        "mutation": case.mutation,
        "call": case.call,
        "args": case.args,
        "outcome": outcome,
        "rerun": f"python fuzz/campaign.py --seed {seed} --case {case.index} --out {out}",
    }
    (folder / "case.json").write_text(json.dumps(meta, indent=2) + "\n")
    (folder / "traceback.txt").write_text(text)
    return folder


# -------------------------------------------------------------------------------------- workers


def worker(seed: int, seeds_dir: str, timeout: float, out: str, conn: Any) -> None:
    seeds = load_seeds(Path(seeds_dir))
    conn.send(("ready", None))
    while True:
        index = conn.recv()
        if index is None:
            return
        case = make_case(seed, index, seeds)
        outcome, text = run_case(case, seeds, timeout)
        if outcome in ("TRACEBACK", "HANG"):
            save_repro(case, outcome, text, Path(out), seed)
        conn.send((index, (case.kind, case.mutation, case.call, outcome, text.strip().splitlines()[-1:] or [""])))


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
        head = f"{'kind':16s}" + "".join(f"{o:>14s}" for o in OUTCOMES) + f"{'total':>8s}"
        rows = [head]
        for kind in sorted(self.by_kind):
            c = self.by_kind[kind]
            rows.append(f"{kind:16s}" + "".join(f"{c[o]:14d}" for o in OUTCOMES) + f"{sum(c.values()):8d}")
        t = self.totals
        rows.append(f"{'all':16s}" + "".join(f"{t[o]:14d}" for o in OUTCOMES) + f"{sum(t.values()):8d}")
        rate = self.cases / self.seconds if self.seconds else 0.0
        rows.append(f"{self.cases} cases, seed {self.seed}, {self.seconds:.1f} s ({rate:.1f} cases/s)")
        return "\n".join(rows)


def run_campaign(
    cases: int,
    seed: int,
    out: Path,
    *,
    workers: int = 2,
    timeout: float = 20.0,
    start: int = 0,
    progress: bool = False,
) -> Result:
    """Run cases ``start .. start+cases-1`` of ``seed`` on ``workers`` processes; write OUT/summary.json."""
    out.mkdir(parents=True, exist_ok=True)
    seeds_dir = out / "seeds"
    build_seed_log(seeds_dir)
    ctx = mp.get_context("fork")
    t0 = time.perf_counter()
    result = Result(seed, cases, 0.0)
    pending = list(range(start + cases - 1, start - 1, -1))
    procs: dict[int, tuple[Any, Any, int | None, float]] = {}  # slot -> (process, conn, index, started)

    def spawn(slot: int) -> None:
        parent, child = ctx.Pipe()
        p = ctx.Process(target=worker, args=(seed, str(seeds_dir), timeout, str(out), child), daemon=True)
        p.start()
        parent.recv()  # ready
        procs[slot] = (p, parent, None, 0.0)

    def feed(slot: int) -> None:
        p, conn, _, _ = procs[slot]
        if pending:
            index = pending.pop()
            conn.send(index)
            procs[slot] = (p, conn, index, time.perf_counter())
        else:
            conn.send(None)
            p.join()
            del procs[slot]

    def record(index: int, kind: str, mutation: str, call: str, outcome: str, last: list[str]) -> None:
        result.by_kind.setdefault(kind, Counter())[outcome] += 1
        if outcome in ("TRACEBACK", "HANG"):
            result.failures.append(
                {"index": index, "kind": kind, "mutation": mutation, "call": call, "outcome": outcome, "error": last[0]}
            )

    for slot in range(max(1, workers)):
        spawn(slot)
        feed(slot)
    done = 0
    while procs:
        for slot in list(procs):
            p, conn, index, started = procs[slot]
            if conn.poll(0.01):
                got, info = conn.recv()
                record(got, *info)
                done += 1
                feed(slot)
            elif index is not None and time.perf_counter() - started > timeout + 15:
                # stuck where the alarm cannot reach (inside C code): kill the worker, save, go on
                p.kill()
                p.join()
                seeds = load_seeds(seeds_dir)
                case = make_case(seed, index, seeds)
                save_repro(case, "HANG", "worker killed after the time limit", out, seed)
                record(index, case.kind, case.mutation, case.call, "HANG", ["killed"])
                done += 1
                spawn(slot)
                feed(slot)
        if progress and done and done % 500 == 0:
            print(f"  {done}/{cases} ({time.perf_counter() - t0:.0f} s)", file=sys.stderr, flush=True)
    result.seconds = time.perf_counter() - t0
    result.failures.sort(key=lambda f: f["index"])
    summary = {
        "seed": seed,
        "start": start,
        "cases": cases,
        "seconds": round(result.seconds, 1),
        "outcomes": dict(sorted(result.totals.items())),
        "by_kind": {k: dict(sorted(v.items())) for k, v in sorted(result.by_kind.items())},
        "failures": result.failures,
    }
    (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    return result


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--cases", type=int, default=1000, help="number of cases (default 1000)")
    parser.add_argument("--seed", type=int, default=0, help="campaign seed (default 0)")
    parser.add_argument("--start", type=int, default=0, help="index of the first case (default 0)")
    parser.add_argument("--out", type=Path, required=True, help="folder for seeds, summary.json and repro/")
    parser.add_argument("--workers", type=int, default=2, help="worker processes (default 2)")
    parser.add_argument("--timeout", type=float, default=20.0, help="seconds per case before it is a HANG")
    parser.add_argument("--case", type=int, help="re-run this one case in-process and print its traceback")
    args = parser.parse_args(argv)
    if args.case is not None:
        seeds = load_seeds(args.out / "seeds")
        case = make_case(args.seed, args.case, seeds)
        print(f"case {case.index}: {case.kind} {case.mutation} -> {case.call} {case.args}")
        outcome, text = run_case(case, seeds, args.timeout)
        print(outcome)
        print(text, end="")
        return 1 if outcome in ("TRACEBACK", "HANG") else 0
    result = run_campaign(
        args.cases, args.seed, args.out, workers=args.workers, timeout=args.timeout, start=args.start, progress=True
    )
    print(result.table())
    for f in result.failures[:50]:
        print(f"  {f['outcome']} case {f['index']} {f['kind']} {f['mutation']} -> {f['call']}: {f['error']}")
    return 1 if result.failures else 0


if __name__ == "__main__":
    sys.exit(main())
