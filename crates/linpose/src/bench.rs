//! What the crate's own benchmarks and examples time, for them alone: hidden from the
//! documentation, with no stability promised. Every function here is safe and runs at the SIMD
//! level detected on this CPU (capped by `LINPOSE_SIMD`, to time the other paths).

pub use crate::kernels::dot_q::DIGITS;
pub use crate::kernels::gram::gram_f32_fma;
pub use crate::kernels::gram8::gram_levels;
pub use crate::kernels::peak::{fma_flops_f64, read_seconds, vnni_gram_flops};
pub use crate::kernels::syrk::{pack_columns, pack_pairs_u8, pack_quads_u8, padded, SyrkAcc, KC, KCP, KCQ};
pub use crate::linalg::{gram, gram_f32, par, transpose_features};
pub use crate::methods::eigenspace::search::NearestIndex;
pub use crate::pixel_noise::add_uniform_noise;

/// The refined eigenspace's coarse-scan kernels (`crate::kernels::scan`), each at the detected
/// level.
pub mod scan {
    use crate::kernels::{scan, Level};

    pub use scan::boxes;

    /// `dist[i] = sum_q wt[q] (cols[q][i] - y[q])^2`.
    pub fn sq_dist(cols: &[f32], y: &[f32], wt: &[f32], dist: &mut [f32]) {
        scan::sq_dist(Level::detect(), cols, y, wt, dist)
    }

    /// [`sq_dist`] for the points within twice the least distance (+inf elsewhere), by boxes.
    pub fn sq_dist_boxed(cols: &[f32], boxes: &[f32], split: usize, y: &[f32], wt: &[f32], dist: &mut [f32], lb: &mut Vec<f32>) -> f32 {
        scan::sq_dist_boxed(Level::detect(), cols, scan::Boxes { boxes, split }, y, wt, dist, lb)
    }

    /// `u[i] = sum_q a[q] cols[q][i]` and `v[i] = sum_q a[q] gcols[q][i]`.
    pub fn dots2(cols: &[f32], gcols: &[f32], a: &[f32], u: &mut [f32], v: &mut [f32]) {
        scan::dots2(Level::detect(), cols, gcols, a, u, v)
    }

    /// The affine match's residual at every point, in place of `u`.
    pub fn affine_residuals(u: &mut [f32], v: &[f32], b_over_a: &[f64], inv_a: &[f64], inv_s: &[f64], ac: f64, zz: f64) {
        scan::affine_residuals(Level::detect(), u, v, b_over_a, inv_a, inv_s, scan::AffineTerms { ac, zz })
    }

    /// The least of `v`.
    pub fn least(v: &[f32]) -> f32 {
        scan::least(Level::detect(), v)
    }

    /// The index of the least of `v`.
    pub fn argmin(v: &[f32]) -> Option<usize> {
        scan::argmin(Level::detect(), v)
    }
}
