//! Collapsed Gibbs sampler for the finite model with A prototypes (6.15–6.24).
//!
//! θ, φ, (μ, Σ) and ψ are integrated out; the state is the assignment vector z and, per prototype,
//! the counts and sufficient statistics. One update of z_mi draws from (6.15):
//!
//! p(z_mi = j | z₋, 𝒟) ∝ (n_mj + α) · (n_jw + β)/(n_j + Qβ) · p(x_mi | j) · p(b_mi | j),
//!
//! with the count ratios (6.16, 6.17) (the denominator of 6.16 does not depend on j and is dropped;
//! that of 6.17 is the number of data in prototype j, which the seed's typesetting garbles),
//! p(x | j) the exact Student-t predictive of the Normal–inverse-Wishart posterior — not the seed's
//! moment-matched normal (6.18–6.21): the t is the true collapsed conditional, so the chain leaves
//! the posterior exactly invariant (a Geweke test in `tests/` checks this and detects the
//! approximation), its heavy tails keep small prototypes from rejecting nearby grasps, and it is
//! defined for every n_j where δ_j of (6.21) is not — and p(b | j) the collapsed appearance
//! predictive standing in for (6.22–6.24) (see [`crate::prior`]).

use rand::Rng;

use crate::data::Dataset;
use crate::error::{Result, invalid};
use crate::math::{ln_gamma, sample_log_weights};
use crate::prior::{Derived, Hyperparameters};
use crate::stats::{AppearanceCache, AppearanceStats, PositionCache, PositionStats};

/// Marker for a datum not yet assigned.
const UNASSIGNED: u32 = u32::MAX;

/// The working state of the collapsed Gibbs sampler (the data stay in a separate [`Dataset`]).
#[derive(Debug, Clone)]
pub struct GibbsState {
    a: usize,
    q: usize,
    m: usize,
    hyper: Hyperparameters,
    derived: Derived,
    z: Vec<u32>,
    /// n_mj, row-major M×A.
    n_obj: Vec<u32>,
    /// n_j.
    n_proto: Vec<u32>,
    /// n_jw, row-major A×Q.
    n_orient: Vec<u32>,
    pos: Vec<PositionStats>,
    app: Vec<AppearanceStats>,
    pos_cache: Vec<PositionCache>,
    app_cache: Vec<AppearanceCache>,
    logw: Vec<f64>,
}

impl GibbsState {
    /// A state with every datum unassigned; call [`GibbsState::initialise`] (or use
    /// [`GibbsState::with_assignments`]) before sweeping.
    pub fn new(data: &Dataset, hyper: &Hyperparameters, prototypes: usize) -> Result<Self> {
        if prototypes == 0 {
            return Err(invalid("prototypes", "A must be at least 1"));
        }
        let derived = Derived::new(hyper)?;
        let (m, q, a) = (data.num_objects, data.num_orientations, prototypes);
        let empty_pos = PositionCache::new(&PositionStats::default(), &derived);
        let empty_app = AppearanceCache::new(&AppearanceStats::default(), &derived);
        Ok(Self {
            a,
            q,
            m,
            hyper: hyper.clone(),
            derived,
            z: vec![UNASSIGNED; data.len()],
            n_obj: vec![0; m * a],
            n_proto: vec![0; a],
            n_orient: vec![0; a * q],
            pos: vec![PositionStats::default(); a],
            app: vec![AppearanceStats::default(); a],
            pos_cache: vec![empty_pos; a],
            app_cache: vec![empty_app; a],
            logw: vec![0.0; a],
        })
    }

    /// A state with the given assignments (`z[i] < A`).
    pub fn with_assignments(data: &Dataset, hyper: &Hyperparameters, prototypes: usize, z: &[usize]) -> Result<Self> {
        let mut s = Self::new(data, hyper, prototypes)?;
        if z.len() != data.len() {
            return Err(crate::error::GraspError::DimensionMismatch {
                field: "assignments".into(),
                expected: data.len(),
                got: z.len(),
            });
        }
        for (i, &j) in z.iter().enumerate() {
            if j >= prototypes {
                return Err(invalid(
                    format!("assignments[{i}]"),
                    format!("{j} is not < A = {prototypes}"),
                ));
            }
            s.add(data, i, j);
        }
        Ok(s)
    }

    /// Sequential initialisation: each datum in turn is drawn from its conditional given the data
    /// already placed (a better start than uniform labels, and the same cost as one sweep).
    pub fn initialise<R: Rng + ?Sized>(&mut self, data: &Dataset, rng: &mut R) {
        for i in 0..data.len() {
            if self.z[i] == UNASSIGNED {
                let j = self.draw(data, i, rng);
                self.add(data, i, j);
            }
        }
    }

    /// One Gibbs sweep over all data (O(N·A), no allocation), then a refresh of the statistics from
    /// scratch so rounding from millions of incremental updates cannot accumulate.
    pub fn sweep<R: Rng + ?Sized>(&mut self, data: &Dataset, rng: &mut R) {
        debug_assert_eq!(data.len(), self.z.len());
        for i in 0..data.len() {
            let old = self.z[i];
            if old != UNASSIGNED {
                self.remove(data, i, old as usize);
            }
            let j = self.draw(data, i, rng);
            self.add(data, i, j);
        }
        self.refresh(data);
    }

