//! The procedural policy ψ of Sweeney (2011), ch. 5: which place (task-dependent reference) an
//! object goes to, learned from a few demonstrations as a generative Bayesian feature model, and
//! which arm(s) carry it there.
//!
//! # The model (§5.1.1 and its general form §5.3, Fig. 5.16)
//!
//! The task-dependent reference of Pick-And-Place is the place r_P. It gets a latent category
//! q ∈ {1..K}, one value per demonstrated place (5.5)–(5.6). Each feature type has a *feature unit*
//! (§5.3.4):
//!
//! * **colour** — the kept bins of the object's 64-bin HSV histogram (the 20th-percentile rule of
//!   §5.1.2.1), shared out as `D` weighted draws ([`Features::color_draws`]) and mapped to 8
//!   *colour classes* (black, three greys, and the four hues; [`color_class_bin`]): shading moves
//!   a surface's pixels across the value and saturation bins, not across hues. **Departure from
//!   the seed** (whose (5.16)–(5.18) treat every colour observation of every object as an
//!   independent draw from the place's one distribution): the draws of one object are one surface,
//!   not independent evidence about the place, so the unit has two levels —
//!
//!   ```text
//!   (P1)  π_k ~ Dirichlet(α·m)            the colour distribution of place k (m: base measure)
//!   (P2)  θ_i ~ Dirichlet(a·π_k)           object i's own colours, around its place's
//!         x_i ~ Multinomial(D, θ_i)        its D draws (counts x_il per colour l)
//!   ```
//!
//!   with the object concentration a on a small grid, equally likely a priori
//!   ([`Hyper::color_object_concentrations`]), shared by the places of one structure. Integrating
//!   θ_i gives the Pólya factor Γ(a)/Γ(a+D) Πₗ Γ(aπₗ+xᵢₗ)/Γ(aπₗ), and expanding each rising
//!   factorial Γ(aπ+x)/Γ(aπ) = Σₜ s(x,t) (aπ)ᵗ (unsigned Stirling numbers of the first kind; t
//!   = the "tables" of colour l in object i, the draws of that object that were fresh picks from π)
//!   makes π integrable against (P1): with Tₗ = Σᵢ tᵢₗ and T = Σₗ Tₗ,
//!
//!   ```text
//!   (P3)  Z(X; a) = p(x_1..x_n | a) = Πᵢ Γ(a)/Γ(a+D)
//!                   · Σ_T Q(T) Γ(α)/Γ(α+T),
//!         Q = ⊛ₗ qₗ,  qₗ(Tₗ) = [zᵀˡ] Πᵢ (Σₜ s(xᵢₗ,t) aᵗ zᵗ) · Γ(αmₗ+Tₗ)/Γ(αmₗ)
//!   ```
//!
//!   — exact, a product of polynomials (in logs) per colour convolved across colours, O((nD)²).
//!   The evidence of objects X_1..X_K split over K places sharing a is
//!   `(P4)  Σ_a p(a) Πₖ Z(X_k; a)`, and the predictive of a new object õ in place k is
//!   `(P5)  p(õ | k, D) = Σ_a p(a) Πⱼ Z(X_j; a) · Z(X_k ∪ õ; a)/Z(X_k; a)  /  Σ_a p(a) Πⱼ Z(X_j; a)`,
//!   the two-level counterpart of (5.16)–(5.17). As a → ∞ (objects identical to their place) this
//!   is the seed's Dirichlet–multinomial over all draws; for small a one object is worth about one
//!   pick per colour it shows, however many pixels (D) it has. Feature selection then asks whether
//!   the objects of *each* place share colours (the evidence rewards colours found in every object
//!   of a place, not in any), which is what tells a colour task from three random-coloured objects
//!   per place. The place pmf (5.18) is E[π_k | X_k] = Σ_a p(a | X_k) Z(X_k ∪ {l}; a)/Z(X_k; a)
//!   ([`ProceduralModel::color_pmf`]). The statistic is the sorted multiset of the objects' draw
//!   vectors (exact integers);
//! * **size** — the segment size in deci-pixels (§5.1.2.2), one observation per object (the mean of
//!   the left and right cameras, whose sizes are highly correlated, Fig. 5.4); per place a
//!   Normal–Inverse-Gamma prior with a Student-t predictive.
//!
//! The *connectivity* (Fig. 5.16) says which feature types hang off q. A feature type that is not
//! connected is still modelled, with one distribution shared by all places (the pooled statistics),
//! so that every structure explains all the data and their marginal likelihoods compare.
//!
//! # Feature selection (left open in §5.3.3)
//!
//! The four structures S ∈ {neither, colour, size, colour+size} are scored by their closed-form
//! marginal likelihood of the demonstrations, `ln p(D | S) = Σ_f [S connects f ? Σₖ ln p(D_f,k) :
//! ln p(D_f)]`, and a prior over structures (uniform by default) gives the posterior p(S | D)
//! ([`ProceduralModel::structure_posterior`]). The Bayesian Occam factor of the marginal likelihood
//! prefers the shared model unless the places really differ in that feature. Predictions average
//! over the structures (so a clear-cut structure behaves as if it were fixed, and an unsure one
//! hedges); [`Hyper::structure`] can also fix the structure, as the seed does.
//!
//! # Prediction
//!
//! For a new object õ the joint weight of structure S and place k is
//! `p(S | D) ψ(k) p(õ | k, S, D)`; summed over S it gives the posterior over places (5.10) and the
//! MAP place q* (5.9); summed over both it is the task model's marginal p₁(õ) (5.22)–(5.23).
//! ψ is uniform (the seed's choice: a teacher picks exemplars, not frequencies) or the
//! Dirichlet–multinomial (5.14).
//!
//! # Task relevance (§5.1.3)
//!
//! ln B₁₀ = ln p₁(õ) − ln p₀(õ) (5.19) against a background model M₀ of "any object": the *prior*
//! predictive of the feature units, i.e. for colour `(P6)  p₀(õ) = Σ_a p(a) Z({õ}; a)`, one object
//! of a place whose π is drawn around the base measure m — the two-level form of (5.20)–(5.21) with
//! m in place of the seed's uniform L⁻¹, so a colour every object shows (white highlights, dark
//! shading) is no evidence of belonging to the task — and size from the NIG prior predictive
//! (Fig. 5.7). The
//! object is *relevant* when ln B₁₀ > [`Hyper::relevance_log_threshold`], by default
//! [`DEFAULT_RELEVANCE_LOG_THRESHOLD`] = 2 (B₁₀ > e² ≈ 7.4, "substantial" evidence), calibrated on
//! the rendered household catalog: with three examples per class it maximises the mean accuracy of
//! the relevant/irrelevant decision over the colour-class pairs (B₁₀ > 1 accepts too many
//! background objects, since p₁ is a mixture fitted to few examples).
//! (That calibration was done for the version-2 colour unit and has not been redone for the
//! two-level unit; the ROC AUC does not depend on it.)
//!
//! # Incremental learning (§5.2)
//!
//! Every statistic is an integer (each object's colour draw counts, kept as a sorted multiset,
//! demonstrations, and the size sums Σx and Σx² in half-pixels), so
//! [`ProceduralModel::update`] one demonstration at a time gives *exactly* the
//! model [`ProceduralModel::learn`] builds from all of them, in any order, and
//! [`ProceduralModel::merge`] adds two models.
//!
//! # Effector assignment (5.31)–(5.32)
//!
//! [`assign_effectors`]: the arm whose workspace holds both the object and the place, else a
//! hand-to-hand transfer at a hand-off location both arms reach, else "unreachable".
//!
//! The model file format is documented at [`ProceduralModel::to_json`].

