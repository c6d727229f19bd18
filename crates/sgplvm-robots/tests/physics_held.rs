//! Physics replay of what the trajectory does not command (issue 51): joints held still by
//! their controllers (welded where they are held), parts of the model that already touch at
//! rest, and a replay that runs away — each said, none a flood of events.

use sgplvm_robots::physics::{replay, PhysicsError, ReplayOptions, Trajectory};

/// A fixed torso box; an arm in front of it (shoulder pitch, elbow) whose forearm hangs 5 cm in
/// front of the torso, a hand fixed below the forearm, and on the hand a finger on a revolute
/// joint whose sphere overlaps the hand's (as published hands' finger meshes do) and reaches
/// 6 cm towards the torso. The elbow flexes the forearm toward the torso for positive angles.
const ARM: &str = r#"<?xml version="1.0"?>
<robot name="fingered">
  <link name="torso">
    <inertial><mass value="10"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><geometry><box size="0.2 0.3 1.0"/></geometry></collision>
  </link>
  <link name="upper_arm">
    <inertial><origin xyz="0 0 -0.15"/><mass value="2"/>
      <inertia ixx="0.015" iyy="0.015" izz="0.002" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <link name="forearm">
    <inertial><origin xyz="0 0 -0.12"/><mass value="1"/>
      <inertia ixx="0.005" iyy="0.005" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0 0 -0.15"/><geometry><capsule radius="0.03" length="0.1"/></geometry></collision>
  </link>
  <link name="hand">
    <inertial><mass value="0.3"/><inertia ixx="0.0003" iyy="0.0003" izz="0.0003" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><geometry><sphere radius="0.03"/></geometry></collision>
  </link>
  <link name="finger">
    <inertial><mass value="0.01"/><inertia ixx="1e-6" iyy="1e-6" izz="1e-6" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="-0.03 0 0"/><geometry><sphere radius="0.03"/></geometry></collision>
  </link>
  <joint name="shoulder_pitch" type="revolute">
    <parent link="torso"/><child link="upper_arm"/>
    <origin xyz="0.18 0 0.3"/><axis xyz="0 1 0"/>
    <limit lower="-1.5" upper="0.3" effort="100" velocity="5"/>
  </joint>
  <joint name="elbow" type="revolute">
    <parent link="upper_arm"/><child link="forearm"/>
    <origin xyz="0 0 -0.3"/><axis xyz="0 1 0"/>
    <limit lower="-1.5" upper="1.2" effort="50" velocity="5"/>
  </joint>
  <joint name="wrist" type="fixed">
    <parent link="forearm"/><child link="hand"/>
    <origin xyz="0 0 -0.3"/>
  </joint>
  <joint name="finger_joint" type="revolute">
    <parent link="hand"/><child link="finger"/>
    <axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="2"/>
  </joint>
</robot>"#;

/// A 40 Hz trajectory of the shoulder and the elbow over `seconds`, from `f(t)`.
fn arm_motion(seconds: f64, f: impl Fn(f64) -> [f64; 2]) -> Trajectory {
    let frames = (seconds * 40.0).round() as usize + 1;
    let times: Vec<f64> = (0..frames).map(|i| i as f64 / 40.0).collect();
    let positions = times.iter().flat_map(|&t| f(t)).collect();
    Trajectory::new(
        vec!["shoulder_pitch".into(), "elbow".into()],
        times,
        positions,
    )
    .unwrap()
}

fn held_finger() -> ReplayOptions {
    ReplayOptions {
        held: vec![("finger_joint".into(), 0.0)],
        ..ReplayOptions::default()
    }
}

