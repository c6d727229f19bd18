//! Tests of the per-part model: the parts' columns checked, each part the model of its
//! columns, prediction per part, the transfer of the whole structure and the file.

use std::collections::BTreeMap;

use super::*;
use crate::test_support::*;
use crate::{AnyModel, Predictor};

/// Two independent "arms": a human of 3 + 3 columns and a robot of 2 + 2, each arm following
/// its own phase, so that pairings of the two arms' poses vary.
fn arms(n: usize, seed: u64) -> (Mat<f64>, Mat<f64>, Mat<f64>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut noise = move || 0.01 * (rng.random::<f64>() - 0.5);
    let phase = |i: usize, arm: usize| {
        let t = i as f64 / n as f64;
        if arm == 0 {
            6.0 * t
        } else {
            9.5 * t + 1.0
        }
    };
    let human = Mat::from_fn(n, 6, |i, j| {
        let a = phase(i, j / 3);
        (a + 0.7 * (j % 3) as f64).sin()
    });
    let human = Mat::from_fn(n, 6, |i, j| human[(i, j)] + noise());
    let robot = |scale: f64| {
        Mat::from_fn(n, 4, |i, j| {
            let a = phase(i, j / 2);
            scale * (a + 0.4 * (j % 2) as f64).cos()
        })
    };
    (human, robot(1.0), robot(0.8))
}

fn arm_parts(human: usize, robot: (&str, usize)) -> Vec<PartSpec> {
    let half = |d: usize, k: usize| -> Vec<usize> { (k * d / 2..(k + 1) * d / 2).collect() };
    ["left", "right"]
        .iter()
        .enumerate()
        .map(|(k, name)| {
            PartSpec::new(
                *name,
                [("human", half(human, k)), (robot.0, half(robot.1, k))],
            )
        })
        .collect()
}

fn fitted(n: usize, parent: Option<usize>) -> (PartsGplvm, Mat<f64>, Mat<f64>, Mat<f64>) {
    let (h, r1, r2) = arms(n, 1);
    let config = PartsConfig::new(
        ModelConfig::default().with_latent_dim(2),
        arm_parts(6, ("walkman", 4)),
    )
    .with_parent_latent_dim(parent);
    let model = PartsGplvm::fit(
        &config,
        &[("walkman", r1.as_ref()), ("human", h.as_ref())],
        "human",
        &quick(25),
        None,
        None,
    )
    .expect("fit");
    (model, h, r1, r2)
}

#[test]
fn parts_that_do_not_divide_the_columns_are_refused_naming_what_is_wrong() {
    let (h, r, _) = arms(20, 0);
    let spaces = [("human", h.as_ref()), ("walkman", r.as_ref())];
    let config = |parts| PartsConfig::new(ModelConfig::default().with_latent_dim(2), parts);
    let fails = |parts: Vec<PartSpec>| {
        PartsGplvm::fit(&config(parts), &spaces, "human", &quick(2), None, None)
            .unwrap_err()
            .to_string()
    };
    let good = arm_parts(6, ("walkman", 4));
    let mut twice = good.clone();
    twice[1].columns.get_mut("walkman").unwrap().push(1);
    assert!(
        fails(twice).contains("column 1 of space 'walkman' is in part 'left' and in part 'right'"),
    );
    let mut missing = good.clone();
    missing[1].columns.get_mut("walkman").unwrap().pop();
    assert!(fails(missing).contains("column 3 of space 'walkman' is in no part"));
    let mut out_of_range = good.clone();
    out_of_range[0].columns.get_mut("walkman").unwrap().push(9);
    assert!(fails(out_of_range).contains("column 9 of space 'walkman', which has 4 columns"));
    let mut unknown = good.clone();
    unknown[0].columns.insert("coman".into(), vec![0]);
    assert!(fails(unknown).contains("part 'left' names space 'coman'"));
    let mut empty = good.clone();
    empty[0].columns.remove("walkman");
    assert!(fails(empty).contains("part 'left' has no column of space 'walkman'"));
    let mut same = good.clone();
    same[1].name = "left".into();
    assert!(fails(same).contains("part name 'left' is used twice"));
    assert!(fails(Vec::new()).contains("no part given"));
    let e = PartsGplvm::fit(
        &config(good).with_parent_latent_dim(Some(0)),
        &spaces,
        "human",
        &quick(2),
        None,
        None,
    )
    .unwrap_err();
    assert!(e.to_string().contains("parent_latent_dim"), "{e}");
}

