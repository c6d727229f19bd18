#![allow(clippy::unwrap_used)]

use std::f64::consts::FRAC_PI_2;

use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};

use super::*;
use crate::msgs::Time;
use crate::mvn::human::poses_across_ranges as poses;

/// The stream calibrated on its rest pose at once (a T-pose's untold twist palms down, the
/// human model's own), not after watching the motion.
fn no_watch() -> sgplvm_capture::StreamCalibrationOptions {
    sgplvm_capture::StreamCalibrationOptions {
        watch_seconds: 0.0,
        ..Default::default()
    }
}

fn iso(t: [f64; 3], axis: Vector3<f64>, angle: f64) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::new(t[0], t[1], t[2]),
        UnitQuaternion::from_axis_angle(&nalgebra::Unit::new_normalize(axis), angle),
    )
}

fn put(
    b: &mut TfBuffer,
    parent: &str,
    child: &str,
    stamp: i64,
    pose: &Isometry3<f64>,
    is_static: bool,
) {
    b.insert_one(
        &transform(parent, child, Time::from_ns(stamp), pose),
        is_static,
    )
    .unwrap();
}

#[test]
fn a_chain_composes_to_the_hand_computed_pose() {
    // world → a: 1 m along x, turned 90° about z; a → b: 2 m along a's y; b → c: 3 m along
    // b's z, turned 90° about x (static, so valid at any stamp).
    let mut b = TfBuffer::new();
    let t = 5_000_000_000;
    put(
        &mut b,
        "world",
        "a",
        t,
        &iso([1.0, 0.0, 0.0], Vector3::z(), FRAC_PI_2),
        false,
    );
    put(
        &mut b,
        "/a",
        "b",
        t,
        &iso([0.0, 2.0, 0.0], Vector3::z(), 0.0),
        false,
    );
    put(
        &mut b,
        "b",
        "c",
        0,
        &iso([0.0, 0.0, 3.0], Vector3::x(), FRAC_PI_2),
        true,
    );
    let (root, c) = b.compose("c", None, t, STAMP_TOLERANCE_NS).unwrap();
    assert_eq!(root, "world");
    // By hand: a's y is world's −x, so b is at (1 − 2, 0, 0); b's z is world's z, so c is at
    // (−1, 0, 3). c's y is b's z (the turn about x) = world's z; c's z is b's −y = world's x.
    let origin = c * Point3::origin();
    assert!(
        (origin - Point3::new(-1.0, 0.0, 3.0)).norm() < 1e-12,
        "{origin}"
    );
    let y = c * Vector3::y();
    let z = c * Vector3::z();
    assert!((y - Vector3::z()).norm() < 1e-12, "{y}");
    assert!((z - Vector3::x()).norm() < 1e-12, "{z}");
    // Relative to a common root below the world: c in a's frame is (0, 2, 3).
    let (_, in_a) = b.compose("c", Some("a"), t, STAMP_TOLERANCE_NS).unwrap();
    assert!((in_a * Point3::origin() - Point3::new(0.0, 2.0, 3.0)).norm() < 1e-12);
    // A root that is not above the frame, and a stamp with nothing.
    assert!(matches!(
        b.compose("a", Some("c"), t, STAMP_TOLERANCE_NS),
        Err(ComposeError::NotBelow { .. })
    ));
    assert_eq!(
        b.compose("c", None, t + 10_000_000, STAMP_TOLERANCE_NS),
        Err(ComposeError::Missing { frame: "b".into() })
    );
}

#[test]
fn a_set_is_complete_when_every_frame_has_a_transform_at_its_stamp() {
    let mut b = TfBuffer::new();
    let id = Isometry3::identity();
    let t = 1_000_000_000;
    put(&mut b, "world", "torso", 0, &id, true);
    for s in [t, t + 25_000_000] {
        put(&mut b, "torso", "arm", s, &id, false);
    }
    put(&mut b, "arm", "hand", t + 400_000, &id, false);
    let frames = ["torso", "arm", "hand"];
    assert_eq!(b.stamps(frames), [t, t + 400_000, t + 25_000_000].into());
    // The hand's stamp is 0.4 ms off the arm's: within the tolerance, the set is complete;
    // the static torso counts at every stamp.
    assert!(b.missing(frames, t, STAMP_TOLERANCE_NS).is_empty());
    assert_eq!(b.missing(frames, t, 100_000), vec!["hand".to_string()]);
    // The newer stamp lacks the hand.
    assert_eq!(
        b.missing(frames, t + 25_000_000, STAMP_TOLERANCE_NS),
        vec!["hand".to_string()]
    );
    // A transform that is not a pose is refused, saying which.
    let mut bad = transform("arm", "hand", Time::from_ns(t), &id);
    bad.transform.rotation.w = 0.0;
    let e = b.insert_one(&bad, false).unwrap_err().to_string();
    assert!(
        e.contains("arm → hand") && e.contains("unit quaternion"),
        "{e}"
    );
    // The history is bounded.
    for k in 0..(buffer::HISTORY as i64 + 10) {
        put(&mut b, "torso", "arm", t + k * 1_000, &id, false);
    }
    assert!(b.stamps(["arm"]).len() <= buffer::HISTORY);
}

