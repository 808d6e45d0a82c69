//! One sorting / relevance trial as a pure function of (options, features, examples, trial): equal
//! to that trial of the whole experiment, and a χ² test that cannot be computed is reported as such.

use std::path::Path;

use pbd::experiment::features::{FeatureBank, load_bank};
use pbd::experiment::sorting::{chi2_against_random, run_on_bank, trial};
use pbd::experiment::{Feature, SortingOptions};
use pbd::progress::Quiet;

fn bank() -> FeatureBank {
    load_bank(&Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/household_features.json")).expect("fixture")
}

fn options(feature: Feature, classes: &[&str], name: &str) -> SortingOptions {
    SortingOptions {
        feature,
        classes: classes.iter().map(|c| c.to_string()).collect(),
        trials: 3,
        max_examples: 2,
        seed: 11,
        output: std::env::temp_dir().join(format!("pbd-trials-{}-{name}", std::process::id())),
        ..SortingOptions::default()
    }
}

fn csv_rows(path: &Path) -> Vec<Vec<String>> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect()
}

#[test]
fn a_sorting_trial_alone_equals_that_trial_of_the_experiment() {
    let bank = bank();
    let o = options(Feature::Color, &["red", "blue", "green"], "color");
    run_on_bank(&o, &bank, &Quiet).unwrap();
    let rows = csv_rows(&o.output.join("success.csv"));
    assert_eq!(rows.len(), 6);
    for row in &rows {
        let (n, t): (usize, usize) = (row[0].parse().unwrap(), row[1].parse().unwrap());
        let r = trial(&o, &bank, n, t).unwrap();
        assert_eq!(r.correct.to_string(), row[2]);
        assert_eq!(r.tested.to_string(), row[3]);
        assert_eq!(format!("{:.6}", r.success_rate), row[4]);
        assert_eq!(r.chi2_p_value.map_or("NA".into(), |p| format!("{p:.6e}")), row[5]);
        assert_eq!(r.map_structure, row[6]);
    }
    // Out of range, and experiments that are not made of independent trials, are refused.
    assert!(trial(&o, &bank, 0, 0).is_err());
    assert!(
        trial(&o, &bank, 10_000, 0)
            .unwrap_err()
            .to_string()
            .contains("examples")
    );
    let inc = SortingOptions {
        feature: Feature::Incremental,
        ..o.clone()
    };
    assert!(trial(&inc, &bank, 1, 0).is_err());
    let _ = std::fs::remove_dir_all(&o.output);
}

#[test]
fn a_relevance_trial_alone_equals_that_trial_of_the_experiment() {
    let bank = bank();
    let o = options(Feature::Relevance, &["red", "blue"], "relevance");
    run_on_bank(&o, &bank, &Quiet).unwrap();
    for row in csv_rows(&o.output.join("relevance.csv")) {
        let r = trial(&o, &bank, row[0].parse().unwrap(), row[1].parse().unwrap()).unwrap();
        assert_eq!(format!("{:.6}", r.auc.unwrap()), row[2]);
        assert_eq!(format!("{:.6}", r.accuracy_at_threshold.unwrap()), row[3]);
    }
    let _ = std::fs::remove_dir_all(&o.output);
}

#[test]
fn chi2_that_cannot_be_computed_is_not_reported_as_p_one() {
    // Every object in one place: no test, and it says why.
    let e = chi2_against_random(&[vec![5.0, 0.0], vec![4.0, 0.0]]).unwrap_err();
    assert!(e.contains("one place"), "{e}");
    // A place never predicted is left out; the rest is tested: [[5, 0], [0, 4]] has χ² = N φ² = 9
    // with 1 dof, p = erfc(√(9/2)) = 0.0026998 (scipy's chi2_contingency, correction=False).
    let p = chi2_against_random(&[vec![5.0, 0.0, 0.0], vec![0.0, 4.0, 0.0], vec![0.0, 0.0, 0.0]]).unwrap();
    assert!((p - 0.002_699_8).abs() < 1e-6, "{p}");
}

#[test]
fn a_held_out_catalog_tests_every_presentation_of_it() {
    let bank = bank();
    let fixture = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/household_features.json");
    let o = SortingOptions {
        test_features: Some(fixture),
        ..options(Feature::Color, &["red", "blue"], "held-out")
    };
    let classes = |c: &str| {
        bank.presentations
            .iter()
            .filter(|p| p.color_class.as_deref() == Some(c))
            .count()
    };
    let r = pbd::experiment::sorting::trial_held_out(&o, &bank, Some(&bank), 1, 0).unwrap();
    assert_eq!(r.tested, classes("red") + classes("blue"));
    assert!(r.success_rate > 0.5, "{r:?}");
    // The whole run reads the held-out bank and says so.
    let s = run_on_bank(&o, &bank, &Quiet).unwrap();
    assert!(s.catalog.contains("held-out"), "{}", s.catalog);
    let _ = std::fs::remove_dir_all(&o.output);
}
