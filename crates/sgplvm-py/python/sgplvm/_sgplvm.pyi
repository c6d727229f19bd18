"""Type stubs of the native module (Rust, PyO3). Users import from ``sgplvm`` directly."""

from os import PathLike
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple, Union, final

import numpy as np
import numpy.typing as npt

__all__ = [
    "DEFAULT_PATIENCE",
    "NativeModel",
    "NativePartsModel",
    "NativeRegression",
    "Robot",
    "__version__",
    "_panic_for_tests",
    "arm_columns",
    "bayesian_bound",
    "canonical_back_constraint",
    "experiment_assemble",
    "experiment_config",
    "experiment_data",
    "experiment_execute",
    "experiment_plan",
    "experiment_report",
    "experiment_run",
    "experiment_write_outputs",
    "load_any",
    "load_demonstrations",
    "read_bvh",
    "read_joint_states",
    "retarget_native",
    "simulate",
    "sparse_bound",
    "write_joint_states",
]
__version__: str
DEFAULT_PATIENCE: int

_Path = Union[str, PathLike]
_F64 = npt.NDArray[np.float64]
_Callback = Callable[[int, float], Optional[bool]]
_ValidationCallback = Callable[[Dict[str, Any]], Optional[bool]]

@final
class NativeModel:
    """A trained shared GP-LVM (native part; use ``sgplvm.SharedGPLVM``)."""

    @staticmethod
    def fit(
        spaces: Sequence[Tuple[str, _F64]],
        input: str,
        latent_dim: int,
        back_constraint: Optional[str],
        seed: int,
        scale: bool,
        max_iters: int,
        validation: Optional[Sequence[int]],
        patience: int,
        max_seconds: Optional[float] = None,
        callback: Optional[_Callback] = None,
        column_names: Optional[Sequence[Tuple[str, List[str]]]] = None,
        inducing: Optional[int] = None,
        validation_callback: Optional[_ValidationCallback] = None,
        whiten_back_constraint: bool = False,
        bayesian: bool = False,
    ) -> "NativeModel": ...
    def transfer(
        self,
        name: str,
        data: _F64,
        max_iters: int,
        validation: Optional[Sequence[int]],
        patience: int,
        max_seconds: Optional[float] = None,
        callback: Optional[_Callback] = None,
        column_names: Optional[List[str]] = None,
        validation_callback: Optional[_ValidationCallback] = None,
    ) -> "NativeModel": ...
    @property
    def stop_reason(self) -> Optional[str]: ...
    @staticmethod
    def block_validation_rows(n: int) -> List[int]: ...
    def selection_json(self) -> Optional[str]: ...
    def annotations_json(self) -> str: ...
    def with_annotations(self, json: str) -> NativeModel: ...
    def predict(self, h: _F64, robot: str, with_variance: bool) -> Tuple[_F64, Optional[_F64]]: ...
    def reconstruction_errors(self, h: _F64) -> List[float]: ...
    def reconstruction_threshold(self) -> float: ...
    def novelties(self, h: _F64) -> List[float]: ...
    def align_girdle(self, h: _F64) -> Optional[_F64]: ...
    def novelty_threshold(self) -> float: ...
    def trust_threshold(self, robot: str) -> float: ...
    def latent(self, h: _F64) -> _F64: ...
    def latent_points(self) -> _F64: ...
    @property
    def input_name(self) -> str: ...
    @property
    def output_names(self) -> List[str]: ...
    def column_names(self, space: str) -> Optional[List[str]]: ...
    def space_dim(self, space: str) -> Optional[int]: ...
    def config(self) -> Dict[str, Any]: ...
    def inducing_inputs(self) -> Optional[_F64]: ...
    def latent_variances(self) -> Optional[_F64]: ...
    def ard_weights(self, space: str) -> List[float]: ...
    def history(self) -> Dict[str, Any]: ...
    def params(self) -> Dict[str, Any]: ...
    def gradient(self) -> Dict[str, Any]: ...
    def objective(self) -> float: ...
    def with_params(self, params: Dict[str, Any]) -> "NativeModel": ...
    def to_bytes(self) -> bytes: ...
    @staticmethod
    def from_bytes(bytes: bytes, source: str) -> "NativeModel": ...
    def save(self, path: _Path) -> None: ...
    @staticmethod
    def load(path: _Path) -> "NativeModel": ...

_PartsCallback = Callable[[str, int, float], Optional[bool]]

