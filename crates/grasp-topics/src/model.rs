//! Learning a grasp model from a corpus (§6.4) and generating pre-grasps from it (§6.4.1).
//!
//! # Model file (`pbd-grasp-model`, version 1)
//!
//! [`GraspModel`] serialises with serde to JSON (the CLI's `prototypes.json`): the configuration
//! and hyperparameters used, the canonical orientations, the object names, per object the prototype
//! of each training grasp in the selected posterior sample, per prototype its posterior (the
//! Normal–inverse-Wishart parameters of the position, the Wishart posterior of the appearance scale,
//! the orientation counts and φ̂) and the run's diagnostics (log-joint traces per chain, occupied
//! prototypes per sweep, Gelman–Rubin R̂). [`GraspModel::from_json_str`] validates it on read.

use std::path::Path;

use nalgebra::{Matrix2, Matrix3, UnitQuaternion, Vector3};
use rand::{Rng, RngExt};
use serde::{Deserialize, Serialize};

use crate::corpus::{Corpus, validate_spd2};
use crate::data::Dataset;
use crate::dp::DpState;
use crate::error::{GraspError, Result, invalid};
use crate::gibbs::GibbsState;
use crate::math::{DX, a2, a3, cholesky, det2, inv2, m2, m3, sample_mvn, sample_weights, symmetrize, v3a};
use crate::metrics::gelman_rubin;
use crate::orientation::CanonicalOrientations;
use crate::prior::{Derived, Hyperparameters};
use crate::stats::{AppearanceCache, AppearanceStats, PositionStats};

/// The `format` tag of model files.
pub const MODEL_FORMAT: &str = "pbd-grasp-model";
/// The model file version this build writes and reads.
pub const MODEL_VERSION: u32 = 1;

/// Settings of the nonparametric (Dirichlet-process) variant.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DpConfig {
    /// DP concentration α > 0 (expected number of prototypes grows like α ln N).
    pub concentration: f64,
    /// Number m ≥ 1 of auxiliary components in Neal's algorithm 8.
    pub auxiliary: usize,
}

impl Default for DpConfig {
    fn default() -> Self {
        Self {
            concentration: 1.0,
            auxiliary: 3,
        }
    }
}

/// How to learn: model size, sampler schedule and seed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Config {
    /// Number of prototypes A of the finite model (the seed used 10). Ignored by the DP variant.
    pub prototypes: usize,
    /// Number of canonical orientations Q (the seed used 6).
    pub orientations: usize,
    /// `Some` for the Dirichlet-process variant, which infers the number of prototypes.
    pub nonparametric: Option<DpConfig>,
    /// Sweeps discarded before samples are kept (the seed used about 200).
    pub burn_in: usize,
    /// Samples kept per chain after burn-in.
    pub samples: usize,
    /// Sweeps between kept samples.
    pub thin: usize,
    /// Independent chains (run in parallel threads); the kept sample with the highest log joint
    /// over all chains becomes the model.
    pub chains: usize,
    /// Seed of every random choice (orientation clustering and all chains): same seed, same model.
    pub seed: u64,
    /// Hyperparameters; `None` = [`Hyperparameters::from_data`].
    pub hyperparameters: Option<Hyperparameters>,
}

impl Default for Config {
    fn default() -> Self {
        Self {
            prototypes: 10,
            orientations: 6,
            nonparametric: None,
            burn_in: 200,
            samples: 10,
            thin: 10,
            chains: 4,
            seed: 0,
            hyperparameters: None,
        }
    }
}

/// Largest number of pre-grasps one [`GraspModel::generate`] call draws.
pub const MAX_GENERATE: usize = 100_000;

impl Config {
    /// Largest number of prototypes A.
    pub const MAX_PROTOTYPES: usize = 1_000;
    /// Largest number of canonical orientations Q.
    pub const MAX_ORIENTATIONS: usize = 360;
    /// Largest number of chains.
    pub const MAX_CHAINS: usize = 64;
    /// Largest number of sweeps per chain (burn-in + kept samples × thinning).
    pub const MAX_SWEEPS: usize = 1_000_000;

