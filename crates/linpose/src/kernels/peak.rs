//! The machine's measured peak, for benchmarks to report kernels against: fused multiply-add
//! throughput on registers (no memory traffic) and the time to read a buffer.

use rayon::prelude::*;
use std::time::Instant;

/// f64 FLOP/s (2 per fused multiply-add) of a register-only FMA loop run on every rayon thread
/// for about `seconds`, using the widest vectors available.
pub fn fma_flops_f64(seconds: f64) -> f64 {
    let threads = rayon::current_num_threads();
    let iters = calibrate(seconds);
    let t = Instant::now();
    let s: f64 = (0..threads).into_par_iter().map(|i| fma_loop(iters, 1.0 + i as f64 * 1e-9)).sum();
    let dt = t.elapsed().as_secs_f64();
    std::hint::black_box(s);
    (threads as u64 * iters * FMAS_PER_ITER) as f64 * 2.0 / dt
}

/// Fused multiply-adds of f64 lanes per loop iteration (16 independent 8-lane chains; on AVX2
/// 8 independent 4-lane chains, each 4 deep: enough in flight to cover the latency, with the
/// constants, in 16 registers).
const FMAS_PER_ITER: u64 = 16 * 8;

fn calibrate(seconds: f64) -> u64 {
    calibrate_loop(seconds, 1 << 16, |n| {
        std::hint::black_box(fma_loop(n, 1.0));
    })
}

/// Iterations of `run` that take about `seconds`, from a first count of `first` quadrupled until
/// a run takes over 20 ms.
fn calibrate_loop(seconds: f64, first: u64, run: impl Fn(u64)) -> u64 {
    let mut n = first;
    loop {
        let t = Instant::now();
        run(n);
        let dt = t.elapsed().as_secs_f64();
        if dt > 0.02 {
            return ((n as f64) * seconds / dt).max(1.0) as u64;
        }
        n *= 4;
    }
}

fn fma_loop(iters: u64, seed: f64) -> f64 {
    #[cfg(target_arch = "x86_64")]
    if is_x86_feature_detected!("avx512f") {
        // SAFETY: avx512f was detected just above; the kernel touches registers only.
        return unsafe { x86::fma_loop_avx512(iters, seed) };
    }
    #[cfg(target_arch = "x86_64")]
    if is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma") {
        // SAFETY: avx2 and fma were detected just above; the kernel touches registers only.
        return unsafe { x86::fma_loop_avx2(iters, seed) };
    }
    let mut acc = [seed; 128];
    for _ in 0..iters {
        for a in acc.iter_mut() {
            *a = a.mul_add(0.999_999_999, 1e-9);
        }
    }
    acc.iter().sum()
}

/// The f64-FLOP-equivalent peak of the 8-bit Gram ([`super::gram8::gram_levels`]): a
/// register-only loop of AVX-512 VNNI instructions on every rayon thread for about `seconds`,
/// `vpdpwssd` and `vpdpbusd` in equal numbers as the Gram issues them, counted as 2 FLOP per
/// lane per instruction (the Gram spends one 32-bit lane of one instruction per product of two
/// features: half a `vpdpwssd` lane for k_p k_q over a step pair, two halves of `vpdpbusd`
/// lanes for k_p r_q + r_p k_q over a step quad, where the f64 kernel spends one f64 lane of
/// one fused multiply-add). None without AVX-512 VNNI.
pub fn vnni_gram_flops(seconds: f64) -> Option<f64> {
    #[cfg(target_arch = "x86_64")]
    if is_x86_feature_detected!("avx512f") && is_x86_feature_detected!("avx512vnni") {
        // SAFETY: avx512f and avx512vnni were detected just above; the loop touches registers only.
        let run = |iters: u64, seed: i32| unsafe { x86::vnni_loop(iters, seed) };
        let iters = calibrate_loop(seconds, 1 << 14, |n| {
            std::hint::black_box(run(n, 1));
        });
        let threads = rayon::current_num_threads();
        let t = Instant::now();
        let s: i64 = (0..threads).into_par_iter().map(|i| run(iters, i as i32) as i64).sum();
        let dt = t.elapsed().as_secs_f64();
        std::hint::black_box(s);
        return Some((threads as u64 * iters * x86::VNNI_PER_ITER * 16) as f64 * 2.0 / dt);
    }
    let _ = seconds;
    None
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use std::arch::x86_64::*;

    /// VNNI instructions per iteration of [`vnni_loop`].
    pub(super) const VNNI_PER_ITER: u64 = 16;

    /// 8 `vpdpwssd` and 8 `vpdpbusd` per iteration into 16 independent accumulators.
    ///
    /// # Safety
    /// The CPU must support AVX-512F and AVX-512 VNNI.
    #[target_feature(enable = "avx512f,avx512vnni")]
    pub(super) unsafe fn vnni_loop(iters: u64, seed: i32) -> i32 {
        let (x, y) = (_mm512_set1_epi32(seed | 0x0001_0001), _mm512_set1_epi32(0x0102_0304));
        let mut acc = [_mm512_setzero_si512(); 16];
        for _ in 0..iters {
            for (j, a) in acc.iter_mut().enumerate() {
                *a = if j % 2 == 0 { _mm512_dpwssd_epi32(*a, x, y) } else { _mm512_dpbusd_epi32(*a, x, y) };
            }
        }
        let mut s = _mm512_setzero_si512();
        for a in acc {
            s = _mm512_add_epi32(s, a);
        }
        _mm512_reduce_add_epi32(s)
    }

    /// The wrapping sum of `words`, 32 per step in four independent vector sums.
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[target_feature(enable = "avx512f")]
    pub(super) unsafe fn read_avx512(words: &[u64]) -> u64 {
        let mut acc = [_mm512_setzero_si512(); 4];
        let chunks = words.chunks_exact(32);
        let tail = chunks.remainder().iter().fold(0u64, |a, &b| a.wrapping_add(b));
        for c in chunks {
            for (k, a) in acc.iter_mut().enumerate() {
                *a = _mm512_add_epi64(*a, _mm512_loadu_si512(c.as_ptr().add(8 * k) as *const _));
            }
        }
        let s = _mm512_add_epi64(_mm512_add_epi64(acc[0], acc[1]), _mm512_add_epi64(acc[2], acc[3]));
        (_mm512_reduce_add_epi64(s) as u64).wrapping_add(tail)
    }

    /// [`fma_loop_avx512`]'s 128 lanes an iteration on AVX2 (without it, the portable loop's
    /// `mul_add` would be a library call, and the peak 2 orders of magnitude low).
    ///
    /// # Safety
    /// The CPU must support AVX2 and FMA.
    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn fma_loop_avx2(iters: u64, seed: f64) -> f64 {
        let mul = _mm256_set1_pd(0.999_999_999);
        let add = _mm256_set1_pd(1e-9);
        let mut acc = [_mm256_set1_pd(seed); 8];
        for _ in 0..iters {
            for _ in 0..4 {
                for a in acc.iter_mut() {
                    *a = _mm256_fmadd_pd(*a, mul, add);
                }
            }
        }
        let mut s = _mm256_setzero_pd();
        for a in acc {
            s = _mm256_add_pd(s, a);
        }
        let mut lanes = [0f64; 4];
        _mm256_storeu_pd(lanes.as_mut_ptr(), s);
        lanes.iter().sum()
    }

    /// # Safety
    /// The CPU must support AVX-512F.
    #[target_feature(enable = "avx512f")]
    pub(super) unsafe fn fma_loop_avx512(iters: u64, seed: f64) -> f64 {
        let mul = _mm512_set1_pd(0.999_999_999);
        let add = _mm512_set1_pd(1e-9);
        let mut acc = [_mm512_set1_pd(seed); 16];
        for _ in 0..iters {
            for a in acc.iter_mut() {
                *a = _mm512_fmadd_pd(*a, mul, add);
            }
        }
        let mut s = _mm512_setzero_pd();
        for a in acc {
            s = _mm512_add_pd(s, a);
        }
        _mm512_reduce_add_pd(s)
    }
}

