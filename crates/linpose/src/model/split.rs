//! When a batch of 8-bit queries is worth splitting across rayon's threads.
//!
//! A parallel iterator called from outside rayon's pool (the command line's main thread, a
//! Python thread, any caller's own thread) hands the batch to a worker, wakes it (and the second
//! worker when the batch splits) and sleeps until the last task is done, which wakes the caller
//! again: four context switches a call, whatever the batch. On the 2-core machine of
//! BENCHMARKS.md (a virtual machine, where waking a thread whose core sits idle is slow) that
//! round trip costs about 10 us, and on a 72-image COIL-20 batch (0.09-0.25 ms on one thread)
//! the second worker often wakes too late to take a share. A batch smaller than
//! [`SPLIT_FROM_PIXELS`] therefore runs whole on the calling thread (no pool, no switches); a
//! larger one is split as before, each task at least half that size. The linear model's, the
//! eigenspace's and the refined eigenspace's 8-bit paths and the second look all follow it.
//!
//! What it trades: below the threshold a batch never uses the second core, which costs up to
//! half its time when both cores are idle and the workers awake; above it, the round trip is
//! small beside the work. The value is measured, not derived: BENCHMARKS.md ("Small batches")
//! has the batch sizes, times and the command (`benches/split_timing.rs`, which compares both
//! sides at every size with the environment variable `LINPOSE_SPLIT_FROM_PIXELS=0`: every
//! batch split, as before this threshold). It is measured for a caller that predicts back to
//! back. After a millisecond idle the workers are asleep, waking them costs that machine
//! 0.06-0.47 ms a split call, and the batches just above the thresholds run slower split than
//! whole (the same section, `--gap`).

pub(crate) use super::tuning::{LOOK_SPLIT_FROM, SPLIT_FROM_PIXELS};
use std::sync::OnceLock;

/// [`SPLIT_FROM_PIXELS`], or the value of `LINPOSE_SPLIT_FROM_PIXELS` where it is set (for
/// measuring; read once).
fn split_from() -> usize {
    static FROM: OnceLock<usize> = OnceLock::new();
    *FROM.get_or_init(|| std::env::var("LINPOSE_SPLIT_FROM_PIXELS").ok().and_then(|v| v.parse().ok()).unwrap_or(SPLIT_FROM_PIXELS))
}

/// Whether a batch of `n` queries of `m` pixels is split across threads.
pub(crate) fn splits(n: usize, m: usize) -> bool {
    n.saturating_mul(m) >= split_from()
}

/// Whether a batch of `n` second looks is split across threads: from [`LOOK_SPLIT_FROM`]
/// queries, or as [`splits`] would where `LINPOSE_SPLIT_FROM_PIXELS` is set (for measuring).
pub(crate) fn look_splits(n: usize, m: usize) -> bool {
    if std::env::var_os("LINPOSE_SPLIT_FROM_PIXELS").is_some() {
        return splits(n, m);
    }
    n >= LOOK_SPLIT_FROM
}

/// The fewest queries of `m` pixels a parallel task takes: half the threshold's pixels.
pub(crate) fn min_task_queries(m: usize) -> usize {
    (split_from() / 2).div_ceil(m.max(1)).max(1)
}

/// Runs `task` over a batch in tasks: `queries` in chunks of `q_len` values beside `out` in chunks
/// of `o_len`, spread over rayon's threads (each thread with its own `init()` state) when
/// `parallel`, else one after the other on the calling thread with one state.
pub(crate) fn for_each_task<Q, O, S>(
    queries: &[Q],
    q_len: usize,
    out: &mut [O],
    o_len: usize,
    parallel: bool,
    init: impl Fn() -> S + Sync + Send,
    task: impl Fn(&mut S, (&[Q], &mut [O])) + Sync + Send,
) where
    Q: Sync,
    O: Send,
{
    use rayon::prelude::*;
    if parallel {
        queries.par_chunks(q_len).zip(out.par_chunks_mut(o_len)).for_each_init(init, task);
    } else {
        let mut s = init();
        queries.chunks(q_len).zip(out.chunks_mut(o_len)).for_each(|c| task(&mut s, c));
    }
}
