//! The f64 symmetric rank-k update, linpose's own kernel against faer's lower-triangular matrix
//! product (`faer::linalg::matmul::triangular::matmul`, destination `TriangularLower`), timed
//! alternately in one run, on the two sizes training takes (M = 19,200: 160 x 120 images):
//! - Gram, G = X X^T for N = 222 and 2000 images (the in-memory fit of features that are not
//!   8-bit). From the f32 rows, as training has them: linpose packs them itself, faer takes the
//!   f64 copy `linalg::transpose_features` makes (included). And from that f64 copy for both
//!   (the kernels alone).
//! - Stream, C += P P^T for one block of 256 images into the M x M lower triangle (the streamed
//!   least-squares fit of features that are not 8-bit): linpose packs the block and updates its
//!   bands, faer converts it to f64 and updates a column-major M x M matrix.
//!
//! Each case runs its variants in turn, REPS rounds (the first variant rotating), after one
//! warm-up each, and prints the median and least seconds of each and the ratio of the medians.
//! faer runs on rayon's pool with as many threads as linpose. It also prints whether faer's
//! Gram has the same bits on one thread as on all (linpose's does, by construction).
//!
//! cargo bench -p linpose --bench syrk [-- REPS]
use faer::linalg::matmul::triangular::{matmul, BlockStructure};
use faer::{Accum, Mat, MatMut, MatRef, Par};
use linpose::bench::{gram, transpose_features};
use linpose::bench::{gram_f32_fma, pack_columns, padded, SyrkAcc, KC};
use std::hint::black_box;
use std::time::Instant;

mod common;
use common::*;

/// The lower triangle of `dst` = X X^T by faer, from X^T (M x N, one image a column).
fn faer_gram(dst: MatMut<'_, f64>, xt: MatRef<'_, f64>, par: Par) {
    matmul(dst, BlockStructure::TriangularLower, Accum::Replace, xt.transpose(), BlockStructure::Rectangular, xt, BlockStructure::Rectangular, 1.0, par);
}

/// Runs every variant `reps` times in turn (the first rotating) after one warm-up each; prints
/// the median and least of each and each median over the first's.
fn alternate(case: &str, reps: usize, variants: &mut [(&str, &mut dyn FnMut())]) {
    let k = variants.len();
    let mut times = vec![Vec::new(); k];
    for (_, f) in variants.iter_mut() {
        f();
    }
    for r in 0..reps {
        for j in 0..k {
            let v = (r + j) % k;
            let t = Instant::now();
            (variants[v].1)();
            times[v].push(t.elapsed().as_secs_f64());
        }
    }
    let median = |t: &mut Vec<f64>| {
        t.sort_by(f64::total_cmp);
        t[t.len() / 2]
    };
    let medians: Vec<f64> = times.iter_mut().map(median).collect();
    for (j, (name, _)) in variants.iter().enumerate() {
        println!("{case}: {name:44} median {:9.4} ms, least {:9.4} ms, {:.2}x the first", medians[j] * 1e3, times[j][0] * 1e3, medians[j] / medians[0]);
    }
}

fn main() {
    let reps: usize = std::env::args().skip(1).find_map(|a| a.parse().ok()).unwrap_or(9);
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    println!("{} threads, load average {}, {reps} rounds", rayon::current_num_threads(), load.split_whitespace().take(3).collect::<Vec<_>>().join(" "));
    let par = Par::rayon(rayon::current_num_threads());
    for n in [222usize, 2000] {
        let f: Vec<f32> = images_u8(n, 3).iter().map(|&v| v as f32 * 0.7 / 255.0 + 0.001).collect();
        let xt = transpose_features(&f, n, M, None);
        let mut dst = Mat::<f64>::zeros(n, n);
        // The two agree up to rounding; faer's bits on one thread and on all.
        let ours = gram_f32_fma(&f, n, M, None);
        faer_gram(dst.as_mut(), xt.as_ref(), par);
        let worst = (0..n).flat_map(|j| (j..n).map(move |i| (i, j))).map(|(i, j)| (ours[(i, j)] - dst[(i, j)]).abs() / ours[(i, i)]).fold(0f64, f64::max);
        let mut one = Mat::<f64>::zeros(n, n);
        faer_gram(one.as_mut(), xt.as_ref(), Par::Seq);
        let same = (0..n).all(|j| (j..n).all(|i| one[(i, j)].to_bits() == dst[(i, j)].to_bits()));
        println!("gram N={n}: largest difference {worst:.1e} of the diagonal; faer's bits on 1 thread and on all the same: {same}");
        assert!(worst < 1e-12);
        alternate(
            &format!("gram N={n}"),
            reps,
            &mut [
                ("linpose from f32 rows", &mut || drop(black_box(gram_f32_fma(&f, n, M, None)))),
                ("faer from f32 rows (with the f64 copy)", &mut || faer_gram(one.as_mut(), transpose_features(black_box(&f), n, M, None).as_ref(), par)),
                ("linpose from the f64 copy", &mut || drop(black_box(gram(xt.as_ref())))),
                ("faer from the f64 copy", &mut || faer_gram(dst.as_mut(), black_box(xt.as_ref()), par)),
            ],
        );
    }
    let f: Vec<f32> = images_u8(KC, 6).iter().map(|&v| v as f32 * 0.7 / 255.0 + 0.001).collect();
    let mut acc = SyrkAcc::new(M);
    let mut panel = vec![0f64; padded(M) * KC];
    let mut dst = Mat::<f64>::zeros(M, M);
    alternate(
        &format!("stream, block of {KC}"),
        reps,
        &mut [
            ("linpose (pack, update)", &mut || {
                pack_columns(&mut panel, black_box(&f), KC, M, None);
                acc.update(&panel, KC);
            }),
            ("faer (f64 copy, update)", &mut || {
                // P = block^T: M x KC, one image a column.
                let p = transpose_features(black_box(&f), KC, M, None);
                matmul(
                    dst.as_mut(),
                    BlockStructure::TriangularLower,
                    Accum::Add,
                    p.as_ref(),
                    BlockStructure::Rectangular,
                    p.as_ref().transpose(),
                    BlockStructure::Rectangular,
                    1.0,
                    par,
                );
            }),
        ],
    );
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    println!("load average after: {}", load.split_whitespace().take(3).collect::<Vec<_>>().join(" "));
}
