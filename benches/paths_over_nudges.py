"""How many evaluations each optimiser needs to a level over last-bit variants of one problem
(issue 18): the bench's time-to-solution problem (`bench_vs_gpy.py`: smooth data, free latent
points or input back constraints, the same start on both sides) with its first human value
multiplied by 1 + k·10⁻¹⁵ for each k given. Such a change moves each side's late-phase path
(BENCHMARKS.md, issue 18's twelfth pass), so one bench run is one draw: this prints the draws,
evaluations to within 1e-4 (relative) of `--level`, for ours and for GPy's L-BFGS-B (one BLAS
thread, as the bench's `--quick` rows). A time-to-solution ratio is the evaluation ratio times
the per-evaluation ratio; the counts do not depend on the machine's load, so this may run
beside other work.

    python benches/paths_over_nudges.py --n 1000 --level -80531.93 --nudges 0,1,2 \
        [--side ours|gpy|both] [--back-constraint] [--max-evaluations 6000]
"""

import argparse
import time

from threadpoolctl import threadpool_limits

import sgplvm
from bench_vs_gpy import TOL, gpy_model, initial_model, run_gpy, smooth_data


def nudged_spaces(n, seed, k):
    human, walkman, _ = smooth_data(n, seed=seed)
    human[0, 0] *= 1.0 + k * 1e-15
    return {"human": human, "walkman": walkman}


def ours_path(spaces, bc, max_evaluations):
    """Our training's path [(evaluations, objective)] per iteration, and its seconds."""
    m = sgplvm.SharedGPLVM(latent_dim=5, back_constraint=bc, seed=0)
    t = time.perf_counter()
    m.fit(spaces, input="human", max_iters=max_evaluations, validation=None)
    seconds = time.perf_counter() - t
    h = m.history
    return list(zip(h["evaluations"], h["objective"])), seconds


def gpy_path(spaces, bc, max_evaluations, level):
    """GPy's path [(evaluations, objective)] per evaluation from our start, with one BLAS
    thread, stopped once within TOL of `level`, and its seconds."""
    start = initial_model(spaces, bc)
    with threadpool_limits(limits=1, user_api="blas"):
        model, seconds = run_gpy(gpy_model(spaces, start.params, bc), level,
                                 max_evaluations=max_evaluations)
    return [(k + 1, f) for k, (_, f) in enumerate(model.trace)], seconds


def first_within(path, level):
    """The evaluations at which `path` first comes within TOL of `level` (None if never)."""
    target = level + TOL * abs(level)
    return next((int(e) for e, f in path if f <= target), None)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=1000)
    ap.add_argument("--seed", type=int, default=1, help="seed of the data (the bench uses 1)")
    ap.add_argument("--level", type=float, required=True, help="the objective level to reach")
    ap.add_argument("--nudges", default="0,1,2,3,4,5", help="comma-separated k")
    ap.add_argument("--side", choices=["ours", "gpy", "both"], default="both")
    ap.add_argument("--back-constraint", action="store_true",
                    help="input back constraints instead of free latent points")
    ap.add_argument("--max-evaluations", type=int, default=6000,
                    help="each run's budget (ours: iterations; GPy: scipy's maxfun)")
    args = ap.parse_args()
    bc = "input" if args.back_constraint else None
    sides = ["ours", "gpy"] if args.side == "both" else [args.side]
    for k in [float(v) for v in args.nudges.split(",")]:
        spaces = nudged_spaces(args.n, args.seed, k)
        for side in sides:
            if side == "ours":
                path, seconds = ours_path(spaces, bc, args.max_evaluations)
            else:
                path, seconds = gpy_path(spaces, bc, args.max_evaluations, args.level)
            hit = first_within(path, args.level)
            if hit:
                outcome = f"{hit} evaluations to {args.level}"
            else:
                # Where it stopped instead, and when it came within TOL of that.
                best = min(f for _, f in path)
                outcome = (f"{args.level} not reached in {int(path[-1][0])} evaluations; best "
                           f"{best:.2f}, within 1e-4 of it from evaluation "
                           f"{first_within(path, best)}")
            print(f"N = {args.n}, seed {args.seed}, nudge {k:g}, {side}: {outcome} "
                  f"({seconds:.1f} s)", flush=True)


if __name__ == "__main__":
    main()
