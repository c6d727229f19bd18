"""The conftest hook that makes a skip a failure when ``CI=true`` (and only then)."""

from pathlib import Path

import pytest

pytest_plugins = ["pytester"]

CONFTEST = (Path(__file__).resolve().parent / "conftest.py").read_text()

INNER = """
import pytest

missing = pytest.importorskip("no_such_reference_package_xyz")

def test_uses_it():
    pass
"""

INNER_IN_TEST = """
import pytest

def test_reference():
    pytest.importorskip("no_such_reference_package_xyz")

def test_plain():
    pass

@pytest.mark.xfail(reason="known")
def test_known_failure():
    assert False
"""


@pytest.mark.parametrize("ci", ["true", "false", None])
def test_a_skip_fails_only_in_ci(pytester, monkeypatch, ci):
    if ci is None:
        monkeypatch.delenv("CI", raising=False)
    else:
        monkeypatch.setenv("CI", ci)
    pytester.makeconftest(CONFTEST)
    # A skip inside a test: a failure in CI; plain tests and xfails are left alone.
    pytester.makepyfile(test_in_test_skip=INNER_IN_TEST)
    result = pytester.runpytest("-p", "no:cacheprovider")
    outcomes = result.parseoutcomes()
    assert outcomes.get("passed", 0) == 1 and outcomes.get("xfailed", 0) == 1, outcomes
    if ci == "true":
        assert outcomes.get("failed", 0) == 1 and outcomes.get("skipped", 0) == 0, outcomes
        result.stdout.fnmatch_lines(["*CI=true*no_such_reference_package_xyz*"])
    else:
        assert outcomes.get("skipped", 0) == 1 and outcomes.get("failed", 0) == 0, outcomes
    # A module skipped at import (module-level importorskip): a collection error in CI.
    pytester.makepyfile(test_module_skip=INNER)
    result = pytester.runpytest("-p", "no:cacheprovider", "test_module_skip.py")
    outcomes = result.parseoutcomes()
    if ci == "true":
        assert outcomes.get("errors", 0) == 1 and outcomes.get("skipped", 0) == 0, outcomes
        assert result.ret != 0
        result.stdout.fnmatch_lines(["*CI=true*no_such_reference_package_xyz*"])
    else:
        assert outcomes.get("skipped", 0) == 1, outcomes
        assert result.ret == pytest.ExitCode.NO_TESTS_COLLECTED  # nothing else in that run
