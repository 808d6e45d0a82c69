//! Feature selection (module docs, "Feature selection"): the posterior p(S | D) over the four
//! connectivity structures from their closed-form marginal likelihoods.

use bayes::special::log_sum_exp;
use serde::Serialize;

use super::hyper::{Connectivity, FeatureType, StructureChoice};
use super::model::ProceduralModel;
use crate::error::SchemaError;

/// The posterior over connectivity structures p(S | D).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StructurePosterior {
    /// (structure, ln p(D | S), posterior probability), in [`Connectivity::ALL`] order.
    pub structures: Vec<StructureScore>,
}

/// One structure's evidence.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct StructureScore {
    /// The structure.
    pub connectivity: Connectivity,
    /// ln p(D | S): the marginal likelihood of the demonstrations' features.
    pub log_evidence: f64,
    /// p(S | D).
    pub probability: f64,
}

impl StructurePosterior {
    /// The most probable structure (the first on ties).
    pub fn map(&self) -> Connectivity {
        self.structures
            .iter()
            .fold(None::<&StructureScore>, |best, s| match best {
                Some(b) if b.probability >= s.probability => Some(b),
                _ => Some(s),
            })
            .map_or(Connectivity::ALL[0], |s| s.connectivity)
    }

    /// p(feature type connects to the place | D): the sum over structures that connect it.
    pub fn feature_probability(&self, f: FeatureType) -> f64 {
        self.structures
            .iter()
            .filter(|s| s.connectivity.connects(f))
            .map(|s| s.probability)
            .sum()
    }

    /// The probability of the MAP structure.
    pub fn map_probability(&self) -> f64 {
        let m = self.map();
        self.structures
            .iter()
            .find(|s| s.connectivity == m)
            .map_or(0.0, |s| s.probability)
    }
}

impl ProceduralModel {
    /// ln p(D_f | one shared distribution) and Σₖ ln p(D_f,k) for both feature types:
    /// `[[color pooled, color split], [size pooled, size split]]`.
    fn feature_evidence(&self) -> Result<[[f64; 2]; 2], SchemaError> {
        let unit = self.hyper.color_unit();
        let nig = &self.hyper.size_prior;
        let q = self.hyper.size_unit.quanta_per_unit();
        let pooled = self.pooled()?;
        let mut size_split = 0.0;
        let mut z_split = Vec::with_capacity(self.places.len());
        for p in self.places.values() {
            z_split.push(unit.log_z_grid(&p.objects.iter().collect::<Vec<_>>()));
            size_split += nig.log_marginal_likelihood(&p.size.gaussian(q));
        }
        let z_pooled = unit.log_z_grid(&pooled.objects.iter().collect::<Vec<_>>());
        Ok([
            [unit.log_evidence(&[z_pooled]), unit.log_evidence(&z_split)],
            [nig.log_marginal_likelihood(&pooled.size.gaussian(q)), size_split],
        ])
    }

    /// Feature selection: the posterior over the four connectivity structures (module docs). With
    /// a fixed structure the posterior is 1 on it. Errors: an empty model.
    pub fn structure_posterior(&self) -> Result<StructurePosterior, SchemaError> {
        self.check_nonempty()?;
        let ev = self.feature_evidence()?;
        let log_evidence: Vec<f64> = Connectivity::ALL
            .iter()
            .map(|c| ev[0][usize::from(c.color)] + ev[1][usize::from(c.size)])
            .collect();
        let prior: [f64; 4] = match self.hyper.structure {
            StructureChoice::Inferred => self.hyper.structure_prior,
            StructureChoice::Fixed(c) => {
                let mut p = [0.0; 4];
                p[c.index()] = 1.0;
                p
            }
        };
        let log_joint: Vec<f64> = log_evidence.iter().zip(prior).map(|(l, p)| l + p.ln()).collect();
        let z = log_sum_exp(&log_joint);
        Ok(StructurePosterior {
            structures: Connectivity::ALL
                .iter()
                .enumerate()
                .map(|(i, &connectivity)| StructureScore {
                    connectivity,
                    log_evidence: log_evidence[i],
                    probability: if log_joint[i] == f64::NEG_INFINITY {
                        0.0
                    } else {
                        (log_joint[i] - z).exp()
                    },
                })
                .collect(),
        })
    }
}
