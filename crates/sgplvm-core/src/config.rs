//! The model's configuration: how many latent dimensions, where the latent points come from
//! (the back constraint), how the data are scaled and how training starts.
//!
//! [`BackConstraint`] has one set of names, used by the command line, the experiments and the
//! Python module alike: `none`, `input`, `output` ([`std::str::FromStr`] / [`std::fmt::Display`]).
//! The model file stores the serde names (`None`, `Input`, `Output`), unchanged since format 1.

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// Where the latent points come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum BackConstraint {
    /// Free latent points X (initialised from PCA); human → latent by a GP regression fitted
    /// after training.
    None,
    /// X = K_bc(H, H) W on the input (human) space: the paper's choice; x* = k_bc(h*, H) W.
    Input,
    /// X = K_bc(R, R) W on the output spaces given to `fit` (concatenated); human → latent by a
    /// GP regression fitted after training.
    Output,
}

/// How spaces are scaled after centring when [`ModelConfig::scale`] is on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum ScaleMode {
    /// Each column divided by its own standard deviation (constant columns are left as is).
    PerColumn,
    /// All columns of a space divided by one number: the root of the mean column variance.
    PerSpace,
}

/// Model configuration. `Default`: Q = 5, input back constraints, seed 0, no scaling.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ModelConfig {
    /// Latent dimension Q (1 ≤ Q < N).
    pub latent_dim: usize,
    /// Latent parametrisation.
    pub back_constraint: BackConstraint,
    /// Seed of the (only) random step: the perturbation of the PCA initialisation.
    pub seed: u64,
    /// Scale every space after centring (see `scale_mode`); off by default.
    pub scale: bool,
    /// Scaling rule used when `scale` is on.
    pub scale_mode: ScaleMode,
    /// Standard deviation of the Gaussian perturbation added to the PCA initialisation (whose
    /// first column has unit standard deviation). 0 makes the seed irrelevant.
    pub init_perturbation: f64,
    /// Ridge λ of the back-constraint initialisation (K_bc + λI) W = X_pca.
    pub bc_ridge: f64,
    /// Initial noise variance of each space as a fraction of its mean column variance.
    pub init_noise_fraction: f64,
    /// Number M of inducing inputs of the sparse model (Titsias' bound, O(N M²) per
    /// evaluation; back constraints `none` or `input`); `None`: the exact model (O(N³)).
    /// Recorded in model files from format 2 (absent in format 1: exact).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub inducing: Option<usize>,
    /// Keep the sparse model's inducing inputs where they start instead of training them.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub fixed_inducing: bool,
    /// The Bayesian shared GP-LVM (MRD, `sparse::bayesian`): a Gaussian q(X) per frame instead
    /// of point latent positions, its means back-constrained or free as `back_constraint` says,
    /// a KL term to the N(0, I) prior, the latent dimensions a space does not need switched off
    /// by its ARD lengthscales. Needs [`ModelConfig::inducing`]. Model files of it are format 3.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub bayesian: bool,
}

impl Default for ModelConfig {
    fn default() -> Self {
        Self {
            latent_dim: 5,
            back_constraint: BackConstraint::Input,
            seed: 0,
            scale: false,
            scale_mode: ScaleMode::PerColumn,
            init_perturbation: 0.01,
            bc_ridge: 1e-3,
            init_noise_fraction: 0.1,
            inducing: None,
            fixed_inducing: false,
            bayesian: false,
        }
    }
}

impl ModelConfig {
    /// Sets Q.
    pub fn with_latent_dim(mut self, q: usize) -> Self {
        self.latent_dim = q;
        self
    }
    /// Sets the latent parametrisation.
    pub fn with_back_constraint(mut self, bc: BackConstraint) -> Self {
        self.back_constraint = bc;
        self
    }
    /// Sets the seed.
    pub fn with_seed(mut self, seed: u64) -> Self {
        self.seed = seed;
        self
    }
    /// Turns scaling on or off.
    pub fn with_scale(mut self, scale: bool) -> Self {
        self.scale = scale;
        self
    }
    /// Sets the scaling rule (and turns scaling on).
    pub fn with_scale_mode(mut self, mode: ScaleMode) -> Self {
        self.scale = true;
        self.scale_mode = mode;
        self
    }
    /// Sets the number of inducing inputs (`Some(M)`: the sparse model; `None`: exact).
    pub fn with_inducing(mut self, inducing: Option<usize>) -> Self {
        self.inducing = inducing;
        self
    }
    /// Keeps the inducing inputs fixed at their starting points (sparse model).
    pub fn with_fixed_inducing(mut self, fixed: bool) -> Self {
        self.fixed_inducing = fixed;
        self
    }
    /// The Bayesian model (on) or point latent positions (off); see [`ModelConfig::bayesian`].
    pub fn with_bayesian(mut self, bayesian: bool) -> Self {
        self.bayesian = bayesian;
        self
    }
    /// Sets the initial perturbation standard deviation.
    pub fn with_init_perturbation(mut self, s: f64) -> Self {
        self.init_perturbation = s;
        self
    }

