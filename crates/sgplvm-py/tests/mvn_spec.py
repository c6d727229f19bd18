"""Xsens MVN network-streaming datagrams written straight from the specification's tables, for
tests that play MVN Analyze/Animate to ``sgplvm teleop --input mvn`` (a helper module, not a test).

Follows *MVN real-time network streaming protocol specification*, Xsens Technologies B.V.,
document MV0305P revision N (September 2018):

- §2.4.1 "Datagram header", 24 bytes, big-endian ("network byte order"): 6-byte ID string
  ``MXTP`` + two-digit message type, u32 sample counter, u8 datagram counter (bit 7: last datagram
  of the sample; ``0x80`` is a whole frame), u8 number of items, u32 time code (ms), u8 character
  ID, u8 number of body segments, u8 number of props, u8 number of finger tracking segments
  (these three from MVN 2019), 2 reserved bytes, u16 payload size (bytes after the header);
- §2.5.3 "Segment data quaternion (type 02)", 32 bytes per segment: 4-byte segment ID, position
  x y z, quaternion q1 (re) q2 (i) q3 (j) q4 (k), all f32; Z-up, right-handed. Positions are
  metres, as MVN sends them (§2.5.6 says cm; Xsens' own sample parser reads type 02 unscaled);
- §2.5.2 "Segment data Euler (type 01)", 28 bytes per segment: 4-byte segment ID, position x y z
  (cm), rotation x y z (degrees), f32; Y-up, right-handed;
- §3.1 Table 1, segment ID = index + 1: 1 Pelvis ... 23 LeftToe (:data:`SEGMENT_IDS`).

Written independently of the Rust encoder (``sgplvm_live::mvn``), so that the node is tested
against the specification rather than against itself.
"""

from __future__ import annotations

import socket
import struct
from collections.abc import Iterable, Mapping, Sequence

DEFAULT_PORT = 9763
"""§2.3: MVN's default port (9 = X, M = 6, E = 3)."""

HEADER = struct.Struct(">6sIBBIBBBBHH")
"""§2.4.1, the 24-byte header."""

QUATERNION_ITEM = struct.Struct(">I3f4f")
"""§2.5.3, a type 02 segment: ID, x y z, q1 q2 q3 q4."""

EULER_ITEM = struct.Struct(">I3f3f")
"""§2.5.2, a type 01 segment: ID, x y z, rotation x y z."""

SEGMENT_IDS: dict[str, int] = {
    name: index + 1
    for index, name in enumerate(
        [
            "Pelvis", "L5", "L3", "T12", "T8", "Neck", "Head",
            "RightShoulder", "RightUpperArm", "RightForeArm", "RightHand",
            "LeftShoulder", "LeftUpperArm", "LeftForeArm", "LeftHand",
            "RightUpperLeg", "RightLowerLeg", "RightFoot", "RightToe",
            "LeftUpperLeg", "LeftLowerLeg", "LeftFoot", "LeftToe",
        ]
    )
}  # fmt: skip
"""§3.1 Table 1: the 23 body segments by MVN name, ID = index + 1."""

Vec3 = Sequence[float]
Quat = Sequence[float]

assert HEADER.size == 24 and QUATERNION_ITEM.size == 32 and EULER_ITEM.size == 28


def header(
    message_type: str,
    sample_counter: int,
    items: int,
    payload_size: int,
    *,
    time_code_ms: int = 0,
    character_id: int = 0,
    datagram_counter: int = 0x80,
    body_segments: int = 23,
    props: int = 0,
    finger_segments: int = 0,
) -> bytes:
    """The 24-byte header of §2.4.1, field by field."""
    return HEADER.pack(
        b"MXTP" + message_type.encode("ascii"),
        sample_counter,
        datagram_counter,
        items,
        time_code_ms,
        character_id,
        body_segments,
        props,
        finger_segments,
        0,  # reserved
        payload_size,
    )


def quaternion_datagram(
    sample_counter: int,
    segments: Mapping[str, tuple[Vec3, Quat]],
    **header_fields: int,
) -> bytes:
    """A whole-frame type 02 datagram: ``segments`` maps MVN names to (position in metres,
    quaternion w x y z), Z-up; sent in segment ID order."""
    items = sorted((SEGMENT_IDS[name], pose) for name, pose in segments.items())
    payload = b"".join(QUATERNION_ITEM.pack(sid, *p, *q) for sid, (p, q) in items)
    return header("02", sample_counter, len(items), len(payload), **header_fields) + payload


def euler_datagram(
    sample_counter: int,
    segments: Mapping[str, tuple[Vec3, Vec3]],
    **header_fields: int,
) -> bytes:
    """A whole-frame type 01 datagram: ``segments`` maps MVN names to (position in centimetres,
    rotation x y z in degrees), Y-up; sent in segment ID order."""
    items = sorted((SEGMENT_IDS[name], pose) for name, pose in segments.items())
    payload = b"".join(EULER_ITEM.pack(sid, *p, *r) for sid, (p, r) in items)
    return header("01", sample_counter, len(items), len(payload), **header_fields) + payload


def t_pose(pelvis_height: float = 0.95) -> dict[str, tuple[Vec3, Quat]]:
    """MVN's null pose: every orientation the identity (a T-pose facing +x, y left, z up, §2.6.2),
    each segment at its origin for an adult of plausible proportions, metres."""
    identity = (1.0, 0.0, 0.0, 0.0)
    z = pelvis_height
    spine = {"Pelvis": 0, "L5": 0.1, "L3": 0.2, "T12": 0.3, "T8": 0.42, "Neck": 0.62, "Head": 0.72}
    poses: dict[str, tuple[Vec3, Quat]] = {
        name: ((0.0, 0.0, z + h), identity) for name, h in spine.items()
    }
    for side, y in (("Left", 1.0), ("Right", -1.0)):
        arm = {"Shoulder": 0.02, "UpperArm": 0.18, "ForeArm": 0.47, "Hand": 0.73}
        for part, out in arm.items():
            poses[side + part] = ((0.0, y * out, z + 0.6), identity)
        leg = {
            "UpperLeg": (0.0, 0.0),
            "LowerLeg": (0.0, -0.45),
            "Foot": (0.0, -0.88),
            "Toe": (0.15, -0.93),
        }
        for part, (x, dz) in leg.items():
            poses[side + part] = ((x, y * 0.09, z + dz), identity)
    return poses


def send(datagrams: Iterable[bytes], port: int = DEFAULT_PORT, host: str = "127.0.0.1") -> None:
    """Sends each datagram to ``host:port`` over UDP, as MVN's network streamer does."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        for d in datagrams:
            s.sendto(d, (host, port))
