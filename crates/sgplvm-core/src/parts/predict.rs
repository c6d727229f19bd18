//! Prediction of a per-part model: each part maps its own human columns to its latent point and
//! that point to its robot columns; the parts' outputs fill the robot's columns. The parent is
//! not used (see the module docs).

use faer::{Mat, MatRef};

use super::PartsGplvm;
use crate::error::{check_buffer, Error, Result};
use crate::predict::Prediction;
use crate::preprocess::check_finite;

/// Values a frame's part is gathered into on the stack (more go to the heap).
const STACK: usize = 64;

impl PartsGplvm {
    /// Posterior mean (and optionally variance) of robot `space` for the raw human frames in the
    /// rows of `h`, each part predicting its columns from its own human columns
    /// ([`SharedGplvm::predict`](crate::SharedGplvm::predict)). The prediction's `latent` holds
    /// every part's latent points side by side (part order; [`PartsGplvm::latent_dim`]
    /// columns).
    pub fn predict(
        &self,
        h: MatRef<'_, f64>,
        space: &str,
        with_variance: bool,
    ) -> Result<Prediction> {
        self.check_input_matrix(h)?;
        let d = self.output_dim(space)?;
        let n = h.nrows();
        let mut mean = Mat::zeros(n, d);
        let mut variance = with_variance.then(|| Mat::zeros(n, d));
        let mut latent = Mat::zeros(n, self.latent_dim());
        let mut at = 0;
        for part in &self.parts {
            let hp = Self::columns_of(h, &part.columns[self.input_name()]);
            let p = part
                .model
                .predict(hp.as_ref(), space, with_variance)
                .map_err(|e| e.in_part(&part.name))?;
            for (k, &c) in part.columns[space].iter().enumerate() {
                mean.as_mut().col_mut(c).copy_from(p.mean.col(k));
                if let (Some(v), Some(pv)) = (variance.as_mut(), p.variance.as_ref()) {
                    v.as_mut().col_mut(c).copy_from(pv.col(k));
                }
            }
            let q = p.latent.ncols();
            latent.as_mut().subcols_mut(at, q).copy_from(&p.latent);
            at += q;
        }
        Ok(Prediction {
            mean,
            variance,
            latent,
        })
    }

    /// The gate's three signals for robot `space` of each raw human frame (row of `h`), each as
    /// the largest over the parts of the part's signal over its own threshold (so each is
    /// beyond 1 where some part does not know its share of the pose): the standardised
    /// predictive standard deviation over the trust threshold, the reconstruction error over
    /// the reconstruction threshold and the novelty over the novelty threshold, each part on
    /// its own human columns.
    pub fn gate_ratios(&self, h: MatRef<'_, f64>, space: &str) -> Result<[Vec<f64>; 3]> {
        self.check_input_matrix(h)?;
        self.output_dim(space)?;
        let mut out = [(); 3].map(|_| vec![0.0f64; h.nrows()]);
        for part in &self.parts {
            let m = &part.model;
            let hp = Self::columns_of(h, &part.columns[self.input_name()]);
            let signals = (|| {
                Ok::<_, Error>([
                    (
                        m.prediction_sd(hp.as_ref(), space)?,
                        m.trust_threshold(space)?,
                    ),
                    (
                        m.reconstruction_errors(hp.as_ref())?,
                        m.reconstruction_threshold()?,
                    ),
                    (m.novelties(hp.as_ref())?, m.novelty_threshold()?),
                ])
            })()
            .map_err(|e| e.in_part(&part.name))?;
            for (k, (values, threshold)) in signals.into_iter().enumerate() {
                for (o, v) in out[k].iter_mut().zip(values) {
                    // A signal not a number stays one (the gate holds on it).
                    let r = v / threshold;
                    *o = if r.is_nan() || o.is_nan() {
                        f64::NAN
                    } else {
                        o.max(r)
                    };
                }
            }
        }
        Ok(out)
    }

