//! Frames split over several datagrams, reassembled; the receiver on loopback.

use std::time::Duration;

use super::super::assemble::{Reassembler, LATE_WINDOW};
use super::*;

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

/// A standing person's 23 body segments (an adult in MVN's T-pose, as `mvn_spec.t_pose`),
/// positions in metres times `scale`.
fn person(scale: f32) -> Vec<(u32, [f32; 3], [f32; 4])> {
    let id = |n: &str| segment_id(n, 0).unwrap();
    let mut items = Vec::new();
    let z = 0.95;
    for (n, h) in [
        ("Pelvis", 0.0),
        ("L5", 0.1),
        ("L3", 0.2),
        ("T12", 0.3),
        ("T8", 0.42),
        ("Neck", 0.62),
        ("Head", 0.72),
    ] {
        items.push((id(n), [0.0, 0.0, z + h]));
    }
    for (side, y) in [("Left", 1.0f32), ("Right", -1.0)] {
        for (part, out) in [
            ("Shoulder", 0.02),
            ("UpperArm", 0.18),
            ("ForeArm", 0.47),
            ("Hand", 0.73),
        ] {
            items.push((id(&format!("{side}{part}")), [0.0, y * out, z + 0.6]));
        }
        for (part, x, dz) in [
            ("UpperLeg", 0.0, 0.0),
            ("LowerLeg", 0.0, -0.45),
            ("Foot", 0.0, -0.88),
            ("Toe", 0.15, -0.93),
        ] {
            items.push((id(&format!("{side}{part}")), [x, y * 0.09, z + dz]));
        }
    }
    items.sort_by_key(|(i, _)| *i);
    items
        .into_iter()
        .map(|(i, p)| (i, p.map(|v| v * scale), [1.0, 0.0, 0.0, 0.0]))
        .collect()
}

#[test]
fn mvn_receiver_takes_one_sender_and_counts_the_others() {
    // Default: the first sender whose datagram is pose data, locked. A stranger's garbage
    // first does not take the lock.
    let mut rx =
        MvnReceiver::bind("127.0.0.1:0".parse().unwrap(), ReceiverOptions::default()).unwrap();
    let to = rx.local_addr().unwrap();
    let stranger = std::net::UdpSocket::bind("127.0.0.2:0").unwrap();
    let suit = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
    let frame = |sample| spec_type_02(sample, &body_items(), [23, 0, 0]);
    stranger
        .send_to(b"this is not an MVN datagram at all", to)
        .unwrap();
    suit.send_to(&frame(1), to).unwrap();
    stranger.send_to(&frame(100), to).unwrap();
    let got = drain(&mut rx, |rx, _| rx.counts().datagrams == 3);
    assert_eq!(
        got.iter().map(|f| f.sample_counter).collect::<Vec<_>>(),
        [1]
    );
    assert_eq!(rx.sender(), Some(suit.local_addr().unwrap()));
    assert_eq!(rx.counts().other_sender, 1, "{:?}", rx.counts());
    assert_eq!(rx.counts().bad.get("not MXTP"), Some(&1));
    assert_eq!(rx.refused(), [stranger.local_addr().unwrap()]);
    // Another port of the suit's host is the suit started again; the stranger stays out.
    let other_port = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
    other_port.send_to(&frame(200), to).unwrap();
    stranger.send_to(&frame(300), to).unwrap();
    let got = drain(&mut rx, |rx, _| rx.counts().datagrams == 5);
    assert_eq!(
        got.iter().map(|f| f.sample_counter).collect::<Vec<_>>(),
        [200]
    );
    assert_eq!(rx.sender(), Some(other_port.local_addr().unwrap()));
    assert_eq!(rx.counts().other_sender, 2);
    // Named: a host (any of its ports), or an address.
    for from in [
        Senders::Host("127.0.0.1".parse().unwrap()),
        Senders::Address(suit.local_addr().unwrap()),
    ] {
        let options = ReceiverOptions {
            from,
            ..ReceiverOptions::default()
        };
        let mut rx = MvnReceiver::bind("127.0.0.1:0".parse().unwrap(), options).unwrap();
        let to = rx.local_addr().unwrap();
        stranger.send_to(&frame(300), to).unwrap();
        suit.send_to(&frame(1), to).unwrap();
        other_port.send_to(&frame(2), to).unwrap();
        let got = drain(&mut rx, |rx, _| rx.counts().datagrams == 3);
        let taken: Vec<u32> = got.iter().map(|f| f.sample_counter).collect();
        match from {
            Senders::Host(_) => assert_eq!((taken.last(), rx.counts().other_sender), (Some(&2), 1)),
            _ => assert_eq!((taken, rx.counts().other_sender), (vec![1], 2)),
        }
    }
    assert_eq!(
        Senders::parse("10.0.0.7").unwrap(),
        Senders::Host("10.0.0.7".parse().unwrap())
    );
    assert_eq!(
        Senders::parse("[::1]:9763").unwrap(),
        Senders::Address("[::1]:9763".parse().unwrap())
    );
    let e = Senders::parse("suit.local").unwrap_err();
    assert!(e.contains("suit.local") && e.contains("IP:PORT"), "{e}");
}

#[test]
fn mvn_receiver_tells_centimetres_from_metres_by_the_persons_proportions() {
    use crate::mvn::units::body_span;
    let metres = decode(&spec_type_02(1, &person(1.0), [23, 0, 0])).unwrap();
    let span = body_span(&metres).unwrap();
    assert!((span - 2.05).abs() < 1e-6, "{span}");
    for (scale, units) in [(1.0, Units::AsDecoded), (100.0, Units::Centimetres)] {
        let mut rx =
            MvnReceiver::bind("127.0.0.1:0".parse().unwrap(), ReceiverOptions::default()).unwrap();
        let to = rx.local_addr().unwrap();
        let tx = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
        assert_eq!(rx.units(PoseType::Quaternion), None);
        tx.send_to(&spec_type_02(1, &person(scale), [23, 0, 0]), to)
            .unwrap();
        let got = drain(&mut rx, |_, f| !f.is_empty());
        let (found, span) = rx.units(PoseType::Quaternion).unwrap();
        assert_eq!(found, units);
        assert!((span - 2.05).abs() < 1e-4, "{span}");
        // Positions in metres whatever was sent.
        for (s, m) in got[0].segments.iter().zip(&metres.segments) {
            for k in 0..3 {
                assert!((s.position[k] - m.position[k]).abs() < 1e-5, "{s:?} {m:?}");
            }
        }
    }
    // Not a person (every segment at one point): nothing told, positions as decoded.
    let mut rx =
        MvnReceiver::bind("127.0.0.1:0".parse().unwrap(), ReceiverOptions::default()).unwrap();
    let to = rx.local_addr().unwrap();
    let tx = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
    tx.send_to(&spec_type_02(1, &person(0.0), [23, 0, 0]), to)
        .unwrap();
    drain(&mut rx, |_, f| !f.is_empty());
    assert_eq!(rx.units(PoseType::Quaternion), None);
}
