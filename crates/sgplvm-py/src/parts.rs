//! The native class behind `sgplvm.PartsGPLVM`: a latent space per body part
//! (`sgplvm_core::PartsGplvm`), and the functions the Python wrapper needs around it — a body's
//! arm columns from its joint names (the facade's rule) and a model file of either kind.

use std::collections::BTreeMap;
use std::sync::{Arc, Mutex, PoisonError};

use numpy::{PyArray2, PyReadonlyArray2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};
use sgplvm_core::{
    AnyModel, Control, IterationRecord, Mat, ModelConfig, PartSpec, PartStage, PartsConfig,
    PartsGplvm, SharedGplvm, TrainOptions, Validation,
};

use crate::guard::guarded;
use crate::model::{
    added_annotations, aligned_girdle, annotations_json, finish_training, model_error,
    parse_back_constraint, read_error, settle, signal_interrupt, to_mat, to_numpy, NativeModel,
};

/// Parts as Python gives them: (part name, [(space name, columns)]).
type PartColumns = Vec<(String, Vec<(String, Vec<usize>)>)>;

/// Posterior mean and, when asked for, variance.
type MeanAndVariance<'py> = (Bound<'py, PyArray2<f64>>, Option<Bound<'py, PyArray2<f64>>>);

/// A trained model with a latent space per body part (native part; use `sgplvm.PartsGPLVM`).
#[pyclass(module = "sgplvm._sgplvm", name = "NativePartsModel", frozen)]
pub struct NativePartsModel {
    pub(crate) inner: PartsGplvm,
}

/// What a per-part training heard from Python: the exception a callback raised, and the one a
/// signal handler raised (Ctrl-C).
#[derive(Default)]
struct Heard {
    raised: Mutex<Option<PyErr>>,
    signal: Arc<Mutex<Option<PyErr>>>,
}

/// Runs a per-part training with the GIL released: Ctrl-C stops it (every remaining model at
/// its first check) and is raised with the model trained so far as `_sgplvm_native`;
/// `callback(part, iteration, objective)` hears every iteration (False stops that model's
/// training; an exception stops it and is raised).
fn train_parts(
    py: Python<'_>,
    options: TrainOptions,
    callback: Option<Py<PyAny>>,
    train: impl FnOnce(
            &TrainOptions,
            Option<sgplvm_core::PartsCallback<'_>>,
        ) -> sgplvm_core::Result<PartsGplvm>
        + Send,
) -> PyResult<NativePartsModel> {
    let heard = Arc::new(Heard::default());
    let options = options.with_interrupt(signal_interrupt(Arc::clone(&heard.signal)));
    let result = py.detach(|| {
        let mut hear = callback.as_ref().map(|cb| {
            let heard = Arc::clone(&heard);
            move |stage: PartStage<'_>, rec: &IterationRecord, _: &SharedGplvm| {
                let name = match stage {
                    PartStage::Part { name, .. } => name.to_string(),
                    PartStage::Parent => "parent".to_string(),
                };
                Python::attach(
                    |py| match cb.call1(py, (name, rec.iteration, rec.objective)) {
                        Ok(v) if !v.is_none(py) && !v.is_truthy(py).unwrap_or(true) => {
                            Control::Stop
                        }
                        Ok(_) => Control::Continue,
                        Err(e) => {
                            let mut raised =
                                heard.raised.lock().unwrap_or_else(PoisonError::into_inner);
                            raised.get_or_insert(e);
                            Control::Stop
                        }
                    },
                )
            }
        });
        train(
            &options,
            hear.as_mut().map(|f| f as sgplvm_core::PartsCallback<'_>),
        )
    });
    let (model, signal) = settle(py, Some(&heard.raised), &heard.signal, result)?;
    finish_training(py, NativePartsModel { inner: model }, signal)
}

/// `parts` as the core takes them: (part name, [(space, columns)]).
fn specs(parts: PartColumns) -> Vec<PartSpec> {
    parts
        .into_iter()
        .map(|(name, columns)| PartSpec::new(name, columns))
        .collect()
}

