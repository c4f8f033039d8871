//! Scenes: a view's object put in front of a background ([`super::background`]) and partly
//! hidden by occluders ([`super::occlude`]), each view its own draw from a seed, and the record
//! of what was drawn ([`SceneRecord`], a row of `scene.csv`).
//!
//! Every method projects the whole image, so a background that is not the training views' or an
//! occluder moves every estimate; scenes are the data sets to measure that on. `linpose synth`
//! renders the object over the background (the renderer knows which samples the object covers,
//! so its silhouette's edge mixes the two as a camera would); `linpose scene` puts the views of
//! an existing data set into scenes, the object found against its studio backdrop
//! ([`crate::scene`]).
//!
//! View i draws its background from stream 2i and its occluders from stream 2i + 1 of a ChaCha8
//! generator seeded with the scene's seed, so a view's scene does not depend on the order or the
//! threads it is made in, nor its occluders on the background.

use super::background::{Background, BackgroundDraw, BackgroundSpec};
use super::occlude::{occlude, Occluder, Occlusion};
use super::place::{lay, Canvas};
use crate::image_io::ImageSpec;
use crate::{Error, Result};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::io::Write;
use std::path::Path;

/// The seed of the scenes' draws when none is given.
pub const DEFAULT_SEED: u64 = 0;

/// A scene as a command line gives it, before its photographs (if any) are read:
/// [`SceneSpec::open`] makes it a [`Scene`] for views of a size.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneSpec {
    /// The background.
    pub background: BackgroundSpec,
    /// The share of the object's pixels occluders hide, in [0, 1).
    pub occlude: f64,
    /// The seed of the draws.
    pub seed: u64,
    /// Views put somewhere in a larger image instead of filling their own frame (None: in place).
    pub canvas: Option<Canvas>,
}

impl SceneSpec {
    /// The scene for views of `width` x `height` pixels (a folder's photographs read here);
    /// refuses a share outside [0, 1) before reading any.
    /// With a canvas, the background is the canvas's size and the views must fit it.
    pub fn open(&self, width: u32, height: u32) -> Result<Scene> {
        Scene::new(Background::Level(0.0), self.occlude, self.seed)?;
        let (bw, bh) = match &self.canvas {
            Some(c) => {
                c.check_views(width, height)?;
                (c.width, c.height)
            }
            None => (width, height),
        };
        Ok(Scene { canvas: self.canvas, ..Scene::new(self.background.open(bw, bh)?, self.occlude, self.seed)? })
    }
}

/// How the views of a data set are put into scenes: their background, the share of the object
/// occluders hide, and the seed of the draws.
#[derive(Debug, Clone)]
pub struct Scene {
    background: Background,
    occlude: f64,
    seed: u64,
    canvas: Option<Canvas>,
}

impl Scene {
    /// A scene of `background` with occluders hiding about `occlude` of the object's pixels (in
    /// [0, 1); 0 for none), drawn from `seed`.
    pub fn new(background: Background, occlude: f64, seed: u64) -> Result<Self> {
        if !(0.0..1.0).contains(&occlude) {
            return Err(Error::invalid("occlude", occlude, "must be the share of the object's pixels to hide, in [0, 1)"));
        }
        Ok(Scene { background, occlude, seed, canvas: None })
    }

    /// The background.
    pub fn background(&self) -> &Background {
        &self.background
    }

    /// The share of the object's pixels to hide.
    pub fn occlude(&self) -> f64 {
        self.occlude
    }

    /// The seed of the draws.
    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// Whether it is only a uniform background and no occluder: what the renderer draws by itself.
    pub fn is_plain(&self) -> bool {
        self.background.is_level() && self.occlude == 0.0
    }