    /// Checks the ranges (names as in the model file's `config`), including the upper bounds
    /// ([`Self::MAX_PROTOTYPES`], …).
    pub fn validate(&self) -> Result<()> {
        if self.nonparametric.is_none() && self.prototypes == 0 {
            return Err(invalid("config.prototypes", "A must be at least 1"));
        }
        // Upper bounds, checked before anything is allocated: each is far above any useful value
        // (the seed used A = 10, Q = 6, ~200 sweeps) and keeps memory and time bounded.
        for (field, value, max) in [
            ("config.prototypes", self.prototypes, Self::MAX_PROTOTYPES),
            ("config.orientations", self.orientations, Self::MAX_ORIENTATIONS),
            ("config.chains", self.chains, Self::MAX_CHAINS),
            ("config.burn_in", self.burn_in, Self::MAX_SWEEPS),
            ("config.samples", self.samples, Self::MAX_SWEEPS),
            ("config.thin", self.thin, Self::MAX_SWEEPS),
        ] {
            if value > max {
                return Err(invalid(field, format!("{value} is above the limit of {max}")));
            }
        }
        if self.burn_in + self.samples.saturating_mul(self.thin) > Self::MAX_SWEEPS {
            return Err(invalid(
                "config",
                format!(
                    "burn_in + samples × thin is above the limit of {} sweeps per chain",
                    Self::MAX_SWEEPS
                ),
            ));
        }
        if self.orientations == 0 {
            return Err(invalid("config.orientations", "Q must be at least 1"));
        }
        if self.samples == 0 {
            return Err(invalid("config.samples", "at least one sample must be kept"));
        }
        if self.thin == 0 {
            return Err(invalid("config.thin", "must be at least 1"));
        }
        if self.chains == 0 {
            return Err(invalid("config.chains", "must be at least 1"));
        }
        if let Some(dp) = &self.nonparametric
            && (!(dp.concentration > 0.0 && dp.concentration.is_finite()) || dp.auxiliary == 0)
        {
            return Err(invalid(
                "config.nonparametric",
                format!("concentration must be > 0 and auxiliary ≥ 1, got {dp:?}"),
            ));
        }
        if let Some(h) = &self.hyperparameters {
            h.validate()?;
        }
        Ok(())
    }
}

/// One chain's record.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ChainTrace {
    /// The chain's own seed (derived from [`Config::seed`]).
    pub seed: u64,
    /// ln p(z, 𝒟) after every sweep, burn-in included.
    pub log_joint: Vec<f64>,
    /// Occupied prototypes after every sweep.
    pub occupied: Vec<usize>,
    /// The highest log joint among this chain's kept samples.
    pub best_log_joint: f64,
}

/// How the run went (outcomes, not errors).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Diagnostics {
    /// Per chain.
    pub chains: Vec<ChainTrace>,
    /// Chain of the selected sample.
    pub selected_chain: usize,
    /// Gelman–Rubin R̂ of the log joint over the post-burn-in sweeps (≥ 2 chains).
    pub r_hat: Option<f64>,
}

/// The result of running the sampler on a [`Dataset`].
#[derive(Debug, Clone, PartialEq)]
pub struct Fit {
    /// The selected sample's assignments (prototype per datum, labels 0..K by decreasing size).
    pub assignments: Vec<usize>,
    /// Its log joint.
    pub log_joint: f64,
    /// Traces and convergence.
    pub diagnostics: Diagnostics,
}

/// Relabels by decreasing size (ties: first appearance), so labels are deterministic.
fn canonical_labels(z: &[usize]) -> Vec<usize> {
    let k = z.iter().copied().max().map_or(0, |m| m + 1);
    let mut count = vec![0usize; k];
    let mut first = vec![usize::MAX; k];
    for (i, &j) in z.iter().enumerate() {
        count[j] += 1;
        first[j] = first[j].min(i);
    }
    let mut order: Vec<usize> = (0..k).filter(|&j| count[j] > 0).collect();
    order.sort_by(|&a, &b| count[b].cmp(&count[a]).then(first[a].cmp(&first[b])));
    let mut map = vec![0; k];
    for (new, &old) in order.iter().enumerate() {
        map[old] = new;
    }
    z.iter().map(|&j| map[j]).collect()
}

