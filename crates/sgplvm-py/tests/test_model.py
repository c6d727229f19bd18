"""The Python model API: GPy agreement, fit / transfer / predict / save / load / pickle, threads,
and errors for every kind of bad input."""

import multiprocessing
import os
import pathlib
import pickle
import threading

import numpy as np
import pytest

import sgplvm

Q = 3
# Measured ratios and errors (tolerances about 10× these; see the tests that use them).
MSE_RATIO_TRAIN = 3e-3  # training-frame MSE / variance: measured 2.6e-4
MSE_RATIO_TRANSFER = 1e-2  # after transfer: measured 9.9e-4
MEAN_RTOL = 2e-12  # predicted mean vs numpy: measured 1.8e-13
VAR_RTOL = 1e-14  # predicted std² vs numpy, relative to the prior variance: measured 1.1e-15


def smooth_data(n=40, seed=0):
    """Human (6-D) and two robots (4-D each) driven by one 2-D latent trajectory."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 2 * np.pi, n)
    z = np.stack([np.sin(t), np.cos(2 * t)], axis=1)
    human = np.tanh(z @ rng.normal(size=(2, 6))) + 0.01 * rng.normal(size=(n, 6))
    r1 = np.sin(z @ rng.normal(size=(2, 4))) + 0.01 * rng.normal(size=(n, 4))
    r2 = 0.5 * np.sin(z @ rng.normal(size=(2, 4)) + 0.3) + 0.01 * rng.normal(size=(n, 4))
    return human, r1, r2


@pytest.fixture(scope="module")
def data():
    return smooth_data()


@pytest.fixture(scope="module")
def trained(data):
    human, r1, _ = data
    m = sgplvm.SharedGPLVM(latent_dim=Q, back_constraint="input", seed=0)
    m.fit({"human": human, "walkman": r1}, input="human", max_iters=60)
    return m


# ---------------------------------------------------------------- GPy agreement


def gpy_objective_and_grads(spaces, X, params):
    """Sum over spaces of GPy's GPLVM negative log likelihood and its gradients (w.r.t. X and
    each space's kernel and noise), with centred data, as DESIGN.md defines the model."""
    GPy = pytest.importorskip("GPy")
    total = 0.0
    grad_x = np.zeros_like(X)
    grads = {}
    for name, Y in spaces.items():
        p = params["spaces"][name]
        kern = GPy.kern.RBF(X.shape[1], ARD=True)
        model = GPy.models.GPLVM(Y - Y.mean(axis=0), X.shape[1], X=X.copy(), kernel=kern)
        model.kern.variance = p["variance"]
        model.kern.lengthscale = np.asarray(p["lengthscale"])
        # GPy factorises K + (noise + 1e-8) I: give it noise - 1e-8 so both see the same matrix.
        model.likelihood.variance = p["noise"] - 1e-8
        total += model.objective_function()
        grad_x -= model.X.gradient
        grads[name] = {
            "variance": -float(model.kern.variance.gradient[0]),
            "lengthscale": -np.asarray(model.kern.lengthscale.gradient),
            "noise": -float(model.likelihood.variance.gradient[0]),
        }
    return total, grad_x, grads


@pytest.mark.parametrize("names", [("human", "walkman"), ("human", "walkman", "coman")])
def test_objective_and_gradient_match_gpy(data, names):
    human, r1, r2 = data
    all_spaces = {"human": human, "walkman": r1, "coman": r2}
    spaces = {n: all_spaces[n] for n in names}
    m = sgplvm.SharedGPLVM(latent_dim=Q, back_constraint=None, seed=3)
    m.fit(spaces, input="human", max_iters=0)
    rng = np.random.default_rng(7)
    p = m.params
    p["latent"] = rng.normal(size=p["latent"].shape)
    for k, name in enumerate(names):
        p["spaces"][name] = {
            "variance": 0.7 + 0.3 * k,
            "lengthscale": rng.uniform(0.5, 2.0, size=Q),
            "noise": 0.05 + 0.01 * k,
        }
    m.set_params(p)
    ours = m.objective()
    grad = m.gradient()
    theirs, grad_x, grads = gpy_objective_and_grads(spaces, p["latent"], p)
    assert ours == pytest.approx(theirs, rel=1e-8)
    np.testing.assert_allclose(grad["latent"], grad_x, rtol=1e-7, atol=1e-8 * np.abs(grad_x).max())
    for name in names:
        for key in ("variance", "lengthscale", "noise"):
            np.testing.assert_allclose(grad["spaces"][name][key], grads[name][key], rtol=1e-7)


