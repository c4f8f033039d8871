//! When no path fits: what would, with the numbers ([`Remedy`](crate::error::Remedy)), found by searching the
//! estimates for the most images and the largest images that fit, and the settings that would
//! let the fit stream; and the error that says so ([`Error::NotEnoughMemory`]).

use super::{estimate, format_bytes, Blocker, Estimate, Job, Limit, Path, Plan, USABLE_FRACTION};
use crate::error::{Remedy, StreamChange};
use crate::Error;

/// The error of a plan whose chosen path does not fit: what each path needs, and the remedies.
pub(super) fn not_enough(job: &Job, plan: &Plan, blocker: Option<Blocker>) -> Error {
    let usable = plan.limit.usable().unwrap_or(u64::MAX);
    let force = plan.forced.then_some(plan.path);
    let size = |e: &Estimate| format!("{} ({})", format_bytes(e.bytes), e.what);
    let limit = plan.limit.describe();
    let needs = match (force, &plan.streamed, &blocker) {
        (Some(path), _, _) => format!("{} (as asked) needs {}, more than {limit}", path.name(), size(plan.chosen())),
        (None, Some(s), _) => format!("in memory needs {} and streamed needs {}, both more than {limit}", size(&plan.in_memory), size(s)),
        (None, None, b) => {
            let why = b.as_ref().map(|b| format!("; not streamed: {}", b.reason(job))).unwrap_or_default();
            format!("in memory needs {}, more than {limit}{why}", size(&plan.in_memory))
        }
    };
    // The least any allowed path needs, for a job.
    let least = |j: &Job| -> u64 {
        let mem = (force != Some(Path::Streamed)).then(|| estimate::in_memory(j).bytes);
        let st = (force != Some(Path::InMemory) && j.stream_blocker().is_none()).then(|| estimate::streamed(j).bytes);
        mem.into_iter().chain(st).min().unwrap_or(u64::MAX)
    };
    let mut remedies = Vec::new();
    if let Some(n) = largest(job.n, |n| least(&job.with_n(n)) <= usable) {
        remedies.push(Remedy::FewerImages { at_most: n, shards: job.n.div_ceil(n) });
    }
    if let Some(m) = largest(job.m, |m| least(&Job { m, ..job.clone() }) <= usable) {
        remedies.push(Remedy::SmallerImages { at_most: m });
    }
    if let (Some(b), None | Some(Path::Streamed)) = (&blocker, force) {
        if let Some(j) = job.unblocked(b) {
            let bytes = estimate::streamed(&j).bytes;
            let change = match b {
                Blocker::Setting(s) => s.change,
                _ => StreamChange::NoNormalization,
            };
            if bytes <= usable {
                remedies.push(Remedy::Stream { change, bytes });
            }
        }
    }
    let bytes = least(job);
    let (bytes, budget) = match plan.limit {
        Limit::Available(_) => ((bytes as f64 / USABLE_FRACTION).ceil() as u64, false),
        _ => (bytes, true),
    };
    remedies.push(Remedy::MoreMemory { bytes, budget });
    Error::NotEnoughMemory { needs, remedies }
}

/// The largest value in `1..below` for which `fits` holds (`fits` monotone: true up to some
/// value, false beyond); None when it fails for 1.
fn largest(below: usize, fits: impl Fn(usize) -> bool) -> Option<usize> {
    if below <= 1 || !fits(1) {
        return None;
    }
    let (mut lo, mut hi) = (1, below); // fits(lo), and hi is not known to fit
    while hi - lo > 1 {
        let mid = lo + (hi - lo) / 2;
        if fits(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Some(lo)
}
