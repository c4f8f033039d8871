//! 8-bit features as integers. An 8-bit image's feature is the f32 value k * S8 (k the level,
//! S8 = fl(1/255), as `image_io` makes it). S8 has 24 significant bits and lies in [2^-8, 2^-7),
//! so m = S8 2^31 is an integer (8,421,505) and every feature is V_k 2^-31 with V_k = k m + r_k,
//! |r_k| <= 127 ([`residuals`]). A product of two features is then
//! 2^-62 (m^2 k_p k_q + m (k_p r_q + r_p k_q) + r_p r_q): the first two sums are what the
//! integer kernels of [`super::syrk`] add exactly ([`SCALE_PAIRS`] and [`SCALE_CROSS`] are their
//! weights); the last, at most 127^2 2^-62 < 4e-15 per product, is left out, which puts sums of
//! products within about 1e-14 (relative) of those of the f32 features, the size of an f64
//! summation's own rounding.

/// 1/255 as `image_io` computes 8-bit features (`k as f32 * S8`).
pub(crate) const S8: f32 = 1.0 / 255.0;

/// The feature of an 8-bit value `v`: v / 255 as an f32, the same bits the image reader makes
/// of an 8-bit pixel (`crate::image_io::feature_of_u8` is this).
#[inline]
pub(crate) fn feature_of_u8(v: u8) -> f32 {
    v as f32 * S8
}

/// Weight of the integer sums of k_p k_q: S8^2 = 2^-62 m^2, exact in f64.
pub(crate) const SCALE_PAIRS: f64 = (S8 as f64) * (S8 as f64);

/// Weight of the integer sums of k_p r_q + r_p k_q: 2^-62 m, exact in f64.
pub(crate) const SCALE_CROSS: f64 = (S8 as f64) / 2_147_483_648.0;

/// The residuals r_k = V_k - k m of the 8-bit features k * S8 = V_k 2^-31; all within -127..=127.
pub(crate) fn residuals() -> [i8; 256] {
    let m = S8 as f64 * 2f64.powi(31);
    let mut r = [0i8; 256];
    for (k, r) in r.iter_mut().enumerate() {
        let v = (k as f32 * S8) as f64 * 2f64.powi(31);
        let d = v - k as f64 * m;
        assert!(v.fract() == 0.0 && d.abs() <= 127.0, "8-bit feature {k} is not V 2^-31 with a small residual");
        *r = d as i8;
    }
    r
}

/// The level of one value, when it is an 8-bit feature.
#[inline(always)]
pub(crate) fn level(v: f32) -> Option<u8> {
    // Truncation rounds a non-negative value to the nearest level (and inlines, where f32::round
    // is a libm call); anything else, NaN included, fails the comparison.
    let k = (v * 255.0 + 0.5) as i32;
    ((0..=255).contains(&k) && (k as f32) * S8 == v).then_some(k as u8)
}

/// Fills `q` with the 8-bit levels of `f` and says whether every value is one (values that are
/// not get level 0).
pub(crate) fn quantize(f: &[f32], q: &mut [u8]) -> bool {
    let mut exact = true;
    for (d, &v) in q.iter_mut().zip(f) {
        let k = level(v);
        exact &= k.is_some();
        *d = k.unwrap_or(0);
    }
    exact
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_level_is_recovered_and_other_values_are_refused() {
        let f: Vec<f32> = (0..256).map(|k| k as f32 * S8).collect();
        let mut q = vec![0u8; 256];
        assert!(quantize(&f, &mut q));
        assert!(q.iter().enumerate().all(|(k, &v)| v as usize == k));
        for bad in [-S8, 1.0 + S8, 0.5, f32::NAN, f32::INFINITY, 3.0 / 255.0 + 1e-7] {
            assert!(!quantize(&[S8, bad], &mut [0, 0]), "{bad} taken for a level");
        }
        // k / 255 by division is not k * S8 for every k: those values are refused, not rounded.
        let divided = (0..256).filter(|&k| k as f32 / 255.0 != k as f32 * S8).count();
        assert!(divided > 0);
        assert!(!quantize(&(0..256).map(|k| k as f32 / 255.0).collect::<Vec<_>>(), &mut [0; 256]));
    }

    #[test]
    fn residuals_and_scales_give_the_f32_products() {
        let r = residuals();
        let m = 8_421_505f64;
        assert_eq!(S8 as f64 * 2f64.powi(31), m);
        for (k, &rk) in r.iter().enumerate() {
            let v = (k as f32 * S8) as f64;
            assert_eq!(v, (k as f64 * m + rk as f64) * 2f64.powi(-31));
        }
        assert_eq!(SCALE_PAIRS, m * m * 2f64.powi(-62));
        assert_eq!(SCALE_CROSS, m * 2f64.powi(-62));
    }
}
