"""sgplvm on a Ray cluster: the paper's experiment, sweeps and fleet transfer, in parallel.

Needs Ray (``pip install "sgplvm[ray]"``); ``address=None`` starts or joins a local Ray.

* :func:`run_experiment` runs exactly the trainings of ``sgplvm experiment`` (the same plan, seeds
  and report code: :func:`sgplvm._sgplvm.experiment_plan`, ``experiment_execute``,
  ``experiment_assemble``), each as a Ray task with one CPU, and writes the same
  ``results.json``, ``report.md`` and figures. Every record but the measured seconds is
  bit-identical to the serial run's.
* :func:`sweep` trains one model per grid point and scores it on held-out rows of the training
  data (never a test set: it is not given one).
* :func:`transfer_fleet` transfers one trained model to many robots at once.
* :func:`tune_trainable` is a Ray Tune function trainable (``pip install "sgplvm[tune]"``): each
  trial trains one model and reports its validation error after every iteration of the
  selection run, so that Tune's schedulers (ASHA) can stop poor runs early;
  :func:`tune_model` loads a trial's model from its checkpoint.

Each task's numeric thread pool is sized to the CPUs Ray gave it (``RAYON_NUM_THREADS``, set in
the worker before its first training), so N tasks on N cores do not oversubscribe them.
"""

import itertools
import json
import os
import time
from typing import Any, Callable, Dict, List, Mapping, Optional, Sequence, Tuple, Union

from . import _sgplvm
from ._model import DEFAULT_PATIENCE, SharedGPLVM

__all__ = ["run_experiment", "sweep", "transfer_fleet", "experiment_config", "tune_trainable", "tune_model"]

PathLike = Union[str, "os.PathLike[str]"]

#: Retries of a task whose worker died (a training that raised is not retried: it would fail
#: again the same way).
MAX_RETRIES = 3


def _ray() -> Any:
    try:
        import ray
    except ImportError as e:  # pragma: no cover - depends on the installation
        raise ImportError('sgplvm.ray needs Ray: pip install "sgplvm[ray]"') from e
    return ray


def _ensure_ray(address: Optional[str]) -> Any:
    ray = _ray()
    if not ray.is_initialized():
        ray.init(address=address, include_dashboard=False, log_to_driver=False)
    return ray


def _use_cpus() -> None:
    """Sizes this worker's numeric thread pool to the CPUs Ray gave the running task (the pool
    is built once per process, on its first training, from ``RAYON_NUM_THREADS``)."""
    cpus = 1.0
    try:
        cpus = float(_ray().get_runtime_context().get_assigned_resources().get("CPU", 1.0))
    except Exception:  # outside a Ray task: one thread
        pass
    os.environ["RAYON_NUM_THREADS"] = str(max(1, int(cpus)))


def experiment_config(config: Union[str, Mapping[str, Any]] = "quick") -> Dict[str, Any]:
    """The protocol as a dict: ``"quick"`` or ``"paper"`` (as ``sgplvm experiment [--quick]``),
    or a dict of fields overriding the paper's protocol (``runs``, ``transfers_per_run``,
    ``max_iters``, ``transfer_max_iters``, ``latent_dim``, ``seed``, ``direct_max_iters``,
    ``patience``, ``fractions``)."""
    if isinstance(config, str):
        return dict(json.loads(_sgplvm.experiment_config(config)))
    base = json.loads(_sgplvm.experiment_config(str(config.get("base", "paper"))))
    unknown = sorted(set(config) - set(base) - {"base"})
    if unknown:
        raise ValueError(f"config: unknown fields {unknown}; expected some of {sorted(base)}")
    base.update({k: v for k, v in config.items() if k != "base"})
    return dict(base)


def _experiment_data(data: Union[None, PathLike, bytes]) -> bytes:
    if isinstance(data, (bytes, bytearray)):
        return bytes(data)
    return bytes(_sgplvm.experiment_data(None if data is None else os.fspath(data)))


