//! Reading JointState topics from an MCAP file in one streaming pass (mcap's sans-io reader,
//! chunk CRCs checked): only the requested topics are decoded, straight into row-major
//! position arrays in the joint order the caller asks for; messages that list their joints
//! in another order are reordered, and a message lacking a wanted joint is an error. Rows
//! come back sorted by time.

use std::collections::{BTreeMap, HashMap};
use std::fs::File;
use std::io::{BufReader, Read};
use std::path::Path;

use ::mcap::records::{op, Record};
use ::mcap::sans_io::{LinearReadEvent, LinearReader, LinearReaderOptions};
use ::mcap::McapError;

use super::{cdr, json, JointStateError, JointStates, Result};

/// Which timestamp of a message places it on the clock.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum TimeSource {
    /// The MCAP record's log time (when the recorder received it; what rosbag2 writes).
    #[default]
    LogTime,
    /// The message's `header.stamp` (when the sender measured it).
    HeaderStamp,
}

/// One topic to read and, optionally, the joints wanted from it in the wanted order.
#[derive(Debug, Clone, PartialEq)]
pub struct TopicRequest {
    /// Topic name.
    pub topic: String,
    /// Joints to extract, in this order (e.g. a body model's joint names); extra joints in the
    /// messages are ignored, missing ones are an error. `None` takes the first message's joints.
    pub joint_names: Option<Vec<String>>,
    /// Which timestamp to use.
    pub time_source: TimeSource,
}

impl TopicRequest {
    /// Request for all joints of `topic`, in the order of its first message.
    pub fn all(topic: impl Into<String>) -> Self {
        Self {
            topic: topic.into(),
            joint_names: None,
            time_source: TimeSource::LogTime,
        }
    }

    /// Request for the named joints of `topic`, in that order.
    pub fn joints(topic: impl Into<String>, names: &[String]) -> Self {
        Self {
            topic: topic.into(),
            joint_names: Some(names.to_vec()),
            time_source: TimeSource::LogTime,
        }
    }
}

/// What a streaming pass over an MCAP returns.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TopicsRead {
    /// One series per request, in request order, rows sorted by time.
    pub states: Vec<JointStates>,
    /// All metadata records of the file (name → key/value map).
    pub metadata: BTreeMap<String, BTreeMap<String, String>>,
    /// All channels of the file: topic, schema name, message encoding.
    pub channels: Vec<ChannelInfo>,
}

/// A channel found in a file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ChannelInfo {
    /// Topic name.
    pub topic: String,
    /// Schema name (empty without a schema).
    pub schema: String,
    /// Message encoding.
    pub message_encoding: String,
}

/// Reads all joints of one JointState topic, in the joint order of its first message (later
/// messages with another order are reordered; a message lacking one of them is an error).
pub fn read_joint_states(path: impl AsRef<Path>, topic: &str) -> Result<JointStates> {
    let mut read = read_topics(path, &[TopicRequest::all(topic)])?;
    Ok(read.states.remove(0))
}

/// Streams `path` once and extracts the requested topics, plus the file's metadata and
/// channel list. Messages of other topics are skipped without decoding.
pub fn read_topics(path: impl AsRef<Path>, requests: &[TopicRequest]) -> Result<TopicsRead> {
    let path = path.as_ref();
    let file = File::open(path).map_err(|source| JointStateError::Io {
        path: path.to_path_buf(),
        action: "open",
        source,
    })?;
    let file_len = file
        .metadata()
        .map_err(|source| JointStateError::Io {
            path: path.to_path_buf(),
            action: "read the size of",
            source,
        })?
        .len();
    // The reader asks for small pieces (one record of an uncompressed chunk at a time): a
    // large buffer turns those into few system calls.
    let mut stream = Stream::new(path, file_len, requests);
    let mut file = BufReader::with_capacity(1 << 20, file);
    // Every record, and every chunk's decompressed content, is checked against a limit derived
    // from the file's size before anything is allocated for it; chunks are decompressed whole
    // and their CRC checked before any record inside is parsed.
    let mut reader = LinearReader::new_with_options(
        LinearReaderOptions::default()
            .with_validate_chunk_crcs(true)
            .with_prevalidate_chunk_crcs(true)
            .with_record_length_limit(record_length_limit(file_len)),
    );
    while let Some(event) = next_event(&mut reader).map_err(|detail| stream.corrupt(detail))? {
        let event = event.map_err(|e| match e {
            McapError::UnexpectedEof => JointStateError::Truncated {
                path: path.to_path_buf(),
                topics: stream.topics_str.clone(),
            },
            source => stream.invalid(source),
        })?;
        match event {
            LinearReadEvent::ReadRequest(need) => {
                let buf = reader.insert(need);
                let n = read_retrying(&mut file, buf).map_err(|source| JointStateError::Io {
                    path: path.to_path_buf(),
                    action: "read",
                    source,
                })?;
                reader.notify_read(n);
            }
            LinearReadEvent::Record {
                opcode: op::MESSAGE,
                data,
            } => stream.message(data)?,
            // Only these records are used; the others are not even parsed.
            LinearReadEvent::Record {
                opcode: opcode @ (op::SCHEMA | op::CHANNEL | op::METADATA),
                data,
            } => {
                // mcap's parser reserves a string's declared length before reading it: check
                // every length against the record first.
                strings_fit(opcode, data).map_err(|detail| stream.corrupt(detail))?;
                let record = ::mcap::parse_record(opcode, data).map_err(|e| stream.invalid(e))?;
                stream.record(record)?;
            }
            LinearReadEvent::Record { .. } => {}
        }
    }
    stream.finish()
}

