//! What the refined method's fit allocates, for the memory plan ([`crate::memory`]); bytes, with
//! N images, M features and P points of the reporting lattice: the binned copies (4 N M (1/4 +
//! 1/16) when the factor is chosen, 4 N M / b^2 for a factor b > 1), 5.5 N M + 7.5 N M / b^2
//! (the held-out fits' copies at the finest factor b tried), 40 N^2 (the PCA), 2 KiB P (the
//! held-out fits' lattice searches) and, with three or more pose parameters (where a camera roll
//! can be, `crate::manifold::roll`), 4 (S - 1) N M for the training views turned between the
//! training rolls, S the roll split.

use super::tuning::{BINNED_BYTES, DEFAULT_RESOLUTION, FULL_BYTES, LATTICE_BYTES, ROLL_SPLIT, SYSTEM_BYTES};
use super::RefinedParams;
use crate::model::footprint::{system, Footprint, Parts, Sizes};

impl Footprint for RefinedParams {
    fn fit(&self, s: &Sizes) -> Parts {
        let (n, m) = (s.n as f64, s.m as f64);
        // The binned copies (every candidate factor's when chosen), and the held-out fits
        // at the finest factor tried.
        let (copies, finest) = match self.bin {
            None => (4.0 * n * m * (1.0 / 4.0 + 1.0 / 16.0), 1.0),
            Some(b) if b > 1 => (4.0 * n * m / (b * b) as f64, (b * b) as f64),
            Some(_) => (0.0, 1.0),
        };
        // A roll is counted wherever one could be: the plan runs before the poses' names matter.
        let split = if s.params >= 3 { self.roll_split.unwrap_or(ROLL_SPLIT).max(1) } else { 1 };
        Parts::default()
            .add(copies, "the binned images")
            .add(4.0 * (split - 1) as f64 * n * m, "the views turned between the training rolls")
            .add(FULL_BYTES * n * m + BINNED_BYTES * n * m / finest, "the held-out fits' copies of the images")
            .add(system(n, SYSTEM_BYTES), format!("N x N Gram of {} images and its eigendecomposition", s.n))
            .add(LATTICE_BYTES * s.lattice as f64, "the held-out fits' lattice searches")
    }

    /// The reporting lattice: the resolution, or the default one for continuous poses.
    fn lattice_step(&self) -> Option<f64> {
        Some(if self.resolution > 0.0 { self.resolution } else { DEFAULT_RESOLUTION })
    }
}
