"""How many evaluations a transfer takes, over eight transfer problems (issue 18, tenth pass):
evaluations until the objective first comes within 1e-4 (relative) of the transfer's own final
objective, and in all, each transfer trained to convergence. The counts do not depend on the
machine's load, so two builds of the module compare exactly.

Problems: `bench_vs_gpy.smooth_data(300, seed)` for seeds 0-2, from a free-latent source (human
+ WALK-MAN, trained to convergence) to COMAN and from an input-back-constrained source (human +
COMAN, 300 iterations) to WALK-MAN; and the shipped data, from an input-back-constrained COMAN
model (200 iterations) to WALK-MAN and CENTAURO.

    python benches/transfer_evaluations.py [--inducing M]   # module from `maturin develop --release`

With `--inducing M` every source model is the sparse model with M inducing inputs, so the
transfers are sparse too (issue 18, eleventh pass).
"""

import argparse
from pathlib import Path

import numpy as np

import sgplvm
from bench_vs_gpy import TOL, smooth_data

SHIPPED = Path(__file__).resolve().parents[1] / "data" / "demos" / "bimanual.mcap"


def problems(inducing=None):
    """(label, source model, target robot, target data) of each problem; sparse sources with
    `inducing` inducing inputs."""
    for seed in (0, 1, 2):
        human, walkman, coman = smooth_data(300, seed=seed)
        free = sgplvm.SharedGPLVM(latent_dim=5, back_constraint=None, seed=0).fit(
            {"human": human, "walkman": walkman}, input="human", max_iters=100_000, validation=None,
            inducing=inducing)
        yield f"seed {seed}, free source → coman", free, "coman", coman
        bc = sgplvm.SharedGPLVM(latent_dim=5, seed=0).fit(
            {"human": human, "coman": coman}, input="human", max_iters=300, validation=None,
            inducing=inducing)
        yield f"seed {seed}, input-BC source → walkman", bc, "walkman", walkman
    demo = sgplvm.load_demonstrations(SHIPPED)
    train = demo["train"]
    human = demo["human"]["positions"][train]
    robots = {name: r["positions"][train] for name, r in demo["robots"].items()}
    source = sgplvm.SharedGPLVM(latent_dim=5, seed=0).fit(
        {"human": human, "coman": robots["coman"]}, input="human", max_iters=200, validation=None,
        inducing=inducing)
    for name in ("walkman", "centauro"):
        yield f"shipped, coman → {name}", source, name, robots[name]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--inducing", type=int, help="sparse models with this many inducing inputs")
    args = ap.parse_args()
    to_level, in_all = 0, 0
    print(f"{'problem':<36} {'to its final':>12} {'in all':>7}   final objective")
    for label, source, name, data in problems(args.inducing):
        h = source.transfer(name, data, max_iters=100_000, validation=None).history
        objective, evaluations = np.array(h["objective"]), np.array(h["evaluations"], dtype=int)
        final = objective[-1]
        reached = int(evaluations[np.argmax(objective <= final + TOL * abs(final))])
        to_level, in_all = to_level + reached, in_all + int(evaluations[-1])
        print(f"{label:<36} {reached:>12} {int(evaluations[-1]):>7}   {final - source.objective():.4f}")
    print(f"{'all eight':<36} {to_level:>12} {in_all:>7}")


if __name__ == "__main__":
    main()
