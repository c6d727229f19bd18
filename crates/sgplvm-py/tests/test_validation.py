"""Early stopping on held-out rows (``validation=``): the default, what it records, that it is
"train on the rest, pick the best iteration, retrain on everything", and bad arguments."""

import pickle
from pathlib import Path

import numpy as np
import pytest

import sgplvm

DEMOS = Path(__file__).resolve().parents[3] / "data" / "demos" / "bimanual.mcap"


@pytest.fixture(scope="module")
def demo():
    return sgplvm.load_demonstrations(DEMOS)


def spaces(demo, robot="walkman"):
    train = demo["train"]
    return {
        "human": demo["human"]["positions"][train],
        robot: demo["robots"][robot]["positions"][train],
    }


def test_the_shipped_split_holds_out_the_last_repetition(demo):
    rows = np.asarray(demo["validation"])
    train = demo["train"]
    frames = train[rows]
    last = max(s["repetition"] for s in demo["segments"] if s["repetition"] is not None)

    def repetition(frame):
        return next(s["repetition"] for s in demo["segments"] if s["start"] <= frame < s["end"])

    assert len(rows) == 84 and len(train) == 249
    assert all(repetition(f) == last for f in frames)
    assert all(repetition(f) != last for f in np.delete(train, rows))
    # Test frames are not among them.
    assert not set(frames) & set(demo["test"])


def test_default_fit_is_early_stopping_then_retraining(demo):
    data = spaces(demo)
    model = sgplvm.SharedGPLVM(5, "input").fit(data, max_iters=200, validation=demo["validation"])
    sel = model.selection
    assert (sel["fit_frames"], sel["validation_frames"]) == (165, 84)
    errors = [c["validation_mse"] for c in sel["curve"]]
    assert sel["curve"][int(np.argmin(errors))]["iteration"] == sel["best_iteration"]
    assert sel["curve"][-1]["iteration"] <= sel["best_iteration"] + sel["patience"]
    # The final model is the plain fit on all rows for the chosen budget.
    plain = sgplvm.SharedGPLVM(5, "input").fit(
        data, max_iters=sel["best_iteration"], validation=None
    )
    assert plain.selection is None
    h = data["human"]
    np.testing.assert_array_equal(model.predict(h, "walkman"), plain.predict(h, "walkman"))
    # The plain fit ran out of the budget it was given; the validated one ran out of the budget
    # the held-out rows chose (the selection run went past its best iteration), and says so.
    assert sel["curve"][-1]["iteration"] > sel["best_iteration"]
    assert plain.stop_reason == "max_iterations"
    assert model.stop_reason == "validated_budget"
    # The selection and the stop reason travel with the model.
    restored = pickle.loads(pickle.dumps(model))
    assert restored.selection == sel and restored.stop_reason == "validated_budget"
    # "auto" holds out every third of nine blocks of rows.
    auto = sgplvm.SharedGPLVM(5, "input").fit(data, max_iters=20)
    blocks = np.arange(249) * 9 // 249
    held = int(np.sum(blocks % 3 == 2))  # 81: blocks 2, 5, 8 of nine
    assert (auto.selection["fit_frames"], auto.selection["validation_frames"]) == (249 - held, held)


def test_transfer_chooses_its_budget_too(demo):
    data = spaces(demo)
    source = sgplvm.SharedGPLVM(5, "input").fit(data, max_iters=20, validation=demo["validation"])
    coman = demo["robots"]["coman"]["positions"][demo["train"]]
    moved = source.transfer("coman", coman, validation=demo["validation"], patience=5)
    sel = moved.selection
    assert sel["validation_frames"] == 84
    plain = source.transfer("coman", coman, max_iters=sel["best_iteration"], validation=None)
    h = data["human"]
    np.testing.assert_array_equal(moved.predict(h, "coman"), plain.predict(h, "coman"))
    if plain.stop_reason == "max_iterations" and sel["curve"][-1]["iteration"] > sel["best_iteration"]:
        assert moved.stop_reason == "validated_budget"
    else:
        assert moved.stop_reason == plain.stop_reason