#[test]
fn a_held_finger_is_welded_and_what_it_touches_is_named_as_a_held_part() {
    // Still arms: the finger overlaps its hand, but held rigid on it that is no collision.
    let still = arm_motion(1.0, |_| [0.0, 0.0]);
    let report = replay(ARM, "fingered.urdf", &still, &held_finger()).unwrap();
    assert_eq!(report.held, vec![("finger_joint".to_string(), 0.0)]);
    let names: Vec<&str> = report.joints.iter().map(|j| j.name.as_str()).collect();
    assert_eq!(
        names,
        ["shoulder_pitch", "elbow"],
        "the held finger is not tracked"
    );
    assert!(report.collisions.is_empty(), "{:?}", report.collisions);
    assert!(report.diverged.is_none());
    // Flexing the elbow brings the finger, then the hand, into the torso: each pair named,
    // the finger's as a part held still.
    let flex = arm_motion(2.0, |t| [0.0, (0.6 * t).min(1.0)]);
    let report = replay(ARM, "fingered.urdf", &flex, &held_finger()).unwrap();
    let finger = report
        .collisions
        .iter()
        .find(|c| c.link_b == "finger" || c.link_a == "finger")
        .unwrap_or_else(|| panic!("{:?}", report.collisions));
    assert!(finger.held_part, "{finger:?}");
    assert!(report
        .collisions
        .iter()
        .filter(|c| c.link_a == "torso" && c.link_b == "hand")
        .all(|c| !c.held_part));
    assert!(report
        .self_collision_summary()
        .contains("with a part held still"));
    // A held joint is not commanded: a column for it is refused, naming it.
    let both = Trajectory::new(
        vec!["shoulder_pitch".into(), "finger_joint".into()],
        vec![0.0, 1.0],
        vec![0.0; 4],
    )
    .unwrap();
    let err = replay(ARM, "fingered.urdf", &both, &held_finger()).unwrap_err();
    assert!(
        matches!(err, PhysicsError::InvalidOption { field: "held", .. }),
        "{err}"
    );
    assert!(err.to_string().contains("finger_joint"), "{err}");
}

#[test]
fn a_joint_with_one_value_allowed_is_held_there_without_a_column() {
    // Toyota's HSR: `wrist_ft_sensor_frame_joint` is revolute with lower = upper = 0. With no
    // column for it the replay refused the file (or, commanded, took it as unlimited); it is
    // held at its one value, as any held joint.
    let pinned = ARM.replace(
        r#"<limit lower="-1" upper="1" effort="1" velocity="2"/>"#,
        r#"<limit lower="0.25" upper="0.25" effort="1" velocity="2"/>"#,
    );
    assert_ne!(pinned, ARM);
    let still = arm_motion(1.0, |_| [0.0, 0.0]);
    let report = replay(&pinned, "pinned.urdf", &still, &ReplayOptions::default()).unwrap();
    assert_eq!(report.held, vec![("finger_joint".to_string(), 0.25)]);
    assert!(report.diverged.is_none());
}

#[test]
fn links_touching_at_rest_are_left_out_and_listed() {
    // Without a hold the finger is a joint of its own with no column: allowed, it is driven to
    // 0 by its motor, and its sphere overlapping the hand's at rest is the model's own overlap.
    // (Hand and finger are neighbours, never checked.) A finger reaching back into the
    // forearm at rest across a moving wrist: not neighbours (two moving joints, the hand
    // between has a shape), the model's own overlap.
    let reaching = ARM
        .replace(
            r#"<origin xyz="-0.03 0 0"/><geometry><sphere radius="0.03"/>"#,
            r#"<origin xyz="0 0 0.08"/><geometry><sphere radius="0.03"/>"#,
        )
        .replace(
            r#"<joint name="wrist" type="fixed">"#,
            r#"<joint name="wrist" type="revolute"><axis xyz="1 0 0"/>
    <limit lower="-1" upper="1" effort="10" velocity="2"/>"#,
        );
    let still = arm_motion(1.0, |_| [0.0, 0.0]);
    let options = ReplayOptions {
        allow_missing_joints: true,
        ..ReplayOptions::default()
    };
    let report = replay(&reaching, "fingered.urdf", &still, &options).unwrap();
    assert_eq!(
        report.overlapping_at_rest,
        vec![("forearm".to_string(), "finger".to_string())]
    );
    assert!(report.collisions.is_empty(), "{:?}", report.collisions);
    let names: Vec<&str> = report.joints.iter().map(|j| j.name.as_str()).collect();
    assert_eq!(names, ["shoulder_pitch", "elbow", "wrist", "finger_joint"]);
}

