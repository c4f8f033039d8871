//! SIMD kernels behind the hot loops: the symmetric rank-k update that builds Gram matrices
//! ([`syrk`]; [`gram`] drives it for X X^T in memory, [`gram8`] for 8-bit features in exact
//! integer sums, with [`levels`]), the 8-bit query products ([`dot_u8`] in f32; [`dot_q`] exact
//! in integers against weights in 16-bit fixed point, for the eigenspace where AVX-512 VNNI
//! runs it; [`dot_w`] the same for the 16-bit block sums of binned images) and the refined
//! eigenspace's coarse scan ([`scan`]), and the robust stage's check ([`recon`]: a query's
//! least-squares reconstruction on binned rows, in f64).
//!
//! Each kernel has one portable body written so that it computes exactly the same operations in
//! the same order as its intrinsics version (fused multiply-adds, one accumulator per lane), so
//! every path gives bit-identical results; the paths are tested against each other and against a
//! plain reference. The instruction set is detected once at run time, as a token that only
//! detection makes ([`Level`], in [`isa`] with [`dispatch!`], which compiles a portable body
//! for each level), so no safe function can run an instruction the CPU lacks.
//!
//! The module is private to the crate; the benchmarks and examples reach what they time through
//! [`bench`], whose functions detect the level themselves, and [`peak`] measures the machine's
//! peaks for them to report against.

pub(crate) mod affine;
pub(crate) mod binning;
pub(crate) mod combine;
pub(crate) mod dot_q;
pub(crate) mod dot_u8;
pub(crate) mod dot_w;
pub(crate) mod gram;
pub(crate) mod gram8;
mod isa;
pub(crate) mod kdtree;
pub(crate) mod lattice;
pub(crate) mod levels;
pub(crate) mod noise;
pub(crate) mod recon;
// Peak-rate measurements: for the benches and the tests only.
#[cfg(any(test, feature = "bench"))]
pub(crate) mod peak;
mod rows;
pub(crate) mod scan;
pub(crate) mod surface;
pub(crate) mod syrk;
mod tuning;

pub(crate) use isa::{dispatch, Isa, Level};
pub use rows::Rows;

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
pub(crate) struct AlignedF32 {
    buf: Vec<f32>,
    off: usize,
    len: usize,
}

impl AlignedF32 {
    /// A 64-byte aligned copy of `v`.
    pub(crate) fn new(v: &[f32]) -> Self {
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
    pub(super) fn data(n: usize, m: usize) -> Vec<f32> {
        (0..n * m).map(|i| ((i * 2654435761usize) % 1009) as f32 / 1009.0 - 0.3).collect()
    }

    /// The Gram matrix of n rows of m values, row-major, summed plainly in f64.
    pub(super) fn reference(x: &[f32], n: usize, m: usize) -> Vec<f64> {
        let mut g = vec![0.0; n * n];
        for i in 0..n {
            for j in 0..n {
                g[i * n + j] = (0..m).map(|k| x[i * m + k] as f64 * x[j * m + k] as f64).sum();
            }
        }
        g
    }
}
