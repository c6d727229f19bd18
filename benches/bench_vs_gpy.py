#!/usr/bin/env python3
"""sgplvm against GPy, side by side, in one run: same data, same model, same initial point.
Prints each figure for both and their ratio (GPy's time / ours).

    python benches/bench_vs_gpy.py            # every row (about 10 minutes on 2 cores)
    python benches/bench_vs_gpy.py --quick    # N = 300 only, fewer repetitions
    python benches/bench_vs_gpy.py --quick --transfer-only   # the transfer and prediction rows
    python benches/bench_vs_gpy.py --to-solution-only --sizes 1000 --rows free,input-whitened \\
        --ours-cap-seconds 300 --gpy-cap-seconds 600        # N = 1000 time to solution, capped
    RAYON_NUM_THREADS=1 OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1 \\
        python benches/bench_vs_gpy.py --evaluation-only   # the one-core evaluation rows

Needs the module (`pip install .` or `maturin develop --release`), GPy and threadpoolctl.

Threads: sgplvm runs as a user gets it (each observation space of an evaluation on its own
thread of rayon's pool, all cores unless RAYON_NUM_THREADS says otherwise). GPy is timed with
one BLAS thread and with numpy's default BLAS pool (threadpoolctl) and its *faster* time is the
one compared (at N = 300 one thread always wins here, and --quick times only that).

Rows (human 18-D + robot 14-D, Q = 5, RBF-ARD kernels; each row's two sides run one after the
other, so that a shared machine's load falls on both):
  * one objective + gradient, free latent points and input back constraints, N = 300 and 1000;
  * `set_params` + `gradient()` against `gradient()` alone (a user driving the model from their
    own optimiser);
  * time to solution, free latent points and input back constraints (GPy: its kernel-mapping
    back constraint, `GPy.mappings.Kernel`, started from our W and bandwidth), N = 300 and
    1000: both start from our initial point and run L-BFGS to their own convergence; each
    side's time is when its objective first came within 1e-4 (relative) of the level both
    reach (the worse of the two final objectives). GPy is stopped early once it is within
    1e-4 of our final objective (the level both reach is then ours; its later iterations
    cannot change the row, and at N = 1000 they take minutes). Our time is from the start of training
    (the history's clock); our whole `fit()` call, which also fits the human → latent map of a
    free-latent model, is printed beside it. GPy's `optimize(max_iters=k)` bounds *function
    evaluations* (scipy's maxfun), so iteration budgets do not compare: evaluations are
    printed for both (ours from the training history). The input back-constraint rows are
    ours with plain weights W (the default) and with whitened weights (`fit(...,
    whiten_back_constraint=True)`: the optimiser moves V, W = K_bc^(-1/2) V), both against the
    same GPy run (GPy keeps its plain parametrisation, its fastest; it stops once it is within
    1e-4 of the better of our two final objectives). `--gpy-cap-seconds` stops GPy after that
    many seconds: if it has not reached our final objective by then, the row is a lower bound
    ("GPy had not reached our level after X s: >= cap / our time"). `--ours-cap-seconds` bounds
    our fit() the same way (`max_seconds`; its stop reason then says time_limit);
  * transfer time to solution: only a new robot's kernel on the frozen latent points (GPy: a
    GP regression from the same latent points, started from our transfer's initial kernel);
  * batch prediction of 10,000 human frames, including the human → latent step (GPy: a GP
    regression human → latent, then latent → robot).
GPy's exact inference adds 1e-8 to the diagonal; it is given our noise minus 1e-8 so that both
factorise the same matrix, and every model's objective is checked to agree to 1e-8 before timing.
"""

import argparse
import os
import time

import numpy as np

import GPy
import sgplvm
from GPy.inference.latent_function_inference import ExactGaussianInference
from threadpoolctl import threadpool_info, threadpool_limits

TOL = 1e-4  # relative distance to the common level that counts as "reached"


class Reached(Exception):
    """Raised inside GPy's optimiser once its objective reached the level ours stopped at."""


class Capped(Exception):
    """Raised inside GPy's optimiser once its wall-clock cap (`--gpy-cap-seconds`) ran out."""


