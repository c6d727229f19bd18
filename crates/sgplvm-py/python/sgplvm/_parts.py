"""A latent space per body part: ``PartsGPLVM`` over the native per-part model, and
``load_model`` for a model file of either kind."""

from __future__ import annotations

import json
import os
from typing import Any, Callable, Dict, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from . import _sgplvm
from ._model import (
    DEFAULT_PATIENCE,
    ArrayLike,
    SharedGPLVM,
    Validation,
    _align_girdle,
    _as_frames,
    _as_matrix,
    _builtin_joint_names,
    _integer,
    _interrupted_model,
    _max_seconds,
    _named_columns,
    _patience,
    _validation_rows,
)

#: ``parts`` of :class:`PartsGPLVM`: ``"arms"``, or part name -> {space name -> column indices}.
Parts = Union[str, Mapping[str, Mapping[str, Sequence[int]]]]

#: The names of the parts ``parts="arms"`` makes, left then right.
ARM_PARTS: Tuple[str, str] = ("left_arm", "right_arm")

#: ``callback(part, iteration, objective)`` of :meth:`PartsGPLVM.fit`; ``False`` stops that part.
PartsCallback = Callable[[str, int, float], Optional[bool]]


def _arm_columns(space: str, names: Optional[List[str]]) -> Tuple[List[int], List[int]]:
    """The left-arm and right-arm columns of ``space`` by its joint names."""
    if names is None:
        raise ValueError(
            f"parts='arms' needs the joint names of space {space!r} to tell its arms apart: give "
            "column_names, or name the space after a built-in body with its joints in order"
        )
    left, right = _sgplvm.arm_columns(space, list(names))
    return list(left), list(right)


