//! Knots between the training rolls: where a pose space has a camera roll beside elevation and
//! azimuth ([`crate::PoseSpace::error_deg`]'s rotation), a roll turns the image in its plane and
//! nothing else, so the view at a roll between two training rolls is a training view turned in
//! the image. The surface through the training views' coordinates bends between its knots as a
//! cubic in each parameter, and an image turned by half a knot interval is far from the cubic's
//! midpoint (a turned edge is not a blend of two edges): turned views placed as extra knots along
//! the roll axis hold the surface to the images there.
//!
//! [`RollKnots::new`] splits every knot interval of the roll axis into `split` equal parts
//! (the closing interval of a circular roll too, when it is no wider than the widest other one)
//! and makes the view at each new knot from the two training views around it, each turned to
//! the new roll about the image's centre (bilinear) and weighted by its nearness. A turned
//! image's corners come from outside the frame: they take the view's backdrop level, the median
//! of its border pixels per channel, which is the background where the object stays clear of the
//! border (a rendered view's, a turntable's uniform backdrop) and only an approximation where it
//! does not. The turned views are not training views: they are only knots of a surface, and the
//! settings chosen on held-out training views are chosen without them.

use crate::dataset::Dataset;
use crate::image_io::ImageSpec;
use crate::manifold::grid::Grid;
use crate::manifold::tuning::TURN_PAIRS;
use crate::Result;
use rayon::prelude::*;

/// The dense grid of knots along a roll axis: its positions, and at each point a training view
/// or a turned one.
#[derive(Debug)]
pub(crate) struct RollKnots {
    /// Knot positions per parameter: the grid's, with the roll axis split.
    pub axes: Vec<Vec<f64>>,
    /// What stands at each point of the dense grid (row-major, the last parameter fastest).
    pub knots: Vec<Knot>,
    /// The turned views in the grid's order, at the training views' size.
    pub turned: Dataset,
}

/// One point of [`RollKnots`]' grid.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Knot {
    /// A training view (its index in the training set).
    View(usize),
    /// A turned view (its index in [`RollKnots::turned`]).
    Turned(usize),
}

impl RollKnots {
    /// The dense knots of the training views `full` on `grid` with the roll axis's intervals
    /// split into `split` parts; None when the space has no roll ([`crate::PoseSpace`]'s
    /// in-plane roll), the roll has one training value, or `split` is below 2.
    pub(crate) fn new(full: &Dataset, grid: &Grid, split: usize) -> Result<Option<RollKnots>> {
        let space = full.space();
        let Some(r) = space.in_plane_roll() else { return Ok(None) };
        let rolls = &grid.axes[r];
        if split < 2 || rolls.len() < 2 {
            return Ok(None);
        }
        let period = space.params()[r].period;
        // Each dense roll: (value, lower knot index, upper knot index, the upper's value).
        let mut dense: Vec<(f64, usize, usize, f64)> = Vec::new();
        let widest = rolls.windows(2).map(|w| w[1] - w[0]).fold(0.0, f64::max);
        let n = rolls.len();
        for i in 0..n {
            let (j, b) = match (i + 1 < n, period) {
                (true, _) => (i + 1, rolls[i + 1]),
                (false, Some(t)) if rolls[0] + t - rolls[i] <= widest => (0, rolls[0] + t),
                _ => (i, rolls[i]),
            };
            let a = rolls[i];
            dense.push((a, i, i, a));
            if j != i {
                dense.extend((1..split).map(|k| (a + (b - a) * k as f64 / split as f64, i, j, b)));
            }
        }
        let mut axes = grid.axes.clone();
        axes[r] = dense.iter().map(|p| p.0).collect();
        // Row-major strides of the original grid and of the dense one.
        let shape: Vec<usize> = grid.axes.iter().map(Vec::len).collect();
        let dshape: Vec<usize> = axes.iter().map(Vec::len).collect();
        let total: usize = dshape.iter().product();
        let spec = full.spec();
        let mf = spec.features();
        // The original grid's flat index of a dense point with its roll knot replaced by `k`.
        let original = |mut flat: usize, k: usize| {
            let mut idx = vec![0; dshape.len()];
            for j in (0..dshape.len()).rev() {
                idx[j] = flat % dshape[j];
                flat /= dshape[j];
            }
            let (d, mut o) = (dense[idx[r]], 0);
            for j in 0..shape.len() {
                o = o * shape[j] + if j == r { k } else { idx[j] };
            }
            (d, o)
        };
        let mut at_turned = Vec::new();
        let knots: Vec<Knot> = (0..total)
            .map(|p| {
                let ((v, i, _, _), _) = original(p, 0);
                if v == rolls[i] {
                    Knot::View(grid.sample_at[original(p, i).1])
                } else {
                    at_turned.push(p);
                    Knot::Turned(at_turned.len() - 1)
                }
            })
            .collect();
        let mut pixels = vec![0f32; at_turned.len() * mf];
        pixels.par_chunks_exact_mut(mf).zip(&at_turned).for_each_init(
            || vec![0f32; mf],
            |turned, (out, &p)| {
                let ((v, i, j, b), _) = original(p, 0);
                let lower = grid.sample_at[original(p, i).1];
                let upper = grid.sample_at[original(p, j).1];
                let (a, wa) = (rolls[i], (b - v) / (b - rolls[i]));
                turn(full.row(lower), spec, v - a, &backdrop(full.row(lower), spec), out);
                out.iter_mut().for_each(|x| *x *= wa as f32);
                turn(full.row(upper), spec, v - b, &backdrop(full.row(upper), spec), turned);
                out.iter_mut().zip(turned.iter()).for_each(|(x, &y)| *x += (1.0 - wa) as f32 * y);
            },
        );
        let mut poses = Vec::with_capacity(at_turned.len() * dshape.len());
        for &(mut p) in &at_turned {
            let at = poses.len();
            poses.resize(at + dshape.len(), 0.0);
            for j in (0..dshape.len()).rev() {
                poses[at + j] = axes[j][p % dshape[j]];
                p /= dshape[j];
            }
        }
        // A circular roll's values stay within one period of its first knot (the grid's own).
        let turned = Dataset::new(spec, pixels, space.clone(), poses)?;
        Ok(Some(RollKnots { axes, knots, turned }))
    }

