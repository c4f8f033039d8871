//! One module per subcommand.

pub(crate) mod eval;
pub(crate) mod experiment;
pub(crate) mod objects;
pub(crate) mod predict;
pub(crate) mod scene;
pub(crate) mod shard;
pub(crate) mod synth;
pub(crate) mod train;
mod tuning;