/// A one-armed robot: one part holding the human's right arm and every robot column. The
/// human's left arm is no input: what it does changes no prediction and no gate signal, and the
/// file keeps the part's columns.
#[test]
fn human_columns_in_no_part_are_not_inputs() {
    let (h, r, _) = arms(30, 2);
    let r = PartsGplvm::columns_of(r.as_ref(), &[2, 3]);
    let spaces = [("human", h.as_ref()), ("arm", r.as_ref())];
    let right = PartSpec::new("right", [("human", vec![3, 4, 5]), ("arm", vec![0, 1])]);
    let config = PartsConfig::new(ModelConfig::default().with_latent_dim(2), vec![right]);
    let model = PartsGplvm::fit(&config, &spaces, "human", &quick(20), None, None).expect("fit");
    let mut other = h.clone();
    for i in 0..other.nrows() {
        for j in 0..3 {
            other[(i, j)] = 5.0 - 2.0 * other[(i, j)];
        }
    }
    let same = |a: &Mat<f64>, b: &Mat<f64>| (a - b).norm_max() == 0.0;
    let p = model.predict(h.as_ref(), "arm", true).expect("predict");
    let q = model.predict(other.as_ref(), "arm", true).expect("predict");
    assert!(same(&p.mean, &q.mean) && same(&p.latent, &q.latent));
    let [a, b] = [&h, &other].map(|m| model.gate_ratios(m.as_ref(), "arm").expect("gate"));
    assert_eq!(a, b);
    let back = PartsGplvm::from_bytes(&model.to_bytes()).expect("loads");
    assert_eq!(back.part_columns("right", "human"), Some(&[3, 4, 5][..]));
    // The right arm does matter.
    let mut moved = h.clone();
    moved[(0, 4)] += 0.5;
    let m = model
        .predict(moved.as_ref(), "arm", false)
        .expect("predict");
    assert!(!same(&m.mean, &p.mean));
}