enum Chain {
    Finite(GibbsState),
    Dp(DpState),
}

impl Chain {
    fn sweep<R: Rng>(&mut self, data: &Dataset, rng: &mut R) {
        match self {
            Chain::Finite(s) => s.sweep(data, rng),
            Chain::Dp(s) => s.sweep(data, rng),
        }
    }
    fn log_joint(&mut self, data: &Dataset) -> f64 {
        match self {
            Chain::Finite(s) => s.log_joint(),
            Chain::Dp(s) => s.log_joint(data),
        }
    }
    fn occupied(&self) -> usize {
        match self {
            Chain::Finite(s) => s.num_occupied(),
            Chain::Dp(s) => s.num_occupied(),
        }
    }
    fn assignments(&self) -> Vec<usize> {
        match self {
            Chain::Finite(s) => s.assignments(),
            Chain::Dp(s) => s.assignments(),
        }
    }
}

fn run_chain(
    data: &Dataset,
    hyper: &Hyperparameters,
    config: &Config,
    chain: usize,
) -> Result<(ChainTrace, Vec<usize>)> {
    let seed = bayes::rng::split(config.seed, chain as u64);
    let mut rng = bayes::rng::seeded(seed);
    let mut state = match &config.nonparametric {
        None => {
            let mut s = GibbsState::new(data, hyper, config.prototypes)?;
            s.initialise(data, &mut rng);
            Chain::Finite(s)
        }
        Some(dp) => {
            let mut s = DpState::new(data, hyper, dp.concentration, dp.auxiliary)?;
            s.initialise(data, &mut rng);
            Chain::Dp(s)
        }
    };
    let total = config.burn_in + config.samples * config.thin;
    let mut trace = ChainTrace {
        seed,
        log_joint: Vec::with_capacity(total),
        occupied: Vec::with_capacity(total),
        best_log_joint: f64::NEG_INFINITY,
    };
    let mut best = Vec::new();
    for sweep in 1..=total {
        state.sweep(data, &mut rng);
        let lj = state.log_joint(data);
        trace.log_joint.push(lj);
        trace.occupied.push(state.occupied());
        let kept = sweep > config.burn_in && (sweep - config.burn_in).is_multiple_of(config.thin);
        if kept && lj > trace.best_log_joint {
            trace.best_log_joint = lj;
            best = state.assignments();
        }
    }
    Ok((trace, best))
}

/// Runs `config.chains` chains on `data` (in parallel on rayon's pool, chain `c` on stream `c` of the
/// seed: results do not depend on thread timing nor on the number of threads) and returns the kept
/// sample with the highest log joint.
pub fn fit(data: &Dataset, hyper: &Hyperparameters, config: &Config) -> Result<Fit> {
    config.validate()?;
    hyper.validate()?;
    use rayon::prelude::*;
    let results: Vec<Result<(ChainTrace, Vec<usize>)>> = (0..config.chains)
        .into_par_iter()
        .map(|c| run_chain(data, hyper, config, c))
        .collect();
    let mut chains = Vec::with_capacity(results.len());
    let mut best: Option<(f64, usize, Vec<usize>)> = None;
    for (c, r) in results.into_iter().enumerate() {
        let (trace, z) = r?;
        if best.as_ref().is_none_or(|b| trace.best_log_joint > b.0) {
            best = Some((trace.best_log_joint, c, z));
        }
        chains.push(trace);
    }
    let (log_joint, selected_chain, z) = best.ok_or_else(|| invalid("config.chains", "no chain ran"))?;
    let post: Vec<Vec<f64>> = chains.iter().map(|t| t.log_joint[config.burn_in..].to_vec()).collect();
    Ok(Fit {
        assignments: canonical_labels(&z),
        log_joint,
        diagnostics: Diagnostics {
            r_hat: gelman_rubin(&post),
            chains,
            selected_chain,
        },
    })
}

