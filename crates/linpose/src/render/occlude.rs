//! Occluders: opaque things in front of the object that hide a chosen share of it, as a hand, a
//! cup or a box in front of it would in a cluttered scene.
//!
//! Each view places one or two occluders (each an upright rectangle or ellipse, its aspect
//! ratio within 1:4) over an object's mask so that about the share `F` of the object's pixels
//! is hidden: each occluder's centre is a random pixel of the object, their sizes keep random
//! ratios to each other, and one common scale is found by bisection so that the count of the
//! object's pixels they cover comes nearest `F` times the object's (covering grows with the
//! scale, the shapes being nested). What is achieved is reported ([`Occlusion::hidden`]); it
//! differs from `F` by the pixels one step of the scale uncovers at once (a rectangle's edge
//! sweeps a row of them), a percent or two of a small object.
//!
//! Each occluder has a surface of its own: a flat level (a colour, on colour views) crossed by
//! square stripes of another at a random period and angle, so that it is neither the object nor
//! the background. A pixel is covered when its centre lies inside the shape.

use super::tuning::OCCLUDE_STEPS;
use crate::image_io::ImageSpec;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use std::f64::consts::PI;
use std::fmt;

/// An occluder's outline.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OccluderShape {
    /// An upright rectangle.
    Rect,
    /// An upright ellipse.
    Ellipse,
}

/// One occluder: its outline, centre and half-sizes in pixels (the image's top-left corner at
/// (0, 0), pixel centres at half-integers), and its surface.
#[derive(Debug, Clone, PartialEq)]
pub struct Occluder {
    /// The outline.
    pub shape: OccluderShape,
    /// The centre (x right, y down), pixels.
    pub centre: [f64; 2],
    /// The half-width and half-height, pixels.
    pub half: [f64; 2],
    surface: Surface,
}

/// A flat colour crossed by stripes of a second one.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct Surface {
    colour: [[u8; 3]; 2],
    period: f64,
    direction: [f64; 2],
}

/// What the occluders of one view are and hide.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Occlusion {
    /// The occluders, in the order they were painted.
    pub occluders: Vec<Occluder>,
    /// The share of the object's pixels they hide, in [0, 1].
    pub hidden: f64,
    /// The object's pixels.
    pub object_pixels: usize,
}

impl Occluder {
    /// An occluder of `shape` at `centre` with half-sizes `half` (pixels), of a plain surface:
    /// what a `scene.csv` row describes ([`super::scene::SceneRecord`]).
    pub fn new(shape: OccluderShape, centre: [f64; 2], half: [f64; 2]) -> Self {
        Occluder { shape, centre, half, surface: Surface::default() }
    }

    /// Whether it covers the pixel at column `x`, row `y` (its centre inside the outline).
    pub fn covers(&self, x: usize, y: usize) -> bool {
        let u = (x as f64 + 0.5 - self.centre[0]) / self.half[0];
        let v = (y as f64 + 0.5 - self.centre[1]) / self.half[1];
        match self.shape {
            OccluderShape::Rect => u.abs() <= 1.0 && v.abs() <= 1.0,
            OccluderShape::Ellipse => u * u + v * v <= 1.0,
        }
    }

    /// The pixels its bounding box spans in a `width` x `height` image: columns `x0..x1` and
    /// rows `y0..y1`, as `[x0, y0, x1, y1]` (empty when it lies outside).
    pub fn bounds(&self, width: usize, height: usize) -> [usize; 4] {
        // Pixel i's centre i + 0.5 lies in [c - h, c + h] for i in ceil(c - h - 0.5)..=floor(c + h - 0.5).
        let lo = |c: f64, h: f64, n: usize| (libm::ceil(c - h - 0.5).max(0.0) as usize).min(n);
        let hi = |c: f64, h: f64, n: usize| ((libm::floor(c + h - 0.5) + 1.0).max(0.0) as usize).min(n);
        let [cx, cy] = self.centre;
        let [hx, hy] = self.half;
        [lo(cx, hx, width), lo(cy, hy, height), hi(cx, hx, width), hi(cy, hy, height)]
    }