#[pymethods]
impl NativePartsModel {
    /// Fits a latent space per part of `parts` on named spaces (see `sgplvm_core::PartsGplvm`).
    #[staticmethod]
    #[pyo3(signature = (spaces, input, parts, latent_dim, back_constraint, seed, scale, max_iters, validation, patience, max_seconds=None, callback=None, column_names=None, inducing=None, bayesian=false, parent_latent_dim=None))]
    #[allow(clippy::too_many_arguments)]
    fn fit(
        py: Python<'_>,
        spaces: Vec<(String, PyReadonlyArray2<'_, f64>)>,
        input: &str,
        parts: PartColumns,
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
        bayesian: bool,
        parent_latent_dim: Option<usize>,
    ) -> PyResult<Self> {
        guarded(|| {
            let model = ModelConfig::default()
                .with_latent_dim(latent_dim)
                .with_back_constraint(parse_back_constraint(back_constraint)?)
                .with_seed(seed)
                .with_scale(scale)
                .with_inducing(inducing)
                .with_bayesian(bayesian);
            let config =
                PartsConfig::new(model, specs(parts)).with_parent_latent_dim(parent_latent_dim);
            let mats: Vec<(String, Mat<f64>)> =
                spaces.iter().map(|(n, a)| (n.clone(), to_mat(a))).collect();
            let options = TrainOptions::default()
                .with_max_iters(max_iters)
                .with_max_seconds(max_seconds);
            let validation = validation.map(|rows| Validation::new(rows).with_patience(patience));
            let mut trained = train_parts(py, options, callback, |options, cb| {
                let views: Vec<(&str, _)> =
                    mats.iter().map(|(n, m)| (n.as_str(), m.as_ref())).collect();
                PartsGplvm::fit(&config, &views, input, options, validation.as_ref(), cb)
            })?;
            for (space, names) in column_names.unwrap_or_default() {
                trained
                    .inner
                    .set_column_names(&space, names)
                    .map_err(model_error)?;
            }
            Ok(trained)
        })
    }

    /// A new model that also predicts robot `name` (`columns`: each part's columns of `data`),
    /// each part training only that robot's kernel.
    #[pyo3(signature = (name, data, columns, max_iters, validation, patience, max_seconds=None, callback=None, column_names=None))]
    #[allow(clippy::too_many_arguments)]
    fn transfer(
        &self,
        py: Python<'_>,
        name: &str,
        data: PyReadonlyArray2<'_, f64>,
        columns: Vec<(String, Vec<usize>)>,
        max_iters: usize,
        validation: Option<Vec<usize>>,
        patience: usize,
        max_seconds: Option<f64>,
        callback: Option<Py<PyAny>>,
        column_names: Option<Vec<String>>,
    ) -> PyResult<Self> {
        guarded(|| {
            let data = to_mat(&data);
            let columns: BTreeMap<String, Vec<usize>> = columns.into_iter().collect();
            let options = TrainOptions::default()
                .with_max_iters(max_iters)
                .with_max_seconds(max_seconds);
            let validation = validation.map(|rows| Validation::new(rows).with_patience(patience));
            let mut trained = train_parts(py, options, callback, |options, cb| {
                self.inner.transfer(
                    name,
                    data.as_ref(),
                    &columns,
                    options,
                    validation.as_ref(),
                    cb,
                )
            })?;
            if let Some(names) = column_names {
                trained
                    .inner
                    .set_column_names(name, names)
                    .map_err(model_error)?;
            }
            Ok(trained)
        })
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
            let p = py
                .detach(|| self.inner.predict(h.as_ref(), robot, with_variance))
                .map_err(model_error)?;
            let variance = p.variance.as_ref().map(|v| to_numpy(py, v));
            Ok((to_numpy(py, &p.mean), variance))
        })
    }

    /// Latent points of human frames: every part's side by side (n × ΣQ).
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

    /// Latent points of the training frames, every part's side by side (N × ΣQ).
    fn latent_points<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        to_numpy(py, &self.inner.latent_points())
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

    /// Column (joint) names of a space, if stored.
    fn column_names(&self, space: &str) -> Option<Vec<String>> {
        self.inner.column_names(space).map(<[String]>::to_vec)
    }

    /// Dimension of a space.
    fn space_dim(&self, space: &str) -> Option<usize> {
        self.inner.space_dim(space)
    }

    /// One person's human frames aligned to the model's people ([`NativeModel`]'s
    /// `align_girdle`).
    fn align_girdle<'py>(
        &self,
        py: Python<'py>,
        h: PyReadonlyArray2<'_, f64>,
    ) -> PyResult<Option<Bound<'py, PyArray2<f64>>>> {
        let names = self.inner.column_names(self.inner.input_name());
        aligned_girdle(py, names, &self.inner.input_means(), &h)
    }

    /// The parts' names, in order.
    #[getter]
    fn part_names(&self) -> Vec<String> {
        self.inner
            .part_names()
            .into_iter()
            .map(str::to_string)
            .collect()
    }

    /// Each space's columns of part `name` (space → column indices); None for an unknown part.
    fn part_columns<'py>(
        &self,
        py: Python<'py>,
        name: &str,
    ) -> PyResult<Option<Bound<'py, PyDict>>> {
        let Some(spec) = self.inner.part_specs().into_iter().find(|p| p.name == name) else {
            return Ok(None);
        };
        let d = PyDict::new(py);
        for (space, columns) in spec.columns {
            d.set_item(space, columns)?;
        }
        Ok(Some(d))
    }

    /// The shared GP-LVM of part `name` (its spaces hold the part's columns).
    fn part(&self, name: &str) -> PyResult<NativeModel> {
        self.inner
            .part(name)
            .map(|m| NativeModel { inner: m.clone() })
            .ok_or_else(|| {
                PyValueError::new_err(format!(
                    "no part named {name:?}; the model's parts are {:?}",
                    self.inner.part_names()
                ))
            })
    }

    /// The parent above the parts (its spaces are the parts' latent points), if trained.
    fn parent(&self) -> Option<NativeModel> {
        self.inner
            .parent()
            .map(|m| NativeModel { inner: m.clone() })
    }

    /// Number of training frames.
    #[getter]
    fn num_points(&self) -> usize {
        self.inner.num_points()
    }

    /// The parts' configuration as a dict (latent_dim, back_constraint, seed, scale, inducing,
    /// bayesian) with parent_latent_dim.
    fn config<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = self.part(self.inner.part_names()[0])?.config(py)?;
        d.set_item(
            "parent_latent_dim",
            self.inner.parent().map(|p| p.config().latent_dim),
        )?;
        Ok(d)
    }

    /// The annotations saved with the model (kept with its first part) as one JSON object.
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
        Ok(NativePartsModel { inner })
    }

    /// The versioned model file (format 4) as bytes.
    fn to_bytes<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyBytes>> {
        guarded(|| Ok(PyBytes::new(py, &self.inner.to_bytes())))
    }

    /// Reads a model from bytes (`source` names them in errors).
    #[staticmethod]
    fn from_bytes(py: Python<'_>, bytes: &[u8], source: &str) -> PyResult<Self> {
        guarded(|| {
            py.detach(|| PartsGplvm::from_bytes(bytes))
                .map(|inner| NativePartsModel { inner })
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
            py.detach(|| PartsGplvm::load(&path))
                .map(|inner| NativePartsModel { inner })
                .map_err(|e| read_error(&path.display().to_string(), e))
        })
    }
}