use std::collections::BTreeMap;
use std::path::Path;

use bayes::bayes_factor::{BayesFactor, log_mixture_marginal, log_place_weights};
use bayes::dirichlet::{CategoryCounts, SymmetricDirichlet};
use bayes::special::{ln_gamma, log_sum_exp};
use bayes::univariate::{GaussianStats, NormalInverseGamma, StudentT};
use serde::{Deserialize, Serialize};

use crate::error::SchemaError;
use crate::percept::{COLOR_TERMS, SegmentPercept};

pub mod effector;
pub mod explain;
mod format;

pub use effector::{ArmReach, EffectorAssignment, Handoff, Unreachable, assign_effectors};
pub use explain::{ColorMass, Explanation, PlaceExplanation, SyntheticInstance, bin_center_hsv, color_name};

/// The `format` field of a model file.
pub const MODEL_FORMAT: &str = "pbd-procedural-model";
/// The model format version this crate reads and writes.
pub const MODEL_VERSION: u32 = 3;
/// Number of colours L of the HSV histogram (4 hue × 4 saturation × 4 value bins, §5.1.2.1).
pub const COLOR_BINS: usize = 64;

/// Where errors about in-memory input are reported (no file).
const INPUT: &str = "<input>";

// ---------------------------------------------------------------------------------------------
// Input
// ---------------------------------------------------------------------------------------------

/// The observed features of one object (mirrors [`SegmentPercept`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Features {
    /// The kept bins of the 64-bin HSV histogram as (bin, weight); each kept bin is one colour
    /// observation õᵢ (the weights are informative only and not used by the model).
    pub histogram: Vec<(u8, f64)>,
    /// Segment size in pixels in the left and right camera; 0 = not seen by that camera.
    pub pixels: [u32; 2],
    /// The kept colour terms as (term, share) ([`SegmentPercept::colors`],
    /// [`crate::percept::color_term`]). Carried with the features for inspection and for colour
    /// units over named colours; the version-3 colour unit reads [`Features::histogram`] only.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub colors: Vec<(u8, f64)>,
}

impl From<&SegmentPercept> for Features {
    fn from(s: &SegmentPercept) -> Self {
        Features {
            histogram: s.histogram.clone(),
            pixels: s.pixels,
            colors: s.colors.clone(),
        }
    }
}

impl Features {
    /// Checks bins (< 64, no duplicates) and weights (finite, ≥ 0); `field` prefixes error fields.
    pub fn validate(&self, field: &str) -> Result<(), SchemaError> {
        let mut seen = 0u64;
        for (i, &(bin, w)) in self.histogram.iter().enumerate() {
            if usize::from(bin) >= COLOR_BINS {
                return Err(SchemaError::invalid(
                    INPUT,
                    format!("{field}histogram[{i}]"),
                    format!("bin {bin} out of range 0..{COLOR_BINS}"),
                ));
            }
            if seen & (1u64 << bin) != 0 {
                return Err(SchemaError::invalid(
                    INPUT,
                    format!("{field}histogram[{i}]"),
                    format!("bin {bin} appears twice"),
                ));
            }
            seen |= 1u64 << bin;
            if !(w.is_finite() && w >= 0.0) {
                return Err(SchemaError::invalid(
                    INPUT,
                    format!("{field}histogram[{i}]"),
                    format!("weight {w} is not a finite number >= 0"),
                ));
            }
        }
        for (i, &(term, w)) in self.colors.iter().enumerate() {
            if usize::from(term) >= COLOR_TERMS.len() || !(w.is_finite() && w >= 0.0) {
                return Err(SchemaError::invalid(
                    INPUT,
                    format!("{field}colors[{i}]"),
                    format!(
                        "({term}, {w}): the term must be < {} and the share a finite number >= 0",
                        COLOR_TERMS.len()
                    ),
                ));
            }
        }
        Ok(())
    }

    /// The colour observations: kept bins, ascending.
    pub fn color_bins(&self) -> Vec<usize> {
        let mut v: Vec<usize> = self.histogram.iter().map(|&(b, _)| usize::from(b)).collect();
        v.sort_unstable();
        v.dedup();
        v
    }

    /// The colour draws õ₁..õₙ of this object as (bin, count), ascending by bin.
    ///
    /// With `draws_per_object = 0` every kept bin is one draw (the seed's reading). Otherwise the
    /// object contributes exactly that many draws, shared among its kept bins in proportion to
    /// their pixel weights (largest remainder, ties to the lower bin; equal shares when all weights
    /// are 0), so the dominant colours of the object outweigh the rare shading bins. With
    /// `classes`, every bin counts as its colour class ([`color_class_bin`]).
    pub fn color_draws(&self, draws_per_object: u32, classes: bool) -> Vec<(usize, u64)> {
        let canon = |b: u8| {
            if classes {
                color_class_bin(usize::from(b))
            } else {
                usize::from(b)
            }
        };
        let mut out: BTreeMap<usize, u64> = BTreeMap::new();
        if self.histogram.is_empty() {
            return Vec::new();
        }
        if draws_per_object == 0 {
            for &(b, _) in &self.histogram {
                out.insert(canon(b), 1);
            }
            return out.into_iter().collect();
        }
        let total: f64 = self.histogram.iter().map(|h| h.1).sum();
        let weights: Vec<f64> = if total > 0.0 && total.is_finite() {
            self.histogram.iter().map(|h| h.1 / total).collect()
        } else {
            vec![1.0 / self.histogram.len() as f64; self.histogram.len()]
        };
        let w = f64::from(draws_per_object);
        let mut shares: Vec<(u64, f64, u8)> = self
            .histogram
            .iter()
            .zip(&weights)
            .map(|(&(b, _), &q)| {
                let x = q * w;
                (x.floor() as u64, x - x.floor(), b)
            })
            .collect();
        let given: u64 = shares.iter().map(|s| s.0).sum();
        let mut order: Vec<usize> = (0..shares.len()).collect();
        order.sort_by(|&i, &j| shares[j].1.total_cmp(&shares[i].1).then(shares[i].2.cmp(&shares[j].2)));
        for &i in order
            .iter()
            .cycle()
            .take(u64::from(draws_per_object).saturating_sub(given) as usize)
        {
            shares[i].0 += 1;
        }
        for (n, _, b) in shares {
            if n > 0 {
                *out.entry(canon(b)).or_insert(0) += n;
            }
        }
        out.into_iter().collect()
    }