/// The largest record, or decompressed chunk, that [`read_topics`] accepts in a file of
/// `file_len` bytes: 16 MiB plus 16 times the file's size (the shipped demonstrations compress
/// 7.5 : 1 in chunks of under 1 MiB), so that a corrupt length field cannot make the reader
/// allocate more than that.
pub fn record_length_limit(file_len: u64) -> usize {
    const FLOOR: u64 = 16 << 20;
    const RATIO: u64 = 16;
    usize::try_from(file_len.saturating_mul(RATIO).saturating_add(FLOOR)).unwrap_or(usize::MAX)
}

/// Lists the channels of a file (one streaming pass, no message decoded).
pub fn list_channels(path: impl AsRef<Path>) -> Result<Vec<ChannelInfo>> {
    Ok(read_topics(path, &[])?.channels)
}

/// Where the messages of a channel go: the index of the request that wants them (or
/// `usize::MAX` for none) and whether they are JSON.
type Route = (usize, bool);

/// The state of one streaming pass of [`read_topics`].
struct Stream<'a> {
    path: &'a Path,
    /// The file's size, for the record length limit.
    file_len: u64,
    requests: &'a [TopicRequest],
    /// What is being read, for messages: `reading topic(s) `/a``, or `listing its channels and
    /// metadata`.
    topics_str: String,
    /// One accumulator per request.
    accs: Vec<TopicAcc>,
    /// Schema id → (name, encoding).
    schemas: BTreeMap<u16, (String, String)>,
    /// Channel id → route.
    channel_route: BTreeMap<u16, Route>,
    channels: Vec<ChannelInfo>,
    metadata: BTreeMap<String, BTreeMap<String, String>>,
    /// Whether each request's topic has a channel.
    seen_topics: Vec<bool>,
    /// The CDR decoder's scratch space for name offsets.
    names_scratch: Vec<(usize, usize)>,
    /// Route of the last message's channel, to skip the map lookup in long runs.
    last_route: Option<(u16, Route)>,
}

impl<'a> Stream<'a> {
    fn new(path: &'a Path, file_len: u64, requests: &'a [TopicRequest]) -> Self {
        let topics_str = if requests.is_empty() {
            "listing its channels and metadata".to_string()
        } else {
            let topics: Vec<String> = requests.iter().map(|r| format!("`{}`", r.topic)).collect();
            format!("reading topic(s) {}", topics.join(", "))
        };
        let accs = requests
            .iter()
            .map(|r| TopicAcc {
                names: r.joint_names.clone().unwrap_or_default(),
                fixed_names: r.joint_names.is_some(),
                ..TopicAcc::default()
            })
            .collect();
        Stream {
            path,
            file_len,
            requests,
            topics_str,
            accs,
            schemas: BTreeMap::new(),
            channel_route: BTreeMap::new(),
            channels: Vec::new(),
            metadata: BTreeMap::new(),
            seen_topics: vec![false; requests.len()],
            names_scratch: Vec::new(),
            last_route: None,
        }
    }

    /// A [`JointStateError::Corrupt`] saying `detail`.
    fn corrupt(&self, detail: String) -> JointStateError {
        JointStateError::Corrupt {
            path: self.path.to_path_buf(),
            topics: self.topics_str.clone(),
            detail,
        }
    }

