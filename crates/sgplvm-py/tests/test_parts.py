"""A latent space per body part (``sgplvm.PartsGPLVM``, issue 49): its likelihood against GPy's
GPLVM part by part and for the parent, the arms found by joint names, prediction arm by arm,
transfer of the whole structure, the file (format 4) and pickling, and the errors."""

import pickle
from pathlib import Path

import numpy as np
import pytest

import sgplvm

REPO = Path(__file__).resolve().parents[3]
DEMOS = REPO / "data" / "demos" / "bimanual.mcap"


@pytest.fixture(scope="module")
def demo():
    d = sgplvm.load_demonstrations(str(DEMOS))
    train = d["train"][::2]  # 125 frames: quick
    return {
        "human": d["human"]["positions"][train],
        "walkman": d["robots"]["walkman"]["positions"][train],
        "coman": d["robots"]["coman"]["positions"][train],
        "test": d["human"]["positions"][d["test"]],
    }


@pytest.fixture(scope="module")
def arms(demo):
    m = sgplvm.PartsGPLVM(latent_dim=3, parts="arms", parent_latent_dim=2)
    return m.fit({"human": demo["human"], "walkman": demo["walkman"]}, max_iters=20, validation=None)


def _gpy_objective(spaces, X, params):
    """Sum over spaces of GPy's GPLVM negative log likelihood (centred data), as DESIGN.md
    defines the model: an implementation independent of ours."""
    GPy = pytest.importorskip("GPy")
    total = 0.0
    for name, Y in spaces.items():
        p = params["spaces"][name]
        kern = GPy.kern.RBF(X.shape[1], ARD=True)
        model = GPy.models.GPLVM(Y - Y.mean(axis=0), X.shape[1], X=X.copy(), kernel=kern)
        model.kern.variance = p["variance"]
        model.kern.lengthscale = np.asarray(p["lengthscale"])
        # GPy factorises K + (noise + 1e-8) I: give it noise - 1e-8 so both see the same matrix.
        model.likelihood.variance = p["noise"] - 1e-8
        total += model.objective_function()
    return total


def test_the_likelihood_of_every_part_and_of_the_parent_equals_gpy(demo):
    """The per-part model's objective is its parts' and its parent's: each a shared GP-LVM of
    its own data (a part's columns; the parts' latent points), checked against GPy's GPLVM."""
    m = sgplvm.PartsGPLVM(latent_dim=3, back_constraint=None, parts="arms", parent_latent_dim=2)
    spaces = {"human": demo["human"], "walkman": demo["walkman"]}
    m.fit(spaces, max_iters=15, validation=None)
    worst = 0.0
    latents = {}
    for name in m.part_names:
        part = m.part(name)
        columns = m.part_columns(name)
        own = {s: spaces[s][:, columns[s]] for s in spaces}
        ours, theirs = part.objective(), _gpy_objective(own, part.params["latent"], part.params)
        worst = max(worst, abs(ours - theirs) / abs(theirs))
        latents[name] = part.latent_points
    parent = m.parent()
    assert parent is not None and parent.robots == ["right_arm"]
    ours, theirs = parent.objective(), _gpy_objective(latents, parent.params["latent"], parent.params)
    worst = max(worst, abs(ours - theirs) / abs(theirs))
    # Measured 3.5e-14 (GPy 1.15.0, numpy 2.4.6); the tolerance 1e-8.
    assert worst < 1e-8


def test_arms_are_found_by_joint_names_and_predicted_each_from_its_own(demo, arms):
    assert arms.part_names == ["left_arm", "right_arm"]
    assert arms.part_columns("left_arm") == {"human": list(range(9)), "walkman": list(range(7))}
    assert arms.column_names("walkman")[7] == "RShSag"
    h = demo["test"]
    pred, std = arms.predict(h, "walkman", return_std=True)
    assert pred.shape == std.shape == (len(h), 14)
    assert arms.latent(h).shape == (len(h), 6)
    # A frame's left arm with another frame's right arm: each arm predicted as its own frame's.
    mixed = np.concatenate([h[:, :9], h[::-1, 9:]], axis=1)
    other = arms.predict(mixed, "walkman")
    np.testing.assert_array_equal(other[:, :7], pred[:, :7])
    np.testing.assert_array_equal(other[:, 7:], pred[::-1, 7:])
    # One frame, and each part as a SharedGPLVM of its columns.
    np.testing.assert_allclose(arms.predict(h[0], "walkman"), pred[0], rtol=1e-12)
    left = arms.part("left_arm").predict(h[:, :9], "walkman")
    np.testing.assert_array_equal(left, pred[:, :7])


