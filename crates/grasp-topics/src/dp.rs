//! Nonparametric variant: a Dirichlet-process mixture of grasp prototypes (Appendix A.1.4) sampled
//! with Neal's (2000) algorithm 8, the Gibbs sampler with auxiliary components that §6.4 cites.
//!
//! The model is G ~ DP(α G₀), (μ, Σ, ψ, φ)_i ~ G, (x, b, w)_i ~ f(· | parameters), with G₀ the
//! priors of [`crate::prior`]. The number of prototypes is inferred instead of fixed.
//!
//! Unlike the finite model there is no per-object θ_m: the mixing weights are one DP draw shared by
//! all objects. (Letting A → ∞ in the finite model with per-object Dirichlet(α/A) weights would give
//! every object its own DP and no prototype would be shared between objects; keeping per-object
//! weights with shared atoms needs a hierarchical DP, left for later.) Prototypes are still shared
//! across objects, and the sharing table is computed the same way.
//!
//! Algorithm 8 keeps explicit component parameters. For each datum: remove it from its component
//! (a component left empty becomes the first auxiliary), draw the other m auxiliary components from
//! G₀, and choose among the K live components with weight n_k f(datum | θ_k) and the auxiliaries with
//! weight (α/m) f(datum | θ_aux). After each sweep every live component's parameters are redrawn from
//! their conjugate posterior. Component storage is a pool allocated once, so an update allocates
//! nothing; its cost is O(K + m).

use nalgebra::{Matrix2, Matrix3, Vector3};
use rand::Rng;

use crate::data::Dataset;
use crate::error::{Result, invalid};
use crate::math::{
    cholesky, det2, dirichlet_into, dirichlet_symmetric_into, inv2, ln_det_from_chol, ln_gamma, mahalanobis_sq,
    sample_inv_wishart, sample_log_weights, sample_mvn, sample_wishart,
};
use crate::prior::{Derived, Hyperparameters};
use crate::stats::{AppearanceStats, PositionStats};

const UNASSIGNED: u32 = u32::MAX;

#[derive(Debug, Clone, Copy)]
struct Params {
    mu: Vector3<f64>,
    /// Cholesky factor of Σ.
    l: Matrix3<f64>,
    half_ln_det_sigma: f64,
    psi: Matrix2<f64>,
    /// (u/2) ln|ψ|.
    half_u_ln_det_psi: f64,
}

impl Default for Params {
    fn default() -> Self {
        Self {
            mu: Vector3::zeros(),
            l: Matrix3::identity(),
            half_ln_det_sigma: 0.0,
            psi: Matrix2::identity(),
            half_u_ln_det_psi: 0.0,
        }
    }
}

/// The working state of the DP sampler (algorithm 8).
#[derive(Debug, Clone)]
pub struct DpState {
    concentration: f64,
    aux: usize,
    q: usize,
    hyper: Hyperparameters,
    derived: Derived,
    z: Vec<u32>,
    count: Vec<u32>,
    params: Vec<Params>,
    /// ln φ per slot, slots × Q.
    log_phi: Vec<f64>,
    free: Vec<u32>,
    active: Vec<u32>,
    active_pos: Vec<u32>,
    aux_params: Vec<Params>,
    aux_log_phi: Vec<f64>,
    logw: Vec<f64>,
    dir_alpha: Vec<f64>,
    dir_out: Vec<f64>,
    pos: Vec<PositionStats>,
    app: Vec<AppearanceStats>,
    orient: Vec<u32>,
}

impl DpState {
    /// A state with every datum unassigned; `concentration` α > 0, `auxiliary` m ≥ 1.
    pub fn new(data: &Dataset, hyper: &Hyperparameters, concentration: f64, auxiliary: usize) -> Result<Self> {
        if !(concentration > 0.0 && concentration.is_finite()) {
            return Err(invalid(
                "nonparametric.concentration",
                format!("must be > 0, got {concentration}"),
            ));
        }
        if auxiliary == 0 {
            return Err(invalid("nonparametric.auxiliary", "m must be at least 1"));
        }
        let derived = Derived::new(hyper)?;
        let n = data.len();
        let q = data.num_orientations;
        let slots = n.max(1);
        Ok(Self {
            concentration,
            aux: auxiliary,
            q,
            hyper: hyper.clone(),
            derived,
            z: vec![UNASSIGNED; n],
            count: vec![0; slots],
            params: vec![Params::default(); slots],
            log_phi: vec![0.0; slots * q],
            free: (0..slots as u32).rev().collect(),
            active: Vec::with_capacity(slots),
            active_pos: vec![0; slots],
            aux_params: vec![Params::default(); auxiliary],
            aux_log_phi: vec![0.0; auxiliary * q],
            logw: vec![0.0; slots + auxiliary],
            dir_alpha: vec![0.0; q],
            dir_out: vec![0.0; q],
            pos: vec![PositionStats::default(); slots],
            app: vec![AppearanceStats::default(); slots],
            orient: vec![0; slots * q],
        })
    }

