"""map_server I/O and OccupancyGrid conversion of OccupancyMap."""

from __future__ import annotations

import numpy as np
import pytest

from navlog.errors import ConfigError
from navlog.replay import messages as m
from navlog.replay.io.map_server import load_map, save_map
from navlog.replay.occupancy_map import OccupancyMap


def _grid() -> OccupancyMap:
    data = np.zeros((4, 6), dtype=np.int8)
    data[0, 0] = 100  # lowest y, lowest x
    data[3, 5] = -1  # highest y, highest x
    data[1, 2] = 100
    data[2, :] = -1
    return OccupancyMap(data=data, resolution=0.05, origin=(-1.25, 2.5, 0.3))


def _write_pgm(path, pixels: np.ndarray) -> None:
    h, w = pixels.shape
    path.write_bytes(f"P5\n{w} {h}\n255\n".encode() + pixels.astype(np.uint8).tobytes())


def test_world_cell_conversions():
    grid = _grid()
    assert grid.world_to_cell(-1.25, 2.5) == (0, 0)
    assert grid.world_to_cell(-1.25 + 0.049, 2.5 + 0.051) == (0, 1)
    assert grid.world_to_cell(-1.26, 2.5) == (-1, 0)
    assert grid.contains(*grid.world_to_cell(-1.26, 2.5)) is False
    assert grid.cell_to_world(0, 0) == pytest.approx((-1.225, 2.525))
    assert grid.cell_to_world(5, 3) == pytest.approx((-1.25 + 5.5 * 0.05, 2.5 + 3.5 * 0.05))
    mx, my = grid.world_to_cell(np.array([-1.2, -1.0]), np.array([2.5, 2.6]))
    assert mx.tolist() == [1, 5] and my.tolist() == [0, 2]
    assert grid.value_at(-1.24, 2.51) == 100
    assert grid.value_at(10.0, 2.51) is None


def test_save_load_round_trip_is_exact(tmp_path):
    grid = _grid()
    yaml_path, pgm_path = save_map(grid, tmp_path / "room.yaml")
    assert pgm_path.name == "room.pgm"
    assert pgm_path.read_bytes().startswith(b"P5\n")
    back = load_map(yaml_path)
    assert back == grid
    assert back.data.dtype == np.int8


def test_saved_pixels_are_trinary_and_flipped(tmp_path):
    grid = _grid()
    _, pgm_path = save_map(grid, tmp_path / "room.yaml")
    raw = pgm_path.read_bytes()
    pixels = np.frombuffer(raw[-24:], dtype=np.uint8).reshape(4, 6)
    # image row 0 is the top: map row 3
    assert pixels[0, 5] == 205 and pixels[0, 0] == 254
    assert pixels[3, 0] == 0  # map (0, 0) occupied, bottom-left of the image
    assert pixels[1].tolist() == [205] * 6  # map row 2 unknown
    assert set(np.unique(pixels).tolist()) == {0, 205, 254}


def test_save_is_deterministic(tmp_path):
    a = save_map(_grid(), tmp_path / "a" / "m.yaml")
    b = save_map(_grid(), tmp_path / "b" / "m.yaml")
    assert a[0].read_bytes() == b[0].read_bytes()
    assert a[1].read_bytes() == b[1].read_bytes()


def test_free_threshold_trap(tmp_path):
    """A 205 pixel (occ 0.19608) is unknown with free_thresh 0.196 but free with 0.25."""
    _write_pgm(tmp_path / "m.pgm", np.array([[205, 254, 0]]))
    for free, expected in ((0.196, [-1, 0, 100]), (0.25, [0, 0, 100])):
        (tmp_path / "m.yaml").write_text(
            f"image: m.pgm\nresolution: 0.1\norigin: [0, 0, 0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: {free}\n"
        )
        assert load_map(tmp_path / "m.yaml").data[0].tolist() == expected
    # what save_map writes reloads 205 as unknown
    grid = OccupancyMap(np.array([[-1, 0, 100]], dtype=np.int8), 0.1)
    assert load_map(save_map(grid, tmp_path / "s.yaml")[0]).data[0].tolist() == [-1, 0, 100]


