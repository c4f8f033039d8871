//! Tests of the pixel-noise estimate: what it measures, and that every path (8-bit and f32,
//! staged and whole, AVX-512 and portable) gives the same numbers.

use super::*;
use rand::{Rng, SeedableRng};

#[test]
fn pixel_noise_ignores_planes_and_measures_white_noise() {
    // Immerkaer's mask cancels any plane exactly, and for white noise of variance s^2 its mean
    // absolute response is 6 s sqrt(2 / pi) (the mask's squared weights sum to 36).
    let (w, h) = (64, 48);
    let plane: Vec<f32> = (0..w * h).map(|i| 0.2 + 0.003 * (i % w) as f32 + 0.002 * (i / w) as f32).collect();
    assert!(pixel_noise(&plane, w, h, 1) < 1e-9);
    // Uniform noise of +-a (variance a^2 / 3) on a constant 0.5 image, from a fixed LCG.
    let (a, mut state) = (0.05f32, 12345u64);
    let noisy: Vec<f32> = (0..w * h)
        .map(|_| {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            0.5 + a * (2.0 * (state >> 40) as f32 / (1u64 << 24) as f32 - 1.0)
        })
        .collect();
    let ms = noisy.iter().map(|&v| v as f64 * v as f64).sum::<f64>() / (w * h) as f64;
    let want = (a as f64).powi(2) / 3.0 / ms;
    let got = pixel_noise(&noisy, w, h, 1);
    assert!((got / want - 1.0).abs() < 0.25, "estimate {got}, expected {want}");
}

/// The 8-bit pixel-noise estimate (i16 lanes, u32 sums) is exact: it equals the mask responses
/// summed plainly in i64, on random images and on a 0 / 255 checkerboard, whose responses reach
/// the extreme +-2040, grey and in 3 channels.
#[test]
fn the_8_bit_pixel_variance_is_exact() {
    let reference = |x: &[u8], w: usize, h: usize, ch: usize| -> f64 {
        let at = |yy: usize, i: usize| x[yy * w * ch + i] as i64;
        let (mut sum, mut count) = (0i64, 0usize);
        for yy in (1..h - 1).step_by(NOISE_ROW_STEP) {
            let dy = |i: usize| at(yy - 1, i) - 2 * at(yy, i) + at(yy + 1, i);
            sum += (0..w * ch - 2 * ch).map(|i| (dy(i) - 2 * dy(i + ch) + dy(i + 2 * ch)).abs()).sum::<i64>();
            count += 1;
        }
        let sigma = (std::f64::consts::PI / 2.0).sqrt() * sum as f64 / (6.0 * ((w * ch - 2 * ch) * count) as f64);
        sigma * sigma
    };
    let mut state = 7u64;
    let mut slot = None;
    for &(w, h, ch) in &[(160usize, 120usize, 1usize), (37, 21, 3), (3, 3, 1), (1000, 9, 1)] {
        let random: Vec<u8> = (0..w * h * ch)
            .map(|_| {
                state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                (state >> 56) as u8
            })
            .collect();
        let checker: Vec<u8> = (0..w * h * ch).map(|i| if ((i / ch) % w + i / (w * ch)) % 2 == 0 { 255 } else { 0 }).collect();
        // Row buffers reused from image to image and size to size (as batches do), and ones
        // flushing their u32 lanes after every row (as a very wide image would).
        let mut flushing = RowsU8::new(w * ch, ch);
        flushing.flush_every = 1;
        for x in [&random, &checker] {
            let (got, want) = (pixel_variance_u8(x, w, h, ch), reference(x, w, h, ch));
            assert_eq!(got, want, "{w} x {h} x {ch}");
            assert_eq!(pixel_variance_u8_in(x, w, h, ch, RowsU8::reuse(&mut slot, w * ch, ch), 0.0), want, "reused, {w} x {h} x {ch}");
            assert_eq!(pixel_variance_u8_in(x, w, h, ch, &mut flushing, 0.0), want, "flushed, {w} x {h} x {ch}");
        }
    }
}

