//! Robots as their makers publish them, through the command line: `sgplvm robot` says what it
//! finds and keeps it in a description file; `retarget` holds the joints outside the arms
//! exactly and reaches what is reachable; `train` and `predict` (a Foxglove scene drawn from
//! the robot's own URDF) follow; unusable descriptions fail naming the file and the link, and
//! write nothing.

use std::path::{Path, PathBuf};

mod common;
use common::{fails_on_one_line, ok, s, scratch, sgplvm};
use sgplvm::robots::dataset::load_demonstrations;

fn published(file: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("data/urdf/published")
        .join(file)
}

/// A copy of the G1 in its own folder (so that a description file can be written beside it).
fn g1_copy(dir: &Path) -> PathBuf {
    let urdf = dir.join("g1.urdf");
    std::fs::copy(published("g1_29dof.urdf"), &urdf).unwrap();
    urdf
}

#[test]
fn robot_reports_what_it_finds_and_keeps_it() {
    let dir = scratch("robot-describe");
    let urdf = g1_copy(&dir);
    let out = common::sgplvm(&["robot", s(&urdf), "--json"]);
    assert!(out.status.success());
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    // Its meshes are not beside it: a viewer would draw its links without them, and it says so.
    let said = String::from_utf8_lossy(&out.stderr);
    assert!(
        said.contains(
            "warning: g1_29dof_rev_1_0: 35 visual mesh(es) not found, on link(s) \"pelvis\""
        ) && said.contains("Foxglove draws those links without them"),
        "{said}"
    );
    assert_eq!(report["found"], "names");
    assert_eq!(report["torso_link"], "torso_link");
    assert_eq!(report["arms"][1]["to"], "right_rubber_hand");
    assert_eq!(report["held"].as_array().unwrap().len(), 15);
    let text = ok(&["robot", s(&published("icub.urdf"))]);
    assert!(
        text.contains("forward is -x, left -y and up +z of base_link"),
        "{text}"
    );
    // Written once, read by every command: here `robot` itself, with a hold from the file.
    ok(&[
        "robot",
        s(&urdf),
        "--hold",
        "waist_yaw_joint=0.25",
        "--write",
    ]);
    let kept = dir.join("g1.anatomy.json");
    assert!(kept.is_file());
    let again: serde_json::Value =
        serde_json::from_str(&ok(&["robot", s(&urdf), "--json"])).unwrap();
    assert_eq!(again["found"]["file"], s(&kept));
    let held = again["held"].as_array().unwrap();
    assert!(held
        .iter()
        .any(|h| h[0] == "waist_yaw_joint" && h[1] == 0.25));
}

#[test]
fn unusable_descriptions_fail_naming_the_file_and_link_and_write_nothing() {
    let dir = scratch("robot-bad");
    let urdf = g1_copy(&dir);
    let kept = dir.join("g1.anatomy.json");
    let waist = fails_on_one_line(&[
        "robot",
        s(&urdf),
        "--arm",
        "left=pelvis:left_rubber_hand",
        "--arm",
        "right=pelvis:right_rubber_hand",
        "--write",
    ]);
    assert!(
        waist.contains("g1.urdf") && waist.contains("waist_yaw_joint"),
        "{waist}"
    );
    let missing = fails_on_one_line(&[
        "robot",
        s(&urdf),
        "--arm",
        "left=torso_link:left_palm",
        "--arm",
        "right=torso_link:right_rubber_hand",
    ]);
    assert!(
        missing.contains("--arm left") && missing.contains("\"left_palm\""),
        "{missing}"
    );
    let hold = fails_on_one_line(&["robot", s(&urdf), "--hold", "left_elbow_joint=0.3"]);
    assert!(hold.contains("is an arm joint"), "{hold}");
    assert!(!kept.exists());
    // A URDF with no arm to find (one joint: no chain of four).
    let stick = dir.join("stick.urdf");
    std::fs::write(
        &stick,
        r#"<robot name="stick"><link name="a"/><link name="b"/><joint name="j" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" velocity="1" effort="1"/></joint></robot>"#,
    )
    .unwrap();
    let none = fails_on_one_line(&["robot", s(&stick)]);
    assert!(
        none.contains("stick.urdf: cannot tell the robot's arms"),
        "{none}"
    );
    let out = dir.join("never.mcap");
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/demos/bimanual.mcap");
    fails_on_one_line(&[
        "retarget",
        "--demos",
        s(&data),
        "--urdf",
        s(&stick),
        "--out",
        s(&out),
    ]);
    assert!(!out.exists());
    let builtin = fails_on_one_line(&["robot", "coman", "--write"]);
    assert!(builtin.contains("built-in"), "{builtin}");
}

