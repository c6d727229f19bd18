//! Transfer with less data (the paper's Section V: "the proposed transfer learning process also
//! allows us to train the transferred shared GP-LVMs with less datapoints"): a new robot whose
//! joint commands exist for only some of the model's training frames.
//!
//! The latent points, the human mapping and every robot of the model stay as they are; the new
//! robot's mapping is the GP from the latent points of its frames to its joints, `f ~ GP(0, k)`
//! with the transfer's kernel `(α², ℓ, σ²)` trained by maximum marginal likelihood from the
//! transfer's starting point — exactly what [`SharedGplvm::transfer`] trains when the frames are
//! all of them (tested). It is returned beside the model ([`PartialTransfer`]) because the
//! model's spaces all share the N training frames.

use faer::{Mat, MatRef};

use crate::error::{Error, Result};
use crate::kernel::KernelParams;
use crate::model::{unscale, SharedGplvm};
use crate::predict::check_prediction_matrix;
use crate::regression::{fit_kernel, GpRegression};
use crate::train::{Control, Limits, TrainOptions};
use crate::validation::{select_kernel_budget, take_rows, Selection, Validation};

/// A robot's latent → joints mapping learned from some of a model's training frames (see the
/// module docs); predicts through the model it was transferred from.
#[derive(Clone, Debug)]
pub struct PartialTransfer {
    name: String,
    frames: usize,
    regression: GpRegression,
    offset: Vec<f64>,
    scale: Vec<f64>,
    selection: Option<Selection>,
}

impl SharedGplvm {
    /// Transfers the model to robot `name` from its joint commands `data` at training frames
    /// `rows` (distinct, in range; `data` has one row per entry of `rows`). The starting kernel
    /// is [`SharedGplvm::transfer`]'s (perturbed as [`SharedGplvm::transfer_seeded`]'s when
    /// `seed` is given). With `validation` (positions in `rows`), the iteration budget is chosen
    /// on the held-out positions as [`SharedGplvm::transfer_validated`] chooses it.
    pub fn transfer_partial(
        &self,
        name: &str,
        rows: &[usize],
        data: MatRef<'_, f64>,
        seed: Option<u64>,
        options: &TrainOptions,
        validation: Option<&Validation>,
    ) -> Result<PartialTransfer> {
        options.check()?;
        let limits = Limits::start(options);
        let n = self.n();
        let mut seen = vec![false; n];
        for &r in rows {
            if r >= n || std::mem::replace(&mut seen[r], true) {
                return Err(Error::InvalidValue {
                    what: "transfer rows".into(),
                    reason: format!(
                        "row {r} is out of range or given twice; expected distinct rows < {n}"
                    ),
                });
            }
        }
        if data.nrows() != rows.len() {
            return Err(Error::RowCountMismatch {
                space: name.into(),
                expected: rows.len(),
                found: data.nrows(),
            });
        }
        let space = self.transfer_space_on(name, data, rows.len(), seed)?;
        let x = take_rows(self.x.as_ref(), rows);
        let selection = validation
            .map(|v| select_kernel_budget(x.as_ref(), &space, data, v, options, &limits))
            .transpose()?;
        let budget = match &selection {
            Some(s) => options.clone().with_max_iters(s.best_iteration),
            None => options.clone(),
        };
        let kernel = fit_kernel(
            x.as_ref(),
            space.data.as_ref(),
            space.kernel.clone(),
            &budget,
            &limits,
            name,
            |_, _| Control::Continue,
        )?;
        let regression = GpRegression::with_kernel(
            x.as_ref(),
            vec![0.0; space.data.ncols()],
            space.data.as_ref(),
            kernel,
            name,
        )?;
        Ok(PartialTransfer {
            name: name.into(),
            frames: rows.len(),
            regression,
            offset: space.offset,
            scale: space.scale,
            selection,
        })
    }
}

