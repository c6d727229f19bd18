"""Our L-BFGS against scipy's L-BFGS-B on *our* objective (issue 18): the same model, data and
start as `bench_vs_gpy.py`'s time-to-solution rows (free latent points), the same
parametrisation as our optimiser (latent points as they are, kernel variance, lengthscales and
noise by their logarithms; `--transform softplus` gives scipy GPy's instead), scipy's defaults
(m = 10, ftol 2.2e-9, gtol 1e-5, maxls 20). Prints how many objective + gradient evaluations
each needs to come within 1e-4 (relative) of a few levels (0.9, 0.99 and 0.999 of the way from
the start to the worse of the two final objectives, and both finals): a difference in
evaluations is then the optimiser's, not the objective's or the parametrisation's.

`--textbook` runs a textbook L-BFGS (two-loop recursion, scipy's strong-Wolfe line search) in
scipy's place: whether a difference is our implementation's or L-BFGS-B's own. With
`--search dcsrch` it takes L-BFGS-B's line search and skipping rule, which makes it L-BFGS-B
without bounds in Python; `--first-step X` then changes only its first step (a multiple of −g;
default "unit", L-BFGS-B's step of length 1). `--diagonal` replaces its scalar initial inverse
Hessian sᵀy / yᵀy by a diagonal one, rescaled by sᵀy / yᵀDy and updated after each pair as the
diagonal of BFGS's direct update (Gilbert & Lemaréchal 1989, M1QN3's "DIS" scaling): tried for
free latent points, whose latent coordinates' curvatures spread over two to three decades
(BENCHMARKS.md, issue 18's thirteenth pass), and not adopted.

`--back-constraint` compares them on input back constraints (the bench's plain weights W,
the bandwidth fixed as in training) instead of free latent points.

`--transfer` compares the two on the bench's transfer instead (`bench_vs_gpy.py
--transfer-only`: the source trained with free latent points to convergence, the COMAN kernel
trained on its frozen latent points, log parameters): evaluations to within 1e-4 of the level.

Run (module built with `maturin develop --release`; GPy installed for the bench's data):

    python benches/lbfgs_vs_scipy.py --n 300 [--seed 1] [--max-evaluations 6000] \
        [--textbook [--search dcsrch] [--first-step unit|X] [--diagonal]]
    python benches/lbfgs_vs_scipy.py --transfer [--n 300] [--seed 1]
    python benches/lbfgs_vs_scipy.py --back-constraint --max-evaluations 40000 \
        [--transform softplus]
"""

import argparse
import time

import numpy as np
from scipy.optimize import line_search, minimize
from scipy.optimize._dcsrch import DCSRCH  # scipy >= 1.11: L-BFGS-B's line search

import sgplvm
from bench_vs_gpy import TOL, initial_model, smooth_data


# Positive parameters θ as functions of unconstrained u: (θ(u), θ from u's inverse, dθ/du).
TRANSFORMS = {
    # Ours: θ = exp(u).
    "log": (np.exp, np.log, np.exp),
    # GPy's Logexp: θ = log(1 + exp(u)).
    "softplus": (lambda u: np.logaddexp(0.0, u), lambda t: t + np.log(-np.expm1(-t)),
                 lambda u: 1.0 / (1.0 + np.exp(-u))),
}


def latent_block(latent):
    """The latent block the optimisers move: the latent points, or the back-constraint
    weights W (the bandwidth is fixed during training)."""
    return np.asarray(latent["weights"] if isinstance(latent, dict) else latent, dtype=float)


def flatten(params, names, transform):
    """The optimiser's vector: latent points (or back-constraint weights), then per space the
    variance, lengthscales and noise through `transform`'s inverse."""
    inv = TRANSFORMS[transform][1]
    parts = [latent_block(params["latent"]).ravel()]
    for name in names:
        k = params["spaces"][name]
        parts += [inv(np.array([k["variance"]])), inv(np.asarray(k["lengthscale"], dtype=float)),
                  inv(np.array([k["noise"]]))]
    return np.concatenate(parts)