    /// The error of an invalid MCAP structure: parse failures and oversized lengths as one
    /// plain line ([`JointStateError::Corrupt`]), the rest as the mcap crate reports them.
    fn invalid(&self, source: McapError) -> JointStateError {
        let corrupt = |detail: String| self.corrupt(detail);
        match &source {
            McapError::Parse(inner) => corrupt(format!(
                "record parse failed: {}",
                plain_line(&inner.to_string())
            )),
            McapError::RecordTooLarge { opcode, len } => corrupt(format!(
                "record with opcode {opcode:#04x} declares {len} bytes, more than the {} allowed for this file",
                record_length_limit(self.file_len)
            )),
            McapError::ChunkTooLarge(len) => corrupt(format!(
                "chunk declares {len} (de)compressed bytes, more than the {} allowed for this file",
                record_length_limit(self.file_len)
            )),
            McapError::Io(inner) => corrupt(plain_line(&format!("{source}: {inner}"))),
            McapError::DecompressionError(_) | McapError::BadChunkLength { .. } => {
                corrupt(plain_line(&source.to_string()))
            }
            _ => JointStateError::Mcap {
                path: self.path.to_path_buf(),
                topics: self.topics_str.clone(),
                source,
            },
        }
    }

    /// The route of `channel_id`'s messages.
    fn route(&mut self, channel_id: u16) -> Route {
        match self.last_route {
            Some((id, route)) if id == channel_id => route,
            _ => {
                let route = self
                    .channel_route
                    .get(&channel_id)
                    .copied()
                    .unwrap_or((usize::MAX, false));
                self.last_route = Some((channel_id, route));
                route
            }
        }
    }

    /// Decodes a Message record of a requested topic into its accumulator.
    fn message(&mut self, data: &[u8]) -> Result<()> {
        if data.len() < 22 {
            return Err(self.invalid(McapError::UnexpectedEoc));
        }
        let channel_id = u16::from_le_bytes([data[0], data[1]]);
        let (req, is_json) = self.route(channel_id);
        if req == usize::MAX {
            return Ok(());
        }
        let log_time = u64::from_le_bytes(
            data[6..14]
                .try_into()
                .expect("invariant: length checked above"),
        );
        let payload = &data[22..];
        let acc = &mut self.accs[req];
        let ctx = MsgCtx {
            path: self.path,
            topic: &self.requests[req].topic,
            index: acc.count,
            log_time,
        };
        let use_stamp = self.requests[req].time_source == TimeSource::HeaderStamp;
        if is_json {
            let msg = json::decode_joint_state(payload)
                .map_err(|e| ctx.malformed(format!("invalid JSON JointState: {e}")))?;
            let time = if use_stamp {
                let (sec, nanosec) = msg.stamp();
                stamp_time_ns(&ctx, sec, nanosec)?
            } else {
                log_time_ns(&ctx)?
            };
            acc.ingest(
                &ctx,
                time,
                msg.name.len(),
                |i| msg.name[i].as_bytes(),
                msg.position.len(),
                |i| msg.position[i],
            )
        } else {
            let view = cdr::decode_joint_state(payload, &mut self.names_scratch)
                .map_err(|d| ctx.malformed(format!("invalid CDR JointState: {d}")))?;
            let time = if use_stamp {
                stamp_time_ns(&ctx, view.stamp.0, view.stamp.1)?
            } else {
                log_time_ns(&ctx)?
            };
            acc.ingest(
                &ctx,
                time,
                view.name_count(),
                |i| view.name(i),
                view.position_len(),
                |i| view.position(i),
            )
        }
    }

    /// Takes note of a Schema, Channel or Metadata record; other records are skipped.
    fn record(&mut self, record: Record<'_>) -> Result<()> {
        match record {
            Record::Schema { header, .. } => {
                self.schemas
                    .insert(header.id, (header.name, header.encoding));
            }
            Record::Channel(ch) => {
                if self.channel_route.contains_key(&ch.id) {
                    return Ok(()); // repeated in the summary section
                }
                self.last_route = None;
                let (schema, schema_encoding) =
                    self.schemas.get(&ch.schema_id).cloned().unwrap_or_default();
                let mut route = (usize::MAX, false);
                if let Some(req) = self.requests.iter().position(|r| r.topic == ch.topic) {
                    self.seen_topics[req] = true;
                    let is_json = check_channel(
                        self.path,
                        &ch.topic,
                        &schema,
                        &schema_encoding,
                        &ch.message_encoding,
                    )?;
                    route = (req, is_json);
                }
                self.channel_route.insert(ch.id, route);
                self.channels.push(ChannelInfo {
                    topic: ch.topic,
                    schema,
                    message_encoding: ch.message_encoding,
                });
            }
            Record::Metadata(m) => {
                self.metadata.insert(m.name, m.metadata);
            }
            _ => {}
        }
        Ok(())
    }

