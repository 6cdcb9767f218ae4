"""Fast CDR decoders of the types a replay reads most (``tf2_msgs/msg/TFMessage``, ``nav_msgs/msg/Odometry``).

The type store's generated deserializer calls one function per nested type and unpacks field by field:
about 36 us per /tf message and 26 us per odometry message, about 0.4 s of a 2D mapping replay of the
138 s tour. These decoders read the same little-endian CDR with a few ``struct`` calls and build the
same message objects (the store's own classes; covariances as read-only float64 arrays over the bytes,
as the store makes them). A TFMessage also has a light form, ``messages.TFTransforms``: the same numbers
as tuples, no objects, for the subscribers that accept it (TF buffers).

``decoder(typename, store[, light=True])`` gives the decoder of a type, or None when there is none or when ``store``
defines the type (or one it contains) otherwise than the ROS 2 definitions these layouts assume. A
decoder raises ``ValueError`` (or ``struct.error``, ``UnicodeDecodeError``) on bytes it does not
accept — big-endian, truncated, a bad string or sequence length, trailing bytes — and the caller then
asks the store's deserializer, which decodes or rejects them as it always does.
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from typing import Any

import numpy as np

from navlog.replay import messages

_U32 = struct.Struct("<I")
_TIME = struct.Struct("<iI")  # builtin_interfaces/Time: sec, nanosec
_D6 = struct.Struct("<6d")
_D7 = struct.Struct("<7d")
_COV = 36  # float64 values of a 6x6 covariance
_HEADER = 4  # CDR encapsulation header (alignment counts from the end of it)

# the types each decoder builds, every one of which must keep its standard definition
USES = {
    messages.TF_MESSAGE: (
        "tf2_msgs/msg/TFMessage",
        "geometry_msgs/msg/TransformStamped",
        "std_msgs/msg/Header",
        "builtin_interfaces/msg/Time",
        "geometry_msgs/msg/Transform",
        "geometry_msgs/msg/Vector3",
        "geometry_msgs/msg/Quaternion",
    ),
    messages.ODOMETRY: (
        "nav_msgs/msg/Odometry",
        "std_msgs/msg/Header",
        "builtin_interfaces/msg/Time",
        "geometry_msgs/msg/PoseWithCovariance",
        "geometry_msgs/msg/Pose",
        "geometry_msgs/msg/Point",
        "geometry_msgs/msg/Quaternion",
        "geometry_msgs/msg/TwistWithCovariance",
        "geometry_msgs/msg/Twist",
        "geometry_msgs/msg/Vector3",
    ),
}


def _string(data: bytes, pos: int) -> tuple[str, int]:
    """A CDR string at payload offset ``pos`` (aligned to 4 here): its text and the offset after it."""
    pos = (pos + 3) & -4
    (size,) = _U32.unpack_from(data, _HEADER + pos)
    end = _HEADER + pos + 4 + size
    if size < 1 or end > len(data) or data[end - 1] != 0:
        raise ValueError(f"bad CDR string at offset {pos}")
    return data[end - size : end - 1].decode(), pos + 4 + size


def _check(data: bytes) -> None:
    if len(data) < _HEADER or data[0] != 0 or data[1] != 1:
        raise ValueError("not little-endian CDR")


def _check_end(data: bytes, pos: int) -> None:
    if pos + _HEADER + 3 < len(data):  # the store's rule: at most 3 bytes of padding after the message
        raise ValueError("CDR message size mismatch")


def _tf_parse(data: bytes, max_len: int) -> list[tuple]:
    """A TFMessage's transforms as ``(sec, nanosec, frame_id, child_frame_id, tx, ty, tz, qx, qy, qz, qw)``."""
    _check(data)
    (count,) = _U32.unpack_from(data, _HEADER)
    pos = 4
    if pos + count > len(data) - _HEADER or count > max_len:
        raise ValueError(f"bad sequence length {count}")
    out = []
    for _ in range(count):
        pos = (pos + 3) & -4
        sec, nanosec = _TIME.unpack_from(data, _HEADER + pos)
        frame_id, pos = _string(data, pos + 8)
        child, pos = _string(data, pos)
        pos = (pos + 7) & -8
        out.append((sec, nanosec, frame_id, child, *_D7.unpack_from(data, _HEADER + pos)))
        pos += 56
    _check_end(data, pos)
    return out


