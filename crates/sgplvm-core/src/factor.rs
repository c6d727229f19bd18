//! A Cholesky factorisation and a solve whose work is cut into pieces that two threads share.
//!
//! faer's own factorisation and solve gain nothing from a second thread at a few hundred points
//! (their parallelism lives inside products too small to split well). The factorisation here is
//! right-looking in blocks of [`BLOCK`] columns: each block's panel solve and trailing update
//! are cut in two pieces of equal work, run side by side on a two-thread `Par` and one after the
//! other otherwise. The pieces are the same operations on the same data either way, so the
//! factor does not depend on the threads, bit for bit. [`cholesky`] and [`solve`] use the pieces
//! from [`IN_PIECES_FROM`] points up to [`PARALLEL_FROM`], and faer's own code outside that
//! range: beyond it faer's parallelism takes every thread of a larger machine.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt;
use faer::linalg::matmul::triangular::BlockStructure;
use faer::linalg::triangular_solve::solve_lower_triangular_in_place;
use faer::reborrow::{Reborrow, ReborrowMut};
use faer::{Accum, MatMut, MatRef, Par};

use crate::pool::{both, PARALLEL_FROM};

/// Points from which a space's factorisation and solve run in pieces (below [`PARALLEL_FROM`]),
/// and the products of its latent gradient too (at any size beyond).
pub(crate) const IN_PIECES_FROM: usize = 256;

/// Columns factorised at a time. At 300 points, on two threads, 64 took 171–183 µs against 207
/// for 128 and faer's 216–219; on one thread 248 against faer's 244 (`piece_times`, the fastest
/// of 60, quiet runs).
const BLOCK: usize = 64;

/// True when an `n`-point factorisation and solve run in pieces.
fn in_pieces(n: usize) -> bool {
    (IN_PIECES_FROM..PARALLEL_FROM).contains(&n)
}

/// The factorisation failed: the matrix is not numerically positive definite.
#[derive(Clone, Copy, Debug)]
pub(crate) struct NotPositive;

/// Factorises the lower triangle of the square `a` in place, `a = L Lᵀ`, with `par`: in pieces
/// where [`in_pieces`], by faer's factorisation otherwise.
pub(crate) fn cholesky(a: MatMut<'_, f64>, par: Par) -> Result<(), NotPositive> {
    let n = a.nrows();
    if in_pieces(n) {
        return cholesky_in_pieces(a, par);
    }
    let mut mem = MemBuffer::new(llt::factor::cholesky_in_place_scratch::<f64>(
        n,
        par,
        Default::default(),
    ));
    llt::factor::cholesky_in_place(
        a,
        Default::default(),
        par,
        MemStack::new(&mut mem),
        Default::default(),
    )
    .map(|_| ())
    .map_err(|_| NotPositive)
}

/// Solves `L Lᵀ A = B` in place (`rhs` holds B, then A), with `par`: in pieces where
/// [`in_pieces`], by faer's solve otherwise.
pub(crate) fn solve(l: MatRef<'_, f64>, rhs: MatMut<'_, f64>, par: Par) {
    if in_pieces(l.nrows()) {
        solve_in_pieces(l, rhs, par);
    } else {
        llt::solve::solve_in_place(l, rhs, par, MemStack::new(&mut []));
    }
}

/// Factorises the lower triangle of the square `a` in place, `a = L Lᵀ` (the upper triangle is
/// not read or written).
fn cholesky_in_pieces(a: MatMut<'_, f64>, par: Par) -> Result<(), NotPositive> {
    cholesky_blocks(a, par, BLOCK)
}

