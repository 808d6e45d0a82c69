//! The colour feature unit: the two-level Dirichlet model of the module docs ((P1)–(P6)) on the grid
//! of concentrations (a, α), built from the hyper-parameters; its evidence is taken in
//! `evidence.rs`, and by the full expansion for the tests' reference.

#[cfg(test)]
use std::collections::BTreeMap;

#[cfg(test)]
use bayes::special::ln_gamma;
use bayes::special::log_sum_exp;

use super::evidence::GroupEvidence;
use super::features::ObjectDraws;
use super::hyper::Hyper;

impl Hyper {
    /// The colour unit of these hyper-parameters.
    pub(crate) fn color_unit(&self) -> ColorUnit {
        let total: f64 = self.color_base.iter().sum();
        let mut grid = Vec::with_capacity(self.color_concentrations.len() * self.color_object_concentrations.len());
        for &alpha in &self.color_concentrations {
            for &a in &self.color_object_concentrations {
                grid.push((a, alpha));
            }
        }
        ColorUnit {
            base: self.color_base.iter().map(|p| p / total).collect(),
            ln_grid_prior: -(grid.len() as f64).ln(),
            grid,
            #[cfg(test)]
            ln_stirling: self.ln_stirling(),
        }
    }

    /// ln s(x, t), unsigned Stirling numbers of the first kind, x, t ≤ D (the full expansion's
    /// rows, [`ColorUnit::log_z_grid_full`]).
    #[cfg(test)]
    fn ln_stirling(&self) -> Vec<Vec<f64>> {
        let d = self.color_draws_per_object as usize;
        // ln s(x, t), unsigned Stirling numbers of the first kind, x, t ≤ D:
        // s(x+1, t) = x·s(x, t) + s(x, t−1), in logs.
        let mut ln_stirling = vec![vec![f64::NEG_INFINITY; d + 1]; d + 1];
        ln_stirling[0][0] = 0.0;
        for x in 0..d {
            for t in 1..=x + 1 {
                let grow = if x > 0 {
                    (x as f64).ln() + ln_stirling[x][t]
                } else {
                    f64::NEG_INFINITY
                };
                ln_stirling[x + 1][t] = log_add(grow, ln_stirling[x][t - 1]);
            }
        }
        ln_stirling
    }
}

/// ln(eˣ + eʸ).
#[cfg(test)]
fn log_add(x: f64, y: f64) -> f64 {
    let m = x.max(y);
    if m == f64::NEG_INFINITY {
        return m;
    }
    m + ((x - m).exp() + (y - m).exp()).ln()
}

/// The coefficients (in logs) of the product of two polynomials given by their coefficients in
/// logs: `out[k] = ln Σ_{i+j=k} exp(a[i] + b[j])`, each sum taken relative to its own largest term.
#[cfg(test)]
fn log_convolve(a: &[f64], b: &[f64]) -> Vec<f64> {
    let n = a.len() + b.len() - 1;
    let mut max = vec![f64::NEG_INFINITY; n];
    for (i, &x) in a.iter().enumerate().filter(|v| v.1.is_finite()) {
        for (j, &y) in b.iter().enumerate().filter(|v| v.1.is_finite()) {
            max[i + j] = max[i + j].max(x + y);
        }
    }
    let mut sum = vec![0.0; n];
    for (i, &x) in a.iter().enumerate().filter(|v| v.1.is_finite()) {
        for (j, &y) in b.iter().enumerate().filter(|v| v.1.is_finite()) {
            sum[i + j] += (x + y - max[i + j]).exp();
        }
    }
    max.iter()
        .zip(&sum)
        .map(|(&m, &s)| if m.is_finite() { m + s.ln() } else { m })
        .collect()
}

/// The colour feature unit: the two-level model of the module docs, π ~ Dirichlet(α·m) per place,
/// θ ~ Dirichlet(a·π) per object, the object's D draws ~ Multinomial(θ), with a on a grid.
pub(crate) struct ColorUnit {
    /// The base measure m, normalised.
    base: Vec<f64>,
    /// The (object concentration a, place concentration α) pairs.
    grid: Vec<(f64, f64)>,
    /// ln of the prior weight of each pair (uniform).
    ln_grid_prior: f64,
    /// ln s(x, t) for x, t ≤ D.
    #[cfg(test)]
    ln_stirling: Vec<Vec<f64>>,
}

impl ColorUnit {
    /// The evidence of the objects X of one place at every (a, α) of the grid
    /// ([`GroupEvidence`]: ln Z(X; a, α), eq. (P3), and one object more).
    pub(crate) fn group(&self, objects: &[&ObjectDraws]) -> GroupEvidence {
        GroupEvidence::new(&self.base, &self.grid, objects)
    }