class PartsGPLVM:
    """A shared GP-LVM per body part, joined on request by a parent latent space (the paper's
    future work, §V-B; Lawrence & Moore's hierarchical GP-LVM, fitted in two stages).

    Each part — with ``parts="arms"``, each arm: the human's 9 joints of that arm and each
    robot's joints of it — is a shared GP-LVM of its own columns (:meth:`part`), back-constrained
    on its own human columns, so a new pairing of two known arm motions is predicted as each
    arm's own motion. The parent (:meth:`parent`, with ``parent_latent_dim``) is a GP-LVM over
    the parts' latent points, trained after them; no prediction goes through it. :meth:`transfer` moves the whole
    structure to a new robot: every part's latent space and human mapping and the parent stay
    frozen, each part learns only the new robot's kernel.

    Parameters are :class:`SharedGPLVM`'s, applied to every part, plus ``parts`` (``"arms"``,
    or ``{part: {space: [column, ...]}}`` dividing every column of every robot space among the
    parts; a human column in no part is no input, as a one-armed robot's other arm)
    and ``parent_latent_dim`` (0, the default: no parent; it changes no prediction and trains
    about as long as the parts together).
    """

    def __init__(
        self,
        latent_dim: int = 5,
        back_constraint: Optional[str] = "input",
        seed: int = 0,
        scale: bool = False,
        bayesian: bool = False,
        parts: Parts = "arms",
        parent_latent_dim: int = 0,
    ) -> None:
        self._settings = SharedGPLVM(latent_dim, back_constraint, seed, scale, bayesian)
        if isinstance(parts, str):
            if parts != "arms":
                raise ValueError(f"parts is {parts!r}; expected 'arms' or a dict of part -> {{space: columns}}")
        elif not isinstance(parts, Mapping) or not parts:
            raise ValueError("parts: expected 'arms' or a non-empty dict of part -> {space: columns}")
        self.parts = parts
        #: The parent's latent dimension; 0: no parent.
        self.parent_latent_dim = _integer(parent_latent_dim, "parent_latent_dim", 0)
        self._native: Optional[_sgplvm.NativePartsModel] = None

    @property
    def latent_dim(self) -> int:
        """Latent dimension Q of each part."""
        return self._settings.latent_dim

    @property
    def back_constraint(self) -> Optional[str]:
        """Back constraint of each part (``"input"``, ``"output"`` or None)."""
        return self._settings.back_constraint

    @property
    def seed(self) -> int:
        """Seed of each part's initialisation."""
        return self._settings.seed

    def _part_columns(
        self, arrays: List[Tuple[str, np.ndarray]], names: Dict[str, List[str]]
    ) -> List[Tuple[str, List[Tuple[str, List[int]]]]]:
        """The parts as the native model takes them: (part, [(space, columns)])."""
        if isinstance(self.parts, str):
            sides: List[List[Tuple[str, List[int]]]] = [[], []]
            for space, _ in arrays:
                left, right = _arm_columns(space, names.get(space))
                sides[0].append((space, left))
                sides[1].append((space, right))
            return [(ARM_PARTS[k], sides[k]) for k in range(2)]
        return [
            (str(part), [(str(space), [int(c) for c in cols]) for space, cols in columns.items()])
            for part, columns in self.parts.items()
        ]

    def fit(
        self,
        spaces: Mapping[str, ArrayLike],
        input: str = "human",
        max_iters: int = 1000,
        callback: Optional[PartsCallback] = None,
        column_names: Optional[Mapping[str, list]] = None,
        validation: Validation = "auto",
        patience: int = DEFAULT_PATIENCE,
        max_seconds: Optional[float] = None,
        inducing: Optional[int] = None,
    ) -> "PartsGPLVM":
        """Trains a shared GP-LVM per part on its columns of named spaces (same rows), each as
        :meth:`SharedGPLVM.fit` would with these settings (``max_iters``, ``validation``,
        ``patience``, ``max_seconds`` and ``inducing`` apply to each part), then the parent.
        ``callback(part, iteration, objective)`` hears every iteration of each (``"parent"``
        for the parent). ``parts="arms"`` tells the arms apart by the joint names:
        ``column_names``, or a built-in body's for a space named after it. Returns ``self``."""
        if not isinstance(spaces, Mapping) or not spaces:
            raise ValueError("spaces: expected a non-empty dict of name -> 2-D array")
        if input not in spaces:
            raise ValueError(f"input {input!r} is not one of the spaces {list(spaces)}")
        if inducing is not None and (isinstance(inducing, bool) or int(inducing) < 1):
            raise ValueError(f"inducing is {inducing!r}; expected an integer >= 1 or None")
        arrays = [(str(name), _as_matrix(data, f"spaces[{name!r}]")) for name, data in spaces.items()]
        named = _named_columns(arrays, column_names) or []
        frames = len(dict(arrays)[input])
        if self._settings.bayesian and inducing is None:
            inducing = min(50, frames)
        parts = self._part_columns(arrays, dict(named))
        try:
            self._native = _sgplvm.NativePartsModel.fit(
                arrays,
                input,
                parts,
                self.latent_dim,
                self.back_constraint,
                self.seed,
                self._settings.scale,
                _integer(max_iters, "max_iters", 0),
                _validation_rows(validation, frames),
                _patience(patience),
                _max_seconds(max_seconds),
                callback,
                named or None,
                None if inducing is None else int(inducing),
                self._settings.bayesian,
                self.parent_latent_dim or None,
            )
        except BaseException as e:
            interrupted = _interrupted_model(e)
            if interrupted is not None:
                self._native = interrupted  # type: ignore[assignment]
            raise
        return self

    def transfer(
        self,
        name: str,
        data: ArrayLike,
        max_iters: int = 1000,
        callback: Optional[PartsCallback] = None,
        column_names: Optional[list] = None,
        validation: Validation = "auto",
        patience: int = DEFAULT_PATIENCE,
        max_seconds: Optional[float] = None,
        parts: Optional[Mapping[str, Sequence[int]]] = None,
    ) -> "PartsGPLVM":
        """A new model that also predicts robot ``name`` from ``data`` (rows: the training
        frames): every part's latent space, human mapping and existing robots and the parent
        stay frozen; each part learns only the new robot's kernel on its columns. ``parts``
        gives them (part -> column indices of ``data``); by default, for arms, they are found
        from ``column_names`` (or the built-in robot's joints). This model is not changed."""
        native = self._require()
        matrix = _as_matrix(data, name)
        names = _builtin_joint_names(name, matrix.shape[1]) if column_names is None else list(column_names)
        if parts is None:
            if list(native.part_names) != list(ARM_PARTS):
                raise ValueError(
                    f"parts: give each of the model's parts {native.part_names} its columns of {name!r}"
                )
            left, right = _arm_columns(name, names)
            columns = [(ARM_PARTS[0], left), (ARM_PARTS[1], right)]
        else:
            columns = [(str(p), [int(c) for c in cols]) for p, cols in parts.items()]
        new = self._like()
        try:
            new._native = native.transfer(
                name,
                matrix,
                columns,
                _integer(max_iters, "max_iters", 0),
                _validation_rows(validation, len(matrix)),
                _patience(patience),
                _max_seconds(max_seconds),
                callback,
                names,
            )
        except BaseException as e:
            interrupted = _interrupted_model(e)
            if interrupted is not None:
                new._native = interrupted  # type: ignore[assignment]
                setattr(e, "model", new)
            raise
        return new

    def predict(self, H: ArrayLike, robot: str, return_std: bool = False):
        """Joint commands of ``robot`` for human frames ``H`` (n × D_H, or one frame), each
        part predicting its columns from its own human columns; with ``return_std=True`` also
        the posterior standard deviation (same shape)."""
        frames, single = _as_frames(H, "H")
        mean, variance = self._require().predict(frames, robot, bool(return_std))
        if single:
            mean = mean[0]
            variance = None if variance is None else variance[0]
        if return_std:
            assert variance is not None, "the native model returns a variance when asked for one"
            return mean, np.sqrt(variance)
        return mean

    def _worst_part(self, H: ArrayLike, signal: str):
        """Per frame, the worst part's ``signal`` (``reconstruction_error`` or ``novelty``) over
        that part's own threshold, on the part's human columns."""
        frames, single = _as_frames(H, "H")
        worst = np.zeros(len(frames))
        for name in self.part_names:
            part = self.part(name)
            cols = self.part_columns(name)[self.input_name]
            threshold = {
                "reconstruction_error": part.reconstruction_threshold,
                "novelty": part.novelty_threshold,
            }[signal]()
            values = np.asarray(getattr(part, signal)(frames[:, cols]), dtype=float)
            worst = np.maximum(worst, values / threshold)
        return float(worst[0]) if single else worst

    def reconstruction_error(self, H: ArrayLike):
        """Per human frame (n × D_H, or one frame), the worst part's reconstruction error over
        that part's own threshold: ``sgplvm teleop`` holds the robot where it is above 1
        (:meth:`reconstruction_threshold`), as it gates a per-part model."""
        return self._worst_part(H, "reconstruction_error")

    def reconstruction_threshold(self) -> float:
        """1: :meth:`reconstruction_error` is each part's over its own threshold."""
        return 1.0

    def novelty(self, H: ArrayLike):
        """Per human frame, the worst part's novelty (distance to the nearest training pose
        of that part's joints) over that part's own threshold; held above 1."""
        return self._worst_part(H, "novelty")

    def align_girdle(self, H: ArrayLike) -> np.ndarray:
        """One person's human frames (n × D_H, in their order) as ``sgplvm predict`` gives them
        to this model by default (``--girdle aligned``; :meth:`SharedGPLVM.align_girdle`)."""
        return _align_girdle(self._require(), H)

    def novelty_threshold(self) -> float:
        """1: :meth:`novelty` is each part's over its own threshold."""
        return 1.0

    def trusted(self, H: ArrayLike):
        """Whether ``teleop``'s default gate follows each human frame: every part's
        reconstruction error and novelty within that part's thresholds; False where the robot
        would hold (the counts ``sgplvm evaluate`` reports for a per-part model)."""
        errors = np.asarray(self.reconstruction_error(H))
        distances = np.asarray(self.novelty(H))
        ok = (errors <= 1.0) & (distances <= 1.0)
        return bool(ok) if ok.ndim == 0 else ok

    def latent(self, H: ArrayLike) -> np.ndarray:
        """Latent points of human frames: every part's side by side (n × parts·Q)."""
        frames, single = _as_frames(H, "H")
        x = self._require().latent(frames)
        return x[0] if single else x

    @property
    def latent_points(self) -> np.ndarray:
        """Latent points of the training frames, every part's side by side."""
        return self._require().latent_points()

    @property
    def part_names(self) -> List[str]:
        """The parts, in order."""
        return list(self._require().part_names)

    def part_columns(self, part: str) -> Dict[str, List[int]]:
        """Each space's columns of ``part``."""
        columns = self._require().part_columns(part)
        if columns is None:
            raise ValueError(f"no part named {part!r}; the model's parts are {self.part_names}")
        return {str(k): list(v) for k, v in columns.items()}

    def part(self, name: str) -> SharedGPLVM:
        """The shared GP-LVM of part ``name`` (its spaces hold the part's columns only)."""
        return SharedGPLVM._from_native(self._require().part(name))

    def parent(self) -> Optional[SharedGPLVM]:
        """The parent above the parts: a GP-LVM whose spaces are the parts' latent points (named
        after the parts); None when trained without one."""
        native = self._require().parent()
        return None if native is None else SharedGPLVM._from_native(native)

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
    def annotations(self) -> Dict[str, Any]:
        """What the model file carries beside the model, by key (a copy; see
        ``SharedGPLVM.annotations``)."""
        return json.loads(self._require().annotations_json())

    def annotate(self, annotations: Mapping[str, Any]) -> None:
        """Adds ``annotations`` (JSON values by key; robot records join those there, another
        key's value replaces) to what is saved with the model, as ``SharedGPLVM.annotate``."""
        self._native = self._require().with_annotations(json.dumps(dict(annotations)))

    def save(self, path: Union[str, os.PathLike]) -> None:
        """Writes the model to a versioned file (format 4, atomically)."""
        self._require().save(os.fspath(path))

    @classmethod
    def load(cls, path: Union[str, os.PathLike]) -> "PartsGPLVM":
        """Reads a per-part model file written by :meth:`save` or ``sgplvm train --parts``."""
        return cls._from_native(_sgplvm.NativePartsModel.load(os.fspath(path)))

    def to_bytes(self) -> bytes:
        """The model file's bytes."""
        return bytes(self._require().to_bytes())

    @classmethod
    def from_bytes(cls, data: bytes) -> "PartsGPLVM":
        """A model from :meth:`to_bytes` output."""
        return cls._from_native(_sgplvm.NativePartsModel.from_bytes(bytes(data), "bytes"))

    @classmethod
    def _from_native(cls, native: "_sgplvm.NativePartsModel") -> "PartsGPLVM":
        config = native.config()
        parts = {p: {k: list(v) for k, v in (native.part_columns(p) or {}).items()} for p in native.part_names}
        model = cls(
            config["latent_dim"],
            config["back_constraint"],
            config["seed"],
            config["scale"],
            config["bayesian"],
            "arms" if list(native.part_names) == list(ARM_PARTS) else parts,
            config["parent_latent_dim"] or 0,
        )
        model._native = native
        return model

    def _like(self) -> "PartsGPLVM":
        s = self._settings
        return PartsGPLVM(s.latent_dim, s.back_constraint, s.seed, s.scale, s.bayesian, self.parts, self.parent_latent_dim)

    def __getstate__(self) -> dict:
        s = self._settings
        return {
            "config": (s.latent_dim, s.back_constraint, s.seed, s.scale, s.bayesian, self.parts, self.parent_latent_dim),
            "model": None if self._native is None else self.to_bytes(),
        }

    def __setstate__(self, state: dict) -> None:
        PartsGPLVM.__init__(self, *state["config"])
        if state["model"] is not None:
            self._native = _sgplvm.NativePartsModel.from_bytes(state["model"], "pickle")

    def __repr__(self) -> str:
        fitted = f", parts={self.part_names}, robots={self.robots}" if self._native is not None else ", not fitted"
        return f"PartsGPLVM(latent_dim={self.latent_dim}, back_constraint={self.back_constraint!r}{fitted})"

    def _require(self) -> "_sgplvm.NativePartsModel":
        if self._native is None:
            raise RuntimeError("this PartsGPLVM is not fitted yet: call fit() or load() first")
        return self._native


def load_model(path: Union[str, os.PathLike]) -> Union[SharedGPLVM, PartsGPLVM]:
    """Reads a model file of either kind: a :class:`SharedGPLVM` (one shared latent space) or a
    :class:`PartsGPLVM` (a latent space per body part)."""
    native = _sgplvm.load_any(os.fspath(path))
    if isinstance(native, _sgplvm.NativePartsModel):
        return PartsGPLVM._from_native(native)
    return SharedGPLVM._from_native(native)
