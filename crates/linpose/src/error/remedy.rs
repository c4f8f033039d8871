//! What would make a training run fit the memory there is ([`Remedy`]), as
//! [`Error::NotEnoughMemory`](super::Error::NotEnoughMemory) reports it; the memory planner
//! (`crate::memory`) finds them.

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

/// Remedies in one phrase, "; " between them ([`Error::NotEnoughMemory`](crate::Error::NotEnoughMemory)'s text).
pub(crate) fn remedies_text(remedies: &[Remedy]) -> String {
    if remedies.is_empty() {
        return "nothing short of more memory".into();
    }
    remedies.iter().map(Remedy::to_string).collect::<Vec<_>>().join("; ")
}

/// Bytes for people: `512 B`, `3.4 KiB`, `81.2 GiB` (one decimal from KiB up).
pub fn format_bytes(bytes: u64) -> String {
    const UNITS: [&str; 5] = ["KiB", "MiB", "GiB", "TiB", "PiB"];
    if bytes < 1024 {
        return format!("{bytes} B");
    }
    let mut v = bytes as f64 / 1024.0;
    let mut unit = 0;
    while v >= 1024.0 && unit + 1 < UNITS.len() {
        v /= 1024.0;
        unit += 1;
    }
    format!("{v:.1} {}", UNITS[unit])
}
