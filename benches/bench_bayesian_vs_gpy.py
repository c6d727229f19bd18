"""One evaluation of the Bayesian shared GP-LVM's bound and gradient, sgplvm against GPy's MRD
(issue 34): two spaces (18 and 14 columns), Q = 8, M = 50, at N = 300 and N = 3,000; one core
each (BLAS pinned to one thread), the same parameters, side by side in one run.

    python benches/bench_bayesian_vs_gpy.py [--repeats 5] [--sizes 300,3000]

Prints, per N, the median seconds of an evaluation of each and their ratio; the values agree
(checked before timing, as in crates/sgplvm-py/tests/test_bayesian.py).
"""
import argparse
import os

for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[var] = "1"

import time  # noqa: E402

import numpy as np  # noqa: E402
import GPy  # noqa: E402

from sgplvm import _sgplvm  # noqa: E402


def problem(n, q=8, m=50, dims=(18, 14), seed=0):
    rng = np.random.default_rng(seed)
    mean = rng.standard_normal((n, q))
    var = rng.uniform(0.05, 0.6, (n, q))
    z = rng.standard_normal((m, q))
    ys, kernels = [], []
    for d in dims:
        y = np.sin(mean @ rng.standard_normal((q, d))) + 0.1 * rng.standard_normal((n, d))
        ys.append(y - y.mean(0))
        kernels.append((float(rng.uniform(0.5, 2)), list(rng.uniform(0.7, 2.5, q)), float(rng.uniform(0.05, 0.5))))
    return mean, var, z, ys, kernels


def gpy_model(mean, var, z, ys, kernels):
    q = mean.shape[1]
    kerns = [GPy.kern.RBF(q, ARD=True, variance=v, lengthscale=np.array(l)) for v, l, _ in kernels]
    m = GPy.models.MRD(ys, q, X=mean.copy(), X_variance=var.copy(), Z=z.copy(),
                       num_inducing=len(z), kernel=kerns, normalizer=False)
    m.Z[:] = z
    for s, (_, _, noise) in enumerate(kernels):
        m.bgplvms[s].likelihood.variance = noise
    m.optimizer_array = m.optimizer_array.copy()
    return m


def median_seconds(f, repeats):
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        f()
        times.append(time.perf_counter() - t)
    return float(np.median(times))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--sizes", default="300,3000")
    args = ap.parse_args()
    print(f"GPy {GPy.__version__}, numpy {np.__version__}; two spaces (18, 14), Q = 8, M = 50, one core each")
    print(f"{'N':>6}  {'GPy MRD (s)':>12}  {'sgplvm (s)':>11}  {'ratio':>7}  {'|value diff|/|value|':>21}")
    for n in [int(s) for s in args.sizes.split(",")]:
        mean, var, z, ys, kernels = problem(n)
        model = gpy_model(mean, var, z, ys, kernels)
        x = model.optimizer_array.copy()
        jitter = model.bgplvms[0].inference_method.const_jitter
        ours = _sgplvm.bayesian_bound(mean, var, z, ys, kernels, jitter)
        diff = abs(ours["value"] - model.objective_function()) / abs(model.objective_function())
        gpy_s = median_seconds(lambda: model._objective_grads(x), args.repeats)
        our_s = median_seconds(lambda: _sgplvm.bayesian_bound(mean, var, z, ys, kernels, jitter), args.repeats)
        print(f"{n:>6}  {gpy_s:>12.4f}  {our_s:>11.5f}  {gpy_s / our_s:>6.1f}x  {diff:>21.1e}")


if __name__ == "__main__":
    main()
