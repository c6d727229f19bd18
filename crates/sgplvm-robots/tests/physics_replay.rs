//! Physics replay on a small hand-written robot: a fixed torso box with one arm in front of it
//! (shoulder roll and pitch through a shapeless shoulder link, an elbow, a hand on a fixed
//! joint). The elbow flexes the forearm backward, toward the torso, for positive angles.

use sgplvm_robots::physics::{replay, PhysicsError, ReplayOptions, Trajectory};

/// Torso: box x ∈ [-0.1, 0.1], y ∈ [-0.15, 0.15], z ∈ [-0.5, 0.5]. Shoulder at (0.13, 0, 0.3):
/// the upper-arm capsule overlaps the torso's front face by 1 cm (a neighbour through the
/// shapeless shoulder link, so never reported). Elbow at (0.23, 0, 0); forearm and hand hang
/// below it, their surfaces 3.5 cm and 8 cm in front of the torso. The hand (sphere r = 0.05,
/// 0.3 below the elbow) touches the torso at an elbow angle of asin(0.08/0.3) ≈ 0.27 rad, the
/// forearm (capsule r = 0.035 reaching 0.25 below the elbow) only at ≈ 0.38 rad.
const ARM: &str = r#"<?xml version="1.0"?>
<robot name="mini">
  <link name="torso">
    <inertial><mass value="10"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><geometry><box size="0.2 0.3 1.0"/></geometry></collision>
  </link>
  <link name="shoulder_link"/>
  <link name="upper_arm">
    <inertial><origin xyz="0 0 -0.15"/><mass value="2"/>
      <inertia ixx="0.015" iyy="0.015" izz="0.002" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0 0 -0.15"/><geometry><capsule radius="0.04" length="0.22"/></geometry></collision>
  </link>
  <link name="forearm">
    <inertial><origin xyz="0 0 -0.12"/><mass value="1"/>
      <inertia ixx="0.005" iyy="0.005" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0 0 -0.145"/><geometry><capsule radius="0.035" length="0.14"/></geometry></collision>
  </link>
  <link name="hand">
    <inertial><mass value="0.5"/><inertia ixx="0.0005" iyy="0.0005" izz="0.0005" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><geometry><sphere radius="0.05"/></geometry></collision>
  </link>
  <joint name="shoulder_roll" type="revolute">
    <parent link="torso"/><child link="shoulder_link"/>
    <origin xyz="0.13 0 0.3" rpy="0 0 0"/><axis xyz="1 0 0"/>
    <limit lower="-0.5" upper="0.5" effort="100" velocity="5"/>
  </joint>
  <joint name="shoulder_pitch" type="revolute">
    <parent link="shoulder_link"/><child link="upper_arm"/>
    <axis xyz="0 1 0"/>
    <limit lower="-1.5" upper="0.3" effort="100" velocity="5"/>
  </joint>
  <joint name="elbow" type="revolute">
    <parent link="upper_arm"/><child link="forearm"/>
    <origin xyz="0.1 0 -0.3"/><axis xyz="0 1 0"/>
    <limit lower="-1.5" upper="0.8" effort="50" velocity="5"/>
  </joint>
  <joint name="wrist" type="fixed">
    <parent link="forearm"/><child link="hand"/>
    <origin xyz="0 0 -0.3"/>
  </joint>
</robot>"#;

const NAMES: [&str; 3] = ["shoulder_roll", "shoulder_pitch", "elbow"];

/// A 40 Hz trajectory of `seconds`, positions from `f(t)`.
fn sampled(seconds: f64, f: impl Fn(f64) -> [f64; 3]) -> Trajectory {
    let frames = (seconds * 40.0).round() as usize + 1;
    let times: Vec<f64> = (0..frames).map(|i| i as f64 / 40.0).collect();
    let positions = times.iter().flat_map(|&t| f(t)).collect();
    Trajectory::new(
        NAMES.iter().map(|s| s.to_string()).collect(),
        times,
        positions,
    )
    .expect("test trajectory is valid")
}

fn smooth() -> Trajectory {
    use std::f64::consts::PI;
    sampled(4.0, |t| {
        [
            0.15 * (2.0 * PI * 0.5 * t).sin(),
            -0.3 + 0.25 * (2.0 * PI * 0.5 * t).sin(),
            -0.6 + 0.4 * (2.0 * PI * 0.4 * t).sin(),
        ]
    })
}

