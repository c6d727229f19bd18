//! Datagrams written byte by byte from the specification's tables (independently of
//! [`encode`]), decoded to the exact values; round trips; every kind of bad input. Split frames
//! and the receiver on loopback in `receiver.rs`; frames through the importer's fit in `fit.rs`.

use nalgebra::{UnitQuaternion, Vector3};

use super::*;

mod fit;
mod receiver;

/// The 24-byte header in the order of §2.4.1, field by field, big-endian.
#[allow(clippy::too_many_arguments)]
fn spec_header(
    kind: &[u8; 2],
    sample: u32,
    datagram_counter: u8,
    items: u8,
    time_code: u32,
    character: u8,
    counts: [u8; 3],
    payload: u16,
) -> Vec<u8> {
    let mut b = Vec::new();
    b.extend_from_slice(b"MXTP"); // 0..4 ID string
    b.extend_from_slice(kind); // 4..6 message type
    b.extend_from_slice(&sample.to_be_bytes()); // 6..10 sample counter
    b.push(datagram_counter); // 10
    b.push(items); // 11
    b.extend_from_slice(&time_code.to_be_bytes()); // 12..16
    b.push(character); // 16
    b.extend_from_slice(&counts); // 17, 18, 19: body segments, props, fingers
    b.extend_from_slice(&[0, 0]); // 20..22 reserved
    b.extend_from_slice(&payload.to_be_bytes()); // 22..24 payload size
    assert_eq!(b.len(), 24);
    b
}

/// A type 02 item (§2.5.3): ID, x y z, q1..q4.
fn spec_quaternion_item(id: u32, p: [f32; 3], q: [f32; 4]) -> Vec<u8> {
    let mut b = id.to_be_bytes().to_vec();
    for v in p.iter().chain(&q) {
        b.extend_from_slice(&v.to_be_bytes());
    }
    assert_eq!(b.len(), 32);
    b
}

/// A type 01 item (§2.5.2): ID, x y z, rotation x y z.
fn spec_euler_item(id: u32, p: [f32; 3], r: [f32; 3]) -> Vec<u8> {
    let mut b = id.to_be_bytes().to_vec();
    for v in p.iter().chain(&r) {
        b.extend_from_slice(&v.to_be_bytes());
    }
    assert_eq!(b.len(), 28);
    b
}

/// A whole-frame type 02 datagram of `items` for an MVN 2019+ sender.
fn spec_type_02(sample: u32, items: &[(u32, [f32; 3], [f32; 4])], counts: [u8; 3]) -> Vec<u8> {
    let payload = (items.len() * 32) as u16;
    let mut b = spec_header(
        b"02",
        sample,
        0x80,
        items.len() as u8,
        777,
        0,
        counts,
        payload,
    );
    for (id, p, q) in items {
        b.extend(spec_quaternion_item(*id, *p, *q));
    }
    b
}

/// The 23 body segments with distinct positions and unit quaternions.
fn body_items() -> Vec<(u32, [f32; 3], [f32; 4])> {
    (1..=23u32)
        .map(|id| {
            let f = id as f32;
            let (s, c) = (0.05 * f).sin_cos();
            let q = [c, 0.6 * s, -0.8 * s, 0.0];
            (id, [0.01 * f, -0.25 + 0.02 * f, 0.5 + 0.04 * f], q)
        })
        .collect()
}