def test_load_modes_known_pixels(tmp_path):
    # occ = 1 - p/255: 0 -> 1.0, 255 -> 0.0, 128 -> 0.498, 100 -> 0.608, 230 -> 0.098
    _write_pgm(tmp_path / "m.pgm", np.array([[0, 255, 128, 100, 230], [50, 60, 70, 80, 90]]))

    def load(extra):
        (tmp_path / "m.yaml").write_text(
            "image: m.pgm\nresolution: 0.5\norigin: [1.0, 2.0, 0.0]\n"
            "occupied_thresh: 0.65\nfree_thresh: 0.196\n" + extra
        )
        return load_map(tmp_path / "m.yaml").data

    tri = load("negate: 0\nmode: trinary\n")
    # image row 0 (top) becomes map row 1
    assert tri[1].tolist() == [100, 0, -1, -1, 0]
    scale = load("negate: 0\nmode: scale\n")
    # 128: rint((0.49804 - 0.196) / 0.454 * 100) = 67; 100: rint((0.60784-0.196)/0.454*100) = 91
    assert scale[1].tolist() == [100, 0, 67, 91, 0]
    neg = load("negate: 1\nmode: trinary\n")
    assert neg[1].tolist() == [0, 100, -1, -1, 100]
    raw = load("negate: 0\nmode: raw\n")
    assert raw[1].tolist() == [0, -1, -1, 100, -1]
    assert raw[0].tolist() == [50, 60, 70, 80, 90]


def test_load_rgb_png_uses_mean_shade(tmp_path):
    from PIL import Image

    rgb = np.zeros((1, 2, 3), dtype=np.uint8)
    rgb[0, 0] = (255, 255, 255)
    rgb[0, 1] = (0, 0, 30)  # mean 10 -> occ 0.96
    Image.fromarray(rgb, "RGB").save(tmp_path / "m.png")
    (tmp_path / "m.yaml").write_text(
        "image: m.png\nresolution: 0.1\norigin: [0, 0, 0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.25\n"
    )
    assert load_map(tmp_path / "m.yaml").data.tolist() == [[0, 100]]


@pytest.mark.parametrize(
    "text, words",
    [
        ("image: m.pgm\norigin: [0, 0, 0]\n", ["missing key 'resolution'"]),
        ("image: m.pgm\nresolution: 0.1\norigin: [0, 0]\n", ["'origin'", "[x, y, yaw]"]),
        ("image: m.pgm\nresolution: 0.1\norigin: [0, 0, 0]\nmode: trinery\n", ["'mode'", "trinary"]),
        ("image: m.pgm\nresolution: 0.1\norigin: [0, 0, 0]\nfree_thres: 0.2\n", ["free_thres", "free_thresh"]),
        ("image: gone.pgm\nresolution: 0.1\norigin: [0, 0, 0]\n", ["m.yaml: its image 'gone.pgm' is not found"]),
        ("image: m.pgm\nresolution: 0.1: 2\norigin: [0, 0, 0]\n", ["m.yaml", "line 2"]),
        ("image: m.pgm\nresolution: 0.1\norigin: [.nan, 0, 0]\n", ["'origin'", "finite"]),
        ("image: m.pgm\nresolution: .inf\norigin: [0, 0, 0]\n", ["'resolution'", "finite"]),
        ("image: m.pgm\nresolution: 1" + "0" * 400 + "\norigin: [0, 0, 0]\n", ["'resolution'", "finite"]),
        ("image: m.pgm\nresolution: 0.1\norigin: [0, 1" + "0" * 400 + ", 0]\n", ["'origin'", "finite"]),
    ],
)
def test_bad_map_yaml_names_file_and_key(tmp_path, text, words):
    _write_pgm(tmp_path / "m.pgm", np.array([[0]]))
    (tmp_path / "m.yaml").write_text(text)
    with pytest.raises(ConfigError) as exc:
        load_map(tmp_path / "m.yaml")
    message = str(exc.value)
    for word in words:
        assert word in message


@pytest.mark.parametrize(
    ("size", "said"),
    [
        ("60000 60000", "cannot read map image"),  # 3.6e9 pixels: the image library's own bomb guard
        ("11000 11000", "11000 x 11000 pixels, above the bound"),  # 1.21e8: below its guard, above navlog's
    ],
)
def test_a_map_image_whose_header_claims_billions_of_pixels_is_refused_before_reading(tmp_path, size, said):
    (tmp_path / "m.pgm").write_bytes(b"P5\n" + size.encode() + b"\n255\n" + b"\xfe" * 1000)
    (tmp_path / "m.yaml").write_text("image: m.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n")
    with pytest.raises(ConfigError, match=said):
        load_map(tmp_path / "m.yaml")


def test_msg_round_trip_through_cdr():
    grid = _grid()
    msg = grid.to_msg(1_500_000_000)
    assert msg.header.frame_id == "map" and msg.info.width == 6 and msg.info.height == 4
    assert msg.data[0] == 100 and msg.data[6 * 3 + 5] == -1  # row-major, row 0 = lowest y
    back = OccupancyMap.from_msg(m.deserialize(m.serialize(msg, m.OCCUPANCY_GRID), m.OCCUPANCY_GRID))
    assert back.resolution == 0.05
    assert back.origin == pytest.approx(grid.origin)
    assert np.array_equal(back.data, grid.data)