#[test]
fn a_fast_command_is_followed_not_taken_for_a_runaway() {
    // The elbow swung through 1 rad in one 25 ms frame: the motor follows at up to ~70 rad/s,
    // close to its reference (a runaway is judged in `control.rs`'s unit test).
    let swing = arm_motion(1.0, |t| [0.0, if t < 0.5 { -1.0 } else { 0.0 }]);
    let report = replay(ARM, "fingered.urdf", &swing, &held_finger()).unwrap();
    assert!(report.diverged.is_none(), "{:?}", report.diverged);
    assert_eq!(report.physics_steps, 1000);
}

/// A dual-arm station as Franka's FR3 pair is published: an empty root link (no inertia, no
/// shape), each arm's base fixed to it through an empty mount link 0.4 m to its side, and on
/// each base a one-joint arm whose 0.25 m sphere would overlap the other's at the origin.
const STATION: &str = r#"<?xml version="1.0"?>
<robot name="station">
  <link name="base"/>
  <link name="left_mount"/>
  <link name="right_mount"/>
  <link name="left_link0">
    <inertial><mass value="5"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><geometry><sphere radius="0.25"/></geometry></collision>
  </link>
  <link name="right_link0">
    <inertial><mass value="5"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><geometry><sphere radius="0.25"/></geometry></collision>
  </link>
  <link name="left_link1">
    <inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0 0 0.4"/><geometry><sphere radius="0.05"/></geometry></collision>
  </link>
  <link name="right_link1">
    <inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0 0 0.4"/><geometry><sphere radius="0.05"/></geometry></collision>
  </link>
  <joint name="left_mount_joint" type="fixed">
    <parent link="base"/><child link="left_mount"/><origin xyz="0 0.4 0" rpy="-0.7 0 0"/>
  </joint>
  <joint name="right_mount_joint" type="fixed">
    <parent link="base"/><child link="right_mount"/><origin xyz="0 -0.4 0" rpy="0.7 0 0"/>
  </joint>
  <joint name="left_base_joint" type="fixed">
    <parent link="left_mount"/><child link="left_link0"/>
  </joint>
  <joint name="right_base_joint" type="fixed">
    <parent link="right_mount"/><child link="right_link0"/>
  </joint>
  <joint name="left_joint1" type="revolute">
    <parent link="left_link0"/><child link="left_link1"/><origin xyz="0 0 0.3"/><axis xyz="0 0 1"/>
    <limit lower="-2" upper="2" effort="50" velocity="2"/>
  </joint>
  <joint name="right_joint1" type="revolute">
    <parent link="right_link0"/><child link="right_link1"/><origin xyz="0 0 0.3"/><axis xyz="0 0 1"/>
    <limit lower="-2" upper="2" effort="50" velocity="2"/>
  </joint>
</robot>"#;

#[test]
fn arms_mounted_on_an_empty_root_stand_where_their_fixed_joints_put_them() {
    // rapier3d-urdf's squeeze of empty links dropped the mounts' origins: both bases at the
    // origin, their spheres inside each other, 2,907 intervals and a divergence on the FR3 pair.
    let still = Trajectory::new(
        vec!["left_joint1".into(), "right_joint1".into()],
        vec![0.0, 0.5, 1.0],
        vec![0.0, 0.0, 0.3, -0.3, 0.0, 0.0],
    )
    .unwrap();
    let report = replay(STATION, "station.urdf", &still, &ReplayOptions::default()).unwrap();
    assert!(report.collisions.is_empty(), "{:?}", report.collisions);
    assert!(
        report.overlapping_at_rest.is_empty(),
        "{:?}",
        report.overlapping_at_rest
    );
    assert!(report.diverged.is_none());
}
