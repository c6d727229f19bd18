"""Cost of predict's Foxglove scene against its joint commands alone (issue 16): the fastest of
RUNS interleaved runs of `sgplvm predict --out x.mcap` with `--no-tf`, `--no-tf --std` and the
default scene, CPU time of the process (getrusage) and elapsed time, each with its ratio to the
two baselines. With `--before BINARY`, that binary's scene runs interleaved too.

Run from the repository root after `cargo build --release`:

    python benches/scene_cost.py --runs 21 [--binary target/release/sgplvm] [--before OLD]

The model (`sgplvm train --robot coman --max-iters 100` on the shipped data) is trained once
into the output directory (default: a temporary one)."""

import argparse
import os
import pathlib
import resource
import subprocess
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
DATA = ROOT / "data" / "demos" / "bimanual.mcap"


def timed(cmd):
    """CPU and elapsed seconds of one run of `cmd`."""
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    subprocess.run(cmd, check=True, capture_output=True)
    elapsed = time.perf_counter() - t
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime), elapsed


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=21)
    target = pathlib.Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))
    ap.add_argument("--binary", default=str(target / "release" / "sgplvm"))
    ap.add_argument("--before", help="another sgplvm binary whose scene runs interleaved")
    ap.add_argument("--out", help="directory for the model and the outputs")
    args = ap.parse_args()
    out = pathlib.Path(args.out or tempfile.mkdtemp(prefix="sgplvm-scene-cost-"))
    out.mkdir(parents=True, exist_ok=True)
    model = out / "coman.sgp"
    if not model.exists():
        subprocess.run([args.binary, "train", "--data", str(DATA), "--robot", "coman",
                        "--max-iters", "100", "--out", str(model)], check=True, capture_output=True)
    predict = ["predict", "--model", str(model), "--input", str(DATA), "--robot", "coman"]
    rows = {
        "--no-tf": [args.binary, *predict, "--out", str(out / "no-tf.mcap"), "--no-tf"],
        "--no-tf --std": [args.binary, *predict, "--out", str(out / "std.mcap"), "--no-tf",
                          "--std"],
        "scene": [args.binary, *predict, "--out", str(out / "scene.mcap")],
    }
    if args.before:
        rows["scene, --before"] = [args.before, *predict, "--out", str(out / "before.mcap")]
    best = {k: (float("inf"), float("inf")) for k in rows}
    for _ in range(args.runs):
        for k, cmd in rows.items():
            cpu, elapsed = timed(cmd)
            best[k] = (min(best[k][0], cpu), min(best[k][1], elapsed))
    print(f"load average after: {os.getloadavg()[0]:.2f}")
    base, std = best["--no-tf"], best["--no-tf --std"]
    for k, cmd in rows.items():
        cpu, el = best[k]
        size = pathlib.Path(cmd[cmd.index("--out") + 1]).stat().st_size / 1e6
        print(f"{k:16s} cpu {cpu * 1e3:6.1f} ms  elapsed {el * 1e3:6.1f} ms  {size:5.2f} MB  "
              f"| /--no-tf {cpu / base[0]:.2f}x cpu {el / base[1]:.2f}x elapsed  "
              f"| /--std {cpu / std[0]:.2f}x cpu {el / std[1]:.2f}x elapsed")


if __name__ == "__main__":
    main()
