//! Simulated pixel noise: uniform noise added to images and clipped, the noise of the paper's
//! experiments and of the held-out views that the automatic choices score under noise.

use crate::{Error, Result};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

/// Adds uniform noise of +-`amplitude` (a fraction of full brightness) to every feature of every
/// row and clips to [0, 1]. Row i draws from its own ChaCha8 stream of `seed`, so the result does
/// not depend on the thread count.
#[cfg_attr(not(feature = "bench"), allow(unreachable_pub))] // public through crate::bench
pub fn add_uniform_noise(features: &mut [f32], m: usize, amplitude: f64, seed: u64) -> Result<()> {
    if !(amplitude.is_finite() && (0.0..=1.0).contains(&amplitude)) {
        return Err(Error::invalid("noise", amplitude, "must be a fraction of full brightness in [0, 1] (0.05 = +-5%)"));
    }
    if amplitude == 0.0 {
        return Ok(());
    }
    let a = amplitude as f32;
    features.par_chunks_mut(m).enumerate().for_each(|(i, row)| {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(i as u64);
        for v in row.iter_mut() {
            *v = (*v + rng.random_range(-a..a)).clamp(0.0, 1.0);
        }
    });
    Ok(())
}