/// [`cholesky_in_pieces`] in blocks of `block` columns.
fn cholesky_blocks(mut a: MatMut<'_, f64>, par: Par, block: usize) -> Result<(), NotPositive> {
    let n = a.nrows();
    let mut mem = MemBuffer::new(llt::factor::cholesky_in_place_scratch::<f64>(
        block,
        Par::Seq,
        Default::default(),
    ));
    let mut k = 0;
    while k < n {
        let b = block.min(n - k);
        llt::factor::cholesky_in_place(
            a.rb_mut().submatrix_mut(k, k, b, b),
            Default::default(),
            Par::Seq,
            MemStack::new(&mut mem),
            Default::default(),
        )
        .map_err(|_| NotPositive)?;
        let m = n - k - b;
        if m == 0 {
            break;
        }
        let (top, bottom) = a.rb_mut().split_at_row_mut(k + b);
        let l11 = top.rb().submatrix(k, k, b, b);
        let (left, a22) = bottom.split_at_col_mut(k + b);
        let mut a21 = left.subcols_mut(k, b);
        // The panel: A21 ← A21 L11⁻ᵀ, its rows in two halves.
        {
            let (p1, p2) = a21.rb_mut().split_at_row_mut(m / 2);
            both(
                par,
                || solve_lower_triangular_in_place(l11, p1.transpose_mut(), Par::Seq),
                || solve_lower_triangular_in_place(l11, p2.transpose_mut(), Par::Seq),
            );
        }
        // The trailing update: tril(A22) −= A21 A21ᵀ. Rows [0, r) hold a triangle of r²/2
        // entries, rows [r, m) the other (m² − r²)/2: equal at r = m/√2.
        let a21 = a21.rb();
        let r = ((m as f64 / std::f64::consts::SQRT_2) as usize).clamp(1, m);
        let (upper_rows, lower_rows) = a22.split_at_row_mut(r);
        both(
            par,
            || {
                let dst = upper_rows.subcols_mut(0, r);
                trailing_triangle(dst, a21.subrows(0, r));
            },
            || {
                if r < m {
                    let (rect, tri) = lower_rows.split_at_col_mut(r);
                    let rows = a21.subrows(r, m - r);
                    faer::linalg::matmul::matmul(
                        rect,
                        Accum::Add,
                        rows,
                        a21.subrows(0, r).transpose(),
                        -1.0,
                        Par::Seq,
                    );
                    trailing_triangle(tri.subcols_mut(0, m - r), rows);
                }
            },
        );
        k += b;
    }
    Ok(())
}

/// Solves `L Lᵀ A = B` in place (`rhs` holds B, then A). On a two-thread `par` its columns are
/// solved in two halves side by side (faer's own solve gains nothing from a second thread at a
/// few hundred points). A column's solution does not depend on the others solved with it, as
/// long as each half holds at least two columns (faer solves a single column by another path):
/// the result is the same bit for bit on any number of threads (pinned by a test).
fn solve_in_pieces(l: MatRef<'_, f64>, rhs: MatMut<'_, f64>, par: Par) {
    let d = rhs.ncols();
    match par {
        Par::Rayon(t) if t.get() > 1 && d >= 4 => {
            let (left, right) = rhs.split_at_col_mut(d / 2);
            both(
                par,
                || llt::solve::solve_in_place(l, left, Par::Seq, MemStack::new(&mut [])),
                || llt::solve::solve_in_place(l, right, Par::Seq, MemStack::new(&mut [])),
            );
        }
        _ => llt::solve::solve_in_place(l, rhs, Par::Seq, MemStack::new(&mut [])),
    }
}

