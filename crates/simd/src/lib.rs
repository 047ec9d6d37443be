//! # simd — the CPU token of parallax
//!
//! The one place where parallax asks the CPU what it can do, in the manner of pulp (faer's SIMD
//! layer) and kornia-rs (one probe per process):
//!
//! * [`SimdLevel`]: the instruction-set levels the kernels are compiled for, ordered; the CPU's
//!   level is detected once per process ([`SimdLevel::detect`]).
//! * Tokens, [`Avx2`] and [`Avx512`]: zero-sized values that can only be obtained on a CPU that
//!   has the level ([`Avx2::new`], [`Avx2::at_most`]), so holding one proves the instruction set.
//!   A kernel compiled with `#[target_feature]` takes the token and is entered once per call.
//! * [`Level`]: what a kernel written once needs from a token: its register count and
//!   [`Level::vectorize`], which runs an `#[inline(always)]` closure inside a function compiled
//!   for the level (the one `unsafe` entry per level is here, as in pulp's `Simd::vectorize`).
//! * Lanes (x86-64), [`U16x16`] and [`U32x8`]: sixteen `u16` or eight `u32` in a 256-bit
//!   register, and the [`Lanes`] trait over both widths. A lane value can only be made through
//!   a token, so its operations are safe methods; only raw loads and stores are `unsafe` (the
//!   caller vouches for the memory, never for the CPU).
//!
//! * [`CacheAligned`]: a buffer whose first element starts a cache line, so that a kernel's
//!   vector loads and stores do not straddle lines depending on where the allocator put it.
//!
//! Every kernel keeps a portable path (`SimdLevel::Scalar`), which is what runs on other
//! architectures and what the kernels are tested against.
//!
//! ```
//! use parallax_simd::{Avx2, SimdLevel};
//!
//! let level = SimdLevel::detect();
//! println!("this CPU runs {level:?}; available: {:?}", SimdLevel::available());
//! // a token exists exactly when the level does
//! assert_eq!(Avx2::new().is_some(), level >= SimdLevel::Avx2);
//! // and never above a level the caller asks for
//! assert!(Avx2::at_most(SimdLevel::Scalar).is_none());
//! # #[cfg(target_arch = "x86_64")]
//! if let Some(t) = Avx2::new() {
//!     let a = t.splat(7);
//!     let b = t.splat(9);
//!     assert_eq!(a.min(b).horizontal_min(), 7);
//!     let mut out = [0u16; 16];
//!     t.store(&mut out, a.adds(b));
//!     assert_eq!(out, [16; 16]);
//!     // a kernel written once, compiled for the level by `vectorize`
//!     use parallax_simd::{Lanes, Level, U32x8};
//!     let m = t.vectorize(#[inline(always)] || U32x8::ramp(t).wrapping_add(U32x8::splat(t, 5)).horizontal_min());
//!     assert_eq!(m, 5);
//! }
//! ```

use std::sync::OnceLock;

use serde::{Deserialize, Serialize};

/// Which instruction set the inner loops are compiled for (chosen at run time). Levels are
/// ordered: a CPU that has a level has every level below it. More may come with new instruction
/// sets.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[non_exhaustive]
pub enum SimdLevel {
    /// Portable code (the compiler's baseline, SSE2 on x86-64).
    Scalar,
    /// AVX2 with FMA, BMI1, BMI2, LZCNT and POPCNT (x86-64-v3).
    Avx2,
    /// [`SimdLevel::Avx2`] and AVX-512 F, BW and VL. The kernels that gain from it (32 vector
    /// registers) have a copy for it; every other kernel runs its AVX2 code at this level.
    Avx512,
}

impl SimdLevel {
    /// The best level this CPU supports, detected on the first call and remembered for the
    /// process (the only place in parallax that queries the CPU's features).
    pub fn detect() -> Self {
        static LEVEL: OnceLock<SimdLevel> = OnceLock::new();
        *LEVEL.get_or_init(probe)
    }

    /// Every level this CPU supports, lowest first (tests run each kernel at each).
    pub fn available() -> Vec<SimdLevel> {
        [SimdLevel::Scalar, SimdLevel::Avx2, SimdLevel::Avx512].into_iter().filter(|&l| l <= Self::detect()).collect()
    }
}

/// Asks the CPU (once per process, through [`SimdLevel::detect`]).
fn probe() -> SimdLevel {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::is_x86_feature_detected as has;
        // every feature a kernel of the level enables (the AVX2 band kernels of block matching
        // also use BMI1/2, LZCNT and POPCNT)
        let avx2 = has!("avx2") && has!("fma") && has!("bmi1") && has!("bmi2") && has!("lzcnt") && has!("popcnt");
        let avx512 = has!("avx512f") && has!("avx512bw") && has!("avx512vl");
        if avx2 && avx512 {
            return SimdLevel::Avx512;
        }
        if avx2 {
            return SimdLevel::Avx2;
        }
    }
    SimdLevel::Scalar
}

