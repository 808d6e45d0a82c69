//! `pbd experiment`: the seed's procedural-learning experiments (Sweeney 2011, §5.1–5.2) on features
//! rendered from an object catalog — colour sorting (Figs. 5.2, 5.3), size sorting (Fig. 5.6), task
//! relevance ROC (Figs. 5.8, 5.10) and incremental pmfs (Fig. 5.11), plus feature selection (§5.3.3).

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

pub mod execute;
pub mod faults;
pub mod features;
pub mod perception;
pub mod sorting;

/// Which experiment.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum Feature {
    /// Colour sorting by the catalog's `color_class` labels (Figs. 5.2, 5.3).
    #[default]
    Color,
    /// Size sorting by `size_class` (Small vs Large, Fig. 5.6).
    Size,
    /// Task relevance ROC: objects of the task's classes vs all others (Figs. 5.8, 5.10).
    Relevance,
    /// Incremental learning: the pmfs after each example (Fig. 5.11); incremental = batch.
    Incremental,
    /// Feature selection: which feature type decides the place, for colour-only, size-only and
    /// colour-and-size tasks (§5.3.3).
    Selection,
}

/// Options of the sorting experiments ([`sorting::run`]).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SortingOptions {
    /// The experiment.
    pub feature: Feature,
    /// Object catalog (TOML); default: the built-in household catalog.
    pub catalog: Option<PathBuf>,
    /// Trials per number of examples.
    pub trials: usize,
    /// Largest number of examples per class.
    pub max_examples: usize,
    /// Classes to sort (labels); default red,blue for colour, small,large for size.
    pub classes: Vec<String>,
    /// Connectivity structure: inferred (feature selection) or fixed (color, size, color+size).
    /// Default: the feature under test for color, size and relevance (the seed fixes it), inferred
    /// for incremental and selection.
    pub structure: Option<String>,
    /// Rendered views per presentation (trials draw among them).
    pub views: usize,
    /// Random seed (renders and trials).
    pub seed: u64,
    /// Output directory (CSV, summary.md; the figures' files).
    pub output: PathBuf,
    /// Also write the rendered features to this JSON file.
    pub dump_features: Option<PathBuf>,
    /// Read the features from this JSON file (written by `dump_features`) instead of rendering the
    /// catalog: the trials then run on exactly those features (`catalog` and `views` are ignored).
    pub features: Option<PathBuf>,
    /// A held-out catalog to test on (TOML): the examples come from `catalog` (the training
    /// catalog), the test objects are every presentation of this one. Default: test objects held
    /// out from the training catalog.
    pub test_catalog: Option<PathBuf>,
    /// Or the held-out catalog's features already rendered (a feature bank).
    pub test_features: Option<PathBuf>,
    /// Relevance: objects of the demonstration scenes the teacher left alone, per trial — drawn from
    /// the training catalog's presentations outside the task's classes — that fit the background
    /// model M₀ (§5.1.3). 0: M₀ is the prior predictive. Their objects are never test objects.
    pub background: usize,
    /// The colour base measure m of the model: the household catalog's colour-term shares
    /// ([`schema::procedural::DEFAULT_COLOR_BASE`], the default) or, when true, uniform over the
    /// colour terms (the seed's L⁻¹).
    pub uniform_base: bool,
    /// ε of [`schema::procedural::Hyper::color_neighbour_share`]: the share of an object's colour
    /// term given to each perceptually neighbouring term (0 ≤ ε ≤ ½; default
    /// [`schema::procedural::DEFAULT_COLOR_NEIGHBOUR_SHARE`]).
    pub neighbour_share: f64,
    /// The chromatic rule's share ([`schema::procedural::Hyper::color_chromatic_share`]): an
    /// object's black, grey and white pixels are left out when its chromatic terms cover at least
    /// this share (0 ≤ share ≤ 1, 1 turns the rule off; default
    /// [`schema::procedural::DEFAULT_CHROMATIC_SHARE`]).
    pub chromatic_share: f64,
    /// The unit of the size feature: the seed's deci-pixels (the default: these are the seed's
    /// experiments, its objects at one distance from the cameras) or `cm`, the metric size the robot
    /// measures (features rendered by this build carry it; older feature banks do not).
    pub size_unit: schema::procedural::SizeUnit,
}

impl Default for SortingOptions {
    fn default() -> Self {
        SortingOptions {
            feature: Feature::Color,
            catalog: None,
            trials: 10,
            max_examples: 6,
            classes: Vec::new(),
            structure: None,
            views: 4,
            seed: 1,
            output: PathBuf::from("experiment-sorting"),
            dump_features: None,
            features: None,
            test_catalog: None,
            test_features: None,
            background: 0,
            uniform_base: false,
            neighbour_share: schema::procedural::DEFAULT_COLOR_NEIGHBOUR_SHARE,
            chromatic_share: schema::procedural::DEFAULT_CHROMATIC_SHARE,
            size_unit: schema::procedural::SizeUnit::DeciPixels,
        }
    }
}