def unflatten(u, shape, names, q, transform, bandwidth=None):
    """`flatten`'s inverse, as the params dict `set_params` takes (back-constraint weights
    with `bandwidth` when it is given)."""
    fwd = TRANSFORMS[transform][0]
    n = shape[0] * shape[1]
    latent = u[:n].reshape(shape)
    if bandwidth is not None:
        latent = {"weights": latent, "bandwidth": bandwidth}
    params = {"latent": latent, "spaces": {}}
    at = n
    for name in names:
        params["spaces"][name] = {"variance": float(fwd(u[at])),
                                  "lengthscale": fwd(u[at + 1:at + 1 + q]),
                                  "noise": float(fwd(u[at + 1 + q]))}
        at += q + 2
    return params


def chain(grad, u, n, names, q, transform):
    """The gradient in `flatten`'s coordinates (d/du = dθ/du · d/dθ)."""
    deriv = TRANSFORMS[transform][2]
    parts = [latent_block(grad["latent"]).ravel()]
    at = n
    for name in names:
        g = grad["spaces"][name]
        parts += [[g["variance"] * deriv(u[at])],
                  np.asarray(g["lengthscale"]) * deriv(u[at + 1:at + 1 + q]),
                  [g["noise"] * deriv(u[at + 1 + q])]]
        at += q + 2
    return np.concatenate([np.ravel(p) for p in parts])


def textbook_lbfgs(fun, x, max_evaluations, memory=10, search="wolfe", first_step="unit",
                   diagonal=False):
    """Textbook L-BFGS (Nocedal & Wright, Alg. 7.4–7.5): the two-loop recursion with
    H0 = (sᵀy / yᵀy) I from the latest pair (I at the start), from the unit step.
    `search="wolfe"`: scipy's strong-Wolfe line search (c1 = 1e-4, c2 = 0.9), pairs with
    sᵀy <= 1e-10 yᵀy skipped. `search="dcsrch"`: L-BFGS-B's own (MINPACK-2's dcsrch with
    ftol 1e-3, gtol 0.9, xtol 0.1, steps up to 1e10) and its skipping rule
    (sᵀy <= ε · (−gᵀs)), which makes this L-BFGS-B without bounds. The first step is
    `first_step` times −g: "unit" is L-BFGS-B's 1/‖g‖ (a step of length 1); a number gives
    another (ours before the fifth pass was 1/(N·ΣD)). `diagonal=True` takes a diagonal H0
    in place of sᵀy / yᵀy (see the module's docstring). `fun(x)` returns (objective,
    gradient) and is called once per evaluation."""
    last = {}

    def cached(u):
        key = u.tobytes()
        if key not in last:
            last.clear()
            last[key] = fun(u)
        return last[key]

    f, g = cached(x)
    pairs = []
    diag = None
    evaluations = 1
    while evaluations < max_evaluations:
        q = g.copy()
        alphas = []
        for s, y in reversed(pairs):
            a = (s @ q) / (y @ s)
            alphas.append(a)
            q -= a * y
        gamma = (pairs[-1][0] @ pairs[-1][1]) / (pairs[-1][1] @ pairs[-1][1]) if pairs else 1.0
        d = -(diag if diag is not None else gamma) * q
        for (s, y), a in zip(pairs, reversed(alphas)):
            d -= s * (a - (y @ -d) / (y @ s))
        step0 = 1.0
        if evaluations == 1:
            step0 = 1.0 / np.linalg.norm(d) if first_step == "unit" else float(first_step)
        if search == "wolfe":
            step, calls, grads, *_ = line_search(lambda u: cached(u)[0], lambda u: cached(u)[1],
                                                 x, d * step0, gfk=g, old_fval=f, c1=1e-4,
                                                 c2=0.9, maxiter=20)
            evaluations += max(calls, grads)
            step = None if step is None else step * step0
        else:
            calls = [0]

            def phi(a):
                calls[0] += 1
                return cached(x + a * d)[0]

            search_ = DCSRCH(phi, lambda a: cached(x + a * d)[1] @ d, ftol=1e-3, gtol=0.9,
                             xtol=0.1, stpmin=0.0, stpmax=1e10)
            step, *_ = search_(step0, phi0=f, derphi0=g @ d, maxiter=20)
            evaluations += calls[0]
        if step is None:
            return "line search failed"
        x_new = x + step * d
        f_new, g_new = cached(x_new)
        s, y = x_new - x, g_new - g
        keep = s @ y > (np.finfo(float).eps * -(g @ s) if search == "dcsrch" else 1e-10 * (y @ y))
        if keep:
            pairs = (pairs + [(s, y)])[-memory:]
            if diagonal:
                sy = s @ y
                diag = np.ones_like(s) if diag is None else diag
                diag = diag * sy / (y @ (diag * y))
                b = 1.0 / diag
                b = b - (b * s) ** 2 / (s @ (b * s)) + y * y / sy
                diag = 1.0 / b
        x, f, g = x_new, f_new, g_new
    return "evaluation limit"


