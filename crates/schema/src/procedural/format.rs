//! The model file: versioned JSON with the hyper-parameters and every place's sufficient statistics.

use bayes::univariate::NormalInverseGamma;
use serde::{Deserialize, Serialize};
use serde_json::Value;

use super::features::COLORS;
use super::hyper::{Connectivity, Hyper, PlacePrior, SizeUnit, StructureChoice};
use super::model::{MAX_PLACES, ProceduralModel};
use super::stats::{PlaceStats, SizeStats};
use crate::error::SchemaError;
use crate::percept::COLOR_TERMS;

/// The `format` field of a model file.
pub const MODEL_FORMAT: &str = "pbd-procedural-model";
/// The model format version this crate writes: 5 adds sizes in centimetres (`hyper.size.unit` `cm`)
/// and names the size sums `sum`, `sum_sq` in the unit's integer quanta. Version 4 files (sizes in
/// deci-pixels, sums `sum_half_pixels`, `sum_sq_half_pixels`) still read.
pub const MODEL_VERSION: u32 = 5;

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct HyperFile {
    place_prior: PlacePrior,
    color: ColorHyper,
    size: SizeHyper,
    structure_prior: StructurePriorFile,
    structure: String,
    relevance_log_threshold: f64,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ColorHyper {
    terms: Vec<String>,
    concentrations: Vec<f64>,
    base: Vec<f64>,
    draws_per_object: u32,
    object_concentrations: Vec<f64>,
    chromatic_share: f64,
    /// Absent in files written before 2026-11-27: 0, the draws those files' places were learned with.
    #[serde(default)]
    neighbour_share: f64,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct SizeHyper {
    unit: String,
    mu: f64,
    kappa: f64,
    alpha: f64,
    beta: f64,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct StructurePriorFile {
    neither: f64,
    color: f64,
    size: f64,
    #[serde(rename = "color+size")]
    color_size: f64,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct PlaceFile {
    name: String,
    demonstrations: u64,
    color_objects: Vec<Vec<(usize, u64)>>,
    size: SizeStats,
}

/// The background model's data (objects left alone in the demonstration scenes, §5.1.3).
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct BackgroundFile {
    color_objects: Vec<Vec<(usize, u64)>>,
    size: SizeStats,
}

#[derive(Serialize)]
struct FileV4<'a> {
    format: &'a str,
    version: u32,
    hyper: HyperFile,
    places: Vec<PlaceFile>,
    #[serde(skip_serializing_if = "Option::is_none")]
    background: Option<BackgroundFile>,
    #[serde(skip_serializing_if = "Option::is_none")]
    schema: Option<String>,
}

impl ProceduralModel {
    /// The model as pretty JSON:
    ///
    /// ```json
    /// {
    ///   "format": "pbd-procedural-model",
    ///   "version": 5,
    ///   "hyper": {
    ///     "place_prior": { "kind": "uniform" },            // or { "kind": "dirichlet", "beta": 1.0 }
    ///     "color": { "terms": ["black", "grey", …, "pink"],  // the colour terms, in index order
    ///                "concentrations": [1, 16, 256, 4096],  // grid of α, π ~ Dirichlet(α·m) per place
    ///                "base": [0.119, 0.156, …],             // m over the terms
    ///                "draws_per_object": 30,                // D draws per object
    ///                "object_concentrations": [1, 4, 16, 64], // grid of a, θ ~ Dirichlet(a·π)
    ///                "chromatic_share": 0.3,                // the chromatic rule
    ///                "neighbour_share": 0.06 },             // ε to each neighbouring term (optional, 0)
    ///     "size": { "unit": "cm", "mu": 8.0, "kappa": 0.05, "alpha": 2.0, "beta": 12.5 }, // or "deci-pixels"
    ///     "structure_prior": { "neither": 0.328, "color": 0.328, "size": 0.328, "color+size": 0.016 },
    ///     "structure": "inferred",                         // or a fixed structure name
    ///     "relevance_log_threshold": 1.0                   // relevant when ln B10 > this
    ///   },
    ///   "schema": "pick_and_place",                        // the demonstrations' schema (optional)
    ///   "places": [                                        // sorted by name
    ///     { "name": "bin_left", "demonstrations": 3,
    ///       "color_objects": [[[3, 21], [9, 9]], …],        // per object its (term, draws), D in all
    ///       "size": { "n": 3, "sum": 2401, "sum_sq": 1951203 } }  // in quanta of the unit
    ///   ]
    /// }
    /// ```
    ///
    /// Versions 1 (independent colour draws, symmetric Dirichlet, uniform background), 2 (one
    /// Dirichlet per place over the summed colour draws, weighted per object) and 3 (the two-level
    /// model over 8 classes of the 64-bin histogram) are refused with an error that says to
    /// re-learn: their colour observations are histogram bins, not colour terms. The objects of a
    /// place are listed in sorted order.
    ///
    /// Size statistics are exact integers in quanta of the unit: tenths of a millimetre for `cm`
    /// (the observation in cm is x / 100), half-pixels (left + right pixel counts) for
    /// `deci-pixels` (x / 20). Version 4 files (deci-pixels only, the sums named `sum_half_pixels`
    /// and `sum_sq_half_pixels`) are read as well.
    pub fn to_json(&self) -> String {
        let h = &self.hyper;
        let file = FileV4 {
            format: MODEL_FORMAT,
            version: MODEL_VERSION,
            hyper: HyperFile {
                place_prior: h.place_prior,
                color: ColorHyper {
                    terms: COLOR_TERMS.iter().map(|t| t.to_string()).collect(),
                    concentrations: h.color_concentrations.clone(),
                    base: h.color_base.clone(),
                    draws_per_object: h.color_draws_per_object,
                    object_concentrations: h.color_object_concentrations.clone(),
                    chromatic_share: h.color_chromatic_share,
                    neighbour_share: h.color_neighbour_share,
                },
                size: SizeHyper {
                    unit: h.size_unit.name().into(),
                    mu: h.size_prior.mu(),
                    kappa: h.size_prior.kappa(),
                    alpha: h.size_prior.alpha(),
                    beta: h.size_prior.beta(),
                },
                structure_prior: StructurePriorFile {
                    neither: h.structure_prior[0],
                    color: h.structure_prior[1],
                    size: h.structure_prior[2],
                    color_size: h.structure_prior[3],
                },
                structure: h.structure.name().into(),
                relevance_log_threshold: h.relevance_log_threshold,
            },
            places: self
                .places
                .iter()
                .map(|(name, p)| PlaceFile {
                    name: name.clone(),
                    demonstrations: p.demonstrations,
                    color_objects: p.objects.clone(),
                    size: p.size,
                })
                .collect(),
            background: (!self.background.objects.is_empty()).then(|| BackgroundFile {
                color_objects: self.background.objects.clone(),
                size: self.background.size,
            }),
            schema: self.schema.clone(),
        };
        let mut s = serde_json::to_string_pretty(&file).unwrap_or_default();
        s.push('\n');
        s
    }

    /// Parses and validates a model; `origin` (a path) names the source in errors. Errors name the
    /// offending field: another `format` or `version`, a missing or unknown field, a wrong number of
    /// colour counts, inconsistent statistics, invalid hyper-parameters.
    pub fn from_json(text: &str, origin: &str) -> Result<Self, SchemaError> {
        let parse = |message: String| SchemaError::Parse {
            path: origin.to_string(),
            message,
        };
        let invalid = |field: &str, message: String| SchemaError::Invalid {
            path: origin.to_string(),
            field: field.to_string(),
            message,
        };
        if let Err(dup) = bayes::input::check_json_keys(text) {
            return Err(invalid(&dup.path, dup.to_string()));
        }
        let v: Value = serde_json::from_str(text).map_err(|e| parse(e.to_string()))?;
        let Value::Object(obj) = &v else {
            return Err(parse("a procedural model must be a JSON object".into()));
        };
        match obj.get("format") {
            Some(Value::String(f)) if f == MODEL_FORMAT => {}
            Some(other) => {
                return Err(invalid("format", format!("{other} is not {MODEL_FORMAT:?}")));
            }
            None => return Err(invalid("format", format!("missing (expected {MODEL_FORMAT:?})"))),
        }
        match obj.get("version") {
            Some(Value::Number(n)) if matches!(n.as_u64(), Some(4)) || n.as_u64() == Some(u64::from(MODEL_VERSION)) => {
            }
            Some(Value::Number(n)) if matches!(n.as_u64(), Some(1..=3)) => {
                let what = match n.as_u64() {
                    Some(1) => "independent colour draws",
                    Some(2) => "summed colour draws with a per-object weight",
                    _ => "colour classes of the 64-bin histogram",
                };
                return Err(invalid(
                    "version",
                    format!(
                        "model version {n} ({what}) is no longer supported; this build reads version \
                         {MODEL_VERSION} (two-level colour model over colour terms): re-run `pbd learn` on \
                         the demonstrations"
                    ),
                ));
            }
            Some(other) if other.is_u64() => {
                return Err(invalid(
                    "version",
                    format!("model version {other} is not supported (this build reads version {MODEL_VERSION})"),
                ));
            }
            Some(other) => {
                return Err(invalid(
                    "version",
                    format!(
                        "must be the integer {MODEL_VERSION}, got {other} (a JSON {})",
                        json_kind(other)
                    ),
                ));
            }
            None => return Err(invalid("version", "missing".into())),
        }
        for key in obj.keys() {
            if !matches!(
                key.as_str(),
                "format" | "version" | "hyper" | "places" | "background" | "schema"
            ) {
                return Err(invalid(key, "unknown field".into()));
            }
        }
        let hyper_v = obj.get("hyper").ok_or_else(|| invalid("hyper", "missing".into()))?;
        let hf: HyperFile = serde_json::from_value(hyper_v.clone()).map_err(|e| invalid("hyper", e.to_string()))?;
        if hf.color.terms != COLOR_TERMS {
            return Err(invalid(
                "hyper.color.terms",
                format!(
                    "{:?}; this build counts the colour terms {:?}",
                    hf.color.terms, COLOR_TERMS
                ),
            ));
        }
        let version4 = obj.get("version").and_then(Value::as_u64) == Some(4);
        let size_unit = match SizeUnit::parse(&hf.size.unit) {
            Some(SizeUnit::Centimetres) if version4 => {
                return Err(invalid(
                    "hyper.size.unit",
                    "\"cm\" in a version 4 file (version 4 sizes are deci-pixels)".into(),
                ));
            }
            Some(u) => u,
            None => {
                return Err(invalid(
                    "hyper.size.unit",
                    format!(
                        "{:?} is not one of {}",
                        hf.size.unit,
                        SizeUnit::ALL.map(|u| format!("{:?}", u.name())).join(", ")
                    ),
                ));
            }
        };
        let size_prior = NormalInverseGamma::new(hf.size.mu, hf.size.kappa, hf.size.alpha, hf.size.beta)
            .map_err(|e| invalid("hyper.size", e.to_string()))?;
        let structure = StructureChoice::parse(&hf.structure).ok_or_else(|| {
            invalid(
                "hyper.structure",
                format!(
                    "{:?} is not one of inferred, {}",
                    hf.structure,
                    Connectivity::ALL.map(Connectivity::name).join(", ")
                ),
            )
        })?;
        let sp = &hf.structure_prior;
        let hyper = Hyper {
            place_prior: hf.place_prior,
            color_concentrations: hf.color.concentrations,
            color_base: hf.color.base,
            color_draws_per_object: hf.color.draws_per_object,
            color_object_concentrations: hf.color.object_concentrations,
            color_chromatic_share: hf.color.chromatic_share,
            color_neighbour_share: hf.color.neighbour_share,
            size_unit,
            size_prior,
            structure_prior: [sp.neither, sp.color, sp.size, sp.color_size],
            structure,
            relevance_log_threshold: hf.relevance_log_threshold,
        };
        hyper.validate().map_err(|e| match e {
            SchemaError::Invalid { field, message, .. } => invalid(&field, message),
            other => other,
        })?;
        let places_v = obj.get("places").ok_or_else(|| invalid("places", "missing".into()))?;
        let Value::Array(places_v) = places_v else {
            return Err(invalid("places", "must be an array".into()));
        };
        if places_v.len() > MAX_PLACES {
            return Err(invalid(
                "places",
                format!("{} places is above the limit of {}", places_v.len(), MAX_PLACES),
            ));
        }
        let mut model = ProceduralModel::new(hyper)?;
        for (i, pv) in places_v.iter().enumerate() {
            let field = format!("places[{i}]");
            let pf: PlaceFile = serde_json::from_value(pv.clone()).map_err(|e| invalid(&field, e.to_string()))?;
            if pf.name.trim().is_empty() {
                return Err(invalid(&format!("{field}.name"), "empty place name".into()));
            }
            if let Some(c) = pf.name.chars().find(|c| c.is_control()) {
                return Err(invalid(
                    &format!("{field}.name"),
                    format!("{:?} contains the control character U+{:04X}", pf.name, u32::from(c)),
                ));
            }
            if model.places.contains_key(&pf.name) {
                return Err(invalid(
                    &format!("{field}.name"),
                    format!("duplicate place {:?}", pf.name),
                ));
            }
            if pf.demonstrations == 0 {
                return Err(invalid(&format!("{field}.demonstrations"), "must be >= 1".into()));
            }
            if pf.size.n != pf.demonstrations {
                return Err(invalid(
                    &format!("{field}.size.n"),
                    format!(
                        "{} size observations for {} demonstrations",
                        pf.size.n, pf.demonstrations
                    ),
                ));
            }
            pf.size.check().map_err(|m| invalid(&format!("{field}.size"), m))?;
            if pf.color_objects.len() as u64 != pf.demonstrations {
                return Err(invalid(
                    &format!("{field}.color_objects"),
                    format!(
                        "{} objects for {} demonstrations",
                        pf.color_objects.len(),
                        pf.demonstrations
                    ),
                ));
            }
            let d = u64::from(model.hyper.color_draws_per_object);
            let mut stats = color_objects(pf.color_objects, d, &field, &invalid)?;
            stats.demonstrations = pf.demonstrations;
            stats.size = pf.size;
            model.places.insert(pf.name, stats);
        }
        match obj.get("schema") {
            None => {}
            Some(Value::String(name)) if !name.is_empty() => model.schema = Some(name.clone()),
            Some(other) => {
                return Err(invalid(
                    "schema",
                    format!("must be a schema name, got {other} (a JSON {})", json_kind(other)),
                ));
            }
        }
        if let Some(bv) = obj.get("background") {
            let field = "background";
            let bf: BackgroundFile = serde_json::from_value(bv.clone()).map_err(|e| invalid(field, e.to_string()))?;
            if bf.color_objects.is_empty() {
                return Err(invalid(
                    "background.color_objects",
                    "empty (leave `background` out instead)".into(),
                ));
            }
            if bf.size.n > bf.color_objects.len() as u64 {
                return Err(invalid(
                    "background.size.n",
                    format!("{} size observations for {} objects", bf.size.n, bf.color_objects.len()),
                ));
            }
            bf.size.check().map_err(|m| invalid("background.size", m))?;
            let d = u64::from(model.hyper.color_draws_per_object);
            let mut stats = color_objects(bf.color_objects, d, field, &invalid)?;
            stats.size = bf.size;
            model.background = stats;
        }
        Ok(model)
    }
}

/// Checks and adds the colour draws of `objects` (each strictly ascending terms < [`COLORS`], no
/// zero counts, `d` draws) to a new [`PlaceStats`]; `field` prefixes errors.
fn color_objects(
    objects: Vec<Vec<(usize, u64)>>,
    d: u64,
    field: &str,
    invalid: &dyn Fn(&str, String) -> SchemaError,
) -> Result<PlaceStats, SchemaError> {
    let mut stats = PlaceStats::empty();
    for (j, o) in objects.into_iter().enumerate() {
        let of = format!("{field}.color_objects[{j}]");
        if o.windows(2).any(|w| w[0].0 >= w[1].0) {
            return Err(invalid(&of, "colour terms must be strictly ascending".into()));
        }
        for &(b, n) in &o {
            if b >= COLORS {
                return Err(invalid(&of, format!("colour term {b} out of range 0..{COLORS}")));
            }
            if n == 0 {
                return Err(invalid(&of, format!("colour term {b} has 0 draws")));
            }
        }
        let total: u64 = o.iter().map(|x| x.1).sum();
        if total != d {
            return Err(invalid(
                &of,
                format!("{total} colour draws, expected draws_per_object = {d}"),
            ));
        }
        stats.add_object(o).map_err(|e| invalid(&of, e.to_string()))?;
    }
    Ok(stats)
}

/// What kind of JSON value `v` is, for messages.
fn json_kind(v: &Value) -> &'static str {
    match v {
        Value::Null => "null",
        Value::Bool(_) => "boolean",
        Value::Number(_) => "number",
        Value::String(_) => "string",
        Value::Array(_) => "array",
        Value::Object(_) => "object",
    }
}
