//! One step of differential inverse kinematics as a small quadratic program, the shape of mink
//! and Pink: weighted *tasks* (least-squares objectives on the joint step) and *limits* (linear
//! inequalities on it), composed freely:
//!
//! ```text
//! min_Δq  Σₖ wₖ ‖Jₖ Δq − eₖ‖² + λ ‖Δq‖²    s.t.  lo ≤ Δq ≤ hi,   Aᵢ Δq ≤ bᵢ
//! ```
//!
//! i.e. `½ Δqᵀ H Δq + gᵀ Δq` with `H = 2 (Σ wₖ JₖᵀJₖ + λ I)` and `g = −2 Σ wₖ Jₖᵀ eₖ`. The
//! unconstrained minimiser (one Cholesky solve) is taken when it satisfies every limit — the
//! common case, and then it is the QP's solution too; otherwise Clarabel (a maintained
//! interior-point solver in pure Rust) solves the QP.

use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettingsBuilder, DefaultSolver, IPSolver, NonnegativeConeT, SolverStatus,
};
use nalgebra::{DMatrix, DVector};

/// Why a step could not be solved.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum QpError {
    /// The limits admit no step (e.g. a collision limit that the position limits forbid
    /// moving away from).
    #[error("the limits admit no step (the QP solver reports {0})")]
    Infeasible(String),
    /// A task or limit is not a finite number.
    #[error("a task or limit is not a finite number")]
    NotFinite,
}

/// How the step was found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Solved {
    /// The unconstrained minimiser satisfied every limit.
    Unconstrained,
    /// A limit was active: the QP solver found the step.
    Constrained,
}

/// What the dual active-set method found.
#[derive(Debug)]
enum Dual {
    /// The step.
    Solved(DVector<f64>),
    /// A violated limit contradicts those that bind: the limits admit no step.
    Contradicted,
    /// A system was singular, or the method did not settle.
    Unsettled,
}

/// One step's quadratic program over `n` joint variables.
#[derive(Debug, Clone)]
pub struct Step {
    h: DMatrix<f64>,
    g: DVector<f64>,
    lower: DVector<f64>,
    upper: DVector<f64>,
    rows: Vec<(DVector<f64>, f64)>,
}

impl Step {
    /// An empty step over `n` variables with damping `lambda` (≥ 0) and no bounds.
    pub fn new(n: usize, lambda: f64) -> Step {
        Step {
            h: DMatrix::identity(n, n) * (2.0 * lambda.max(0.0)),
            g: DVector::zeros(n),
            lower: DVector::from_element(n, f64::NEG_INFINITY),
            upper: DVector::from_element(n, f64::INFINITY),
            rows: Vec::new(),
        }
    }

    /// The number of variables.
    pub fn dim(&self) -> usize {
        self.g.len()
    }

    /// Adds the task `w ‖J Δq − e‖²` (`jacobian` is `m × n`, `error` has `m` entries).
    pub fn add_task(&mut self, jacobian: &DMatrix<f64>, error: &DVector<f64>, weight: f64) {
        if weight <= 0.0 || jacobian.nrows() == 0 {
            return;
        }
        let jt = jacobian.transpose();
        self.h += (&jt * jacobian) * (2.0 * weight);
        self.g -= (jt * error) * (2.0 * weight);
    }

    /// Narrows the bounds of variable `i` to `[lo, hi]` (intersected with what is there; an
    /// empty intersection keeps the bound nearest to the other).
    pub fn bound(&mut self, i: usize, lo: f64, hi: f64) {
        let (l, u) = (self.lower[i].max(lo), self.upper[i].min(hi));
        if l <= u {
            self.lower[i] = l;
            self.upper[i] = u;
        } else if hi < self.lower[i] {
            self.upper[i] = self.lower[i];
        } else {
            self.lower[i] = self.upper[i];
        }
    }

    /// Adds the limit `aᵀ Δq ≤ b`.
    pub fn add_row(&mut self, a: DVector<f64>, b: f64) {
        self.rows.push((a, b));
    }