    /// One series per request (every requested topic must have a channel and messages).
    fn finish(self) -> Result<TopicsRead> {
        let path = self.path;
        let mut states = Vec::with_capacity(self.requests.len());
        for ((req, acc), seen) in self.requests.iter().zip(self.accs).zip(self.seen_topics) {
            if !seen {
                let mut available: Vec<String> =
                    self.channels.iter().map(|c| c.topic.clone()).collect();
                available.dedup();
                return Err(JointStateError::MissingTopic {
                    path: path.to_path_buf(),
                    topic: req.topic.clone(),
                    available,
                });
            }
            if acc.count == 0 {
                return Err(JointStateError::EmptyTopic {
                    path: path.to_path_buf(),
                    topic: req.topic.clone(),
                });
            }
            let mut s = JointStates {
                times_ns: acc.times,
                names: acc.names,
                positions: acc.positions,
            };
            s.sort_by_time();
            states.push(s);
        }
        Ok(TopicsRead {
            states,
            metadata: self.metadata,
            channels: self.channels,
        })
    }
}

/// The reader's next event. mcap 0.26 can panic on inconsistent chunk contents (an arithmetic
/// overflow when a record inside an uncompressed chunk without CRC claims more bytes than the
/// chunk has, in builds with overflow checks): that panic is caught and becomes an error.
fn next_event(
    reader: &mut LinearReader,
) -> std::result::Result<Option<std::result::Result<LinearReadEvent<'_>, McapError>>, String> {
    crate::panics::catch(move || {
        let reader = reader;
        reader.next_event()
    })
    .map_err(|what| {
        format!(
            "inconsistent chunk contents (the mcap reader stopped: {})",
            plain_line(&what)
        )
    })
}

/// Checks that every string (and string map) of a Schema, Channel or Metadata record fits in
/// the record, so that parsing it allocates at most the record's size. A record too short for
/// a length field is left to mcap's parser, which reports it.
fn strings_fit(opcode: u8, data: &[u8]) -> std::result::Result<(), String> {
    struct Fields<'d> {
        data: &'d [u8],
        at: usize,
        record: &'static str,
    }
    impl Fields<'_> {
        fn u32(&mut self) -> Option<usize> {
            let b = self.data.get(self.at..self.at.checked_add(4)?)?;
            self.at += 4;
            usize::try_from(u32::from_le_bytes(b.try_into().ok()?)).ok()
        }
        fn string(&mut self, what: &str) -> std::result::Result<Option<()>, String> {
            let Some(len) = self.u32() else {
                return Ok(None);
            };
            let remain = self.data.len() - self.at;
            if len > remain {
                return Err(format!(
                    "{} record: {what} declares {len} bytes, only {remain} remain in the record",
                    self.record
                ));
            }
            self.at += len;
            Ok(Some(()))
        }
        fn map(&mut self, what: &str) -> std::result::Result<Option<()>, String> {
            let Some(byte_len) = self.u32() else {
                return Ok(None);
            };
            let start = self.at;
            while self.at - start < byte_len {
                if self.string(what)?.is_none() || self.string(what)?.is_none() {
                    return Ok(None);
                }
            }
            Ok(Some(()))
        }
    }
    let mut f = Fields {
        data,
        at: 0,
        record: "",
    };
    match opcode {
        op::SCHEMA => {
            f.record = "Schema";
            f.at = 2;
            if f.string("the name")?.is_some() {
                f.string("the encoding")?;
            }
        }
        op::CHANNEL => {
            f.record = "Channel";
            f.at = 4;
            if f.string("the topic")?.is_some() && f.string("the message encoding")?.is_some() {
                f.map("a metadata string")?;
            }
        }
        op::METADATA => {
            f.record = "Metadata";
            if f.string("the name")?.is_some() {
                f.map("a metadata string")?;
            }
        }
        _ => {}
    }
    Ok(())
}

