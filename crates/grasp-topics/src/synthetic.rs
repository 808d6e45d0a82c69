//! Simulation from the generative model (6.9–6.13): synthetic corpora with known prototypes for
//! tests and benches, and the conditional draws a Geweke joint-distribution test needs.

use nalgebra::{Matrix2, Matrix3, Vector3};
use rand::Rng;

use crate::corpus::{Corpus, DemoGrasp};
use crate::data::Dataset;
use crate::error::{GraspError, Result, invalid};
use crate::math::{
    a2, cholesky, dirichlet_into, dirichlet_symmetric_into, inv2, sample_inv_wishart, sample_mvn, sample_weights,
    sample_wishart,
};
use crate::orientation::CanonicalOrientations;
use crate::prior::{Derived, Hyperparameters};
use crate::stats::{AppearanceStats, PositionStats};

/// The parameters of one prototype, 𝐂_j = (ψ_j, μ_j, Σ_j, φ_j) (u is shared).
#[derive(Debug, Clone, PartialEq)]
pub struct PrototypeParams {
    /// μ_j (m, object frame).
    pub mean: Vector3<f64>,
    /// Σ_j (m², SPD).
    pub covariance: Matrix3<f64>,
    /// ψ_j (SPD): b ~ Inv-Wishart(u, ψ_j).
    pub psi: Matrix2<f64>,
    /// φ_j over the Q canonical orientations.
    pub orientation_probabilities: Vec<f64>,
}

/// What to simulate.
#[derive(Debug, Clone, PartialEq)]
pub struct SyntheticSpec {
    /// Number of objects M.
    pub objects: usize,
    /// Grasps per object N.
    pub grasps_per_object: usize,
    /// α of θ_m ~ Dirichlet(α) (6.9).
    pub alpha: f64,
    /// u: b ~ Inv-Wishart(u, ψ_j) (6.11).
    pub appearance_dof: f64,
    /// The true prototypes (A = their number; all with the same Q).
    pub prototypes: Vec<PrototypeParams>,
}

/// A simulated dataset and the true assignment of every datum.
#[derive(Debug, Clone)]
pub struct Synthetic {
    /// The data.
    pub data: Dataset,
    /// True prototype per datum.
    pub truth: Vec<usize>,
}

/// Prototypes that are easy to tell apart: means 12 cm from the centroid spread over the upper
/// hemisphere, 1 cm standard deviation, appearance scales spread over a factor of ~10, and φ putting
/// 90% on one orientation (prototype j prefers orientation j mod Q).
pub fn well_separated_prototypes(a: usize, q: usize, u: f64) -> Vec<PrototypeParams> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..a)
        .map(|j| {
            // Fibonacci points on the upper hemisphere.
            let zc = 1.0 - (j as f64 + 0.5) / a as f64;
            let r = (1.0 - zc * zc).sqrt();
            let th = golden * j as f64;
            let mean = Vector3::new(r * th.cos(), r * th.sin(), zc) * 0.12;
            let scale = 10f64.powf(j as f64 / a.max(1) as f64);
            let ecc = 0.5 + (j % 3) as f64 * 0.5;
            let b_mean = Matrix2::new(scale, 0.1 * scale, 0.1 * scale, scale * ecc) * 1e-3;
            let mut phi = vec![0.1 / (q as f64 - 1.0).max(1.0); q];
            phi[j % q] = if q == 1 { 1.0 } else { 0.9 };
            PrototypeParams {
                mean,
                covariance: Matrix3::identity() * 1e-4,
                psi: b_mean * (u - 3.0),
                orientation_probabilities: phi,
            }
        })
        .collect()
}

/// Draws A prototypes from the prior G₀ given by `hyper`.
pub fn prior_prototypes<R: Rng + ?Sized>(
    hyper: &Hyperparameters,
    a: usize,
    q: usize,
    rng: &mut R,
) -> Result<Vec<PrototypeParams>> {
    let d = Derived::new(hyper)?;
    Ok((0..a)
        .map(|_| {
            draw_posterior(
                &d,
                hyper.beta,
                &PositionStats::default(),
                &AppearanceStats::default(),
                &vec![0; q],
                rng,
            )
        })
        .collect())
}

fn draw_posterior<R: Rng + ?Sized>(
    d: &Derived,
    beta: f64,
    pos: &PositionStats,
    app: &AppearanceStats,
    orient: &[usize],
    rng: &mut R,
) -> PrototypeParams {
    let (kn, nun, mun, lam) = pos.posterior(d);
    let sigma = sample_inv_wishart(nun, &lam, rng);
    let l = cholesky(&sigma).unwrap_or_else(Matrix3::identity);
    let mean = sample_mvn(&mun, &(l / kn.sqrt()), rng);
    let (nu_psi, pm) = app.posterior(d);
    let pl = cholesky(&inv2(&pm)).unwrap_or_else(Matrix2::identity);
    let psi = sample_wishart(nu_psi, &pl, rng);
    let alpha: Vec<f64> = orient.iter().map(|&c| beta + c as f64).collect();
    let mut phi = vec![0.0; orient.len()];
    dirichlet_into(&alpha, &mut phi, rng);
    PrototypeParams {
        mean,
        covariance: sigma,
        psi,
        orientation_probabilities: phi,
    }
}

