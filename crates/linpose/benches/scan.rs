//! The refined eigenspace's coarse-scan kernels on one query against n = 3108 coarse points of
//! L = 20 coordinates (a 6 x 37 grid of knots, 4 points per knot interval, as the default
//! parameters give for the paper's training grid).
//!
//! The kernels run at the detected SIMD level: `LINPOSE_SIMD=avx2` times their AVX2 build.
//!
//! cargo bench -p linpose --bench scan
use criterion::{criterion_group, criterion_main, Criterion};
use linpose::bench::scan;
use std::hint::black_box;

const N: usize = 21 * 148;
const L: usize = 20;

fn kernels(c: &mut Criterion) {
    println!("LINPOSE_SIMD={}", std::env::var("LINPOSE_SIMD").unwrap_or_default());
    // Points along a smooth curve (coordinate-major), so that the boxed scan rules most out.
    let cols: Vec<f32> = (0..L)
        .flat_map(|q| (0..N).map(move |i| ((i as f32 * 0.013 * (q + 1) as f32).sin() + 0.01 * ((i * 31 + q * 7) % 13) as f32) / (q + 1) as f32))
        .collect();
    let gcols: Vec<f32> = cols.iter().map(|&v| 0.5 * v + 0.01).collect();
    let y: Vec<f32> = (0..L).map(|q| cols[q * N + 777] + 0.003 * (q as f32 - 4.0)).collect();
    let wt: Vec<f32> = (0..L).map(|q| 1.0 / (1.0 + q as f32)).collect();
    let boxes = scan::boxes(&cols, N, 8);
    let ba: Vec<f64> = (0..N).map(|i| (i % 17) as f64 / 9.0 - 0.5).collect();
    let ia: Vec<f64> = (0..N).map(|i| 0.5 + (i % 5) as f64 / 7.0).collect();
    let is: Vec<f64> = (0..N).map(|i| 1.0 + (i % 3) as f64).collect();
    let (mut dist, mut lb) = (vec![0f32; N], Vec::new());
    let (mut u, mut v) = (vec![0f32; N], vec![0f32; N]);
    let mut g = c.benchmark_group("scan");
    g.bench_function("sq_dist", |b| b.iter(|| scan::sq_dist(black_box(&cols), &y, &wt, &mut dist)));
    g.bench_function("sq_dist_boxed", |b| b.iter(|| scan::sq_dist_boxed(black_box(&cols), &boxes, 8, &y, &wt, &mut dist, &mut lb)));
    g.bench_function("dots2", |b| b.iter(|| scan::dots2(black_box(&cols), &gcols, &y, &mut u, &mut v)));
    g.bench_function("affine_residuals", |b| {
        b.iter(|| {
            u.copy_from_slice(&dist);
            scan::affine_residuals(black_box(&mut u), &v, &ba, &ia, &is, 0.37, 9.5)
        })
    });
    scan::sq_dist(&cols, &y, &wt, &mut dist);
    g.bench_function("least", |b| b.iter(|| scan::least(black_box(&dist))));
    g.bench_function("argmin", |b| b.iter(|| scan::argmin(black_box(&dist))));
    g.finish();
}

criterion_group!(benches, kernels);
criterion_main!(benches);