/// Each part is exactly the shared GP-LVM of its columns, and the whole predicts each robot
/// column from its own part: batch, frame by frame and latent points agree.
#[test]
fn each_part_is_the_model_of_its_columns_and_predicts_its_columns() {
    let (model, h, r1, _) = fitted(40, Some(2));
    assert_eq!(model.part_names(), ["left", "right"]);
    assert_eq!(model.output_names(), ["walkman"]);
    assert_eq!(model.latent_dim(), 4);
    let config = ModelConfig::default().with_latent_dim(2);
    for (k, name) in ["left", "right"].iter().enumerate() {
        let hc: Vec<usize> = (3 * k..3 * k + 3).collect();
        let rc: Vec<usize> = (2 * k..2 * k + 2).collect();
        assert_eq!(model.part_columns(name, "human"), Some(hc.as_slice()));
        let alone = SharedGplvm::fit(
            &config,
            &[
                ("walkman", PartsGplvm::columns_of(r1.as_ref(), &rc).as_ref()),
                ("human", PartsGplvm::columns_of(h.as_ref(), &hc).as_ref()),
            ],
            "human",
            &quick(25),
            None,
        )
        .expect("fit");
        assert_eq!(model.part(name).expect("part").params(), alone.params());
    }
    let p = model.predict(h.as_ref(), "walkman", true).expect("predict");
    let mut frame = vec![0.0; 4];
    for i in 0..40 {
        let row: Vec<f64> = (0..6).map(|j| h[(i, j)]).collect();
        model
            .predict_frame(&row, "walkman", &mut frame)
            .expect("frame");
        for j in 0..4 {
            assert!((frame[j] - p.mean[(i, j)]).abs() < 1e-12, "{i} {j}");
        }
    }
    let left = model.part("left").expect("left");
    let lp = left
        .predict(
            PartsGplvm::columns_of(h.as_ref(), &[0, 1, 2]).as_ref(),
            "walkman",
            true,
        )
        .expect("predict");
    for i in 0..40 {
        for j in 0..2 {
            assert_eq!(p.mean[(i, j)], lp.mean[(i, j)]);
            assert_eq!(
                p.variance.as_ref().unwrap()[(i, j)],
                lp.variance.as_ref().unwrap()[(i, j)]
            );
            assert_eq!(p.latent[(i, j)], lp.latent[(i, j)]);
        }
    }
    let x = model.latent(h.as_ref()).expect("latent");
    assert_eq!((x.nrows(), x.ncols()), (40, 4));
    assert_eq!(model.latent_points().ncols(), 4);
    // The fit on the training frames is close: a model, not noise.
    let mse = (0..40)
        .flat_map(|i| (0..4).map(move |j| (i, j)))
        .map(|(i, j)| (p.mean[(i, j)] - r1[(i, j)]).powi(2))
        .sum::<f64>()
        / 160.0;
    assert!(mse < 0.05, "{mse}");
    // The parent: the parts' latent points as its spaces, named after them.
    let parent = model.parent().expect("parent");
    assert_eq!(parent.input_name(), "left");
    assert_eq!(parent.output_names(), ["right"]);
    assert_eq!(parent.space_dim("right"), Some(2));
    assert_eq!(parent.num_points(), 40);
    // Errors name the whole input, the output and the frame buffer.
    let e = model
        .predict_frame(&[0.0; 5], "walkman", &mut frame)
        .unwrap_err();
    assert!(e.to_string().contains("expected 6"), "{e}");
    let e = model.predict(h.as_ref(), "coman", false).unwrap_err();
    assert!(matches!(e, Error::NotAnOutput { .. }), "{e}");
    let mut bad = h.clone();
    bad[(3, 4)] = f64::NAN;
    let e = model.predict(bad.as_ref(), "walkman", false).unwrap_err();
    assert!(matches!(e, Error::NonFinite { row: 3, col: 4, .. }), "{e}");
}

/// A frame whose left arm comes from one training frame and right arm from another is
/// predicted as each arm's own training frame: the per-part model has no pairing to learn.
#[test]
fn a_new_pairing_of_known_arm_poses_is_predicted_arm_by_arm() {
    let (model, h, _, _) = fitted(40, None);
    let p = model
        .predict(h.as_ref(), "walkman", false)
        .expect("predict");
    let mixed = Mat::from_fn(40, 6, |i, j| if j < 3 { h[(i, j)] } else { h[(39 - i, j)] });
    let q = model
        .predict(mixed.as_ref(), "walkman", false)
        .expect("predict");
    for i in 0..40 {
        for j in 0..4 {
            let expected = if j < 2 {
                p.mean[(i, j)]
            } else {
                p.mean[(39 - i, j)]
            };
            assert_eq!(q.mean[(i, j)], expected);
        }
    }
    assert!(model.parent().is_none());
}

