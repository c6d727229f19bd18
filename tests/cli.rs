//! The `sgplvm` program end to end: generate → train → transfer → predict → evaluate on
//! generated data, the experiment's results schema, and every kind of bad input failing with a
//! clear one-line message, a non-zero exit code and no output file.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::OnceLock;

mod common;
use common::{fails, fails_on_one_line, ok, s, scratch, sgplvm};

/// Generated data and a model trained on WALK-MAN, shared by the tests.
struct Fixture {
    dir: PathBuf,
    data: PathBuf,
    model: PathBuf,
}

fn fixture() -> &'static Fixture {
    static FIXTURE: OnceLock<Fixture> = OnceLock::new();
    FIXTURE.get_or_init(|| {
        let dir = scratch("fixture");
        let stdout = ok(&["generate", "--out", s(&dir), "--subsample", "24"]);
        assert!(stdout.contains("bimanual.mcap"), "{stdout}");
        let data = dir.join("bimanual.mcap");
        let model = dir.join("walkman.sgp");
        ok(&[
            "train",
            "--data",
            s(&data),
            "--robot",
            "walkman",
            "--max-iters",
            "40",
            "--out",
            s(&model),
        ]);
        Fixture { dir, data, model }
    })
}

/// The human's test frames of the fixture as CSV (a few seconds of motion: physics replays of
/// it stay short).
fn human_test_csv(f: &Fixture) -> PathBuf {
    static CSV: OnceLock<PathBuf> = OnceLock::new();
    CSV.get_or_init(|| {
        let path = f.dir.join("human_test.csv");
        ok(&[
            "export",
            "--data",
            s(&f.data),
            "--body",
            "human",
            "--out",
            s(&path),
        ]);
        path
    })
    .clone()
}

#[test]
fn train_transfer_predict_evaluate() {
    let f = fixture();
    let coman = transfer_to_coman(f);
    let evaluation = evaluate_per_joint(f, &coman);
    let first = predict_to_csv_and_mcap(f, &coman);
    predictions_agree_with_evaluate_and_a_dense_reference(f, &coman, &evaluation);
    let human_csv = predict_from_reordered_csv(f, &coman, &first);
    predict_streaming(&coman, &human_csv, &first);
}

/// Transfers the fixture's WALK-MAN model to COMAN; returns the new model's path.
fn transfer_to_coman(f: &Fixture) -> PathBuf {
    let coman = f.dir.join("coman.sgp");
    let json = ok(&[
        "transfer",
        "--model",
        s(&f.model),
        "--data",
        s(&f.data),
        "--robot",
        "coman",
        "--max-iters",
        "40",
        "--out",
        s(&coman),
        "--json",
    ]);
    let value: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert_eq!(value["robots"], serde_json::json!(["walkman", "coman"]));
    // The budget was chosen on held-out frames (the default) and the final run kept to it.
    let selection = &value["selection"];
    assert!(
        selection["validation_frames"].as_u64().unwrap() > 0,
        "{json}"
    );
    assert!(
        value["iterations"].as_u64().unwrap() <= selection["best_iteration"].as_u64().unwrap(),
        "{json}"
    );
    coman
}

/// `evaluate --json`'s per-joint test MSEs, the overall one and the mean training pose's.
type Evaluated = (Vec<f64>, f64, f64);

/// Returns `evaluate --json`'s per-joint test MSEs, the overall one and the mean training
/// pose's.
fn evaluate_per_joint(f: &Fixture, coman: &Path) -> Evaluated {
    // Evaluate: overall and per joint, the per-joint errors averaging to the overall one.
    let json = ok(&[
        "evaluate",
        "--model",
        s(coman),
        "--data",
        s(&f.data),
        "--robot",
        "coman",
        "--json",
    ]);
    let e: serde_json::Value = serde_json::from_str(&json).unwrap();
    let per_joint: Vec<f64> = e["per_joint"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p[1].as_f64().unwrap())
        .collect();
    assert_eq!(per_joint.len(), 14);
    let mean = per_joint.iter().sum::<f64>() / 14.0;
    let mse = e["mse"].as_f64().unwrap();
    assert!((mean - mse).abs() < 1e-12 * mse.max(1.0), "{e}");
    (per_joint, mse, e["mean_pose_mse"].as_f64().unwrap())
}

/// The predictions written by `predict --std` checked independently: the test MSE recomputed
/// from them equals what `evaluate` reported, it is far below the error of predicting the mean,
/// and the standard deviations equal a dense computation from the model's parameters
/// (`√(α² − k*ᵀ (K + σ²I)⁻¹ k*) · scale`).
fn predictions_agree_with_evaluate_and_a_dense_reference(
    f: &Fixture,
    coman: &Path,
    (per_joint, mse, mean_pose): &Evaluated,
) {
    use sgplvm::robots::joint_state::read_joint_states;
    let ds = sgplvm::robots::dataset::load_demonstrations(&f.data).unwrap();
    let mcap = f.dir.join("coman.mcap");
    let predicted = read_joint_states(&mcap, "/coman/joint_command").unwrap();
    let std = read_joint_states(&mcap, "/coman/joint_command_std").unwrap();
    let desired = ds.robot("coman").unwrap();
    assert_eq!(predicted.len(), ds.len());
    assert_eq!(predicted.names, desired.joint_names);
    let d = predicted.names.len();
    let test = &ds.test;
    let mut baseline = 0.0;
    let mut train_mean_error = 0.0;
    for (j, &reported) in per_joint.iter().enumerate() {
        // The error of the mean training pose, which evaluate reports beside the model's.
        let m = ds
            .train
            .iter()
            .map(|&k| desired.positions[(k, j)])
            .sum::<f64>()
            / ds.train.len() as f64;
        train_mean_error += test
            .iter()
            .map(|&k| (desired.positions[(k, j)] - m).powi(2))
            .sum::<f64>()
            / (test.len() * d) as f64;
        let err: f64 = test
            .iter()
            .map(|&k| (predicted.row(k)[j] - desired.positions[(k, j)]).powi(2))
            .sum::<f64>()
            / test.len() as f64;
        assert!(
            (err - reported).abs() <= 1e-12 * err.max(1e-12),
            "joint {j}: {err} from the predictions, {reported} from evaluate"
        );
        let m = test.iter().map(|&k| desired.positions[(k, j)]).sum::<f64>() / test.len() as f64;
        baseline += test
            .iter()
            .map(|&k| (desired.positions[(k, j)] - m).powi(2))
            .sum::<f64>()
            / (test.len() * d) as f64;
    }
    assert!(
        (train_mean_error - mean_pose).abs() <= 1e-12 * mean_pose.max(1e-12),
        "{train_mean_error} against evaluate's {mean_pose}"
    );
    // Measured: test MSE 0.035 rad², 0.29 × the 0.12 rad² of predicting the test mean.
    assert!(*mse > 0.0 && *mse < 0.07, "test MSE {mse}");
    assert!(
        *mse < 0.5 * baseline,
        "test MSE {mse} vs {baseline} for the mean"
    );

    // The standard deviations against a dense computation from the model's parameters, on
    // the frames as predict gives them to the model (the clavicles aligned, `--girdle`).
    let model = sgplvm::SharedGplvm::load(coman).unwrap();
    let (aligned, _) =
        sgplvm::girdle::aligned_dataset(&sgplvm::AnyModel::Single(model.clone()), &ds).unwrap();
    let human = &aligned.human.positions;
    let frames: Vec<usize> = (0..ds.len()).step_by(17).collect();
    let h = sgplvm::Mat::from_fn(frames.len(), human.ncols(), |r, c| human[(frames[r], c)]);
    let xs = model.latent(h.as_ref()).unwrap();
    let x = model.latent_points();
    let k = model.kernel("coman").unwrap();
    let (_, scale) = model.normalisation("coman").unwrap();
    let kern = |a: &dyn Fn(usize) -> f64, b: &dyn Fn(usize) -> f64| {
        let r2: f64 = (0..x.ncols())
            .map(|t| ((a(t) - b(t)) / k.lengthscale[t]).powi(2))
            .sum();
        k.variance * (-0.5 * r2).exp()
    };
    let n = x.nrows();
    // nalgebra's Cholesky: another library than the model's faer.
    let kmat = nalgebra::DMatrix::from_fn(n, n, |i, j| {
        kern(&|t| x[(i, t)], &|t| x[(j, t)]) + if i == j { k.noise } else { 0.0 }
    });
    let chol = kmat.cholesky().expect("K + σ²I is positive definite");
    let mut worst = 0.0f64;
    for (r, &frame) in frames.iter().enumerate() {
        let ks = nalgebra::DVector::from_fn(n, |i, _| kern(&|t| xs[(r, t)], &|t| x[(i, t)]));
        let var = k.variance - ks.dot(&chol.solve(&ks));
        for (&sd, &sc) in std.row(frame).iter().zip(scale) {
            let want = var * sc * sc;
            worst = worst.max((sd * sd - want).abs() / (k.variance * sc * sc));
        }
    }
    // Measured 2.8e-15.
    assert!(
        worst < 3e-14,
        "std² off by {worst:e} relative to the prior variance"
    );
}