/// The f32 pixel-noise estimate gives its portable body's bits on every build (the AVX-512 one
/// sums the same lanes in the same order), on random images of several shapes: rows of whole
/// vectors, with a tail, narrower than a vector, and of 1 to 3 channels.
#[test]
fn the_f32_pixel_variance_gives_the_portable_bits() {
    let mut state = 11u64;
    for &(w, h, ch) in &[(160usize, 120usize, 1usize), (128, 128, 1), (37, 21, 3), (3, 3, 1), (1000, 9, 1), (17, 5, 2), (9, 40, 1)] {
        let x: Vec<f32> = (0..w * h * ch)
            .map(|_| {
                state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                (state >> 40) as f32 / (1u64 << 24) as f32
            })
            .collect();
        let portable = immerkaer(&x, w, h, ch, &mut RowsF32::new(w * ch, h, ch));
        assert_eq!(pixel_variance(&x, w, h, ch).to_bits(), portable.to_bits(), "{w} x {h} x {ch}");
        assert!(portable > 0.0);
    }
}

/// The staged pixel-noise estimate stops on its first pass exactly when that pass's estimate is
/// under `early`, and otherwise gives the whole estimate's bits, f32 and 8-bit, on random
/// images of several shapes (one of fewer than 2 x 4 sampled rows is never staged).
#[test]
fn the_staged_pixel_variance_stops_only_under_its_early_level() {
    let mut state = 5u64;
    for &(w, h, ch) in &[(160usize, 120usize, 1usize), (128, 128, 1), (37, 64, 3), (9, 40, 1)] {
        let x8: Vec<u8> = (0..w * h * ch)
            .map(|_| {
                state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                (state >> 56) as u8
            })
            .collect();
        let xf: Vec<f32> = x8.iter().map(|&v| v as f32 / 255.0).collect();
        let staged = sampled_rows(h) >= 2 * FIRST_EVERY;
        // f32: the first pass's estimate from the portable body.
        let mut rows = RowsF32::new(w * ch, h, ch);
        let (s, c) = immerkaer_pass(&xf, w, h, ch, &mut rows, Pass::First);
        let first = variance_from(s, c, w * ch, ch);
        let whole = pixel_variance(&xf, w, h, ch);
        assert!(first > 0.0 && first != whole, "{w} x {h} x {ch}");
        let mut slot = None;
        let mut at = |early: f64| pixel_variance_in(&xf, w, h, ch, RowsF32::reuse(&mut slot, w * ch, ch), early).to_bits();
        assert_eq!(at(first.next_up()), if staged { first } else { whole }.to_bits(), "f32 {w} x {h} x {ch}: stops");
        assert_eq!(at(first), whole.to_bits(), "f32 {w} x {h} x {ch}: goes on");
        assert_eq!(at(0.0), whole.to_bits());
        // 8-bit.
        let mut rows = RowsU8::new(w * ch, ch);
        let (s, c) = immerkaer_pass(&x8, w, h, ch, &mut rows, Pass::First);
        let first = variance_from(s, c, w * ch, ch);
        let whole = pixel_variance_u8(&x8, w, h, ch);
        let mut slot = None;
        let mut at = |early: f64| pixel_variance_u8_in(&x8, w, h, ch, RowsU8::reuse(&mut slot, w * ch, ch), early);
        assert_eq!(at(first.next_up()), if staged { first } else { whole }, "8-bit {w} x {h} x {ch}: stops");
        assert_eq!(at(first), whole, "8-bit {w} x {h} x {ch}: goes on");
    }
}

#[test]
fn immerkaer_recovers_white_noise_on_a_smooth_image() {
    let (w, h) = (64, 48);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
    let sigma = 0.03;
    let img: Vec<f32> = (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f64, (i / w) as f64);
            // A plane (the mask's response to it is zero) plus uniform noise of variance sigma^2.
            let a = sigma * 3f64.sqrt();
            (0.3 + 0.002 * x + 0.001 * y + rng.random_range(-a..a)) as f32
        })
        .collect();
    let est = estimate_noise_sigma(&img, w, h);
    assert!((est - sigma).abs() < 0.1 * sigma, "{est} vs {sigma}");
    let clean: Vec<f32> = (0..w * h).map(|i| 0.3 + 0.002 * (i % w) as f32).collect();
    assert!(estimate_noise_sigma(&clean, w, h) < 1e-6);
}
