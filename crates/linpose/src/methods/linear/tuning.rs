//! The linear model's tuning constants, each with what it trades and how it was set: its
//! leave-one-out spread, and what its fit costs in memory for the memory plan ([`crate::memory`],
//! whose documentation tables the measurements).

/// Most training rows whose leave-one-out residuals measure the pairs' spread
/// (`GramSystem::pair_spread`): each costs a solve with the Gram matrix's factor (N^2), so the
/// spread costs at most 256 N^2 beside the fit's N^3 / 3. The RMS of 256 residuals is within
/// about 5% (one standard error) of that of all. Not tuned.
pub(crate) const LOO_SAMPLE: usize = 256;

/// Bytes per N^2 of the linear model's in-memory fit: G (f64 N x N), G + lambda I (a copy) and
/// its Cholesky factor (another): 3 x 8, all alive while the factor is made. Read from the code;
/// measured 24.5 N^2 at N = 2,880 to 11,160 (16 x 12 images, where N^2 dominates).
pub(crate) const GRAM_SYSTEM_BYTES: f64 = 24.0;

/// Bytes per N^2 of the linear model with `ridge auto` (leave-one-out): G, its
/// eigendecomposition (the eigenvectors and faer's workspace) and the eigenvectors squared.
/// Measured 33 N^2 (N = 5,760), 35 (2,880) and 41 (1,440, where the heap's spare N x N matrix,
/// `crate::huge::HEAP_MATRIX_BYTES`, makes up the difference): 38, so that the larger sets,
/// which matter, are not overstated by more than about 20%.
pub(crate) const LOO_SYSTEM_BYTES: f64 = 38.0;