    /// View `view`'s generator for its background (`part` 0) or its occluders (1).
    fn rng(&self, view: usize, part: u64) -> ChaCha8Rng {
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed);
        rng.set_stream(2 * view as u64 + part);
        rng
    }

    /// Fills `out` (8-bit, `spec`'s size and channels) with view `view`'s background.
    pub fn draw_background(&self, view: usize, spec: ImageSpec, out: &mut [u8]) -> BackgroundDraw {
        self.background.draw(&mut self.rng(view, 0), spec, out)
    }

    /// Paints view `view`'s occluders over the object whose pixels `mask` marks, into `pixels`.
    pub fn draw_occluders(&self, view: usize, spec: ImageSpec, mask: &[bool], pixels: &mut [u8]) -> Occlusion {
        occlude(self.occlude, &mut self.rng(view, 1), spec, mask, pixels)
    }

    /// Puts view `view` (its `pixels`, 8-bit, `spec`'s size and channels) into its scene: the
    /// pixels outside `mask` (the object) become the view's background, then the occluders are
    /// painted. `image` names the view in the record.
    pub fn restage(&self, view: usize, image: &str, spec: ImageSpec, mask: &[bool], pixels: &mut [u8]) -> SceneRecord {
        let c = spec.color.channels();
        let mut back = vec![0u8; pixels.len()];
        let background = self.draw_background(view, spec, &mut back);
        for ((px, bg), &m) in pixels.chunks_exact_mut(c).zip(back.chunks_exact(c)).zip(mask) {
            if !m {
                px.copy_from_slice(bg);
            }
        }
        let occlusion = self.draw_occluders(view, spec, mask, pixels);
        self.record(image, background, occlusion)
    }

    /// Where the views go in a larger image, if they do.
    pub fn canvas(&self) -> Option<&Canvas> {
        self.canvas.as_ref()
    }

    /// Puts view `view` (its `pixels`, 8-bit, `spec`'s size and channels, its object where
    /// `mask` is) somewhere on the scene's canvas ([`super::place`]): the occluders painted over
    /// the object in the view's frame, the two scaled and placed over the canvas's background.
    /// Returns the canvas's pixels and the record, its box set. None without a canvas.
    pub fn place(&self, view: usize, image: &str, spec: ImageSpec, mask: &[bool], pixels: &[u8]) -> Option<(Vec<u8>, SceneRecord)> {
        let canvas = self.canvas?;
        let (w, h) = (spec.width as usize, spec.height as usize);
        let mut layer = pixels.to_vec();
        let occlusion = self.draw_occluders(view, spec, mask, &mut layer);
        let opaque: Vec<bool> = (0..w * h).map(|k| mask[k] || occlusion.occluders.iter().any(|o| o.covers(k % w, k / w))).collect();
        let cspec = canvas.spec(spec);
        let mut out = vec![0u8; cspec.features()];
        let background = self.draw_background(view, cspec, &mut out);
        let bbox = canvas.draw_box(self.seed, view, spec.width, spec.height);
        lay(&layer, &opaque, spec, bbox, &mut out, canvas.width as usize);
        let mut record = self.record(image, background, occlusion);
        record.bbox = Some(bbox);
        Some((out, record))
    }

    /// The record of a view named `image`.
    pub fn record(&self, image: &str, background: BackgroundDraw, occlusion: Occlusion) -> SceneRecord {
        SceneRecord {
            image: image.to_string(),
            background,
            seed: self.seed,
            occlude: self.occlude,
            hidden: occlusion.hidden,
            object_pixels: occlusion.object_pixels,
            occluders: occlusion.occluders,
            bbox: None,
        }
    }
}

/// What one view's scene is: a row of `scene.csv`.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneRecord {
    /// The image, as `poses.csv` names it.
    pub image: String,
    /// Its background.
    pub background: BackgroundDraw,
    /// The seed of the draws.
    pub seed: u64,
    /// The share of the object's pixels the occluders were to hide.
    pub occlude: f64,
    /// The share they hide.
    pub hidden: f64,
    /// The object's pixels (before occlusion).
    pub object_pixels: usize,
    /// The occluders (in the view's own frame when the view was placed on a canvas).
    pub occluders: Vec<Occluder>,
    /// Where the view's frame was placed on a canvas: left, top, width, height in the canvas's
    /// pixels (None: the view fills its own frame).
    pub bbox: Option<[f64; 4]>,
}

/// The header of `scene.csv`.
pub const SCENE_CSV_HEADER: [&str; 8] = ["image", "background", "seed", "occlude", "hidden", "object_pixels", "occluders", "box"];

impl SceneRecord {
    /// The row's fields: the occluders as `rect CX CY HX HY` or `ellipse ...`, joined by `;`.
    fn fields(&self) -> [String; 8] {
        let occluders: Vec<String> = self.occluders.iter().map(|o| o.to_string()).collect();
        [
            self.image.clone(),
            self.background.to_string(),
            self.seed.to_string(),
            self.occlude.to_string(),
            self.hidden.to_string(),
            self.object_pixels.to_string(),
            occluders.join(";"),
            self.bbox.map(|b| b.map(|v| v.to_string()).join(" ")).unwrap_or_default(),
        ]
    }
}

/// Writes `scene.csv` rows to `w` (the header first when `header`), quoted where a name needs it.
pub fn write_scene_csv(w: &mut impl Write, records: &[SceneRecord], header: bool) -> Result<()> {
    let mut csv = csv::WriterBuilder::new().from_writer(w);
    let io = |e: csv::Error| Error::io("scene.csv", std::io::Error::other(e.to_string()));
    if header {
        csv.write_record(SCENE_CSV_HEADER).map_err(io)?;
    }
    for r in records {
        csv.write_record(r.fields()).map_err(io)?;
    }
    csv.flush().map_err(|e| Error::io("scene.csv", e))
}

