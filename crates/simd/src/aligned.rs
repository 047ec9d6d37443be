//! Buffers that start on a cache line.

use std::ops::{Deref, DerefMut};

/// Bytes of a cache line on the CPUs parallax targets.
pub const CACHE_LINE: usize = 64;

/// A growable buffer of `T` whose first element sits on a [`CACHE_LINE`] boundary, however the
/// allocator placed it (a `Vec` over-allocated by one line, viewed from its first aligned
/// element: no `unsafe`). A kernel whose vector loads and stores fall at multiples of the vector
/// width from the start then never splits one across two lines; with a plain `Vec` that depended
/// on the allocator's history, and so did a frame's time (measured in the performance journal,
/// `benches/RESULTS.md`, 2026-12-06).
///
/// Derefs to the `len` elements as a slice.
#[derive(Debug, Clone)]
pub struct CacheAligned<T> {
    buf: Vec<T>,
    start: usize,
    len: usize,
}

impl<T> Default for CacheAligned<T> {
    fn default() -> Self {
        Self { buf: Vec::new(), start: 0, len: 0 }
    }
}

impl<T: Copy> CacheAligned<T> {
    /// `Vec::resize`'s semantics: the first `min(old, len)` elements kept, the rest `value`.
    /// A call with the current length does nothing.
    pub fn resize(&mut self, len: usize, value: T) {
        if len == self.len && !self.buf.is_empty() {
            return;
        }
        let pad = CACHE_LINE.div_ceil(size_of::<T>().max(1));
        let mut buf = vec![value; len + pad];
        let off = buf.as_ptr().align_offset(CACHE_LINE);
        // (a type whose size does not divide the line may have no aligned element: start at 0)
        let start = if off < pad { off } else { 0 };
        let keep = self.len.min(len);
        buf[start..start + keep].copy_from_slice(&self[..keep]);
        (self.buf, self.start, self.len) = (buf, start, len);
    }
}

impl<T> Deref for CacheAligned<T> {
    type Target = [T];
    fn deref(&self) -> &[T] {
        // (empty before the first `resize`)
        self.buf.get(self.start..self.start + self.len).unwrap_or(&[])
    }
}

impl<T> DerefMut for CacheAligned<T> {
    fn deref_mut(&mut self) -> &mut [T] {
        let (start, len) = (self.start, self.len);
        self.buf.get_mut(start..start + len).unwrap_or(&mut [])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The slice starts on a line for every element size that divides it, and resizing keeps
    /// `Vec::resize`'s contents.
    #[test]
    fn starts_on_a_line_and_resizes_as_a_vec() {
        fn check<T: Copy + PartialEq + std::fmt::Debug + From<u8>>() {
            let mut a = CacheAligned::<T>::default();
            let mut v: Vec<T> = Vec::new();
            assert!(a.is_empty());
            for (i, n) in [5usize, 17, 3, 3, 100, 0, 64, 33].into_iter().enumerate() {
                let x = T::from(i as u8 + 1);
                a.resize(n, x);
                v.resize(n, x);
                assert_eq!(&a[..], &v[..], "contents after resize({n})");
                assert_eq!(a.as_ptr() as usize % CACHE_LINE, 0, "aligned after resize({n})");
                a.iter_mut().enumerate().for_each(|(k, e)| *e = T::from(k as u8));
                v.iter_mut().enumerate().for_each(|(k, e)| *e = T::from(k as u8));
            }
        }
        check::<u16>();
        check::<u32>();
        check::<u64>();
        check::<f32>();
        check::<f64>();
    }
}
