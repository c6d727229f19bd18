use std::path::PathBuf;

use super::whole_scene::ENCODE_BATCH;
use super::*;
use crate::joint_state::{list_channels, read_joint_states, JointStates, JOINT_STATE_SCHEMA};
use crate::urdf::Robot;

fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("sgplvm-scene-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir.join("scene.mcap")
}

fn two_bodies(frames: usize) -> (SceneBody, JointStates, SceneBody, JointStates) {
    let human = SceneBody::builtin("human", "/human/joint_states", [0.0, 0.6, 0.0]).expect("h");
    let coman = SceneBody::builtin("coman", "/coman/joint_command", [0.0, -0.6, 0.0]).expect("c");
    let series = |b: &SceneBody| {
        let names = b.robot.joint_names();
        let d = names.len();
        let times = (0..frames as i64)
            .map(|i| 1_000_000_000 + i * 25_000_000)
            .collect();
        let values = (0..frames * d).map(|k| 0.01 * (k % 37) as f64).collect();
        JointStates::new(times, names, values).expect("states")
    };
    let (hs, cs) = (series(&human), series(&coman));
    (human, hs, coman, cs)
}

#[test]
fn a_scene_has_every_topic_and_its_joint_states_read_back() {
    let path = tmp("topics");
    let (human, hs, coman, cs) = two_bodies(5);
    let std_topic = ArrayTopic::float64("/coman/prediction_std", "joint", 14);
    let std_values = vec![0.1; 5 * 14];
    write_scene(
        &path,
        &[
            SceneSeries {
                body: &human,
                states: &hs,
            },
            SceneSeries {
                body: &coman,
                states: &cs,
            },
        ],
        &[ArraySeries {
            topic: &std_topic,
            values: &std_values,
        }],
        &SceneOptions::default(),
    )
    .expect("writes");
    let mut topics: Vec<(String, String)> = list_channels(&path)
        .expect("lists")
        .into_iter()
        .map(|c| (c.topic, c.schema))
        .collect();
    topics.sort();
    let expected = [
        ("/coman/joint_command", JOINT_STATE_SCHEMA),
        ("/coman/prediction_std", FLOAT64_MULTI_ARRAY_SCHEMA),
        ("/coman/robot_description", STRING_SCHEMA),
        ("/human/joint_states", JOINT_STATE_SCHEMA),
        ("/human/robot_description", STRING_SCHEMA),
        ("/tf", TF_MESSAGE_SCHEMA),
        ("/tf_static", TF_MESSAGE_SCHEMA),
    ];
    let expected: Vec<(String, String)> = expected
        .iter()
        .map(|(a, b)| (a.to_string(), b.to_string()))
        .collect();
    assert_eq!(topics, expected);
    assert_eq!(
        read_joint_states(&path, "/coman/joint_command").expect("reads"),
        cs
    );
    assert_eq!(
        read_joint_states(&path, "/human/joint_states").expect("reads"),
        hs
    );
    let _ = std::fs::remove_dir_all(path.parent().expect("dir"));
}

#[test]
fn without_tf_only_joint_states_and_arrays_are_written() {
    let path = tmp("notf");
    let (human, hs, _, _) = two_bodies(3);
    write_scene(
        &path,
        &[SceneSeries {
            body: &human,
            states: &hs,
        }],
        &[],
        &SceneOptions {
            tf: false,
            ..SceneOptions::default()
        },
    )
    .expect("writes");
    let topics: Vec<String> = list_channels(&path)
        .expect("lists")
        .into_iter()
        .map(|c| c.topic)
        .collect();
    assert_eq!(topics, ["/human/joint_states"]);
    let _ = std::fs::remove_dir_all(path.parent().expect("dir"));
}

#[test]
fn the_prefixed_description_parses_with_the_same_joints_and_prefixed_links() {
    let (human, ..) = two_bodies(1);
    let xml = human.prefixed_urdf().expect("writes");
    let back = Robot::from_urdf_str(&xml, "prefixed").expect("parses");
    assert_eq!(back.joint_names(), human.robot.joint_names());
    let links: Vec<String> = human
        .robot
        .link_names()
        .iter()
        .map(|l| format!("human/{l}"))
        .collect();
    assert_eq!(back.link_names(), links);
    // Same kinematics: the hand of the prefixed model is where the original's is.
    let q: Vec<f64> = (0..back.dof()).map(|i| 0.1 * i as f64).collect();
    let a = human.robot.forward_kinematics(&q, "left_hand").expect("fk");
    let b = back.forward_kinematics(&q, "human/left_hand").expect("fk");
    assert!((a.translation.vector - b.translation.vector).norm() < 1e-12);
}