#[test]
fn smooth_motion_within_limits_tracks_closely_without_events() {
    let report = replay(ARM, "mini.urdf", &smooth(), &ReplayOptions::default()).unwrap();
    assert_eq!(report.physics_steps, 4000);
    assert!((report.duration - 4.0).abs() < 1e-12);
    let names: Vec<&str> = report.joints.iter().map(|j| j.name.as_str()).collect();
    assert_eq!(names, NAMES);
    for joint in &report.joints {
        // Gravity sag over a 40 000 s⁻² servo: a few milliradians.
        assert!(joint.rms_error < 0.005, "{joint:?}");
        assert!(joint.max_error < 0.015, "{joint:?}");
        assert!(
            joint.rms_error > 1e-5,
            "a simulated arm never tracks exactly: {joint:?}"
        );
    }
    assert!(
        report.limit_violations.is_empty(),
        "{:?}",
        report.limit_violations
    );
    // The upper arm overlaps the torso through the whole motion, but they are neighbours.
    assert!(report.collisions.is_empty(), "{:?}", report.collisions);
    assert!(report.simulated.is_none());
}

#[test]
fn gravity_shows_as_tracking_error_and_stiffer_motors_reduce_it() {
    // Holding the arm still and bent forward: the only error source is gravity.
    let hold = sampled(1.0, |_| [0.0, -0.8, -0.8]);
    let off = ReplayOptions {
        gravity: false,
        ..ReplayOptions::default()
    };
    let soft = ReplayOptions {
        stiffness: 10_000.0,
        damping: 200.0,
        ..ReplayOptions::default()
    };
    let r_off = replay(ARM, "mini.urdf", &hold, &off).unwrap();
    let r_on = replay(ARM, "mini.urdf", &hold, &ReplayOptions::default()).unwrap();
    let r_soft = replay(ARM, "mini.urdf", &hold, &soft).unwrap();
    let pitch = |r: &sgplvm_robots::ReplayReport| r.joints[1].max_error;
    assert!(
        pitch(&r_off) < 1e-4,
        "no gravity, no error: {}",
        pitch(&r_off)
    );
    assert!(
        pitch(&r_on) > 1e-3,
        "gravity sags the shoulder: {}",
        pitch(&r_on)
    );
    // Quartering the stiffness roughly quadruples the static sag.
    let ratio = pitch(&r_soft) / pitch(&r_on);
    assert!((2.5..6.0).contains(&ratio), "sag ratio {ratio}");
}

#[test]
fn driving_the_hand_into_the_torso_reports_that_collision() {
    // Elbow from -0.3 (hand in front) to +0.6 (well into the torso) and back.
    let trajectory = sampled(3.0, |t| {
        let s = (std::f64::consts::PI * t / 3.0).sin();
        [0.0, 0.0, -0.3 + 0.9 * s]
    });
    let report = replay(ARM, "mini.urdf", &trajectory, &ReplayOptions::default()).unwrap();
    let hand: Vec<_> = report
        .collisions
        .iter()
        .filter(|c| (c.link_a.as_str(), c.link_b.as_str()) == ("torso", "hand"))
        .collect();
    assert_eq!(hand.len(), 1, "one merged event: {:?}", report.collisions);
    let event = hand[0];
    // The reference reaches 0.27 rad at t = 3/π·asin(0.57/0.9) ≈ 0.65 s and leaves it at
    // ≈ 2.35 s; the arm lags a little behind the reference.
    assert!(event.time > 0.5 && event.time < 0.9, "{event:?}");
    assert!(event.end_time > 2.1 && event.end_time < 2.6, "{event:?}");
    assert!(event.max_penetration < 0.05, "{event:?}");
    // Where: on the torso's front face (x = 0.1), in its middle plane (y = 0), at the height of
    // the hand's centre (0.3 below the elbow, which is at z = 0, tilted by about 0.3 rad).
    let [x, y, z] = event.point;
    assert!((x - 0.1).abs() < 0.03 && y.abs() < 0.02, "{event:?}");
    assert!(z > -0.33 && z < -0.24, "{event:?}");
    // The torso stops the hand: the elbow falls far behind its reference.
    let elbow = &report.joints[2];
    assert!(elbow.max_error > 0.1, "{elbow:?}");

    // Detection only: the hand passes through, the elbow tracks, the penetration is deep.
    let ghost = ReplayOptions {
        contact_response: false,
        ..ReplayOptions::default()
    };
    let report = replay(ARM, "mini.urdf", &trajectory, &ghost).unwrap();
    let event = report
        .collisions
        .iter()
        .find(|c| c.link_b == "hand")
        .expect("hand-torso collision detected without response");
    assert!(event.max_penetration > 0.05, "{event:?}");
    assert!(report.joints[2].max_error < 0.05, "{:?}", report.joints[2]);
    // Without response the forearm goes into the torso as well, later and shorter.
    let forearm = report
        .collisions
        .iter()
        .find(|c| c.link_b == "forearm")
        .expect("forearm-torso collision");
    assert!(forearm.time > event.time && forearm.end_time < event.end_time);
}

