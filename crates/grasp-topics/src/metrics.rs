//! Clustering agreement and convergence diagnostics.

use std::collections::HashMap;

/// Adjusted Rand index (Hubert & Arabie 1985) between two labelings of the same items: 1 for
/// identical partitions (up to relabelling), about 0 for independent ones. Labels are arbitrary
/// integers. Returns 1 when both partitions are trivial in the same way.
pub fn adjusted_rand_index(a: &[usize], b: &[usize]) -> f64 {
    let n = a.len().min(b.len());
    if n < 2 {
        return 1.0;
    }
    let mut table: HashMap<(usize, usize), u64> = HashMap::new();
    let mut ra: HashMap<usize, u64> = HashMap::new();
    let mut rb: HashMap<usize, u64> = HashMap::new();
    for i in 0..n {
        *table.entry((a[i], b[i])).or_default() += 1;
        *ra.entry(a[i]).or_default() += 1;
        *rb.entry(b[i]).or_default() += 1;
    }
    let c2 = |x: u64| (x * x.saturating_sub(1)) as f64 / 2.0;
    let index: f64 = table.values().map(|&v| c2(v)).sum();
    let sa: f64 = ra.values().map(|&v| c2(v)).sum();
    let sb: f64 = rb.values().map(|&v| c2(v)).sum();
    let expected = sa * sb / c2(n as u64);
    let max = 0.5 * (sa + sb);
    if (max - expected).abs() < 1e-12 {
        return 1.0;
    }
    (index - expected) / (max - expected)
}

/// Gelman–Rubin potential scale reduction R̂ of a scalar over several chains (each a trace of
/// equal length ≥ 2). Values near 1 mean the chains agree; > 1.1 suggests more burn-in. `None` with
/// fewer than two chains or too short traces.
pub fn gelman_rubin(chains: &[Vec<f64>]) -> Option<f64> {
    let m = chains.len();
    let n = chains.iter().map(|c| c.len()).min()?;
    if m < 2 || n < 2 {
        return None;
    }
    let means: Vec<f64> = chains.iter().map(|c| c[..n].iter().sum::<f64>() / n as f64).collect();
    let grand = means.iter().sum::<f64>() / m as f64;
    let b = n as f64 / (m as f64 - 1.0) * means.iter().map(|x| (x - grand).powi(2)).sum::<f64>();
    let w = chains
        .iter()
        .zip(&means)
        .map(|(c, mu)| c[..n].iter().map(|x| (x - mu).powi(2)).sum::<f64>() / (n as f64 - 1.0))
        .sum::<f64>()
        / m as f64;
    if w <= 0.0 {
        return Some(if b <= 0.0 { 1.0 } else { f64::INFINITY });
    }
    let var = (n as f64 - 1.0) / n as f64 * w + b / n as f64;
    Some((var / w).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ari_of_relabelled_partition_is_one() {
        let a = [0, 0, 1, 1, 2, 2];
        let b = [5, 5, 3, 3, 9, 9];
        assert!((adjusted_rand_index(&a, &b) - 1.0).abs() < 1e-12);
        let c = [0, 1, 0, 1, 0, 1];
        assert!(adjusted_rand_index(&a, &c) < 0.1);
    }
}