def _execute(data: bytes, config: str, task: str, source: Optional[bytes]) -> Tuple[str, Optional[bytes]]:
    _use_cpus()
    result, model = _sgplvm.experiment_execute(data, config, task, source)
    return result, None if model is None else bytes(model)


def run_experiment(
    data: Union[None, PathLike, bytes] = None,
    config: Union[str, Mapping[str, Any]] = "quick",
    out: Optional[PathLike] = "experiment-out",
    address: Optional[str] = None,
    progress: Optional[Callable[[int, int, str], None]] = None,
    max_retries: int = MAX_RETRIES,
) -> dict:
    """The paper's experiment (as ``sgplvm experiment``) with every training a Ray task.

    ``data``: a demonstrations MCAP (``None``: the shipped or generated default, as the CLI).
    The data is sent to the cluster once (``ray.put``); a transfer takes its source model's
    object reference, so it starts as soon as that training ends. Results are collected with
    ``ray.wait`` and put in the plan's order; a task whose worker died is retried
    (``max_retries``). Only when every task has finished are ``results.json``, the figures and
    ``report.md`` written into ``out`` (each file atomically; ``None``: nothing written).
    ``progress(done, total, what)`` hears of each finished task. Returns the results dict."""
    ray = _ensure_ray(address)
    config_json = json.dumps(experiment_config(config))
    data_bytes = _experiment_data(data)
    tasks = json.loads(_sgplvm.experiment_plan(data_bytes, config_json))
    data_ref = ray.put(data_bytes)
    execute = ray.remote(num_cpus=1, num_returns=2, max_retries=int(max_retries), retry_exceptions=False)(_execute)
    records: Dict[int, Any] = {}
    models: Dict[int, Any] = {}
    for task in tasks:
        source = None if task["source"] is None else models[task["source"]]
        result, model = execute.remote(data_ref, config_json, json.dumps(task), source)
        records[task["id"]] = result
        if task["keep_model"]:
            models[task["id"]] = model
    pending = [records[t["id"]] for t in tasks]
    context = {records[t["id"]]: t["context"] for t in tasks}
    done = 0
    while pending:
        ready, pending = ray.wait(pending, num_returns=1)
        done += len(ready)
        if progress is not None:
            for ref in ready:
                progress(done, len(tasks), context[ref])
    # Fixed order: the plan's.
    results = ray.get([records[t["id"]] for t in tasks])
    results_json = _sgplvm.experiment_assemble(data_bytes, config_json, results)
    if out is not None:
        os.makedirs(os.fspath(out), exist_ok=True)
        _sgplvm.experiment_write_outputs(results_json, os.fspath(out))
    return dict(json.loads(results_json))


def run_experiment_serial(
    data: Union[None, PathLike, bytes] = None,
    config: Union[str, Mapping[str, Any]] = "quick",
    out: Optional[PathLike] = None,
) -> dict:
    """The serial experiment in this process: the code of ``sgplvm experiment``, for comparison."""
    config_json = json.dumps(experiment_config(config))
    results_json = _sgplvm.experiment_run(_experiment_data(data), config_json)
    if out is not None:
        os.makedirs(os.fspath(out), exist_ok=True)
        _sgplvm.experiment_write_outputs(results_json, os.fspath(out))
    return dict(json.loads(results_json))


# ---------------------------------------------------------------------------------- sweeps

_MODEL_KEYS = ("latent_dim", "back_constraint", "seed", "scale")


_FIT_KEYS = ("max_iters", "validation", "patience", "max_seconds", "inducing", "whiten_back_constraint")


def _grid_points(grid: Union[Mapping[str, Sequence[Any]], Sequence[Mapping[str, Any]]]) -> List[Dict[str, Any]]:
    if isinstance(grid, Mapping):
        keys = list(grid)
        points = [dict(zip(keys, values)) for values in itertools.product(*(list(grid[k]) for k in keys))]
    else:
        points = [dict(point) for point in grid]
    for point in points:
        unknown = sorted(set(point) - set(_MODEL_KEYS) - set(_FIT_KEYS))
        if unknown:
            raise ValueError(f"grid: unknown parameters {unknown}; expected some of {sorted(_MODEL_KEYS + _FIT_KEYS)}")
    return points


