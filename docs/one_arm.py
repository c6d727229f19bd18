"""A one-armed robot served by one shared latent space (the person's 18 joints in) and by its
arm's own latent space (`train --parts arms`: the 9 joints of the arm that drives it in). The
test frames as they are, then with the person's other arm taken from another test frame (a
shuffle, seed 0) or set to random poses within its training range: the driving arm, hence the
truth, unchanged. "Followed" is teleop's default gate (reconstruction and novelty).

    python docs/one_arm.py DEMOS.mcap ROBOT SINGLE.sgp ARMS.sgp

Needs the Python module (`pip install .` or `maturin develop`). The commands that make the
inputs are in docs/robots.md (single-arm robots).
"""

import sys

import numpy as np
import sgplvm


def main():
    demos, robot, single_path, arms_path = sys.argv[1:5]
    d = sgplvm.load_demonstrations(demos)
    H = np.asarray(d["human"]["positions"])
    names = list(d["human"]["joint_names"])
    Y = np.asarray(d["robots"][robot]["positions"])
    test, train = np.asarray(d["test"]), np.asarray(d["train"])
    single = sgplvm.load_model(single_path)
    arms = sgplvm.load_model(arms_path)
    (part_name,) = arms.part_names
    part = arms.part(part_name)
    inputs = arms.part_columns(part_name)["human"]
    other = [k for k in range(len(names)) if k not in inputs]
    rng = np.random.default_rng(0)
    lo, hi = H[train][:, other].min(axis=0), H[train][:, other].max(axis=0)
    shuffled = H[test].copy()
    shuffled[:, other] = H[test][rng.permutation(len(test))][:, other]
    random = H[test].copy()
    random[:, other] = rng.uniform(lo, hi, size=(len(test), len(other)))
    variants = {
        "test frames": H[test],
        "other arm from another test frame": shuffled,
        "other arm random within its training range": random,
    }
    print(f"{robot}: {len(train)} training, {len(test)} test frames; its arm's part {part_name}, "
          f"{len(inputs)} human joints in")
    print(f"{'':44s} test MSE (rad²): one space, the arm's; followed: one space, the arm's")
    for label, h in variants.items():
        mse = [np.mean((m.predict(h, robot) - Y[test]) ** 2) for m in (single, arms)]
        followed = [np.mean(single.trusted(h)), np.mean(part.trusted(h[:, inputs]))]
        print(f"  {label:42s} {mse[0]:.4f}  {mse[1]:.4f}    {100 * followed[0]:.1f} %  "
              f"{100 * followed[1]:.1f} %")


if __name__ == "__main__":
    main()