#[test]
fn the_human_model_s_angles_come_back_through_tf_and_the_importer_s_fit() {
    let tree = HumanTf::new("actor1/").unwrap();
    let mut b = TfBuffer::new();
    b.insert(&tree.static_message(Time::default()), true);
    let qs = poses(40);
    let t0 = 1_700_000_000_000_000_000i64;
    b.insert(&tree.message(&qs[0], Time::from_ns(t0)).unwrap(), false);
    let mut fitted = identify(&b, None, no_watch()).unwrap();
    assert!(fitted.scheme().contains("Xsens MVN"), "{}", fitted.scheme());
    assert_eq!(fitted.torso(), "actor1/T8");
    // The fit needs the arms' frames from the torso down, not the spine or the world.
    assert_eq!(fitted.needed().len(), 8, "{:?}", fitted.needed());
    let mut worst = 0.0_f64;
    for (k, q) in qs.iter().enumerate() {
        let stamp = t0 + k as i64 * 25_000_000;
        b.insert(&tree.message(q, Time::from_ns(stamp)).unwrap(), false);
        let (angles, fits) = fitted.fit(&b, stamp, STAMP_TOLERANCE_NS).unwrap().unwrap();
        for f in &fits {
            assert!(f.elbow_m < 1e-6 && f.wrist_m < 1e-6, "{k}: {f:?}");
        }
        for j in 0..18 {
            worst = worst.max((angles[j] - q[j]).abs());
        }
    }
    // Double precision travels.
    assert!(worst < 1e-6, "worst angle difference {worst} rad");
}

#[test]
fn a_frame_missing_from_a_set_is_named() {
    let tree = HumanTf::new("").unwrap();
    let mut b = TfBuffer::new();
    b.insert(&tree.static_message(Time::default()), true);
    let q = &poses(1)[0];
    b.insert(&tree.message(q, Time::from_ns(1_000)).unwrap(), false);
    let mut fitted = identify(&b, None, no_watch()).unwrap();
    // The next set without the left hand.
    let mut msg = tree.message(q, Time::from_ns(50_000_000)).unwrap();
    msg.transforms.retain(|t| t.child_frame_id != "LeftHand");
    b.insert(&msg, false);
    let missing = fitted.fit(&b, 50_000_000, STAMP_TOLERANCE_NS).unwrap_err();
    let SetNotFitted::Missing(missing) = missing else {
        panic!("{missing:?}")
    };
    assert_eq!(missing, vec!["LeftHand".to_string()]);
    assert!(fitted.fit(&b, 1_000, STAMP_TOLERANCE_NS).is_ok());
}

#[test]
fn frames_no_scheme_names_are_refused_naming_the_frames_found() {
    let tree = HumanTf::new("").unwrap();
    let mut b = TfBuffer::new();
    let mut msg = tree.message(&poses(1)[0], Time::from_ns(1_000)).unwrap();
    for t in &mut msg.transforms {
        for id in [&mut t.header.frame_id, &mut t.child_frame_id] {
            *id = id.replace("Left", "Port").replace("Right", "Starboard");
        }
    }
    b.insert(&msg, false);
    let e = identify(&b, None, no_watch()).err().unwrap().to_string();
    assert!(e.contains("cannot tell which segments are the arms"), "{e}");
    for frame in ["T8", "PortUpperArm", "StarboardHand"] {
        assert!(e.contains(frame), "{frame} not in: {e}");
    }
    // A map naming them finds them, with the importer's map keys.
    let map: sgplvm_capture::ArmMap = serde_json::from_str(
        r#"{"jLeftC7Shoulder": "PortShoulder", "jLeftShoulder": "PortUpperArm", "jLeftElbow": "PortForeArm", "jLeftWrist": "PortHand",
            "jRightC7Shoulder": "StarboardShoulder", "jRightShoulder": "StarboardUpperArm", "jRightElbow": "StarboardForeArm", "jRightWrist": "StarboardHand"}"#,
    )
    .unwrap();
    // Without the spine (no /tf_static here) the torso's up is taken between the shoulders;
    // what matters is that the map is what finds the arms.
    let fitted = identify(&b, Some(&map), no_watch()).unwrap();
    assert_eq!(fitted.scheme(), "map file");
    // A map naming a frame not there says so, listing the frames.
    let wrong: sgplvm_capture::ArmMap = serde_json::from_str(
        r#"{"jLeftShoulder": "Nope", "jLeftElbow": "PortForeArm", "jLeftWrist": "PortHand"}"#,
    )
    .unwrap();
    let e = identify(&b, Some(&wrong), no_watch())
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("`Nope`") && e.contains("PortForeArm"), "{e}");
}

