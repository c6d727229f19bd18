//! The native model class behind `sgplvm.SharedGPLVM` (the Python wrapper in
//! `python/sgplvm/_model.py` converts arguments and adds pickling).
//!
//! The module's parts: `convert` (core errors as Python exceptions, numpy ↔ faer matrices,
//! back-constraint names), `training` (a training with the GIL released: Python's signal
//! handlers and callbacks) and `params` (parameters as nested dicts and back).

mod convert;
mod params;
mod training;

use numpy::{PyArray1, PyArray2, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};
use std::collections::BTreeMap;

use pyo3::exceptions::PyValueError;
use sgplvm::capture::girdle::GirdleAlignment;
use sgplvm::pipeline::human_pose_bounds;
use sgplvm::provenance::added_annotation;
use sgplvm_core::{KernelParams, Mat, ModelConfig, SharedGplvm, TrainOptions, Validation};

use crate::guard::guarded;
use convert::back_constraint_name;
pub(crate) use convert::{
    canonical_back_constraint, model_error, parse_back_constraint, read_error, to_mat, to_numpy,
};
pub(crate) use params::kernel_to_dict;
use params::{params_from_dict, params_to_dict};
pub(crate) use training::{finish_training, settle, signal_interrupt};
use training::{train_detached, PyCallbacks};

/// Posterior mean and, when asked for, variance.
type MeanAndVariance<'py> = (Bound<'py, PyArray2<f64>>, Option<Bound<'py, PyArray2<f64>>>);

/// A trained shared GP-LVM (native part; use `sgplvm.SharedGPLVM`).
#[pyclass(module = "sgplvm._sgplvm", name = "NativeModel", frozen)]
pub struct NativeModel {
    pub(crate) inner: SharedGplvm,
}