#[test]
fn unknown_joints_and_mismatched_rows_are_errors_naming_the_topic() {
    let path = tmp("bad");
    let (human, hs, ..) = two_bodies(2);
    let mut wrong = hs.clone();
    wrong.names[0] = "nope".into();
    let err = write_scene(
        &path,
        &[SceneSeries {
            body: &human,
            states: &wrong,
        }],
        &[],
        &SceneOptions::default(),
    )
    .expect_err("unknown joint");
    assert!(
        err.to_string().contains("`nope`") && err.to_string().contains("/human/joint_states"),
        "{err}"
    );
    let topic = ArrayTopic::float64("/x", "x", 2);
    let err = write_scene(
        &path,
        &[SceneSeries {
            body: &human,
            states: &hs,
        }],
        &[ArraySeries {
            topic: &topic,
            values: &[1.0],
        }],
        &SceneOptions::default(),
    )
    .expect_err("short array");
    assert!(err.to_string().contains("`/x`"), "{err}");
    assert!(!path.exists());
    let _ = std::fs::remove_dir_all(path.parent().expect("dir"));
}

#[test]
fn markers_get_their_own_topic_and_bad_ones_are_refused_naming_it() {
    let path = tmp("markers");
    let (human, hs, ..) = two_bodies(3);
    let marker = |topic: &str, time_ns| TimedMarkers {
        topic: topic.to_string(),
        time_ns,
        markers: vec![SceneMarker {
            frame: "human/DWYTorso".into(),
            ns: "collision".into(),
            id: 0,
            shape: MarkerShape::Sphere,
            position: [0.1, 0.2, 0.3],
            scale: [0.05; 3],
            color: [1.0, 0.0, 1.0, 1.0],
            lifetime_ns: 50_000_000,
        }],
    };
    let series = [SceneSeries {
        body: &human,
        states: &hs,
    }];
    let options = SceneOptions::default();
    write_scene_with_markers(
        &path,
        &series,
        &[],
        &[marker("/human/events", 1_030_000_000)],
        &options,
    )
    .expect("writes");
    let events: Vec<_> = list_channels(&path)
        .expect("lists")
        .into_iter()
        .filter(|c| c.topic == "/human/events")
        .collect();
    assert_eq!(events.len(), 1);
    assert_eq!(events[0].schema, MARKER_ARRAY_SCHEMA);
    for (bad, what) in [
        (marker("/human/joint_states", 1_000_000_000), "another type"),
        (marker("/tf", 1_000_000_000), "another type"),
        (marker("/human/events", -1), "negative"),
    ] {
        let err =
            write_scene_with_markers(&path, &series, &[], std::slice::from_ref(&bad), &options)
                .expect_err("refused");
        let text = err.to_string();
        assert!(
            text.contains(&format!("`{}`", bad.topic)) && text.contains(what),
            "{text}"
        );
    }
    let _ = std::fs::remove_dir_all(path.parent().expect("dir"));
}