@final
class NativePartsModel:
    """A trained model with a latent space per body part (native part; use ``sgplvm.PartsGPLVM``)."""

    @staticmethod
    def fit(
        spaces: Sequence[Tuple[str, _F64]],
        input: str,
        parts: Sequence[Tuple[str, Sequence[Tuple[str, List[int]]]]],
        latent_dim: int,
        back_constraint: Optional[str],
        seed: int,
        scale: bool,
        max_iters: int,
        validation: Optional[Sequence[int]],
        patience: int,
        max_seconds: Optional[float] = None,
        callback: Optional[_PartsCallback] = None,
        column_names: Optional[Sequence[Tuple[str, List[str]]]] = None,
        inducing: Optional[int] = None,
        bayesian: bool = False,
        parent_latent_dim: Optional[int] = None,
    ) -> "NativePartsModel": ...
    def transfer(
        self,
        name: str,
        data: _F64,
        columns: Sequence[Tuple[str, List[int]]],
        max_iters: int,
        validation: Optional[Sequence[int]],
        patience: int,
        max_seconds: Optional[float] = None,
        callback: Optional[_PartsCallback] = None,
        column_names: Optional[List[str]] = None,
    ) -> "NativePartsModel": ...
    def predict(self, h: _F64, robot: str, with_variance: bool) -> Tuple[_F64, Optional[_F64]]: ...
    def align_girdle(self, h: _F64) -> Optional[_F64]: ...
    def latent(self, h: _F64) -> _F64: ...
    def latent_points(self) -> _F64: ...
    @property
    def input_name(self) -> str: ...
    @property
    def output_names(self) -> List[str]: ...
    def column_names(self, space: str) -> Optional[List[str]]: ...
    def space_dim(self, space: str) -> Optional[int]: ...
    @property
    def part_names(self) -> List[str]: ...
    def part_columns(self, name: str) -> Optional[Dict[str, List[int]]]: ...
    def part(self, name: str) -> NativeModel: ...
    def parent(self) -> Optional[NativeModel]: ...
    @property
    def num_points(self) -> int: ...
    def config(self) -> Dict[str, Any]: ...
    def annotations_json(self) -> str: ...
    def with_annotations(self, json: str) -> NativePartsModel: ...
    def to_bytes(self) -> bytes: ...
    @staticmethod
    def from_bytes(bytes: bytes, source: str) -> "NativePartsModel": ...
    def save(self, path: _Path) -> None: ...
    @staticmethod
    def load(path: _Path) -> "NativePartsModel": ...

def arm_columns(body: str, joints: List[str]) -> Tuple[List[int], List[int]]:
    """The left-arm and right-arm columns of a body with these joints (anatomy or names)."""

def load_any(path: _Path) -> Union[NativeModel, NativePartsModel]:
    """A model file of either kind."""

@final
class NativeRegression:
    """A trained GP regression (native part; use ``sgplvm.GPRegression``)."""

    @staticmethod
    def fit(
        x: _F64, y: _F64, max_iters: int, max_seconds: Optional[float] = None
    ) -> "NativeRegression": ...
    def predict(self, x: _F64) -> _F64: ...
    def kernel(self) -> Dict[str, Any]: ...
    @property
    def stop_reason(self) -> Optional[str]: ...

@final
class Robot:
    """A robot (or human) body from a URDF: joint names, limits and forward kinematics."""

    @staticmethod
    def builtin(name: str) -> "Robot":
        """One of the shipped bodies: "walkman", "coman", "centauro" or "human"."""
    @staticmethod
    def builtin_names() -> List[str]: ...
    @staticmethod
    def builtin_urdf(name: str) -> str: ...
    @staticmethod
    def from_urdf(
        path: _Path,
        base: Optional[str] = None,
        tip: Optional[str] = None,
        *,
        arms: Optional[Dict[str, Tuple[str, str]]] = None,
        hold: Optional[Dict[str, float]] = None,
        up: Optional[Tuple[float, float, float]] = None,
        forward: Optional[Tuple[float, float, float]] = None,
        mount_roll_deg: Optional[float] = None,
        command_joints: Union[None, str, List[str]] = None,
    ) -> "Robot":
        """Loads a URDF file as its maker publishes it; ``arms``, ``hold``, ``up``, ``forward``,
        ``mount_roll_deg`` (the person's arm turned outward about the forward axis: 90 by
        default for an arm that cannot hang, as on a table) and ``command_joints`` say what its
        names do not; with ``base``/``tip`` the body is
        restricted to that chain."""
    @property
    def name(self) -> str: ...
    @property
    def joint_names(self) -> List[str]: ...
    @property
    def joint_limits(self) -> List[Tuple[float, float]]: ...
    @property
    def link_names(self) -> List[str]: ...
    def forward_kinematics(self, q: Sequence[float], link: Optional[str] = None) -> _F64:
        """4×4 pose of ``link`` for configuration ``q``: every joint of ``joint_names``, in that
        order (a whole robot's every movable joint, not only ``command_joint_names``). ``link``
        may be left out for a chain (``Robot.chain``): its tip; a whole robot needs it named."""
    @property
    def anatomy(self) -> Dict[str, Any]:
        """Arms, held joints, body frame, reach, neutral posture and notes."""
    def summary(self) -> str: ...
    @property
    def command_joint_names(self) -> List[str]: ...
    @property
    def held_joints(self) -> List[Tuple[str, float]]: ...
    @property
    def hold_configuration(self) -> List[float]: ...
    def description(self) -> str:
        """The description file's JSON (``ROBOT.anatomy.json``) that keeps this anatomy."""

