//! The subcommands' arguments, in one module below the commands, so that the commands that share
//! them (train, its shards and memory plan, and the many-object paths of train, eval and
//! predict) depend on it and not on each other.

pub mod eval;
pub mod method;
pub mod predict;
pub mod train;

pub use eval::EvalArgs;
pub use predict::PredictArgs;
pub use train::{ShardArg, TrainArgs};