    /// Whether `x` satisfies every bound and row within `tol`.
    fn feasible(&self, x: &DVector<f64>, tol: f64) -> bool {
        (0..x.len()).all(|i| x[i] >= self.lower[i] - tol && x[i] <= self.upper[i] + tol)
            && self.rows.iter().all(|(a, b)| a.dot(x) <= b + tol)
    }

    /// The step: the unconstrained minimiser where it satisfies every limit, else the QP's
    /// solution.
    pub fn solve(&self) -> Result<(DVector<f64>, Solved), QpError> {
        if self.h.iter().chain(self.g.iter()).any(|v| !v.is_finite())
            || self
                .rows
                .iter()
                .any(|(a, b)| b.is_nan() || a.iter().any(|v| !v.is_finite()))
        {
            return Err(QpError::NotFinite);
        }
        if let Some(ch) = self.h.clone().cholesky() {
            let x = -ch.solve(&self.g);
            if self.feasible(&x, 1e-12) {
                return Ok((x, Solved::Unconstrained));
            }
        }
        // Bounds alone bind (joints at their limits): an active set on the box, a few small
        // solves, where it gives a step that keeps the rows too.
        if let Some(x) = self.box_active_set() {
            if self.feasible(&x, 1e-9) {
                return Ok((x, Solved::Constrained));
            }
        }
        // Rows bind too: the dual active set (from the unconstrained minimiser, feasible start
        // or not: a collision limit already inside its margin); a primal active set from the
        // zero step where that is feasible; the interior-point solver where neither settles.
        // Asked only where the dual active set did not give the step.
        let zero_feasible = || self.feasible(&DVector::zeros(self.dim()), 0.0);
        match self.dual_active_set() {
            Dual::Solved(x) if self.feasible(&x, 1e-9) => return Ok((x, Solved::Constrained)),
            // Proven: no point keeps a violated limit and those that bind together. The
            // interior-point solver agreed every time it was asked after this (5,890 steps of
            // two published robots' retargeting, 2026-12-07), at a tenth of MOVO's time.
            Dual::Contradicted if !zero_feasible() => {
                return Err(QpError::Infeasible(
                    "the dual active set: a violated limit contradicts those that bind".into(),
                ))
            }
            _ => {}
        }
        if zero_feasible() {
            if let Some(x) = self.active_set() {
                return Ok((x, Solved::Constrained));
            }
        }
        self.solve_qp().map(|x| (x, Solved::Constrained))
    }

    /// Every limit as a row `aᵀx ≤ b`: the finite bounds, then the rows.
    fn all_rows(&self) -> Vec<(DVector<f64>, f64)> {
        let n = self.dim();
        let mut rows = Vec::with_capacity(2 * n + self.rows.len());
        for i in 0..n {
            if self.upper[i].is_finite() {
                rows.push((
                    DVector::from_fn(n, |k, _| if k == i { 1.0 } else { 0.0 }),
                    self.upper[i],
                ));
            }
            if self.lower[i].is_finite() {
                rows.push((
                    DVector::from_fn(n, |k, _| if k == i { -1.0 } else { 0.0 }),
                    -self.lower[i],
                ));
            }
        }
        rows.extend(self.rows.iter().cloned());
        rows
    }