def per_evaluation(history, offset=0.0):
    """The objective known after each of our evaluations, from a training history (each
    iteration's objective at its last evaluation), less `offset`."""
    trace = []
    for f, e in zip(history["objective"], history["evaluations"]):
        trace += [f - offset] * (int(e) - len(trace))
    return trace


def evaluations_to(trace, level):
    """1-based index of the first evaluation within TOL of `level` (None if never)."""
    target = level + TOL * abs(level)
    return next((i + 1 for i, f in enumerate(trace) if f <= target), None)


def compare_transfer(n, seed, transform):
    """Our transfer against scipy's L-BFGS-B on the same transfer objective (the new robot's
    kernel through `transform`, ours log, via `set_params` / `gradient()` of the untrained
    transfer).
    As in `bench_vs_gpy.py`, the frozen source's objective is taken off, so that the 1e-4 is
    relative to the new robot's term alone."""
    human, walkman, coman = smooth_data(n, seed=seed)
    source = sgplvm.SharedGPLVM(latent_dim=5, back_constraint=None, seed=0)
    source.fit({"human": human, "walkman": walkman}, input="human", max_iters=100_000,
               validation=None)
    ours = source.transfer("coman", coman, max_iters=100_000, validation=None)
    h = ours.history
    frozen = source.objective()
    start = source.transfer("coman", coman, max_iters=0, validation=None)
    params = start.params
    q = len(params["spaces"]["coman"]["lengthscale"])
    trace = []

    fwd, inv, deriv = TRANSFORMS[transform]

    def fun(u):
        theta = fwd(u)
        kernel = {"variance": float(theta[0]), "lengthscale": theta[1:1 + q],
                  "noise": float(theta[1 + q])}
        start.set_params({**params, "spaces": {**params["spaces"], "coman": kernel}})
        f = start.objective() - frozen
        trace.append(min(f, trace[-1]) if trace else f)
        g = start.gradient()["spaces"]["coman"]
        return f, np.concatenate([[g["variance"]], g["lengthscale"], [g["noise"]]]) * deriv(u)

    k = params["spaces"]["coman"]
    u0 = inv(np.concatenate([[k["variance"]], k["lengthscale"], [k["noise"]]]))
    res = minimize(fun, u0, jac=True, method="L-BFGS-B")
    ours_trace = per_evaluation(h, frozen)
    print(f"transfer, N = {n}, data seed {seed}: start {ours_trace[0]:.4f} (frozen source "
          f"{frozen:.4f} taken off)")
    print(f"ours : {len(ours_trace)} evaluations ({h['iteration'][-1]} iterations, "
          f"{h['seconds'][-1] * 1e3:.1f} ms by the history's clock), final {ours_trace[-1]:.4f}, "
          f"stop {ours.stop_reason}")
    print(f"scipy L-BFGS-B ({transform}): {len(trace)} evaluations ({res.nit} iterations), final "
          f"{trace[-1]:.4f}, {res.message}")
    level = max(ours_trace[-1], trace[-1])
    print(f"to within 1e-4 of {level:.4f}: ours {evaluations_to(ours_trace, level)}, "
          f"scipy {evaluations_to(trace, level)} evaluations")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=300)
    ap.add_argument("--max-evaluations", type=int, default=6000)
    ap.add_argument("--seed", type=int, default=1, help="seed of the data (the bench uses 1)")
    ap.add_argument("--transform", choices=sorted(TRANSFORMS), default="log",
                    help="scipy's parametrisation of the positive parameters (ours: log)")
    ap.add_argument("--textbook", action="store_true",
                    help="instead of scipy's L-BFGS-B, a textbook L-BFGS with scipy's "
                         "strong-Wolfe line search")
    ap.add_argument("--search", choices=["wolfe", "dcsrch"], default="wolfe",
                    help="--textbook's line search: scipy's strong-Wolfe one, or L-BFGS-B's "
                         "dcsrch (then --textbook is L-BFGS-B without bounds)")
    ap.add_argument("--first-step", default="unit",
                    help="--textbook's first step, as a multiple of -g: 'unit' (1/|g|, "
                         "L-BFGS-B's) or a number")
    ap.add_argument("--diagonal", action="store_true",
                    help="--textbook with a diagonal H0 (Gilbert & Lemarechal's diagonal BFGS "
                         "update) in place of the scalar s'y / y'y")
    ap.add_argument("--transfer", action="store_true",
                    help="compare the two on the bench's transfer instead (see above)")
    ap.add_argument("--back-constraint", action="store_true",
                    help="input back constraints (plain weights W, the bandwidth fixed) "
                         "instead of free latent points")
    args = ap.parse_args()
    if args.diagonal and not args.textbook:
        ap.error("--diagonal changes --textbook's L-BFGS: give --textbook too")
    if args.transfer:
        compare_transfer(args.n, args.seed, args.transform)
        return
    human, walkman, _ = smooth_data(args.n, seed=args.seed)
    spaces = {"human": human, "walkman": walkman}
    names = list(spaces)
    bc = "input" if args.back_constraint else None
    start = initial_model(spaces, bc)
    p0 = start.params
    shape = latent_block(p0["latent"]).shape
    q = len(p0["spaces"]["human"]["lengthscale"])
    bandwidth = p0["latent"]["bandwidth"] if bc else None

    # Ours: its own L-BFGS from the same start; every evaluation's objective is not exposed,
    # the history gives the objective after each iteration and the evaluations spent so far.
    t = time.perf_counter()
    ours = sgplvm.SharedGPLVM(latent_dim=q, back_constraint=bc, seed=0)
    ours.fit(spaces, input="human", max_iters=args.max_evaluations, validation=None)
    t_ours = time.perf_counter() - t
    h = ours.history
    ours_trace = per_evaluation(h)[:args.max_evaluations]

    # scipy on the same objective.
    model = initial_model(spaces, bc)
    trace = []
    n_latent = shape[0] * shape[1]

    def fun(u):
        model.set_params(unflatten(u, shape, names, q, args.transform, bandwidth))
        f = model.objective()
        trace.append(min(f, trace[-1]) if trace else f)
        return f, chain(model.gradient(), u, n_latent, names, q, args.transform)

    t = time.perf_counter()
    u0 = flatten(p0, names, args.transform)
    if args.textbook:
        label = f"textbook L-BFGS ({args.search}, first step {args.first_step})"
        how = textbook_lbfgs(fun, u0, args.max_evaluations, search=args.search,
                             first_step=args.first_step, diagonal=args.diagonal)
        label += ", diagonal H0" if args.diagonal else ""
    else:
        res = minimize(fun, u0, jac=True, method="L-BFGS-B",
                       options={"maxcor": 10, "maxfun": args.max_evaluations,
                                "maxiter": args.max_evaluations})
        label, how = "scipy L-BFGS-B", f"{res.nit} iterations, {res.message}"
    t_scipy = time.perf_counter() - t
    kind = "input back constraints" if bc else "free latent points"
    print(f"N = {args.n}, data seed {args.seed}, {kind}, start objective "
          f"{start.objective():.2f}")
    print(f"ours : {len(ours_trace)} evaluations ({h['iteration'][-1]} iterations, "
          f"{t_ours:.1f} s), final {ours_trace[-1]:.2f}, stop {ours.stop_reason}")
    print(f"{label} ({args.transform}): {len(trace)} evaluations ({t_scipy:.1f} s), final "
          f"{trace[-1]:.2f}, {how}")
    best = min(ours_trace[-1], trace[-1])
    levels = sorted({max(ours_trace[-1], trace[-1]), best}, reverse=True)
    f0 = start.objective()
    levels = [f0 + frac * (levels[0] - f0) for frac in (0.9, 0.99, 0.999)] + levels
    print(f"{'level':>14} {'ours':>8} {'other':>8}  evaluations to within 1e-4")
    for level in levels:
        a, b = evaluations_to(ours_trace, level), evaluations_to(trace, level)
        print(f"{level:14.2f} {a if a else '-':>8} {b if b else '-':>8}")


if __name__ == "__main__":
    main()
