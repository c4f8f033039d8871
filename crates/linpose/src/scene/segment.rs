//! Finding the object of a studio view: the pixels that are not the uniform backdrop.
//!
//! 1. **Backdrop.** Its level is the median of the frame's border pixels (per channel), its
//!    spread the [`SPREAD_QUANTILE`] of their deviations from it, so that an object reaching the
//!    border, as in views framed to their objects, does not count as backdrop noise.
//! 2. **Object pixels.** Those that deviate from the level (the largest deviation over the
//!    channels) by more than [`SPREAD_FACTOR`] times the spread, and at least
//!    [`MIN_THRESHOLD`] gray levels.
//! 3. **Cleaning.** Their 8-connected regions; the largest, and every other region at least
//!    [`SPECK_SHARE`] of it (and [`SPECK_PIXELS`]) and within [`JOIN_GAP`] of its size, are the object (a handle or a
//!    part a dark band cuts off joins it, specks are left out).
//! 4. **Holes.** A region of backdrop pixels the object encloses (4-connected, not reaching the
//!    frame) is filled when it is at most [`HOLE_SHARE`] of the object: a part of the object
//!    as dark as the backdrop (or a hole through a handle, which the two cannot be told from);
//!    a larger one is a hole through the object (a ring's) and gets the scene's background.
//!
//! A view is refused, with the reason, when its border is not a uniform backdrop (the threshold
//! would exceed [`MAX_THRESHOLD`]) or nothing but specks differs from it.
//!
//! What it cannot do: a part of the object at the backdrop's level that reaches the object's
//! outline is taken for backdrop (a black tyre or handle on black), a small hole through the
//! object keeps the studio's backdrop, a shadow the object casts on the backdrop is taken for
//! the object, and a backdrop that is not uniform (a gradient, a seam, a second object) is
//! refused or, when faint, partly taken for the object. A pixel the object's edge covers in
//! part keeps its mix with the studio's backdrop.

use super::tuning::{HOLE_SHARE, JOIN_GAP, MAX_THRESHOLD, MIN_OBJECT_PIXELS, MIN_THRESHOLD, SPECK_PIXELS, SPECK_SHARE, SPREAD_FACTOR, SPREAD_QUANTILE};
use crate::image_io::ImageSpec;
use crate::{Error, Result};
use std::path::Path;

/// The object found in a studio view.
#[derive(Debug, Clone, PartialEq)]
pub struct ObjectMask {
    /// The object's pixels, row-major.
    pub mask: Vec<bool>,
    /// The backdrop's level per channel (gray: the first), 8-bit.
    pub level: [u8; 3],
    /// The smallest deviation from the level that counted as the object, gray levels.
    pub threshold: f64,
    /// How many regions make the object.
    pub parts: usize,
    /// How many of its pixels are holes filled.
    pub filled: usize,
}