#[test]
fn commanding_beyond_a_limit_reports_the_violation() {
    // The elbow ramps from -1.0 to -1.8 (0.3 rad past its lower limit of -1.5) in one second,
    // stays there one second and ramps back.
    let trajectory = sampled(3.0, |t| {
        let e = if t <= 1.0 {
            -1.0 - 0.8 * t
        } else if t <= 2.0 {
            -1.8
        } else {
            -1.8 + 0.8 * (t - 2.0)
        };
        [0.0, -0.2, e]
    });
    let report = replay(ARM, "mini.urdf", &trajectory, &ReplayOptions::default()).unwrap();
    let commanded: Vec<_> = report
        .limit_violations
        .iter()
        .filter(|v| v.commanded)
        .collect();
    assert_eq!(commanded.len(), 1, "{:?}", report.limit_violations);
    let v = commanded[0];
    assert_eq!(v.joint, "elbow");
    assert_eq!(v.limit, -1.5);
    assert!((v.amount - 0.3).abs() < 1e-9, "{v:?}");
    // The reference is more than 0.001 past -1.5 from t = 0.62625 s to t = 2.37375 s.
    assert!((v.time - 0.627).abs() < 0.0015, "{v:?}");
    assert!((v.end_time - 2.373).abs() < 0.0015, "{v:?}");
    // The simulator enforces the limit: the elbow itself stays (almost) inside.
    let measured: Vec<_> = report
        .limit_violations
        .iter()
        .filter(|v| !v.commanded)
        .collect();
    assert!(
        measured.iter().all(|v| v.amount < 0.02),
        "enforced limit held: {measured:?}"
    );

    // Not enforced: the elbow follows the command past the limit.
    let loose = ReplayOptions {
        enforce_limits: false,
        ..ReplayOptions::default()
    };
    let report = replay(ARM, "mini.urdf", &trajectory, &loose).unwrap();
    let measured = report
        .limit_violations
        .iter()
        .find(|v| !v.commanded)
        .expect("measured violation");
    assert_eq!(measured.joint, "elbow");
    assert!((measured.amount - 0.3).abs() < 0.02, "{measured:?}");
}

#[test]
fn recorded_positions_follow_the_reference_at_frame_times() {
    let options = ReplayOptions {
        record_simulated: true,
        ..ReplayOptions::default()
    };
    let trajectory = smooth();
    let report = replay(ARM, "mini.urdf", &trajectory, &options).unwrap();
    let sim = report.simulated.expect("recorded");
    assert_eq!(sim.joint_names, NAMES);
    assert_eq!(sim.times, trajectory.times);
    assert_eq!(sim.positions.len(), trajectory.positions.len());
    // The first frame is the state after settling on the first reference frame.
    for (a, b) in sim.positions[..3].iter().zip(&trajectory.positions[..3]) {
        assert!((a - b).abs() < 0.01 && a != b, "{a} vs {b}");
    }
    let worst = sim
        .positions
        .iter()
        .zip(&trajectory.positions)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(worst < 0.03 && worst > 0.0, "{worst}");
}

