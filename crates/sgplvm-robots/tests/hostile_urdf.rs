//! Hostile URDF input (issue 13): deep nesting, huge element counts and absurd numbers must
//! give a one-line error naming the file and the element, never a stack overflow or a panic
//! inside the physics engine. Every input is made here. No test bounds wall-clock time (the
//! machines are shared).

use sgplvm_robots::urdf::{MAX_DEPTH, MAX_LENGTH_M, MAX_MASS_KG};
use sgplvm_robots::{Robot, RobotError};

const FILE: &str = "hostile.urdf";

/// A two-link arm whose `base` link holds `link_body` and whose joint carries `limit`.
fn arm(link_body: &str, limit: &str) -> String {
    format!(
        r#"<?xml version="1.0"?>
<robot name="hostile">
  <link name="base">{link_body}</link>
  <link name="tip"/>
  <joint name="j" type="revolute"><parent link="base"/><child link="tip"/>
    <axis xyz="0 0 1"/>{limit}</joint>
</robot>"#
    )
}

const LIMIT: &str = r#"<limit lower="-1" upper="1" effort="5" velocity="2"/>"#;

/// The error of loading `xml`: one line, naming the file.
fn rejected(xml: &str) -> RobotError {
    let e = match Robot::from_urdf_str(xml, FILE) {
        Ok(_) => panic!("should be rejected"),
        Err(e) => e,
    };
    let msg = e.to_string();
    assert!(msg.starts_with(FILE), "{msg}");
    assert!(!msg.contains('\n'), "{msg}");
    e
}

fn invalid_at(xml: &str, element: &str, says: &str) {
    match rejected(xml) {
        RobotError::InvalidElement {
            element: el,
            message,
            line,
            ..
        } => {
            assert!(el.contains(element), "element {el:?}, expected {element:?}");
            assert!((2..=6).contains(&line), "line {line} of {el:?}");
            assert!(message.contains(says), "{message}");
        }
        other => panic!("expected an Invalid error, got {other}"),
    }
}

#[test]
fn the_reference_arm_loads() {
    let r = Robot::from_urdf_str(&arm("", LIMIT), FILE).expect("loads");
    assert_eq!(r.dof(), 1);
}

#[test]
fn twenty_five_thousand_nested_elements_are_refused_before_parsing() {
    let n = 25_000;
    let nested = format!("{}{}", "<a>".repeat(n), "</a>".repeat(n));
    // In a thread with a small stack: nothing may recurse per level.
    let xml = arm(&nested, LIMIT);
    let e = std::thread::Builder::new()
        .stack_size(256 << 10)
        .spawn(move || rejected(&xml).to_string())
        .expect("spawn")
        .join()
        .expect("no stack overflow");
    assert!(e.contains("nest deeper than"), "{e}");
    assert!(e.contains("line 3"), "{e}");
}

#[test]
fn nesting_inside_comments_cdata_and_attributes_does_not_count() {
    let many = "<a>".repeat(2 * MAX_DEPTH);
    let body = format!(
        r#"<!-- {many} --><visual><geometry><box size="1 1 1"/></geometry><material name="{}"/></visual><![CDATA[{many}]]>"#,
        "&lt;a&gt;".repeat(10)
    );
    Robot::from_urdf_str(&arm(&body, LIMIT), FILE).expect("loads");
    // Exactly at the limit is fine (robot and link are two levels).
    let deep = MAX_DEPTH - 2;
    let ok = format!("{}{}", "<a>".repeat(deep), "</a>".repeat(deep));
    Robot::from_urdf_str(&arm(&ok, LIMIT), FILE).expect("at the limit");
    let too = format!("{}{}", "<a>".repeat(deep + 1), "</a>".repeat(deep + 1));
    rejected(&arm(&too, LIMIT));
}

#[test]
fn a_hundred_thousand_elements_and_a_five_thousand_link_chain_load() {
    let flat = "<a/>".repeat(100_000);
    Robot::from_urdf_str(&arm(&flat, LIMIT), FILE).expect("loads");
    // A chain of 5,000 links: the cycle check walks each link once.
    let n = 5_000;
    let mut xml = String::from("<robot name=\"chain\">");
    for i in 0..n {
        xml += &format!("<link name=\"l{i}\"/>");
    }
    for i in 1..n {
        xml += &format!(
            "<joint name=\"j{i}\" type=\"fixed\"><parent link=\"l{}\"/><child link=\"l{i}\"/></joint>",
            i - 1
        );
    }
    xml += "</robot>";
    let chain = Robot::from_urdf_str(&xml, FILE).expect("loads");
    assert_eq!(chain.dof(), 0, "every joint of the chain is fixed");
}

