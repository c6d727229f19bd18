"""A model trained in Python carries what one trained by ``sgplvm train`` does: the person's
calibration and the robot its commands were retargeted onto, read from the demonstrations
(``load_demonstrations(path)["provenance"]``) and saved with ``model.annotate``. The command
line then reads them: ``predict`` says when it is given another robot than the one learned."""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np
import pytest

import sgplvm
from _cli import ROOT, sgplvm_binary

G1 = ROOT / "data" / "urdf" / "published" / "g1_29dof.urdf"


def run(*args: str) -> subprocess.CompletedProcess:
    done = subprocess.run([str(sgplvm_binary()), *args], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    return done


@pytest.fixture(scope="module")
def g1_demos(tmp_path_factory) -> Path:
    """Twenty seconds of the shipped capture, imported and retargeted onto the G1's URDF."""
    dir = tmp_path_factory.mktemp("provenance")
    me = dir / "me.mcap"
    run("import", str(ROOT / "data" / "capture" / "cmu-13_26.bvh"), "--to", "20", "--out", str(me))
    g1 = dir / "g1.mcap"
    run("retarget", "--demos", str(me), "--urdf", str(G1), "--robot", "g1", "--out", str(g1))
    return g1


def test_a_model_fitted_in_python_records_its_person_and_robot(g1_demos, tmp_path):
    demo = sgplvm.load_demonstrations(g1_demos)
    provenance = demo["provenance"]
    assert set(provenance) == {"sgplvm.capture", "sgplvm.robots"}, provenance.keys()
    assert provenance["sgplvm.capture"][0]["file"].endswith("cmu-13_26.bvh")
    assert "calibration" in provenance["sgplvm.capture"][0]
    assert provenance["sgplvm.robots"]["g1"]["urdf_name"] == "g1_29dof_rev_1_0"

    train = demo["train"]
    g1 = demo["robots"]["g1"]
    m = sgplvm.SharedGPLVM(latent_dim=3, seed=0)
    m.fit(
        {"human": demo["human"]["positions"][train], "g1": g1["positions"][train]},
        input="human",
        max_iters=5,
        validation=None,
        column_names={"g1": g1["joint_names"]},
    )
    assert m.annotations == {}
    m.annotate(provenance)
    m.annotate({"lab.note": {"session": 3}})
    assert m.annotations == {**provenance, "lab.note": {"session": 3}}
    # Robot records join those there (as `sgplvm transfer` adds each robot it fits).
    m.annotate({"sgplvm.robots": {"g1_copy": provenance["sgplvm.robots"]["g1"]}})
    assert set(m.annotations["sgplvm.robots"]) == {"g1", "g1_copy"}
    # Kept through a transfer, a save and a pickle.
    assert sgplvm.SharedGPLVM.from_bytes(m.to_bytes()).annotations == m.annotations
    model = tmp_path / "g1.sgp"
    m.save(model)

    # The command line reads the record: the G1 it was learned on predicts without a word, a
    # revised G1 (another elbow limit, the same joint names) is said.
    human = tmp_path / "human.mcap"
    run("export", "--demos", str(g1_demos), "--body", "human", "--out", str(human))

    def predict(urdf: Path) -> str:
        return run(
            "predict", "--model", str(model), "--input", str(human), "--robot", "g1",
            "--urdf", str(urdf), "--out", str(tmp_path / "g1.csv"),
        ).stderr

    assert "another robot" not in predict(G1)
    text = G1.read_text()
    elbow = text.index('<joint name="left_elbow_joint"')
    limit = '<limit lower="-1.0472"'
    at = elbow + text[elbow:].index(limit)
    revised = tmp_path / "g1_revised.urdf"
    revised.write_text(text[:at] + '<limit lower="-0.5"' + text[at + len(limit):])
    said = predict(revised)
    assert "g1: the model's commands were learned on another robot" in said, said
    assert 'other limits on "left_elbow_joint"' in said, said


def test_what_sgplvm_reads_is_checked_when_annotated():
    rng = np.random.default_rng(0)
    h = rng.normal(size=(30, 4))
    m = sgplvm.SharedGPLVM(latent_dim=2, seed=0)
    m.fit({"human": h, "robot": h @ rng.normal(size=(4, 3))}, input="human", max_iters=2, validation=None)
    with pytest.raises(ValueError, match="annotation `sgplvm.robots`: expected robot records"):
        m.annotate({"sgplvm.robots": [1]})
    with pytest.raises(ValueError, match="annotation `sgplvm.capture`: expected capture records"):
        m.annotate({"sgplvm.capture": [{}]})  # no file, skeleton, fit: teleop could not read it
    with pytest.raises(TypeError):
        m.annotate({"lab.when": object()})  # not JSON
    assert m.annotations == {}
    with pytest.raises(ValueError):
        m.annotate({"lab.a": 1, "sgplvm.robots": 2})
    assert m.annotations == {}  # all or nothing

    parts = {"a": {"human": [0, 1], "robot": [0]}, "b": {"human": [2, 3], "robot": [1, 2]}}
    arms = sgplvm.PartsGPLVM(latent_dim=2, parts=parts, seed=0)
    arms.fit({"human": h, "robot": h @ rng.normal(size=(4, 3))}, max_iters=2, validation=None)
    arms.annotate({"lab.note": "x"})
    assert sgplvm.PartsGPLVM.from_bytes(arms.to_bytes()).annotations == {"lab.note": "x"}
