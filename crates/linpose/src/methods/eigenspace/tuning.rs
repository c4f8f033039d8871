//! The eigenspace's tuning constants, each with what it trades and how it was set: its search,
//! and what the memory plan ([`crate::memory`]) assumes of it.

/// Manifold size from which `Auto` search uses the k-d tree (brute force below it, and whenever
/// L exceeds the tree's largest dimension). What it trades: the tree's fixed cost per query
/// against brute force's cost per point. Measured with benches/eigen_search.rs (one thread,
/// points on a smooth curve or sheet, queries near it, as appearance manifolds and their queries
/// are; 2026-11-22): brute force costs about 0.0095 us x points x L / 20 and wins at 32 points
/// on the 8-D sheet only (0.09 against 0.13 us); from 64 points on the tree wins everywhere
/// (0.12-0.18 against 0.18-0.99 us).
pub(crate) const AUTO_TREE_FROM: usize = 64;

/// Eigenimages the memory plan ([`crate::memory`]) assumes for an eigenspace given an energy
/// fraction instead of a number (the number is known only once fitted). Murase & Nayar used 8 to
/// 20; a set needing more makes the estimate low by 24 bytes per point and eigenimage beyond it.
/// Not tuned.
pub(crate) const ENERGY_COMPONENTS: usize = 40;