#[test]
fn a_published_humanoid_is_retargeted_trained_and_drawn_with_its_waist_held() {
    let dir = scratch("robot-g1");
    let urdf = published("g1_29dof.urdf");
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/demos/bimanual.mcap");
    let demos = dir.join("g1-demos.mcap");
    let out = ok(&[
        "retarget",
        "--demos",
        s(&data),
        "--urdf",
        s(&urdf),
        "--robot",
        "g1",
        "--hold",
        "waist_pitch_joint=0.1",
        "--command-joints",
        "all",
        "--match",
        "hands",
        "--json",
        "--out",
        s(&demos),
    ]);
    let report: serde_json::Value = serde_json::from_str(&out).unwrap();
    let reach = &report["reach"][0];
    assert!(reach["worst_m"].as_f64().unwrap() <= 0.005, "{reach}");
    let reached = reach["reached"].as_f64().unwrap() / reach["targets"].as_f64().unwrap();
    assert!(reached > 0.99, "{reach}");
    // The default, whole-arm retargeting: the person's arm posture, out of self-collision
    // (the G1's collision shapes are meshes, not shipped here: the report says so).
    let arms = ok(&[
        "retarget",
        "--demos",
        s(&data),
        "--urdf",
        s(&urdf),
        "--robot",
        "g1",
        "--json",
        "--out",
        s(&dir.join("g1-arms.mcap")),
    ]);
    let arms: serde_json::Value = serde_json::from_str(&arms).unwrap();
    let posture = &arms["reach"][0]["posture"];
    assert!(
        posture["upper_arm_deg"][0].as_f64().unwrap() < 10.0,
        "{posture}"
    );
    assert!(
        posture["forearm_deg"][0].as_f64().unwrap() < 10.0,
        "{posture}"
    );
    assert!(
        !posture["unchecked"].as_array().unwrap().is_empty(),
        "{posture}"
    );
    // Every joint outside the arms at its hold value in every frame, exactly.
    let ds = load_demonstrations(&demos).unwrap();
    let g1 = ds.robot("g1").unwrap();
    assert_eq!(g1.joint_names.len(), 29);
    for (name, value) in [
        ("waist_pitch_joint", 0.1),
        ("waist_yaw_joint", 0.0),
        ("left_knee_joint", 0.0),
    ] {
        let c = g1.joint_names.iter().position(|n| n == name).unwrap();
        assert!(g1.positions.column(c).iter().all(|&v| v == value), "{name}");
    }
    let model = dir.join("g1.sgp");
    ok(&[
        "train",
        "--data",
        s(&demos),
        "--robot",
        "g1",
        "--max-iters",
        "30",
        "--out",
        s(&model),
    ]);
    let human = dir.join("human.mcap");
    ok(&[
        "export",
        "--demos",
        s(&demos),
        "--body",
        "human",
        "--out",
        s(&human),
    ]);
    // The arm joints by default; the scene carries the G1's own URDF, its links prefixed.
    let scene = dir.join("g1.mcap");
    ok(&[
        "predict",
        "--model",
        s(&model),
        "--input",
        s(&human),
        "--robot",
        "g1",
        "--urdf",
        s(&urdf),
        "--out",
        s(&scene),
    ]);
    let read = sgplvm::robots::joint_state::read_topics(&scene, &[]).unwrap();
    let topics: Vec<&str> = read.channels.iter().map(|c| c.topic.as_str()).collect();
    for t in [
        "/g1/robot_description",
        "/g1/joint_command",
        "/tf",
        "/tf_static",
    ] {
        assert!(topics.contains(&t), "{t} not in {topics:?}");
    }
    arm_commands_as_csv_replay_with_the_rest_held(&dir, &model, &human, &urdf);
    another_robot_of_the_same_joint_names_is_said(&dir, &model, &human, &urdf);
}

