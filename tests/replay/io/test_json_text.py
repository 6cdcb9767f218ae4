"""JSON outputs never hold NaN or Infinity: null, and the path and kind of each under non_finite_values."""

from __future__ import annotations

import json
import math

import numpy as np

from navlog.analysis.metrics.report import to_json as metrics_json
from navlog.replay.io.json_text import dumps


def test_a_finite_document_is_written_as_json_writes_it():
    doc = {"b": [1.5, (2, 3)], "a": {"x": np.float64(0.25), "n": None, "s": "nan"}}
    for options in ({}, {"indent": 2, "sort_keys": True}):
        assert dumps(doc, **options) == json.dumps(doc, **options)


def test_nan_and_infinity_are_null_and_named():
    doc = {"ate": {"rmse_m": math.nan, "per_pose": [0.1, math.inf, -math.inf]}, "poses": 3}
    text = dumps(doc, indent=2, sort_keys=True)

    def refuse(token: str) -> None:
        raise AssertionError(f"{token} in the JSON text")

    back = json.loads(text, parse_constant=refuse)
    assert back["ate"] == {"rmse_m": None, "per_pose": [0.1, None, None]} and back["poses"] == 3
    assert back["non_finite_values"] == {
        "ate.rmse_m": "NaN, written as null",
        "ate.per_pose[1]": "+inf, written as null",
        "ate.per_pose[2]": "-inf, written as null",
    }
    assert doc["ate"]["rmse_m"] != doc["ate"]["rmse_m"]  # the caller's document is left as it was


def test_metrics_json_of_a_nan_figure_is_valid_json():
    # json.dumps(..., allow_nan=False) raised ValueError here: a traceback instead of metrics.json
    text = metrics_json({"ate": {"rmse_m": float("nan")}, "scans": 10})
    assert json.loads(text) == {
        "ate": {"rmse_m": None},
        "scans": 10,
        "non_finite_values": {"ate.rmse_m": "NaN, written as null"},
    }