class GPySharedGPLVM(GPy.core.Model):
    """DESIGN.md's shared GP-LVM written with GPy's own inference: one latent matrix (free, or
    the kernel mapping X = k(H, H) W of the human data), one RBF-ARD kernel and Gaussian
    likelihood per space, the objective summed over spaces. Every objective evaluation is
    recorded with its time in `trace`."""

    def __init__(self, spaces, params, bc_data=None):
        super().__init__("shared_gplvm")
        self.trace, self.start, self.Ys, self.kerns, self.liks = [], None, [], [], []
        self.stop_at, self.cap = -np.inf, np.inf
        lat = params["latent"]
        if bc_data is None:
            self.mapping = None
            self.X = GPy.core.Param("latent", lat.copy())
            self.link_parameter(self.X)
            q = lat.shape[1]
        else:
            q = lat["weights"].shape[1]
            # Our back-constraint kernel exp(-|d|²/(2 bw²)): GPy's RBF, variance 1, not trained.
            self.H = bc_data
            kern = GPy.kern.RBF(bc_data.shape[1], variance=1.0, lengthscale=lat["bandwidth"])
            self.mapping = GPy.mappings.Kernel(bc_data.shape[1], q, bc_data, kern)
            self.mapping.A[:] = lat["weights"]
            self.H = bc_data
            self.link_parameter(self.mapping)
            self.X = None
        for name, Y in spaces.items():
            p = params["spaces"][name]
            kern = GPy.kern.RBF(q, variance=p["variance"], lengthscale=np.array(p["lengthscale"], dtype=float),
                                ARD=True, name=f"rbf_{name}")
            lik = GPy.likelihoods.Gaussian(variance=p["noise"] - 1e-8, name=f"noise_{name}")
            self.link_parameters(kern, lik)
            self.Ys.append(Y - Y.mean(axis=0))
            self.kerns.append(kern)
            self.liks.append(lik)
        self.inference = ExactGaussianInference()
        self._lml = 0.0

    def parameters_changed(self):
        X = self.X.values if self.mapping is None else self.mapping.f(self.H)
        self._lml = 0.0
        grad_x = np.zeros_like(X)
        for Y, kern, lik in zip(self.Ys, self.kerns, self.liks):
            _, lml, grads = self.inference.inference(kern, X, lik, Y)
            self._lml += lml
            kern.update_gradients_full(grads["dL_dK"], X)
            lik.update_gradients(grads["dL_dthetaL"])
            grad_x += kern.gradients_X(grads["dL_dK"], X)
        if self.mapping is None:
            self.X.gradient = grad_x
        else:
            # The mapping's own kernel is not a parameter of the model (the bandwidth is fixed).
            self.mapping.update_gradients(grad_x, self.H)
        if self.start is not None:
            elapsed = time.perf_counter() - self.start
            self.trace.append((elapsed, -self._lml))
            if -self._lml <= self.stop_at:
                raise Reached()
            if elapsed >= self.cap:
                raise Capped()

    def log_likelihood(self):
        return self._lml


class TracedGP(GPy.models.GPRegression):
    """GPy's GP regression recording every objective evaluation with its time."""

    def __init__(self, *args, **kwargs):
        self.trace, self.start, self.stop_at, self.cap = [], None, -np.inf, np.inf
        super().__init__(*args, **kwargs)

    def parameters_changed(self):
        super().parameters_changed()
        if self.start is not None:
            f = self.objective_function()
            self.trace.append((time.perf_counter() - self.start, f))
            if f <= self.stop_at:
                raise Reached()
            if time.perf_counter() - self.start >= self.cap:
                raise Capped()


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