/// Seconds for one thread to read `buf` (summed as 64-bit words in 8-lane vectors, 4
/// independent sums, the widest loads available: the loads are the only cost), median of `reps`
/// after one warm-up pass, so a buffer that fits in the caches is read from them. The bound of
/// a read-only kernel on the same bytes: a copy also writes, and costs about twice as much.
/// The words lie on 64-byte boundaries, as the models' weights do: from the allocator's 16-byte
/// alignment three loads in four would straddle two cache lines, and the bound would depend on
/// where the buffer landed.
pub fn read_seconds(buf: &[u8], reps: usize) -> f64 {
    let lines: Vec<Line64> = buf
        .chunks(64)
        .map(|c| {
            let mut l = Line64([0; 8]);
            for (w, b) in l.0.iter_mut().zip(c.chunks(8)) {
                *w = b.iter().fold(0u64, |a, &b| a << 8 | b as u64);
            }
            l
        })
        .collect();
    // SAFETY: a `Line64` is 8 u64 with no padding, and the lines are contiguous.
    let words = unsafe { std::slice::from_raw_parts(lines.as_ptr() as *const u64, lines.len() * 8) };
    let mut times = Vec::with_capacity(reps);
    for r in 0..=reps {
        let t = Instant::now();
        std::hint::black_box(read_words(words));
        if r > 0 {
            times.push(t.elapsed().as_secs_f64());
        }
    }
    times.sort_by(f64::total_cmp);
    times[times.len() / 2]
}

/// 8 words on a 64-byte boundary.
#[derive(Clone, Copy)]
#[repr(C, align(64))]
struct Line64([u64; 8]);

fn read_words(words: &[u64]) -> u64 {
    #[cfg(target_arch = "x86_64")]
    if is_x86_feature_detected!("avx512f") {
        // SAFETY: avx512f was detected just above.
        return unsafe { x86::read_avx512(words) };
    }
    words.iter().fold(0u64, |a, &b| a.wrapping_add(b))
}

#[cfg(test)]
mod tests {
    /// The VNNI loop does the instructions it counts: per iteration 8 `vpdpwssd` adding
    /// 1 * 0x0304 + 1 * 0x0102 = 1030 and 8 `vpdpbusd` adding 1 * 4 + 1 * 2 = 6 to each of 16 lanes.
    #[test]
    #[cfg(target_arch = "x86_64")]
    fn the_vnni_loop_computes_what_it_counts() {
        if !(is_x86_feature_detected!("avx512f") && is_x86_feature_detected!("avx512vnni")) {
            // Rust has no skipped status: said on stderr (shown with --nocapture), and the one
            // thing checkable here checked: no VNNI figure is made up.
            eprintln!("skipped: the_vnni_loop_computes_what_it_counts: this CPU lacks AVX-512 F or VNNI");
            assert!(super::vnni_gram_flops(0.01).is_none());
            return;
        }
        // SAFETY: avx512f and avx512vnni were detected just above.
        let s = unsafe { super::x86::vnni_loop(10, 0) };
        assert_eq!(s, 10 * 16 * 8 * (1030 + 6));
        assert_eq!(super::x86::VNNI_PER_ITER, 16);
        assert!(super::vnni_gram_flops(0.01).is_some_and(|f| f > 0.0));
    }
}
