"""TUM trajectory files: exact nanoseconds, byte-stable round trip, errors naming file and line."""

from __future__ import annotations

import numpy as np
import pytest

from navlog.errors import NavlogError
from navlog.replay.io.tum import (
    format_rows,
    format_seconds,
    parse_seconds_ns,
    parse_tum,
    read_tum,
    write_poses,
    write_tum,
)


def test_seconds_are_exact_nanoseconds():
    assert parse_seconds_ns("1700000000.123456789") == 1_700_000_000_123_456_789  # beyond float64 precision
    assert parse_seconds_ns("12") == 12_000_000_000
    assert parse_seconds_ns("0.5") == 500_000_000
    assert parse_seconds_ns("1.5e-3") == 1_500_000
    assert format_seconds(1_700_000_000_000_000_001) == "1700000000.000000001"
    assert format_seconds(-1_500_000_000) == "-1.500000000"


def test_round_trip_is_exact_and_byte_stable(tmp_path):
    times = np.array([1_700_000_000_000_000_001, 1_700_000_000_100_000_000, 1_700_000_001_999_999_999], dtype=np.int64)
    pos = np.array([[0.0, 0.0, 0.0], [1.25, -2.5, 0.125], [-3.000000001, 4.0, 0.0]])
    quats = np.array([[0, 0, 0, 1.0], [0, 0, np.sin(0.3), np.cos(0.3)], [0.5, 0.5, 0.5, 0.5]])
    p1 = write_tum(tmp_path / "a.tum", times, pos, quats)
    back = read_tum(p1)
    assert back.times_ns.dtype == np.int64
    assert np.array_equal(back.times_ns, times)
    assert np.allclose(back.positions, pos, atol=1e-9)
    assert np.allclose(back.quaternions, quats, atol=1e-9)
    p2 = write_tum(tmp_path / "b.tum", *back)
    assert p1.read_bytes() == p2.read_bytes()
    lines = p1.read_text().splitlines()
    assert lines[0].startswith("#")
    assert (
        lines[1]
        == "1700000000.000000001 0.000000000 0.000000000 0.000000000 0.000000000 0.000000000 0.000000000 1.000000000"
    )
    assert lines[3].split()[1] == "-3.000000001"


def test_write_creates_folders_and_poses_write_the_same_text(tmp_path):
    times = [0, 500_000_000]
    mats = np.tile(np.eye(4), (2, 1, 1))
    mats[1, :3, 3] = (1.0, -0.0, 2.0)
    p = write_tum(tmp_path / "a" / "b" / "t.tum", times, mats[:, :3, 3], np.tile([0, 0, 0, 1.0], (2, 1)))
    q = write_poses(tmp_path / "poses.tum", times, list(mats))
    assert p.read_text() == q.read_text()
    assert q.read_text().splitlines()[2] == (
        "0.500000000 1.000000000 0.000000000 2.000000000 0.000000000 0.000000000 0.000000000 1.000000000"
    )


def test_pose_quaternions_are_scipys_bit_for_bit(tmp_path):
    from scipy.spatial.transform import Rotation

    from navlog.replay.geometry import quat_from_rpy, quat_to_matrix

    poses = np.tile(np.eye(4), (4, 1, 1))
    poses[1, :3, :3] = quat_to_matrix(quat_from_rpy(0.1, -0.2, 2.5))
    poses[2, :3, :3] = np.diag([-1.0, -1.0, 1.0])  # a half turn: w = 0
    # a matrix SciPy first projects onto a rotation (an SVD): the file takes SciPy's result for it too
    poses[3, :3, :3] = [[1.0, 1e-6, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    for rows in (poses[:3], poses):
        text = write_poses(tmp_path / "p.tum", range(len(rows)), list(rows)).read_text()
        want = Rotation.from_matrix(rows[:, :3, :3]).as_quat(canonical=True)
        assert text == format_rows(range(len(rows)), rows[:, :3, 3], want)
    assert text.splitlines()[3].endswith(" 0.000000000 0.000000000 1.000000000 0.000000000")


def test_comments_blank_lines_and_tabs_are_accepted():
    traj = parse_tum("# header\n\n1.0\t1 2 3 0 0 0 1\n  2.0 4 5 6 0 0 0 1  \n")
    assert list(traj.times_ns) == [1_000_000_000, 2_000_000_000]
    assert traj.positions[1].tolist() == [4.0, 5.0, 6.0]


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("1.0 1 2 3 0 0 0 1\n2.0 1 2 3 0 0 1\n", r"traj\.tum:2: expected 8 numbers .* got 7"),
        ("# c\n1.0 1 2 x 0 0 0 1\n", r"traj\.tum:2: 'x' is not a number"),
        ("abc 1 2 3 0 0 0 1\n", r"traj\.tum:1: time 'abc' is not a number"),
        ("1.0 1 2 3 0 0 0 0\n", r"traj\.tum:1: quaternion .* is zero"),
        ("1.0 1 2 3 0 0 0 1e200\n", r"traj\.tum:1: quaternion .* too long to normalise"),  # its square overflows
        ("1.0 1 2 nan 0 0 0 1\n", r"traj\.tum:1: pose values must be finite"),
        ("2.0 1 2 3 0 0 0 1\n\n1.0 1 2 3 0 0 0 1\n", r"traj\.tum:3: time 1.0 s does not increase \(line 1"),
        ("# only a comment\n", r"traj\.tum: no poses"),
    ],
)
def test_bad_files_name_file_and_line(tmp_path, text, message):
    path = tmp_path / "traj.tum"
    path.write_text(text)
    with pytest.raises(NavlogError, match=message):
        read_tum(path)


def test_missing_file(tmp_path):
    with pytest.raises(NavlogError, match="no such trajectory file"):
        read_tum(tmp_path / "nope.tum")