#[test]
fn the_threaded_whole_scene_is_the_file_frame_by_frame_writing_gives() {
    // `write_scene_with_markers` encodes on a thread of its own in batches; frame-by-frame
    // writing (teleoperation) does not. Over several batches, a partial last one and markers
    // before, between and after the frames, both must write the same bytes.
    let dir = tmp("threaded");
    let (threaded, by_frame) = (dir.with_file_name("a.mcap"), dir.with_file_name("b.mcap"));
    let frames = 2 * ENCODE_BATCH + 13;
    let (human, hs, coman, cs) = two_bodies(frames);
    let latent = ArrayTopic::float64("/latent", "latent", 3);
    let latent_values: Vec<f64> = (0..frames * 3).map(|k| k as f64 * 0.5).collect();
    let marker = |time_ns, id| TimedMarkers {
        topic: "/coman/events".into(),
        time_ns,
        markers: vec![SceneMarker {
            frame: "coman/LElb".into(),
            ns: "collision".into(),
            id,
            shape: MarkerShape::Text(format!("event {id}")),
            position: [0.0, 0.1, 0.2],
            scale: [0.05; 3],
            color: [1.0; 4],
            lifetime_ns: 0,
        }],
    };
    let times = &hs.times_ns;
    let markers = [
        marker(times[0] - 1, 0),
        marker(times[ENCODE_BATCH], 1),
        marker(times[ENCODE_BATCH] + 1, 2),
        marker(times[frames - 1] + 1_000, 3),
    ];
    let series = [
        SceneSeries {
            body: &human,
            states: &hs,
        },
        SceneSeries {
            body: &coman,
            states: &cs,
        },
    ];
    let arrays = [ArraySeries {
        topic: &latent,
        values: &latent_values,
    }];
    let options = SceneOptions::default();
    write_scene_with_markers(&threaded, &series, &arrays, &markers, &options).expect("writes");
    let bodies = vec![
        (human.clone(), hs.names.clone()),
        (coman.clone(), cs.names.clone()),
    ];
    let mut w = SceneWriter::create(&by_frame, bodies, vec![latent.clone()], &options, false)
        .expect("creates");
    let mut next_marker = 0;
    for i in 0..frames {
        w.write_frame(
            times[i],
            &[hs.row(i), cs.row(i)],
            &[&latent_values[i * 3..i * 3 + 3]],
        )
        .expect("frame");
        let until = times.get(i + 1).copied().unwrap_or(i64::MAX);
        while next_marker < markers.len() && markers[next_marker].time_ns < until {
            w.write_markers(&markers[next_marker]).expect("markers");
            next_marker += 1;
        }
    }
    w.finish().expect("finishes");
    let (a, b) = (
        std::fs::read(&threaded).expect("reads"),
        std::fs::read(&by_frame).expect("reads"),
    );
    assert!(a == b, "{} and {} bytes differ", a.len(), b.len());
    let _ = std::fs::remove_dir_all(dir.parent().expect("dir"));
}

#[test]
fn a_stream_sends_what_the_file_holds() {
    // The same scene written to a file and encoded by a stream: channel for channel (topic,
    // schema) and message for message the same bytes.
    let path = tmp("stream");
    let (human, hs, coman, cs) = two_bodies(3);
    let std_topic = ArrayTopic::float64("/coman/prediction_std", "joint", 14);
    let std_values = vec![0.2; 3 * 14];
    write_scene(
        &path,
        &[
            SceneSeries {
                body: &human,
                states: &hs,
            },
            SceneSeries {
                body: &coman,
                states: &cs,
            },
        ],
        &[ArraySeries {
            topic: &std_topic,
            values: &std_values,
        }],
        &SceneOptions::default(),
    )
    .expect("write");
    let bytes = std::fs::read(&path).expect("read");
    let mut file: Vec<(String, String, Vec<u8>)> = Vec::new();
    for m in ::mcap::MessageStream::new(&bytes).expect("mcap") {
        let m = m.expect("message");
        let schema = m
            .channel
            .schema
            .as_ref()
            .map(|s| s.name.clone())
            .unwrap_or_default();
        file.push((m.channel.topic.clone(), schema, m.data.to_vec()));
    }
    let mut stream = SceneStream::new(
        vec![
            (human.clone(), hs.names.clone()),
            (coman.clone(), cs.names.clone()),
        ],
        vec![std_topic.clone()],
        &SceneOptions::default(),
    )
    .expect("stream");
    let specs: Vec<(String, String)> = stream
        .channels()
        .iter()
        .map(|s| (s.topic.clone(), s.schema_name.to_string()))
        .collect();
    let mut streamed: Vec<(String, String, Vec<u8>)> = Vec::new();
    for (c, data) in stream.static_messages(hs.times_ns[0]).expect("static") {
        let (t, s) = specs[c as usize].clone();
        streamed.push((t, s, data));
    }
    for f in 0..3 {
        let frame = stream
            .frame(
                hs.times_ns[f],
                &[hs.row(f), cs.row(f)],
                &[&std_values[f * 14..(f + 1) * 14]],
            )
            .expect("frame");
        for (c, data) in frame {
            let (t, s) = specs[*c as usize].clone();
            streamed.push((t, s, data.clone()));
        }
    }
    let key = |v: &mut Vec<(String, String, Vec<u8>)>| v.sort();
    key(&mut file);
    key(&mut streamed);
    assert_eq!(file.len(), streamed.len());
    assert!(
        file == streamed,
        "the stream's messages differ from the file's"
    );
    std::fs::remove_dir_all(path.parent().expect("dir")).ok();
}