/// Reads a `scene.csv`; errors name the file and line.
pub fn read_scene_csv(path: &Path) -> Result<Vec<SceneRecord>> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    let mut rdr = csv::ReaderBuilder::new().has_headers(false).from_reader(text.as_bytes());
    let mut out = Vec::new();
    for (k, row) in rdr.records().enumerate() {
        let line = k + 1;
        let row = row.map_err(|e| Error::parse(path, line, e.to_string()))?;
        let fields: Vec<&str> = row.iter().collect();
        if k == 0 {
            // Files written before the box column have the first seven.
            if fields != SCENE_CSV_HEADER && fields != SCENE_CSV_HEADER[..7] {
                return Err(Error::parse(path, 1, format!("expected the header {}", SCENE_CSV_HEADER.join(","))));
            }
            continue;
        }
        let bad = |what: &str| Error::parse(path, line, format!("{what}: '{}'", fields.join(",")));
        let (image, background, seed, occlude, hidden, pixels, occluders, bbox) = match fields[..] {
            [a, b, c, d, e, f, g] => (a, b, c, d, e, f, g, ""),
            [a, b, c, d, e, f, g, h] => (a, b, c, d, e, f, g, h),
            _ => return Err(bad("expected 8 fields")),
        };
        let number = |s: &str, name: &str| s.trim().parse::<f64>().ok().filter(|v| v.is_finite()).ok_or_else(|| bad(name));
        out.push(SceneRecord {
            image: image.to_string(),
            background: BackgroundDraw::parse(background).ok_or_else(|| bad("not a background"))?,
            seed: seed.trim().parse().map_err(|_| bad("not a seed"))?,
            occlude: number(occlude, "not a share")?,
            hidden: number(hidden, "not a share")?,
            object_pixels: pixels.trim().parse().map_err(|_| bad("not a pixel count"))?,
            occluders: occluders
                .split(';')
                .filter(|s| !s.trim().is_empty())
                .map(|s| Occluder::parse(s).ok_or_else(|| bad("not an occluder")))
                .collect::<Result<Vec<_>>>()?,
            bbox: match bbox.trim() {
                "" => None,
                b => {
                    let v: Vec<f64> = b.split_whitespace().map(|x| number(x, "not a box")).collect::<Result<_>>()?;
                    Some(<[f64; 4]>::try_from(v).map_err(|_| bad("not a box of four numbers"))?)
                }
            },
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image_io::ColorMode;
    use crate::render::occlude::OccluderShape;

    #[test]
    fn a_share_outside_0_1_is_refused_by_value() {
        for bad in [-0.1, 1.0, 1.5, f64::NAN] {
            let e = Scene::new(Background::Texture, bad, 0).unwrap_err().to_string();
            assert!(e.contains("occlude") && e.contains(&bad.to_string()), "{e}");
        }
        assert!(Scene::new(Background::Level(0.0), 0.0, 0).unwrap().is_plain());
        assert!(!Scene::new(Background::Level(0.0), 0.1, 0).unwrap().is_plain());
    }

    #[test]
    fn restaging_keeps_the_object_and_draws_per_view() {
        let spec = ImageSpec { width: 40, height: 30, color: ColorMode::Gray };
        let mask: Vec<bool> = (0..1200).map(|k| (10..30).contains(&(k % 40)) && (8..22).contains(&(k / 40))).collect();
        let scene = Scene::new(Background::Texture, 0.0, 7).unwrap();
        let studio = vec![9u8; 1200];
        let mut a = studio.clone();
        let r = scene.restage(3, "v.png", spec, &mask, &mut a);
        assert!(mask.iter().zip(&a).all(|(&m, &v)| !m || v == 9));
        assert!(mask.iter().zip(&a).filter(|(&m, &v)| !m && v != 9).count() > 500);
        let mut b = studio.clone();
        assert_eq!(scene.restage(3, "v.png", spec, &mask, &mut b), r);
        assert_eq!(a, b, "one seed and view, one scene");
        let mut c = studio.clone();
        scene.restage(4, "w.png", spec, &mask, &mut c);
        assert_ne!(a, c, "each view its own draw");
        assert_eq!((r.object_pixels, r.hidden, r.background.clone()), (280, 0.0, BackgroundDraw::Texture));
    }

    #[test]
    fn scene_csv_reads_back() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("scene.csv");
        let records = vec![
            SceneRecord {
                image: "a,b.png".into(),
                background: BackgroundDraw::Texture,
                seed: 3,
                occlude: 0.2,
                hidden: 0.2013,
                object_pixels: 812,
                occluders: vec![Occluder::new(OccluderShape::Rect, [10.5, 3.25], [4.0, 2.5]), Occluder::new(OccluderShape::Ellipse, [1.0, 2.0], [3.0, 4.0])],
                bbox: Some([12.25, 40.0, 102.4, 76.8]),
            },
            SceneRecord {
                image: "c.png".into(),
                background: BackgroundDraw::Level(0.5),
                seed: 3,
                occlude: 0.0,
                hidden: 0.0,
                object_pixels: 0,
                occluders: vec![],
                bbox: None,
            },
        ];
        let mut bytes = Vec::new();
        write_scene_csv(&mut bytes, &records, true).unwrap();
        std::fs::write(&path, &bytes).unwrap();
        assert_eq!(read_scene_csv(&path).unwrap(), records);
        std::fs::write(&path, b"image,background\n").unwrap();
        assert!(read_scene_csv(&path).unwrap_err().to_string().contains("scene.csv:1"));
        std::fs::write(&path, [&bytes[..], b"d.png,texture,0,0.2,x,3,\n"].concat()).unwrap();
        assert!(read_scene_csv(&path).unwrap_err().to_string().contains("scene.csv:4"));
    }
}
