//! Large transient buffers asked on transparent huge pages.
//!
//! A fit's largest temporaries (the eigenspace's M x N f64 copy of the training images: 34 MB
//! for the paper's 222 views of 160 x 120) are above glibc's largest mmap threshold
//! ([`HEAP_MATRIX_BYTES`], 32 MiB), so every fit maps them afresh and touches them
//! page by page: on 4 kB pages the kernel takes a fault and zeroes a page 8,300 times for that
//! one copy. Linux backs a range with 2 MB pages only where the process asks
//! (`madvise(MADV_HUGEPAGE)`, the kernel's default `madvise` mode), as numpy does for its arrays.
//!
//! Only buffers above that threshold are advised: they are always fresh mappings, so the advice
//! comes before the first touch and the alignment slack is never touched. A smaller one may be
//! carved from the heap, already touched, where the slack would be zeroed too and the advice
//! would split pages when the heap shrinks: with the threshold at numpy's 4 MB, COIL-20 object
//! 1's refined fit (4.7 MB copies) was 7-37% slower in three alternated runs
//! (`bench/ab_timing.py`).
//!
//! Measured on an AVX2 machine (`bench/ab_timing.py`, 21 alternated turns of 0.2 s): the
//! rendered duck's eigenspace fit 161.3 -> 133.6 ms.
//!
//! Only the advice changes: the values, and so every result's bits, are the same.

/// glibc's largest mmap threshold (`DEFAULT_MMAP_THRESHOLD_MAX`, 64-bit): an N x N f64 matrix
/// smaller than this is carved from the heap once the threshold has grown past it, and one freed
/// there may stay resident, so the estimates of N x N systems add one such matrix (none for
/// larger ones, which are mapped and unmapped whole). Measured: the eigendecompositions at
/// N = 1,440 (16.6 MB matrices) peak about 20 MB above those at N = 2,880 and 5,760 scaled by
/// N^2.
pub(crate) const HEAP_MATRIX_BYTES: u64 = 32 << 20;

use crate::tuning::huge::HUGE_MIN_BYTES;
// Only buffers that are always fresh mappings are advised (see the module doc).
const _: () = assert!(HUGE_MIN_BYTES == HEAP_MATRIX_BYTES as usize);

/// The huge page size the buffer aligns to (x86-64's 2 MiB).
const HUGE_PAGE: usize = 2 << 20;

/// A zeroed run of `len` f64 values, on huge pages where the kernel grants them.
pub(crate) struct HugeBuf {
    v: Vec<f64>,
    off: usize,
    len: usize,
}

impl HugeBuf {
    /// `len` zeros. Above [`HUGE_MIN_BYTES`] (on Linux), the run starts on a huge page boundary inside an
    /// allocation up to one huge page larger (the slack is never touched, so it takes no memory)
    /// and its whole huge pages are advised as such before they are first touched.
    pub(crate) fn zeroed(len: usize) -> HugeBuf {
        if !cfg!(target_os = "linux") || len.saturating_mul(8) <= HUGE_MIN_BYTES {
            return HugeBuf { v: vec![0.0; len], off: 0, len };
        }
        // Zeroed allocation: fresh mappings (above the mmap threshold) are not written to.
        let v = vec![0.0f64; len + HUGE_PAGE / 8];
        let addr = v.as_ptr() as usize;
        let off = (addr.next_multiple_of(HUGE_PAGE) - addr) / 8;
        advise_huge(&v[off..off + len]);
        HugeBuf { v, off, len }
    }

    /// The values.
    pub(crate) fn as_slice(&self) -> &[f64] {
        &self.v[self.off..self.off + self.len]
    }

    /// The values, to write.
    pub(crate) fn as_mut_slice(&mut self) -> &mut [f64] {
        &mut self.v[self.off..self.off + self.len]
    }
}

/// Asks the kernel to back the whole huge pages of `run` (which starts on a boundary) with huge
/// pages; a kernel that refuses (or another system) leaves it as it is.
fn advise_huge(run: &[f64]) {
    let bytes = std::mem::size_of_val(run) / HUGE_PAGE * HUGE_PAGE;
    #[cfg(target_os = "linux")]
    if bytes > 0 {
        // SAFETY: the range is the first `bytes` bytes of `run`, memory this process owns and
        // keeps mapped while the call runs; MADV_HUGEPAGE changes how the kernel backs those
        // pages, never their contents or the mapping's validity.
        unsafe { libc::madvise(run.as_ptr() as *mut libc::c_void, bytes, libc::MADV_HUGEPAGE) };
    }
    let _ = bytes;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn runs_are_zeros_of_their_length_and_large_ones_start_on_a_huge_page() {
        for len in [0, 1, 1000, HUGE_MIN_BYTES / 8, HUGE_MIN_BYTES / 8 + 1, HUGE_MIN_BYTES / 8 + 3 * HUGE_PAGE / 8 + 5] {
            let mut b = HugeBuf::zeroed(len);
            assert_eq!(b.as_slice().len(), len);
            assert!(b.as_slice().iter().all(|&v| v == 0.0));
            if cfg!(target_os = "linux") && len * 8 > HUGE_MIN_BYTES {
                assert_eq!(b.as_slice().as_ptr() as usize % HUGE_PAGE, 0, "len {len}");
            }
            b.as_mut_slice().iter_mut().enumerate().for_each(|(i, v)| *v = i as f64);
            assert!(b.as_slice().iter().enumerate().all(|(i, &v)| v == i as f64));
        }
    }
}