    /// The size observation in half-pixels: left + right when both cameras saw the object, twice
    /// the one count otherwise, `None` when neither did.
    pub fn size_half_pixels(&self) -> Option<u64> {
        match self.pixels {
            [0, 0] => None,
            [l, 0] => Some(2 * u64::from(l)),
            [0, r] => Some(2 * u64::from(r)),
            [l, r] => Some(u64::from(l) + u64::from(r)),
        }
    }

    /// The size observation in deci-pixels (§5.1.2.2): mean pixel count over the cameras / 10.
    pub fn deci_pixels(&self) -> Option<f64> {
        self.size_half_pixels().map(|h| h as f64 / 20.0)
    }
}

/// The bin that stands for a bin's *colour class*: black (v < ¼: bin 0), dark grey, grey and white
/// (s < ¼, whose hue is noise: bins 1, 2, 3), and the four hues red–yellow, green, cyan–blue and
/// purple–pink (every saturation and value of hue h: the vivid bright bin `16·h + 15`).
pub fn color_class_bin(bin: usize) -> usize {
    let (h, s, v) = ((bin / 16) % 4, (bin / 4) % 4, bin % 4);
    if v == 0 {
        0
    } else if s == 0 {
        v
    } else {
        16 * h + 15
    }
}

/// The representative bins of the 8 colour classes ([`color_class_bin`]), ascending.
pub const COLOR_CLASS_BINS: [usize; 8] = [0, 1, 2, 3, 15, 31, 47, 63];

/// One demonstrated Pick-And-Place: the features of the object and the place it was put.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Example {
    /// What the robot saw of the object.
    pub features: Features,
    /// The place (task-dependent reference) the teacher put it, e.g. `bin_left`.
    pub reference: String,
}

// ---------------------------------------------------------------------------------------------
// Structures and hyper-parameters
// ---------------------------------------------------------------------------------------------

/// A feature type of the feature unit (§5.3.3).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FeatureType {
    /// The HSV colour histogram's kept bins.
    Color,
    /// The segment size in deci-pixels.
    Size,
}

impl FeatureType {
    /// Both feature types.
    pub const ALL: [FeatureType; 2] = [FeatureType::Color, FeatureType::Size];

    /// `color` or `size`.
    pub fn name(self) -> &'static str {
        match self {
            FeatureType::Color => "color",
            FeatureType::Size => "size",
        }
    }
}

/// Which feature types connect to the place category q (Fig. 5.16).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
pub struct Connectivity {
    /// Colour depends on the place.
    pub color: bool,
    /// Size depends on the place.
    pub size: bool,
}

impl Connectivity {
    /// The four structures, in the order `neither`, `color`, `size`, `color+size`.
    pub const ALL: [Connectivity; 4] = [
        Connectivity {
            color: false,
            size: false,
        },
        Connectivity {
            color: true,
            size: false,
        },
        Connectivity {
            color: false,
            size: true,
        },
        Connectivity {
            color: true,
            size: true,
        },
    ];

    /// `neither`, `color`, `size` or `color+size`.
    pub fn name(self) -> &'static str {
        match (self.color, self.size) {
            (false, false) => "neither",
            (true, false) => "color",
            (false, true) => "size",
            (true, true) => "color+size",
        }
    }

    /// Parses [`Connectivity::name`] (also `both`, `none`, `colour`).
    pub fn parse(s: &str) -> Option<Connectivity> {
        Some(match s {
            "neither" | "none" => Connectivity::ALL[0],
            "color" | "colour" => Connectivity::ALL[1],
            "size" => Connectivity::ALL[2],
            "color+size" | "both" | "colour+size" => Connectivity::ALL[3],
            _ => return None,
        })
    }

    /// Whether feature type `f` connects to the place.
    pub fn connects(self, f: FeatureType) -> bool {
        match f {
            FeatureType::Color => self.color,
            FeatureType::Size => self.size,
        }
    }

    fn index(self) -> usize {
        usize::from(self.color) + 2 * usize::from(self.size)
    }
}

/// The prior ψ over place categories (5.5).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum PlacePrior {
    /// Every demonstrated place equally likely (the seed's choice, §5.1.1).
    Uniform,
    /// The Dirichlet–multinomial (5.14) over the demonstration counts with concentration β.
    Dirichlet {
        /// β > 0.
        beta: f64,
    },
}

/// Whether the connectivity is inferred (feature selection) or given.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum StructureChoice {
    /// Average over the four structures with their posterior p(S | D).
    #[default]
    Inferred,
    /// Use this structure only (the seed's experiments fix it).
    Fixed(Connectivity),
}

impl StructureChoice {
    /// `inferred` or a structure name.
    pub fn name(self) -> &'static str {
        match self {
            StructureChoice::Inferred => "inferred",
            StructureChoice::Fixed(c) => c.name(),
        }
    }

    /// Parses [`StructureChoice::name`].
    pub fn parse(s: &str) -> Option<StructureChoice> {
        if s == "inferred" {
            Some(StructureChoice::Inferred)
        } else {
            Connectivity::parse(s).map(StructureChoice::Fixed)
        }
    }
}