/// The left-arm and right-arm columns of body `body` with joints `joints`: by the built-in
/// robot's anatomy when `body` names one, else by the joints' names (`jLeft…`/`jRight…`,
/// `L…`/`R…`, `left_…`/`right_…`, `j_arm1_…`/`j_arm2_…`).
#[pyfunction]
pub fn arm_columns(body: &str, joints: Vec<String>) -> PyResult<(Vec<usize>, Vec<usize>)> {
    guarded(|| {
        let error = |e: sgplvm::pipeline::PipelineError| PyValueError::new_err(e.to_string());
        let anatomy = sgplvm::pipeline::known_anatomy(body, None).map_err(error)?;
        let known = anatomy.filter(|a| {
            let arms = a.arm_joint_names();
            joints.iter().all(|j| arms.contains(j))
        });
        let [left, right] =
            sgplvm::pipeline::arm_columns(body, &joints, known.as_ref()).map_err(error)?;
        Ok((left, right))
    })
}

/// Reads a model file of either kind: a `NativeModel` (one shared latent space) or a
/// `NativePartsModel` (a latent space per body part).
#[pyfunction]
pub fn load_any(py: Python<'_>, path: std::path::PathBuf) -> PyResult<Py<PyAny>> {
    guarded(|| {
        let model = py
            .detach(|| AnyModel::load(&path))
            .map_err(|e| read_error(&path.display().to_string(), e))?;
        Ok(match model {
            AnyModel::Single(inner) => Py::new(py, NativeModel { inner })?.into_any(),
            AnyModel::Parts(inner) => Py::new(py, NativePartsModel { inner })?.into_any(),
        })
    })
}