/// Posterior of a prototype's hand position: Σ ~ IW(ν_n, Λ_n), μ | Σ ~ N(μ_n, Σ/κ_n).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PositionPosterior {
    /// μ_n (m, object frame) — the point estimate μ̂_j of (6.27).
    pub mean: [f64; 3],
    /// κ_n.
    pub kappa: f64,
    /// ν_n.
    pub dof: f64,
    /// Λ_n (m²).
    pub scale: [[f64; 3]; 3],
    /// E[Σ | data] = Λ_n/(ν_n − 4) — the point estimate Σ̂_j of (6.27).
    pub covariance: [[f64; 3]; 3],
}

/// Posterior of a prototype's appearance scale: ψ ~ Wishart(ν_n, P⁻¹), P = S₀⁻¹ + Σ b⁻¹.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AppearancePosterior {
    /// ν_n = ν_ψ + n u.
    pub dof: f64,
    /// P = S₀⁻¹ + Σ b⁻¹.
    pub precision_sum: [[f64; 2]; 2],
    /// E[ψ | data] = ν_n P⁻¹ (the ψ̂_j of 6.28).
    pub psi_mean: [[f64; 2]; 2],
    /// E[b | ψ = ψ̂] = ψ̂/(u − 3): the typical appearance of the prototype's objects.
    pub typical_appearance: [[f64; 2]; 2],
}

/// A learned visual grasp prototype 𝐂_j = (ψ_j, u_j, μ_j, Σ_j, φ_j) (§6.2), as a posterior.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Prototype {
    /// Number of training grasps assigned (n_j).
    pub count: usize,
    /// Hand position.
    pub position: PositionPosterior,
    /// Training grasps per canonical orientation (n_jw).
    pub orientation_counts: Vec<usize>,
    /// φ̂_j: posterior mean (n_jw + β)/(n_j + Qβ) (6.17).
    pub orientation_probabilities: Vec<f64>,
    /// Appearance.
    pub appearance: AppearancePosterior,
}

/// A learned grasp model: the prototypes of one posterior sample with everything needed to generate
/// pre-grasps and to report how they were learned.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GraspModel {
    /// Always [`MODEL_FORMAT`].
    pub format: String,
    /// Always [`MODEL_VERSION`].
    pub version: u32,
    /// How it was learned.
    pub config: Config,
    /// The hyperparameters used (given or derived from the data).
    pub hyperparameters: Hyperparameters,
    /// The Q canonical orientations.
    pub orientations: CanonicalOrientations,
    /// Training object names, in corpus order.
    pub objects: Vec<String>,
    /// Per object, the prototype of each training grasp (in corpus order).
    pub assignments: Vec<Vec<usize>>,
    /// The occupied prototypes, by decreasing size.
    pub prototypes: Vec<Prototype>,
    /// ln p(z, 𝒟) of the selected sample.
    pub log_joint: f64,
    /// Traces and convergence.
    pub diagnostics: Diagnostics,
}

/// A candidate pre-grasp (palm-surface pose in the object frame: centroid origin, world axes).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PreGrasp {
    /// Prototype it came from (`None` for the naive baseline).
    pub prototype: Option<usize>,
    /// Canonical orientation index (`None` for the naive baseline).
    pub orientation_index: Option<usize>,
    /// Palm-surface position (m, object frame).
    pub position: [f64; 3],
    /// Palm-surface orientation, unit quaternion `[w, x, y, z]` (hand +z = palm normal).
    pub orientation: [f64; 4],
}

impl PreGrasp {
    /// Position as a vector.
    pub fn position(&self) -> Vector3<f64> {
        Vector3::from(self.position)
    }

    /// Orientation as a rotation.
    pub fn orientation(&self) -> UnitQuaternion<f64> {
        let [w, x, y, z] = self.orientation;
        UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, y, z))
    }

    /// Palm-surface pose in the object frame.
    pub fn object_from_palm(&self) -> nalgebra::Isometry3<f64> {
        nalgebra::Isometry3::from_parts(nalgebra::Translation3::from(self.position()), self.orientation())
    }
}

