//! A structure-aware mutator of MCAP files (issue 13): an input is parsed into its top-level
//! records and chunks, each chunk decompressed (none, zstd, lz4) into its records; a mutation
//! works on that structure — a message's CDR JointState payload, a record's fields, opcodes,
//! timestamps, channel ids, record order, chunk boundaries and compression — and the file is
//! written back with every length, uncompressed size and chunk CRC correct, so that the
//! mutation reaches the record and message parsers instead of stopping at a checksum or a
//! length. Some mutations then break one length, size or CRC field of the written file on
//! purpose (by one, or to 0 / 2⁶² / 2⁶³ / u64::MAX), the classes the issue found.
//!
//! Inputs that do not parse (not an MCAP, a length past the end, a chunk that does not
//! decompress) are left to libFuzzer's byte-level mutation.

use std::io::{Read, Write};

/// The MCAP magic, at the start and the end of a file.
pub const MAGIC: &[u8; 8] = b"\x89MCAP0\r\n";
/// MCAP opcodes used here.
pub mod op {
    /// Header.
    pub const HEADER: u8 = 0x01;
    /// Footer.
    pub const FOOTER: u8 = 0x02;
    /// Schema.
    pub const SCHEMA: u8 = 0x03;
    /// Channel.
    pub const CHANNEL: u8 = 0x04;
    /// Message.
    pub const MESSAGE: u8 = 0x05;
    /// Chunk.
    pub const CHUNK: u8 = 0x06;
    /// Metadata.
    pub const METADATA: u8 = 0x0C;
    /// Data end.
    pub const DATA_END: u8 = 0x0F;
}

/// Decompressed chunks larger than this are not parsed (left to the byte-level mutator).
const MAX_CHUNK: usize = 1 << 22;

/// One record: opcode and body.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Rec {
    /// Opcode.
    pub op: u8,
    /// Body (everything after the 9-byte opcode and length).
    pub body: Vec<u8>,
}

/// A chunk, decompressed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Chunk {
    /// Earliest message log time.
    pub start: u64,
    /// Latest message log time.
    pub end: u64,
    /// "", "zstd" or "lz4" (anything else is written uncompressed under that name).
    pub compression: String,
    /// The records inside.
    pub records: Vec<Rec>,
}

/// A top-level item of a file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Top {
    /// A record other than a (parsed) chunk.
    Rec(Rec),
    /// A chunk and its records.
    Chunk(Chunk),
}

/// An MCAP file as records and chunks.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Mcap {
    /// Top-level items between the magics.
    pub top: Vec<Top>,
    /// Whether the file ends with the magic.
    pub trailing_magic: bool,
}

fn u64_at(b: &[u8], at: usize) -> Option<u64> {
    Some(u64::from_le_bytes(b.get(at..at + 8)?.try_into().ok()?))
}

fn u32_at(b: &[u8], at: usize) -> Option<u32> {
    Some(u32::from_le_bytes(b.get(at..at + 4)?.try_into().ok()?))
}

/// Splits `b` into records; `None` if a length runs past the end.
fn parse_records(b: &[u8]) -> Option<Vec<Rec>> {
    let mut out = Vec::new();
    let mut i = 0usize;
    while i < b.len() {
        let op = *b.get(i)?;
        let len = usize::try_from(u64_at(b, i + 1)?).ok()?;
        let body = b.get(i + 9..(i + 9).checked_add(len)?)?;
        out.push(Rec {
            op,
            body: body.to_vec(),
        });
        i += 9 + len;
    }
    Some(out)
}

fn decompress(compression: &str, data: &[u8], size: u64) -> Option<Vec<u8>> {
    let size = usize::try_from(size).ok().filter(|&s| s <= MAX_CHUNK)?;
    let out = match compression {
        "" => data.to_vec(),
        "zstd" => zstd::bulk::decompress(data, size).ok()?,
        "lz4" => {
            let mut out = Vec::new();
            lz4::Decoder::new(data)
                .ok()?
                .take(size as u64 + 1)
                .read_to_end(&mut out)
                .ok()?;
            out
        }
        _ => return None,
    };
    (out.len() == size).then_some(out)
}

fn compress(compression: &str, data: &[u8]) -> Vec<u8> {
    match compression {
        "zstd" => zstd::bulk::compress(data, 1).unwrap_or_else(|_| data.to_vec()),
        "lz4" => {
            let Ok(mut enc) = lz4::EncoderBuilder::new().build(Vec::new()) else {
                return data.to_vec();
            };
            if enc.write_all(data).is_err() {
                return data.to_vec();
            }
            let (out, res) = enc.finish();
            if res.is_err() {
                return data.to_vec();
            }
            out
        }
        _ => data.to_vec(),
    }
}

