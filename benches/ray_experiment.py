"""The experiment on a local Ray cluster against the serial CLI, on the same machine.

Runs `sgplvm experiment` (serial), then `sgplvm.ray.run_experiment` on a local Ray of `--cpus`
CPUs, checks that every record but the measured seconds is bit-identical, and prints wall times,
the speed-up, and Ray's overhead per task (an empty task's round trip, and what the experiment
lost against a perfect split of the serial time). Ray must only see the loopback device, so run
it as root in a network namespace of its own:

    unshare -n sh -c 'ip link set lo up && RAY_USAGE_STATS_ENABLED=0 \\
        python benches/ray_experiment.py --config paper --cli $CARGO_TARGET_DIR/release/sgplvm'
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

from loopback import refuse_unless_loopback_only


def without_seconds(value):
    if isinstance(value, dict):
        return {k: without_seconds(v) for k, v in value.items() if k != "seconds"}
    if isinstance(value, list):
        return [without_seconds(v) for v in value]
    return value


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--config", choices=["quick", "paper"], default="quick")
    parser.add_argument("--cli", required=True, help="the sgplvm binary (release)")
    parser.add_argument("--data", default=None, help="demonstrations MCAP (default: the shipped one)")
    parser.add_argument("--cpus", type=int, default=2)
    args = parser.parse_args()
    if refuse_unless_loopback_only():
        return 2
    os.environ["RAY_USAGE_STATS_ENABLED"] = "0"
    import ray

    import sgplvm
    import sgplvm.ray as sray

    load = os.getloadavg()
    work = tempfile.mkdtemp(prefix="sgplvm-ray-bench-")
    serial_out, ray_out = os.path.join(work, "serial"), os.path.join(work, "ray")
    command = [args.cli, "experiment", "--out", serial_out] + (["--quick"] if args.config == "quick" else [])
    if args.data:
        command += ["--data", args.data]
    started = time.perf_counter()
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    serial = time.perf_counter() - started
    with open(os.path.join(serial_out, "results.json")) as f:
        serial_results = json.load(f)

    ray.init(num_cpus=args.cpus, include_dashboard=False, log_to_driver=False)
    noop = ray.remote(lambda: None).options(num_cpus=1)
    ray.get([noop.remote() for _ in range(20)])  # workers started
    started = time.perf_counter()
    ray.get([noop.remote() for _ in range(400)])
    empty_task = (time.perf_counter() - started) / 400 * args.cpus

    data = sray._experiment_data(args.data)
    tasks = len(json.loads(sgplvm._sgplvm.experiment_plan(data, json.dumps(sray.experiment_config(args.config)))))
    started = time.perf_counter()
    results = sray.run_experiment(data, config=args.config, out=ray_out)
    on_ray = time.perf_counter() - started
    ray.shutdown()
    identical = without_seconds(results) == without_seconds(serial_results)
    lost = (on_ray * args.cpus - serial) / tasks
    print(f"config {args.config}: {tasks} tasks; load average at the start {load}")
    print(f"serial CLI        {serial:9.1f} s")
    print(f"Ray, {args.cpus} CPUs       {on_ray:9.1f} s   speed-up {serial / on_ray:.2f}x")
    print(f"empty Ray task    {empty_task * 1e3:9.2f} ms per task and CPU")
    print(f"lost per task     {lost * 1e3:9.1f} ms (Ray wall x CPUs - serial wall, over tasks)")
    print(f"records identical to the CLI's (seconds aside): {identical}")
    return 0 if identical else 1


if __name__ == "__main__":
    sys.exit(main())
