"""``fit(..., whiten_back_constraint=True)``: it really trains another path (a lower objective
on the same budget), the model it returns stores and predicts like any other, it reaches
sweeps, and it is refused where it cannot apply with a message naming the keyword."""

import numpy as np
import pytest

import sgplvm
from sgplvm import ray as sgray
from test_model import smooth_data as model_data


def smooth_data(n=60, seed=0):
    """test_model's human and first robot, 60 frames."""
    human, robot, _ = model_data(n=n, seed=seed)
    return {"human": human, "walkman": robot}


def fit(bc, whiten, max_iters=25):
    m = sgplvm.SharedGPLVM(latent_dim=2, back_constraint=bc, seed=0)
    return m.fit(smooth_data(), max_iters=max_iters, validation=None, whiten_back_constraint=whiten)


@pytest.mark.parametrize("bc", ["input", "output"])
def test_whitening_changes_the_path_and_the_model_is_like_any_other(bc):
    plain, white = fit(bc, False), fit(bc, True)
    hp, hw = plain.history, white.history
    # The same start (to rounding), then a lower objective on the same budget.
    assert abs(hp["objective"][0] - hw["objective"][0]) < 1e-12 * abs(hp["objective"][0])
    assert hw["objective"][-1] < hp["objective"][-1], (hw["objective"][-1], hp["objective"][-1])
    # It stores W: the objective evaluated from its parameters is what training ended at.
    assert white.objective() == pytest.approx(min(hw["objective"]), rel=1e-9)
    loaded = sgplvm.SharedGPLVM.from_bytes(white.to_bytes())
    human = smooth_data()["human"]
    np.testing.assert_array_equal(loaded.predict(human, robot="walkman"), white.predict(human, robot="walkman"))
    np.testing.assert_array_equal(loaded.latent_points, white.latent_points)


def test_whitening_is_refused_where_it_cannot_apply():
    with pytest.raises(ValueError, match="whiten_back_constraint.*free latent points"):
        fit(None, True)
    m = sgplvm.SharedGPLVM(latent_dim=2, back_constraint="input", seed=0)
    with pytest.raises(ValueError, match="whiten_back_constraint.*sparse"):
        m.fit(smooth_data(), max_iters=3, validation=None, inducing=8, whiten_back_constraint=True)
    # Off, the same calls train.
    fit(None, False, max_iters=2)


def test_sweeps_accept_the_keyword():
    assert "whiten_back_constraint" in sgray._FIT_KEYS
    points = sgray._grid_points({"whiten_back_constraint": [False, True]})
    assert [p["whiten_back_constraint"] for p in points] == [False, True]
