//! Finding the object in one image: the background's level (dark, or the border's median), the
//! pixels that differ from it by more than a threshold, their 8-connected regions, the largest of
//! them (by summed deviation) taken as the object, and its position and size as moments of the
//! deviation over its pixels.
//!
//! The moments are weighted by each pixel's deviation from the background, not counted over a
//! mask: an edge pixel half covered by the object weighs half, so the centroid and the radius
//! follow the object by fractions of a pixel, and a change of exposure (every deviation times
//! the same factor) leaves both unchanged. Sums are taken from the object's bounding box corner,
//! in row order, so an image moved by whole pixels gives bit-identical relative moments. The
//! silhouette's moments (every object pixel weighing 1) were measured against these: they serve
//! the twin better and the duck, the pot, the cap and COIL-20 worse (docs/normalization.md).

use super::tuning::{BLOB_SHARE, NOISE_FACTOR};
use super::{Background, Rejection};

/// Where the object is and how large: what [`super::Normalizer::apply`] needs to resample it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Placement {
    /// The background level per channel (up to 3).
    pub level: [f32; 3],
    /// The object's bounding box corner (column, row): the origin of `cx`, `cy`.
    pub origin: (i64, i64),
    /// The centroid relative to `origin` (pixels).
    pub cx: f64,
    /// See `cx`.
    pub cy: f64,
    /// The root-mean-square distance of the object's weight from its centroid (pixels).
    pub radius: f64,
    /// The summed deviation over the object's pixels.
    pub weight: f64,
    /// Whether the object touches the frame edge (left, right, top, bottom).
    pub touches: [bool; 4],
}

impl Placement {
    /// The object's brightness independent of its size: weight per squared radius.
    pub fn brightness(&self) -> f64 {
        self.weight / (self.radius * self.radius)
    }
}

/// The background's statistics along the frame edge.
pub(crate) struct Border {
    /// The median of the border per channel.
    pub median: [f32; 3],
    /// The 90th percentile of the border's deviations from `level` (see [`deviation`]).
    pub q90: f32,
}

/// The mean over channels of the absolute differences from the background level.
#[inline]
pub(crate) fn deviation(px: &[f32], level: &[f32; 3]) -> f32 {
    let s: f32 = px.iter().zip(level).map(|(v, b)| (v - b).abs()).sum();
    s / px.len() as f32
}

/// The frame edge's pixel indices (each once).
fn border_pixels(w: usize, h: usize) -> impl Iterator<Item = usize> {
    let top_bottom = (0..w).flat_map(move |x| [x, (h - 1) * w + x]);
    let sides = (1..h.saturating_sub(1)).flat_map(move |y| [y * w, y * w + w - 1]);
    top_bottom.chain(sides).filter(move |&i| h > 1 || i < w)
}

/// The median (the upper one of an even count).
pub(crate) fn median(v: &mut [f32]) -> f32 {
    let k = v.len() / 2;
    *v.select_nth_unstable_by(k, f32::total_cmp).1
}

/// The border's median per channel and the 90th percentile of its deviations from `level`
/// (the median when `level` is `None`).
pub(crate) fn border(img: &[f32], w: usize, h: usize, c: usize, level: Option<[f32; 3]>) -> Border {
    let idx: Vec<usize> = border_pixels(w, h).collect();
    let mut med = [0.0f32; 3];
    for (ch, m) in med.iter_mut().enumerate().take(c) {
        let mut v: Vec<f32> = idx.iter().map(|&i| img[i * c + ch]).collect();
        *m = median(&mut v);
    }
    let level = level.unwrap_or(med);
    let mut dev: Vec<f32> = idx.iter().map(|&i| deviation(&img[i * c..(i + 1) * c], &level)).collect();
    let k = (dev.len() * 9 / 10).min(dev.len() - 1);
    let q90 = *dev.select_nth_unstable_by(k, f32::total_cmp).1;
    Border { median: med, q90 }
}