/// Hyper-parameters of the procedural model (all validated by [`Hyper::validate`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Hyper {
    /// The place prior ψ.
    pub place_prior: PlacePrior,
    /// Concentration α of the Dirichlet(α·m) prior of each place's colour distribution π (5.18).
    pub color_concentration: f64,
    /// Base measure m over the 64 bins (normalised when used; ≥ 0, and > 0 on every bin an object
    /// can show): the prior mean of a place's colour distribution and the background colour model
    /// of M₀.
    pub color_base: Vec<f64>,
    /// Colour draws D per object (1..=[`MAX_COLOR_DRAWS`]); see [`Features::color_draws`].
    pub color_draws_per_object: u32,
    /// The grid of object concentrations a (each finite and > 0, at most
    /// [`MAX_OBJECT_CONCENTRATIONS`] values), equally likely a priori: an object's own colour
    /// distribution is θ ~ Dirichlet(a·π) around its place's π (module docs). Small a: the objects
    /// of a place vary; large a: they all look like π.
    pub color_object_concentrations: Vec<f64>,
    /// Count every bin as its colour class ([`color_class_bin`]).
    pub color_classes: bool,
    /// NIG prior of each place's size distribution, in deci-pixels; its prior predictive is also
    /// the background size model of M₀.
    pub size_prior: NormalInverseGamma,
    /// Prior probabilities of the structures, indexed like [`Connectivity::ALL`].
    pub structure_prior: [f64; 4],
    /// Inferred or fixed connectivity.
    pub structure: StructureChoice,
    /// An object is task-relevant when ln B₁₀ exceeds this (0: B₁₀ > 1, §5.1.3).
    pub relevance_log_threshold: f64,
}

/// Default α = 1: a place's colour distribution π is worth one object-level draw of prior around
/// the base measure, so a place may well be dominated by a single colour class.
pub const DEFAULT_COLOR_CONCENTRATION: f64 = 1.0;

/// Default grid of object concentrations a (log-uniform, 1 to 64): from "the objects of a place
/// share little more than the place's palette" to "every object of the place has nearly the
/// place's colour distribution". The data choose by the marginal likelihood (module docs).
pub const DEFAULT_COLOR_OBJECT_CONCENTRATIONS: [f64; 4] = [1.0, 4.0, 16.0, 64.0];

/// Largest number of colour draws per object (the cost of the exact colour evidence grows with
/// the square of the draws per place).
pub const MAX_COLOR_DRAWS: u32 = 200;

/// Largest number of object concentrations in [`Hyper::color_object_concentrations`].
pub const MAX_OBJECT_CONCENTRATIONS: usize = 16;

/// Default ln B₁₀ threshold of task relevance (module docs).
pub const DEFAULT_RELEVANCE_LOG_THRESHOLD: f64 = 2.0;

/// Default base measure over the colour classes [`COLOR_CLASS_BINS`] (black, dark grey, grey,
/// white, red–yellow, green, cyan–blue, purple–pink): the mean colour-class shares of the
/// presentations of the built-in household catalog rendered by Dexter's head cameras
/// (`tests/data/household_features.json`), each class smoothed by half an object.
pub const DEFAULT_COLOR_CLASS_BASE: [f64; 8] = [0.111, 0.033, 0.107, 0.151, 0.238, 0.103, 0.134, 0.046];

/// [`DEFAULT_COLOR_CLASS_BASE`] spread over the 64 bins (0 off the class bins).
pub fn default_color_base() -> Vec<f64> {
    let mut m = vec![0.0; COLOR_BINS];
    for (b, p) in COLOR_CLASS_BINS.iter().zip(DEFAULT_COLOR_CLASS_BASE) {
        m[*b] = p;
    }
    m
}

/// Default colour draws per object D = 30 (see [`Features::color_draws`]): enough for an object's
/// own colour distribution to be seen well (its share of a colour to about ±0.1), which the
/// two-level model needs to tell "objects of one place alike" from "objects of one place varied";
/// the evidence an object gives about its place stays bounded however large D is.
pub const DEFAULT_COLOR_DRAWS: u32 = 30;

impl Default for Hyper {
    /// Defaults for Dexter's head cameras at 160×120 (the built-in scenes), where household objects
    /// measure 6–60 deci-pixels: a prior mean of 25 deci-pixels worth 0.05 observations and
    /// σ² ~ InvGamma(2, 2·8²) (a within-place spread of about 8 deci-pixels; the prior predictive
    /// is broad, spanning roughly 0–100).
    fn default() -> Self {
        Hyper {
            place_prior: PlacePrior::Uniform,
            color_concentration: DEFAULT_COLOR_CONCENTRATION,
            color_base: default_color_base(),
            color_draws_per_object: DEFAULT_COLOR_DRAWS,
            color_object_concentrations: DEFAULT_COLOR_OBJECT_CONCENTRATIONS.to_vec(),
            color_classes: true,
            size_prior: default_size_prior(),
            structure_prior: [0.25; 4],
            structure: StructureChoice::Inferred,
            relevance_log_threshold: DEFAULT_RELEVANCE_LOG_THRESHOLD,
        }
    }
}

/// Default prior mean object size (deci-pixels) at the default camera.
pub const DEFAULT_SIZE_MU: f64 = 25.0;

/// The default size prior (see [`Hyper::default`]).
fn default_size_prior() -> NormalInverseGamma {
    NormalInverseGamma::new(DEFAULT_SIZE_MU, 0.05, 2.0, 2.0 * 8.0 * 8.0).expect("constant NIG parameters are valid")
}

