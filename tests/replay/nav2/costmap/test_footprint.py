"""The robot footprint: radii of the 16-gon and of a square."""

from __future__ import annotations

import math

import pytest

from navlog.replay.nav2.costmap import footprint_radii, radius_footprint


def test_footprint_radii():
    inscribed, circumscribed = footprint_radii(radius_footprint(0.34))
    assert inscribed == pytest.approx(0.9808 * 0.34, abs=1e-4)
    assert circumscribed == pytest.approx(0.34)
    assert footprint_radii([(0.2, 0.2), (0.2, -0.2), (-0.2, -0.2), (-0.2, 0.2)]) == pytest.approx(
        (0.2, 0.2 * math.sqrt(2))
    )
