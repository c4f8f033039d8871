//! The tuning constants of the model layer, each with what it trades and how it was set: when a
//! batch of queries is split across threads ([`super::split`], whose module doc says what the
//! split trades and how it was measured), and what every fit's N x N system costs in memory
//! ([`super::footprint::system`]), which the memory plan ([`crate::memory`], whose documentation
//! tables the measurements) adds up for each method and recogniser.

/// Query pixels (images x pixels per image) from which an 8-bit batch is split across threads.
/// 1.2 million: 72 COIL-20 images of 128 x 128 (1.18 million) run on the calling thread. Measured,
/// not derived: BENCHMARKS.md ("Small batches") has the batch sizes, times and the command
/// (`benches/split_timing.rs`, which compares both sides at every size with the environment
/// variable `LINPOSE_SPLIT_FROM_PIXELS=0`: every batch split).
pub(crate) const SPLIT_FROM_PIXELS: usize = 1_200_000;

/// Queries from which a batch's second look (`second_look`) is split across threads.
/// A second look costs 12-90 us a query (COIL-20 to the paper's grid, BENCHMARKS.md), so 8 of
/// them are more work than the 72 COIL-20 images (about 0.08 ms of the linear model's products)
/// at which [`SPLIT_FROM_PIXELS`] starts splitting: the same amount of work, not the same pixels.
/// Measured on COIL-20 object 1 (BENCHMARKS.md, "Small batches", `bench/split_timing.py`, load
/// 1-1.7): a 72-image batch, which the pixel rule keeps whole, took 0.91 -> 0.64 ms
/// (eigenspace) and 0.74 -> 0.46 ms (refined) with its second look split; at 8 images the split
/// costs the eigenspace 0.10 -> 0.11 ms, at 16 it pays (0.20 -> 0.19, refined 0.15 -> 0.12).
pub(crate) const LOOK_SPLIT_FROM: usize = 8;

/// Bytes per training row beside the N x N matrices: the factorisation's scratch and the
/// leave-one-out spread's solve with up to 256 unit columns (N x 256 f64, twice). Measured: the
/// linear fits at N = 5,760 and 11,160 sit 1.2 KiB per row above 24 N^2.
pub(crate) const ROW_BYTES: f64 = 2048.0;

/// glibc's largest mmap threshold (see [`crate::huge::HEAP_MATRIX_BYTES`]).
pub(crate) use crate::huge::HEAP_MATRIX_BYTES;