def _tf_decoder(store: Any) -> Callable[[bytes], Any]:
    c = store.types
    tf_message, stamped = c["tf2_msgs/msg/TFMessage"], c["geometry_msgs/msg/TransformStamped"]
    header, time = c["std_msgs/msg/Header"], c["builtin_interfaces/msg/Time"]
    transform, vector3, quaternion = (
        c["geometry_msgs/msg/Transform"],
        c["geometry_msgs/msg/Vector3"],
        c["geometry_msgs/msg/Quaternion"],
    )
    max_len = store.max_sequence_length

    def decode(data: bytes) -> Any:
        return tf_message(
            [
                stamped(
                    header(time(sec, nanosec), frame_id),
                    child,
                    transform(vector3(tx, ty, tz), quaternion(qx, qy, qz, qw)),
                )
                for sec, nanosec, frame_id, child, tx, ty, tz, qx, qy, qz, qw in _tf_parse(data, max_len)
            ]
        )

    return decode


def _tf_light_decoder(store: Any) -> Callable[[bytes], Any]:
    max_len = store.max_sequence_length

    def decode(data: bytes) -> Any:
        return messages.TFTransforms(
            [
                (frame_id, child, sec * 1_000_000_000 + nanosec, tx, ty, tz, qx, qy, qz, qw)
                for sec, nanosec, frame_id, child, tx, ty, tz, qx, qy, qz, qw in _tf_parse(data, max_len)
            ]
        )

    return decode


def _odometry_decoder(store: Any) -> Callable[[bytes], Any]:
    c = store.types
    odometry, header, time = c["nav_msgs/msg/Odometry"], c["std_msgs/msg/Header"], c["builtin_interfaces/msg/Time"]
    pose_cov, pose, point = (
        c["geometry_msgs/msg/PoseWithCovariance"],
        c["geometry_msgs/msg/Pose"],
        c["geometry_msgs/msg/Point"],
    )
    quaternion, twist_cov, twist, vector3 = (
        c["geometry_msgs/msg/Quaternion"],
        c["geometry_msgs/msg/TwistWithCovariance"],
        c["geometry_msgs/msg/Twist"],
        c["geometry_msgs/msg/Vector3"],
    )

    def decode(data: bytes) -> Any:
        _check(data)
        sec, nanosec = _TIME.unpack_from(data, _HEADER)
        frame_id, pos = _string(data, 8)
        child, pos = _string(data, pos)
        pos = (pos + 7) & -8
        px, py, pz, qx, qy, qz, qw = _D7.unpack_from(data, _HEADER + pos)
        pos += 56
        pcov = np.frombuffer(data, dtype=np.float64, count=_COV, offset=_HEADER + pos)
        pos += 8 * _COV
        lx, ly, lz, ax, ay, az = _D6.unpack_from(data, _HEADER + pos)
        pos += 48
        tcov = np.frombuffer(data, dtype=np.float64, count=_COV, offset=_HEADER + pos)
        pos += 8 * _COV
        _check_end(data, pos)
        return odometry(
            header(time(sec, nanosec), frame_id),
            child,
            pose_cov(pose(point(px, py, pz), quaternion(qx, qy, qz, qw)), pcov),
            twist_cov(twist(vector3(lx, ly, lz), vector3(ax, ay, az)), tcov),
        )

    return decode


_FACTORIES = {messages.TF_MESSAGE: _tf_decoder, messages.ODOMETRY: _odometry_decoder}
_LIGHT_FACTORIES = {messages.TF_MESSAGE: _tf_light_decoder}


def decoder(typename: str, store: Any, *, light: bool = False) -> Callable[[bytes], Any] | None:
    """The fast decoder of ``typename`` building ``store``'s message objects, or with ``light`` the type's
    light form (``messages.TFTransforms``), or None (see the module docstring)."""
    factory = (_LIGHT_FACTORIES if light else _FACTORIES).get(typename)
    if factory is None:
        return None
    base = messages.typestore().fielddefs
    if any(store.fielddefs.get(name) != base[name] for name in USES[typename]):
        return None
    return factory(store)
