//! The thread pool the core computes on: rayon's, rebuilt after `fork()`.
//!
//! A forked child inherits a copy of a rayon pool's bookkeeping but none of its threads, so
//! work handed to an inherited pool waits forever — Python's `multiprocessing` with the `fork`
//! start method hung in the first evaluation of a child. This pool remembers the process that
//! built it and is rebuilt in a child. faer only parallelises on this pool's threads
//! ([`par_for`]); everywhere else the core runs sequentially.

use std::sync::{Arc, Mutex, MutexGuard};

use faer::Par;
use rayon::ThreadPool;

use crate::simd::clear_upper_simd_state;

/// Sizes from which faer's rayon parallelism is used by [`par_for`] and by spaces evaluated side
/// by side (below it, sequential code was faster on the 2-core machine the project is developed
/// on: a 300×300 Cholesky takes 0.34 ms on one thread). A space evaluated alone uses
/// [`ALONE_PARALLEL_FROM`].
pub(crate) const PARALLEL_FROM: usize = 700;

/// Sizes from which a space evaluated alone (a transfer, the input map's regression) spreads
/// every step of its evaluation over the pool's threads, and from which any space spreads its
/// kernel matrix and its factor's inverse over threads to spare. A space alone on two threads
/// measured faster than on one from here: by 3 % at 256 points, 5 % at 300, 12 % at 450 and
/// 16–18 % at 500–680 (`step_times`, quiet), though faer's parallel Cholesky alone is slower at
/// 300 points: the second thread, kept busy, is not put to sleep and woken between steps. Below
/// [`PARALLEL_FROM`] the factorisation and the solve are cut in pieces of their own
/// ([`crate::factor`]), which two threads share better than faer's.
pub(crate) const ALONE_PARALLEL_FROM: usize = 256;

/// Runs `a` and `b`, side by side when `par` has more than one thread and one after the other
/// otherwise, and clears the upper SIMD state on each thread after them: a piece may run faer's
/// AVX-512 kernels, which leave it dirty (see [`clear_upper_simd_state`]).
pub(crate) fn both(par: Par, a: impl FnOnce() + Send, b: impl FnOnce() + Send) {
    match par {
        Par::Rayon(t) if t.get() > 1 => {
            rayon::join(
                || {
                    a();
                    clear_upper_simd_state()
                },
                || {
                    b();
                    clear_upper_simd_state()
                },
            );
        }
        _ => {
            a();
            b();
            clear_upper_simd_state();
        }
    }
}

/// The faer parallelism used for an `n`×`n` problem: rayon's from [`PARALLEL_FROM`] points, and
/// only on a pool thread (see [`crate::pool`]), sequential everywhere else.
pub(crate) fn par_for(n: usize) -> Par {
    shared(n, PARALLEL_FROM, 1)
}

/// [`par_for`] for one of `alongside` evaluations running side by side on the pool: they
/// share its threads. An evaluation alone is parallel from [`ALONE_PARALLEL_FROM`] points.
pub(crate) fn par_space(n: usize, alongside: usize) -> Par {
    let from = if alongside <= 1 {
        ALONE_PARALLEL_FROM
    } else {
        PARALLEL_FROM
    };
    shared(n, from, alongside)
}

/// The parallelism of an evaluation's kernel matrix and factor inverse: from
/// [`ALONE_PARALLEL_FROM`] points whenever each of the `alongside` evaluations gets two threads
/// or more. For a space alone this is [`par_space`]; it differs only for spaces side by side on
/// a pool of four threads or more, whose other steps wait for [`PARALLEL_FROM`].
pub(crate) fn par_alone_for(n: usize, alongside: usize) -> Par {
    shared(n, ALONE_PARALLEL_FROM, alongside)
}

/// Rayon's parallelism over the pool's threads shared among `alongside` tasks, from `from`
/// points and on a pool thread; sequential when that leaves fewer than two threads each (nested
/// parallelism then only adds hand-offs). faer's parallel factorisation, solves, inverse and
/// products give the sequential results bit for bit here (a test in `likelihood` pins it), so
/// this choice changes only the time.
fn shared(n: usize, from: usize, alongside: usize) -> Par {
    // Off the pool `current_num_threads` would start rayon's global pool: ask on it only.
    if n < from || !on_pool_thread() {
        return Par::Seq;
    }
    match rayon::current_num_threads() / alongside.max(1) {
        threads @ 2.. => Par::rayon(threads),
        _ => Par::Seq,
    }
}

/// The pool and the id of the process that built it.
static POOL: Mutex<Option<(u32, Arc<ThreadPool>)>> = Mutex::new(None);

/// The pool of this process (built on first use; `RAYON_NUM_THREADS` sets its size). `None`
/// when no thread can be started, and the caller then computes on its own thread.
fn pool() -> Option<Arc<ThreadPool>> {
    let pid = std::process::id();
    let mut guard = lock(&POOL);
    if let Some((owner, pool)) = guard.as_ref() {
        if *owner == pid {
            return Some(Arc::clone(pool));
        }
    }
    if let Some((_, inherited)) = guard.take() {
        // Its threads live in the parent process: dropping it would wait on threads that do
        // not exist here.
        std::mem::forget(inherited);
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .thread_name(|i| format!("sgplvm-{i}"))
        .build()
        .ok()
        .map(Arc::new)?;
    *guard = Some((pid, Arc::clone(&pool)));
    Some(pool)
}

/// Locks a mutex, also after a panic on another thread: what the core keeps behind its mutexes
/// (buffers, caches, the pool) holds no invariant that a panic could break.
pub(crate) fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    match m.lock() {
        Ok(g) => g,
        Err(p) => p.into_inner(),
    }
}

/// Runs `f` on one of the pool's threads, where [`on_pool_thread`] holds and parallel work may
/// be spread over the pool; on the calling thread if there is no pool.
pub(crate) fn in_pool<R: Send>(f: impl FnOnce() -> R + Send) -> R {
    match pool() {
        Some(p) => p.install(f),
        None => f(),
    }
}

/// True on a thread of a rayon pool (ours inside [`in_pool`]): only there may faer or a
/// parallel iterator spread work without touching rayon's fork-unsafe global pool.
pub(crate) fn on_pool_thread() -> bool {
    rayon::current_thread_index().is_some()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn work_runs_on_a_pool_thread_and_only_there() {
        assert!(!on_pool_thread());
        assert!(in_pool(on_pool_thread) || pool().is_none());
        // The same pool is reused within a process.
        let (a, b) = (pool(), pool());
        if let (Some(a), Some(b)) = (a, b) {
            assert!(Arc::ptr_eq(&a, &b));
        }
    }
}