    /// Checks the length of a raw human frame `h`.
    fn check_input_frame(&self, h: &[f64]) -> Result<()> {
        let dh = self.spaces[0].dim;
        if h.len() != dh {
            return Err(Error::DimensionMismatch {
                what: format!("input frame for '{}'", self.input_name()),
                expected: dh,
                found: h.len(),
            });
        }
        Ok(())
    }

    /// Checks a raw human frame `h` and an output buffer of `out` values for `space`.
    fn check_frame(&self, h: &[f64], space: &str, out: usize) -> Result<()> {
        self.check_input_frame(h)?;
        check_buffer("output", space, self.output_dim(space)?, out)
    }

    /// Posterior mean of robot `space` for one raw human frame `h`, written to `out` (the
    /// space's columns): each part's [`SharedGplvm::predict_frame`](crate::SharedGplvm::predict_frame)
    /// on its own columns. Allocates nothing for parts of at most 64 columns per space.
    pub fn predict_frame(&self, h: &[f64], space: &str, out: &mut [f64]) -> Result<()> {
        self.check_frame(h, space, out.len())?;
        let (mut hin, mut hout) = ([0.0f64; STACK], [0.0f64; STACK]);
        let (mut hin_heap, mut hout_heap) = (Vec::new(), Vec::new());
        for part in &self.parts {
            let (ins, outs) = (&part.columns[self.input_name()], &part.columns[space]);
            let hp = buffer(&mut hin, &mut hin_heap, ins.len());
            for (v, &c) in hp.iter_mut().zip(ins) {
                *v = h[c];
            }
            let op = buffer(&mut hout, &mut hout_heap, outs.len());
            part.model
                .predict_frame(hp, space, op)
                .map_err(|e| e.in_part(&part.name))?;
            for (&v, &c) in op.iter().zip(outs) {
                out[c] = v;
            }
        }
        Ok(())
    }

    /// One raw human frame's latent point, every part's side by side ([`Self::latent_dim`]
    /// values, part order) into `x`, and its reconstruction error and novelty, each the largest
    /// of the parts' (on their own human columns) over the part's threshold: the live gate's
    /// signals of a per-part model, beyond 1 where a part does not know its share of the pose.
    /// `x` is the input of [`PartsGplvm::predict_latent_sd`], computed once for every robot.
    pub fn known_frame(&self, h: &[f64], x: &mut [f64]) -> Result<[f64; 2]> {
        self.check_input_frame(h)?;
        if x.len() != self.latent_dim() {
            return Err(Error::DimensionMismatch {
                what: "latent point (every part's)".into(),
                expected: self.latent_dim(),
                found: x.len(),
            });
        }
        let (mut stack, mut heap) = ([0.0f64; STACK], Vec::new());
        let (mut out, mut at) = ([0.0f64; 2], 0);
        for part in &self.parts {
            let m = &part.model;
            let ins = &part.columns[self.input_name()];
            let hp = buffer(&mut stack, &mut heap, ins.len());
            for (v, &c) in hp.iter_mut().zip(ins) {
                *v = h[c];
            }
            let xp = &mut x[at..at + m.config().latent_dim];
            at += xp.len();
            let ratios = (|| {
                m.latent_frame(hp, xp)?;
                Ok::<_, Error>([
                    m.reconstruction_error(hp, xp)? / m.reconstruction_threshold()?,
                    m.novelty(hp)? / m.novelty_threshold()?,
                ])
            })()
            .map_err(|e| e.in_part(&part.name))?;
            out[0] = out[0].max(ratios[0]);
            out[1] = out[1].max(ratios[1]);
        }
        Ok(out)
    }

