//! x86-64 lanes. Every method is `#[inline(always)]`: inlined into a kernel that a token's
//! `#[target_feature]` entry point compiles for AVX2, the intrinsic becomes one instruction; at
//! opt-level 0 it stays a call, which is still correct on the CPU the token proved.

use std::arch::x86_64::*;

use crate::Avx2;

/// Sixteen `u16` lanes in a 256-bit register. A value can only be made by an [`Avx2`] token
/// (the field is private and there is no other constructor), so every method may use AVX2.
#[derive(Clone, Copy)]
#[repr(transparent)]
pub struct U16x16(__m256i);

impl std::fmt::Debug for U16x16 {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let mut lanes = [0u16; 16];
        // SAFETY: 16 writable lanes; a `U16x16` exists only where AVX2 does.
        unsafe { _mm256_storeu_si256(lanes.as_mut_ptr().cast(), self.0) };
        f.debug_tuple("U16x16").field(&lanes).finish()
    }
}

impl Avx2 {
    /// `x` in every lane.
    #[inline(always)]
    pub fn splat(self, x: u16) -> U16x16 {
        // SAFETY: the token proves AVX2.
        U16x16(unsafe { _mm256_set1_epi16(x as i16) })
    }

    /// The first 16 lanes of `s` (panics when `s` is shorter).
    #[inline(always)]
    pub fn load(self, s: &[u16]) -> U16x16 {
        let s = &s[..16];
        // SAFETY: 16 readable lanes (just checked); the token proves AVX2.
        unsafe { self.load_ptr(s.as_ptr()) }
    }

    /// Stores `v` into the first 16 lanes of `s` (panics when `s` is shorter).
    #[inline(always)]
    pub fn store(self, s: &mut [u16], v: U16x16) {
        let s = &mut s[..16];
        // SAFETY: 16 writable lanes (just checked); the token proves AVX2.
        unsafe { self.store_ptr(s.as_mut_ptr(), v) }
    }

    /// Loads 16 lanes from `p`.
    ///
    /// # Safety
    /// `p` must point to 16 readable `u16` (no alignment needed).
    #[inline(always)]
    pub unsafe fn load_ptr(self, p: *const u16) -> U16x16 {
        // SAFETY: the caller vouches for the memory, the token for AVX2.
        U16x16(unsafe { _mm256_loadu_si256(p.cast()) })
    }

    /// Stores `v` at `p`.
    ///
    /// # Safety
    /// `p` must point to 16 writable `u16` (no alignment needed).
    #[inline(always)]
    pub unsafe fn store_ptr(self, p: *mut u16, v: U16x16) {
        // SAFETY: the caller vouches for the memory, the token for AVX2.
        unsafe { _mm256_storeu_si256(p.cast(), v.0) }
    }

    /// The Birchfield–Tomasi difference of row a minus row b's per lane (wrapping), from byte
    /// pairs as [`Avx2::pair_difference`]: left values `u` and intervals `[u0, u1]` (lane `k` =
    /// `a | b << 8` each), and the 16 byte pairs of the right values at `v`, of their intervals'
    /// lower ends at `v0` and upper ends at `v1`. Per byte, `min(dist(u, [v0, v1]),
    /// dist(v, [u0, u1]))` with saturating byte subtractions (at most one of the two per distance
    /// is non-zero when the interval holds its value, `lo ≤ v ≤ hi`, so their `or` is their
    /// maximum), then the multiply-add by `(1, −1)`: exact for any such bytes (each difference
    /// is at most 255). With `extra = Some((e, p))`, a second term's difference is added to each
    /// byte before the multiply-add: `|e_a − p_a|` and `|e_b − p_b|` of the byte pairs `e` (as
    /// `u`) and the 16 at `p`, exact when every byte of both terms is below 128 (each sum is
    /// then at most 254).
    ///
    /// # Safety
    /// `v`, `v0`, `v1` (and `extra`'s `p`) must each point to 32 readable bytes.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)] // the left triple, the right triple and a second term
    pub unsafe fn pair_bt_difference(
        self,
        u: U16x16,
        u0: U16x16,
        u1: U16x16,
        v: *const u8,
        v0: *const u8,
        v1: *const u8,
        extra: Option<(U16x16, *const u8)>,
    ) -> U16x16 {
        // SAFETY: the caller vouches for the 3 · 32 bytes (4 · 32 with `extra`), the token for
        // AVX2.
        U16x16(unsafe {
            let (r, r0, r1) =
                (_mm256_loadu_si256(v.cast()), _mm256_loadu_si256(v0.cast()), _mm256_loadu_si256(v1.cast()));
            let du = _mm256_or_si256(_mm256_subs_epu8(u.0, r1), _mm256_subs_epu8(r0, u.0));
            let dv = _mm256_or_si256(_mm256_subs_epu8(r, u1.0), _mm256_subs_epu8(u0.0, r));
            let mut d = _mm256_min_epu8(du, dv);
            if let Some((e, p)) = extra {
                d = _mm256_add_epi8(d, _mm256_abs_epi8(_mm256_sub_epi8(e.0, _mm256_loadu_si256(p.cast()))));
            }
            _mm256_maddubs_epi16(d, _mm256_set1_epi16(0xff01u16 as i16))
        })
    }

