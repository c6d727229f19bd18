"""sgplvm.ray on a real local Ray cluster of two nodes (one CPU each), against the serial code.

Ray binds to every interface and advertises the machine's address, so these tests only start it
inside a network namespace that has nothing but the loopback device: `.ci/run` runs this file
under ``unshare -n sh -c 'ip link set lo up && ...'``. Anywhere else the module is skipped (a
failure with ``CI=true``, see conftest.py); run it by hand as root with::

    unshare -n sh -c 'ip link set lo up && RAY_USAGE_STATS_ENABLED=0 \\
        python -m pytest crates/sgplvm-py/tests/test_ray.py -q'
"""

import json
import os
import signal
import threading
import time

import numpy as np
import pytest

ray = pytest.importorskip("ray")

import sgplvm  # noqa: E402
import sgplvm.ray as sray  # noqa: E402

def _interfaces() -> list:
    """Network devices of this process's namespace (/proc/net/dev is per namespace; /sys/class/net
    shows the namespace sysfs was mounted in)."""
    with open("/proc/net/dev") as f:
        return sorted(line.split(":")[0].strip() for line in f.readlines()[2:])


if _interfaces() != ["lo"]:
    pytest.skip(
        f"network interfaces {_interfaces()}: Ray tests run only in a loopback-only network namespace "
        "(unshare -n sh -c 'ip link set lo up && python -m pytest .../test_ray.py')",
        allow_module_level=True,
    )

# The quick protocol (`sgplvm experiment --quick`): 145 trainings of every kind (direct
# regressions, baselines, transfers from their source's object reference, multi-robot, less data
# from the input-BC sources).
CONFIG = "quick"


def _loopback_only() -> None:
    assert _interfaces() == ["lo"]


@pytest.fixture(scope="module")
def cluster():
    """Two Ray nodes of one CPU each, on 127.0.0.1 only."""
    from ray.cluster_utils import Cluster

    _loopback_only()
    os.environ["RAY_USAGE_STATS_ENABLED"] = "0"
    c = Cluster(initialize_head=True, head_node_args={"num_cpus": 1, "include_dashboard": False})
    c.add_node(num_cpus=1)
    ray.init(address=c.address, log_to_driver=False)
    try:
        assert ray.cluster_resources().get("CPU") == 2
        assert all(n["NodeManagerAddress"] == "127.0.0.1" for n in ray.nodes())
        yield c
    finally:
        ray.shutdown()
        c.shutdown()


def _without_seconds(value):
    """Results with the measured seconds (wall-clock, different in every run) taken out."""
    if isinstance(value, dict):
        return {k: _without_seconds(v) for k, v in value.items() if k != "seconds"}
    if isinstance(value, list):
        return [_without_seconds(v) for v in value]
    return value


@pytest.fixture(scope="module")
def serial(tmp_path_factory):
    out = tmp_path_factory.mktemp("serial")
    return sray.run_experiment_serial(config=CONFIG, out=out), out


def _assert_same_results(ray_results, serial_results):
    assert ray_results["config"] == serial_results["config"]
    # Every record, bit for bit (floats compared exactly), in the same order.
    assert _without_seconds(ray_results) == _without_seconds(serial_results)
    assert len(ray_results["runs"]) == len(serial_results["runs"]) > 0
    assert len(ray_results["less_data"]) > 0 and len(ray_results["direct_regression"]) > 0


def _assert_same_files(ray_out, serial_out):
    ray_files = sorted(os.listdir(ray_out))
    assert ray_files == sorted(os.listdir(serial_out))
    assert "results.json" in ray_files and "report.md" in ray_files
    assert not [f for f in ray_files if f.startswith(".")], "a temporary file was left behind"
    with open(os.path.join(ray_out, "results.json")) as f:
        on_disk = json.load(f)
    with open(os.path.join(serial_out, "results.json")) as f:
        assert _without_seconds(on_disk) == _without_seconds(json.load(f))


def test_experiment_on_two_nodes_equals_the_serial_run(cluster, serial, tmp_path):
    serial_results, serial_out = serial
    seen = []
    results = sray.run_experiment(config=CONFIG, out=tmp_path, progress=lambda d, n, what: seen.append((d, n)))
    _assert_same_results(results, serial_results)
    _assert_same_files(tmp_path, serial_out)
    total = len(json.loads(sgplvm._sgplvm.experiment_plan(sray._experiment_data(None), json.dumps(sray.experiment_config(CONFIG)))))
    assert seen[-1] == (total, total) and len(seen) == total