#[test]
fn mvn_literal_bytes_decode_to_exact_values() {
    #[rustfmt::skip]
    let bytes: [u8; 56] = [
        b'M', b'X', b'T', b'P', b'0', b'2', // ID string
        0x00, 0x00, 0x04, 0xD2, // sample counter 1234
        0x80, // datagram counter: index 0, last
        0x01, // one item
        0x00, 0x00, 0xDD, 0xD5, // time code 56789 ms
        0x03, // character 3
        23, 0, 0, // body segments, props, fingers
        0x00, 0x00, // reserved
        0x00, 0x20, // payload 32 bytes
        0x00, 0x00, 0x00, 0x09, // segment 9, RightUpperArm
        0x3F, 0x80, 0x00, 0x00, // x 1.0
        0xBF, 0x00, 0x00, 0x00, // y -0.5
        0x40, 0x00, 0x00, 0x00, // z 2.0
        0x3F, 0x00, 0x00, 0x00, // q1 0.5
        0xBF, 0x00, 0x00, 0x00, // q2 -0.5
        0x3F, 0x00, 0x00, 0x00, // q3 0.5
        0x3F, 0x00, 0x00, 0x00, // q4 0.5
    ];
    let pose = decode(&bytes).unwrap();
    assert_eq!(pose.kind, PoseType::Quaternion);
    assert_eq!(pose.sample_counter, 1234);
    assert_eq!(pose.time_code_ms, 56_789);
    assert_eq!(pose.character_id, 3);
    assert_eq!(
        pose.counts,
        Some(SegmentCounts {
            body: 23,
            props: 0,
            fingers: 0
        })
    );
    assert_eq!(
        pose.segments,
        vec![SegmentPose {
            id: 9,
            position: [1.0, -0.5, 2.0],
            orientation: [0.5, -0.5, 0.5, 0.5],
        }]
    );
    assert_eq!(segment_name(9, 0), Some("RightUpperArm"));
    let w = pose.named("RightUpperArm").unwrap();
    assert_eq!(w.position, Vector3::new(1.0, -0.5, 2.0));
    // w = 0.5, (x, y, z) = (-0.5, 0.5, 0.5): 120° about (-1, 1, 1)/√3.
    let expected = UnitQuaternion::from_axis_angle(
        &nalgebra::Unit::new_normalize(Vector3::new(-1.0, 1.0, 1.0)),
        120f64.to_radians(),
    );
    assert!((w.rotation.matrix() - expected.to_rotation_matrix().matrix()).norm() < 1e-12);
}

#[test]
fn mvn_type_02_of_23_segments_decodes_exactly_and_round_trips() {
    let items = body_items();
    let bytes = spec_type_02(42, &items, [23, 0, 0]);
    assert_eq!(bytes.len(), 24 + 23 * 32);
    let pose = decode(&bytes).unwrap();
    assert_eq!(pose.segments.len(), 23);
    for (s, (id, p, q)) in pose.segments.iter().zip(&items) {
        assert_eq!((s.id, s.position, s.orientation), (*id, *p, *q));
    }
    let names: Vec<&str> = pose.world_poses().keys().copied().collect();
    let mut body = BODY_SEGMENTS.to_vec();
    body.sort_unstable();
    assert_eq!(names, body);
    assert_eq!(
        pose.named("T8").unwrap().position.z,
        f64::from(items[4].1[2])
    );
    // Bytes → pose → bytes, and pose → bytes → pose, exactly.
    assert_eq!(encode(&pose, PoseType::Quaternion).unwrap(), bytes);
    assert_eq!(
        decode(&encode(&pose, PoseType::Quaternion).unwrap()).unwrap(),
        pose
    );
}

#[test]
fn mvn_type_01_converts_cm_y_up_euler_to_m_z_up_quaternions() {
    let cases: [(u32, [f32; 3], [f32; 3]); 4] = [
        (1, [10.0, 170.0, 20.0], [0.0, 0.0, 0.0]),
        (5, [0.0, 0.0, 0.0], [90.0, 0.0, 0.0]),
        (9, [0.0, 0.0, 0.0], [0.0, 90.0, 0.0]),
        (13, [-4.0, 8.0, 12.0], [30.0, 40.0, 50.0]),
    ];
    let mut b = spec_header(b"01", 7, 0x80, 4, 0, 0, [23, 0, 0], 4 * 28);
    for (id, p, r) in cases {
        b.extend(spec_euler_item(id, p, r));
    }
    let pose = decode(&b).unwrap();
    assert_eq!(pose.kind, PoseType::Euler);
    // Y-up (x, y, z) cm → Z-up (z, x, y) m.
    let p0 = pose.segments[0].position.map(f64::from);
    for (got, want) in p0.iter().zip([0.2, 0.1, 1.7]) {
        assert!((got - want).abs() < 1e-6, "{p0:?}");
    }
    // Y-up x is Z-up y, Y-up y is Z-up z, Y-up z is Z-up x.
    let (yx, yy, yz) = (Vector3::y_axis(), Vector3::z_axis(), Vector3::x_axis());
    let deg = |a: f64| a.to_radians();
    let expected = [
        UnitQuaternion::identity(),
        UnitQuaternion::from_axis_angle(&yx, deg(90.0)),
        UnitQuaternion::from_axis_angle(&yy, deg(90.0)),
        // R = Rz(50) Ry(40) Rx(30) about the Y-up axes.
        UnitQuaternion::from_axis_angle(&yz, deg(50.0))
            * UnitQuaternion::from_axis_angle(&yy, deg(40.0))
            * UnitQuaternion::from_axis_angle(&yx, deg(30.0)),
    ];
    for (s, q) in pose.segments.iter().zip(expected) {
        let got = s.world().rotation;
        assert!(
            (got.matrix() - q.to_rotation_matrix().matrix()).norm() < 1e-6,
            "segment {}: {got:?} vs {q:?}",
            s.id
        );
    }
    let p3 = pose.segments[3].position.map(f64::from);
    for (got, want) in p3.iter().zip([0.12, -0.04, 0.08]) {
        assert!((got - want).abs() < 1e-6, "{p3:?}");
    }
}

