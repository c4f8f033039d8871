//! 8-bit query throughput against bounds measured in the same run, alternating, medians of REPS:
//! the memory bound (a parallel copy of the same bytes: a batch of images, or one image plus the
//! weights it meets) and, for the eigenspace, the f32 FMA bound (2 x the f64 FMA loop's rate).
//! The linear model runs on pseudo-random images (its cost does not depend on them); the
//! eigenspace on the rendered duck (trained on the 9-degree views, queried with all 1760 views
//! repeated), so that its k-d tree search behaves as on real data. The 8-bit products skip
//! black steps (85% of the duck's pixels are background): the eigenspace's integer products
//! skip a step of 64 pixels where all 8 views of a register block are black,
//! so the eigenspace batch is also timed on the same views with every 0 raised to 1: no step
//! skipped, the dense work; once against the model above (the raised views lie off its
//! manifold, and its search costs more there than on real views) and once against a model
//! trained on the raised views (a background that is not black, as a user's would be). The FMA
//! bound counts that work as f32 fused multiply-adds; the integer kernel's `vpdpbusd` runs at
//! the same instruction rate and needs `bench::DIGITS` (2) where they need 4, so its own
//! compute bound is DIGITS / 4 of the FMA bound; the larger of that and the copy is printed
//! beside the rest.
//!
//! cargo bench -p linpose --bench query_timing [-- REPS]
use linpose::bench::{fma_flops_f64, read_seconds};
use linpose::{EigenspaceParams, Estimator, LinearParams, PoseModel};
use rayon::prelude::*;
use std::time::Instant;

// The benchmarks' fixtures: 160 x 120 pseudo-random 8-bit images on the paper's training grid.
#[path = "../benches/common/mod.rs"]
mod common;
use common::{images_u8 as images, raised, rendered_duck, training_set, M};

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn time(reps: usize, mut f: impl FnMut()) -> f64 {
    f();
    let t = Instant::now();
    for _ in 0..reps {
        f();
    }
    t.elapsed().as_secs_f64() / reps as f64
}

fn copy(src: &[u8], dst: &mut [u8]) {
    if src.len() >= 1 << 20 {
        dst.par_chunks_mut(1 << 20).zip(src.par_chunks(1 << 20)).for_each(|(d, s)| d.copy_from_slice(s));
    } else {
        dst.copy_from_slice(src);
    }
}

