//! The f64 symmetric rank-k update, linpose's own kernel against faer's lower-triangular matrix
//! product (`faer::linalg::matmul::triangular::matmul`, destination `TriangularLower`), in one
//! run, on the two sizes training takes (M = 19,200: 160 x 120 images):
//! - `gram`: G = X X^T for N = 222 and 2000 images (the in-memory fit of features that are not
//!   8-bit). linpose from the f32 rows (what training calls) and from an f64 copy (the same
//!   input faer takes); faer from the f64 copy, and from the f32 rows including the copy.
//! - `stream`: C += P P^T for one block of 256 images into the M x M lower triangle (the
//!   streamed least-squares fit of features that are not 8-bit): linpose packs and updates its
//!   bands, faer converts the block to f64 and updates a column-major M x M matrix.
//!
//! faer runs on rayon's pool with as many threads as linpose. Throughput is the lower
//! triangle's multiply-adds (2 FLOP each), reported by criterion as elements (read as FLOP/s).
//!
//! cargo bench -p linpose --bench syrk
use criterion::{criterion_group, criterion_main, Criterion, SamplingMode, Throughput};
use faer::linalg::matmul::triangular::{matmul, BlockStructure};
use faer::{Accum, Mat, MatMut, MatRef, Par};
use linpose::bench::gram_f32_fma;
use linpose::bench::{pack_columns, padded, SyrkAcc, KC};
use std::hint::black_box;
use std::time::Duration;

mod common;
use common::*;

fn par() -> Par {
    Par::rayon(rayon::current_num_threads())
}

/// X^T (M x N, one image a column) in f64 from N row-major f32 rows.
fn transposed(f: &[f32], n: usize) -> Mat<f64> {
    Mat::from_fn(M, n, |k, i| f[i * M + k] as f64)
}

/// The lower triangle of `dst` += `x^T`^T `x^T` by faer (N x N from M x N).
fn faer_gram(dst: MatMut<'_, f64>, xt: MatRef<'_, f64>) {
    matmul(dst, BlockStructure::TriangularLower, Accum::Replace, xt.transpose(), BlockStructure::Rectangular, xt, BlockStructure::Rectangular, 1.0, par());
}

fn gram(c: &mut Criterion) {
    let mut g = c.benchmark_group("gram");
    g.sample_size(10).sampling_mode(SamplingMode::Flat);
    for n in [222usize, 2000] {
        let f: Vec<f32> = images_u8(n, 3).iter().map(|&v| v as f32 * 0.7 / 255.0 + 0.001).collect();
        let xt = transposed(&f, n);
        let mut dst = Mat::<f64>::zeros(n, n);
        // The two agree up to rounding.
        let ours = gram_f32_fma(&f, n, M, None);
        faer_gram(dst.as_mut(), xt.as_ref());
        let worst = (0..n).flat_map(|j| (j..n).map(move |i| (i, j))).map(|(i, j)| (ours[(i, j)] - dst[(i, j)]).abs() / ours[(i, i)]).fold(0f64, f64::max);
        println!("N={n}: largest difference {worst:.1e} of the diagonal");
        assert!(worst < 1e-12);
        g.throughput(Throughput::Elements((n * (n + 1) / 2 * M * 2) as u64));
        g.bench_function(format!("N={n} linpose f32 rows"), |b| b.iter(|| black_box(gram_f32_fma(&f, n, M, None))));
        g.bench_function(format!("N={n} linpose f64"), |b| b.iter(|| black_box(linpose::linalg::gram(xt.as_ref()))));
        g.bench_function(format!("N={n} faer f64"), |b| b.iter(|| faer_gram(dst.as_mut(), black_box(xt.as_ref()))));
        g.bench_function(format!("N={n} faer f32 rows (with the f64 copy)"), |b| {
            b.iter(|| {
                let xt = transposed(black_box(&f), n);
                faer_gram(dst.as_mut(), xt.as_ref());
            })
        });
    }
    g.finish();
}

fn stream(c: &mut Criterion) {
    let mut g = c.benchmark_group("stream");
    g.sample_size(10).sampling_mode(SamplingMode::Flat).measurement_time(Duration::from_secs(20));
    let f: Vec<f32> = images_u8(KC, 6).iter().map(|&v| v as f32 * 0.7 / 255.0 + 0.001).collect();
    g.throughput(Throughput::Elements((M * (M + 1) / 2 * KC * 2) as u64));
    {
        let mut acc = SyrkAcc::new(M);
        let mut panel = vec![0f64; padded(M) * KC];
        g.bench_function(format!("linpose, block of {KC} images"), |b| {
            b.iter(|| {
                pack_columns(&mut panel, black_box(&f), KC, M, None);
                acc.update(&panel, KC);
            })
        });
    }
    {
        let mut dst = Mat::<f64>::zeros(M, M);
        g.bench_function(format!("faer, block of {KC} images"), |b| {
            b.iter(|| {
                // P = block^T: M x KC, one image a column.
                let p = Mat::<f64>::from_fn(M, KC, |k, i| black_box(&f)[i * M + k] as f64);
                matmul(
                    dst.as_mut(),
                    BlockStructure::TriangularLower,
                    Accum::Add,
                    p.as_ref(),
                    BlockStructure::Rectangular,
                    p.transpose(),
                    BlockStructure::Rectangular,
                    1.0,
                    par(),
                );
            })
        });
    }
    g.finish();
}

criterion_group!(benches, gram, stream);
criterion_main!(benches);
