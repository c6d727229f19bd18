#!/usr/bin/env python3
"""sgplvm against GPy, side by side, in one run: same data, same initial point, same iteration
budget. Prints each figure for both and their ratio, and both final objectives.

    python benches/bench_vs_gpy.py            # needs `pip install .` (or maturin develop),
    python benches/bench_vs_gpy.py --quick    # GPy and threadpoolctl; --quick: fewer repetitions

Threads: sgplvm runs as a user gets it (its objective evaluates each observation space on its
own thread of rayon's pool, all cores unless RAYON_NUM_THREADS says otherwise; the same run with
RAYON_NUM_THREADS=1 gives the one-core figures). GPy is timed twice, with one BLAS thread and
with numpy's default BLAS pool (through threadpoolctl), and its *faster* time is the one
compared: OpenBLAS threads spinning on a loaded machine can make the default far slower, and a
ratio against that would flatter us.

What is compared (human 18-D + robot 14-D, Q = 5, RBF-ARD kernels, free latent points so that
GPy computes exactly the same model):
  * one objective + gradient evaluation at N = 300 and N = 1000;
  * full training (L-BFGS, the same iteration budget) from the same initial point;
  * transfer: only a new robot's kernel trained on the frozen latent points (in GPy: a GP
    regression from the fixed latent points, the same thing);
  * batch prediction of the new robot's joints from latent points.
GPy's exact inference adds 1e-8 to the diagonal; our noise is given 1e-8 more so that both
factorise the same matrix.
"""

import argparse
import os
import time

import numpy as np

import GPy
import sgplvm
from GPy.inference.latent_function_inference import ExactGaussianInference
from threadpoolctl import threadpool_info, threadpool_limits


class GPySharedGPLVM(GPy.core.Model):
    """DESIGN.md's shared GP-LVM written with GPy's own inference: one latent matrix, one RBF-ARD
    kernel and Gaussian likelihood per space, the objective summed over spaces."""

    def __init__(self, spaces, X, params):
        super().__init__("shared_gplvm")
        self.X = GPy.core.Param("latent", X.copy())
        self.link_parameter(self.X)
        self.Ys, self.kerns, self.liks = [], [], []
        for name, Y in spaces.items():
            p = params["spaces"][name]
            kern = GPy.kern.RBF(X.shape[1], variance=p["variance"], lengthscale=np.asarray(p["lengthscale"]),
                                ARD=True, name=f"rbf_{name}")
            lik = GPy.likelihoods.Gaussian(variance=p["noise"] - 1e-8, name=f"noise_{name}")
            self.link_parameters(kern, lik)
            self.Ys.append(Y - Y.mean(axis=0))
            self.kerns.append(kern)
            self.liks.append(lik)
        self.inference = ExactGaussianInference()
        self._lml = 0.0

    def parameters_changed(self):
        self._lml = 0.0
        grad_x = np.zeros_like(self.X.values)
        for Y, kern, lik in zip(self.Ys, self.kerns, self.liks):
            _, lml, grads = self.inference.inference(kern, self.X, lik, Y)
            self._lml += lml
            kern.update_gradients_full(grads["dL_dK"], self.X)
            lik.update_gradients(grads["dL_dthetaL"])
            grad_x += kern.gradients_X(grads["dL_dK"], self.X)
        self.X.gradient = grad_x

    def log_likelihood(self):
        return self._lml


