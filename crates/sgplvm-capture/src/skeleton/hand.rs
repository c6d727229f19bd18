//! Where a hand ends: the middle finger's base where the rig has one, found by name across
//! conventions; else a finger's base near the wrist, the End Site, or the mean of the hand's
//! other children.
//!
//! The hand's end sets the wrist's angles (the direction wrist → end is the hand's long axis),
//! so which finger it is matters: the index finger's knuckle lies 9–10° to the thumb's side of
//! the middle finger's, and taking it for the hand's end turns the wrist by as much.

use nalgebra::Vector3;

use super::names::normalise;
use crate::bvh::Bvh;
use crate::calibration::HandEnd;

/// Where the hand ends, in its own frame, and whether the skeleton says so ([`HandEnd`]):
///
/// 1. the middle finger's base anywhere below the hand, the nearest the hand first
///    ([`is_middle_finger`], [`numbered_middle_finger`]): past a carpal or metacarpal bone
///    (DAZ's `lCarpal2` → `lMid1`, MakeHuman's `metacarpal2.l` → `finger3-1.l`);
/// 2. else, as before middle fingers were looked for, the first child or grandchild (file
///    order) that is a finger's base ([`is_finger`]: cgspeed's CMU `LeftFingerBase`);
/// 3. else the hand's End Site;
/// 4. else the mean of the children that are not the thumb (a guess: [`HandEnd::Unmeasured`]).
pub(super) fn hand_tip(bvh: &Bvh, hand: usize) -> Option<(Vector3<f64>, HandEnd)> {
    let below = descendants(bvh, hand);
    let middle = middle_finger(bvh, &below);
    // Children and grandchildren, each with its offset from the hand.
    let near = || below.iter().filter(|b| b.depth <= 2);
    let finger = middle.or_else(|| near().find(|b| is_finger(&bvh.joints[b.joint].name)));
    if let Some(&Below { joint, offset, .. }) = finger {
        // Down the finger until the chain leaves the wrist (CMU's finger base sits on it).
        let mut tip = offset;
        let mut at = joint;
        while tip.norm() == 0.0 {
            match bvh.children(at).next() {
                Some(next) => {
                    tip += bvh.rest_translation(next);
                    at = next;
                }
                None => {
                    tip += bvh.joints[at].end_site.unwrap_or_else(Vector3::zeros);
                    break;
                }
            }
        }
        if tip.norm() > 0.0 {
            return Some((tip, HandEnd::Measured));
        }
    }
    if let Some(e) = bvh.joints[hand].end_site.filter(|v| v.norm() > 0.0) {
        return Some((e, HandEnd::Measured));
    }
    let others: Vec<Vector3<f64>> = near()
        .filter(|b| b.depth == 1 && !normalise(&bvh.joints[b.joint].name).contains("thumb"))
        .map(|b| b.offset)
        .collect();
    if others.is_empty() {
        return None;
    }
    // The mean of children that are no fingers (an Xsens prop): a guess.
    let mean = others.iter().sum::<Vector3<f64>>() / others.len() as f64;
    Some((mean, HandEnd::Unmeasured)).filter(|(v, _)| v.norm() > 0.0)
}

/// A joint below the hand.
#[derive(Debug, Clone, Copy)]
struct Below {
    joint: usize,
    /// Its place in the hand's frame at rest (the joints between at zero rotation).
    offset: Vector3<f64>,
    /// 1 for a child of the hand, 2 for a grandchild, …
    depth: usize,
}

/// Every joint below `hand`, level by level (children in file order, then their children in
/// that order, …).
fn descendants(bvh: &Bvh, hand: usize) -> Vec<Below> {
    let mut found: Vec<Below> = bvh
        .children(hand)
        .map(|c| Below {
            joint: c,
            offset: bvh.rest_translation(c),
            depth: 1,
        })
        .collect();
    let mut k = 0;
    while k < found.len() {
        let parent = found[k];
        found.extend(bvh.children(parent.joint).map(|c| Below {
            joint: c,
            offset: parent.offset + bvh.rest_translation(c),
            depth: parent.depth + 1,
        }));
        k += 1;
    }
    found
}

