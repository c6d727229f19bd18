//! One MVN datagram decoded into a [`MvnPose`], or a pose written as one (the tables are in the
//! [module documentation](super)).

use std::fmt;

use super::segments::segment_name;
use super::MvnError;

/// The port MVN Analyze/Animate streams to by default (§2.3: 9 = X, M = 6, E = 3).
pub const DEFAULT_PORT: u16 = 9763;

/// Bytes of the datagram header (§2.4.1).
pub const HEADER_BYTES: usize = 24;

/// The first four bytes of every datagram (§2.4.1.1).
const MAGIC: &[u8; 4] = b"MXTP";

/// Datagram counter bit that marks a sample's last datagram; `0x80` alone is a whole frame.
const LAST_BIT: u8 = 0x80;

/// How far from 1 a quaternion's norm may be: MVN sends normalised f32 quaternions (§2.5.8,
/// within about 1e-7); anything further off is not an orientation.
const UNIT_TOLERANCE: f32 = 1e-2;

/// Segment IDs a legacy header (bytes 17–23 zero, before MVN 2019) may carry: body and props.
const LEGACY_MAX_ID: u32 = 27;

/// The pose datagram types decoded and encoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum PoseType {
    /// `01`: position (cm, Y-up) and Euler angles (degrees) per segment, 28 bytes (§2.5.2).
    Euler,
    /// `02`: position (m, Z-up) and quaternion per segment, 32 bytes (§2.5.3); MVN's default.
    #[default]
    Quaternion,
}

impl PoseType {
    /// The two ASCII digits of the ID string.
    pub const fn code(self) -> &'static str {
        match self {
            PoseType::Euler => "01",
            PoseType::Quaternion => "02",
        }
    }

    /// Bytes per segment item.
    pub const fn item_bytes(self) -> usize {
        match self {
            PoseType::Euler => 28,
            PoseType::Quaternion => 32,
        }
    }

    /// The type of message type `code` (two ASCII digits), or why it is not decoded.
    pub fn from_code(code: [u8; 2]) -> Result<PoseType, MvnError> {
        let unsupported = |what: &'static str, why: &'static str| MvnError::Unsupported {
            code: String::from_utf8_lossy(&code).into_owned(),
            what,
            why,
        };
        let not_a_pose = "not a world pose of the segments";
        match &code {
            b"01" => Ok(PoseType::Euler),
            b"02" => Ok(PoseType::Quaternion),
            b"03" => Err(unsupported(
                "positions only, virtual marker set",
                "no orientations, and point IDs the specification defines two ways",
            )),
            b"04" => Err(unsupported("MotionGrid tag data", "deprecated")),
            b"05" => Err(unsupported(
                "Unity3D pose data",
                "local rotations in another segment order, left-handed",
            )),
            b"10" | b"11" => Err(unsupported("character information", "deprecated")),
            b"12" => Err(unsupported("character meta data", not_a_pose)),
            b"13" => Err(unsupported("character scale information", not_a_pose)),
            b"20" => Err(unsupported("joint angles", not_a_pose)),
            b"21" => Err(unsupported("linear segment kinematics", not_a_pose)),
            b"22" => Err(unsupported("angular segment kinematics", not_a_pose)),
            b"23" => Err(unsupported("motion tracker kinematics", not_a_pose)),
            b"24" => Err(unsupported("center of mass", not_a_pose)),
            b"25" => Err(unsupported("time code", not_a_pose)),
            _ => Err(unsupported(
                "not in the specification",
                "unknown message type",
            )),
        }
    }
}

impl fmt::Display for PoseType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PoseType::Euler => write!(f, "01 (Euler)"),
            PoseType::Quaternion => write!(f, "02 (quaternion)"),
        }
    }
}

/// The counts of a post-2019 header (bytes 17–19).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct SegmentCounts {
    /// Body segments (23 in practice).
    pub body: u8,
    /// Props (0–4).
    pub props: u8,
    /// Finger tracking segments, both hands (0 or 40).
    pub fingers: u8,
}