def _fit_point(
    spaces: Mapping[str, Any], input: str, point: Dict[str, Any], fit_options: Dict[str, Any]
) -> Tuple[Dict[str, Any], bytes]:
    _use_cpus()
    model_args = {k: v for k, v in point.items() if k in _MODEL_KEYS}
    fit_args = dict(fit_options)
    fit_args.update({k: v for k, v in point.items() if k not in _MODEL_KEYS})
    started = time.perf_counter()
    model = SharedGPLVM(**model_args).fit(spaces, input=input, **fit_args)
    seconds = time.perf_counter() - started
    selection = model.selection
    if selection is None:
        raise ValueError("sweep: every grid point needs held-out rows to be scored (validation=None given)")
    best = selection["best_iteration"]
    score = next(r["validation_mse"] for r in selection["curve"] if r["iteration"] == best)
    row = dict(point)
    row.update(validation_mse=score, best_iteration=best, seconds=seconds)
    return row, model.to_bytes()


def sweep(
    spaces: Mapping[str, Any],
    grid: Union[Mapping[str, Sequence[Any]], Sequence[Mapping[str, Any]]],
    input: str = "human",
    max_iters: int = 1000,
    validation: Any = "auto",
    patience: int = DEFAULT_PATIENCE,
    address: Optional[str] = None,
    max_retries: int = MAX_RETRIES,
) -> Tuple[List[Dict[str, Any]], SharedGPLVM]:
    """Trains one model per grid point, one Ray task each, and scores it on held-out rows of
    the *training* data: the validation error of the selection run at the iteration budget it
    chose (``validation="auto"`` holds out every third of nine blocks of frames, or give the
    rows, e.g. ``demo["validation"]``). No test data is given to a sweep, so none can leak into
    the choice.

    ``grid``: a dict of lists (every combination) or a list of dicts; keys are
    :class:`~sgplvm.SharedGPLVM` arguments (``latent_dim``, ``back_constraint``, ``seed``,
    ``scale``) or :meth:`~sgplvm.SharedGPLVM.fit` arguments (``max_iters``, ``patience``,
    ``inducing``, ``whiten_back_constraint``, …).
    Returns the table (one dict per point, best first: its parameters, ``validation_mse``,
    ``best_iteration``, ``seconds``) and the best model (trained on all training rows with
    the chosen budget). Ties keep grid order."""
    ray = _ensure_ray(address)
    points = _grid_points(grid)
    if not points:
        raise ValueError("grid: no points; expected a dict of lists or a list of dicts")
    spaces_ref = ray.put({k: v for k, v in spaces.items()})
    fit_options = {"max_iters": max_iters, "validation": validation, "patience": patience}
    remote = ray.remote(num_cpus=1, num_returns=2, max_retries=int(max_retries), retry_exceptions=False)(_fit_point)
    refs = [remote.remote(spaces_ref, input, point, fit_options) for point in points]
    # Only the scores come to the driver; the models stay in the object store but the best.
    rows = ray.get([row for row, _ in refs])
    order = sorted(range(len(rows)), key=lambda i: (rows[i]["validation_mse"], i))
    table = [rows[i] for i in order]
    return table, SharedGPLVM.from_bytes(ray.get(refs[order[0]][1]))


# ---------------------------------------------------------------------------------- fleets


def _transfer_one(model: bytes, name: str, data: Any, options: Dict[str, Any]) -> bytes:
    _use_cpus()
    return SharedGPLVM.from_bytes(model).transfer(name, data, **options).to_bytes()