def blas_threads():
    return max([p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"] or [1])


def gpy_best(fn, pooled_too=True):
    """GPy's faster of one BLAS thread and the default BLAS pool: (result, seconds, threads).
    `fn` returns (result, seconds)."""
    with threadpool_limits(limits=1, user_api="blas"):
        best = (*fn(), 1)
    default = blas_threads()
    if pooled_too and default > 1:
        pooled = fn()
        if pooled[1] < best[1]:
            best = (*pooled, default)
    return best


def settle():
    """Lets idle BLAS worker threads (left spinning by GPy's last numpy call) go to sleep before
    sgplvm is timed: on 2 cores a spinning OpenBLAS thread halves our second thread's share."""
    time.sleep(0.5)


def row(label, ours, theirs, unit="ms", scale=1e3):
    ratio = theirs / ours if ours > 0 else float("inf")
    print(f"{label:<52} {ours * scale:>10.3f} {theirs * scale:>10.3f} {unit:<3} {ratio:>7.1f}x",
          flush=True)


def initial_model(spaces, bc, seed=0):
    """Our model at its initial point (PCA latent points, W for back constraints)."""
    m = sgplvm.SharedGPLVM(latent_dim=5, back_constraint=bc, seed=seed)
    m.fit(spaces, input="human", max_iters=0, validation=None)
    return m


def gpy_model(spaces, params, bc):
    bc_data = spaces["human"] - spaces["human"].mean(axis=0) if bc else None
    return GPySharedGPLVM(spaces, params, bc_data)


def check_same(ours, theirs, what):
    rel = abs(ours - theirs) / abs(theirs)
    assert rel < 1e-8, f"{what}: objectives differ by {rel:.2e} ({ours} vs {theirs})"


def reached(trace, level):
    """First time in `trace` [(seconds, objective)] at which the objective is within TOL of
    `level` (or below it)."""
    target = level + TOL * abs(level)
    return next((t for t, f in trace if f <= target), float("inf"))


def split_by_evaluations(ours_history, gpy_trace, level):
    """Why a time-to-solution ratio is what it is: the evaluations each side needed to reach
    `level` and the time per evaluation until then. The time ratio is the product of the two
    ratios; the first depends on each optimiser's path, which rounding can change (BENCHMARKS.md,
    issue 18, twelfth pass), the second on the code's speed."""
    target = level + TOL * abs(level)
    ours = next(((e, t) for e, t, f in zip(ours_history["evaluations"], ours_history["seconds"],
                                           ours_history["objective"]) if f <= target), None)
    theirs = next(((k + 1, t) for k, (t, f) in enumerate(gpy_trace) if f <= target), None)
    if ours is None or theirs is None:
        return None
    (e_ours, t_ours), (e_gpy, t_gpy) = ours, theirs
    ms_ours, ms_gpy = 1e3 * t_ours / e_ours, 1e3 * t_gpy / e_gpy
    return (f"{'':<4}to that level: sgplvm {int(e_ours)} evaluations ({ms_ours:.2f} ms each), GPy "
            f"{e_gpy} ({ms_gpy:.2f} ms each): GPy/ours {e_gpy / e_ours:.2f}x in evaluations times "
            f"{ms_gpy / ms_ours:.2f}x per evaluation")


def evaluation_rows(sizes, repeat, pooled_too):
    for n in sizes:
        human, walkman, _ = smooth_data(n)
        spaces = {"human": human, "walkman": walkman}
        for bc in (None, "input"):
            ours = initial_model(spaces, bc)
            params = ours.params
            theirs = gpy_model(spaces, params, bc)
            check_same(ours.objective(), theirs.objective_function(), f"N = {n} {bc}")
            x = theirs.optimizer_array.copy()
            reps = max(1, repeat // 3 if n >= 1000 else repeat)
            _, t_gpy, threads = gpy_best(
                lambda: (None, best_time(lambda: theirs._objective_grads(x), reps)), pooled_too)
            settle()
            t_ours = best_time(ours.gradient, 3 * reps)
            kind = "input back constraints" if bc else "free latent points"
            row(f"objective+gradient, N = {n}, {kind} [{threads}]", t_ours, t_gpy)
            if n == 300:
                # set_params + gradient, against gradient alone (both ours).
                p = ours.params

                def step():
                    ours.set_params(p)
                    ours.gradient()

                t_step, t_grad = float("inf"), float("inf")
                for _ in range(3 * reps):  # interleaved: the same load falls on both
                    t_step = min(t_step, best_time(step, 1))
                    t_grad = min(t_grad, best_time(ours.gradient, 1))
                print(f"{'':<4}set_params + gradient {t_step * 1e3:.3f} ms, gradient alone "
                      f"{t_grad * 1e3:.3f} ms: {t_step / t_grad:.2f}x (target <= 1.3)", flush=True)


def run_gpy(model, stop_at, cap=np.inf, max_evaluations=100_000):
    """Runs GPy's L-BFGS-B on `model` to its own convergence, or until its objective is
    within TOL of `stop_at` (what it does after that cannot change the row: the level both
    reach is then at most `stop_at`'s), or until `cap` seconds have passed (then
    `model.capped` is true), or for about `max_evaluations` evaluations (scipy's maxfun).
    Returns (model, seconds)."""
    model.trace, model.stop_at, model.cap = [], stop_at + TOL * abs(stop_at), cap
    model.capped = False
    model.start = time.perf_counter()
    try:
        model.optimize("lbfgsb", max_iters=max_evaluations, messages=False)
    except Reached:
        pass
    except Capped:
        model.capped = True
    return model, time.perf_counter() - model.start


def train_ours(spaces, bc, whiten, cap):
    """Our training from the bench's start to convergence (or `cap` seconds): (model, whole
    fit() seconds)."""
    settle()
    t0 = time.perf_counter()
    ours = sgplvm.SharedGPLVM(latent_dim=5, back_constraint=bc, seed=0)
    ours.fit(spaces, input="human", max_iters=100_000, validation=None, max_seconds=cap,
             whiten_back_constraint=whiten)
    return ours, time.perf_counter() - t0


def to_solution(spaces, bc, pooled_too, whitened=(False,), ours_cap=None, gpy_cap=np.inf):
    """Time-to-solution rows for one model, one per entry of `whitened` (ours with plain or
    whitened back-constraint weights), all against one GPy run from the same start; returns
    the first of our trained models. Ours run first (their final objectives tell GPy where it
    may stop), then GPy."""
    n = len(spaces["human"])
    start = initial_model(spaces, bc)
    params = start.params
    f0 = start.objective()
    runs = [(whiten, *train_ours(spaces, bc, whiten, ours_cap)) for whiten in whitened]
    for whiten, ours, _ in runs:
        f_start = ours.history["objective"][0]
        # Whitened, X = K_bc P V rather than K_bc W: the same start up to rounding.
        assert abs(f_start - f0) <= (1e-9 if whiten else 1e-12) * abs(f0), \
            f"our training (whitened: {whiten}) did not start at the start"
    best_ours = min(ours.history["objective"][-1] for _, ours, _ in runs)

    def gpy_run():
        model = gpy_model(spaces, params, bc)
        check_same(f0, model.objective_function(), f"start, N = {n} {bc}")
        return run_gpy(model, best_ours, gpy_cap)

    theirs, t_gpy_total, threads = gpy_best(gpy_run, pooled_too)
    f_gpy = min(f for _, f in theirs.trace)
    for whiten, ours, t_fit in runs:
        h = ours.history
        ours_trace = list(zip(h["seconds"], h["objective"]))
        f_ours = h["objective"][-1]
        kind = "free latent points" if not bc else (
            "input back constraints, whitened" if whiten else "input back constraints")
        label = f"time to solution, N = {n}, {kind} [{threads}]"
        if theirs.capped and reached(theirs.trace, f_ours) == float("inf"):
            # GPy stopped by its cap short of our level: a lower bound on the ratio.
            t_ours = reached(ours_trace, f_ours)
            print(f"{label:<52} {t_ours:>10.3f} {'>' + format(t_gpy_total, '.1f'):>10} s   "
                  f"{'>=' + format(t_gpy_total / t_ours, '.1f'):>7}x  (GPy had not reached our level "
                  f"{f_ours:.4f} after {t_gpy_total:.1f} s: lower bound)", flush=True)
            # And at the level GPy had reached when it was stopped (both reached it).
            t_at = reached(ours_trace, f_gpy)
            print(f"{'':<4}at GPy's level when capped ({f_gpy:.4f}): sgplvm {t_at:.3f} s, GPy "
                  f"{reached(theirs.trace, f_gpy):.3f} s: {reached(theirs.trace, f_gpy) / t_at:.1f}x",
                  flush=True)
            level = f_gpy
        else:
            level = max(f_ours, f_gpy)
            row(label, reached(ours_trace, level), reached(theirs.trace, level), "s", 1.0)
        split = split_by_evaluations(h, theirs.trace, level)
        if split:
            print(split, flush=True)
        iters = int(h["iteration"][-1])
        evals = int(h["evaluations"][-1])
        gpy_stop = ("capped" if theirs.capped else
                    "reached our level" if f_gpy <= best_ours + TOL * abs(best_ours) else "converged")
        print(f"{'':<4}final objective: sgplvm {f_ours:.4f} ({iters} iterations, {evals} evaluations, "
              f"{evals / max(iters, 1):.2f} per iteration, stop: {ours.stop_reason}); GPy {f_gpy:.4f} "
              f"({len(theirs.trace)} evaluations, {t_gpy_total:.2f} s until it stopped: {gpy_stop}); "
              f"our whole fit() call {t_fit:.2f} s", flush=True)
    return runs[0][1]


def transfer_and_prediction(trained, human, coman, repeat, pooled_too):
    n = len(human)
    # A transfer takes ~20 ms (GPy's ~0.1 s): a thread woken late moves one run by a third, so
    # both sides get at least 15 runs and the fastest is compared.
    runs_each = max(repeat, 15)
    start = trained.transfer("coman", coman, max_iters=0, validation=None)
    p0 = start.params["spaces"]["coman"]
    X = trained.latent_points
    frozen = trained.objective()

    settle()
    # The fastest of `runs_each` calls (each one deterministic: the same iterations every time).
    transferred, t_call = None, float("inf")
    for _ in range(runs_each):
        t0 = time.perf_counter()
        candidate = trained.transfer("coman", coman, max_iters=100_000, validation=None)
        t_call = min(t_call, time.perf_counter() - t0)
        if transferred is None or candidate.history["seconds"][-1] < transferred.history["seconds"][-1]:
            transferred = candidate
    h = transferred.history
    ours_trace = [(t, f - frozen) for t, f in zip(h["seconds"], h["objective"])]

    def gpy_run():
        gp = TracedGP(X, coman - coman.mean(axis=0),
                      GPy.kern.RBF(5, variance=p0["variance"], lengthscale=np.array(p0["lengthscale"], dtype=float),
                                   ARD=True),
                      noise_var=p0["noise"] - 1e-8)
        check_same(start.objective() - frozen, gp.objective_function(), "transfer start")
        return run_gpy(gp, ours_trace[-1][1])

    # GPy too the fastest of `runs_each` runs (its runs are deterministic as well).
    runs = [gpy_best(gpy_run, pooled_too) for _ in range(runs_each)]
    level = max(ours_trace[-1][1], min(f for _, f in runs[0][0].trace))
    gp, _, threads = min(runs, key=lambda r: reached(r[0].trace, level))
    row(f"transfer time to solution, N = {n} [{threads}]", reached(ours_trace, level),
        reached(gp.trace, level), "s", 1.0)
    print(f"{'':<4}sgplvm: {int(h['iteration'][-1])} iterations, {int(h['evaluations'][-1])} "
          f"evaluations, whole transfer() call {t_call:.3f} s (fastest of {runs_each}); GPy: {len(gp.trace)} evaluations",
          flush=True)

    # Batch prediction, human frames in: ours human → latent → robot in one call; GPy a GP
    # regression human → latent (its hyperparameters do not change the cost), then the robot.
    batch = np.repeat(human, 10_000 // n + 1, axis=0)[:10_000]
    hc = human - human.mean(axis=0)
    to_latent = GPy.models.GPRegression(hc, X - X.mean(axis=0), GPy.kern.RBF(18, ARD=True))
    batch_c = batch - human.mean(axis=0)

    def gpy_predict():
        lat = to_latent.predict(batch_c)[0] + X.mean(axis=0)
        return gp.predict(lat)

    _, t_gpy, threads = gpy_best(lambda: (None, best_time(gpy_predict, repeat)), pooled_too)
    settle()
    t_ours = best_time(lambda: transferred.predict(batch, robot="coman"), repeat)
    row(f"batch prediction, 10,000 human frames [{threads}]", t_ours, t_gpy)
    print(f"{'':<4}sgplvm: {len(batch) / t_ours:,.0f} frames/s, human → latent → robot", flush=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true",
                        help="N = 300 only, GPy with one BLAS thread, fewer repetitions")
    parser.add_argument("--evaluation-only", action="store_true", help="only the evaluation rows")
    parser.add_argument("--transfer-only", action="store_true",
                        help="only the transfer and batch-prediction rows (N = 300; the source "
                             "model is our free-latent training, without GPy's time to solution)")
    parser.add_argument("--to-solution-only", action="store_true",
                        help="only the time-to-solution rows")
    parser.add_argument("--sizes", default=None,
                        help="comma-separated N of the evaluation and time-to-solution rows "
                             "(default 300,1000; 300 with --quick)")
    parser.add_argument("--rows", default="free,input,input-whitened",
                        help="time-to-solution rows: some of free, input (plain weights, the "
                             "default training), input-whitened (default: all three)")
    parser.add_argument("--gpy-cap-seconds", type=float, default=3600.0,
                        help="stop GPy's time-to-solution run after this many seconds; a row "
                             "whose level GPy had not reached is printed as a lower bound "
                             "(default 3600)")
    parser.add_argument("--ours-cap-seconds", type=float, default=None,
                        help="bound our time-to-solution fit() the same way (max_seconds; "
                             "default: none)")
    parser.add_argument("--write-bc-data", metavar="FILE",
                        help="write the bench data (N = 300, or the first of --sizes; seed "
                             "--data-seed) for the core's ignored timing tests (BC_DATA=FILE: "
                             "n, 18, 14, then the human and the walkman rows as little-endian "
                             "f64) and exit")
    parser.add_argument("--data-seed", type=int, default=1,
                        help="with --write-bc-data, the seed of smooth_data (default 1, the "
                             "bench's)")
    args = parser.parse_args()
    if args.write_bc_data:
        n = int(args.sizes.split(",")[0]) if args.sizes else 300
        human, walkman, _ = smooth_data(n, seed=args.data_seed)
        header = np.array([len(human), human.shape[1], walkman.shape[1]], dtype="<f8")
        with open(args.write_bc_data, "wb") as f:
            for part in (header, human, walkman):
                f.write(np.ascontiguousarray(part, dtype="<f8").tobytes())
        return
    repeat = 3 if args.quick else 10
    sizes = (300,) if args.quick else (300, 1000)
    if args.sizes:
        sizes = tuple(int(v) for v in args.sizes.split(","))
    rows = [r.strip() for r in args.rows.split(",") if r.strip()]
    unknown = sorted(set(rows) - {"free", "input", "input-whitened"})
    if unknown:
        parser.error(f"--rows: unknown rows {unknown}; expected some of free, input, input-whitened")
    pooled_too = not args.quick

    print(f"sgplvm {sgplvm.__version__} vs GPy {GPy.__version__}; numpy {np.__version__}; "
          f"{os.cpu_count()} cores, RAYON_NUM_THREADS={os.environ.get('RAYON_NUM_THREADS', 'unset')}, "
          f"default BLAS threads {blas_threads()}")
    print("GPy: the faster of one BLAS thread and the default pool; [n] = BLAS threads of that time")
    print(f"{'':<52} {'sgplvm':>10} {'GPy':>10} {'':<3} {'GPy/ours':>8}", flush=True)

    if args.transfer_only:
        human, walkman, coman = smooth_data(300, seed=1)
        trained = sgplvm.SharedGPLVM(latent_dim=5, back_constraint=None, seed=0)
        trained.fit({"human": human, "walkman": walkman}, input="human", max_iters=100_000,
                    validation=None)
        transfer_and_prediction(trained, human, coman, repeat, pooled_too)
        return
    if not args.to_solution_only:
        evaluation_rows(sizes, repeat, pooled_too)
    if args.evaluation_only:
        return
    caps = {"ours_cap": args.ours_cap_seconds, "gpy_cap": args.gpy_cap_seconds}
    whitened = tuple(w for w, name in ((False, "input"), (True, "input-whitened")) if name in rows)
    for n in sizes:
        human, walkman, coman = smooth_data(n, seed=1)
        spaces = {"human": human, "walkman": walkman}
        trained = to_solution(spaces, None, pooled_too, **caps) if "free" in rows else None
        if whitened:
            to_solution(spaces, "input", pooled_too, whitened, **caps)
        if n == 300 and trained is not None and not args.to_solution_only:
            transfer_and_prediction(trained, human, coman, repeat, pooled_too)


if __name__ == "__main__":
    main()
