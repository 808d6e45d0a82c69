//! The procedural model (§5.1–5.3): incremental = batch, the model file format, explanations.
//! The acceptance figures on rendered catalog features are measured with the experiment itself, in
//! `crates/pbd/tests/sorting_acceptance.rs`.

use proptest::prelude::*;
use rand::seq::SliceRandom;
use schema::SchemaError;
use schema::procedural::{
    Connectivity, Example, Features, Hyper, MODEL_VERSION, ProceduralModel, SizeUnit, StructureChoice,
};

fn arb_example() -> impl Strategy<Value = Example> {
    (
        proptest::collection::btree_map(0u8..10, 1u32..100, 1..5),
        1u32..50_000,
        0u32..50_000,
        0usize..3,
    )
        .prop_map(|(terms, l, r, place)| Example {
            features: Features {
                histogram: Vec::new(),
                pixels: [l, r],
                colors: terms.iter().map(|(&t, &w)| (t, f64::from(w) / 100.0)).collect(),
                dimensions: None,
            },
            reference: ["bin_a", "bin_b", "table"][place].to_string(),
        })
}

fn assert_same_predictions(a: &ProceduralModel, b: &ProceduralModel, probe: &Features) {
    let (pa, pb) = (a.predict(probe).unwrap(), b.predict(probe).unwrap());
    assert_eq!(pa.map_place, pb.map_place);
    for ((_, x), (_, y)) in pa.places.iter().zip(&pb.places) {
        assert!((x - y).abs() <= 1e-12);
    }
    assert!((pa.relevance.bayes_factor.log_b10 - pb.relevance.bayes_factor.log_b10).abs() <= 1e-12);
    let (sa, sb) = (a.structure_posterior().unwrap(), b.structure_posterior().unwrap());
    for (x, y) in sa.structures.iter().zip(&sb.structures) {
        assert!((x.probability - y.probability).abs() <= 1e-12);
        assert!((x.log_evidence - y.log_evidence).abs() <= 1e-12 * (1.0 + x.log_evidence.abs()));
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// §5.2: one demonstration at a time, in any order, or two halves merged = all at once.
    #[test]
    fn incremental_equals_batch_in_any_order(
        examples in proptest::collection::vec(arb_example(), 1..25),
        seed in any::<u64>(),
        cut in 0usize..25,
    ) {
        let batch = ProceduralModel::learn(Hyper::default().with_size_unit(SizeUnit::DeciPixels), &examples).unwrap();
        let mut shuffled = examples.clone();
        shuffled.shuffle(&mut bayes::rng::seeded(seed));
        let mut inc = ProceduralModel::new(Hyper::default().with_size_unit(SizeUnit::DeciPixels)).unwrap();
        for e in &shuffled {
            inc.update(e).unwrap();
        }
        prop_assert_eq!(&inc, &batch);
        let cut = cut.min(shuffled.len());
        let mut left = ProceduralModel::new(Hyper::default().with_size_unit(SizeUnit::DeciPixels)).unwrap();
        for e in &shuffled[..cut] {
            left.update(e).unwrap();
        }
        let mut right = ProceduralModel::new(Hyper::default().with_size_unit(SizeUnit::DeciPixels)).unwrap();
        for e in &shuffled[cut..] {
            right.update(e).unwrap();
        }
        left.merge(&right).unwrap();
        prop_assert_eq!(&left, &batch);
        assert_same_predictions(&inc, &batch, &examples[0].features);
        // And the file round trip is exact.
        let back = ProceduralModel::from_json(&batch.to_json(), "test").unwrap();
        prop_assert_eq!(&back, &batch);
    }
}

fn small_model() -> ProceduralModel {
    // Colour terms: 2 white, 3 red, 7 blue.
    let ex = |terms: &[u8], px: u32, place: &str| Example {
        features: Features {
            histogram: Vec::new(),
            pixels: [px, px + 20],
            colors: terms.iter().map(|&t| (t, 0.5)).collect(),
            dimensions: None,
        },
        reference: place.into(),
    };
    ProceduralModel::learn(
        Hyper::default().with_size_unit(SizeUnit::DeciPixels),
        &[
            ex(&[2, 3], 900, "red_bin"),
            ex(&[2, 7], 2500, "blue_bin"),
            ex(&[3], 1000, "red_bin"),
        ],
    )
    .unwrap()
}

fn field_of(e: SchemaError) -> String {
    match e {
        SchemaError::Invalid { field, message, .. } => format!("{field}: {message}"),
        other => panic!("expected an Invalid error, got {other}"),
    }
}

#[test]
fn model_file_round_trips_and_names_bad_fields() {
    let m = small_model();
    let json = m.to_json();
    assert!(json.contains("\"format\": \"pbd-procedural-model\""));
    assert_eq!(ProceduralModel::from_json(&json, "m.json").unwrap(), m);

    let next = MODEL_VERSION + 1;
    let other_version = json.replace(
        &format!("\"version\": {MODEL_VERSION}"),
        &format!("\"version\": {next}"),
    );
    let e = field_of(ProceduralModel::from_json(&other_version, "m.json").unwrap_err());
    assert!(
        e.starts_with("version") && e.contains(&format!("version {next}")),
        "{e}"
    );
    // A version 4 file (deci-pixels, the sums named for half-pixels) reads as the same model.
    let v4 = json
        .replace(&format!("\"version\": {MODEL_VERSION}"), "\"version\": 4")
        .replace("\"sum\":", "\"sum_half_pixels\":")
        .replace("\"sum_sq\":", "\"sum_sq_half_pixels\":");
    assert!(v4.contains("sum_half_pixels") && v4.contains("\"unit\": \"deci-pixels\""));
    assert_eq!(ProceduralModel::from_json(&v4, "v4.json").unwrap(), m);
    // Centimetres are version 5's.
    let v4_cm = v4.replace("\"unit\": \"deci-pixels\"", "\"unit\": \"cm\"");
    let e = field_of(ProceduralModel::from_json(&v4_cm, "v4.json").unwrap_err());
    assert!(e.starts_with("hyper.size.unit"), "{e}");
    // Versions 1 to 3 counted histogram bins, not colour terms: refused with a pointer to re-learn.
    for old in [1, 2, 3] {
        let v = json.replace(&format!("\"version\": {MODEL_VERSION}"), &format!("\"version\": {old}"));
        let e = field_of(ProceduralModel::from_json(&v, "m.json").unwrap_err());
        assert!(
            e.starts_with("version") && e.contains(&format!("version {old}")) && e.contains("pbd learn"),
            "{e}"
        );
    }

    let other_format = json.replace("pbd-procedural-model", "something-else");
    assert!(field_of(ProceduralModel::from_json(&other_format, "m.json").unwrap_err()).starts_with("format"));

    let mut v: serde_json::Value = serde_json::from_str(&json).unwrap();
    v["places"][1].as_object_mut().unwrap().remove("color_objects");
    let e = field_of(ProceduralModel::from_json(&v.to_string(), "m.json").unwrap_err());
    assert!(e.starts_with("places[1]") && e.contains("color_objects"), "{e}");

    let mut v: serde_json::Value = serde_json::from_str(&json).unwrap();
    v["places"][0]["color_objects"][0] = serde_json::json!([[3, 1], [7, 2]]);
    let e = field_of(ProceduralModel::from_json(&v.to_string(), "m.json").unwrap_err());
    assert!(
        e.starts_with("places[0].color_objects[0]") && e.contains("draws"),
        "{e}"
    );

    let mut v: serde_json::Value = serde_json::from_str(&json).unwrap();
    v["places"][0]["color_objects"][0] = serde_json::json!([[10, 30]]);
    let e = field_of(ProceduralModel::from_json(&v.to_string(), "m.json").unwrap_err());
    assert!(
        e.starts_with("places[0].color_objects[0]") && e.contains("term 10"),
        "{e}"
    );

    let mut v: serde_json::Value = serde_json::from_str(&json).unwrap();
    v["hyper"]["color"]["terms"][3] = serde_json::json!("crimson");
    let e = field_of(ProceduralModel::from_json(&v.to_string(), "m.json").unwrap_err());
    assert!(e.starts_with("hyper.color.terms"), "{e}");

    let mut v: serde_json::Value = serde_json::from_str(&json).unwrap();
    v["places"][0]["color_objects"].as_array_mut().unwrap().pop();
    let e = field_of(ProceduralModel::from_json(&v.to_string(), "m.json").unwrap_err());
    assert!(e.starts_with("places[0].color_objects"), "{e}");

    let mut v: serde_json::Value = serde_json::from_str(&json).unwrap();
    v["hyper"].as_object_mut().unwrap().remove("size");
    let e = field_of(ProceduralModel::from_json(&v.to_string(), "m.json").unwrap_err());
    assert!(e.starts_with("hyper") && e.contains("size"), "{e}");

    let mut v: serde_json::Value = serde_json::from_str(&json).unwrap();
    v["hyper"]["color"]["concentrations"][1] = serde_json::json!(-1.0);
    let e = field_of(ProceduralModel::from_json(&v.to_string(), "m.json").unwrap_err());
    assert!(e.starts_with("hyper.color.concentrations[1]"), "{e}");

    let mut v: serde_json::Value = serde_json::from_str(&json).unwrap();
    v["hyper"]["color"]["base"][5] = serde_json::json!(0.0);
    let e = field_of(ProceduralModel::from_json(&v.to_string(), "m.json").unwrap_err());
    assert!(e.starts_with("hyper.color.base[5]"), "{e}");

    let mut v: serde_json::Value = serde_json::from_str(&json).unwrap();
    v["hyper"]["color"]["chromatic_share"] = serde_json::json!(-0.5);
    let e = field_of(ProceduralModel::from_json(&v.to_string(), "m.json").unwrap_err());
    assert!(e.starts_with("hyper.color.chromatic_share"), "{e}");

    let mut v: serde_json::Value = serde_json::from_str(&json).unwrap();
    v["hyper"]["color"]["neighbour_share"] = serde_json::json!(0.75);
    let e = field_of(ProceduralModel::from_json(&v.to_string(), "m.json").unwrap_err());
    assert!(e.starts_with("hyper.color.neighbour_share"), "{e}");

    // A file written before the neighbour share existed reads as 0 (the draws it was learned with).
    let mut v: serde_json::Value = serde_json::from_str(&json).unwrap();
    v["hyper"]["color"].as_object_mut().unwrap().remove("neighbour_share");
    let m = ProceduralModel::from_json(&v.to_string(), "m.json").unwrap();
    assert_eq!(m.hyper().color_neighbour_share, 0.0);

    let mut v: serde_json::Value = serde_json::from_str(&json).unwrap();
    v["places"][0]["size"]["n"] = serde_json::json!(7);
    let e = field_of(ProceduralModel::from_json(&v.to_string(), "m.json").unwrap_err());
    assert!(e.starts_with("places[0].size"), "{e}");

    assert!(matches!(
        ProceduralModel::from_json("{", "m.json"),
        Err(SchemaError::Parse { .. })
    ));
}

#[test]
fn explain_and_samples_are_deterministic_and_plain() {
    let m = small_model();
    let e = m.explain().unwrap();
    assert_eq!(e, m.explain().unwrap());
    assert_eq!(e.places.len(), 2);
    assert!(
        e.text.contains("red_bin") && e.text.contains("deci-pixels"),
        "{}",
        e.text
    );
    assert!(
        e.places[1].top_colors.iter().any(|c| c.name == "red"),
        "{:?}",
        e.places[1]
    );
    let draw = |seed| m.sample_instances(&mut bayes::rng::seeded(seed), 20).unwrap();
    assert_eq!(draw(7), draw(7));
    assert!(
        draw(7)
            .iter()
            .all(|i| !i.features.colors.is_empty() && i.features.pixels[0] > 0)
    );
}

#[test]
fn fixed_structure_ignores_the_other_feature() {
    let mut m = small_model();
    m.set_structure(StructureChoice::Fixed(Connectivity::parse("size").unwrap()))
        .unwrap();
    let sp = m.structure_posterior().unwrap();
    assert_eq!(sp.map(), Connectivity::parse("size").unwrap());
    // A red-coloured object of the blue bin's size goes to the blue bin.
    let f = Features {
        histogram: Vec::new(),
        pixels: [2500, 2500],
        colors: vec![(3, 1.0)],
        dimensions: None,
    };
    assert_eq!(m.predict(&f).unwrap().map_place, "blue_bin");
}

/// Explaining a model with many places stays cheap: the consistency draws are shared out over the
/// places (400 in all, 10 to 200 each) and the model-wide terms are computed once.
#[test]
fn explain_handles_many_places_and_the_place_limit_holds() {
    let examples: Vec<Example> = (0..40)
        .map(|i| Example {
            features: Features {
                histogram: Vec::new(),
                pixels: [1000 + 10 * i, 1000 + 10 * i],
                colors: vec![((i % 10) as u8, 1.0)],
                dimensions: None,
            },
            reference: format!("place_{i:03}"),
        })
        .collect();
    let m = ProceduralModel::learn(Hyper::default().with_size_unit(SizeUnit::DeciPixels), &examples).unwrap();
    let e = m.explain().unwrap();
    assert_eq!(e.places.len(), 40);
    assert!(e.places.iter().all(|p| (0.0..=1.0).contains(&p.consistency)));
    // A model file above the place limit is refused, naming the field.
    let many: Vec<Example> = (0..=schema::procedural::MAX_PLACES)
        .map(|i| Example {
            reference: format!("p{i}"),
            ..examples[0].clone()
        })
        .collect();
    let err = ProceduralModel::learn(Hyper::default().with_size_unit(SizeUnit::DeciPixels), &many)
        .unwrap_err()
        .to_string();
    assert!(err.contains("limit"), "{err}");
    let mut v: serde_json::Value = serde_json::from_str(&m.to_json()).unwrap();
    let place = v["places"][0].clone();
    v["places"] = serde_json::Value::Array(vec![place; schema::procedural::MAX_PLACES + 1]);
    let err = ProceduralModel::from_json(&v.to_string(), "big.json")
        .unwrap_err()
        .to_string();
    assert!(err.contains("places") && err.contains("limit"), "{err}");
}

/// §5.1.3: M₀ "a procedural feature model for non-sortable objects". Objects the teacher left alone
/// fit it; an object like them then has a lower B₁₀, one unlike them is still relevant; the background
/// survives the file round trip and `merge`, and a bad one is named.
#[test]
fn background_objects_fit_the_relevance_model_m0() {
    let probe = |terms: &[u8], px: u32| Features {
        histogram: Vec::new(),
        pixels: [px, px + 20],
        colors: terms.iter().map(|&t| (t, 1.0 / terms.len() as f64)).collect(),
        dimensions: None,
    };
    let prior = small_model();
    assert_eq!(prior.background_objects(), 0);
    // Left alone in the scenes: pink (9) and white-and-pink objects.
    let mut fitted = small_model();
    for (terms, px) in [(&[9u8][..], 1000), (&[2, 9][..], 1200), (&[9][..], 900)] {
        fitted.observe_background(&probe(terms, px)).unwrap();
    }
    assert_eq!(fitted.background_objects(), 3);
    let b10 = |m: &ProceduralModel, f: &Features| m.predict(f).unwrap().relevance.bayes_factor.log_b10;
    let (pink, red) = (probe(&[9, 3], 1000), probe(&[3], 1000));
    assert!(
        b10(&fitted, &pink) < b10(&prior, &pink) - 1.0,
        "a pink-and-red object looks like the background: {} vs {}",
        b10(&fitted, &pink),
        b10(&prior, &pink)
    );
    assert!(
        b10(&fitted, &red) > 2.0,
        "a red object is still relevant: {}",
        b10(&fitted, &red)
    );
    // The place decision does not change (an unconnected feature is scored by M₀ in every place, so
    // only the mixing over structures moves the place probabilities).
    assert_eq!(
        fitted.predict(&red).unwrap().map_place,
        prior.predict(&red).unwrap().map_place
    );

    let back = ProceduralModel::from_json(&fitted.to_json(), "m.json").unwrap();
    assert_eq!(back, fitted);
    assert!(
        !prior.to_json().contains("background"),
        "no background: the file is unchanged"
    );
    let mut merged = small_model();
    merged.merge(&fitted).unwrap();
    assert_eq!(merged.background_objects(), 3);

    let mut v: serde_json::Value = serde_json::from_str(&fitted.to_json()).unwrap();
    v["background"]["size"]["n"] = serde_json::json!(7);
    let e = field_of(ProceduralModel::from_json(&v.to_string(), "m.json").unwrap_err());
    assert!(e.starts_with("background.size.n"), "{e}");
    let mut v: serde_json::Value = serde_json::from_str(&fitted.to_json()).unwrap();
    v["background"]["color_objects"][0] = serde_json::json!([[12, 100]]);
    let e = field_of(ProceduralModel::from_json(&v.to_string(), "m.json").unwrap_err());
    assert!(e.starts_with("background.color_objects[0]"), "{e}");
    assert!(fitted.observe_background(&probe(&[], 0)).is_err());
}