/// The lines of a CSV output that are not `#` comments.
fn csv_rows(text: &str) -> Vec<&str> {
    text.lines().filter(|l| !l.starts_with('#')).collect()
}

/// Returns the first predicted CSV row (time, then the joints).
fn predict_to_csv_and_mcap(f: &Fixture, coman: &Path) -> Vec<f64> {
    // Predict from MCAP to CSV (commands within COMAN's limits, the default) and to MCAP (the
    // model's output as it is, with its standard deviation).
    let csv = f.dir.join("coman.csv");
    let mcap = f.dir.join("coman.mcap");
    // Without the self-collision limit: the position and velocity limits alone, checked below.
    ok(&[
        "predict",
        "--model",
        s(coman),
        "--input",
        s(&f.data),
        "--robot",
        "coman",
        "--margin",
        "0",
        "--out",
        s(&csv),
    ]);
    // By default the commands are kept out of self-collision too, and stderr says how many.
    let safe = f.dir.join("coman-safe.csv");
    let said = sgplvm(&[
        "predict",
        "--model",
        s(coman),
        "--input",
        s(&f.data),
        "--robot",
        "coman",
        "--out",
        s(&safe),
    ]);
    assert!(said.status.success());
    let err = String::from_utf8_lossy(&said.stderr);
    assert!(err.contains("self-collision"), "{err}");
    assert!(!err.contains("that is most of the"), "{err}");
    // A margin the robot cannot keep holds most commands: said, with the way out.
    let held = sgplvm(&[
        "predict",
        "--model",
        s(coman),
        "--input",
        s(&f.data),
        "--robot",
        "coman",
        "--margin",
        "0.3",
        "--out",
        s(&f.dir.join("coman-held.csv")),
    ]);
    let held = String::from_utf8_lossy(&held.stderr);
    assert!(held.contains("; warning: that is most of the"), "{held}");
    // The CSV starts with its header (numpy, pandas and spreadsheets read it without options);
    // what the commands are is in the sidecar OUT.json and on stderr.
    assert!(std::fs::read_to_string(&safe)
        .unwrap()
        .starts_with("time,LShSag,"));
    assert!(err.contains("coman commands: within the robot's URDF position and velocity limits and out of self-collision"), "{err}");
    let sidecar: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(f.dir.join("coman-safe.csv.json")).unwrap())
            .unwrap();
    assert_eq!(sidecar["sgplvm.predict"]["commands"], "limited");
    assert_eq!(sidecar["sgplvm.predict"]["limits"], "position and velocity");
    assert!(sidecar["description"]
        .as_str()
        .unwrap()
        .contains("out of self-collision"));
    ok(&[
        "predict",
        "--model",
        s(coman),
        "--input",
        s(&f.data),
        "--robot",
        "coman",
        "--out",
        s(&mcap),
        "--std",
        "--raw",
    ]);
    let text = std::fs::read_to_string(&csv).unwrap();
    assert!(!text.contains('#'), "{:.200}", text);
    let sidecar = std::fs::read_to_string(f.dir.join("coman.csv.json")).unwrap();
    assert!(
        sidecar.contains("coman commands: within the robot's URDF position and velocity limits"),
        "{sidecar}"
    );
    let rows = csv_rows(&text);
    let header: Vec<&str> = rows[0].split(',').collect();
    assert_eq!(header[0], "time");
    assert_eq!(header[1], "LShSag");
    let limited: Vec<Vec<f64>> = rows[1..]
        .iter()
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    let states =
        sgplvm::robots::joint_state::read_joint_states(&mcap, "/coman/joint_command").unwrap();
    assert_eq!(states.names.len(), 14);
    assert_eq!(metadata(&mcap, "sgplvm.predict")["commands"], "raw");
    commands_within_limits(&limited, &states, "coman");
    let std =
        sgplvm::robots::joint_state::read_joint_states(&mcap, "/coman/joint_command_std").unwrap();
    assert!(std.positions.iter().all(|v| *v > 0.0));
    limited[0].clone()
}

/// The metadata record `name` of an MCAP file.
fn metadata(path: &Path, name: &str) -> std::collections::BTreeMap<String, String> {
    let mut read = sgplvm::robots::joint_state::read_topics(path, &[]).unwrap();
    read.metadata
        .remove(name)
        .unwrap_or_else(|| panic!("{}: no metadata record {name}", path.display()))
}

/// The limited commands (`time, joints…` rows) checked against the raw ones and the robot's URDF
/// by hand: every command within the position limits and within a velocity limit's step of the
/// one before; a command differs from the model's only where the model's was beyond a limit.
fn commands_within_limits(
    limited: &[Vec<f64>],
    raw: &sgplvm::robots::joint_state::JointStates,
    robot: &str,
) {
    let body = sgplvm::robots::Robot::builtin(robot).unwrap();
    let names = body.joint_names();
    let k: Vec<usize> = raw
        .names
        .iter()
        .map(|n| names.iter().position(|m| m == n).unwrap())
        .collect();
    let (position, velocity) = (body.joint_limits(), body.velocity_limits());
    assert_eq!(limited.len(), raw.len());
    let (mut moved, mut equal) = (0, 0);
    for (i, row) in limited.iter().enumerate() {
        let dt = (i > 0).then(|| row[0] - limited[i - 1][0]);
        let mut beyond = false;
        for (j, &kj) in k.iter().enumerate() {
            let (lo, hi) = position[kj];
            let (q, model) = (row[j + 1], raw.row(i)[j]);
            assert!(
                q >= lo && q <= hi,
                "frame {i} joint {}: {q} beyond [{lo}, {hi}]",
                raw.names[j]
            );
            let step = dt.map(|dt| velocity[kj] * dt + 1e-9);
            if let Some(step) = step {
                let from = limited[i - 1][j + 1];
                assert!(
                    (q - from).abs() <= step,
                    "frame {i} joint {}: a step of {}",
                    raw.names[j],
                    q - from
                );
                beyond |= (model - from).abs() > step;
            }
            beyond |= model < lo || model > hi;
        }
        let same = row[1..].iter().zip(raw.row(i)).all(|(a, b)| a == b);
        assert!(
            same || beyond,
            "frame {i} differs from the model's though it was within the limits"
        );
        if same {
            equal += 1
        } else {
            moved += 1
        }
    }
    assert!(equal > 0, "no command was the model's own");
    eprintln!(
        "{moved} of {} commands moved within {robot}'s limits",
        limited.len()
    );
}

/// Returns the human CSV file written (three frames, columns reversed).
fn predict_from_reordered_csv(f: &Fixture, coman: &Path, first: &[f64]) -> PathBuf {
    // Human frames as CSV, columns in another order, back through the model.
    let human =
        sgplvm::robots::joint_state::read_joint_states(&f.data, "/human/joint_states").unwrap();
    let mut names = human.names.clone();
    names.reverse();
    let human_csv = f.dir.join("human.csv");
    let mut w = std::fs::File::create(&human_csv).unwrap();
    writeln!(w, "{}", names.join(",")).unwrap();
    for i in 0..3 {
        let row: Vec<String> = human.row(i).iter().rev().map(|v| v.to_string()).collect();
        writeln!(w, "{}", row.join(",")).unwrap();
    }
    drop(w);
    let out = f.dir.join("from_csv.csv");
    ok(&[
        "predict",
        "--model",
        s(coman),
        "--input",
        s(&human_csv),
        "--robot",
        "coman",
        "--out",
        s(&out),
    ]);
    let text = std::fs::read_to_string(&out).unwrap();
    let row: Vec<f64> = csv_rows(&text)[1]
        .split(',')
        .map(|v| v.parse().unwrap())
        .collect();
    for (a, b) in row[1..].iter().zip(&first[1..]) {
        assert!((a - b).abs() < 1e-9, "{a} vs {b}");
    }
    human_csv
}