def transfer_fleet(
    model: SharedGPLVM,
    robots: Mapping[str, Any],
    address: Optional[str] = None,
    max_retries: int = MAX_RETRIES,
    **options: Any,
) -> Dict[str, SharedGPLVM]:
    """Transfers ``model`` to every robot of ``robots`` (name → joint data, the same frames as
    the model's human training data) in parallel, one Ray task each; ``options`` go to
    :meth:`~sgplvm.SharedGPLVM.transfer` (``max_iters``, ``validation``, ``patience``, …).
    The model is sent once. Returns the transferred models by name, each identical to
    ``model.transfer(name, data, **options)``."""
    ray = _ensure_ray(address)
    model_ref = ray.put(model.to_bytes())
    remote = ray.remote(num_cpus=1, max_retries=int(max_retries), retry_exceptions=False)(_transfer_one)
    refs = {name: remote.remote(model_ref, name, data, dict(options)) for name, data in robots.items()}
    names = list(refs)
    models = ray.get([refs[n] for n in names])
    return {n: SharedGPLVM.from_bytes(b) for n, b in zip(names, models)}


# ---------------------------------------------------------------------------------- Ray Tune

#: The file of a trial's checkpoint that holds its model (:meth:`SharedGPLVM.to_bytes`).
TUNE_MODEL_FILE = "model.sgplvm"


def _tune() -> Any:
    try:
        from ray import tune
    except ImportError as e:  # pragma: no cover - depends on the installation
        raise ImportError('sgplvm.ray.tune_trainable needs Ray Tune: pip install "sgplvm[tune]"') from e
    return tune


def _tune_trial(
    config: Dict[str, Any],
    spaces: Optional[Mapping[str, Any]] = None,
    input: str = "human",
    fit_options: Optional[Dict[str, Any]] = None,
    report_every: int = 1,
    checkpoint: bool = True,
) -> None:
    """One Tune trial: trains the model of ``config`` (see :func:`tune_trainable`)."""
    import math
    import tempfile

    tune = _tune()
    _use_cpus()
    assert spaces is not None, "tune.with_parameters passes the data"
    (point,) = _grid_points([config])
    model_args = {k: v for k, v in point.items() if k in _MODEL_KEYS}
    fit_args = dict(fit_options or {})
    fit_args.update({k: v for k, v in point.items() if k not in _MODEL_KEYS})
    if fit_args.get("validation", "auto") is None:
        raise ValueError("tune_trainable: validation=None given; a trial is scored on held-out rows")
    best: Dict[str, Any] = {"validation_mse": math.inf, "iteration": 0}

    def hear(record: Dict[str, Any]) -> None:
        error = record["validation_mse"]
        if math.isfinite(error) and error < best["validation_mse"]:
            best.update(validation_mse=error, iteration=record["iteration"])
        if record["iteration"] % report_every == 0:
            tune.report(
                {
                    "iteration": record["iteration"],
                    "objective": record["objective"],
                    "validation_mse": error,
                    "best_validation_mse": best["validation_mse"],
                    "best_iteration": best["iteration"],
                }
            )

    model = SharedGPLVM(**model_args).fit(spaces, input=input, validation_callback=hear, **fit_args)
    selection = model.selection
    assert selection is not None, "a fit with validation records its selection"
    chosen = selection["best_iteration"]
    objective = model.history["objective"]
    score = next((r["validation_mse"] for r in selection["curve"] if r["iteration"] == chosen), math.nan)
    final = {
        "iteration": selection["curve"][-1]["iteration"] if selection["curve"] else 0,
        # The final run's objective: trained on all rows for the chosen budget.
        "objective": float(objective[-1]) if len(objective) else math.nan,
        "validation_mse": score,
        "best_validation_mse": score,
        "best_iteration": chosen,
        "done_training": True,
    }
    if not checkpoint:
        tune.report(final)
        return
    with tempfile.TemporaryDirectory() as directory:
        with open(os.path.join(directory, TUNE_MODEL_FILE), "wb") as f:
            f.write(model.to_bytes())
        tune.report(final, checkpoint=tune.Checkpoint.from_directory(directory))


