//! This machine's vector throughput, the base of the block matcher's ceiling: eight independent
//! chains of 16-bit vector adds (`vpaddw`, one of the cheapest vector instructions) in inline
//! assembly, at 128 and 256 bits, on every core at once. (Not 512: the block matcher's vectors
//! are 256-bit at every level, its AVX-512 level included, which uses AVX-512's 32 registers at
//! 256 bits; its ceiling is the widest width it uses.)
//!
//! `../shared/reference/stereo-limits.md` puts SAD block matching with running box sums at
//! ~9.5 vector operations per disparity evaluation (|L − R| of the entering and leaving rows, the
//! vertical and horizontal running sums, minimum and arg-minimum), so the ceiling in disparity
//! evaluations per second is the best 16-bit lane rate divided by [`OPS_PER_EVALUATION`].
//! Assembly because the compiler folds a loop of constant vector adds into one multiply-add.

use parallax_block_matching::SimdLevel;
use std::time::Instant;

/// Vector operations per disparity evaluation assumed by the ceiling (`stereo-limits.md`).
pub const OPS_PER_EVALUATION: f64 = 9.5;

/// Adds per round of the chains: each of the eight accumulators twice.
const ADDS_PER_ROUND: usize = 16;

/// A vector width.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Width {
    /// 128-bit (`xmm`, AVX encoding): the width of the pip build of OpenCV's StereoBM and SGBM.
    W128,
    /// 256-bit (`ymm`, AVX2).
    W256,
}

impl Width {
    /// Every width, narrowest first.
    pub const ALL: [Width; 2] = [Width::W128, Width::W256];

    /// Bits per vector.
    pub fn bits(self) -> usize {
        match self {
            Width::W128 => 128,
            Width::W256 => 256,
        }
    }

    /// 16-bit lanes per vector.
    pub fn lanes(self) -> usize {
        self.bits() / 16
    }

    /// Whether this CPU runs the chains at this width (both widths are compiled with VEX
    /// encodings: the AVX2 level, which implies AVX).
    pub fn available(self) -> bool {
        cfg!(target_arch = "x86_64") && SimdLevel::detect() >= SimdLevel::Avx2
    }
}

/// Runs `rounds` rounds of the add chains at `width`: `acc` holds the eight accumulators' lanes
/// (`8 · width.lanes()` values, accumulator `k` in `acc[k · lanes..]`), each lane gets `inc` added
/// [`ADDS_PER_ROUND`]` / 8` times per round (wrapping). `None` (and `acc` untouched) when the CPU
/// lacks the width; panics when `acc` has the wrong length.
pub fn add_chains(width: Width, acc: &mut [u16], inc: u16, rounds: usize) -> Option<()> {
    assert_eq!(acc.len(), 8 * width.lanes(), "eight accumulators of {} lanes", width.lanes());
    if !width.available() {
        return None;
    }
    #[cfg(target_arch = "x86_64")]
    // SAFETY: `available` checked the width's target features on this CPU; the length is asserted.
    unsafe {
        match width {
            Width::W128 => x86::chains128(acc, inc, rounds),
            Width::W256 => x86::chains256(acc, inc, rounds),
        }
    }
    Some(())
}

