//! SIMD kernels behind the hot loops: the symmetric rank-k update that builds Gram matrices
//! ([`syrk`]; [`gram`] drives it for X X^T in memory, [`gram8`] for 8-bit features in exact
//! integer sums, with [`levels`]), the 8-bit query products ([`dot_u8`] in f32; [`dot_q`] exact
//! in integers against weights in 16-bit fixed point, for the eigenspace where AVX-512 VNNI runs
//! it; [`dot_w`] the same for the 16-bit block sums of binned images) and the refined eigenspace's coarse scan ([`scan`]).
//!
//! Each kernel has one portable body written so that it computes exactly the same operations in
//! the same order as its intrinsics version (fused multiply-adds, one accumulator per lane), so
//! every path gives bit-identical results; the paths are tested against each other and against a
//! plain reference. The instruction set is detected once at run time ([`Level::detect`]).

pub mod dot_q;
pub mod dot_u8;
pub mod dot_w;
pub mod gram;
pub mod gram8;
pub mod levels;
pub mod peak;
pub mod scan;
pub mod syrk;

/// The sum of the 16 u32 lanes of `v` (the binning kernels' and the noise estimate's squares
/// and responses, summed in u32 lanes between flushes).
#[cfg(target_arch = "x86_64")]
#[inline]
#[target_feature(enable = "avx512f")]
pub(crate) fn sum_u32_lanes(v: std::arch::x86_64::__m512i) -> u64 {
    use std::arch::x86_64::*;
    _mm512_reduce_add_epi64(_mm512_cvtepu32_epi64(_mm512_castsi512_si256(v))) as u64
        + _mm512_reduce_add_epi64(_mm512_cvtepu32_epi64(_mm512_extracti64x4_epi64::<1>(v))) as u64
}

/// f32 values that start on a 64-byte boundary (a cache line, one AVX-512 vector), so that a
/// kernel can load them aligned in place instead of copying them ([`dot_u8::dots_batch`] reads
/// model weights this way). Read-only once made; a clone is aligned afresh.
#[derive(Default)]
pub struct AlignedF32 {
    buf: Vec<f32>,
    off: usize,
    len: usize,
}

impl AlignedF32 {
    /// A 64-byte aligned copy of `v`.
    pub fn new(v: &[f32]) -> Self {
        let mut buf = vec![0f32; v.len() + 15];
        let off = buf.as_ptr().align_offset(64).min(15);
        buf[off..off + v.len()].copy_from_slice(v);
        AlignedF32 { buf, off, len: v.len() }
    }
}

impl std::ops::Deref for AlignedF32 {
    type Target = [f32];
    fn deref(&self) -> &[f32] {
        &self.buf[self.off..self.off + self.len]
    }
}

impl Clone for AlignedF32 {
    fn clone(&self) -> Self {
        AlignedF32::new(self)
    }
}

impl std::fmt::Debug for AlignedF32 {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_list().entries(self.iter()).finish()
    }
}

/// Fixtures shared by the Gram kernels' tests.
#[cfg(test)]
mod test_data {
    /// n rows of m deterministic values in [-0.3, 0.7).
    pub fn data(n: usize, m: usize) -> Vec<f32> {
        (0..n * m).map(|i| ((i * 2654435761usize) % 1009) as f32 / 1009.0 - 0.3).collect()
    }

    /// The Gram matrix of n rows of m values, row-major, summed plainly in f64.
    pub fn reference(x: &[f32], n: usize, m: usize) -> Vec<f64> {
        let mut g = vec![0.0; n * n];
        for i in 0..n {
            for j in 0..n {
                g[i * n + j] = (0..m).map(|k| x[i * m + k] as f64 * x[j * m + k] as f64).sum();
            }
        }
        g
    }
}

/// The SIMD instruction set a kernel runs with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Level {
    /// Plain Rust, whatever the target's baseline gives.
    Portable,
    /// AVX2 with FMA (the portable body compiled for it).
    Avx2,
    /// AVX-512 F/BW intrinsics.
    Avx512,
}

impl Level {
    /// The best level this CPU supports (cached after the first call). The environment variable
    /// `LINPOSE_SIMD=portable|avx2|avx512` caps it, for testing and benchmarking the other paths.
    pub fn detect() -> Level {
        use std::sync::OnceLock;
        static LEVEL: OnceLock<Level> = OnceLock::new();
        *LEVEL.get_or_init(|| {
            let cap = match std::env::var("LINPOSE_SIMD").as_deref() {
                Ok("portable") => Level::Portable,
                Ok("avx2") => Level::Avx2,
                _ => Level::Avx512,
            };
            Self::supported().into_iter().filter(|&l| l <= cap).max().unwrap_or(Level::Portable)
        })
    }

    /// Every level this CPU can run (always includes [`Level::Portable`]).
    pub fn supported() -> Vec<Level> {
        #[allow(unused_mut)]
        let mut v = vec![Level::Portable];
        #[cfg(target_arch = "x86_64")]
        {
            if is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma") {
                v.push(Level::Avx2);
            }
            if is_x86_feature_detected!("avx512f") && is_x86_feature_detected!("avx512bw") {
                v.push(Level::Avx512);
            }
        }
        v
    }
}
