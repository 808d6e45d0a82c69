//! What the robot tells the teacher (§5.2): per place, the predictive colour pmf and size density
//! in plain words, which features matter and how sure it is; and synthetic task instances drawn
//! from the posterior predictive p(D̃ | D) so that the teacher can judge whether to demonstrate more.

use rand::Rng;

use serde::Serialize;

use super::features::{COLORS, Features, MAX_DIMENSION};
use super::hyper::{Connectivity, FeatureType, PlacePrior, SizeUnit};
use super::model::ProceduralModel;
use super::stats::PlaceStats;
use super::structure::StructurePosterior;
use crate::error::SchemaError;
use crate::percept::{COLOR_TERM_HSV, COLOR_TERMS};

/// A representative HSV colour (hue in degrees, s and v in [0, 1]) of colour term `term`, for
/// drawing; out-of-range terms are black.
pub fn term_hsv(term: usize) -> [f64; 3] {
    COLOR_TERM_HSV.get(term).copied().unwrap_or([0.0, 0.0, 0.0])
}

/// The name of colour term `term` (`"red"`, `"grey"`, …; `"?"` out of range).
pub fn color_name(term: usize) -> &'static str {
    COLOR_TERMS.get(term).copied().unwrap_or("?")
}

/// One colour term's predictive probability.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ColorMass {
    /// Term index ([`COLOR_TERMS`]).
    pub term: u8,
    /// Its name ([`color_name`]).
    pub name: String,
    /// Its representative HSV ([`term_hsv`]; hue in degrees, s and v in [0, 1]).
    pub hsv: [f64; 3],
    /// Predictive probability (5.18).
    pub probability: f64,
}

/// What was learned about one place.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PlaceExplanation {
    /// Place name.
    pub name: String,
    /// Demonstrations seen.
    pub demonstrations: u64,
    /// The most probable colours of its predictive pmf (up to 5, those above uniform).
    pub top_colors: Vec<ColorMass>,
    /// The whole predictive colour pmf over the colour terms.
    pub color_pmf: Vec<f64>,
    /// Predictive size location (in [`Explanation::size_unit`]).
    pub size_mean: f64,
    /// Predictive size standard deviation (in [`Explanation::size_unit`]; the Student-t scale when
    /// ν ≤ 2).
    pub size_sd: f64,
    /// Degrees of freedom ν of the Student-t size predictive.
    pub size_df: f64,
    /// Probability that a new object drawn from this place's predictive is put back here.
    pub consistency: f64,
    /// One sentence.
    pub sentence: String,
}

/// The model in plain words.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Explanation {
    /// The posterior over structures (feature selection).
    pub structure: StructurePosterior,
    /// Name of the MAP structure.
    pub map_structure: String,
    /// p(colour decides the place | D).
    pub color_matters: f64,
    /// p(size decides the place | D).
    pub size_matters: f64,
    /// Per place.
    pub places: Vec<PlaceExplanation>,
    /// Mean of the places' consistencies: how sure the model is of its own sorting.
    pub consistency: f64,
    /// The unit of the sizes (`cm` or `deci-pixels`).
    pub size_unit: String,
    /// Objects the teacher left alone that the relevance background M₀ is fitted to.
    pub background_objects: usize,
    /// The whole story, several lines.
    pub text: String,
}

/// A synthetic task instance drawn from the posterior predictive.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SyntheticInstance {
    /// The place it belongs to.
    pub place: String,
    /// The structure it was drawn under.
    pub structure: Connectivity,
    /// Its features (colour bins with their drawn weights, equal pixels in both cameras).
    pub features: Features,
}

/// Monte-Carlo draws per place for the consistency figure.
const CONSISTENCY_DRAWS: usize = 200;

/// See [`ProceduralModel::sampler`].
struct Sampler<'a> {
    structures: StructurePosterior,
    pooled: PlaceStats,
    theta_pooled: Vec<f64>,
    places: Vec<(&'a str, &'a PlaceStats)>,
    theta: Vec<Vec<f64>>,
}

/// Synthetic objects drawn over all places for the consistency figures: each place gets
/// `CONSISTENCY_TOTAL / places` of them (at most [`CONSISTENCY_DRAWS`], at least
/// [`CONSISTENCY_MIN_DRAWS`]). A prediction scores the object against every place with the exact
/// colour evidence (P5), so it costs O(places); with the draws shared out, explaining costs
/// O(places) predictions' worth up to 40 places and O(places²) beyond (measured: 8 places 1.2 s,
/// 100 places ~40 s, the limit [`super::MAX_PLACES`](super::model::MAX_PLACES)), instead of 200 predictions per place, each
/// re-deriving the model-wide posterior (8 places took 23 s).
const CONSISTENCY_TOTAL: usize = 400;

/// The fewest synthetic objects per place.
const CONSISTENCY_MIN_DRAWS: usize = 10;

