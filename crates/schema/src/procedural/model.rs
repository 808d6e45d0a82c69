//! The procedural feature model: hyper-parameters plus every place's sufficient statistics and the
//! background objects of M₀; learning, incremental updates (§5.2), merging, the places' predictive
//! densities, and the model file on disk.

use std::collections::BTreeMap;
use std::path::Path;

use bayes::univariate::StudentT;

use super::features::{Example, Features, INPUT};
use super::hyper::{Hyper, SizeUnit, StructureChoice};
use super::stats::{PlaceStats, SizeStats};
use crate::error::SchemaError;

/// The most places a model file may hold: a sorting task with a hundred bins is far beyond any
/// demonstration, and a prediction scores every place with the exact colour evidence (P5), so the
/// bound keeps a hostile file from costing hours in `explain` or `predict`.
pub const MAX_PLACES: usize = 100;

/// The procedural feature model: hyper-parameters plus per-place sufficient statistics. Places
/// are kept in name order, so the model does not depend on the order of the demonstrations.
#[derive(Debug, Clone, PartialEq)]
pub struct ProceduralModel {
    pub(super) hyper: Hyper,
    pub(super) places: BTreeMap<String, PlaceStats>,
    /// Objects of the demonstration scenes that the teacher left alone: the data of the background
    /// model M₀ (§5.1.3). Empty: M₀ is the prior predictive.
    pub(super) background: PlaceStats,
    /// The schema the demonstrations were instances of (`None`: a model from before the field,
    /// Pick-And-Place's). Its references are places for a schema that puts the object somewhere,
    /// else the arm the teacher used.
    pub(super) schema: Option<String>,
}

impl ProceduralModel {
    /// An empty model (no places yet). Errors: invalid hyper-parameters.
    pub fn new(hyper: Hyper) -> Result<Self, SchemaError> {
        hyper.validate()?;
        Ok(ProceduralModel {
            hyper,
            places: BTreeMap::new(),
            background: PlaceStats::empty(),
            schema: None,
        })
    }

    /// The schema whose instances the model learned from (`None`: not recorded — a model written
    /// before the field, learned from Pick-And-Place instances).
    pub fn schema(&self) -> Option<&str> {
        self.schema.as_deref()
    }

    /// The schema to run this model with from `library`: the one it learned from, else (a model
    /// written before the field) the library's task ([`crate::Library::task`]).
    pub fn schema_in<'a>(&'a self, library: &'a crate::Library) -> Result<&'a str, SchemaError> {
        match self.schema() {
            Some(s) => Ok(s),
            None => library.task_schema().map(|s| s.name.as_str()),
        }
    }

