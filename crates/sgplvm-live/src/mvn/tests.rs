//! Datagrams written byte by byte from the specification's tables (independently of
//! [`encode`]), decoded to the exact values; round trips; every kind of bad input; split frames;
//! the receiver on loopback; a frame through the capture importer's arm fit.

use std::time::Duration;

use nalgebra::{Rotation3, UnitQuaternion, Vector3};

use super::assemble::{Reassembler, LATE_WINDOW};
use super::*;

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

/// The 23 body items as three datagrams of one sample (counters 0, 1, 0x82).
fn split_frame(sample: u32) -> Vec<Vec<u8>> {
    let items = body_items();
    [(0x00u8, 0..8), (0x01, 8..16), (0x82, 16..23)]
        .into_iter()
        .map(|(counter, range)| {
            let part = &items[range];
            let mut b = spec_header(
                b"02",
                sample,
                counter,
                part.len() as u8,
                777,
                0,
                [23, 0, 0],
                (part.len() * 32) as u16,
            );
            for (id, p, q) in part {
                b.extend(spec_quaternion_item(*id, *p, *q));
            }
            b
        })
        .collect()
}

#[test]
fn mvn_split_frames_are_refused_by_decode_and_reassembled() {
    let parts = split_frame(50);
    refuses(
        &parts[0],
        |e| {
            matches!(
                e,
                MvnError::Split {
                    index: 0,
                    last: false
                }
            )
        },
        &["decode_part"],
    );
    refuses(
        &parts[2],
        |e| {
            matches!(
                e,
                MvnError::Split {
                    index: 2,
                    last: true
                }
            )
        },
        &["its last"],
    );
    let whole = decode(&spec_type_02(50, &body_items(), [23, 0, 0])).unwrap();
    // Out of order: 1, 2 (the last), 0.
    let mut r = Reassembler::new();
    for at in [1, 2] {
        let pushed = r.push(decode_part(&parts[at]).unwrap()).unwrap();
        assert_eq!(pushed.complete, None);
    }
    let pushed = r.push(decode_part(&parts[0]).unwrap()).unwrap();
    assert_eq!(pushed.complete, Some(whole));
    assert!(!r.pending());
    // A newer sample gives up an incomplete one; a part of the older one is then late.
    let newer = split_frame(51);
    r.push(decode_part(&parts[0]).unwrap()).unwrap();
    let pushed = r.push(decode_part(&newer[0]).unwrap()).unwrap();
    assert!(pushed.abandoned);
    assert!(r.push(decode_part(&parts[1]).unwrap()).unwrap().late);
    // An index twice, two last datagrams, a segment in two parts.
    let mut r = Reassembler::new();
    r.push(decode_part(&parts[0]).unwrap()).unwrap();
    let e = r.push(decode_part(&parts[0]).unwrap()).unwrap_err();
    assert!(e.to_string().contains("datagram 0 twice"), "{e}");
    let mut other_last = parts[1].clone();
    other_last[10] = 0x81;
    r.push(decode_part(&parts[2]).unwrap()).unwrap();
    let e = r.push(decode_part(&other_last).unwrap()).unwrap_err();
    assert!(e.to_string().contains("both say they are the last"), "{e}");
    let mut r = Reassembler::new();
    let mut overlap = parts[1].clone();
    overlap[24..28].copy_from_slice(&1u32.to_be_bytes());
    for b in [&parts[0], &overlap] {
        r.push(decode_part(b).unwrap()).unwrap();
    }
    let e = r.push(decode_part(&parts[2]).unwrap()).unwrap_err();
    assert!(matches!(e, MvnError::DuplicateSegment { id: 1, .. }), "{e}");
}

/// Waits (bounded) on `rx` and collects every frame `newest` returns until `until` holds.
fn drain(rx: &mut MvnReceiver, until: impl Fn(&MvnReceiver, &[MvnPose]) -> bool) -> Vec<MvnPose> {
    // The node's poll type: the receiver registers with it as with mio's own.
    let mut poll = ros2_client::dds::rustdds::mio1::Poll::new().unwrap();
    let mut events = ros2_client::dds::rustdds::mio1::Events::with_capacity(4);
    poll.registry()
        .register(rx, mio::Token(7), mio::Interest::READABLE)
        .unwrap();
    let mut frames = Vec::new();
    for _ in 0..100 {
        frames.extend(rx.newest().unwrap());
        if until(rx, &frames) {
            break;
        }
        poll.poll(&mut events, Some(Duration::from_millis(50)))
            .unwrap();
    }
    poll.registry().deregister(rx).unwrap();
    frames
}

