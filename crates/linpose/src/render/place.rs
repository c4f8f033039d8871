//! Views put somewhere in a larger image (a canvas): the object, with its occluders, scaled by
//! a random factor and placed at a random position over the canvas's background, so that a
//! search for the object (`linpose::robust`, a query larger than the training views) can be
//! measured against where it is.
//!
//! The view's object and occluders are a layer over a transparent frame: opaque where the
//! object or an occluder is, transparent elsewhere. The layer is scaled by s (log-uniform in the
//! canvas's range) with bilinear resampling of its premultiplied colour and its opacity, placed
//! with its frame's top-left corner at a uniform position that keeps the frame inside the
//! canvas, and laid over the background. The frame's box in the canvas is recorded.

use crate::image_io::ImageSpec;
use crate::{Error, Result};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The generator's seed offset of the placements, apart from the backgrounds' and occluders'.
const PLACE_SALT: u64 = 0x9e37_79b9_7f4a_7c15;

/// Where views go: a canvas of `width` x `height` pixels, each view scaled by a factor in
/// `scale` (smallest, largest).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Canvas {
    /// The canvas's width, pixels.
    pub width: u32,
    /// The canvas's height, pixels.
    pub height: u32,
    /// The smallest and largest scale of a view on it.
    pub scale: [f64; 2],
}

impl Canvas {
    /// A canvas of `width` x `height` holding views scaled by `scale[0]` to `scale[1]`.
    pub fn new(width: u32, height: u32, scale: [f64; 2]) -> Result<Canvas> {
        let [lo, hi] = scale;
        if !(lo.is_finite() && hi.is_finite() && lo > 0.0 && lo <= hi) {
            return Err(Error::invalid("scale", format!("{lo}:{hi}"), "a range LO:HI of positive factors, LO <= HI"));
        }
        if width == 0 || height == 0 {
            return Err(Error::invalid("canvas", format!("{width}x{height}"), "a size of at least one pixel"));
        }
        Ok(Canvas { width, height, scale })
    }

    /// The canvas for views of `w` x `h`: refused when the largest scale's view does not fit.
    pub fn check_views(&self, w: u32, h: u32) -> Result<()> {
        let hi = self.scale[1];
        if w as f64 * hi > self.width as f64 || h as f64 * hi > self.height as f64 {
            return Err(Error::invalid(
                "canvas",
                format!("{}x{}", self.width, self.height),
                format!("room for the views ({w}x{h}) scaled by {hi}: at least {:.0}x{:.0}", (w as f64 * hi).ceil(), (h as f64 * hi).ceil()),
            ));
        }
        Ok(())
    }

    /// View `view`'s box (left, top, width, height) for a frame of `w` x `h`, drawn from `seed`.
    pub(crate) fn draw_box(&self, seed: u64, view: usize, w: u32, h: u32) -> [f64; 4] {
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ PLACE_SALT);
        rng.set_stream(view as u64);
        let [lo, hi] = self.scale;
        let s = if hi > lo { (lo.ln() + rng.random::<f64>() * (hi / lo).ln()).exp() } else { lo };
        let (bw, bh) = (w as f64 * s, h as f64 * s);
        let x = rng.random::<f64>() * (self.width as f64 - bw).max(0.0);
        let y = rng.random::<f64>() * (self.height as f64 - bh).max(0.0);
        [x, y, bw, bh]
    }

    /// The canvas's spec for views of `spec`'s colour.
    pub fn spec(&self, spec: ImageSpec) -> ImageSpec {
        ImageSpec { width: self.width, height: self.height, color: spec.color }
    }
}