pub(crate) fn quat_array(q: &UnitQuaternion<f64>) -> [f64; 4] {
    let c = q.quaternion();
    [c.w, c.i, c.j, c.k]
}

/// Object × prototype counts of training grasps (Table 6.1).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SharingTable {
    /// Row names (training objects).
    pub objects: Vec<String>,
    /// `counts[m][j]`: grasps of object m assigned to prototype j.
    pub counts: Vec<Vec<usize>>,
}

impl SharingTable {
    /// Number of objects using each prototype (the x's per column of Table 6.1).
    pub fn objects_per_prototype(&self) -> Vec<usize> {
        let k = self.counts.first().map_or(0, |r| r.len());
        (0..k)
            .map(|j| self.counts.iter().filter(|r| r[j] > 0).count())
            .collect()
    }

    /// Fraction of prototypes used by at least two objects (7/10 in the seed's Table 6.1).
    pub fn shared_fraction(&self) -> f64 {
        let per = self.objects_per_prototype();
        if per.is_empty() {
            return 0.0;
        }
        per.iter().filter(|&&c| c >= 2).count() as f64 / per.len() as f64
    }
}

impl std::fmt::Display for SharingTable {
    /// Renders like Table 6.1: one row per object, an `x` where the object uses the prototype.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let k = self.counts.first().map_or(0, |r| r.len());
        let w = self.objects.iter().map(|s| s.len()).max().unwrap_or(0).max(6);
        write!(f, "{:w$}", "object")?;
        for j in 0..k {
            write!(f, " {:>3}", j + 1)?;
        }
        writeln!(f)?;
        for (name, row) in self.objects.iter().zip(&self.counts) {
            write!(f, "{name:w$}")?;
            for &c in row {
                write!(f, " {:>3}", if c > 0 { "x" } else { "" })?;
            }
            writeln!(f)?;
        }
        Ok(())
    }
}

impl GraspModel {
    /// Learns the model from a corpus (§6.4): validates it, learns Q canonical orientations
    /// (k-medoids, seeded), runs the configured sampler and keeps the best posterior sample.
    pub fn learn(corpus: &Corpus, config: &Config) -> Result<Self> {
        corpus.validate()?;
        config.validate()?;
        let quats: Vec<UnitQuaternion<f64>> = corpus
            .objects
            .iter()
            .flat_map(|o| o.grasps.iter().map(|g| g.orientation()))
            .collect();
        let orientations = CanonicalOrientations::learn(&quats, config.orientations, config.seed)?;
        let data = Dataset::from_corpus(corpus, &orientations)?;
        let hyper = match &config.hyperparameters {
            Some(h) => h.clone(),
            None => Hyperparameters::from_data(&data),
        };
        let fit = fit(&data, &hyper, config)?;
        let names = corpus.objects.iter().map(|o| o.name.clone()).collect();
        Self::from_fit(&data, names, orientations, hyper, config.clone(), fit)
    }

