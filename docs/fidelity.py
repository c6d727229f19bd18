"""Why does the shared GP-LVM generalise worse than a direct GP regression? Measurements.

Runs, for each demonstration file given (default: the shipped one), a validation split carved
from the *training* trajectories only (the trajectories towards every 4th key pose are held
out), then per robot:

- the yardsticks: predicting the training mean, and a direct GP regression H → R (GPy,
  RBF-ARD, centred data, 1000 L-BFGS iterations);
- the shared GP-LVM (human + that robot) with input / no back constraints, scaled or not,
  trained for 0, 5, 10, 20, 50, 100, 200, 500 iterations (training is deterministic, so a
  budget of k iterations is the state after k iterations of a longer run): validation and
  test MSE at each checkpoint, the test MSE at the validation-selected checkpoint (early
  stopping), and the final kernel hyperparameters;
- how far test frames are from the training frames (nearest neighbour, both spaces).

The test set is never used to choose anything: it is only reported.

    python docs/fidelity.py [file.mcap ...] > fidelity.txt

Needs the sgplvm module (pip install .) and GPy.
"""

from __future__ import annotations

import sys

import numpy as np

import sgplvm

CHECKPOINTS = [0, 5, 10, 20, 50, 100, 200, 500]
HELD_OUT_EVERY = 4


SPLIT = "poses"


def split(demo):
    """Fit / validation frames from the training frames only. `SPLIT = "poses"`: every training
    segment to or from every `HELD_OUT_EVERY`-th key pose (both directions, all repetitions)
    is held out; `"repetitions"`: the last repetition of every training segment is held out."""
    train = np.asarray(demo["train"])
    segments = [s for s in demo["segments"] if s["repetition"] is not None]
    if SPLIT == "poses":
        poses = sorted({s["to_pose"] for s in segments if s["to_pose"] != 0})
        held = sorted(poses[HELD_OUT_EVERY - 1 :: HELD_OUT_EVERY])
        chosen = [s for s in segments if s["to_pose"] in held or s["from_pose"] in held]
    else:
        held = [max(s["repetition"] for s in segments)]
        chosen = [s for s in segments if s["repetition"] in held]
    is_held = np.zeros(len(demo["times_ns"]), dtype=bool)
    for s in chosen:
        is_held[s["start"] : s["end"]] = True
    is_val = is_held[train]
    return train[~is_val], train[is_val], held


def mse(a, b):
    return float(np.mean((np.asarray(a) - np.asarray(b)) ** 2))


def gp_regression(h_fit, r_fit, h_eval):
    import GPy

    mu_h, mu_r = h_fit.mean(0), r_fit.mean(0)
    m = GPy.models.GPRegression(h_fit - mu_h, r_fit - mu_r, GPy.kern.RBF(h_fit.shape[1], ARD=True))
    m.optimize(max_iters=1000)
    return [m.predict(h - mu_h)[0] + mu_r for h in h_eval]


def nearest(a, b):
    d = ((a[:, None, :] - b[None, :, :]) ** 2).sum(-1)
    return np.sqrt(d.min(1))


