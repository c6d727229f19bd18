"""Demonstration files, the dataset and physics replay from Python, and the whole pipeline:
load the shipped demonstrations, train on one robot, transfer to another, predict."""

from pathlib import Path

import numpy as np
import pytest

import sgplvm

REPO = Path(__file__).resolve().parents[3]
DEMOS = REPO / "data" / "demos" / "bimanual.mcap"


def test_joint_states_round_trip(tmp_path):
    times = np.arange(5, dtype=np.int64) * 25_000_000 + 1_000
    names = ["a", "b", "c"]
    positions = np.random.default_rng(0).normal(size=(5, 3))
    path = tmp_path / "js.mcap"
    for compression in ("zstd", "lz4", "none"):
        sgplvm.write_joint_states(str(path), "/arm/joint_states", times, names, positions, compression)
        t, n, p = sgplvm.read_joint_states(str(path), "/arm/joint_states")
        np.testing.assert_array_equal(t, times)
        assert n == names
        np.testing.assert_array_equal(p, positions)


def test_joint_states_errors(tmp_path):
    path = tmp_path / "js.mcap"
    times = np.arange(2, dtype=np.int64)
    with pytest.raises(ValueError, match="shape"):
        sgplvm.write_joint_states(str(path), "/t", times, ["a"], np.zeros((3, 1)))
    with pytest.raises(ValueError, match="finite"):
        sgplvm.write_joint_states(str(path), "/t", times, ["a"], np.array([[0.0], [np.nan]]))
    with pytest.raises(ValueError, match="compression"):
        sgplvm.write_joint_states(str(path), "/t", times, ["a"], np.zeros((2, 1)), "gzip")
    assert not path.exists()
    sgplvm.write_joint_states(str(path), "/t", times, ["a"], np.zeros((2, 1)))
    with pytest.raises(ValueError, match="/other"):
        sgplvm.read_joint_states(str(path), "/other")
    truncated = tmp_path / "cut.mcap"
    truncated.write_bytes(path.read_bytes()[:-40])
    with pytest.raises(ValueError, match="cut.mcap"):
        sgplvm.read_joint_states(str(truncated), "/t")
    with pytest.raises(OSError, match="missing.mcap"):
        sgplvm.read_joint_states(str(tmp_path / "missing.mcap"), "/t")


@pytest.fixture(scope="module")
def demo():
    assert DEMOS.exists(), f"{DEMOS} is shipped with the repository"
    return sgplvm.load_demonstrations(str(DEMOS))


def test_shipped_demonstrations(demo):
    n = len(demo["times_ns"])
    assert demo["human"]["positions"].shape == (n, 18)
    assert set(demo["robots"]) == {"walkman", "coman", "centauro"}
    for name, robot in demo["robots"].items():
        assert robot["positions"].shape == (n, 14)
        assert robot["joint_names"] == sgplvm.Robot.builtin(name).joint_names
    assert demo["human"]["joint_names"] == sgplvm.Robot.builtin("human").joint_names
    train, test = set(demo["train"].tolist()), set(demo["test"].tolist())
    assert train and test and not (train & test)
    assert len(demo["pose_names"]) == 16


def test_pipeline_train_transfer_predict(demo):
    train, test = demo["train"], demo["test"]
    H = demo["human"]["positions"]
    R = {k: v["positions"] for k, v in demo["robots"].items()}
    m = sgplvm.SharedGPLVM(latent_dim=5, back_constraint="input", seed=0)
    m.fit({"human": H[train], "walkman": R["walkman"][train]}, input="human", max_iters=150)
    t = m.transfer("coman", R["coman"][train], max_iters=150)
    pred = t.predict(H[test], robot="coman")
    mse = np.mean((pred - R["coman"][test]) ** 2)
    var = np.mean((R["coman"][test] - R["coman"][train].mean(0)) ** 2)
    assert mse < 0.25 * var, (mse, var)


def test_simulate_smooth_motion_on_a_builtin_robot():
    robot = sgplvm.Robot.builtin("coman")
    lo, hi = np.asarray(robot.joint_limits).T
    mid = np.clip(0.0, lo, hi)
    times = np.arange(80) / 40.0
    s = 0.5 - 0.5 * np.cos(np.pi * times / times[-1])
    # The left arm moves (its positive shoulder roll is outward); the right arm holds still.
    target = np.clip(mid + np.r_[np.full(7, 0.2), np.zeros(7)], lo, hi)
    positions = mid + s[:, None] * (target - mid)
    report = sgplvm.simulate("coman", robot.joint_names, times, positions)
    assert len(report["joints"]) == 14
    assert max(j["rms_error"] for j in report["joints"]) < 0.05
    assert report["limit_violations"] == []
    assert report["collisions"] == []
    with pytest.raises(ValueError, match="columns"):
        sgplvm.simulate("coman", robot.joint_names, times, positions[:, :3])
    with pytest.raises(ValueError, match="r2d2"):
        sgplvm.simulate("r2d2", robot.joint_names, times, positions)
