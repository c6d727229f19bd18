"""Side-by-side timing of one objective+gradient evaluation in GPy, to compare with
`cargo bench -p sgplvm-core --bench model -- evaluation` (same sizes: human 18-D + robot 14-D,
Q = 5, RBF-ARD kernels, free X; one GPy GPLVM per space, as the shared model sums them).

Run: python3 benches/gpy/gpy_eval_timing.py
"""
import time

import numpy as np
import GPy


def data(n):
    t = np.arange(n) / n * 12.0
    h = np.stack([np.sin(t * (1 + 0.05 * j)) + 0.3 * np.cos(0.37 * t + j) for j in range(18)], 1)
    r = np.stack([0.8 * np.sin(t * (1 + 0.07 * j) + 0.1) + 0.2 * np.cos(0.41 * t + j) for j in range(14)], 1)
    return h - h.mean(0), r - r.mean(0)


for n in (300, 1000):
    h, r = data(n)
    x = np.random.default_rng(0).normal(size=(n, 5))
    models = [GPy.models.GPLVM(y, 5, X=x.copy(), kernel=GPy.kern.RBF(5, ARD=True)) for y in (h, r)]
    p = [m.optimizer_array.copy() for m in models]
    reps = 20 if n == 300 else 5
    t0 = time.perf_counter()
    for i in range(reps):
        for m, p0 in zip(models, p):
            p0[0] += 1e-9  # force a recomputation, like an optimiser step
            m._objective_grads(p0)
    dt = (time.perf_counter() - t0) / reps
    print(f"GPy N={n}: {dt * 1e3:.1f} ms per objective+gradient (two spaces)")
