//! Fig. 12 (issue 34): which latent dimensions each space uses — the Bayesian multi-robot
//! model's ARD weights α²/ℓ² per space side by side, as the MRD paper draws them. A dimension
//! every space weighs is shared; one only some spaces weigh is private to them; one no space
//! weighs is switched off.

use std::path::{Path, PathBuf};

use sgplvm_core::BackConstraint;

use crate::plots::{write_figure, Markers, Panel, PlotError, Series};
use crate::results::{Results, ARD_USED_SHARE};

/// Fig. 12: per back constraint of the Bayesian study (a row each) and space (a column each),
/// every latent dimension's ARD weight relative to the space's largest — the mean over runs
/// (stem and circle) and each run (crosses) — with the 5 % line below which a dimension is
/// switched off. From the Bayesian multi-robot models, which hold every space; `None` when the
/// study was not run.
pub fn ard_weights(results: &Results, dir: &Path) -> Result<Option<[PathBuf; 2]>, PlotError> {
    let mut panels = Vec::new();
    let mut columns = 0;
    for bc in [BackConstraint::Input, BackConstraint::None] {
        let models = results.bayesian_multi_models(bc.name());
        let Some(first) = models.first() else {
            continue;
        };
        columns = columns.max(first.ard_weights.len());
        for (s, (space, _)) in first.ard_weights.iter().enumerate() {
            let relative: Vec<Vec<f64>> = models
                .iter()
                .filter_map(|m| m.ard_weights.get(s).map(|(_, w)| relative_to_largest(w)))
                .collect();
            panels.push(space_panel(&format!("{space}, {bc} BC"), &relative));
        }
    }
    if panels.is_empty() {
        return Ok(None);
    }
    write_figure(
        &dir.join("fig12"),
        "Fig. 12: ARD weights of the Bayesian multi-robot model, per space (relative to its largest)",
        &panels,
        columns,
    )
    .map(Some)
}

/// `weights` divided by their largest (zeros when none is positive).
fn relative_to_largest(weights: &[f64]) -> Vec<f64> {
    let largest = weights.iter().copied().fold(0.0, f64::max);
    weights
        .iter()
        .map(|w| if largest > 0.0 { w / largest } else { 0.0 })
        .collect()
}

/// One space's panel from its relative weights per run.
fn space_panel(title: &str, relative: &[Vec<f64>]) -> Panel {
    let q = relative.iter().map(Vec::len).max().unwrap_or(0);
    let mean: Vec<f64> = (0..q)
        .map(|t| {
            let values: Vec<f64> = relative.iter().filter_map(|w| w.get(t).copied()).collect();
            values.iter().sum::<f64>() / values.len().max(1) as f64
        })
        .collect();
    let x = |t: usize| (t + 1) as f64;
    let mut series: Vec<Series> = mean
        .iter()
        .enumerate()
        .map(|(t, &m)| Series {
            label: String::new(),
            color: 0,
            points: vec![(x(t), 0.0), (x(t), m)],
            ..Series::default()
        })
        .collect();
    series.push(Series {
        label: format!("{:.0} % of the largest", ARD_USED_SHARE * 100.0),
        color: 7,
        dashed: true,
        points: vec![(0.5, ARD_USED_SHARE), (q as f64 + 0.5, ARD_USED_SHARE)],
        band: None,
    });
    let markers = vec![
        Markers {
            label: "mean over runs".into(),
            color: 0,
            circles: true,
            points: mean.iter().enumerate().map(|(t, &m)| (x(t), m)).collect(),
            annotations: vec![],
        },
        Markers {
            label: "one run".into(),
            color: 1,
            circles: false,
            points: relative
                .iter()
                .flat_map(|w| w.iter().enumerate().map(|(t, &v)| (x(t), v)))
                .collect(),
            annotations: vec![],
        },
    ];
    Panel {
        title: title.into(),
        x_label: "latent dimension".into(),
        y_label: "α²/ℓ² ÷ largest".into(),
        series,
        markers,
        x_categories: (1..=q).map(|t| t.to_string()).collect(),
        ..Panel::default()
    }
}
