"""map_server files: an ``OccupancyMap`` (``navlog.replay.occupancy_map``) to and from YAML + image.

map_server files (``load_map`` / ``save_map``): a YAML with image, resolution, origin, free_thresh,
occupied_thresh, negate, mode (trinary | scale | raw). Image rows are stored top-down, so they are
flipped on load and on save. ``save_map`` writes a binary PGM (P5) in trinary form -- free 254,
occupied 0, unknown 205 -- with thresholds chosen so the file reloads exactly as saved (see
``SAVE_FREE_THRESH``).
"""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np

from navlog.errors import ConfigError
from navlog.replay.config import load_yaml, suggest
from navlog.replay.io.atomic import WriteError, write_file
from navlog.replay.limits import MAX_GRID_CELLS, MAX_TRANSLATION_M
from navlog.replay.occupancy_map import FREE, OCCUPIED, UNKNOWN, OccupancyMap

# Pixel values written by the trinary saver.
PIXEL_FREE = 254
PIXEL_OCCUPIED = 0
PIXEL_UNKNOWN = 205

# Thresholds written next to saved maps. A 205 pixel has occupancy 1 - 205/255 = 0.19608: with the
# map_saver default free_thresh 0.25 it would reload as FREE. 0.196 keeps it unknown, while a free
# pixel (254: occ 0.0039) stays free and an occupied one (0: occ 1.0) stays occupied.
SAVE_FREE_THRESH = 0.196
SAVE_OCCUPIED_THRESH = 0.65

# Defaults when a map YAML omits them (map_saver's defaults).
DEFAULT_FREE_THRESH = 0.25
DEFAULT_OCCUPIED_THRESH = 0.65

MODES = ("trinary", "scale", "raw")


# ---------------------------------------------------------------- map_server I/O


def _read_image(path: Path) -> np.ndarray:
    """Pixels as float shade in 0..1, shape (rows, cols), row 0 = top of the image."""
    if not path.is_file():
        raise ConfigError(f"{path}: map image not found")
    try:
        from PIL import Image

        with warnings.catch_warnings():  # the bound below is navlog's, not the image library's warning
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)
            img = Image.open(path)
        with img:
            if img.width * img.height > MAX_GRID_CELLS:  # checked before the pixels are read
                raise ConfigError(
                    f"{path}: the map image is {img.width} x {img.height} pixels, above the bound of "
                    f"{MAX_GRID_CELLS:.0e} cells (a 500 m square at 5 cm); is its header right?"
                )
            img.load()
            if img.mode in ("I;16", "I;16B", "I;16L", "I"):
                arr = np.asarray(img, dtype=np.float64)
                maxval = 65535.0 if arr.max(initial=0) > 255 else 255.0
                return arr / maxval
            shades = img if img.mode in ("L", "RGB") else img.convert("RGBA" if "A" in img.mode else "RGB")
            arr = np.asarray(shades, dtype=np.float64)
    except (OSError, ValueError, MemoryError, Image.DecompressionBombError) as exc:
        raise ConfigError(f"{path}: cannot read map image: {exc}") from None
    if arr.ndim == 3:
        arr = arr[:, :, :3].mean(axis=2)  # shade = mean of RGB, alpha ignored
    return arr / 255.0