# ---------------------------------------------------------------- fit, transfer, predict


def test_fit_reduces_objective_and_records_history(trained):
    h = trained.history
    assert len(h["objective"]) >= 2
    assert h["objective"][-1] < h["objective"][0]
    assert all(b <= a + 1e-9 for a, b in zip(h["objective"], h["objective"][1:]))
    assert all(s >= 0 for s in h["seconds"])
    # Evaluations so far: one at the start, at least one more per iteration.
    assert h["evaluations"][0] == 1
    assert all(b > a for a, b in zip(h["evaluations"], h["evaluations"][1:]))


def test_predictions_follow_set_params_and_the_map_is_refitted(data):
    """set_params defers the prediction caches and the input map's refit to the first
    prediction: what it then predicts equals a model loaded with those parameters."""
    human, r1, _ = data
    m = sgplvm.SharedGPLVM(latent_dim=Q, back_constraint=None, seed=3)
    m.fit({"human": human, "walkman": r1}, input="human", max_iters=5, validation=None)
    before = m.predict(human[:7], robot="walkman")
    p = m.params
    p["latent"] = p["latent"] * 1.3 + 0.1
    m.set_params(p)
    m.gradient()
    after = m.predict(human[:7], robot="walkman")
    assert not np.allclose(after, before)
    reloaded = sgplvm.SharedGPLVM.from_bytes(m.to_bytes())
    np.testing.assert_array_equal(reloaded.predict(human[:7], robot="walkman"), after)
    np.testing.assert_array_equal(reloaded.params["latent"], p["latent"])


def test_predict_shapes_and_accuracy(trained, data):
    human, r1, _ = data
    pred = trained.predict(human, robot="walkman")
    assert pred.shape == r1.shape and pred.dtype == np.float64
    # Training frames are reproduced much better than by the mean (measured 2.6e-4 × var).
    assert np.mean((pred - r1) ** 2) < MSE_RATIO_TRAIN * np.mean((r1 - r1.mean(0)) ** 2)
    mean, std = trained.predict(human[:5], robot="walkman", return_std=True)
    assert std.shape == (5, 4) and np.all(std > 0)
    np.testing.assert_array_equal(mean, pred[:5])
    one = trained.predict(human[0], robot="walkman")
    assert one.shape == (4,)
    np.testing.assert_allclose(one, pred[0], rtol=0, atol=1e-12)
    assert trained.latent(human).shape == (len(human), Q)


def test_inputs_of_any_float_kind_and_order(trained, data):
    human, _, _ = data
    ref = trained.predict(human, robot="walkman")
    fortran = np.asfortranarray(human)
    # A strided view of a larger array (neither C- nor Fortran-contiguous) and a view with
    # negative strides.
    wide = np.zeros((2 * len(human), 12))
    wide[::2, ::2] = human
    strided = wide[::2, ::2]
    backwards = np.ascontiguousarray(human[::-1, ::-1])[::-1, ::-1]
    for view in (strided, backwards):
        assert not view.flags.c_contiguous and not view.flags.f_contiguous
        np.testing.assert_array_equal(view, human)
    assert backwards.strides[0] < 0 and backwards.strides[1] < 0
    assert not fortran.flags.c_contiguous
    for layout in (fortran, strided, backwards, human.tolist()):
        np.testing.assert_array_equal(trained.predict(layout, robot="walkman"), ref)
    np.testing.assert_allclose(trained.predict(human.astype(np.float32), robot="walkman"), ref, atol=1e-5)


