"""What a newcomer does first (issue 45): a model fitted in Python the README's way is used by
the command line as it is, and ``sgplvm predict``'s CSV is read by numpy and pandas without
options."""

import json
import subprocess

import numpy as np
import pytest

import sgplvm
from _cli import ROOT, sgplvm_binary

DEMOS = ROOT / "data" / "demos" / "bimanual.mcap"


@pytest.fixture(scope="module")
def demo():
    return sgplvm.load_demonstrations(DEMOS)


@pytest.fixture(scope="module")
def readme_model(demo, tmp_path_factory):
    """The README's Python example (a shorter budget): no ``column_names`` anywhere."""
    train = demo["train"]
    H = demo["human"]["positions"]
    R = {name: body["positions"] for name, body in demo["robots"].items()}
    m = sgplvm.SharedGPLVM(latent_dim=5, back_constraint="input", seed=0)
    m.fit({"human": H[train], "walkman": R["walkman"][train]}, input="human", validation=demo["validation"], max_iters=40)
    t = m.transfer("coman", R["coman"][train], validation=demo["validation"], max_iters=40)
    path = tmp_path_factory.mktemp("readme") / "coman-py.sgp"
    t.save(path)
    return path


def predict(model, out, *extra):
    return subprocess.run(
        [str(sgplvm_binary()), "predict", "--model", str(model), "--input", str(DEMOS), "--robot", "coman", "--out", str(out), *extra],
        capture_output=True,
        text=True,
        cwd=ROOT,
    )


@pytest.fixture(scope="module")
def predicted(readme_model, tmp_path_factory):
    out = tmp_path_factory.mktemp("predicted") / "out.csv"
    done = predict(readme_model, out)
    assert done.returncode == 0, done.stderr
    return out


def test_a_model_fitted_on_load_demonstrations_names_its_joints(demo, readme_model):
    t = sgplvm.SharedGPLVM.load(readme_model)
    assert t.column_names("human") == demo["human"]["joint_names"]
    for robot in ("walkman", "coman"):
        assert t.column_names(robot) == demo["robots"][robot]["joint_names"]


def test_the_readme_s_python_model_predicts_on_the_command_line(demo, predicted):
    header = predicted.read_text().splitlines()[0].split(",")
    assert header == ["time"] + demo["robots"]["coman"]["joint_names"]
    # What the commands are: the sidecar beside the CSV (the CSV holds no comment line).
    sidecar = json.loads(predicted.with_name(predicted.name + ".json").read_text())
    assert sidecar["sgplvm.predict"]["commands"] == "limited"
    assert "coman commands" in sidecar["description"]


def test_given_column_names_win_and_unknown_spaces_stay_unnamed(demo):
    train = demo["train"][:60]
    H = demo["human"]["positions"][train]
    C = demo["robots"]["coman"]["positions"][train]
    mine = [f"q{j}" for j in range(C.shape[1])]
    m = sgplvm.SharedGPLVM(latent_dim=2, seed=0)
    m.fit({"person": H, "coman": C}, input="person", column_names={"coman": mine}, max_iters=3, validation=None)
    assert m.column_names("coman") == mine
    assert m.column_names("person") is None
    # A built-in name with another number of columns is not given that body's joints.
    m.fit({"human": H[:, :10], "coman": C}, input="human", max_iters=3, validation=None)
    assert m.column_names("human") is None
    assert m.column_names("coman") == demo["robots"]["coman"]["joint_names"]


def test_a_model_without_joint_names_is_refused_saying_how_to_name_them(demo, tmp_path):
    train = demo["train"][:60]
    m = sgplvm.SharedGPLVM(latent_dim=2, seed=0)
    m.fit(
        {"person": demo["human"]["positions"][train], "coman": demo["robots"]["coman"]["positions"][train]},
        input="person",
        max_iters=3,
        validation=None,
    )
    m.save(tmp_path / "unnamed.sgp")
    done = predict(tmp_path / "unnamed.sgp", tmp_path / "x.csv")
    assert done.returncode == 1, done.stderr
    assert "panicked" not in done.stderr
    assert "no joint names for its space `person`" in done.stderr, done.stderr
    assert "column_names=" in done.stderr, done.stderr
    assert not (tmp_path / "x.csv").exists()


def test_numpy_reads_predict_s_csv_without_options(demo, predicted):
    table = np.genfromtxt(predicted, delimiter=",", names=True)
    names = demo["robots"]["coman"]["joint_names"]
    assert list(table.dtype.names) == ["time"] + names
    assert len(table) == len(demo["times_ns"])
    assert np.all(np.isfinite(table["time"])) and np.all(np.diff(table["time"]) > 0)
    plain = np.loadtxt(predicted, delimiter=",", skiprows=1)
    assert plain.shape == (len(demo["times_ns"]), 1 + len(names))
    assert np.array_equal(plain[:, 1], table[names[0]])


def test_pandas_reads_predict_s_csv_without_options(demo, predicted):
    pandas = pytest.importorskip("pandas")
    frame = pandas.read_csv(predicted)
    assert list(frame.columns) == ["time"] + demo["robots"]["coman"]["joint_names"]
    assert len(frame) == len(demo["times_ns"])
    assert frame.dtypes.map(lambda d: d.kind == "f").all()