#[test]
fn mvn_type_01_round_trips_within_f32_rounding() {
    let pose = decode(&spec_type_02(3, &body_items(), [23, 0, 0])).unwrap();
    let euler = encode(&pose, PoseType::Euler).unwrap();
    assert_eq!(&euler[..6], b"MXTP01");
    assert_eq!(euler.len(), 24 + 23 * 28);
    let back = decode(&euler).unwrap();
    assert_eq!(back.kind, PoseType::Euler);
    assert_eq!(back.sample_counter, 3);
    for (a, b) in pose.segments.iter().zip(&back.segments) {
        assert_eq!(a.id, b.id);
        let (wa, wb) = (a.world(), b.world());
        assert!((wa.position - wb.position).norm() < 1e-6);
        assert!((wa.rotation.matrix() - wb.rotation.matrix()).norm() < 1e-5);
    }
}

#[test]
fn mvn_legacy_header_is_read_and_written_back() {
    // Before MVN 2019 bytes 17-23 were free (zero): no counts, no payload size.
    let items = body_items();
    let mut b = spec_header(b"02", 9, 0x80, 23, 5, 0, [0, 0, 0], 0);
    for (id, p, q) in &items {
        b.extend(spec_quaternion_item(*id, *p, *q));
    }
    let pose = decode(&b).unwrap();
    assert_eq!(pose.counts, None);
    assert_eq!(pose.segments.len(), 23);
    assert_eq!(encode(&pose, PoseType::Quaternion).unwrap(), b);
    // A prop (ID 24) is accepted from a legacy sender, a 28th ID is not.
    let mut with_prop = spec_header(b"02", 9, 0x80, 1, 5, 0, [0, 0, 0], 0);
    with_prop.extend(spec_quaternion_item(24, [0.0; 3], [1.0, 0.0, 0.0, 0.0]));
    let prop = decode(&with_prop).unwrap();
    assert_eq!(
        prop.world_poses().keys().copied().collect::<Vec<_>>(),
        ["Prop1"]
    );
    let mut beyond = spec_header(b"02", 9, 0x80, 1, 5, 0, [0, 0, 0], 0);
    beyond.extend(spec_quaternion_item(28, [0.0; 3], [1.0, 0.0, 0.0, 0.0]));
    assert!(matches!(
        decode(&beyond),
        Err(MvnError::SegmentId { id: 28, .. })
    ));
}

#[test]
fn mvn_props_and_fingers_follow_the_body_segments() {
    let unit = [1.0, 0.0, 0.0, 0.0];
    // Two props, forty finger segments: props 24-25, left carpus 26, right carpus 46.
    let items: Vec<(u32, [f32; 3], [f32; 4])> = [1, 24, 25, 26, 45, 46, 65]
        .iter()
        .map(|&id| (id, [id as f32, 0.0, 0.0], unit))
        .collect();
    let pose = decode(&spec_type_02(1, &items, [23, 2, 40])).unwrap();
    let names: Vec<(&str, f64)> = pose
        .world_poses()
        .into_iter()
        .map(|(n, w)| (n, w.position.x))
        .collect();
    for (name, id) in [
        ("Pelvis", 1.0),
        ("Prop1", 24.0),
        ("Prop2", 25.0),
        ("LeftCarpus", 26.0),
        ("LeftFifthDistalPhalange", 45.0),
        ("RightCarpus", 46.0),
        ("RightFifthDistalPhalange", 65.0),
    ] {
        assert!(names.contains(&(name, id)), "{name} at {id}: {names:?}");
    }
    assert_eq!(segment_id("RightCarpus", 2), Some(46));
    assert_eq!(segment_id("Prop3", 2), None);
    let over = spec_type_02(1, &[(66, [0.0; 3], unit)], [23, 2, 40]);
    let e = decode(&over).unwrap_err();
    assert!(matches!(e, MvnError::SegmentId { id: 66, .. }), "{e}");
    assert!(e.to_string().contains("24 to 65"), "{e}");
}