def study(path):
    demo = sgplvm.load_demonstrations(path)
    fit_i, val_i, held = split(demo)
    test_i = np.asarray(demo["test"])
    H = demo["human"]["positions"]
    print(f"\n## {path}\n")
    print(
        f"{len(fit_i)} fit, {len(val_i)} validation (held out by {SPLIT}: {held}), "
        f"{len(test_i)} test frames\n"
    )
    dh = nearest(H[test_i], H[np.concatenate([fit_i, val_i])])
    print(f"human: test frame to nearest training frame {np.median(dh):.3f} rad median, {dh.max():.3f} max")
    for robot, body in demo["robots"].items():
        R = body["positions"]
        dr = nearest(R[test_i], R[np.concatenate([fit_i, val_i])])
        print(f"{robot}: test frame to nearest training frame {np.median(dr):.3f} rad median, {dr.max():.3f} max")
    for robot, body in demo["robots"].items():
        R = body["positions"]
        print(f"\n### {robot}\n")
        print("| model | val MSE | test MSE | note |\n|---|---|---|---|")
        mean = R[fit_i].mean(0)
        print(f"| training mean | {mse(R[val_i], mean):.4f} | {mse(R[test_i], mean):.4f} | |")
        pv, pt = gp_regression(H[fit_i], R[fit_i], [H[val_i], H[test_i]])
        print(f"| GP regression H → R (GPy) | {mse(R[val_i], pv):.4f} | {mse(R[test_i], pt):.4f} | yardstick |")
        all_i = np.sort(np.concatenate([fit_i, val_i]))
        (pa,) = gp_regression(H[all_i], R[all_i], [H[test_i]])
        print(f"| GP regression H → R (GPy), all training frames | | {mse(R[test_i], pa):.4f} | yardstick |")
        for bc, scale in [("input", False), (None, False), ("input", True)]:
            curve = []
            for k in CHECKPOINTS:
                m = sgplvm.SharedGPLVM(latent_dim=5, back_constraint=bc, seed=0, scale=scale)
                m.fit({"human": H[fit_i], robot: R[fit_i]}, input="human", max_iters=k, validation=None)
                curve.append(
                    (k, mse(R[val_i], m.predict(H[val_i], robot)), mse(R[test_i], m.predict(H[test_i], robot)), m)
                )
            best = min(curve, key=lambda c: c[1])
            name = f"GP-LVM bc={bc}{' scaled' if scale else ''}"
            path_txt = ", ".join(f"{k}: {v:.4f}/{t:.4f}" for k, v, t, _ in curve)
            print(f"| {name}, 500 iterations | {curve[-1][1]:.4f} | {curve[-1][2]:.4f} | val/test by iteration: {path_txt} |")
            print(f"| {name}, early-stopped | {best[1]:.4f} | {best[2]:.4f} | iteration {best[0]} chosen on validation |")
            again = sgplvm.SharedGPLVM(latent_dim=5, back_constraint=bc, seed=0, scale=scale)
            again.fit({"human": H[all_i], robot: R[all_i]}, input="human", max_iters=best[0], validation=None)
            print(
                f"| {name}, {best[0]} iterations on all training frames | | "
                f"{mse(R[test_i], again.predict(H[test_i], robot)):.4f} | the validated budget |"
            )
            p = curve[-1][3].params
            for space, k in p["spaces"].items():
                ls = np.asarray(k["lengthscale"])
                print(
                    f"|  · {space} kernel | | | variance {k['variance']:.3g}, noise {k['noise']:.3g} "
                    f"(noise/variance {k['noise'] / k['variance']:.2g}), lengthscales {np.round(ls, 2).tolist()} |"
                )
            if isinstance(p["latent"], dict):
                w = np.asarray(p["latent"]["weights"])
                print(f"|  · back constraint | | | bandwidth {p['latent']['bandwidth']:.3g}, |W| max {np.abs(w).max():.3g} |")


