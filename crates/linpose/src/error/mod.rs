//! The library's one error type.
//!
//! Every error a user can cause - a file, an image, a label, a model, a parameter - names the thing
//! at fault (path, line, value) so the message alone tells what to fix.

mod rejection;
mod remedy;

pub use rejection::Rejection;
pub(crate) use remedy::remedies_text;
pub use remedy::{format_bytes, Remedy, StreamChange};
use std::path::PathBuf;

/// Result alias used throughout linpose.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Everything that can go wrong in linpose.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// Reading or writing a file failed.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying I/O error.
        #[source]
        source: std::io::Error,
    },
    /// An image could not be decoded.
    #[error("{path}: cannot decode image: {reason}")]
    ImageDecode {
        /// The image file.
        path: PathBuf,
        /// What the decoder said.
        reason: String,
    },
    /// An image has a different size from the rest of the data set or from the model.
    #[error("{path}: image is {got_w}x{got_h} but {expected_w}x{expected_h} was expected ({context})")]
    ImageSizeMismatch {
        /// The image file.
        path: PathBuf,
        /// Expected width.
        expected_w: u32,
        /// Expected height.
        expected_h: u32,
        /// Actual width.
        got_w: u32,
        /// Actual height.
        got_h: u32,
        /// Where the expectation comes from (the data set's first image, the model).
        context: String,
    },
    /// An image is refused before decoding because it would need absurd memory.
    #[error("{path}: image of {width}x{height} pixels exceeds the limit of {limit} pixels")]
    ImageTooLarge {
        /// The image file.
        path: PathBuf,
        /// Declared width.
        width: u32,
        /// Declared height.
        height: u32,
        /// The pixel limit.
        limit: u64,
    },
    /// A manifest (poses.csv) or configuration file is malformed.
    #[error("{path}:{line}: {message}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// 1-based line number (0 when the whole file is at fault).
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// A data set is unusable as a whole (empty, no matching files, inconsistent). A data set in
    /// memory has an empty path, and its message stands alone.
    #[error("{}{message}", located(path))]
    Dataset {
        /// The data set folder or manifest.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// The Gram matrix of the training images is singular or numerically so.
    #[error("the training images' Gram matrix is singular ({detail}); {hint}")]
    SingularGram {
        /// Which pivot or pair of images shows it.
        detail: String,
        /// The likely cause and the remedy.
        hint: String,
    },
    /// A parameter of an estimator, the renderer or an evaluation is out of range.
    #[error("invalid {name} = {value}: {reason}")]
    InvalidParameter {
        /// The parameter's name.
        name: &'static str,
        /// The offending value, as given.
        value: String,
        /// Why it is refused.
        reason: String,
    },
    /// A method's setting given by name ([`crate::Settings`]) is unknown to the method or cannot
    /// be read.
    #[error("setting {name} = '{value}' of the {method} method: {reason}")]
    Setting {
        /// The method's name.
        method: &'static str,
        /// The setting's name.
        name: String,
        /// Its value, as given.
        value: String,
        /// Why it is refused.
        reason: String,
    },
    /// A model file is not a linpose model, is damaged, or comes from another format version.
    #[error("{path}: {message}")]
    ModelFile {
        /// The model file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// Partial training statistics that cannot be made, merged or finished: a file or shard
    /// named, and what is wrong (another image size, other settings, shards missing or twice).
    #[error("{source_name}: {message}")]
    Partial {
        /// The partial statistics' file, or the shard.
        source_name: String,
        /// What is wrong.
        message: String,
    },
    /// A query does not fit the model (wrong number of features).
    #[error("query has {got} features but the model expects {expected} ({context})")]
    FeatureMismatch {
        /// Features the model expects.
        expected: usize,
        /// Features the query has.
        got: usize,
        /// What the query is.
        context: String,
    },
    /// A mesh file is unusable.
    #[error("{path}: {message}")]
    Mesh {
        /// The mesh file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// An image the normalisation stage cannot normalise ([`crate::normalize`]).
    #[error("{image}: cannot normalise: {reason}")]
    Normalize {
        /// The image (a file, or a query's place in its batch).
        image: String,
        /// Why.
        reason: Rejection,
    },
    /// A numerical routine failed to converge or met a non-finite value.
    #[error("numerical failure: {0}")]
    Numerical(String),
    /// No way of training fits the memory there is ([`crate::memory`]): said before any large
    /// allocation, with what each way needs and what would help.
    #[error("not enough memory to train: {needs}; what would help: {}", remedies_text(remedies))]
    NotEnoughMemory {
        /// What each way of training needs against the memory there is, in words.
        needs: String,
        /// What would make it fit, with the numbers.
        remedies: Vec<Remedy>,
    },
}

impl Error {
    /// An I/O error on `path`.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io { path: path.into(), source }
    }

    /// A parse error at `line` of `path`.
    pub fn parse(path: impl Into<PathBuf>, line: usize, message: impl Into<String>) -> Self {
        Error::Parse { path: path.into(), line, message: message.into() }
    }

    /// An invalid parameter value.
    pub fn invalid(name: &'static str, value: impl ToString, reason: impl Into<String>) -> Self {
        Error::InvalidParameter { name, value: value.to_string(), reason: reason.into() }
    }
}

/// `path: ` before a message about the data set at `path`; nothing for a data set in memory
/// (an empty path), whose message then stands alone.
fn located(path: &std::path::Path) -> String {
    if path.as_os_str().is_empty() {
        String::new()
    } else {
        format!("{}: ", path.display())
    }
}