/// The 24-byte header, field for field (§2.4.1; offsets in the [module documentation](super)).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Header {
    /// The message type's two ASCII digits (bytes 4–5).
    pub message_type: [u8; 2],
    /// Sample counter (bytes 6–9).
    pub sample_counter: u32,
    /// Datagram counter (byte 10): index in bits 0–6, bit 7 on the sample's last datagram.
    pub datagram_counter: u8,
    /// Number of items (byte 11).
    pub items: u8,
    /// Time code, ms since the recording started (bytes 12–15).
    pub time_code_ms: u32,
    /// Character ID (byte 16).
    pub character_id: u8,
    /// Body, prop and finger counts (bytes 17–19); `None` for a legacy header, bytes 17–23 all
    /// zero (before MVN 2019).
    pub counts: Option<SegmentCounts>,
    /// Payload size, bytes after the header (bytes 22–23); 0 in a legacy header.
    pub payload_bytes: u16,
}

impl Header {
    /// Reads and checks the header of `datagram`: its length, `MXTP` and a two-digit type.
    pub fn read(datagram: &[u8]) -> Result<Header, MvnError> {
        let Some(h) = datagram.get(..HEADER_BYTES) else {
            return Err(MvnError::Short {
                got: datagram.len(),
            });
        };
        if &h[..4] != MAGIC {
            return Err(MvnError::Magic {
                found: String::from_utf8_lossy(&h[..4]).into_owned(),
            });
        }
        let message_type = [h[4], h[5]];
        if !message_type.iter().all(u8::is_ascii_digit) {
            return Err(MvnError::Type {
                found: String::from_utf8_lossy(&message_type).into_owned(),
            });
        }
        let legacy = h[17..24].iter().all(|&b| b == 0);
        Ok(Header {
            message_type,
            sample_counter: be_u32(h, 6),
            datagram_counter: h[10],
            items: h[11],
            time_code_ms: be_u32(h, 12),
            character_id: h[16],
            counts: (!legacy).then_some(SegmentCounts {
                body: h[17],
                props: h[18],
                fingers: h[19],
            }),
            payload_bytes: u16::from_be_bytes([h[22], h[23]]),
        })
    }

    /// The datagram's index within its sample.
    pub fn index(&self) -> u8 {
        self.datagram_counter & !LAST_BIT
    }

    /// Whether this is its sample's last datagram.
    pub fn is_last(&self) -> bool {
        self.datagram_counter & LAST_BIT != 0
    }

    /// Appends the header's 24 bytes to `out` (reserved bytes zero).
    fn write(&self, out: &mut Vec<u8>) {
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&self.message_type);
        out.extend_from_slice(&self.sample_counter.to_be_bytes());
        out.push(self.datagram_counter);
        out.push(self.items);
        out.extend_from_slice(&self.time_code_ms.to_be_bytes());
        out.push(self.character_id);
        match self.counts {
            Some(c) => out.extend_from_slice(&[c.body, c.props, c.fingers]),
            None => out.extend_from_slice(&[0, 0, 0]),
        }
        out.extend_from_slice(&[0, 0]);
        out.extend_from_slice(&self.payload_bytes.to_be_bytes());
    }

    /// Which segment IDs this header allows, the props count their names assume, and the
    /// allowed ranges in words.
    fn id_ranges(&self) -> IdRanges {
        match self.counts {
            None => IdRanges {
                body: 23,
                extra_to: LEGACY_MAX_ID,
                props: 4,
            },
            Some(c) => IdRanges {
                body: u32::from(c.body),
                extra_to: 23 + u32::from(c.props) + u32::from(c.fingers),
                props: c.props,
            },
        }
    }
}

