//! Sums of scaled rows, W^T = D^T X (K x M), over a chunk of pixels: what the linear model's
//! weights are made of. X's rows are read as the data set holds them (f32 features or their
//! 8-bit values, the same features) and widened to f64; every path does the same operations
//! in the same order (no fused multiply-add), so its bits do not depend on the CPU.

use super::dispatch;
use crate::kernels::levels::feature_of_u8;
use crate::kernels::Rows;

/// The rows a combination reads: `x`, rows of `m` values, each less `mean` (of M values) when
/// given.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Centred<'a> {
    pub x: Rows<'a>,
    pub mean: Option<&'a [f64]>,
    pub m: usize,
}

dispatch! {
    /// For pixels `p0..p0 + row.len()` of the `n = d.len() / k` rows of `m` values of `x`
    /// (`src`): `w[j * len + p] = sum_i d[i k + j] (x_i[p0 + p] - mean[p0 + p])`, the rows taken
    /// in order (`w` zeroed first; `row` is scratch of the chunk's length).
    pub(crate) fn combine_rows(src: Centred, p0: usize, d: &[f64], k: usize, w: &mut [f64], row: &mut [f64]) = combine_portable;
}

#[inline(always)]
fn combine_portable(src: Centred, p0: usize, d: &[f64], k: usize, w: &mut [f64], row: &mut [f64]) {
    let Centred { x, mean, m } = src;
    let len = row.len();
    assert!(k > 0 && d.len().is_multiple_of(k) && w.len() == k * len && p0 + len <= m && x.len() >= d.len() / k * m, "chunk inside the rows");
    w.fill(0.0);
    for (i, di) in d.chunks_exact(k).enumerate() {
        let at = i * m + p0..i * m + p0 + len;
        match x {
            Rows::F32(x) => row.iter_mut().zip(&x[at]).for_each(|(r, &v)| *r = v as f64),
            Rows::U8(x) => row.iter_mut().zip(&x[at]).for_each(|(r, &v)| *r = feature_of_u8(v) as f64),
        }
        if let Some(mu) = mean {
            row.iter_mut().zip(&mu[p0..p0 + len]).for_each(|(r, &u)| *r -= u);
        }
        for (wj, &dij) in w.chunks_exact_mut(len).zip(di) {
            wj.iter_mut().zip(&*row).for_each(|(w, &v)| *w += dij * v);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernels::Level;

    #[test]
    fn every_level_and_both_row_forms_give_the_same_bits() {
        let (n, m, k, p0, len) = (7, 300, 3, 40, 200);
        let px: Vec<u8> = (0..n * m).map(|i| ((i * 2654435761usize) >> 9) as u8).collect();
        let f: Vec<f32> = px.iter().map(|&v| feature_of_u8(v)).collect();
        let d: Vec<f64> = (0..n * k).map(|i| (i as f64 * 0.37).sin()).collect();
        let mu: Vec<f64> = (0..m).map(|p| p as f64 / m as f64).collect();
        for mean in [None, Some(&mu[..])] {
            let mut want = vec![0.0; k * len];
            for j in 0..k {
                for p in 0..len {
                    for i in 0..n {
                        let v = f[i * m + p0 + p] as f64 - mean.map_or(0.0, |u| u[p0 + p]);
                        want[j * len + p] += d[i * k + j] * v;
                    }
                }
            }
            for level in Level::supported() {
                for x in [Rows::F32(&f), Rows::U8(&px)] {
                    let (mut w, mut row) = (vec![9.0; k * len], vec![0.0; len]);
                    combine_rows(level, Centred { x, mean, m }, p0, &d, k, &mut w, &mut row);
                    assert!(w.iter().zip(&want).all(|(a, b)| a.to_bits() == b.to_bits()), "{level:?} {x:?}");
                }
            }
        }
    }
}