fn predict_streaming(coman: &Path, human_csv: &Path, first: &[f64]) {
    // Streaming on stdin: one flushed output line per input line.
    let mut child = Command::new(env!("CARGO_BIN_EXE_sgplvm"))
        .args([
            "predict",
            "--model",
            s(coman),
            "--input",
            "-",
            "--robot",
            "coman",
            "--out",
            "-",
        ])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let input = std::fs::read_to_string(human_csv).unwrap();
    child
        .stdin
        .take()
        .unwrap()
        .write_all(input.as_bytes())
        .unwrap();
    let output = child.wait_with_output().unwrap();
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let text = String::from_utf8(output.stdout).unwrap();
    assert!(text.starts_with("LShSag,"), "{text:.200}");
    let err = String::from_utf8_lossy(&output.stderr);
    assert!(
        err.contains(
            "coman commands: within the robot's URDF position limits (the input has no times"
        ),
        "{err}"
    );
    assert_eq!(csv_rows(&text).len(), 4);
    let streamed: Vec<f64> = csv_rows(&text)[1]
        .split(',')
        .map(|v| v.parse().unwrap())
        .collect();
    for (a, b) in streamed.iter().zip(&first[1..]) {
        assert!((a - b).abs() < 1e-9);
    }
}

/// A command that must fail: its exit code, and what its stderr must say.
struct Failure<'a> {
    args: Vec<&'a str>,
    code: i32,
    /// Every one of these appears in stderr.
    says: Vec<&'a str>,
    /// Stderr is a single line.
    one_line: bool,
}

/// A run that must fail with exit code 1 (an error naming `says`).
fn error<'a>(args: &[&'a str], says: &[&'a str]) -> Failure<'a> {
    Failure {
        args: args.to_vec(),
        code: 1,
        says: says.to_vec(),
        one_line: false,
    }
}

/// A run that must fail with exit code 2 (bad usage).
fn usage<'a>(args: &[&'a str]) -> Failure<'a> {
    Failure {
        args: args.to_vec(),
        code: 2,
        says: Vec::new(),
        one_line: false,
    }
}

#[test]
fn bad_inputs_fail_cleanly_and_write_nothing() {
    let f = fixture();
    let dir = scratch("bad");
    let out = dir.join("out.sgp");
    let out_s = s(&out);
    let (data, model) = (s(&f.data), s(&f.model));
    let p_csv = dir.join("p.csv");
    let p_csv = s(&p_csv);

    let corrupt = dir.join("corrupt.sgp");
    std::fs::write(&corrupt, b"SGPLVM but not really").unwrap();
    let truncated = dir.join("truncated.mcap");
    let bytes = std::fs::read(&f.data).unwrap();
    std::fs::write(&truncated, &bytes[..bytes.len() / 2]).unwrap();
    let wrong = dir.join("wrong.csv");
    std::fs::write(&wrong, "a,b,c\n1,2,3\n").unwrap();
    let nan = dir.join("nan.csv");
    let human =
        sgplvm::robots::joint_state::read_joint_states(&f.data, "/human/joint_states").unwrap();
    std::fs::write(
        &nan,
        format!("{}\n{}\n", human.names.join(","), vec!["nan"; 18].join(",")),
    )
    .unwrap();

    // One row a failure: the arguments, and what the one-line error must name.
    #[rustfmt::skip]
    let cases = [
        // Missing and corrupt files.
        error(&["train", "--data", "/nonexistent/demo.mcap", "--robot", "walkman", "--out", out_s],
              &["/nonexistent/demo.mcap"]),
        Failure {
            one_line: true,
            ..error(&["evaluate", "--model", s(&corrupt), "--data", data, "--robot", "walkman"],
                    &["corrupt.sgp"])
        },
        error(&["train", "--data", s(&truncated), "--robot", "walkman", "--out", out_s],
              &["truncated.mcap"]),
        // Unknown robots.
        error(&["train", "--data", data, "--robot", "r2d2", "--out", out_s],
              &["r2d2", "walkman"]),
        // A replay for Foxglove is MCAP only.
        error(&["simulate", "--model", model, "--input", data, "--robot", "walkman", "--out", p_csv],
              &[p_csv, "expected a name ending in .mcap"]),
        error(&["predict", "--model", model, "--input", data, "--robot", "coman", "--out", p_csv],
              &["coman"]),
        // Model and data with different joints.
        error(&["predict", "--model", model, "--input", s(&wrong), "--robot", "walkman", "--out", p_csv],
              &["wrong.csv", "none of the model's 18 human joint columns is there", "and 13 more",
                "the file has 3 columns: \"a\", \"b\", \"c\""]),
        error(&["predict", "--model", model, "--input", s(&nan), "--robot", "walkman", "--out", p_csv],
              &["nan.csv", "line 2"]),
        // The limits of the commands come from a URDF that must be there and be the robot's.
        error(&["predict", "--model", model, "--input", data, "--robot", "walkman", "--out", p_csv,
                "--urdf", "/nonexistent/walkman.urdf"],
              &["/nonexistent/walkman.urdf"]),
        error(&["predict", "--model", model, "--input", data, "--robot", "walkman", "--out", p_csv,
                "--urdf", concat!(env!("CARGO_MANIFEST_DIR"), "/data/urdf/ur5e.urdf")],
              &["walkman joints", "not a movable joint", "LShSag"]),
        // Bad flag values are usage errors (exit 2).
        usage(&["train", "--robot", "walkman", "--latent-dim", "0", "--out", out_s]),
        usage(&["train", "--robot", "walkman", "--back-constraint", "sideways", "--out", out_s]),
        usage(&["train", "--robot", "walkman", "--max-iters", "-3", "--out", out_s]),
        usage(&["train", "--robot", "walkman", "--validation", "sideways", "--out", out_s]),
        usage(&["train", "--robot", "walkman", "--patience", "-1", "--out", out_s]),
        usage(&["frobnicate"]),
        // A latent dimension the data cannot support.
        error(&["train", "--data", data, "--robot", "walkman", "--latent-dim", "100000", "--out", out_s],
              &["latent dimension"]),
        // Generating for an unknown robot names the known ones; a robot twice is refused.
        Failure {
            says: vec!["asimo", "walkman, coman, centauro, ur5e"],
            ..usage(&["generate", "--robots", "walkman,asimo", "--file", "g.mcap", "--out", s(&dir)])
        },
        error(&["generate", "--robots", "coman,ur5e,coman", "--file", "g.mcap", "--out", s(&dir)],
              &["coman", "twice"]),
        // Test pairs: paper, all or a count that exists.
        Failure {
            says: vec!["--test-pairs", "paper, all or a number from 1 to 210"],
            ..usage(&["generate", "--test-pairs", "211", "--file", "g.mcap", "--out", s(&dir)])
        },
    ];
    for case in &cases {
        let err = fails(&case.args, case.code);
        for says in &case.says {
            assert!(err.contains(says), "sgplvm {:?}: {err}", case.args);
        }
        if case.one_line {
            assert!(err.lines().count() == 1, "sgplvm {:?}: {err}", case.args);
        }
    }

    let leftovers: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| {
            !["corrupt.sgp", "truncated.mcap", "wrong.csv", "nan.csv"].contains(&n.as_str())
        })
        .collect();
    assert!(
        leftovers.is_empty(),
        "output files left behind: {leftovers:?}"
    );
}