    /// Sequential initialisation: data are seated one at a time by the algorithm-8 update, then the
    /// parameters are drawn from their posteriors.
    pub fn initialise<R: Rng + ?Sized>(&mut self, data: &Dataset, rng: &mut R) {
        for i in 0..data.len() {
            if self.z[i] == UNASSIGNED {
                self.update(data, i, rng);
            }
        }
        self.resample_params(data, rng);
    }

    /// One sweep: an algorithm-8 update of every assignment, then every live component's
    /// parameters redrawn from their conjugate posterior.
    pub fn sweep<R: Rng + ?Sized>(&mut self, data: &Dataset, rng: &mut R) {
        for i in 0..data.len() {
            self.update(data, i, rng);
        }
        self.resample_params(data, rng);
    }

    /// ln f(datum i | params) up to terms shared by every component.
    #[inline]
    fn log_lik(p: &Params, log_phi: &[f64], data: &Dataset, i: usize) -> f64 {
        let bi = &data.b_inv[i];
        let tr = p.psi[(0, 0)] * bi[(0, 0)]
            + p.psi[(0, 1)] * bi[(1, 0)]
            + p.psi[(1, 0)] * bi[(0, 1)]
            + p.psi[(1, 1)] * bi[(1, 1)];
        -p.half_ln_det_sigma - 0.5 * mahalanobis_sq(&p.l, &(data.x[i] - p.mu)) + p.half_u_ln_det_psi - 0.5 * tr
            + log_phi[data.w[i] as usize]
    }

    fn update<R: Rng + ?Sized>(&mut self, data: &Dataset, i: usize, rng: &mut R) {
        let q = self.q;
        let mut first_aux = 0;
        let old = self.z[i];
        if old != UNASSIGNED {
            let c = old as usize;
            self.count[c] -= 1;
            if self.count[c] == 0 {
                // The emptied component becomes the first auxiliary (algorithm 8).
                self.aux_params[0] = self.params[c];
                let (src, dst) = (&self.log_phi[c * q..(c + 1) * q], &mut self.aux_log_phi[0..q]);
                dst.copy_from_slice(src);
                self.deactivate(c);
                first_aux = 1;
            }
            self.z[i] = UNASSIGNED;
        }
        for k in first_aux..self.aux {
            let lp = &mut self.aux_log_phi[k * q..(k + 1) * q];
            self.aux_params[k] = draw_prior(&self.derived, self.hyper.beta, lp, rng);
        }
        let na = self.active.len();
        for (s, &c) in self.active.iter().enumerate() {
            let c = c as usize;
            self.logw[s] = (self.count[c] as f64).ln()
                + Self::log_lik(&self.params[c], &self.log_phi[c * q..(c + 1) * q], data, i);
        }
        let aux_w = (self.concentration / self.aux as f64).ln();
        for k in 0..self.aux {
            self.logw[na + k] =
                aux_w + Self::log_lik(&self.aux_params[k], &self.aux_log_phi[k * q..(k + 1) * q], data, i);
        }
        let pick = sample_log_weights(&mut self.logw[..na + self.aux], rng);
        let c = if pick < na {
            self.active[pick] as usize
        } else {
            let k = pick - na;
            let c = self.activate();
            self.params[c] = self.aux_params[k];
            let (src, dst) = (
                &self.aux_log_phi[k * q..(k + 1) * q],
                &mut self.log_phi[c * q..(c + 1) * q],
            );
            dst.copy_from_slice(src);
            c
        };
        self.count[c] += 1;
        self.z[i] = c as u32;
    }

    fn activate(&mut self) -> usize {
        // The pool has one slot per datum, so a free slot always exists.
        let c = self.free.pop().unwrap_or(0) as usize;
        self.active_pos[c] = self.active.len() as u32;
        self.active.push(c as u32);
        c
    }

    fn deactivate(&mut self, c: usize) {
        let p = self.active_pos[c] as usize;
        self.active.swap_remove(p);
        if p < self.active.len() {
            self.active_pos[self.active[p] as usize] = p as u32;
        }
        self.free.push(c as u32);
    }