    /// The primal active-set method from `x = 0` (feasible): the step to the minimiser with
    /// the working set's rows held tight, cut at the first row it would cross (which joins the
    /// set); at a minimiser on the set, a row with a negative multiplier leaves it; done when
    /// none has. `None` if it does not settle or a system is singular.
    fn active_set(&self) -> Option<DVector<f64>> {
        let n = self.dim();
        let rows = self.all_rows();
        let mut x = DVector::zeros(n);
        let mut work: Vec<usize> = Vec::new();
        for _ in 0..(4 * rows.len() + 10) {
            let w = work.len();
            // KKT: [H Aᵀ; A 0] [p; λ] = [−(Hx + g); 0]
            let mut kkt = DMatrix::zeros(n + w, n + w);
            kkt.view_mut((0, 0), (n, n)).copy_from(&self.h);
            for (r, &k) in work.iter().enumerate() {
                for c in 0..n {
                    kkt[(n + r, c)] = rows[k].0[c];
                    kkt[(c, n + r)] = rows[k].0[c];
                }
            }
            let mut rhs = DVector::zeros(n + w);
            rhs.rows_mut(0, n).copy_from(&(-(&self.h * &x + &self.g)));
            let sol = kkt.lu().solve(&rhs)?;
            let p = sol.rows(0, n).into_owned();
            if p.amax() < 1e-12 {
                // A minimiser on the working set: drop the row with the most negative multiplier.
                let drop = (0..w)
                    .filter(|&r| sol[n + r] < -1e-12)
                    .min_by(|&a, &b| sol[n + a].total_cmp(&sol[n + b]));
                match drop {
                    Some(r) => {
                        work.remove(r);
                        continue;
                    }
                    None => return Some(x),
                }
            }
            // The longest step along p that crosses no row outside the working set.
            let mut alpha = 1.0;
            let mut blocking = None;
            for (k, (a, b)) in rows.iter().enumerate() {
                if work.contains(&k) {
                    continue;
                }
                let ap = a.dot(&p);
                if ap > 1e-14 {
                    let room = ((b - a.dot(&x)) / ap).max(0.0);
                    if room < alpha {
                        alpha = room;
                        blocking = Some(k);
                    }
                }
            }
            x += &p * alpha;
            if let Some(k) = blocking {
                work.push(k);
            }
        }
        None
    }

    /// Goldfarb and Idnani's dual active-set method (the algorithm of quadprog): from the
    /// unconstrained minimiser, the most violated limit is added to the working set by raising
    /// its multiplier, which moves the point along the working set until the limit holds or
    /// another multiplier drops to zero (that limit leaves the set); done when no limit is
    /// violated. Every iterate is optimal for the limits in the set, so the start need not be
    /// feasible. [`Dual::Contradicted`] when a violated limit cannot be met with those in the
    /// set (the limits admit no point), [`Dual::Unsettled`] when a system is singular or it
    /// does not settle (the caller falls back on the interior-point solver).
    fn dual_active_set(&self) -> Dual {
        let n = self.dim();
        let rows = self.all_rows();
        let Some(ch) = self.h.clone().cholesky() else {
            return Dual::Unsettled;
        };
        let mut x = -ch.solve(&self.g);
        let mut work: Vec<usize> = Vec::new();
        let mut mult: Vec<f64> = Vec::new();
        let scale = 1.0 + self.g.amax();
        let max_iterations = 4 * rows.len() + 10;
        let mut iterations = 0;
        loop {
            // The most violated limit outside the working set.
            let worst = rows
                .iter()
                .enumerate()
                .filter(|(k, _)| !work.contains(k))
                .map(|(k, (a, b))| (k, a.dot(&x) - b))
                .max_by(|a, b| a.1.total_cmp(&b.1));
            let Some((p, violation)) = worst else {
                return Dual::Solved(x);
            };
            if violation <= 1e-12 * scale {
                return Dual::Solved(x);
            }
            let mut raised = 0.0;
            loop {
                iterations += 1;
                if iterations > max_iterations {
                    return Dual::Unsettled;
                }
                // [H Aᵀ; A 0] [z; r] = [−a_p; 0]: how x and the multipliers move as p's rises.
                let w = work.len();
                let mut kkt = DMatrix::zeros(n + w, n + w);
                kkt.view_mut((0, 0), (n, n)).copy_from(&self.h);
                for (r, &k) in work.iter().enumerate() {
                    for c in 0..n {
                        kkt[(n + r, c)] = rows[k].0[c];
                        kkt[(c, n + r)] = rows[k].0[c];
                    }
                }
                let mut rhs = DVector::zeros(n + w);
                rhs.rows_mut(0, n).copy_from(&(-&rows[p].0));
                let Some(sol) = kkt.lu().solve(&rhs) else {
                    return Dual::Unsettled;
                };
                let z = sol.rows(0, n).into_owned();
                let r = sol.rows(n, w).into_owned();
                // The first multiplier of the set to reach zero.
                let leaving = (0..w)
                    .filter(|&i| r[i] < -1e-14)
                    .map(|i| (i, mult[i] / -r[i]))
                    .min_by(|a, b| a.1.total_cmp(&b.1));
                let slope = rows[p].0.dot(&z);
                let full = if slope < -1e-14 {
                    Some((rows[p].0.dot(&x) - rows[p].1) / -slope)
                } else {
                    None
                };
                let t = match (full, leaving) {
                    (None, None) => return Dual::Contradicted,
                    (Some(f), Some((_, d))) if d < f => d,
                    (Some(f), _) => f,
                    (None, Some((_, d))) => d,
                };
                if full.is_some() {
                    x += &z * t;
                }
                for (m, ri) in mult.iter_mut().zip(r.iter()) {
                    *m = (*m + t * ri).max(0.0);
                }
                raised += t;
                match (full, leaving) {
                    (Some(f), Some((i, d))) if d < f => {
                        work.remove(i);
                        mult.remove(i);
                    }
                    (Some(_), _) => {
                        work.push(p);
                        mult.push(raised);
                        break;
                    }
                    (None, Some((i, _))) => {
                        work.remove(i);
                        mult.remove(i);
                    }
                    (None, None) => return Dual::Contradicted,
                }
            }
        }
    }

