"""Angle differences as the MPPI critics take them, the sign spelled out in the name."""

from __future__ import annotations

from typing import Any

import numpy as np


def signed_angle_from_to(a_from: Any, a_to: Any) -> Any:
    """Nav2's ``shortest_angular_distance(a_from, a_to)``: ``a_to - a_from`` wrapped to [-pi, pi), element-wise."""
    t = np.fmod(np.asarray(a_to) - np.asarray(a_from) + np.pi, 2.0 * np.pi)
    return np.where(t < 0.0, t + np.pi, t - np.pi)