/// Transfer moves the whole structure: every part's latent points and human kernel and the
/// parent stay as they were; each part learns the new robot's kernel on its columns, as the
/// part's own model would transfer.
#[test]
fn transfer_trains_only_the_new_robots_kernel_of_each_part() {
    let (model, h, r1, r2) = fitted(40, Some(2));
    let columns = BTreeMap::from([
        ("left".to_string(), vec![0, 1]),
        ("right".to_string(), vec![2, 3]),
    ]);
    let t = model
        .transfer("coman", r2.as_ref(), &columns, &quick(20), None, None)
        .expect("transfer");
    assert_eq!(t.output_names(), ["walkman", "coman"]);
    for name in ["left", "right"] {
        let (a, b) = (model.part(name).unwrap(), t.part(name).unwrap());
        assert_eq!(a.latent_points(), b.latent_points());
        assert_eq!(a.kernel("human"), b.kernel("human"));
        assert_eq!(a.kernel("walkman"), b.kernel("walkman"));
        let cols = t.part_columns(name, "coman").unwrap().to_vec();
        let alone = a
            .transfer(
                "coman",
                PartsGplvm::columns_of(r2.as_ref(), &cols).as_ref(),
                &quick(20),
                None,
            )
            .expect("transfer");
        assert_eq!(alone.kernel("coman"), b.kernel("coman"));
    }
    assert_eq!(
        t.parent().unwrap().params(),
        model.parent().unwrap().params()
    );
    assert_eq!(
        t.predict(h.as_ref(), "walkman", false).unwrap(),
        model.predict(h.as_ref(), "walkman", false).unwrap()
    );
    let mse = {
        let p = t.predict(h.as_ref(), "coman", false).unwrap().mean;
        (0..40)
            .flat_map(|i| (0..4).map(move |j| (i, j)))
            .map(|(i, j)| (p[(i, j)] - r2[(i, j)]).powi(2))
            .sum::<f64>()
            / 160.0
    };
    assert!(mse < 0.05, "{mse}");
    // Columns that do not divide the new robot, an unknown part, a robot it has.
    let bad = BTreeMap::from([("left".to_string(), vec![0, 1, 2])]);
    let e = model
        .transfer("coman", r2.as_ref(), &bad, &quick(2), None, None)
        .unwrap_err();
    assert!(
        e.to_string()
            .contains("part 'right' has no column of space 'coman'"),
        "{e}"
    );
    let mut unknown = columns.clone();
    unknown.insert("torso".into(), vec![]);
    let e = model
        .transfer("coman", r2.as_ref(), &unknown, &quick(2), None, None)
        .unwrap_err();
    assert!(e.to_string().contains("part 'torso'"), "{e}");
    let e = model
        .transfer("walkman", r1.as_ref(), &columns, &quick(2), None, None)
        .unwrap_err();
    assert!(matches!(e, Error::DuplicateSpace { .. }), "{e}");
}