    /// `|a − r_a| − |b − r_b|` per lane (wrapping) from the byte pairs `(a, b)` of `ab` (lane
    /// `k` = `a | b << 8`) and the 16 byte pairs `(r_a, r_b)` at `p`, every byte below 128: the
    /// byte difference does not wrap, its absolute value is below 128 and the multiply-add by
    /// `(1, −1)` is exact.
    ///
    /// # Safety
    /// `p` must point to 32 readable bytes.
    #[inline(always)]
    pub unsafe fn pair_difference(self, ab: U16x16, p: *const u8) -> U16x16 {
        // SAFETY: the caller vouches for the 32 bytes at p, the token for AVX2.
        let r = unsafe { _mm256_loadu_si256(p.cast()) };
        // SAFETY: the token proves AVX2.
        U16x16(unsafe {
            _mm256_maddubs_epi16(_mm256_abs_epi8(_mm256_sub_epi8(ab.0, r)), _mm256_set1_epi16(0xff01u16 as i16))
        })
    }
}

/// A binary lane operation by one intrinsic.
macro_rules! binary {
    ($($(#[$doc:meta])* $name:ident: $intrinsic:ident;)+) => {
        $(
            $(#[$doc])*
            #[inline(always)]
            pub fn $name(self, b: Self) -> Self {
                // SAFETY: a `U16x16` is only made by an `Avx2` token: the CPU runs AVX2.
                Self(unsafe { $intrinsic(self.0, b.0) })
            }
        )+
    };
}

impl U16x16 {
    binary! {
        /// Wrapping `a + b`.
        wrapping_add: _mm256_add_epi16;
        /// Wrapping `a − b`.
        wrapping_sub: _mm256_sub_epi16;
        /// Saturating unsigned `a + b`.
        adds: _mm256_adds_epu16;
        /// Saturating unsigned `a − b`.
        subs: _mm256_subs_epu16;
        /// Unsigned minimum.
        min: _mm256_min_epu16;
        /// Unsigned maximum.
        max: _mm256_max_epu16;
        /// All ones in the lanes where `a = b`, zero elsewhere.
        eq: _mm256_cmpeq_epi16;
        /// Bitwise or.
        or: _mm256_or_si256;
    }

    /// `|a − b|` per lane.
    #[inline(always)]
    pub fn abs_diff(self, b: Self) -> Self {
        self.subs(b).or(b.subs(self))
    }

    /// All ones in the lanes where `a < b` (unsigned), zero elsewhere: `max(a, b) ≠ a`.
    #[inline(always)]
    pub fn less(self, b: Self) -> Self {
        // SAFETY: a `U16x16` is only made by an `Avx2` token: the CPU runs AVX2.
        Self(unsafe {
            _mm256_xor_si256(_mm256_cmpeq_epi16(_mm256_max_epu16(self.0, b.0), self.0), _mm256_set1_epi16(-1))
        })
    }

    /// `a` in the lanes where `self` (a mask of all-ones or zero lanes) is set, `b` elsewhere.
    #[inline(always)]
    pub fn select(self, a: Self, b: Self) -> Self {
        // SAFETY: a `U16x16` is only made by an `Avx2` token: the CPU runs AVX2.
        Self(unsafe { _mm256_blendv_epi8(b.0, a.0, self.0) })
    }

    /// The smallest lane.
    #[inline(always)]
    pub fn horizontal_min(self) -> u16 {
        let v = self.0;
        // SAFETY: a `U16x16` is only made by an `Avx2` token: the CPU runs AVX2 (and SSE4.1).
        unsafe {
            let m = _mm_min_epu16(_mm256_castsi256_si128(v), _mm256_extracti128_si256::<1>(v));
            (_mm_cvtsi128_si32(_mm_minpos_epu16(m)) & 0xffff) as u16
        }
    }

    /// Lanes moved up by one: lane `k` of the result is lane `k − 1` of `self`, lane 0 the last
    /// lane of `before`.
    #[inline(always)]
    pub fn up(self, before: Self) -> Self {
        let (v, b) = (self.0, before.0);
        // [before.hi, v.lo], then per 128-bit half the last 2 bytes of the first operand's half
        // and the first 14 of the second's
        // SAFETY: a `U16x16` is only made by an `Avx2` token: the CPU runs AVX2.
        Self(unsafe { _mm256_alignr_epi8::<14>(v, _mm256_permute2x128_si256::<0x21>(b, v)) })
    }

    /// Lanes moved down by one: lane `k` of the result is lane `k + 1` of `self`, the last lane
    /// lane 0 of `after`.
    #[inline(always)]
    pub fn down(self, after: Self) -> Self {
        let (v, a) = (self.0, after.0);
        // SAFETY: a `U16x16` is only made by an `Avx2` token: the CPU runs AVX2.
        Self(unsafe { _mm256_alignr_epi8::<2>(_mm256_permute2x128_si256::<0x21>(v, a), v) })
    }
}

/// Eight `u32` lanes in a 256-bit register, made only by an [`Avx2`] token as [`U16x16`].
#[derive(Clone, Copy)]
#[repr(transparent)]
pub struct U32x8(__m256i);

impl std::fmt::Debug for U32x8 {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let mut lanes = [0u32; 8];
        // SAFETY: 8 writable lanes; a `U32x8` exists only where AVX2 does.
        unsafe { _mm256_storeu_si256(lanes.as_mut_ptr().cast(), self.0) };
        f.debug_tuple("U32x8").field(&lanes).finish()
    }
}

/// The same 256 bits as eight 32-bit lanes.
impl From<U16x16> for U32x8 {
    #[inline(always)]
    fn from(v: U16x16) -> Self {
        U32x8(v.0)
    }
}

/// The same 256 bits as sixteen 16-bit lanes.
impl From<U32x8> for U16x16 {
    #[inline(always)]
    fn from(v: U32x8) -> Self {
        U16x16(v.0)
    }
}

/// The lane operations a kernel written once for both lane widths uses ([`U16x16`], [`U32x8`]).
/// Values exist only through an [`Avx2`] token, so everything but raw loads and stores is safe.
pub trait Lanes: Copy + Send + Sync + 'static {
    /// The lane type.
    type Elem: Copy;
    /// Lanes per vector.
    const LANES: usize;
    /// `x` in every lane.
    fn splat(t: Avx2, x: Self::Elem) -> Self;
    /// `x` clamped to `[−1, the largest signed lane]`, in every lane (a range bound for
    /// [`Lanes::greater_signed`]).
    fn splat_bound(t: Avx2, x: i64) -> Self;
    /// The byte pair `ab` (`a | b << 8`) in every 16-bit half-lane (see [`Lanes::pair_difference`]).
    fn splat_pair(t: Avx2, ab: u16) -> Self;
    /// The lane indices `0, 1, …, LANES − 1`.
    fn ramp(t: Avx2) -> Self;
    /// Loads `LANES` lanes from `p`.
    ///
    /// # Safety
    /// `p` must point to `LANES` readable lanes (no alignment needed).
    unsafe fn load_ptr(t: Avx2, p: *const Self::Elem) -> Self;
    /// `LANES` 16-bit values from `p`, widened to the lane type.
    ///
    /// # Safety
    /// `p` must point to `LANES` readable `u16` (no alignment needed).
    unsafe fn load_u16_ptr(t: Avx2, p: *const u16) -> Self;
    /// Stores the lanes at `p`.
    ///
    /// # Safety
    /// `p` must point to `LANES` writable lanes (no alignment needed).
    unsafe fn store_ptr(self, p: *mut Self::Elem);
    /// `|a − r_a| − |b − r_b|` per lane from the byte pair `(a, b)` of [`Lanes::splat_pair`] and
    /// the `LANES` byte pairs `(r_a, r_b)` at `p`, every byte below 128 (exact: see
    /// [`Avx2::pair_difference`]).
    ///
    /// # Safety
    /// `p` must point to `2 · LANES` readable bytes.
    unsafe fn pair_difference(ab: Self, p: *const u8) -> Self;
    /// Wrapping `a + b`.
    fn wrapping_add(self, b: Self) -> Self;
    /// Wrapping `a − b`.
    fn wrapping_sub(self, b: Self) -> Self;
    /// Bitwise or.
    fn or(self, b: Self) -> Self;
    /// Bitwise `!a & b`.
    fn and_not(self, b: Self) -> Self;
    /// Unsigned minimum.
    fn min(self, b: Self) -> Self;
    /// All ones in the lanes where `a = b`, zero elsewhere.
    fn eq(self, b: Self) -> Self;
    /// All ones in the lanes where `a > b` as signed integers, zero elsewhere.
    fn greater_signed(self, b: Self) -> Self;
    /// `|a − b|` for lanes below half the lane range (the wrapping difference's signed absolute
    /// value).
    fn abs_diff_small(self, b: Self) -> Self;
    /// `a` in the lanes where `self` (a mask of all-ones or zero lanes) is set, `b` elsewhere.
    fn select(self, a: Self, b: Self) -> Self;
    /// Lanes moved up by one: lane `k` is lane `k − 1` of `self`, lane 0 the last of `before`.
    fn up(self, before: Self) -> Self;
    /// The last lane.
    fn last(self) -> Self::Elem;
    /// The smallest lane.
    fn horizontal_min(self) -> Self::Elem;
    /// `self` unchanged, but opaque to the optimiser (no instruction runs): keeps it from
    /// rewriting an operation into another whose result it knows equal.
    fn opaque(self) -> Self;
}

/// An empty `asm!` that takes `v`'s register and gives it back.
#[inline]
#[target_feature(enable = "avx")]
fn opaque_ymm(mut v: __m256i) -> __m256i {
    // SAFETY: the template is a comment: nothing executes, and only `v`'s register is named
    // (read and written back unchanged).
    unsafe { std::arch::asm!("/* {0} */", inout(ymm_reg) v, options(pure, nomem, nostack, preserves_flags)) };
    v
}

/// The operations of [`Lanes`] that are one intrinsic on the whole register.
macro_rules! common_lanes {
    ($add:ident, $sub:ident, $min:ident, $eq:ident, $gt:ident, $abs:ident) => {
        #[inline(always)]
        fn wrapping_add(self, b: Self) -> Self {
            // SAFETY: the lanes exist only where AVX2 does (made by an `Avx2` token).
            Self(unsafe { $add(self.0, b.0) })
        }
        #[inline(always)]
        fn wrapping_sub(self, b: Self) -> Self {
            // SAFETY: as `wrapping_add`.
            Self(unsafe { $sub(self.0, b.0) })
        }
        #[inline(always)]
        fn or(self, b: Self) -> Self {
            // SAFETY: as `wrapping_add`.
            Self(unsafe { _mm256_or_si256(self.0, b.0) })
        }
        #[inline(always)]
        fn and_not(self, b: Self) -> Self {
            // SAFETY: as `wrapping_add`.
            Self(unsafe { _mm256_andnot_si256(self.0, b.0) })
        }
        #[inline(always)]
        fn min(self, b: Self) -> Self {
            // SAFETY: as `wrapping_add`.
            Self(unsafe { $min(self.0, b.0) })
        }
        #[inline(always)]
        fn eq(self, b: Self) -> Self {
            // SAFETY: as `wrapping_add`.
            Self(unsafe { $eq(self.0, b.0) })
        }
        #[inline(always)]
        fn greater_signed(self, b: Self) -> Self {
            // SAFETY: as `wrapping_add`.
            Self(unsafe { $gt(self.0, b.0) })
        }
        #[inline(always)]
        fn abs_diff_small(self, b: Self) -> Self {
            // SAFETY: as `wrapping_add`.
            Self(unsafe { $abs($sub(self.0, b.0)) })
        }
        #[inline(always)]
        fn select(self, a: Self, b: Self) -> Self {
            // SAFETY: as `wrapping_add`.
            Self(unsafe { _mm256_blendv_epi8(b.0, a.0, self.0) })
        }
        #[inline(always)]
        fn splat_pair(_t: Avx2, ab: u16) -> Self {
            // SAFETY: the token proves AVX2.
            Self(unsafe { _mm256_set1_epi16(ab as i16) })
        }
        /// # Safety
        /// As [`Lanes::load_ptr`].
        #[inline(always)]
        unsafe fn load_ptr(_t: Avx2, p: *const Self::Elem) -> Self {
            // SAFETY: the caller vouches for the memory, the token for AVX2.
            Self(unsafe { _mm256_loadu_si256(p.cast()) })
        }
        /// # Safety
        /// As [`Lanes::store_ptr`].
        #[inline(always)]
        unsafe fn store_ptr(self, p: *mut Self::Elem) {
            // SAFETY: the caller vouches for the memory; the lanes exist only where AVX2 does.
            unsafe { _mm256_storeu_si256(p.cast(), self.0) }
        }
        #[inline(always)]
        fn opaque(self) -> Self {
            // SAFETY: the lanes exist only where AVX2 (and so AVX) does.
            Self(unsafe { opaque_ymm(self.0) })
        }
    };
}

impl Lanes for U16x16 {
    type Elem = u16;
    const LANES: usize = 16;
    common_lanes!(
        _mm256_add_epi16,
        _mm256_sub_epi16,
        _mm256_min_epu16,
        _mm256_cmpeq_epi16,
        _mm256_cmpgt_epi16,
        _mm256_abs_epi16
    );

    #[inline(always)]
    fn splat(t: Avx2, x: u16) -> Self {
        t.splat(x)
    }
    #[inline(always)]
    fn splat_bound(t: Avx2, x: i64) -> Self {
        t.splat(x.clamp(-1, i16::MAX as i64) as i16 as u16)
    }
    #[inline(always)]
    fn ramp(_t: Avx2) -> Self {
        // SAFETY: the token proves AVX2.
        Self(unsafe { _mm256_setr_epi16(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15) })
    }
    /// # Safety
    /// As [`Lanes::load_u16_ptr`].
    #[inline(always)]
    unsafe fn load_u16_ptr(t: Avx2, p: *const u16) -> Self {
        // SAFETY: the caller's.
        unsafe { t.load_ptr(p) }
    }
    /// # Safety
    /// As [`Lanes::pair_difference`].
    #[inline(always)]
    unsafe fn pair_difference(ab: Self, p: *const u8) -> Self {
        // SAFETY: the caller's; the lanes exist only where AVX2 does.
        unsafe { Avx2 { _proof: () }.pair_difference(ab, p) }
    }
    #[inline(always)]
    fn up(self, before: Self) -> Self {
        U16x16::up(self, before)
    }
    #[inline(always)]
    fn last(self) -> u16 {
        // SAFETY: the lanes exist only where AVX2 does.
        unsafe { _mm256_extract_epi16::<15>(self.0) as u16 }
    }
    #[inline(always)]
    fn horizontal_min(self) -> u16 {
        U16x16::horizontal_min(self)
    }
}

impl U16x16 {
    /// The lanes paired with `high`'s as 32-bit lanes `self[k] | high[k] << 16`: lanes 0–3 and
    /// 8–11 in the first vector, 4–7 and 12–15 in the second (AVX2's unpacks work per 128-bit
    /// half).
    #[inline(always)]
    pub fn zip(self, high: Self) -> (U32x8, U32x8) {
        // SAFETY: the lanes exist only where AVX2 does.
        unsafe { (U32x8(_mm256_unpacklo_epi16(self.0, high.0)), U32x8(_mm256_unpackhi_epi16(self.0, high.0))) }
    }
}

impl Lanes for U32x8 {
    type Elem = u32;
    const LANES: usize = 8;
    common_lanes!(
        _mm256_add_epi32,
        _mm256_sub_epi32,
        _mm256_min_epu32,
        _mm256_cmpeq_epi32,
        _mm256_cmpgt_epi32,
        _mm256_abs_epi32
    );

    #[inline(always)]
    fn splat(_t: Avx2, x: u32) -> Self {
        // SAFETY: the token proves AVX2.
        Self(unsafe { _mm256_set1_epi32(x as i32) })
    }
    #[inline(always)]
    fn splat_bound(t: Avx2, x: i64) -> Self {
        Self::splat(t, x.clamp(-1, i32::MAX as i64) as i32 as u32)
    }
    #[inline(always)]
    fn ramp(_t: Avx2) -> Self {
        // SAFETY: the token proves AVX2.
        Self(unsafe { _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7) })
    }
    /// # Safety
    /// As [`Lanes::load_u16_ptr`].
    #[inline(always)]
    unsafe fn load_u16_ptr(_t: Avx2, p: *const u16) -> Self {
        // SAFETY: the caller vouches for 8 readable `u16`, the token for AVX2.
        Self(unsafe { _mm256_cvtepu16_epi32(_mm_loadu_si128(p.cast())) })
    }
    /// # Safety
    /// As [`Lanes::pair_difference`].
    #[inline(always)]
    unsafe fn pair_difference(ab: Self, p: *const u8) -> Self {
        // SAFETY: the caller vouches for 16 readable bytes; the lanes exist only where AVX2 does.
        unsafe {
            let r = _mm_loadu_si128(p.cast());
            let d = _mm_abs_epi8(_mm_sub_epi8(_mm256_castsi256_si128(ab.0), r));
            Self(_mm256_cvtepi16_epi32(_mm_maddubs_epi16(d, _mm_set1_epi16(0xff01u16 as i16))))
        }
    }
    #[inline(always)]
    fn up(self, before: Self) -> Self {
        // SAFETY: the lanes exist only where AVX2 does.
        Self(unsafe { _mm256_alignr_epi8::<12>(self.0, _mm256_permute2x128_si256::<0x21>(before.0, self.0)) })
    }
    #[inline(always)]
    fn last(self) -> u32 {
        // SAFETY: the lanes exist only where AVX2 does.
        unsafe { _mm256_extract_epi32::<7>(self.0) as u32 }
    }
    #[inline(always)]
    fn horizontal_min(self) -> u32 {
        // SAFETY: the lanes exist only where AVX2 does.
        unsafe {
            let k = _mm_min_epu32(_mm256_castsi256_si128(self.0), _mm256_extracti128_si256::<1>(self.0));
            let k = _mm_min_epu32(k, _mm_shuffle_epi32::<0b01_00_11_10>(k));
            let k = _mm_min_epu32(k, _mm_shuffle_epi32::<0b10_11_00_01>(k));
            _mm_cvtsi128_si32(k) as u32
        }
    }
}

