"""PointCloud2 <-> numpy: the layout navlog writes reads back, and a field outside the point is refused."""

from __future__ import annotations

import numpy as np
import pytest

from navlog.replay import messages
from navlog.replay.pointcloud import VELODYNE_POINT_STEP, cloud_dtype, make_cloud, read_points


def test_a_velodyne_cloud_reads_back_field_by_field():
    columns = {"x": np.array([1.5, -2.0]), "y": np.array([0.25, 3.0]), "z": np.array([0.0, -0.5])}
    columns["ring"] = np.array([3, 15])
    arr = read_points(make_cloud(1_000, "velodyne", columns))
    assert arr.dtype.itemsize == VELODYNE_POINT_STEP == 22
    assert arr["x"].tolist() == [1.5, -2.0] and arr["z"].tolist() == [0.0, -0.5] and arr["ring"].tolist() == [3, 15]


def _field(name: str, offset: int, datatype: int = 7, count: int = 1):
    return messages.msg_class(messages.POINT_FIELD)(name=name, offset=offset, datatype=datatype, count=count)


@pytest.mark.parametrize(
    ("offset", "count"),
    [
        (2_147_483_647, 1),  # numpy's own check overflows here: reading the field read outside the buffer
        (19, 1),  # 4 bytes from 19 end past 22
        (-4, 1),
        (16, 2),  # two floats from 16 end at 24
    ],
)
def test_a_field_outside_the_point_step_is_refused_by_name(offset, count):
    fields = [_field("x", 0), _field("y", 4), _field("z", offset, count=count)]
    with pytest.raises(
        ValueError, match=f"PointField 'z': {count} x float32 at offset {offset} lies outside point_step 22"
    ):
        cloud_dtype(fields, 22)


def test_fields_that_fill_the_point_exactly_are_kept():
    dt = cloud_dtype([_field("x", 0), _field("rgb", 14, count=2)], 22)  # two floats from 14 end at 22
    assert dt.itemsize == 22 and dt.fields["rgb"][1] == 14 and dt.fields["rgb"][0].shape == (2,)
