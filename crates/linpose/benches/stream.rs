//! The streaming accumulation of X^T X (M = 19,200: 160 x 120 images), one block of images at a
//! time as `linpose train --stream` does it on the least-squares path (N > M): the 8-bit integer
//! path where the CPU has AVX-512 VNNI, as training takes it only there (1024 images per panel,
//! two VNNI passes: pack_pairs_u8 + update_u8 for sum k_p k_q, pack_quads_u8 + update_u8_cross
//! for the f32 features' residuals) and the f64 path
//! (pack_columns + the f64 kernel: 256 images per panel), with the machine's FMA peak in the same
//! run. Throughput is M^2 per image (the lower triangle's M^2 / 2 multiply-adds, 2 operations
//! each; integer ones on the 8-bit path), reported by criterion as elements: read them as
//! FLOP/s. Each iteration takes about a second on 2 cores (flat sampling: 10 samples of a few).
//!
//! cargo bench -p linpose --bench stream
use criterion::{criterion_group, criterion_main, Criterion, SamplingMode, Throughput};
use linpose::bench::fma_flops_f64;
use linpose::bench::{pack_columns, pack_pairs_u8, pack_quads_u8, padded, SyrkAcc, KC, KCP, KCQ};
use std::time::Duration;

mod common;
use common::*;

fn stream(c: &mut Criterion) {
    println!("FMA peak: {:.1} GFLOP/s f64 on {} threads", fma_flops_f64(0.5) / 1e9, rayon::current_num_threads());
    let np = padded(M);
    let mut g = c.benchmark_group("stream_xtx");
    g.sample_size(10).sampling_mode(SamplingMode::Flat).measurement_time(Duration::from_secs(20));

    let n = 2 * KCP;
    assert_eq!(n, 4 * KCQ);
    let q = images_u8(n, 5);
    let r: [i8; 256] = std::array::from_fn(|k| ((k * 37) % 191) as i8 - 95);
    let mut acc = SyrkAcc::new(M);
    // Training takes the 8-bit path only with VNNI (`NormalEquations`); elsewhere its portable
    // kernels, which exist for the tests' bitwise comparisons, would take many minutes a sample.
    if acc.uses_vnni() {
        println!("8-bit kernels: AVX-512 VNNI");
        let (mut a, mut b) = (vec![0i32; np * KCP], vec![0i32; np * KCP]);
        let mut quads: [Vec<i32>; 4] = std::array::from_fn(|_| vec![0i32; np * KCQ]);
        g.throughput(Throughput::Elements((M * M * n) as u64));
        g.bench_function(format!("8-bit integer (both passes), block of {n} images"), |bench| {
            bench.iter(|| {
                pack_pairs_u8(&mut a, &mut b, &q, n, M);
                acc.update_u8(&a, &b, KCP, 1.0);
                let [ak, ar, bk, br] = &mut quads;
                pack_quads_u8([ak, ar, bk, br], &q, n, M, &r);
                acc.update_u8_cross(ak, ar, bk, br, KCQ, 1.0);
            })
        });
    } else {
        println!("8-bit kernels: none timed (no AVX-512 VNNI: training streams 8-bit images by the f64 path)");
    }
    drop(acc);

    let n = 2 * KC;
    let f: Vec<f32> = images_u8(n, 6).iter().map(|&v| v as f32 / 255.0).collect();
    let mut acc = SyrkAcc::new(M);
    let mut panel = vec![0f64; np * KC];
    g.throughput(Throughput::Elements((M * M * n) as u64));
    g.bench_function(format!("f64, block of {n} images"), |bench| {
        bench.iter(|| {
            for r0 in (0..n).step_by(KC) {
                pack_columns(&mut panel, &f[r0 * M..(r0 + KC) * M], KC, M, None);
                acc.update(&panel, KC);
            }
        })
    });
    g.finish();
    println!("FMA peak: {:.1} GFLOP/s f64 (after)", fma_flops_f64(0.5) / 1e9);
}

criterion_group!(benches, stream);
criterion_main!(benches);