#[test]
fn absurd_sizes_are_refused_with_the_element_and_absurd_inertials_left_out_with_their_line() {
    let visual = |shape: &str| format!("<visual><geometry>{shape}</geometry></visual>");
    invalid_at(
        &arm(&visual(r#"<cylinder radius="0.1" length="1e29"/>"#), LIMIT),
        "<cylinder> @length",
        "too large",
    );
    // A shape of size zero has no extent: left out as nothing to draw or touch, with its line
    // (ROS's parser loads it; Pollen's Reachy has five).
    for shape in [
        r#"<cylinder radius="0" length="1"/>"#,
        r#"<box size="1 0 1"/>"#,
        r#"<sphere radius="0"/>"#,
    ] {
        let robot = Robot::from_urdf_str(&arm(&visual(shape), LIMIT), FILE).expect("loads");
        let said: Vec<String> = robot.repairs().iter().map(ToString::to_string).collect();
        assert!(
            said.iter()
                .any(|r| r.starts_with("<visual> whose shape has a size of zero at line")),
            "{shape}: {said:?}"
        );
        assert!(robot.urdf().links[0].visual.is_empty(), "{shape}");
    }
    invalid_at(
        &arm(&visual(r#"<mesh filename="m.stl" scale="1 0 1"/>"#), LIMIT),
        "<mesh> @scale",
        "scale",
    );
    let too_far = format!("{}", MAX_LENGTH_M * 10.0);
    invalid_at(
        &arm(
            &format!(
                r#"<collision><origin xyz="{too_far} 0 0"/><geometry><sphere radius="1"/></geometry></collision>"#
            ),
            LIMIT,
        ),
        "<origin> @xyz",
        "too large",
    );
    let inertial = |mass: &str, ixx: &str| {
        format!(
            r#"<inertial><mass value="{mass}"/><inertia ixx="{ixx}" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>"#
        )
    };
    // An inertial beyond any robot's (an exporter's garbage ROS's parser loads) is left out,
    // said with its line: the link declares no mass.
    for (mass, ixx, why) in [
        ("1e308", "1", "a mass of 1e308 kg"),
        (
            &format!("{}", MAX_MASS_KG * 2.0)[..],
            "1",
            "a mass of 2e6 kg",
        ),
        ("1", "1e300", "an inertia of 1e300 kg·m²"),
        // RobotEra's STAR1: a placeholder's mass on its hands (the physics engine failed).
        (
            "1.375E-08",
            "5.7e-14",
            "a mass of 1.375e-8 kg, under a milligram",
        ),
        // Pollen's Reachy: g·mm² written as kg·m², its mass 660 m from the axis.
        (
            "0.158",
            "6.887e4",
            "an inertia of 6.887e4 kg·m² on 0.158 kg: its mass 660 m from the axis",
        ),
    ] {
        let robot = Robot::from_urdf_str(&arm(&inertial(mass, ixx), LIMIT), FILE).expect("loads");
        let said: Vec<String> = robot.repairs().iter().map(ToString::to_string).collect();
        assert!(
            said.iter()
                .any(|r| r.contains(&format!("<inertial> of no use ({why}) at line"))),
            "{said:?}"
        );
    }
    let far = format!(
        r#"<inertial><origin xyz="0 {too_far} 0"/><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>"#
    );
    let robot = Robot::from_urdf_str(&arm(&far, LIMIT), FILE).expect("loads");
    assert!(
        robot.repairs()[0]
            .to_string()
            .contains("its origin 1e5 m away"),
        "{}",
        robot.repairs()[0]
    );
    Robot::from_urdf_str(&arm(&inertial("0", "0"), LIMIT), FILE).expect("a massless link loads");
}

#[test]
fn negative_and_zero_velocity_limits_read_as_none_given_and_say_so() {
    let limit = |v: &str| format!(r#"<limit lower="-1" upper="1" effort="5" velocity="{v}"/>"#);
    // 0 on a joint that can move would forbid all motion, and a limit is > 0: makers write
    // either for "not given" (ROS's parser and Pinocchio read the file), so it loads as no
    // limit, and says so on its line.
    for v in ["0", "-1", "-1.0"] {
        let r = Robot::from_urdf_str(&arm("", &limit(v)), FILE).expect("loads");
        assert_eq!(r.velocity_limits(), vec![0.0]);
        let notes: Vec<String> = r.repairs().iter().map(ToString::to_string).collect();
        assert_eq!(notes.len(), 1, "{notes:?}");
        assert!(
            notes[0].contains("line 6 (<joint name=\"j\">)")
                && notes[0].contains("no velocity limit"),
            "{notes:?}"
        );
    }
    let r = Robot::from_urdf_str(
        &arm(
            "",
            r#"<limit lower="-1" upper="1" effort="-5" velocity="1"/>"#,
        ),
        FILE,
    )
    .expect("loads");
    let notes: Vec<String> = r.repairs().iter().map(ToString::to_string).collect();
    assert!(
        notes.len() == 1
            && notes[0].contains("effort=\"-5\"")
            && notes[0].contains("no effort limit"),
        "{notes:?}"
    );
    assert_eq!(r.velocity_limits(), vec![1.0]);
    // No velocity attribute: no limit. A locked joint (lower = upper) may say 0.
    Robot::from_urdf_str(&arm("", r#"<limit lower="-1" upper="1"/>"#), FILE).expect("no velocity");
    Robot::from_urdf_str(
        &arm(
            "",
            r#"<limit lower="0" upper="0" effort="0" velocity="0"/>"#,
        ),
        FILE,
    )
    .expect("locked joint");
}