fn main() {
    let reps: usize = std::env::args().skip(1).find(|a| a != "--bench").map_or(7, |s| s.parse().expect("REPS"));
    let train = training_set();
    let lin = LinearParams::default().ridge(1e-6).fit(&train).unwrap();
    let batch = 4096;
    let q = images(batch, 7);
    let (duck_train, duck) = rendered_duck();
    let eig = EigenspaceParams::default().components(20).fit(&duck_train).unwrap();
    let eig_d = EigenspaceParams::default().components(20).fit(&raised(&duck_train)).unwrap();
    let qe: Vec<u8> = duck.iter().copied().cycle().take(batch * M).collect();
    let qd: Vec<u8> = qe.iter().map(|&v| v.max(1)).collect();
    let mut out = vec![0.0; batch * 2];
    let (mut d_batch, mut d_lin, mut d_eig) = (vec![0u8; batch * M], vec![0u8; M + lin.weights().len() * 4], vec![0u8; M + eig.basis().len() * 4]);
    let (s_lin, s_eig) = (vec![1u8; d_lin.len()], vec![1u8; d_eig.len()]);
    let mut r: Vec<Vec<f64>> = vec![vec![]; 15];
    let mut y = vec![0f32; batch * 20];
    for _ in 0..reps {
        r[0].push(time(3, || copy(&q, &mut d_batch)));
        r[1].push(time(2000, || copy(&s_lin, &mut d_lin)));
        r[2].push(time(300, || copy(&s_eig, &mut d_eig)));
        r[3].push(time(3, || lin.predict_u8_into(&q, &mut out).unwrap()));
        r[4].push(time(2000, || lin.predict_u8_into(&q[..M], &mut out[..2]).unwrap()));
        r[5].push(time(3, || eig.predict_u8_into(&qe, &mut out).unwrap()));
        r[6].push(time(300, || eig.predict_u8_into(&qe[77 * M..78 * M], &mut out[..2]).unwrap()));
        r[7].push(fma_flops_f64(0.2) * 2.0);
        r[9].push(time(3, || eig.project_u8_into(&qe, &mut y).unwrap()));
        r[12].push(time(3, || eig.predict_u8_into(&qd, &mut out).unwrap()));
        r[13].push(time(3, || eig.project_u8_into(&qd, &mut y).unwrap()));
        r[14].push(time(3, || eig_d.predict_u8_into(&qd, &mut out).unwrap()));
        r[10].push(read_seconds(&s_lin, 200));
        r[11].push(read_seconds(&s_eig, 50));
        r[8].push(time(1, || lin.predict_into(&q.iter().map(|&v| v as f32 / 255.0).collect::<Vec<_>>(), &mut out).unwrap()));
    }
    let m: Vec<f64> = r.into_iter().map(median).collect();
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    println!("threads {}, load average {}, medians of {reps}", rayon::current_num_threads(), load.split_whitespace().take(3).collect::<Vec<_>>().join(" "));
    let gb = |bytes: usize, t: f64| bytes as f64 / t / 1e9;
    println!(
        "copy bound: batch {:.1} GB/s; one image + linear weights (cached) {:.1} GB/s; + eigenspace basis {:.1} GB/s",
        gb(batch * M, m[0]),
        gb(d_lin.len(), m[1]),
        gb(d_eig.len(), m[2])
    );
    println!(
        "linear u8 batch {batch}: {:.3} us/query, {:.1} GB/s of images = {:.0}% of the copy bound",
        m[3] / batch as f64 * 1e6,
        gb(batch * M, m[3]),
        100.0 * m[0] / m[3]
    );
    println!(
        "linear u8 single: {:.2} us, bytes touched {:.1} GB/s = {:.0}% of the cached copy of the same bytes",
        m[4] * 1e6,
        gb(d_lin.len(), m[4]),
        100.0 * m[1] / m[4]
    );
    println!(
        "linear u8 single against one thread reading the same bytes from the caches ({:.2} us, {:.1} GB/s): {:.0}% of that bound",
        m[10] * 1e6,
        gb(d_lin.len(), m[10]),
        100.0 * m[10] / m[4]
    );
    let flops = (2 * 20 * M) as f64;
    println!("f32 FMA bound {:.0} GFLOP/s: eigenspace {:.2} us/query at best when batched", m[7] / 1e9, flops / m[7] * 1e6);
    let bound_b = (m[0] / batch as f64).max(flops / m[7]);
    println!(
        "eigenspace u8 batch {batch}: {:.3} us/query = {:.0}% of its bound (max of copy and FMA bounds)",
        m[5] / batch as f64 * 1e6,
        100.0 * bound_b / (m[5] / batch as f64)
    );
    let bound_s = m[11].max(flops / (m[7] / rayon::current_num_threads() as f64));
    println!(
        "eigenspace u8 single: {:.2} us = {:.0}% of its bound {:.2} us (max of one thread reading image + basis from the caches, {:.2} us, and one core's FMA bound)",
        m[6] * 1e6,
        100.0 * bound_s / m[6],
        bound_s * 1e6,
        m[11] * 1e6
    );
    println!(
        "eigenspace u8 projection alone, batch {batch}: {:.3} us/query = {:.0}% of its bound",
        m[9] / batch as f64 * 1e6,
        100.0 * bound_b / (m[9] / batch as f64)
    );
    println!(
        "dense (the same views, black raised to 1: no step skipped): eigenspace u8 batch {:.3} us/query = {:.0}%, projection alone {:.3} us = {:.0}%",
        m[12] / batch as f64 * 1e6,
        100.0 * bound_b / (m[12] / batch as f64),
        m[13] / batch as f64 * 1e6,
        100.0 * bound_b / (m[13] / batch as f64)
    );
    println!(
        "dense against a model trained on the raised views: eigenspace u8 batch {:.3} us/query = {:.0}%",
        m[14] / batch as f64 * 1e6,
        100.0 * bound_b / (m[14] / batch as f64)
    );
    let digits = linpose::bench::DIGITS as f64;
    let copy_b = m[0] / batch as f64;
    let vnni_b = copy_b.max(digits / 4.0 * flops / m[7]);
    println!(
        "  against the integer kernel's bound (max of copy, {:.2} us, and {digits}/4 of the FMA bound, {:.2} us): duck batch {:.0}%, dense {:.0}%, dense on its own model {:.0}%",
        copy_b * 1e6,
        digits / 4.0 * flops / m[7] * 1e6,
        100.0 * vnni_b / (m[5] / batch as f64),
        100.0 * vnni_b / (m[12] / batch as f64),
        100.0 * vnni_b / (m[14] / batch as f64)
    );
    println!("(linear f32 batch incl. conversion: {:.3} us/query)", m[8] / batch as f64 * 1e6);
}