def ridge_study(path, lambdas=(0.0, 0.1, 1.0, 10.0), iters=300, bandwidths=(1.0,)):
    """A Gaussian prior on the back-constraint weights and other bandwidths: minimise
    NLL + λ/2 ‖W‖² with scipy's L-BFGS through the model's objective/gradient/set_params
    (log-transformed kernel parameters) at the median-rule bandwidth times each factor in
    `bandwidths` (W starts at (K_bc + 10⁻³ I)⁻¹ X_init for that bandwidth). λ = 0 and factor 1
    is the plain model."""
    demo = sgplvm.load_demonstrations(path)
    fit_i, val_i, _ = split(demo)
    test_i = np.asarray(demo["test"])
    H = demo["human"]["positions"]
    print(f"\n## Prior on W and bandwidth, {path} ({iters} L-BFGS iterations, scipy)\n")
    print("| robot | bandwidth × | λ | val MSE | test MSE | max abs(W) |\n|---|---|---|---|---|---|")
    hc = H[fit_i] - H[fit_i].mean(0)
    d2 = ((hc[:, None, :] - hc[None, :, :]) ** 2).sum(-1)
    for robot, body in demo["robots"].items():
        R = body["positions"]
        spaces = {"human": H[fit_i], robot: R[fit_i]}
        start = sgplvm.SharedGPLVM(latent_dim=5, back_constraint="input", seed=0)
        start.fit(spaces, input="human", max_iters=0, validation=None)
        p0 = start.params
        for factor in bandwidths:
            bw = p0["latent"]["bandwidth"] * factor
            k_bc = np.exp(-d2 / (2 * bw * bw))
            w0 = np.linalg.solve(k_bc + 1e-3 * np.eye(len(hc)), start.latent_points)
            for lam in lambdas:
                model = sgplvm.SharedGPLVM(latent_dim=5, back_constraint="input", seed=0)
                model.fit(spaces, input="human", max_iters=0, validation=None)
                w = train_with_prior(model, p0, w0, bw, lam, iters)
                print(
                    f"| {robot} | {factor:g} | {lam:g} | {mse(R[val_i], model.predict(H[val_i], robot)):.4f} | "
                    f"{mse(R[test_i], model.predict(H[test_i], robot)):.4f} | {np.abs(w).max():.3g} |"
                )


def train_with_prior(model, p0, w0, bw, lam, iters):
    """Trains `model` from weights `w0` and the kernels of `p0` at bandwidth `bw`, minimising
    NLL + λ/2 ‖W‖²; leaves the optimum in the model and returns its W."""
    from scipy.optimize import minimize

    names = list(p0["spaces"])

    def unpack(theta):
        w = theta[: w0.size].reshape(w0.shape)
        spaces, off = {}, w0.size
        for n in names:
            q = len(p0["spaces"][n]["lengthscale"])
            t = np.exp(theta[off : off + q + 2])
            spaces[n] = {"variance": t[0], "lengthscale": t[1 : q + 1], "noise": t[q + 1]}
            off += q + 2
        return {"latent": {"weights": w, "bandwidth": bw}, "spaces": spaces}

    def f(theta):
        p = unpack(theta)
        try:
            model.set_params(p)
        except ValueError:
            return 1e30, np.zeros_like(theta)
        g = model.gradient()
        w = p["latent"]["weights"]
        grad = [np.asarray(g["latent"]["weights"]).ravel() + lam * w.ravel()]
        for n in names:
            k, gk = p["spaces"][n], g["spaces"][n]
            grad.append(
                np.r_[
                    gk["variance"] * k["variance"],
                    np.asarray(gk["lengthscale"]) * k["lengthscale"],
                    gk["noise"] * k["noise"],
                ]
            )
        return model.objective() + 0.5 * lam * float((w**2).sum()), np.concatenate(grad)

    theta0 = [w0.ravel()]
    for n in names:
        k = p0["spaces"][n]
        theta0.append(np.log(np.r_[k["variance"], k["lengthscale"], k["noise"]]))
    res = minimize(f, np.concatenate(theta0), jac=True, method="L-BFGS-B", options={"maxiter": iters})
    best = unpack(res.x)
    model.set_params(best)
    return best["latent"]["weights"]


if __name__ == "__main__":
    args = sys.argv[1:]
    if args[:1] == ["--split-repetitions"]:
        SPLIT, args = "repetitions", args[1:]
    if args[:1] == ["--ridge"]:
        for path in args[1:] or ["data/demos/bimanual.mcap"]:
            ridge_study(path)
    elif args[:1] == ["--bandwidth"]:
        for path in args[1:] or ["data/demos/bimanual.mcap"]:
            ridge_study(path, lambdas=(0.0,), bandwidths=(0.125, 0.25, 0.5, 1.0))
    else:
        for path in args or ["data/demos/bimanual.mcap"]:
            study(path)