def tune_trainable(
    spaces: Mapping[str, Any],
    input: str = "human",
    max_iters: int = 1000,
    validation: Any = "auto",
    patience: int = DEFAULT_PATIENCE,
    report_every: int = 1,
    checkpoint: bool = True,
) -> Any:
    """A Ray Tune function trainable that trains one model per trial on ``spaces``.

    Use it as any function trainable::

        tuner = tune.Tuner(
            sgplvm.ray.tune_trainable({"human": H, "walkman": R}),
            param_space={"latent_dim": tune.grid_search([2, 3, 5]), "back_constraint": "input"},
            tune_config=tune.TuneConfig(metric="validation_mse", mode="min", reuse_actors=True,
                                        scheduler=ASHAScheduler(grace_period=2)),
        )
        best = sgplvm.ray.tune_model(tuner.fit().get_best_result(
            metric="best_validation_mse", mode="min", scope="last").checkpoint)

    A trial's config holds :class:`~sgplvm.SharedGPLVM` arguments (``latent_dim``,
    ``back_constraint``, ``seed``, ``scale``) and :meth:`~sgplvm.SharedGPLVM.fit` arguments
    (``inducing``, ``max_iters``, ``patience``, ``max_seconds``, ``validation``), overriding
    the ones given here; another key is a ``ValueError``. ``spaces`` go to the cluster once
    (``tune.with_parameters``); a trial takes one CPU and computes on one thread. Pass
    ``reuse_actors=True`` to ``TuneConfig``: a new actor per trial (Ray's default) costs
    seconds, more than a small training (BENCHMARKS.md).

    Each trial is scored on held-out rows of the *training* data as :meth:`~sgplvm.SharedGPLVM.fit`
    chooses its iteration budget (``validation``; never a test set). After the initial model and
    every ``report_every``-th iteration of that selection run it calls ``ray.tune.report`` with
    ``iteration``, ``objective``, ``validation_mse`` (that iteration's held-out error; ``nan``
    when the model could not predict), ``best_validation_mse`` and ``best_iteration`` (so far):
    a scheduler stops poor trials there. Tune counts reports as ``training_iteration``; with
    ``report_every`` > 1 use ``time_attr="iteration"`` to count iterations. A trial that runs to
    the end trains the model on all rows for its best iteration and reports once more —
    ``validation_mse`` and ``best_validation_mse`` the chosen score, ``done_training`` True —
    with the model as its checkpoint (``checkpoint=False``: none); :func:`tune_model` loads it.
    """
    tune = _tune()
    if isinstance(report_every, bool) or int(report_every) < 1:
        raise ValueError(f"report_every is {report_every!r}; expected an integer >= 1")
    if validation is None:
        raise ValueError("tune_trainable: validation=None given; every trial needs held-out rows to be scored")
    fit_options = {"max_iters": max_iters, "validation": validation, "patience": patience}
    trainable = tune.with_parameters(
        _tune_trial,
        spaces={k: v for k, v in spaces.items()},
        input=input,
        fit_options=fit_options,
        report_every=int(report_every),
        checkpoint=bool(checkpoint),
    )
    return tune.with_resources(trainable, {"cpu": 1})


def tune_model(checkpoint: Any) -> SharedGPLVM:
    """The model of a :func:`tune_trainable` trial's checkpoint (``result.checkpoint``),
    bit-identical to the one the trial trained."""
    if checkpoint is None:
        raise ValueError("tune_model: no checkpoint; a trial stopped early by the scheduler has none")
    with checkpoint.as_directory() as directory:
        path = os.path.join(directory, TUNE_MODEL_FILE)
        if not os.path.exists(path):
            raise ValueError(f"{path}: no model in this checkpoint; expected a tune_trainable trial's")
        with open(path, "rb") as f:
            return SharedGPLVM.from_bytes(f.read())