/// Lays `layer` (8-bit, `spec`'s size and channels; opaque where `opaque`) over `canvas` (8-bit,
/// the canvas's size, same channels) in the box `bbox` (left, top, width, height), bilinear.
pub(crate) fn lay(layer: &[u8], opaque: &[bool], spec: ImageSpec, bbox: [f64; 4], canvas: &mut [u8], canvas_w: usize) {
    let c = spec.color.channels();
    let (w, h) = (spec.width as usize, spec.height as usize);
    let canvas_h = canvas.len() / c / canvas_w;
    let [x0, y0, bw, bh] = bbox;
    let s = bw / w as f64;
    // The layer's pixel (i, j), premultiplied, or transparent outside the frame.
    let alpha = |i: isize, j: isize| if i < 0 || j < 0 || i >= w as isize || j >= h as isize || !opaque[j as usize * w + i as usize] { 0.0 } else { 1.0 };
    let value = |i: isize, j: isize, ch: usize| if alpha(i, j) > 0.0 { layer[(j as usize * w + i as usize) * c + ch] as f64 } else { 0.0 };
    let xs = (x0.floor().max(0.0) as usize).min(canvas_w);
    let xe = ((x0 + bw).ceil().max(0.0) as usize).min(canvas_w);
    let ys = (y0.floor().max(0.0) as usize).min(canvas_h);
    let ye = ((y0 + bh).ceil().max(0.0) as usize).min(canvas_h);
    for yy in ys..ye {
        let v = (yy as f64 + 0.5 - y0) / s - 0.5;
        let (j, fy) = (v.floor() as isize, v - v.floor());
        for xx in xs..xe {
            let u = (xx as f64 + 0.5 - x0) / s - 0.5;
            let (i, fx) = (u.floor() as isize, u - u.floor());
            let weights = [((0, 0), (1.0 - fx) * (1.0 - fy)), ((1, 0), fx * (1.0 - fy)), ((0, 1), (1.0 - fx) * fy), ((1, 1), fx * fy)];
            let a: f64 = weights.iter().map(|&((di, dj), wt)| wt * alpha(i + di, j + dj)).sum();
            if a <= 0.0 {
                continue;
            }
            let px = &mut canvas[(yy * canvas_w + xx) * c..(yy * canvas_w + xx + 1) * c];
            for (ch, p) in px.iter_mut().enumerate() {
                let pre: f64 = weights.iter().map(|&((di, dj), wt)| wt * value(i + di, j + dj, ch)).sum();
                *p = (pre + (1.0 - a) * *p as f64).round().clamp(0.0, 255.0) as u8;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image_io::ColorMode;

    #[test]
    fn a_layer_lands_in_its_box_over_the_background() {
        let spec = ImageSpec { width: 20, height: 10, color: ColorMode::Gray };
        let layer = vec![200u8; 200];
        let opaque: Vec<bool> = (0..200).map(|k| (5..15).contains(&(k % 20))).collect();
        let mut canvas = vec![10u8; 60 * 40];
        let bbox = [12.0, 8.0, 30.0, 15.0]; // scale 1.5
        lay(&layer, &opaque, spec, bbox, &mut canvas, 60);
        // The opaque columns 5..15 of the layer span canvas columns 12 + 7.5 .. 12 + 22.5.
        for y in 0..40 {
            for x in 0..60 {
                let v = canvas[y * 60 + x];
                let inside = (21..33).contains(&x) && (9..22).contains(&y);
                let outside = !(18..36).contains(&x) || !(7..24).contains(&y);
                assert!(!inside || v == 200, "({x}, {y}) = {v}");
                assert!(!outside || v == 10, "({x}, {y}) = {v}");
            }
        }
    }

    #[test]
    fn boxes_are_drawn_in_range_and_a_small_canvas_is_refused() {
        let c = Canvas::new(320, 240, [0.8, 1.2]).unwrap();
        for view in 0..200 {
            let [x, y, w, h] = c.draw_box(7, view, 128, 128);
            assert!(x >= 0.0 && y >= 0.0 && x + w <= 320.0 && y + h <= 240.0);
            assert!((102.4..=153.6).contains(&w) && w == h);
        }
        assert_eq!(c.draw_box(7, 3, 128, 128), c.draw_box(7, 3, 128, 128));
        assert!(c.check_views(128, 128).is_ok());
        let e = c.check_views(128, 220).unwrap_err().to_string();
        assert!(e.contains("320x240") && e.contains("128x220"), "{e}");
        for bad in [[0.0, 1.0], [1.2, 0.8], [f64::NAN, 1.0]] {
            assert!(Canvas::new(320, 240, bad).is_err());
        }
    }
}
