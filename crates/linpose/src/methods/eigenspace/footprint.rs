//! What the eigenspace's fit allocates, for the memory plan ([`crate::memory`]); bytes, with N
//! images, M features, L eigenimages, D pose parameters and P manifold points (the lattice every
//! `manifold-step` degrees over the training poses, or with more than two pose parameters
//! 2^D per training view, the knots' surface and starts, 16 bytes per point and eigenimage
//! rather than 24):
//!
//! - in memory, N <= M: the PCA through the Gram matrix, 8 N M (an f64 transposed copy) +
//!   36 N^2 (the Gram matrix and its eigendecomposition) + 16 M L, then, the copy freed, the
//!   manifold, 8 M L + 24 P L, and the second look's knots (below).
//! - in memory, N > M: the PCA through the M x M scatter (`manifold::scatter`), 44 M^2 (the
//!   scatter, the covariance and its eigendecomposition), 16 B M (a block of B images in f64),
//!   8 N L (the coordinates) and 16 M L, then the manifold and the second look: its own PCA of
//!   the images binned by b (the coarsest of 4, 2, 1 leaving at least N pixels, M_b = M / b^2),
//!   through the scatter when N > M_b, and its K = min(N - 1, M_b) coordinates per view, kept
//!   as f64 and f32 knots and a surface of 2^D values per knot (K of them), and scanned at
//!   N or, for D <= 2, N 2^D points: about (20 + 4 2^D + 4 2^D) N K. A million views of 32 x 24
//!   and three parameters: K = 768, 53 GiB in all, which is why such a set streams.
//! - streamed, N > M (`stream.rs`; no second look): the PCA through the scatter as above, a
//!   block of images as f32 (4 B M), then the manifold. For N <= M the streamed fit loads the
//!   set and needs what the fit in memory needs.

use super::tuning::ENERGY_COMPONENTS;
use super::{Dimension, EigenspaceParams};
use crate::manifold::tuning::{EVD_SYSTEM_BYTES, KNOT_VALUE_BYTES, MANIFOLD_VALUE_BYTES, SCATTER_BLOCK};
use crate::model::footprint::{system, Footprint, Parts, Sizes};
use crate::tuning::second_look::{PER_CELL, SECOND_LOOK_BIN};

impl EigenspaceParams {
    /// Eigenimages L the fit keeps of `s`'s images.
    fn kept(&self, s: &Sizes) -> f64 {
        match self.dimension() {
            Dimension::Fixed(l) => l,
            Dimension::Energy(_) => ENERGY_COMPONENTS,
        }
        .min(s.n.saturating_sub(1))
        .min(s.m)
        .max(1) as f64
    }
}

/// The PCA of `n` images of `m` features keeping `l` components: through the Gram matrix for
/// N <= M, through the scatter beyond.
fn pca(n: f64, m: f64, l: f64) -> Parts {
    if n <= m {
        Parts::default()
            .add(8.0 * n * m, "the images' f64 transposed copy")
            .add(system(n, EVD_SYSTEM_BYTES), format!("N x N Gram of {} images and its eigendecomposition", n as usize))
            .add(16.0 * m * l, "the eigenimages")
    } else {
        scatter(n, m, l).add(16.0 * SCATTER_BLOCK.min(n as usize) as f64 * m, "a block of images in f64")
    }
}

/// The scatter route's own arrays: the M x M scatter and its eigendecomposition, the
/// coordinates and the eigenimages.
fn scatter(n: f64, m: f64, l: f64) -> Parts {
    Parts::default()
        .add(8.0 * m * m + system(m, EVD_SYSTEM_BYTES), format!("the M x M scatter of {} features and its eigendecomposition", m as usize))
        .add(8.0 * n * l, "the coordinates")
        .add(16.0 * m * l, "the eigenimages")
}

/// The manifold: the eigenimages and the manifold's points (or the knots, 4 N L, and their
/// surface and starts).
fn manifold(s: &Sizes, l: f64) -> Parts {
    let p = Parts::default().add(8.0 * s.m as f64 * l, "the eigenimages");
    if crate::manifold::dense_lattice(s.params) {
        p.add(MANIFOLD_VALUE_BYTES * s.lattice as f64 * l, "the resampled manifold")
    } else {
        p.add(4.0 * s.n as f64 * l, "the knots").add(KNOT_VALUE_BYTES * s.lattice as f64 * l, "the knots' surface and starts")
    }
}

/// The second look's arrays beyond what the first PCA needed (`second_look`), where they count:
/// with more images than binned features its PCA takes the scatter route, and its knots
/// (N x K, K = min(N - 1, M_b)) grow with N times the binned image.
fn second_look(s: &Sizes) -> Parts {
    let mut b = SECOND_LOOK_BIN;
    while b > 1 && s.m / (b * b) < s.n {
        b /= 2;
    }
    let (n, mb) = (s.n as f64, (s.m / (b * b)).max(1) as f64);
    let k = (n - 1.0).min(mb).max(1.0);
    let per_knot = if crate::manifold::dense_lattice(s.params) { PER_CELL.pow(s.params as u32) } else { 1 } as f64;
    let corners = (1u64 << s.params.min(16)) as f64;
    let look = if n > mb { scatter(n, mb, k) } else { Parts::default() };
    look.add((20.0 + 4.0 * corners + 4.0 * per_knot) * n * k, format!("the second look's {} coordinates per view", k as usize))
}

impl Footprint for EigenspaceParams {
    fn fit(&self, s: &Sizes) -> Parts {
        let (n, m) = (s.n as f64, s.m as f64);
        let l = self.kept(s);
        // The PCA, then, its copy and scatter freed, the manifold and the second look.
        let after = manifold(s, l).join(second_look(s));
        Parts::default().stage(pca(n, m, l), after)
    }

    fn lattice_step(&self) -> Option<f64> {
        Some(self.step())
    }

    /// With more images than features: the scatter, a block of images, the coordinates, then
    /// the manifold (no second look); for N <= M the streamed fit loads the set.
    fn streamed(&self, s: &Sizes) -> Option<Parts> {
        if s.n <= s.m {
            return None;
        }
        let (n, m) = (s.n as f64, s.m as f64);
        let l = self.kept(s);
        let pass = scatter(n, m, l).add(16.0 * SCATTER_BLOCK.min(s.n) as f64 * m, "a block of images in f32 and f64");
        let named = format!("the M x M scatter of {} features", s.m);
        Some(Parts::default().stage(pass, manifold(s, l).add(8.0 * n * l, "the coordinates")).named(named))
    }
}
