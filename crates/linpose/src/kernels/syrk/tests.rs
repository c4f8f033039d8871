use super::*;
use crate::kernels::test_data::{data, reference};

#[test]
fn column_panels_accumulate_xtx() {
    // C = X^T X over blocks of rows, against the reference on X^T.
    let (n, m) = (70, 29);
    let x = data(n, m);
    let mut xt = vec![0f32; n * m];
    for i in 0..n {
        for p in 0..m {
            xt[p * n + i] = x[i * m + p];
        }
    }
    let want = reference(&xt, m, n);
    let mut acc = SyrkAcc::new(m);
    for rows in [0..32, 32..64, 64..70] {
        let kc = rows.len();
        let mut panel = vec![0.0; padded(m) * kc];
        pack_columns(&mut panel, &x[rows.start * m..rows.end * m], kc, m, None);
        acc.update(&panel, kc);
    }
    let c = acc.into_matrix();
    for i in 0..m {
        for j in 0..m {
            assert!((c[(i, j)] - want[i * m + j]).abs() <= 1e-12 * want[i * m + j].abs().max(1.0));
        }
    }
}
/// The 8-bit kernel sums exactly: against an integer reference, on the VNNI and portable
/// kernels (same bits), with odd step counts and sizes that are not multiples of 16 or 48.
#[test]
fn u8_panels_accumulate_exact_integer_xtx() {
    for &(n, m, kc) in &[(1usize, 1usize, 1usize), (7, 5, 3), (70, 29, 31), (300, 100, 64), (130, 200, 129)] {
        let x: Vec<u8> = (0..n * m).map(|i| ((i * 2654435761usize) >> 7) as u8).collect();
        let mut want = vec![0i64; m * m];
        for i in 0..n {
            for p in 0..m {
                for q in 0..m {
                    want[p * m + q] += x[i * m + p] as i64 * x[i * m + q] as i64;
                }
            }
        }
        let accs = [SyrkAcc::new(m), SyrkAcc::new(m).without_vnni()];
        let mut got = Vec::new();
        for mut acc in accs {
            let mut r0 = 0;
            while r0 < n {
                let k = kc.min(n - r0);
                let kcp = k.div_ceil(2);
                let (mut a, mut b) = (vec![0; padded(m) * kcp], vec![0; padded(m) * kcp]);
                pack_pairs_u8(&mut a, &mut b, &x[r0 * m..(r0 + k) * m], k, m);
                acc.update_u8(&a, &b, kcp, 1.0);
                r0 += k;
            }
            let c = acc.into_lower(1.0);
            assert_lower_is(&c, &want, m, &format!("n {n} m {m} kc {kc}"));
            got.push(c);
        }
        assert!(got[0] == got[1]);
    }
}

/// The cross kernel: s * sum (k_p r_q + r_p k_q) exactly, VNNI and portable the same bits,
/// on top of what C already holds.
#[test]
fn u8_cross_panels_accumulate_exact_integer_sums() {
    let mut r = [0i8; 256];
    r.iter_mut().enumerate().for_each(|(k, v)| *v = ((k * 97 + 13) % 255) as i32 as i8);
    r[7] = -127;
    r[200] = 127;
    for &(n, m, kc) in &[(1usize, 1usize, 1usize), (7, 5, 3), (70, 29, 31), (300, 100, 64), (130, 200, 129)] {
        let x: Vec<u8> = (0..n * m).map(|i| ((i * 2654435761usize) >> 9) as u8).collect();
        let mut want = vec![0i64; m * m];
        for i in 0..n {
            for p in 0..m {
                for q in 0..m {
                    let (kp, kq) = (x[i * m + p] as i64, x[i * m + q] as i64);
                    want[p * m + q] += kp * r[kq as usize] as i64 + r[kp as usize] as i64 * kq;
                }
            }
        }
        let mut got = Vec::new();
        for mut acc in [SyrkAcc::new(m), SyrkAcc::new(m).without_vnni()] {
            acc.scale(0.0);
            let mut r0 = 0;
            while r0 < n {
                let k = kc.min(n - r0);
                let len = padded(m) * k.div_ceil(4);
                let mut v = [vec![0; len], vec![0; len], vec![0; len], vec![0; len]];
                let [ak, ar, bk, br] = &mut v;
                pack_quads_u8([ak, ar, bk, br], &x[r0 * m..(r0 + k) * m], k, m, &r);
                acc.update_u8_cross(ak, ar, bk, br, k.div_ceil(4), 0.5);
                r0 += k;
            }
            let c = acc.into_lower(2.0);
            assert_lower_is(&c, &want, m, &format!("n {n} m {m} kc {kc}"));
            got.push(c);
        }
        assert!(got[0] == got[1]);
    }
}

/// `c` (column-major lower triangle, zero above) holds the exact integer sums `want`
/// (row-major, m x m) below and on the diagonal.
fn assert_lower_is(c: &[f64], want: &[i64], m: usize, what: &str) {
    for p in 0..m {
        for q in 0..m {
            let w = if p >= q { want[p * m + q] as f64 } else { 0.0 };
            assert_eq!(c[q * m + p], w, "{what} ({p},{q})");
        }
    }
}

#[test]
fn scale_and_into_lower_agree_with_into_matrix() {
    let (n, m) = (40, 37);
    let x = data(n, m);
    let mut panel = vec![0.0; padded(m) * n];
    pack_columns(&mut panel, &x, n, m, None);
    let (mut a, mut b) = (SyrkAcc::new(m), SyrkAcc::new(m));
    a.update(&panel, n);
    b.update(&panel, n);
    a.scale(0.5);
    let full = b.into_matrix();
    let lower = a.into_lower(2.0);
    for j in 0..m {
        for i in 0..m {
            assert_eq!(lower[j * m + i], if i >= j { full[(i, j)] } else { 0.0 });
        }
    }
}