impl U32x8 {
    /// The smallest lane in every lane.
    #[inline(always)]
    pub fn min_everywhere(self) -> Self {
        let v = self.0;
        // SAFETY: the lanes exist only where AVX2 does.
        unsafe {
            let v = _mm256_min_epu32(v, _mm256_permute2x128_si256::<0x01>(v, v));
            let v = _mm256_min_epu32(v, _mm256_shuffle_epi32::<0b01_00_11_10>(v));
            Self(_mm256_min_epu32(v, _mm256_shuffle_epi32::<0b10_11_00_01>(v)))
        }
    }

    /// The first lane.
    #[inline(always)]
    pub fn first(self) -> u32 {
        // SAFETY: the lanes exist only where AVX2 does.
        unsafe { _mm256_extract_epi32::<0>(self.0) as u32 }
    }

    /// The low 32 bits of `a · b` per lane.
    #[inline(always)]
    pub fn wrapping_mul(self, b: Self) -> Self {
        // SAFETY: the lanes exist only where AVX2 does.
        Self(unsafe { _mm256_mullo_epi32(self.0, b.0) })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lanes(t: Avx2, v: U16x16) -> [u16; 16] {
        let mut o = [0u16; 16];
        t.store(&mut o, v);
        o
    }

    /// Every operation against the same operation on plain `u16`s, on values that reach the
    /// wrap-around and saturation edges.
    #[test]
    fn lanes_equal_their_scalar_definition() {
        let Some(t) = Avx2::new() else {
            println!("skipped: this CPU has no AVX2 (levels {:?})", crate::SimdLevel::available());
            return;
        };
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            let v = seed as u16;
            // a third of the lanes at the edges
            match seed >> 60 {
                0..=1 => 0,
                2..=3 => u16::MAX,
                4 => 1,
                _ => v,
            }
        };
        for _ in 0..2000 {
            let a: [u16; 16] = std::array::from_fn(|_| next());
            let b: [u16; 16] = std::array::from_fn(|_| next());
            let (va, vb) = (t.load(&a), t.load(&b));
            let each = |f: &dyn Fn(u16, u16) -> u16| -> [u16; 16] { std::array::from_fn(|k| f(a[k], b[k])) };
            let mask = |c: bool| if c { u16::MAX } else { 0 };
            assert_eq!(lanes(t, va.wrapping_add(vb)), each(&|x, y| x.wrapping_add(y)));
            assert_eq!(lanes(t, va.wrapping_sub(vb)), each(&|x, y| x.wrapping_sub(y)));
            assert_eq!(lanes(t, va.adds(vb)), each(&|x, y| x.saturating_add(y)));
            assert_eq!(lanes(t, va.subs(vb)), each(&|x, y| x.saturating_sub(y)));
            assert_eq!(lanes(t, va.min(vb)), each(&|x, y| x.min(y)));
            assert_eq!(lanes(t, va.max(vb)), each(&|x, y| x.max(y)));
            assert_eq!(lanes(t, va.eq(vb)), each(&|x, y| mask(x == y)));
            assert_eq!(lanes(t, va.or(vb)), each(&|x, y| x | y));
            assert_eq!(lanes(t, va.abs_diff(vb)), each(&|x, y| x.abs_diff(y)));
            assert_eq!(lanes(t, va.less(vb)), each(&|x, y| mask(x < y)));
            let m = va.less(vb);
            assert_eq!(lanes(t, m.select(va, vb)), each(&|x, y| if x < y { x } else { y }));
            assert_eq!(va.horizontal_min(), *a.iter().min().unwrap());
            let up: [u16; 16] = std::array::from_fn(|k| if k == 0 { b[15] } else { a[k - 1] });
            assert_eq!(lanes(t, va.up(vb)), up);
            let down: [u16; 16] = std::array::from_fn(|k| if k == 15 { b[0] } else { a[k + 1] });
            assert_eq!(lanes(t, va.down(vb)), down);
            assert_eq!(lanes(t, t.splat(a[3])), [a[3]; 16]);
            // byte pairs below 128
            let ab: [u16; 16] = std::array::from_fn(|k| a[k] & 0x7f7f);
            let r: [u8; 32] = std::array::from_fn(|i| (b[i / 2] >> (8 * (i % 2))) as u8 & 0x7f);
            // SAFETY: 32 readable bytes.
            let d = unsafe { t.pair_difference(t.load(&ab), r.as_ptr()) };
            let want: [u16; 16] = std::array::from_fn(|k| {
                let (x, y) = ((ab[k] & 0xff) as i32, (ab[k] >> 8) as i32);
                ((x - r[2 * k] as i32).abs() - (y - r[2 * k + 1] as i32).abs()) as u16
            });
            assert_eq!(lanes(t, d), want);
            // Birchfield–Tomasi byte pairs over the whole byte range, each interval holding its
            // value (as the matcher's: `lo ≤ v ≤ hi`)
            let [c, d2, e2, f2]: [[u16; 16]; 4] = std::array::from_fn(|_| std::array::from_fn(|_| next()));
            let byte = |v: u16, i: usize| (v >> (8 * (i % 2))) as u8;
            let pair = |lo: u8, hi: u8| lo as u16 | (hi as u16) << 8;
            let around = |v: &[u16; 16], x: &[u16; 16], f: fn(u8, u8) -> u8| -> [u16; 16] {
                std::array::from_fn(|k| pair(f(byte(v[k], 0), byte(x[k], 0)), f(byte(v[k], 1), byte(x[k], 1))))
            };
            // every byte, then with a second term every byte of both below 128
            for (mask, extra) in [(0xffu8, false), (0x7f, true)] {
                let m = u16::from_le_bytes([mask, mask]);
                let u = a.map(|v| v & m);
                let (u0x, u1x) = (around(&u, &b.map(|v| v & m), u8::min), around(&u, &c.map(|v| v & m), u8::max));
                let rv: [u8; 32] = std::array::from_fn(|i| byte(d2[i / 2], i) & mask);
                let r0: [u8; 32] = std::array::from_fn(|i| rv[i].min(byte(e2[i / 2], i) & mask));
                let r1: [u8; 32] = std::array::from_fn(|i| rv[i].max(byte(f2[i / 2], i) & mask));
                let e: [u16; 16] = std::array::from_fn(|k| (a[k] ^ f2[k]) & m);
                let pe: [u8; 32] = std::array::from_fn(|i| byte(e2[i / 2], i) & mask);
                // SAFETY: 3 · 32 readable bytes (4 · 32 with the second term).
                let got = unsafe {
                    let (u, u0, u1) = (t.load(&u), t.load(&u0x), t.load(&u1x));
                    let second = extra.then(|| (t.load(&e), pe.as_ptr()));
                    t.pair_bt_difference(u, u0, u1, rv.as_ptr(), r0.as_ptr(), r1.as_ptr(), second)
                };
                let bt = |k: usize, h: usize| -> i32 {
                    let i = 2 * k + h;
                    let (uu, uu0, uu1) = (byte(u[k], h) as i32, byte(u0x[k], h) as i32, byte(u1x[k], h) as i32);
                    let (vv, vv0, vv1) = (rv[i] as i32, r0[i] as i32, r1[i] as i32);
                    let dist = |x: i32, lo: i32, hi: i32| (x - hi).max(lo - x).max(0);
                    let second = if extra { (byte(e[k], h) as i32 - pe[i] as i32).abs() } else { 0 };
                    dist(uu, vv0, vv1).min(dist(vv, uu0, uu1)) + second
                };
                let want: [u16; 16] = std::array::from_fn(|k| (bt(k, 0) - bt(k, 1)) as u16);
                assert_eq!(lanes(t, got), want, "byte mask {mask:#x}");
            }
        }
    }