impl PartialTransfer {
    /// Joint commands (posterior mean, the user's units) for human frames `h`, through the
    /// latent space of `model` — the model this robot was transferred from.
    pub fn predict(&self, model: &SharedGplvm, h: MatRef<'_, f64>) -> Result<Mat<f64>> {
        let x = model.latent(h)?;
        let mut p = self.regression.predict(x.as_ref())?;
        unscale(&mut p, &self.offset, &self.scale);
        check_prediction_matrix(&self.name, p.as_ref())?;
        Ok(p)
    }

    /// The robot's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Frames the robot's mapping was learned from.
    pub fn frames(&self) -> usize {
        self.frames
    }

    /// The trained kernel.
    pub fn kernel(&self) -> &KernelParams {
        self.regression.kernel()
    }

    /// How the iteration budget was chosen, when it was.
    pub fn selection(&self) -> Option<&Selection> {
        self.selection.as_ref()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::*;

    /// On every frame, the partial transfer is the transfer: the same kernel and predictions.
    #[test]
    fn on_all_frames_it_is_the_transfer() {
        let n = 40;
        let (h, _, r2, _) = demo(n, 7);
        let source = fit(BackConstraint::Input, n, 15, 0);
        let options = quick(8).with_rel_tol(0.0);
        let rows: Vec<usize> = (0..n).collect();
        let partial = source
            .transfer_partial("coman", &rows, r2.as_ref(), Some(2), &options, None)
            .expect("partial");
        let full = source
            .transfer_seeded("coman", r2.as_ref(), 2, &options, None)
            .expect("transfer");
        let (a, b) = (partial.kernel(), full.kernel("coman").expect("kernel"));
        let close = |x: f64, y: f64| (x - y).abs() <= 1e-9 * y.abs();
        assert!(
            close(a.variance, b.variance) && close(a.noise, b.noise),
            "{a:?} {b:?}"
        );
        for (x, y) in a.lengthscale.iter().zip(&b.lengthscale) {
            assert!(close(*x, *y), "{a:?} {b:?}");
        }
        let p = partial.predict(&source, h.as_ref()).expect("predict");
        let q = full
            .predict(h.as_ref(), "coman", false)
            .expect("predict")
            .mean;
        for i in 0..n {
            for j in 0..p.ncols() {
                assert!((p[(i, j)] - q[(i, j)]).abs() < 1e-8, "{i},{j}");
            }
        }
        assert_eq!((partial.name(), partial.frames()), ("coman", n));
    }

    /// On a third of the frames it learns from those alone (the others' data cannot matter),
    /// chooses a budget on held-out positions, and refuses bad rows.
    #[test]
    fn on_some_frames_only_they_count() {
        let n = 45;
        let (h, _, r2, _) = demo(n, 7);
        let source = fit(BackConstraint::Input, n, 15, 0);
        let rows: Vec<usize> = (0..n).step_by(3).collect();
        let data = take_rows(r2.as_ref(), &rows);
        let validation = Validation::new(vec![1, 4, 7, 10, 13]).with_patience(3);
        let t = source
            .transfer_partial(
                "coman",
                &rows,
                data.as_ref(),
                None,
                &quick(40),
                Some(&validation),
            )
            .expect("partial");
        let s = t.selection().expect("selection");
        assert_eq!((s.fit_frames, s.validation_frames), (10, 5));
        let p = t.predict(&source, h.as_ref()).expect("predict");
        let mse: f64 = (0..n)
            .flat_map(|i| (0..4).map(move |j| (i, j)))
            .map(|(i, j)| (p[(i, j)] - r2[(i, j)]).powi(2))
            .sum::<f64>()
            / (4 * n) as f64;
        assert!(mse < 0.05, "all-frame error {mse}");
        for (bad_rows, bad_data) in [
            (vec![0, 0], take_rows(r2.as_ref(), &[0, 1])),
            (vec![n], take_rows(r2.as_ref(), &[0])),
            (vec![0, 1], take_rows(r2.as_ref(), &[0])),
        ] {
            assert!(source
                .transfer_partial("coman", &bad_rows, bad_data.as_ref(), None, &quick(5), None)
                .is_err());
        }
        assert!(source
            .transfer_partial("walkman", &rows, data.as_ref(), None, &quick(5), None)
            .is_err());
    }
}