/// `decode` fails with `what` and a message containing every one of `words`.
fn refuses(bytes: &[u8], what: fn(&MvnError) -> bool, words: &[&str]) {
    match decode(bytes) {
        Ok(p) => panic!("decoded {p:?}; expected an error with {words:?}"),
        Err(e) => {
            assert!(what(&e), "{e:?}");
            let text = e.to_string();
            for w in words {
                assert!(text.contains(w), "{text:?} lacks {w:?}");
            }
        }
    }
}

#[test]
fn mvn_bad_headers_are_typed_errors() {
    let good = spec_type_02(1, &body_items()[..2], [23, 0, 0]);
    refuses(
        &[],
        |e| matches!(e, MvnError::Short { got: 0 }),
        &["0 bytes", "24-byte header"],
    );
    refuses(
        &good[..23],
        |e| matches!(e, MvnError::Short { got: 23 }),
        &["23 bytes"],
    );
    let mut magic = good.clone();
    magic[..4].copy_from_slice(b"MXTQ");
    refuses(
        &magic,
        |e| matches!(e, MvnError::Magic { .. }),
        &["\"MXTQ\"", "expected \"MXTP\""],
    );
    let mut letters = good.clone();
    letters[4..6].copy_from_slice(b"0x");
    refuses(
        &letters,
        |e| matches!(e, MvnError::Type { .. }),
        &["\"0x\"", "two ASCII digits"],
    );
    for (code, what) in [
        (b"03", "positions only"),
        (b"05", "Unity3D"),
        (b"13", "scale"),
        (b"20", "joint angles"),
        (b"25", "time code"),
        (b"99", "not in the specification"),
    ] {
        let mut other = good.clone();
        other[4..6].copy_from_slice(code);
        refuses(
            &other,
            |e| matches!(e, MvnError::Unsupported { .. }),
            &[what, "expected 02"],
        );
    }
    for (at, value, field) in [
        (17, 24, "number of body segments is 24; expected at most 23"),
        (18, 5, "number of props is 5; expected at most 4"),
        (
            19,
            41,
            "number of finger tracking segments is 41; expected at most 40",
        ),
    ] {
        let mut counts = good.clone();
        counts[at] = value;
        refuses(&counts, |e| matches!(e, MvnError::Counts { .. }), &[field]);
    }
}

#[test]
fn mvn_sizes_that_disagree_with_the_bytes_are_typed_errors() {
    let good = spec_type_02(1, &body_items()[..2], [23, 0, 0]);
    assert_eq!(good.len(), 88);
    // Cut inside the second item: the payload size still says 64.
    refuses(
        &good[..70],
        |e| {
            matches!(
                e,
                MvnError::PayloadSize {
                    stated: 64,
                    present: 46
                }
            )
        },
        &["payload size is 64 bytes but 46 bytes follow"],
    );
    let mut longer = good.clone();
    longer.push(0);
    refuses(
        &longer,
        |e| matches!(e, MvnError::PayloadSize { .. }),
        &["65 bytes follow"],
    );
    // The item count overruns the datagram.
    let mut overrun = good.clone();
    overrun[11] = 3;
    refuses(
        &overrun,
        |e| {
            matches!(
                e,
                MvnError::ItemCount {
                    items: 3,
                    needed: 96,
                    present: 64,
                    ..
                }
            )
        },
        &[
            "number of items is 3",
            "96 bytes",
            "the 64 bytes after the header",
        ],
    );
    // A legacy header (no payload size) is held to the item count alone.
    let mut legacy = good.clone();
    legacy[17..24].fill(0);
    assert!(decode(&legacy).is_ok());
    refuses(
        &legacy[..70],
        |e| matches!(e, MvnError::ItemCount { .. }),
        &["46 bytes"],
    );
    // A Euler datagram counts 28-byte items.
    let mut euler = good.clone();
    euler[5] = b'1';
    refuses(
        &euler,
        |e| matches!(e, MvnError::ItemCount { item_bytes: 28, .. }),
        &["type 01"],
    );
}