fn sureness(p: f64) -> &'static str {
    if p >= 0.95 {
        "very sure"
    } else if p >= 0.8 {
        "fairly sure"
    } else if p >= 0.6 {
        "unsure — more demonstrations would help"
    } else {
        "guessing — please demonstrate more"
    }
}

/// The at most `k` most probable colour terms of `pmf` that are above uniform, most probable first
/// (ties by term).
fn top_terms(pmf: &[f64], k: usize) -> Vec<usize> {
    let mut order: Vec<usize> = (0..COLORS).collect();
    order.sort_by(|&a, &b| pmf[b].total_cmp(&pmf[a]).then(a.cmp(&b)));
    order
        .into_iter()
        .take(k)
        .filter(|&b| pmf[b] > 1.0 / COLORS as f64)
        .collect()
}

fn categorical<R: Rng + ?Sized>(rng: &mut R, w: &[f64]) -> usize {
    use rand::RngExt;
    let total: f64 = w.iter().sum();
    let u = rng.random::<f64>() * total;
    let mut acc = 0.0;
    for (i, &x) in w.iter().enumerate() {
        acc += x;
        if u < acc {
            return i;
        }
    }
    w.len().saturating_sub(1)
}

impl ProceduralModel {
    /// Draws `n` synthetic task instances from the posterior predictive (§5.2): a structure from
    /// p(S | D), a place from ψ, then colour bins (as many as the place's demonstrations kept on
    /// average, drawn without replacement from a posterior draw of θ) and a size from the Student-t
    /// predictive — connected features from the place's statistics, the others from all places'.
    pub fn sample_instances<R: Rng + ?Sized>(
        &self,
        rng: &mut R,
        n: usize,
    ) -> Result<Vec<SyntheticInstance>, SchemaError> {
        let sampler = self.sampler(self.structure_posterior()?)?;
        let psi: Vec<f64> = self.log_place_prior()?.iter().map(|l| l.exp()).collect();
        let mut out = Vec::with_capacity(n);
        for _ in 0..n {
            let k = categorical(rng, &psi);
            out.push(self.sample_instance_at(rng, k, &sampler)?);
        }
        Ok(out)
    }

