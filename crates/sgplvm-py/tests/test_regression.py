"""sgplvm.GPRegression, the yardstick: its mean is the GP posterior mean at its hyperparameters,
it learns as well as GPy's GPRegression on the shipped demonstrations, bad input is an error."""

from pathlib import Path

import numpy as np
import pytest

import sgplvm

DEMOS = Path(__file__).resolve().parents[3] / "data" / "demos" / "bimanual.mcap"


def rbf(a, b, kernel):
    d = (a[:, None, :] - b[None, :, :]) / np.asarray(kernel["lengthscale"])
    return kernel["variance"] * np.exp(-0.5 * (d**2).sum(-1))


def test_mean_is_the_posterior_mean_at_the_trained_hyperparameters():
    rng = np.random.default_rng(3)
    x = rng.uniform(-2, 2, size=(50, 3))
    y = np.stack([np.sin(x[:, 0]) + x[:, 1], np.cos(x[:, 2])], axis=1) + 0.01 * rng.normal(size=(50, 2))
    gp = sgplvm.GPRegression(max_iters=200).fit(x, y)
    k = gp.kernel
    assert k["noise"] > 0 and k["variance"] > 0 and len(k["lengthscale"]) == 3
    xq = rng.uniform(-2, 2, size=(20, 3))
    mu = y.mean(0)
    alpha = np.linalg.solve(rbf(x, x, k) + k["noise"] * np.eye(50), y - mu)
    dense = rbf(xq, x, k) @ alpha + mu
    # measured up to 3.7e-11 (the trained noise is small, so the solve is ill-conditioned)
    np.testing.assert_allclose(gp.predict(xq), dense, rtol=0, atol=4e-10)
    np.testing.assert_allclose(gp.predict(xq[0]), dense[0], rtol=0, atol=4e-10)
    # It learned: far below the outputs' variance on unseen inputs.
    truth = np.stack([np.sin(xq[:, 0]) + xq[:, 1], np.cos(xq[:, 2])], axis=1)
    assert np.mean((gp.predict(xq) - truth) ** 2) < 0.01 * np.var(y)


def test_as_good_as_gpy_on_the_shipped_demonstrations():
    GPy = pytest.importorskip("GPy")
    demo = sgplvm.load_demonstrations(DEMOS)
    train, test = demo["train"], demo["test"]
    h = demo["human"]["positions"]
    for robot in ["walkman"]:  # GPy's optimisation takes about a minute per robot here
        r = demo["robots"][robot]["positions"]
        ours = sgplvm.GPRegression().fit(h[train], r[train]).predict(h[test])
        mu = r[train].mean(0)
        m = GPy.models.GPRegression(h[train], r[train] - mu, GPy.kern.RBF(h.shape[1], ARD=True))
        m.optimize(max_iters=1000)
        theirs = m.predict(h[test])[0] + mu
        mse_ours = np.mean((ours - r[test]) ** 2)
        mse_gpy = np.mean((theirs - r[test]) ** 2)
        # measured: walkman 0.0406 vs 0.041 (coman 0.037 vs 0.037, centauro 0.026 vs 0.026)
        assert mse_ours < 1.1 * mse_gpy, f"{robot}: ours {mse_ours:.4f}, GPy {mse_gpy:.4f}"


def test_bad_input_is_an_error():
    x = np.linspace(0, 1, 20)[:, None]
    with pytest.raises(ValueError, match="regression outputs' has 19 rows; expected 20"):
        sgplvm.GPRegression().fit(x, x[:19])
    bad = x.copy()
    bad[4, 0] = np.nan
    with pytest.raises(ValueError, match="row 4, column 0 is NaN"):
        sgplvm.GPRegression().fit(bad, x)
    gp = sgplvm.GPRegression(max_iters=5).fit(x, np.sin(x))
    with pytest.raises(ValueError, match="found 2 columns/values; expected 1"):
        gp.predict(np.zeros((3, 2)))
    with pytest.raises(RuntimeError, match="not fitted"):
        sgplvm.GPRegression().predict(x)
    with pytest.raises(ValueError, match="max_iters"):
        sgplvm.GPRegression(max_iters=-1)