def dense_posterior(model, H, robot, Y, scale):
    """The posterior mean and standard deviation of the latent function computed with numpy from
    the model's parameters and latent points: K = k(X, X) + σ²I, mean = k*ᵀK⁻¹(Y − ȳ)/s · s + ȳ,
    std = √(α² − k*ᵀK⁻¹k*) · s, with s the columns' standard deviations when scaling is on."""
    p = model.params["spaces"][robot]
    X = model.latent_points
    xs = model.latent(H)

    def k(a, b):
        d = (a[:, None, :] - b[None, :, :]) / np.asarray(p["lengthscale"])
        return p["variance"] * np.exp(-0.5 * (d**2).sum(-1))

    offset = Y.mean(axis=0)
    s = Y.std(axis=0) if scale else np.ones(Y.shape[1])
    K = k(X, X) + p["noise"] * np.eye(len(X))
    ks = k(xs, X)
    mean = ks @ np.linalg.solve(K, (Y - offset) / s) * s + offset
    var = p["variance"] - np.einsum("ij,ji->i", ks, np.linalg.solve(K, ks.T))
    return mean, np.sqrt(var)[:, None] * s, p["variance"]


@pytest.mark.parametrize("scale", [False, True])
def test_predicted_mean_and_std_match_numpy(data, scale):
    human, r1, _ = data
    m = sgplvm.SharedGPLVM(latent_dim=Q, back_constraint="input", seed=0, scale=scale)
    m.fit({"human": human, "walkman": r1}, input="human", max_iters=30)
    # Training and new frames (a shifted copy of the training motion).
    frames = np.vstack([human[::7], human[3::9] + 0.05])
    mean, std = m.predict(frames, robot="walkman", return_std=True)
    want_mean, want_std, variance = dense_posterior(m, frames, "walkman", r1, scale)
    if scale:
        assert np.ptp(r1.std(axis=0)) > 0.05  # the per-column scales differ
    # Errors relative to the mean's size and to the prior variance α²·s²: see MEAN_RTOL, VAR_RTOL.
    s = r1.std(axis=0) if scale else np.ones(r1.shape[1])
    prior_std = np.sqrt(variance) * s
    mean_err = np.max(np.abs(mean - want_mean) / np.maximum(np.abs(want_mean), 1.0))
    std_err = np.max(np.abs(std ** 2 - want_std ** 2) / prior_std ** 2)
    assert mean_err < MEAN_RTOL, mean_err
    assert std_err < VAR_RTOL, std_err


def test_transfer_trains_only_the_new_robot(trained, data):
    human, _, r2 = data
    before = trained.params
    t = trained.transfer("coman", r2, max_iters=60)
    after = trained.params
    np.testing.assert_array_equal(before["latent"]["weights"], after["latent"]["weights"])
    tp = t.params
    np.testing.assert_array_equal(tp["latent"]["weights"], before["latent"]["weights"])
    for key in ("variance", "lengthscale", "noise"):
        np.testing.assert_array_equal(tp["spaces"]["human"][key], before["spaces"]["human"][key])
    pred = t.predict(human, robot="coman")
    # Measured 9.9e-4 × var.
    assert np.mean((pred - r2) ** 2) < MSE_RATIO_TRANSFER * np.mean((r2 - r2.mean(0)) ** 2)
    with pytest.raises(ValueError, match="coman"):
        trained.predict(human, robot="coman")


def test_multi_robot_fit(data):
    human, r1, r2 = data
    m = sgplvm.SharedGPLVM(latent_dim=Q, back_constraint="input", seed=1)
    m.fit({"human": human, "walkman": r1, "coman": r2}, input="human", max_iters=30)
    assert set(m.params["spaces"]) == {"human", "walkman", "coman"}
    assert m.predict(human, robot="coman").shape == r2.shape


@pytest.mark.parametrize("bc", [None, "output"])
def test_other_back_constraints_predict_through_gp_regression(data, bc):
    human, r1, _ = data
    m = sgplvm.SharedGPLVM(latent_dim=Q, back_constraint=bc, seed=0)
    m.fit({"human": human, "walkman": r1}, input="human", max_iters=30)
    assert np.all(np.isfinite(m.predict(human, robot="walkman")))


def test_callback_can_stop_training(data):
    human, r1, _ = data
    seen = []

    def callback(iteration, objective):
        seen.append((iteration, objective))
        return len(seen) < 3

    m = sgplvm.SharedGPLVM(latent_dim=Q, seed=0)
    m.fit({"human": human, "walkman": r1}, input="human", max_iters=50, callback=callback)
    assert len(seen) == 3


