//! What the eigenspace's fit allocates, for the memory plan ([`crate::memory`]); bytes, with N
//! images, M features, L eigenimages and P resampled manifold points: the PCA, 8 N M (an f64
//! transposed copy) + 36 N^2 (the Gram matrix and its eigendecomposition) + 16 M L, then, the
//! copy freed, the manifold, 8 M L + 24 P L. P counts the points of the lattice every
//! `manifold-step` degrees over the training poses.

use super::tuning::ENERGY_COMPONENTS;
use super::{Dimension, EigenspaceParams};
use crate::manifold::tuning::{EVD_SYSTEM_BYTES, MANIFOLD_VALUE_BYTES};
use crate::model::footprint::{system, Footprint, Parts, Sizes};

impl Footprint for EigenspaceParams {
    fn fit(&self, s: &Sizes) -> Parts {
        let (n, m) = (s.n as f64, s.m as f64);
        let l = match self.dimension() {
            Dimension::Fixed(l) => l,
            Dimension::Energy(_) => ENERGY_COMPONENTS,
        }
        .min(s.n.saturating_sub(1))
        .min(s.m)
        .max(1) as f64;
        // The PCA (a transposed f64 copy, the Gram matrix and its eigendecomposition), then,
        // the copy freed, the manifold.
        let pca = Parts::default()
            .add(8.0 * n * m, "the images' f64 transposed copy")
            .add(system(n, EVD_SYSTEM_BYTES), format!("N x N Gram of {} images and its eigendecomposition", s.n))
            .add(16.0 * m * l, "the eigenimages");
        let manifold = Parts::default().add(8.0 * m * l, "the eigenimages").add(MANIFOLD_VALUE_BYTES * s.lattice as f64 * l, "the resampled manifold");
        Parts::default().stage(pca, manifold)
    }

    fn lattice_step(&self) -> Option<f64> {
        Some(self.step())
    }
}
