//! Timing statistics of a serve run in fixed memory: a server may run for
//! days, and its step loop must not allocate after warm-up.

/// Buckets per decade: neighbouring bucket bounds differ by 10^(1/200),
/// 1.16 %, the error of a quantile read back.
const PER_DECADE: f64 = 200.0;
/// The lowest bound (us); smaller times fall into the first bucket.
const LOW_US: f64 = 1e-2;
/// Nine decades: 0.01 us to 10 s; larger times fall into the last bucket.
const BUCKETS: usize = 9 * PER_DECADE as usize;

/// Durations in microseconds, counted in log-spaced buckets.
#[derive(Debug, Clone)]
pub struct Histogram {
    counts: Box<[u64]>,
    n: u64,
    sum: f64,
}

impl Default for Histogram {
    fn default() -> Histogram {
        Histogram {
            counts: vec![0; BUCKETS].into_boxed_slice(),
            n: 0,
            sum: 0.0,
        }
    }
}

impl Histogram {
    pub fn add(&mut self, us: f64) {
        let i = ((us / LOW_US).log10() * PER_DECADE).floor();
        // NaN and negative logs go to the first bucket (`as` saturates).
        let i = (i.max(0.0) as usize).min(BUCKETS - 1);
        self.counts[i] += 1;
        self.n += 1;
        self.sum += us;
    }

    pub fn len(&self) -> u64 {
        self.n
    }

    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    pub fn mean(&self) -> Option<f64> {
        (self.n > 0).then(|| self.sum / self.n as f64)
    }

    /// The `p` quantile (the sample of rank round((n - 1) p)), as the
    /// geometric centre of its bucket.
    pub fn quantile(&self, p: f64) -> Option<f64> {
        if self.n == 0 {
            return None;
        }
        let rank = ((self.n - 1) as f64 * p.clamp(0.0, 1.0)).round() as u64;
        let mut seen = 0;
        for (i, &c) in self.counts.iter().enumerate() {
            seen += c;
            if seen > rank {
                return Some(LOW_US * 10f64.powf((i as f64 + 0.5) / PER_DECADE));
            }
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_come_back_within_the_bucket_width() {
        let mut h = Histogram::default();
        // 1..=1000 us: median 500 (rank 499.5 rounds to 500: the value 501),
        // p99 at rank 989: the value 990.
        for k in 1..=1000 {
            h.add(k as f64);
        }
        let close = |a: f64, b: f64| (a / b - 1.0).abs() < 0.012;
        assert!(
            close(h.quantile(0.5).unwrap(), 501.0),
            "{:?}",
            h.quantile(0.5)
        );
        assert!(
            close(h.quantile(0.99).unwrap(), 990.0),
            "{:?}",
            h.quantile(0.99)
        );
        assert_eq!(h.mean(), Some(500.5));
        assert_eq!(h.len(), 1000);
    }

    #[test]
    fn out_of_range_and_empty() {
        let mut h = Histogram::default();
        assert_eq!(h.quantile(0.5), None);
        assert_eq!(h.mean(), None);
        h.add(0.0);
        h.add(f64::NAN);
        h.add(1e12);
        assert!(h.quantile(0.0).unwrap() < 2e-2);
        assert!(h.quantile(1.0).unwrap() > 9e6);
    }
}
