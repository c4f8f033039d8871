//! The appearance manifold as a continuous surface: the tensor-product cubic spline through the
//! training views' eigenspace coordinates (the same spline the eigenspace resamples densely), kept
//! in Hermite form and evaluated with its derivatives at any pose, so a query's pose is found by
//! Levenberg-Marquardt on the distance to the surface instead of the nearest of a fixed grid of
//! resampled points.
//!
//! The surface may instead be the local cubic ([`Interpolant::Local`]): the same Hermite pieces,
//! with each knot's slope the derivative of the parabola through it and its two neighbours along
//! the axis ([`Spline::local`]). Everything below holds for either; only the slope operators
//! differ.
//!
//! On each grid cell the spline is the tensor product of the per-axis cubic Hermite pieces, fixed
//! by the values and the mixed slopes at the cell's 2^D corners: for a derivative mask d (which
//! axes are differentiated) the slopes are S_d Y, the per-axis slope operators of
//! [`Spline::slopes`] applied along the axes in d. A point's value is a sum of 4^D products of
//! per-axis Hermite weights with those corner vectors, and its derivative in t_k the same sum with
//! axis k's weights differentiated. Resampling this at the eigenspace's dense positions gives the
//! eigenspace's manifold points (tested).
//!
//! Evaluation ([`eval`]), Levenberg-Marquardt on the distance to the surface and the snap to the
//! reporting lattice ([`lm`]), and the climb on that lattice ([`climb`]) are each in a file of
//! their own; their AVX-512 bodies are in [`crate::kernels::surface`].

pub(crate) mod climb;
mod eval;
pub(crate) mod lm;

pub(crate) use climb::BLOCK_DIM;

use crate::manifold::spline::{Boundary, Spline};
use crate::pose::{wrap_positive, PoseSpace};
use crate::Result;
use serde::{Deserialize, Serialize};

/// One pose parameter's curve ([`Surface::line_parts`]): knots (with the closing knot of a
/// circular axis), period, knot values and slopes (knot-major, L each), and L.
pub(crate) type LineParts<'a> = (&'a [f64], Option<f64>, &'a [f32], &'a [f32], usize);

/// How the surface passes between its knots: both are cubic on each knot interval, in Hermite
/// form, and differ only in the slopes at the knots.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Interpolant {
    /// The C2 cubic spline: the eigenspace's own manifold, every knot's slope
    /// tied to every value.
    #[default]
    Spline,
    /// The local cubic: each slope the derivative of the parabola through
    /// the knot and its two neighbours (Catmull-Rom on uniform knots), C1. A coordinate that
    /// changes abruptly between two training views (an edge or a highlight passing) moves it
    /// only on the pieces around them, where the spline rings along the whole axis.
    Local,
}

/// The interpolants the automatic choice scores, the spline first (it wins a tie).
pub(crate) const INTERPOLANTS: &[Interpolant] = &[Interpolant::Spline, Interpolant::Local];

impl Interpolant {
    /// The curve of this interpolant through `knots` with `boundary` ([`Spline::new`] or
    /// [`Spline::local`]).
    pub(crate) fn along(self, knots: &[f64], boundary: Boundary) -> Result<Spline> {
        match self {
            Interpolant::Spline => Spline::new(knots, boundary),
            Interpolant::Local => Spline::local(knots, boundary),
        }
    }

    /// Its name: `spline` or `local`.
    pub fn name(self) -> &'static str {
        match self {
            Interpolant::Spline => "spline",
            Interpolant::Local => "local",
        }
    }
}

impl std::fmt::Display for Interpolant {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Interpolant {
    type Err = crate::Error;
    fn from_str(s: &str) -> Result<Self> {
        INTERPOLANTS.iter().copied().find(|i| i.name() == s).ok_or_else(|| crate::Error::invalid("interpolant", s, "expected 'spline' or 'local'"))
    }
}

/// The continuous manifold of one fitted model.
#[derive(Debug, Clone)]
pub(crate) struct Surface {
    pub(crate) splines: Vec<Spline>,
    pub(crate) periods: Vec<Option<f64>>,
    /// Knots per axis.
    pub(crate) shape: Vec<usize>,
    /// Flat-index stride of each axis (row-major, the last fastest).
    pub(crate) stride: Vec<usize>,
    /// Coordinates per point, L.
    pub(crate) dim: usize,
    /// For each derivative mask (2^D), each knot's L values: `[mask][knot][L]`.
    pub(crate) coef: Vec<f32>,
}

impl Surface {
    /// The coefficients as the kernels read them.
    pub(crate) fn coefs(&self) -> crate::kernels::surface::Coefs<'_> {
        crate::kernels::surface::Coefs { coef: &self.coef, dim: self.dim }
    }

    /// The knot grid of a two-parameter surface as the kernels read it.
    pub(crate) fn grid2(&self) -> crate::kernels::surface::Grid2 {
        crate::kernels::surface::Grid2 { knots: self.shape[0] * self.shape[1], stride: [self.stride[0], self.stride[1]] }
    }