/// Allowed segment IDs: 1 to `body`, then 24 to `extra_to` (props and fingers).
#[derive(Debug, Clone, Copy)]
struct IdRanges {
    body: u32,
    extra_to: u32,
    props: u8,
}

impl IdRanges {
    fn allows(&self, id: u32) -> bool {
        (1..=self.body).contains(&id) || (24..=self.extra_to).contains(&id)
    }

    fn describe(&self) -> String {
        let mut s = match self.body {
            0 => String::from("no body segment"),
            b => format!("1 to {b} (body)"),
        };
        if self.extra_to >= 24 {
            s += &format!(" or 24 to {} (props, fingers)", self.extra_to);
        }
        s
    }
}

/// One segment's pose in MVN's Z-up global frame, as the f32 values that travel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SegmentPose {
    /// Segment ID (§3.1; [`segment_name`] names it).
    pub id: u32,
    /// Position of the segment's origin, metres, x y z.
    pub position: [f32; 3],
    /// Orientation, unit quaternion w x y z (segment axes into global axes).
    pub orientation: [f32; 4],
}

/// One sample of one character: every segment's pose.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct MvnPose {
    /// The type it was decoded from (or is meant to be sent as).
    pub kind: PoseType,
    /// Sample counter (+1 per sample MVN sends; not a clock).
    pub sample_counter: u32,
    /// Time code, ms since the recording started.
    pub time_code_ms: u32,
    /// Character ID.
    pub character_id: u8,
    /// The header's body, prop and finger counts; `None` from a legacy header.
    pub counts: Option<SegmentCounts>,
    /// The segments in the order sent (body, props, left fingers, right fingers).
    pub segments: Vec<SegmentPose>,
}

/// One decoded datagram that may be part of a split frame.
#[derive(Debug, Clone, PartialEq)]
pub struct MvnPart {
    /// The datagram's segments (the whole frame when `index` is 0 and `last`).
    pub pose: MvnPose,
    /// Its index within its sample.
    pub index: u8,
    /// Whether it is the sample's last datagram.
    pub last: bool,
}

/// Decodes one whole-frame datagram (datagram counter `0x80`), checking every header field
/// against the bytes present and every value; a part of a split frame is refused with
/// [`MvnError::Split`] (see [`decode_part`]).
pub fn decode(datagram: &[u8]) -> Result<MvnPose, MvnError> {
    let part = decode_part(datagram)?;
    if part.index != 0 || !part.last {
        return Err(MvnError::Split {
            index: part.index,
            last: part.last,
        });
    }
    Ok(part.pose)
}

/// Decodes any pose datagram, whole frame or one part of a split one.
pub fn decode_part(datagram: &[u8]) -> Result<MvnPart, MvnError> {
    let header = Header::read(datagram)?;
    let kind = PoseType::from_code(header.message_type)?;
    if let Some(c) = header.counts {
        for (field, value, max) in [
            ("number of body segments", c.body, 23),
            ("number of props", c.props, 4),
            ("number of finger tracking segments", c.fingers, 40),
        ] {
            if value > max {
                return Err(MvnError::Counts { field, value, max });
            }
        }
    }
    let payload = &datagram[HEADER_BYTES..];
    if header.counts.is_some() && usize::from(header.payload_bytes) != payload.len() {
        return Err(MvnError::PayloadSize {
            stated: header.payload_bytes,
            present: payload.len(),
        });
    }
    let item_bytes = kind.item_bytes();
    let needed = usize::from(header.items) * item_bytes;
    if needed != payload.len() {
        return Err(MvnError::ItemCount {
            items: header.items,
            item_bytes,
            needed,
            present: payload.len(),
            code: kind.code(),
        });
    }
    let ranges = header.id_ranges();
    let mut seen = 0u128;
    let mut segments = Vec::with_capacity(usize::from(header.items));
    for (item, bytes) in payload.chunks_exact(item_bytes).enumerate() {
        let id = be_u32(bytes, 0);
        if !ranges.allows(id) {
            return Err(MvnError::SegmentId {
                item,
                id,
                expected: ranges.describe(),
            });
        }
        let name = segment_name(id, ranges.props).unwrap_or("?");
        // IDs are at most 67 here (23 + 4 + 40).
        let bit = 1u128 << id;
        if seen & bit != 0 {
            return Err(MvnError::DuplicateSegment { item, id, name });
        }
        seen |= bit;
        let segment = match kind {
            PoseType::Quaternion => quaternion_item(bytes, item, name)?,
            PoseType::Euler => euler_item(bytes, item, name)?,
        };
        segments.push(SegmentPose { id, ..segment });
    }
    Ok(MvnPart {
        pose: MvnPose {
            kind,
            sample_counter: header.sample_counter,
            time_code_ms: header.time_code_ms,
            character_id: header.character_id,
            counts: header.counts,
            segments,
        },
        index: header.index(),
        last: header.is_last(),
    })
}