#[test]
fn columns_are_matched_by_name_in_any_order() {
    let t = smooth();
    // Reverse the columns.
    let n = 3;
    let mut reversed = t.clone();
    reversed.joint_names.reverse();
    for row in reversed.positions.chunks_mut(n) {
        row.reverse();
    }
    let a = replay(ARM, "mini.urdf", &t, &ReplayOptions::default()).unwrap();
    let b = replay(ARM, "mini.urdf", &reversed, &ReplayOptions::default()).unwrap();
    let names: Vec<&str> = b.joints.iter().map(|j| j.name.as_str()).collect();
    assert_eq!(names, ["elbow", "shoulder_pitch", "shoulder_roll"]);
    for (ja, jb) in a.joints.iter().zip(b.joints.iter().rev()) {
        assert_eq!(ja.name, jb.name);
        assert!((ja.rms_error - jb.rms_error).abs() < 1e-6, "{ja:?} {jb:?}");
    }
}

#[test]
fn bad_trajectories_give_clear_errors() {
    let names = || NAMES.iter().map(|s| s.to_string()).collect::<Vec<_>>();
    // NaN.
    let mut positions = vec![0.0; 9];
    positions[7] = f64::NAN;
    let err = Trajectory::new(names(), vec![0.0, 0.025, 0.05], positions).unwrap_err();
    assert!(
        matches!(err, PhysicsError::NonFinitePosition { frame: 2, ref joint, .. } if joint == "shoulder_pitch"),
        "{err}"
    );
    assert!(err.to_string().contains("frame 2"), "{err}");
    // Wrong column count.
    let err = Trajectory::new(names(), vec![0.0, 0.025, 0.05], vec![0.0; 8]).unwrap_err();
    assert!(
        err.to_string()
            .contains("expected 3 frames × 3 joint columns = 9"),
        "{err}"
    );
    // Times not increasing.
    let err = Trajectory::new(names(), vec![0.0, 0.025, 0.025], vec![0.0; 9]).unwrap_err();
    assert!(err.to_string().contains("frame 2"), "{err}");
    // Duplicate column.
    let dup = vec!["elbow".into(), "elbow".into(), "shoulder_roll".into()];
    let err = Trajectory::new(dup, vec![0.0, 0.025], vec![0.0; 6]).unwrap_err();
    assert!(err.to_string().contains("\"elbow\""), "{err}");
    // A hand-built (unchecked) trajectory is checked by replay too.
    let raw = Trajectory {
        joint_names: names(),
        times: vec![0.0, 0.025],
        positions: vec![0.0, 0.0, f64::INFINITY, 0.0, 0.0, 0.0],
    };
    let err = replay(ARM, "mini.urdf", &raw, &ReplayOptions::default()).unwrap_err();
    assert!(
        matches!(err, PhysicsError::NonFinitePosition { frame: 0, .. }),
        "{err}"
    );

    // Unknown joint.
    let unknown = Trajectory::new(
        vec![
            "shoulder_roll".into(),
            "shoulder_pitch".into(),
            "knee".into(),
        ],
        vec![0.0, 0.025],
        vec![0.0; 6],
    )
    .unwrap();
    let err = replay(ARM, "mini.urdf", &unknown, &ReplayOptions::default()).unwrap_err();
    let text = err.to_string();
    assert!(matches!(err, PhysicsError::UnknownJoint { .. }), "{text}");
    assert!(
        text.contains("\"knee\"") && text.contains("mini.urdf") && text.contains("elbow"),
        "{text}"
    );
    // The fixed wrist is not a trajectory joint.
    let fixed = Trajectory::new(
        vec![
            "shoulder_roll".into(),
            "shoulder_pitch".into(),
            "elbow".into(),
            "wrist".into(),
        ],
        vec![0.0, 0.025],
        vec![0.0; 8],
    )
    .unwrap();
    let err = replay(ARM, "mini.urdf", &fixed, &ReplayOptions::default()).unwrap_err();
    assert!(
        matches!(err, PhysicsError::UnknownJoint { ref joint, .. } if joint == "wrist"),
        "{err}"
    );

    // Missing joint, unless allowed.
    let missing = Trajectory::new(
        vec!["shoulder_roll".into(), "elbow".into()],
        vec![0.0, 0.5],
        vec![0.0, -0.5, 0.0, -0.5],
    )
    .unwrap();
    let err = replay(ARM, "mini.urdf", &missing, &ReplayOptions::default()).unwrap_err();
    assert!(
        matches!(err, PhysicsError::MissingJoint { ref joint, .. } if joint == "shoulder_pitch"),
        "{err}"
    );
    let allow = ReplayOptions {
        allow_missing_joints: true,
        ..ReplayOptions::default()
    };
    let report = replay(ARM, "mini.urdf", &missing, &allow).unwrap();
    assert_eq!(report.joints.len(), 3);
    assert_eq!(report.joints[2].name, "shoulder_pitch");
}