    /// Builds the model from a fit on `data` (for callers that build a [`Dataset`] themselves).
    pub fn from_fit(
        data: &Dataset,
        objects: Vec<String>,
        orientations: CanonicalOrientations,
        hyper: Hyperparameters,
        config: Config,
        fit: Fit,
    ) -> Result<Self> {
        if objects.len() != data.num_objects() {
            return Err(GraspError::DimensionMismatch {
                field: "objects (names)".into(),
                expected: data.num_objects(),
                got: objects.len(),
            });
        }
        if orientations.len() != data.num_orientations() {
            return Err(GraspError::DimensionMismatch {
                field: "orientations".into(),
                expected: data.num_orientations(),
                got: orientations.len(),
            });
        }
        let d = Derived::new(&hyper)?;
        let z = &fit.assignments;
        let k = z.iter().copied().max().map_or(0, |m| m + 1);
        let q = data.num_orientations();
        let mut pos = vec![PositionStats::default(); k];
        let mut app = vec![AppearanceStats::default(); k];
        let mut orient = vec![vec![0usize; q]; k];
        let mut assignments = vec![Vec::new(); data.num_objects()];
        for i in 0..data.len() {
            let j = z[i];
            pos[j].add(&data.x[i]);
            app[j].add(&data.b_inv[i], data.ln_det_b[i]);
            orient[j][data.orientation(i)] += 1;
            assignments[data.object(i)].push(j);
        }
        let beta = hyper.beta;
        let prototypes = (0..k)
            .map(|j| {
                let (kn, nun, mun, lam) = pos[j].posterior(&d);
                let (nu_b, pm) = app[j].posterior(&d);
                let psi = inv2(&pm) * nu_b;
                let n = pos[j].n as f64;
                Prototype {
                    count: pos[j].n as usize,
                    position: PositionPosterior {
                        mean: v3a(&mun),
                        kappa: kn,
                        dof: nun,
                        scale: a3(&lam),
                        covariance: a3(&(lam / (nun - DX as f64 - 1.0).max(1e-3))),
                    },
                    orientation_probabilities: orient[j]
                        .iter()
                        .map(|&c| (c as f64 + beta) / (n + q as f64 * beta))
                        .collect(),
                    orientation_counts: orient[j].clone(),
                    appearance: AppearancePosterior {
                        dof: nu_b,
                        precision_sum: a2(&pm),
                        psi_mean: a2(&psi),
                        typical_appearance: a2(&(psi / (d.u - 3.0).max(1e-3))),
                    },
                }
            })
            .collect();
        Ok(Self {
            format: MODEL_FORMAT.into(),
            version: MODEL_VERSION,
            config,
            hyperparameters: hyper,
            orientations,
            objects,
            assignments,
            prototypes,
            log_joint: fit.log_joint,
            diagnostics: fit.diagnostics,
        })
    }

    /// The object × prototype table of training grasps (Table 6.1).
    pub fn sharing_table(&self) -> SharingTable {
        let k = self.prototypes.len();
        let counts = self
            .assignments
            .iter()
            .map(|row| {
                let mut c = vec![0; k];
                for &j in row {
                    if j < k {
                        c[j] += 1;
                    }
                }
                c
            })
            .collect();
        SharingTable {
            objects: self.objects.clone(),
            counts,
        }
    }

    /// p(z = j | b_t) for every prototype (6.28): the collapsed appearance predictive of each
    /// prototype at b_t, normalised, with the seed's uniform p(z = j) over the learned prototypes.
    pub fn prototype_probabilities(&self, appearance: &Matrix2<f64>) -> Result<Vec<f64>> {
        validate_spd2("appearance", &a2(appearance))?;
        let d = Derived::new(&self.hyperparameters)?;
        let bi = inv2(appearance);
        let ld = det2(appearance).ln();
        let mut logw: Vec<f64> = self
            .prototypes
            .iter()
            .map(|p| {
                let c = AppearanceCache::from_posterior(p.appearance.dof, m2(&p.appearance.precision_sum), &d);
                c.log_pred(&bi, ld)
            })
            .collect();
        let m = logw.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let mut s = 0.0;
        for v in logw.iter_mut() {
            *v = (*v - m).exp();
            s += *v;
        }
        Ok(logw.into_iter().map(|v| v / s).collect())
    }

