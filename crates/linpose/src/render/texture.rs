//! Procedural clutter: a texture with structure at every scale, for the backgrounds of scenes
//! ([`super::background`]) and the surfaces of occluders ([`super::occlude`]).
//!
//! A texture is two layers, drawn from a random generator:
//!
//! 1. **Value noise** of several octaves: random values on lattices whose cells are from half the
//!    image's larger side down to [`FINEST_CELL`] pixels, each octave interpolated smoothly
//!    (bilinear with a cubic fade) and weighted half the one before, its range stretched between
//!    two random levels. This is the slow shading of a wall, a table or foliage.
//! 2. **Shapes** over it, [`SHAPES`] in number: rectangles, ellipses and parallelograms turned at
//!    random angles, from 4% to 60% of the image's smaller side (log-uniform, so small ones are
//!    many), each flat at a random level or striped (square stripes of 2 to 16 pixels at their own
//!    angle). This is the objects, edges and patterns of a room or a street.
//!
//! Nothing in it is uniform over more than a few percent of the image, and its edges run at
//! every angle and scale, so an eigenspace learnt on a uniform studio backdrop cannot take it
//! for one. On a colour image every level is a colour (the noise tinted per channel, each shape
//! its own colour); on a gray one a gray level.
//!
//! The arithmetic is IEEE-exact or goes through the pure-Rust `libm`, so a generator state gives
//! the same pixels on every machine.

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use std::f64::consts::PI;

/// The finest octave's lattice cell, pixels: finer noise would be pixel noise (the `noise`
/// background's business), coarser would leave the texture smooth at the scale of an object's
/// edges. A definition of the texture, not a trade-off.
pub(crate) const FINEST_CELL: f64 = 3.0;

/// How many shapes lie over the noise: two fifths of them are at least a fifth of the image's
/// smaller side, so large shapes and small ones are over every view, and no two views' layouts
/// look alike. A definition of the texture.
pub(crate) const SHAPES: std::ops::RangeInclusive<usize> = 10..=18;

/// Fills `out` (`width` x `height` pixels of `channels` interleaved 8-bit channels, 1 or 3) with
/// a clutter texture drawn from `rng`.
pub(crate) fn clutter(rng: &mut ChaCha8Rng, width: usize, height: usize, channels: usize, out: &mut [u8]) {
    debug_assert_eq!(out.len(), width * height * channels);
    let mut field = vec![0.0f64; width * height * channels];
    value_noise(rng, width, height, channels, &mut field);
    let side = width.min(height) as f64;
    for _ in 0..rng.random_range(SHAPES) {
        let shape = Shape::draw(rng, width as f64, height as f64, side, channels);
        shape.paint(width, height, channels, &mut field);
    }
    for (o, v) in out.iter_mut().zip(&field) {
        *o = quantise(*v);
    }
}

/// Value noise of several octaves, its range stretched between two random levels, added to
/// `field`; on colour images tinted per channel.
fn value_noise(rng: &mut ChaCha8Rng, width: usize, height: usize, channels: usize, field: &mut [f64]) {
    let mut cell = width.max(height) as f64 / 2.0;
    let mut weight = 1.0;
    let mut total = 0.0;
    let mut gray = vec![0.0f64; width * height];
    while cell >= FINEST_CELL {
        octave(rng, width, height, cell, weight, &mut gray);
        total += weight;
        cell /= 2.0;
        weight /= 2.0;
    }
    let (a, b) = (rng.random_range(0.0..0.5), rng.random_range(0.5..1.0));
    let tint: Vec<f64> = (0..channels).map(|_| if channels == 1 { 1.0 } else { rng.random_range(0.6..1.0) }).collect();
    for (k, g) in gray.iter().enumerate() {
        // Octaves sum to `total` at most; their sum sits near half of it, so the stretch is
        // about the middle.
        let v = a + (b - a) * (g / total);
        for (c, t) in tint.iter().enumerate() {
            field[k * channels + c] = v * t;
        }
    }
}

/// One octave: a lattice of `cell`-pixel cells with random values in [0, 1), interpolated at each
/// pixel's centre, times `weight`, added to `gray`.
fn octave(rng: &mut ChaCha8Rng, width: usize, height: usize, cell: f64, weight: f64, gray: &mut [f64]) {
    let (gw, gh) = ((width as f64 / cell) as usize + 2, (height as f64 / cell) as usize + 2);
    let lattice: Vec<f64> = (0..gw * gh).map(|_| rng.random::<f64>()).collect();
    // A random offset, so the lattices of the octaves do not share their corners.
    let (ox, oy) = (rng.random::<f64>(), rng.random::<f64>());
    let fade = |t: f64| t * t * (3.0 - 2.0 * t);
    for y in 0..height {
        let v = (y as f64 + 0.5) / cell + oy;
        let j = (v as usize).min(gh - 2);
        let ty = fade(v - j as f64);
        for x in 0..width {
            let u = (x as f64 + 0.5) / cell + ox;
            let i = (u as usize).min(gw - 2);
            let tx = fade(u - i as f64);
            let at = |i: usize, j: usize| lattice[j * gw + i];
            let top = at(i, j) + (at(i + 1, j) - at(i, j)) * tx;
            let bottom = at(i, j + 1) + (at(i + 1, j + 1) - at(i, j + 1)) * tx;
            gray[y * width + x] += weight * (top + (bottom - top) * ty);
        }
    }
}

/// What a shape looks like: a kind, its place, size and angle, and its surface.
struct Shape {
    kind: Kind,
    centre: [f64; 2],
    half: [f64; 2],
    /// Its axes' direction (cos, sin).
    axis: [f64; 2],
    /// The colour (or gray level) of its surface, and of its stripes' second half.
    level: [[f64; 3]; 2],
    /// Square stripes: their period in pixels and direction (cos, sin), if any.
    stripes: Option<(f64, [f64; 2])>,
}

