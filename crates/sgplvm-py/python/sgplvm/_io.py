"""Demonstration files and physics replay: thin wrappers that accept any array-like input."""

from __future__ import annotations

import json
import os
import warnings
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from . import _sgplvm

PathLike = Union[str, os.PathLike]


def _real(value: Any, what: str, dtype: Any) -> np.ndarray:
    """``value`` as a C-contiguous array of ``dtype``, refusing what the conversion would
    change silently: complex values (the imaginary part dropped) and, for integer
    ``dtype``, numbers with a fraction (truncated)."""
    probe = value if isinstance(value, np.ndarray) else np.asarray(value)
    if np.iscomplexobj(probe):
        raise ValueError(f"{what}: expected real numbers, got a {probe.dtype} array")
    if np.issubdtype(dtype, np.integer) and probe.dtype.kind == "f":
        if not np.all(np.isfinite(probe)) or not np.all(probe == np.trunc(probe)):
            raise ValueError(f"{what}: expected integers, got {probe.dtype} values with a fraction or NaN")
    return np.ascontiguousarray(probe, dtype=dtype)


def read_joint_states(path: PathLike, topic: str) -> Tuple[np.ndarray, List[str], np.ndarray]:
    """Reads one ``sensor_msgs/msg/JointState`` topic (CDR or JSON) of an MCAP file.

    Returns ``(times_ns, joint_names, positions)``: int64 (n,), list of str, float64 (n, joints).
    """
    return _sgplvm.read_joint_states(os.fspath(path), topic)


def write_joint_states(
    path: PathLike,
    topic: str,
    times_ns: Any,
    names: Sequence[str],
    positions: Any,
    compression: str = "zstd",
    robot: Optional[str] = None,
) -> None:
    """Writes one JointState topic (CDR, ROS 2 profile) to an MCAP file, atomically.

    ``compression`` is ``"zstd"`` (ROS 2's default), ``"lz4"`` or ``"none"``. With ``robot`` (a
    built-in body: ``"coman"``, ``"human"``, …) the file also carries what Foxglove needs to draw
    it moving: its URDF on ``/ROBOT/robot_description`` (links renamed ``ROBOT/<link>``),
    ``/tf_static`` and ``/tf`` (every movable joint at every frame); ``names`` must then be
    joints of that robot."""
    times = _real(times_ns, "times_ns", np.int64).reshape(-1)
    values = _real(positions, "positions", np.float64)
    if values.ndim != 2:
        raise ValueError(f"positions: expected a 2-D array (frames × joints), got {values.ndim}-D")
    _sgplvm.write_joint_states(os.fspath(path), topic, times, list(names), values, compression, robot)


def load_demonstrations(path: PathLike) -> Dict[str, Any]:
    """Loads a demonstration MCAP as numpy arrays.

    Returns a dict with ``times_ns``, ``human`` and ``robots`` (name → ``{"topic",
    "joint_names", "positions"}``), ``train`` and ``test`` frame indices, ``segments`` (start,
    end, from_pose, to_pose, repetition, person: who was captured, or None) and ``pose_names``. Files written by ROS 2 without
    sgplvm's labels load with every topic aligned onto a 40 Hz clock and all frames in ``train``.
    """
    return _sgplvm.load_demonstrations(os.fspath(path))


def read_bvh(
    path: PathLike,
    rate: float = 40.0,
    map: Optional[Dict[str, str]] = None,
    units: Optional[str] = None,
    start: Optional[float] = None,
    end: Optional[float] = None,
) -> Dict[str, Any]:
    """Imports a BVH motion capture as the human model's 18 joint angles, like ``sgplvm import``.

    The arms are found by their names (CMU/cgspeed, Mixamo, Xsens MVN, Xsens BVH exports, Poser,
    Unreal and Rigify schemes) or by ``map`` (the model's joint groups ``"jLeftShoulder"``,
    ``"jLeftElbow"``, … to the capture's segments); the motion is taken in the upper torso's
    frame, scaled to the human model and resampled to ``rate`` Hz. ``units`` (``"m"``,
    ``"dm"``, ``"cm"``, ``"mm"``, ``"in"``, ``"cmu"``) only names sizes in the report (guessed if
    ``None``); ``start`` and ``end`` (seconds) cut the capture.

    Returns a dict shaped like :func:`load_demonstrations`'s human part: ``times_ns`` (n,),
    ``human`` (``{"joint_names", "positions"}``, positions (n, 18) in radians) and ``source``
    (``file``, ``skeleton``, ``frame_rate``, ``units``, ``arm_length``, ``span_s``, ``fit``: the
    model's elbow and wrist against the scaled capture, medians and worst cases in metres, the
    elbow angle's in degrees, frames beyond the limits, joints held at a limit).
    """
    times, names, positions, source = _sgplvm.read_bvh(
        os.fspath(path), float(rate), None if map is None else dict(map), units, start, end
    )
    return {
        "times_ns": times,
        "human": {"topic": "/human/joint_states", "joint_names": names, "positions": positions},
        "source": json.loads(source),
    }


