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
        }
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