    /// What every synthetic instance shares: the structure posterior, the pooled statistics and the
    /// colour predictives (5.18) of each place and of all places pooled — each an exact but costly
    /// sum over the concentration grid, so computed once.
    fn sampler(&self, structures: StructurePosterior) -> Result<Sampler<'_>, SchemaError> {
        let unit = self.hyper.color_unit();
        let pooled = self.pooled()?;
        Ok(Sampler {
            structures,
            theta_pooled: unit.predictive(&pooled.objects),
            pooled,
            places: self.places.iter().map(|(n, p)| (n.as_str(), p)).collect(),
            theta: self.places.values().map(|p| unit.predictive(&p.objects)).collect(),
        })
    }

    fn sample_instance_at<R: Rng + ?Sized>(
        &self,
        rng: &mut R,
        k: usize,
        sampler: &Sampler<'_>,
    ) -> Result<SyntheticInstance, SchemaError> {
        let structures = &sampler.structures;
        let probs: Vec<f64> = structures.structures.iter().map(|s| s.probability).collect();
        let structure = structures.structures[categorical(rng, &probs)].connectivity;
        let (place, own) = sampler.places[k];
        let pooled = &sampler.pooled;
        let color_src = if structure.color { own } else { pooled };
        let size_src = if structure.size { own } else { pooled };
        // The colour pmf of the synthetic object: the place's predictive (5.18) (the posterior mean
        // of its colour distribution).
        let theta = if structure.color {
            &sampler.theta[k]
        } else {
            &sampler.theta_pooled
        };
        // As many draws as a demonstrated object gives, with replacement; the histogram is their
        // shares (the kept bins of a synthetic object).
        let per_demo = color_src.color.total() as f64 / color_src.demonstrations.max(1) as f64;
        let m = (per_demo.round() as usize).clamp(1, 1000);
        let mut counts = [0u32; COLORS];
        for _ in 0..m {
            counts[categorical(rng, theta)] += 1;
        }
        let colors: Vec<(u8, f64)> = counts
            .iter()
            .enumerate()
            .filter(|c| *c.1 > 0)
            .map(|(b, &c)| (b as u8, f64::from(c) / m as f64))
            .collect();
        let x = self
            .hyper
            .size_prior
            .posterior(&size_src.size.gaussian(self.hyper.size_unit.quanta_per_unit()))
            .sample_predictive(rng)
            .max(0.1);
        // The sampled size in the model's unit: a segment of that many pixels per camera, or a
        // cube whose sides have that geometric mean.
        let (px, dimensions) = match self.hyper.size_unit {
            SizeUnit::DeciPixels => ((x * 10.0).round().clamp(1.0, f64::from(u32::MAX)) as u32, None),
            SizeUnit::Centimetres => (1, Some([(x / 100.0).min(MAX_DIMENSION); 3])),
        };
        Ok(SyntheticInstance {
            place: place.to_string(),
            structure,
            features: Features {
                histogram: Vec::new(),
                pixels: [px, px],
                colors,
                dimensions,
            },
        })
    }

    /// What the model has learned, in plain words (see [`Explanation`]). Deterministic (its
    /// Monte-Carlo consistency figure uses a fixed seed). Errors: an empty model.
    pub fn explain(&self) -> Result<Explanation, SchemaError> {
        let structure = self.structure_posterior()?;
        let map = structure.map();
        let color_matters = structure.feature_probability(FeatureType::Color);
        let size_matters = structure.feature_probability(FeatureType::Size);
        let mut rng = bayes::rng::seeded(0x05EE_D512);
        let mut places = Vec::new();
        let predictor = self.predictor()?;
        let sampler = self.sampler(structure.clone())?;
        let draws = (CONSISTENCY_TOTAL / self.places.len().max(1)).clamp(CONSISTENCY_MIN_DRAWS, CONSISTENCY_DRAWS);
        for (k, (name, p)) in self.places.iter().enumerate() {
            let pmf = self.color_pmf(name)?;
            let top_colors: Vec<ColorMass> = top_terms(&pmf, 5)
                .into_iter()
                .map(|b| ColorMass {
                    term: b as u8,
                    name: color_name(b).to_string(),
                    hsv: term_hsv(b),
                    probability: pmf[b],
                })
                .collect();
            let t = self.size_density(name)?;
            let size_sd = if t.df() > 2.0 {
                t.scale() * (t.df() / (t.df() - 2.0)).sqrt()
            } else {
                t.scale()
            };
            let mut hits = 0usize;
            for _ in 0..draws {
                let inst = self.sample_instance_at(&mut rng, k, &sampler)?;
                if self.predict_with(&inst.features, &predictor)?.map_place == *name {
                    hits += 1;
                }
            }
            let consistency = hits as f64 / draws as f64;
            let colors = if top_colors.is_empty() {
                "no particular colour".to_string()
            } else {
                top_colors
                    .iter()
                    .map(|c| format!("{} ({:.2})", c.name, c.probability))
                    .collect::<Vec<_>>()
                    .join(", ")
            };
            let sentence = format!(
                "{name} ({} demonstration{}): colours mostly {colors}; size {:.0} ± {:.0} {}; \
                 a new object like these goes here with probability {consistency:.2} ({}).",
                p.demonstrations,
                if p.demonstrations == 1 { "" } else { "s" },
                t.loc(),
                size_sd,
                self.hyper.size_unit.name(),
                sureness(consistency),
            );
            places.push(PlaceExplanation {
                name: name.clone(),
                demonstrations: p.demonstrations,
                top_colors,
                color_pmf: pmf,
                size_mean: t.loc(),
                size_sd,
                size_df: t.df(),
                consistency,
                sentence,
            });
        }
        let consistency = places.iter().map(|p| p.consistency).sum::<f64>() / places.len().max(1) as f64;
        let matters = |what: &str, p: f64| {
            if p >= 0.5 {
                format!("{what} decides the place (p = {p:.2})")
            } else {
                format!("{what} does not matter (p = {:.2} that it does)", p)
            }
        };
        let mut text = format!(
            "Learned from {} demonstration{} at {} place{}. {}; {}. Most likely structure: {} ({:.2}).\n",
            self.num_demonstrations(),
            if self.num_demonstrations() == 1 { "" } else { "s" },
            self.places.len(),
            if self.places.len() == 1 { "" } else { "s" },
            matters("Colour", color_matters),
            matters("size", size_matters),
            map.name(),
            structure.map_probability(),
        );
        if matches!(self.hyper.place_prior, PlacePrior::Uniform) {
            text.push_str("Every place is equally likely a priori.\n");
        }
        for p in &places {
            text.push_str("  ");
            text.push_str(&p.sentence);
            text.push('\n');
        }
        let background = self.background.objects.len();
        if background > 0 {
            let pmf = self.hyper.color_unit().predictive(&self.background.objects);
            let colors: Vec<String> = top_terms(&pmf, 4)
                .into_iter()
                .map(|b| format!("{} ({:.2})", color_name(b), pmf[b]))
                .collect();
            text.push_str(&format!(
                "  Left alone by the teacher ({background} object{}, what task relevance is weighed against): colours mostly {}.\n",
                if background == 1 { "" } else { "s" },
                if colors.is_empty() { "no particular colour".to_string() } else { colors.join(", ") }
            ));
        }
        text.push_str(&format!(
            "Overall {} of its own sorting (consistency {consistency:.2}).\n",
            sureness(consistency)
        ));
        Ok(Explanation {
            map_structure: map.name().to_string(),
            structure,
            color_matters,
            size_matters,
            places,
            consistency,
            size_unit: self.hyper.size_unit.name().to_string(),
            background_objects: background,
            text,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colour_names() {
        assert_eq!(color_name(0), "black");
        assert_eq!(color_name(2), "white");
        assert_eq!(color_name(3), "red");
        assert_eq!(color_name(99), "?");
        assert_eq!(term_hsv(7)[0], 220.0);
    }
}
