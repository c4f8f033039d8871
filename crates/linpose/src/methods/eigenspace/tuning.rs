//! The eigenspace's tuning constants, each with what it trades and how it was set.

/// Eigenimages the memory plan ([`crate::memory`]) assumes for an eigenspace given an energy
/// fraction instead of a number (the number is known only once fitted). Murase & Nayar used 8 to
/// 20; a set needing more makes the estimate low by 24 bytes per point and eigenimage beyond it.
/// Not tuned.
pub(crate) const ENERGY_COMPONENTS: usize = 40;