def test_callback_exception_propagates(data):
    human, r1, _ = data

    def callback(iteration, objective):
        raise RuntimeError("stop here")

    m = sgplvm.SharedGPLVM(latent_dim=Q, seed=0)
    with pytest.raises(RuntimeError, match="stop here"):
        m.fit({"human": human, "walkman": r1}, input="human", max_iters=50, callback=callback)


def test_seeded_training_is_deterministic(data):
    human, r1, _ = data
    preds = []
    for _ in range(2):
        m = sgplvm.SharedGPLVM(latent_dim=Q, seed=5)
        m.fit({"human": human, "walkman": r1}, input="human", max_iters=20)
        preds.append(m.predict(human, robot="walkman"))
    np.testing.assert_array_equal(preds[0], preds[1])


# ---------------------------------------------------------------- persistence


def test_save_load_and_pickle_are_bit_identical(trained, data, tmp_path):
    human, _, _ = data
    ref = trained.predict(human, robot="walkman")
    path = tmp_path / "model.sgp"
    trained.save(str(path))
    loaded = sgplvm.SharedGPLVM.load(str(path))
    np.testing.assert_array_equal(loaded.predict(human, robot="walkman"), ref)
    np.testing.assert_array_equal(
        pickle.loads(pickle.dumps(trained)).predict(human, robot="walkman"), ref
    )