#[derive(Clone, Copy)]
enum Kind {
    Rect,
    Ellipse,
    /// A rectangle sheared by half its height: the edges of a roof or a stair.
    Slant,
}

impl Shape {
    fn draw(rng: &mut ChaCha8Rng, width: f64, height: f64, side: f64, channels: usize) -> Shape {
        let kind = [Kind::Rect, Kind::Ellipse, Kind::Slant][rng.random_range(0..3)];
        // Log-uniform sizes from 4% to 60% of the smaller side, an aspect ratio within 1:4.
        let size = side * libm::exp(rng.random_range(libm::log(0.04)..libm::log(0.6)));
        let aspect = libm::exp(rng.random_range(-0.7..0.7));
        let half = [size * aspect / 2.0, size / aspect / 2.0];
        let centre = [rng.random_range(0.0..width), rng.random_range(0.0..height)];
        let angle = rng.random_range(0.0..PI);
        let mut colour = || -> [f64; 3] {
            let base = rng.random_range(0.0..1.0);
            match channels {
                1 => [base; 3],
                _ => [0, 1, 2].map(|_| (base + rng.random_range(-0.25..0.25)).clamp(0.0, 1.0)),
            }
        };
        let level = [colour(), colour()];
        let stripes = if rng.random_bool(0.4) {
            let period = libm::exp(rng.random_range(libm::log(4.0)..libm::log(32.0)));
            let a = rng.random_range(0.0..PI);
            Some((period, [libm::cos(a), libm::sin(a)]))
        } else {
            None
        };
        Shape { kind, centre, half, axis: [libm::cos(angle), libm::sin(angle)], level, stripes }
    }

    /// Paints the shape over `field` at the pixels whose centres it covers.
    fn paint(&self, width: usize, height: usize, channels: usize, field: &mut [f64]) {
        // The bounding box of the turned shape (a slant's shear widens it by half its height).
        let reach = self.half[0] + self.half[1] * 1.5;
        let x0 = (self.centre[0] - reach).max(0.0) as usize;
        let y0 = (self.centre[1] - reach).max(0.0) as usize;
        let x1 = ((self.centre[0] + reach + 1.0).max(0.0) as usize).min(width);
        let y1 = ((self.centre[1] + reach + 1.0).max(0.0) as usize).min(height);
        let [c, s] = self.axis;
        for y in y0..y1 {
            for x in x0..x1 {
                let (dx, dy) = (x as f64 + 0.5 - self.centre[0], y as f64 + 0.5 - self.centre[1]);
                let (u, v) = ((c * dx + s * dy) / self.half[0], (c * dy - s * dx) / self.half[1]);
                let inside = match self.kind {
                    Kind::Rect => u.abs() <= 1.0 && v.abs() <= 1.0,
                    Kind::Ellipse => u * u + v * v <= 1.0,
                    Kind::Slant => (u - 0.5 * v).abs() <= 1.0 && v.abs() <= 1.0,
                };
                if !inside {
                    continue;
                }
                let second = self.stripes.is_some_and(|(p, [sc, ss])| {
                    let t = (x as f64 * sc + y as f64 * ss) / p;
                    t - libm::floor(t) >= 0.5
                });
                let colour = self.level[second as usize];
                let k = (y * width + x) * channels;
                field[k..k + channels].copy_from_slice(&colour[..channels]);
            }
        }
    }
}

/// [0, 1] to 0..=255, rounding half up.
fn quantise(v: f64) -> u8 {
    (v * 255.0 + 0.5).clamp(0.0, 255.0) as u8
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    fn draw(seed: u64, w: usize, h: usize, c: usize) -> Vec<u8> {
        let mut out = vec![0u8; w * h * c];
        clutter(&mut ChaCha8Rng::seed_from_u64(seed), w, h, c, &mut out);
        out
    }

    #[test]
    fn a_generator_state_gives_one_texture() {
        assert_eq!(draw(3, 64, 48, 1), draw(3, 64, 48, 1));
        assert_ne!(draw(3, 64, 48, 1), draw(4, 64, 48, 1));
    }

    #[test]
    fn the_texture_is_varied_at_every_scale() {
        for seed in 0..20 {
            let (w, h) = (96, 72);
            let t = draw(seed, w, h, 1);
            // Spread over the levels: no level holds more than a third of the pixels.
            let mut hist = [0usize; 256];
            t.iter().for_each(|&v| hist[v as usize] += 1);
            assert!(*hist.iter().max().unwrap() < w * h / 3, "seed {seed}");
            // Its blocks of 12 x 12 differ from each other: not one uniform field.
            let means: Vec<f64> = (0..6)
                .flat_map(|by| (0..8).map(move |bx| (bx, by)))
                .map(|(bx, by)| (0..144).map(|k| t[(by * 12 + k / 12) * w + bx * 12 + k % 12] as f64).sum::<f64>() / 144.0)
                .collect();
            let spread = means.iter().cloned().fold(f64::MIN, f64::max) - means.iter().cloned().fold(f64::MAX, f64::min);
            assert!(spread > 40.0, "seed {seed}: block means within {spread}");
        }
    }

    #[test]
    fn colour_textures_have_colour() {
        let t = draw(1, 64, 48, 3);
        let coloured = t.chunks_exact(3).filter(|p| p[0] != p[1] || p[1] != p[2]).count();
        assert!(coloured > 64 * 48 / 2, "{coloured}");
    }
}
