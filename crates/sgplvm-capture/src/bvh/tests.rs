//! Tests of the BVH reader.

use super::parser::short;
use super::*;

pub(crate) const TWO_FRAMES: &str = "HIERARCHY
ROOT Hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT Spine
  {
    OFFSET 0 10 0
    CHANNELS 3 Zrotation Yrotation Xrotation
    End Site
    {
      OFFSET 0 5 0
    }
  }
}
MOTION
Frames: 2
Frame Time: 0.0083333
1 2 3 0 0 0 90 0 0
1 2 3 0 0 0 0 90 0
";

fn err(text: &str) -> String {
    Bvh::parse(text, "t.bvh").unwrap_err().to_string()
}

#[test]
fn reads_hierarchy_channels_and_frames() {
    let b = Bvh::parse(TWO_FRAMES, "t.bvh").unwrap();
    assert_eq!(b.joints.len(), 2);
    assert_eq!(b.channels, 9);
    assert_eq!(b.frames(), 2);
    assert_eq!(b.joints[1].parent, Some(0));
    assert_eq!(b.joints[1].first_channel, 6);
    assert_eq!(b.joints[1].end_site, Some(Vector3::new(0.0, 5.0, 0.0)));
    assert!((b.frame_rate() - 120.0).abs() < 1e-2);
    // Spine: Zrotation 90 then the End Site (0, 5, 0) points along -x.
    let (t, r) = b.joints[1].local(b.frame(0));
    assert_eq!(t, Vector3::new(0.0, 10.0, 0.0));
    let tip = r * Vector3::new(0.0, 5.0, 0.0);
    assert!((tip - Vector3::new(-5.0, 0.0, 0.0)).norm() < 1e-12);
    // Root: position channels replace the offset.
    let (t0, _) = b.joints[0].local(b.frame(0));
    assert_eq!(t0, Vector3::new(1.0, 2.0, 3.0));
}

#[test]
fn a_joint_with_position_channels_rests_where_the_first_frame_puts_it() {
    // Perception Neuron's exports carry positions on every joint, and the bones move by them:
    // one whose offset says 10 and whose channels say 12 is 12 long at rest, as a stream of it
    // (each joint's translation as the frame gives it) rests.
    let six = TWO_FRAMES
        .replace(
            "    OFFSET 0 10 0\n    CHANNELS 3 Zrotation Yrotation Xrotation",
            "    OFFSET 0 10 0\n    CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation",
        )
        .replace("1 2 3 0 0 0 90 0 0", "1 2 3 0 0 0 0 12 0 90 0 0")
        .replace("1 2 3 0 0 0 0 90 0", "1 2 3 0 0 0 0 12 0 0 90 0");
    let b = Bvh::parse(&six, "t.bvh").unwrap();
    assert_eq!(b.rest_position(0, 1), Some(Vector3::new(0.0, 12.0, 0.0)));
    // Without position channels: the offset.
    let b = Bvh::parse(TWO_FRAMES, "t.bvh").unwrap();
    assert_eq!(b.rest_position(0, 1), Some(Vector3::new(0.0, 10.0, 0.0)));
}

#[test]
fn channel_order_composes_left_to_right() {
    // Zrotation Xrotation Yrotation 30 40 50 is Rz(30) Rx(40) Ry(50).
    let j = BvhJoint {
        name: "j".into(),
        parent: None,
        offset: Vector3::zeros(),
        channels: vec![Channel::Zrotation, Channel::Xrotation, Channel::Yrotation],
        first_channel: 0,
        end_site: None,
        line: 1,
    };
    let (_, r) = j.local(&[30.0, 40.0, 50.0]);
    let expect = Rotation3::from_axis_angle(&Vector3::z_axis(), 30f64.to_radians())
        * Rotation3::from_axis_angle(&Vector3::x_axis(), 40f64.to_radians())
        * Rotation3::from_axis_angle(&Vector3::y_axis(), 50f64.to_radians());
    assert!((r.matrix() - expect.matrix()).norm() < 1e-12);
}

