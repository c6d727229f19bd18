//! Metres or centimetres: the specification (§2.5.6) gives every pose type's positions in
//! centimetres, the MVN user manual and Xsens' own sample parser read type 02 as metres (the
//! decoder takes 02 as metres and 01 as centimetres, [`super`]'s module docs). The stream itself
//! tells them apart: a person's segments are about as long in every pose. [`body_span`] adds the
//! lengths between the segment origins of the spine (pelvis to neck), an upper arm and forearm
//! and a thigh and shank (each the mean of both sides): 1.6–2.4 m for an adult, above 1 m for a
//! child. [`Units::of_span`] reads the units off it; the receiver decides on the first frame
//! that holds those segments and keeps that for the stream ([`super::MvnReceiver::units`]).
//!
//! The commands do not depend on it (the arms' fit uses the segments' orientations); the fit's
//! residuals, in metres, do.

use serde::Serialize;

use super::datagram::{MvnPose, SegmentPose};
use super::segments::segment_id;

/// The range of [`body_span`] taken as a person's, metres: a small child to a tall adult with
/// room on both sides. Its hundredfold is 80–400: a person in centimetres; its hundredth
/// 8–40 mm, no person.
pub const PERSON_SPAN_M: (f64, f64) = (0.8, 4.0);

/// What a stream's positions were sent in, as its person's proportions say.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Units {
    /// Read as decoded: a person's span in metres.
    AsDecoded,
    /// A hundred times a person's span: centimetres where the decoder read metres (type 02 as
    /// §2.5.6 says); scaled by 0.01.
    Centimetres,
    /// A hundredth of a person's span: metres where the decoder read centimetres (type 01);
    /// scaled by 100.
    Metres,
}

impl Units {
    /// The units that make a span of `span` (as decoded) a person's, if any does.
    pub fn of_span(span: f64) -> Option<Units> {
        let person = |s: f64| s >= PERSON_SPAN_M.0 && s <= PERSON_SPAN_M.1;
        if person(span) {
            Some(Units::AsDecoded)
        } else if person(span * 0.01) {
            Some(Units::Centimetres)
        } else if person(span * 100.0) {
            Some(Units::Metres)
        } else {
            None
        }
    }

    /// The factor that makes the decoded positions metres.
    pub fn scale(self) -> f32 {
        match self {
            Units::AsDecoded => 1.0,
            Units::Centimetres => 0.01,
            Units::Metres => 100.0,
        }
    }

    /// Scales every position of `pose` into metres.
    pub fn apply(self, pose: &mut MvnPose) {
        let s = self.scale();
        if s != 1.0 {
            for seg in &mut pose.segments {
                for v in &mut seg.position {
                    *v *= s;
                }
            }
        }
    }
}

/// The sum of the lengths between the segment origins of the spine (pelvis to neck), an upper
/// arm, a forearm, a thigh and a shank (each the mean of both sides), in the units decoded;
/// `None` when a segment is missing.
pub fn body_span(pose: &MvnPose) -> Option<f64> {
    let props = pose.counts.map_or(0, |c| c.props);
    let at = |name: &str| -> Option<[f64; 3]> {
        let id = segment_id(name, props)?;
        let s: &SegmentPose = pose.segments.iter().find(|s| s.id == id)?;
        Some(s.position.map(f64::from))
    };
    let length = |a: &str, b: &str| -> Option<f64> {
        let (p, q) = (at(a)?, at(b)?);
        Some(((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt())
    };
    let both = |a: &str, b: &str| -> Option<f64> {
        Some(
            0.5 * (length(&format!("Left{a}"), &format!("Left{b}"))?
                + length(&format!("Right{a}"), &format!("Right{b}"))?),
        )
    };
    Some(
        length("Pelvis", "Neck")?
            + both("UpperArm", "ForeArm")?
            + both("ForeArm", "Hand")?
            + both("UpperLeg", "LowerLeg")?
            + both("LowerLeg", "Foot")?,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_persons_span_tells_metres_from_centimetres() {
        assert_eq!(Units::of_span(2.05), Some(Units::AsDecoded));
        assert_eq!(Units::of_span(205.0), Some(Units::Centimetres));
        assert_eq!(Units::of_span(0.0205), Some(Units::Metres));
        assert_eq!(Units::of_span(0.0), None);
        assert_eq!(Units::of_span(20.0), None);
        assert_eq!(Units::Centimetres.scale(), 0.01);
    }
}
