//! `linpose predict`'s arguments.

use std::path::PathBuf;

/// Arguments of `linpose predict`.
#[derive(clap::Args, Debug)]
pub(crate) struct PredictArgs {
    /// The model file.
    #[arg(long, value_name = "MODEL")]
    pub model: PathBuf,
    /// Images (PNG, PGM, PPM, JPEG, TIFF), or folders whose images are all estimated (their
    /// .png, .pgm, .ppm, .pnm, .jpg, .jpeg, .tif and .tiff files, sorted by name).
    #[arg(value_name = "IMAGE", required_unless_present = "list")]
    pub images: Vec<PathBuf>,
    /// Also estimate the images listed in FILE, one path per line (for more paths than a
    /// command line holds).
    #[arg(long, value_name = "FILE")]
    pub list: Option<PathBuf>,
    /// Print one JSON object per image instead of text.
    #[arg(long)]
    pub json: bool,
    /// Also give the K best distinct poses the model considered, with their scores (each one's
    /// probability of being right, as the model judges it) and the estimate's confidence; an
    /// estimate whose confidence is under --flag-below is marked FLAGGED.
    #[arg(long, value_name = "K", value_parser = clap::value_parser!(u64).range(1..=8))]
    pub top: Option<u64>,
    /// The confidence under which an estimate is flagged (with --top).
    #[arg(long, value_name = "C", default_value_t = linpose::confidence::FLAG_BELOW, requires = "top")]
    pub flag_below: f64,
    /// Stop at the first image that cannot be estimated (unreadable, the wrong size, all black,
    /// refused by the model's normalisation), with an error naming it, instead of estimating
    /// every other image and naming each refused one.
    #[arg(long)]
    pub strict: bool,
    /// Write the estimates to FILE instead of standard output, atomically: FILE is the previous
    /// one or the complete new one, never a part, whatever stops the run.
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
}
