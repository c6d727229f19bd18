//! Hand-written CDR (XCDR1, as ROS 2's Fast-CDR writes it) for `sensor_msgs/msg/JointState`.
//!
//! Layout: a 4-byte encapsulation header (`00 01 00 00` little-endian, `00 00 00 00` big-endian),
//! then `header.stamp.sec: int32`, `header.stamp.nanosec: uint32`, `header.frame_id: string`,
//! `name: string[]`, `position`, `velocity`, `effort: float64[]`. Alignment counts from byte 4;
//! a string is a `uint32` length including the NUL, then the bytes; a sequence is a `uint32`
//! count followed by its elements, each aligned to its own size (so an empty float64 sequence
//! adds no padding, as Fast-CDR and the Python `mcap-ros2-support` package agree).

/// Encapsulation header of a little-endian plain CDR payload.
const CDR_LE: [u8; 4] = [0x00, 0x01, 0x00, 0x00];

/// The `ros2msg` definition of `sensor_msgs/msg/JointState` with its dependencies, in the
/// concatenated form rosbag2 stores (built from the ROS 2 `.msg` files with the scene's
/// other schema texts).
pub use crate::scene::JOINT_STATE_MSGDEF;

/// Appends one CDR-encoded JointState to `buf` (cleared first).
///
/// `velocity` and `effort` may be empty (ROS allows it and command topics usually do so).
pub(crate) fn encode_joint_state(
    buf: &mut Vec<u8>,
    stamp: (i32, u32),
    frame_id: &str,
    names: &[String],
    position: &[f64],
    velocity: &[f64],
    effort: &[f64],
) {
    let mut w = Cdr::begin(buf);
    w.header(stamp, frame_id);
    w.u32(names.len() as u32);
    for name in names {
        w.string(name);
    }
    for seq in [position, velocity, effort] {
        w.u32(seq.len() as u32);
        for &v in seq {
            w.f64(v);
        }
    }
}

/// A CDR payload being written into a reused buffer.
pub(crate) struct Cdr<'a> {
    buf: &'a mut Vec<u8>,
}

impl<'a> Cdr<'a> {
    /// Clears `buf` and writes the encapsulation header.
    pub(crate) fn begin(buf: &'a mut Vec<u8>) -> Self {
        buf.clear();
        buf.extend_from_slice(&CDR_LE);
        Cdr { buf }
    }
    /// Pads to a multiple of `n` bytes from the start of the payload (after the header).
    fn align(&mut self, n: usize) {
        let off = self.buf.len() - 4;
        let pad = (n - off % n) % n;
        // A slice copy: `extend(repeat_n(0, pad))` called memset for these few bytes.
        self.buf.extend_from_slice(&[0u8; 8][..pad]);
    }
    /// A `uint32`.
    pub(crate) fn u32(&mut self, v: u32) {
        self.align(4);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }
    /// An `int32`.
    pub(crate) fn i32(&mut self, v: i32) {
        self.align(4);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }
    /// A `float64`.
    pub(crate) fn f64(&mut self, v: f64) {
        self.align(8);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }
    /// A `float32`.
    pub(crate) fn f32(&mut self, v: f32) {
        self.align(4);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }
    /// A `bool` (one byte, 0 or 1).
    pub(crate) fn bool(&mut self, v: bool) {
        self.buf.push(u8::from(v));
    }
    /// A `string`: length with its NUL, bytes, NUL.
    pub(crate) fn string(&mut self, s: &str) {
        self.buf.reserve(s.len() + 8);
        self.u32(s.len() as u32 + 1);
        self.buf.extend_from_slice(s.as_bytes());
        self.buf.push(0);
    }
    /// A `std_msgs/Header`: stamp (sec, nanosec) and frame id.
    pub(crate) fn header(&mut self, stamp: (i32, u32), frame_id: &str) {
        self.i32(stamp.0);
        self.u32(stamp.1);
        self.string(frame_id);
    }
}

/// A zero-copy view of a decoded JointState: the names stay byte ranges into the payload.
#[derive(Debug)]
pub(crate) struct JointStateView<'a> {
    /// `header.stamp` as (sec, nanosec).
    pub stamp: (i32, u32),
    /// Joint names as (start, length) byte ranges into the payload, without the NUL.
    names: &'a [(usize, usize)],
    /// Byte offset of the first position element and the position count.
    position_start: usize,
    position_len: usize,
    little_endian: bool,
    data: &'a [u8],
}