/// tril(dst) −= rows rowsᵀ.
fn trailing_triangle(dst: MatMut<'_, f64>, rows: MatRef<'_, f64>) {
    faer::linalg::matmul::triangular::matmul(
        dst,
        BlockStructure::TriangularLower,
        Accum::Add,
        rows,
        BlockStructure::Rectangular,
        rows.transpose(),
        BlockStructure::Rectangular,
        -1.0,
        Par::Seq,
    );
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::Mat;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn spd(n: usize) -> Mat<f64> {
        let mut rng = ChaCha8Rng::seed_from_u64(n as u64);
        let g = Mat::from_fn(n, n, |_, _| rng.random_range(-1.0..1.0));
        let mut k = &g * g.transpose();
        for i in 0..n {
            k[(i, i)] += n as f64;
        }
        k
    }

    /// faer's factorisation of `a` in place, with scratch for up to `mem`'s size.
    fn faer_llt(a: MatMut<'_, f64>, par: Par, mem: &mut MemBuffer) {
        llt::factor::cholesky_in_place(
            a,
            Default::default(),
            par,
            MemStack::new(mem),
            Default::default(),
        )
        .expect("positive definite");
    }

    /// Scratch for faer's factorisation of `n` points on up to two threads.
    fn faer_scratch(n: usize) -> MemBuffer {
        MemBuffer::new(llt::factor::cholesky_in_place_scratch::<f64>(
            n,
            Par::rayon(2),
            Default::default(),
        ))
    }

    #[test]
    fn pieces_factorise_as_faer_does_on_one_thread_and_two() {
        let two = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .expect("pool");
        // Block edges and a last block of one column.
        for n in [1usize, 2, 63, 64, 65, 129, 300, 641] {
            let k = spd(n);
            let mut reference = k.clone();
            faer_llt(reference.as_mut(), Par::Seq, &mut faer_scratch(n));
            let mut one = k.clone();
            cholesky_in_pieces(one.as_mut(), Par::Seq).expect("positive definite");
            let mut both_threads = k.clone();
            two.install(|| cholesky_in_pieces(both_threads.as_mut(), Par::rayon(2)))
                .expect("positive definite");
            for j in 0..n {
                for i in j..n {
                    let scale = reference[(j, j)].abs().max(1.0);
                    assert!(
                        (one[(i, j)] - reference[(i, j)]).abs() <= 1e-12 * scale,
                        "N = {n}, ({i}, {j}): {} against faer's {}",
                        one[(i, j)],
                        reference[(i, j)]
                    );
                    assert_eq!(one[(i, j)].to_bits(), both_threads[(i, j)].to_bits());
                }
            }
        }
    }

    #[test]
    fn a_matrix_that_is_not_positive_definite_is_refused_in_any_block() {
        for (n, bad) in [(10usize, 3usize), (300, 5), (300, 200), (600, 599)] {
            let mut k = spd(n);
            k[(bad, bad)] = -1.0;
            assert!(
                cholesky_in_pieces(k.as_mut(), Par::Seq).is_err(),
                "N = {n}, {bad}"
            );
        }
    }

    #[test]
    fn the_halved_solve_gives_the_whole_solve_bit_for_bit() {
        let two = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .expect("pool");
        let n = 300;
        let mut l = spd(n);
        cholesky_in_pieces(l.as_mut(), Par::Seq).expect("positive definite");
        for d in [1usize, 2, 3, 4, 5, 14, 18] {
            let y = Mat::from_fn(n, d, |i, j| ((i * 7 + j * 13) as f64).sin());
            let mut whole = y.clone();
            solve_in_pieces(l.as_ref(), whole.as_mut(), Par::Seq);
            let mut halves = y.clone();
            two.install(|| solve_in_pieces(l.as_ref(), halves.as_mut(), Par::rayon(2)));
            for j in 0..d {
                for i in 0..n {
                    assert_eq!(whole[(i, j)].to_bits(), halves[(i, j)].to_bits(), "D = {d}");
                }
            }
            // And it solves: L Lᵀ A = Y.
            let lower = Mat::from_fn(n, n, |i, j| if i >= j { l[(i, j)] } else { 0.0 });
            let back = &lower * (lower.transpose() * &whole);
            let worst = (0..d)
                .flat_map(|j| (0..n).map(move |i| (i, j)))
                .map(|(i, j)| (back[(i, j)] - y[(i, j)]).abs())
                .fold(0.0, f64::max);
            assert!(worst < 1e-9, "D = {d}: residual {worst}");
        }
    }

    /// faer's factorisation against the one in pieces, 64 and 128 columns wide, on one and two
    /// threads (profiling aid, no assertion): `cargo test --release -p sgplvm-core --lib
    /// piece_times -- --ignored --nocapture`. The fastest of 60 runs of each.
    #[test]
    #[ignore = "profiling aid: prints times"]
    fn piece_times() {
        use std::time::Instant;
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .expect("pool");
        for n in [256usize, 300, 400, 500, 700, 1000] {
            let k = spd(n);
            let mut l = k.clone();
            let reps = 60;
            let mut time = |what: &str, f: &mut dyn FnMut(&mut Mat<f64>)| {
                let mut best = f64::INFINITY;
                for _ in 0..reps {
                    l.copy_from(&k);
                    let t = Instant::now();
                    f(&mut l);
                    best = best.min(t.elapsed().as_secs_f64());
                }
                println!("N = {n:>4} {what:<24} {:>9.1} us", best * 1e6);
            };
            let mut mem = faer_scratch(n);
            pool.install(|| {
                time("faer, 1 thread", &mut |l| {
                    faer_llt(l.as_mut(), Par::Seq, &mut mem)
                });
                time("faer, 2 threads", &mut |l| {
                    faer_llt(l.as_mut(), Par::rayon(2), &mut mem)
                });
                for bs in [64usize, 128] {
                    time(&format!("pieces {bs}, 1 thread"), &mut |l| {
                        cholesky_blocks(l.as_mut(), Par::Seq, bs).expect("positive definite")
                    });
                }
                for bs in [64usize, 128] {
                    time(&format!("pieces {bs}, 2 threads"), &mut |l| {
                        cholesky_blocks(l.as_mut(), Par::rayon(2), bs).expect("positive definite")
                    });
                }
            });
        }
    }
}