def test_transfer_moves_the_whole_structure(demo, arms):
    t = arms.transfer("coman", demo["coman"], max_iters=20, validation=None)
    assert t.robots == ["walkman", "coman"] and arms.robots == ["walkman"]
    for name in arms.part_names:
        np.testing.assert_array_equal(t.part(name).latent_points, arms.part(name).latent_points)
    np.testing.assert_array_equal(t.parent().latent_points, arms.parent().latent_points)
    pred = t.predict(demo["human"], "coman")
    assert np.mean((pred - demo["coman"]) ** 2) < 0.05 * np.var(demo["coman"], axis=0).sum()
    # Explicit columns, and columns that do not divide the robot.
    explicit = arms.transfer(
        "coman", demo["coman"], max_iters=20, validation=None,
        parts={"left_arm": list(range(7)), "right_arm": list(range(7, 14))},
    )
    np.testing.assert_array_equal(explicit.predict(demo["human"], "coman"), pred)
    with pytest.raises(ValueError, match="column 13 of space 'coman' is in no part"):
        arms.transfer("coman", demo["coman"], validation=None,
                      parts={"left_arm": list(range(7)), "right_arm": list(range(7, 13))})


def test_files_pickles_and_each_kind_refused_as_the_other(tmp_path, demo, arms):
    path = tmp_path / "arms.sgp"
    arms.save(path)
    assert path.read_bytes()[8:12] == (4).to_bytes(4, "little")
    back = sgplvm.PartsGPLVM.load(path)
    h = demo["test"]
    np.testing.assert_array_equal(back.predict(h, "walkman"), arms.predict(h, "walkman"))
    assert isinstance(sgplvm.load_model(path), sgplvm.PartsGPLVM)
    again = pickle.loads(pickle.dumps(arms))
    np.testing.assert_array_equal(again.predict(h, "walkman"), arms.predict(h, "walkman"))
    with pytest.raises(ValueError, match="latent space per body part"):
        sgplvm.SharedGPLVM.load(path)
    single = tmp_path / "single.sgp"
    arms.part("left_arm").save(single)
    assert isinstance(sgplvm.load_model(single), sgplvm.SharedGPLVM)
    with pytest.raises(ValueError, match="one shared latent space"):
        sgplvm.PartsGPLVM.load(single)
    newer = tmp_path / "newer.sgp"
    data = bytearray(path.read_bytes())
    data[8:12] = (5).to_bytes(4, "little")
    newer.write_bytes(bytes(data))
    with pytest.raises(ValueError, match="version 5 is not supported"):
        sgplvm.load_model(newer)


def test_bad_parts_are_refused_naming_what_is_wrong(demo):
    spaces = {"human": demo["human"], "walkman": demo["walkman"]}
    with pytest.raises(ValueError, match="expected 'arms'"):
        sgplvm.PartsGPLVM(parts="legs")
    unnamed = {"human": demo["human"], "robot": demo["walkman"]}
    with pytest.raises(ValueError, match="joint names of space 'robot'"):
        sgplvm.PartsGPLVM().fit(unnamed, max_iters=1, validation=None)
    overlap = {"a": {"human": list(range(10)), "walkman": list(range(7))},
               "b": {"human": list(range(9, 18)), "walkman": list(range(7, 14))}}
    with pytest.raises(ValueError, match="column 9 of space 'human' is in part 'a' and in part 'b'"):
        sgplvm.PartsGPLVM(parts=overlap).fit(spaces, max_iters=1, validation=None)
    heard = []
    sgplvm.PartsGPLVM(latent_dim=2).fit(
        spaces, max_iters=3, validation=None, callback=lambda part, it, f: heard.append(part)
    )
    assert heard and set(heard) == {"left_arm", "right_arm"}