/// `text` on one plain line: without terminal escape sequences, decoration lines, source
/// locations (`at /path/file.rs:123`) and frame numbers, its remaining lines joined by "; ".
/// binrw prints its errors as a coloured multi-line backtrace; this keeps what it says
/// ("failed to fill whole buffer; while parsing field 'metadata' in Channel").
fn plain_line(text: &str) -> String {
    let mut clean = String::with_capacity(text.len().min(4096));
    let mut chars = text.chars();
    while let Some(c) = chars.next() {
        match c {
            '\u{1b}' => {
                // CSI sequence: ESC [ parameters final-byte (0x40..=0x7e).
                if chars.next() == Some('[') {
                    for c in chars.by_ref() {
                        if ('\u{40}'..='\u{7e}').contains(&c) {
                            break;
                        }
                    }
                }
            }
            '\n' => clean.push('\n'),
            c if c.is_control() => {}
            c => clean.push(c),
        }
    }
    let mut parts: Vec<String> = Vec::new();
    for line in clean.lines() {
        let mut line = line.trim();
        if line.is_empty()
            || line.starts_with("at ")
            || !line.starts_with(|c: char| c.is_alphanumeric() || c == '`' || c == '\'')
        {
            continue;
        }
        // Frame numbers "0: ".
        if let Some((n, rest)) = line.split_once(": ") {
            if !n.is_empty() && n.bytes().all(|b| b.is_ascii_digit()) {
                line = rest.trim();
            }
        }
        let line = line.strip_prefix("Error: ").unwrap_or(line);
        let line = match line.strip_prefix("While ") {
            Some(rest) => format!("while {rest}"),
            None => line.to_string(),
        };
        if !line.is_empty() && !parts.contains(&line) {
            parts.push(line);
        }
    }
    let mut out = parts.join("; ");
    if out.len() > 300 {
        let cut = (0..=300)
            .rev()
            .find(|&i| out.is_char_boundary(i))
            .unwrap_or(0);
        out.truncate(cut);
        out.push('…');
    }
    out
}

#[cfg(test)]
mod plain_line_tests {
    #[test]
    fn binrw_backtraces_become_one_plain_line() {
        let raw = "\n ╺━━━━┅ Backtrace ┅━━━━╸\n\n 0: \u{1b}[1m\u{1b}[1mError: failed to fill whole buffer\u{1b}[22m\n           \u{1b}[1mWhile parsing field 'offset' in MessageIndexEntry\u{1b}[22m\u{1b}[22m\n     at /root/.cargo/registry/src/x/mcap-0.26.0/src/records.rs:373\n 1: \u{1b}[1mWhile parsing field 'records' in MessageIndex\u{1b}[22m\n     at /root/.cargo/registry/src/x/mcap-0.26.0/src/records.rs:382\n\n ╺━━━━╸\n\n";
        assert_eq!(
            super::plain_line(raw),
            "failed to fill whole buffer; while parsing field 'offset' in MessageIndexEntry; while parsing field 'records' in MessageIndex"
        );
        assert_eq!(
            super::plain_line("Data corruption detected"),
            "Data corruption detected"
        );
    }
}

fn read_retrying(file: &mut impl Read, buf: &mut [u8]) -> std::io::Result<usize> {
    loop {
        match file.read(buf) {
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            other => return other,
        }
    }
}

/// Validates a requested channel; returns whether its messages are JSON.
fn check_channel(
    path: &Path,
    topic: &str,
    schema: &str,
    schema_encoding: &str,
    message_encoding: &str,
) -> Result<bool> {
    let wrong_schema = || JointStateError::WrongSchema {
        path: path.to_path_buf(),
        topic: topic.to_string(),
        schema: schema.to_string(),
        schema_encoding: schema_encoding.to_string(),
    };
    let is_joint_state = matches!(
        schema,
        "sensor_msgs/msg/JointState" | "sensor_msgs/JointState"
    );
    match message_encoding {
        "cdr" => {
            if !is_joint_state || !matches!(schema_encoding, "ros2msg" | "ros2idl") {
                return Err(wrong_schema());
            }
            Ok(false)
        }
        "json" => {
            let schema_ok = schema.is_empty() || is_joint_state;
            if !schema_ok || !matches!(schema_encoding, "" | "jsonschema") {
                return Err(wrong_schema());
            }
            Ok(true)
        }
        other => Err(JointStateError::WrongEncoding {
            path: path.to_path_buf(),
            topic: topic.to_string(),
            encoding: other.to_string(),
        }),
    }
}