#[test]
fn mvn_receiver_keeps_the_newest_frame_on_loopback() {
    let mut rx =
        MvnReceiver::bind("127.0.0.1:0".parse().unwrap(), ReceiverOptions::default()).unwrap();
    let to = rx.local_addr().unwrap();
    assert!(to.ip().is_loopback() && to.port() != 0);
    let tx = MvnSender::new(to).unwrap();
    assert_eq!(tx.target(), to);
    let pose = decode(&spec_type_02(10, &body_items(), [23, 0, 0])).unwrap();
    for sample in [10, 11, 12] {
        let p = MvnPose {
            sample_counter: sample,
            ..pose.clone()
        };
        tx.send(&p, PoseType::Quaternion).unwrap();
    }
    let frames = drain(&mut rx, |rx, _| rx.counts().datagrams == 3);
    let last = frames.last().unwrap();
    assert_eq!(last.sample_counter, 12);
    assert_eq!(last.segments, pose.segments);
    let c = rx.counts().clone();
    assert_eq!(c.frames + c.superseded, 3, "{c:?}");
    assert_eq!(c.frames as usize, frames.len());
    // Late, another character, garbage, a type not decoded: counted, nothing returned.
    let late = MvnPose {
        sample_counter: 11,
        ..pose.clone()
    };
    tx.send(&late, PoseType::Quaternion).unwrap();
    let other = MvnPose {
        sample_counter: 13,
        character_id: 1,
        ..pose.clone()
    };
    tx.send(&other, PoseType::Quaternion).unwrap();
    tx.send_datagram(b"this is not an MVN datagram at all")
        .unwrap();
    let mut joint_angles = spec_type_02(14, &body_items()[..1], [23, 0, 0]);
    joint_angles[4..6].copy_from_slice(b"20");
    tx.send_datagram(&joint_angles).unwrap();
    let none = drain(&mut rx, |rx, _| rx.counts().datagrams == 7);
    assert!(none.is_empty(), "{none:?}");
    let c = rx.counts();
    assert_eq!((c.late, c.other_character), (1, 1), "{c:?}");
    assert_eq!(c.bad.get("not MXTP"), Some(&1), "{c:?}");
    assert_eq!(c.bad.get("type not decoded"), Some(&1), "{c:?}");
    assert!(rx.last_bad().unwrap().to_string().contains("joint angles"));
    // A frame split in three arrives whole; then a restarted counter is taken.
    for part in split_frame(20) {
        tx.send_datagram(&part).unwrap();
    }
    let split = drain(&mut rx, |_, f| !f.is_empty());
    assert_eq!(split.len(), 1);
    assert_eq!(split[0].sample_counter, 20);
    assert_eq!(split[0].segments.len(), 23);
    let restarted = MvnPose {
        sample_counter: 20u32.wrapping_sub(LATE_WINDOW + 1),
        ..pose.clone()
    };
    tx.send(&restarted, PoseType::Euler).unwrap();
    let again = drain(&mut rx, |_, f| !f.is_empty());
    assert_eq!(again.len(), 1);
    assert_eq!(again[0].kind, PoseType::Euler);
    assert_eq!(rx.counts().restarts, 1);
}

#[test]
fn mvn_receiver_reports_a_port_in_use() {
    let first =
        MvnReceiver::bind("127.0.0.1:0".parse().unwrap(), ReceiverOptions::default()).unwrap();
    let taken = first.local_addr().unwrap();
    let e = MvnReceiver::bind(taken, ReceiverOptions::default()).unwrap_err();
    assert!(e.to_string().contains(&format!("binding {taken}")), "{e}");
}

/// Left-arm rest offsets, each in its parent segment's frame (T8 → clavicle → upper arm →
/// forearm → hand), metres; the right arm mirrors y.
const REST: [[f64; 3]; 4] = [
    [0.0, 0.02, 0.18],
    [0.0, 0.16, 0.0],
    [0.0, 0.29, 0.0],
    [0.0, 0.26, 0.0],
];

/// An MVN frame of T8 and both arms built by forward kinematics: the body turned and leaning,
/// each upper arm hanging down, each elbow bent 90° forward.
fn arms_frame() -> MvnPose {
    let deg = |a: f64| a.to_radians();
    let t8 = WorldPose {
        position: Vector3::new(0.3, -0.2, 1.3),
        rotation: Rotation3::from_euler_angles(0.0, deg(10.0), deg(30.0)),
    };
    let mut named = vec![("T8", t8)];
    for (sign, names) in [
        (
            1.0,
            ["LeftShoulder", "LeftUpperArm", "LeftForeArm", "LeftHand"],
        ),
        (
            -1.0,
            [
                "RightShoulder",
                "RightUpperArm",
                "RightForeArm",
                "RightHand",
            ],
        ),
    ] {
        // The arm down (its +y or −y to −z), then the forearm forward (to +x).
        let turns = [
            Rotation3::identity(),
            Rotation3::from_euler_angles(sign * deg(-90.0), 0.0, 0.0),
            Rotation3::from_euler_angles(0.0, 0.0, sign * deg(-90.0)),
            Rotation3::identity(),
        ];
        let mut parent = t8;
        for ((name, offset), turn) in names.iter().zip(REST).zip(turns) {
            let offset = Vector3::new(offset[0], sign * offset[1], offset[2]);
            let pose = WorldPose {
                position: parent.position + parent.rotation * offset,
                rotation: parent.rotation * turn,
            };
            named.push((name, pose));
            parent = pose;
        }
    }
    MvnPose::from_world_poses(5, 40, 0, named).unwrap()
}