#[pymethods]
impl NativeModel {
    /// Fits a model on named spaces (one robot: full model; several: multi-robot). A signal
    /// handler's exception (Ctrl-C) stops training and is raised carrying the model trained so
    /// far as its `_sgplvm_native` attribute.
    #[staticmethod]
    #[pyo3(signature = (spaces, input, latent_dim, back_constraint, seed, scale, max_iters, validation, patience, max_seconds=None, callback=None, column_names=None, inducing=None, validation_callback=None, whiten_back_constraint=false, bayesian=false))]
    #[allow(clippy::too_many_arguments)]
    fn fit(
        py: Python<'_>,
        spaces: Vec<(String, PyReadonlyArray2<'_, f64>)>,
        input: &str,
        latent_dim: usize,
        back_constraint: Option<&str>,
        seed: u64,
        scale: bool,
        max_iters: usize,
        validation: Option<Vec<usize>>,
        patience: usize,
        max_seconds: Option<f64>,
        callback: Option<Py<PyAny>>,
        column_names: Option<Vec<(String, Vec<String>)>>,
        inducing: Option<usize>,
        validation_callback: Option<Py<PyAny>>,
        whiten_back_constraint: bool,
        bayesian: bool,
    ) -> PyResult<Self> {
        guarded(|| {
            let config = ModelConfig::default()
                .with_latent_dim(latent_dim)
                .with_back_constraint(parse_back_constraint(back_constraint)?)
                .with_seed(seed)
                .with_scale(scale)
                .with_inducing(inducing)
                .with_bayesian(bayesian);
            let mats: Vec<(String, Mat<f64>)> =
                spaces.iter().map(|(n, a)| (n.clone(), to_mat(a))).collect();
            let options = TrainOptions::default()
                .with_max_iters(max_iters)
                .with_max_seconds(max_seconds)
                .with_whiten_back_constraint(whiten_back_constraint);
            let input = input.to_string();
            let callbacks = PyCallbacks {
                callback,
                validation_callback,
            };
            let (mut model, signal) =
                train_detached(py, callbacks, options, |options, cb, on_selection| {
                    let views: Vec<(&str, _)> =
                        mats.iter().map(|(n, m)| (n.as_str(), m.as_ref())).collect();
                    match validation {
                        Some(rows) => {
                            let validation = Validation::new(rows).with_patience(patience);
                            SharedGplvm::fit_validated_observed(
                                &config,
                                &views,
                                &input,
                                options,
                                &validation,
                                on_selection,
                                cb,
                            )
                        }
                        None => SharedGplvm::fit(&config, &views, &input, options, cb),
                    }
                })?;
            let column_names = column_names.unwrap_or_default();
            // The novelty's threshold where 1 % of random poses within the human's joint
            // limits are followed, as `sgplvm train` sets it: an input space of the built-in
            // human's joints (named so, or 18 columns called `human`, the importer's order).
            let input_names = column_names
                .iter()
                .find(|(space, _)| *space == input)
                .map(|(_, names)| names.clone())
                .or_else(|| {
                    let human = mats.iter().find(|(n, _)| *n == input)?;
                    let builtin = sgplvm_robots::Robot::builtin("human").ok()?.joint_names();
                    (input == "human" && human.1.ncols() == builtin.len()).then_some(builtin)
                });
            for (space, names) in column_names {
                model.set_column_names(&space, names).map_err(model_error)?;
            }
            if let Some(bounds) = input_names.and_then(|n| human_pose_bounds(&n).ok()) {
                model
                    .set_pose_bounds(bounds, sgplvm_core::RANDOM_PERCENTILE)
                    .map_err(model_error)?;
            }
            finish_training(py, NativeModel { inner: model }, signal)
        })
    }

    /// A new model that also predicts for robot `name`, trained only on that robot's kernel.
    /// Ctrl-C as in [`NativeModel::fit`].
    #[pyo3(signature = (name, data, max_iters, validation, patience, max_seconds=None, callback=None, column_names=None, validation_callback=None))]
    #[allow(clippy::too_many_arguments)]
    fn transfer(
        &self,
        py: Python<'_>,
        name: &str,
        data: PyReadonlyArray2<'_, f64>,
        max_iters: usize,
        validation: Option<Vec<usize>>,
        patience: usize,
        max_seconds: Option<f64>,
        callback: Option<Py<PyAny>>,
        column_names: Option<Vec<String>>,
        validation_callback: Option<Py<PyAny>>,
    ) -> PyResult<Self> {
        guarded(|| {
            let data = to_mat(&data);
            let options = TrainOptions::default()
                .with_max_iters(max_iters)
                .with_max_seconds(max_seconds);
            let callbacks = PyCallbacks {
                callback,
                validation_callback,
            };
            let (mut model, signal) = train_detached(
                py,
                callbacks,
                options,
                |options, cb, on_selection| match validation {
                    Some(rows) => {
                        let validation = Validation::new(rows).with_patience(patience);
                        self.inner.transfer_validated_observed(
                            name,
                            data.as_ref(),
                            None,
                            options,
                            &validation,
                            on_selection,
                            cb,
                        )
                    }
                    None => self.inner.transfer(name, data.as_ref(), options, cb),
                },
            )?;
            if let Some(names) = column_names {
                model.set_column_names(name, names).map_err(model_error)?;
            }
            finish_training(py, NativeModel { inner: model }, signal)
        })
    }

    /// Why the last training stopped (`StopReason::name`), if the model was trained.
    #[getter]
    fn stop_reason(&self) -> Option<&'static str> {
        self.inner.stop_reason().map(|r| r.name())
    }

    /// Every third of nine equal blocks of `n` rows: the default validation rows.
    #[staticmethod]
    fn block_validation_rows(n: usize) -> Vec<usize> {
        Validation::blocks(n).rows
    }

    /// How the iteration budget was chosen on held-out frames (JSON), if it was.
    fn selection_json(&self) -> Option<String> {
        self.inner
            .selection()
            .and_then(|s| serde_json::to_string(s).ok())
    }

