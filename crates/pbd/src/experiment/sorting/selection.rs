//! The feature-selection experiment (§5.3.3): is the MAP connectivity structure the task's, for
//! colour-only, size-only and colour-and-size tasks.

use anyhow::bail;
use rand::seq::SliceRandom;
use schema::procedural::{Connectivity, Example, Hyper, ProceduralModel, StructureChoice};

use super::pools::{trial_rng, view};
use super::report::{Row, Summary, mean_sd, write_csv};
use crate::experiment::SortingOptions;
use crate::experiment::features::FeatureBank;
use crate::figure::{Figure, LineChart, Series};
use crate::progress::Progress;

/// A place of a feature-selection task: (place name, colour class, size class) constraints.
type TaskPlace = (&'static str, Option<&'static str>, Option<&'static str>);

/// The feature-selection tasks: (name, expected structure, places).
fn selection_tasks() -> Vec<(&'static str, Connectivity, Vec<TaskPlace>)> {
    vec![
        (
            "color-only (red vs blue)",
            Connectivity::parse("color").unwrap_or_default(),
            vec![("red", Some("red"), None), ("blue", Some("blue"), None)],
        ),
        (
            "size-only (small vs large)",
            Connectivity::parse("size").unwrap_or_default(),
            vec![("small", None, Some("small")), ("large", None, Some("large"))],
        ),
        (
            "color-and-size (red/green x small/large)",
            Connectivity::parse("color+size").unwrap_or_default(),
            vec![
                ("red-small", Some("red"), Some("small")),
                ("red-large", Some("red"), Some("large")),
                ("green-small", Some("green"), Some("small")),
                ("green-large", Some("green"), Some("large")),
            ],
        ),
    ]
}

pub(super) fn selection(
    args: &SortingOptions,
    progress: &dyn Progress,
    bank: &FeatureBank,
    hyper: &Hyper,
    summary: &mut Summary,
) -> anyhow::Result<()> {
    let max_n = args.max_examples.min(3);
    let tasks = selection_tasks();
    progress.phase("trials", Some((tasks.len() * max_n * args.trials) as u64));
    let mut csv = Vec::new();
    let mut series = Vec::new();
    let hyper = Hyper {
        structure: StructureChoice::Inferred,
        ..hyper.clone()
    };
    for (ti, (name, expected, places)) in tasks.iter().enumerate() {
        let pools: Vec<Vec<usize>> = places
            .iter()
            .map(|(_, c, s)| {
                (0..bank.presentations.len())
                    .filter(|&i| {
                        let p = &bank.presentations[i];
                        c.is_none_or(|c| p.color_class.as_deref() == Some(c))
                            && s.is_none_or(|s| p.size_class.as_deref() == Some(s))
                    })
                    .collect()
            })
            .collect();
        if let Some((k, _)) = pools.iter().enumerate().find(|(_, p)| p.is_empty()) {
            bail!(
                "catalog {}: no presentation for place `{}` of task {name}",
                bank.catalog,
                places[k].0
            );
        }
        let names: Vec<String> = places.iter().map(|p| p.0.to_string()).collect();
        let mut rows = Vec::new();
        for n in 1..=max_n {
            let mut hits = Vec::new();
            for t in 0..args.trials {
                let mut rng = trial_rng(args.seed, 10 + ti as u64, n, t);
                let mut train = Vec::new();
                for (k, pool) in pools.iter().enumerate() {
                    let mut pool = pool.clone();
                    pool.shuffle(&mut rng);
                    for &p in pool.iter().take(n) {
                        train.push(Example {
                            features: view(bank, &mut rng, p).clone(),
                            reference: names[k].clone(),
                        });
                    }
                }
                let model = ProceduralModel::learn(hyper.clone(), &train)?;
                let sp = model.structure_posterior()?;
                let ok = sp.map() == *expected;
                hits.push(f64::from(u8::from(ok)));
                let probs: Vec<String> = sp.structures.iter().map(|s| format!("{:.6}", s.probability)).collect();
                csv.push(format!("{name},{n},{t},{},{ok},{}", sp.map().name(), probs.join(",")));
                progress.advance(1);
            }
            let (mean, sd) = mean_sd(&hits);
            rows.push(Row {
                examples: n,
                mean,
                sd,
                median_p: None,
                max_p: None,
                p_computed: None,
                pooled: None,
            });
        }
        series.push(Series {
            label: name.to_string(),
            points: rows.iter().map(|r| (r.examples as f64, r.mean)).collect(),
            errors: vec![],
        });
        summary.rows.insert(name.to_string(), rows);
    }
    progress.finish();
    let dir = &args.output;
    let csv_path = dir.join("selection.csv");
    write_csv(
        &csv_path,
        "task,examples_per_class,trial,map_structure,correct,p_neither,p_color,p_size,p_color_size",
        &csv,
    )?;
    let svg = dir.join("selection.svg");
    summary.figures.push((
        svg.clone(),
        Figure::Lines(LineChart {
            title: "feature selection: right structure named (fraction of trials)".into(),
            x_label: "examples per class".into(),
            y_label: "fraction of trials".into(),
            x_range: (0.5, max_n as f64 + 0.5),
            y_range: (0.0, 1.05),
            log_y: false,
            series,
            hlines: vec![(0.9, "0.9".into())],
        }),
    ));
    summary.measure = "fraction of trials whose MAP structure is the task's".into();
    summary.classes = tasks.iter().map(|t| t.0.to_string()).collect();
    summary.files.extend([csv_path, svg].map(|p| p.display().to_string()));
    Ok(())
}
