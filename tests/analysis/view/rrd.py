"""Reading a saved .rrd back: entities, their columns in time order, and `rerun rrd verify`."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

RERUN = Path(sys.executable).with_name("rerun")


def read_rrd(path: Path) -> dict[str, dict[str, list]]:
    """entity -> {"static": [record batches], "temporal": [record batches]} of the first recording."""
    from rerun.chunk import RrdReader

    out: dict[str, dict[str, list]] = {}
    for ch in RrdReader(path).stream().collect().stream():
        slot = out.setdefault(ch.entity_path, {"static": [], "temporal": []})
        slot["static" if ch.is_static else "temporal"].append(ch.to_record_batch())
    return out


def column(data: dict, entity: str, name: str, static: bool = False) -> list:
    """All values of one column of an entity, in time order for temporal data."""
    rows = []
    for rb in data[entity]["static" if static else "temporal"]:
        if name not in rb.schema.names:
            continue
        vals = rb.column(name).to_pylist()
        times = rb.column("sim_time").cast("int64").to_pylist() if "sim_time" in rb.schema.names else [0] * len(vals)
        rows.extend(zip(times, vals))
    rows.sort(key=lambda r: r[0])
    return rows


def verify(path: Path) -> subprocess.CompletedProcess:
    return subprocess.run([str(RERUN), "rrd", "verify", str(path)], capture_output=True, text=True, timeout=60)