impl Hyper {
    /// Checks every hyper-parameter; errors name the field.
    pub fn validate(&self) -> Result<(), SchemaError> {
        let bad = |field: &str, msg: String| Err(SchemaError::invalid(INPUT, format!("hyper.{field}"), msg));
        if let PlacePrior::Dirichlet { beta } = self.place_prior
            && !(beta.is_finite() && beta > 0.0)
        {
            return bad("place_prior.beta", format!("{beta} must be finite and > 0"));
        }
        if !(self.color_concentration.is_finite() && self.color_concentration > 0.0) {
            return bad(
                "color.concentration",
                format!("{} must be finite and > 0", self.color_concentration),
            );
        }
        if !(1..=MAX_COLOR_DRAWS).contains(&self.color_draws_per_object) {
            return bad(
                "color.draws_per_object",
                format!("{} must be in 1..={MAX_COLOR_DRAWS}", self.color_draws_per_object),
            );
        }
        let grid = &self.color_object_concentrations;
        if grid.is_empty() || grid.len() > MAX_OBJECT_CONCENTRATIONS {
            return bad(
                "color.object_concentrations",
                format!("{} values, expected 1..={MAX_OBJECT_CONCENTRATIONS}", grid.len()),
            );
        }
        if let Some(i) = grid.iter().position(|a| !(a.is_finite() && *a > 0.0)) {
            return bad(
                &format!("color.object_concentrations[{i}]"),
                format!("{} must be finite and > 0", grid[i]),
            );
        }
        if self.color_base.len() != COLOR_BINS {
            return bad(
                "color.base",
                format!("{} values, expected {COLOR_BINS}", self.color_base.len()),
            );
        }
        if let Some(i) = self.color_base.iter().position(|p| !(p.is_finite() && *p >= 0.0)) {
            return bad(
                &format!("color.base[{i}]"),
                format!("{} must be finite and >= 0", self.color_base[i]),
            );
        }
        for b in 0..COLOR_BINS {
            let reachable = !self.color_classes || color_class_bin(b) == b;
            if reachable && self.color_base[b] <= 0.0 {
                return bad(
                    &format!("color.base[{b}]"),
                    "must be > 0: objects can show this colour".into(),
                );
            }
        }
        for (i, &p) in self.structure_prior.iter().enumerate() {
            if !(p.is_finite() && p >= 0.0) {
                return bad(
                    &format!("structure_prior.{}", Connectivity::ALL[i].name()),
                    format!("{p} must be finite and >= 0"),
                );
            }
        }
        if self.structure_prior.iter().sum::<f64>() <= 0.0 {
            return bad("structure_prior", "all structures have prior 0".into());
        }
        if let StructureChoice::Fixed(c) = self.structure
            && self.structure_prior[c.index()] <= 0.0
        {
            return bad(
                "structure",
                format!("fixed structure {} has prior probability 0", c.name()),
            );
        }
        if self.relevance_log_threshold.is_nan() {
            return bad("relevance_log_threshold", "NaN".into());
        }
        Ok(())
    }

    /// The colour draws of an object under these hyper-parameters, as (bin, count).
    fn draws(&self, f: &Features) -> Vec<(usize, u64)> {
        f.color_draws(self.color_draws_per_object, self.color_classes)
    }

    /// The colour unit of these hyper-parameters.
    pub(crate) fn color_unit(&self) -> ColorUnit {
        let total: f64 = self.color_base.iter().sum();
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
        ColorUnit {
            alpha_m: self
                .color_base
                .iter()
                .map(|p| self.color_concentration * p / total)
                .collect(),
            concentration: self.color_concentration,
            grid: self.color_object_concentrations.clone(),
            ln_grid_prior: -(self.color_object_concentrations.len() as f64).ln(),
            ln_stirling,
        }
    }
}

/// ln(eˣ + eʸ).
fn log_add(x: f64, y: f64) -> f64 {
    let m = x.max(y);
    if m == f64::NEG_INFINITY {
        return m;
    }
    m + ((x - m).exp() + (y - m).exp()).ln()
}

/// The coefficients (in logs) of the product of two polynomials given by their coefficients in
/// logs: `out[k] = ln Σ_{i+j=k} exp(a[i] + b[j])`, each sum taken relative to its own largest term.
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

/// One object's colour draws, (bin, count) ascending by bin.
pub type ObjectDraws = Vec<(usize, u64)>;

/// The colour feature unit: the two-level model of the module docs, π ~ Dirichlet(α·m) per place,
/// θ ~ Dirichlet(a·π) per object, the object's D draws ~ Multinomial(θ), with a on a grid.
pub(crate) struct ColorUnit {
    /// α·m per bin.
    alpha_m: Vec<f64>,
    /// α = Σ α·m.
    concentration: f64,
    /// The object concentrations a.
    grid: Vec<f64>,
    /// ln of the prior weight of each a (uniform).
    ln_grid_prior: f64,
    /// ln s(x, t) for x, t ≤ D.
    ln_stirling: Vec<Vec<f64>>,
}

impl ColorUnit {
    /// ln Z(X; a) = ln p(X | a), the exact marginal likelihood of the objects X of one place for
    /// object concentration `a` (module docs, eq. (P3)).
    fn log_z(&self, objects: &[&ObjectDraws], a: f64) -> f64 {
        if objects.is_empty() {
            return 0.0;
        }
        let ln_a = a.ln();
        let mut per_object = 0.0;
        let mut by_bin: BTreeMap<usize, Vec<u64>> = BTreeMap::new();
        for o in objects {
            let n: u64 = o.iter().map(|d| d.1).sum();
            per_object += ln_gamma(a) - ln_gamma(a + n as f64);
            for &(b, x) in o.iter() {
                if x > 0 {
                    by_bin.entry(b).or_default().push(x);
                }
            }
        }
        let mut total = vec![0.0];
        for (b, xs) in by_bin {
            // P_b(z) = Π_i Σ_t s(x_ib, t) aᵗ zᵗ: the distribution of the tables T_b of colour b.
            let mut poly = vec![0.0];
            for x in xs {
                let x = x as usize;
                let row = &self.ln_stirling[x.min(self.ln_stirling.len() - 1)];
                let term: Vec<f64> = (0..=x)
                    .map(|t| row.get(t).copied().unwrap_or(f64::NEG_INFINITY) + t as f64 * ln_a)
                    .collect();
                poly = log_convolve(&poly, &term);
            }
            let am = self.alpha_m[b];
            let lg_am = ln_gamma(am);
            for (t, c) in poly.iter_mut().enumerate() {
                if c.is_finite() {
                    *c += ln_gamma(am + t as f64) - lg_am;
                }
            }
            total = log_convolve(&total, &poly);
        }
        let lg_alpha = ln_gamma(self.concentration);
        let terms: Vec<f64> = total
            .iter()
            .enumerate()
            .map(|(t, &c)| c + lg_alpha - ln_gamma(self.concentration + t as f64))
            .collect();
        per_object + log_sum_exp(&terms)
    }

    /// ln Z(X; a) for every a of the grid.
    fn log_z_grid(&self, objects: &[&ObjectDraws]) -> Vec<f64> {
        self.grid.iter().map(|&a| self.log_z(objects, a)).collect()
    }

    /// ln Σ_a p(a) Π_groups Z(X_g; a) given the per-group ln Z grids: the evidence of groups of
    /// objects that share a but each have their own π (eq. (P4)).
    fn log_evidence(&self, groups: &[Vec<f64>]) -> f64 {
        let terms: Vec<f64> = (0..self.grid.len())
            .map(|i| self.ln_grid_prior + groups.iter().map(|g| g[i]).sum::<f64>())
            .collect();
        log_sum_exp(&terms)
    }

