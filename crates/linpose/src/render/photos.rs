//! Photographs as backgrounds: a folder of pictures (of rooms, streets, desks), each view of a
//! scene drawing a random crop of a random one, resampled to the view's size and colour.
//!
//! The folder's images (PNG, PNM, JPEG, TIFF, by extension; other files are ignored) are read
//! once, in name order, when the set is opened, and kept in memory as 8-bit RGB reduced by a
//! whole factor (the mean of each block) to at most 4 times the views' larger side on their
//! smaller side (`PHOTO_DETAIL`, render/tuning.rs). A crop has the views' aspect ratio, a size from the views' own (one
//! photo pixel a view pixel) up to the whole photo's height or width (log-uniform), and a uniform
//! place; each view pixel is the mean of the photo pixels whose centres fall in its footprint (the
//! nearest one when the crop is smaller than the view). A gray view takes the crop's Rec. 601
//! luma ([`crate::image_io`]'s).

use super::tuning::PHOTO_DETAIL;
use crate::image_io::{self, luma601, ColorMode, ImageSpec};
use crate::{Error, Result};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// The photographs of a folder, ready to be cropped.
#[derive(Debug, Clone)]
pub struct PhotoSet {
    dir: PathBuf,
    photos: Vec<Photo>,
}

/// One photograph, reduced.
#[derive(Debug, Clone)]
struct Photo {
    /// The file's name in the folder.
    name: String,
    width: usize,
    height: usize,
    /// The factor it was reduced by.
    factor: usize,
    /// 8-bit RGB, interleaved.
    rgb: Vec<u8>,
}

/// Which part of which photograph a view's background is.
#[derive(Debug, Clone, PartialEq)]
pub struct PhotoCrop {
    /// The photograph's file name in its folder.
    pub name: String,
    /// The crop's corners in the photograph's own pixels: left, top, right, bottom.
    pub rect: [f64; 4],
}

impl PhotoSet {
    /// Reads every image of `dir` for views of `width` x `height` pixels. Refused: a path that is
    /// not a folder, a folder without images, and an image that cannot be read (the error names
    /// it).
    pub fn open(dir: &Path, width: u32, height: u32) -> Result<Self> {
        if !dir.is_dir() {
            let message = if dir.exists() { "not a folder of photographs" } else { "no such folder of photographs" };
            return Err(Error::Dataset { path: dir.to_path_buf(), message: message.into() });
        }
        let mut names = Vec::new();
        for entry in std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))? {
            let entry = entry.map_err(|e| Error::io(dir, e))?;
            let path = entry.path();
            if path.is_file() && image_io::has_image_extension(&path) {
                let name = entry.file_name();
                let name = name.to_str().ok_or_else(|| Error::Dataset { path: path.clone(), message: "the file name is not UTF-8".into() })?;
                names.push(name.to_string());
            }
        }
        names.sort();
        if names.is_empty() {
            return Err(Error::Dataset {
                path: dir.to_path_buf(),
                message: "no photographs in this folder to draw backgrounds from (PNG, PNM, JPEG or TIFF files)".into(),
            });
        }
        let keep = PHOTO_DETAIL * width.max(height) as usize;
        let photos = names.into_par_iter().map(|name| Photo::read(dir, name, keep)).collect::<Result<Vec<_>>>()?;
        Ok(PhotoSet { dir: dir.to_path_buf(), photos })
    }

    /// The folder the photographs were read from.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// How many photographs there are.
    pub fn len(&self) -> usize {
        self.photos.len()
    }

    /// Whether there are none (never, once opened).
    pub fn is_empty(&self) -> bool {
        self.photos.is_empty()
    }

    /// Fills `out` (a view of `spec`, 8-bit, its channels interleaved) with a random crop of a
    /// random photograph drawn from `rng`, and says which.
    pub(crate) fn draw(&self, rng: &mut ChaCha8Rng, spec: ImageSpec, out: &mut [u8]) -> PhotoCrop {
        let photo = &self.photos[rng.random_range(0..self.photos.len())];
        let (tw, th) = (spec.width as f64, spec.height as f64);
        let (pw, ph) = (photo.width as f64, photo.height as f64);
        // Photo pixels per view pixel: from 1 up to the whole photo's width or height.
        let most = (pw / tw).min(ph / th);
        let scale = if most <= 1.0 { most } else { libm::exp(rng.random_range(0.0..=libm::log(most))) };
        let (cw, ch) = (tw * scale, th * scale);
        let x0 = if pw > cw { rng.random_range(0.0..pw - cw) } else { 0.0 };
        let y0 = if ph > ch { rng.random_range(0.0..ph - ch) } else { 0.0 };
        let cols = spans(x0, scale, spec.width as usize, photo.width);
        let rows = spans(y0, scale, spec.height as usize, photo.height);
        let c = spec.color.channels();
        for (y, &(ya, yb)) in rows.iter().enumerate() {
            for (x, &(xa, xb)) in cols.iter().enumerate() {
                let mut sum = [0u32; 3];
                for py in ya..yb {
                    let row = &photo.rgb[(py * photo.width + xa) * 3..(py * photo.width + xb) * 3];
                    for p in row.chunks_exact(3) {
                        (0..3).for_each(|k| sum[k] += p[k] as u32);
                    }
                }
                let n = ((yb - ya) * (xb - xa)) as u32;
                let mean = sum.map(|s| ((s + n / 2) / n) as u8);
                let k = (y * spec.width as usize + x) * c;
                match spec.color {
                    ColorMode::Gray => out[k] = luma601(mean[0], mean[1], mean[2]),
                    ColorMode::Rgb => out[k..k + 3].copy_from_slice(&mean),
                }
            }
        }
        let f = photo.factor as f64;
        PhotoCrop { name: photo.name.clone(), rect: [x0 * f, y0 * f, (x0 + cw) * f, (y0 + ch) * f] }
    }
}