    /// Recomputes all statistics and caches from z.
    pub fn refresh(&mut self, data: &Dataset) {
        for j in 0..self.a {
            self.pos[j] = PositionStats::default();
            self.app[j] = AppearanceStats::default();
        }
        for i in 0..data.len() {
            let j = self.z[i];
            if j != UNASSIGNED {
                self.pos[j as usize].add(&data.x[i]);
                self.app[j as usize].add(&data.b_inv[i], data.ln_det_b[i]);
            }
        }
        for j in 0..self.a {
            self.update_cache(j);
        }
    }

    #[inline]
    fn update_cache(&mut self, j: usize) {
        self.pos_cache[j] = PositionCache::new(&self.pos[j], &self.derived);
        self.app_cache[j] = AppearanceCache::new(&self.app[j], &self.derived);
    }

    #[inline]
    fn add(&mut self, data: &Dataset, i: usize, j: usize) {
        let m = data.object[i] as usize;
        let w = data.w[i] as usize;
        self.z[i] = j as u32;
        self.n_obj[m * self.a + j] += 1;
        self.n_proto[j] += 1;
        self.n_orient[j * self.q + w] += 1;
        self.pos[j].add(&data.x[i]);
        self.app[j].add(&data.b_inv[i], data.ln_det_b[i]);
        self.update_cache(j);
    }

    #[inline]
    fn remove(&mut self, data: &Dataset, i: usize, j: usize) {
        let m = data.object[i] as usize;
        let w = data.w[i] as usize;
        self.z[i] = UNASSIGNED;
        self.n_obj[m * self.a + j] -= 1;
        self.n_proto[j] -= 1;
        self.n_orient[j * self.q + w] -= 1;
        self.pos[j].remove(&data.x[i]);
        self.app[j].remove(&data.b_inv[i], data.ln_det_b[i]);
        self.update_cache(j);
    }

    /// Draws z_i from (6.15) given everything else (datum i must be unassigned).
    #[inline]
    fn draw<R: Rng + ?Sized>(&mut self, data: &Dataset, i: usize, rng: &mut R) -> usize {
        let m = data.object[i] as usize;
        let w = data.w[i] as usize;
        let (alpha, beta) = (self.hyper.alpha, self.hyper.beta);
        let qbeta = self.q as f64 * beta;
        let x = &data.x[i];
        let bi = &data.b_inv[i];
        let ld = data.ln_det_b[i];
        let row = &self.n_obj[m * self.a..(m + 1) * self.a];
        for (j, &n_mj) in row.iter().enumerate() {
            let counts = (n_mj as f64 + alpha) * (self.n_orient[j * self.q + w] as f64 + beta)
                / (self.n_proto[j] as f64 + qbeta);
            self.logw[j] = counts.ln() + self.pos_cache[j].log_pred(x) + self.app_cache[j].log_pred(bi, ld);
        }
        sample_log_weights(&mut self.logw, rng)
    }

    /// ln p(z, 𝒟 | Ω) with θ, φ, μ, Σ, ψ integrated out: the Dirichlet–multinomial terms for z and
    /// w plus each prototype's marginal likelihoods of x and b. Unassigned data are left out.
    pub fn log_joint(&self) -> f64 {
        let (alpha, beta) = (self.hyper.alpha, self.hyper.beta);
        let (a, q) = (self.a as f64, self.q as f64);
        let mut s = 0.0;
        let (lg_a, lg_aa) = (ln_gamma(alpha), ln_gamma(a * alpha));
        for m in 0..self.m {
            let row = &self.n_obj[m * self.a..(m + 1) * self.a];
            let nm: u32 = row.iter().sum();
            s += lg_aa - ln_gamma(nm as f64 + a * alpha);
            for &c in row {
                if c > 0 {
                    s += ln_gamma(c as f64 + alpha) - lg_a;
                }
            }
        }
        let (lg_b, lg_qb) = (ln_gamma(beta), ln_gamma(q * beta));
        for j in 0..self.a {
            if self.n_proto[j] == 0 {
                continue;
            }
            s += lg_qb - ln_gamma(self.n_proto[j] as f64 + q * beta);
            for &c in &self.n_orient[j * self.q..(j + 1) * self.q] {
                if c > 0 {
                    s += ln_gamma(c as f64 + beta) - lg_b;
                }
            }
            s += self.pos[j].log_marginal(&self.derived) + self.app[j].log_marginal(&self.derived);
        }
        s
    }

    /// The assignments z (prototype index per datum).
    pub fn assignments(&self) -> Vec<usize> {
        self.z.iter().map(|&j| j as usize).collect()
    }

    /// Number of prototypes with at least one datum.
    pub fn num_occupied(&self) -> usize {
        self.n_proto.iter().filter(|&&n| n > 0).count()
    }

    /// Number of prototypes A.
    pub fn num_prototypes(&self) -> usize {
        self.a
    }

    /// The hyperparameters in use.
    pub fn hyperparameters(&self) -> &Hyperparameters {
        &self.hyper
    }
}