/// The file: bit-identical predictions after a round trip, each kind refused as the other,
/// both read by `AnyModel`, and damaged payloads refused as corrupt.
#[test]
fn the_file_round_trips_and_each_kind_is_refused_as_the_other() {
    let (mut model, h, _, _) = fitted(30, Some(2));
    model
        .set_column_names("human", (0..6).map(|j| format!("h{j}")).collect())
        .expect("names");
    assert_eq!(
        model.part("right").unwrap().column_names("human").unwrap(),
        ["h3", "h4", "h5"]
    );
    let bytes = model.to_bytes();
    assert_eq!(u32::from_le_bytes(bytes[8..12].try_into().unwrap()), 4);
    let back = PartsGplvm::from_bytes(&bytes).expect("loads");
    assert_eq!(back.to_bytes(), bytes);
    assert_eq!(
        back.predict(h.as_ref(), "walkman", true).unwrap(),
        model.predict(h.as_ref(), "walkman", true).unwrap()
    );
    assert_eq!(back.column_names("human").unwrap()[4], "h4");
    let e = SharedGplvm::from_bytes(&bytes).unwrap_err();
    assert!(matches!(e, Error::WrongModelKind { .. }), "{e}");
    assert!(e.to_string().contains("latent space per body part"), "{e}");
    let single = model.part("left").unwrap().to_bytes();
    let e = PartsGplvm::from_bytes(&single).unwrap_err();
    assert!(e.to_string().contains("one shared latent space"), "{e}");
    assert!(matches!(
        AnyModel::from_bytes(&bytes),
        Ok(AnyModel::Parts(_))
    ));
    assert!(matches!(
        AnyModel::from_bytes(&single),
        Ok(AnyModel::Single(_))
    ));
    let any = AnyModel::from_bytes(&bytes).unwrap();
    assert_eq!(any.latent_dim(), 4);
    assert_eq!(any.to_bytes(), bytes);
    // A newer format is refused by its version.
    let mut newer = bytes.clone();
    newer[8..12].copy_from_slice(&5u32.to_le_bytes());
    assert!(matches!(
        PartsGplvm::from_bytes(&newer),
        Err(Error::UnsupportedVersion {
            found: 5,
            supported: 4
        })
    ));
    // Damaged payloads.
    let edit = |f: &dyn Fn(&mut serde_json::Value)| {
        PartsGplvm::from_bytes(&crate::io::with_payload(&bytes, f))
            .unwrap_err()
            .to_string()
    };
    let e = edit(&|j| j["parts"][1]["columns"]["walkman"] = serde_json::json!([1, 3]));
    assert!(
        e.contains("corrupt") && e.contains("column 1 of space 'walkman'"),
        "{e}"
    );
    let e = edit(&|j| j["parts"][0]["columns"]["human"] = serde_json::json!([0, 2, 1]));
    assert!(e.contains("corrupt") && e.contains("part 'left'"), "{e}");
    let e = edit(&|j| j["spaces"][0]["columns"][4] = serde_json::json!("other"));
    assert!(e.contains("part 'right'") && e.contains("joints"), "{e}");
    let e = edit(&|j| j["parts"][0]["version"] = serde_json::json!(4));
    assert!(e.contains("format 4 inside a per-part file"), "{e}");
    let e = edit(&|j| j["parent"]["model"]["spaces"][1]["name"] = serde_json::json!("torso"));
    assert!(e.contains("parent"), "{e}");
    let e = edit(&|j| j["parts"][1]["model"]["config"]["latent_dim"] = serde_json::json!(0));
    assert!(e.contains("part 'right'"), "{e}");
}

#[test]
fn each_arm_follows_a_tenth_of_its_random_poses_so_the_frame_follows_a_hundredth() {
    // Two parts: each arm's novelty threshold follows 1 %^(1/2) = 10 % of that arm's random
    // poses, so a random frame (both arms followed, the arms drawn independently) is followed
    // 1 % of the time; the ratios the gate reads are each part's own over its threshold.
    let (mut model, h, ..) = fitted(60, None);
    let bounds = vec![(-2.0, 4.0); 6];
    assert!(model.set_pose_bounds(&bounds[..5]).is_err());
    model.set_pose_bounds(&bounds).unwrap();
    for name in model.part_names() {
        let part = model.part(name).unwrap();
        assert!((part.random_followed() - 0.1).abs() < 1e-12, "{name}");
        assert_eq!(part.pose_bounds(), Some(&bounds[..3]));
    }
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
    let frames = Mat::from_fn(3000, 6, |_, _| rng.random_range(-2.0..4.0));
    let [_, _, novelty] = model.gate_ratios(frames.as_ref(), "walkman").unwrap();
    let followed = novelty.iter().filter(|&&r| r <= 1.0).count();
    assert!(followed <= 60, "{followed} of 3000 random frames followed");
    // A training frame is followed by every part, and its per-frame ratios are the batch's.
    let row: Vec<f64> = (0..6).map(|j| h[(4, j)]).collect();
    let mut x = vec![0.0; model.latent_dim()];
    let [e, n] = model.known_frame(&row, &mut x).unwrap();
    let batch = model.gate_ratios(h.subrows(4, 1), "walkman").unwrap();
    assert!(n < 1e-9 && (e - batch[1][0]).abs() < 1e-12 && n == batch[2][0]);
}
