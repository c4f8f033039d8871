//! The Gram matrix G = X X^T (M = 19,200) for N = 222 and 2000, with the machine's peaks in the
//! same run (printed first): the f64 FMA loop and the VNNI loop of the 8-bit Gram. Throughput is
//! the lower triangle's multiply-adds (2 FLOP each), reported by criterion as elements: read
//! them as FLOP/s (f64-equivalent for the 8-bit path).
//!
//! The features are 8-bit levels k * (1/255), as `image_io` makes them from PNGs: `gram_f32`
//! (what training calls) sums them in integers where the CPU has AVX-512 VNNI;
//! `gram_f32_fma` is the f64 kernel on the same data.
//!
//! cargo bench -p linpose --bench gram
use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use linpose::bench::gram_f32;
use linpose::bench::gram_f32_fma;
use linpose::bench::{fma_flops_f64, vnni_gram_flops};
use std::hint::black_box;

mod common;
use common::*;

fn peaks(when: &str) {
    let vnni = vnni_gram_flops(0.5).map_or("no VNNI".into(), |v| format!("{:.1} GFLOP/s-equivalent", v / 1e9));
    println!("peaks ({when}) on {} threads: FMA {:.1} GFLOP/s f64, 8-bit Gram VNNI loop {vnni}", rayon::current_num_threads(), fma_flops_f64(0.5) / 1e9);
}

fn gram(c: &mut Criterion) {
    peaks("before");
    let mut g = c.benchmark_group("gram");
    for n in [222usize, 2000] {
        let f: Vec<f32> = images_u8(n, 3).iter().map(|&v| v as f32 * (1.0 / 255.0)).collect();
        g.throughput(Throughput::Elements((n * (n + 1) / 2 * M * 2) as u64));
        g.bench_function(format!("N={n}"), |b| b.iter(|| black_box(gram_f32(&f, n, M, None))));
        g.bench_function(format!("N={n} f64 kernel"), |b| b.iter(|| black_box(gram_f32_fma(&f, n, M, None))));
    }
    g.finish();
    peaks("after");
}

criterion_group! { name = benches; config = Criterion::default().sample_size(10); targets = gram }
criterion_main!(benches);