/// Every error line says each fact once (issue 38): a file name appears once, and lists of
/// names are cut to the first few and a count.
#[test]
fn errors_name_each_file_once_and_cut_long_lists() {
    let f = fixture();
    let dir = scratch("once");
    let (data, model) = (s(&f.data), s(&f.model));
    let nosuch = dir.join("nosuch.sgp");
    let folder = dir.join("a-folder.sgp");
    std::fs::create_dir_all(&folder).unwrap();
    let out = dir.join("p.csv");
    // A CSV with 5 of the human's 18 joints, and a robot trajectory with two of its own.
    let human =
        sgplvm::robots::joint_state::read_joint_states(&f.data, "/human/joint_states").unwrap();
    let five = dir.join("five.csv");
    std::fs::write(
        &five,
        format!("{}\n{}\n", human.names[..5].join(","), ["0.1"; 5].join(",")),
    )
    .unwrap();
    let stranger = dir.join("stranger.csv");
    std::fs::write(&stranger, "time,LShSag,elbow,knee\n0,0,0,0\n0.5,0,0,0\n").unwrap();
    let replay = dir.join("no-such-folder").join("replay.mcap");
    let human_csv = human_test_csv(f);
    // A file where the output folder should go: refused before any training.
    let taken = dir.join("taken-name");
    std::fs::write(&taken, "").unwrap();
    let cases: Vec<(Vec<&str>, &str, Vec<&str>)> = vec![
        (
            vec!["experiment", "--data", data, "--out", s(&taken)],
            "taken-name",
            vec!["cannot create the output folder"],
        ),
        (
            vec!["demo", "--data", data, "--out", s(&taken)],
            "taken-name",
            vec!["cannot create the output folder"],
        ),
        (
            vec!["predict", "--model", s(&nosuch), "--input", data, "--robot", "walkman", "--out", s(&out)],
            "nosuch.sgp",
            vec!["No such file"],
        ),
        (
            vec!["joints", "--model", s(&folder)],
            "a-folder.sgp",
            vec!["model file"],
        ),
        (
            vec!["predict", "--model", model, "--input", s(&five), "--robot", "walkman", "--out", s(&out)],
            "five.csv",
            vec!["13 of the model's 18 human joint columns are missing: ", "and 8 more", "the file has 5 columns"],
        ),
        (
            vec!["simulate", "--robot", "walkman", "--trajectory", s(&stranger)],
            "stranger.csv",
            vec!["2 columns of the trajectory name no movable joint of builtin:walkman: \"elbow\", \"knee\"", "its 14 movable joints: ", "and 9 more"],
        ),
        (
            vec!["simulate", "--model", model, "--input", s(&human_csv), "--robot", "walkman", "--out", s(&replay)],
            "replay.mcap",
            vec!["cannot write the replay"],
        ),
    ];
    for (args, file, says) in cases {
        let err = fails_on_one_line(&args);
        assert_eq!(err.matches(file).count(), 1, "{file} not named once: {err}");
        for s in says {
            assert!(err.contains(s), "sgplvm {args:?}: {err}");
        }
        // Short, whatever the length of the scratch folder's path.
        let text = err.replace(s(&dir), "DIR");
        assert!(text.len() < 400, "{} bytes: {text}", text.len());
    }
}

#[test]
fn generate_records_the_chosen_robots() {
    let dir = scratch("generate");
    let stdout = ok(&[
        "generate",
        "--robots",
        "ur5e,coman",
        "--file",
        "two.mcap",
        "--subsample",
        "24",
        "--out",
        s(&dir),
    ]);
    assert!(stdout.contains("robots ur5e, coman"), "{stdout}");
    let data = sgplvm::robots::dataset::load_demonstrations(dir.join("two.mcap")).unwrap();
    assert_eq!(data.robot_names(), ["ur5e", "coman"]);
    assert_eq!(data.robot("ur5e").unwrap().positions.ncols(), 12);
    assert_eq!(data.human.positions.ncols(), 18);
    // The human's data does not depend on the robots recorded.
    let three = sgplvm::robots::dataset::load_demonstrations(&fixture().data).unwrap();
    assert_eq!(data.human.positions, three.human.positions);
    assert_eq!(data.robot("coman"), three.robot("coman"));
    // A richer test set: the training frames are the paper protocol's, the test frames more.
    let stdout = ok(&[
        "generate",
        "--test-pairs",
        "12",
        "--seed",
        "0",
        "--subsample",
        "24",
        "--file",
        "rich.mcap",
        "--out",
        s(&dir),
    ]);
    assert!(stdout.contains("test"), "{stdout}");
    let rich = sgplvm::robots::dataset::load_demonstrations(dir.join("rich.mcap")).unwrap();
    let rows = |d: &sgplvm::robots::dataset::Dataset, idx: &[usize]| -> Vec<Vec<f64>> {
        idx.iter()
            .map(|&i| (0..18).map(|j| d.human.positions[(i, j)]).collect())
            .collect()
    };
    assert_eq!(rows(&rich, &rich.train), rows(&three, &three.train));
    assert!(
        rich.test.len() > 5 * three.test.len(),
        "{} test frames",
        rich.test.len()
    );
}