    /// Number of points on the dense grid.
    pub(crate) fn len(&self) -> usize {
        self.knots.len()
    }
}

/// How far each training view of `full` on `grid` turned in the image to the next training value
/// of the roll (parameter `r`) lands from the training view there, relative to how far apart the
/// two views are: the sum of ||turn(x_a, b - a) - x_b||^2 over every pair of neighbouring rolls
/// (every other parameter equal) over the sum of ||x_a - x_b||^2. Near 0 where a roll turns the
/// image and nothing else (less the corners and the bilinear blur); near 1 or above where it
/// changes the image otherwise. At most [`TURN_PAIRS`] pairs, evenly spread over the grid, are
/// compared. None with fewer than two rolls or identical neighbours.
pub(crate) fn turn_error(full: &Dataset, grid: &Grid, r: usize) -> Option<f64> {
    let shape: Vec<usize> = grid.axes.iter().map(Vec::len).collect();
    let stride: usize = shape[r + 1..].iter().product();
    let n = shape[r];
    let spec = full.spec();
    let all: Vec<usize> = (0..grid.sample_at.len()).filter(|&p| (p / stride) % n + 1 < n).collect();
    let every = all.len().div_ceil(TURN_PAIRS).max(1);
    let pairs: Vec<usize> = all.into_iter().step_by(every).collect();
    let (turned, still) = pairs
        .par_iter()
        .map_init(
            || vec![0f32; spec.features()],
            |out, &p| {
                let k = (p / stride) % n;
                let (a, b) = (full.row(grid.sample_at[p]), full.row(grid.sample_at[p + stride]));
                turn(a, spec, grid.axes[r][k + 1] - grid.axes[r][k], &backdrop(a, spec), out);
                let sq = |x: &[f32]| x.iter().zip(b).map(|(&u, &v)| (u as f64 - v as f64).powi(2)).sum::<f64>();
                (sq(out), sq(a))
            },
        )
        .reduce(|| (0.0, 0.0), |x, y| (x.0 + y.0, x.1 + y.1));
    (still > 0.0).then(|| turned / still)
}

/// The backdrop level of an image: the median of its border pixels, per channel.
pub(crate) fn backdrop(image: &[f32], spec: ImageSpec) -> Vec<f32> {
    let (w, h, ch) = (spec.width as usize, spec.height as usize, spec.color.channels());
    let border = |x: usize, y: usize| x == 0 || y == 0 || x + 1 == w || y + 1 == h;
    (0..ch)
        .map(|c| {
            let mut v: Vec<f32> = (0..w * h).filter(|&p| border(p % w, p / w)).map(|p| image[p * ch + c]).collect();
            v.sort_by(f32::total_cmp);
            v.get(v.len() / 2).copied().unwrap_or(0.0)
        })
        .collect()
}