def simulate(robot: Union[str, PathLike], joint_names: Sequence[str], times: Any, positions: Any) -> Dict[str, Any]:
    """Replays a joint trajectory on a robot in the rapier physics engine.

    ``robot`` is a built-in name (``"coman"``, …) or a URDF path; ``times`` in seconds (n,),
    ``positions`` (n, len(joint_names)). PD position control at 1 kHz with the base fixed.
    Returns a dict: ``joints`` (per joint rms_error, max_error and max_error_time, and
    ``prismatic``: its values in metres, else radians), ``limit_violations``,
    ``velocity_violations``, ``collisions``, ``duration``, ``physics_steps``,
    ``wall_seconds``, ``warnings``."""
    t = _real(times, "times", np.float64).reshape(-1)
    q = _real(positions, "positions", np.float64)
    if q.ndim != 2:
        raise ValueError(f"positions: expected a 2-D array (frames × joints), got {q.ndim}-D")
    return _sgplvm.simulate(os.fspath(robot), list(joint_names), t, q)


def retarget(
    robots: Union[Sequence[str], Dict[str, Any]],
    human: Any = None,
    times_ns: Any = None,
    *,
    demos: Union[None, PathLike, Sequence[PathLike]] = None,
    out: Optional[PathLike] = None,
    match: str = "arms",
    redundancy: str = "continuous",
    velocity_limits: bool = False,
    block_seconds: float = 4.0,
    test_every: int = 4,
    test_files: Optional[Sequence[str]] = None,
    guard_seconds: float = 0.5,
    train_subsample: int = 12,
    test_subsample: int = 3,
    test_people: Optional[Sequence[str]] = None,
) -> Dict[str, Any]:
    """Robot commands for a human's motion, like ``sgplvm retarget``: each robot's hands placed
    where the person's are relative to the shoulders (in units of reach, in each body's own
    frame), each arm moving its own joints, every other joint held.

    ``robots`` is a list of built-in names or a dict name → :class:`Robot` (e.g.
    ``Robot.from_urdf(path, arms=...)``) or built-in name. The human is either ``human``, an
    (n, 18) array of the human model's joint angles with ``times_ns`` (n,) int64, or ``demos``,
    MCAP files (e.g. from ``sgplvm import``). ``match`` (``"arms"``: the person's arm posture,
    out of self-collision; ``"hands"``, ``"hands+elbows"``, ``"poses"``), ``redundancy`` and
    ``velocity_limits`` are the CLI's ``--match``, ``--redundancy`` and
    ``--velocity-limits``.

    Without ``out``: returns ``{robot: {"joint_names", "positions" (n, joints), "report"}}``.
    With ``out`` (and ``demos``): writes the demonstrations split for training, as the CLI does
    (``block_seconds``, ``test_every``, or ``test_files``, or ``test_people`` — every file of
    those people, as imported with ``--person``, kept whole for testing: strangers to the
    model — ``guard_seconds``, ``train_subsample``, ``test_subsample``), and returns the report
    (``frames``, ``split``, ``reach``, ``seconds``, ``files``, ``test_files``,
    ``train_people``, ``test_people``); :func:`load_demonstrations` reads the
    file. Demonstrations too short for one test block (fewer than ``test_every`` blocks) go to
    training whole, with a ``UserWarning`` (``split["fallback"]`` says why)."""
    named = dict(robots) if isinstance(robots, dict) else {name: name for name in robots}
    files = None
    if demos is not None:
        files = [os.fspath(demos)] if isinstance(demos, (str, os.PathLike)) else [os.fspath(d) for d in demos]
    h = None if human is None else _real(human, "human", np.float64)
    if h is not None and h.ndim != 2:
        raise ValueError(f"human: expected a 2-D array (frames × 18), got {h.ndim}-D")
    t = None if times_ns is None else _real(times_ns, "times_ns", np.int64).reshape(-1)
    result = _sgplvm.retarget_native(
        named,
        match,
        redundancy,
        bool(velocity_limits),
        h,
        t,
        files,
        None if out is None else os.fspath(out),
        float(block_seconds),
        int(test_every),
        None if test_files is None else list(test_files),
        float(guard_seconds),
        int(train_subsample),
        int(test_subsample),
        None if test_people is None else [str(p) for p in test_people],
    )
    fallback = result.get("split", {}).get("fallback") if out is not None else None
    if fallback:
        # A capture too short for a test block: every frame went to training.
        warnings.warn(fallback, stacklevel=2)
    return result
