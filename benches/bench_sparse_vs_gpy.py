"""The sparse model (issue 14) against GPy's SparseGPLVM: one objective + gradient evaluation.

Human 18-D + robot 14-D, Q = 5, M = 100 inducing inputs, N = 20,000 frames (``--n`` to change).
Our sparse model (input back constraints with M centres, Z trained) at its starting point; GPy
gets, per space, a ``SparseGPLVM`` with the same latent points X, inducing inputs Z, kernel and
noise (its X and Z are free parameters: it computes ∂/∂X and ∂/∂Z, as we compute ∂/∂W and ∂/∂Z).
GPy's time is the sum over the two spaces. Run with one thread each, in one run:

    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 RAYON_NUM_THREADS=1 python benches/bench_sparse_vs_gpy.py

The sum of GPy's two objectives is printed beside ours: they differ only by the jitter on K_mm
(GPy: 1e-8; ours: 1e-6 × variance), the bound itself agrees to 1e-8 (crates/sgplvm-py/tests/test_sparse.py).
"""

import argparse
import os
import time

import numpy as np

import GPy
import sgplvm


def smooth_data(n):
    t = np.arange(n)[:, None] / n * 120.0
    j = np.arange(18)[None, :]
    human = np.sin(t * (1 + 0.05 * j)) + 0.3 * np.cos(0.37 * t + j)
    j = np.arange(14)[None, :]
    robot = 0.8 * np.sin(t * (1 + 0.07 * j) + 0.1) + 0.2 * np.cos(0.41 * t + j)
    return human, robot


def best_time(fn, reps):
    best = float("inf")
    for _ in range(reps):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return best


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--n", type=int, default=20_000)
    parser.add_argument("--m", type=int, default=100)
    parser.add_argument("--reps", type=int, default=5)
    args = parser.parse_args()
    human, robot = smooth_data(args.n)
    ours = sgplvm.SharedGPLVM(latent_dim=5).fit(
        {"human": human, "robot": robot}, max_iters=0, validation=None, inducing=args.m
    )
    x = ours.latent_points
    z = ours.inducing_inputs
    params = ours.params
    total_gpy = 0.0
    t_gpy = 0.0
    for name, data in (("human", human), ("robot", robot)):
        k = params["spaces"][name]
        y = data - data.mean(axis=0)
        kern = GPy.kern.RBF(5, variance=k["variance"], lengthscale=np.asarray(k["lengthscale"]), ARD=True)
        m = GPy.models.SparseGPLVM(y, 5, X=x.copy(), kernel=kern, num_inducing=args.m)
        m.Z[:] = z
        m.likelihood.variance = k["noise"]
        total_gpy += m.objective_function()
        theta = m.optimizer_array.copy()
        t_gpy += best_time(lambda: m._objective_grads(theta), args.reps)
    time.sleep(0.5)
    t_ours = best_time(ours._require().gradient, args.reps)
    print(f"sgplvm {sgplvm.__version__} vs GPy {GPy.__version__}; N = {args.n}, M = {args.m}, Q = 5; "
          f"threads: RAYON {os.environ.get('RAYON_NUM_THREADS', 'unset')}, OMP {os.environ.get('OMP_NUM_THREADS', 'unset')}")
    print(f"objective: sgplvm {ours._require().objective():.6f}, GPy (sum over spaces) {total_gpy:.6f}")
    print(f"objective+gradient: sgplvm {t_ours * 1e3:.1f} ms, GPy {t_gpy * 1e3:.1f} ms, ratio {t_gpy / t_ours:.2f}x")


if __name__ == "__main__":
    main()