def test_corrupt_files_raise(tmp_path, trained):
    path = tmp_path / "model.sgp"
    trained.save(str(path))
    raw = path.read_bytes()
    (tmp_path / "short.sgp").write_bytes(raw[: len(raw) // 2])
    (tmp_path / "foreign.sgp").write_bytes(b"not a model at all")
    for name in ("short.sgp", "foreign.sgp"):
        with pytest.raises(ValueError, match=name):
            sgplvm.SharedGPLVM.load(str(tmp_path / name))
    with pytest.raises((OSError, ValueError), match="missing.sgp"):
        sgplvm.SharedGPLVM.load(str(tmp_path / "missing.sgp"))


# ---------------------------------------------------------------- threads


def test_two_models_train_in_two_threads(data):
    human, r1, r2 = data
    results = {}

    def train(name, robot):
        m = sgplvm.SharedGPLVM(latent_dim=Q, seed=2)
        m.fit({"human": human, name: robot}, input="human", max_iters=30)
        results[name] = m.predict(human, robot=name)

    threads = [threading.Thread(target=train, args=a) for a in (("walkman", r1), ("coman", r2))]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    # The same training alone gives the same answer.
    alone = sgplvm.SharedGPLVM(latent_dim=Q, seed=2)
    alone.fit({"human": human, "walkman": r1}, input="human", max_iters=30)
    np.testing.assert_array_equal(results["walkman"], alone.predict(human, robot="walkman"))
    assert results["coman"].shape == r2.shape


def _fit_and_predict(args):
    human, robot = args
    m = sgplvm.SharedGPLVM(latent_dim=Q, seed=3)
    m.fit({"human": human, "walkman": robot}, input="human", max_iters=5)
    return m.predict(human, robot="walkman")


@pytest.mark.skipif(not hasattr(os, "fork"), reason="no fork() on this platform")
def test_models_train_in_forked_processes():
    # A child inherits a copy of a thread pool without its threads: work handed to rayon's
    # global pool (faer's default for its operators, and our space-parallel evaluation before
    # it had a fork-aware pool) waited there forever. The paper's sizes (300 frames, 18 human
    # and 14 robot joints) are large enough for both.
    rng = np.random.default_rng(4)
    t = np.linspace(0, 2 * np.pi, 300)
    z = np.stack([np.sin(t), np.cos(2 * t)], axis=1)
    human = np.tanh(z @ rng.normal(size=(2, 18)))
    r1 = np.sin(z @ rng.normal(size=(2, 14)))
    here = _fit_and_predict((human, r1))  # the pool now runs in this process
    with multiprocessing.get_context("fork").Pool(2) as pool:
        children = pool.map_async(_fit_and_predict, [(human, r1)] * 2).get(timeout=60)
    for child in children:
        np.testing.assert_array_equal(child, here)


# ---------------------------------------------------------------- bad input


def test_bad_inputs_raise_value_errors(data, trained):
    human, r1, _ = data
    m = sgplvm.SharedGPLVM(latent_dim=Q, seed=0)
    bad = human.copy()
    bad[3, 2] = np.nan
    with pytest.raises(ValueError, match=r"'human': value at row 3, column 2 is NaN"):
        m.fit({"human": bad, "walkman": r1}, input="human", max_iters=5)
    with pytest.raises(ValueError, match=r"'walkman' has 39 rows; expected 40"):
        m.fit({"human": human, "walkman": r1[:-1]}, input="human", max_iters=5)
    with pytest.raises(ValueError, match="nobody"):
        m.fit({"human": human, "walkman": r1}, input="nobody", max_iters=5)
    with pytest.raises(ValueError, match="back_constraint is 'sideways'"):
        sgplvm.SharedGPLVM(latent_dim=Q, back_constraint="sideways")
    with pytest.raises(ValueError, match=r"latent dimension Q = 60 is invalid for N = 40"):
        big = sgplvm.SharedGPLVM(latent_dim=60, seed=0)
        big.fit({"human": human, "walkman": r1}, input="human", max_iters=5)
    with pytest.raises(ValueError, match=r"'human' is empty \(0×6\)"):
        m.fit({"human": human[:0], "walkman": r1[:0]}, input="human", max_iters=5)
    with pytest.raises(ValueError, match=r"found 5 columns/values; expected 6"):
        trained.predict(human[:, :5], robot="walkman")
    with pytest.raises(ValueError, match="centauro"):
        trained.predict(human, robot="centauro")
    with pytest.raises(ValueError, match="expected a 2-D array"):
        trained.predict(np.zeros((2, 3, 6)), robot="walkman")
    with pytest.raises(RuntimeError, match=r"not fitted yet"):
        sgplvm.SharedGPLVM(latent_dim=Q).predict(human, robot="walkman")


def test_the_gate_s_signal_and_decision_are_those_of_evaluate(tmp_path):
    """``reconstruction_error``, ``novelty``, their thresholds and ``trusted`` (issue 49): on the
    captured test frames, the same frames 1 rad off and random poses, the frames the gate holds
    are the ones ``sgplvm evaluate`` counts for teleop's default gate, at the same thresholds."""
    import json
    import subprocess

    from _cli import sgplvm_binary

    captured = pathlib.Path(__file__).resolve().parents[3] / "data" / "demos" / "captured.mcap"
    model_path = tmp_path / "w.sgp"
    def run(*args):
        return subprocess.run([str(sgplvm_binary()), *map(str, args)], capture_output=True, text=True, check=True)

    run("train", "--data", captured, "--robot", "walkman", "--out", model_path)
    report = json.loads(run("evaluate", "--model", model_path, "--robot", "walkman", "--data", captured, "--json").stdout)
    gate = next(r for r in report["gate"]["rates"] if r["gate"] == "known")
    model = sgplvm.SharedGPLVM.load(model_path)
    assert model.reconstruction_threshold() == pytest.approx(report["gate"]["reconstruction_threshold"], rel=1e-12)
    assert model.novelty_threshold() == pytest.approx(report["gate"]["novelty_threshold"], rel=1e-12)
    assert model.trust_threshold("walkman") == pytest.approx(report["gate"]["sd_threshold"], rel=1e-12)
    d = sgplvm.load_demonstrations(captured)
    test = np.asarray(d["human"]["positions"])[np.asarray(d["test"])]
    for frames, held in ((test, gate["test"]["held"]), (test + 1.0, gate["far"]["held"])):
        trusted = model.trusted(frames)
        assert trusted.dtype == bool and int((~trusted).sum()) == held
        errors, distances = model.reconstruction_error(frames), model.novelty(frames)
        assert errors.shape == distances.shape == (len(frames),)
        known = (errors <= model.reconstruction_threshold()) & (distances <= model.novelty_threshold())
        assert np.array_equal(trusted, known)
    # A training frame is at distance 0; the test frames 1 rad off are all held, by both signals.
    train = np.asarray(d["human"]["positions"])[np.asarray(d["train"])]
    assert model.novelty(train[5]) < 1e-12
    assert (model.novelty(test + 1.0) > model.novelty_threshold()).all()
    # A model fitted here on the same training frames sets the novelty's threshold as `train`
    # does (random poses within the human's joint limits): until 2026-12-07 a Python model fell
    # back to another rule and followed 3.3 % of random poses against the CLI's 0.6 %.
    robot = np.asarray(d["robots"]["walkman"]["positions"])[np.asarray(d["train"])]
    here = sgplvm.SharedGPLVM(seed=0).fit({"human": train, "walkman": robot}, max_iters=2, validation=None)
    assert here.novelty_threshold() == pytest.approx(model.novelty_threshold(), rel=1e-12)
    # One frame in, one number out.
    assert isinstance(model.reconstruction_error(test[0]), float) and isinstance(model.trusted(test[0]), bool)
    with pytest.raises(ValueError):
        model.reconstruction_error(np.zeros((2, 5)))
    # A frame the signals cannot be had for (NaN, a value far enough to overflow) is held on
    # its own; the other frames are answered (the whole batch raised until 2026-12-07).
    bad = test[:3].copy()
    bad[1, 2], bad[2, 5] = np.nan, 1e155
    assert model.trusted(bad).tolist() == [bool(model.trusted(test[0])), False, False]
    errors = model.reconstruction_error(bad)
    assert np.isfinite(errors[0]) and np.isnan(errors[1:]).all()


def test_a_per_arm_model_s_gate_is_evaluate_s(tmp_path):
    """``PartsGPLVM`` exposes the gate ``teleop`` and ``evaluate`` apply to a latent space per
    arm (the model training.md advises for strangers): each part's signals over its own
    thresholds, the worst part's; a frame followed where every part follows it."""
    import json
    import subprocess

    from _cli import sgplvm_binary

    captured = pathlib.Path(__file__).resolve().parents[3] / "data" / "demos" / "captured.mcap"
    path = tmp_path / "arms.sgp"
    def run(*args):
        return subprocess.run([str(sgplvm_binary()), *map(str, args)], capture_output=True, text=True, check=True)

    run("train", "--data", captured, "--robot", "walkman", "--parts", "arms", "--out", path)
    report = json.loads(run("evaluate", "--model", path, "--robot", "walkman", "--data", captured, "--json").stdout)
    gate = next(r for r in report["gate"]["rates"] if r["gate"] == "known")
    model = sgplvm.load_model(path)
    assert isinstance(model, sgplvm.PartsGPLVM)
    assert model.reconstruction_threshold() == model.novelty_threshold() == 1.0
    d = sgplvm.load_demonstrations(captured)
    test = np.asarray(d["human"]["positions"])[np.asarray(d["test"])]
    for frames, held in ((test, gate["test"]["held"]), (test + 1.0, gate["far"]["held"])):
        trusted = model.trusted(frames)
        assert trusted.dtype == bool and int((~trusted).sum()) == held
        worst = np.maximum(model.reconstruction_error(frames), model.novelty(frames))
        assert np.array_equal(trusted, worst <= 1.0)
    # Each part's own gate, combined by hand, is the same decision.
    by_hand = np.ones(len(test), bool)
    for name in model.part_names:
        by_hand &= model.part(name).trusted(test[:, model.part_columns(name)["human"]])
    assert np.array_equal(model.trusted(test), by_hand)
    assert isinstance(model.trusted(test[0]), bool) and isinstance(model.novelty(test[0]), float)


def test_segments_name_their_people():
    """``load_demonstrations`` gives each segment's person (``import --person``; issue 49): the
    shipped corpus of thirteen people names them all, its test frames are the four strangers'
    (03, 07, 10, 14) and no training frame is theirs; a file without people says None."""
    root = pathlib.Path(__file__).resolve().parents[3] / "data" / "demos"
    d = sgplvm.load_demonstrations(root / "people.mcap")
    person = np.empty(len(d["times_ns"]), dtype=object)
    for s in d["segments"]:
        person[s["start"]:s["end"]] = s["person"]
    assert len(set(person)) == 13 and None not in set(person)
    assert set(person[np.asarray(d["test"])]) == {"03", "07", "10", "14"}
    assert not set(person[np.asarray(d["train"])]) & {"03", "07", "10", "14"}
    assert all(s["person"] is None for s in sgplvm.load_demonstrations(root / "bimanual.mcap")["segments"])
