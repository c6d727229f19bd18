//! Real-world URDF quirks that must load, one test each, and broken files that must be rejected
//! with a message naming the file, the element and what was expected.
//!
//! Each quirk test also records what urdf-rs 0.9 alone does with the same text, so that a
//! change of urdf-rs's behaviour shows up here.

use nalgebra::Vector3;
use sgplvm_robots::{JointKind, Robot, RobotError};

/// A two-link arm around `joint` (the text of one `<joint>` element named `j`, base → tip).
fn arm(joint: &str) -> String {
    format!(
        r#"<?xml version="1.0"?>
<robot name="quirk">
  <link name="base"/>
  <link name="tip"/>
  {joint}
</robot>"#
    )
}

fn load(xml: &str) -> Robot {
    Robot::from_urdf_str(xml, "quirk.urdf").unwrap_or_else(|e| panic!("should load: {e}"))
}

fn reject(xml: &str) -> String {
    match Robot::from_urdf_str(xml, "broken.urdf") {
        Ok(_) => panic!("should be rejected:\n{xml}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn joint_without_origin_sits_at_the_parent_frame() {
    let xml = arm(
        r#"<joint name="j" type="revolute"><parent link="base"/><child link="tip"/>
        <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>"#,
    );
    assert!(urdf_rs::read_from_string(&xml).is_ok());
    let r = load(&xml);
    let p = r.forward_kinematics(&[0.7], "tip").unwrap();
    assert!(p.translation.vector.norm() < 1e-15);
    assert!((p.rotation.angle() - 0.7).abs() < 1e-12);
}

#[test]
fn origin_without_rpy_or_xyz_defaults_to_zero() {
    let xml = arm(r#"<joint name="j" type="fixed"><origin xyz="0.1 0.2 0.3"/>
        <parent link="base"/><child link="tip"/></joint>"#);
    assert!(urdf_rs::read_from_string(&xml).is_ok());
    let p = load(&xml).forward_kinematics(&[], "tip").unwrap();
    assert_eq!(p.translation.vector, Vector3::new(0.1, 0.2, 0.3));
    assert_eq!(p.rotation.angle(), 0.0);
    let xml = arm(r#"<joint name="j" type="fixed"><origin rpy="0 0 1.5"/>
        <parent link="base"/><child link="tip"/></joint>"#);
    let p = load(&xml).forward_kinematics(&[], "tip").unwrap();
    assert_eq!(p.translation.vector, Vector3::zeros());
    assert!((p.rotation.angle() - 1.5).abs() < 1e-15);
}

#[test]
fn numbers_written_0dot_and_with_exponents_parse() {
    let xml = arm(
        r#"<joint name="j" type="prismatic"><origin xyz="0. 1.6E-4 -2.5e+1" rpy="0. 0 0."/>
        <parent link="base"/><child link="tip"/><axis xyz="1. 0 0"/>
        <limit lower="-.5" upper="+1." effort="1E2" velocity="2."/></joint>"#,
    );
    assert!(urdf_rs::read_from_string(&xml).is_ok());
    let r = load(&xml);
    assert_eq!(r.joint_limits(), vec![(-0.5, 1.0)]);
    let p = r.forward_kinematics(&[0.25], "tip").unwrap();
    assert_eq!(p.translation.vector, Vector3::new(0.25, 1.6e-4, -25.0));
}

#[test]
fn floating_root_joint_is_held_at_its_origin() {
    let xml = r#"<robot name="floating">
      <link name="world"/>
      <link name="base"/>
      <link name="tip"/>
      <joint name="root" type="floating"><origin xyz="0 0 1"/><parent link="world"/><child link="base"/></joint>
      <joint name="j" type="revolute"><origin xyz="0 0 0.5"/><parent link="base"/><child link="tip"/>
        <axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
    </robot>"#;
    assert!(urdf_rs::read_from_string(xml).is_ok());
    let r = load(xml);
    assert_eq!(r.joint_names(), vec!["j".to_string()]);
    assert_eq!(r.joints()[0].kind, JointKind::Floating);
    assert_eq!(r.root_link(), "world");
    let p = r.forward_kinematics(&[0.0], "tip").unwrap();
    assert_eq!(p.translation.vector, Vector3::new(0.0, 0.0, 1.5));
}

#[test]
fn gazebo_sensor_and_transmission_blocks_are_ignored() {
    let xml = r#"<robot name="g" xmlns:xacro="http://www.ros.org/wiki/xacro">
      <link name="base"><sensor name="imu" type="imu"><update_rate>100</update_rate></sensor></link>
      <link name="tip"/>
      <gazebo reference="base"><material>Gazebo/Grey</material><sensor type="camera" name="cam">
        <camera><horizontal_fov>1.3</horizontal_fov></camera></sensor></gazebo>
      <gazebo><plugin name="ros_control" filename="libgazebo_ros_control.so"/></gazebo>
      <transmission name="t"><type>transmission_interface/SimpleTransmission</type>
        <joint name="j"><hardwareInterface>EffortJointInterface</hardwareInterface></joint></transmission>
      <joint name="j" type="continuous"><origin xyz="1 0 0"/><parent link="base"/><child link="tip"/>
        <axis xyz="0 0 1"/></joint>
    </robot>"#;
    assert!(urdf_rs::read_from_string(xml).is_ok());
    let r = load(xml);
    assert_eq!(r.dof(), 1);
    assert_eq!(r.joint_limits(), vec![(f64::NEG_INFINITY, f64::INFINITY)]);
}

#[test]
fn revolute_joint_with_equal_limits_stays_in_the_configuration_but_no_chain_moves_it() {
    let xml = arm(
        r#"<joint name="j" type="revolute"><parent link="base"/><child link="tip"/>
        <axis xyz="0 0 1"/><limit lower="0.2" upper="0.2" effort="0" velocity="0"/></joint>"#,
    );
    assert!(urdf_rs::read_from_string(&xml).is_ok());
    let r = load(&xml);
    assert_eq!(r.joint_limits(), vec![(0.2, 0.2)]);
    // FK does not clamp.
    let p = r.forward_kinematics(&[0.3], "tip").unwrap();
    assert!((p.rotation.angle() - 0.3).abs() < 1e-12);
    // A chain holds it at its one value (Toyota's HSR's sensor frame joint is no arm joint).
    let chain = r.chain("base", "tip").unwrap();
    assert_eq!(chain.dof(), 0);
    assert!((chain.forward(&[]).rotation.angle() - 0.2).abs() < 1e-12);
}

#[test]
fn missing_mesh_files_do_not_matter() {
    let xml = r#"<robot name="m">
      <link name="base"><visual><geometry><mesh filename="package://nowhere/meshes/base.dae" scale="0.001 0.001 0.001"/></geometry></visual>
        <collision><geometry><mesh filename="meshes/does_not_exist.stl"/></geometry></collision></link>
    </robot>"#;
    assert!(urdf_rs::read_from_string(xml).is_ok());
    let r = load(xml);
    assert_eq!(r.link_names(), vec!["base".to_string()]);
    // The third-party fixtures reference meshes that are not copied either.
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures");
    for f in ["kuka_iiwa.urdf", "franka_panda.urdf"] {
        let r = Robot::from_urdf_file(&dir.join(f)).unwrap();
        assert!(r.dof() >= 7);
    }
}

#[test]
fn limit_without_velocity_is_completed_for_urdf_rs() {
    let xml = arm(
        r#"<joint name="j" type="revolute"><parent link="base"/><child link="tip"/>
        <axis xyz="0 0 1"/><limit lower="-1" upper="2"/></joint>"#,
    );
    // urdf-rs 0.9 alone insists on `velocity`.
    assert!(urdf_rs::read_from_string(&xml).is_err());
    let r = load(&xml);
    assert_eq!(r.joint_limits(), vec![(-1.0, 2.0)]);
    assert_eq!(r.velocity_limits(), vec![0.0]);
    assert_eq!(r.urdf().joints[0].limit.upper, 2.0);
}

#[test]
fn limits_written_the_wrong_way_round_are_read_swapped_and_said() {
    // InMoov's head roll: lower 0.3, upper -0.3. ROS's parser reads it; a range cannot run
    // backwards, so it is read the other way round, for the kinematics and for urdf-rs alike.
    let xml = arm(
        r#"<joint name="j" type="revolute"><parent link="base"/><child link="tip"/>
        <axis xyz="0 0 1"/><limit lower="0.3" upper="-0.3" effort="1" velocity="1"/></joint>"#,
    );
    let r = load(&xml);
    assert_eq!(r.joint_limits(), vec![(-0.3, 0.3)]);
    let limit = &r.urdf().joints[0].limit;
    assert_eq!((limit.lower, limit.upper), (-0.3, 0.3));
    let notes: Vec<String> = r.repairs().iter().map(ToString::to_string).collect();
    assert!(
        notes.len() == 1
            && notes[0].contains("<limit> whose lower is above its upper at line 6")
            && notes[0].contains("read the other way round"),
        "{notes:?}"
    );
    // Without a lower (the specification's 0), an upper below it.
    let r = load(&arm(
        r#"<joint name="j" type="revolute"><parent link="base"/><child link="tip"/>
        <axis xyz="0 0 1"/><limit upper="-0.5" effort="1" velocity="1"/></joint>"#,
    ));
    assert_eq!(r.joint_limits(), vec![(-0.5, 0.0)]);
    let limit = &r.urdf().joints[0].limit;
    assert_eq!((limit.lower, limit.upper), (-0.5, 0.0));
}

#[test]
fn nameless_materials_load_as_ros_reads_them_and_each_is_named_by_line() {
    // A published humanoid has 55 of these: the specification requires a name, urdfdom drops
    // such a visual with an error and goes on, urdf-rs 0.9 refuses the whole file.
    let xml = r#"<?xml version="1.0"?>
<robot name="painted">
  <material><color rgba="1 1 1 1"/></material>
  <link name="base">
    <visual><geometry><box size="1 1 1"/></geometry>
      <material><color rgba="0 1 0 1"/></material></visual>
  </link>
  <link name="tip">
    <visual><geometry><sphere radius="0.1"/></geometry>
      <material>
        <color rgba="0 0 1 1"/><texture/>
      </material></visual>
  </link>
  <joint name="j" type="continuous"><parent link="base"/><child link="tip"/></joint>
</robot>"#;
    let e = urdf_rs::read_from_string(xml).unwrap_err().to_string();
    assert!(e.contains("missing field `name`"), "{e}");
    let r = load(xml);
    let notes: Vec<String> = r.repairs().iter().map(ToString::to_string).collect();
    assert_eq!(notes.len(), 2, "{notes:?}");
    assert!(
        notes[0].starts_with("3 × <material> without a name")
            && notes[0].contains("line 3 (<robot>), line 6 (<link name=\"base\"> <visual>), line 10 (<link name=\"tip\"> <visual>)"),
        "{notes:?}"
    );
    assert!(
        notes[1].contains("<texture> without a filename at line 11"),
        "{notes:?}"
    );
    // The colours are kept, the lines are the file's.
    let tip = &r.urdf().links[1].visual[0];
    let m = tip.material.as_ref().unwrap();
    assert_eq!(m.name, "material_line_10");
    assert_eq!(*m.color.as_ref().unwrap().rgba, [0.0, 0.0, 1.0, 1.0]);
    assert!(m.texture.is_none());
    // A broken element after the repaired ones still names its own line.
    let broken = xml.replace(r#"<sphere radius="0.1"/>"#, r#"<sphere radius="-1"/>"#);
    let e = reject(&broken);
    assert!(
        e.starts_with("broken.urdf:9: <link name=\"tip\"> <visual> <geometry> <sphere> @radius: -1 is negative"),
        "{e}"
    );
}

#[test]
fn text_beside_a_geometry_s_shape_is_left_out_as_ros_reads_it() {
    // AgileX's Tracer wheels (mobile_aloha_sim, expanded from xacro): `<geometry>-->`, a
    // comment's end left behind. urdf-rs took the text for a shape ("unknown variant `-->`",
    // no line); ROS's parser reads the mesh.
    let xml = r#"<?xml version="1.0"?>
<robot name="wheeled">
  <link name="base">
    <collision><geometry>--><cylinder radius="0.1" length="0.05"/></geometry></collision>
  </link>
  <link name="tip">
    <visual><geometry><sphere radius="0.1"/>
      --></geometry></visual>
  </link>
  <joint name="j" type="continuous"><parent link="base"/><child link="tip"/></joint>
</robot>"#;
    let e = urdf_rs::read_from_string(xml).unwrap_err().to_string();
    assert!(e.contains("-->"), "{e}");
    let r = load(xml);
    let notes: Vec<String> = r.repairs().iter().map(ToString::to_string).collect();
    assert_eq!(notes.len(), 1, "{notes:?}");
    assert!(
        notes[0].starts_with("2 × text inside a <geometry> beside its shape at line 4 (<link name=\"base\"> <collision>), line 8 (<link name=\"tip\"> <visual>)"),
        "{notes:?}"
    );
    assert!(matches!(
        r.urdf().links[0].collision[0].geometry,
        urdf_rs::Geometry::Cylinder { .. }
    ));
}

#[test]
fn what_the_specification_defaults_is_filled_and_what_it_requires_is_noted() {
    let xml = arm(
        r#"<joint name="j" type="revolute"><parent link="base"/><child link="tip"/>
        <axis/><dynamics damping="0.5"/><limit upper="1" effort="2" velocity="3"/>
        <safety_controller soft_upper_limit="0.9"/></joint>"#,
    );
    let r = load(&xml);
    assert_eq!(r.joint_limits(), vec![(0.0, 1.0)]);
    assert_eq!(*r.urdf().joints[0].axis.xyz, [1.0, 0.0, 0.0]);
    assert_eq!(r.urdf().joints[0].dynamics.as_ref().unwrap().friction, 0.0);
    let notes: Vec<String> = r.repairs().iter().map(ToString::to_string).collect();
    assert_eq!(notes.len(), 2, "{notes:?}");
    assert!(
        notes[0].starts_with("<axis> without xyz (the specification requires it) at line 6"),
        "{notes:?}"
    );
    assert!(
        notes[1].starts_with("<safety_controller> without k_velocity"),
        "{notes:?}"
    );
}

#[test]
fn quat_xyzw_origins_of_urdf_1_1_are_read() {
    let h = std::f64::consts::FRAC_1_SQRT_2;
    let xml = format!(
        r#"<robot name="q" version="1.1"><link name="base"/><link name="tip"/>
        <joint name="j" type="fixed"><origin xyz="0 0 0" quat_xyzw="0 0 {h} {h}"/>
        <parent link="base"/><child link="tip"/></joint></robot>"#
    );
    let r = load(&xml);
    let p = r.forward_kinematics(&[], "tip").unwrap();
    assert!((p.rotation.angle() - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
    assert!((p.rotation.axis().unwrap().z - 1.0).abs() < 1e-12);
}

#[test]
fn quat_xyzw_conflicts_and_old_versions() {
    // Both orientations at once is an error in URDF 1.1 ...
    let both = r#"<robot name="q" version="1.1"><link name="base"/><link name="tip"/>
        <joint name="j" type="fixed"><origin rpy="0 0 1" quat_xyzw="0 0 0 1"/>
        <parent link="base"/><child link="tip"/></joint></robot>"#;
    assert!(reject(both).contains("both rpy and quat_xyzw are given"));
    let zero = both.replace(
        r#"rpy="0 0 1" quat_xyzw="0 0 0 1""#,
        r#"quat_xyzw="0 0 0 0""#,
    );
    assert!(reject(&zero).contains("@quat_xyzw: the quaternion is zero"));
    // ... and before 1.1 quat_xyzw is ignored, as urdfdom does.
    let old = both.replace(" version=\"1.1\"", "");
    let p = load(&old).forward_kinematics(&[], "tip").unwrap();
    assert!((p.rotation.angle() - 1.0).abs() < 1e-12);
}

#[test]
fn robots_without_the_arm_convention_have_no_arms() {
    let r = load(&arm(
        r#"<joint name="j" type="fixed"><parent link="base"/><child link="tip"/></joint>"#,
    ));
    assert!(r.arms().is_none());
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures");
    let kuka = Robot::from_urdf_file(&dir.join("kuka_iiwa.urdf")).unwrap();
    assert!(kuka.arms().is_none());
    assert_eq!(kuka.joint_names().len(), 7);
    assert_eq!(kuka.joint_index("lbr_iiwa_joint_4"), Some(3));
    assert_eq!(kuka.joint_index("nope"), None);
}

// ----------------------------------------------------------------------------- broken files

#[test]
fn unknown_parent_link_is_named() {
    let e = reject(&arm(
        r#"<joint name="j" type="fixed"><parent link="bsae"/><child link="tip"/></joint>"#,
    ));
    assert_eq!(
        e,
        "broken.urdf:5: <joint name=\"j\">: unknown parent link \"bsae\" (expected the name of a declared <link>)"
    );
    // urdf-rs alone does not notice.
    assert!(urdf_rs::read_from_string(&arm(
        r#"<joint name="j" type="fixed"><parent link="bsae"/><child link="tip"/></joint>"#
    ))
    .is_ok());
}

#[test]
fn unknown_child_link_is_named() {
    let e = reject(&arm(
        r#"<joint name="j" type="fixed"><parent link="base"/><child link="tpi"/></joint>"#,
    ));
    assert!(e.contains("unknown child link \"tpi\""), "{e}");
}

#[test]
fn a_cycle_is_reported_with_its_links() {
    let xml = r#"<robot name="c"><link name="root"/><link name="a"/><link name="b"/><link name="c"/>
      <joint name="ra" type="fixed"><parent link="root"/><child link="a"/></joint>
      <joint name="bc" type="fixed"><parent link="b"/><child link="c"/></joint>
      <joint name="cb" type="fixed"><parent link="c"/><child link="b"/></joint></robot>"#;
    assert!(urdf_rs::read_from_string(xml).is_ok());
    let e = Robot::from_urdf_str(xml, "broken.urdf").unwrap_err();
    match &e {
        RobotError::Cycle { file, links } => {
            assert_eq!(file, "broken.urdf");
            let mut l = links.clone();
            l.sort();
            assert_eq!(l, vec!["b".to_string(), "c".to_string()]);
        }
        other => panic!("expected a cycle, got {other}"),
    }
    assert!(e.to_string().contains("cycle through links"), "{e}");
    // A joint from a link to itself.
    let e = reject(&arm(
        r#"<joint name="j" type="fixed"><parent link="tip"/><child link="tip"/></joint>"#,
    ));
    assert!(e.contains("cycle through links \"tip\""), "{e}");
}

#[test]
fn two_roots_are_listed() {
    let xml = r#"<robot name="t"><link name="base"/><link name="tip"/><link name="stray"/>
      <joint name="j" type="fixed"><parent link="base"/><child link="tip"/></joint></robot>"#;
    assert_eq!(
        reject(xml),
        "broken.urdf: 2 root links (\"base\", \"stray\"); expected exactly one link that is no joint's child"
    );
}

#[test]
fn a_link_with_two_parents_is_rejected() {
    let xml = r#"<robot name="t"><link name="a"/><link name="b"/><link name="tip"/>
      <joint name="j1" type="fixed"><parent link="a"/><child link="tip"/></joint>
      <joint name="j2" type="fixed"><parent link="b"/><child link="tip"/></joint></robot>"#;
    let e = reject(xml);
    assert!(
        e.contains("<joint name=\"j2\">") && e.contains("already the child of joint \"j1\""),
        "{e}"
    );
}

#[test]
fn a_bad_number_names_element_attribute_and_text() {
    let e = reject(&arm(
        r#"<joint name="j" type="fixed"><origin xyz="0 0,5 1"/>
        <parent link="base"/><child link="tip"/></joint>"#,
    ));
    assert_eq!(
        e,
        "broken.urdf:5: <joint name=\"j\"> <origin> @xyz: bad number \"0,5\", expected a finite decimal number such as 0.25 or 1.6E-4"
    );
    // urdf-rs 0.9 silently drops the unparsable token when three others remain.
    let sloppy = arm(r#"<joint name="j" type="fixed"><origin xyz="1 x 2 3"/>
        <parent link="base"/><child link="tip"/></joint>"#);
    let parsed = urdf_rs::read_from_string(&sloppy).unwrap();
    assert_eq!(*parsed.joints[0].origin.xyz, [1.0, 2.0, 3.0]);
    let e = reject(&sloppy);
    assert!(
        e.contains("@xyz: \"1 x 2 3\" has 4 values, expected 3 numbers"),
        "{e}"
    );
    let e = reject(&arm(
        r#"<joint name="j" type="revolute"><parent link="base"/><child link="tip"/>
        <limit lower="-1" upper="NaN" effort="1" velocity="1"/></joint>"#,
    ));
    assert!(
        e.contains("<joint name=\"j\"> <limit> @upper: bad number \"NaN\""),
        "{e}"
    );
    let e = reject(
        r#"<robot name="m"><link name="l"><inertial><mass value="heavy"/>
        <inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link></robot>"#,
    );
    assert!(
        e.contains("<link name=\"l\"> <inertial> <mass> @value: bad number \"heavy\""),
        "{e}"
    );
}

#[test]
fn an_unknown_joint_type_lists_the_known_ones() {
    let e = reject(&arm(
        r#"<joint name="j" type="ball"><parent link="base"/><child link="tip"/></joint>"#,
    ));
    assert_eq!(
        e,
        "broken.urdf:5: <joint name=\"j\"> @type: unknown joint type \"ball\", expected one of revolute, continuous, prismatic, fixed, floating, planar"
    );
}

#[test]
fn repeated_elements_ros_reads_once_keep_the_first_and_say_so() {
    // PAL's REEM-C (expanded from xacro) gives a leg joint two <dynamics>, PAL's ARI a
    // collision two <origin>: urdfdom reads the first of each, urdf-rs refused the file.
    let xml = r#"<?xml version="1.0"?>
<robot name="repeats">
  <link name="base"/>
  <link name="tip">
    <collision>
      <origin xyz="0 0 0.1"/>
      <origin xyz="5 5 5"/>
      <geometry><sphere radius="0.05"/></geometry>
    </collision>
  </link>
  <joint name="j" type="revolute">
    <parent link="base"/><child link="tip"/>
    <axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="5" velocity="2"/>
    <dynamics damping="0.5"/>
    <dynamics damping="9"/>
    <limit lower="-3" upper="3" effort="5" velocity="2"/>
  </joint>
</robot>"#;
    assert!(urdf_rs::read_from_string(xml).is_err());
    let r = load(xml);
    let notes: Vec<String> = r.repairs().iter().map(ToString::to_string).collect();
    assert_eq!(
        notes,
        [
            "a second <origin> at line 7 (<link name=\"tip\"> <collision>): left out: ROS's parser reads the first",
            "a second <limit> at line 17 (<joint name=\"j\">): left out: ROS's parser reads the first",
            "a second <dynamics> at line 16 (<joint name=\"j\">): left out: ROS's parser reads the first",
        ]
    );
    assert_eq!(r.joint_limits()[0], (-1.0, 1.0));
    let collision = &r.urdf().links[1].collision[0];
    assert!((collision.origin.xyz[2] - 0.1).abs() < 1e-12);
    assert_eq!(r.urdf().joints[0].dynamics.as_ref().unwrap().damping, 0.5);
}

#[test]
fn other_broken_files() {
    // Not XML.
    let e = Robot::from_urdf_str("<robot name=\"x\"><link name=\"a\"></robot>", "broken.urdf")
        .unwrap_err();
    assert!(matches!(e, RobotError::Xml { .. }), "{e}");
    assert!(
        e.to_string()
            .starts_with("broken.urdf: not well-formed XML"),
        "{e}"
    );
    let e = Robot::from_urdf_str("", "empty.urdf")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("empty.urdf") && e.contains("expected <robot>"),
        "{e}"
    );
    // Wrong document element.
    assert!(reject("<sdf version=\"1.6\"><model/></sdf>")
        .contains("<sdf>: the document element must be <robot>"));
    // A revolute joint without limits, a zero axis.
    let e = reject(&arm(
        r#"<joint name="j" type="revolute"><parent link="base"/><child link="tip"/></joint>"#,
    ));
    assert!(
        e.contains("missing <limit lower=... upper=...>, required for a revolute joint"),
        "{e}"
    );
    let e = reject(&arm(
        r#"<joint name="j" type="continuous"><parent link="base"/><child link="tip"/>
        <axis xyz="0 0 0"/></joint>"#,
    ));
    assert!(e.contains("<axis> @xyz: the axis is zero"), "{e}");
    // Missing attributes and elements.
    let e = reject(&arm(
        r#"<joint type="fixed"><parent link="base"/><child link="tip"/></joint>"#,
    ));
    assert!(e.contains("<joint>: missing attribute \"name\""), "{e}");
    let e = reject(&arm(
        r#"<joint name="j" type="fixed"><child link="tip"/></joint>"#,
    ));
    assert!(e.contains("missing <parent link=\"...\">"), "{e}");
    // Duplicate names.
    let e = reject(r#"<robot name="d"><link name="a"/><link name="a"/></robot>"#);
    assert!(e.contains("a second link with this name"), "{e}");
    // Geometry problems.
    let e = reject(
        r#"<robot name="g"><link name="a"><collision><geometry><cone radius="1"/></geometry></collision></link></robot>"#,
    );
    assert!(e.contains("unknown shape <cone>"), "{e}");
    let e = reject(
        r#"<robot name="g"><link name="a"><collision><geometry><sphere radius="-1"/></geometry></collision></link></robot>"#,
    );
    assert!(e.contains("<sphere> @radius: -1 is negative"), "{e}");
    // No links at all; an unreadable file.
    assert!(reject(r#"<robot name="e"/>"#).contains("no <link> elements"));
    let e = Robot::from_urdf_file(std::path::Path::new("/nonexistent/robot.urdf")).unwrap_err();
    assert!(
        e.to_string()
            .starts_with("/nonexistent/robot.urdf: cannot read the URDF file"),
        "{e}"
    );
}

#[test]
fn random_mutations_never_panic() {
    // Byte-level mutations of a real model: every outcome must be Ok or a typed error.
    use rand::{Rng, SeedableRng};
    let base = Robot::builtin_urdf("coman").unwrap().as_bytes().to_vec();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    let alphabet = b"<>/=\" .-eE0123456789abcxyz";
    let mut loaded = 0;
    for _ in 0..300 {
        let mut bytes = base.clone();
        for _ in 0..rng.random_range(1..6) {
            let i = rng.random_range(0..bytes.len());
            match rng.random_range(0..3) {
                0 => bytes[i] = alphabet[rng.random_range(0..alphabet.len())],
                1 => {
                    bytes.remove(i);
                }
                _ => {
                    let end = (i + rng.random_range(1..200)).min(bytes.len());
                    bytes.drain(i..end);
                }
            }
        }
        let text = String::from_utf8_lossy(&bytes);
        if Robot::from_urdf_str(&text, "mutated.urdf").is_ok() {
            loaded += 1;
        }
    }
    // Some mutations hit comments or names and still load; most must not.
    assert!(loaded < 300, "{loaded}");
}