/// The floats of one item at `offsets`, each checked finite.
fn floats<const N: usize>(
    bytes: &[u8],
    offsets: [(usize, &'static str); N],
    item: usize,
    name: &'static str,
) -> Result<[f32; N], MvnError> {
    let mut out = [0.0; N];
    for (v, (at, field)) in out.iter_mut().zip(offsets) {
        *v = f32::from_bits(be_u32(bytes, at));
        if !v.is_finite() {
            return Err(MvnError::NotANumber {
                item,
                name,
                field,
                value: *v,
            });
        }
    }
    Ok(out)
}

/// A type 02 item (its ID already read).
fn quaternion_item(bytes: &[u8], item: usize, name: &'static str) -> Result<SegmentPose, MvnError> {
    let position = floats(bytes, [(4, "x"), (8, "y"), (12, "z")], item, name)?;
    let orientation = floats(
        bytes,
        [
            (16, "q1 (re)"),
            (20, "q2 (i)"),
            (24, "q3 (j)"),
            (28, "q4 (k)"),
        ],
        item,
        name,
    )?;
    let norm = orientation.iter().map(|v| v * v).sum::<f32>().sqrt();
    if (norm - 1.0).abs() > UNIT_TOLERANCE {
        return Err(MvnError::NotUnit { item, name, norm });
    }
    Ok(SegmentPose {
        id: 0,
        position,
        orientation,
    })
}

/// A type 01 item (its ID already read), into metres, quaternion, Z-up.
fn euler_item(bytes: &[u8], item: usize, name: &'static str) -> Result<SegmentPose, MvnError> {
    let p = floats(bytes, [(4, "x"), (8, "y"), (12, "z")], item, name)?;
    let r = floats(
        bytes,
        [(16, "x rotation"), (20, "y rotation"), (24, "z rotation")],
        item,
        name,
    )?;
    let q = euler_y_up_to_quaternion_z_up([f64::from(r[0]), f64::from(r[1]), f64::from(r[2])]);
    let p = y_up_to_z_up([f64::from(p[0]), f64::from(p[1]), f64::from(p[2])]);
    Ok(SegmentPose {
        id: 0,
        position: p.map(|v| (v / 100.0) as f32),
        orientation: q.map(|v| v as f32),
    })
}

/// A vector in MVN's Y-up axes (x, y, z) in its Z-up axes: (z, x, y).
fn y_up_to_z_up(v: [f64; 3]) -> [f64; 3] {
    [v[2], v[0], v[1]]
}

/// A vector in MVN's Z-up axes back in its Y-up axes (the inverse of [`y_up_to_z_up`]).
fn z_up_to_y_up(v: [f64; 3]) -> [f64; 3] {
    [v[1], v[2], v[0]]
}

/// Euler angles (degrees, `R = Rz(z) · Ry(y) · Rx(x)` about the Y-up axes) as a quaternion
/// (w, x, y, z) about the Z-up axes.
pub(crate) fn euler_y_up_to_quaternion_z_up(deg: [f64; 3]) -> [f64; 4] {
    let [hx, hy, hz] = deg.map(|a| 0.5 * a.to_radians());
    let (sx, cx) = hx.sin_cos();
    let (sy, cy) = hy.sin_cos();
    let (sz, cz) = hz.sin_cos();
    let w = cx * cy * cz + sx * sy * sz;
    let v = [
        sx * cy * cz - cx * sy * sz,
        cx * sy * cz + sx * cy * sz,
        cx * cy * sz - sx * sy * cz,
    ];
    let [x, y, z] = y_up_to_z_up(v);
    [w, x, y, z]
}

/// The inverse of [`euler_y_up_to_quaternion_z_up`]: a quaternion (w, x, y, z) about the Z-up
/// axes as Euler angles in degrees about the Y-up axes (`y` within ±90°).
pub(crate) fn quaternion_z_up_to_euler_y_up(q: [f64; 4]) -> [f64; 3] {
    let n = q.iter().map(|v| v * v).sum::<f64>().sqrt();
    let n = if n > 0.0 { n } else { 1.0 };
    let w = q[0] / n;
    let [x, y, z] = z_up_to_y_up([q[1] / n, q[2] / n, q[3] / n]);
    let rx = (2.0 * (w * x + y * z)).atan2(1.0 - 2.0 * (x * x + y * y));
    let ry = (2.0 * (w * y - z * x)).clamp(-1.0, 1.0).asin();
    let rz = (2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z));
    [rx, ry, rz].map(f64::to_degrees)
}

/// Writes `pose` as one whole-frame datagram of type `kind` (datagram counter `0x80`, the
/// pose's header fields, reserved bytes zero). Type 02 is exact: [`decode`] gives `pose` back
/// bit for bit; type 01 converts to centimetres, Y-up and Euler angles and back to within f32
/// rounding. Fails only for more than 255 segments (the item count is one byte).
pub fn encode(pose: &MvnPose, kind: PoseType) -> Result<Vec<u8>, MvnError> {
    let items = u8::try_from(pose.segments.len()).map_err(|_| MvnError::TooManyItems {
        items: pose.segments.len(),
    })?;
    let payload = usize::from(items) * kind.item_bytes();
    let header = Header {
        message_type: match kind {
            PoseType::Euler => *b"01",
            PoseType::Quaternion => *b"02",
        },
        sample_counter: pose.sample_counter,
        datagram_counter: LAST_BIT,
        items,
        time_code_ms: pose.time_code_ms,
        character_id: pose.character_id,
        counts: pose.counts,
        // At most 255 × 32 bytes.
        payload_bytes: match pose.counts {
            Some(_) => u16::try_from(payload).unwrap_or(u16::MAX),
            None => 0,
        },
    };
    let mut out = Vec::with_capacity(HEADER_BYTES + payload);
    header.write(&mut out);
    for s in &pose.segments {
        out.extend_from_slice(&s.id.to_be_bytes());
        match kind {
            PoseType::Quaternion => push_f32s(&mut out, s.position.iter().chain(&s.orientation)),
            PoseType::Euler => {
                let p = z_up_to_y_up(s.position.map(|v| f64::from(v) * 100.0));
                let r = quaternion_z_up_to_euler_y_up(s.orientation.map(f64::from));
                push_f32s(&mut out, p.iter().chain(&r).map(|&v| v as f32));
            }
        }
    }
    Ok(out)
}

/// Appends `values` as big-endian f32.
fn push_f32s(out: &mut Vec<u8>, values: impl IntoIterator<Item = impl std::borrow::Borrow<f32>>) {
    for v in values {
        out.extend_from_slice(&v.borrow().to_be_bytes());
    }
}

/// The big-endian u32 at `at` (the caller has checked the length).
fn be_u32(b: &[u8], at: usize) -> u32 {
    u32::from_be_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]])
}