    /// The prediction for `space` at the latent point `x` of [`PartsGplvm::known_frame`]: the
    /// mean into `mean` and each joint's predictive standard deviation into `sd`, each part
    /// ([`SharedGplvm::predict_latent_sd`](crate::SharedGplvm::predict_latent_sd)) on its own
    /// columns; returns the largest of the parts' standardised standard deviations over their
    /// trust thresholds (the live gate's σ signal of a per-part model: beyond 1 where a part is
    /// unsure). Allocates nothing for parts of at most 64 columns per space.
    pub fn predict_latent_sd(
        &self,
        x: &[f64],
        space: &str,
        mean: &mut [f64],
        sd: &mut [f64],
    ) -> Result<f64> {
        let d = self.output_dim(space)?;
        check_buffer("mean", space, d, mean.len())?;
        check_buffer("standard deviation", space, d, sd.len())?;
        if x.len() != self.latent_dim() {
            return Err(Error::DimensionMismatch {
                what: "latent point (every part's)".into(),
                expected: self.latent_dim(),
                found: x.len(),
            });
        }
        let (mut mean_stack, mut sd_stack) = ([0.0f64; STACK], [0.0f64; STACK]);
        let (mut mean_heap, mut sd_heap) = (Vec::new(), Vec::new());
        let (mut ratio, mut at) = (0.0f64, 0);
        for part in &self.parts {
            let m = &part.model;
            let xp = &x[at..at + m.config().latent_dim];
            at += xp.len();
            let outs = &part.columns[space];
            let mp = buffer(&mut mean_stack, &mut mean_heap, outs.len());
            let sp = buffer(&mut sd_stack, &mut sd_heap, outs.len());
            let in_part = |e: Error| e.in_part(&part.name);
            let s = m.predict_latent_sd(xp, space, mp, sp).map_err(in_part)?;
            ratio = ratio.max(s / m.trust_threshold(space).map_err(in_part)?);
            for (k, &c) in outs.iter().enumerate() {
                mean[c] = mp[k];
                sd[c] = sp[k];
            }
        }
        Ok(ratio)
    }

    /// Latent points of raw human frames: every part's (n × its Q) side by side, in part order.
    pub fn latent(&self, h: MatRef<'_, f64>) -> Result<Mat<f64>> {
        self.check_input_matrix(h)?;
        let mut latent = Mat::zeros(h.nrows(), self.latent_dim());
        let mut at = 0;
        for part in &self.parts {
            let hp = Self::columns_of(h, &part.columns[self.input_name()]);
            let x = part
                .model
                .latent(hp.as_ref())
                .map_err(|e| e.in_part(&part.name))?;
            latent.as_mut().subcols_mut(at, x.ncols()).copy_from(&x);
            at += x.ncols();
        }
        Ok(latent)
    }

    /// The training frames' latent points of every part, side by side (N × [`latent_dim`]).
    ///
    /// [`latent_dim`]: PartsGplvm::latent_dim
    pub fn latent_points(&self) -> Mat<f64> {
        let mut latent = Mat::zeros(self.num_points(), self.latent_dim());
        let mut at = 0;
        for part in &self.parts {
            let x = part.model.latent_points();
            latent.as_mut().subcols_mut(at, x.ncols()).copy_from(x);
            at += x.ncols();
        }
        latent
    }

    /// Checks the columns and values of input frames (errors name the whole input's columns,
    /// not a part's).
    fn check_input_matrix(&self, h: MatRef<'_, f64>) -> Result<()> {
        let dh = self.spaces[0].dim;
        if h.ncols() != dh {
            return Err(Error::DimensionMismatch {
                what: format!("input columns for '{}'", self.input_name()),
                expected: dh,
                found: h.ncols(),
            });
        }
        check_finite(self.input_name(), h)
    }

    /// Columns of output space `space`, or [`Error::NotAnOutput`].
    fn output_dim(&self, space: &str) -> Result<usize> {
        match self.spaces[1..].iter().find(|s| s.name == space) {
            Some(s) => Ok(s.dim),
            None => Err(Error::NotAnOutput {
                name: space.into(),
                known: self.output_names().iter().map(|s| s.to_string()).collect(),
            }),
        }
    }
}

/// The first `n` values of `stack`, or of `heap` grown to `n` when `stack` is too short.
fn buffer<'a>(stack: &'a mut [f64; STACK], heap: &'a mut Vec<f64>, n: usize) -> &'a mut [f64] {
    if n <= STACK {
        &mut stack[..n]
    } else {
        heap.resize(n, 0.0);
        &mut heap[..n]
    }
}
