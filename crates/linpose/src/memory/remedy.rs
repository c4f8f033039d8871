//! When no path fits: what would, with the numbers ([`Remedy`]), found by searching the
//! estimates for the most images and the largest images that fit, and the settings that would
//! let the fit stream; and the error that says so ([`Error::NotEnoughMemory`]).

use super::{estimate, format_bytes, Blocker, Estimate, Job, Limit, Path, Plan, USABLE_FRACTION};
use crate::Error;

/// What would make a job fit, with the numbers.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum Remedy {
    /// Training on at most `at_most` images (a coarser training step, a shorter list), or the
    /// set split into `shards` shards of at most that many, one model each.
    FewerImages {
        /// Most training images that fit.
        at_most: usize,
        /// Shards of that many the set would take.
        shards: usize,
    },
    /// Images of at most `at_most` features (smaller or binned images).
    SmallerImages {
        /// Most features per image that fit.
        at_most: usize,
    },
    /// More memory: a machine with `bytes` available, or a budget of `bytes`.
    MoreMemory {
        /// Bytes.
        bytes: u64,
        /// Whether that is a budget (the plan was held to one) rather than available memory.
        budget: bool,
    },
    /// A change of settings that lets the fit stream, and what streaming then needs.
    Stream {
        /// The change.
        change: StreamChange,
        /// What the streamed path then needs.
        bytes: u64,
    },
}

/// A change of settings that lets a fit stream.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum StreamChange {
    /// A fixed ridge instead of `ridge auto`.
    FixedRidge,
    /// A fixed ridge instead of the noise-level rule.
    FixedNoiseLevel,
    /// No centring.
    NoCentring,
    /// No normalisation.
    NoNormalization,
}

impl std::fmt::Display for Remedy {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Remedy::FewerImages { at_most, shards } => {
                write!(f, "at most {at_most} training images (a coarser training step; or the set in {shards} shards of that many, a model each)")
            }
            Remedy::SmallerImages { at_most } => write!(f, "images of at most {at_most} features (smaller or binned images)"),
            Remedy::MoreMemory { bytes, budget: true } => write!(f, "a budget of {}", format_bytes(*bytes)),
            Remedy::MoreMemory { bytes, budget: false } => write!(f, "a machine with {} available", format_bytes(*bytes)),
            Remedy::Stream { change, bytes } => {
                let what = match change {
                    StreamChange::FixedRidge => "a fixed ridge instead of ridge auto",
                    StreamChange::FixedNoiseLevel => "a fixed ridge instead of the noise-level rule",
                    StreamChange::NoCentring => "no centring",
                    StreamChange::NoNormalization => "no normalisation",
                };
                write!(f, "{what}, which lets the fit stream in {}", format_bytes(*bytes))
            }
        }
    }
}

/// Remedies in one phrase, "; " between them ([`Error::NotEnoughMemory`]'s text).
pub fn remedies_text(remedies: &[Remedy]) -> String {
    if remedies.is_empty() {
        return "nothing short of more memory".into();
    }
    remedies.iter().map(Remedy::to_string).collect::<Vec<_>>().join("; ")
}

/// The error of a plan whose chosen path does not fit: what each path needs, and the remedies.
pub(super) fn not_enough(job: &Job, plan: &Plan, blocker: Option<Blocker>) -> Error {
    let usable = plan.limit.usable().unwrap_or(u64::MAX);
    let force = plan.forced.then_some(plan.path);
    let size = |e: &Estimate| format!("{} ({})", format_bytes(e.bytes), e.what);
    let limit = plan.limit.describe();
    let needs = match (force, &plan.streamed, blocker) {
        (Some(path), _, _) => format!("{} (as asked) needs {}, more than {limit}", path.name(), size(plan.chosen())),
        (None, Some(s), _) => format!("in memory needs {} and streamed needs {}, both more than {limit}", size(&plan.in_memory), size(s)),
        (None, None, b) => {
            let why = b.map(|b| format!("; not streamed: {}", b.reason(job))).unwrap_or_default();
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
    if let (Some(b), None | Some(Path::Streamed)) = (blocker, force) {
        if let Some(j) = job.unblocked(b) {
            let bytes = estimate::streamed(&j).bytes;
            let change = match b {
                Blocker::RidgeAuto => StreamChange::FixedRidge,
                Blocker::NoiseAuto => StreamChange::FixedNoiseLevel,
                Blocker::Center => StreamChange::NoCentring,
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
