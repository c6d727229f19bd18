"""Is every robot joint a function of the person's pose? A GP regression from the human's 18
angles to each robot's joints, per joint: test MSE against the joint's test variance (a ratio
of 1 is no better than predicting the mean; issue 48 asks every arm joint ≤ 0.5).

    python docs/learnable.py [DEMOS.mcap]      (default data/demos/captured.mcap)

Splits of the same frames: the file's own (its train and test frames), and the four 4-second
block splits: the file's 4 s blocks (its segments), the blocks whose index is k modulo 4 for
testing (every 2nd frame), every 4th frame of the other blocks for training, k = 0 … 3 (each
block is tested once over the four). Needs the Python module (`pip install .` or `maturin
develop`).
"""

import sys

import numpy as np
import sgplvm


def block_split(d, offset=2):
    train, test = [], []
    for k, s in enumerate(d["segments"]):
        frames = np.arange(s["start"], s["end"])
        if k % 4 == offset:
            test.extend(frames[::2])
        else:
            train.extend(frames[::4])
    return np.array(train), np.array(test)


def ratios(d, train, test):
    """Per robot, per joint: (name, test MSE, test variance)."""
    h = d["human"]["positions"]
    out = {}
    for robot, body in d["robots"].items():
        y = body["positions"]
        gp = sgplvm.GPRegression(max_iters=300).fit(h[train], y[train])
        err = gp.predict(h[test]) - y[test]
        mse = np.mean(err**2, axis=0)
        var = np.var(y[test], axis=0)
        out[robot] = list(zip(body["joint_names"], mse, var))
    return out


def main():
    path = sys.argv[1] if len(sys.argv) > 1 else "data/demos/captured.mcap"
    d = sgplvm.load_demonstrations(path)
    worst_all = 0.0
    splits = {"shipped": (d["train"], d["test"])}
    splits.update({f"4 s blocks, test k = {k} mod 4": block_split(d, k) for k in range(4)})
    for name, (train, test) in splits.items():
        print(f"## {name} split: {len(train)} training, {len(test)} test frames")
        for robot, rows in ratios(d, train, test).items():
            bad = [(j, m, v) for j, m, v in rows if v > 1e-12 and m > 0.5 * v]
            r = [m / v for _, m, v in rows if v > 1e-12]
            worst = max(r) if r else 0.0
            worst_all = max(worst_all, worst)
            print(f"{robot:10s} total MSE {np.mean([m for _, m, _ in rows]):.4f} rad²; worst MSE/var {worst:.2f}; "
                  f"joints above 0.5: {', '.join(f'{j} {m:.3f}/{v:.3f}' for j, m, v in bad) or 'none'}")
    print(f"worst ratio over both splits: {worst_all:.2f}")


if __name__ == "__main__":
    main()
