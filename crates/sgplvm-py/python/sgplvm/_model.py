"""The user-facing model class: numpy in, numpy out, over the native Rust model."""

from __future__ import annotations

import json
import operator
import os
from typing import Any, Callable, Dict, List, Mapping, Optional, Tuple, Union

import numpy as np

from . import _sgplvm

ArrayLike = Union[np.ndarray, list, tuple]


def _refuse_complex(value: object, what: str) -> None:
    """Complex values would lose their imaginary part in the float64 conversion: refused."""
    probe = value if isinstance(value, np.ndarray) else np.asarray(value)
    if np.iscomplexobj(probe):
        raise ValueError(f"{what}: expected real numbers, got a {probe.dtype} array")


def _integer(value: object, what: str, minimum: int) -> int:
    """``value`` as an int (a Python or numpy integer, not a bool or a float like 2.7)."""
    if isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{what} is {value!r}; expected an integer >= {minimum}")
    try:
        number = operator.index(value)  # type: ignore[arg-type]
    except TypeError:
        raise ValueError(f"{what} is {value!r}; expected an integer >= {minimum}") from None
    if number < minimum:
        raise ValueError(f"{what} is {value!r}; expected an integer >= {minimum}")
    return number


def _as_matrix(value: ArrayLike, what: str) -> np.ndarray:
    """A C-contiguous float64 2-D array from anything numpy can convert (not complex)."""
    _refuse_complex(value, what)
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise ValueError(f"{what}: cannot convert to a float64 array ({e})") from None
    if array.ndim != 2:
        raise ValueError(f"{what}: expected a 2-D array (frames × joints), got {array.ndim}-D")
    return np.ascontiguousarray(array)


def _as_frames(value: ArrayLike, what: str) -> Tuple[np.ndarray, bool]:
    """2-D frames; a single 1-D frame is accepted and flagged so results can be squeezed."""
    _refuse_complex(value, what)
    array = np.asarray(value, dtype=np.float64) if not isinstance(value, np.ndarray) else value
    if array.ndim == 1:
        return _as_matrix(array[None, :], what), True
    return _as_matrix(array, what), False


def _align_girdle(native, H: ArrayLike) -> np.ndarray:
    """``align_girdle`` of a native model of either kind (one frame or n)."""
    frames, single = _as_frames(H, "H")
    aligned = native.align_girdle(frames)
    out = frames if aligned is None else aligned
    return out[0] if single else out


def _per_frame_signal(signal: Callable[[np.ndarray], object], frames: np.ndarray) -> np.ndarray:
    """``signal`` of every frame, NaN for a frame it cannot give one for (a non-finite value,
    a pose far enough to overflow): the gate holds on a signal that is not a number, frame by
    frame, not the whole batch (``trust-gate.md``)."""
    out = np.full(len(frames), np.nan)
    finite = np.isfinite(frames).all(axis=1)
    if not finite.any():
        return out
    try:
        out[finite] = np.asarray(signal(frames[finite]), dtype=float)
    except ValueError as batch_error:
        answered = False
        for k in np.flatnonzero(finite):
            try:
                out[k] = float(np.asarray(signal(frames[k : k + 1]), dtype=float)[0])
                answered = True
            except ValueError:
                pass
        if not answered:
            raise batch_error  # no frame answers: the input itself is wrong (its shape, say)
    return out


Validation = Union[str, None, np.ndarray, list, tuple]

#: Iterations without a lower validation error after which the selection run stops.
DEFAULT_PATIENCE: int = _sgplvm.DEFAULT_PATIENCE

#: Inducing inputs of a Bayesian model when ``fit`` is given none (at most one per frame).
DEFAULT_BAYESIAN_INDUCING: int = 50


