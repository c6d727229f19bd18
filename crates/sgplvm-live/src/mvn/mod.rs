//! The Xsens MVN real-time network streaming protocol: a person in an Xsens suit, live, as the
//! segment poses MVN Analyze/Animate streams over UDP (issue 44).
//!
//! - [`datagram`]: one datagram decoded ([`decode`], [`decode_part`]) or written ([`encode`]);
//! - [`assemble`]: the datagrams of one frame put back together when MVN splits a frame;
//! - [`receiver`]: the UDP side, [`MvnReceiver`] (a `mio` source keeping the newest complete
//!   frame) and [`MvnSender`] (what `sgplvm replay --as mvn` sends with);
//! - [`body`]: a frame as named segment world poses and as the capture importer's per-arm
//!   [`ArmPose`](sgplvm_capture::ArmPose).
//!
//! # The specification followed
//!
//! *MVN real-time network streaming protocol specification*, Xsens Technologies B.V., document
//! MV0305P, revision N (September 2018, "added finger tracking and updated header"; MVN
//! Analyze/Animate 2018 and later). Section numbers below are that document's. Where the
//! document is silent or contradicts itself, Xsens' own public-domain sample parser (the
//! `xsens_mvn_sdk` `Datagram`/`EulerDatagram`/`QuaternionDatagram` classes shipped in Xsens'
//! `xsens_mvn_ros2` repository and in IIT's `xsens_mvn_ros`) settled it, as said at each place.
//! No code was taken from either; the tables were.
//!
//! Transport (§2.2–2.4): UDP, default port [`DEFAULT_PORT`] 9763; every value big-endian
//! ("network byte order"); a 24-byte header, then a run of equal-sized items.
//!
//! ## Header (§2.4.1), 24 bytes
//!
//! | offset | bytes | field | here |
//! |---:|---:|---|---|
//! | 0 | 6 | ID string: ASCII `MXTP` then the two-digit message type (`01`, `02`, …), not terminated | checked: [`MvnError::Magic`], [`MvnError::Type`], [`MvnError::Unsupported`] |
//! | 6 | 4 | sample counter, u32, +1 per sample sent | [`MvnPose::sample_counter`] |
//! | 10 | 1 | datagram counter: bits 0–6 the datagram's index within its sample, bit 7 set on the sample's last datagram (`0x80`: a whole frame in one datagram) | [`decode_part`], [`assemble`] |
//! | 11 | 1 | number of items, u8 | checked against the payload: [`MvnError::ItemCount`] |
//! | 12 | 4 | time code, u32, milliseconds since the recording started | [`MvnPose::time_code_ms`] |
//! | 16 | 1 | character ID (0 in a one-person setup; each character sends its own datagrams) | [`MvnPose::character_id`] |
//! | 17 | 1 | number of body segments (MVN 2019+; "in practice always 23") | checked ≤ 23 |
//! | 18 | 1 | number of props (MVN 2019+; 0–4) | checked ≤ 4 |
//! | 19 | 1 | number of finger tracking segments (MVN 2019+; 0 or 40, both hands) | checked ≤ 40 |
//! | 20 | 2 | reserved | ignored, written 0 |
//! | 22 | 2 | payload size, u16: the datagram's bytes after the header | checked: [`MvnError::PayloadSize`] |
//!
//! Senders older than MVN 2019 wrote bytes 17–23 as "free" (zero). A header whose bytes 17–23
//! are all zero is read as such a legacy header: the payload size is then not stated (the item
//! count alone must match the bytes present) and segment IDs 1–27 (body and props) are taken.
//!
//! ## Items (§2.5), in the order body segments, props, left-hand fingers, right-hand fingers
//!
//! Type **01**, pose data Euler (§2.5.2), 28 bytes: offset 0 segment ID (4-byte integer), 4/8/12
//! position x, y, z (f32), 16/20/24 rotation x, y, z (f32). Y-up, right-handed (§2.5.2);
//! positions in centimetres (§2.5.6), angles in degrees (§2.5.7).
//!
//! Type **02**, pose data quaternion (§2.5.3), 32 bytes: offset 0 segment ID, 4/8/12 position
//! x, y, z, 16/20/24/28 orientation q1 (re, w), q2 (i, x), q3 (j, y), q4 (k, z), all f32. Z-up,
//! right-handed; the quaternion normalised but not necessarily with w ≥ 0 (§2.5.8). This is the
//! type MVN's network monitor and third-party skeletons use by default.
//!
//! ## Segment IDs (§2.5.9, §3.1 Table 1): ID = index + 1
//!
//! | ID | segment | ID | segment | ID | segment |
//! |---:|---|---:|---|---:|---|
//! | 1 | `Pelvis` | 9 | `RightUpperArm` | 17 | `RightLowerLeg` |
//! | 2 | `L5` | 10 | `RightForeArm` | 18 | `RightFoot` |
//! | 3 | `L3` | 11 | `RightHand` | 19 | `RightToe` |
//! | 4 | `T12` | 12 | `LeftShoulder` | 20 | `LeftUpperLeg` |
//! | 5 | `T8` | 13 | `LeftUpperArm` | 21 | `LeftLowerLeg` |
//! | 6 | `Neck` | 14 | `LeftForeArm` | 22 | `LeftFoot` |
//! | 7 | `Head` | 15 | `LeftHand` | 23 | `LeftToe` |
//! | 8 | `RightShoulder` | 16 | `RightUpperLeg` | | |
//!
//! Props `Prop1`–`Prop4` are IDs 24 to 23 + props; the 20 finger segments of the left hand
//! follow (`LeftCarpus`, `LeftFirstMetacarpal`, … in §3.1 Table 2's order), then the right
//! hand's. Table 1 prints 24–27 for the props in its *index* column, but Table 2 puts the left
//! carpus at index 23 + number of props, which holds only with the props at indices 23…, so
//! IDs 24…: that reading is the one taken. Names are MVN's own spelling (`RightForeArm`, as
//! in MVN's BVH and MVNX exports; the table writes "Right Forearm").
//!
//! # What is implemented, and what is not
//!
//! - **02** (quaternion) and **01** (Euler) are decoded and encoded.
//! - **03** (positions only, a virtual optical marker set) is refused with
//!   [`MvnError::Unsupported`]: it carries no orientations (the arm fit needs the segments'
//!   frames), its point IDs are defined twice and differently (§2.5.4: 100 × segment ID + point;
//!   §2.5.10: 256 × segment ID + point) and the local point IDs are only in the MVN user manual.
//! - **05** (Unity3D: local rotations, a different segment order, left-handed), the character
//!   and scale information (12, 13) and the additional kinematics (20–25) are refused alike:
//!   none is a world pose of the segments. A receiver counts them by kind and goes on.
//! - **Split frames** (§2.4.1.3): [`decode`] takes a whole frame (datagram counter `0x80`) and
//!   refuses a part with [`MvnError::Split`]; [`decode_part`] decodes any datagram, and
//!   [`assemble::Reassembler`] (used by [`MvnReceiver`]) puts the parts of one sample back
//!   together by sample counter and index, giving up an incomplete frame when a newer one
//!   starts.
//!
//! # Units and frame of [`MvnPose`]
//!
//! One frame for every type: MVN's global frame, **right-handed, z up, metres**, orientations as
//! unit quaternions (w, x, y, z) rotating segment axes into global axes. In MVN's null pose
//! (every orientation the identity: a T-pose, §2.6.2) every segment's axes are x forward, y
//! left, z up.
//!
//! - Type 02 positions are decoded as **metres**, unchanged. §2.5.6 says centimetres for every
//!   type, but MVN sends metres in type 02: Xsens' sample parser divides by 100 only the
//!   positions of types 01 and 03 and reads type 02 as is, and the ROS drivers built on it
//!   publish type 02 positions unscaled as metres. The receiver does not rely on either: the
//!   person's segment lengths in the first full frame tell metres from centimetres
//!   ([`units`]), and a stream in centimetres is scaled to metres.
//! - Type 01 is converted: positions ÷ 100 (cm → m); Y-up axes (x, y, z) become Z-up axes
//!   (z, x, y) — a proper rotation taking Y-up's up (y) to z, as Xsens' sample does; the Euler
//!   angles (degrees) are `R = Rz(rz) · Ry(ry) · Rx(rx)` about the Y-up axes (Xsens'
//!   `XsQuaternion::fromEulerAngles`; the specification names no order), and the rotation is
//!   carried to the Z-up axes the same way (q's vector part permuted like a position).
//!
//! Values are kept as the f32 they travel as, so that type 02 round-trips exactly.

