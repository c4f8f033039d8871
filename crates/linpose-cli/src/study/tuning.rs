//! The study's tuning constants: for each, what it trades and how its value was set.

/// The largest share of accuracy on registered views the normalisation stage may cost and still
/// be recommended (0.10: the normalised unseen mean at most 1.1 times the plain one). What it
/// trades: a larger share recommends the stage where it costs more on registered views. Not
/// tuned: the bar issue 33 set, a cost a user who needs unregistered queries would accept.
pub(crate) const REGISTERED_COST: f64 = 0.10;
