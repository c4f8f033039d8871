//! Helpers for the CLI integration tests: a temporary folder, the built command, and data sets
//! made on the spot.

#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A temporary folder removed at the end of the test.
pub struct Dir {
    tmp: tempfile::TempDir,
}

impl Dir {
    /// A fresh folder.
    pub fn new() -> Self {
        Dir { tmp: tempfile::tempdir().expect("temp dir") }
    }

    /// A path inside it.
    pub fn path(&self, rel: &str) -> PathBuf {
        self.tmp.path().join(rel)
    }

    /// Runs `linpose ARGS` in this folder.
    pub fn run(&self, args: &[&str]) -> Output {
        Command::new(env!("CARGO_BIN_EXE_linpose")).args(args).current_dir(self.tmp.path()).output().expect("run linpose")
    }

    /// Runs and asserts success, returning stdout.
    pub fn ok(&self, args: &[&str]) -> String {
        let out = self.run(args);
        assert!(out.status.success(), "linpose {args:?} failed: {}", String::from_utf8_lossy(&out.stderr));
        String::from_utf8(out.stdout).expect("utf-8 stdout")
    }

    /// Runs and asserts failure with a one-paragraph message containing every one of `words`.
    pub fn fails(&self, args: &[&str], words: &[&str]) -> String {
        let out = self.run(args);
        let err = String::from_utf8_lossy(&out.stderr).into_owned();
        assert!(!out.status.success(), "linpose {args:?} should have failed; stdout: {}", String::from_utf8_lossy(&out.stdout));
        assert!(!err.contains("panicked"), "linpose {args:?} panicked: {err}");
        for w in words {
            assert!(err.contains(w), "linpose {args:?}: error lacks '{w}': {err}");
        }
        err
    }
}

/// A synthetic turntable image: two Gaussian blobs circling the centre with the azimuth, raised
/// with the elevation.
pub fn blob_image(w: u32, h: u32, elevation: f64, azimuth: f64) -> image::GrayImage {
    let r = azimuth.to_radians();
    let (wf, hf) = (w as f64, h as f64);
    let lift = elevation / 90.0 * 0.3 * hf;
    image::GrayImage::from_fn(w, h, |x, y| {
        let (xf, yf) = (x as f64, y as f64);
        let mut v = 0.05 * (((x * 31 + y * 17) % 7) as f64 / 7.0);
        for (rad, ph, amp) in [(0.3, 0.0, 1.0), (0.2, 2.5, 0.6)] {
            let cx = wf / 2.0 + rad * wf * (r + ph).cos();
            let cy = hf / 2.0 + 0.25 * hf * (r + ph).sin() - lift;
            let d2 = ((xf - cx) / wf).powi(2) + ((yf - cy) / hf).powi(2);
            v += amp * (-d2 / 0.02).exp();
        }
        image::Luma([(v.clamp(0.0, 1.0) * 255.0).round() as u8])
    })
}

/// Writes a data set in the directory format: azimuth every `az_step` degrees over a full turn,
/// at each of `elevations` (none: azimuth only). Returns the folder.
pub fn write_dataset(dir: &Path, az_step: u32, elevations: &[f64], size: (u32, u32)) -> PathBuf {
    std::fs::create_dir_all(dir).unwrap();
    let mut csv = String::from(if elevations.is_empty() { "image,azimuth\n" } else { "image,elevation,azimuth\n" });
    let els: Vec<Option<f64>> = if elevations.is_empty() { vec![None] } else { elevations.iter().map(|&e| Some(e)).collect() };
    for el in els {
        for az in (0..360).step_by(az_step as usize) {
            let name = match el {
                Some(e) => format!("e{e}_a{az}.png"),
                None => format!("a{az:03}.png"),
            };
            blob_image(size.0, size.1, el.unwrap_or(30.0), az as f64).save(dir.join(&name)).unwrap();
            match el {
                Some(e) => csv.push_str(&format!("{name},{e},{az}\n")),
                None => csv.push_str(&format!("{name},{az}\n")),
            }
        }
    }
    std::fs::write(dir.join("poses.csv"), csv).unwrap();
    dir.to_path_buf()
}
