"""The Bayesian shared GP-LVM (``SharedGPLVM(bayesian=True)``, issue 34): its bound and every
gradient against a live GPy's ``BayesianGPLVM`` (one space) and ``MRD`` (two) at the same
parameters, and the Python switch (training, saving, transfer, ARD weights)."""

import pickle

import numpy as np
import pytest

import sgplvm
from sgplvm import _sgplvm


def _gpy_model(GPy, ys, mean, var, z, kernels):
    """GPy's model at exactly these parameters, with fresh gradients."""
    q = mean.shape[1]
    kerns = [GPy.kern.RBF(q, ARD=True, variance=v, lengthscale=np.array(l)) for v, l, _ in kernels]
    if len(ys) == 1:
        m = GPy.models.BayesianGPLVM(ys[0], q, X=mean.copy(), X_variance=var.copy(), Z=z.copy(),
                                     num_inducing=len(z), kernel=kerns[0])
        m.likelihood.variance = kernels[0][2]
        spaces = [(m.kern, m.likelihood)]
    else:
        m = GPy.models.MRD(ys, q, X=mean.copy(), X_variance=var.copy(), Z=z.copy(),
                           num_inducing=len(z), kernel=kerns, normalizer=False)
        m.Z[:] = z  # MRD draws its own inducing inputs whatever Z it is given (GPy 1.15)
        spaces = []
        for s, (_, _, noise) in enumerate(kernels):
            m.bgplvms[s].likelihood.variance = noise
            spaces.append((m.bgplvms[s].kern, m.bgplvms[s].likelihood))
    # Parameters set after construction leave `.gradient` stale until the model updates once
    # more (GPy 1.15): update it, as its optimiser does.
    m.optimizer_array = m.optimizer_array.copy()
    return m, spaces


@pytest.mark.parametrize("dims", [[18], [18, 14]], ids=["BayesianGPLVM", "MRD"])
def test_bound_and_gradients_equal_gpy(dims):
    GPy = pytest.importorskip("GPy")
    rng = np.random.default_rng(34)
    n, m, q = 80, 12, 5
    mean = rng.standard_normal((n, q))
    var = rng.uniform(0.05, 0.6, (n, q))
    z = rng.standard_normal((m, q))
    ys, kernels = [], []
    for d in dims:
        y = np.sin(mean @ rng.standard_normal((q, d))) + 0.1 * rng.standard_normal((n, d))
        ys.append(y - y.mean(0))
        kernels.append((float(rng.uniform(0.5, 2)), list(rng.uniform(0.7, 2.5, q)), float(rng.uniform(0.05, 0.5))))
    model, spaces = _gpy_model(GPy, ys, mean, var, z, kernels)
    jitter = model.inference_method.const_jitter if len(dims) == 1 else model.bgplvms[0].inference_method.const_jitter
    ours = _sgplvm.bayesian_bound(mean, var, z, ys, kernels, jitter)

    def rel(a, b):
        a, b = np.ravel(a), np.ravel(b)
        return float(np.max(np.abs(a - b)) / max(np.max(np.abs(b)), 1e-300))

    gpy_value = float(model.objective_function())
    errors = {
        "value": abs(ours["value"] - gpy_value) / abs(gpy_value),
        # GPy's `.gradient` is of the bound; the objective is its negative.
        "d_mean": rel(ours["d_mean"], -model.X.mean.gradient),
        "d_variance": rel(ours["d_variance"], -model.X.variance.gradient),
        "d_inducing": rel(ours["d_inducing"], -model.Z.gradient),
    }
    for s, ((kern, lik), d) in enumerate(zip(spaces, ours["d_spaces"])):
        theirs = np.concatenate([-kern.variance.gradient, -kern.lengthscale.gradient, -lik.variance.gradient])
        errors[f"space {s}"] = rel([d["variance"], *d["lengthscale"], d["noise"]], theirs)
    # Measured about 1e-15 (GPy 1.15.0, numpy 2.4.6); the tolerance 1e-8.
    assert max(errors.values()) <= 1e-8, errors
    # Not an accident of the numbers: other variances give another bound.
    other = _sgplvm.bayesian_bound(mean, var * 1.1, z, ys, kernels, jitter)
    assert abs(other["value"] - gpy_value) > 1e-4 * abs(gpy_value)


def _spaces(n, seed=0):
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 6, n)
    human = np.column_stack([np.sin(t * (1 + 0.2 * j)) for j in range(6)]) + 0.01 * rng.standard_normal((n, 6))
    robot = np.column_stack([np.cos(t * (1 + 0.1 * j)) for j in range(4)]) + 0.01 * rng.standard_normal((n, 4))
    other = np.column_stack([np.sin(t * (0.5 + 0.1 * j)) for j in range(3)]) + 0.01 * rng.standard_normal((n, 3))
    return {"human": human, "robot": robot, "other": other}


def test_a_bayesian_model_trains_saves_pickles_and_transfers():
    spaces = _spaces(120)
    model = sgplvm.SharedGPLVM(latent_dim=3, bayesian=True).fit(
        {"human": spaces["human"], "robot": spaces["robot"]}, max_iters=80, validation=None
    )
    assert model.bayesian and model.inducing == 50
    s = model.latent_variances
    assert s.shape == (120, 3) and np.all(s > 0)
    w = model.ard_weights("robot")
    assert w.shape == (3,) and np.all(w > 0)
    pred = model.predict(spaces["human"], "robot")
    assert np.mean((pred - spaces["robot"]) ** 2) < 0.2 * np.mean(np.var(spaces["robot"], axis=0))
    back = sgplvm.SharedGPLVM.from_bytes(model.to_bytes())
    assert back.bayesian
    np.testing.assert_array_equal(back.predict(spaces["human"], "robot"), pred)
    again = pickle.loads(pickle.dumps(model))
    assert again.bayesian
    np.testing.assert_array_equal(again.latent_variances, s)
    t = model.transfer("other", spaces["other"], max_iters=40, validation=None)
    np.testing.assert_array_equal(t.latent_variances, s)
    assert t.predict(spaces["human"], "other").shape == (120, 3)
    # Point latent positions have no variances.
    plain = sgplvm.SharedGPLVM(latent_dim=2).fit(
        {"human": spaces["human"], "robot": spaces["robot"]}, max_iters=3, validation=None
    )
    assert not plain.bayesian and plain.latent_variances is None


def test_bad_bayesian_input_is_a_value_error():
    with pytest.raises(ValueError, match="at least one space"):
        _sgplvm.bayesian_bound(np.zeros((4, 2)), np.ones((4, 2)), np.zeros((2, 2)), [], [], 1e-8)
    with pytest.raises(ValueError, match="variance"):
        _sgplvm.bayesian_bound(np.zeros((4, 2)), np.zeros((4, 2)), np.zeros((2, 2)),
                               [np.zeros((4, 1))], [(1.0, [1.0, 1.0], 0.1)], 1e-8)
    with pytest.raises(ValueError, match="unknown space 'nosuch'"):
        sgplvm.SharedGPLVM(latent_dim=2, bayesian=True).fit(
            {k: v for k, v in _spaces(40).items() if k != "other"}, max_iters=2, validation=None
        ).ard_weights("nosuch")
