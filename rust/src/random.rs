//! Deterministic pseudo-random numbers for tests and examples: a 64-bit linear
//! congruential generator (Knuth's MMIX constants), the same sequence on every
//! machine.

/// The generator's state; `Lcg(seed)` starts a sequence.
pub struct Lcg(pub u64);

impl Lcg {
    /// The next value, uniform in [−1, 1) (53 bits).
    pub fn uniform(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }
}
