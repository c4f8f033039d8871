//! Pieces the subcommands share: data set arguments, progress bars, JSON output.

use anyhow::Context;
use indicatif::{ProgressBar, ProgressStyle};
use linpose::image_io::ColorMode;
use linpose::{Dataset, Manifest};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};

/// Where a data set comes from.
#[derive(clap::Args, Debug, Clone)]
pub(crate) struct DataArgs {
    /// Data set folder: `poses.csv` beside the images, or a COIL folder with --object.
    #[arg(long, value_name = "DIR")]
    pub data: PathBuf,
    /// Read a COIL folder (`objO__K.png` files), object O.
    #[arg(long, value_name = "O")]
    pub object: Option<u32>,
}

/// How images become features.
#[derive(clap::ValueEnum, Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum ColorArg {
    /// Gray (Rec. 601 luma for colour images).
    #[default]
    Gray,
    /// Keep red, green and blue as three features per pixel.
    Rgb,
}

impl From<ColorArg> for ColorMode {
    fn from(c: ColorArg) -> Self {
        match c {
            ColorArg::Gray => ColorMode::Gray,
            ColorArg::Rgb => ColorMode::Rgb,
        }
    }
}

impl DataArgs {
    /// Reads the manifest (no pixels yet).
    pub(crate) fn manifest(&self) -> anyhow::Result<Manifest> {
        Ok(Manifest::open(&self.data, self.object)?)
    }
}

/// Decodes a manifest's images with a progress bar on a terminal.
pub(crate) fn load_dataset(manifest: Manifest, color: ColorMode) -> anyhow::Result<Dataset> {
    let bar = progress(manifest.len() as u64, "decoding images");
    let data = Dataset::load(manifest, color, &|n| bar.inc(n))?;
    bar.finish_and_clear();
    Ok(data)
}

/// A progress bar on stderr when it is a terminal; hidden (and free) otherwise.
pub(crate) fn progress(len: u64, what: &str) -> ProgressBar {
    if !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(len);
    bar.set_style(ProgressStyle::with_template("{msg:>20} [{bar:40}] {pos}/{len} ({eta})").expect("static template").progress_chars("=> "));
    bar.set_message(what.to_string());
    bar
}

/// Writes `value` as pretty JSON to `path`, atomically.
pub(crate) fn write_json(path: &Path, value: &impl serde::Serialize) -> anyhow::Result<()> {
    let mut text = serde_json::to_string_pretty(value).context("serialising JSON")?;
    text.push('\n');
    linpose::atomic::write_atomic(path, text.as_bytes())?;
    Ok(())
}

/// Refuses an output path that is an existing folder, before any work is done.
pub(crate) fn check_output_file(path: &Path, what: &str) -> anyhow::Result<()> {
    if path.is_dir() {
        anyhow::bail!("{}: {what} output path is an existing folder; give a file name", path.display());
    }
    if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
        if !parent.is_dir() {
            anyhow::bail!("{}: the folder for the {what} does not exist", parent.display());
        }
    }
    Ok(())
}
