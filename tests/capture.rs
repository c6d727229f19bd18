//! Motion capture in, end to end: `sgplvm import` on hostile BVH files (one line naming the file
//! and the line, no output left behind), on the human model's own motion written as BVH (it must
//! come back), and `import → retarget → train → transfer → predict` on it.

use std::path::Path;

mod common;
use common::{fails_on_one_line, ok, s, scratch};

/// A BVH file with a CMU-named two-arm skeleton (ZYX joints, 6-channel root), `frames` lines.
fn cmu_bvh(frames: usize) -> String {
    cmu_bvh_bending(frames, 0, 1.0)
}

/// [`cmu_bvh`] with the elbows bending about their `axis`-th channel (0: z, 1: y) and every
/// bone `scale` times as long.
fn cmu_bvh_bending(frames: usize, axis: usize, scale: f64) -> String {
    let mut t = String::from(
        "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n  CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation\n  JOINT Spine1\n  {\n    OFFSET 0 5 0\n    CHANNELS 3 Zrotation Yrotation Xrotation\n    JOINT Neck\n    {\n      OFFSET 0 2 0\n      CHANNELS 3 Zrotation Yrotation Xrotation\n      End Site\n      {\n        OFFSET 0 1 0\n      }\n    }\n",
    );
    for (side, x) in [("Left", 1.0), ("Right", -1.0)] {
        for (name, len) in [
            ("Shoulder", 1.0),
            ("Arm", 3.5),
            ("ForeArm", 5.4),
            ("Hand", 3.7),
        ] {
            t.push_str(&format!(
                "JOINT {side}{name}\n{{\nOFFSET {} 0 0\nCHANNELS 3 Zrotation Yrotation Xrotation\n",
                x * len * scale
            ));
        }
        t.push_str(&format!(
            "End Site\n{{\nOFFSET {} 0 0\n}}\n}}\n}}\n}}\n}}\n",
            x * 0.6
        ));
    }
    t.push_str(&format!(
        "  }}\n}}\nMOTION\nFrames: {frames}\nFrame Time: 0.0083333\n"
    ));
    for f in 0..frames {
        // Channels: Hips 0–5, Spine1 6–8, Neck 9–11, then per arm Shoulder, Arm, ForeArm,
        // Hand (left 12–23, right 24–35), each Zrotation Yrotation Xrotation. The arms are
        // lowered from the T-pose by 60°, the elbows bend slowly.
        let mut v = vec![0.0; 36];
        v[15] = -60.0;
        v[16] = -20.0;
        v[18 + axis] = -20.0 - 0.1 * f as f64;
        v[27] = 60.0;
        v[30 + axis] = 20.0 + 0.1 * f as f64;
        let line: Vec<String> = v.iter().map(|x| format!("{x:.4}")).collect();
        t.push_str(&line.join(" "));
        t.push('\n');
    }
    t
}

/// The shipped human's every frame, written by `sgplvm export` to `out` (BVH or CSV by its name).
fn export_human(out: &Path) {
    ok(&[
        "export",
        "--data",
        "data/demos/bimanual.mcap",
        "--body",
        "human",
        "--frames",
        "all",
        "--out",
        s(out),
    ]);
}

/// `sgplvm import FILE --out OUT` must fail with one line naming the file (and `needle`) and
/// leave no output file.
fn refused(dir: &Path, name: &str, text: &str, needle: &str) {
    let path = dir.join(name);
    std::fs::write(&path, text).expect("write");
    let out = dir.join(format!("{name}.mcap"));
    let err = fails_on_one_line(&["import", s(&path), "--out", s(&out)]);
    assert!(err.contains(name), "{err}");
    assert!(err.contains(needle), "{needle:?} not in: {err}");
    assert!(!out.exists(), "{} written after an error", out.display());
    let leftovers: Vec<_> = std::fs::read_dir(dir)
        .expect("dir")
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().contains(".tmp"))
        .collect();
    assert!(leftovers.is_empty(), "temporary files left: {leftovers:?}");
}

