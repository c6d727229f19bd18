//! A person's shoulder girdle aligned to the people a model learned from, before the model
//! maps or judges their frames.
//!
//! Where a rig puts the sternoclavicular joint decides how much of each upper arm's turn its
//! clavicle angles carry and how much the shoulder's: the CMU people of the shipped corpus hold
//! their clavicles about 6° forward on average, a Kinect's skeleton (no clavicle) at 0, a studio
//! rig whose collar starts at the sternum 5–10° back. The same arm pose then reads as other
//! clavicle *and* shoulder angles, and the gate's novelty holds a stranger's frames for their
//! rig, not their pose (docs/experiment-report-people.md). Aligned, each arm's clavicle is
//! shifted by the difference between the model's people's mean clavicle angles and the
//! person's own mean so far (every frame of theirs up to this one, this one included: a file
//! and a stream of the same motion are aligned alike), and the shoulder re-solved so that the
//! upper arm keeps its orientation ([`sgplvm_capture::fit::with_clavicle`]): the arm's pose is
//! the person's, its parameterisation the model's people's.

use sgplvm_capture::girdle::GirdleAlignment;
use sgplvm_core::{AnyModel, Mat, Predictor};
use sgplvm_robots::dataset::Dataset;

/// The alignment to `model`'s people, for frames of its human columns; `None` where the model
/// stores no names for them or has no arm of the human model's nine angles.
pub fn for_model(model: &AnyModel) -> Option<GirdleAlignment> {
    let names = model.column_names(model.input_name())?;
    GirdleAlignment::new(names, &model.input_means())
}

/// `alignment` on every row of `h`, in order (one person's frames).
pub fn align_rows(alignment: &mut GirdleAlignment, h: &mut Mat<f64>) {
    let mut row = vec![0.0; h.ncols()];
    for i in 0..h.nrows() {
        row.iter_mut().enumerate().for_each(|(t, v)| *v = h[(i, t)]);
        alignment.align(&mut row);
        row.iter().enumerate().for_each(|(t, &v)| h[(i, t)] = v);
    }
}

/// Who performed each frame of `dataset` (its segment's person; `None` where none is named).
fn people_of(dataset: &Dataset) -> Vec<Option<&str>> {
    (0..dataset.human.positions.nrows())
        .map(|f| dataset.segment_of(f).and_then(|s| s.person.as_deref()))
        .collect()
}

/// Each person's shift of each arm's clavicle (elevation, protraction; radians) after their
/// last frame, by the person's name (`None`: frames of no named person).
pub type PersonShifts = Vec<(Option<String>, Vec<[f64; 2]>)>;

/// `dataset` as `model` takes its human frames: every person's frames aligned to the model's
/// people in their order in the file (each person's mean from their own frames up to each
/// one), and each person's shifts; `None` where the model has no alignment (its human columns
/// not named as the human model's).
pub fn aligned_dataset(model: &AnyModel, dataset: &Dataset) -> Option<(Dataset, PersonShifts)> {
    let fresh = for_model(model)?;
    let people = people_of(dataset);
    let mut out = dataset.clone();
    let h = &mut out.human.positions;
    let mut by_person: Vec<(Option<&str>, GirdleAlignment)> = Vec::new();
    let mut row = vec![0.0; h.ncols()];
    for f in 0..h.nrows() {
        let k = match by_person.iter().position(|(p, _)| *p == people[f]) {
            Some(k) => k,
            None => {
                by_person.push((people[f], fresh.clone()));
                by_person.len() - 1
            }
        };
        row.iter_mut().enumerate().for_each(|(t, v)| *v = h[(f, t)]);
        by_person[k].1.align(&mut row);
        row.iter().enumerate().for_each(|(t, &v)| h[(f, t)] = v);
    }
    let shifts = by_person
        .into_iter()
        .map(|(p, a)| (p.map(str::to_string), a.shifts()))
        .collect();
    Some((out, shifts))
}