impl<'a> JointStateView<'a> {
    /// Number of joint names.
    pub fn name_count(&self) -> usize {
        self.names.len()
    }

    /// Joint name `i` as bytes (caller checks `i < name_count()`).
    #[inline]
    pub fn name(&self, i: usize) -> &'a [u8] {
        let (start, len) = self.names[i];
        &self.data[start..start + len]
    }

    /// Number of position values.
    pub fn position_len(&self) -> usize {
        self.position_len
    }

    /// Position `i` (caller checks `i < position_len()`).
    #[inline]
    pub fn position(&self, i: usize) -> f64 {
        // Elements are contiguous once the first one is aligned (8-byte elements).
        let at = self.position_start + 8 * i;
        let bytes: [u8; 8] = self.data[at..at + 8]
            .try_into()
            .expect("invariant: bounds checked while decoding");
        if self.little_endian {
            f64::from_le_bytes(bytes)
        } else {
            f64::from_be_bytes(bytes)
        }
    }
}

/// Decodes a CDR JointState. `names_scratch` is reused between calls to avoid allocation.
///
/// Only `header`, `name` and `position` are decoded; `velocity` and `effort` are bounds-checked
/// but otherwise ignored.
pub(crate) fn decode_joint_state<'a>(
    data: &'a [u8],
    names_scratch: &'a mut Vec<(usize, usize)>,
) -> Result<JointStateView<'a>, String> {
    if data.len() < 4 {
        return Err(format!(
            "payload of {} bytes is shorter than the CDR encapsulation header",
            data.len()
        ));
    }
    let little_endian = match (data[0], data[1]) {
        (0x00, 0x01) => true,
        (0x00, 0x00) => false,
        (a, b) => {
            return Err(format!(
                "unsupported CDR encapsulation {a:02x} {b:02x} (expected 00 01 little-endian or 00 00 big-endian plain CDR)"
            ))
        }
    };
    let mut r = Reader {
        data,
        pos: 4,
        little_endian,
        had_nul: false,
    };
    let sec = r.u32("header.stamp.sec")? as i32;
    let nanosec = r.u32("header.stamp.nanosec")?;
    r.string("header.frame_id")?;
    let n_names = r.u32("name length")? as usize;
    if n_names > data.len() {
        return Err(format!("name length {n_names} exceeds the payload size"));
    }
    names_scratch.clear();
    for _ in 0..n_names {
        let name = r.string("name[]")?;
        names_scratch.push((r.pos - name.len() - usize::from(r.had_nul), name.len()));
    }
    let (position_start, position_len) = r.f64_seq("position")?;
    r.f64_seq("velocity")?;
    r.f64_seq("effort")?;
    Ok(JointStateView {
        stamp: (sec, nanosec),
        names: names_scratch,
        position_start,
        position_len,
        little_endian,
        data,
    })
}

struct Reader<'a> {
    data: &'a [u8],
    pos: usize,
    little_endian: bool,
    /// Whether the last string read ended with a NUL (to locate its bytes).
    had_nul: bool,
}