/// Proof that this CPU runs [`SimdLevel::Avx2`]: it can only be obtained where
/// [`SimdLevel::detect`] found the level. Zero-sized and `Copy`; pass it to the kernels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Avx2 {
    _proof: (),
}

impl Avx2 {
    /// The token, when this CPU runs AVX2.
    #[inline]
    pub fn new() -> Option<Self> {
        Self::at_most(SimdLevel::Avx2)
    }

    /// The token when `level` asks for AVX2 or more and this CPU runs it (a caller capping
    /// its kernels at a lower level gets `None`).
    #[inline]
    pub fn at_most(level: SimdLevel) -> Option<Self> {
        (level >= SimdLevel::Avx2 && SimdLevel::detect() >= SimdLevel::Avx2).then_some(Avx2 { _proof: () })
    }
}

/// Proof that this CPU runs [`SimdLevel::Avx512`] (and therefore [`SimdLevel::Avx2`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Avx512 {
    _proof: (),
}

impl Avx512 {
    /// The token, when this CPU runs AVX-512 F/BW/VL as well as AVX2.
    #[inline]
    pub fn new() -> Option<Self> {
        Self::at_most(SimdLevel::Avx512)
    }

    /// The token when `level` asks for AVX-512 and this CPU runs it.
    #[inline]
    pub fn at_most(level: SimdLevel) -> Option<Self> {
        (level >= SimdLevel::Avx512 && SimdLevel::detect() >= SimdLevel::Avx512).then_some(Avx512 { _proof: () })
    }

    /// The AVX2 token the level implies.
    #[inline]
    pub fn avx2(self) -> Avx2 {
        Avx2 { _proof: () }
    }
}

/// A token of an instruction-set level: what a kernel written once needs to be compiled for
/// that level (the pattern of pulp's `Simd::vectorize`).
pub trait Level: Copy + Send + Sync + 'static {
    /// Vector registers the level has (16 for AVX2, 32 with AVX-512's EVEX encodings): how
    /// many vectors a kernel may keep in registers.
    const REGISTERS: usize;

    /// The AVX2 token the level implies (lane values are made from it).
    fn avx2(self) -> Avx2;

    /// Runs `f` inside a function compiled for this level's features. Write `f` as an
    /// `#[inline(always)]` closure whose body calls only `#[inline(always)]` functions: what is
    /// inlined into the level's function is compiled for the level (intrinsics become single
    /// instructions there); what is not still runs correctly, at the baseline.
    fn vectorize<R>(self, f: impl FnOnce() -> R) -> R;
}

impl Level for Avx2 {
    const REGISTERS: usize = 16;

    #[inline(always)]
    fn avx2(self) -> Avx2 {
        self
    }

    #[inline(always)]
    fn vectorize<R>(self, f: impl FnOnce() -> R) -> R {
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
        fn imp<R>(f: impl FnOnce() -> R) -> R {
            f()
        }
        #[cfg(target_arch = "x86_64")]
        // SAFETY: the token proves every feature `imp` is compiled with (see `probe`).
        return unsafe { imp(f) };
        #[cfg(not(target_arch = "x86_64"))]
        f()
    }
}

impl Level for Avx512 {
    const REGISTERS: usize = 32;

    #[inline(always)]
    fn avx2(self) -> Avx2 {
        Avx2 { _proof: () }
    }

    #[inline(always)]
    fn vectorize<R>(self, f: impl FnOnce() -> R) -> R {
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt,avx512f,avx512bw,avx512vl")]
        fn imp<R>(f: impl FnOnce() -> R) -> R {
            f()
        }
        #[cfg(target_arch = "x86_64")]
        // SAFETY: the token proves every feature `imp` is compiled with (see `probe`).
        return unsafe { imp(f) };
        #[cfg(not(target_arch = "x86_64"))]
        f()
    }
}

mod aligned;
pub use aligned::CacheAligned;

#[cfg(target_arch = "x86_64")]
mod x86;
#[cfg(target_arch = "x86_64")]
pub use x86::{Lanes, U16x16, U32x8};

#[cfg(test)]
mod tests {
    use super::*;

    /// The detected level is stable, heads `available`, and the tokens follow it.
    #[test]
    fn tokens_follow_the_detected_level() {
        let level = SimdLevel::detect();
        println!("SIMD levels on this machine: {:?}", SimdLevel::available());
        assert_eq!(SimdLevel::detect(), level);
        assert_eq!(SimdLevel::available().first(), Some(&SimdLevel::Scalar));
        assert_eq!(SimdLevel::available().last(), Some(&level));
        assert_eq!(Avx2::new().is_some(), level >= SimdLevel::Avx2);
        assert_eq!(Avx512::new().is_some(), level >= SimdLevel::Avx512);
        for cap in [SimdLevel::Scalar, SimdLevel::Avx2, SimdLevel::Avx512] {
            assert_eq!(Avx2::at_most(cap).is_some(), cap.min(level) >= SimdLevel::Avx2);
            assert_eq!(Avx512::at_most(cap).is_some(), cap.min(level) >= SimdLevel::Avx512);
        }
    }
}