def _descendants_running(name: str):
    """Pids of this process's descendants whose title is ``ray::name`` (a worker executing it)."""
    me = os.getpid()
    found = []
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            with open(f"/proc/{pid}/cmdline", "rb") as f:
                title = f.read().split(b"\0")[0].decode(errors="replace")
            if not title.startswith(f"ray::{name}"):
                continue
            p = int(pid)
            while p > 1:  # only our own cluster's workers, never another process's
                with open(f"/proc/{p}/stat") as f:
                    p = int(f.read().rsplit(")", 1)[1].split()[1])
                if p == me:
                    found.append(int(pid))
                    break
        except (OSError, ValueError, IndexError):
            continue
    return found


def test_a_worker_killed_mid_task_is_retried_and_results_are_complete(cluster, serial, tmp_path):
    serial_results, serial_out = serial
    out = tmp_path / "out"
    killed = []
    written_at_kill = []

    def killer():
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and not killed:
            pids = _descendants_running("_execute")
            if pids:
                time.sleep(0.3)  # in the middle of a training
                try:
                    os.kill(pids[0], signal.SIGKILL)
                    killed.append(pids[0])
                    written_at_kill.append(sorted(os.listdir(out)) if out.exists() else [])
                except ProcessLookupError:
                    continue
            time.sleep(0.05)

    thread = threading.Thread(target=killer)
    thread.start()
    try:
        results = sray.run_experiment(config=CONFIG, out=out)
    finally:
        thread.join()
    assert killed, "no worker was caught executing a task"
    assert written_at_kill == [[]], "outputs were written before every task had finished"
    _assert_same_results(results, serial_results)
    _assert_same_files(out, serial_out)


def _toy(seed: int, n: int = 45):
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 3.0, n)[:, None]
    human = np.hstack([np.sin(t + k) for k in range(4)]) + 0.01 * rng.standard_normal((n, 4))
    robot = np.hstack([np.cos(t + 0.5 * k) for k in range(3)])
    return human, robot


def _assert_same_params(a, b, path="params"):
    if isinstance(a, dict):
        assert sorted(a) == sorted(b), path
        for k in a:
            _assert_same_params(a[k], b[k], f"{path}.{k}")
    else:
        assert np.array_equal(np.asarray(a), np.asarray(b)), path


def _assert_same_model(a, b, human, robot):
    _assert_same_params(a.params, b.params)
    assert a.selection == {**b.selection, "seconds": a.selection["seconds"]} if b.selection else a.selection is None
    assert np.array_equal(a.predict(human, robot=robot), b.predict(human, robot=robot))


def test_transfer_fleet_over_20_variants_equals_serial_transfers(cluster):
    human, robot = _toy(0)
    model = sgplvm.SharedGPLVM(latent_dim=2, seed=0).fit({"human": human, "r": robot}, max_iters=20, validation=None)
    rng = np.random.default_rng(1)
    fleet = {f"variant{k:02d}": robot * (1 + 0.05 * k) + 0.01 * rng.standard_normal(robot.shape) for k in range(20)}
    transferred = sray.transfer_fleet(model, fleet, max_iters=15)
    assert list(transferred) == list(fleet)
    for name, data in fleet.items():
        expected = model.transfer(name, data, max_iters=15)
        # Bit for bit: parameters and predictions (the model bytes also hold training seconds).
        _assert_same_model(transferred[name], expected, human, name)


def test_a_task_computes_on_as_many_threads_as_cpus_ray_gave_it(cluster):
    def pool_threads_after_a_fit(human, robot):
        """Sizes the pool as a task does and trains a model whose two spaces are evaluated on
        the pool (64 rows or more: a transfer's one space, or fewer rows, stay on the calling
        thread and would start no pool), then counts this worker's numeric pool threads
        (defined here so that Ray sends it by value: workers cannot import this test file)."""
        sray._use_cpus()
        sgplvm.SharedGPLVM(latent_dim=2).fit({"human": human, "r": robot}, max_iters=3, validation=None)
        names = []
        for tid in os.listdir("/proc/self/task"):
            with open(f"/proc/self/task/{tid}/comm") as f:
                names.append(f.read().strip())
        return sum(1 for n in names if n.startswith("sgplvm-"))

    human, robot = _toy(3, n=90)
    remote = ray.remote(num_cpus=1)(pool_threads_after_a_fit)
    counts = ray.get([remote.remote(human, robot) for _ in range(4)])
    assert counts == [1, 1, 1, 1]


def test_a_sweep_rejects_unknown_parameters_before_starting_anything(cluster):
    human, robot = _toy(2)
    with pytest.raises(ValueError, match="bandwidth"):
        sray.sweep({"human": human, "r": robot}, {"latent_dim": [1], "bandwidth": [0.5]})


