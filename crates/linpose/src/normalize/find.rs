//! Finding the object in one image: the background's level (dark, or the border's median), the
//! pixels that differ from it by more than a threshold, their 8-connected regions, the heaviest
//! of them (by summed deviation) and every region near it taken as the object, and its position
//! and size as moments of the deviation over its pixels. A noisy image is measured on a smoothed
//! copy.
//!
//! The moments are weighted by each pixel's deviation from the background, not counted over a
//! mask: an edge pixel half covered by the object weighs half, so the centroid and the radius
//! follow the object by fractions of a pixel, and a change of exposure (every deviation times
//! the same factor) leaves both unchanged. Sums are taken from the object's bounding box corner,
//! in row order, so an image moved by whole pixels gives bit-identical relative moments. The
//! silhouette's moments (every object pixel weighing 1) were measured against these: they serve
//! the twin better and the duck, the pot, the cap and COIL-20 worse (docs/normalization.md).

use super::tuning::{BLOB_SHARE, JOIN_GAP, NOISE_FACTOR, NOISE_ROW_STEP, NOISE_SIGMAS, PART_SHARE, SMOOTH};
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
    /// How many regions of the foreground make the object (its parts, and specks near them).
    pub parts: usize,
    /// The heaviest region away from the object that is heavy enough to be a second object, if
    /// any (left out of the object).
    pub apart: Option<Apart>,
}

