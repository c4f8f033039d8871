//! Atomic file writes: write to a temporary name beside the target, flush, then rename.
//!
//! A reader (or a crash) sees either the old file or the complete new one, never a partial one.
//! A writer killed mid-write leaves its temporary `.NAME.tmp-PID` behind (a hidden name no reader
//! takes for the output); the next successful write of NAME removes those whose process is gone.

use crate::{Error, Result};
use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};

/// The temporary name used while `path` is being written: `.NAME.tmp-PID` in the same folder, so
/// the final rename never crosses a file system.
pub(crate) fn temp_path(path: &Path) -> PathBuf {
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    path.with_file_name(format!(".{name}.tmp-{}", std::process::id()))
}

/// Writes `bytes` to `path` atomically.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    write_atomic_with(path, |f| f.write_all(bytes))
}

/// Writes `path` atomically with a closure that fills the temporary file.
pub(crate) fn write_atomic_with(path: &Path, fill: impl FnOnce(&mut std::io::BufWriter<fs::File>) -> std::io::Result<()>) -> Result<()> {
    if path.is_dir() {
        return Err(Error::io(path, std::io::Error::new(std::io::ErrorKind::IsADirectory, "output path is a directory")));
    }
    let tmp = temp_path(path);
    let result = (|| {
        let file = fs::File::create(&tmp)?;
        let mut w = std::io::BufWriter::new(file);
        fill(&mut w)?;
        let file = w.into_inner().map_err(|e| e.into_error())?;
        file.sync_all()?;
        fs::rename(&tmp, path)
    })();
    if let Err(e) = result {
        let _ = fs::remove_file(&tmp);
        return Err(Error::io(path, e));
    }
    remove_stale_temps(path);
    Ok(())
}

/// Writes the folder `out` atomically: `fill` fills a temporary folder `.NAME.tmp-PID` beside
/// it, which is renamed to `out` once complete and removed on error, so nothing half-written is
/// ever left at `out`. `out` must not exist yet or be an empty folder (refused otherwise, before
/// `fill` runs).
#[cfg(feature = "render")] // used by the renderer and the scenes only
pub(crate) fn write_folder(out: &Path, fill: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    let replace_empty = match fs::metadata(out) {
        Ok(m) if m.is_dir() => {
            let mut entries = fs::read_dir(out).map_err(|e| Error::io(out, e))?;
            if entries.next().is_some() {
                return Err(Error::Dataset {
                    path: out.to_path_buf(),
                    message: "the output folder exists and is not empty; give a new folder (it is created) or an empty one".into(),
                });
            }
            true
        }
        Ok(_) => return Err(Error::Dataset { path: out.to_path_buf(), message: "exists and is not a folder".into() }),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => false,
        Err(e) => return Err(Error::io(out, e)),
    };
    let name = out.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| "dataset".into());
    let tmp = out.with_file_name(format!(".{name}.tmp-{}", std::process::id()));
    if let Some(parent) = tmp.parent().filter(|p| !p.as_os_str().is_empty()) {
        fs::create_dir_all(parent).map_err(|e| Error::io(parent, e))?;
    }
    fs::create_dir(&tmp).map_err(|e| Error::io(&tmp, e))?;
    let result = fill(&tmp).and_then(|()| {
        if replace_empty {
            fs::remove_dir(out).map_err(|e| Error::io(out, e))?;
        }
        fs::rename(&tmp, out).map_err(|e| Error::io(out, e))
    });
    if result.is_err() {
        let _ = fs::remove_dir_all(&tmp);
    } else {
        remove_stale_temps(out);
    }
    result
}

/// Removes what killed writers of `path` left beside it: `.NAME.tmp-PID` (and `.NAME.old-PID`, an
/// old folder moved aside while being replaced), files or folders, whose process PID is no longer
/// running. Only where that can be told (Linux's /proc); elsewhere it does nothing. A PID reused
/// by a live process keeps its leftover, which is harmless.
pub fn remove_stale_temps(path: &Path) {
    #[cfg(target_os = "linux")]
    {
        let Some(name) = path.file_name().and_then(|n| n.to_str()) else { return };
        let dir = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
        let Ok(entries) = fs::read_dir(dir) else { return };
        let (tmp, old) = (format!(".{name}.tmp-"), format!(".{name}.old-"));
        for e in entries.flatten() {
            let file = e.file_name();
            let Some(file) = file.to_str() else { continue };
            let Some(pid) = file.strip_prefix(&tmp).or_else(|| file.strip_prefix(&old)).and_then(|p| p.parse::<u32>().ok()) else {
                continue;
            };
            if pid == std::process::id() || Path::new("/proc").join(pid.to_string()).exists() {
                continue;
            }
            let _ = if e.file_type().is_ok_and(|t| t.is_dir()) { fs::remove_dir_all(e.path()) } else { fs::remove_file(e.path()) };
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = path;
}
