//! Prediction (module docs, "Prediction" and "Task relevance"): the posterior over places
//! (5.9)–(5.10) of a new object, averaged over the structures, and its task relevance B₁₀
//! (5.19)–(5.23).

use bayes::bayes_factor::{BayesFactor, log_mixture_marginal, log_place_weights};
use bayes::dirichlet::{CategoryCounts, SymmetricDirichlet};
use bayes::special::log_sum_exp;
use serde::Serialize;

use super::evidence::GroupEvidence;
use super::features::{Features, INPUT};
use super::hyper::{Connectivity, PlacePrior};
use super::model::ProceduralModel;
use super::structure::StructurePosterior;
use crate::error::SchemaError;

/// What every prediction of one model shares ([`ProceduralModel::predictor`]).
#[derive(Debug, Clone)]
pub struct Predictor {
    structures: StructurePosterior,
    log_psi: Vec<f64>,
    /// Each place's colour evidence (P3).
    z: Vec<GroupEvidence>,
    /// The background objects' colour evidence (None: no background objects).
    z_background: Option<GroupEvidence>,
}

/// The task-relevance decision for one object (§5.1.3).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Relevance {
    /// ln p₁(õ), ln p₀(õ) and ln B₁₀ (5.19).
    pub bayes_factor: BayesFactor,
    /// The decision threshold on ln B₁₀.
    pub log_threshold: f64,
    /// ln B₁₀ > threshold.
    pub relevant: bool,
}

/// What the model says about one presented object.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Prediction {
    /// Posterior over places p(q | õ, D) (5.10), in place-name order.
    pub places: Vec<(String, f64)>,
    /// The MAP place q* (5.9).
    pub map_place: String,
    /// Its posterior probability.
    pub map_probability: f64,
    /// Task relevance by B₁₀.
    pub relevance: Relevance,
    /// Which of the object's features were available: (colour, size).
    pub observed: Connectivity,
}

impl ProceduralModel {
    /// ln ψ(k) for the places in order.
    pub(crate) fn log_place_prior(&self) -> Result<Vec<f64>, SchemaError> {
        let k = self.places.len();
        match self.hyper.place_prior {
            PlacePrior::Uniform => Ok(vec![-(k as f64).ln(); k]),
            PlacePrior::Dirichlet { beta } => {
                let prior = SymmetricDirichlet::new(k, beta)?;
                let counts = CategoryCounts::from_counts(self.places.values().map(|p| p.demonstrations).collect())?;
                Ok(log_place_weights(&prior, &counts)?)
            }
        }
    }

    /// Per feature type, ln p(õ_f | place k) for every place and the background ln p₀(õ_f):
    /// `(color_per_place, color_background, size_per_place, size_background)`; a missing feature
    /// scores 0.
    fn feature_scores(
        &self,
        f: &Features,
        z: &[GroupEvidence],
        z_background: Option<&GroupEvidence>,
    ) -> Result<(Vec<f64>, f64, Vec<f64>, f64), SchemaError> {
        let unit = self.hyper.color_unit();
        let draws = self.hyper.draws(f);
        let size = self.hyper.size_unit.value(f);
        let groups: Vec<&GroupEvidence> = z.iter().collect();
        let color_k = unit.log_scores(&groups, &draws);
        let color_bg = match z_background {
            None => unit.log_background(&draws),
            Some(g) => unit.log_scores(&[g], &draws)[0],
        };
        let size_k = self
            .places
            .values()
            .map(|p| size.map_or(0.0, |x| self.size_predictive(&p.size).log_pdf(x)))
            .collect();
        let size_bg = size.map_or(0.0, |x| {
            if self.background.size.n == 0 {
                self.hyper.size_prior.predictive().log_pdf(x)
            } else {
                self.size_predictive(&self.background.size).log_pdf(x)
            }
        });
        Ok((color_k, color_bg, size_k, size_bg))
    }

