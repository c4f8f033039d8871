//! Where the k-d tree overtakes brute force for the eigenspace's nearest-manifold-point search,
//! the measurement behind `SearchKind::Auto`.
//!
//!     cargo bench -p linpose --bench eigen_search
//!
//! Points lie on a smooth closed curve (a one-parameter manifold) or a smooth sheet (two
//! parameters) in L dimensions, as appearance manifolds do; queries are points between them plus
//! a little noise, one thread, time per query in microseconds.

use linpose::bench::NearestIndex;
use linpose::methods::eigenspace::SearchKind;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::time::Instant;

fn manifold(n: usize, dim: usize, sheet: bool) -> Vec<f32> {
    let side = (n as f64).sqrt().round() as usize;
    (0..n)
        .flat_map(|k| {
            let (s, t) = if sheet {
                ((k / side) as f64 / side as f64, (k % side) as f64 / side as f64 * std::f64::consts::TAU)
            } else {
                (0.5, k as f64 / n as f64 * std::f64::consts::TAU)
            };
            (0..dim).map(move |l| {
                let f = (l / 2 + 1) as f64;
                let amp = 1.0 / f;
                (amp * if l % 2 == 0 { (f * t + s * l as f64).cos() } else { (f * t).sin() * (1.0 + s) }) as f32
            })
        })
        .collect()
}

fn main() {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    println!("| manifold | L | points | brute us/query | tree us/query |");
    println!("|---|---|---|---|---|");
    for sheet in [false, true] {
        for dim in [8, 20, 32] {
            for n in [32, 64, 128, 256, 512, 1024, 2048, 4096, 8192, 16384, 65536] {
                if !sheet && n > 8192 {
                    continue;
                }
                let pts = manifold(n, dim, sheet);
                let mut queries = Vec::with_capacity(2000 * dim);
                for _ in 0..2000 {
                    let k = rng.random_range(0..n);
                    for &v in &pts[k * dim..(k + 1) * dim] {
                        queries.push(v + rng.random_range(-0.01f32..0.01));
                    }
                }
                let mut t = [0.0; 2];
                for (i, kind) in [SearchKind::Brute, SearchKind::KdTree].into_iter().enumerate() {
                    let index = NearestIndex::new(&pts, dim, kind).unwrap();
                    let t0 = Instant::now();
                    let mut sink = 0usize;
                    for q in queries.chunks_exact(dim) {
                        sink = sink.wrapping_add(index.nearest(q));
                    }
                    t[i] = t0.elapsed().as_secs_f64() * 1e6 / 2000.0;
                    std::hint::black_box(sink);
                }
                println!("| {} | {dim} | {n} | {:.2} | {:.2} |", if sheet { "sheet" } else { "curve" }, t[0], t[1]);
            }
        }
    }
}
