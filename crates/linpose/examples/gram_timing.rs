//! Times the Gram matrix G = X X^T for the training-set sizes of issue 7 (M = 19,200).
//!
//! cargo run --release --example gram_timing
use linpose::linalg::{gram, transpose_features};
use std::time::Instant;

fn main() {
    let m = 19_200;
    for n in [222usize, 2000] {
        let f: Vec<f32> = (0..n * m).map(|i| ((i * 2654435761usize) % 1000) as f32 / 1000.0).collect();
        let xt = transpose_features(&f, n, m, None);
        let mut best = f64::INFINITY;
        for _ in 0..5 {
            let t = Instant::now();
            let g = gram(xt.as_ref());
            best = best.min(t.elapsed().as_secs_f64());
            std::hint::black_box(g);
        }
        let flops = 2.0 * (n * n * m) as f64;
        println!("N = {n}: gram {:.4} s, {:.1} GFLOP/s (full product)", best, flops / best / 1e9);
    }
}