/// Finds the object in `pixels` (8-bit, `spec`'s size and channels interleaved) against its
/// studio backdrop: the pixels that deviate from the backdrop's level (the border's median) by
/// more than its own spread allows, their largest region with the parts near it (specks left
/// out), and the holes it encloses filled up to a quarter of its size ([`crate::scene`] says
/// more). Refused, with the reason and `path`: a border that is not a uniform backdrop, and a
/// view where nothing but specks differs from it.
pub fn find_object(path: &Path, spec: ImageSpec, pixels: &[u8]) -> Result<ObjectMask> {
    let (w, h, c) = (spec.width as usize, spec.height as usize, spec.color.channels());
    if pixels.len() != w * h * c {
        return Err(Error::Dataset { path: path.to_path_buf(), message: format!("{} values for a {w}x{h} view of {c} channels", pixels.len()) });
    }
    let refuse = |message: String| Error::Dataset { path: path.to_path_buf(), message: format!("no separable object: {message}") };
    let border = border_pixels(w, h);
    let mut level = [0u8; 3];
    for (ch, l) in level.iter_mut().enumerate().take(c) {
        let mut v: Vec<u8> = border.iter().map(|&k| pixels[k * c + ch]).collect();
        let mid = v.len() / 2;
        *l = *v.select_nth_unstable(mid).1;
    }
    let deviation = |k: usize| (0..c).map(|ch| pixels[k * c + ch].abs_diff(level[ch])).max().unwrap_or(0);
    let mut spread: Vec<u8> = border.iter().map(|&k| deviation(k)).collect();
    let q = ((spread.len() - 1) as f64 * SPREAD_QUANTILE) as usize;
    let spread = *spread.select_nth_unstable(q).1 as f64;
    let threshold = (SPREAD_FACTOR * spread).max(MIN_THRESHOLD);
    if threshold > MAX_THRESHOLD {
        return Err(refuse(format!(
            "the border is not a uniform backdrop (its pixels spread over +-{spread} gray levels around {}); the object is found only against a plain one",
            level_text(level, c)
        )));
    }
    let foreground: Vec<bool> = (0..w * h).map(|k| deviation(k) as f64 > threshold).collect();
    let regions = label(&foreground, w, h, true);
    let Some(main) = regions.iter().max_by_key(|r| r.area) else {
        return Err(refuse(format!("nothing differs from the backdrop ({}) by more than {threshold} gray levels", level_text(level, c))));
    };
    if main.area < MIN_OBJECT_PIXELS {
        return Err(refuse(format!("only specks of at most {} pixels differ from the backdrop ({})", main.area, level_text(level, c))));
    }
    let size = main.extent() as f64;
    let speck = (SPECK_SHARE * main.area as f64).max(SPECK_PIXELS as f64);
    let keep: Vec<bool> = regions.iter().map(|r| r.area as f64 >= speck && main.gap(r) <= JOIN_GAP * size).collect();
    let parts = keep.iter().filter(|&&k| k).count();
    let mut mask: Vec<bool> = vec![false; w * h];
    for (r, _) in regions.iter().zip(&keep).filter(|(_, &k)| k) {
        r.pixels.iter().for_each(|&k| mask[k] = true);
    }
    let area = mask.iter().filter(|&&m| m).count();
    let mut filled = 0;
    let holes = label(&mask.iter().map(|&m| !m).collect::<Vec<_>>(), w, h, false);
    for hole in holes.iter().filter(|r| !r.touches && r.area as f64 <= HOLE_SHARE * area as f64) {
        hole.pixels.iter().for_each(|&k| mask[k] = true);
        filled += hole.area;
    }
    Ok(ObjectMask { mask, level, threshold, parts, filled })
}

/// `12` for gray, `(12, 40, 7)` for colour.
fn level_text(level: [u8; 3], c: usize) -> String {
    match c {
        1 => format!("level {}", level[0]),
        _ => format!("level {:?}", &level[..c]),
    }
}

/// The frame edge's pixel indices (each once).
fn border_pixels(w: usize, h: usize) -> Vec<usize> {
    let top_bottom = (0..w).flat_map(|x| [x, (h - 1) * w + x]);
    let sides = (1..h.saturating_sub(1)).flat_map(|y| [y * w, y * w + w - 1]);
    let mut v: Vec<usize> = top_bottom.chain(sides).collect();
    v.sort_unstable();
    v.dedup();
    v
}

/// A connected region of pixels.
struct Region {
    pixels: Vec<usize>,
    area: usize,
    /// Bounding box: columns x0..=x1, rows y0..=y1.
    bbox: [usize; 4],
    /// Whether it reaches the frame edge.
    touches: bool,
}

impl Region {
    /// The longer side of its bounding box.
    fn extent(&self) -> usize {
        let [x0, y0, x1, y1] = self.bbox;
        (x1 - x0).max(y1 - y0) + 1
    }

    /// The distance between its bounding box and `other`'s (0 when they overlap or touch).
    fn gap(&self, other: &Region) -> f64 {
        let along = |a0: usize, a1: usize, b0: usize, b1: usize| b0.saturating_sub(a1 + 1).max(a0.saturating_sub(b1 + 1)) as f64;
        let ([ax0, ay0, ax1, ay1], [bx0, by0, bx1, by1]) = (self.bbox, other.bbox);
        let (gx, gy) = (along(ax0, ax1, bx0, bx1), along(ay0, ay1, by0, by1));
        (gx * gx + gy * gy).sqrt()
    }
}

