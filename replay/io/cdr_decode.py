"""Fast CDR decoders of the types a replay reads most: ``tf2_msgs/msg/TFMessage``, ``nav_msgs/msg/Odometry``,
``sensor_msgs/msg/Imu``, ``sensor_msgs/msg/LaserScan``, ``geometry_msgs/msg/Twist`` and ``TwistStamped``.

The type store's generated deserializer calls one function per nested type and unpacks field by field.
These decoders read the bytes with the type's compiled ``cdr.Layout`` and build the same message objects,
the store's own classes (arrays as read-only NumPy arrays over the bytes, as the store makes them): the
byte layout of each type is the one ``cdr`` compiles from the type store's definition, the same that
writes the logs. A stream repeats a few shapes (the same frames, the same scan length), so messages are
read with ``cdr.RepeatedShapes``: one ``struct`` call for a message whose shape was seen before, the
layout walked (``Layout.decode``) for a new one. A TFMessage also has a light form,
``messages.TFTransforms``: the same numbers as tuples, no objects, for the subscribers that accept it
(TF buffers).

The other way, ``encoder(typename)`` gives a writer the CDR bytes of a ``geometry_msgs/msg/Twist`` (the
safety filters' outputs) with one ``struct`` call (``Layout.packer``), the bytes ``messages.serialize``
makes.

``decoder(typename, store[, light=True])`` gives the decoder of a type, or None when there is none or when
``store`` defines the type (or one it contains) otherwise than the ROS 2 definitions the layouts are
compiled from. A decoder raises ``ValueError`` (or ``struct.error``, ``UnicodeDecodeError``) on bytes it
does not accept — big-endian, truncated, a bad string or sequence length, trailing bytes — and the caller
then asks the store's deserializer, which decodes or rejects them as it always does.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from typing import Any

from navlog.replay import messages
from navlog.replay.io.cdr import RepeatedShapes, layout


def _shapes(typename: str, store: Any) -> Callable[[bytes], tuple[tuple[Any, ...], list[str], list[Any]]]:
    return RepeatedShapes(layout(typename), store.max_sequence_length).read


def _tf_decoder(store: Any) -> Callable[[bytes], Any]:
    c = store.types
    tf_message, stamped = c["tf2_msgs/msg/TFMessage"], c["geometry_msgs/msg/TransformStamped"]
    header, time = c["std_msgs/msg/Header"], c["builtin_interfaces/msg/Time"]
    transform, vector3, quaternion = (
        c["geometry_msgs/msg/Transform"],
        c["geometry_msgs/msg/Vector3"],
        c["geometry_msgs/msg/Quaternion"],
    )
    read = _shapes(messages.TF_MESSAGE, store)

    def decode(data: bytes) -> Any:
        v, frames, _ = read(data)  # per transform: sec, nanosec, x, y, z, qx, qy, qz, qw; frame_id, child_frame_id
        return tf_message(
            [
                stamped(
                    header(time(v[k], v[k + 1]), frames[j]),
                    frames[j + 1],
                    transform(
                        vector3(v[k + 2], v[k + 3], v[k + 4]), quaternion(v[k + 5], v[k + 6], v[k + 7], v[k + 8])
                    ),
                )
                for j, k in zip(range(0, len(frames), 2), range(0, len(v), 9))
            ]
        )

    return decode


def _tf_light_decoder(store: Any) -> Callable[[bytes], Any]:
    read = _shapes(messages.TF_MESSAGE, store)

    def decode(data: bytes) -> Any:
        v, frames, _ = read(data)
        return messages.TFTransforms(
            [
                (frames[j], frames[j + 1], v[k] * 1_000_000_000 + v[k + 1], *v[k + 2 : k + 9])
                for j, k in zip(range(0, len(frames), 2), range(0, len(v), 9))
            ]
        )

    return decode


def _imu_decoder(store: Any) -> Callable[[bytes], Any]:
    c = store.types
    imu, header, time = c["sensor_msgs/msg/Imu"], c["std_msgs/msg/Header"], c["builtin_interfaces/msg/Time"]
    quaternion, vector3 = c["geometry_msgs/msg/Quaternion"], c["geometry_msgs/msg/Vector3"]
    read = _shapes(messages.IMU, store)

    def decode(data: bytes) -> Any:
        (sec, nanosec, qx, qy, qz, qw, wx, wy, wz, ax, ay, az), (frame_id,), (cov_q, cov_w, cov_a) = read(data)
        return imu(
            header(time(sec, nanosec), frame_id),
            quaternion(qx, qy, qz, qw),
            cov_q,
            vector3(wx, wy, wz),
            cov_w,
            vector3(ax, ay, az),
            cov_a,
        )

    return decode


def _laser_scan_decoder(store: Any) -> Callable[[bytes], Any]:
    c = store.types
    scan, header, time = c["sensor_msgs/msg/LaserScan"], c["std_msgs/msg/Header"], c["builtin_interfaces/msg/Time"]
    read = _shapes(messages.LASER_SCAN, store)

    def decode(data: bytes) -> Any:
        (sec, nanosec, *values), (frame_id,), (ranges, intensities) = read(data)  # values: angle_min .. range_max
        return scan(header(time(sec, nanosec), frame_id), *values, ranges, intensities)

    return decode


def _twist_decoder(store: Any) -> Callable[[bytes], Any]:
    c = store.types
    twist, vector3 = c["geometry_msgs/msg/Twist"], c["geometry_msgs/msg/Vector3"]
    read = _shapes(messages.TWIST, store)

    def decode(data: bytes) -> Any:
        (lx, ly, lz, ax, ay, az), _, _ = read(data)
        return twist(vector3(lx, ly, lz), vector3(ax, ay, az))

    return decode


def _twist_stamped_decoder(store: Any) -> Callable[[bytes], Any]:
    c = store.types
    stamped, header, time = (
        c["geometry_msgs/msg/TwistStamped"],
        c["std_msgs/msg/Header"],
        c["builtin_interfaces/msg/Time"],
    )
    twist, vector3 = c["geometry_msgs/msg/Twist"], c["geometry_msgs/msg/Vector3"]
    read = _shapes(messages.TWIST_STAMPED, store)

    def decode(data: bytes) -> Any:
        (sec, nanosec, lx, ly, lz, ax, ay, az), (frame_id,), _ = read(data)
        return stamped(header(time(sec, nanosec), frame_id), twist(vector3(lx, ly, lz), vector3(ax, ay, az)))

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
    read = _shapes(messages.ODOMETRY, store)

    def decode(data: bytes) -> Any:
        numbers, (frame_id, child), (pcov, tcov) = read(data)
        sec, nanosec, px, py, pz, qx, qy, qz, qw, lx, ly, lz, ax, ay, az = numbers
        return odometry(
            header(time(sec, nanosec), frame_id),
            child,
            pose_cov(pose(point(px, py, pz), quaternion(qx, qy, qz, qw)), pcov),
            twist_cov(twist(vector3(lx, ly, lz), vector3(ax, ay, az)), tcov),
        )

    return decode


_FACTORIES = {
    messages.TF_MESSAGE: _tf_decoder,
    messages.ODOMETRY: _odometry_decoder,
    messages.IMU: _imu_decoder,
    messages.LASER_SCAN: _laser_scan_decoder,
    messages.TWIST: _twist_decoder,
    messages.TWIST_STAMPED: _twist_stamped_decoder,
}
_LIGHT_FACTORIES = {messages.TF_MESSAGE: _tf_light_decoder}


def decoder(typename: str, store: Any, *, light: bool = False) -> Callable[[bytes], Any] | None:
    """The fast decoder of ``typename`` building ``store``'s message objects, or with ``light`` the type's
    light form (``messages.TFTransforms``), or None (see the module docstring)."""
    factory = (_LIGHT_FACTORIES if light else _FACTORIES).get(typename)
    if factory is None:
        return None
    base = messages.typestore().fielddefs
    if any(store.fielddefs.get(name) != base[name] for name in layout(typename).types):
        return None
    return factory(store)


def encoder(typename: str) -> Callable[[Any], bytes] | None:
    """A fast encoder of ``typename``'s message objects into the CDR bytes ``messages.serialize`` makes, or
    None (a type without one; a big-endian host, where that serializer writes big-endian CDR)."""
    if typename != messages.TWIST or sys.byteorder != "little":
        return None
    packer = layout(messages.TWIST).packer()
    assert packer is not None  # a Twist is six float64
    pack = packer.pack

    def encode(msg: Any) -> bytes:
        lin, ang = msg.linear, msg.angular
        return pack(b"\x00\x01\x00\x00", lin.x, lin.y, lin.z, ang.x, ang.y, ang.z)

    return encode
