//! Tests on 2×2 contingency tables of counts: Fisher's exact test (one-sided), the companion of
//! [`crate::chi2::chi2_contingency`] when counts are small.

use crate::special::ln_gamma;

/// One-sided Fisher exact test (H1: the first group succeeds more often) on successes `a` of `n`
/// against `c` of `n`: P(X ≥ a) under the hypergeometric law with the table's margins.
pub fn fisher_one_sided(a: usize, c: usize, n: usize) -> f64 {
    let (n1, n2) = (n, n);
    let k = a + c; // successes in all
    let total = n1 + n2;
    let ln_choose = |n: usize, k: usize| -> f64 {
        ln_gamma(n as f64 + 1.0) - ln_gamma(k as f64 + 1.0) - ln_gamma((n - k) as f64 + 1.0)
    };
    let denom = ln_choose(total, k);
    let hi = k.min(n1);
    let mut p = 0.0;
    for x in a..=hi {
        if k - x > n2 {
            continue;
        }
        p += (ln_choose(n1, x) + ln_choose(n2, k - x) - denom).exp();
    }
    p.min(1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fisher_matches_scipy() {
        // The seed's counts: scipy.stats.fisher_exact([[53, 19], [43, 29]], alternative="greater")
        // gives p = 0.055573 (exact hypergeometric sum).
        let p = fisher_one_sided(53, 43, 72);
        assert!((p - 0.055_573_479).abs() < 1e-7, "{p}");
        assert!((fisher_one_sided(6, 0, 6) - 0.0011).abs() < 1e-3);
        assert_eq!(fisher_one_sided(0, 0, 6), 1.0);
    }
}