impl<'a> Reader<'a> {
    fn align(&mut self, n: usize) {
        let off = self.pos - 4;
        self.pos += (n - off % n) % n;
    }
    fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8], String> {
        let end = self.pos.checked_add(n).filter(|&e| e <= self.data.len());
        match end {
            Some(end) => {
                let s = &self.data[self.pos..end];
                self.pos = end;
                Ok(s)
            }
            None => Err(format!(
                "payload ends inside `{what}` (needs {n} bytes at offset {}, payload has {})",
                self.pos,
                self.data.len()
            )),
        }
    }
    fn u32(&mut self, what: &str) -> Result<u32, String> {
        self.align(4);
        let b: [u8; 4] = self
            .take(4, what)?
            .try_into()
            .expect("invariant: take returned 4 bytes");
        Ok(if self.little_endian {
            u32::from_le_bytes(b)
        } else {
            u32::from_be_bytes(b)
        })
    }
    fn string(&mut self, what: &str) -> Result<&'a [u8], String> {
        let len = self.u32(what)? as usize;
        let bytes = self.take(len, what)?;
        // Serializers differ on whether an empty string has length 0 or 1 (just the NUL).
        self.had_nul = !bytes.is_empty();
        Ok(match bytes.split_last() {
            Some((0, body)) => body,
            Some(_) => return Err(format!("string `{what}` is not NUL-terminated")),
            None => bytes,
        })
    }
    fn f64_seq(&mut self, what: &str) -> Result<(usize, usize), String> {
        let n = self.u32(what)? as usize;
        if n == 0 {
            return Ok((self.pos, 0));
        }
        self.align(8);
        let start = self.pos;
        let bytes = n
            .checked_mul(8)
            .ok_or_else(|| format!("`{what}` length {n} overflows"))?;
        self.take(bytes, what)?;
        Ok((start, n))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn encodes_the_ros2_byte_layout() {
        let mut buf = Vec::new();
        let names = vec!["a".to_string()];
        encode_joint_state(&mut buf, (1, 2), "", &names, &[0.5], &[], &[]);
        let expected: Vec<u8> = [
            &[0u8, 1, 0, 0][..],
            &1i32.to_le_bytes(),
            &2u32.to_le_bytes(),
            &1u32.to_le_bytes(), // frame_id "" = length 1 (NUL)
            &[0, 0, 0, 0],       // NUL + pad to 4
            &1u32.to_le_bytes(), // one name (offset 16)
            &2u32.to_le_bytes(), // "a\0"
            &[b'a', 0, 0, 0],    // + pad to 4 (offset 28)
            &1u32.to_le_bytes(), // one position (offset 32 after)
            &0.5f64.to_le_bytes(),
            &0u32.to_le_bytes(), // velocity: empty, no alignment padding
            &0u32.to_le_bytes(), // effort
        ]
        .concat();
        assert_eq!(buf, expected);
    }

    #[test]
    fn decode_inverts_encode_including_padding() {
        let mut buf = Vec::new();
        let names: Vec<String> = ["l_sh", "elbow_2", "w"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        let pos = [1.25, -3.5e-7, f64::MAX];
        encode_joint_state(
            &mut buf,
            (-3, 999_999_999),
            "base",
            &names,
            &pos,
            &[0.1],
            &[],
        );
        let mut scratch = Vec::new();
        let v = decode_joint_state(&buf, &mut scratch).expect("decodes");
        assert_eq!(v.stamp, (-3, 999_999_999));
        let got: Vec<&str> = (0..v.name_count())
            .map(|i| std::str::from_utf8(v.name(i)).expect("utf8"))
            .collect();
        assert_eq!(got, ["l_sh", "elbow_2", "w"]);
        assert_eq!(v.position_len(), 3);
        for (i, p) in pos.iter().enumerate() {
            assert_eq!(v.position(i).to_bits(), p.to_bits());
        }
    }

    #[test]
    fn truncated_and_bad_headers_are_errors() {
        let mut buf = Vec::new();
        let names = vec!["j".to_string()];
        encode_joint_state(&mut buf, (0, 0), "", &names, &[1.0], &[], &[]);
        for cut in [0, 3, 9, 20, buf.len() - 1] {
            let mut scratch = Vec::new();
            assert!(
                decode_joint_state(&buf[..cut], &mut scratch).is_err(),
                "cut {cut}"
            );
        }
        let mut bad = buf.clone();
        bad[1] = 0x07;
        let mut scratch = Vec::new();
        let err = decode_joint_state(&bad, &mut scratch).unwrap_err();
        assert!(err.contains("encapsulation"), "{err}");
    }

    #[test]
    fn reads_big_endian_payloads() {
        // Hand-built big-endian message: stamp (7, 8), frame "", names ["x"], position [2.0].
        let mut b = vec![0u8, 0, 0, 0];
        b.extend_from_slice(&7i32.to_be_bytes());
        b.extend_from_slice(&8u32.to_be_bytes());
        b.extend_from_slice(&1u32.to_be_bytes());
        b.extend_from_slice(&[0, 0, 0, 0]);
        b.extend_from_slice(&1u32.to_be_bytes());
        b.extend_from_slice(&2u32.to_be_bytes());
        b.extend_from_slice(&[b'x', 0, 0, 0]);
        b.extend_from_slice(&1u32.to_be_bytes());
        b.extend_from_slice(&2.0f64.to_be_bytes());
        b.extend_from_slice(&0u32.to_be_bytes());
        b.extend_from_slice(&0u32.to_be_bytes());
        let mut scratch = Vec::new();
        let v = decode_joint_state(&b, &mut scratch).expect("decodes");
        assert_eq!(v.stamp, (7, 8));
        assert_eq!(v.name_count(), 1);
        assert_eq!(v.name(0), b"x");
        assert_eq!(v.position(0), 2.0);
    }
}