def canonical_back_constraint(value: object) -> Optional[str]: ...
def sparse_bound(
    x: _F64,
    z: _F64,
    y: _F64,
    variance: float,
    lengthscale: Sequence[float],
    noise: float,
    relative_jitter: float,
) -> float:
    """One space's negative collapsed (Titsias/VarDTC) bound of the sparse model."""
def bayesian_bound(
    mean: _F64,
    variance: _F64,
    z: _F64,
    ys: Sequence[_F64],
    kernels: Sequence[Tuple[float, Sequence[float], float]],
    absolute_jitter: float,
) -> Dict[str, Any]:
    """The Bayesian GP-LVM's (MRD's) negative bound and its gradient, in natural units."""
def _panic_for_tests(message: str) -> None:
    """Panics in Rust with ``message``: the panic must arrive as a ``RuntimeError``."""

def read_joint_states(path: _Path, topic: str) -> Tuple[npt.NDArray[np.int64], List[str], _F64]:
    """Reads a ``sensor_msgs/msg/JointState`` topic: (times_ns, joint names, positions)."""

def write_joint_states(
    path: _Path,
    topic: str,
    times_ns: npt.NDArray[np.int64],
    names: List[str],
    positions: _F64,
    compression: str = "zstd",
    robot: Optional[str] = None,
) -> None:
    """Writes a JointState topic (CDR, ROS 2 profile) atomically; with ``robot``, also TF for Foxglove."""

def load_demonstrations(path: _Path) -> Dict[str, Any]:
    """A demonstration MCAP as numpy arrays (times_ns, human, robots, train, test, segments, pose_names)."""

def read_bvh(
    path: _Path,
    rate: float = 40.0,
    map: Optional[Dict[str, str]] = None,
    units: Optional[str] = None,
    start: Optional[float] = None,
    end: Optional[float] = None,
) -> Tuple[npt.NDArray[np.int64], List[str], _F64, str]:
    """A BVH capture as the human model's joint angles: times_ns, names, positions, source JSON."""

def simulate(
    robot: str, joint_names: List[str], times: _F64, positions: _F64
) -> Dict[str, Any]:
    """Replays a joint trajectory in rapier; returns tracking errors, limit violations, collisions."""

def retarget_native(
    robots: Dict[str, Any],
    mode: str,
    redundancy: str,
    velocity_limits: bool,
    human: Optional[_F64] = None,
    times_ns: Optional[npt.NDArray[np.int64]] = None,
    demos: Optional[List[str]] = None,
    out: Optional[str] = None,
    block_seconds: float = 4.0,
    test_every: int = 4,
    test_files: Optional[List[str]] = None,
    guard_seconds: float = 0.5,
    train_subsample: int = 12,
    test_subsample: int = 3,
    test_people: Optional[List[str]] = None,
) -> Any:
    """Robot commands for a human's motion (see ``sgplvm.retarget``)."""

# The experiment as tasks (sgplvm.ray schedules them; `sgplvm experiment` runs them in order).
def experiment_config(name: str) -> str:
    """The protocol ``"quick"`` or ``"paper"`` as JSON."""

def experiment_data(path: Optional[_Path] = None, all_frames: bool = False, parts: bool = False) -> bytes:
    """The experiment's data (train/test frames, held-out rows) from demonstrations, as bytes;
    with ``all_frames``, also every training frame at full rate (for a config with ``inducing``:
    the sparse model on every frame, as ``sgplvm experiment --all-frames``)."""

def experiment_plan(data: bytes, config: str) -> str:
    """Every task of the experiment, in serial order, as a JSON list."""

def experiment_execute(
    data: bytes, config: str, task: str, source: Optional[bytes] = None
) -> Tuple[str, Optional[bytes]]:
    """Performs one task: its records (JSON) and, if later tasks start from it, its model's bytes."""

def experiment_assemble(data: bytes, config: str, results: List[str]) -> str:
    """The results (``results.json``'s text) from the records of every task."""

def experiment_run(data: bytes, config: str) -> str:
    """The serial experiment (the code of ``sgplvm experiment``); its results as JSON."""

def experiment_write_outputs(results: str, out: _Path) -> List[str]:
    """Writes results.json, the figures and report.md into ``out`` (atomically); returns the paths."""

def experiment_report(results: str) -> str:
    """The Markdown report of results (JSON)."""
