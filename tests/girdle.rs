//! A person's clavicles aligned to the model's people (`--girdle`, `sgplvm::girdle`): one motion
//! written as two rigs would write it — the second putting each collarbone 0.2 rad further back
//! and its shoulder angles taking up the difference, the arm's pose the same — is commanded
//! alike; as captured it is not. A file and a stream of the same frames are aligned alike, and
//! `evaluate` says by how much each person's clavicles were moved.

mod common;

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::OnceLock;

use common::{ok, s, scratch};
use sgplvm::capture::fit::{with_clavicle, ArmAngles};

const DEMOS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/data/demos/captured.mcap");

/// A CSV's header and rows.
fn read_csv(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    let header = lines
        .next()
        .unwrap()
        .split(',')
        .map(str::to_string)
        .collect();
    let rows = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    (header, rows)
}

fn write_csv(path: &Path, header: &[String], rows: &[Vec<f64>]) {
    let mut text = header.join(",") + "\n";
    for r in rows {
        let cells: Vec<String> = r.iter().map(|v| format!("{v:?}")).collect();
        text += &(cells.join(",") + "\n");
    }
    std::fs::write(path, text).unwrap();
}

/// The frames of `rows` (columns named by `header`) as a rig that puts each clavicle `back`
/// radians further back would write them: protraction lowered, the shoulder re-solved so that
/// the upper arm keeps its orientation.
fn other_rig(header: &[String], rows: &[Vec<f64>], back: f64) -> Vec<Vec<f64>> {
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    let human = sgplvm::capture::HumanArms::new(&sgplvm::Robot::builtin("human").unwrap()).unwrap();
    let limits = *human.limits(sgplvm::robots::Side::Left);
    rows.iter()
        .map(|r| {
            let mut out = r.clone();
            for side in ["Left", "Right"] {
                let first = col(&format!("j{side}C7Shoulder_elevation"));
                let mut arm: ArmAngles = [0.0; 9];
                arm.copy_from_slice(&r[first..first + 9]);
                let moved = with_clavicle(&arm, arm[0], arm[1] - back, &limits);
                out[first..first + 9].copy_from_slice(&moved);
            }
            out
        })
        .collect()
}

fn predict(model: &Path, input: &Path, out: &Path, girdle: &str) -> Vec<Vec<f64>> {
    ok(&[
        "predict",
        "--model",
        s(model),
        "--input",
        s(input),
        "--robot",
        "coman",
        "--out",
        s(out),
        "--raw",
        "--girdle",
        girdle,
    ]);
    read_csv(out).1
}

fn largest_difference(a: &[Vec<f64>], b: &[Vec<f64>]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .flat_map(|(x, y)| x.iter().zip(y).map(|(p, q)| (p - q).abs()))
        .fold(0.0, f64::max)
}

struct Setup {
    dir: PathBuf,
    model: PathBuf,
    capture: PathBuf,
    rig: PathBuf,
}

/// The model and the two rigs' files, made once for every test here.
fn setup() -> &'static Setup {
    static SETUP: OnceLock<Setup> = OnceLock::new();
    SETUP.get_or_init(make_setup)
}

fn make_setup() -> Setup {
    let dir = scratch("girdle");
    let model = dir.join("coman.sgp");
    ok(&[
        "train",
        "--data",
        DEMOS,
        "--robot",
        "coman",
        "--parts",
        "arms",
        "--out",
        s(&model),
    ]);
    let capture = dir.join("human.csv");
    ok(&[
        "export",
        "--data",
        DEMOS,
        "--body",
        "human",
        "--out",
        s(&capture),
    ]);
    let (header, rows) = read_csv(&capture);
    let rig = dir.join("other_rig.csv");
    write_csv(&rig, &header, &other_rig(&header, &rows, 0.2));
    Setup {
        dir,
        model,
        capture,
        rig,
    }
}