#[test]
fn hostile_bvh_files_are_one_line_naming_the_file_and_line() {
    let dir = scratch("hostile-bvh");
    let good = cmu_bvh(20);
    // The good file imports.
    std::fs::write(dir.join("good.bvh"), &good).expect("write");
    ok(&[
        "import",
        s(&dir.join("good.bvh")),
        "--out",
        s(&dir.join("good.mcap")),
    ]);
    let frame_line = good
        .lines()
        .position(|l| l.starts_with("Frame Time"))
        .expect("frame time")
        + 2;
    let lines: Vec<&str> = good.lines().collect();
    let with_line = |k: usize, new: &str| -> String {
        let mut l = lines.clone();
        l[k] = new;
        l.join("\n") + "\n"
    };
    let first_frame = frame_line - 1;
    let short: String = lines[first_frame]
        .rsplit_once(' ')
        .expect("values")
        .0
        .to_string();
    refused(
        &dir,
        "short.bvh",
        &with_line(first_frame, &short),
        &format!("short.bvh:{frame_line}: frame 1 has 35 values, expected 36"),
    );
    let nan = lines[first_frame].replacen("0.0000", "nan", 1);
    refused(
        &dir,
        "nan.bvh",
        &with_line(first_frame, &nan),
        "expected a finite number",
    );
    let text = lines[first_frame].replacen("0.0000", "zero", 1);
    refused(
        &dir,
        "text.bvh",
        &with_line(first_frame, &text),
        "found `zero`",
    );
    let truncated: String = lines[..lines.len() - 5].join("\n") + "\n";
    refused(&dir, "truncated.bvh", &truncated, "truncated MOTION block");
    // More frame lines than `Frames:` declares: read as declared, the rest said (assimp's
    // Boxing_Toes.bvh has one more than its header).
    let more = dir.join("more.bvh");
    std::fs::write(&more, good.replace("Frames: 20", "Frames: 18")).expect("write");
    let out = common::sgplvm(&["import", s(&more), "--out", s(&dir.join("more.mcap"))]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("more.bvh: 2 frame lines past the 18 frames that `Frames:` declares left out"),
        "{err}"
    );
    refused(
        &dir,
        "huge.bvh",
        &good.replace("Frames: 20", "Frames: 100000000"),
        "declares 100000000 frames",
    );
    refused(
        &dir,
        "zero.bvh",
        &good.replace("Frame Time: 0.0083333", "Frame Time: 0"),
        "frame time 0 s",
    );
    let mut deep = String::from(
        "HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n",
    );
    for i in 0..10_000 {
        deep.push_str(&format!(
            "JOINT j{i}\n{{\nOFFSET 0 1 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n"
        ));
    }
    refused(&dir, "deep.bvh", &deep, "nested deeper than 1000");
    let armless = "HIERARCHY\nROOT Hips\n{\nOFFSET 0 0 0\nCHANNELS 3 Zrotation Xrotation Yrotation\nJOINT Tail\n{\nOFFSET 0 -1 0\nCHANNELS 3 Zrotation Xrotation Yrotation\nEnd Site\n{\nOFFSET 0 -1 0\n}\n}\n}\nMOTION\nFrames: 2\nFrame Time: 0.01\n0 0 0 0 0 0\n0 0 0 0 0 0\n";
    refused(
        &dir,
        "armless.bvh",
        armless,
        "segments, nearest the root first: Hips, Tail",
    );
    refused(&dir, "empty.bvh", "", "empty");
    let missing = dir.join("nosuch.bvh");
    let err = fails_on_one_line(&["import", s(&missing), "--out", s(&dir.join("x.mcap"))]);
    assert!(err.contains("nosuch.bvh"), "{err}");
    // A map naming a segment the file lacks.
    let map = dir.join("map.json");
    std::fs::write(&map, r#"{"jLeftShoulder": "LeftUpperArm"}"#).expect("write");
    let err = fails_on_one_line(&[
        "import",
        s(&dir.join("good.bvh")),
        "--map",
        s(&map),
        "--out",
        s(&dir.join("y.mcap")),
    ]);
    assert!(
        err.contains("`jLeftShoulder` names segment `LeftUpperArm`"),
        "{err}"
    );
}

#[test]
fn the_human_s_own_motion_goes_through_import_retarget_train_transfer_predict() {
    let dir = scratch("capture-pipeline");
    let p = |n: &str| dir.join(n);
    // The shipped human, written as BVH: the importer must give back its angles.
    export_human(&p("capture.bvh"));
    export_human(&p("human.csv"));
    let summary = ok(&[
        "import",
        s(&p("capture.bvh")),
        "--out",
        s(&p("imported.csv")),
    ]);
    assert!(summary.contains("Xsens MVN"), "{summary}");
    let read = |path: &Path| -> Vec<Vec<f64>> {
        std::fs::read_to_string(path)
            .expect("csv")
            .lines()
            .skip(1)
            .map(|l| {
                l.split(',')
                    .skip(1)
                    .map(|v| v.parse().expect("number"))
                    .collect()
            })
            .collect()
    };
    let (original, imported) = (read(&p("human.csv")), read(&p("imported.csv")));
    assert_eq!(original.len(), imported.len());
    let worst = original
        .iter()
        .zip(&imported)
        .flat_map(|(a, b)| a.iter().zip(b).map(|(x, y)| (x - y).abs()))
        .fold(0.0, f64::max);
    // The twist of a straight arm is not in the positions: allow the frames where the elbow
    // is straight to differ there, but no angle may be far off.
    assert!(worst < 0.05, "worst angle difference {worst} rad");
    ok(&["import", s(&p("capture.bvh")), "--out", s(&p("human.mcap"))]);
    let report = ok(&[
        "retarget",
        "--demos",
        s(&p("human.mcap")),
        "--robots",
        "walkman,coman",
        "--out",
        s(&p("demos.mcap")),
        "--json",
    ]);
    let v: serde_json::Value = serde_json::from_str(&report).expect("json");
    // The robots take the person's arm posture (whole-arm retargeting, the default).
    for r in v["reach"].as_array().expect("reach") {
        let p = &r["posture"];
        assert!(p["upper_arm_deg"][0].as_f64().expect("upper") < 10.0, "{r}");
        assert!(p["forearm_deg"][0].as_f64().expect("forearm") < 10.0, "{r}");
        assert_eq!(p["colliding_frames"], 0, "{r}");
    }
    ok(&[
        "train",
        "--data",
        s(&p("demos.mcap")),
        "--robot",
        "walkman",
        "--out",
        s(&p("w.sgp")),
    ]);
    ok(&[
        "transfer",
        "--data",
        s(&p("demos.mcap")),
        "--model",
        s(&p("w.sgp")),
        "--robot",
        "coman",
        "--out",
        s(&p("c.sgp")),
    ]);
    ok(&[
        "predict",
        "--model",
        s(&p("c.sgp")),
        "--input",
        s(&p("human.mcap")),
        "--robot",
        "coman",
        "--out",
        s(&p("c.mcap")),
    ]);
    assert!(p("c.mcap").exists());
    models_carry_the_person_and_the_robots(&p);
    // Retargeting refuses what it cannot do, naming it.
    let err = fails_on_one_line(&[
        "retarget",
        "--demos",
        s(&p("human.mcap")),
        "--robots",
        "nao",
        "--out",
        s(&p("x.mcap")),
    ]);
    assert!(err.contains("nao") && err.contains("coman"), "{err}");
    let err = fails_on_one_line(&[
        "retarget",
        "--demos",
        s(&p("human.mcap")),
        "--robots",
        "coman",
        "--split",
        "files",
        "--test-files",
        "other",
        "--out",
        s(&p("x.mcap")),
    ]);
    assert!(
        err.contains("no file `other`; the files are: capture"),
        "{err}"
    );
    assert!(!p("x.mcap").exists());
}

#[test]
fn a_short_capture_retargets_with_the_defaults_and_every_split_says_what_it_did() {
    let dir = scratch("short-capture");
    let p = |n: &str| dir.join(n);
    export_human(&p("c.bvh"));
    // 2.4 s: one block of 4 s, too few for one block in 4 to test.
    ok(&[
        "import",
        s(&p("c.bvh")),
        "--to",
        "2.4",
        "--out",
        s(&p("short.mcap")),
    ]);
    let short = p("short.mcap");
    let retarget = |extra: &[&str], out: &str| {
        let mut args = vec![
            "retarget",
            "--demos",
            s(&short),
            "--robots",
            "coman",
            "--out",
        ];
        let out = p(out);
        args.push(s(&out));
        args.extend_from_slice(extra);
        let output = common::sgplvm(&args);
        let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
        assert!(output.status.success(), "{args:?}: {stderr}");
        let stdout = String::from_utf8(output.stdout).unwrap();
        (stdout, stderr)
    };
    // The defaults: every frame for training (all of them: a short capture keeps at least
    // 200 where it has them), with a warning that says what testing would need.
    let (stdout, stderr) = retarget(&[], "r.mcap");
    assert!(
        stderr.contains("warning: the frames make 1 block of 4 s")
            && stderr.contains("`train` needs no test frames"),
        "{stderr}"
    );
    assert!(
        stdout.contains("split: none: every frame for training (1 block of 4 s, too few for one in 4 to test); 97 training frames kept (1 in 1: a short capture keeps at least 200 where it has them), no test frames"),
        "{stdout}"
    );
    let ds = sgplvm::robots::dataset::load_demonstrations(p("r.mcap")).unwrap();
    assert_eq!((ds.train.len(), ds.test.len()), (97, 0));
    // And `train` takes it with its defaults (it needs no test frames).
    ok(&[
        "train",
        "--data",
        s(&p("r.mcap")),
        "--robot",
        "coman",
        "--out",
        s(&p("r.sgp")),
    ]);
    // Asked for: no warning; every frame with --train-subsample 1.
    let (stdout, stderr) = retarget(&["--split", "none", "--train-subsample", "1"], "n.mcap");
    assert!(!stderr.contains("warning"), "{stderr}");
    assert!(
        stdout.contains("split: none: every frame for training; 97 training frames kept (1 in 1), no test frames"),
        "{stdout}"
    );
    // Two files, one kept for testing: the report names it, not "blocks of 4 s".
    ok(&[
        "import",
        s(&p("c.bvh")),
        "--from",
        "10",
        "--to",
        "20",
        "--out",
        s(&p("second.mcap")),
    ]);
    let second = p("second.mcap");
    let mut args = vec!["--demos", s(&second)];
    // Both imported from c.bvh: named by index.
    args.extend(["--split", "files", "--test-files", "1"]);
    let (stdout, _) = retarget(&args, "f.mcap");
    assert!(
        stdout.contains(
            "split: files kept whole for testing: c (1 of 2 files; 3 of the 4 blocks of 4 s)"
        ),
        "{stdout}"
    );
}

#[test]
fn a_rig_scaled_up_keeps_its_file_s_units() {
    use sgplvm::capture::Units;
    // An adult's arm (upper arm and forearm, 54 cm) in each unit, and a Mixamo rig (cm) scaled
    // 2.5×: its units are still found, its size then says it is a giant's.
    assert_eq!(Units::guess(54.0), Some(Units::Centimetres));
    assert_eq!(Units::guess(0.54), Some(Units::Metres));
    assert_eq!(Units::guess(540.0), Some(Units::Millimetres));
    assert_eq!(Units::guess(2.5 * 54.0), Some(Units::Centimetres));
    // Nothing near a person in any unit.
    assert_eq!(Units::guess(1e9), None);
}

#[test]
fn people_named_at_import_are_split_whole_trained_a_person_at_a_time_and_judged_per_person() {
    use sgplvm::robots::dataset::{load_demonstrations, ValidationRule};
    let dir = scratch("people");
    let p = |n: &str| dir.join(n);
    export_human(&p("c.bvh"));
    // Four "people", 12 s of motion each (three blocks of 4 s).
    let mut demos = Vec::new();
    for (k, person) in ["ann", "bo", "cy", "di"].iter().enumerate() {
        let (from, to) = (format!("{}", 12 * k), format!("{}", 12 * (k + 1)));
        let out = p(&format!("{person}.mcap"));
        ok(&[
            "import",
            s(&p("c.bvh")),
            "--from",
            &from,
            "--to",
            &to,
            "--person",
            person,
            "--out",
            s(&out),
        ]);
        demos.push(out);
    }
    let out = p("r.mcap");
    let mut args = vec!["retarget", "--robots", "coman", "--out", s(&out)];
    for d in &demos {
        args.extend(["--demos", s(d)]);
    }
    // Nobody of that name: refused, naming who there is.
    let mut wrong = args.clone();
    wrong.extend(["--split", "people", "--test-people", "eve"]);
    let err = fails_on_one_line(&wrong);
    assert!(
        err.contains("nobody called `eve`") && err.contains("ann, bo, cy, di"),
        "{err}"
    );
    args.extend(["--split", "people", "--test-people", "di"]);
    let stdout = ok(&args);
    assert!(
        stdout.contains(
            "people kept whole for testing: di (1 files of 4 files); training people: ann, bo, cy"
        ),
        "{stdout}"
    );
    let ds = load_demonstrations(p("r.mcap")).unwrap();
    assert_eq!(ds.people_of(&ds.test), vec!["di".to_string()]);
    assert_eq!(ds.people_of(&ds.train), vec!["ann", "bo", "cy"]);
    // Three training people: validated and calibrated a person at a time, cy held out.
    let groups = ds.training_groups();
    assert_eq!(groups.rule, ValidationRule::EveryThirdPerson);
    assert_eq!(groups.validation, vec![2]);
    ok(&[
        "train",
        "--data",
        s(&p("r.mcap")),
        "--robot",
        "coman",
        "--max-iters",
        "20",
        "--out",
        s(&p("m.sgp")),
    ]);
    let json = ok(&[
        "evaluate",
        "--model",
        s(&p("m.sgp")),
        "--data",
        s(&p("r.mcap")),
        "--robot",
        "coman",
        "--json",
    ]);
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    let arms = &v["arms"];
    let (followed, held) = (
        arms["followed"]["frames"].as_u64().unwrap(),
        arms["held"]["frames"].as_u64().unwrap(),
    );
    assert_eq!(followed + held, ds.test.len() as u64, "{arms}");
    assert_eq!(arms["people"][0]["person"], "di", "{arms}");
    assert_eq!(arms["people"][0]["followed"].as_u64(), Some(followed));
    let median = arms["followed"]["upper_arm_median_deg"].as_f64();
    assert!(median.is_none_or(|m| (0.0..180.0).contains(&m)), "{arms}");
}

#[test]
fn cmu_asf_amc_import_through_the_command_line_and_an_amc_without_its_skeleton_is_refused() {
    let dir = scratch("capture-asf");
    let fixtures =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("crates/sgplvm-capture/tests/fixtures");
    let (asf, amc) = (
        fixtures.join("cmu-12.asf"),
        fixtures.join("cmu-02_01-60frames.amc"),
    );
    let out = dir.join("walk.mcap");
    let report = ok(&["import", s(&asf), s(&amc), "--out", s(&out), "--json"]);
    assert!(report.contains("CMU ASF"), "{report}");
    let ds = sgplvm::robots::dataset::load_demonstrations(&out).unwrap();
    assert_eq!(ds.human.joint_names.len(), 18);
    assert_eq!(ds.len(), 20); // 60 frames at 120 Hz, at 40 Hz
                              // Alone in a folder without its subject's skeleton: one line naming what was expected,
                              // and nothing written.
    let lone = dir.join("02_01.amc");
    std::fs::copy(&amc, &lone).unwrap();
    let never = dir.join("never.mcap");
    let e = fails_on_one_line(&["import", s(&lone), "--out", s(&never)]);
    assert!(e.contains("02.asf") && e.contains("ASF skeleton"), "{e}");
    assert!(!never.exists());
}

/// A model trained on imported, retargeted data carries the person's calibration and each
/// robot it learned, one latent space or one per arm, through transfer; a per-arm model's
/// calibration serves `import --calibration` (and a stream's, in `teleop`) as a single one's.
fn models_carry_the_person_and_the_robots(p: &dyn Fn(&str) -> std::path::PathBuf) {
    for (trained, transferred, parts) in [("w.sgp", "c.sgp", false), ("wp.sgp", "cp.sgp", true)] {
        let (data, trained, transferred) = (p("demos.mcap"), p(trained), p(transferred));
        if parts {
            ok(&[
                "train",
                "--data",
                s(&data),
                "--robot",
                "walkman",
                "--parts",
                "arms",
                "--max-iters",
                "5",
                "--out",
                s(&trained),
            ]);
            ok(&[
                "transfer",
                "--data",
                s(&data),
                "--model",
                s(&trained),
                "--robot",
                "coman",
                "--max-iters",
                "5",
                "--out",
                s(&transferred),
            ]);
        }
        let model = sgplvm::AnyModel::load(&transferred).unwrap();
        let notes = sgplvm::Predictor::annotations(&model);
        assert!(notes.contains_key("sgplvm.capture"), "{transferred:?}");
        let robots = &notes[sgplvm::provenance::ROBOTS_ANNOTATION];
        for robot in ["walkman", "coman"] {
            assert!(
                robots[robot]["joints"]
                    .as_object()
                    .is_some_and(|j| j.len() >= 14),
                "{transferred:?}: {robot}"
            );
        }
    }
    let again = ok(&[
        "import",
        s(&p("capture.bvh")),
        "--calibration",
        s(&p("cp.sgp")),
        "--out",
        s(&p("again.mcap")),
    ]);
    assert!(p("again.mcap").exists(), "{again}");
}

/// Takes of one person (skeletons resting alike) imported together share one calibration, the
/// twist their rest leaves untold read from the elbow's hinge over all of them (each take alone
/// told it its own way, and a stream of the person could be fitted through one of them only);
/// a skeleton resting otherwise keeps its own.
#[test]
fn takes_of_one_person_imported_together_share_one_calibration() {
    let dir = scratch("capture-takes");
    let p = |n: &str| dir.join(n);
    std::fs::write(p("a.bvh"), cmu_bvh_bending(120, 0, 1.0)).unwrap();
    std::fs::write(p("b.bvh"), cmu_bvh_bending(120, 1, 1.0)).unwrap();
    std::fs::write(p("c.bvh"), cmu_bvh_bending(120, 0, 1.3)).unwrap();
    let calibrations = |files: &[&str]| -> Vec<serde_json::Value> {
        let mut args = vec!["import".to_string()];
        args.extend(files.iter().map(|f| p(f).display().to_string()));
        args.extend(["--json", "--out"].map(String::from));
        args.push(p("out.mcap").display().to_string());
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let v: serde_json::Value = serde_json::from_str(&ok(&args)).unwrap();
        v.as_array()
            .unwrap()
            .iter()
            .map(|c| c["calibration"].clone())
            .collect()
    };
    let alone = [calibrations(&["a.bvh"]), calibrations(&["b.bvh"])].map(|mut c| c.remove(0));
    assert_eq!(
        alone[0]["arms"][0]["twist"]["kind"], "elbow_hinge",
        "{}",
        alone[0]
    );
    assert_ne!(
        alone[0]["arms"][0]["upper_arm_frame"],
        alone[1]["arms"][0]["upper_arm_frame"]
    );
    let together = calibrations(&["a.bvh", "b.bvh", "c.bvh"]);
    assert_eq!(together[0], together[1]);
    let made_from = together[0]["made_from"].as_str().unwrap();
    assert!(
        made_from.ends_with("a.bvh and 1 more file resting alike"),
        "{made_from}"
    );
    let frames = |c: &serde_json::Value| c["arms"][0]["twist"]["frames"].as_u64().unwrap();
    assert_eq!(frames(&together[0]), frames(&alone[0]) + frames(&alone[1]));
    assert!(
        together[2]["made_from"]
            .as_str()
            .unwrap()
            .ends_with("c.bvh"),
        "{}",
        together[2]
    );
    // One calibration of one person: --calibration-out writes it.
    let written = p("person.json");
    ok(&[
        "import",
        s(&p("a.bvh")),
        s(&p("b.bvh")),
        "--calibration-out",
        s(&written),
        "--out",
        s(&p("ab.mcap")),
    ]);
    assert!(written.exists());
}