    /// The minimiser within the bounds alone, by an active set: variables beyond a bound are
    /// fixed at it and the rest solved again; a fixed variable whose gradient would pull it
    /// back inside is freed; until neither happens (`None` if it does not settle).
    fn box_active_set(&self) -> Option<DVector<f64>> {
        let n = self.dim();
        // 0: free, -1: at its lower bound, 1: at its upper bound.
        let mut at = vec![0i8; n];
        for _ in 0..(3 * n + 3) {
            let free: Vec<usize> = (0..n).filter(|&i| at[i] == 0).collect();
            let mut x = DVector::zeros(n);
            for i in 0..n {
                x[i] = match at[i] {
                    -1 => self.lower[i],
                    1 => self.upper[i],
                    _ => 0.0,
                };
            }
            if !free.is_empty() {
                let hf =
                    DMatrix::from_fn(free.len(), free.len(), |r, c| self.h[(free[r], free[c])]);
                let rhs = DVector::from_fn(free.len(), |r, _| {
                    let i = free[r];
                    -(self.g[i]
                        + (0..n)
                            .filter(|&k| at[k] != 0)
                            .map(|k| self.h[(i, k)] * x[k])
                            .sum::<f64>())
                });
                let xf = hf.cholesky()?.solve(&rhs);
                for (r, &i) in free.iter().enumerate() {
                    x[i] = xf[r];
                }
            }
            // The free variable furthest beyond a bound is fixed there.
            let beyond = free
                .iter()
                .map(|&i| (i, (self.lower[i] - x[i]).max(x[i] - self.upper[i])))
                .filter(|&(_, d)| d > 1e-12)
                .max_by(|a, b| a.1.total_cmp(&b.1));
            if let Some((i, _)) = beyond {
                at[i] = if x[i] < self.lower[i] { -1 } else { 1 };
                continue;
            }
            // A fixed variable whose gradient pulls it inside is freed.
            let grad = &self.h * &x + &self.g;
            let pulled = (0..n)
                .filter(|&i| (at[i] == -1 && grad[i] < -1e-12) || (at[i] == 1 && grad[i] > 1e-12))
                .max_by(|&a, &b| grad[a].abs().total_cmp(&grad[b].abs()));
            match pulled {
                Some(i) => at[i] = 0,
                None => return Some(x),
            }
        }
        None
    }