#[test]
fn sets_are_used_newest_first_and_the_others_counted() {
    let tree = HumanTf::new("").unwrap();
    let mut b = TfBuffer::new();
    b.insert(&tree.static_message(Time::default()), true);
    let qs = poses(6);
    let at = |k: usize| 1_000_000_000 + k as i64 * 25_000_000;
    b.insert(&tree.message(&qs[0], Time::from_ns(at(0))).unwrap(), false);
    let needed = identify(&b, None, no_watch()).unwrap().needed().to_vec();
    let mut sets = FrameSets::new();
    assert_eq!(sets.next(&b, &needed).stamp, Some(at(0)));
    // Nothing new: nothing to fit.
    assert_eq!(sets.next(&b, &needed), Next::default());
    // Sets 1 (complete) and 2 (no right hand) arrive, then half of set 3 (the left arm).
    b.insert(&tree.message(&qs[1], Time::from_ns(at(1))).unwrap(), false);
    let mut two = tree.message(&qs[2], Time::from_ns(at(2))).unwrap();
    two.transforms.retain(|t| t.child_frame_id != "RightHand");
    b.insert(&two, false);
    let mut three = tree.message(&qs[3], Time::from_ns(at(3))).unwrap();
    let right = three.transforms.split_off(4);
    b.insert(&three, false);
    // The newest complete set is 1: set 3 is still arriving, set 2 is newer but incomplete
    // and stays pending (its hand may still come).
    assert_eq!(sets.next(&b, &needed).stamp, Some(at(1)));
    // Set 3's right arm: 3 is used, 2 given up for it, its missing hand named.
    b.insert(&TFMessage { transforms: right }, false);
    let next = sets.next(&b, &needed);
    assert_eq!(next.stamp, Some(at(3)));
    assert_eq!(
        next.incomplete,
        vec![(at(2), vec!["RightHand".to_string()])]
    );
    // Sets 4 and 5 complete before the next look: 5 used, 4 superseded.
    for k in [4, 5] {
        b.insert(&tree.message(&qs[k], Time::from_ns(at(k))).unwrap(), false);
    }
    assert_eq!(sets.next(&b, &needed).stamp, Some(at(5)));
    // A last set without the right hand, pending at the end: counted as incomplete.
    let mut six = tree.message(&qs[0], Time::from_ns(at(6))).unwrap();
    six.transforms.retain(|t| t.child_frame_id != "RightHand");
    b.insert(&six, false);
    assert_eq!(sets.next(&b, &needed).stamp, None);
    let c = sets.counts(&b, &needed);
    assert_eq!((c.frames, c.superseded, c.incomplete), (4, 1, 2));
    assert_eq!(c.missing, [("RightHand".to_string(), 2)].into());
}

#[test]
fn a_flat_tree_is_refused_saying_the_chain_is_needed() {
    // Every segment in the world frame, as some drivers publish: names right, no chain.
    let tree = HumanTf::new("").unwrap();
    let msg = tree.message(&poses(1)[0], Time::from_ns(1_000)).unwrap();
    let mut b = TfBuffer::new();
    for t in &msg.transforms {
        let mut flat = t.clone();
        flat.header.frame_id = "world".into();
        b.insert_one(&flat, false).unwrap();
    }
    let e = identify(&b, None, no_watch()).err().unwrap().to_string();
    assert!(
        e.contains("hangs straight from `world`") && e.contains("LeftForeArm"),
        "{e}"
    );
}