/// 16-bit lane additions per second of `threads` threads running `rounds` rounds of the chains
/// at once (wall-clock time of the whole group); `None` when the CPU lacks the width.
pub fn lane_rate(width: Width, threads: usize, rounds: usize) -> Option<f64> {
    if !width.available() {
        return None;
    }
    let t = Instant::now();
    std::thread::scope(|s| {
        for k in 0..threads {
            s.spawn(move || {
                let mut acc = vec![k as u16; 8 * width.lanes()];
                add_chains(width, &mut acc, 1, rounds);
                std::hint::black_box(acc);
            });
        }
    });
    let seconds = t.elapsed().as_secs_f64();
    Some((threads * rounds * ADDS_PER_ROUND * width.lanes()) as f64 / seconds)
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use std::arch::asm;
    use std::arch::x86_64::*;

    /// One add to each of the eight accumulators.
    macro_rules! eight_adds {
        () => {
            "vpaddw {a0}, {a0}, {i}\nvpaddw {a1}, {a1}, {i}\nvpaddw {a2}, {a2}, {i}\nvpaddw {a3}, {a3}, {i}\n\
             vpaddw {a4}, {a4}, {i}\nvpaddw {a5}, {a5}, {i}\nvpaddw {a6}, {a6}, {i}\nvpaddw {a7}, {a7}, {i}\n"
        };
    }

    macro_rules! chains {
        ($name:ident, $feat:literal, $t:ty, $class:ident, $ld:ident, $st:ident, $set1:ident) => {
            /// The add chains at this width (see [`super::add_chains`]).
            ///
            /// # Safety
            /// The CPU must support the target features of the attribute, and `acc` must hold
            /// eight vectors' lanes.
            #[target_feature(enable = $feat)]
            pub(super) unsafe fn $name(acc: &mut [u16], inc: u16, rounds: usize) {
                const LANES: usize = size_of::<$t>() / 2;
                assert_eq!(acc.len(), 8 * LANES);
                let p = acc.as_mut_ptr();
                // SAFETY: `acc` holds 8 · LANES values (asserted); the loads are unaligned ones.
                let ld = |k: usize| -> $t { unsafe { $ld(p.add(k * LANES) as *const _) } };
                let (mut a0, mut a1, mut a2, mut a3) = (ld(0), ld(1), ld(2), ld(3));
                let (mut a4, mut a5, mut a6, mut a7) = (ld(4), ld(5), ld(6), ld(7));
                let i: $t = $set1(inc as i16);
                for _ in 0..rounds {
                    // SAFETY: register-to-register adds only: no memory, stack or flags touched.
                    unsafe {
                        asm!(
                            concat!(eight_adds!(), eight_adds!()),
                            a0 = inout($class) a0,
                            a1 = inout($class) a1,
                            a2 = inout($class) a2,
                            a3 = inout($class) a3,
                            a4 = inout($class) a4,
                            a5 = inout($class) a5,
                            a6 = inout($class) a6,
                            a7 = inout($class) a7,
                            i = in($class) i,
                            options(nomem, nostack, preserves_flags),
                        );
                    }
                }
                for (k, v) in [a0, a1, a2, a3, a4, a5, a6, a7].into_iter().enumerate() {
                    // SAFETY: as for the loads.
                    unsafe { $st(p.add(k * LANES) as *mut _, v) };
                }
            }
        };
    }

    chains!(chains128, "avx", __m128i, xmm_reg, _mm_loadu_si128, _mm_storeu_si128, _mm_set1_epi16);
    chains!(chains256, "avx2", __m256i, ymm_reg, _mm256_loadu_si256, _mm256_storeu_si256, _mm256_set1_epi16);
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// The assembly adds what plain wrapping arithmetic adds, lane by lane, at every width this
    /// CPU has (and says which ran: a machine without them would test nothing here).
    #[test]
    fn add_chains_match_wrapping_arithmetic() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let mut ran = Vec::new();
        for width in Width::ALL {
            for _ in 0..4 {
                let init: Vec<u16> = (0..8 * width.lanes()).map(|_| rng.random()).collect();
                let (inc, rounds) = (rng.random::<u16>(), rng.random_range(0..5000usize));
                let mut acc = init.clone();
                if add_chains(width, &mut acc, inc, rounds).is_none() {
                    assert_eq!(acc, init, "{width:?} unavailable must leave the lanes alone");
                    continue;
                }
                let per_lane = (ADDS_PER_ROUND / 8 * rounds) as u16;
                let want: Vec<u16> = init.iter().map(|&v| v.wrapping_add(inc.wrapping_mul(per_lane))).collect();
                assert_eq!(acc, want, "{width:?}, inc {inc}, {rounds} rounds");
            }
            if width.available() {
                ran.push(width.bits());
            }
        }
        println!("add chains checked at {ran:?} bits");
        assert!(!ran.is_empty() || !cfg!(target_arch = "x86_64"), "no width ran on an x86-64 CPU");
    }
}
