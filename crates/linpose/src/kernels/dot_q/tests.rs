use super::*;

fn weights(n: usize) -> Vec<f32> {
    (0..n).map(|i| ((i * 104_729) % 2001) as f32 / 1000.0 - 1.0).collect()
}

/// Pixels with whole black steps of 64 (every fourth), black images (every fifth) and
/// bright ones.
fn images(m: usize, n: usize) -> Vec<u8> {
    (0..m * n).map(|i| if ((i % m) / 64) % 4 == 1 || (i / m) % 5 == 3 { 0 } else { ((i * 7919 + 13) % 256) as u8 }).collect()
}

/// The exact sum of row r against `x`, in i64 from the stored integers.
fn exact(q: &QuantRows, x: &[u8], r: usize) -> f32 {
    let s: i64 = x.iter().enumerate().map(|(p, &v)| v as i64 * q.int(r, p) as i64).sum();
    (s as f64 * q.scale[r]) as f32
}

#[test]
fn digits_rebuild_the_integers_and_the_rows_stay_within_half_a_step() {
    for m in [300, 1025, 2048] {
        let w = weights(3 * m);
        let q = QuantRows::new(&w, m);
        assert_eq!((q.rows(), q.m), (3, m));
        for r in 0..3 {
            let row = q.row(r);
            for (p, (&a, &b)) in w[r * m..].iter().zip(&row).enumerate() {
                assert!((a as f64 - b).abs() <= q.scale[r] / 2.0 * (1.0 + 1e-12), "row {r} pixel {p}");
                assert!((0..DIGITS).all(|k| q.digits()[q.at(r, k, p)] >= -128), "balanced digits");
                assert!(q.int(r, p).abs() <= VMAX);
            }
        }
        // Every tile's digits past m are zero.
        let used: usize =
            (0..3).map(|r| (0..m).flat_map(|p| (0..DIGITS).map(move |k| (r, k, p))).filter(|&(r, k, p)| q.digits()[q.at(r, k, p)] != 0).count()).sum();
        assert_eq!(used, q.digits().iter().filter(|&&d| d != 0).count());
    }
    // The extremes land on +-VMAX.
    let q = QuantRows::new(&[0.5, -0.5, 0.25], 3);
    assert_eq!((q.int(0, 0), q.int(0, 1)), (VMAX, -VMAX));
    assert!((q.int(0, 2) - VMAX / 2).abs() <= 1, "{}", q.int(0, 2));
    let z = QuantRows::new(&[0.0; 4], 4);
    assert!((0..4).all(|p| z.int(0, p) == 0));
}

#[test]
fn every_path_gives_the_exact_sums() {
    for &(m, rows) in &[(1, 1), (63, 3), (64, 2), (100, 9), (19_200 / 40, 20), (1000, 3), (1024, 8), (64 * 1030 + 5, 2)] {
        let w = weights(m * rows);
        let q = QuantRows::new(&w, m);
        let x = &images(m, 1)[..];
        let want: Vec<f32> = (0..rows).map(|r| exact(&q, x, r)).collect();
        for level in Level::supported() {
            let mut out = vec![0f32; rows];
            dots(level, x, &q, &mut out);
            assert_eq!(out, want, "{level:?} m {m}");
        }
        // Within the quantisation of the weights of the f64 products.
        for (r, &got) in want.iter().enumerate() {
            let f: f64 = x.iter().zip(&w[r * m..(r + 1) * m]).map(|(&a, &b)| a as f64 * b as f64).sum();
            let bound = q.scale[r] / 2.0 * x.iter().map(|&v| v as f64).sum::<f64>() + f.abs() * 1e-7;
            assert!((got as f64 - f).abs() <= bound, "m {m} row {r}: {got} vs {f}");
        }
    }
}

#[test]
fn the_batch_gives_the_bits_of_one_image_at_a_time() {
    let sizes = [(64, 2, 4), (100, 13, 20), (19_200 / 40, 7, 3), (37, 12, 5), (480, 5, 20), (1000, 200, 6), (64 * 1030 + 5, 3, 2)];
    let more = [(1024 + 64, 8, 4), (2100, 16, 20), (2100, 17, 3), (640, 24, 1), (640, 40, 7), (19_200 / 10, 33, 20)];
    for &(m, n, rows) in sizes.iter().chain(&more) {
        let xs = images(m, n);
        let q = QuantRows::new(&weights(m * rows), m);
        let want: Vec<f32> = xs.chunks_exact(m).flat_map(|x| (0..rows).map(|r| exact(&q, x, r)).collect::<Vec<_>>()).collect();
        for level in Level::supported() {
            let mut one = vec![0f32; n * rows];
            xs.chunks_exact(m).zip(one.chunks_exact_mut(rows)).for_each(|(x, o)| dots(level, x, &q, o));
            assert_eq!(one, want, "{level:?} m {m} n {n}");
            let (mut batch, mut energy) = (vec![0f32; n * rows], vec![0u64; n]);
            dots_batch(level, &xs, &q, &mut batch, &mut energy, &mut Vec::new());
            assert_eq!(batch, want, "{level:?} m {m} n {n}");
            assert_eq!(energy, xs.chunks_exact(m).map(crate::kernels::dot_u8::sum_squares).collect::<Vec<_>>(), "{level:?} m {m} n {n}");
        }
    }
}

#[test]
fn the_exact_sums_agree_with_the_f32_kernel_within_the_quantisation() {
    // The two families callers switch between (`fast`): apart by at most the weights'
    // quantisation (half a step times the pixel sum) and a few f32 steps of the sum of |x w|.
    for &(m, rows) in &[(19_200 / 40, 20), (2100, 7), (19_200, 3)] {
        let w = weights(m * rows);
        let q = QuantRows::new(&w, m);
        for x in images(m, 4).chunks_exact(m) {
            for level in Level::supported() {
                let (mut a, mut b) = (vec![0f32; rows], vec![0f32; rows]);
                dots(level, x, &q, &mut a);
                crate::kernels::dot_u8::dots(level, x, &w, &mut b);
                for r in 0..rows {
                    let mag: f64 = x.iter().zip(&w[r * m..(r + 1) * m]).map(|(&p, &v)| p as f64 * (v as f64).abs()).sum();
                    let quant = q.scale[r] / 2.0 * x.iter().map(|&v| v as f64).sum::<f64>();
                    assert!(((a[r] - b[r]) as f64).abs() <= quant + 1e-6 * mag + 1e-30, "{level:?} m {m} row {r}: {} vs {}", a[r], b[r]);
                }
            }
        }
    }
}

#[test]
fn the_largest_sums_do_not_overflow() {
    // 65,536 pixels of 255 against weights at +-VMAX: the lanes' and the energy's extremes.
    let m = 65_536;
    let xs = vec![255u8; 8 * m];
    for sign in [1f32, -1.0] {
        let q = QuantRows::new(&vec![sign; m], m);
        for level in Level::supported() {
            let (mut out, mut energy) = (vec![0f32; 8], vec![0u64; 8]);
            dots_batch(level, &xs, &q, &mut out, &mut energy, &mut Vec::new());
            assert!(out.iter().all(|&v| v == sign * 255.0 * m as f32), "{level:?} {out:?}");
            assert!(energy.iter().all(|&e| e == 65_025 * m as u64), "{level:?} {energy:?}");
        }
    }
}
