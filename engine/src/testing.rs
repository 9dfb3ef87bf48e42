//! Helpers of the engine's unit tests.

/// A small deterministic generator (xorshift64) for test inputs.
pub struct Xorshift(u64);

impl Xorshift {
    /// From `seed` (made odd: zero is the generator's fixed point).
    pub fn new(seed: u64) -> Xorshift {
        Xorshift(seed | 1)
    }

    pub fn next_u64(&mut self) -> u64 {
        let s = &mut self.0;
        *s ^= *s << 13;
        *s ^= *s >> 7;
        *s ^= *s << 17;
        *s
    }

    /// Uniform in [0, 1).
    pub fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
}