#[test]
fn bad_urdfs_and_options_give_clear_errors() {
    let t = smooth();
    let opts = ReplayOptions::default();
    let err = replay("<robot name=\"x\"><link name=", "broken.urdf", &t, &opts).unwrap_err();
    assert!(matches!(err, PhysicsError::Robot(_)), "{err}");
    assert!(err.to_string().starts_with("broken.urdf:"), "{err}");

    let dangling = ARM.replace("<child link=\"forearm\"/>", "<child link=\"lower_arm\"/>");
    let err = replay(&dangling, "dangling.urdf", &t, &opts).unwrap_err();
    let text = err.to_string();
    assert!(
        text.contains("dangling.urdf")
            && text.contains("\"lower_arm\"")
            && text.contains("<joint name=\"elbow\">"),
        "{text}"
    );

    let bad = ReplayOptions {
        physics_rate_hz: f64::NAN,
        ..ReplayOptions::default()
    };
    let err = replay(ARM, "mini.urdf", &t, &bad).unwrap_err();
    assert!(err.to_string().contains("physics_rate_hz"), "{err}");

    let pair = ReplayOptions {
        ignored_pairs: vec![("hand".into(), "tail".into())],
        ..ReplayOptions::default()
    };
    let err = replay(ARM, "mini.urdf", &t, &pair).unwrap_err();
    assert!(err.to_string().contains("\"tail\""), "{err}");
}

#[test]
fn ignored_pairs_silence_a_collision() {
    let trajectory = sampled(2.0, |t| {
        [
            0.0,
            0.0,
            -0.3 + 0.9 * (std::f64::consts::PI * t / 2.0).sin(),
        ]
    });
    let options = ReplayOptions {
        ignored_pairs: vec![("hand".into(), "torso".into())],
        contact_response: false,
        ..ReplayOptions::default()
    };
    let report = replay(ARM, "mini.urdf", &trajectory, &options).unwrap();
    assert!(
        report.collisions.iter().all(|c| c.link_b != "hand"),
        "{:?}",
        report.collisions
    );
    assert!(
        report.collisions.iter().any(|c| c.link_b == "forearm"),
        "{:?}",
        report.collisions
    );
}

#[test]
fn a_floating_world_root_is_fixed_with_a_warning() {
    let floating = ARM.replace(
        "<link name=\"torso\">",
        "<link name=\"world\"/>\n  <joint name=\"base\" type=\"floating\"><parent link=\"world\"/><child link=\"torso\"/></joint>\n  <link name=\"torso\">",
    );
    let report = replay(
        &floating,
        "floating.urdf",
        &smooth(),
        &ReplayOptions::default(),
    )
    .unwrap();
    assert!(
        report.warnings.iter().any(|w| w.contains("\"base\"")),
        "{:?}",
        report.warnings
    );
    for joint in &report.joints {
        assert!(joint.max_error < 0.03, "torso stays put: {joint:?}");
    }
}

