"""The sparse model (``fit(..., inducing=M)``, issue #14): its per-space bound against GPy's
``SparseGPLVM`` on the same X, Z and kernel, and the Python switch."""

import numpy as np
import pytest

import sgplvm
from sgplvm import _sgplvm


def _spaces(n, seed=0):
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 6, n)
    human = np.column_stack([np.sin(t * (1 + 0.2 * j)) for j in range(6)]) + 0.01 * rng.standard_normal((n, 6))
    robot = np.column_stack([np.cos(t * (1 + 0.1 * j)) for j in range(4)]) + 0.01 * rng.standard_normal((n, 4))
    return {"human": human, "robot": robot}


def test_the_bound_equals_gpy_sparse_gplvm_per_space():
    GPy = pytest.importorskip("GPy")
    rng = np.random.default_rng(0)
    n, m, q = 300, 20, 5
    x = rng.standard_normal((n, q))
    z = rng.standard_normal((m, q))
    worst = 0.0
    # The spaces: a human of 18 columns and a robot of 14.
    for d, variance, noise in [(18, 1.3, 0.05), (14, 0.7, 0.2)]:
        y = rng.standard_normal((n, d))
        lengthscale = rng.uniform(0.8, 2.5, q)
        kern = GPy.kern.RBF(q, variance=variance, lengthscale=lengthscale, ARD=True)
        model = GPy.models.SparseGPLVM(y, q, X=x.copy(), kernel=kern, num_inducing=m)
        model.Z[:] = z
        model.likelihood.variance = noise
        gpy = float(model.objective_function())
        # GPy's VarDTC adds a constant 1e-8 to K_mm's diagonal; ours is relative to the variance.
        jitter = model.inference_method.const_jitter
        ours = _sgplvm.sparse_bound(x, z, y, variance, list(lengthscale), noise, jitter / variance)
        worst = max(worst, abs(ours - gpy) / abs(gpy))
        assert abs(ours - gpy) <= 1e-8 * abs(gpy), (ours, gpy)
        # Not an accident of the numbers: other inducing inputs give another bound.
        other = _sgplvm.sparse_bound(x, z + 0.1, y, variance, list(lengthscale), noise, jitter / variance)
        assert abs(other - gpy) > 1e-4 * abs(gpy)
    # Measured 5.6e-16 (GPy 1.15.0, numpy 2.4.6); tolerance the 1e-8.
    assert worst < 1e-8


def test_fit_with_inducing_trains_a_sparse_model_that_round_trips():
    spaces = _spaces(400)
    model = sgplvm.SharedGPLVM(latent_dim=2).fit(spaces, max_iters=30, validation=None, inducing=25)
    assert model.inducing == 25
    z = model.inducing_inputs
    assert z is not None and z.shape == (25, 2)
    pred = model.predict(spaces["human"], "robot")
    assert np.mean((pred - spaces["robot"]) ** 2) < 0.05
    back = sgplvm.SharedGPLVM.from_bytes(model.to_bytes())
    assert back.inducing == 25
    np.testing.assert_array_equal(back.inducing_inputs, z)
    np.testing.assert_array_equal(back.predict(spaces["human"], "robot"), pred)
    exact = sgplvm.SharedGPLVM(latent_dim=2).fit(_spaces(60), max_iters=5, validation=None)
    assert exact.inducing is None and exact.inducing_inputs is None


@pytest.mark.parametrize("bad", [0, -3, True])
def test_bad_inducing_counts_are_refused(bad):
    with pytest.raises(ValueError, match="inducing"):
        sgplvm.SharedGPLVM(latent_dim=2).fit(_spaces(50), max_iters=2, validation=None, inducing=bad)


def test_more_inducing_inputs_than_frames_is_a_value_error():
    with pytest.raises(ValueError, match="at most 50"):
        sgplvm.SharedGPLVM(latent_dim=2).fit(_spaces(50), max_iters=2, validation=None, inducing=51)


def test_the_experiment_trains_the_sparse_model_on_every_frame():
    """``experiment_data(all_frames=True)`` with ``inducing`` in the config: the plan gains, per
    run and robot, the sparse model on the subsample and on every full-rate training frame of
    the default data; without the frames such a task is refused by name."""
    import json

    config = json.loads(_sgplvm.experiment_config("quick"))
    config.update(runs=1, transfers_per_run=1, max_iters=3, transfer_max_iters=3, fractions=[], inducing=10)
    config = json.dumps(config)
    data = _sgplvm.experiment_data(all_frames=True)
    tasks = [t for t in json.loads(_sgplvm.experiment_plan(data, config)) if t["spec"]["kind"] == "all_frames"]
    # Per robot the control (the sparse model on the subsample), then every frame.
    assert [(t["spec"]["robot"], t["spec"]["full_rate"]) for t in tasks] == [
        (0, False), (1, False), (2, False), (0, True), (1, True), (2, True)
    ]
    tasks = tasks[3:]
    records, model = _sgplvm.experiment_execute(data, config, json.dumps(tasks[0]))
    assert model is None
    record = json.loads(records)["all_frames"]
    assert record["robot"] == "walkman" and record["inducing"] == 10
    assert record["frames"] > 11 * record["subsampled_frames"]
    assert np.isfinite(record["test_mse"]) and record["test_mse"] > 0
    with pytest.raises(Exception, match="full-rate training frames"):
        _sgplvm.experiment_execute(_sgplvm.experiment_data(), config, json.dumps(tasks[0]))