    /// ln Z(X; a, α) = ln p(X | a, α) for every (a, α) of the grid (eq. (P3)).
    pub(super) fn log_z_grid(&self, objects: &[&ObjectDraws]) -> Vec<f64> {
        self.group(objects).ln_z
    }

    /// [`ColorUnit::log_z_grid`] by the full expansion, O((nD)²): the tests' reference. The exact marginal likelihood
    /// of the objects X of one place (module docs, eq. (P3)). The tables polynomial of each colour
    /// depends on a only, so it is built once per a and weighted for every α.
    #[cfg(test)]
    fn log_z_grid_full(&self, objects: &[&ObjectDraws]) -> Vec<f64> {
        if objects.is_empty() {
            return vec![0.0; self.grid.len()];
        }
        let mut by_bin: BTreeMap<usize, Vec<u64>> = BTreeMap::new();
        let mut sizes = Vec::with_capacity(objects.len());
        for o in objects {
            sizes.push(o.iter().map(|d| d.1).sum::<u64>() as f64);
            for &(b, x) in o.iter() {
                if x > 0 {
                    by_bin.entry(b).or_default().push(x);
                }
            }
        }
        let mut out = vec![0.0; self.grid.len()];
        let mut a_done: Vec<f64> = Vec::new();
        for (gi, &(a, _)) in self.grid.iter().enumerate() {
            if a_done.contains(&a) {
                continue;
            }
            a_done.push(a);
            let ln_a = a.ln();
            let per_object: f64 = sizes.iter().map(|&n| ln_gamma(a) - ln_gamma(a + n)).sum();
            // P_b(z) = Π_i Σ_t s(x_ib, t) aᵗ zᵗ: the distribution of the tables T_b of colour b.
            let polys: Vec<(usize, Vec<f64>)> = by_bin
                .iter()
                .map(|(&b, xs)| {
                    let mut poly = vec![0.0];
                    for &x in xs {
                        let x = x as usize;
                        let row = &self.ln_stirling[x.min(self.ln_stirling.len() - 1)];
                        let term: Vec<f64> = (0..=x)
                            .map(|t| row.get(t).copied().unwrap_or(f64::NEG_INFINITY) + t as f64 * ln_a)
                            .collect();
                        poly = log_convolve(&poly, &term);
                    }
                    (b, poly)
                })
                .collect();
            for (gj, &(a2, alpha)) in self.grid.iter().enumerate().skip(gi) {
                if a2 != a {
                    continue;
                }
                let mut total = vec![0.0];
                for (b, poly) in &polys {
                    let am = alpha * self.base[*b];
                    let lg_am = ln_gamma(am);
                    let weighted: Vec<f64> = poly
                        .iter()
                        .enumerate()
                        .map(|(t, &c)| {
                            if c.is_finite() {
                                c + ln_gamma(am + t as f64) - lg_am
                            } else {
                                c
                            }
                        })
                        .collect();
                    total = log_convolve(&total, &weighted);
                }
                let lg_alpha = ln_gamma(alpha);
                let terms: Vec<f64> = total
                    .iter()
                    .enumerate()
                    .map(|(t, &c)| c + lg_alpha - ln_gamma(alpha + t as f64))
                    .collect();
                out[gj] = per_object + log_sum_exp(&terms);
            }
        }
        out
    }

    /// ln Σ_a p(a) Π_groups Z(X_g; a) given the per-group ln Z grids: the evidence of groups of
    /// objects that share a but each have their own π (eq. (P4)).
    pub(super) fn log_evidence(&self, groups: &[Vec<f64>]) -> f64 {
        let terms: Vec<f64> = (0..self.grid.len())
            .map(|i| self.ln_grid_prior + groups.iter().map(|g| g[i]).sum::<f64>())
            .collect();
        log_sum_exp(&terms)
    }

    /// ln Σᵢ exp(joint[i] + ln p_i(õ)) over the grid, where `ln_p(i)` = ln Z(X ∪ õ) − ln Z(X) ≤ 0 at
    /// grid point i (a probability of the object's draws). Grid points are taken from the most
    /// probable down and the rest skipped once their joint weight is e⁴⁰·(grid size) below the best
    /// term so far: each skipped term is at most e^{joint}, so the sum is exact to 1e-17 relative.
    fn log_predictive_sum(&self, joint: &[f64], ln_p: impl Fn(usize) -> f64) -> f64 {
        let mut order: Vec<usize> = (0..joint.len()).collect();
        order.sort_by(|&x, &y| joint[y].total_cmp(&joint[x]).then(x.cmp(&y)));
        let margin = 40.0 + (joint.len() as f64).ln();
        let mut terms = Vec::with_capacity(joint.len());
        let mut best = f64::NEG_INFINITY;
        for i in order {
            if joint[i] < best - margin || joint[i] == f64::NEG_INFINITY {
                break;
            }
            let t = joint[i] + ln_p(i);
            best = best.max(t);
            terms.push(t);
        }
        log_sum_exp(&terms)
    }

