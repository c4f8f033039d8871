//! The linear model's tuning constants: for each, what it trades and how its value was set.

/// Most training rows whose leave-one-out residuals measure the pairs' spread
/// (`GramSystem::pair_spread`): each costs a solve with the Gram matrix's factor (N^2), so the
/// spread costs at most 256 N^2 beside the fit's N^3 / 3. The RMS of 256 residuals is within
/// about 5% (one standard error) of that of all. Not tuned.
pub(crate) const LOO_SAMPLE: usize = 256;