/// `image` turned by `deg` degrees counter-clockwise (as seen, rows top to bottom) about the
/// image's centre into `out`, as a camera's roll turns it (the renderer's `Camera::roll`):
/// bilinear, each of the four source pixels outside the frame read as `fill` (one value per
/// channel).
pub(crate) fn turn(image: &[f32], spec: ImageSpec, deg: f64, fill: &[f32], out: &mut [f32]) {
    let (w, h, ch) = (spec.width as usize, spec.height as usize, spec.color.channels());
    let (cx, cy) = ((w as f64 - 1.0) / 2.0, (h as f64 - 1.0) / 2.0);
    let (s, c) = deg.to_radians().sin_cos();
    let at = |x: isize, y: isize, k: usize| -> f64 {
        if x < 0 || y < 0 || x >= w as isize || y >= h as isize {
            fill[k] as f64
        } else {
            image[(y as usize * w + x as usize) * ch + k] as f64
        }
    };
    // floor without a library call (the source points are within a few frames of the image).
    let floor = |v: f64| {
        let i = v as isize;
        if (i as f64) > v {
            i - 1
        } else {
            i
        }
    };
    for y in 0..h {
        let qy = y as f64 - cy;
        for x in 0..w {
            let qx = x as f64 - cx;
            // The point that the turn carries to (x, y): the inverse turn of (x, y).
            let (sx, sy) = (cx + qx * c - qy * s, cy + qx * s + qy * c);
            let (x0, y0) = (floor(sx), floor(sy));
            let (fx, fy) = (sx - x0 as f64, sy - y0 as f64);
            if x0 >= 0 && y0 >= 0 && x0 + 1 < w as isize && y0 + 1 < h as isize {
                // Inside the frame (most pixels): the four source pixels read directly.
                let (i, o) = ((y0 as usize * w + x0 as usize) * ch, (y * w + x) * ch);
                let (fx, fy) = (fx as f32, fy as f32);
                for k in 0..ch {
                    let top = image[i + k] * (1.0 - fx) + image[i + ch + k] * fx;
                    let bottom = image[i + w * ch + k] * (1.0 - fx) + image[i + (w + 1) * ch + k] * fx;
                    out[o + k] = top * (1.0 - fy) + bottom * fy;
                }
                continue;
            }
            for k in 0..ch {
                let top = at(x0, y0, k) * (1.0 - fx) + at(x0 + 1, y0, k) * fx;
                let bottom = at(x0, y0 + 1, k) * (1.0 - fx) + at(x0 + 1, y0 + 1, k) * fx;
                out[(y * w + x) * ch + k] = (top * (1.0 - fy) + bottom * fy) as f32;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image_io::ColorMode;
    use crate::render::{objects, render, Camera, RenderParams};

    fn view(roll: f64) -> Vec<f32> {
        let mesh = objects::builtin("duck").unwrap();
        let params = RenderParams::default().width(64).height(48).camera(Camera::default().roll(roll));
        render(&mesh, 30.0, 50.0, &params).unwrap().pixels().map(|p| p.0[0] as f32 / 255.0).collect()
    }

    fn sq(a: &[f32], b: &[f32]) -> f64 {
        a.iter().zip(b).map(|(&u, &v)| (u as f64 - v as f64).powi(2)).sum()
    }

    #[test]
    fn a_positive_turn_is_the_renderers_positive_roll() {
        let spec = ImageSpec { width: 64, height: 48, color: ColorMode::Gray };
        let (at0, at10) = (view(0.0), view(10.0));
        let fill = backdrop(&at0, spec);
        assert_eq!(fill, vec![0.0]);
        let (mut plus, mut minus) = (vec![0.0; at0.len()], vec![0.0; at0.len()]);
        turn(&at0, spec, 10.0, &fill, &mut plus);
        turn(&at0, spec, -10.0, &fill, &mut minus);
        let (e_plus, e_minus, apart) = (sq(&plus, &at10), sq(&minus, &at10), sq(&at0, &at10));
        assert!(e_plus < 0.1 * apart && e_minus > apart, "{e_plus} {e_minus} {apart}");
        // No turn is the image itself.
        turn(&at0, spec, 0.0, &fill, &mut plus);
        assert_eq!(plus, at0);
    }
}
