"""Issue 12's table with the default training (iteration budget chosen on held-out training
frames: the last repetition of every training motion), for full and transferred input-BC models,
against a direct GP regression and against each model's own initial state.

    python docs/validated.py [file.mcap ...]     # default: the shipped data and seeds 1, 2

(seeds 1 and 2: `sgplvm generate --seed 1 --out /tmp/seed1`, `--seed 2 --out /tmp/seed2`).
Needs the Python module. Test frames are only used to report errors, never to choose.
"""

import sys
from pathlib import Path

import numpy as np

import sgplvm

FILES = ["data/demos/bimanual.mcap", "/tmp/seed1/bimanual.mcap", "/tmp/seed2/bimanual.mcap"]


def main(files):
    ratios = {"full": [], "transfer": []}
    worse = {"full": 0, "transfer": 0}
    print("| data | model | budget (it) | test MSE | ÷ direct GP | initial model | trained ≤ initial |")
    print("|---|---|---|---|---|---|---|")
    for f in files:
        d = sgplvm.load_demonstrations(f)
        tr, te, val = d["train"], d["test"], d["validation"]
        h = d["human"]["positions"]
        robots = list(d["robots"])
        r = {name: d["robots"][name]["positions"] for name in robots}
        data = Path(f).parent.name

        def mse(model, robot):
            return float(np.mean((model.predict(h[te], robot) - r[robot][te]) ** 2))

        gp = {
            name: float(
                np.mean((sgplvm.GPRegression().fit(h[tr], r[name][tr]).predict(h[te]) - r[name][te]) ** 2)
            )
            for name in robots
        }

        def row(kind, label, robot, model, initial):
            e, e0 = mse(model, robot), mse(initial, robot)
            ratios[kind].append(e / gp[robot])
            worse[kind] += e > e0
            budget = model.selection["best_iteration"]
            print(
                f"| {data} | {label} | {budget} | {e:.4f} | {e / gp[robot]:.2f}× | {e0:.4f} | "
                f"{'yes' if e <= e0 else '**no**'} |"
            )

        full = {}
        for name in robots:
            spaces = {"human": h[tr], name: r[name][tr]}
            full[name] = sgplvm.SharedGPLVM(5, "input", 0).fit(spaces, validation=val)
            initial = sgplvm.SharedGPLVM(5, "input", 0).fit(spaces, max_iters=0, validation=None)
            row("full", f"{name} full", name, full[name], initial)
        for source in robots:
            for target in robots:
                if source != target:
                    moved = full[source].transfer(target, r[target][tr], validation=val)
                    initial = full[source].transfer(target, r[target][tr], max_iters=0, validation=None)
                    row("transfer", f"{source} → {target}", target, moved, initial)
    print()
    for kind, values in ratios.items():
        v = np.array(values)
        print(
            f"{kind}: {np.sum(v <= 1.1)} of {len(v)} within 1.1× the direct GP, median {np.median(v):.2f}×, "
            f"worst {v.max():.2f}×; {worse[kind]} of {len(v)} end above their initial model's test error"
        )


if __name__ == "__main__":
    main(sys.argv[1:] or FILES)