    /// Records the schema whose instances the model learned from.
    pub fn set_schema(&mut self, schema: impl Into<String>) {
        self.schema = Some(schema.into());
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
        if !self.places.contains_key(&e.reference) && self.places.len() >= MAX_PLACES {
            return Err(SchemaError::invalid(
                INPUT,
                format!("{field}reference"),
                format!(
                    "place `{}` would be place {} of a model; the limit is {MAX_PLACES}",
                    e.reference,
                    MAX_PLACES + 1
                ),
            ));
        }
        e.features.validate(&format!("{field}features."))?;
        let draws = self.hyper.draws(&e.features);
        if draws.is_empty() {
            return Err(SchemaError::invalid(
                INPUT,
                format!("{field}features.colors"),
                "missing colour feature (no colour terms; features written before percept colour terms \
                 existed must be re-made with `pbd infer`)",
            ));
        }
        let Some(x) = self.hyper.size_unit.quanta(&e.features) else {
            return Err(self.missing_size(&format!("{field}features")));
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
        let mut background = self.background.clone();
        background.absorb(&other.background)?;
        self.places = places;
        self.background = background;
        Ok(())
    }

    /// Adds an object of a demonstration scene that the teacher did not move to the background
    /// model M₀ of task relevance (§5.1.3: "a procedural feature model for non-sortable objects").
    /// With background objects, p₀(õ) is the posterior predictive of a place holding them — the
    /// two-level colour unit (P5) and the size unit's Student-t — instead of the prior predictive.
    /// An object whose size was not measured adds to the colour model only.
    pub fn observe_background(&mut self, features: &Features) -> Result<(), SchemaError> {
        features.validate("background.")?;
        let draws = self.hyper.draws(features);
        if draws.is_empty() {
            return Err(SchemaError::invalid(INPUT, "background.colors", "no colour terms"));
        }
        // A size that was not measured leaves M₀'s size model as it is (its colour still counts).
        let x = self.hyper.size_unit.quanta(features);
        let mut size = self.background.size;
        if let Some(x) = x {
            size.add(x)?;
        }
        self.background.add_object(draws)?;
        self.background.size = size;
        Ok(())
    }

    /// The error for an object without the size feature of this model's unit; `field` names it.
    fn missing_size(&self, field: &str) -> SchemaError {
        match self.hyper.size_unit {
            SizeUnit::DeciPixels => SchemaError::invalid(
                INPUT,
                format!("{field}.pixels"),
                "missing size feature (0 pixels in both cameras)",
            ),
            SizeUnit::Centimetres => SchemaError::invalid(
                INPUT,
                format!("{field}.dimensions"),
                "missing size feature: vision did not measure the object's extent (a recording made before \
                 extents were recorded; learn with sizes in deci-pixels, `--size-unit deci-pixels`)",
            ),
        }
    }

    /// Background objects observed so far ([`ProceduralModel::observe_background`]).
    pub fn background_objects(&self) -> usize {
        self.background.objects.len()
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

    pub(super) fn check_nonempty(&self) -> Result<(), SchemaError> {
        if self.places.is_empty() {
            Err(SchemaError::Empty("the procedural model has no demonstrations".into()))
        } else {
            Ok(())
        }
    }

    pub(super) fn pooled(&self) -> Result<PlaceStats, SchemaError> {
        let mut all = PlaceStats::empty();
        for p in self.places.values() {
            all.absorb(p)?;
        }
        Ok(all)
    }

    /// Size predictive (Student-t) of a place's statistics.
    pub(super) fn size_predictive(&self, s: &SizeStats) -> StudentT {
        self.hyper
            .size_prior
            .posterior_predictive(&s.gaussian(self.hyper.size_unit.quanta_per_unit()))
    }

    /// The posterior-predictive colour pmf (5.18) of a place over the colour terms ([`COLORS`](super::features::COLORS)).
    pub fn color_pmf(&self, place: &str) -> Result<Vec<f64>, SchemaError> {
        let p = self.place_or_err(place)?;
        Ok(self.hyper.color_unit().predictive(&p.objects))
    }

    /// The posterior-predictive size density (Student-t, in the model's [`Hyper::size_unit`]) of a
    /// place.
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
        let text = bayes::input::read_text(path).map_err(|source| SchemaError::Io {
            path: path.display().to_string(),
            source,
        })?;
        Self::from_json(&text, &path.display().to_string())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::procedural::hyper::Connectivity;

    /// An example whose colour terms are `terms`, in equal shares.
    fn ex(terms: &[u8], px: [u32; 2], place: &str) -> Example {
        Example {
            features: Features {
                histogram: Vec::new(),
                pixels: px,
                colors: terms.iter().map(|&t| (t, 1.0 / terms.len() as f64)).collect(),
                dimensions: None,
            },
            reference: place.into(),
        }
    }

    const BLACK: u8 = 0;
    const WHITE: u8 = 2;
    const RED: u8 = 3;
    const GREEN: u8 = 6;
    const BLUE: u8 = 7;

    #[test]
    fn colour_task_picks_colour_and_sorts() {
        let demos = vec![
            ex(&[RED, WHITE], [1500, 1480], "a"),
            ex(&[RED], [3000, 3100], "a"),
            ex(&[RED, BLACK], [1000, 1100], "a"),
            ex(&[BLUE], [1400, 1500], "b"),
            ex(&[BLUE, WHITE], [2900, 3000], "b"),
            ex(&[BLUE], [2000, 1900], "b"),
        ];
        let m = ProceduralModel::learn(Hyper::default().with_size_unit(SizeUnit::DeciPixels), &demos).unwrap();
        let s = m.structure_posterior().unwrap();
        assert_eq!(s.map(), Connectivity::ALL[1], "{s:?}");
        let p = m.predict(&ex(&[RED, WHITE], [2000, 2000], "?").features).unwrap();
        assert_eq!(p.map_place, "a");
        assert!(p.relevance.relevant, "{p:?}");
        let q = m.predict(&ex(&[GREEN], [2000, 2000], "?").features).unwrap();
        assert!(!q.relevance.relevant, "{q:?}");
    }

    #[test]
    fn bad_examples_are_errors() {
        let mut m = ProceduralModel::new(Hyper::default().with_size_unit(SizeUnit::DeciPixels)).unwrap();
        assert!(m.update(&ex(&[10], [10, 10], "a")).is_err());
        assert!(m.update(&ex(&[], [10, 10], "a")).is_err());
        assert!(m.update(&ex(&[1], [0, 0], "a")).is_err());
        assert!(m.update(&ex(&[1, 1], [5, 5], "a")).is_err());
        assert!(m.update(&ex(&[1], [5, 5], "")).is_err());
        assert_eq!(m.num_demonstrations(), 0);
        assert!(ProceduralModel::learn(Hyper::default(), &[]).is_err());
        assert!(m.predict(&ex(&[1], [5, 5], "").features).is_err());
    }
}
