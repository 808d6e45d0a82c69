//! The feature-selection experiment (§5.3.3): is the MAP connectivity structure the task's, for
//! colour-only, size-only and colour-and-size tasks.

use anyhow::bail;
use schema::procedural::{Connectivity, Example, Hyper, ProceduralModel, StructureChoice};

use super::pools::{draw, trial_rng};
use super::report::{Row, Summary, examples_chart};
use super::sweep::Trials;
use crate::experiment::SortingOptions;
use crate::experiment::features::FeatureBank;
use crate::figure::{Figure, Series};
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

/// Runs it: `selection.csv`, `selection.svg`, a table per task.
pub(super) fn selection(
    args: &SortingOptions,
    progress: &dyn Progress,
    bank: &FeatureBank,
    hyper: &Hyper,
    summary: &mut Summary,
) -> anyhow::Result<()> {
    let max_n = args.max_examples.min(3);
    let tasks = selection_tasks();
    let mut trials = Trials::start(progress, tasks.len(), max_n, args.trials);
    let mut csv = Vec::new();
    let mut series = Vec::new();
    let hyper = Hyper {
        structure: StructureChoice::Inferred,
        ..hyper.clone()
    };
    for (ti, (name, expected, places)) in tasks.iter().enumerate() {
        let pools = task_pools(bank, name, places)?;
        let names: Vec<String> = places.iter().map(|p| p.0.to_string()).collect();
        let by_n = trials.sweep(|n, t| {
            let mut rng = trial_rng(args.seed, 10 + ti as u64, n, t);
            let mut train = Vec::new();
            for (k, pool) in pools.iter().enumerate() {
                for (_, features) in draw(bank, pool, n, &mut rng) {
                    train.push(Example {
                        features,
                        reference: names[k].clone(),
                    });
                }
            }
            let model = ProceduralModel::learn(hyper.clone(), &train)?;
            let sp = model.structure_posterior()?;
            let ok = sp.map() == *expected;
            let probs: Vec<String> = sp.structures.iter().map(|s| format!("{:.6}", s.probability)).collect();
            let line = format!("{name},{n},{t},{},{ok},{}", sp.map().name(), probs.join(","));
            Ok((f64::from(u8::from(ok)), line))
        })?;
        // Stopped (Ctrl-C) before this task's first trial: the tasks done so far are the result,
        // marked partial.
        if by_n.is_empty() {
            break;
        }
        let mut rows = Vec::new();
        for (n, results) in by_n {
            let (hits, lines): (Vec<f64>, Vec<String>) = results.into_iter().unzip();
            csv.extend(lines);
            rows.push(Row::of(n, &hits));
        }
        series.push(Series {
            label: name.to_string(),
            points: rows.iter().map(Row::point).collect(),
            errors: vec![],
        });
        summary.rows.insert(name.to_string(), rows);
    }
    summary.partial = trials.finish();
    let dir = &args.output;
    summary.write_csv(
        dir,
        "selection.csv",
        "task,examples_per_class,trial,map_structure,correct,p_neither,p_color,p_size,p_color_size",
        &csv,
    )?;
    summary.add_figure(
        dir,
        "selection.svg",
        Figure::Lines(examples_chart(
            "feature selection: right structure named (fraction of trials)".into(),
            "fraction of trials",
            max_n,
            series,
            vec![(0.9, "0.9".into())],
        )),
    );
    summary.measure = "fraction of trials whose MAP structure is the task's".into();
    summary.classes = tasks.iter().map(|t| t.0.to_string()).collect();
    Ok(())
}

/// The presentations of each place of the task `name`: those whose labels match its constraints.
fn task_pools(bank: &FeatureBank, name: &str, places: &[TaskPlace]) -> anyhow::Result<Vec<Vec<usize>>> {
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
    Ok(pools)
}
