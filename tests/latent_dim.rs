//! `train --choose-latent-dim`: the latent dimension chosen on held-out training motions, one
//! validated model per Q, the lowest held-out error kept; refused without validation or beside
//! --latent-dim.

mod common;
use common::{fails, s, scratch, sgplvm};

#[test]
fn the_latent_dimension_is_chosen_on_held_out_training_motions() {
    let dir = scratch("choose-latent-dim");
    let out = dir.join("chosen.sgp");
    let data = dir.join("data");
    let gen = sgplvm(&["generate", "--out", s(&data), "--subsample", "24"]);
    assert!(gen.status.success());
    let demos = data.join("bimanual.mcap");
    let run = sgplvm(&[
        "train",
        "--data",
        s(&demos),
        "--robot",
        "coman",
        "--choose-latent-dim",
        "2,4",
        "--max-iters",
        "40",
        "--out",
        s(&out),
    ]);
    let err = String::from_utf8_lossy(&run.stderr).into_owned();
    assert!(run.status.success(), "{err}");
    // Each Q's held-out error is said, and the lowest is the one kept.
    let held: Vec<(usize, f64)> = err
        .lines()
        .filter_map(|l| l.trim().strip_prefix("Q = "))
        .map(|l| {
            let (q, e) = l.split_once(": held-out MSE ").unwrap();
            (q.parse().unwrap(), e.parse().unwrap())
        })
        .collect();
    assert_eq!(held.len(), 2, "{err}");
    let best = held.iter().min_by(|a, b| a.1.total_cmp(&b.1)).unwrap().0;
    assert!(err.contains(&format!("chose Q = {best}")), "{err}");
    let model = sgplvm::SharedGplvm::load(&out).unwrap();
    assert_eq!(model.config().latent_dim, best);
    // It chooses on held-out motions: refused without them, and beside --latent-dim.
    let never = dir.join("never.sgp");
    for (extra, code, says) in [
        (["--validation", "none"], 1, "needs --validation auto"),
        (["--latent-dim", "3"], 2, "--latent-dim"),
    ] {
        let mut args = vec![
            "train",
            "--data",
            s(&demos),
            "--robot",
            "coman",
            "--choose-latent-dim",
            "2,4",
            "--out",
            s(&never),
        ];
        args.extend(extra);
        let e = fails(&args, code);
        assert!(e.contains(says), "{e}");
    }
    assert!(!dir.join("never.sgp").exists());
}