def smooth_data(n, seed=0):
    """Human 18-D and two robots 14-D driven by a 3-D latent trajectory, plus noise."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 4 * np.pi, n)
    z = np.stack([np.sin(t), np.cos(0.5 * t), np.sin(1.5 * t + 1)], axis=1)
    human = np.tanh(z @ rng.normal(size=(3, 18))) + 0.02 * rng.normal(size=(n, 18))
    walkman = np.sin(z @ rng.normal(size=(3, 14))) + 0.02 * rng.normal(size=(n, 14))
    coman = 0.7 * np.sin(z @ rng.normal(size=(3, 14)) + 0.5) + 0.02 * rng.normal(size=(n, 14))
    return human, walkman, coman


def best_time(fn, repeat):
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return min(times)


def gpy_best(fn, *args):
    """GPy's faster of one BLAS thread and the default BLAS pool: (seconds, threads used)."""
    default_threads = max([p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"] or [1])
    with threadpool_limits(limits=1, user_api="blas"):
        single = fn(*args)
    pooled = fn(*args) if default_threads > 1 else float("inf")
    return (single, 1) if single <= pooled else (pooled, default_threads)


def settle():
    """Lets idle BLAS worker threads (left spinning by GPy's last numpy call) go to sleep before
    sgplvm is timed: on 2 cores a spinning OpenBLAS thread halves our second thread's share."""
    time.sleep(0.5)


def timed(fn):
    start = time.perf_counter()
    fn()
    return time.perf_counter() - start


def row(label, ours, theirs, unit="ms", scale=1e3):
    ratio = theirs / ours if ours > 0 else float("inf")
    print(f"{label:<44} {ours * scale:>11.3f} {theirs * scale:>11.3f} {unit:<3} {ratio:>8.1f}x")


def initial_model(spaces, seed=0):
    """Our model at its initial point (free latent points from PCA) and its parameters."""
    m = sgplvm.SharedGPLVM(latent_dim=5, back_constraint=None, seed=seed)
    m.fit(spaces, input="human", max_iters=0, validation=None)
    return m, m.params


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="fewer repetitions and iterations")
    parser.add_argument("--iters", type=int, default=200, help="L-BFGS iteration budget")
    args = parser.parse_args()
    repeat = 3 if args.quick else 10
    iters = 50 if args.quick else args.iters

    print(f"sgplvm {sgplvm.__version__} vs GPy {GPy.__version__}; numpy {np.__version__}; "
          f"{os.cpu_count()} cores, RAYON_NUM_THREADS={os.environ.get('RAYON_NUM_THREADS', 'unset')}")
    print("GPy: the faster of one BLAS thread and the default pool; [n] = BLAS threads of that time")
    print(f"{'':<44} {'sgplvm':>11} {'GPy':>11} {'':<3} {'GPy/ours':>9}")

    # 1. One objective + gradient evaluation.
    for n in (300, 1000):
        human, walkman, _ = smooth_data(n)
        spaces = {"human": human, "walkman": walkman}
        ours, params = initial_model(spaces)
        theirs = GPySharedGPLVM(spaces, params["latent"], params)
        rel = abs(ours.objective() - theirs.objective_function()) / abs(theirs.objective_function())
        assert rel < 1e-8, f"objectives differ by {rel:.2e} at N = {n}"
        x = theirs.optimizer_array.copy()
        reps = max(1, repeat // 3 if n == 1000 else repeat)
        t_gpy, threads = gpy_best(best_time, lambda: theirs._objective_grads(x), reps)
        settle()
        t_ours = best_time(ours.gradient, 3 * repeat)
        row(f"objective+gradient, N = {n} [{threads}]", t_ours, t_gpy)

    # 2. Full training, same initial point and iteration budget.
    n = 300
    human, walkman, coman = smooth_data(n, seed=1)
    spaces = {"human": human, "walkman": walkman}
    ours, params = initial_model(spaces, seed=1)
    settle()
    start = time.perf_counter()
    trained = sgplvm.SharedGPLVM(latent_dim=5, back_constraint=None, seed=1)
    trained.fit(spaces, input="human", max_iters=iters, validation=None)
    t_ours = time.perf_counter() - start
    fits = []

    def gpy_fit():
        model = GPySharedGPLVM(spaces, params["latent"], params)
        fits.append(model)
        return timed(lambda: model.optimize("lbfgsb", max_iters=iters, messages=False))

    t_gpy, threads = gpy_best(gpy_fit)
    theirs = fits[-1]
    row(f"full training, N = {n}, {iters} iterations [{threads}]", t_ours, t_gpy, "s", 1.0)
    print(f"{'':<4}final objective: sgplvm {trained.history['objective'][-1]:.4f} "
          f"({len(trained.history['objective']) - 1} iterations), GPy {theirs.objective_function():.4f}")

    # 3. Transfer: only a new robot's kernel, on the frozen latent points.
    settle()
    start = time.perf_counter()
    transferred = trained.transfer("coman", coman, max_iters=iters, validation=None)
    t_ours = time.perf_counter() - start
    X = trained.latent_points
    p = transferred.params["spaces"]["coman"]
    gps = []

    def gpy_transfer():
        gp = GPy.models.GPRegression(X, coman - coman.mean(axis=0), GPy.kern.RBF(5, ARD=True))
        gps.append(gp)
        return timed(lambda: gp.optimize("lbfgsb", max_iters=iters, messages=False))

    t_gpy, threads = gpy_best(gpy_transfer)
    gp = gps[-1]
    row(f"transfer (robot kernel only), N = {n} [{threads}]", t_ours, t_gpy, "s", 1.0)
    print(f"{'':<4}sgplvm transfer: {len(transferred.history['objective']) - 1} iterations, "
          f"robot kernel variance {p['variance']:.4f}; GPy: variance {float(gp.kern.variance[0]):.4f}")

    # 4. Batch prediction from human frames (ours: human → latent → robot; GPy: latent → robot).
    batch = np.repeat(human, 34, axis=0)[:10_000]
    settle()
    t_ours = best_time(lambda: transferred.predict(batch, robot="coman"), repeat)
    latent = transferred.latent(batch)
    t_gpy, threads = gpy_best(best_time, lambda: gp.predict(latent), repeat)
    row(f"batch prediction, 10,000 frames [{threads}]", t_ours, t_gpy)
    print(f"{'':<4}sgplvm: {len(batch) / t_ours:,.0f} frames/s including the human → latent step")


if __name__ == "__main__":
    main()