    /// Sufficient statistics per live component from z.
    fn collect_stats(&mut self, data: &Dataset) {
        let q = self.q;
        for &c in &self.active {
            let c = c as usize;
            self.pos[c] = PositionStats::default();
            self.app[c] = AppearanceStats::default();
            self.orient[c * q..(c + 1) * q].fill(0);
        }
        for i in 0..data.len() {
            let c = self.z[i] as usize;
            self.pos[c].add(&data.x[i]);
            self.app[c].add(&data.b_inv[i], data.ln_det_b[i]);
            self.orient[c * q + data.w[i] as usize] += 1;
        }
    }

    fn resample_params<R: Rng + ?Sized>(&mut self, data: &Dataset, rng: &mut R) {
        self.collect_stats(data);
        let q = self.q;
        for s in 0..self.active.len() {
            let c = self.active[s] as usize;
            let (kn, nun, mun, lam) = self.pos[c].posterior(&self.derived);
            let sigma = sample_inv_wishart(nun, &lam, rng);
            let (nu_psi, pm) = self.app[c].posterior(&self.derived);
            let pl = cholesky(&inv2(&pm)).unwrap_or_else(Matrix2::identity);
            let psi = sample_wishart(nu_psi, &pl, rng);
            self.params[c] = make_params(&self.derived, &sigma, &mun, kn, &psi, rng);
            for k in 0..q {
                self.dir_alpha[k] = self.hyper.beta + self.orient[c * q + k] as f64;
            }
            dirichlet_into(&self.dir_alpha, &mut self.dir_out, rng);
            for k in 0..q {
                self.log_phi[c * q + k] = self.dir_out[k].ln();
            }
        }
    }

    /// Collapsed ln p(z, 𝒟 | Ω): the Chinese-restaurant prior of z plus each component's marginal
    /// likelihoods (parameters integrated out), comparable across chains and with the finite model.
    pub fn log_joint(&mut self, data: &Dataset) -> f64 {
        self.collect_stats(data);
        let a = self.concentration;
        let n = data.len() as f64;
        let q = self.q as f64;
        let beta = self.hyper.beta;
        let mut s = ln_gamma(a) - ln_gamma(n + a);
        for &c in &self.active {
            let c = c as usize;
            let nk = self.count[c] as f64;
            s += a.ln() + ln_gamma(nk);
            s += ln_gamma(q * beta) - ln_gamma(nk + q * beta);
            for k in 0..self.q {
                let o = self.orient[c * self.q + k];
                if o > 0 {
                    s += ln_gamma(o as f64 + beta) - ln_gamma(beta);
                }
            }
            s += self.pos[c].log_marginal(&self.derived) + self.app[c].log_marginal(&self.derived);
        }
        s
    }

    /// The assignments, relabelled 0..K in order of first appearance.
    pub fn assignments(&self) -> Vec<usize> {
        let mut map = vec![usize::MAX; self.count.len()];
        let mut next = 0;
        self.z
            .iter()
            .map(|&c| {
                let c = c as usize;
                if map[c] == usize::MAX {
                    map[c] = next;
                    next += 1;
                }
                map[c]
            })
            .collect()
    }

    /// Number of live components K.
    pub fn num_occupied(&self) -> usize {
        self.active.len()
    }

    /// The hyperparameters (G₀) in use.
    pub fn hyperparameters(&self) -> &Hyperparameters {
        &self.hyper
    }
}

/// A component drawn from G₀; φ's logarithms are written to `log_phi`.
fn draw_prior<R: Rng + ?Sized>(p: &Derived, beta: f64, log_phi: &mut [f64], rng: &mut R) -> Params {
    let sigma = sample_inv_wishart(p.nu0, &p.xi, rng);
    let psi = sample_wishart(p.nu_psi, &p.s0_chol, rng);
    let out = make_params(p, &sigma, &p.mu0, p.kappa0, &psi, rng);
    dirichlet_symmetric_into(beta, log_phi, rng);
    for v in log_phi.iter_mut() {
        *v = v.ln();
    }
    out
}

/// Parameters with the given Σ and ψ and μ ~ Normal(mean, Σ/κ).
fn make_params<R: Rng + ?Sized>(
    p: &Derived,
    sigma: &Matrix3<f64>,
    mean: &Vector3<f64>,
    kappa: f64,
    psi: &Matrix2<f64>,
    rng: &mut R,
) -> Params {
    let l = cholesky(sigma).unwrap_or_else(Matrix3::identity);
    let mu = sample_mvn(mean, &(l / kappa.sqrt()), rng);
    Params {
        mu,
        l,
        half_ln_det_sigma: 0.5 * ln_det_from_chol(&l),
        psi: *psi,
        half_u_ln_det_psi: 0.5 * p.u * det2(psi).ln(),
    }
}