#[test]
fn simulate_a_prediction() {
    let f = fixture();
    let dir = scratch("simulate-model");
    let (predicted, replay) = (dir.join("predicted.mcap"), dir.join("replay.mcap"));
    let json = ok(&[
        "simulate",
        "--model",
        s(&f.model),
        "--input",
        s(&f.data),
        "--robot",
        "walkman",
        "--json",
        "--out",
        s(&replay),
    ]);
    let report: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert_eq!(report["joints"].as_array().unwrap().len(), 14);
    assert!(report["physics_steps"].as_u64().unwrap() > 1000);
    // What is replayed is what `predict` sends: the same commands, to the last bit (within the
    // limits and kept out of self-collision; until 2026-12-07 the self-collision step was left
    // out, and a published humanoid's replay diverged where predict's own output did not).
    ok(&[
        "predict",
        "--model",
        s(&f.model),
        "--input",
        s(&f.data),
        "--robot",
        "walkman",
        "--no-tf",
        "--out",
        s(&predicted),
    ]);
    let read = |p: &Path| {
        sgplvm::robots::joint_state::read_joint_states(p, "/walkman/joint_command").unwrap()
    };
    let (sent, replayed) = (read(&predicted), read(&replay));
    assert_eq!(sent.names, replayed.names);
    assert_eq!(sent.positions, replayed.positions);
    // A URDF and no --robot: the model's only robot, whatever the URDF calls itself (it said
    // the model did not know robot 'robot' until 2026-12-07).
    let renamed = dir.join("renamed.urdf");
    let walkman = std::fs::read_to_string("data/urdf/walkman.urdf").unwrap();
    let xml = walkman.replacen(r#"<robot name="walkman""#, r#"<robot name="renamed""#, 1);
    assert_ne!(xml, walkman);
    std::fs::write(&renamed, xml).unwrap();
    let json = ok(&[
        "simulate",
        "--model",
        s(&f.model),
        "--input",
        s(&f.data),
        "--urdf",
        s(&renamed),
        "--json",
    ]);
    let report: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert_eq!(report["joints"].as_array().unwrap().len(), 14);
    let err = fails(
        &[
            "simulate",
            "--robot",
            "walkman",
            "--trajectory",
            "/nonexistent.csv",
        ],
        1,
    );
    assert!(err.contains("/nonexistent.csv"), "{err}");
}

/// `experiment`'s yardstick of retargeting each frame directly: every robot's retargeted test
/// frames against the person, and every run of the paper's model beside them, in results.json
/// and report.md.
fn retargeting_beside_every_run(results: &serde_json::Value, report: &Path) {
    let retargeted = results["retargeting"]["retargeted"].as_array().unwrap();
    assert_eq!(retargeted.len(), 3, "{retargeted:?}");
    for run in results["runs"].as_array().unwrap() {
        if run.get("bayesian").is_some() {
            continue;
        }
        let median = run["arms_from_person"]["upper_arm_median_deg"]
            .as_f64()
            .unwrap();
        assert!(median.is_finite() && median >= 0.0, "{run}");
    }
    let report = std::fs::read_to_string(report).unwrap();
    assert!(
        report.contains("## The learned mapping against retargeting each frame directly")
            && report.contains("| coman, retargeted |"),
        "{report}"
    );
}

#[test]
fn experiment_writes_results_in_the_documented_schema() {
    let f = fixture();
    let out = f.dir.join("experiment");
    let run = sgplvm(&[
        "experiment",
        "--quick",
        "--runs",
        "1",
        "--max-iters",
        "3",
        "--data",
        s(&f.data),
        "--out",
        s(&out),
    ]);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}");
    // stderr is not a terminal here: one progress line per group of runs, no bar.
    assert!(
        stderr.contains("baselines, input BC: 3/3 trainings, ") && stderr.contains(" ETA "),
        "{stderr}"
    );
    assert!(!stderr.contains("[="), "{stderr}");
    let results: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
    assert_eq!(
        results["robots"],
        serde_json::json!(["walkman", "coman", "centauro"])
    );
    let runs = results["runs"].as_array().unwrap();
    let mut kinds = std::collections::BTreeSet::new();
    for run in runs {
        for key in [
            "robot",
            "model",
            "back_constraint",
            "run",
            "iterations",
            "seconds",
            "test_mse",
        ] {
            assert!(run.get(key).is_some(), "run without {key}: {run}");
        }
        let n = run["iterations"].as_array().unwrap().len();
        assert!(n >= 1);
        for key in ["iteration", "seconds", "test_mse"] {
            assert!(
                run["shipped"][key].is_number(),
                "shipped without {key}: {run}"
            );
        }
        assert_eq!(run["seconds"].as_array().unwrap().len(), n);
        assert_eq!(run["test_mse"].as_array().unwrap().len(), n);
        kinds.insert((
            run["model"].as_str().unwrap().to_string(),
            run["back_constraint"].as_str().unwrap().to_string(),
        ));
    }
    for (model, bc) in [
        ("baseline", "none"),
        ("transfer", "none"),
        ("multi", "none"),
        ("baseline", "input"),
        ("transfer", "input"),
        ("multi", "input"),
        ("baseline", "output"),
    ] {
        assert!(
            kinds.contains(&(model.to_string(), bc.to_string())),
            "missing {model}/{bc}"
        );
    }
    // The yardstick: one direct GP regression per robot.
    let direct = results["direct_regression"].as_array().unwrap();
    assert_eq!(direct.len(), 3);
    for d in direct {
        assert!(d["test_mse"].as_f64().unwrap() > 0.0, "{d}");
    }
    retargeting_beside_every_run(&results, &out.join("report.md"));
    for file in [
        "fig4.svg",
        "fig4.png",
        "fig5.svg",
        "fig5_seconds.png",
        "fig6.png",
        "report.md",
    ] {
        assert!(out.join(file).exists(), "missing {file}");
    }
    // `experiment --help` names every file the command wrote, and the summary every figure.
    let help = ok(&["experiment", "--help"]);
    let summary = ok(&["--help"]);
    let mut figures = std::collections::BTreeSet::new();
    for entry in std::fs::read_dir(&out).unwrap() {
        let name = entry.unwrap().file_name().to_string_lossy().into_owned();
        let stem = name.split('.').next().unwrap().to_string();
        assert!(
            help.contains(&stem),
            "`experiment --help` does not name {name}:\n{help}"
        );
        if let Some(number) = stem.strip_prefix("fig") {
            figures.insert(number.trim_end_matches("_seconds").to_string());
        }
    }
    assert_eq!(figures.len(), 5, "{figures:?}");
    let line = summary
        .lines()
        .find(|l| l.trim_start().starts_with("experiment "))
        .unwrap();
    assert!(
        line.contains("Figs. 4-6, 9 and 10 (and 11 with --all-frames, 12 with --bayesian)"),
        "{line}"
    );
    // `--from-results` redraws the same figures and report from results.json, training nothing;
    // a file that is not one is refused, naming it, and nothing is written.
    let again = f.dir.join("experiment-again");
    let results_json = out.join("results.json");
    ok(&[
        "experiment",
        "--from-results",
        s(&results_json),
        "--out",
        s(&again),
    ]);
    for name in ["fig6.svg", "fig10.svg", "report.md", "results.json"] {
        assert_eq!(
            std::fs::read(out.join(name)).unwrap(),
            std::fs::read(again.join(name)).unwrap(),
            "{name} differs when redrawn"
        );
    }
    let not_results = f.dir.join("not-results");
    let e = sgplvm(&[
        "experiment",
        "--from-results",
        s(&f.data),
        "--out",
        s(&not_results),
    ]);
    let stderr = String::from_utf8_lossy(&e.stderr);
    assert!(!e.status.success() && !not_results.exists());
    assert!(
        stderr.contains(&format!("{}: not the results.json", f.data.display())),
        "{stderr}"
    );
}

/// `experiment --all-frames`: beside the subsampled exact baselines, per robot one sparse
/// model on every full-rate training frame, finite, in results.json and report.md; the same
/// seed gives the same records (the measured seconds aside).
#[test]
fn experiment_all_frames_reports_the_sparse_model_beside_the_exact_one() {
    let dir = scratch("all-frames");
    // One repetition, every 12th frame: 83 training frames of 996 at full rate.
    ok(&[
        "generate",
        "--out",
        s(&dir),
        "--subsample",
        "12",
        "--repetitions",
        "1",
    ]);
    let data = dir.join("bimanual.mcap");
    let run = |out: &str| -> serde_json::Value {
        let out = dir.join(out);
        ok(&[
            "experiment",
            "--quick",
            "--runs",
            "1",
            "--max-iters",
            "3",
            "--all-frames",
            "--inducing",
            "20",
            "--data",
            s(&data),
            "--out",
            s(&out),
        ]);
        assert!(out.join("fig11.svg").exists() && out.join("fig11.png").exists());
        assert!(ok(&["experiment", "--help"]).contains("with --all-frames, fig11"));
        let report = std::fs::read_to_string(out.join("report.md")).unwrap();
        assert!(
            report.contains("**Does using all the data help?**") && report.contains("(996 frames)"),
            "{report}"
        );
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap()
    };
    let first = run("a");
    assert_eq!(first["config"]["inducing"], 20);
    let records = first["all_frames"].as_array().unwrap();
    // Per robot the control (the sparse model on the 83 subsampled frames), then all 996.
    let robots: Vec<(&str, u64)> = records
        .iter()
        .map(|r| (r["robot"].as_str().unwrap(), r["frames"].as_u64().unwrap()))
        .collect();
    assert_eq!(
        robots,
        [
            ("walkman", 83),
            ("coman", 83),
            ("centauro", 83),
            ("walkman", 996),
            ("coman", 996),
            ("centauro", 996)
        ]
    );
    for r in records {
        assert_eq!(r["back_constraint"], "input", "{r}");
        assert_eq!(r["full_rate"], r["frames"] == 996, "{r}");
        assert_eq!(r["subsampled_frames"], 83, "{r}");
        let mse = r["test_mse"].as_f64().unwrap();
        assert!(mse.is_finite() && mse > 0.0, "{r}");
        assert!(r["seconds"].as_f64().unwrap().is_finite(), "{r}");
        assert!(r["stop_reason"].is_string(), "{r}");
    }
    // Every run records why its training stopped.
    for r in first["runs"].as_array().unwrap() {
        assert!(r["stop_reason"].is_string(), "{r}");
    }
    let without_seconds = |v: &serde_json::Value| {
        let mut records = v["all_frames"].clone();
        for r in records.as_array_mut().unwrap() {
            r.as_object_mut().unwrap().remove("seconds");
        }
        records
    };
    assert_eq!(without_seconds(&run("b")), without_seconds(&first));
    // An M larger than the control's training frames is refused before anything is trained.
    let err = fails_on_one_line(&[
        "experiment",
        "--quick",
        "--all-frames",
        "--inducing",
        "1000",
        "--data",
        s(&data),
        "--out",
        s(&dir.join("c")),
    ]);
    assert!(
        err.contains("1000 inducing inputs") && err.contains("expected at most"),
        "{err}"
    );
    assert!(!dir.join("c").join("results.json").exists());
    // --inducing belongs to --all-frames.
    let err = fails(&["experiment", "--inducing", "20", "--data", s(&data)], 2);
    assert!(err.contains("--all-frames"), "{err}");
}