#[test]
fn a_reversed_joint_axis_reverses_the_coordinate() {
    // The same elbow with axis -y: the hand reaches the torso for negative angles.
    let flipped = ARM.replace(
        "<origin xyz=\"0.1 0 -0.3\"/><axis xyz=\"0 1 0\"/>\n    <limit lower=\"-1.5\" upper=\"0.8\"",
        "<origin xyz=\"0.1 0 -0.3\"/><axis xyz=\"0 -1 0\"/>\n    <limit lower=\"-0.8\" upper=\"1.5\"",
    );
    assert_ne!(flipped, ARM);
    let toward = sampled(2.0, |t| {
        [
            0.0,
            0.0,
            -0.3 + 0.9 * (std::f64::consts::PI * t / 2.0).sin(),
        ]
    });
    let mut mirrored = toward.clone();
    for row in mirrored.positions.chunks_mut(3) {
        row[2] = -row[2];
    }
    let a = replay(ARM, "mini.urdf", &toward, &ReplayOptions::default()).unwrap();
    let b = replay(
        &flipped,
        "flipped.urdf",
        &mirrored,
        &ReplayOptions::default(),
    )
    .unwrap();
    let hand = |r: &sgplvm_robots::ReplayReport| {
        r.collisions
            .iter()
            .find(|c| c.link_b == "hand")
            .map(|c| (c.time, c.end_time))
            .expect("hand-torso collision")
    };
    let (ta, tb) = (hand(&a), hand(&b));
    assert!(
        (ta.0 - tb.0).abs() < 0.01 && (ta.1 - tb.1).abs() < 0.01,
        "{ta:?} {tb:?}"
    );
}

#[test]
fn moving_faster_than_the_velocity_limit_is_reported() {
    // The elbow (velocity limit 5 rad/s) drops from -0.2 to -1.2 in 0.1 s: 10 rad/s commanded.
    let trajectory = sampled(1.0, |t| {
        let e = if t < 0.2 {
            -0.2
        } else if t < 0.3 {
            -0.2 - 10.0 * (t - 0.2)
        } else {
            -1.2
        };
        [0.0, -0.2, e]
    });
    let report = replay(ARM, "mini.urdf", &trajectory, &ReplayOptions::default()).unwrap();
    assert!(
        report.limit_violations.is_empty(),
        "{:?}",
        report.limit_violations
    );
    let commanded: Vec<_> = report
        .velocity_violations
        .iter()
        .filter(|v| v.commanded)
        .collect();
    assert_eq!(commanded.len(), 1, "{:?}", report.velocity_violations);
    let v = commanded[0];
    assert_eq!(v.joint, "elbow");
    assert_eq!(v.limit, -5.0);
    assert!((v.amount - 5.0).abs() < 1e-6, "{v:?}");
    assert!(
        (v.time - 0.201).abs() < 1e-6 && (v.end_time - 0.3).abs() < 1e-6,
        "{v:?}"
    );
    // The servo follows, so the simulated elbow is too fast as well, for a similar stretch.
    let measured = report
        .velocity_violations
        .iter()
        .find(|v| !v.commanded)
        .expect("measured velocity violation");
    assert_eq!(measured.joint, "elbow");
    assert!(
        measured.amount > 2.0 && measured.amount < 8.0,
        "{measured:?}"
    );
    assert!(measured.time > 0.2 && measured.time < 0.26, "{measured:?}");
    // The smooth trajectory stays well under every velocity limit.
    let calm = replay(ARM, "mini.urdf", &smooth(), &ReplayOptions::default()).unwrap();
    assert!(
        calm.velocity_violations.is_empty(),
        "{:?}",
        calm.velocity_violations
    );
}

/// The report says which joints slide, so that their values are read in metres (issue 38: the
/// command line printed every joint in degrees).
#[test]
fn prismatic_joints_are_marked_in_the_report() {
    let urdf = ARM.replace(
        r#"<joint name="elbow" type="revolute">"#,
        r#"<joint name="elbow" type="prismatic">"#,
    );
    // The sliding elbow goes 0.1 m past its lower limit of -1.5 m.
    let trajectory = sampled(2.0, |t| [0.0, -0.2, -1.4 - 0.2 * t.min(1.0)]);
    let report = replay(&urdf, "slide.urdf", &trajectory, &ReplayOptions::default()).unwrap();
    let kinds: Vec<(&str, bool)> = report
        .joints
        .iter()
        .map(|j| (j.name.as_str(), j.prismatic))
        .collect();
    assert_eq!(
        kinds,
        [
            ("shoulder_roll", false),
            ("shoulder_pitch", false),
            ("elbow", true)
        ]
    );
    let v = report
        .limit_violations
        .iter()
        .find(|v| v.commanded)
        .expect("commanded violation");
    assert_eq!((v.joint.as_str(), v.limit), ("elbow", -1.5));
    assert!((v.amount - 0.1).abs() < 1e-9, "{v:?}");
    let json = serde_json::to_value(&report).unwrap();
    assert_eq!(json["joints"][2]["prismatic"], true);
}