    /// Every operation of [`Lanes`] at both widths against its definition on plain integers,
    /// on values that reach the edges (raw loads and stores through arrays of the lane count).
    fn lanes_trait_matches<V: Lanes>(t: Avx2, next: &mut dyn FnMut() -> u64)
    where
        V::Elem: Copy + Default + PartialEq + std::fmt::Debug + TryFrom<u64> + Into<u64>,
    {
        let n = V::LANES;
        let bits = 8 * std::mem::size_of::<V::Elem>() as u32;
        let max = (1u64 << bits) - 1;
        let el = |v: u64| -> V::Elem { V::Elem::try_from(v & max).ok().unwrap() };
        let load = |a: &[u64]| -> V {
            let e: Vec<V::Elem> = a.iter().map(|&v| el(v)).collect();
            // SAFETY: `n` readable lanes.
            unsafe { V::load_ptr(t, e.as_ptr()) }
        };
        let lanes = |v: V| -> Vec<u64> {
            let mut e = vec![V::Elem::default(); n];
            // SAFETY: `n` writable lanes.
            unsafe { v.store_ptr(e.as_mut_ptr()) };
            e.into_iter().map(Into::into).collect()
        };
        let signed = |v: u64| -> i64 { if v >> (bits - 1) == 1 { v as i64 - (1i64 << bits) } else { v as i64 } };
        let mask = |c: bool| if c { max } else { 0 };
        for _ in 0..500 {
            let a: Vec<u64> = (0..n).map(|_| next() & max).collect();
            let b: Vec<u64> = (0..n).map(|_| next() & max).collect();
            let m: Vec<u64> = (0..n).map(|_| mask(next() & 1 == 1)).collect();
            let (va, vb, vm) = (load(&a), load(&b), load(&m));
            let each =
                |f: &dyn Fn(u64, u64) -> u64| -> Vec<u64> { a.iter().zip(&b).map(|(&x, &y)| f(x, y) & max).collect() };
            assert_eq!(lanes(va.wrapping_add(vb)), each(&|x, y| x + y));
            assert_eq!(lanes(va.wrapping_sub(vb)), each(&|x, y| x.wrapping_sub(y)));
            assert_eq!(lanes(va.or(vb)), each(&|x, y| x | y));
            assert_eq!(lanes(va.and_not(vb)), each(&|x, y| !x & y));
            assert_eq!(lanes(va.min(vb)), each(&|x, y| x.min(y)));
            assert_eq!(lanes(va.eq(vb)), each(&|x, y| mask(x == y)));
            assert_eq!(lanes(va.greater_signed(vb)), each(&|x, y| mask(signed(x) > signed(y))));
            // below half the range
            let (ha, hb) = (
                load(&a.iter().map(|v| v >> 1).collect::<Vec<_>>()),
                load(&b.iter().map(|v| v >> 1).collect::<Vec<_>>()),
            );
            let half: Vec<u64> = a.iter().zip(&b).map(|(&x, &y)| (x >> 1).abs_diff(y >> 1)).collect();
            assert_eq!(lanes(ha.abs_diff_small(hb)), half);
            let sel: Vec<u64> = (0..n).map(|k| if m[k] != 0 { a[k] } else { b[k] }).collect();
            assert_eq!(lanes(vm.select(va, vb)), sel);
            let up: Vec<u64> = (0..n).map(|k| if k == 0 { b[n - 1] } else { a[k - 1] }).collect();
            assert_eq!(lanes(va.up(vb)), up);
            assert_eq!(va.last().into(), a[n - 1]);
            assert_eq!(va.horizontal_min().into(), *a.iter().min().unwrap());
            assert_eq!(lanes(va.opaque()), a);
            assert_eq!(lanes(V::splat(t, el(a[0]))), vec![a[0]; n]);
            assert_eq!(lanes(V::ramp(t)), (0..n as u64).collect::<Vec<_>>());
            let bound = signed(a[1]) >> 1;
            assert_eq!(lanes(V::splat_bound(t, bound)), vec![(bound.max(-1) as u64) & max; n]);
            assert_eq!(lanes(V::splat_bound(t, i64::MAX)), vec![max >> 1; n]);
            assert_eq!(lanes(V::splat_bound(t, -5)), vec![max; n]);
            // 16-bit values widened
            let px: Vec<u16> = (0..n).map(|_| next() as u16).collect();
            // SAFETY: `n` readable `u16`.
            let w = unsafe { V::load_u16_ptr(t, px.as_ptr()) };
            assert_eq!(lanes(w), px.iter().map(|&p| p as u64 & max).collect::<Vec<_>>());
            // byte pairs below 128: |a − r_a| − |b − r_b| per lane, wrapping
            let ab = (next() as u16) & 0x7f7f;
            let r: Vec<u8> = (0..2 * n).map(|_| next() as u8 & 0x7f).collect();
            // SAFETY: 2n readable bytes.
            let d = unsafe { V::pair_difference(V::splat_pair(t, ab), r.as_ptr()) };
            let (x, y) = ((ab & 0xff) as i64, (ab >> 8) as i64);
            let want: Vec<u64> =
                (0..n).map(|k| ((x - r[2 * k] as i64).abs() - (y - r[2 * k + 1] as i64).abs()) as u64 & max).collect();
            assert_eq!(lanes(d), want);
        }
    }

