//! One streaming pass of [`read_topics`](super::read_topics): the schemas and channels seen so
//! far, where each channel's messages go, and every message of a requested topic decoded
//! (CDR or JSON) into that topic's rows.

use std::collections::BTreeMap;
use std::path::Path;

use ::mcap::records::Record;
use ::mcap::McapError;

use super::guard::plain_line;
use super::topic::{log_time_ns, stamp_time_ns, MsgCtx, TopicAcc};
use super::{record_length_limit, ChannelInfo, TimeSource, TopicRequest, TopicsRead};
use crate::joint_state::{cdr, json, JointStateError, JointStates, Result};

/// Where the messages of a channel go: the index of the request that wants them (or
/// `usize::MAX` for none) and whether they are JSON.
type Route = (usize, bool);

/// The state of one streaming pass of [`read_topics`](super::read_topics).
pub(super) struct Stream<'a> {
    path: &'a Path,
    /// The file's size, for the record length limit.
    file_len: u64,
    requests: &'a [TopicRequest],
    /// What is being read, for messages: `reading topic(s) `/a``, or `listing its channels and
    /// metadata`.
    pub(super) topics_str: String,
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
    pub(super) fn new(path: &'a Path, file_len: u64, requests: &'a [TopicRequest]) -> Self {
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
    pub(super) fn corrupt(&self, detail: String) -> JointStateError {
        JointStateError::Corrupt {
            path: self.path.to_path_buf(),
            topics: self.topics_str.clone(),
            detail,
        }
    }

    /// The error of an invalid MCAP structure: parse failures and oversized lengths as one
    /// plain line ([`JointStateError::Corrupt`]), the rest as the mcap crate reports them.
    pub(super) fn invalid(&self, source: McapError) -> JointStateError {
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
    pub(super) fn message(&mut self, data: &[u8]) -> Result<()> {
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
    pub(super) fn record(&mut self, record: Record<'_>) -> Result<()> {
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
    pub(super) fn finish(self) -> Result<TopicsRead> {
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
