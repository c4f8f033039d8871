//! The subcommands' arguments, in one module below the commands, so that the commands that share
//! them (train, its shards and memory plan, and the many-object paths of train, eval and
//! predict) depend on it and not on each other.

pub(crate) mod eval;
pub(crate) mod method;
pub(crate) mod predict;
pub(crate) mod train;

pub(crate) use eval::EvalArgs;
pub(crate) use predict::PredictArgs;
pub(crate) use train::{ShardArg, TrainArgs};