    /// Posterior mean (and variance, when asked) of `robot` for human frames `h` (n × D_H).
    fn predict<'py>(
        &self,
        py: Python<'py>,
        h: PyReadonlyArray2<'py, f64>,
        robot: &str,
        with_variance: bool,
    ) -> PyResult<MeanAndVariance<'py>> {
        guarded(|| {
            let h = to_mat(&h);
            let prediction = py
                .detach(|| self.inner.predict(h.as_ref(), robot, with_variance))
                .map_err(model_error)?;
            let variance = prediction.variance.as_ref().map(|v| to_numpy(py, v));
            Ok((to_numpy(py, &prediction.mean), variance))
        })
    }

    /// Each human frame's reconstruction error (n): how far the pose is from the model's own
    /// reconstruction of it, in the human space's standardised units (teleop's default gate).
    fn reconstruction_errors(
        &self,
        py: Python<'_>,
        h: PyReadonlyArray2<'_, f64>,
    ) -> PyResult<Vec<f64>> {
        guarded(|| {
            let h = to_mat(&h);
            py.detach(|| self.inner.reconstruction_errors(h.as_ref()))
                .map_err(model_error)
        })
    }

    /// The reconstruction threshold: frames above it are held live.
    fn reconstruction_threshold(&self) -> PyResult<f64> {
        guarded(|| self.inner.reconstruction_threshold().map_err(model_error))
    }

    /// Each human frame's distance to the nearest training pose (n), each joint in units of its
    /// spread over the training poses (teleop's default gate, with the reconstruction error).
    fn novelties(&self, py: Python<'_>, h: PyReadonlyArray2<'_, f64>) -> PyResult<Vec<f64>> {
        guarded(|| {
            let h = to_mat(&h);
            py.detach(|| self.inner.novelties(h.as_ref()))
                .map_err(model_error)
        })
    }

    /// One person's human frames (rows of `h`, in their order) with their clavicles aligned to
    /// the model's people, as `sgplvm predict` gives them to it; `None` where the model's human
    /// columns are not the human model's arm angles.
    fn align_girdle<'py>(
        &self,
        py: Python<'py>,
        h: PyReadonlyArray2<'_, f64>,
    ) -> PyResult<Option<Bound<'py, PyArray2<f64>>>> {
        let names = self.inner.column_names(self.inner.input_name());
        aligned_girdle(py, names, &self.inner.input_means(), &h)
    }

    /// The novelty threshold: frames farther than it from every training pose are held live.
    fn novelty_threshold(&self) -> PyResult<f64> {
        guarded(|| self.inner.novelty_threshold().map_err(model_error))
    }

    /// The trust threshold of `robot` (standardised predictive standard deviation).
    fn trust_threshold(&self, robot: &str) -> PyResult<f64> {
        guarded(|| self.inner.trust_threshold(robot).map_err(model_error))
    }

    /// Latent points of human frames (n × Q).
    fn latent<'py>(
        &self,
        py: Python<'py>,
        h: PyReadonlyArray2<'py, f64>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        guarded(|| {
            let h = to_mat(&h);
            let x = py
                .detach(|| self.inner.latent(h.as_ref()))
                .map_err(model_error)?;
            Ok(to_numpy(py, &x))
        })
    }

    /// Latent points of the training frames (N × Q).
    fn latent_points<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        to_numpy(py, &self.inner.latent_points().to_owned())
    }

    /// The annotations saved with the model (the person's calibration, the robots its commands
    /// were learned on, …) as one JSON object.
    fn annotations_json(&self) -> String {
        annotations_json(self.inner.annotations())
    }

    /// A copy with the annotations of the JSON object `json` added: robot records join those
    /// there, another key's value replaces its earlier one.
    fn with_annotations(&self, json: &str) -> PyResult<Self> {
        let mut inner = self.inner.clone();
        for (key, value) in added_annotations(inner.annotations(), json)? {
            inner.annotate(&key, value);
        }
        Ok(NativeModel { inner })
    }

    /// Name of the input (human) space.
    #[getter]
    fn input_name(&self) -> String {
        self.inner.input_name().to_string()
    }

    /// Names of the robot spaces.
    #[getter]
    fn output_names(&self) -> Vec<String> {
        self.inner
            .output_names()
            .into_iter()
            .map(str::to_string)
            .collect()
    }

    /// Column (joint) names of a space, if they were given.
    fn column_names(&self, space: &str) -> Option<Vec<String>> {
        self.inner.column_names(space).map(|c| c.to_vec())
    }

    /// Dimension of a space.
    fn space_dim(&self, space: &str) -> Option<usize> {
        self.inner.space_dim(space)
    }

    /// Inducing inputs Z (M×Q) of a sparse model; None for the exact model.
    fn inducing_inputs<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray2<f64>>> {
        self.inner
            .inducing_inputs()
            .map(|z| to_numpy(py, &z.to_owned()))
    }

    /// Variances S (N×Q) of a Bayesian model's q(X); None for point latent positions.
    fn latent_variances<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray2<f64>>> {
        self.inner
            .latent_variances()
            .map(|s| to_numpy(py, &s.to_owned()))
    }

    /// ARD weights α²/ℓ_q² of a space's kernel, one per latent dimension.
    fn ard_weights(&self, space: &str) -> PyResult<Vec<f64>> {
        self.inner.ard_weights(space).map_err(model_error)
    }

    /// Configuration as a dict (latent_dim, back_constraint, seed, scale, inducing, bayesian).
    pub(crate) fn config<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let c = self.inner.config();
        let d = PyDict::new(py);
        d.set_item("latent_dim", c.latent_dim)?;
        d.set_item("back_constraint", back_constraint_name(c.back_constraint))?;
        d.set_item("seed", c.seed)?;
        d.set_item("scale", c.scale)?;
        d.set_item("inducing", c.inducing)?;
        d.set_item("bayesian", c.bayesian)?;
        Ok(d)
    }

    /// Training history: iteration, objective, seconds, gradient norm and evaluations so far
    /// (objective + gradient, the line searches' trials included) per iteration.
    fn history<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let h = self.inner.history();
        let d = PyDict::new(py);
        d.set_item(
            "iteration",
            h.iter().map(|r| r.iteration).collect::<Vec<_>>(),
        )?;
        d.set_item(
            "objective",
            PyArray1::from_vec(py, h.iter().map(|r| r.objective).collect()),
        )?;
        d.set_item(
            "seconds",
            PyArray1::from_vec(py, h.iter().map(|r| r.seconds).collect()),
        )?;
        d.set_item(
            "gradient_norm",
            PyArray1::from_vec(py, h.iter().map(|r| r.gradient_norm).collect()),
        )?;
        d.set_item(
            "evaluations",
            h.iter().map(|r| r.evaluations).collect::<Vec<_>>(),
        )?;
        Ok(d)
    }

    /// Parameters in natural units as nested dicts of numpy arrays and floats.
    fn params<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        guarded(|| params_to_dict(py, &self.inner.params()))
    }

    /// Gradient of the objective, in the structure of `params`.
    fn gradient<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        guarded(|| params_to_dict(py, &self.inner.gradient()))
    }

    /// Negative log marginal likelihood at the current parameters.
    fn objective(&self) -> PyResult<f64> {
        guarded(|| Ok(self.inner.objective()))
    }

    /// A copy of the model with the given parameters.
    fn with_params(&self, params: &Bound<'_, PyDict>) -> PyResult<Self> {
        guarded(|| {
            let current = self.inner.params();
            let p = params_from_dict(params, &current)?;
            let model = self.inner.with_params(&p).map_err(model_error)?;
            Ok(NativeModel { inner: model })
        })
    }

    /// The versioned model file as bytes.
    fn to_bytes<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyBytes>> {
        guarded(|| Ok(PyBytes::new(py, &self.inner.to_bytes())))
    }

    /// Reads a model from bytes (`source` names them in errors).
    #[staticmethod]
    fn from_bytes(py: Python<'_>, bytes: &[u8], source: &str) -> PyResult<Self> {
        guarded(|| {
            py.detach(|| SharedGplvm::from_bytes(bytes))
                .map(|inner| NativeModel { inner })
                .map_err(|e| read_error(source, e))
        })
    }

    /// Writes the model file atomically.
    fn save(&self, py: Python<'_>, path: std::path::PathBuf) -> PyResult<()> {
        guarded(|| py.detach(|| self.inner.save(&path)).map_err(model_error))
    }

    /// Reads a model file.
    #[staticmethod]
    fn load(py: Python<'_>, path: std::path::PathBuf) -> PyResult<Self> {
        guarded(|| {
            py.detach(|| SharedGplvm::load(&path))
                .map(|inner| NativeModel { inner })
                .map_err(|e| read_error(&path.display().to_string(), e))
        })
    }
}

