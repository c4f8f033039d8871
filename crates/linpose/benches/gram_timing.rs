//! Times the Gram matrix G = X X^T for N = 222 and 2000 images of M = 19,200 pixels against the
//! machine's peaks measured in the same run (an AVX-512 FMA loop on every thread, a large square
//! faer matmul, and the VNNI loop of the 8-bit Gram), alternating, medians of REPS.
//!
//! The images are 8-bit features k * (1/255), as `image_io` makes them from PNGs, so
//! `gram_f32` takes the 8-bit integer path where the CPU has AVX-512 VNNI; the f64 kernel
//! (`gram_f32_fma`) is timed on the same data beside it.
//!
//! cargo bench -p linpose --bench gram_timing [-- REPS]
use faer::linalg::matmul::matmul;
use faer::{Accum, Mat};
use linpose::bench::{fma_flops_f64, gram_f32_fma, vnni_gram_flops};
use linpose::bench::{gram_f32, par};
use std::time::Instant;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let reps: usize = std::env::args().skip(1).find(|a| a != "--bench").map_or(7, |s| s.parse().expect("REPS"));
    let m = 19_200;
    let sq = 2048;
    let a = Mat::<f64>::from_fn(sq, sq, |i, j| ((i * 31 + j * 17) % 101) as f64 / 101.0);
    let mut c = Mat::<f64>::zeros(sq, sq);
    let data: Vec<(usize, Vec<f32>)> =
        [222usize, 2000].iter().map(|&n| (n, (0..n * m).map(|i| ((i * 2654435761usize) % 256) as f32 * (1.0 / 255.0)).collect())).collect();
    let (mut fma, mut vnni, mut mm) = (vec![], vec![], vec![]);
    // Per size: the default path, the f64 kernel.
    let mut g: Vec<[Vec<f64>; 2]> = vec![[vec![], vec![]]; data.len()];
    for _ in 0..reps {
        fma.push(fma_flops_f64(0.3));
        vnni.push(vnni_gram_flops(0.3).unwrap_or(f64::NAN));
        let t = Instant::now();
        matmul(c.as_mut(), Accum::Replace, a.as_ref(), a.as_ref(), 1.0, par());
        mm.push(2.0 * (sq * sq * sq) as f64 / t.elapsed().as_secs_f64());
        for (k, (n, f)) in data.iter().enumerate() {
            let t = Instant::now();
            std::hint::black_box(gram_f32(f, *n, m, None));
            g[k][0].push(t.elapsed().as_secs_f64());
            let t = Instant::now();
            std::hint::black_box(gram_f32_fma(f, *n, m, None));
            g[k][1].push(t.elapsed().as_secs_f64());
        }
    }
    let (fma, vnni, mm) = (median(fma), median(vnni), median(mm));
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    println!("threads {}, load average {}", rayon::current_num_threads(), load.split_whitespace().take(3).collect::<Vec<_>>().join(" "));
    println!(
        "peak: FMA loop {:.1} GFLOP/s, faer {sq}^3 matmul {:.1} GFLOP/s, 8-bit Gram VNNI loop {:.1} GFLOP/s-equivalent (medians of {reps})",
        fma / 1e9,
        mm / 1e9,
        vnni / 1e9
    );
    let integer = linpose::bench::gram_levels(&data[0].1[..m], 1, m).is_some();
    for (k, (n, _)) in data.iter().enumerate() {
        let done = (n * (n + 1) / 2 * m) as f64 * 2.0; // the lower triangle's multiply-adds
        for (p, name) in [(0, if integer { "gram_f32 (8-bit integer path)" } else { "gram_f32 (f64 kernel: no VNNI)" }), (1, "gram_f32_fma (f64 kernel)")] {
            let t = median(g[k][p].clone());
            let tmin = g[k][p].iter().copied().fold(f64::INFINITY, f64::min);
            let vs = if p == 0 && integer {
                format!(", {:.0}% of the VNNI peak (fastest {:.0}%)", 100.0 * done / t / vnni, 100.0 * done / tmin / vnni)
            } else {
                String::new()
            };
            println!(
                "N = {n}: {name} {:.4} s (fastest {:.4} s); {:.1} GFLOP/s (triangle) = {:.0}% of the FMA peak (fastest {:.0}%), {:.0}% of faer's{vs}",
                t,
                tmin,
                done / t / 1e9,
                100.0 * done / t / fma,
                100.0 * done / tmin / fma,
                100.0 * done / t / mm,
            );
        }
    }
}
