//! Reading query images in batches and reporting the ones that have no estimate (unreadable,
//! the wrong size, refused by the model's normalisation or by the model): what `predict` and
//! `eval` do for one model and for many objects alike. One such image never costs the others
//! their estimates ([`each_row`]); each is named with its reason, and the exit status says that
//! some were refused ([`SomeRefused`]).

pub(crate) use crate::tuning::BATCH;
use linpose::image_io::{read_query, QueryImage};
use std::ops::Range;
use std::path::Path;

/// Refused images listed by name on the terminal; the JSON has them all.
const REFUSED_SHOWN: usize = 5;

/// Prints how many of the evaluated images have no estimate (`count`, none: nothing) and the first [`REFUSED_SHOWN`] of `lines` (one per image, its name and why).
pub(crate) fn print_refused(count: usize, lines: impl Iterator<Item = String>) {
    if count == 0 {
        return;
    }
    println!("{count} images refused, with no estimate (not in the figures below):");
    for l in lines.take(REFUSED_SHOWN) {
        println!("  {l}");
    }
    if count > REFUSED_SHOWN {
        println!("  ... and {} more (all in the JSON's \"rejected\")", count - REFUSED_SHOWN);
    }
}

/// Why an image the model's normalisation stage refused has no estimate.
pub(crate) fn cannot_normalise(reason: &linpose::normalize::Rejection) -> String {
    format!("cannot normalise: {reason}")
}

/// Names an image that has no estimate, with the reason, on stderr (above the progress bar).
pub(crate) fn report_refused(bar: &indicatif::ProgressBar, path: &Path, reason: &str) {
    bar.suspend(|| eprintln!("linpose: {}: refused: {reason}", path.display()));
}

/// Some images had no estimate, each named on its own line, and every other image (at least
/// one) was estimated: `linpose` exits with status [`SomeRefused::EXIT_CODE`].
#[derive(Debug)]
pub(crate) struct SomeRefused {
    /// Images with no estimate.
    pub refused: usize,
    /// Images given.
    pub total: usize,
}

impl SomeRefused {
    /// The exit status of a run in which some images were refused and the others estimated
    /// (1 is an error that stopped the command; 2 a command line clap refused).
    pub(crate) const EXIT_CODE: u8 = 3;
}

impl std::fmt::Display for SomeRefused {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} of {} images have no estimate (each named above with its reason); every other image was estimated", self.refused, self.total)
    }
}

impl std::error::Error for SomeRefused {}

/// The end of a `predict` or `eval` of `total` images of which `refused` had no estimate (each
/// named by [`report_refused`]): [`SomeRefused`] when any had, so the exit status says so.
/// When every image was refused, nothing was estimated: an error (status 1) like any other.
pub(crate) fn refusals(refused: usize, total: usize) -> anyhow::Result<()> {
    if refused > 0 && refused == total {
        anyhow::bail!("none of the {total} images has an estimate (each named above with its reason)");
    }
    if refused > 0 {
        return Err(SomeRefused { refused, total }.into());
    }
    Ok(())
}

/// Why a query image has no estimate, from the library's error: the reason alone where the error
/// is about a query of a batch (the caller names the file), else the whole message (which names
/// the file itself).
pub(crate) fn refusal_reason(e: &linpose::Error) -> String {
    match e {
        linpose::Error::InvalidParameter { name: "query", reason, .. } => reason.clone(),
        linpose::Error::Normalize { reason, .. } => cannot_normalise(reason),
        e => e.to_string(),
    }
}

/// [`refusal_reason`] of an error reading the image at `path`, without the path it begins with
/// (the caller names the file).
pub(crate) fn read_refusal(path: &Path, e: &linpose::Error) -> String {
    let why = refusal_reason(e);
    match why.strip_prefix(&format!("{}: ", path.display())) {
        Some(rest) => rest.to_string(),
        None => why,
    }
}