/// The connected regions of the `true` pixels of `set` (`w` x `h`, row-major): 8-connected when
/// `diagonal`, else 4-connected, in the order of their first pixel.
fn label(set: &[bool], w: usize, h: usize, diagonal: bool) -> Vec<Region> {
    let mut seen = vec![false; w * h];
    let mut regions = Vec::new();
    let mut stack = Vec::new();
    for start in 0..w * h {
        if !set[start] || seen[start] {
            continue;
        }
        seen[start] = true;
        stack.push(start);
        let mut r = Region { pixels: Vec::new(), area: 0, bbox: [start % w, start / w, start % w, start / w], touches: false };
        while let Some(k) = stack.pop() {
            let (x, y) = (k % w, k / w);
            r.pixels.push(k);
            r.area += 1;
            r.bbox = [r.bbox[0].min(x), r.bbox[1].min(y), r.bbox[2].max(x), r.bbox[3].max(y)];
            r.touches |= x == 0 || y == 0 || x + 1 == w || y + 1 == h;
            for (dx, dy) in [(-1i64, 0i64), (1, 0), (0, -1), (0, 1), (-1, -1), (1, -1), (-1, 1), (1, 1)].into_iter().take(if diagonal { 8 } else { 4 }) {
                let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
                    continue;
                }
                let n = ny as usize * w + nx as usize;
                if set[n] && !seen[n] {
                    seen[n] = true;
                    stack.push(n);
                }
            }
        }
        regions.push(r);
    }
    regions
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image_io::ColorMode;

    fn gray(w: u32, h: u32) -> ImageSpec {
        ImageSpec { width: w, height: h, color: ColorMode::Gray }
    }

    /// A 40 x 30 view on a backdrop of 50: a ring (outer radius 10, inner 6) at (14, 15) with a
    /// dark dot of the backdrop's level inside its body... and a bright square at (30, 8).
    fn view() -> Vec<u8> {
        (0..1200)
            .map(|k| {
                let (x, y) = ((k % 40) as f64 + 0.5, (k / 40) as f64 + 0.5);
                let d = ((x - 14.0).powi(2) + (y - 15.0).powi(2)).sqrt();
                if (27.0..34.0).contains(&x) && (5.0..12.0).contains(&y) {
                    200
                } else if d <= 10.0 && d > 6.0 {
                    if (x - 22.0).abs() < 1.0 && (y - 15.0).abs() < 1.0 {
                        50
                    } else {
                        180
                    }
                } else {
                    50
                }
            })
            .collect()
    }

    #[test]
    fn the_object_its_parts_and_its_small_holes_are_found() {
        let v = view();
        let o = find_object(Path::new("v.png"), gray(40, 30), &v).unwrap();
        assert_eq!(o.level, [50, 0, 0]);
        assert_eq!(o.parts, 2, "the square is a part: near the ring");
        // The dark dot enclosed by the ring's body is filled; the ring's hole is not.
        assert!(o.mask[15 * 40 + 21]);
        assert!(!o.mask[15 * 40 + 14], "the hole through the ring keeps the backdrop");
        assert_eq!(o.filled, 4);
        for (k, &p) in v.iter().enumerate() {
            if p != 50 {
                assert!(o.mask[k], "{k}");
            }
        }
    }

    #[test]
    fn specks_are_left_out_and_nothing_is_refused() {
        let mut v = view();
        v[29 * 40 + 39] = 255;
        let o = find_object(Path::new("v.png"), gray(40, 30), &v).unwrap();
        assert!(!o.mask[29 * 40 + 39]);
        let flat = vec![50u8; 1200];
        let e = find_object(Path::new("flat.png"), gray(40, 30), &flat).unwrap_err().to_string();
        assert!(e.contains("flat.png") && e.contains("no separable object"), "{e}");
        let mut specks = flat.clone();
        specks[600] = 200;
        let e = find_object(Path::new("s.png"), gray(40, 30), &specks).unwrap_err().to_string();
        assert!(e.contains("specks"), "{e}");
        let clutter: Vec<u8> = (0..1200u32).map(|k| (k * 7919 % 256) as u8).collect();
        let e = find_object(Path::new("c.png"), gray(40, 30), &clutter).unwrap_err().to_string();
        assert!(e.contains("c.png") && e.contains("not a uniform backdrop"), "{e}");
    }

    #[test]
    fn colour_views_use_every_channel() {
        // A red square on a green backdrop of the same luma would vanish in gray.
        let mut v = vec![0u8; 30 * 20 * 3];
        for k in 0..600 {
            let inside = (10..20).contains(&(k % 30)) && (5..15).contains(&(k / 30));
            v[k * 3..k * 3 + 3].copy_from_slice(if inside { &[150, 0, 0] } else { &[0, 77, 0] });
        }
        let o = find_object(Path::new("c.png"), ImageSpec { width: 30, height: 20, color: ColorMode::Rgb }, &v).unwrap();
        assert_eq!(o.mask.iter().filter(|&&m| m).count(), 100);
        assert_eq!(o.level, [0, 77, 0]);
    }
}
