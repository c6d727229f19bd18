//! A frame MVN split across several datagrams put back together (§2.4.1.3): the parts of one
//! sample carry the same sample counter and the indices 0, 1, …, the last one with bit 7 set
//! (`0, 1, 0x82` for three). One frame is assembled at a time: a stream of poses has no use for
//! an old one, so a part of a newer sample gives up the frame being assembled.

use super::datagram::{MvnPart, MvnPose, PoseType};
use super::segments::segment_name;
use super::MvnError;

/// Samples by which a counter may go back and still be the same stream (a late datagram); one
/// further back is taken as the sender starting again (MVN restarted, or a new recording).
/// About a second at MVN's highest rate, 240 Hz.
pub const LATE_WINDOW: u32 = 240;

/// How a sample counter stands against another.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Age {
    /// The same sample.
    Same,
    /// A later sample (counters wrap around).
    Newer,
    /// An earlier sample, at most [`LATE_WINDOW`] back.
    Late,
    /// Further back than [`LATE_WINDOW`]: the sender started counting again.
    Restart,
}

/// How sample `s` stands against `reference`.
pub fn age(s: u32, reference: u32) -> Age {
    // Reinterpreting the wrapped difference as signed orders counters across the wrap.
    let d = s.wrapping_sub(reference) as i32;
    match d {
        0 => Age::Same,
        d if d > 0 => Age::Newer,
        d if d.unsigned_abs() <= LATE_WINDOW => Age::Late,
        _ => Age::Restart,
    }
}

/// What one datagram did to the frame being assembled.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Pushed {
    /// The frame it completed (a whole-frame datagram completes itself).
    pub complete: Option<MvnPose>,
    /// Whether an incomplete frame was given up for this newer one.
    pub abandoned: bool,
    /// Whether it belonged to a sample older than the one being assembled (dropped).
    pub late: bool,
}

/// The parts of one sample so far.
#[derive(Debug, Clone)]
struct Pending {
    sample: u32,
    kind: PoseType,
    character: u8,
    parts: Vec<Option<MvnPose>>,
    last: Option<u8>,
}

/// Puts split frames back together, one frame at a time.
#[derive(Debug, Clone, Default)]
pub struct Reassembler {
    pending: Option<Pending>,
}

impl Reassembler {
    /// An assembler with nothing pending.
    pub fn new() -> Reassembler {
        Reassembler::default()
    }

    /// Whether parts of an incomplete frame are waiting.
    pub fn pending(&self) -> bool {
        self.pending.is_some()
    }

    /// Takes one decoded datagram. A part that does not fit the others of its sample (an index
    /// twice, two different last indices, an index past the last, a segment in two parts) is an
    /// error, and the frame is given up.
    pub fn push(&mut self, part: MvnPart) -> Result<Pushed, MvnError> {
        let sample = part.pose.sample_counter;
        let mut pushed = Pushed::default();
        let relation = self.pending.as_ref().map(|p| {
            let same_stream = p.kind == part.pose.kind && p.character == part.pose.character_id;
            (age(sample, p.sample), same_stream)
        });
        if part.index == 0 && part.last {
            if let Some((Age::Same | Age::Newer | Age::Restart, _)) = relation {
                self.pending = None;
                pushed.abandoned = true;
            }
            pushed.complete = Some(part.pose);
            return Ok(pushed);
        }
        match relation {
            Some((Age::Same, true)) => {}
            Some((Age::Late, _)) => {
                pushed.late = true;
                return Ok(pushed);
            }
            other => {
                pushed.abandoned = other.is_some();
                self.pending = Some(Pending {
                    sample,
                    kind: part.pose.kind,
                    character: part.pose.character_id,
                    parts: Vec::new(),
                    last: None,
                });
            }
        }
        match self.add(part) {
            Ok(complete) => {
                pushed.complete = complete;
                Ok(pushed)
            }
            Err(e) => {
                self.pending = None;
                Err(e)
            }
        }
    }

    /// Adds `part` to the pending frame; the frame when it is complete.
    fn add(&mut self, part: MvnPart) -> Result<Option<MvnPose>, MvnError> {
        let Some(p) = self.pending.as_mut() else {
            return Ok(None);
        };
        let sample = p.sample;
        let bad = |message: String| MvnError::Parts { sample, message };
        let i = usize::from(part.index);
        if part.last {
            if let Some(l) = p.last.filter(|&l| l != part.index) {
                return Err(bad(format!(
                    "datagrams {l} and {} both say they are the last; expected one last datagram",
                    part.index
                )));
            }
            p.last = Some(part.index);
        }
        if p.parts.len() <= i {
            p.parts.resize(i + 1, None);
        }
        if p.parts[i].is_some() {
            return Err(bad(format!("datagram {i} twice; expected each index once")));
        }
        p.parts[i] = Some(part.pose);
        let Some(last) = p.last.map(usize::from) else {
            return Ok(None);
        };
        if p.parts.len() > last + 1 {
            return Err(bad(format!(
                "a datagram with index {} past the last, {last}",
                p.parts.len() - 1
            )));
        }
        if p.parts.iter().any(Option::is_none) {
            return Ok(None);
        }
        let parts = std::mem::take(&mut p.parts);
        self.pending = None;
        merge(sample, parts.into_iter().flatten()).map(Some)
    }
}

/// The parts of one sample, in index order, as one frame (header fields from the first).
fn merge(sample: u32, mut parts: impl Iterator<Item = MvnPose>) -> Result<MvnPose, MvnError> {
    let Some(mut frame) = parts.next() else {
        return Err(MvnError::Parts {
            sample,
            message: "no datagram".into(),
        });
    };
    for p in parts {
        frame.segments.extend(p.segments);
    }
    let props = frame.counts.map_or(4, |c| c.props);
    let mut seen = 0u128;
    for (item, s) in frame.segments.iter().enumerate() {
        // Each part's IDs were checked to be at most 67.
        let bit = 1u128 << s.id.min(127);
        if seen & bit != 0 {
            return Err(MvnError::DuplicateSegment {
                item,
                id: s.id,
                name: segment_name(s.id, props).unwrap_or("?"),
            });
        }
        seen |= bit;
    }
    Ok(frame)
}