#[test]
fn messages_say_what_happened() {
    let f = fixture();
    let dir = scratch("messages");
    let (data, model) = (s(&f.data), s(&f.model));
    // A robot the model does not know: named, with the robots it knows.
    let err = fails_on_one_line(&[
        "evaluate", "--model", model, "--data", data, "--robot", "coman",
    ]);
    assert!(
        err.contains("does not know robot 'coman'") && err.contains("[\"walkman\"]"),
        "{err}"
    );
    // A transfer says only the new robot's kernel was trained, on whose latent space.
    let coman = dir.join("coman.sgp");
    let args = [
        "transfer",
        "--model",
        model,
        "--data",
        data,
        "--robot",
        "coman",
        "--max-iters",
        "5",
        "--out",
        s(&coman),
    ];
    let said = ok(&args);
    assert!(
        said.starts_with(
            "transferred to coman (its kernel only; shared latent space from walkman) in "
        ),
        "{said}"
    );
    assert!(!said.contains("trained walkman + coman"), "{said}");
    // Transferring to a robot the model already has.
    let err = fails_on_one_line(&[
        "transfer",
        "--model",
        s(&coman),
        "--data",
        data,
        "--robot",
        "coman",
        "--out",
        s(&dir.join("again.sgp")),
    ]);
    assert!(err.contains("already predicts for 'coman'"), "{err}");
    // A budget chosen on held-out frames is said in words (issue 38), not as the caller's
    // `MaxIterations`; --json gives the stop reason's name, as results.json and Python do.
    let trained = dir.join("validated.sgp");
    let args = [
        "train",
        "--data",
        data,
        "--robot",
        "walkman",
        "--out",
        s(&trained),
    ];
    let said = ok(&args);
    let lines: Vec<&str> = said.lines().collect();
    // A budget of fewer than 5 iterations gets a third line saying what it means.
    let budget: usize = lines[1]
        .trim_start_matches("  validated budget: ")
        .split(' ')
        .next()
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("{said}"));
    assert_eq!(lines.len(), if budget < 5 { 3 } else { 2 }, "{said}");
    assert_eq!(
        lines.get(2).is_some_and(|l| l.starts_with("  note: ")
            && l.contains("predicted the held-out training motions best")),
        budget < 5,
        "{said}"
    );
    assert!(
        lines[1].starts_with("  validated budget: ")
            && lines[1].contains("held-out training frames")
            && lines[1].contains("until their error had not fallen for 50 iterations")
            && lines[1].contains("then retrained on all "),
        "{said}"
    );
    assert!(
        !said.contains("MaxIterations") && !said.contains("budget used up"),
        "{said}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&ok(&[&args[..], &["--json"]].concat())).unwrap();
    assert_eq!(json["stop_reason"], "validated_budget", "{json}");
    // Trained to a fixed budget, the first line says that budget ran out.
    let said = ok(&[&args[..], &["--validation", "none", "--max-iters", "3"]].concat());
    assert!(
        said.contains(" (iteration budget used up); wrote "),
        "{said}"
    );
    // A missing folder: the error names the user's path, not a temporary file.
    let missing = dir.join("no-such-folder").join("x.sgp");
    let err = fails_on_one_line(&[
        "train",
        "--data",
        data,
        "--robot",
        "walkman",
        "--max-iters",
        "2",
        "--out",
        s(&missing),
    ]);
    assert!(err.contains(s(&missing)) && !err.contains(".tmp"), "{err}");
}

/// Runs `sgplvm args…` with its stdout closed before it writes anything: the command must end
/// quietly with exit code 0.
fn closed_stdout_ends_quietly(args: &[&str]) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_sgplvm"))
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "sgplvm {args:?}: {stderr}");
    assert!(
        !stderr.contains("panicked") && !stderr.contains("error"),
        "sgplvm {args:?}: {stderr}"
    );
}

#[test]
fn a_closed_stdout_pipe_ends_quietly() {
    let f = fixture();
    let (data, model) = (s(&f.data), s(&f.model));
    // Printed with println! (a table), and written through an io::Write (a CSV to stdout).
    closed_stdout_ends_quietly(&[
        "evaluate", "--model", model, "--data", data, "--robot", "walkman",
    ]);
    closed_stdout_ends_quietly(&[
        "predict", "--model", model, "--input", data, "--robot", "walkman", "--out", "-",
    ]);
    let human = human_test_csv(f);
    closed_stdout_ends_quietly(&[
        "simulate",
        "--model",
        model,
        "--input",
        s(&human),
        "--robot",
        "walkman",
    ]);
}

#[test]
fn simulate_prints_a_summary_and_details_on_request() {
    let f = fixture();
    let human = human_test_csv(f);
    // The model's raw output (beyond the robot's limits, as `simulate --model` no longer sends
    // it): a trajectory with many limit events to summarise.
    let raw = f.dir.join("raw-prediction.csv");
    ok(&[
        "predict",
        "--model",
        s(&f.model),
        "--input",
        s(&human),
        "--robot",
        "walkman",
        "--raw",
        "--out",
        s(&raw),
    ]);
    let args = ["simulate", "--trajectory", s(&raw), "--robot", "walkman"];
    let summary = ok(&args);
    let verbose = ok(&[&args[..], &["--verbose"]].concat());
    // One line per joint and a few per kind of event, whatever the number of intervals.
    assert!(summary.lines().count() < 40, "{summary}");
    assert!(
        summary.contains("over limit") && summary.contains("too fast"),
        "{summary}"
    );
    for joint in ["LShSag", "RWrj2"] {
        assert!(summary.contains(joint), "{summary}");
    }
    let intervals = summary
        .lines()
        .find_map(|l| {
            l.strip_suffix(
                " intervals in all: every one with --verbose, the whole report with --json",
            )
        })
        .map(|n| n.trim().parse::<usize>().unwrap());
    let report: serde_json::Value =
        serde_json::from_str(&ok(&[&args[..], &["--json"]].concat())).unwrap();
    let in_json: usize = ["limit_violations", "velocity_violations", "collisions"]
        .iter()
        .map(|k| report[k].as_array().unwrap().len())
        .sum();
    assert_eq!(intervals.unwrap_or(0), in_json, "{summary}");
    // More intervals than the summary lists: it shows the worst of each kind and groups the
    // rest.
    let listed = summary
        .lines()
        .filter(|l| l.contains('–') && l.contains(" s "))
        .count();
    assert!(
        in_json > 10 && (1..in_json).contains(&listed),
        "{in_json} intervals, {listed} listed: {summary}"
    );
    // --verbose lists each interval on a line of its own.
    assert!(
        verbose.lines().count() >= summary.lines().count() + in_json.saturating_sub(10),
        "{verbose}"
    );
}

