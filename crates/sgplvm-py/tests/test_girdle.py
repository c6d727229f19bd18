"""A person's clavicles aligned to the model's people (``model.align_girdle``: what ``sgplvm
predict``, ``evaluate``, ``simulate`` and ``teleop`` give a model by default, ``--girdle``),
checked against the human model's arm written here from its definition — clavicle
``Rx(e) Rz(−p)``, shoulder ``Ry(−f) Rx(a) Rz(−r)`` (crates/sgplvm-capture/src/fit/mod.rs) — with
numpy alone: every frame's upper arm keeps its orientation, the elbow and wrist keep their angles,
and each clavicle is moved by the model's people's mean less the person's mean so far."""

from pathlib import Path

import numpy as np
import pytest

import sgplvm

REPO = Path(__file__).resolve().parents[3]
CAPTURED = REPO / "data" / "demos" / "captured.mcap"


def rx(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def ry(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def rz(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def upper_arm(q):
    """The upper arm's orientation in the body of one arm's angles (the model's order)."""
    e, p, f, a, r = q[:5]
    return rx(e) @ rz(-p) @ ry(-f) @ rx(a) @ rz(-r)


@pytest.fixture(scope="module")
def data():
    d = sgplvm.load_demonstrations(str(CAPTURED))
    train, test = d["train"], d["test"]
    H = d["human"]["positions"]
    return {
        "train_h": H[train],
        "walkman": d["robots"]["walkman"]["positions"][train],
        "test_h": H[test],
        "names": d["human"]["joint_names"],
    }


@pytest.fixture(scope="module", params=["one latent space", "a latent space per arm"])
def model(request, data):
    spaces = {"human": data["train_h"], "walkman": data["walkman"]}
    if request.param == "one latent space":
        return sgplvm.SharedGPLVM(latent_dim=3, seed=0).fit(spaces, input="human", max_iters=5, validation=None)
    return sgplvm.PartsGPLVM(latent_dim=3, parts="arms").fit(spaces, max_iters=5, validation=None)


def test_each_arm_keeps_its_pose_and_its_clavicle_moves_to_the_people_s_mean(data, model):
    H = data["test_h"]
    aligned = model.align_girdle(H)
    assert aligned.shape == H.shape
    reference = data["train_h"].mean(axis=0)
    for first in (0, 9):
        clavicle = slice(first, first + 2)
        # Elbow and wrist angles as they were; the upper arm turned as it was.
        assert np.array_equal(aligned[:, first + 5:first + 9], H[:, first + 5:first + 9])
        for k in range(len(H)):
            np.testing.assert_allclose(upper_arm(aligned[k, first:first + 9]), upper_arm(H[k, first:first + 9]), atol=1e-9)
        # Each frame's clavicle moved by the people's mean less the person's mean so far
        # (every test frame lies within the human's clavicle limits, so each is counted).
        so_far = np.cumsum(H[:, clavicle], axis=0) / np.arange(1, len(H) + 1)[:, None]
        np.testing.assert_allclose(aligned[:, clavicle], H[:, clavicle] + reference[clavicle] - so_far, atol=1e-9)
    # One frame is aligned as the first of its person.
    np.testing.assert_allclose(model.align_girdle(H[5])[:2], reference[:2], atol=1e-12)


def test_a_model_of_other_joints_takes_frames_as_they_are():
    rng = np.random.default_rng(0)
    H = rng.normal(size=(30, 4))
    m = sgplvm.SharedGPLVM(latent_dim=2, seed=0).fit({"x": H, "y": H[:, :2] * 2}, input="x", max_iters=2, validation=None)
    assert np.array_equal(m.align_girdle(H), H)
