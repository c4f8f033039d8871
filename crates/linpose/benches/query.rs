//! Query throughput of the 8-bit paths against the memory-bandwidth bound measured in the same
//! run (a parallel copy of as many bytes): the linear model (K = 3 products) and the eigenspace
//! (L = 20 products, then the search), one query and batches of 1024. The linear model runs on
//! pseudo-random images (its cost does not depend on them), the eigenspace on the rendered duck
//! (trained on the 9-degree views, queried with its own views), so that its k-d tree search
//! behaves as on real data; the 8-bit products skip black steps (16 pixels of one image for the
//! linear model, 64 pixels of 8 images for the eigenspace), so the eigenspace batch is also run
//! on the same views with every 0 raised to 1 (no step skipped, the dense work), against the
//! model above and against one trained on the raised views (whose manifold they lie on, as a
//! user's views on a background that is not black lie on the manifold of their training views).
//! The refined eigenspace (the default: its binning factor chosen from the duck's training
//! views, 4) runs on the same views, 8-bit (block sums through the 16-bit products) and f32.
//! `benches/query_timing.rs` prints the same figures as fractions of their bounds (the copy, one
//! thread reading the same bytes, the FMA peak).
//!
//! cargo bench -p linpose --bench query
use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use linpose::{EigenspaceParams, Estimator, LinearParams, PoseModel, RefinedParams};
use rayon::prelude::*;
use std::hint::black_box;

mod common;
use common::*;

fn copy(c: &mut Criterion, name: &str, bytes: usize) {
    let src = vec![1u8; bytes];
    let mut dst = vec![0u8; bytes];
    let mut g = c.benchmark_group("copy");
    g.throughput(Throughput::Bytes(bytes as u64));
    g.bench_function(name, |b| {
        b.iter(|| {
            if bytes >= 1 << 20 {
                dst.par_chunks_mut(1 << 20).zip(src.par_chunks(1 << 20)).for_each(|(d, s)| d.copy_from_slice(s));
            } else {
                dst.copy_from_slice(&src);
            }
            black_box(&dst);
        })
    });
    g.finish();
}

fn queries(c: &mut Criterion) {
    let train = training_set();
    let lin = LinearParams::default().ridge(1e-6).fit(&train).unwrap();
    let (duck_train, duck) = rendered_duck();
    let eig = EigenspaceParams::default().components(20).fit(&duck_train).unwrap();
    let batch = 1024;
    let q = images_u8(batch, 7);
    let qf: Vec<f32> = q[..M].iter().map(|&v| v as f32 / 255.0).collect();
    let qe = &duck[..batch * M];
    let qef: Vec<f32> = qe[77 * M..78 * M].iter().map(|&v| v as f32 / 255.0).collect();
    let mut out = vec![0.0; batch * 2];
    // Bounds: one image plus the weights it is multiplied with (cache-resident), and a batch.
    copy(c, "one image + linear weights", M + lin.weights().len() * 4);
    copy(c, "one image + eigenspace basis", M + eig.basis().len() * 4);
    copy(c, "batch of 1024 images", batch * M);
    let mut g = c.benchmark_group("linear");
    g.throughput(Throughput::Bytes(M as u64));
    g.bench_function("u8 single", |b| b.iter(|| lin.predict_u8_into(black_box(&q[..M]), &mut out[..2]).unwrap()));
    g.bench_function("f32 single", |b| b.iter(|| lin.predict_into(black_box(&qf), &mut out[..2]).unwrap()));
    g.throughput(Throughput::Bytes((batch * M) as u64));
    g.bench_function("u8 batch 1024", |b| b.iter(|| lin.predict_u8_into(black_box(&q), &mut out).unwrap()));
    g.finish();
    let mut g = c.benchmark_group("eigenspace");
    g.throughput(Throughput::Bytes(M as u64));
    g.bench_function("u8 single", |b| b.iter(|| eig.predict_u8_into(black_box(&qe[77 * M..78 * M]), &mut out[..2]).unwrap()));
    g.bench_function("f32 single", |b| b.iter(|| eig.predict_into(black_box(&qef), &mut out[..2]).unwrap()));
    g.throughput(Throughput::Bytes((batch * M) as u64));
    g.bench_function("u8 batch 1024", |b| b.iter(|| eig.predict_u8_into(black_box(qe), &mut out).unwrap()));
    let mut y = vec![0f32; batch * 20];
    g.bench_function("u8 batch 1024, projection alone", |b| b.iter(|| eig.project_u8_into(black_box(qe), &mut y).unwrap()));
    let qd: Vec<u8> = qe.iter().map(|&v| v.max(1)).collect();
    g.bench_function("u8 batch 1024, dense (black raised to 1)", |b| b.iter(|| eig.predict_u8_into(black_box(&qd), &mut out).unwrap()));
    let eig_d = EigenspaceParams::default().components(20).fit(&raised(&duck_train)).unwrap();
    g.bench_function("u8 batch 1024, dense, model trained on raised views", |b| b.iter(|| eig_d.predict_u8_into(black_box(&qd), &mut out).unwrap()));
    g.finish();
    let refined = RefinedParams::default().fit(&duck_train).unwrap();
    let qrf: Vec<f32> = qe.iter().map(|&v| v as f32 / 255.0).collect();
    let mut g = c.benchmark_group(format!("refined (bin {})", refined.settings().bin));
    g.throughput(Throughput::Bytes(M as u64));
    g.bench_function("u8 single", |b| b.iter(|| refined.predict_u8_into(black_box(&qe[77 * M..78 * M]), &mut out[..2]).unwrap()));
    g.bench_function("f32 single", |b| b.iter(|| refined.predict_into(black_box(&qef), &mut out[..2]).unwrap()));
    g.throughput(Throughput::Bytes((batch * M) as u64));
    g.bench_function("u8 batch 1024", |b| b.iter(|| refined.predict_u8_into(black_box(qe), &mut out).unwrap()));
    g.bench_function("f32 batch 1024", |b| b.iter(|| refined.predict_into(black_box(&qrf), &mut out).unwrap()));
    g.bench_function("eigenspace f32 batch 1024 (beside it)", |b| b.iter(|| eig.predict_into(black_box(&qrf), &mut out).unwrap()));
    g.finish();
}

criterion_group! { name = benches; config = Criterion::default().sample_size(20); targets = queries }
criterion_main!(benches);