def test_sweep_scores_on_held_out_training_rows_and_returns_the_best(cluster):
    human, robot = _toy(2)
    grid = {"latent_dim": [1, 2], "back_constraint": ["input", None]}
    table, best = sray.sweep({"human": human, "r": robot}, grid, max_iters=20)
    assert len(table) == 4
    scores = [row["validation_mse"] for row in table]
    assert scores == sorted(scores) and all(np.isfinite(scores))
    # The best model is the one the serial fit of the best point gives, and its score is the
    # held-out error of that fit's selection run.
    top = table[0]
    serial = sgplvm.SharedGPLVM(latent_dim=top["latent_dim"], back_constraint=top["back_constraint"]).fit(
        {"human": human, "r": robot}, max_iters=20
    )
    _assert_same_model(best, serial, human, "r")
    curve = {r["iteration"]: r["validation_mse"] for r in serial.selection["curve"]}
    assert top["validation_mse"] == curve[serial.selection["best_iteration"]]


# ---------------------------------------------------------------------------------- Ray Tune

TUNE_ITERS, TUNE_PATIENCE = 40, 8


def test_a_tune_asha_search_stops_poor_trials_and_its_best_equals_a_serial_fit(cluster, tmp_path):
    tune = pytest.importorskip("ray.tune", reason='Ray Tune is not installed (pip install "sgplvm[tune]")')
    from ray.tune.schedulers import ASHAScheduler

    human, robot = _toy(5)
    data = {"human": human, "r": robot}
    grid = {"latent_dim": [1, 2], "back_constraint": ["input", None]}
    serial = {
        (q, bc): sgplvm.SharedGPLVM(latent_dim=q, back_constraint=bc).fit(
            data, max_iters=TUNE_ITERS, patience=TUNE_PATIENCE
        )
        for q in grid["latent_dim"]
        for bc in grid["back_constraint"]
    }
    tuner = tune.Tuner(
        sray.tune_trainable(data, max_iters=TUNE_ITERS, patience=TUNE_PATIENCE),
        param_space={k: tune.grid_search(v) for k, v in grid.items()},
        tune_config=tune.TuneConfig(
            metric="validation_mse",
            mode="min",
            scheduler=ASHAScheduler(grace_period=1, reduction_factor=2, max_t=10 * TUNE_ITERS),
            # One trial at a time: ASHA's decisions then depend only on the (deterministic)
            # reported values, not on which trial reached a rung first.
            max_concurrent_trials=1,
            # A stopped trial's actor runs the next one: its training must end when stopped.
            reuse_actors=True,
        ),
        run_config=tune.RunConfig(storage_path=str(tmp_path), name="asha", verbose=0),
    )
    results = tuner.fit()
    assert results.num_errors == 0 and len(results) == 4
    finished, stopped = [], []
    for result in results:
        key = (result.config["latent_dim"], result.config["back_constraint"])
        curve = serial[key].selection["curve"]
        reports = result.metrics_dataframe
        # A trial stopped by ASHA never reported `done_training` (no such column).
        final = reports["done_training"] if "done_training" in reports else None
        heard = reports if final is None else reports[final.isna()]
        # Every iteration of the selection run was reported, in order, with its held-out error
        # (the CSV keeps 15+ digits: compared to rounding; the final metrics below exactly).
        assert list(heard["iteration"]) == [r["iteration"] for r in curve[: len(heard)]]
        np.testing.assert_allclose(
            heard["validation_mse"], [r["validation_mse"] for r in curve[: len(heard)]], rtol=1e-12
        )
        print(key, "reports", len(reports), "curve", len(curve))
        if result.metrics.get("done_training"):
            assert len(heard) == len(curve) == len(reports) - 1, key
            assert result.checkpoint is not None
            finished.append(result)
        else:
            assert len(heard) < len(curve), f"{key}: not finished, yet every iteration was reported"
            assert result.checkpoint is None
            stopped.append(result)
    assert stopped, "ASHA stopped no trial: nothing was tested of early stopping"
    assert finished, "ASHA stopped every trial"
    best = min(finished, key=lambda r: r.metrics["best_validation_mse"])
    key = (best.config["latent_dim"], best.config["back_constraint"])
    expected = serial[key]
    sel = expected.selection
    score = next(r["validation_mse"] for r in sel["curve"] if r["iteration"] == sel["best_iteration"])
    assert best.metrics["best_validation_mse"] == score
    assert best.metrics["best_iteration"] == sel["best_iteration"]
    _assert_same_model(sray.tune_model(best.checkpoint), expected, human, "r")