    /// The posterior-predictive pmf (5.18) over the bins given one place's objects: the
    /// probability that a new object's draw has colour l, E[π_l | X] = Σ_a p(a | X)
    /// Z(X ∪ {l}; a) / Z(X; a).
    pub(crate) fn predictive(&self, objects: &[ObjectDraws]) -> Vec<f64> {
        let refs: Vec<&ObjectDraws> = objects.iter().collect();
        let z = self.log_z_grid(&refs);
        let ev = self.log_evidence(std::slice::from_ref(&z));
        let mut p: Vec<f64> = (0..self.alpha_m.len())
            .map(|l| {
                if self.alpha_m[l] <= 0.0 {
                    return 0.0;
                }
                let one = vec![(l, 1u64)];
                let mut with = refs.clone();
                with.push(&one);
                let terms: Vec<f64> = self
                    .grid
                    .iter()
                    .zip(&z)
                    .map(|(&a, &zx)| self.ln_grid_prior + zx + self.log_z(&with, a) - zx)
                    .collect();
                (log_sum_exp(&terms) - ev).exp()
            })
            .collect();
        let s: f64 = p.iter().sum();
        if s > 0.0 {
            p.iter_mut().for_each(|v| *v /= s);
        }
        p
    }

    /// ln p(õ | X_k) for each group k, where all groups share a (eq. (P5)): `groups[k]` are the
    /// objects of group k and `z[k]` their ln Z grid.
    fn log_scores(&self, groups: &[Vec<&ObjectDraws>], z: &[Vec<f64>], draws: &ObjectDraws) -> Vec<f64> {
        if draws.is_empty() {
            return vec![0.0; groups.len()];
        }
        let ev = self.log_evidence(z);
        let joint: Vec<f64> = self
            .grid
            .iter()
            .enumerate()
            .map(|(i, _)| self.ln_grid_prior + z.iter().map(|g| g[i]).sum::<f64>())
            .collect();
        groups
            .iter()
            .enumerate()
            .map(|(k, objs)| {
                let mut with = objs.clone();
                with.push(draws);
                let terms: Vec<f64> = self
                    .grid
                    .iter()
                    .enumerate()
                    .map(|(i, &a)| joint[i] + self.log_z(&with, a) - z[k][i])
                    .collect();
                log_sum_exp(&terms) - ev
            })
            .collect()
    }

    /// ln p₀(õ): the prior predictive of one object (the background model M₀, eq. (P6)).
    fn log_background(&self, draws: &ObjectDraws) -> f64 {
        if draws.is_empty() {
            return 0.0;
        }
        let z = self.log_z_grid(&[draws]);
        self.log_evidence(&[z])
    }
}

// ---------------------------------------------------------------------------------------------
// Sufficient statistics
// ---------------------------------------------------------------------------------------------

/// Exact sufficient statistics of the size observations, in half-pixels (integers, so any order of
/// updates gives the same bits).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SizeStats {
    /// Number of observations.
    pub n: u64,
    /// Σ x (half-pixels).
    pub sum_half_pixels: u64,
    /// Σ x² (half-pixels²).
    pub sum_sq_half_pixels: u64,
}

impl SizeStats {
    fn add(&mut self, x: u64) -> Result<(), SchemaError> {
        let overflow = || SchemaError::invalid(INPUT, "size", "size statistics overflow u64");
        let sq = x.checked_mul(x).ok_or_else(overflow)?;
        let new = SizeStats {
            n: self.n.checked_add(1).ok_or_else(overflow)?,
            sum_half_pixels: self.sum_half_pixels.checked_add(x).ok_or_else(overflow)?,
            sum_sq_half_pixels: self.sum_sq_half_pixels.checked_add(sq).ok_or_else(overflow)?,
        };
        *self = new;
        Ok(())
    }

    fn merged(&self, o: &SizeStats) -> Result<SizeStats, SchemaError> {
        let overflow = || SchemaError::invalid(INPUT, "size", "size statistics overflow u64");
        Ok(SizeStats {
            n: self.n.checked_add(o.n).ok_or_else(overflow)?,
            sum_half_pixels: self
                .sum_half_pixels
                .checked_add(o.sum_half_pixels)
                .ok_or_else(overflow)?,
            sum_sq_half_pixels: self
                .sum_sq_half_pixels
                .checked_add(o.sum_sq_half_pixels)
                .ok_or_else(overflow)?,
        })
    }

    /// Checks consistency (n = 0 ⇒ sums 0; Cauchy–Schwarz n·Σx² ≥ (Σx)²).
    fn check(&self) -> Result<(), String> {
        if self.n == 0 && (self.sum_half_pixels != 0 || self.sum_sq_half_pixels != 0) {
            return Err("sums must be 0 when n = 0".into());
        }
        let lhs = u128::from(self.n) * u128::from(self.sum_sq_half_pixels);
        let rhs = u128::from(self.sum_half_pixels) * u128::from(self.sum_half_pixels);
        if lhs < rhs {
            return Err("inconsistent: n * sum_sq_half_pixels < sum_half_pixels^2".into());
        }
        Ok(())
    }

    /// The statistics (n, x̄, M2) in deci-pixels (x / 20), M2 computed exactly in integers.
    pub fn gaussian(&self) -> GaussianStats {
        if self.n == 0 {
            return GaussianStats::new();
        }
        let n = u128::from(self.n);
        let s = u128::from(self.sum_half_pixels);
        let m2_times_n = n * u128::from(self.sum_sq_half_pixels) - s * s;
        let mean = self.sum_half_pixels as f64 / (20.0 * self.n as f64);
        let m2 = m2_times_n as f64 / (self.n as f64 * 400.0);
        GaussianStats::from_parts(self.n, mean, m2).unwrap_or_default()
    }
}

/// One place's statistics: demonstrations, colour draws per object, size sums.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PlaceStats {
    /// Number of demonstrations that used this place.
    pub demonstrations: u64,
    /// Colour draw counts over the 64 bins, summed over the objects (for display).
    pub color: CategoryCounts,
    /// Every object's colour draws, as a sorted multiset (so the order of the demonstrations does
    /// not matter): the sufficient statistic of the two-level colour model.
    pub objects: Vec<ObjectDraws>,
    /// Size statistics.
    pub size: SizeStats,
}

impl PlaceStats {
    fn empty() -> Self {
        PlaceStats {
            demonstrations: 0,
            color: CategoryCounts::new(COLOR_BINS).unwrap_or_else(|_| unreachable_counts()),
            objects: Vec::new(),
            size: SizeStats::default(),
        }
    }