fn log_time_ns(ctx: &MsgCtx<'_>) -> Result<i64> {
    i64::try_from(ctx.log_time)
        .map_err(|_| ctx.malformed("log time exceeds i64 nanoseconds".into()))
}

/// The time of a `header.stamp`, refused when negative (MCAP times are unsigned).
fn stamp_time_ns(ctx: &MsgCtx<'_>, sec: i32, nanosec: u32) -> Result<i64> {
    let t = sec as i64 * 1_000_000_000 + nanosec as i64;
    if t < 0 {
        return Err(ctx.malformed(format!(
            "header.stamp {sec} s {nanosec} ns is negative, expected a time ≥ 0"
        )));
    }
    Ok(t)
}

struct MsgCtx<'a> {
    path: &'a Path,
    topic: &'a str,
    index: usize,
    log_time: u64,
}

impl MsgCtx<'_> {
    fn malformed(&self, detail: String) -> JointStateError {
        JointStateError::Malformed {
            path: self.path.to_path_buf(),
            topic: self.topic.to_string(),
            index: self.index,
            log_time_ns: self.log_time,
            detail,
        }
    }
}

/// Per-topic accumulation of decoded rows.
#[derive(Default)]
struct TopicAcc {
    /// Output joint names (requested, or taken from the first message).
    names: Vec<String>,
    /// Whether `names` came from the request.
    fixed_names: bool,
    times: Vec<i64>,
    positions: Vec<f64>,
    count: usize,
    /// Names of the last message whose mapping is cached, concatenated with NUL separators.
    cached_names: Vec<u8>,
    cached_count: usize,
    /// For each output joint, its index in the cached message layout.
    mapping: Vec<usize>,
}

impl TopicAcc {
    fn ingest<'n>(
        &mut self,
        ctx: &MsgCtx<'_>,
        time: i64,
        name_count: usize,
        name: impl Fn(usize) -> &'n [u8],
        position_len: usize,
        position: impl Fn(usize) -> f64,
    ) -> Result<()> {
        if position_len != name_count {
            return Err(ctx.malformed(format!(
                "{name_count} joint names but {position_len} positions"
            )));
        }
        if !self.same_layout(name_count, &name) {
            self.relayout(ctx, name_count, &name)?;
        }
        self.times.push(time);
        self.positions
            .extend(self.mapping.iter().map(|&i| position(i)));
        self.count += 1;
        Ok(())
    }

    fn same_layout<'n>(&self, name_count: usize, name: &impl Fn(usize) -> &'n [u8]) -> bool {
        if self.count == 0 || name_count != self.cached_count {
            return false;
        }
        let mut at = 0;
        for i in 0..name_count {
            let n = name(i);
            let end = at + n.len();
            if self.cached_names.get(at..end) != Some(n) || self.cached_names.get(end) != Some(&0) {
                return false;
            }
            at = end + 1;
        }
        at == self.cached_names.len()
    }

    fn relayout<'n>(
        &mut self,
        ctx: &MsgCtx<'_>,
        name_count: usize,
        name: &impl Fn(usize) -> &'n [u8],
    ) -> Result<()> {
        // Names are looked up by hash: a message may list tens of thousands of joints.
        let mut present = Vec::with_capacity(name_count);
        let mut position_of: HashMap<&str, usize> = HashMap::with_capacity(name_count);
        for i in 0..name_count {
            let s = std::str::from_utf8(name(i))
                .map_err(|_| ctx.malformed(format!("joint name #{i} is not UTF-8")))?;
            if position_of.insert(s, i).is_some() {
                return Err(ctx.malformed(format!("joint name `{s}` appears twice")));
            }
            present.push(s.to_string());
        }
        if self.count == 0 && !self.fixed_names {
            self.names = present.clone();
        }
        let mut mapping = Vec::with_capacity(self.names.len());
        let mut missing = Vec::new();
        for n in &self.names {
            match position_of.get(n.as_str()) {
                Some(&i) => mapping.push(i),
                None => missing.push(n.clone()),
            }
        }
        drop(position_of);
        if !missing.is_empty() {
            return Err(JointStateError::MissingJoints {
                path: ctx.path.to_path_buf(),
                topic: ctx.topic.to_string(),
                index: ctx.index,
                missing,
                present,
            });
        }
        self.mapping = mapping;
        self.cached_names.clear();
        for p in &present {
            self.cached_names.extend_from_slice(p.as_bytes());
            self.cached_names.push(0);
        }
        self.cached_count = name_count;
        Ok(())
    }
}
