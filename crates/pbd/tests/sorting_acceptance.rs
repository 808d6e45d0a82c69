//! The acceptance figures of the procedural model (§5.1–5.3), measured with the library's own
//! sorting experiment ([`pbd::experiment::sorting::run_on_bank`]) — the code `pbd experiment sorting`
//! runs — on features rendered once from the shipped household catalog.
//!
//! `tests/data/household_features.json` holds those features: every presentation of
//! `assets/objects/household.toml` rendered in 4 seeded views by the simulator's vision pipeline
//! (Dexter's head cameras, background subtraction, stereo matching with the table's plane known,
//! the kept bins of the 64-colour histogram, the kept colour terms weighed by the surface each
//! pixel stands for, the left/right pixel counts and the measured dimensions), written by
//! `pbd experiment sorting --feature color --views 4 --seed 1 --dump-features FILE -o DIR`.

use std::path::{Path, PathBuf};

use pbd::experiment::features::{FeatureBank, load_bank};
use pbd::experiment::sorting::{Summary, run_on_bank};
use pbd::experiment::{Feature, SortingOptions};
use pbd::progress::Quiet;

const COLOR_CLASSES: [&str; 6] = ["red", "blue", "green", "orange", "white", "black"];

fn bank() -> FeatureBank {
    load_bank(&Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/household_features.json")).expect("fixture")
}

fn out_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("pbd-acceptance-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn color_pairs() -> Vec<(&'static str, &'static str)> {
    let mut v = Vec::new();
    for (i, a) in COLOR_CLASSES.iter().enumerate() {
        for b in &COLOR_CLASSES[i + 1..] {
            v.push((*a, *b));
        }
    }
    v
}

fn run(bank: &FeatureBank, feature: Feature, classes: &[&str], n: usize, trials: usize, seed: u64) -> Summary {
    let options = SortingOptions {
        feature,
        classes: classes.iter().map(|c| c.to_string()).collect(),
        trials,
        max_examples: n,
        seed,
        output: out_dir(&format!("{feature:?}-{}", classes.join("-"))),
        ..SortingOptions::default()
    };
    let s = run_on_bank(&options, bank, &Quiet).unwrap();
    let _ = std::fs::remove_dir_all(&options.output);
    s
}

/// The mean of the row for `n` examples per class.
fn at(s: &Summary, n: usize) -> f64 {
    let rows = s.rows.values().next().expect("one row set");
    rows.iter().find(|r| r.examples == n).expect("row for n").mean
}

#[test]
fn fixture_covers_the_household_catalog() {
    let b = bank();
    assert!(b.presentations.len() >= 60);
    assert!(b.features.iter().all(|v| v.len() == 4));
    assert!(
        b.features
            .iter()
            .flatten()
            .all(|f| !f.histogram.is_empty() && !f.colors.is_empty() && f.pixels[0] > 0)
    );
    assert!(b.presentations.iter().any(|p| p.name == "jif-1"));
}

/// Colour sorting with one example per class (Fig. 5.2), the structure fixed to colour as in the
/// seed, 10 trials per pair. Both definitions must reach 0.85: the seed's pair (red vs blue) and
/// the mean over the 15 pairs of the catalog's colour classes. Version 4 measured 0.922 and 0.891.
#[test]
fn acceptance_color_sorting_one_example_per_class() {
    let b = bank();
    let mut means = Vec::new();
    for (x, y) in color_pairs() {
        let mean = at(&run(&b, Feature::Color, &[x, y], 1, 10, 100), 1);
        eprintln!("colour sorting {x} vs {y}, 1 example per class: {mean:.3}");
        means.push(mean);
        if (x, y) == ("red", "blue") {
            assert!(mean >= 0.85, "red vs blue: {mean}");
        }
    }
    let all = means.iter().sum::<f64>() / means.len() as f64;
    eprintln!("colour sorting, 1 example per class, mean over all colour-class pairs: {all:.3}");
    assert!(all >= 0.85, "{all}");
}

/// Size sorting Small vs Large with three examples per class (Fig. 5.6), structure fixed to size.
#[test]
fn acceptance_size_sorting_three_examples_per_class() {
    let mean = at(&run(&bank(), Feature::Size, &["small", "large"], 3, 10, 200), 3);
    eprintln!("size sorting small vs large, 3 examples per class: {mean:.3}");
    assert!(mean >= 0.85, "{mean}");
}

/// Task relevance (Fig. 5.8) by ln B10 with three examples per class: ROC AUC of the task's
/// remaining presentations against every other presentation, colour structure, mean over the
/// colour-class pairs and the seed's red + blue task. Version 4 measured 0.928 mean over pairs,
/// 0.931 red + blue. What limits it: the catalog's "red" class holds the pink drain cleaner, whose
/// colour term is pink, and its "white" yogurt cup has a pink lid.
#[test]
fn acceptance_relevance_roc_auc_three_examples_per_class() {
    let b = bank();
    let mut aucs = Vec::new();
    for (x, y) in color_pairs() {
        let a = at(&run(&b, Feature::Relevance, &[x, y], 3, 10, 300), 3);
        eprintln!("relevance ROC AUC, {x} + {y} vs others, 3 examples per class: {a:.3}");
        aucs.push(a);
    }
    let all = aucs.iter().sum::<f64>() / aucs.len() as f64;
    eprintln!("relevance ROC AUC, mean over colour-class pairs: {all:.3}");
    assert!(all >= 0.9, "{all}");
    assert!(aucs[0] >= 0.9, "red + blue: {}", aucs[0]);
}

/// Feature selection (§5.3.3) from one to three demonstrations per class, 200 trials each: the
/// fraction of trials whose MAP structure is the task's; the acceptance figure is n = 3 for each of
/// the colour, size and colour+size tasks. Version 4 measured 0.28, 0.845, 0.92 for the size task
/// (n = 1, 2, 3) and 1.0 at n = 3 for the other two. Chance colour agreement is what the size task
/// fights (two pink drain cleaners among the large objects); the structure prior makes colour+size
/// e³ times less likely than one feature ([`pbd::schema::procedural::DEFAULT_STRUCTURE_PRIOR`]).
#[test]
fn acceptance_feature_selection() {
    let s = run(&bank(), Feature::Selection, &[], 3, 200, 400);
    for (task, rows) in &s.rows {
        let rate = rows.iter().find(|r| r.examples == 3).expect("n = 3").mean;
        eprintln!("feature selection, {task}: {rate:.3} at n = 3");
        assert!(rate >= 0.9, "{task}: {rate}");
    }
    assert_eq!(s.rows.len(), 3);
}