/// For each of `n` view pixels along an axis, the photo pixels (start, end) whose centres fall in
/// its footprint `[origin + i scale, origin + (i + 1) scale)`, at least the nearest one, within
/// `len`.
fn spans(origin: f64, scale: f64, n: usize, len: usize) -> Vec<(usize, usize)> {
    (0..n)
        .map(|i| {
            let (lo, hi) = (origin + i as f64 * scale, origin + (i + 1) as f64 * scale);
            let a = libm::ceil(lo - 0.5).max(0.0) as usize;
            let b = (libm::ceil(hi - 0.5).max(0.0) as usize).min(len);
            if a < b {
                (a, b)
            } else {
                let c = (libm::floor(origin + (i as f64 + 0.5) * scale).max(0.0) as usize).min(len - 1);
                (c, c + 1)
            }
        })
        .collect()
}

impl Photo {
    /// Reads `dir/name` and reduces it by the largest whole factor that keeps its smaller side at
    /// least `keep` pixels.
    fn read(dir: &Path, name: String, keep: usize) -> Result<Photo> {
        let path = dir.join(&name);
        let (spec, pixels) = image_io::read_u8(&path)?;
        let (w, h) = (spec.width as usize, spec.height as usize);
        let rgb = match spec.color {
            ColorMode::Rgb => pixels,
            ColorMode::Gray => pixels.iter().flat_map(|&v| [v; 3]).collect(),
        };
        let factor = (w.min(h) / keep.max(1)).max(1);
        if factor == 1 {
            return Ok(Photo { name, width: w, height: h, factor, rgb });
        }
        let (rw, rh) = (w / factor, h / factor);
        let n = (factor * factor) as u32;
        let mut out = vec![0u8; rw * rh * 3];
        for y in 0..rh {
            for x in 0..rw {
                let mut sum = [0u32; 3];
                for py in y * factor..(y + 1) * factor {
                    for px in x * factor..(x + 1) * factor {
                        (0..3).for_each(|k| sum[k] += rgb[(py * w + px) * 3 + k] as u32);
                    }
                }
                let k = (y * rw + x) * 3;
                (0..3).for_each(|c| out[k + c] = ((sum[c] + n / 2) / n) as u8);
            }
        }
        Ok(Photo { name, width: rw, height: rh, factor, rgb: out })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn footprints_cover_the_crop_once() {
        // Shrinking by 2.5: footprints of 2 or 3 pixels, in order, none shared.
        let s = spans(0.0, 2.5, 4, 10);
        assert_eq!(s, vec![(0, 2), (2, 5), (5, 7), (7, 10)]);
        // Enlarging by 2: each photo pixel serves two view pixels.
        let s = spans(0.0, 0.5, 4, 2);
        assert_eq!(s, vec![(0, 1), (0, 1), (1, 2), (1, 2)]);
    }

    #[test]
    fn a_crop_of_a_uniform_photo_is_uniform_and_named() {
        let dir = tempfile::tempdir().unwrap();
        image::RgbImage::from_pixel(300, 200, image::Rgb([200, 100, 50])).save(dir.path().join("wall.png")).unwrap();
        std::fs::write(dir.path().join("notes.txt"), "not a photo").unwrap();
        let set = PhotoSet::open(dir.path(), 40, 30).unwrap();
        assert_eq!(set.len(), 1);
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let mut rgb = vec![0u8; 40 * 30 * 3];
        let crop = set.draw(&mut rng, ImageSpec { width: 40, height: 30, color: ColorMode::Rgb }, &mut rgb);
        assert_eq!(crop.name, "wall.png");
        assert!(rgb.chunks_exact(3).all(|p| p == [200, 100, 50]));
        let [x0, y0, x1, y1] = crop.rect;
        assert!(x0 >= 0.0 && y0 >= 0.0 && x1 <= 300.0 && y1 <= 200.0 && x1 - x0 >= 40.0 - 1e-9, "{:?}", crop.rect);
        assert!(((x1 - x0) / (y1 - y0) - 4.0 / 3.0).abs() < 1e-9);
        let mut gray = vec![0u8; 40 * 30];
        set.draw(&mut rng, ImageSpec { width: 40, height: 30, color: ColorMode::Gray }, &mut gray);
        assert!(gray.iter().all(|&v| v == luma601(200, 100, 50)));
    }

    #[test]
    fn an_empty_or_unreadable_folder_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let e = PhotoSet::open(dir.path(), 40, 30).unwrap_err().to_string();
        assert!(e.contains(&dir.path().display().to_string()) && e.contains("no photographs"), "{e}");
        std::fs::write(dir.path().join("broken.jpg"), b"not a jpeg").unwrap();
        let e = PhotoSet::open(dir.path(), 40, 30).unwrap_err().to_string();
        assert!(e.contains("broken.jpg"), "{e}");
        let e = PhotoSet::open(&dir.path().join("nowhere"), 40, 30).unwrap_err().to_string();
        assert!(e.contains("nowhere") && e.contains("no such folder"), "{e}");
    }
}