    /// Clarabel on `½ xᵀ H x + gᵀ x` s.t. `x ≤ upper`, `−x ≤ −lower`, rows.
    fn solve_qp(&self) -> Result<DVector<f64>, QpError> {
        let n = self.dim();
        // The upper triangle of H, column by column.
        let (mut colptr, mut rowval, mut nzval) = (vec![0], Vec::new(), Vec::new());
        for c in 0..n {
            for r in 0..=c {
                if self.h[(r, c)] != 0.0 {
                    rowval.push(r);
                    nzval.push(self.h[(r, c)]);
                }
            }
            colptr.push(rowval.len());
        }
        let p = CscMatrix::new(n, n, colptr, rowval, nzval);
        // Constraint rows: finite upper bounds, finite lower bounds, then the rows.
        let mut dense: Vec<(Vec<(usize, f64)>, f64)> = Vec::new();
        for i in 0..n {
            if self.upper[i].is_finite() {
                dense.push((vec![(i, 1.0)], self.upper[i]));
            }
            if self.lower[i].is_finite() {
                dense.push((vec![(i, -1.0)], -self.lower[i]));
            }
        }
        for (a, b) in &self.rows {
            let entries: Vec<(usize, f64)> = a
                .iter()
                .enumerate()
                .filter(|(_, v)| **v != 0.0)
                .map(|(i, v)| (i, *v))
                .collect();
            dense.push((entries, *b));
        }
        let m = dense.len();
        let (mut colptr, mut rowval, mut nzval) = (vec![0], Vec::new(), Vec::new());
        for c in 0..n {
            for (r, (entries, _)) in dense.iter().enumerate() {
                if let Some((_, v)) = entries.iter().find(|(i, _)| *i == c) {
                    rowval.push(r);
                    nzval.push(*v);
                }
            }
            colptr.push(rowval.len());
        }
        let a = CscMatrix::new(m, n, colptr, rowval, nzval);
        let b: Vec<f64> = dense.iter().map(|(_, b)| *b).collect();
        let cones = [NonnegativeConeT(m)];
        let settings = DefaultSettingsBuilder::default()
            .verbose(false)
            .max_iter(100)
            // Tight: in the directions only a weak posture task decides, a loose solution
            // would leave the step, and with it the posture, undecided.
            .tol_gap_abs(1e-11)
            .tol_gap_rel(1e-11)
            .tol_feas(1e-11)
            .build()
            .map_err(|e| QpError::Infeasible(format!("settings: {e}")))?;
        let q: Vec<f64> = self.g.iter().copied().collect();
        let mut solver = DefaultSolver::new(&p, &q, &a, &b, &cones, settings)
            .map_err(|e| QpError::Infeasible(format!("{e:?}")))?;
        solver.solve();
        match solver.solution.status {
            SolverStatus::Solved | SolverStatus::AlmostSolved => {
                Ok(DVector::from_vec(solver.solution.x.clone()))
            }
            other => Err(QpError::Infeasible(format!("{other:?}"))),
        }
    }