/// The model records the G1 its commands were retargeted onto: the same URDF predicts without a
/// word, a revised one (another name, another elbow limit, the same joint names) is said, by
/// what differs.
fn another_robot_of_the_same_joint_names_is_said(
    dir: &Path,
    model: &Path,
    human: &Path,
    urdf: &Path,
) {
    let predict = |urdf: &Path| {
        let out = sgplvm(&[
            "predict",
            "--model",
            s(model),
            "--input",
            s(human),
            "--robot",
            "g1",
            "--urdf",
            s(urdf),
            "--out",
            s(&dir.join("other.csv")),
        ]);
        assert!(out.status.success());
        String::from_utf8(out.stderr).unwrap()
    };
    let same = predict(urdf);
    assert!(!same.contains("another robot"), "{same}");
    let text = std::fs::read_to_string(urdf).unwrap();
    let elbow = text.find(r#"<joint name="left_elbow_joint""#).unwrap();
    let limit = r#"<limit lower="-1.0472""#;
    let at = elbow + text[elbow..].find(limit).unwrap();
    let revised = format!(
        "{}<limit lower=\"-0.5\"{}",
        &text[..at],
        &text[at + limit.len()..]
    )
    .replacen(
        r#"<robot name="g1_29dof_rev_1_0""#,
        r#"<robot name="g1_revised""#,
        1,
    );
    let other = dir.join("g1_revised.urdf");
    std::fs::write(&other, revised).unwrap();
    let said = predict(&other);
    assert!(
        said.contains("g1: the model's commands were learned on another robot than the URDF given (URDF robot `g1_revised`, learned on `g1_29dof_rev_1_0`: other limits on \"left_elbow_joint\")"),
        "{said}"
    );
}

/// `predict`'s CSV names the G1's 14 arm joints; a command joint the model does not predict is
/// refused; the arm commands replay in physics with the joints they leave out held.
fn arm_commands_as_csv_replay_with_the_rest_held(
    dir: &Path,
    model: &Path,
    human: &Path,
    urdf: &Path,
) {
    let csv = dir.join("g1.csv");
    ok(&[
        "predict",
        "--model",
        s(model),
        "--input",
        s(human),
        "--robot",
        "g1",
        "--urdf",
        s(urdf),
        "--out",
        s(&csv),
    ]);
    let header = std::fs::read_to_string(&csv).unwrap();
    let columns = header.lines().next().unwrap();
    assert_eq!(columns.split(',').count(), 1 + 14, "{columns}");
    assert!(
        columns.starts_with("time,left_shoulder_pitch_joint"),
        "{columns}"
    );
    // A command joint the model does not predict and the robot does not hold is refused.
    let bad = fails_on_one_line(&[
        "predict",
        "--model",
        s(model),
        "--input",
        s(human),
        "--robot",
        "g1",
        "--urdf",
        s(urdf),
        "--command-joints",
        "left_elbow_joint,nonsense_joint",
        "--out",
        s(&csv),
    ]);
    assert!(bad.contains("nonsense_joint"), "{bad}");
    // The arm joints' commands replay in physics as they are: the joints they leave out (the
    // waist, the legs) are held still at their hold values, as the other commands hold them
    // (welded, as their controllers would keep them).
    let replay = ok(&[
        "simulate",
        "--urdf",
        s(urdf),
        "--trajectory",
        s(&csv),
        "--hold",
        "waist_pitch_joint=0.1",
        "--json",
    ]);
    let replay: serde_json::Value = serde_json::from_str(&replay).unwrap();
    let joints = replay["joints"].as_array().unwrap();
    assert_eq!(joints.len(), 14, "{replay}");
    let held = replay["held"].as_array().unwrap();
    assert_eq!(held.len(), 15, "{replay}");
    assert!(
        held.iter()
            .any(|h| h[0] == "waist_pitch_joint" && (h[1].as_f64().unwrap() - 0.1).abs() < 1e-12),
        "{replay}"
    );
}

#[test]
fn a_single_arm_robot_goes_through_every_command_driven_by_the_arm_its_side_names() {
    // KUKA's iiwa as published: one serial chain, no side in its names. Found as one arm
    // driven by the person's right arm; `--arm left=…` alone gives it the person's left.
    let dir = scratch("robot-single-arm");
    let kuka = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("crates/sgplvm-robots/tests/fixtures/kuka_iiwa.urdf");
    let report: serde_json::Value =
        serde_json::from_str(&ok(&["robot", s(&kuka), "--json"])).unwrap();
    let arms = report["arms"].as_array().unwrap();
    assert_eq!(arms.len(), 1, "{report}");
    assert_eq!(arms[0]["side"], "right");
    assert!(report["shoulder_width_m"].is_null());
    // It stands on its base and cannot hang: the person's arm is rolled out to take it.
    assert_eq!(report["mount"]["why"], "cannot_hang", "{report}");
    assert_eq!(report["mount"]["roll_deg"], 90.0, "{report}");
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/demos/captured.mcap");
    let (mut medians, mut ninetieths) = (Vec::new(), Vec::new());
    for (side, demos) in [
        ("right", dir.join("kuka-right.mcap")),
        ("left", dir.join("kuka-left.mcap")),
    ] {
        let arm = format!("{side}=lbr_iiwa_link_0:lbr_iiwa_link_7");
        let out = ok(&[
            "retarget",
            "--demos",
            s(&data),
            "--urdf",
            s(&kuka),
            "--robot",
            "kuka",
            "--arm",
            &arm,
            "--json",
            "--out",
            s(&demos),
        ]);
        let out: serde_json::Value = serde_json::from_str(&out).unwrap();
        let posture = &out["reach"][0]["posture"];
        medians.push(posture["upper_arm_deg"][0].as_f64().unwrap());
        ninetieths.push(posture["upper_arm_deg"][1].as_f64().unwrap());
        let ds = load_demonstrations(&demos).unwrap();
        assert_eq!(ds.robot("kuka").unwrap().joint_names.len(), 7);
    }
    // Each side follows its own arm of the person (rolled out by the mount): the commands
    // differ, both are faithful (2.4° / 31.6° at the 90th percentile with `--mount-roll 0`,
    // where the person's hanging arm asks the arm to point down through its base).
    assert!(medians.iter().all(|&m| m < 5.0), "{medians:?}");
    assert!(ninetieths.iter().all(|&m| m < 10.0), "{ninetieths:?}");
    let (r, l) = (
        load_demonstrations(dir.join("kuka-right.mcap")).unwrap(),
        load_demonstrations(dir.join("kuka-left.mcap")).unwrap(),
    );
    assert!(r.robot("kuka").unwrap().positions != l.robot("kuka").unwrap().positions);
    let demos = dir.join("kuka-right.mcap");
    let model = dir.join("kuka.sgp");
    ok(&[
        "train",
        "--data",
        s(&demos),
        "--robot",
        "kuka",
        "--max-iters",
        "30",
        "--out",
        s(&model),
    ]);
    // `predict` of either kind of model: the time and the arm's 7 joints.
    let predicts_the_arm = |model: &Path| {
        let csv = model.with_extension("csv");
        ok(&[
            "predict",
            "--model",
            s(model),
            "--input",
            s(&demos),
            "--robot",
            "kuka",
            "--urdf",
            s(&kuka),
            "--out",
            s(&csv),
        ]);
        let header = std::fs::read_to_string(&csv).unwrap();
        let header = header.lines().next().unwrap().to_string();
        assert_eq!(header.split(',').count(), 1 + 7, "{header}");
    };
    predicts_the_arm(&model);
    let evaluated: serde_json::Value = serde_json::from_str(&ok(&[
        "evaluate",
        "--model",
        s(&model),
        "--data",
        s(&demos),
        "--robot",
        "kuka",
        "--urdf",
        s(&kuka),
        "--json",
    ]))
    .unwrap();
    let text = evaluated.to_string();
    assert!(text.contains("upper_arm_median_deg"), "{text}");
    // A latent space per arm: one, the arm's that drove it in `retarget` (the file says which,
    // no flag at training); the person's other arm is no input. Its joints come from the
    // URDF's anatomy where given, else from the file (retarget recorded each arm's joints:
    // none of iiwa's names says a side).
    let urdf = format!("kuka={}", s(&kuka));
    let train_arms = |side: &str, with_urdf: bool| {
        let (demos, out) = (
            dir.join(format!("kuka-{side}.mcap")),
            dir.join(format!("kuka-{side}.sgp")),
        );
        let mut args = vec![
            "train",
            "--data",
            s(&demos),
            "--robot",
            "kuka",
            "--parts",
            "arms",
            "--max-iters",
            "20",
            "--out",
            s(&out),
        ];
        if with_urdf {
            args.extend(["--urdf", &urdf]);
        }
        ok(&args);
        let model = sgplvm::PartsGplvm::load(&out).unwrap();
        let part = format!("{side}_arm");
        assert_eq!(model.part_names(), [part.as_str()]);
        let human = model.column_names("human").unwrap();
        let inputs = model.part_columns(&part, "human").unwrap();
        let prefix = if side == "left" { "jLeft" } else { "jRight" };
        assert!(
            inputs.len() == 9 && inputs.iter().all(|&c| human[c].starts_with(prefix)),
            "{inputs:?} of {human:?}"
        );
        assert_eq!(model.part_columns(&part, "kuka").unwrap().len(), 7);
        out
    };
    predicts_the_arm(&train_arms("right", true));
    predicts_the_arm(&train_arms("left", false));
}

#[test]
fn a_two_armed_robot_driven_by_one_arm_trains_that_arm_s_latent_space() {
    // WALK-MAN made one-armed at retargeting (`--arm right=…` alone): its URDF alone finds two
    // arms, the demonstrations hold the right arm's joints and say which arm drove them.
    let dir = scratch("robot-one-of-two-arms");
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let urdf = root.join("data/urdf/walkman.urdf");
    let demos = dir.join("right.mcap");
    ok(&[
        "retarget",
        "--demos",
        s(&root.join("data/demos/captured.mcap")),
        "--urdf",
        s(&urdf),
        "--robot",
        "wmr",
        "--arm",
        "right=DWYTorso:right_hand",
        "--out",
        s(&demos),
    ]);
    let model = dir.join("right.sgp");
    ok(&[
        "train",
        "--data",
        s(&demos),
        "--robot",
        "wmr",
        "--parts",
        "arms",
        "--urdf",
        &format!("wmr={}", s(&urdf)),
        "--max-iters",
        "10",
        "--out",
        s(&model),
    ]);
    let model = sgplvm::PartsGplvm::load(&model).unwrap();
    assert_eq!(model.part_names(), ["right_arm"]);
    assert_eq!(model.part_columns("right_arm", "wmr").unwrap().len(), 7);
    // `simulate --arm` as `retarget --arm`: the left arm is no arm, held still as the waist
    // and head are; without it the left arm's joints have no column and no hold value.
    let replay = ok(&[
        "simulate",
        "--urdf",
        s(&urdf),
        "--arm",
        "right=DWYTorso:right_hand",
        "--trajectory",
        s(&demos),
        "--topic",
        "/wmr/joint_command",
        "--json",
    ]);
    let replay: serde_json::Value = serde_json::from_str(&replay).unwrap();
    let held: Vec<&str> = replay["held"]
        .as_array()
        .unwrap()
        .iter()
        .map(|h| h[0].as_str().unwrap())
        .collect();
    assert!(
        held.contains(&"LShSag") && held.contains(&"LElbj"),
        "{held:?}"
    );
    assert!(!held.contains(&"RShSag"), "{held:?}");
}

#[test]
fn retargeting_says_what_it_assumes_of_a_urdf_without_velocity_limits() {
    // `retarget --velocity-limits` says what it assumes (as `predict` does), and that the
    // meshes are not found (no self-collision checked at all): KUKA's iiwa without them.
    let dir = scratch("robot-no-velocity");
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let kuka = root.join("crates/sgplvm-robots/tests/fixtures/kuka_iiwa.urdf");
    let data = root.join("data/demos/captured.mcap");
    let unstated = dir.join("kuka_no_velocity.urdf");
    let xml = std::fs::read_to_string(&kuka).unwrap();
    let without: String = xml
        .split("velocity=\"")
        .enumerate()
        .map(|(k, part)| match k {
            0 => part,
            _ => part.split_once('"').map_or(part, |(_, rest)| rest),
        })
        .collect();
    std::fs::write(&unstated, without).unwrap();
    let out = sgplvm(&[
        "retarget",
        "--demos",
        s(&data),
        "--urdf",
        s(&unstated),
        "--robot",
        "kuka",
        "--velocity-limits",
        "--out",
        s(&dir.join("unstated.mcap")),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("warning: kuka: 7 commanded joint(s) state no velocity limit"),
        "{err}"
    );
    assert!(err.contains("self-collision not checked at all"), "{err}");
}