/// The middle finger's base among `below` (the joints below a hand, nearest first): the
/// nearest joint named a middle finger ([`is_middle_finger`]), else the nearest of the middle
/// finger where the fingers are numbered ([`numbered_middle_finger`]). A carpal or metacarpal
/// bone (Unreal 5's `middle_metacarpal_l`, Rokoko's `LeftFinger3Metacarpal`) lies in the palm,
/// not at the knuckle: it is passed over for the finger below it.
fn middle_finger<'a>(bvh: &Bvh, below: &'a [Below]) -> Option<&'a Below> {
    let names: Vec<String> = below
        .iter()
        .map(|b| normalise(&bvh.joints[b.joint].name))
        .collect();
    let in_finger = |k: &usize| !names[*k].contains("carpal");
    let named = (0..below.len())
        .filter(in_finger)
        .find(|&k| is_middle_finger(&names[k]));
    let numbered = || {
        let middle = numbered_middle_finger(names.iter().map(String::as_str))?;
        (0..below.len())
            .filter(in_finger)
            .find(|&k| finger_number(&names[k]) == Some(middle))
    };
    named.or_else(numbered).map(|k| &below[k])
}

/// Whether a normalised joint name ([`normalise`]) names a middle finger's bone by a word:
/// `middle` (CMU and Mixamo `LeftHandMiddle1`, Unreal `middle_01_l`, Rigify `f_middle.01.L`,
/// SMPL-X `left_middle1`, MakeHuman's game rig `Middle1_L`) or `mid` and a number (DAZ's
/// `lMid1`).
pub(super) fn is_middle_finger(normalised: &str) -> bool {
    normalised.contains("middle")
        || normalised
            .match_indices("mid")
            .any(|(at, _)| normalised[at + 3..].starts_with(|c: char| c.is_ascii_digit()))
}

/// The number of the finger a normalised name numbers (`finger` and a digit, the first digit
/// only: MakeHuman's `finger3-1.l` is finger 3, 3ds Max Biped's `Bip01 L Finger21` finger 2).
fn finger_number(normalised: &str) -> Option<u32> {
    normalised
        .match_indices("finger")
        .find_map(|(at, word)| normalised[at + word.len()..].chars().next()?.to_digit(10))
}

/// The middle finger's number where `names` (normalised, a hand's joints) number all five
/// fingers, the thumb first: the third of five consecutive numbers — MakeHuman numbers them
/// from 1 (`finger1-2.l` the thumb, `finger2-1.l` the index, `finger3-1.l` the middle), 3ds
/// Max Biped from 0 (`Finger0` the thumb, `Finger2` the middle). `None` where fewer fingers
/// are numbered: which is the middle one is then not told.
pub(super) fn numbered_middle_finger<'a>(names: impl Iterator<Item = &'a str>) -> Option<u32> {
    let mut numbers: Vec<u32> = names.filter_map(finger_number).collect();
    numbers.sort_unstable();
    numbers.dedup();
    let consecutive = numbers.windows(2).all(|w| w[1] == w[0] + 1);
    (numbers.len() == 5 && consecutive).then(|| numbers[0] + 2)
}

/// Whether a joint named `name` is a middle finger or a finger's base (where a hand ends when
/// no middle finger is found: the first such child or grandchild).
fn is_finger(name: &str) -> bool {
    let n = normalise(name);
    ["middle1", "mid1", "middle", "fingerbase", "finger"]
        .iter()
        .any(|k| n.contains(k))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn middle_fingers_are_named_across_conventions() {
        for name in [
            "LeftHandMiddle1",
            "mixamorig:RightHandMiddle1",
            "middle_01_l",
            "DEF-f_middle.01.L",
            "lMid1",
            "Middle1_L",
            "left_middle1",
        ] {
            assert!(is_middle_finger(&normalise(name)), "{name}");
        }
        for name in [
            "LeftHandIndex1",
            "finger2-1.l",
            "lIndex1",
            "midspine",
            "lThumb1",
        ] {
            assert!(!is_middle_finger(&normalise(name)), "{name}");
        }
    }

    #[test]
    fn numbered_fingers_tell_the_middle_one_from_the_count() {
        let n = |names: &[&str]| {
            let names: Vec<String> = names.iter().map(|s| normalise(s)).collect();
            numbered_middle_finger(names.iter().map(String::as_str))
        };
        let makehuman = [
            "metacarpal1.l",
            "finger2-1.l",
            "finger2-2.l",
            "finger3-1.l",
            "finger4-1.l",
            "finger5-1.l",
            "lthumb",
            "finger1-2.l",
        ];
        assert_eq!(n(&makehuman), Some(3));
        let biped = [
            "Bip01 L Finger0",
            "Bip01 L Finger01",
            "Bip01 L Finger1",
            "Bip01 L Finger2",
            "Bip01 L Finger21",
            "Bip01 L Finger3",
            "Bip01 L Finger4",
        ];
        assert_eq!(n(&biped), Some(2));
        // Three fingers numbered: which is the middle one is not told.
        assert_eq!(n(&["finger1", "finger2", "finger3"]), None);
        assert_eq!(n(&["LeftFingerBase", "LeftHandIndex1"]), None);
    }
}