@pytest.mark.parametrize(
    "validation, message",
    [
        ("bogus", "expected 'auto', None"),
        (np.zeros((2, 2), dtype=int), "1-D"),
        ([1.5, 2.0], "integer row indices"),
        ([-1], "negative"),
        (np.ones(3, dtype=bool), "boolean mask of 3 rows"),
        ([0, 0], "given twice"),
        ([10_000], "out of range"),
        ([], "no row is held out"),
    ],
)
def test_bad_validation_arguments_are_errors(demo, validation, message):
    with pytest.raises(ValueError, match=message):
        sgplvm.SharedGPLVM(5, "input").fit(spaces(demo), max_iters=5, validation=validation)


def test_negative_patience_is_an_error(demo):
    with pytest.raises(ValueError, match="patience"):
        sgplvm.SharedGPLVM(5, "input").fit(spaces(demo), max_iters=5, patience=-1)


# ------------------------------------------------------------- validation_callback


def _toy(n=45, seed=0):
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 3.0, n)[:, None]
    human = np.hstack([np.sin(t + k) for k in range(4)]) + 0.01 * rng.standard_normal((n, 4))
    robot = np.hstack([np.cos(t + 0.5 * k) for k in range(3)])
    return {"human": human, "r": robot}


def test_the_validation_callback_hears_the_selection_curve():
    data = _toy()
    heard, final = [], []
    model = sgplvm.SharedGPLVM(2, "input").fit(
        data,
        max_iters=30,
        patience=5,
        validation_callback=heard.append,
        callback=lambda i, f: final.append(i),
    )
    sel = model.selection
    assert len(heard) > 2
    # Exactly the curve the model reports (every value bit for bit), iteration 0 first.
    assert heard == sel["curve"]
    assert [r["iteration"] for r in heard] == list(range(len(heard)))
    best = min(heard, key=lambda r: r["validation_mse"])
    assert best["iteration"] == sel["best_iteration"]
    # The final run on all rows is what `callback` hears; listening changes nothing.
    assert final == list(range(1, sel["best_iteration"] + 1))
    plain = sgplvm.SharedGPLVM(2, "input").fit(data, max_iters=30, patience=5)
    np.testing.assert_array_equal(model.predict(data["human"], "r"), plain.predict(data["human"], "r"))
    assert plain.selection == {**sel, "seconds": plain.selection["seconds"]}


def test_returning_false_ends_the_selection_at_the_best_iteration_so_far():
    data = _toy()
    heard = []

    def stop_at_3(record):
        heard.append(record["iteration"])
        return record["iteration"] < 3

    model = sgplvm.SharedGPLVM(2, None).fit(data, max_iters=30, patience=20, validation_callback=stop_at_3)
    sel = model.selection
    assert heard == [0, 1, 2, 3]
    assert [r["iteration"] for r in sel["curve"]] == [0, 1, 2, 3]
    full = sgplvm.SharedGPLVM(2, None).fit(data, max_iters=30, patience=20).selection
    assert len(full["curve"]) > 4, "the run would have gone on"
    assert sel["curve"] == full["curve"][:4]
    chosen = min(sel["curve"], key=lambda r: r["validation_mse"])["iteration"]
    assert sel["best_iteration"] == chosen
    plain = sgplvm.SharedGPLVM(2, None).fit(data, max_iters=chosen, validation=None)
    np.testing.assert_array_equal(model.predict(data["human"], "r"), plain.predict(data["human"], "r"))


def test_an_exception_in_the_validation_callback_stops_training_and_is_raised():
    data = _toy()
    final = []

    def fail(record):
        # Past the first iterations, so the best so far is not 0: a final run would be heard.
        if record["iteration"] == 8:
            raise RuntimeError("enough")

    with pytest.raises(RuntimeError, match="enough"):
        sgplvm.SharedGPLVM(2, "input").fit(
            data, max_iters=30, patience=20, validation_callback=fail, callback=lambda i, f: final.append(i)
        )
    assert final == [], "the final run went on after the callback raised"


def test_a_transfer_validation_callback_hears_its_curve():
    data = _toy()
    model = sgplvm.SharedGPLVM(2, "input").fit(data, max_iters=10, validation=None)
    heard = []
    new = model.transfer("r2", data["r"][:, ::-1] * 2.0, max_iters=20, validation_callback=heard.append)
    assert heard == new.selection["curve"] and len(heard) > 1


def test_a_validation_callback_needs_held_out_rows():
    with pytest.raises(ValueError, match="validation_callback is given but validation is None"):
        sgplvm.SharedGPLVM(2).fit(_toy(), max_iters=3, validation=None, validation_callback=print)