    /// The objective `½ xᵀ H x + gᵀ x` at `x`.
    pub fn objective(&self, x: &DVector<f64>) -> f64 {
        0.5 * x.dot(&(&self.h * x)) + self.g.dot(x)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A random step over `n` variables: a task of `n + 2` random rows, every variable within
    /// ±`bound`.
    fn random_step(rand: &mut impl FnMut() -> f64, n: usize, bound: f64) -> Step {
        let a = DMatrix::from_fn(n + 2, n, |_, _| rand());
        let e = DVector::from_fn(n + 2, |_, _| 2.0 * rand());
        let mut s = Step::new(n, 1e-3);
        s.add_task(&a, &e, 1.0);
        for i in 0..n {
            s.bound(i, -bound, bound);
        }
        s
    }

    #[test]
    fn the_unconstrained_step_is_least_squares_and_limits_bind_as_a_qp() {
        // Two variables, task: x = (1, 2) with weight 1, tiny damping.
        let mut s = Step::new(2, 1e-9);
        s.add_task(
            &DMatrix::identity(2, 2),
            &DVector::from_vec(vec![1.0, 2.0]),
            1.0,
        );
        let (x, how) = s.solve().unwrap();
        assert_eq!(how, Solved::Unconstrained);
        assert!((x - DVector::from_vec(vec![1.0, 2.0])).norm() < 1e-6);
        // A bound binds: x₁ ≤ 0.5.
        s.bound(0, -1.0, 0.5);
        let (x, how) = s.solve().unwrap();
        assert_eq!(how, Solved::Constrained);
        assert!(
            (x[0] - 0.5).abs() < 1e-6 && (x[1] - 2.0).abs() < 1e-6,
            "{x}"
        );
        // A row binds: x₀ + x₁ ≤ 1 (with x₀ ≤ 0.5): the projection of (1, 2) is (0, 1) but
        // for the bound; the optimum of ‖x − (1,2)‖² on x₀+x₁ ≤ 1 is (0, 1).
        s.add_row(DVector::from_vec(vec![1.0, 1.0]), 1.0);
        let (x, _) = s.solve().unwrap();
        assert!(
            (x[0] - 0.0).abs() < 1e-5 && (x[1] - 1.0).abs() < 1e-5,
            "{x}"
        );
        // Contradicting limits are an error, not a step.
        s.add_row(DVector::from_vec(vec![-1.0, 0.0]), -0.8);
        assert!(matches!(s.solve(), Err(QpError::Infeasible(_))));
        // The box active set agrees with the QP solver on random box-bounded problems.
        let mut seed = 7u64;
        let mut rand = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        };
        for _ in 0..50 {
            let n = 6;
            let a = DMatrix::from_fn(8, n, |_, _| rand());
            let e = DVector::from_fn(8, |_, _| 2.0 * rand());
            let mut box_only = Step::new(n, 1e-3);
            box_only.add_task(&a, &e, 1.0);
            for i in 0..n {
                box_only.bound(i, -0.2 - 0.1 * rand().abs(), 0.2 + 0.1 * rand().abs());
            }
            let by_set = box_only.box_active_set().unwrap();
            let by_qp = box_only.solve_qp().unwrap();
            assert!((by_set - by_qp).amax() < 1e-6);
        }
        // And with rows too, from a feasible zero step.
        for _ in 0..50 {
            let n = 6;
            let mut s = random_step(&mut rand, n, 0.3);
            for _ in 0..3 {
                s.add_row(
                    DVector::from_fn(n, |_, _| rand()),
                    0.05 + 0.1 * rand().abs(),
                );
            }
            let by_set = s.active_set().unwrap();
            let by_qp = s.solve_qp().unwrap();
            assert!((&by_set - &by_qp).amax() < 1e-6, "{by_set} vs {by_qp}");
        }
        // The dual active set agrees with the QP solver where the zero step breaks a row (a
        // collision limit already inside its margin), and where the limits admit no step.
        let (mut solved, mut contradicted) = (0, 0);
        for _ in 0..100 {
            let n = 7;
            let mut s = random_step(&mut rand, n, 0.4);
            for _ in 0..4 {
                s.add_row(DVector::from_fn(n, |_, _| rand()), 0.1 * rand());
            }
            let by_qp = s.solve_qp();
            match (s.dual_active_set(), by_qp) {
                (Dual::Solved(x), Ok(y)) => {
                    assert!(s.feasible(&x, 1e-9));
                    assert!((&x - &y).amax() < 1e-6, "{x} vs {y}");
                    solved += usize::from(!s.feasible(&DVector::zeros(n), 0.0));
                }
                (Dual::Contradicted, Err(_)) => contradicted += 1,
                (x, y) => panic!("dual active set {x:?}, QP solver {y:?}"),
            }
        }
        // A row no step within the bounds can keep: both say so.
        for _ in 0..20 {
            let n = 7;
            let mut s = random_step(&mut rand, n, 0.4);
            let row = DVector::from_fn(n, |_, _| rand());
            let beyond = -0.4 * row.abs().sum() - 0.05;
            s.add_row(DVector::from_fn(n, |_, _| rand()), 0.1 * rand().abs());
            s.add_row(row, beyond);
            match (s.dual_active_set(), s.solve_qp()) {
                (Dual::Contradicted, Err(_)) => contradicted += 1,
                // A point the caller finds beyond a limit: the QP solver is asked.
                (Dual::Solved(x), Err(_)) if !s.feasible(&x, 1e-9) => {}
                (x, y) => panic!("dual active set {x:?}, QP solver {y:?}"),
            }
            assert!(matches!(s.solve(), Err(QpError::Infeasible(_))));
        }
        assert!(
            solved > 20 && contradicted >= 10,
            "{solved} problems with an infeasible zero step solved, {contradicted} contradicted"
        );
        let mut bad = Step::new(1, 0.0);
        bad.add_task(
            &DMatrix::identity(1, 1),
            &DVector::from_vec(vec![f64::NAN]),
            1.0,
        );
        assert_eq!(bad.solve().unwrap_err(), QpError::NotFinite);
    }
}