    /// This occluder scaled by `t` about its centre.
    fn scaled(&self, t: f64) -> Occluder {
        Occluder { half: [self.half[0] * t, self.half[1] * t], ..self.clone() }
    }

    /// The colour of its surface at pixel (x, y).
    fn colour(&self, x: usize, y: usize) -> [u8; 3] {
        let s = &self.surface;
        let t = (x as f64 * s.direction[0] + y as f64 * s.direction[1]) / s.period;
        s.colour[(t - libm::floor(t) >= 0.5) as usize]
    }
}

impl OccluderShape {
    /// `rect` or `ellipse`.
    pub fn name(self) -> &'static str {
        match self {
            OccluderShape::Rect => "rect",
            OccluderShape::Ellipse => "ellipse",
        }
    }
}

impl fmt::Display for Occluder {
    /// `rect CX CY HX HY` or `ellipse CX CY HX HY` (pixels), as `scene.csv` has it.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let [cx, cy] = self.centre;
        let [hx, hy] = self.half;
        write!(f, "{} {cx} {cy} {hx} {hy}", self.shape.name())
    }
}

impl Occluder {
    /// Reads what [`fmt::Display`] writes (the surface plain); None for anything else.
    pub fn parse(s: &str) -> Option<Occluder> {
        let words: Vec<&str> = s.split_whitespace().collect();
        let [name, cx, cy, hx, hy] = words[..] else { return None };
        let shape = match name {
            "rect" => OccluderShape::Rect,
            "ellipse" => OccluderShape::Ellipse,
            _ => return None,
        };
        let v = [cx, cy, hx, hy].map(|w| w.parse::<f64>().ok().filter(|v| v.is_finite()));
        Some(Occluder::new(shape, [v[0]?, v[1]?], [v[2]?, v[3]?]))
    }
}

/// Places occluders over the object whose pixels `mask` marks (row-major, `spec`'s size) so that
/// about `share` of them are hidden, drawing from `rng`, and paints them into `pixels` (8-bit,
/// `spec`'s channels interleaved). Nothing is placed for a share of 0 or an empty mask.
pub(crate) fn occlude(share: f64, rng: &mut ChaCha8Rng, spec: ImageSpec, mask: &[bool], pixels: &mut [u8]) -> Occlusion {
    let (w, h, c) = (spec.width as usize, spec.height as usize, spec.color.channels());
    debug_assert_eq!(mask.len(), w * h);
    let object: Vec<(usize, usize)> = mask.iter().enumerate().filter(|(_, &m)| m).map(|(k, _)| (k % w, k / w)).collect();
    let m = object.len();
    if share <= 0.0 || m == 0 {
        return Occlusion { occluders: Vec::new(), hidden: 0.0, object_pixels: m };
    }
    // The occluders at scale 1: random outlines and proportions, centred on object pixels.
    let count = rng.random_range(1..=2);
    let base: Vec<Occluder> = (0..count)
        .map(|k| {
            let shape = if rng.random_bool(0.5) { OccluderShape::Rect } else { OccluderShape::Ellipse };
            let aspect = libm::exp(rng.random_range(-0.7..0.7));
            let size = if k == 0 { 1.0 } else { rng.random_range(0.5..1.0) };
            let (x, y) = object[rng.random_range(0..m)];
            let centre = [x as f64 + 0.5, y as f64 + 0.5];
            Occluder { shape, centre, half: [size * aspect, size / aspect], surface: Surface::draw(rng, c) }
        })
        .collect();
    let hidden_at = |t: f64| object.iter().filter(|&&(x, y)| base.iter().any(|o| o.scaled(t).covers(x, y))).count();
    // At scale `hi` each occluder spans the whole frame from any centre inside it.
    let target = share * m as f64;
    let smallest = base.iter().flat_map(|o| o.half).fold(f64::INFINITY, f64::min);
    let (mut lo, mut hi) = (0.0, 2.0 * (w.max(h) as f64) / smallest);
    let mut best = (f64::INFINITY, hi);
    for _ in 0..OCCLUDE_STEPS {
        let t = 0.5 * (lo + hi);
        let n = hidden_at(t) as f64;
        if (n - target).abs() < best.0 {
            best = ((n - target).abs(), t);
        }
        if n < target {
            lo = t;
        } else {
            hi = t;
        }
    }
    let occluders: Vec<Occluder> = base.iter().map(|o| o.scaled(best.1)).collect();
    for o in &occluders {
        let [x0, y0, x1, y1] = o.bounds(w, h);
        for y in y0..y1 {
            for x in x0..x1 {
                if o.covers(x, y) {
                    let colour = o.colour(x, y);
                    let k = (y * w + x) * c;
                    pixels[k..k + c].copy_from_slice(&colour[..c]);
                }
            }
        }
    }
    let hidden = object.iter().filter(|&&(x, y)| occluders.iter().any(|o| o.covers(x, y))).count();
    Occlusion { occluders, hidden: hidden as f64 / m as f64, object_pixels: m }
}