def _finite_number(value) -> bool:
    """A YAML number (not a bool) that is a finite float (an integer of 400 digits is none)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return False
    try:
        return math.isfinite(float(value))
    except OverflowError:
        return False


def _number(doc: dict, key: str, path: Path, default: float | None = None) -> float:
    if key not in doc:
        if default is None:
            raise ConfigError(f"{path}: missing key '{key}'")
        return default
    value = doc[key]
    if not _finite_number(value):
        raise ConfigError(f"{path}: key '{key}' must be a finite number, got {value!r}")
    return float(value)


def load_map(yaml_path: str | Path) -> OccupancyMap:
    """Load a map_server map (YAML + image) as an OccupancyMap."""
    path = Path(yaml_path)
    doc = load_yaml(path)
    if not isinstance(doc, dict):
        raise ConfigError(f"{path}: a map YAML must be a mapping with keys image, resolution, origin")
    known = ("image", "resolution", "origin", "free_thresh", "occupied_thresh", "negate", "mode")
    for key in doc:
        if key not in known:
            raise ConfigError(f"{path}: unknown key '{key}'{suggest(str(key), known)}")
    if "image" not in doc:
        raise ConfigError(f"{path}: missing key 'image'")
    if not isinstance(doc["image"], str) or not doc["image"]:
        raise ConfigError(f"{path}: key 'image' must be a file name, got {doc['image']!r}")
    resolution = _number(doc, "resolution", path)
    if resolution <= 0.0:
        raise ConfigError(f"{path}: key 'resolution' must be > 0, got {resolution}")
    origin = doc.get("origin")
    if origin is None:
        raise ConfigError(f"{path}: missing key 'origin'")
    if not isinstance(origin, list) or len(origin) != 3 or not all(_finite_number(v) for v in origin):
        raise ConfigError(f"{path}: key 'origin' must be [x, y, yaw], finite numbers, got {origin!r}")
    if not max(abs(origin[0]), abs(origin[1])) <= MAX_TRANSLATION_M:
        raise ConfigError(f"{path}: key 'origin' {origin!r} lies farther than {MAX_TRANSLATION_M:g} m: metres expected")
    free = _number(doc, "free_thresh", path, DEFAULT_FREE_THRESH)
    occupied = _number(doc, "occupied_thresh", path, DEFAULT_OCCUPIED_THRESH)
    if not 0.0 <= free < occupied <= 1.0:
        raise ConfigError(
            f"{path}: keys 'free_thresh' ({free}) and 'occupied_thresh' ({occupied}) "
            "must satisfy 0 <= free_thresh < occupied_thresh <= 1"
        )
    negate_raw = doc.get("negate", 0)
    if negate_raw not in (0, 1, True, False):
        raise ConfigError(f"{path}: key 'negate' must be 0 or 1, got {negate_raw!r}")
    negate = bool(negate_raw)
    mode = doc.get("mode", "trinary")
    if mode not in MODES:
        raise ConfigError(f"{path}: key 'mode' must be one of {', '.join(MODES)}{suggest(str(mode), MODES)}")

    image_path = Path(doc["image"])
    if not image_path.is_absolute():
        image_path = path.parent / image_path
    if not image_path.is_file():
        raise ConfigError(
            f"{path}: its image {doc['image']!r} is not found ({image_path}); a relative image path starts at the "
            "map YAML's folder"
        )
    shade = _read_image(image_path)[::-1, :]  # image row 0 is the top (largest y)
    occ = shade if negate else 1.0 - shade

    data = np.full(shade.shape, UNKNOWN, dtype=np.int8)
    if mode == "trinary":
        data[occ > occupied] = OCCUPIED
        data[occ < free] = FREE
    elif mode == "scale":
        data[occ > occupied] = OCCUPIED
        data[occ < free] = FREE
        between = (occ >= free) & (occ <= occupied)
        data[between] = np.rint((occ[between] - free) / (occupied - free) * 100.0).astype(np.int8)
    else:  # raw
        raw = np.rint(shade * 255.0)
        ok = raw <= 100
        data[ok] = raw[ok].astype(np.int8)
    x, y, yaw = (float(v) for v in origin)
    return OccupancyMap(data=data, resolution=resolution, origin=(x, y, yaw))


def trinary_pixels(
    data: np.ndarray, free_thresh: float = SAVE_FREE_THRESH, occupied_thresh: float = SAVE_OCCUPIED_THRESH
) -> np.ndarray:
    """map_saver's trinary pixels for occupancy values (same layout, no flip)."""
    values = np.asarray(data, dtype=np.int16)
    pixels = np.full(values.shape, PIXEL_UNKNOWN, dtype=np.uint8)
    known = values >= 0
    pixels[known & (values <= int(np.rint(free_thresh * 100)))] = PIXEL_FREE
    pixels[known & (values >= int(np.rint(occupied_thresh * 100)))] = PIXEL_OCCUPIED
    return pixels


def save_map(occ_map: OccupancyMap, yaml_path: str | Path) -> tuple[Path, Path]:
    """Write ``NAME.yaml`` + ``NAME.pgm`` (binary P5, trinary). Returns (yaml path, image path).

    Cells <= 20 become free, >= 65 occupied, the rest (and -1) unknown, so a map holding only
    -1 / 0 / 100 reloads exactly as it was.
    """
    path = Path(yaml_path)
    image_path = path.with_suffix(".pgm")
    pixels = trinary_pixels(occ_map.data)[::-1, :]  # top row of the image = largest y
    header = f"P5\n# CREATOR: navlog {occ_map.resolution:.3f} m/pix\n{occ_map.width} {occ_map.height}\n255\n"
    doc = (
        f"image: {image_path.name}\n"
        f"mode: trinary\n"
        f"resolution: {_fmt(occ_map.resolution)}\n"
        f"origin: [{', '.join(_fmt(v) for v in occ_map.origin)}]\n"
        f"negate: 0\n"
        f"occupied_thresh: {SAVE_OCCUPIED_THRESH}\n"
        f"free_thresh: {SAVE_FREE_THRESH}\n"
    )
    try:  # the image first: a YAML that appears names a whole image
        path.parent.mkdir(parents=True, exist_ok=True)
        write_file(image_path, header.encode("ascii") + np.ascontiguousarray(pixels).tobytes())
        write_file(path, doc.encode())
    except OSError as exc:
        raise WriteError(path, f"cannot write map: {exc.strerror}") from None
    return path, image_path


def _fmt(value: float) -> str:
    """Shortest decimal text that reloads as the same float (YAML reads it back exactly)."""
    text = repr(float(value))
    return "0.0" if text == "-0.0" else text