/// Annotations as one JSON object.
pub(crate) fn annotations_json(annotations: &BTreeMap<String, serde_json::Value>) -> String {
    serde_json::Value::Object(annotations.clone().into_iter().collect()).to_string()
}

/// Frames `h` of human columns `names` aligned to people of means `means`
/// (`sgplvm::girdle`); `None` where `names` are not the human model's arm angles.
pub(crate) fn aligned_girdle<'py>(
    py: Python<'py>,
    names: Option<&[String]>,
    means: &[f64],
    h: &PyReadonlyArray2<'_, f64>,
) -> PyResult<Option<Bound<'py, PyArray2<f64>>>> {
    guarded(|| {
        let Some(mut girdle) = names.and_then(|n| GirdleAlignment::new(n, means)) else {
            return Ok(None);
        };
        let mut frames = to_mat(h);
        if frames.ncols() != names.map_or(0, <[String]>::len) {
            return Err(PyValueError::new_err(format!(
                "H has {} columns; the model's human has {}",
                frames.ncols(),
                names.map_or(0, <[String]>::len)
            )));
        }
        sgplvm::girdle::align_rows(&mut girdle, &mut frames);
        Ok(Some(to_numpy(py, &frames)))
    })
}

/// The annotations of the JSON object `json` (Python's `json.dumps` of a dict) as they are to
/// be kept on a model whose annotations are `existing` (`added_annotation`: robot records
/// joined, each value checked where sgplvm reads it): a `ValueError` names the key and what
/// was expected, and nothing is to be added.
pub(crate) fn added_annotations(
    existing: &BTreeMap<String, serde_json::Value>,
    json: &str,
) -> PyResult<Vec<(String, serde_json::Value)>> {
    let given: BTreeMap<String, serde_json::Value> = serde_json::from_str(json).map_err(|e| {
        PyValueError::new_err(format!(
            "annotations: expected a mapping of names to JSON values: {e}"
        ))
    })?;
    given
        .into_iter()
        .map(|(key, value)| {
            let kept = added_annotation(existing, &key, value).map_err(PyValueError::new_err)?;
            Ok((key, kept))
        })
        .collect()
}

/// One space's negative collapsed variational bound of the sparse model (see
/// `sgplvm_core::sparse_bound`) at latent points `x`, inducing inputs `z`, data `y` and an
/// RBF-ARD kernel; `relative_jitter × variance` is added to K_mm's diagonal.
#[pyfunction]
#[pyo3(signature = (x, z, y, variance, lengthscale, noise, relative_jitter))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn sparse_bound(
    x: PyReadonlyArray2<'_, f64>,
    z: PyReadonlyArray2<'_, f64>,
    y: PyReadonlyArray2<'_, f64>,
    variance: f64,
    lengthscale: Vec<f64>,
    noise: f64,
    relative_jitter: f64,
) -> PyResult<f64> {
    guarded(|| {
        let kernel = KernelParams {
            variance,
            lengthscale,
            noise,
        };
        sgplvm_core::sparse_bound(
            to_mat(&x).as_ref(),
            to_mat(&z).as_ref(),
            to_mat(&y).as_ref(),
            &kernel,
            relative_jitter,
        )
        .map_err(model_error)
    })
}