impl Placement {
    /// The object's brightness independent of its size: weight per squared radius.
    pub(super) fn brightness(&self) -> f64 {
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

/// How [`locate`] tells the object from the background (the stage's fitted rules, see
/// [`super::Normalizer`]).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Rules {
    /// How the background's level is found.
    pub background: Background,
    /// The smallest deviation from the background that is foreground (a fraction of full
    /// brightness), raised to the border's noise unless `framed`.
    pub threshold: f32,
    /// Whether the data is framed to its objects, their views covering the border: the
    /// border's noise is then not measured.
    pub framed: bool,
    /// Whether the object may touch the frame edge.
    pub edges: bool,
}

/// Finds the object in `img` (`w` x `h` pixels of `c` interleaved channels) by `rules`: the
/// background level from `rules.background`, foreground where the deviation exceeds
/// `rules.threshold` (raised to the border's noise unless the data is `rules.framed`, its
/// objects covering the border), the heaviest 8-connected region and every region near it. An
/// object touching the frame edge is refused unless `rules.edges`. A `noisy` image (its pixel
/// noise given) is measured on a copy smoothed by a box of 2 [`SMOOTH`] + 1 pixels: the
/// background's level on its border, the threshold from the smoothed noise, and the radius
/// corrected for the box's own spread.
pub(crate) fn locate(img: &[f32], w: usize, h: usize, c: usize, rules: Rules, noisy: Option<f32>) -> Result<Placement, Rejection> {
    let Rules { background, threshold, framed, edges } = rules;
    if img.iter().any(|v| !v.is_finite()) {
        return Err(Rejection::NotFinite);
    }
    let smoothed;
    let smooth = if noisy.is_some() { SMOOTH } else { 0 };
    // A dark background's level is 0 whatever noise lifts the smoothed border to: the object's
    // weights are taken from it, so that clipped noise's mean does not lighten them.
    let true_level = (background == Background::Dark).then_some([0.0f32; 3]);
    let (img, background, threshold) = match noisy {
        None => (img, background, threshold),
        Some(sigma) => {
            smoothed = box_blur(img, w, h, c, SMOOTH);
            // Noise clipped at black has a positive mean, so the smoothed background's level
            // is measured on the border; the box divides white noise's deviation by its side.
            (&smoothed[..], Background::Border, threshold.max(NOISE_SIGMAS * sigma / (2 * SMOOTH + 1) as f32))
        }
    };
    // A measured background's border statistics serve both its level and its noise.
    let measured = match background {
        Background::Dark => None,
        Background::Border => Some(border(img, w, h, c, None)),
    };
    let level = measured.as_ref().map_or([0.0; 3], |b| b.median);
    let t = match (framed || noisy.is_some(), &measured) {
        (true, _) => threshold,
        (false, Some(b)) => threshold.max(NOISE_FACTOR * b.q90),
        (false, None) => threshold.max(NOISE_FACTOR * border(img, w, h, c, Some(level)).q90),
    };
    let dev: Vec<f32> = match c {
        1 => img.iter().map(|v| (v - level[0]).abs()).collect(),
        _ => img.chunks_exact(c).map(|px| deviation(px, &level)).collect(),
    };
    // A noisy image's moments are weighted by the smoothed pixels' deviations less what the
    // noise alone gives the background, so that the background pixels the smoothed threshold
    // lets in weigh little. On a dark background, clipped noise lifts a pixel of value v by its
    // mean: for uniform noise of amplitude a, (a - v)^2 / 4a below a. The border's lift (v = 0)
    // gives a = 4 x lift, and the lift is undone: v = 2 sqrt(a s) - a for a smoothed value s
    // below a (negative for the background's own noise, as often as it is positive above).
    let weights: std::borrow::Cow<[f32]> = match (noisy, true_level) {
        (None, _) => (&dev[..]).into(),
        (Some(_), Some(l)) => {
            let a: Vec<f32> = (0..c).map(|ch| 4.0 * (level[ch] - l[ch]).max(0.0)).collect();
            let declip = |s: f32, a: f32| if s >= a { s } else { 2.0 * (a * s.max(0.0)).sqrt() - a };
            match c {
                1 => img.iter().map(|&v| declip(v - l[0], a[0])).collect::<Vec<f32>>().into(),
                _ => img
                    .chunks_exact(c)
                    .map(|px| px.iter().zip(&a).zip(&l).map(|((&v, &a), &l)| declip(v - l, a)).sum::<f32>() / c as f32)
                    .collect::<Vec<f32>>()
                    .into(),
            }
        }
        (Some(_), None) => {
            let floor = border_mean(&dev, w, h);
            dev.iter().map(|d| d - floor).collect::<Vec<f32>>().into()
        }
    };
    // 8-connected regions of the foreground: the runs of each row, joined to the runs of the row
    // above that touch them (overlapping or diagonally adjacent) through a union-find.
    let mut runs: Vec<Run> = Vec::new();
    let mut parent: Vec<usize> = Vec::new();
    let mut above = 0..0;
    for y in 0..h {
        let row = &dev[y * w..(y + 1) * w];
        let first = runs.len();
        let mut x = 0;
        while x < w {
            if row[x] <= t {
                x += 1;
                continue;
            }
            let start = x;
            let mut weight = 0.0f64;
            while x < w && row[x] > t {
                weight += row[x] as f64;
                x += 1;
            }
            let id = runs.len();
            parent.push(id);
            for k in above.clone() {
                let r: &Run = &runs[k];
                if r.x0 <= x && start <= r.x1 {
                    let (a, b) = (root(&mut parent, k), root(&mut parent, id));
                    if a != b {
                        parent[a.max(b)] = a.min(b);
                    }
                }
            }
            runs.push(Run { y, x0: start, x1: x, weight });
        }
        above = first..runs.len();
    }
    // Each region's totals, at its root's place, in the order of the roots.
    let mut of_root = vec![usize::MAX; runs.len()];
    let mut regions: Vec<Region> = Vec::new();
    let mut region_of = vec![0usize; runs.len()];
    for (k, r) in runs.iter().enumerate() {
        let top = root(&mut parent, k);
        if of_root[top] == usize::MAX {
            of_root[top] = regions.len();
            regions.push(Region::new(r.x0, r.y));
        }
        region_of[k] = of_root[top];
        regions[of_root[top]].add_run(r, w, h);
    }
    let Some(main) = (0..regions.len()).max_by(|&a, &b| regions[a].weight.total_cmp(&regions[b].weight)) else {
        return Err(Rejection::Empty { threshold: t, level: level[0] });
    };
    // The object is every region near the heaviest one: a handle, a stem or a part that a dark
    // band or a gap cuts off in the image belongs to it. Regions farther away are another object
    // (when heavy enough to be one, [`Apart`]) or specks, and are left out.
    let size = regions[main].extent() as f64;
    let mut part = vec![false; regions.len()];
    let mut apart: Option<Apart> = None;
    for (k, r) in regions.iter().enumerate() {
        let gap = regions[main].gap(r);
        if r.weight < PART_SHARE * regions[main].weight && k != main {
            // A speck of noise or dust, or a sliver of the object too slight to matter.
        } else if gap <= JOIN_GAP * size {
            part[k] = true;
        } else if r.weight >= BLOB_SHARE * regions[main].weight && apart.is_none_or(|a| r.weight > a.share * regions[main].weight) {
            apart = Some(Apart { share: r.weight / regions[main].weight, gap, limit: JOIN_GAP * size });
        }
    }
    let parts = part.iter().filter(|&&p| p).count();
    let object = regions.iter().enumerate().filter(|&(k, _)| part[k] && k != main).fold(regions[main].clone(), |a, (_, r)| a.union(r));
    if object.touches.iter().any(|&t| t) && !edges {
        return Err(Rejection::TouchesEdge { sides: object.touches });
    }
    // Moments from the bounding box corner, row by row: two passes, the centroid then the spread.
    let (x0, y0) = (object.x0, object.y0);
    // Row by row (the runs are in row order, each row's from the left): the row's weight and
    // its first moment along x, then the row's place.
    let parts_runs: Vec<&Run> = runs.iter().zip(&region_of).filter(|(_, &g)| part[g]).map(|(r, _)| r).collect();
    let (mut sw, mut sx, mut sy) = (0.0, 0.0, 0.0);
    let mut k = 0;
    while k < parts_runs.len() {
        let y = parts_runs[k].y;
        let (mut rw, mut rx) = (0.0f64, 0.0f64);
        while k < parts_runs.len() && parts_runs[k].y == y {
            let r = parts_runs[k];
            for x in r.x0..r.x1 {
                let d = weights[y * w + x] as f64;
                rw += d;
                rx += d * (x - x0) as f64;
            }
            k += 1;
        }
        sw += rw;
        sx += rx;
        sy += rw * (y - y0) as f64;
    }
    let (cx, cy) = (sx / sw, sy / sw);
    let mut s2 = 0.0;
    for r in &parts_runs {
        let dy = (r.y - y0) as f64 - cy;
        for x in r.x0..r.x1 {
            let dx = (x - x0) as f64 - cx;
            s2 += weights[r.y * w + x] as f64 * (dx * dx + dy * dy);
        }
    }
    // A box of 2k + 1 pixels adds its variance, ((2k + 1)^2 - 1) / 12, along each axis.
    let spread = 2.0 * (((2 * smooth + 1) * (2 * smooth + 1)) as f64 - 1.0) / 12.0;
    let radius = (s2 / sw - spread).max(s2 / sw / 4.0).sqrt();
    if !(radius > 0.0 && sw > 0.0) {
        return Err(Rejection::Empty { threshold: t, level: level[0] });
    }
    // The level the image is shifted by: a dark background's stays 0 under noise, as the
    // methods' noisy matches expect clipped noise's lift.
    let level = true_level.unwrap_or(level);
    Ok(Placement { level, origin: (x0 as i64, y0 as i64), cx, cy, radius, weight: sw, touches: object.touches, parts, apart })
}

/// The mean of `dev` over the frame's border.
fn border_mean(dev: &[f32], w: usize, h: usize) -> f32 {
    let idx: Vec<usize> = border_pixels(w, h).collect();
    idx.iter().map(|&i| dev[i]).sum::<f32>() / idx.len().max(1) as f32
}

/// The pixel noise of `img` (`w` x `h` pixels of `c` interleaved channels), on the mean of its
/// channels: Immerkaer's estimate of its standard deviation (Fast noise variance estimation,
/// CVIU 64:300-302, 1996: the response to [1 -2 1; -2 4 -2; 1 -2 1], which cancels planes and
/// smooth shading, has 36 times white noise's variance), taken from the median absolute response
/// rather than the mean, so that the object's edges and texture, a minority of the pixels, do
/// not count as noise (a clean COIL-20 view's mean-based estimate is up to 0.016, +-5% noise's
/// 0.026).
pub(crate) fn noise(img: &[f32], w: usize, h: usize, c: usize) -> f32 {
    if w < 3 || h < 3 {
        return 0.0;
    }
    // Every NOISE_ROW_STEP-th interior row: the median of a few thousand responses is as good,
    // and the estimate stays a small part of a query's normalisation.
    let gray = |y: usize| -> std::borrow::Cow<[f32]> {
        let row = &img[y * w * c..(y + 1) * w * c];
        match c {
            1 => row.into(),
            _ => row.chunks_exact(c).map(|px| px.iter().sum::<f32>() / c as f32).collect::<Vec<f32>>().into(),
        }
    };
    let mut r = Vec::with_capacity((h / NOISE_ROW_STEP + 1) * (w - 2));
    for y in (1..h - 1).step_by(NOISE_ROW_STEP) {
        let (a, b, d) = (gray(y - 1), gray(y), gray(y + 1));
        for x in 1..w - 1 {
            let v = (a[x - 1] + a[x + 1] + d[x - 1] + d[x + 1]) - 2.0 * (a[x] + b[x - 1] + b[x + 1] + d[x]) + 4.0 * b[x];
            r.push(v.abs());
        }
    }
    // For Gaussian noise the median absolute response is 0.6745 of its deviation, 6 sigma.
    median(&mut r) / (0.6745 * 6.0)
}

/// `img` (`w` x `h` pixels of `c` interleaved channels) averaged over a box of 2 `k` + 1 pixels
/// on a side, the box cut at the frame's edges (separable: rows, then columns).
fn box_blur(img: &[f32], w: usize, h: usize, c: usize, k: usize) -> Vec<f32> {
    let pass = |src: &[f32], len: usize, count: usize, at: &dyn Fn(usize, usize) -> usize| -> Vec<f32> {
        let mut out = vec![0.0f32; src.len()];
        for line in 0..count {
            for ch in 0..c {
                for i in 0..len {
                    let (a, b) = (i.saturating_sub(k), (i + k).min(len - 1));
                    let sum: f32 = (a..=b).map(|j| src[at(line, j) * c + ch]).sum();
                    out[at(line, i) * c + ch] = sum / (b - a + 1) as f32;
                }
            }
        }
        out
    };
    let rows = pass(img, w, h, &|y, x| y * w + x);
    pass(&rows, h, w, &|x, y| y * w + x)
}

/// A region of the foreground away from the object: what [`super::Normalizer::fit`] reports as a
/// second object in a training view.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Apart {
    /// Its weight over the object's heaviest region's.
    pub share: f64,
    /// Its distance from that region (pixels between their bounding boxes).
    pub gap: f64,
    /// The farthest a part of the object may lie from that region (pixels): [`JOIN_GAP`] times
    /// its size.
    pub limit: f64,
}

