//! Helpers of the naive-reference tests (`fast_vs_naive.rs`, `sgm_vs_naive.rs`).

/// `v` clamped to `0..hi` (clamp-to-edge indexing).
pub fn clampi(v: i64, hi: usize) -> usize {
    v.clamp(0, hi as i64 - 1) as usize
}

/// A xorshift64 generator, its state the seed after one LCG step.
pub fn rng(seed: u64) -> impl FnMut() -> u64 {
    let mut s = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
    move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        s
    }
}