    /// Adds one object's colour draws, keeping the multiset sorted.
    fn add_object(&mut self, draws: ObjectDraws) -> Result<(), SchemaError> {
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
    fn absorb(&mut self, o: &PlaceStats) -> Result<(), SchemaError> {
        for d in &o.objects {
            self.add_object(d.clone())?;
        }
        self.size = self.size.merged(&o.size)?;
        self.demonstrations += o.demonstrations;
        Ok(())
    }
}

fn unreachable_counts() -> CategoryCounts {
    CategoryCounts::from_counts(vec![0; COLOR_BINS]).expect("64 categories is a valid category set")
}

// ---------------------------------------------------------------------------------------------
// Results
// ---------------------------------------------------------------------------------------------

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

// ---------------------------------------------------------------------------------------------
// The model
// ---------------------------------------------------------------------------------------------

/// The procedural feature model: hyper-parameters plus per-place sufficient statistics. Places
/// are kept in name order, so the model does not depend on the order of the demonstrations.
#[derive(Debug, Clone, PartialEq)]
pub struct ProceduralModel {
    hyper: Hyper,
    places: BTreeMap<String, PlaceStats>,
}

impl ProceduralModel {
    /// An empty model (no places yet). Errors: invalid hyper-parameters.
    pub fn new(hyper: Hyper) -> Result<Self, SchemaError> {
        hyper.validate()?;
        Ok(ProceduralModel {
            hyper,
            places: BTreeMap::new(),
        })
    }

    /// Learns from a batch of demonstrations. Errors: an empty set, invalid hyper-parameters or an
    /// invalid example (named by index).
    pub fn learn(hyper: Hyper, examples: &[Example]) -> Result<Self, SchemaError> {
        if examples.is_empty() {
            return Err(SchemaError::Empty("no demonstrations to learn from".into()));
        }
        let mut m = Self::new(hyper)?;
        for (i, e) in examples.iter().enumerate() {
            m.update_field(e, &format!("examples[{i}]."))?;
        }
        Ok(m)
    }

    /// Adds one demonstration (§5.2). On error the model is unchanged.
    pub fn update(&mut self, example: &Example) -> Result<(), SchemaError> {
        self.update_field(example, "example.")
    }

    fn update_field(&mut self, e: &Example, field: &str) -> Result<(), SchemaError> {
        if e.reference.trim().is_empty() {
            return Err(SchemaError::invalid(
                INPUT,
                format!("{field}reference"),
                "empty place name",
            ));
        }
        e.features.validate(&format!("{field}features."))?;
        let draws = self.hyper.draws(&e.features);
        if draws.is_empty() {
            return Err(SchemaError::invalid(
                INPUT,
                format!("{field}features.histogram"),
                "missing colour feature (no kept bins)",
            ));
        }
        let Some(x) = e.features.size_half_pixels() else {
            return Err(SchemaError::invalid(
                INPUT,
                format!("{field}features.pixels"),
                "missing size feature (0 pixels in both cameras)",
            ));
        };
        let mut stats = self.places.get(&e.reference).cloned().unwrap_or_else(PlaceStats::empty);
        stats.add_object(draws)?;
        stats.size.add(x)?;
        stats.demonstrations += 1;
        self.places.insert(e.reference.clone(), stats);
        Ok(())
    }

    /// Adds another model's statistics (same hyper-parameters required).
    pub fn merge(&mut self, other: &ProceduralModel) -> Result<(), SchemaError> {
        if self.hyper != other.hyper {
            return Err(SchemaError::invalid(
                INPUT,
                "hyper",
                "models with different hyper-parameters cannot be merged",
            ));
        }
        let mut places = self.places.clone();
        for (name, o) in &other.places {
            places.entry(name.clone()).or_insert_with(PlaceStats::empty).absorb(o)?;
        }
        self.places = places;
        Ok(())
    }

    /// The hyper-parameters.
    pub fn hyper(&self) -> &Hyper {
        &self.hyper
    }

    /// Replaces the structure choice (inferred or fixed); statistics are kept.
    pub fn set_structure(&mut self, structure: StructureChoice) -> Result<(), SchemaError> {
        let mut h = self.hyper.clone();
        h.structure = structure;
        h.validate()?;
        self.hyper = h;
        Ok(())
    }

    /// Place names, in order.
    pub fn place_names(&self) -> Vec<&str> {
        self.places.keys().map(String::as_str).collect()
    }

    /// One place's statistics.
    pub fn place(&self, name: &str) -> Option<&PlaceStats> {
        self.places.get(name)
    }

    /// Total number of demonstrations.
    pub fn num_demonstrations(&self) -> u64 {
        self.places.values().map(|p| p.demonstrations).sum()
    }

    fn check_nonempty(&self) -> Result<(), SchemaError> {
        if self.places.is_empty() {
            Err(SchemaError::Empty("the procedural model has no demonstrations".into()))
        } else {
            Ok(())
        }
    }

    fn pooled(&self) -> Result<PlaceStats, SchemaError> {
        let mut all = PlaceStats::empty();
        for p in self.places.values() {
            all.absorb(p)?;
        }
        Ok(all)
    }

