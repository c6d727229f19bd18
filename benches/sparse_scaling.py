"""One sparse objective + gradient per (N, M), one thread, best of 2: the scaling table of the sparse model in BENCHMARKS.md (issue 14). Run: RAYON_NUM_THREADS=1 python benches/sparse_scaling.py"""
import time, numpy as np, sgplvm
def data(n):
    t = np.arange(n)[:, None] / n * 120.0
    j = np.arange(18)[None, :]
    h = np.sin(t * (1 + 0.05 * j)) + 0.3 * np.cos(0.37 * t + j)
    j = np.arange(14)[None, :]
    r = 0.8 * np.sin(t * (1 + 0.07 * j) + 0.1) + 0.2 * np.cos(0.41 * t + j)
    return h, r
print("N M seconds")
for n in (1000, 5000, 20000, 100000):
    h, r = data(n)
    for m in (50, 100, 200):
        mod = sgplvm.SharedGPLVM(latent_dim=5).fit({"human": h, "robot": r}, max_iters=0, validation=None, inducing=m)
        nat = mod._require()
        best = 1e9
        for _ in range(2):
            s = time.perf_counter(); nat.gradient(); best = min(best, time.perf_counter() - s)
        print(n, m, f"{best:.4f}", flush=True)