pub mod assemble;
pub mod body;
pub mod datagram;
pub mod human;
pub mod receiver;
mod segments;
pub mod units;

#[cfg(test)]
mod tests;

pub use body::WorldPose;
pub use datagram::{
    decode, decode_part, encode, Header, MvnPart, MvnPose, PoseType, SegmentCounts, SegmentPose,
    DEFAULT_PORT, HEADER_BYTES,
};
pub use human::{HumanSegments, MvnFit};
pub use receiver::{MvnReceiver, MvnSender, ReceiverCounts, ReceiverOptions, Senders};
pub use segments::{segment_id, segment_name, BODY_SEGMENTS, FINGER_SEGMENTS, PROP_SEGMENTS};
pub use units::Units;

/// What is wrong with a datagram, or with using one; every variant says what was expected.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MvnError {
    /// Fewer bytes than the header.
    #[error("an MVN datagram of {got} bytes; expected at least the {HEADER_BYTES}-byte header")]
    Short {
        /// Bytes received.
        got: usize,
    },
    /// The ID string does not start with `MXTP`.
    #[error("ID string starts with {found:?}; expected \"MXTP\" (an Xsens MVN datagram)")]
    Magic {
        /// The first four bytes, lossily as text.
        found: String,
    },
    /// The message type is not two ASCII digits.
    #[error("message type {found:?} at bytes 4-5; expected two ASCII digits such as \"02\"")]
    Type {
        /// The two bytes, lossily as text.
        found: String,
    },
    /// A message type this module does not decode.
    #[error("message type {code} ({what}) is not decoded; expected 02 (quaternion) or 01 (Euler) pose data: {why}")]
    Unsupported {
        /// The two digits.
        code: String,
        /// What the specification calls it.
        what: &'static str,
        /// Why it is not decoded.
        why: &'static str,
    },
    /// A header count beyond what the specification allows.
    #[error("header {field} is {value}; expected at most {max}")]
    Counts {
        /// Which count.
        field: &'static str,
        /// Its value.
        value: u8,
        /// The specification's maximum.
        max: u8,
    },
    /// The header's payload size disagrees with the bytes present.
    #[error("header payload size is {stated} bytes but {present} bytes follow the header; expected them equal")]
    PayloadSize {
        /// The header's payload size.
        stated: u16,
        /// Bytes after the header.
        present: usize,
    },
    /// The number of items does not fill the payload exactly.
    #[error("header number of items is {items}: {items} × {item_bytes} = {needed} bytes of type {code} items; expected that to be the {present} bytes after the header")]
    ItemCount {
        /// The header's number of items.
        items: u8,
        /// Bytes per item of this type.
        item_bytes: usize,
        /// items × item bytes.
        needed: usize,
        /// Bytes after the header.
        present: usize,
        /// The message type.
        code: &'static str,
    },
    /// A segment ID outside the header's body, prop and finger segments.
    #[error("item {item}: segment ID {id}; expected {expected}")]
    SegmentId {
        /// The item's place in the datagram, from 0.
        item: usize,
        /// The ID sent.
        id: u32,
        /// The IDs the header allows, in words.
        expected: String,
    },
    /// A segment sent twice in one frame.
    #[error("item {item}: segment ID {id} ({name}) again; expected each segment once per frame")]
    DuplicateSegment {
        /// The item's place in the frame, from 0.
        item: usize,
        /// The repeated ID.
        id: u32,
        /// Its name.
        name: &'static str,
    },
    /// The person's calibration given is not the stream's.
    #[error("{0}")]
    Calibration(String),
    /// A value that is not a finite number.
    #[error("item {item} (segment {name}): {field} is {value}; expected a finite number")]
    NotANumber {
        /// The item's place in the datagram, from 0.
        item: usize,
        /// The segment's name.
        name: &'static str,
        /// Which value.
        field: &'static str,
        /// The value.
        value: f32,
    },
    /// An orientation quaternion far from unit length.
    #[error("item {item} (segment {name}): orientation quaternion of norm {norm}; expected a unit quaternion (§2.5.8)")]
    NotUnit {
        /// The item's place in the datagram, from 0.
        item: usize,
        /// The segment's name.
        name: &'static str,
        /// Its norm.
        norm: f32,
    },
    /// One datagram of a frame split across several: [`decode`] takes whole frames.
    #[error("datagram {index} of a frame split across several datagrams{}; expected a whole frame (datagram counter 0x80): decode it with decode_part and put the frame together with assemble::Reassembler (MvnReceiver does)", if *.last { " (its last)" } else { "" })]
    Split {
        /// The datagram's index within its frame.
        index: u8,
        /// Whether it is the frame's last datagram.
        last: bool,
    },
    /// Datagrams of one frame that do not fit together.
    #[error("the datagrams of sample {sample}: {message}")]
    Parts {
        /// The sample counter.
        sample: u32,
        /// What does not fit.
        message: String,
    },
    /// More items than one datagram can count.
    #[error("{items} segments in one pose; an MVN datagram counts at most 255 items")]
    TooManyItems {
        /// Segments in the pose.
        items: usize,
    },
    /// A segment the conversion needs is not in the frame, or a name MVN does not have.
    #[error("segment {name}: {message}")]
    Segment {
        /// The segment's name.
        name: String,
        /// What is wrong.
        message: String,
    },
    /// The UDP socket failed.
    #[error("MVN UDP socket: {action} {addr}: {source}")]
    Socket {
        /// What was being done.
        action: &'static str,
        /// The address involved.
        addr: String,
        /// The system's reason.
        source: std::io::Error,
    },
}

impl MvnError {
    /// A short name of the kind of error, for counting dropped datagrams by kind.
    pub fn kind(&self) -> &'static str {
        match self {
            MvnError::Short { .. } => "short",
            MvnError::Magic { .. } => "not MXTP",
            MvnError::Type { .. } => "bad message type",
            MvnError::Unsupported { .. } => "type not decoded",
            MvnError::Counts { .. } => "bad header count",
            MvnError::PayloadSize { .. } => "payload size mismatch",
            MvnError::ItemCount { .. } => "item count mismatch",
            MvnError::SegmentId { .. } => "unknown segment ID",
            MvnError::DuplicateSegment { .. } => "duplicate segment",
            MvnError::NotANumber { .. } => "not a number",
            MvnError::NotUnit { .. } => "not a unit quaternion",
            MvnError::Split { .. } => "split frame",
            MvnError::Parts { .. } => "parts do not fit",
            MvnError::TooManyItems { .. } => "too many items",
            MvnError::Segment { .. } => "segment",
            MvnError::Calibration(_) => "calibration",
            MvnError::Socket { .. } => "socket",
        }
    }
}