#[test]
fn mvn_frame_gives_the_importers_arm_poses() {
    let frame = arms_frame();
    // Through the wire and back: what the node will see.
    let frame = decode(&encode(&frame, PoseType::Quaternion).unwrap()).unwrap();
    let left = frame.arm_pose(sgplvm_robots::Side::Left).unwrap();
    let close = |a: Vector3<f64>, b: [f64; 3]| (a - Vector3::from(b)).norm() < 1e-5;
    assert!(close(left.clavicle, [0.0, 0.02, 0.18]), "{left:?}");
    assert!(close(left.shoulder, [0.0, 0.18, 0.18]), "{left:?}");
    assert!(close(left.elbow, [0.0, 0.18, -0.11]), "{left:?}");
    assert!(close(left.wrist, [0.26, 0.18, -0.11]), "{left:?}");
    // The hand continues the forearm: one forearm (0.26) further forward.
    assert!(close(left.hand_tip, [0.52, 0.18, -0.11]), "{left:?}");
    let right = frame.arm_pose(sgplvm_robots::Side::Right).unwrap();
    assert!(close(right.wrist, [0.26, -0.18, -0.11]), "{right:?}");
    let rest = frame.rest_arm_pose(sgplvm_robots::Side::Left).unwrap();
    assert!(close(rest.shoulder, [0.0, 0.18, 0.18]), "{rest:?}");
    assert!(close(rest.elbow, [0.0, 0.47, 0.18]), "{rest:?}");
    assert!(close(rest.wrist, [0.0, 0.73, 0.18]), "{rest:?}");
    assert!(close(rest.hand_tip, [0.0, 0.99, 0.18]), "{rest:?}");
    assert_eq!(rest.hand_turn, Rotation3::identity());
    // A segment missing is named.
    let mut no_hand = frame.clone();
    no_hand.segments.retain(|s| s.id != 11);
    let e = no_hand.arm_pose(sgplvm_robots::Side::Right).unwrap_err();
    assert!(
        e.to_string()
            .contains("segment RightHand: not in this frame"),
        "{e}"
    );
    assert!(MvnPose::from_world_poses(0, 0, 0, [("Spine", frame.named("T8").unwrap())]).is_err());
}

#[test]
fn mvn_frame_through_the_importers_arm_fit() {
    use sgplvm_robots::capture::{HumanArms, PoseFitter};
    use sgplvm_robots::Side;
    // The importer's own per-frame fit, on an MVN frame.
    let model = HumanArms::new(&sgplvm_robots::Robot::builtin("human").unwrap()).unwrap();
    let frame = arms_frame();
    let rest = [Side::Left, Side::Right].map(|side| frame.rest_arm_pose(side).unwrap());
    let mut fitter = PoseFitter::new(model, [&rest[0], &rest[1]], [true, true], &|_| None);
    let poses = [Side::Left, Side::Right].map(|side| frame.arm_pose(side).unwrap());
    for (fit, side) in fitter
        .fit([&poses[0], &poses[1]])
        .iter()
        .zip([Side::Left, Side::Right])
    {
        assert!(
            (fit.angles[5].to_degrees() - 90.0).abs() < 1.0,
            "{side:?}: {fit:?}"
        );
        assert!(
            fit.elbow_m < 0.01 && fit.wrist_m < 0.01,
            "{side:?}: {fit:?}"
        );
    }
}

#[test]
fn the_human_model_s_angles_come_back_through_mvn_and_the_importer_s_fit() {
    use super::human::{HumanSegments, MvnFit};
    let human = HumanSegments::new().unwrap();
    let mut fit = MvnFit::new();
    let robot = sgplvm_robots::Robot::builtin("human").unwrap();
    let limits = robot.joint_limits();
    // The null pose first (the stream's calibration), then poses across the joints' ranges.
    let mut t_pose = vec![0.0; 18];
    t_pose[3] = std::f64::consts::FRAC_PI_2;
    t_pose[12] = std::f64::consts::FRAC_PI_2;
    let mut worst = 0.0_f64;
    for k in 0..60 {
        let q: Vec<f64> = if k == 0 {
            t_pose.clone()
        } else {
            limits
                .iter()
                .enumerate()
                .map(|(j, &(lo, hi))| {
                    let s = 0.5 + 0.4 * ((k * 7 + j * 3) as f64).sin();
                    lo + s * (hi - lo) * 0.8 + 0.1 * (hi - lo)
                })
                .collect()
        };
        let frame = human.frame(&q, k as u32, 0).unwrap();
        let bytes = encode(&frame, PoseType::Quaternion).unwrap();
        let back = decode(&bytes).unwrap();
        let (angles, fits) = fit.angles(&back).unwrap();
        for f in &fits {
            assert!(f.elbow_m < 1e-3 && f.wrist_m < 1e-3, "{k}: {f:?}");
        }
        for j in 0..18 {
            worst = worst.max((angles[j] - q[j]).abs());
        }
    }
    // Single precision travels (the quaternions and positions are f32).
    assert!(worst < 1e-3, "worst angle difference {worst} rad");
}
