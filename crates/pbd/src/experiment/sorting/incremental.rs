//! The incremental-learning experiment (Fig. 5.11): the colour pmfs after each example, and
//! incremental = batch over several orders.

use rand::seq::SliceRandom;
use schema::procedural::{Example, Features, Hyper, ProceduralModel};

use super::pools::{Label, class_pools, draw, trial_rng};
use super::report::Summary;
use crate::experiment::SortingOptions;
use crate::experiment::features::FeatureBank;
use crate::figure::Figure;

/// Runs it: `incremental_pmfs.csv`, `incremental_pmfs.svg`, `samples.svg`, `size_density.svg` and
/// the final model's explanation as notes.
pub(super) fn incremental(
    args: &SortingOptions,
    bank: &FeatureBank,
    hyper: &Hyper,
    label: Label,
    classes: &[String],
    summary: &mut Summary,
) -> anyhow::Result<()> {
    let pools = class_pools(bank, label, classes, 1)?;
    let mut rng = trial_rng(args.seed, 3, 0, 0);
    let m = args.max_examples.min(pools.iter().map(Vec::len).min().unwrap_or(1));
    // Interleave the classes: one example of each per step.
    let mut examples = Vec::new();
    for (k, pool) in pools.iter().enumerate() {
        for (i, (_, f)) in draw(bank, pool, m, &mut rng).into_iter().enumerate() {
            examples.push((i, k, f));
        }
    }
    examples.sort_by_key(|e| (e.0, e.1));
    let demos: Vec<Example> = examples
        .iter()
        .map(|(_, k, f)| Example {
            features: f.clone(),
            reference: classes[*k].clone(),
        })
        .collect();
    let mut model = ProceduralModel::new(hyper.clone())?;
    let mut rows: Vec<(String, Vec<Vec<f64>>)> = classes.iter().map(|c| (c.clone(), Vec::new())).collect();
    let mut csv = Vec::new();
    for (step, e) in demos.iter().enumerate() {
        model.update(e)?;
        if step % classes.len() == classes.len() - 1 {
            for (k, c) in classes.iter().enumerate() {
                let pmf = model.color_pmf(c)?;
                for (b, p) in pmf.iter().enumerate() {
                    csv.push(format!("{},{c},{b},{p:.8}", step / classes.len() + 1));
                }
                rows[k].1.push(pmf);
            }
        }
    }
    // Incremental = batch, for several orders.
    let batch = ProceduralModel::learn(hyper.clone(), &demos)?;
    let mut max_diff: f64 = 0.0;
    let mut identical = model == batch;
    for _ in 0..10 {
        let mut d = demos.clone();
        d.shuffle(&mut rng);
        let mut inc = ProceduralModel::new(hyper.clone())?;
        for e in &d {
            inc.update(e)?;
        }
        identical &= inc == batch;
        for c in classes {
            let (a, b) = (inc.color_pmf(c)?, batch.color_pmf(c)?);
            max_diff = a.iter().zip(&b).map(|(x, y)| (x - y).abs()).fold(max_diff, f64::max);
            let (sa, sb) = (inc.size_density(c)?, batch.size_density(c)?);
            max_diff = max_diff
                .max((sa.loc() - sb.loc()).abs())
                .max((sa.scale() - sb.scale()).abs());
        }
    }
    let dir = &args.output;
    summary.write_csv(
        dir,
        "incremental_pmfs.csv",
        "examples_per_class,place,bin,probability",
        &csv,
    )?;
    summary.add_figure(
        dir,
        "incremental_pmfs.svg",
        Figure::PmfGrid {
            title: "colour pmf per place after each example (Fig. 5.11)".into(),
            rows,
        },
    );
    // Swatches and size densities of the final model (Figs. 5.12, 5.5).
    let mut srng = trial_rng(args.seed, 4, 0, 0);
    let inst = model.sample_instances(&mut srng, 36 * classes.len())?;
    let by_place: Vec<(String, Vec<Features>)> = classes
        .iter()
        .map(|c| {
            (
                c.clone(),
                inst.iter()
                    .filter(|i| &i.place == c)
                    .map(|i| i.features.clone())
                    .collect(),
            )
        })
        .collect();
    summary.add_figure(dir, "samples.svg", Figure::Swatches(by_place));
    let dists = classes
        .iter()
        .map(|c| Ok((c.clone(), model.size_density(c)?)))
        .collect::<anyhow::Result<Vec<_>>>()?;
    summary.add_figure(
        dir,
        "size_density.svg",
        Figure::SizeDensities {
            places: dists,
            samples: vec![],
        },
    );
    let ex = model.explain()?;
    summary.measure = "colour pmf per place after each example".into();
    summary.notes.push(format!(
        "incremental = batch over 10 random orders: identical statistics {identical}, max |difference| of predictive quantities {max_diff:e}"
    ));
    summary.notes.extend(ex.text.lines().map(str::to_string));
    Ok(())
}
