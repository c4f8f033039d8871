//! What stands behind the object in a scene: a uniform level (a studio's backdrop, what the
//! renderer draws by itself), procedural clutter (value noise under shapes and stripes of every
//! scale, `render/texture.rs`), pixel noise, or crops of
//! photographs ([`PhotoSet`]). Each view draws its own from the scene's seed
//! ([`super::scene::Scene`]).

use super::photos::{PhotoCrop, PhotoSet};
use super::texture;
use crate::image_io::ImageSpec;
use crate::{Error, Result};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// What a scene's background is, as a command line names it: a level (`0.5`), `texture`,
/// `noise` or a folder of photographs. [`BackgroundSpec::open`] makes it a [`Background`].
#[derive(Debug, Clone, PartialEq)]
pub enum BackgroundSpec {
    /// A uniform level in [0, 1] (0 black, 1 white).
    Level(f64),
    /// Procedural clutter, a new draw per view.
    Texture,
    /// Independent uniform noise in every pixel (and channel), a new draw per view.
    Noise,
    /// Crops of the photographs in this folder.
    Photos(PathBuf),
}

impl BackgroundSpec {
    /// Parses a number in [0, 1] as a level, `texture`, `noise`, or else a folder's path (which
    /// must exist: otherwise the error names the value and what it may be).
    pub fn parse(spec: &str) -> Result<Self> {
        let s = spec.trim();
        if let Ok(level) = s.parse::<f64>() {
            if !(0.0..=1.0).contains(&level) {
                return Err(Error::invalid("background", spec, "a level must be a brightness in [0, 1]"));
            }
            return Ok(BackgroundSpec::Level(level));
        }
        match s {
            "texture" => Ok(BackgroundSpec::Texture),
            "noise" => Ok(BackgroundSpec::Noise),
            _ if Path::new(s).is_dir() => Ok(BackgroundSpec::Photos(PathBuf::from(s))),
            _ => Err(Error::invalid("background", spec, "expected a level in [0, 1], 'texture', 'noise' or a folder of photographs (no such folder)")),
        }
    }

    /// The background for views of `width` x `height` pixels: a folder's photographs are read
    /// here ([`PhotoSet::open`]).
    pub fn open(&self, width: u32, height: u32) -> Result<Background> {
        Ok(match self {
            BackgroundSpec::Level(v) => Background::Level(*v),
            BackgroundSpec::Texture => Background::Texture,
            BackgroundSpec::Noise => Background::Noise,
            BackgroundSpec::Photos(dir) => Background::Photos(Arc::new(PhotoSet::open(dir, width, height)?)),
        })
    }
}

/// A scene's background, ready to draw.
#[derive(Debug, Clone)]
pub enum Background {
    /// A uniform level in [0, 1].
    Level(f64),
    /// Procedural clutter.
    Texture,
    /// Independent uniform noise.
    Noise,
    /// Crops of photographs.
    Photos(Arc<PhotoSet>),
}

/// What one view's background was: its kind, and for a photograph which crop of which.
#[derive(Debug, Clone, PartialEq)]
pub enum BackgroundDraw {
    /// A uniform level.
    Level(f64),
    /// Procedural clutter.
    Texture,
    /// Pixel noise.
    Noise,
    /// A crop of a photograph.
    Photo(PhotoCrop),
}

impl Background {
    /// Whether it is a uniform level.
    pub fn is_level(&self) -> bool {
        matches!(self, Background::Level(_))
    }

    /// Fills `out` (a view of `spec`, 8-bit, channels interleaved) with a background drawn from
    /// `rng`.
    pub(crate) fn draw(&self, rng: &mut ChaCha8Rng, spec: ImageSpec, out: &mut [u8]) -> BackgroundDraw {
        let (w, h, c) = (spec.width as usize, spec.height as usize, spec.color.channels());
        debug_assert_eq!(out.len(), w * h * c);
        match self {
            Background::Level(v) => {
                out.fill((v * 255.0 + 0.5).clamp(0.0, 255.0) as u8);
                BackgroundDraw::Level(*v)
            }
            Background::Texture => {
                texture::clutter(rng, w, h, c, out);
                BackgroundDraw::Texture
            }
            Background::Noise => {
                rng.fill(out);
                BackgroundDraw::Noise
            }
            Background::Photos(set) => BackgroundDraw::Photo(set.draw(rng, spec, out)),
        }
    }
}

impl fmt::Display for BackgroundDraw {
    /// As `scene.csv` has it: the level (`0.5`), `texture`, `noise`, or `photo NAME X0 Y0 X1 Y1`
    /// (the crop's corners in the photograph's pixels).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            BackgroundDraw::Level(v) => write!(f, "{v}"),
            BackgroundDraw::Texture => f.write_str("texture"),
            BackgroundDraw::Noise => f.write_str("noise"),
            BackgroundDraw::Photo(c) => {
                let [x0, y0, x1, y1] = c.rect;
                write!(f, "photo {} {x0:.1} {y0:.1} {x1:.1} {y1:.1}", c.name)
            }
        }
    }
}

impl BackgroundDraw {
    /// Reads what [`fmt::Display`] writes; None for anything else.
    pub fn parse(s: &str) -> Option<Self> {
        let s = s.trim();
        match s {
            "texture" => return Some(BackgroundDraw::Texture),
            "noise" => return Some(BackgroundDraw::Noise),
            _ => {}
        }
        if let Some(rest) = s.strip_prefix("photo ") {
            // The name may hold spaces: the four numbers are the last four words.
            let words: Vec<&str> = rest.rsplitn(5, ' ').collect();
            let [y1, x1, y0, x0, name] = words[..] else { return None };
            let rect = [x0, y0, x1, y1].map(|v| v.parse::<f64>().ok());
            let rect = [rect[0]?, rect[1]?, rect[2]?, rect[3]?];
            return Some(BackgroundDraw::Photo(PhotoCrop { name: name.to_string(), rect }));
        }
        s.parse::<f64>().ok().filter(|v| (0.0..=1.0).contains(v)).map(BackgroundDraw::Level)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_number_is_a_level_and_words_are_kinds() {
        assert_eq!(BackgroundSpec::parse("0.5").unwrap(), BackgroundSpec::Level(0.5));
        assert_eq!(BackgroundSpec::parse("0").unwrap(), BackgroundSpec::Level(0.0));
        assert_eq!(BackgroundSpec::parse("texture").unwrap(), BackgroundSpec::Texture);
        assert_eq!(BackgroundSpec::parse("noise").unwrap(), BackgroundSpec::Noise);
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().to_str().unwrap();
        assert_eq!(BackgroundSpec::parse(p).unwrap(), BackgroundSpec::Photos(PathBuf::from(p)));
        for bad in ["1.5", "-0.1", "textures", "/no/such/folder"] {
            let e = BackgroundSpec::parse(bad).unwrap_err().to_string();
            assert!(e.contains("background") && e.contains(bad), "{e}");
        }
    }

    #[test]
    fn the_record_reads_back() {
        let crop = PhotoCrop { name: "my wall.jpg".into(), rect: [1.5, 2.0, 41.5, 32.0] };
        for d in [BackgroundDraw::Level(0.25), BackgroundDraw::Texture, BackgroundDraw::Noise, BackgroundDraw::Photo(crop)] {
            assert_eq!(BackgroundDraw::parse(&d.to_string()), Some(d.clone()), "{d}");
        }
        assert_eq!(BackgroundDraw::parse("photo x 1 2 3"), None);
        assert_eq!(BackgroundDraw::parse("2"), None);
    }
}