def _validation_rows(validation: Validation, n: int) -> Optional[list]:
    """The rows to hold out as a list of ints (``None``: no validation) from ``"auto"``,
    ``None``, row indices or a boolean mask of ``n`` rows."""
    if validation is None:
        return None
    if isinstance(validation, str):
        if validation != "auto":
            raise ValueError(
                f"validation is {validation!r}; expected 'auto', None, row indices or a boolean mask"
            )
        return list(_sgplvm.NativeModel.block_validation_rows(n))
    rows = np.asarray(validation)
    if rows.ndim != 1:
        raise ValueError(f"validation: expected a 1-D array of row indices, got {rows.ndim}-D")
    if rows.dtype == np.bool_:
        if len(rows) != n:
            raise ValueError(f"validation: a boolean mask of {len(rows)} rows; the data has {n}")
        return [int(r) for r in np.flatnonzero(rows)]
    if rows.size and not np.issubdtype(rows.dtype, np.integer):
        raise ValueError(f"validation: expected integer row indices, got {rows.dtype}")
    if rows.size and rows.min() < 0:
        raise ValueError(f"validation: row {int(rows.min())} is negative; expected 0 <= row < {n}")
    return [int(r) for r in rows]


def _patience(patience: int) -> int:
    return _integer(patience, "patience", 0)


def _max_seconds(max_seconds: Optional[float]) -> Optional[float]:
    if max_seconds is None:
        return None
    seconds = float(max_seconds)
    if not seconds >= 0.0:
        raise ValueError(f"max_seconds is {max_seconds!r}; expected a number of seconds >= 0 or None")
    return seconds


#: ``validation_callback(record)`` of :meth:`SharedGPLVM.fit`: ``record`` is
#: ``{"iteration": int, "objective": float, "validation_mse": float}``; ``False`` stops.
ValidationCallback = Callable[[Dict[str, Any]], Optional[bool]]


def _check_validation_callback(validation_callback: Any, validation: Any) -> None:
    if validation_callback is None:
        return
    if not callable(validation_callback):
        raise ValueError(f"validation_callback is {validation_callback!r}; expected a function of one dict")
    if validation is None:
        raise ValueError(
            "validation_callback is given but validation is None: there are no held-out rows to "
            "score; give validation='auto' or the rows to hold out"
        )


def _builtin_joint_names(space: str, columns: int) -> Optional[list]:
    """The joints of the built-in body named ``space`` (``"human"``, ``"coman"``, …: the order
    :func:`load_demonstrations` gives them in) when it has ``columns`` of them; else ``None``."""
    try:
        names = list(_sgplvm.Robot.builtin(space).joint_names)
    except ValueError:
        return None
    return names if len(names) == columns else None


def _named_columns(
    arrays: List[Tuple[str, np.ndarray]], column_names: Optional[Mapping[str, Any]]
) -> Optional[List[Tuple[str, list]]]:
    """The joint names to store per space: those given, else a built-in body's for a space named
    after it with as many columns (so that the command line can read joint states by name)."""
    given = {} if column_names is None else {str(k): list(v) for k, v in column_names.items()}
    names = []
    for space, data in arrays:
        found = given.pop(space, None)
        if found is None:
            found = _builtin_joint_names(space, data.shape[1])
        if found is not None:
            names.append((space, found))
    # Names of a space that is not in ``spaces``: the native model says which.
    names.extend(given.items())
    return names or None


def _interrupted_model(error: BaseException) -> "Optional[_sgplvm.NativeModel]":
    """The model trained until a signal (Ctrl-C) interrupted it, which the native training
    attaches to the exception the signal handler raised."""
    return getattr(error, "_sgplvm_native", None)


