//! The Gram matrix G = X X^T (M = 19,200) for N = 222 and 2000, with the machine's FMA peak in
//! the same run (printed first). Throughput is the lower triangle's multiply-adds (2 FLOP each),
//! reported by criterion as elements: read them as FLOP/s.
//!
//! cargo bench -p linpose --bench gram
use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use linpose::kernels::peak::fma_flops_f64;
use linpose::linalg::gram_f32;
use std::hint::black_box;

mod common;
use common::*;

fn gram(c: &mut Criterion) {
    println!("FMA peak: {:.1} GFLOP/s f64 on {} threads", fma_flops_f64(0.5) / 1e9, rayon::current_num_threads());
    let mut g = c.benchmark_group("gram");
    for n in [222usize, 2000] {
        let f: Vec<f32> = images_u8(n, 3).iter().map(|&v| v as f32 / 255.0).collect();
        g.throughput(Throughput::Elements((n * (n + 1) / 2 * M * 2) as u64));
        g.bench_function(format!("N={n}"), |b| b.iter(|| black_box(gram_f32(&f, n, M, None))));
    }
    g.finish();
    println!("FMA peak: {:.1} GFLOP/s f64 (after)", fma_flops_f64(0.5) / 1e9);
}

criterion_group! { name = benches; config = Criterion::default().sample_size(10); targets = gram }
criterion_main!(benches);
