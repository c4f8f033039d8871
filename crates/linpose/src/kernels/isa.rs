//! The instruction set the kernels run with, as a token that only run-time detection makes.
//!
//! A [`Level`] is proof that the CPU runs an instruction set: its fields are private to this
//! module, and its only constructors, [`Level::detect`] and `Level::supported` (for tests),
//! check the CPU first. So a safe function that takes a `Level` may run the instructions it
//! stands for (the `unsafe` blocks that call `#[target_feature]` code rely on this and say so),
//! and no caller can make it run an instruction the CPU lacks. Kernels that need more than a
//! level's base set (AVX-512 VNNI, AVX-512 VL) ask the token for exactly what they use.
//!
//! [`dispatch!`] runs a portable body compiled for the level's instruction set: the kernels
//! write each loop once, in plain Rust that the compiler vectorises, and the same operations in
//! the same order give the same bits at every level.

/// Instruction sets, in increasing order: each includes the ones before it. Only a [`Level`]
/// proves that the CPU runs one; an `Isa` alone proves nothing.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub(crate) enum Isa {
    /// Plain Rust, whatever the target's baseline gives.
    Portable,
    /// AVX2 with FMA.
    Avx2,
    /// AVX-512 F and BW (with AVX2 and FMA).
    Avx512,
}

/// The SIMD instruction set a kernel runs with: a token only detection makes (see the module
/// doc).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Level {
    isa: Isa,
    /// AVX-512 VNNI (only with [`Isa::Avx512`]).
    vnni: bool,
    /// AVX-512 VL (only with [`Isa::Avx512`]).
    vl: bool,
}

/// What this CPU has, as the best [`Level`] it runs with nothing capped.
fn cpu() -> Level {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::is_x86_feature_detected as has;
        if has!("avx2") && has!("fma") {
            if has!("avx512f") && has!("avx512bw") {
                return Level { isa: Isa::Avx512, vnni: has!("avx512vnni"), vl: has!("avx512vl") };
            }
            return Level { isa: Isa::Avx2, vnni: false, vl: false };
        }
    }
    Level::PORTABLE
}

impl Level {
    /// Plain Rust: every CPU runs it.
    const PORTABLE: Level = Level { isa: Isa::Portable, vnni: false, vl: false };

    /// `self` capped at `isa` (a subset of what `self` proves, so still proven).
    fn capped(self, isa: Isa) -> Level {
        if self.isa <= isa {
            self
        } else {
            Level { isa, vnni: false, vl: false }
        }
    }

    /// The best level this CPU runs (detected once, then cached). The environment variable
    /// `LINPOSE_SIMD=portable|avx2|avx512` caps it, to test and benchmark the other paths.
    pub(crate) fn detect() -> Level {
        use std::sync::OnceLock;
        static LEVEL: OnceLock<Level> = OnceLock::new();
        *LEVEL.get_or_init(|| {
            let cap = match std::env::var("LINPOSE_SIMD").as_deref() {
                Ok("portable") => Isa::Portable,
                Ok("avx2") => Isa::Avx2,
                _ => Isa::Avx512,
            };
            cpu().capped(cap)
        })
    }

    /// Every level this CPU runs, portable first (for tests that compare the paths).
    #[cfg(test)]
    pub(crate) fn supported() -> Vec<Level> {
        let best = cpu();
        [Isa::Portable, Isa::Avx2, Isa::Avx512].into_iter().filter(|&isa| isa <= best.isa).map(|isa| best.capped(isa)).collect()
    }

    /// This level without AVX-512 VNNI (for tests of the kernels that stand in for it).
    #[cfg(any(test, feature = "bench"))]
    pub(crate) fn without_vnni(self) -> Level {
        Level { vnni: false, ..self }
    }

    /// The instruction set this level proves the CPU runs.
    pub(crate) fn isa(self) -> Isa {
        self.isa
    }

    /// Whether this level is AVX-512 (F and BW, with AVX2 and FMA).
    pub(crate) fn avx512(self) -> bool {
        self.isa == Isa::Avx512
    }

    /// Whether this level runs AVX2 with FMA (AVX2 itself, or AVX-512, which includes them).
    pub(crate) fn avx2(self) -> bool {
        self.isa >= Isa::Avx2
    }

