//! One module per subcommand.

pub mod eval;
pub mod experiment;
pub mod objects;
pub mod predict;
pub mod shard;
pub mod synth;
pub mod train;