    /// ln p(D_f | one shared distribution) and Σₖ ln p(D_f,k) for both feature types:
    /// `[[color pooled, color split], [size pooled, size split]]`.
    fn feature_evidence(&self) -> Result<[[f64; 2]; 2], SchemaError> {
        let unit = self.hyper.color_unit();
        let nig = &self.hyper.size_prior;
        let pooled = self.pooled()?;
        let mut size_split = 0.0;
        let mut z_split = Vec::with_capacity(self.places.len());
        for p in self.places.values() {
            z_split.push(unit.log_z_grid(&p.objects.iter().collect::<Vec<_>>()));
            size_split += nig.log_marginal_likelihood(&p.size.gaussian());
        }
        let z_pooled = unit.log_z_grid(&pooled.objects.iter().collect::<Vec<_>>());
        Ok([
            [unit.log_evidence(&[z_pooled]), unit.log_evidence(&z_split)],
            [nig.log_marginal_likelihood(&pooled.size.gaussian()), size_split],
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

    /// ln ψ(k) for the places in order.
    fn log_place_prior(&self) -> Result<Vec<f64>, SchemaError> {
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

    /// Size predictive (Student-t) of a place's statistics.
    fn size_predictive(&self, s: &SizeStats) -> StudentT {
        self.hyper.size_prior.posterior_predictive(&s.gaussian())
    }

    /// Per feature type, ln p(õ_f | place k) for every place and ln p(õ_f | pooled):
    /// `(color_per_place, color_pooled, size_per_place, size_pooled)`; a missing feature scores 0.
    fn feature_scores(&self, f: &Features) -> Result<(Vec<f64>, f64, Vec<f64>, f64), SchemaError> {
        let unit = self.hyper.color_unit();
        let draws = self.hyper.draws(f);
        let pooled = self.pooled()?;
        let size = f.deci_pixels();
        let groups: Vec<Vec<&ObjectDraws>> = self.places.values().map(|p| p.objects.iter().collect()).collect();
        let z: Vec<Vec<f64>> = groups.iter().map(|g| unit.log_z_grid(g)).collect();
        let color_k = unit.log_scores(&groups, &z, &draws);
        let all: Vec<&ObjectDraws> = pooled.objects.iter().collect();
        let z_all = unit.log_z_grid(&all);
        let color_all = unit.log_scores(&[all], &[z_all], &draws)[0];
        let size_score = |s: &SizeStats| size.map_or(0.0, |x| self.size_predictive(s).log_pdf(x));
        let size_k = self.places.values().map(|p| size_score(&p.size)).collect();
        let size_all = size_score(&pooled.size);
        Ok((color_k, color_all, size_k, size_all))
    }

    /// Posterior over places, MAP place (5.9)–(5.10) and task relevance (5.19)–(5.23) for the
    /// features of a new object, averaged over structures (module docs). Errors: an empty model,
    /// invalid features, or an object with neither feature.
    pub fn predict(&self, features: &Features) -> Result<Prediction, SchemaError> {
        self.check_nonempty()?;
        features.validate("features.")?;
        let draws = self.hyper.draws(features);
        let size = features.deci_pixels();
        if draws.is_empty() && size.is_none() {
            return Err(SchemaError::invalid(
                INPUT,
                "features",
                "no colour bins and no pixels: nothing to predict from",
            ));
        }
        let structures = self.structure_posterior()?;
        let log_psi = self.log_place_prior()?;
        let (color_k, color_all, size_k, size_all) = self.feature_scores(features)?;
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
                .map(|i| (if c.color { color_k[i] } else { color_all }) + (if c.size { size_k[i] } else { size_all }))
                .collect();
            let log_ps = s.probability.ln();
            let marg = log_mixture_marginal(&log_psi, &lik)?;
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
        let log_p0 = self.hyper.color_unit().log_background(&draws)
            + size.map_or(0.0, |x| self.hyper.size_prior.predictive().log_pdf(x));
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

    /// The posterior-predictive colour pmf (5.18) of a place over the 64 bins.
    pub fn color_pmf(&self, place: &str) -> Result<Vec<f64>, SchemaError> {
        let p = self.place_or_err(place)?;
        Ok(self.hyper.color_unit().predictive(&p.objects))
    }

    /// The posterior-predictive size density (Student-t, deci-pixels) of a place.
    pub fn size_density(&self, place: &str) -> Result<StudentT, SchemaError> {
        let p = self.place_or_err(place)?;
        Ok(self.size_predictive(&p.size))
    }

    fn place_or_err(&self, place: &str) -> Result<&PlaceStats, SchemaError> {
        self.places
            .get(place)
            .ok_or_else(|| SchemaError::unknown("place", place, self.places.keys().map(String::as_str)))
    }

    /// Writes the model as JSON (see [`ProceduralModel::to_json`]).
    pub fn save(&self, path: impl AsRef<Path>) -> Result<(), SchemaError> {
        let path = path.as_ref();
        std::fs::write(path, self.to_json()).map_err(|source| SchemaError::Io {
            path: path.display().to_string(),
            source,
        })
    }

    /// Reads and validates a model file.
    pub fn load(path: impl AsRef<Path>) -> Result<Self, SchemaError> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|source| SchemaError::Io {
            path: path.display().to_string(),
            source,
        })?;
        Self::from_json(&text, &path.display().to_string())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ex(bins: &[u8], px: [u32; 2], place: &str) -> Example {
        Example {
            features: Features {
                histogram: bins.iter().map(|&b| (b, 1.0 / bins.len() as f64)).collect(),
                pixels: px,
                colors: Vec::new(),
            },
            reference: place.into(),
        }
    }

    #[test]
    fn colour_task_picks_colour_and_sorts() {
        let demos = vec![
            ex(&[3, 7], [1500, 1480], "a"),
            ex(&[3, 7, 2], [3000, 3100], "a"),
            ex(&[40, 41], [1400, 1500], "b"),
            ex(&[40, 44], [2900, 3000], "b"),
        ];
        let m = ProceduralModel::learn(Hyper::default(), &demos).unwrap();
        let s = m.structure_posterior().unwrap();
        assert_eq!(s.map(), Connectivity::ALL[1], "{s:?}");
        let p = m.predict(&ex(&[3, 2], [2000, 2000], "?").features).unwrap();
        assert_eq!(p.map_place, "a");
        assert!(p.relevance.relevant);
        let q = m.predict(&ex(&[60, 61, 62], [9000, 9000], "?").features).unwrap();
        assert!(!q.relevance.relevant, "{q:?}");
    }

    #[test]
    fn size_stats_are_exact() {
        let mut s = SizeStats::default();
        for x in [3000u64, 2990, 1000] {
            s.add(x).unwrap();
        }
        let g = s.gaussian();
        let want = GaussianStats::from_slice(&[150.0, 149.5, 50.0]).unwrap();
        assert!((g.mean() - want.mean()).abs() < 1e-12);
        assert!((g.m2() - want.m2()).abs() < 1e-9);
    }

    #[test]
    fn bad_examples_are_errors() {
        let mut m = ProceduralModel::new(Hyper::default()).unwrap();
        assert!(m.update(&ex(&[64], [10, 10], "a")).is_err());
        assert!(m.update(&ex(&[], [10, 10], "a")).is_err());
        assert!(m.update(&ex(&[1], [0, 0], "a")).is_err());
        assert!(m.update(&ex(&[1, 1], [5, 5], "a")).is_err());
        assert!(m.update(&ex(&[1], [5, 5], "")).is_err());
        assert_eq!(m.num_demonstrations(), 0);
        assert!(ProceduralModel::learn(Hyper::default(), &[]).is_err());
        assert!(m.predict(&ex(&[1], [5, 5], "").features).is_err());
    }
}