    /// Generates `n` candidate pre-grasps for an object with appearance b_t (6.25–6.28): z_t from
    /// (6.28), w_t ~ Multinomial(φ̂_j) (6.26), x_t ~ Normal(μ̂_j, Σ̂_j) (6.27) with the posterior
    /// means as point estimates.
    pub fn generate<R: Rng + ?Sized>(&self, appearance: &Matrix2<f64>, n: usize, rng: &mut R) -> Result<Vec<PreGrasp>> {
        if n > MAX_GENERATE {
            return Err(invalid(
                "n",
                format!("{n} pre-grasps is above the limit of {MAX_GENERATE}"),
            ));
        }
        let pz = self.prototype_probabilities(appearance)?;
        let chols: Vec<Matrix3<f64>> = self
            .prototypes
            .iter()
            .map(|p| {
                let c = symmetrize(&m3(&p.position.covariance));
                cholesky(&c).unwrap_or_else(|| Matrix3::identity() * 1e-3)
            })
            .collect();
        let mut out = Vec::with_capacity(n);
        for _ in 0..n {
            let j = sample_weights(&pz, rng);
            let p = &self.prototypes[j];
            let w = sample_weights(&p.orientation_probabilities, rng);
            let x = sample_mvn(&Vector3::from(p.position.mean), &chols[j], rng);
            out.push(PreGrasp {
                prototype: Some(j),
                orientation_index: Some(w),
                position: v3a(&x),
                orientation: self.orientations.quaternions[w],
            });
        }
        Ok(out)
    }

    /// Validates the model (format, version, shapes, hyperparameters).
    pub fn validate(&self) -> Result<()> {
        if self.format != MODEL_FORMAT || self.version != MODEL_VERSION {
            return Err(GraspError::UnsupportedFormat {
                what: "grasp model",
                found: format!("{} v{}", self.format, self.version),
                expected: format!("{MODEL_FORMAT} v{MODEL_VERSION}"),
            });
        }
        self.hyperparameters.validate()?;
        CanonicalOrientations::new(self.orientations.quaternions.clone())?;
        if self.prototypes.is_empty() {
            return Err(invalid("prototypes", "a model needs at least one prototype"));
        }
        if self.assignments.len() != self.objects.len() {
            return Err(GraspError::DimensionMismatch {
                field: "assignments (one row per object)".into(),
                expected: self.objects.len(),
                got: self.assignments.len(),
            });
        }
        let q = self.orientations.len();
        for (j, p) in self.prototypes.iter().enumerate() {
            let f = format!("prototypes[{j}]");
            if p.orientation_probabilities.len() != q {
                return Err(GraspError::DimensionMismatch {
                    field: format!("{f}.orientation_probabilities"),
                    expected: q,
                    got: p.orientation_probabilities.len(),
                });
            }
            crate::error::check_finite(|| format!("{f}.position.mean"), &p.position.mean)?;
            validate_spd2(&format!("{f}.appearance.precision_sum"), &p.appearance.precision_sum)?;
            let c = m3(&p.position.covariance);
            if cholesky(&symmetrize(&c)).is_none() {
                return Err(GraspError::NotPositiveDefinite {
                    field: format!("{f}.position.covariance"),
                    reason: "not SPD".into(),
                });
            }
            if p.appearance.dof.is_nan() || p.appearance.dof <= 1.0 {
                return Err(invalid(format!("{f}.appearance.dof"), "must be > 1"));
            }
        }
        let mut assigned = vec![0usize; self.prototypes.len()];
        for (m, row) in self.assignments.iter().enumerate() {
            if let Some(&j) = row.iter().find(|&&j| j >= self.prototypes.len()) {
                return Err(invalid(
                    format!("assignments[{m}]"),
                    format!("prototype {j} does not exist"),
                ));
            }
            for &j in row {
                assigned[j] += 1;
            }
        }
        for (i, name) in self.objects.iter().enumerate() {
            if name.is_empty() || name.chars().any(char::is_control) {
                return Err(invalid(
                    format!("objects[{i}]"),
                    format!("{name:?}: names must be non-empty, without control characters"),
                ));
            }
        }
        // The summaries must agree with the data they summarise.
        for (j, p) in self.prototypes.iter().enumerate() {
            let f = format!("prototypes[{j}]");
            if p.count != assigned[j] {
                return Err(invalid(
                    format!("{f}.count"),
                    format!("{} grasps, but the assignments give it {}", p.count, assigned[j]),
                ));
            }
            if p.orientation_counts.len() != q {
                return Err(GraspError::DimensionMismatch {
                    field: format!("{f}.orientation_counts"),
                    expected: q,
                    got: p.orientation_counts.len(),
                });
            }
            let n: usize = p.orientation_counts.iter().sum();
            if n != p.count {
                return Err(invalid(
                    format!("{f}.orientation_counts"),
                    format!("sum to {n}, the prototype has {} grasps", p.count),
                ));
            }
            let s: f64 = p.orientation_probabilities.iter().sum();
            if p.orientation_probabilities
                .iter()
                .any(|v| !(v.is_finite() && (0.0..=1.0).contains(v)))
                || (s - 1.0).abs() > 1e-6
            {
                return Err(invalid(
                    format!("{f}.orientation_probabilities"),
                    format!("must be probabilities summing to 1 (sum {s})"),
                ));
            }
        }
        Ok(())
    }