#[test]
fn the_description_names_found_meshes_by_absolute_file_uris() {
    let path = tmp("meshes");
    let dir = path.parent().expect("dir").join("robot");
    std::fs::create_dir_all(dir.join("meshes")).expect("dir");
    std::fs::write(dir.join("meshes/arm.stl"), "solid arm\nendsolid arm\n").expect("mesh");
    let urdf = dir.join("arm.urdf");
    std::fs::write(
        &urdf,
        r#"<robot name="arm">
          <link name="base"><visual><geometry><mesh filename="package://nowhere/base.dae"/></geometry></visual></link>
          <link name="arm"><visual><geometry><mesh filename="meshes/arm.stl" scale="0.001 0.001 0.001"/></geometry></visual>
            <collision><geometry><mesh filename="meshes/arm.stl"/></geometry></collision></link>
          <joint name="j" type="revolute"><parent link="base"/><child link="arm"/>
            <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
        </robot>"#,
    )
    .expect("urdf");
    let robot = Robot::from_urdf_file(&urdf).expect("robot");
    let body = SceneBody {
        name: "arm".into(),
        robot,
        placement: nalgebra::Isometry3::identity(),
        joint_topic: "/arm/joint_states".into(),
        meshes: Some(crate::urdf::MeshSearch::for_urdf_file(&urdf)),
        rest: None,
    };
    let states =
        JointStates::new(vec![0, 25_000_000], vec!["j".into()], vec![0.0, 0.1]).expect("states");
    write_scene(
        &path,
        &[SceneSeries {
            body: &body,
            states: &states,
        }],
        &[],
        &SceneOptions::default(),
    )
    .expect("writes");
    let mesh = std::fs::canonicalize(dir.join("meshes/arm.stl")).expect("mesh");
    let uri = crate::urdf::file_uri(&mesh);
    assert!(uri.starts_with("file:///") && uri.ends_with("/robot/meshes/arm.stl"));
    let bytes = std::fs::read(&path).expect("read");
    let description = mcap::MessageStream::new(&bytes)
        .expect("mcap")
        .map(|m| m.expect("message"))
        .find(|m| m.channel.topic == "/arm/robot_description")
        .expect("a description");
    let text = String::from_utf8_lossy(&description.data);
    // Visual and collision: found, and absolute; the package nobody gave stays as it was.
    assert_eq!(text.matches(uri.as_str()).count(), 2, "{text}");
    assert!(!text.contains("\"meshes/arm.stl\""), "{text}");
    assert!(text.contains("package://nowhere/base.dae"), "{text}");
    // The files a live view would serve, under both names.
    let files = body.mesh_files();
    assert_eq!(
        files,
        vec![("meshes/arm.stl".to_string(), mesh.clone()), (uri, mesh)]
    );
    std::fs::remove_dir_all(path.parent().expect("dir")).expect("clean");
}

/// Joints the joint states do not name are drawn at the body's rest configuration (a robot's
/// held waist), or at the neutral one when none fits.
#[test]
fn joints_not_commanded_are_drawn_at_the_rest_configuration() {
    let mut body = SceneBody::builtin("coman", "/coman/joint_command", [0.0; 3]).expect("coman");
    let neutral = body.robot.neutral_configuration();
    let rest: Vec<f64> = (0..neutral.len()).map(|i| 0.01 * i as f64).collect();
    body.rest = Some(rest.clone());
    let drawn = super::body::BodyChannel::new(body.clone(), vec![], vec![], 0, None);
    assert_eq!(drawn.q, rest);
    body.rest = Some(vec![0.5]);
    let drawn = super::body::BodyChannel::new(body, vec![], vec![], 0, None);
    assert_eq!(drawn.q, neutral);
}