    /// The posterior-predictive pmf (5.18) over the bins given one place's objects: the
    /// probability that a new object's draw has colour l, E[π_l | X] = Σ_a p(a | X)
    /// Z(X ∪ {l}; a) / Z(X; a).
    pub(crate) fn predictive(&self, objects: &[ObjectDraws]) -> Vec<f64> {
        let refs: Vec<&ObjectDraws> = objects.iter().collect();
        let group = self.group(&refs);
        let z = &group.ln_z;
        let joint: Vec<f64> = z.iter().map(|&zi| self.ln_grid_prior + zi).collect();
        let ev = log_sum_exp(&joint);
        let mut p: Vec<f64> = (0..self.base.len())
            .map(|l| {
                if self.base[l] <= 0.0 {
                    return 0.0;
                }
                let one = vec![(l, 1u64)];
                (self.log_predictive_sum(&joint, |i| group.ln_z_with(i, &one) - z[i]) - ev).exp()
            })
            .collect();
        let s: f64 = p.iter().sum();
        if s > 0.0 {
            p.iter_mut().for_each(|v| *v /= s);
        }
        p
    }

    /// ln p(õ | X_k) for each group k, where all groups share a (eq. (P5)).
    pub(super) fn log_scores(&self, groups: &[&GroupEvidence], draws: &ObjectDraws) -> Vec<f64> {
        if draws.is_empty() {
            return vec![0.0; groups.len()];
        }
        let joint: Vec<f64> = (0..self.grid.len())
            .map(|i| self.ln_grid_prior + groups.iter().map(|g| g.ln_z[i]).sum::<f64>())
            .collect();
        let ev = log_sum_exp(&joint);
        groups
            .iter()
            .map(|g| self.log_predictive_sum(&joint, |i| g.ln_z_with(i, draws) - g.ln_z[i]) - ev)
            .collect()
    }

    /// ln p₀(õ): the prior predictive of one object (the background model M₀, eq. (P6)).
    pub(super) fn log_background(&self, draws: &ObjectDraws) -> f64 {
        if draws.is_empty() {
            return 0.0;
        }
        let z = self.log_z_grid(&[draws]);
        self.log_evidence(std::slice::from_ref(&z))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::procedural::features::COLORS;

    /// Random objects for the evidence tests: 1–4 colours each, `d` draws shared out at random.
    fn random_objects(rng: &mut impl rand::RngExt, n: usize, d: u64, colours: usize) -> Vec<ObjectDraws> {
        (0..n)
            .map(|_| {
                let k = rng.random_range(1..=4usize);
                let mut counts = vec![0u64; colours];
                // Objects of a place share colours: favour the first three.
                for _ in 0..d {
                    let l = if rng.random_bool(0.7) {
                        rng.random_range(0..3)
                    } else {
                        rng.random_range(0..colours)
                    };
                    if counts.iter().filter(|&&c| c > 0).count() < k || counts[l] > 0 {
                        counts[l] += 1;
                    } else {
                        let first = counts.iter().position(|&c| c > 0).unwrap_or(0);
                        counts[first] += 1;
                    }
                }
                counts
                    .iter()
                    .enumerate()
                    .filter(|c| *c.1 > 0)
                    .map(|(l, &c)| (l, c))
                    .collect()
            })
            .collect()
    }

    #[test]
    fn fast_evidence_matches_the_full_expansion() {
        let mut rng = bayes::rng::seeded(17);
        let mut worst: f64 = 0.0;
        for (d, n_max) in [(30u32, 40usize), (7, 60), (1, 30), (60, 12)] {
            let hyper = Hyper {
                color_draws_per_object: d,
                ..Hyper::default()
            };
            let unit = hyper.color_unit();
            for n in [1usize, 2, 3, 7, n_max] {
                let objects = random_objects(&mut rng, n, u64::from(d), COLORS);
                let refs: Vec<&ObjectDraws> = objects.iter().collect();
                let fast = unit.log_z_grid(&refs);
                let full = unit.log_z_grid_full(&refs);
                let group = unit.group(&refs);
                let probe = random_objects(&mut rng, 1, u64::from(d), COLORS).remove(0);
                let mut with = refs.clone();
                with.push(&probe);
                let full_with = unit.log_z_grid_full(&with);
                for i in 0..full.len() {
                    for (x, y) in [(fast[i], full[i]), (group.ln_z_with(i, &probe), full_with[i])] {
                        let err = (x - y).abs() / y.abs().max(1.0);
                        worst = worst.max(err);
                        assert!(
                            err < 1e-9,
                            "D {d}, n {n}, grid {i}: {x} against the full expansion's {y}"
                        );
                    }
                }
            }
        }
        println!("worst relative difference {worst:e}");
    }
}