/// Parses a chunk record's body; `None` if it is not a well-formed chunk.
fn parse_chunk(body: &[u8]) -> Option<Chunk> {
    let start = u64_at(body, 0)?;
    let end = u64_at(body, 8)?;
    let size = u64_at(body, 16)?;
    let clen = u32_at(body, 28)? as usize;
    let compression = std::str::from_utf8(body.get(32..32usize.checked_add(clen)?)?).ok()?;
    let at = 32 + clen;
    let rlen = usize::try_from(u64_at(body, at)?).ok()?;
    let data = body.get(at + 8..(at + 8).checked_add(rlen)?)?;
    let inner = decompress(compression, data, size)?;
    Some(Chunk {
        start,
        end,
        compression: compression.to_string(),
        records: parse_records(&inner)?,
    })
}

impl Mcap {
    /// Parses `b`; `None` unless it starts with the magic and its top-level lengths hold.
    pub fn parse(b: &[u8]) -> Option<Self> {
        let rest = b.strip_prefix(MAGIC)?;
        let (rest, trailing_magic) = match rest.strip_suffix(MAGIC) {
            Some(r) => (r, true),
            None => (rest, false),
        };
        let top = parse_records(rest)?
            .into_iter()
            .map(|r| match (r.op, parse_chunk(&r.body)) {
                (op::CHUNK, Some(c)) => Top::Chunk(c),
                _ => Top::Rec(r),
            })
            .collect();
        Some(Self {
            top,
            trailing_magic,
        })
    }

    /// Writes the file with correct lengths, sizes and CRCs; `fields` collects the offset of
    /// every length, size and CRC field written (for [`break_field`]).
    pub fn write(&self, fields: &mut Vec<Field>) -> Vec<u8> {
        let mut out = MAGIC.to_vec();
        for t in &self.top {
            match t {
                Top::Rec(r) => write_rec(&mut out, r.op, &r.body, fields),
                Top::Chunk(c) => {
                    let mut inner = Vec::new();
                    let mut inner_fields = Vec::new();
                    for r in &c.records {
                        write_rec(&mut inner, r.op, &r.body, &mut inner_fields);
                    }
                    let crc = crc32fast::hash(&inner);
                    let data = compress(&c.compression, &inner);
                    let mut body = Vec::with_capacity(data.len() + 64);
                    body.extend_from_slice(&c.start.to_le_bytes());
                    body.extend_from_slice(&c.end.to_le_bytes());
                    let at = out.len() + 9;
                    fields.push(Field::Size(at + 16));
                    body.extend_from_slice(&(inner.len() as u64).to_le_bytes());
                    fields.push(Field::Crc(at + 24));
                    body.extend_from_slice(&crc.to_le_bytes());
                    fields.push(Field::Len32(at + 28));
                    body.extend_from_slice(&(c.compression.len() as u32).to_le_bytes());
                    body.extend_from_slice(c.compression.as_bytes());
                    fields.push(Field::Len64(at + body.len()));
                    body.extend_from_slice(&(data.len() as u64).to_le_bytes());
                    let data_at = at + body.len();
                    body.extend_from_slice(&data);
                    // Inside an uncompressed chunk the inner fields are bytes of the file too.
                    if c.compression.is_empty() {
                        fields.extend(inner_fields.into_iter().map(|f| f.shifted(data_at)));
                    }
                    write_rec(&mut out, op::CHUNK, &body, fields);
                }
            }
        }
        if self.trailing_magic {
            out.extend_from_slice(MAGIC);
        }
        out
    }

    /// Every record of the file, inside chunks too, as (top index, inner index).
    fn record_slots(&self) -> Vec<(usize, Option<usize>)> {
        let mut out = Vec::new();
        for (i, t) in self.top.iter().enumerate() {
            match t {
                Top::Rec(_) => out.push((i, None)),
                Top::Chunk(c) => out.extend((0..c.records.len()).map(|j| (i, Some(j)))),
            }
        }
        out
    }

    fn rec_mut(&mut self, slot: (usize, Option<usize>)) -> Option<&mut Rec> {
        match (self.top.get_mut(slot.0)?, slot.1) {
            (Top::Rec(r), None) => Some(r),
            (Top::Chunk(c), Some(j)) => c.records.get_mut(j),
            _ => None,
        }
    }
}