impl Surface {
    fn draw(rng: &mut ChaCha8Rng, channels: usize) -> Surface {
        let mut colour = || -> [u8; 3] {
            let base: u8 = rng.random();
            match channels {
                1 => [base; 3],
                _ => [base, rng.random(), rng.random()],
            }
        };
        let colour = [colour(), colour()];
        let period = rng.random_range(4.0..16.0);
        let a = rng.random_range(0.0..PI);
        Surface { colour, period, direction: [libm::cos(a), libm::sin(a)] }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image_io::ColorMode;
    use rand::SeedableRng;

    /// A disc of radius `r` at the centre of a `w` x `h` frame.
    fn disc(w: usize, h: usize, r: f64) -> Vec<bool> {
        (0..w * h)
            .map(|k| {
                let (x, y) = ((k % w) as f64 + 0.5 - w as f64 / 2.0, (k / w) as f64 + 0.5 - h as f64 / 2.0);
                x * x + y * y <= r * r
            })
            .collect()
    }

    #[test]
    fn the_hidden_share_is_the_one_asked_for() {
        let (w, h) = (96, 72);
        let spec = ImageSpec { width: w as u32, height: h as u32, color: ColorMode::Gray };
        let mask = disc(w, h, 25.0);
        for share in [0.05, 0.2, 0.5, 0.9] {
            for seed in 0..10 {
                let mut pixels = vec![0u8; w * h];
                let o = occlude(share, &mut ChaCha8Rng::seed_from_u64(seed), spec, &mask, &mut pixels);
                assert!((o.hidden - share).abs() < 0.02, "share {share} seed {seed}: {}", o.hidden);
                assert!((1..=2).contains(&o.occluders.len()));
                // Painted where covered, nowhere else.
                for (k, &p) in pixels.iter().enumerate() {
                    let covered = o.occluders.iter().any(|oc| oc.covers(k % w, k / w));
                    let colours: Vec<u8> = o.occluders.iter().flat_map(|oc| oc.surface.colour.map(|c| c[0])).collect();
                    assert!(covered || p == 0, "{k}");
                    assert!(!covered || colours.contains(&p), "{k}");
                }
            }
        }
        let o = occlude(0.0, &mut ChaCha8Rng::seed_from_u64(0), spec, &mask, &mut vec![0u8; w * h]);
        assert!(o.occluders.is_empty() && o.hidden == 0.0);
    }

    #[test]
    fn bounds_hold_the_covered_pixels() {
        for shape in [OccluderShape::Rect, OccluderShape::Ellipse] {
            let o = Occluder::new(shape, [10.3, 7.9], [4.2, 2.6]);
            let [x0, y0, x1, y1] = o.bounds(32, 24);
            for y in 0..24 {
                for x in 0..32 {
                    if o.covers(x, y) {
                        assert!((x0..x1).contains(&x) && (y0..y1).contains(&y));
                    }
                }
            }
            if shape == OccluderShape::Rect {
                assert_eq!((x1 - x0) * (y1 - y0), (0..24 * 32).filter(|k| o.covers(k % 32, k / 32)).count());
            }
            assert_eq!(Occluder::parse(&o.to_string()), Some(o));
        }
        assert_eq!(Occluder::new(OccluderShape::Rect, [-10.0, -10.0], [2.0, 2.0]).bounds(8, 8), [0, 0, 0, 0]);
    }
}