    /// Parses and validates a model from JSON.
    pub fn from_json_str(text: &str) -> Result<Self> {
        if let Err(dup) = bayes::input::check_json_keys(text) {
            return Err(invalid(dup.path.clone(), dup.to_string()));
        }
        let m: Self = serde_json::from_str(text).map_err(|source| GraspError::Json {
            what: "grasp model",
            source,
        })?;
        m.validate()?;
        Ok(m)
    }

    /// Pretty JSON.
    pub fn to_json_string(&self) -> Result<String> {
        serde_json::to_string_pretty(self).map_err(|source| GraspError::Json {
            what: "grasp model",
            source,
        })
    }

    /// Reads and validates a model file.
    pub fn load(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        let text = bayes::input::read_text(path).map_err(|source| GraspError::Io {
            path: path.display().to_string(),
            source,
        })?;
        Self::from_json_str(&text).map_err(|e| GraspError::InFile {
            path: path.display().to_string(),
            error: Box::new(e),
        })
    }

    /// Writes the model as JSON.
    pub fn save(&self, path: impl AsRef<Path>) -> Result<()> {
        let path = path.as_ref();
        std::fs::write(path, self.to_json_string()?).map_err(|source| GraspError::Io {
            path: path.display().to_string(),
            source,
        })
    }
}

/// The naive baseline of §6.5.1: `n` pre-grasps on the upper hemisphere (z ≥ 0, object frame)
/// centred at the centroid with radius half the object's longest dimension, palm normal (hand +z)
/// pointing at the centroid, and a uniformly random roll about that ray. `dimensions` are the
/// object's extents (m, any order); positions are uniform on the hemisphere's surface.
pub fn naive_baseline<R: Rng + ?Sized>(dimensions: &Vector3<f64>, n: usize, rng: &mut R) -> Result<Vec<PreGrasp>> {
    crate::error::check_finite(|| "dimensions".into(), dimensions.as_slice())?;
    if n > MAX_GENERATE {
        return Err(invalid(
            "n",
            format!("{n} pre-grasps is above the limit of {MAX_GENERATE}"),
        ));
    }
    if dimensions.iter().any(|&d| d <= 0.0) {
        return Err(invalid(
            "dimensions",
            format!("extents must be > 0, got {dimensions:?}"),
        ));
    }
    let r = 0.5 * dimensions.amax();
    let mut out = Vec::with_capacity(n);
    for _ in 0..n {
        // Uniform on the upper unit hemisphere: cos(polar) ~ U(0, 1], azimuth ~ U[0, 2π).
        let c: f64 = 1.0 - rng.random::<f64>();
        let s = (1.0 - c * c).max(0.0).sqrt();
        let phi = std::f64::consts::TAU * rng.random::<f64>();
        let dir = Vector3::new(s * phi.cos(), s * phi.sin(), c);
        let approach = -dir; // palm normal points at the centroid
        let align = UnitQuaternion::rotation_between(&Vector3::z(), &approach)
            .unwrap_or_else(|| UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI));
        let roll = std::f64::consts::TAU * rng.random::<f64>();
        let rot = align * UnitQuaternion::from_axis_angle(&Vector3::z_axis(), roll);
        out.push(PreGrasp {
            prototype: None,
            orientation_index: None,
            position: v3a(&(dir * r)),
            orientation: quat_array(&rot),
        });
    }
    Ok(out)
}