/// Finds the object in `img` (`w` x `h` pixels of `c` interleaved channels): the background
/// level from `background`, foreground where the deviation exceeds `threshold` (raised to the
/// border's noise when the border is background, `edges` false), the largest 8-connected region.
pub(crate) fn locate(img: &[f32], w: usize, h: usize, c: usize, background: Background, threshold: f32, edges: bool) -> Result<Placement, Rejection> {
    let n = w * h;
    // A measured background's border statistics serve both its level and its noise.
    let measured = match background {
        Background::Dark => None,
        Background::Border => Some(border(img, w, h, c, None)),
    };
    let level = measured.as_ref().map_or([0.0; 3], |b| b.median);
    let t = match (edges, &measured) {
        (true, _) => threshold,
        (false, Some(b)) => threshold.max(NOISE_FACTOR * b.q90),
        (false, None) => threshold.max(NOISE_FACTOR * border(img, w, h, c, Some(level)).q90),
    };
    let dev: Vec<f32> = match c {
        1 => img.iter().map(|v| (v - level[0]).abs()).collect(),
        _ => img.chunks_exact(c).map(|px| deviation(px, &level)).collect(),
    };
    if dev.iter().any(|d| !d.is_finite()) {
        return Err(Rejection::NotFinite);
    }
    // 8-connected regions of the foreground by flood fill; label 0 is background.
    let mut label = vec![0u32; n];
    let mut regions: Vec<Region> = Vec::new();
    let mut stack = Vec::new();
    for start in 0..n {
        if label[start] != 0 || dev[start] <= t {
            continue;
        }
        let id = regions.len() as u32 + 1;
        let mut r = Region::new(start % w, start / w);
        label[start] = id;
        stack.push(start);
        while let Some(i) = stack.pop() {
            let (x, y) = (i % w, i / w);
            r.add(x, y, dev[i] as f64, w, h);
            for ny in y.saturating_sub(1)..=(y + 1).min(h - 1) {
                for nx in x.saturating_sub(1)..=(x + 1).min(w - 1) {
                    let j = ny * w + nx;
                    if label[j] == 0 && dev[j] > t {
                        label[j] = id;
                        stack.push(j);
                    }
                }
            }
        }
        regions.push(r);
    }
    let Some((main, object)) = regions.iter().enumerate().max_by(|a, b| a.1.weight.total_cmp(&b.1.weight)) else {
        return Err(Rejection::Empty { threshold: t, level: level[0] });
    };
    let others: Vec<f64> = regions.iter().enumerate().filter(|&(k, _)| k != main).map(|(_, r)| r.weight / object.weight).collect();
    let blobs = others.iter().filter(|&&s| s >= BLOB_SHARE).count();
    if blobs > 0 {
        let largest = others.iter().cloned().fold(0.0, f64::max);
        return Err(Rejection::SeveralBlobs { count: blobs + 1, share: largest });
    }
    if object.touches.iter().any(|&t| t) && !edges {
        return Err(Rejection::TouchesEdge { sides: object.touches });
    }
    // Moments from the bounding box corner, row by row: two passes, the centroid then the spread.
    let id = main as u32 + 1;
    let (x0, y0) = (object.x0, object.y0);
    let pixels = || {
        (y0..=object.y1)
            .flat_map(move |y| (x0..=object.x1).map(move |x| (x, y)))
            .filter(|&(x, y)| label[y * w + x] == id)
            .map(|(x, y)| ((x - x0) as f64, (y - y0) as f64, dev[y * w + x] as f64))
    };
    let (mut sw, mut sx, mut sy) = (0.0, 0.0, 0.0);
    for (x, y, d) in pixels() {
        sw += d;
        sx += d * x;
        sy += d * y;
    }
    let (cx, cy) = (sx / sw, sy / sw);
    let s2: f64 = pixels().map(|(x, y, d)| d * ((x - cx) * (x - cx) + (y - cy) * (y - cy))).sum();
    let radius = (s2 / sw).sqrt();
    if !(radius > 0.0) {
        return Err(Rejection::Empty { threshold: t, level: level[0] });
    }
    Ok(Placement { level, origin: (x0 as i64, y0 as i64), cx, cy, radius, weight: sw, touches: object.touches })
}

/// A region's running totals while it is filled.
struct Region {
    weight: f64,
    x0: usize,
    y0: usize,
    x1: usize,
    y1: usize,
    touches: [bool; 4],
}

impl Region {
    fn new(x: usize, y: usize) -> Self {
        Region { weight: 0.0, x0: x, y0: y, x1: x, y1: y, touches: [false; 4] }
    }

    fn add(&mut self, x: usize, y: usize, d: f64, w: usize, h: usize) {
        self.weight += d;
        self.x0 = self.x0.min(x);
        self.y0 = self.y0.min(y);
        self.x1 = self.x1.max(x);
        self.y1 = self.y1.max(y);
        self.touches[0] |= x == 0;
        self.touches[1] |= x + 1 == w;
        self.touches[2] |= y == 0;
        self.touches[3] |= y + 1 == h;
    }
}