    /// The surface through `knots` (the training views' coordinates, `dim` each, row-major over
    /// the grid `axes`, last parameter fastest), by `interpolant` along each axis.
    pub(crate) fn new(space: &PoseSpace, axes: &[Vec<f64>], knots: &[f64], dim: usize, interpolant: Interpolant) -> Result<Self> {
        let d = axes.len();
        let shape: Vec<usize> = axes.iter().map(Vec::len).collect();
        let n: usize = shape.iter().product();
        debug_assert_eq!(knots.len(), n * dim);
        let mut splines = Vec::with_capacity(d);
        let periods: Vec<Option<f64>> = space.params().iter().map(|p| p.period).collect();
        for (ax, p) in axes.iter().zip(&periods) {
            let b = match p {
                Some(t) => Boundary::Periodic(*t),
                None => Boundary::NotAKnot,
            };
            splines.push(interpolant.along(ax, b)?);
        }
        let mut stride = vec![1; d];
        for j in (0..d.saturating_sub(1)).rev() {
            stride[j] = stride[j + 1] * shape[j + 1];
        }
        let mut coef = Vec::with_capacity((1 << d) * n * dim);
        for mask in 0..1usize << d {
            let mut cube = knots.to_vec();
            for j in (0..d).filter(|j| mask >> j & 1 == 1) {
                let inner = stride[j] * dim;
                let block = shape[j] * inner;
                let mut next = Vec::with_capacity(cube.len());
                for o in 0..cube.len() / block {
                    next.extend(splines[j].slopes(&cube[o * block..(o + 1) * block], inner));
                }
                cube = next;
            }
            coef.extend(cube.iter().map(|&v| v as f32));
        }
        Ok(Surface { splines, periods, shape, stride, dim, coef })
    }

    /// Number of pose parameters D.
    pub(crate) fn params(&self) -> usize {
        self.shape.len()
    }

    /// For one pose parameter: its knots (with the closing knot of a circular axis), its
    /// period, and the knot values and slopes (knot-major, L each) with L; None for D > 1.
    pub(crate) fn line_parts(&self) -> Option<LineParts<'_>> {
        if self.params() != 1 {
            return None;
        }
        let n = self.shape[0] * self.dim;
        Some((self.splines[0].knots(), self.periods[0], &self.coef[..n], &self.coef[n..2 * n], self.dim))
    }

    /// Numbers held: 2^D x N x L.
    pub(crate) fn len(&self) -> usize {
        self.coef.len()
    }

    /// Brings `t` into the domain: a circular parameter wrapped into [first knot, first knot +
    /// period), a linear one clamped to its knots' range.
    pub(crate) fn clamp(&self, t: &mut [f64]) {
        for (j, v) in t.iter_mut().enumerate() {
            let (lo, hi) = self.splines[j].span();
            *v = match self.periods[j] {
                Some(p) => lo + wrap_positive(*v - lo, p),
                None => v.clamp(lo, hi),
            };
        }
    }

    /// The number of points along each axis of [`Surface::grid_poses`], and whether the axis is
    /// circular.
    pub(crate) fn grid_shape(&self, per_cell: usize) -> Vec<(usize, bool)> {
        self.grid_shape_by(&vec![per_cell; self.params()])
    }

    /// [`Self::grid_shape`] with `per_cell[j]` points per knot interval along axis j.
    pub(crate) fn grid_shape_by(&self, per_cell: &[usize]) -> Vec<(usize, bool)> {
        self.shape
            .iter()
            .zip(&self.periods)
            .zip(per_cell)
            .map(|((&n, p), &c)| if p.is_some() { (n * c.max(1), true) } else { ((n - 1) * c.max(1) + 1, false) })
            .collect()
    }

    /// The poses of a regular grid over the domain with `per_cell` points per knot interval
    /// along each axis (the knots included), row-major.
    pub(crate) fn grid_poses(&self, per_cell: usize) -> Vec<f64> {
        self.grid_poses_by(&vec![per_cell; self.params()])
    }

    /// [`Self::grid_poses`] with `per_cell[j]` points per knot interval along axis j.
    pub(crate) fn grid_poses_by(&self, per_cell: &[usize]) -> Vec<f64> {
        let axes: Vec<Vec<f64>> = self
            .splines
            .iter()
            .zip(&self.periods)
            .zip(&self.shape)
            .zip(per_cell)
            .map(|(((s, p), &n), &per_cell)| {
                let per_cell = per_cell.max(1);
                let knots = s.knots();
                let pieces = if p.is_some() { n } else { n - 1 };
                let mut v = Vec::new();
                for i in 0..pieces {
                    for k in 0..per_cell {
                        v.push(knots[i] + (knots[i + 1] - knots[i]) * k as f64 / per_cell as f64);
                    }
                }
                if p.is_none() {
                    v.push(knots[n - 1]);
                }
                v
            })
            .collect();
        let total: usize = axes.iter().map(Vec::len).product();
        let d = axes.len();
        let mut out = Vec::with_capacity(total * d);
        for mut k in 0..total {
            let start = out.len();
            out.resize(start + d, 0.0);
            for j in (0..d).rev() {
                out[start + j] = axes[j][k % axes[j].len()];
                k /= axes[j].len();
            }
        }
        out
    }
}