    /// Checks the values that do not depend on the data.
    pub fn check(&self) -> Result<()> {
        let bad = |what: &str, reason: &str| {
            Err(Error::InvalidValue {
                what: what.into(),
                reason: reason.into(),
            })
        };
        if !(self.init_perturbation >= 0.0 && self.init_perturbation.is_finite()) {
            return bad(
                "ModelConfig::init_perturbation",
                "expected a finite number ≥ 0",
            );
        }
        if !(self.bc_ridge > 0.0 && self.bc_ridge.is_finite()) {
            return bad("ModelConfig::bc_ridge", "expected a finite number > 0");
        }
        if !(self.init_noise_fraction > 0.0 && self.init_noise_fraction.is_finite()) {
            return bad(
                "ModelConfig::init_noise_fraction",
                "expected a finite number > 0",
            );
        }
        if self.inducing == Some(0) {
            return bad(
                "ModelConfig::inducing",
                "expected at least 1 inducing input",
            );
        }
        if self.inducing.is_some() && self.back_constraint == BackConstraint::Output {
            return bad(
                "ModelConfig::inducing",
                "the sparse model supports back constraints none and input, not output",
            );
        }
        if self.bayesian && self.inducing.is_none() {
            return bad(
                "ModelConfig::bayesian",
                "the Bayesian model needs inducing inputs: set ModelConfig::inducing",
            );
        }
        Ok(())
    }
}

impl BackConstraint {
    /// Every back constraint, in the paper's order of presentation (none, input, output).
    pub const ALL: [BackConstraint; 3] = [Self::None, Self::Input, Self::Output];

    /// The lower-case name users type: `none`, `input` or `output`.
    pub fn name(self) -> &'static str {
        match self {
            Self::None => "none",
            Self::Input => "input",
            Self::Output => "output",
        }
    }
}

impl fmt::Display for BackConstraint {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for BackConstraint {
    type Err = Error;

    /// Parses `none`, `input` or `output` (exactly these lower-case names).
    fn from_str(s: &str) -> Result<Self> {
        Self::ALL
            .into_iter()
            .find(|bc| bc.name() == s)
            .ok_or_else(|| Error::InvalidValue {
                what: "back constraint".into(),
                reason: format!("'{s}'; expected one of none, input, output"),
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn back_constraint_names_round_trip_and_unknown_names_fail() {
        for bc in BackConstraint::ALL {
            assert_eq!(bc.to_string().parse::<BackConstraint>().unwrap(), bc);
        }
        assert_eq!(BackConstraint::Input.to_string(), "input");
        for bad in ["", "Input", "inputs", " none"] {
            let e = bad.parse::<BackConstraint>().unwrap_err().to_string();
            assert!(e.contains("expected one of none, input, output"), "{e}");
        }
        // The model file keeps format 1's serde names.
        let json = serde_json::to_string(&BackConstraint::Output).unwrap();
        assert_eq!(json, "\"Output\"");
    }

    #[test]
    fn check_rejects_bad_values() {
        assert!(ModelConfig::default().check().is_ok());
        let bad = [
            ModelConfig::default().with_init_perturbation(-1.0),
            ModelConfig {
                bc_ridge: 0.0,
                ..ModelConfig::default()
            },
            ModelConfig {
                init_noise_fraction: f64::NAN,
                ..ModelConfig::default()
            },
        ];
        for c in bad {
            assert!(
                matches!(c.check(), Err(Error::InvalidValue { .. })),
                "{c:?}"
            );
        }
    }
}
