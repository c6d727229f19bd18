"""Ray Tune over sgplvm models (`sgplvm.ray.tune_trainable`): what a trial costs beyond its training.

Fits the same grid of configs (latent_dim × back_constraint, the shipped demonstrations' training
rows, walkman, validation = the last repetition) four ways, every training on one thread:

* serially in this process (`SharedGPLVM.fit`, the reference);
* Tune, FIFO, reporting every selection iteration (`report_every=1`);
* Tune, FIFO, reporting only iteration 0 and the end (`report_every` larger than any run);
* Tune with ASHA (`grace_period=2`), reporting every iteration: what early stopping saves;

all with `reuse_actors=True`, and once more with a new actor per trial (`reuse_actors=False`).

and prints wall times, the overhead per trial ((Tune wall × CPUs − serial wall) / trials) and per
report. Ray must only see the loopback device, so run it as root in a network namespace of its own:

    unshare -n sh -c 'ip link set lo up && RAY_USAGE_STATS_ENABLED=0 python benches/ray_tune.py'
"""

import argparse
import os
import sys
import tempfile
import time

from loopback import refuse_unless_loopback_only


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--cpus", type=int, default=2)
    parser.add_argument("--max-iters", type=int, default=300)
    args = parser.parse_args()
    if refuse_unless_loopback_only():
        return 2
    os.environ["RAY_USAGE_STATS_ENABLED"] = "0"
    os.environ["RAYON_NUM_THREADS"] = "1"  # the serial reference on one thread, as a trial
    import ray
    from ray import tune
    from ray.tune.schedulers import ASHAScheduler, FIFOScheduler

    import sgplvm
    import sgplvm.ray as sray

    demo = sgplvm.load_demonstrations(os.path.join(os.path.dirname(__file__), "..", "data", "demos", "bimanual.mcap"))
    train = demo["train"]
    data = {"human": demo["human"]["positions"][train], "walkman": demo["robots"]["walkman"]["positions"][train]}
    validation = list(demo["validation"])
    grid = {"latent_dim": [2, 3, 5, 8], "back_constraint": ["input", None]}
    configs = [(q, bc) for q in grid["latent_dim"] for bc in grid["back_constraint"]]
    load = os.getloadavg()

    started = time.perf_counter()
    iterations = 0
    for q, bc in configs:
        m = sgplvm.SharedGPLVM(q, bc).fit(data, max_iters=args.max_iters, validation=validation)
        iterations += len(m.selection["curve"])
    serial = time.perf_counter() - started

    ray.init(num_cpus=args.cpus, include_dashboard=False, log_to_driver=False)
    storage = tempfile.mkdtemp(prefix="sgplvm-tune-bench-")

    def run(name, scheduler, report_every, reuse_actors=True):
        tuner = tune.Tuner(
            sray.tune_trainable(data, max_iters=args.max_iters, validation=validation, report_every=report_every),
            param_space={k: tune.grid_search(v) for k, v in grid.items()},
            tune_config=tune.TuneConfig(
                metric="validation_mse", mode="min", scheduler=scheduler, reuse_actors=reuse_actors
            ),
            run_config=tune.RunConfig(storage_path=storage, name=name, verbose=0),
        )
        t0 = time.perf_counter()
        results = tuner.fit()
        wall = time.perf_counter() - t0
        assert results.num_errors == 0
        reports = sum(len(r.metrics_dataframe) for r in results)
        finished = sum(1 for r in results if r.metrics.get("done_training"))
        return wall, reports, finished

    every = run("every", FIFOScheduler(), 1)
    fresh = run("fresh", FIFOScheduler(), 1, reuse_actors=False)
    ends = run("ends", FIFOScheduler(), 10**9)
    asha = run("asha", ASHAScheduler(grace_period=2, max_t=10 * args.max_iters), 1)
    ray.shutdown()

    n = len(configs)
    print(f"load average at start {load[0]:.2f}; {n} trials, {args.cpus} CPUs; serial selection iterations {iterations}")
    print(f"serial (one thread, in process): {serial:.1f} s")
    runs = [
        ("FIFO, every iteration", every),
        ("FIFO, every iteration, a new actor per trial (reuse_actors=False)", fresh),
        ("FIFO, first+last", ends),
        ("ASHA, every iteration", asha),
    ]
    for name, (wall, reports, finished) in runs:
        lost = (wall * args.cpus - serial) / n
        print(f"{name}: {wall:.1f} s, {reports} reports, {finished}/{n} finished; lost per trial {lost * 1000:.0f} ms")
    per_report = (every[0] - ends[0]) * args.cpus / max(1, every[1] - ends[1])
    print(f"per report: {per_report * 1000:.2f} ms (FIFO every vs first+last, × CPUs / extra reports)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