/// Draws every prototype's parameters from their conjugate posterior given the data assigned to it
/// by `z` (prototypes with no data: from the prior). `z[i] < a`.
pub fn posterior_prototypes<R: Rng + ?Sized>(
    data: &Dataset,
    z: &[usize],
    hyper: &Hyperparameters,
    a: usize,
    rng: &mut R,
) -> Result<Vec<PrototypeParams>> {
    let d = Derived::new(hyper)?;
    if z.len() != data.len() {
        return Err(GraspError::DimensionMismatch {
            field: "assignments".into(),
            expected: data.len(),
            got: z.len(),
        });
    }
    let q = data.num_orientations();
    let mut pos = vec![PositionStats::default(); a];
    let mut app = vec![AppearanceStats::default(); a];
    let mut orient = vec![vec![0usize; q]; a];
    for (i, &j) in z.iter().enumerate() {
        if j >= a {
            return Err(invalid(format!("assignments[{i}]"), format!("{j} is not < A = {a}")));
        }
        pos[j].add(&data.x[i]);
        app[j].add(&data.b_inv[i], data.ln_det_b[i]);
        orient[j][data.orientation(i)] += 1;
    }
    Ok((0..a)
        .map(|j| draw_posterior(&d, hyper.beta, &pos[j], &app[j], &orient[j], rng))
        .collect())
}

fn draw_datum<R: Rng + ?Sized>(p: &PrototypeParams, u: f64, rng: &mut R) -> (Vector3<f64>, Matrix2<f64>, usize) {
    let l = cholesky(&p.covariance).unwrap_or_else(Matrix3::identity);
    let x = sample_mvn(&p.mean, &l, rng);
    let b = sample_inv_wishart(u, &p.psi, rng);
    let w = sample_weights(&p.orientation_probabilities, rng);
    (x, b, w)
}

/// Redraws every datum's (x, b, w) from its assigned prototype's parameters (z fixed).
pub fn redraw_data<R: Rng + ?Sized>(
    data: &mut Dataset,
    z: &[usize],
    prototypes: &[PrototypeParams],
    appearance_dof: f64,
    rng: &mut R,
) -> Result<()> {
    for (i, &j) in z.iter().enumerate() {
        let p = prototypes
            .get(j)
            .ok_or_else(|| invalid(format!("assignments[{i}]"), format!("no prototype {j}")))?;
        let (x, b, w) = draw_datum(p, appearance_dof, rng);
        data.set_datum(i, x, b, w)?;
    }
    Ok(())
}

/// Simulates a dataset: per object θ_m ~ Dirichlet(α) (6.9), per grasp z ~ θ_m (6.10), then b, w, x
/// from the prototype (6.11–6.13).
pub fn sample_dataset<R: Rng + ?Sized>(spec: &SyntheticSpec, rng: &mut R) -> Result<Synthetic> {
    let a = spec.prototypes.len();
    if a == 0 || spec.objects == 0 || spec.grasps_per_object == 0 {
        return Err(invalid("synthetic spec", "needs prototypes, objects and grasps"));
    }
    let q = spec.prototypes[0].orientation_probabilities.len();
    let mut theta = vec![0.0; a];
    let (mut object, mut xs, mut bs, mut ws, mut truth) = (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for m in 0..spec.objects {
        dirichlet_symmetric_into(spec.alpha, &mut theta, rng);
        for _ in 0..spec.grasps_per_object {
            let j = sample_weights(&theta, rng);
            let (x, b, w) = draw_datum(&spec.prototypes[j], spec.appearance_dof, rng);
            object.push(m);
            xs.push(x);
            bs.push(b);
            ws.push(w);
            truth.push(j);
        }
    }
    Ok(Synthetic {
        data: Dataset::new(&object, &xs, &bs, &ws, spec.objects, q)?,
        truth,
    })
}

impl Synthetic {
    /// A corpus with the same data: object `m` is named `obj-m`, each grasp carries its own
    /// appearance, and its orientation is canonical orientation w rotated by a small random angle
    /// (≤ `jitter_rad` about a random axis).
    pub fn to_corpus<R: Rng + ?Sized>(
        &self,
        canonical: &CanonicalOrientations,
        jitter_rad: f64,
        rng: &mut R,
    ) -> Corpus {
        let mut corpus = Corpus::new();
        let mut per_object: Vec<Vec<DemoGrasp>> = vec![Vec::new(); self.data.num_objects()];
        let mut first_b: Vec<Option<Matrix2<f64>>> = vec![None; self.data.num_objects()];
        for i in 0..self.data.len() {
            let m = self.data.object(i);
            let base = canonical
                .get(self.data.orientation(i) % canonical.len().max(1))
                .unwrap_or_else(nalgebra::UnitQuaternion::identity);
            let axis = Vector3::new(
                crate::math::std_normal(rng),
                crate::math::std_normal(rng),
                crate::math::std_normal(rng),
            );
            let jitter = nalgebra::UnitQuaternion::from_scaled_axis(
                axis.normalize() * jitter_rad * rand::RngExt::random::<f64>(rng),
            );
            let mut g = DemoGrasp::new(&self.data.position(i), &(base * jitter));
            g.appearance = Some(a2(&self.data.appearance(i)));
            first_b[m].get_or_insert(self.data.appearance(i));
            per_object[m].push(g);
        }
        for (m, grasps) in per_object.into_iter().enumerate() {
            if grasps.is_empty() {
                continue;
            }
            corpus.push_object(
                format!("obj-{m}"),
                &first_b[m].unwrap_or_else(Matrix2::identity),
                grasps,
            );
        }
        corpus
    }
}
