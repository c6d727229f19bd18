"""The guides' Python examples run verbatim: every ```python block of README.md and of the guides
under docs/ is executed, in a fresh namespace, from a scratch folder laid out like a clone
(``data`` links to the shipped data), so each example must define everything it uses."""

import contextlib
import io
import os
import re
from pathlib import Path

import sgplvm

REPO = Path(__file__).resolve().parents[3]


SKIP = "<!-- readme-test: skip python ("


def python_blocks(text: str) -> list[str]:
    """The ```python blocks, but those right after a ``readme-test: skip python (reason)``
    comment (one that starts Ray, for instance: Ray may only run in a loopback-only network
    namespace, where test_ray.py runs it)."""
    found = re.findall(r"^(<!--[^\n]*-->\n)?```python\n(.*?)^```", text, flags=re.S | re.M)
    for marker, _ in found:
        assert not marker.startswith("<!-- readme-test: skip") or (
            marker.startswith(SKIP) and marker.rstrip().endswith(") -->")
        ), f"a skipped python block gives no reason: {marker!r}"
    return [block for marker, block in found if not marker.startswith(SKIP)]


def test_python_blocks_are_found():
    blocks = python_blocks(
        "x\n```python\na = 1\n```\n```bash\nls\n```\n"
        "<!-- readme-test: skip python (needs Ray) -->\n```python\nc = 3\n```\n"
        "```python\nb = 2\n```\n"
    )
    assert blocks == ["a = 1\n", "b = 2\n"]


DOCUMENTS = [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]


def test_the_guides_examples_run_verbatim(tmp_path):
    blocks = [
        (path.relative_to(REPO), block)
        for path in DOCUMENTS
        for block in python_blocks(path.read_text(encoding="utf-8"))
    ]
    assert len(blocks) >= 2, "the guides have fewer than two python blocks"
    (tmp_path / "data").symlink_to(REPO / "data", target_is_directory=True)
    cwd = os.getcwd()
    os.chdir(tmp_path)
    ran = set()
    try:
        for name, block in blocks:
            namespace: dict = {"__name__": "__readme__"}
            printed = io.StringIO()
            with contextlib.redirect_stdout(printed):
                exec(compile(block, str(name), "exec"), namespace)
            ran.add(str(name))
            # The example's results are what it says they are.
            if "R_hat" in namespace:
                assert namespace["R_hat"].shape == (len(namespace["test"]), 14)
                assert isinstance(namespace["report"], dict)
                assert "joint-limit violations" in printed.getvalue()
                # The model it saved predicts what it predicted.
                saved = sgplvm.SharedGPLVM.load("coman-py.sgp")
                first = namespace["H"][namespace["test"]][:1]
                assert (saved.predict(first, robot="coman") == namespace["R_hat"][:1]).all()
            if "R_arms" in namespace:
                # A latent space per arm: both arms predicted, the file read back as its kind.
                assert namespace["R_arms"].shape == (len(namespace["test"]), 14)
                assert isinstance(sgplvm.load_model("arms-py.sgp"), sgplvm.PartsGPLVM)
            if "commands" in namespace:
                # Your capture on your robot: every frame retargeted, the arm joints.
                assert namespace["commands"].shape == (len(namespace["times_ns"]), 14)
                assert "upper-arm direction error" in printed.getvalue()
    finally:
        os.chdir(cwd)
    assert "docs/python.md" in ran, ran
