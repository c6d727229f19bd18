"""The ``sgplvm`` command-line program the Python tests drive."""

import os
import pathlib

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[3]


def sgplvm_binary():
    """The CLI built by ``cargo test --release`` / ``cargo build --release`` (CI builds it first);
    ``SGPLVM_BIN`` names another."""
    if os.environ.get("SGPLVM_BIN"):
        return pathlib.Path(os.environ["SGPLVM_BIN"])
    target = pathlib.Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))
    path = target / "release" / "sgplvm"
    if not path.exists():
        pytest.skip(f"{path} is not built (cargo build --release)")
    return path
