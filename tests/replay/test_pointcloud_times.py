"""Per-point times of real drivers' PointCloud2 layouts decoded to seconds after the header stamp."""

from __future__ import annotations

import numpy as np
import pytest

from navlog.replay.pointcloud import azimuth_times, point_times, read_points, time_field_name

STAMP_NS = 1_700_000_000_123_456_789  # a real clock reading (2023), not a round number
OFFSETS_S = np.array([0.0, 0.025, 0.05, 0.0999])


def cloud(field: str, dtype: str, values) -> np.ndarray:
    arr = np.zeros(len(values), dtype=[("x", "<f4"), ("y", "<f4"), ("z", "<f4"), (field, dtype)])
    arr[field] = values
    return arr


@pytest.mark.parametrize(
    ("driver", "field", "dtype", "values", "convention"),
    [
        ("ouster", "t", "<u4", np.round(OFFSETS_S * 1e9), "relative ns"),
        ("livox", "offset_time", "<u4", np.round(OFFSETS_S * 1e9), "relative ns"),
        ("velodyne", "time", "<f4", OFFSETS_S, "relative s"),
        ("hesai", "timestamp", "<f8", STAMP_NS * 1e-9 + OFFSETS_S, "absolute s"),
        ("ns clock", "time_offset", "<u8", STAMP_NS + np.round(OFFSETS_S * 1e9).astype(np.int64), "absolute ns"),
    ],
)
def test_driver_conventions_decode_to_seconds_after_the_stamp(driver, field, dtype, values, convention):
    arr = cloud(field, dtype, values)
    assert time_field_name(arr.dtype.names) == field
    out = point_times(arr, field, STAMP_NS)
    assert out.convention == convention and out.invalid == 0
    # float64 seconds since 1970 resolve ~0.24 us; float32 offsets ~4 ns at 0.1 s
    np.testing.assert_allclose(out.seconds, OFFSETS_S, atol=5e-7)


def test_velodyne_offsets_before_the_stamp_stay_negative():
    out = point_times(cloud("time", "<f4", -OFFSETS_S[::-1]), "time", STAMP_NS)
    np.testing.assert_allclose(out.seconds, -OFFSETS_S[::-1], atol=1e-7)


def test_non_finite_and_bit_flipped_times_are_nan_and_counted():
    values = np.array([0.0, 0.01, np.nan, np.inf, -np.inf, 3.0e30, 0.05, 0.09], dtype=np.float32)
    out = point_times(cloud("time", "<f4", values), "time", STAMP_NS)
    assert out.invalid == 4
    np.testing.assert_array_equal(np.isnan(out.seconds), [False, False, True, True, True, True, False, False])
    # a bit-flipped integer offset (2**31 ns = 2.1 s) is absurd for a sweep
    ns = np.round(OFFSETS_S * 1e9).astype(np.uint32)
    ns[1] |= np.uint32(1 << 31)
    out = point_times(cloud("t", "<u4", ns), "t", STAMP_NS)
    assert out.invalid == 1 and np.isnan(out.seconds[1])
    np.testing.assert_allclose(out.seconds[[0, 2, 3]], OFFSETS_S[[0, 2, 3]])


def test_field_lookup_order_and_explicit_names():
    assert time_field_name(("x", "y", "z", "intensity")) is None
    assert time_field_name(("x", "t", "timestamp")) == "t"
    assert time_field_name(("x", "t", "timestamp"), "timestamp") == "timestamp"
    assert time_field_name(("x", "t"), "time") is None
    with pytest.raises(ValueError, match="not a number"):
        point_times(np.zeros(2, dtype=[("time", "S4")]), "time", 0)


def test_azimuth_times_follow_the_head_turn():
    # straight behind is the start of the sweep, straight ahead the middle; a clockwise head
    # (seen from above, z up) turns from the back to the left side (+y) in a quarter sweep
    pts = np.array([[-1.0, 1e-9, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, -1.0, 0.0]])
    np.testing.assert_allclose(azimuth_times(pts, 0.1, clockwise=True), [0.0, 0.05, 0.025, 0.075], atol=1e-9)
    np.testing.assert_allclose(azimuth_times(pts, 0.1, clockwise=False), [0.1, 0.05, 0.075, 0.025], atol=1e-9)


def test_read_points_of_an_empty_cloud_has_no_times():
    from navlog.replay.pointcloud import make_cloud

    msg = make_cloud(0, "velodyne", {"x": np.zeros(0, np.float32)})
    arr = read_points(msg)
    assert len(point_times(arr, "time", 0).seconds) == 0


def test_azimuth_times_read_the_turn_and_start_from_the_point_order():
    # a head turning counterclockwise from 30 deg, 8 columns of 2 rings, stored in firing order
    az = np.deg2rad(30.0 + 45.0 * np.repeat(np.arange(8), 2))
    pts = np.stack([np.cos(az), np.sin(az), np.zeros_like(az)], axis=1)
    expected = 0.1 * np.repeat(np.arange(8), 2) / 8
    np.testing.assert_allclose(azimuth_times(pts, 0.1), expected, atol=1e-12)
    # the same head turning clockwise
    pts[:, 1] *= -1
    np.testing.assert_allclose(azimuth_times(pts, 0.1), expected, atol=1e-12)
    # an organized cloud's NaN points neither break the reading of the order nor get a time
    pts[3] = np.nan
    times = azimuth_times(pts, 0.1)
    assert np.isnan(times[3])
    np.testing.assert_allclose(np.delete(times, 3), np.delete(expected, 3), atol=1e-12)
