//! Reading query images in batches and reporting the ones the model's normalisation refuses:
//! what `predict` and `eval` do for one model and for many objects alike.

pub(crate) use crate::tuning::BATCH;
use linpose::image_io::{read_query, QueryImage};
use std::path::Path;

/// Refused images listed by name on the terminal; the JSON has them all.
const REFUSED_SHOWN: usize = 5;

/// Prints how many of the evaluated images the model's normalisation refused (`count`, none:
/// nothing) and the first [`REFUSED_SHOWN`] of `lines` (one per image, its name and why).
pub(crate) fn print_refused(count: usize, lines: impl Iterator<Item = String>) {
    if count == 0 {
        return;
    }
    println!("{count} images refused by the model's normalisation (not in the figures below):");
    for l in lines.take(REFUSED_SHOWN) {
        println!("  {l}");
    }
    if count > REFUSED_SHOWN {
        println!("  ... and {} more (all in the JSON's \"rejected\")", count - REFUSED_SHOWN);
    }
}

/// Names an image the model's normalisation stage refused, with the reason, on stderr.
pub(crate) fn cannot_normalise(bar: &indicatif::ProgressBar, path: &std::path::Path, reason: &linpose::normalize::Rejection) {
    bar.suspend(|| eprintln!("linpose: {}: cannot normalise: {reason}", path.display()));
}

/// The end of a `predict` of `total` images of which `refused` were refused by the stage (each
/// named by [`cannot_normalise`]): an error when any was, so the exit status says so.
pub(crate) fn refusals(refused: usize, total: usize) -> anyhow::Result<()> {
    if refused > 0 {
        anyhow::bail!("{refused} of {total} images could not be normalised (each named above) and have no estimate");
    }
    Ok(())
}

/// The rows of `features` that [`read_one`] left 8-bit (NaN first value) made features from
/// their `pixels` (value / 255), so a batch of mixed images can be estimated on features.
pub(crate) fn eight_bit_as_features(features: &mut [f32], pixels: &[u8], m: usize) {
    for (f, p) in features.chunks_exact_mut(m).zip(pixels.chunks_exact(m)) {
        if f[0].is_nan() {
            f.iter_mut().zip(p).for_each(|(f, &v)| *f = v as f32 * (1.0 / 255.0));
        }
    }
}

/// Decodes one image into `pixels` (8-bit gray, returning true) or else `features` (returning
/// false; `features[0]` is NaN after an 8-bit image, marking the row to convert if needed).
pub(crate) fn read_one(path: &Path, spec: linpose::image_io::ImageSpec, context: &str, features: &mut [f32], pixels: &mut [u8]) -> linpose::Result<bool> {
    match read_query(path, spec, context)? {
        QueryImage::Gray8(v) => {
            pixels.copy_from_slice(&v);
            features[0] = f32::NAN;
            Ok(true)
        }
        QueryImage::Features(f) => {
            features.copy_from_slice(&f);
            Ok(false)
        }
    }
}