    /// Whether this level is AVX-512 with VNNI.
    pub(crate) fn avx512_vnni(self) -> bool {
        self.avx512() && self.vnni
    }

    /// Whether this level is AVX-512 with VL.
    pub(crate) fn avx512_vl(self) -> bool {
        self.avx512() && self.vl
    }
}

/// `$vis fn $name(level: Level, args..) -> ret`: the `#[inline(always)]` function `$body`
/// (same arguments) compiled for the level's instruction set. It makes a `#[target_feature]`
/// copy for AVX-512 F and one for AVX2 and FMA, into which the body is inlined and vectorised
/// for them, and the match on [`Level::isa`] that picks one (the portable level calls the body
/// as it is). One `const Q: usize` parameter is passed on to the body. A body must not depend
/// on the instruction set for its result: written in plain arithmetic (no fused multiply-add
/// unless written), every build computes the same operations in the same order.
macro_rules! dispatch {
    ($(#[$attr:meta])* $vis:vis fn $name:ident $(<const $q:ident: usize>)? ($($arg:ident: $ty:ty),* $(,)?) $(-> $ret:ty)? = $body:ident;) => {
        $(#[$attr])*
        $vis fn $name$(<const $q: usize>)?(level: $crate::kernels::Level, $($arg: $ty),*) $(-> $ret)? {
            /// The body compiled with AVX-512 F.
            ///
            /// # Safety
            /// The CPU must support AVX-512F.
            #[cfg(target_arch = "x86_64")]
            #[target_feature(enable = "avx512f")]
            unsafe fn avx512$(<const $q: usize>)?($($arg: $ty),*) $(-> $ret)? {
                $body$(::<$q>)?($($arg),*)
            }
            /// The body compiled with AVX2 and FMA.
            ///
            /// # Safety
            /// The CPU must support AVX2 and FMA.
            #[cfg(target_arch = "x86_64")]
            #[target_feature(enable = "avx2,fma")]
            unsafe fn avx2$(<const $q: usize>)?($($arg: $ty),*) $(-> $ret)? {
                $body$(::<$q>)?($($arg),*)
            }
            match level.isa() {
                #[cfg(target_arch = "x86_64")]
                // SAFETY: a Level holds Isa::Avx512 only where detection found AVX-512F (with
                // BW, AVX2 and FMA) on this CPU: all that `avx512` enables.
                $crate::kernels::Isa::Avx512 => unsafe { avx512$(::<$q>)?($($arg),*) },
                #[cfg(target_arch = "x86_64")]
                // SAFETY: a Level holds Isa::Avx2 only where detection found AVX2 and FMA on
                // this CPU: all that `avx2` enables.
                $crate::kernels::Isa::Avx2 => unsafe { avx2$(::<$q>)?($($arg),*) },
                _ => $body$(::<$q>)?($($arg),*),
            }
        }
    };
}
pub(crate) use dispatch;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn levels_are_capped_and_ordered() {
        let all = Level::supported();
        assert_eq!(all[0], Level::PORTABLE);
        assert!(all.windows(2).all(|w| w[0].isa < w[1].isa));
        assert!(all.contains(&Level::detect()));
        for l in &all {
            assert!(l.avx512() || !(l.vnni || l.vl), "VNNI and VL only with AVX-512: {l:?}");
            assert!(!l.without_vnni().avx512_vnni());
        }
        let best = *all.last().expect("portable at least");
        assert_eq!(best.capped(Isa::Portable), Level::PORTABLE);
        assert_eq!(best.capped(Isa::Avx512), best);
    }

    #[inline(always)]
    fn halves_body(n: usize) -> f32 {
        (0..n).map(|i| i as f32 * 0.5).sum()
    }

    dispatch! {
        fn halves(n: usize) -> f32 = halves_body;
    }

    #[inline(always)]
    fn first_body<const Q: usize>(v: &[u8]) -> usize {
        v[..Q].iter().map(|&x| x as usize).sum()
    }

    dispatch! {
        fn first<const Q: usize>(v: &[u8]) -> usize = first_body;
    }

    #[test]
    fn every_level_runs_the_body() {
        for l in Level::supported() {
            assert_eq!(halves(l, 100), 2475.0, "{l:?}");
            assert_eq!(first::<3>(l, &[1, 2, 3, 4]), 6, "{l:?}");
        }
    }
}