/// A length, size or CRC field of a written file, by offset.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Field {
    /// A u64 record length or byte-array length.
    Len64(usize),
    /// A u32 string length.
    Len32(usize),
    /// A chunk's uncompressed size (u64).
    Size(usize),
    /// A chunk's uncompressed CRC (u32).
    Crc(usize),
}

impl Field {
    fn shifted(self, by: usize) -> Self {
        match self {
            Field::Len64(a) => Field::Len64(a + by),
            Field::Len32(a) => Field::Len32(a + by),
            Field::Size(a) => Field::Size(a + by),
            Field::Crc(a) => Field::Crc(a + by),
        }
    }
}

fn write_rec(out: &mut Vec<u8>, op: u8, body: &[u8], fields: &mut Vec<Field>) {
    out.push(op);
    fields.push(Field::Len64(out.len()));
    out.extend_from_slice(&(body.len() as u64).to_le_bytes());
    out.extend_from_slice(body);
}

/// A small deterministic generator (xorshift64*), seeded by libFuzzer's seed.
pub struct Rng(u64);

impl Rng {
    /// A generator from libFuzzer's seed.
    pub fn new(seed: u32) -> Self {
        Self(u64::from(seed).wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }
    /// The next 64 random bits.
    pub fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    /// Uniform in `0..n` (0 when `n` is 0).
    pub fn below(&mut self, n: usize) -> usize {
        if n == 0 {
            0
        } else {
            (self.next() % n as u64) as usize
        }
    }
}

/// Values a length or count field is set to.
fn interesting_u64(rng: &mut Rng, old: u64) -> u64 {
    match rng.below(12) {
        0 => 0,
        1 => old.wrapping_add(1),
        2 => old.wrapping_sub(1),
        3 => 1 << 62,
        4 => 1 << 63,
        5 => u64::MAX,
        6 => old.wrapping_mul(2),
        7 => old / 2,
        8 => u64::from(u32::MAX),
        9 => 1 << 32,
        10 => 1_000_000_000_000_000,
        _ => rng.next(),
    }
}

fn interesting_u32(rng: &mut Rng, old: u32) -> u32 {
    match rng.below(10) {
        0 => 0,
        1 => old.wrapping_add(1),
        2 => old.wrapping_sub(1),
        3 => u32::MAX,
        4 => 1 << 31,
        5 => 20_000,
        6 => 0x7fff_ffff,
        7 => old.wrapping_mul(2),
        8 => 1 << 16,
        _ => rng.next() as u32,
    }
}

/// Breaks one length, size or CRC field of a written file.
pub fn break_field(out: &mut [u8], fields: &[Field], rng: &mut Rng) {
    let Some(&f) = fields.get(rng.below(fields.len())) else {
        return;
    };
    match f {
        Field::Len64(a) | Field::Size(a) => {
            if let Some(old) = u64_at(out, a) {
                let new = interesting_u64(rng, old);
                out[a..a + 8].copy_from_slice(&new.to_le_bytes());
            }
        }
        Field::Len32(a) | Field::Crc(a) => {
            if let Some(old) = u32_at(out, a) {
                let new = interesting_u32(rng, old);
                out[a..a + 4].copy_from_slice(&new.to_le_bytes());
            }
        }
    }
}

/// Byte-level mutation of a buffer in place (libFuzzer's `LLVMFuzzerMutate` in the fuzz
/// target; anything in tests), given the room it may grow into.
pub type ByteMutator<'a> = dyn FnMut(&mut Vec<u8>, usize) + 'a;

/// A record's place: its index among the top-level items, and within a chunk its index there.
type Slot = (usize, Option<usize>);

/// Applies one structural mutation to `m`.
pub fn mutate_structure(m: &mut Mcap, rng: &mut Rng, bytes: &mut ByteMutator<'_>) {
    let slots = m.record_slots();
    if slots.is_empty() {
        m.top.push(Top::Rec(Rec {
            op: op::MESSAGE,
            body: vec![0; 22],
        }));
        return;
    }
    let slot = slots[rng.below(slots.len())];
    let messages: Vec<_> = slots
        .iter()
        .copied()
        .filter(|&s| m.rec_mut(s).is_some_and(|r| r.op == op::MESSAGE))
        .collect();
    match rng.below(12) {
        // A message's payload (the CDR JointState, or JSON), byte by byte.
        0 | 1 => mutate_payload(m, rng, bytes, &messages),
        // A 4-aligned u32 of a payload (a CDR sequence count or string length) or a u64 of a
        // record's fixed fields (times, ids, sizes) set to an interesting value.
        2 | 3 => set_interesting_value(m, rng, slot),
        // A message's log time (or publish time) set to an extreme or nearby value.
        4 => set_message_time(m, rng, &messages),
        // A channel or schema id pointed elsewhere.
        5 => repoint_id(m, rng, slot),
        // Any record's body, byte by byte (schema, channel and metadata strings and maps).
        6 => mutate_body(m, bytes, slot),
        // An opcode changed.
        7 => change_opcode(m, rng, slot),
        // A record duplicated, deleted, or moved.
        8 => move_record(m, rng, slot, &slots),
        // A chunk's compression changed, or its time range.
        9 => change_chunk(m, rng),
        // A chunk split in two, or records gathered into a new chunk.
        10 => split_or_gather_chunk(m, rng, slot),
        // Chunks flattened into top-level records (an unchunked file).
        _ => flatten_chunks(m),
    }
}

/// A message's payload (the CDR JointState, or JSON), byte by byte.
fn mutate_payload(m: &mut Mcap, rng: &mut Rng, bytes: &mut ByteMutator<'_>, messages: &[Slot]) {
    if let Some(&s) = messages.get(rng.below(messages.len())) {
        if let Some(r) = m.rec_mut(s) {
            if r.body.len() >= 22 {
                let mut payload = r.body.split_off(22);
                bytes(&mut payload, 64);
                r.body.extend_from_slice(&payload);
            }
        }
    }
}

/// A 4-aligned u32 of a payload (a CDR sequence count or string length) or a u64 of a
/// record's fixed fields (times, ids, sizes) set to an interesting value.
fn set_interesting_value(m: &mut Mcap, rng: &mut Rng, slot: Slot) {
    if let Some(r) = m.rec_mut(slot) {
        let n = r.body.len();
        if r.op == op::MESSAGE && n >= 26 && rng.below(2) == 0 {
            let at = 22 + 4 + 4 * rng.below((n - 26) / 4 + 1);
            if let Some(old) = u32_at(&r.body, at) {
                let new = interesting_u32(rng, old);
                r.body[at..at + 4].copy_from_slice(&new.to_le_bytes());
            }
        } else if n >= 4 {
            let at = rng.below(n - 3);
            if n >= 8 && rng.below(2) == 0 {
                let at = rng.below(n - 7);
                let old = u64_at(&r.body, at).unwrap_or(0);
                let new = interesting_u64(rng, old);
                r.body[at..at + 8].copy_from_slice(&new.to_le_bytes());
            } else {
                let old = u32_at(&r.body, at).unwrap_or(0);
                let new = interesting_u32(rng, old);
                r.body[at..at + 4].copy_from_slice(&new.to_le_bytes());
            }
        }
    }
}

/// A message's log time (or publish time) set to an extreme or nearby value.
fn set_message_time(m: &mut Mcap, rng: &mut Rng, messages: &[Slot]) {
    if let Some(&s) = messages.get(rng.below(messages.len())) {
        let v = rng.next();
        if let Some(r) = m.rec_mut(s) {
            let at = if rng.below(2) == 0 { 6 } else { 14 };
            if let Some(old) = u64_at(&r.body, at) {
                let new = match v % 6 {
                    0 => 0,
                    1 => i64::MAX as u64,
                    2 => old.wrapping_add(1_000_000_000_000_000),
                    3 => old.wrapping_sub(1),
                    4 => 1 << 63,
                    _ => old.wrapping_add(v >> 40),
                };
                r.body[at..at + 8].copy_from_slice(&new.to_le_bytes());
            }
        }
    }
}

/// A channel or schema id pointed elsewhere.
fn repoint_id(m: &mut Mcap, rng: &mut Rng, slot: Slot) {
    if let Some(r) = m.rec_mut(slot) {
        if matches!(r.op, op::MESSAGE | op::CHANNEL | op::SCHEMA) && r.body.len() >= 2 {
            let v = [0u16, 1, 2, 3, u16::MAX][rng.below(5)];
            r.body[..2].copy_from_slice(&v.to_le_bytes());
        } else if r.op == op::CHANNEL && r.body.len() >= 4 {
            let v = [0u16, 1, 2, 3, u16::MAX][rng.below(5)];
            r.body[2..4].copy_from_slice(&v.to_le_bytes());
        }
    }
}

/// Any record's body, byte by byte (schema, channel and metadata strings and maps).
fn mutate_body(m: &mut Mcap, bytes: &mut ByteMutator<'_>, slot: Slot) {
    if let Some(r) = m.rec_mut(slot) {
        bytes(&mut r.body, 64);
    }
}

/// An opcode changed.
fn change_opcode(m: &mut Mcap, rng: &mut Rng, slot: Slot) {
    let new = [
        op::HEADER,
        op::FOOTER,
        op::SCHEMA,
        op::CHANNEL,
        op::MESSAGE,
        op::CHUNK,
        op::METADATA,
        op::DATA_END,
        0x07,
        0x08,
        0x09,
        0x0A,
        0x0B,
        0x0D,
        0x0E,
        0x80,
        0xFF,
    ][rng.below(17)];
    if let Some(r) = m.rec_mut(slot) {
        r.op = new;
    }
}

/// A record duplicated, deleted, or moved.
fn move_record(m: &mut Mcap, rng: &mut Rng, slot: Slot, slots: &[Slot]) {
    let Some(r) = m.rec_mut(slot).cloned() else {
        return;
    };
    let dest = slots[rng.below(slots.len())];
    match rng.below(3) {
        0 => insert_at(m, dest, r),
        1 => remove_at(m, slot),
        _ => {
            remove_at(m, slot);
            insert_at(m, dest, r);
        }
    }
}

/// A chunk's compression changed, or its time range.
fn change_chunk(m: &mut Mcap, rng: &mut Rng) {
    let chunks: Vec<usize> = (0..m.top.len())
        .filter(|&i| matches!(m.top[i], Top::Chunk(_)))
        .collect();
    if let Some(&i) = chunks.get(rng.below(chunks.len())) {
        let v = rng.next();
        if let Top::Chunk(c) = &mut m.top[i] {
            match v % 5 {
                0 => c.compression = String::new(),
                1 => c.compression = "zstd".into(),
                2 => c.compression = "lz4".into(),
                3 => c.start = v >> 8,
                _ => c.end = c.start.wrapping_sub(1),
            }
        }
    }
}

/// A chunk split in two, or records gathered into a new chunk.
fn split_or_gather_chunk(m: &mut Mcap, rng: &mut Rng, slot: Slot) {
    let i = slot.0;
    match m.top.get(i).cloned() {
        Some(Top::Chunk(c)) if c.records.len() >= 2 => {
            let k = 1 + rng.below(c.records.len() - 1);
            let mut a = c.clone();
            let mut b = c;
            b.records = a.records.split_off(k);
            m.top.splice(i..=i, [Top::Chunk(a), Top::Chunk(b)]);
        }
        Some(Top::Rec(r)) => {
            let compression = ["", "zstd", "lz4"][rng.below(3)].to_string();
            m.top[i] = Top::Chunk(Chunk {
                start: 0,
                end: u64::MAX,
                compression,
                records: vec![r],
            });
        }
        _ => {}
    }
}

/// Chunks flattened into top-level records (an unchunked file).
fn flatten_chunks(m: &mut Mcap) {
    let top = std::mem::take(&mut m.top);
    for t in top {
        match t {
            Top::Chunk(c) => m.top.extend(c.records.into_iter().map(Top::Rec)),
            r => m.top.push(r),
        }
    }
}

fn insert_at(m: &mut Mcap, slot: (usize, Option<usize>), r: Rec) {
    match (m.top.get_mut(slot.0), slot.1) {
        (Some(Top::Chunk(c)), Some(j)) => c.records.insert(j.min(c.records.len()), r),
        _ => m.top.insert(slot.0.min(m.top.len()), Top::Rec(r)),
    }
}

fn remove_at(m: &mut Mcap, slot: (usize, Option<usize>)) {
    match (m.top.get_mut(slot.0), slot.1) {
        (Some(Top::Chunk(c)), Some(j)) if j < c.records.len() => {
            c.records.remove(j);
        }
        (Some(Top::Rec(_)), None) => {
            m.top.remove(slot.0);
        }
        _ => {}
    }
}

/// The whole mutation: parse `data`, apply one to three structural mutations, write it back
/// with correct lengths and CRCs and, one time in five, break one length/size/CRC field.
/// `None` when `data` does not parse or the result exceeds `max_size`.
pub fn mutate(
    data: &[u8],
    max_size: usize,
    seed: u32,
    bytes: &mut ByteMutator<'_>,
) -> Option<Vec<u8>> {
    let mut m = Mcap::parse(data)?;
    let mut rng = Rng::new(seed);
    for _ in 0..1 + rng.below(3) {
        mutate_structure(&mut m, &mut rng, bytes);
    }
    let mut fields = Vec::new();
    let mut out = m.write(&mut fields);
    if rng.below(5) == 0 {
        break_field(&mut out, &fields, &mut rng);
    }
    (out.len() <= max_size).then_some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn seed_file(compression: sgplvm_robots::joint_state::Compression) -> Vec<u8> {
        use sgplvm_robots::joint_state::{write_topics, JointStates, MessageEncoding, TopicData};
        let s = JointStates::new(
            vec![1_000, 25_001_000, 50_001_000],
            vec!["a".into(), "b".into()],
            vec![0.1, 0.2, 0.3, 0.4, 0.5, 0.6],
        )
        .expect("series");
        let dir = std::env::temp_dir().join(format!("structured-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let path = dir.join(format!("{compression:?}.mcap"));
        write_topics(
            &path,
            &[TopicData {
                topic: "/human/joint_states",
                states: &s,
                encoding: MessageEncoding::Cdr,
            }],
            &sgplvm_robots::joint_state::WriteSettings {
                compression,
                ..Default::default()
            },
        )
        .expect("write");
        std::fs::read(&path).expect("read")
    }

    fn read(bytes: &[u8]) -> Result<sgplvm_robots::joint_state::JointStates, String> {
        let path =
            std::env::temp_dir().join(format!("structured-read-{}.mcap", std::process::id()));
        std::fs::write(&path, bytes).map_err(|e| e.to_string())?;
        sgplvm_robots::joint_state::read_joint_states(&path, "/human/joint_states")
            .map_err(|e| e.to_string())
    }

    /// Parsing and writing back a file of every compression keeps what the reader reads
    /// (lengths, sizes and CRCs recomputed correctly), and recompressing keeps it too.
    #[test]
    fn round_trip_reads_the_same() {
        use sgplvm_robots::joint_state::Compression;
        for compression in [Compression::None, Compression::Zstd, Compression::Lz4] {
            let bytes = seed_file(compression);
            let want = read(&bytes).expect("seed reads");
            let mut m = Mcap::parse(&bytes).expect("parses");
            assert!(m.top.iter().any(|t| matches!(t, Top::Chunk(_))));
            let mut fields = Vec::new();
            let out = m.write(&mut fields);
            assert_eq!(
                read(&out).expect("written file reads"),
                want,
                "{compression:?}"
            );
            for t in &mut m.top {
                if let Top::Chunk(c) = t {
                    c.compression = "lz4".into();
                }
            }
            let out = m.write(&mut Vec::new());
            assert_eq!(read(&out).expect("recompressed reads"), want);
        }
    }

    /// A message's log time changed structurally reaches the reader (the CRC is right): the
    /// series read changes instead of being refused as corrupt.
    #[test]
    fn structural_changes_reach_the_reader() {
        let bytes = seed_file(sgplvm_robots::joint_state::Compression::Zstd);
        let want = read(&bytes).expect("seed reads");
        let mut m = Mcap::parse(&bytes).expect("parses");
        for t in &mut m.top {
            if let Top::Chunk(c) = t {
                for r in &mut c.records {
                    if r.op == op::MESSAGE {
                        r.body[6..14].copy_from_slice(&7u64.to_le_bytes());
                        break;
                    }
                }
            }
        }
        let got = read(&m.write(&mut Vec::new())).expect("still reads");
        assert_ne!(got, want);
        assert_eq!(got.times_ns[0], 7);
    }

    /// Many seeds of the whole mutation run without panicking and mostly produce files that
    /// still parse as MCAP structure.
    #[test]
    fn mutations_run() {
        let bytes = seed_file(sgplvm_robots::joint_state::Compression::Lz4);
        let mut parsed = 0;
        for seed in 0..2000u32 {
            let mut flip = |b: &mut Vec<u8>, _room: usize| {
                if let Some(x) = b.first_mut() {
                    *x ^= 0x55;
                }
            };
            if let Some(out) = mutate(&bytes, 1 << 20, seed, &mut flip) {
                parsed += usize::from(Mcap::parse(&out).is_some());
            }
        }
        assert!(parsed > 1000, "{parsed}");
    }
}
