//! Times the Gram matrix G = X X^T for the training-set sizes of issue 7 (M = 19,200) against the
//! machine's peak measured in the same run (an AVX-512 FMA loop on every thread, and a large
//! square faer matmul), alternating, medians of REPS.
//!
//! cargo run --release --example gram_timing [-- REPS]
use faer::linalg::matmul::matmul;
use faer::{Accum, Mat};
use linpose::kernels::peak::fma_flops_f64;
use linpose::linalg::{gram_f32, par};
use std::time::Instant;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let reps: usize = std::env::args().nth(1).map_or(7, |s| s.parse().expect("REPS"));
    let m = 19_200;
    let sq = 2048;
    let a = Mat::<f64>::from_fn(sq, sq, |i, j| ((i * 31 + j * 17) % 101) as f64 / 101.0);
    let mut c = Mat::<f64>::zeros(sq, sq);
    let data: Vec<(usize, Vec<f32>)> = [222usize, 2000]
        .iter()
        .map(|&n| (n, (0..n * m).map(|i| ((i * 2654435761usize) % 256) as f32 / 255.0).collect()))
        .collect();
    let (mut fma, mut mm) = (vec![], vec![]);
    let mut g: Vec<Vec<f64>> = vec![vec![]; data.len()];
    for _ in 0..reps {
        fma.push(fma_flops_f64(0.3));
        let t = Instant::now();
        matmul(c.as_mut(), Accum::Replace, a.as_ref(), a.as_ref(), 1.0, par());
        mm.push(2.0 * (sq * sq * sq) as f64 / t.elapsed().as_secs_f64());
        for (k, (n, f)) in data.iter().enumerate() {
            let t = Instant::now();
            std::hint::black_box(gram_f32(f, *n, m, None));
            g[k].push(t.elapsed().as_secs_f64());
        }
    }
    let (fma, mm) = (median(fma), median(mm));
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    println!("threads {}, load average {}", rayon::current_num_threads(), load.split_whitespace().take(3).collect::<Vec<_>>().join(" "));
    println!("peak: FMA loop {:.1} GFLOP/s, faer {sq}^3 matmul {:.1} GFLOP/s (medians of {reps})", fma / 1e9, mm / 1e9);
    for (k, (n, _)) in data.iter().enumerate() {
        let t = median(g[k].clone());
        let tmin = g[k].iter().copied().fold(f64::INFINITY, f64::min);
        let done = (n * (n + 1) / 2 * m) as f64 * 2.0; // the lower triangle's multiply-adds, computed
        let full = (n * n * m) as f64 * 2.0; // what a full X X^T product costs
        println!(
            "N = {n}: gram {:.4} s (fastest {:.4} s = {:.0}%); {:.1} GFLOP/s computed (triangle) = {:.0}% of the FMA peak, {:.0}% of faer's; {:.1} GFLOP/s full-product equivalent",
            t,
            tmin,
            100.0 * done / tmin / fma,
            done / t / 1e9,
            100.0 * done / t / fma,
            100.0 * done / t / mm,
            full / t / 1e9
        );
    }
}