    /// Posterior over places, MAP place (5.9)–(5.10) and task relevance (5.19)–(5.23) for the
    /// features of a new object, averaged over structures (module docs). Errors: an empty model,
    /// invalid features, or an object with neither feature.
    pub fn predict(&self, features: &Features) -> Result<Prediction, SchemaError> {
        self.predict_with(features, &self.predictor()?)
    }

    /// The model-wide terms every prediction shares — the structure posterior p(S | D), the log
    /// place prior and each place's colour normaliser grid — computed once, for many
    /// [`ProceduralModel::predict_with`] calls in a row (an experiment's test objects, `explain`).
    pub fn predictor(&self) -> Result<Predictor, SchemaError> {
        self.check_nonempty()?;
        let unit = self.hyper.color_unit();
        let z = self
            .places
            .values()
            .map(|p| unit.group(&p.objects.iter().collect::<Vec<_>>()))
            .collect();
        let z_background = if self.background.objects.is_empty() {
            None
        } else {
            Some(unit.group(&self.background.objects.iter().collect::<Vec<_>>()))
        };
        Ok(Predictor {
            structures: self.structure_posterior()?,
            log_psi: self.log_place_prior()?,
            z,
            z_background,
        })
    }

    /// [`ProceduralModel::predict`] with the shared terms from [`ProceduralModel::predictor`] (of
    /// this model, unchanged since).
    pub fn predict_with(&self, features: &Features, predictor: &Predictor) -> Result<Prediction, SchemaError> {
        let Predictor {
            structures,
            log_psi,
            z,
            z_background,
        } = predictor;
        if log_psi.len() != self.places.len() || z.len() != self.places.len() {
            return Err(SchemaError::invalid(
                INPUT,
                "predictor",
                "was computed for another model (the number of places differs)",
            ));
        }
        let draws = self.hyper.draws(features);
        let size = self.hyper.size_unit.value(features);
        if draws.is_empty() && size.is_none() {
            return Err(SchemaError::invalid(
                INPUT,
                "features",
                "no colour terms and no size: nothing to predict from",
            ));
        }
        let (color_k, color_bg, size_k, size_bg) = self.feature_scores(features, z, z_background.as_ref())?;
        let k = log_psi.len();
        // Joint log weights over (structure, place).
        let mut log_place = vec![Vec::with_capacity(structures.structures.len()); k];
        let mut log_task_terms = Vec::with_capacity(4);
        for s in &structures.structures {
            if s.probability <= 0.0 {
                continue;
            }
            let c = s.connectivity;
            let lik: Vec<f64> = (0..k)
                .map(|i| (if c.color { color_k[i] } else { color_bg }) + (if c.size { size_k[i] } else { size_bg }))
                .collect();
            let log_ps = s.probability.ln();
            let marg = log_mixture_marginal(log_psi, &lik)?;
            log_task_terms.push(log_ps + marg);
            for i in 0..k {
                log_place[i].push(log_ps + log_psi[i] + lik[i]);
            }
        }
        let log_p1 = log_sum_exp(&log_task_terms);
        let per_place: Vec<f64> = log_place.iter().map(|v| log_sum_exp(v)).collect();
        let z = log_sum_exp(&per_place);
        let places: Vec<(String, f64)> = self
            .places
            .keys()
            .zip(&per_place)
            .map(|(n, &l)| (n.clone(), if z.is_finite() { (l - z).exp() } else { 1.0 / k as f64 }))
            .collect();
        let (map_place, map_probability) = places
            .iter()
            .fold(None::<&(String, f64)>, |best, p| match best {
                Some(b) if b.1 >= p.1 => Some(b),
                _ => Some(p),
            })
            .map(|(n, p)| (n.clone(), *p))
            .unwrap_or_default();
        let log_p0 = color_bg + size_bg;
        let bayes_factor = BayesFactor::new(log_p1, log_p0)?;
        let t = self.hyper.relevance_log_threshold;
        Ok(Prediction {
            places,
            map_place,
            map_probability,
            relevance: Relevance {
                bayes_factor,
                log_threshold: t,
                relevant: bayes_factor.log_b10 > t,
            },
            observed: Connectivity {
                color: !draws.is_empty(),
                size: size.is_some(),
            },
        })
    }
}