#[test]
fn one_motion_from_two_rigs_is_commanded_alike_once_aligned() {
    let t = setup();
    let p = |input: &Path, name: &str, girdle: &str| {
        predict(&t.model, input, &t.dir.join(name), girdle)
    };
    let captured = p(&t.capture, "a.csv", "aligned");
    let rig = p(&t.rig, "b.csv", "aligned");
    // Aligned, the two rigs' frames are the same frames (to the Euler angles' rounding) where
    // both give the shoulder's Euler angles on the same side of its gimbal point (abduction
    // 90°, where flexion and rotation turn about one axis), away from it: there an orientation
    // has one set of angles. (Beyond 90° an arm has two, and the second rig, written with the
    // fit's preference for staying within the limits, takes the other in two frames.)
    let (header, human) = read_csv(&t.capture);
    let (_, other) = read_csv(&t.rig);
    let abduction: Vec<usize> = ["jLeftShoulder_abduction", "jRightShoulder_abduction"]
        .iter()
        .map(|n| header.iter().position(|h| h == n).unwrap())
        .collect();
    let gimbal = std::f64::consts::FRAC_PI_2;
    let side = |a: f64| (a - gimbal).abs() > 0.26;
    let away: Vec<usize> = (0..human.len())
        .filter(|&i| {
            abduction.iter().all(|&c| {
                let (a, b) = (human[i][c], other[i][c]);
                side(a) && side(b) && (a > gimbal) == (b > gimbal)
            })
        })
        .collect();
    assert!(
        away.len() * 100 >= human.len() * 95,
        "{} of {}",
        away.len(),
        human.len()
    );
    let pick =
        |rows: &[Vec<f64>]| -> Vec<Vec<f64>> { away.iter().map(|&i| rows[i].clone()).collect() };
    let aligned = largest_difference(&pick(&captured), &pick(&rig));
    // Measured 5.1e-7 (one frame; the rest within 4e-11).
    assert!(aligned < 1e-6, "aligned: {aligned}");
    // As captured they are not: the model reads the other rig's angles as another pose.
    let raw = largest_difference(
        &p(&t.capture, "c.csv", "as-captured"),
        &p(&t.rig, "d.csv", "as-captured"),
    );
    assert!(raw > 1e-3, "as captured: {raw}");

    // A stream of the same frames is aligned as the file is (the mean so far, frame by frame).
    let mut child = Command::new(env!("CARGO_BIN_EXE_sgplvm"))
        .args([
            "predict",
            "--model",
            s(&t.model),
            "--input",
            "-",
            "--robot",
            "coman",
            "--out",
            "-",
            "--raw",
        ])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let text = std::fs::read_to_string(&t.rig).unwrap();
    child
        .stdin
        .take()
        .unwrap()
        .write_all(text.as_bytes())
        .unwrap();
    let out = child.wait_with_output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let streamed: Vec<Vec<f64>> = String::from_utf8(out.stdout)
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    let d = largest_difference(&rig, &streamed);
    assert!(d < 1e-9, "stream against file: {d}");
}

#[test]
fn evaluate_says_how_far_each_person_s_clavicles_were_moved() {
    let model = &setup().model;
    let evaluate = |extra: &[&str]| {
        let mut args = vec![
            "evaluate",
            "--model",
            s(model),
            "--data",
            DEMOS,
            "--robot",
            "coman",
        ];
        args.extend_from_slice(extra);
        ok(&args)
    };
    let aligned = evaluate(&[]);
    assert!(
        aligned.contains("clavicles aligned to the model's people"),
        "{aligned}"
    );
    let captured = evaluate(&["--girdle", "as-captured"]);
    assert!(captured.contains("clavicles as captured"), "{captured}");
    let json = evaluate(&["--json"]);
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    let shifts = v["girdle_shifts"].as_array().unwrap();
    assert!(!shifts.is_empty(), "{json:.300}");
    assert_eq!(shifts[0]["degrees"].as_array().unwrap().len(), 2);
}
