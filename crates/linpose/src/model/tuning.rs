//! The constants of what every fit's N x N system costs in memory ([`super::footprint::system`]),
//! which the memory plan ([`crate::memory`], whose documentation tables the measurements) adds
//! up for each method and recogniser: what each trades and how its value was set.

/// Bytes per training row beside the N x N matrices: the factorisation's scratch and the
/// leave-one-out spread's solve with up to 256 unit columns (N x 256 f64, twice). Measured: the
/// linear fits at N = 5,760 and 11,160 sit 1.2 KiB per row above 24 N^2.
pub(crate) const ROW_BYTES: f64 = 2048.0;

/// glibc's largest mmap threshold (see [`crate::huge::HEAP_MATRIX_BYTES`]).
pub(crate) use crate::huge::HEAP_MATRIX_BYTES;