#[test]
fn mvn_bad_items_are_typed_errors() {
    let unit = [1.0, 0.0, 0.0, 0.0];
    for (id, words) in [
        (0u32, "segment ID 0; expected 1 to 23 (body)"),
        (24, "segment ID 24; expected 1 to 23 (body)"),
        (1000, "segment ID 1000"),
        (u32::MAX, "segment ID 4294967295"),
    ] {
        let b = spec_type_02(1, &[(id, [0.0; 3], unit)], [23, 0, 0]);
        refuses(
            &b,
            |e| matches!(e, MvnError::SegmentId { .. }),
            &["item 0", words],
        );
    }
    let twice = spec_type_02(1, &[(9, [0.0; 3], unit), (9, [0.0; 3], unit)], [23, 0, 0]);
    refuses(
        &twice,
        |e| matches!(e, MvnError::DuplicateSegment { item: 1, id: 9, .. }),
        &["segment ID 9 (RightUpperArm) again"],
    );
    let fields = ["x", "y", "z", "q1 (re)", "q2 (i)", "q3 (j)", "q4 (k)"];
    for (k, field) in fields.iter().enumerate() {
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            let mut v = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0];
            v[k] = bad;
            let b = spec_type_02(
                1,
                &[
                    (1, [0.0; 3], unit),
                    (14, [v[0], v[1], v[2]], [v[3], v[4], v[5], v[6]]),
                ],
                [23, 0, 0],
            );
            let value = format!("{field} is {bad}");
            let words: [&str; 3] = ["item 1 (segment LeftForeArm)", &value, "finite"];
            refuses(&b, |e| matches!(e, MvnError::NotANumber { .. }), &words);
        }
    }
    let mut b = spec_header(b"01", 1, 0x80, 1, 0, 0, [23, 0, 0], 28);
    b.extend(spec_euler_item(2, [0.0; 3], [0.0, f32::NAN, 0.0]));
    refuses(
        &b,
        |e| matches!(e, MvnError::NotANumber { .. }),
        &["segment L5", "y rotation is NaN"],
    );
    for q in [[0.0; 4], [1.0, 1.0, 0.0, 0.0]] {
        let b = spec_type_02(1, &[(7, [0.0; 3], q)], [23, 0, 0]);
        refuses(
            &b,
            |e| matches!(e, MvnError::NotUnit { .. }),
            &["segment Head", "unit quaternion"],
        );
    }
}

#[test]
fn mvn_decode_never_panics_on_damaged_datagrams() {
    let good = spec_type_02(1, &body_items(), [23, 0, 0]);
    for n in 0..good.len() {
        let _ = decode(&good[..n]);
        let _ = decode_part(&good[..n]);
    }
    // Every byte flipped in turn, and a deterministic stream of noise.
    for at in 0..good.len() {
        for flip in [0x01, 0x80, 0xFF] {
            let mut b = good.clone();
            b[at] ^= flip;
            let _ = decode(&b);
        }
    }
    let mut state = 0x2545_F491_4F6C_DD1Du64;
    for len in 0..400usize {
        let mut b = spec_header(
            b"02",
            1,
            0x80,
            (len / 32) as u8,
            0,
            0,
            [23, 0, 0],
            len as u16,
        );
        for _ in 0..len {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            b.push(state as u8);
        }
        let _ = decode(&b);
    }
}

#[test]
fn mvn_encode_refuses_more_items_than_a_datagram_counts() {
    let mut pose = decode(&spec_type_02(1, &body_items(), [23, 0, 0])).unwrap();
    let s = pose.segments[0];
    pose.segments = vec![s; 256];
    assert!(matches!(
        encode(&pose, PoseType::Quaternion),
        Err(MvnError::TooManyItems { items: 256 })
    ));
}
