//! The exact sufficient statistics of the model (§5.2): per place the demonstrations, every
//! object's colour draws and the size sums, all integers, so any order of updates gives the same bits.

use bayes::dirichlet::CategoryCounts;
use bayes::univariate::GaussianStats;
use serde::{Deserialize, Serialize};

use super::features::{COLORS, INPUT, ObjectDraws};
use crate::error::SchemaError;

/// Exact sufficient statistics of the size observations, in integer quanta of the model's size unit
/// ([`SizeUnit::quanta_per_unit`](super::hyper::SizeUnit::quanta_per_unit): half-pixels, or tenths
/// of a millimetre), so any order of updates gives the same bits.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SizeStats {
    /// Number of observations.
    pub n: u64,
    /// Σ x (quanta; `sum_half_pixels` in model files of version 4).
    #[serde(alias = "sum_half_pixels")]
    pub sum: u64,
    /// Σ x² (quanta²; `sum_sq_half_pixels` in model files of version 4).
    #[serde(alias = "sum_sq_half_pixels")]
    pub sum_sq: u64,
}

impl SizeStats {
    pub(super) fn add(&mut self, x: u64) -> Result<(), SchemaError> {
        let overflow = || SchemaError::invalid(INPUT, "size", "size statistics overflow u64");
        let sq = x.checked_mul(x).ok_or_else(overflow)?;
        let new = SizeStats {
            n: self.n.checked_add(1).ok_or_else(overflow)?,
            sum: self.sum.checked_add(x).ok_or_else(overflow)?,
            sum_sq: self.sum_sq.checked_add(sq).ok_or_else(overflow)?,
        };
        *self = new;
        Ok(())
    }

    pub(super) fn merged(&self, o: &SizeStats) -> Result<SizeStats, SchemaError> {
        let overflow = || SchemaError::invalid(INPUT, "size", "size statistics overflow u64");
        Ok(SizeStats {
            n: self.n.checked_add(o.n).ok_or_else(overflow)?,
            sum: self.sum.checked_add(o.sum).ok_or_else(overflow)?,
            sum_sq: self.sum_sq.checked_add(o.sum_sq).ok_or_else(overflow)?,
        })
    }

    /// Checks consistency (n = 0 ⇒ sums 0; Cauchy–Schwarz n·Σx² ≥ (Σx)²).
    pub(super) fn check(&self) -> Result<(), String> {
        if self.n == 0 && (self.sum != 0 || self.sum_sq != 0) {
            return Err("sums must be 0 when n = 0".into());
        }
        let lhs = u128::from(self.n) * u128::from(self.sum_sq);
        let rhs = u128::from(self.sum) * u128::from(self.sum);
        if lhs < rhs {
            return Err("inconsistent: n * sum_sq < sum^2".into());
        }
        Ok(())
    }

    /// The statistics (n, x̄, M2) in the unit (x / `quanta_per_unit`), M2 computed exactly in
    /// integers.
    pub fn gaussian(&self, quanta_per_unit: f64) -> GaussianStats {
        if self.n == 0 {
            return GaussianStats::new();
        }
        let n = u128::from(self.n);
        let s = u128::from(self.sum);
        let m2_times_n = n * u128::from(self.sum_sq) - s * s;
        let mean = self.sum as f64 / (quanta_per_unit * self.n as f64);
        let m2 = m2_times_n as f64 / (self.n as f64 * quanta_per_unit * quanta_per_unit);
        GaussianStats::from_parts(self.n, mean, m2).unwrap_or_default()
    }
}

/// One place's statistics: demonstrations, colour draws per object, size sums.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PlaceStats {
    /// Number of demonstrations that used this place.
    pub demonstrations: u64,
    /// Colour draw counts over the colour terms, summed over the objects (for display).
    pub color: CategoryCounts,
    /// Every object's colour draws, as a sorted multiset (so the order of the demonstrations does
    /// not matter): the sufficient statistic of the two-level colour model.
    pub objects: Vec<ObjectDraws>,
    /// Size statistics.
    pub size: SizeStats,
}

impl PlaceStats {
    pub(super) fn empty() -> Self {
        PlaceStats {
            demonstrations: 0,
            color: CategoryCounts::new(COLORS).unwrap_or_else(|_| unreachable_counts()),
            objects: Vec::new(),
            size: SizeStats::default(),
        }
    }

    /// Adds one object's colour draws, keeping the multiset sorted.
    pub(super) fn add_object(&mut self, draws: ObjectDraws) -> Result<(), SchemaError> {
        for &(b, n) in &draws {
            for _ in 0..n {
                self.color.update(b)?;
            }
        }
        let at = self.objects.partition_point(|o| *o <= draws);
        self.objects.insert(at, draws);
        Ok(())
    }

    /// Adds another place's statistics.
    pub(super) fn absorb(&mut self, o: &PlaceStats) -> Result<(), SchemaError> {
        for d in &o.objects {
            self.add_object(d.clone())?;
        }
        self.size = self.size.merged(&o.size)?;
        self.demonstrations += o.demonstrations;
        Ok(())
    }
}

fn unreachable_counts() -> CategoryCounts {
    CategoryCounts::from_counts(vec![0; COLORS]).expect("10 categories is a valid category set")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn size_stats_are_exact() {
        let mut s = SizeStats::default();
        for x in [3000u64, 2990, 1000] {
            s.add(x).unwrap();
        }
        let g = s.gaussian(20.0);
        let want = GaussianStats::from_slice(&[150.0, 149.5, 50.0]).unwrap();
        assert!((g.mean() - want.mean()).abs() < 1e-12);
        assert!((g.m2() - want.m2()).abs() < 1e-9);
    }
}