    #[test]
    fn lanes_trait_equals_its_scalar_definition_at_both_widths() {
        let Some(t) = Avx2::new() else {
            println!("skipped: this CPU has no AVX2 (levels {:?})", crate::SimdLevel::available());
            return;
        };
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            match seed >> 60 {
                0..=1 => 0,
                2..=3 => u64::MAX,
                4 => 1,
                5 => 1 << 15,
                _ => seed,
            }
        };
        lanes_trait_matches::<U16x16>(t, &mut next);
        lanes_trait_matches::<U32x8>(t, &mut next);
        // the 16-bit lanes as keys of 32-bit lanes
        let (a, b): ([u16; 16], [u16; 16]) =
            (std::array::from_fn(|k| k as u16 * 3), std::array::from_fn(|k| 100 + k as u16));
        let (lo, hi) = t.load(&a).zip(t.load(&b));
        let (mut l, mut h) = ([0u32; 8], [0u32; 8]);
        // SAFETY: 8 writable lanes each.
        unsafe { (lo.store_ptr(l.as_mut_ptr()), hi.store_ptr(h.as_mut_ptr())) };
        let key = |k: usize| a[k] as u32 | (b[k] as u32) << 16;
        assert_eq!(l, [0, 1, 2, 3, 8, 9, 10, 11].map(key));
        assert_eq!(h, [4, 5, 6, 7, 12, 13, 14, 15].map(key));
        let v = U32x8::ramp(t).wrapping_add(U32x8::splat(t, 70_000));
        let squares = (0..8u32).map(|k| (70_000 + k).wrapping_mul(70_000 + k));
        assert_eq!(v.wrapping_mul(v).min_everywhere().first(), squares.min().unwrap());
        assert_eq!(v.first(), 70_000);
        // the same bits seen at the other width
        assert_eq!(U16x16::from(U32x8::splat(t, 0x0002_0001)).horizontal_min(), 1);
    }

    /// Loads and stores move exactly 16 lanes and check their slices.
    #[test]
    fn loads_and_stores_move_sixteen_lanes() {
        let Some(t) = Avx2::new() else {
            println!("skipped: this CPU has no AVX2");
            return;
        };
        let src: [u16; 20] = std::array::from_fn(|i| i as u16);
        let mut dst = [7u16; 20];
        t.store(&mut dst[2..], t.load(&src[1..]));
        assert_eq!(&dst[..2], &[7, 7]);
        assert_eq!(&dst[2..18], &src[1..17]);
        assert_eq!(&dst[18..], &[7, 7]);
        assert!(std::panic::catch_unwind(|| t.load(&src[5..])).is_err(), "15 lanes are refused");
        assert_eq!(format!("{:?}", t.splat(3)), format!("U16x16({:?})", [3u16; 16]));
    }
}