/// `simulate --package-path`: a URDF whose collision mesh is `package://…` (an STL cube
/// written here) simulates it as a convex hull; without the package path the summary says the
/// mesh could not be checked and how to give it; `--out` names the mesh by its file:// URI.
#[test]
fn simulate_finds_collision_meshes_through_package_paths() {
    let dir = scratch("simulate-meshes");
    let mesh = dir.join("share/sgplvm_cli_meshes/meshes/cube.stl");
    std::fs::create_dir_all(mesh.parent().unwrap()).unwrap();
    let mut stl = String::from("solid cube\n");
    for (a, b, c) in [
        (0, 1, 2),
        (0, 1, 4),
        (0, 2, 4),
        (7, 6, 5),
        (7, 6, 3),
        (7, 5, 3),
    ] {
        let v = |i: i32| format!("vertex {} {} {}\n", i & 1, (i >> 1) & 1, (i >> 2) & 1);
        stl += &format!(
            "facet normal 0 0 0\nouter loop\n{}{}{}endloop\nendfacet\n",
            v(a),
            v(b),
            v(c)
        );
    }
    stl += "endsolid cube\n";
    std::fs::write(&mesh, stl).unwrap();
    let urdf = dir.join("robot/meshy.urdf");
    std::fs::create_dir_all(urdf.parent().unwrap()).unwrap();
    let inertial = r#"<inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>"#;
    std::fs::write(
        &urdf,
        format!(
            r#"<robot name="meshy">
  <link name="base">{inertial}<collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision></link>
  <link name="arm">{inertial}<collision><geometry>
    <mesh filename="package://sgplvm_cli_meshes/meshes/cube.stl" scale="0.1 0.1 0.1"/></geometry></collision></link>
  <joint name="j" type="revolute"><parent link="base"/><child link="arm"/><origin xyz="0.5 0 0"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="10" velocity="3"/></joint>
</robot>"#
        ),
    )
    .unwrap();
    let trajectory = dir.join("hold.csv");
    std::fs::write(&trajectory, "time,j\n0,0\n0.1,0\n").unwrap();
    let out = dir.join("replay.mcap");
    let args = [
        "simulate",
        "--urdf",
        s(&urdf),
        "--trajectory",
        s(&trajectory),
    ];
    let found = ok(&[
        &args[..],
        &["--package-path", s(&dir.join("share")), "--out", s(&out)],
    ]
    .concat());
    assert!(
        found.contains("collision meshes: 1 simulated as convex hulls"),
        "{found}"
    );
    assert!(
        found.contains("no self-collisions among the 2 collision shapes checked\n"),
        "{found}"
    );
    // The replay's topics are named after the URDF's robot (`<robot name="meshy">`).
    let uri = format!("file://{}", s(&mesh.canonicalize().unwrap()));
    let bytes = std::fs::read(&out).unwrap();
    let description = mcap::MessageStream::new(&bytes)
        .unwrap()
        .map(|m| m.unwrap())
        .find(|m| m.channel.topic == "/meshy/robot_description")
        .expect("a robot description");
    let description = String::from_utf8_lossy(&description.data);
    assert!(description.contains(&uri), "no {uri} in {description}");
    let missing = ok(&args);
    assert!(
        missing.contains(
            "no self-collisions among the 1 collision shape checked; 1 collision mesh of link \"arm\" could not be checked (not found)"
        ),
        "{missing}"
    );
    assert!(missing.contains("--package-path DIR"), "{missing}");
    let typo = dir.join("shar");
    let err = fails_on_one_line(&[&args[..], &["--package-path", s(&typo)]].concat());
    assert!(err.contains("shar: no such folder"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn predict_std_output_replays_in_simulate() {
    let f = fixture();
    let human = human_test_csv(f);
    let dir = scratch("std-round-trip");
    for file in ["walkman.csv", "walkman.mcap"] {
        let out = dir.join(file);
        ok(&[
            "predict",
            "--model",
            s(&f.model),
            "--input",
            s(&human),
            "--robot",
            "walkman",
            "--out",
            s(&out),
            "--std",
        ]);
        let replay = |extra: &[&str]| -> serde_json::Value {
            let args = [
                &[
                    "simulate",
                    "--robot",
                    "walkman",
                    "--trajectory",
                    s(&out),
                    "--json",
                ],
                extra,
            ]
            .concat();
            serde_json::from_str(&ok(&args)).unwrap()
        };
        let report = replay(&[]);
        // The 14 joints, not their standard deviations.
        let joints = report["joints"].as_array().unwrap();
        assert_eq!(joints.len(), 14, "{file}: {joints:?}");
        assert!(joints
            .iter()
            .all(|j| !j["name"].as_str().unwrap().ends_with("_std")));
        if file.ends_with(".mcap") {
            // The same replay as naming the command topic.
            let named = replay(&["--topic", "/walkman/joint_command"]);
            assert_eq!(named["joints"], report["joints"]);
        }
    }
}

#[test]
fn export_and_joints_make_the_inputs_of_predict() {
    let f = fixture();
    let dir = scratch("export");
    // The human's joint names, in the columns' order.
    let listed = ok(&["joints", "human"]);
    let names: Vec<&str> = listed
        .trim()
        .strip_prefix("human: ")
        .unwrap()
        .split(',')
        .collect();
    assert_eq!(names.len(), 18, "{listed}");
    let model_joints = ok(&["joints", "--model", s(&f.model)]);
    assert!(model_joints.starts_with(listed.trim()), "{model_joints}");
    for file in ["human.csv", "human.mcap"] {
        let human = dir.join(file);
        ok(&[
            "export",
            "--demos",
            s(&f.data),
            "--body",
            "human",
            "--out",
            s(&human),
        ]);
        let out = dir.join(format!("{file}.out.csv"));
        ok(&[
            "predict",
            "--model",
            s(&f.model),
            "--input",
            s(&human),
            "--robot",
            "walkman",
            "--out",
            s(&out),
        ]);
        let predicted = std::fs::read_to_string(&out).unwrap();
        let test_frames = sgplvm::robots::dataset::load_demonstrations(&f.data)
            .unwrap()
            .test
            .len();
        assert_eq!(csv_rows(&predicted).len(), test_frames + 1, "{file}");
        if file.ends_with(".csv") {
            let csv = std::fs::read_to_string(&human).unwrap();
            assert_eq!(
                csv.lines().next().unwrap(),
                format!("time,{}", names.join(","))
            );
            // Times from the first frame written.
            assert!(
                csv.lines().nth(1).unwrap().starts_with("0,")
                    || csv.lines().nth(1).unwrap().starts_with("0.0,"),
                "{csv:.200}"
            );
        }
    }
    let err = fails_on_one_line(&[
        "export",
        "--data",
        s(&f.data),
        "--body",
        "r2d2",
        "--out",
        s(&dir.join("x.csv")),
    ]);
    assert!(err.contains("r2d2") && err.contains("walkman"), "{err}");
    assert!(!dir.join("x.csv").exists());
}

#[test]
fn the_demo_reports_progress_in_a_log_and_lists_its_models() {
    let f = fixture();
    let out = scratch("demo");
    let run = sgplvm(&[
        "demo",
        "--data",
        s(&f.data),
        "--max-iters",
        "5",
        "--out",
        s(&out),
    ]);
    let (stdout, stderr) = (
        String::from_utf8_lossy(&run.stdout),
        String::from_utf8_lossy(&run.stderr),
    );
    assert!(run.status.success(), "{stderr}");
    // stderr is not a terminal here: one line per step with an estimate of the time left.
    assert!(
        stderr.contains("demo: walkman full trained (1/9 steps, "),
        "{stderr}"
    );
    assert!(
        stderr.contains("demo: figures (9/9 steps, ") && stderr.contains(" ETA "),
        "{stderr}"
    );
    // The closing list names the model files it wrote, and they exist.
    for model in [
        "walkman.sgp",
        "walkman_to_coman.sgp",
        "walkman_to_centauro.sgp",
    ] {
        let path = out.join(model);
        assert!(stdout.contains(s(&path)), "{stdout}");
        assert!(path.exists(), "{model}");
    }
    // Figs. 7 and 8 read on a laptop screen: at least 1,000 pixels wide, SVG and PNG alike;
    // Fig. 8 has a column per test motion (two in the fixture's data) and a legend column.
    for (stem, min_width) in [("latent_space", 1000), ("coman_trajectories", 1000)] {
        let png = std::fs::read(out.join(format!("{stem}.png"))).unwrap();
        let png_size = (
            u32::from_be_bytes(png[16..20].try_into().unwrap()),
            u32::from_be_bytes(png[20..24].try_into().unwrap()),
        );
        let svg = std::fs::read_to_string(out.join(format!("{stem}.svg"))).unwrap();
        let svg_size = format!("width=\"{}\" height=\"{}\"", png_size.0, png_size.1);
        assert!(
            svg.contains(&svg_size),
            "{stem}: {svg_size} {}",
            &svg[..200]
        );
        assert!(png_size.0 >= min_width, "{stem}: {png_size:?}");
    }
    let fig8 = std::fs::read_to_string(out.join("coman_trajectories.svg")).unwrap();
    for motion in ["forward_high ↔ hands_together", "v_up ↔ left_across"] {
        assert!(fig8.contains(motion), "Fig. 8 does not show {motion}");
    }
    // The test frames as each model predicts them, with predict's Foxglove topics.
    let test_frames = sgplvm::robots::dataset::load_demonstrations(&f.data)
        .unwrap()
        .test
        .len();
    for (file, robot) in [
        ("walkman_test.mcap", "walkman"),
        ("walkman_to_coman_test.mcap", "coman"),
        ("walkman_to_centauro_test.mcap", "centauro"),
    ] {
        let path = out.join(file);
        assert!(stdout.contains(s(&path)), "{stdout}");
        let mut topics: Vec<String> = sgplvm::robots::joint_state::list_channels(&path)
            .unwrap()
            .into_iter()
            .map(|c| c.topic)
            .collect();
        topics.sort();
        let mut expected: Vec<String> = [
            "/human/joint_states",
            "/human/robot_description",
            "/latent",
            "/tf",
            "/tf_static",
        ]
        .iter()
        .map(|t| t.to_string())
        .chain(
            ["joint_command", "prediction_std", "robot_description"]
                .iter()
                .map(|t| format!("/{robot}/{t}")),
        )
        .collect();
        expected.sort();
        assert_eq!(topics, expected, "{file}");
        let command = sgplvm::robots::joint_state::read_joint_states(
            &path,
            &format!("/{robot}/joint_command"),
        )
        .unwrap();
        assert_eq!(command.times_ns.len(), test_frames, "{file}");
    }
}

#[test]
fn longer_sessions_and_the_sparse_model_on_every_frame() {
    // `--repetitions` makes longer sessions of the same protocol; `--inducing` trains the
    // sparse model on them, a transfer of it is sparse too, and both files say so.
    let dir = scratch("sparse");
    let frames = |stdout: &str| -> usize {
        let (_, after) = stdout.split_once("frames (").expect("frame counts");
        after
            .split(' ')
            .next()
            .expect("count")
            .parse()
            .expect("a number")
    };
    let short = ok(&[
        "generate",
        "--out",
        s(&dir),
        "--subsample",
        "24",
        "--file",
        "short.mcap",
    ]);
    let long = ok(&[
        "generate",
        "--out",
        s(&dir),
        "--subsample",
        "24",
        "--repetitions",
        "6",
        "--file",
        "long.mcap",
    ]);
    let (n3, n6) = (frames(&short), frames(&long));
    assert!(
        n6 > 19 * n3 / 10 && n6 < 21 * n3 / 10,
        "3 repetitions {n3}, 6 repetitions {n6}"
    );
    let data = dir.join("long.mcap");
    let model = dir.join("sparse.sgp");
    ok(&[
        "train",
        "--data",
        s(&data),
        "--robot",
        "walkman",
        "--max-iters",
        "15",
        "--inducing",
        "30",
        "--validation",
        "none",
        "--out",
        s(&model),
    ]);
    // With the default validation, which a sparse model's transfer cannot do yet: it trains to
    // the budget and says so (it was an error).
    let coman = dir.join("coman.sgp");
    ok(&[
        "transfer",
        "--model",
        s(&model),
        "--data",
        s(&data),
        "--robot",
        "coman",
        "--max-iters",
        "10",
        "--out",
        s(&coman),
    ]);
    // Every frame of the training motions, not the subsampled training set (issue 49).
    let demos = sgplvm::robots::dataset::load_demonstrations(&data).unwrap();
    let every = demos.every_training_frame().len();
    assert!(
        every > 20 * demos.train.len(),
        "{every} of {}",
        demos.train.len()
    );
    for path in [&model, &coman] {
        let m = sgplvm::core::SharedGplvm::load(path).unwrap();
        assert_eq!(m.config().inducing, Some(30));
        assert_eq!(m.inducing_inputs().unwrap().nrows(), 30);
        assert_eq!(m.num_points(), every);
    }
    let out = dir.join("x.sgp");
    let e = fails(
        &[
            "train",
            "--data",
            s(&data),
            "--robot",
            "walkman",
            "--inducing",
            "0",
            "--out",
            s(&out),
        ],
        2,
    );
    assert!(e.contains("--inducing"), "{e}");
    let e = fails_on_one_line(&[
        "train",
        "--data",
        s(&data),
        "--robot",
        "walkman",
        "--inducing",
        "100000",
        "--out",
        s(&out),
    ]);
    assert!(e.contains("expected at most"), "{e}");
    assert!(!out.exists());
}

/// `--whiten-back-constraint` trains another path (on the same budget, a lower objective: the
/// whitened problem is better conditioned), the model it writes is used like any other, and
/// it is refused where it cannot apply with a message naming the flag.
#[test]
fn whitened_back_constraint_trains_faster_and_is_refused_where_it_cannot_apply() {
    let f = fixture();
    let dir = scratch("whiten");
    let data = s(&f.data);
    let train = |name: &str, extra: &[&str]| {
        let out = dir.join(name);
        let mut args = vec![
            "train",
            "--data",
            data,
            "--robot",
            "walkman",
            "--back-constraint",
            "input",
            "--validation",
            "none",
            "--max-iters",
            "30",
            "--json",
            "--out",
            s(&out),
        ];
        args.extend_from_slice(extra);
        let stdout = ok(&args);
        let v: serde_json::Value = serde_json::from_str(stdout.trim()).expect("json");
        (out, v["objective"].as_f64().expect("objective"))
    };
    let (_, plain) = train("plain.sgp", &[]);
    let (white_model, white) = train("white.sgp", &["--whiten-back-constraint"]);
    assert!(
        white < plain,
        "whitened objective {white} after 30 iterations, plain {plain}"
    );
    // The whitened model loads and evaluates like any other.
    let stdout = ok(&[
        "evaluate",
        "--model",
        s(&white_model),
        "--data",
        data,
        "--robot",
        "walkman",
    ]);
    assert!(!stdout.is_empty());

    let out = dir.join("refused.sgp");
    let base = [
        "train",
        "--data",
        data,
        "--robot",
        "walkman",
        "--out",
        s(&out),
    ];
    let with = |extra: &[&'static str]| {
        let mut a = base.to_vec();
        a.extend_from_slice(extra);
        a
    };
    let err = fails_on_one_line(&with(&[
        "--back-constraint",
        "none",
        "--whiten-back-constraint",
    ]));
    assert!(
        err.contains("--whiten-back-constraint") && err.contains("none"),
        "{err}"
    );
    let err = fails(&with(&["--inducing", "8", "--whiten-back-constraint"]), 2);
    assert!(
        err.contains("--whiten-back-constraint") && err.contains("--inducing"),
        "{err}"
    );
    assert!(!out.exists(), "a refused training wrote {}", out.display());
}

#[test]
fn the_demo_and_train_run_the_bayesian_model_without_early_stopping() {
    let f = fixture();
    let out = scratch("demo-bayesian");
    let stdout = ok(&[
        "demo",
        "--bayesian",
        "--data",
        s(&f.data),
        "--max-iters",
        "15",
        "--json",
        "--out",
        s(&out),
    ]);
    let v: serde_json::Value = serde_json::from_str(&stdout).expect("json");
    assert!(v.to_string().contains("walkman"), "{v}");
    // Trained to the budget: no iteration count chosen on held-out frames.
    let model = sgplvm::SharedGplvm::load(&out.join("walkman.sgp")).expect("model");
    assert!(model.is_bayesian() && model.selection().is_none());
    assert_eq!(model.latent_variances().expect("q(X)").ncols(), 5);
    // train --bayesian: format 3, the ARD weights of every space printed and in JSON.
    let path = out.join("coman.sgp");
    let text = ok(&[
        "train",
        "--data",
        s(&f.data),
        "--robot",
        "coman",
        "--bayesian",
        "--validation",
        "none",
        "--max-iters",
        "15",
        "--out",
        s(&path),
    ]);
    assert!(
        text.contains("ARD weights") && text.contains("human") && text.contains("coman"),
        "{text}"
    );
    let bytes = std::fs::read(&path).unwrap();
    assert_eq!(u32::from_le_bytes(bytes[8..12].try_into().unwrap()), 3);
    let json = ok(&[
        "train",
        "--data",
        s(&f.data),
        "--robot",
        "coman",
        "--bayesian",
        "--validation",
        "none",
        "--max-iters",
        "5",
        "--json",
        "--out",
        s(&path),
    ]);
    let v: serde_json::Value = serde_json::from_str(&json).expect("json");
    assert_eq!(
        v["ard_weights"]["coman"].as_array().map(Vec::len),
        Some(5),
        "{v}"
    );
}
