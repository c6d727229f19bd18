//! Writes the seed corpora of the fuzz targets: `corpus/mcap_reader/` (small two-topic files
//! in every compression and encoding, a demonstration file with its metadata, far-apart
//! timestamps), `corpus/urdf_parser/` (the built-in bodies and small arms) and
//! `corpus/bvh_reader/` (the human model's skeleton and a CMU-named one).

use std::collections::BTreeMap;
use std::path::Path;

use sgplvm_robots::joint_state::{
    write_topics, Compression, JointStates, MessageEncoding, TopicData, WriteSettings,
};

fn series(n: usize, joints: &[&str], t0: i64, dt: i64) -> JointStates {
    let times = (0..n as i64).map(|k| t0 + k * dt).collect();
    let pos = (0..n * joints.len())
        .map(|i| (i as f64 * 0.37).sin())
        .collect();
    JointStates::new(times, joints.iter().map(|s| s.to_string()).collect(), pos)
        .expect("valid series")
}

fn write(path: &Path, a: &JointStates, b: &JointStates, settings: &WriteSettings, json: bool) {
    let encoding = if json {
        MessageEncoding::Json
    } else {
        MessageEncoding::Cdr
    };
    write_topics(
        path,
        &[
            TopicData {
                topic: "/human/joint_states",
                states: a,
                encoding: MessageEncoding::Cdr,
            },
            TopicData {
                topic: "/walkman/joint_command",
                states: b,
                encoding,
            },
        ],
        settings,
    )
    .expect("write seed");
}

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("corpus");
    let mcap = root.join("mcap_reader");
    let urdf = root.join("urdf_parser");
    std::fs::create_dir_all(&mcap).expect("corpus dir");
    std::fs::create_dir_all(&urdf).expect("corpus dir");
    let a = series(12, &["a", "b", "c"], 1_000, 25_000_000);
    let b = series(12, &["x", "y"], 2_000, 25_000_000);
    for compression in [Compression::None, Compression::Zstd, Compression::Lz4] {
        for json in [false, true] {
            let settings = WriteSettings {
                compression,
                ..WriteSettings::default()
            };
            let name = format!("{compression:?}-{}.mcap", if json { "json" } else { "cdr" });
            write(&mcap.join(name), &a, &b, &settings, json);
        }
    }
    let mut meta = BTreeMap::new();
    meta.insert("json".to_string(), "{\"version\":1}".to_string());
    let settings = WriteSettings {
        compression: Compression::None,
        metadata: vec![("sgplvm.dataset".to_string(), meta)],
    };
    write(&mcap.join("metadata.mcap"), &a, &b, &settings, false);
    let far = series(2, &["a"], 0, 1_000_000_000_000_000);
    let settings = WriteSettings {
        compression: Compression::None,
        ..WriteSettings::default()
    };
    write(&mcap.join("far.mcap"), &far, &far, &settings, false);

    let urdf_dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../data/urdf");
    for entry in std::fs::read_dir(&urdf_dir).expect("data/urdf") {
        let path = entry.expect("entry").path();
        if path.extension().is_some_and(|e| e == "urdf") {
            let name = path.file_name().expect("name");
            std::fs::copy(&path, urdf.join(name)).expect("copy");
        }
    }
    let arm = r#"<?xml version="1.0"?>
<robot name="arm" version="1.1">
  <link name="base"><inertial><origin xyz="0 0 0.1"/><mass value="1"/>
    <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>
    <collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision></link>
  <link name="tip"><visual><origin quat_xyzw="0 0 0 1"/><geometry><cylinder radius="0.05" length="0.3"/></geometry></visual>
    <collision><geometry><sphere radius="0.05"/></geometry></collision></link>
  <joint name="j" type="revolute"><origin xyz="0 0 0.2" rpy="0 0 0"/><parent link="base"/>
    <child link="tip"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="5" velocity="2"/>
    <dynamics damping="0.1"/></joint>
  <!-- a comment --><gazebo><plugin name="p" filename="x.so"/></gazebo>
</robot>"#;
    std::fs::write(urdf.join("arm.urdf"), arm).expect("write arm");

    // BVH: the human model's own skeleton (Xsens MVN names, ZXY), a few frames; and a
    // CMU-named skeleton with 6-channel joints and ZYX order.
    let bvh = root.join("bvh_reader");
    std::fs::create_dir_all(&bvh).expect("corpus dir");
    let rows: Vec<[f64; 18]> = (0..6)
        .map(|f| std::array::from_fn(|j| 0.1 * ((f * 18 + j) as f64 * 0.7).sin()))
        .collect();
    sgplvm_capture::write_bvh(bvh.join("mvn.bvh"), 1.0 / 40.0, &rows).expect("write bvh");
    let mut cmu = String::from("HIERARCHY\nROOT Hips\n{\nOFFSET 0 0 0\nCHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation\nJOINT Spine1\n{\nOFFSET 0 5 0\nCHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation\nJOINT Neck\n{\nOFFSET 0 2 0\nCHANNELS 3 Zrotation Yrotation Xrotation\nEnd Site\n{\nOFFSET 0 1 0\n}\n}\n");
    for (side, x) in [("Left", 1.0), ("Right", -1.0)] {
        for (name, len) in [("Shoulder", 1.0), ("Arm", 3.5), ("ForeArm", 5.4), ("Hand", 3.7)] {
            cmu.push_str(&format!("JOINT {side}{name}\n{{\nOFFSET {} 0 0\nCHANNELS 3 Zrotation Yrotation Xrotation\n", x * len));
        }
        cmu.push_str(&format!("End Site\n{{\nOFFSET {} 0 0\n}}\n}}\n}}\n}}\n}}\n", x * 0.6));
    }
    cmu.push_str("}\n}\nMOTION\nFrames: 3\nFrame Time: .0083333\n");
    for f in 0..3 {
        let values: Vec<String> = (0..39).map(|k| format!("{:.3}", ((f * 39 + k) as f64 * 0.9).sin() * 30.0)).collect();
        cmu.push_str(&values.join(" "));
        cmu.push('\n');
    }
    std::fs::write(bvh.join("cmu.bvh"), cmu).expect("write cmu bvh");
}