class SharedGPLVM:
    """A shared Gaussian-process latent variable model between a human and one or more robots.

    Parameters
    ----------
    latent_dim:
        Dimension Q of the shared latent space (the paper uses 5).
    back_constraint:
        ``"input"`` (the paper's choice: latent points are a kernel mapping of the human data),
        ``"output"`` (a kernel mapping of the robot data) or ``None`` (free latent points).
    seed:
        Seed of the initialisation; training is deterministic for a given seed.
    scale:
        Scale every space to unit column variance after centring (off by default, so that
        values compare with GPy's on the same data).
    bayesian:
        The Bayesian shared GP-LVM (manifold relevance determination, as GPy's ``MRD``): each
        frame's latent point gets a Gaussian posterior (means back-constrained on the human
        input or free, as ``back_constraint`` says; variances :attr:`latent_variances`) and a
        KL term to the N(0, I) prior replaces the freedom that lets point latent positions
        overfit, while each space's ARD lengthscales switch off the latent dimensions it does
        not need (:meth:`ard_weights`): ``latent_dim`` is then an upper bound, and training to
        convergence (``validation=None``) is its intended use. It is sparse: ``fit``'s
        ``inducing`` defaults to min(50, frames) for it.
    """

    def __init__(
        self,
        latent_dim: int = 5,
        back_constraint: Optional[str] = "input",
        seed: int = 0,
        scale: bool = False,
        bayesian: bool = False,
    ) -> None:
        canonical = _sgplvm.canonical_back_constraint(back_constraint)
        self.latent_dim = _integer(latent_dim, "latent_dim", 1)
        self.back_constraint = canonical
        self.seed = _integer(seed, "seed", 0)
        self.scale = bool(scale)
        self.bayesian = bool(bayesian)
        self._native: Optional[_sgplvm.NativeModel] = None

    # ------------------------------------------------------------------ training

    def fit(
        self,
        spaces: Mapping[str, ArrayLike],
        input: str = "human",
        max_iters: int = 1000,
        callback: Optional[Callable[[int, float], Optional[bool]]] = None,
        column_names: Optional[Mapping[str, list]] = None,
        validation: Validation = "auto",
        patience: int = DEFAULT_PATIENCE,
        max_seconds: Optional[float] = None,
        inducing: Optional[int] = None,
        validation_callback: Optional[ValidationCallback] = None,
        whiten_back_constraint: bool = False,
    ) -> "SharedGPLVM":
        """Trains the model on named spaces with the same number of rows (frames).

        With the input plus one robot this is the paper's fully trained model; with several
        robots, the multi-robot model. ``callback(iteration, objective)`` is called after every
        iteration of the final training and stops it by returning ``False``. ``column_names``
        (joint names per space) are stored in the model, so that ``sgplvm predict`` and
        ``sgplvm teleop`` can read joint states by name. A space left out of them that is named
        after a built-in body (``"human"``, ``"walkman"``, ``"coman"``, ``"centauro"``,
        ``"ur5e"``) and has its number of columns gets that body's joint names, in the order
        :func:`load_demonstrations` gives them (``demo["robots"][name]["joint_names"]``): give
        ``column_names`` when your columns are in another order. Returns ``self``.

        ``validation`` chooses how many iterations to train (trained to convergence, the model
        fits the training frames ever better and motions it has not seen worse): the rows it
        names are held out, the model is trained on the others until their error has not
        fallen for ``patience`` iterations, then trained on all rows for the best iteration
        count (see :attr:`selection`). Give the row indices (or a boolean mask) to hold out —
        ``demo["validation"]`` from :func:`load_demonstrations` holds out the last repetition
        of every training motion — or ``"auto"`` (every third of nine equal blocks of rows,
        for rows in time order), or ``None`` to train on all rows until convergence or
        ``max_iters``.

        ``validation_callback(record)`` hears that choice: after the initial model and every
        iteration of the run on the other rows, a dict ``{"iteration", "objective",
        "validation_mse"}`` — the held-out rows' error (mean over output spaces of the mean
        squared error, your units; ``nan`` when that model could not predict): the values of
        :attr:`selection`'s ``curve``. It costs nothing extra (the error is computed for the
        choice anyway). Returning ``False`` ends the choice there, as a tuner stopping a poor
        run does: the model is then trained on all rows for the best iteration seen so far.
        An exception it raises stops training and is raised. It needs ``validation``; Ray Tune
        users get it wrapped in :func:`sgplvm.ray.tune_trainable`.

        ``max_seconds`` bounds the wall-clock time of the whole call (with validation, half of
        it for choosing the iteration count): when it runs out, training stops and keeps the
        best parameters so far (:attr:`stop_reason` is ``"time_limit"``).

        Ctrl-C (any exception a signal handler raises) stops training within about a second —
        signals are checked between evaluations of the objective — and is raised as usual
        (``KeyboardInterrupt``), but the model keeps the best parameters reached before it:
        after ``except KeyboardInterrupt``, :attr:`is_fitted` is true and :attr:`stop_reason`
        is ``"interrupted"`` (interrupted while the iteration count was being chosen on
        held-out rows, it is the initial model trained on all rows; a signal that comes as
        training ends is raised the same way, with the reason training had stopped for).

        Data whose values are far from unit scale (root mean square after centring outside
        1e-6…1e6) are standardised internally by a power of two — predictions still come back
        in your units; beyond 1e-153…1e153 they are refused with a ``ValueError``. A model too
        large for memory (the exact model holds several N × N matrices) raises ``MemoryError``
        before allocating them.

        ``inducing=M`` trains the sparse model instead (Titsias' variational bound with M
        inducing inputs shared by all spaces): O(N M²) time and O(N M) memory, so every frame
        of long demonstrations can be used; back constraints ``"input"`` or ``None``. Models
        transferred from it are sparse too; :attr:`inducing` and :attr:`inducing_inputs` tell.
        Without it, the exact model (a few thousand frames at most).

        ``whiten_back_constraint=True`` trains back-constraint weights W in a whitened
        parametrisation (W = K_bc^(-1/2) V, the optimiser moves V): the same latent points are
        reachable, but the back-constraint kernel K_bc's condition number (~1e9 on typical data)
        enters the problem once instead of squared, so L-BFGS reaches a low objective in far fewer
        iterations (on the benchmark data, GPy's final level at iteration 56; the plain weights at
        iteration 17,055). Use it when you want the optimum fast — time to solution,
        training to convergence. It is off by default because the slow plain route regularises: on
        the shipped demonstrations the held-out error of the validation-chosen model was worse with
        it in most configurations (BENCHMARKS.md, issue 18). The model stores W as usual: saved,
        loaded and predicting like any other. Needs the exact model with ``back_constraint``
        ``"input"`` or ``"output"``; refused (``ValueError``) for free latent points and with
        ``inducing``.
        """
        if whiten_back_constraint and self.back_constraint is None:
            raise ValueError(
                "whiten_back_constraint=True needs back constraints (back_constraint 'input' or "
                "'output'); this model has free latent points"
            )
        if whiten_back_constraint and inducing is not None:
            raise ValueError(
                "whiten_back_constraint=True needs the exact model; the sparse model (inducing) "
                "trains its weights as they are"
            )
        if inducing is not None and (isinstance(inducing, bool) or int(inducing) < 1):
            raise ValueError(f"inducing is {inducing!r}; expected an integer >= 1 or None")
        _check_validation_callback(validation_callback, validation)
        if not isinstance(spaces, Mapping) or not spaces:
            raise ValueError("spaces: expected a non-empty dict of name -> 2-D array")
        if input not in spaces:
            raise ValueError(f"input {input!r} is not one of the spaces {list(spaces)}")
        arrays = [(str(name), _as_matrix(data, f"spaces[{name!r}]")) for name, data in spaces.items()]
        names = _named_columns(arrays, column_names)
        frames = len(dict(arrays)[input])
        rows = _validation_rows(validation, frames)
        if self.bayesian and inducing is None:
            inducing = min(DEFAULT_BAYESIAN_INDUCING, frames)
        try:
            self._native = _sgplvm.NativeModel.fit(
                arrays,
                input,
                self.latent_dim,
                self.back_constraint,
                self.seed,
                self.scale,
                _integer(max_iters, "max_iters", 0),
                rows,
                _patience(patience),
                _max_seconds(max_seconds),
                callback,
                names,
                None if inducing is None else int(inducing),
                validation_callback,
                bool(whiten_back_constraint),
                self.bayesian,
            )
        except BaseException as e:
            interrupted = _interrupted_model(e)
            if interrupted is not None:
                self._native = interrupted
            raise
        return self

    def transfer(
        self,
        name: str,
        data: ArrayLike,
        max_iters: int = 1000,
        callback: Optional[Callable[[int, float], Optional[bool]]] = None,
        column_names: Optional[list] = None,
        validation: Validation = "auto",
        patience: int = DEFAULT_PATIENCE,
        max_seconds: Optional[float] = None,
        validation_callback: Optional[ValidationCallback] = None,
    ) -> "SharedGPLVM":
        """A new model that also predicts robot ``name``: the latent space, the human mapping
        and the existing robots stay frozen; only the new robot's kernel is trained on ``data``
        (the same frames as the human training data). This model is not changed.
        ``column_names`` (its joint names) default as in :meth:`fit`: a built-in body's when
        ``name`` is one and ``data`` has its number of columns.

        ``validation`` and ``patience`` choose the iteration budget as in :meth:`fit` (the
        held-out rows are predicted from their latent points), and ``validation_callback``
        hears it as in :meth:`fit`; ``max_seconds`` bounds the call's wall-clock time as in
        :meth:`fit`.

        Ctrl-C stops training within about a second and raises ``KeyboardInterrupt`` (no model
        is returned); the new model, with the best parameters reached, is the exception's
        ``model`` attribute."""
        native = self._require()
        _check_validation_callback(validation_callback, validation)
        new = SharedGPLVM(self.latent_dim, self.back_constraint, self.seed, self.scale)
        matrix = _as_matrix(data, name)
        try:
            new._native = native.transfer(
                name,
                matrix,
                _integer(max_iters, "max_iters", 0),
                _validation_rows(validation, len(matrix)),
                _patience(patience),
                _max_seconds(max_seconds),
                callback,
                _builtin_joint_names(name, matrix.shape[1]) if column_names is None else list(column_names),
                validation_callback,
            )
        except BaseException as e:
            interrupted = _interrupted_model(e)
            if interrupted is not None:
                new._native = interrupted
                setattr(e, "model", new)
            raise
        return new

    # ------------------------------------------------------------------ prediction

    def predict(self, H: ArrayLike, robot: str, return_std: bool = False):
        """Joint commands of ``robot`` for human frames ``H`` (n × D_H, or one frame of D_H).

        Returns the posterior mean (n × D_R); with ``return_std=True`` also the posterior
        standard deviation of the latent function (same shape)."""
        frames, single = _as_frames(H, "H")
        mean, variance = self._require().predict(frames, robot, bool(return_std))
        if single:
            mean = mean[0]
            variance = None if variance is None else variance[0]
        if return_std:
            assert variance is not None, "the native model returns a variance when asked for one"
            return mean, np.sqrt(variance)
        return mean

    def latent(self, H: ArrayLike) -> np.ndarray:
        """Latent points (n × Q) of human frames."""
        frames, single = _as_frames(H, "H")
        x = self._require().latent(frames)
        return x[0] if single else x

    def reconstruction_error(self, H: ArrayLike):
        """How far each human frame (n × D_H, or one frame) is from the model's own
        reconstruction of it, in the human space's standardised units: one of the two signals
        ``sgplvm teleop``'s default gate holds the robot on (above
        :meth:`reconstruction_threshold`). NaN for a frame that gives none (a value not finite,
        or far enough to overflow): the gate holds on it."""
        frames, single = _as_frames(H, "H")
        errors = _per_frame_signal(self._require().reconstruction_errors, frames)
        return float(errors[0]) if single else errors

    def reconstruction_threshold(self) -> float:
        """The reconstruction threshold stored in the model (calibrated on its held-out
        training groups): frames above it are held live."""
        return self._require().reconstruction_threshold()

    def novelty(self, H: ArrayLike):
        """How far each human frame (n × D_H, or one frame) is from the nearest training pose,
        each joint in units of its spread over the training poses: the other signal
        ``sgplvm teleop``'s default gate holds the robot on (above :meth:`novelty_threshold`)."""
        frames, single = _as_frames(H, "H")
        distances = _per_frame_signal(self._require().novelties, frames)
        return float(distances[0]) if single else distances

    def align_girdle(self, H: ArrayLike) -> np.ndarray:
        """One person's human frames (n × D_H, in their order) as ``sgplvm predict`` gives them
        to this model by default (``--girdle aligned``): each arm's clavicle moved by the
        difference between the model's people's mean clavicle angles and the person's mean over
        their frames so far, the shoulder turned so that the arm keeps its pose — rigs put the
        collarbone in different places (docs/capture.md). Feed the result to :meth:`predict`,
        :meth:`trusted` and the other signals; ``H`` unchanged where the model's human is not
        the human model's 18 angles."""
        return _align_girdle(self._require(), H)

    def novelty_threshold(self) -> float:
        """The novelty threshold stored in the model (the distance within which 1 % of poses
        drawn at random within the human's joint limits fall, or, for a model trained without
        them, the 99th percentile of its training groups' distances to the others)."""
        return self._require().novelty_threshold()

    def trust_threshold(self, robot: str) -> float:
        """The trust threshold of ``robot`` (standardised predictive standard deviation; the
        gate's other signal, ``teleop --gate sd``)."""
        return self._require().trust_threshold(robot)

    def trusted(self, H: ArrayLike):
        """Whether ``teleop``'s default gate follows each human frame (its reconstruction
        error and its novelty each within its threshold); False where the robot would hold."""
        frames, single = _as_frames(H, "H")
        native = self._require()
        errors = _per_frame_signal(native.reconstruction_errors, frames)
        distances = _per_frame_signal(native.novelties, frames)
        # A signal that is not a number holds the frame (NaN compares False).
        ok = (errors <= self.reconstruction_threshold()) & (distances <= self.novelty_threshold())
        return bool(ok[0]) if single else ok

    @property
    def latent_points(self) -> np.ndarray:
        """Latent points of the training frames (N × Q)."""
        return self._require().latent_points()

    @property
    def inducing(self) -> Optional[int]:
        """Number M of inducing inputs of a sparse model (``fit(..., inducing=M)``); None for
        the exact model."""
        return self._require().config()["inducing"]

    @property
    def inducing_inputs(self) -> Optional[np.ndarray]:
        """Inducing inputs Z (M × Q) of a sparse model; None for the exact model."""
        return self._require().inducing_inputs()

    @property
    def latent_variances(self) -> Optional[np.ndarray]:
        """Variances (N × Q) of a Bayesian model's latent posterior q(X), whose means are
        :attr:`latent_points`; None for a model with point latent positions."""
        return self._require().latent_variances()

    def ard_weights(self, space: str) -> np.ndarray:
        """How strongly ``space`` varies along each latent dimension: its kernel's variance over
        the squared lengthscale (GPy's ``input_sensitivity``). In a Bayesian model, dimensions
        whose weight is a few percent of the space's largest are switched off for that space."""
        return np.asarray(self._require().ard_weights(str(space)))

    # ------------------------------------------------------------------ inspection

    @property
    def is_fitted(self) -> bool:
        """True once the model has been trained (or loaded)."""
        return self._native is not None

    @property
    def input_name(self) -> str:
        """Name of the human (input) space."""
        return self._require().input_name

    @property
    def robots(self) -> list:
        """Names of the robots the model predicts for."""
        return self._require().output_names

    def column_names(self, space: str) -> Optional[list]:
        """Joint names stored for a space, if any."""
        return self._require().column_names(space)

    @property
    def history(self) -> Dict[str, np.ndarray]:
        """Per training iteration: ``iteration``, ``objective`` (negative log marginal
        likelihood), ``seconds`` since training started, ``gradient_norm``, ``evaluations``
        (objective + gradient evaluations since training started, the line searches' trials
        included: ``evaluations[-1] / iteration[-1]`` is the cost of an iteration)."""
        return self._require().history()

    @property
    def stop_reason(self) -> Optional[str]:
        """Why the last training stopped: ``"gradient_tolerance"``, ``"relative_tolerance"``,
        ``"max_iterations"`` (the ``max_iters`` given ran out), ``"validated_budget"`` (the
        iteration count chosen on held-out rows ran out: see :attr:`selection`),
        ``"callback"``, ``"line_search"``, ``"nothing_to_train"``, ``"time_limit"``
        (``max_seconds`` ran out), ``"evaluation_limit"`` or ``"interrupted"`` (Ctrl-C);
        ``None`` for a model that was never trained. Models saved before
        ``"validated_budget"`` existed read as it where it applies."""
        return self._require().stop_reason

    @property
    def selection(self) -> Optional[dict]:
        """How the iteration budget was chosen on held-out rows (``None`` when trained with
        ``validation=None``): ``fit_frames``, ``validation_frames``, ``patience``,
        ``best_iteration`` (the budget of the final training), ``seconds`` and ``curve`` (per
        iteration of the selection run: ``iteration``, ``objective``, ``validation_mse``)."""
        text = self._require().selection_json()
        return None if text is None else json.loads(text)

    @property
    def annotations(self) -> Dict[str, Any]:
        """What the model file carries beside the model, by key (a copy): ``"sgplvm.capture"``,
        the person's calibration of each capture (``teleop`` fits a stream through it) and
        ``"sgplvm.robots"``, the robots its commands were learned on (``predict``, ``teleop``
        and ``simulate`` say when given another); ``sgplvm train`` records both, Python's models
        once ``annotate`` is called."""
        return json.loads(self._require().annotations_json())

    def annotate(self, annotations: Mapping[str, Any]) -> None:
        """Adds ``annotations`` (JSON values by key) to what is saved with the model: robot
        records join those there (a robot's replacing its earlier one), another key's value
        replaces its earlier one. ``annotate(load_demonstrations(path)["provenance"])`` records
        what ``sgplvm train --data path`` does. A value under a key sgplvm reads that it cannot
        read is a ``ValueError``."""
        self._native = self._require().with_annotations(json.dumps(dict(annotations)))

    @property
    def params(self) -> dict:
        """Parameters: ``{"latent": X or {"weights": W, "bandwidth": b}, "spaces": {name:
        {"variance", "lengthscale", "noise"}}}``, in GPy's parametrisation."""
        return self._require().params()

    def set_params(self, params: dict) -> None:
        """Sets the parameters (same structure as :attr:`params`)."""
        self._native = self._require().with_params(params)

    def objective(self) -> float:
        """Negative log marginal likelihood at the current parameters."""
        return self._require().objective()

    def gradient(self) -> dict:
        """Gradient of :meth:`objective` with respect to :attr:`params` (same structure)."""
        return self._require().gradient()

    # ------------------------------------------------------------------ persistence

    def save(self, path: Union[str, os.PathLike]) -> None:
        """Writes the model to a versioned file (atomically)."""
        self._require().save(os.fspath(path))

    @classmethod
    def load(cls, path: Union[str, os.PathLike]) -> "SharedGPLVM":
        """Reads a model file written by :meth:`save` or the ``sgplvm`` command line."""
        return cls._from_native(_sgplvm.NativeModel.load(os.fspath(path)))

    def to_bytes(self) -> bytes:
        """The model file's bytes."""
        return bytes(self._require().to_bytes())

    @classmethod
    def from_bytes(cls, data: bytes) -> "SharedGPLVM":
        """A model from :meth:`to_bytes` output."""
        return cls._from_native(_sgplvm.NativeModel.from_bytes(bytes(data), "bytes"))

    @classmethod
    def _from_native(cls, native: "_sgplvm.NativeModel") -> "SharedGPLVM":
        config = native.config()
        model = cls(config["latent_dim"], config["back_constraint"], config["seed"], config["scale"], config["bayesian"])
        model._native = native
        return model

    def __getstate__(self) -> dict:
        return {
            "config": (self.latent_dim, self.back_constraint, self.seed, self.scale, self.bayesian),
            "model": None if self._native is None else self.to_bytes(),
        }

    def __setstate__(self, state: dict) -> None:
        SharedGPLVM.__init__(self, *state["config"])
        if state["model"] is not None:
            self._native = _sgplvm.NativeModel.from_bytes(state["model"], "pickle")

    def __repr__(self) -> str:
        fitted = f", robots={self.robots}" if self._native is not None else ", not fitted"
        return (
            f"SharedGPLVM(latent_dim={self.latent_dim}, back_constraint={self.back_constraint!r}, "
            f"seed={self.seed}{fitted})"
        )

    def _require(self) -> "_sgplvm.NativeModel":
        if self._native is None:
            raise RuntimeError("this SharedGPLVM is not fitted yet: call fit() or load() first")
        return self._native