/// `estimate(rows)` over rows `0..n` as one batch; where the batch fails, over each row alone, so
/// that one unusable image leaves the others estimated with the numbers they have in a batch
/// without it (a query's estimate does not depend on the other queries of its batch). A row
/// that fails alone gets the reason of its error ([`refusal_reason`]).
pub(crate) fn each_row<T>(n: usize, estimate: impl Fn(Range<usize>) -> linpose::Result<Vec<T>>) -> Vec<Result<T, String>> {
    match estimate(0..n) {
        Ok(v) => v.into_iter().map(Ok).collect(),
        Err(_) => (0..n)
            .map(|i| match estimate(i..i + 1) {
                Ok(mut v) if v.len() == 1 => Ok(v.remove(0)),
                Ok(v) => Err(format!("the model gave {} estimates for one image", v.len())),
                Err(e) => Err(refusal_reason(&e)),
            })
            .collect(),
    }
}

/// Moves the rows of `rows` (`m` values each) listed in `keep` (increasing) to the front, in
/// that order.
pub(crate) fn compact<T: Copy>(rows: &mut [T], m: usize, keep: &[usize]) {
    for (k, &i) in keep.iter().enumerate() {
        if k != i {
            rows.copy_within(i * m..(i + 1) * m, k * m);
        }
    }
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

/// Where `predict` writes its estimates: standard output, or (`--out FILE`) a temporary file
/// beside FILE, `.NAME.tmp-PID` as the library's atomic writes name theirs, renamed to FILE by
/// [`Output::finish`] once complete. Dropped unfinished (an error, `--strict`), the temporary is
/// removed and FILE keeps what it held; killed, the hidden temporary is left for the next write
/// to remove.
pub(crate) struct Output {
    w: Box<dyn std::io::Write>,
    file: Option<(std::path::PathBuf, std::path::PathBuf)>,
}

impl Output {
    /// Standard output, or a temporary beside `path`.
    pub(crate) fn open(path: Option<&Path>) -> anyhow::Result<Self> {
        let Some(path) = path else {
            return Ok(Output { w: Box::new(std::io::BufWriter::new(std::io::stdout().lock())), file: None });
        };
        crate::common::check_output_file(path, "estimates")?;
        let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        let tmp = path.with_file_name(format!(".{name}.tmp-{}", std::process::id()));
        let f = std::fs::File::create(&tmp).map_err(|e| anyhow::anyhow!("{}: cannot write: {e}", path.display()))?;
        Ok(Output { w: Box::new(std::io::BufWriter::new(f)), file: Some((path.to_path_buf(), tmp)) })
    }

    /// Flushes; with a file, syncs it and renames it into place.
    pub(crate) fn finish(mut self) -> anyhow::Result<()> {
        self.w.flush()?;
        if let Some((path, tmp)) = self.file.take() {
            // The writer closes the file before it is synced by name and renamed.
            self.w = Box::new(std::io::sink());
            let done = std::fs::File::open(&tmp).and_then(|f| f.sync_all()).and_then(|_| std::fs::rename(&tmp, &path));
            if let Err(e) = done {
                let _ = std::fs::remove_file(&tmp);
                anyhow::bail!("{}: cannot write: {e}", path.display());
            }
            linpose::atomic::remove_stale_temps(&path);
        }
        Ok(())
    }
}

impl std::io::Write for Output {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.w.write(buf)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.w.flush()
    }
}

impl Drop for Output {
    fn drop(&mut self) {
        if let Some((_, tmp)) = self.file.take() {
            self.w = Box::new(std::io::sink());
            let _ = std::fs::remove_file(tmp);
        }
    }
}

/// Why each image of `manifest` cannot be read as a query of size `spec` (unreadable, damaged,
/// another size), `None` for each one that can: decoded in parallel, for `eval` to count the
/// unreadable ones apart.
pub(crate) fn unreadable(manifest: &linpose::Manifest, spec: linpose::image_io::ImageSpec) -> Vec<Option<String>> {
    use rayon::prelude::*;
    (0..manifest.len())
        .into_par_iter()
        .map(|i| {
            let path = manifest.image_path(i);
            read_query(&path, spec, "the size of the model's training images").err().map(|e| read_refusal(&path, &e))
        })
        .collect()
}