#[test]
fn rejects_broken_files_with_the_line() {
    let wrong_count = TWO_FRAMES.replace("1 2 3 0 0 0 0 90 0", "1 2 3 0 0 0 0 90");
    assert!(
        err(&wrong_count).contains("t.bvh:20: frame 2 has 8 values, expected 9"),
        "{}",
        err(&wrong_count)
    );
    let truncated = TWO_FRAMES.replace("1 2 3 0 0 0 0 90 0\n", "");
    assert!(err(&truncated).contains("truncated"), "{}", err(&truncated));
    let nan = TWO_FRAMES.replace("0 0 0 90 0 0", "0 0 0 NaN 0 0");
    assert!(
        err(&nan).contains("t.bvh:19: frame 1, value 7 (Spine Zrotation): found `NaN`"),
        "{}",
        err(&nan)
    );
    let text = TWO_FRAMES.replace("0 0 0 90 0 0", "0 0 0 ninety 0 0");
    assert!(err(&text).contains("`ninety`"));
    // More frame lines than declared: the count rules, the rest is counted (assimp's
    // `Boxing_Toes.bvh` has one more than its header says).
    let too_many = TWO_FRAMES.replace("Frames: 2", "Frames: 1");
    let one = Bvh::parse(&too_many, "t.bvh").unwrap();
    assert_eq!(
        (one.values.len() / one.channels, one.frame_lines_left_out),
        (1, 1)
    );
    assert_eq!(
        Bvh::parse(TWO_FRAMES, "t.bvh")
            .unwrap()
            .frame_lines_left_out,
        0
    );
    let huge = TWO_FRAMES.replace("Frames: 2", "Frames: 100000000");
    assert!(
        err(&huge).contains("declares 100000000 frames"),
        "{}",
        err(&huge)
    );
    let zero = TWO_FRAMES.replace("0.0083333", "0");
    assert!(
        err(&zero).contains("t.bvh:18: frame time 0 s"),
        "{}",
        err(&zero)
    );
    let bad_channel = TWO_FRAMES.replace(
        "Zrotation Yrotation Xrotation",
        "Zrotation Yrotation Wrotation",
    );
    assert!(
        err(&bad_channel).contains("t.bvh:9: found `Wrotation`"),
        "{}",
        err(&bad_channel)
    );
    let short_channels = TWO_FRAMES.replace(
        "CHANNELS 3 Zrotation Yrotation Xrotation",
        "CHANNELS 3 Zrotation Yrotation",
    );
    assert!(
        err(&short_channels).contains("t.bvh:10:"),
        "{}",
        err(&short_channels)
    );
    assert!(err("").contains("empty"));
    assert!(err("hello").contains("expected `HIERARCHY`"));
    // A binary file (an MCAP given by mistake): said, not printed.
    let binary = String::from_utf8_lossy(b"\x89MCAP0\r\n\x01\xff\x00").into_owned();
    assert_eq!(
        err(&binary),
        "t.bvh:1: found binary data, expected `HIERARCHY` (is this a BVH file?)"
    );
    assert_eq!(short("a\u{1}b"), "a\\u{1}b");
    let unclosed = TWO_FRAMES.replace("  }\n}\nMOTION", "  }\nMOTION");
    assert!(err(&unclosed).contains("still open"), "{}", err(&unclosed));
}

#[test]
fn deep_hierarchies_are_refused_without_recursion() {
    let mut text = String::from(
        "HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n",
    );
    for i in 0..10_000 {
        text.push_str(&format!("JOINT j{i}\n{{\nOFFSET 0 1 0\n"));
    }
    let e = err(&text);
    assert!(e.contains("nested deeper than 1000"), "{e}");
}

#[test]
fn names_with_spaces_and_braces_on_the_same_line() {
    let text = TWO_FRAMES.replace("JOINT Spine\n  {", "JOINT Upper Spine {");
    let b = Bvh::parse(&text, "t.bvh").unwrap();
    assert_eq!(b.joints[1].name, "Upper Spine");
}