/// A run of foreground pixels in one row: columns `x0` to `x1` (exclusive), its summed deviation.
struct Run {
    y: usize,
    x0: usize,
    x1: usize,
    weight: f64,
}

/// The root of `k` in the union-find `parent`, halving the path on the way.
fn root(parent: &mut [usize], mut k: usize) -> usize {
    while parent[k] != k {
        parent[k] = parent[parent[k]];
        k = parent[k];
    }
    k
}

/// A region's running totals while it is filled.
#[derive(Clone)]
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

    /// The longer side of its bounding box (pixels).
    fn extent(&self) -> usize {
        (self.x1 - self.x0).max(self.y1 - self.y0) + 1
    }

    /// The distance between its bounding box and `other`'s (pixels; 0 when they overlap or touch).
    fn gap(&self, other: &Region) -> f64 {
        let along = |a0: usize, a1: usize, b0: usize, b1: usize| b0.saturating_sub(a1 + 1).max(a0.saturating_sub(b1 + 1)) as f64;
        let (gx, gy) = (along(self.x0, self.x1, other.x0, other.x1), along(self.y0, self.y1, other.y0, other.y1));
        (gx * gx + gy * gy).sqrt()
    }

    /// The totals of both regions together.
    fn union(mut self, other: &Region) -> Region {
        self.weight += other.weight;
        self.x0 = self.x0.min(other.x0);
        self.y0 = self.y0.min(other.y0);
        self.x1 = self.x1.max(other.x1);
        self.y1 = self.y1.max(other.y1);
        for (t, o) in self.touches.iter_mut().zip(other.touches) {
            *t |= o;
        }
        self
    }

    fn add_run(&mut self, r: &Run, w: usize, h: usize) {
        self.weight += r.weight;
        self.x0 = self.x0.min(r.x0);
        self.y0 = self.y0.min(r.y);
        self.x1 = self.x1.max(r.x1 - 1);
        self.y1 = self.y1.max(r.y);
        self.touches[0] |= r.x0 == 0;
        self.touches[1] |= r.x1 == w;
        self.touches[2] |= r.y == 0;
        self.touches[3] |= r.y + 1 == h;
    }
}
