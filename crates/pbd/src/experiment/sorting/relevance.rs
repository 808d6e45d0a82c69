//! The task-relevance experiment (Figs. 5.8, 5.10): ROC of ln B10, task objects against all others.

use bayes::roc::roc;

use super::report::{Row, Summary, mean_sd};
use super::trial::Run;
use crate::experiment::SortingOptions;
use crate::experiment::features::FeatureBank;
use crate::figure::{Figure, LineChart, Series};

/// Its report on the trials `run` on `bank`: `relevance.csv`, `relevance_objects.csv`, `roc.csv`, `roc.svg`, a row (AUC) and a note
/// (accuracy at the decision threshold) per n.
pub(super) fn relevance(
    args: &SortingOptions,
    run: Run,
    bank: &FeatureBank,
    classes: &[String],
    summary: &mut Summary,
) -> anyhow::Result<()> {
    // The bank the scored presentations are in: the held-out one, or `bank` (the training bank).
    let names = run.setup.test.as_ref().map_or(bank, |t| t.0);
    let th = run.setup.hyper.relevance_log_threshold;
    let mut csv = Vec::new();
    let mut rows = Vec::new();
    let mut curves = Vec::new();
    let mut accuracy_notes = Vec::new();
    let mut per_object = Vec::new();
    for (n, trials) in run.by_n {
        let mut aucs = Vec::new();
        let mut pooled = Vec::new();
        let mut acc = Vec::new();
        for (r, scores, scored) in trials {
            let t = r.trial;
            for (&(x, task), &p) in scores.iter().zip(&scored) {
                let pr = &names.presentations[p];
                per_object.push(format!(
                    "{n},{t},{},{},{},{},{x:.6}",
                    pr.name,
                    pr.object,
                    pr.color_class.as_deref().unwrap_or(""),
                    u8::from(task)
                ));
            }
            let (a, right) = (r.auc.unwrap_or(f64::NAN), r.accuracy_at_threshold.unwrap_or(f64::NAN));
            acc.push(right);
            csv.push(format!("{n},{t},{a:.6},{right:.6}"));
            aucs.push(a);
            pooled.extend(scores);
        }
        rows.push(Row::of(n, &aucs));
        let (am, asd) = mean_sd(&acc);
        let right = pooled.iter().filter(|(x, pos)| (*x > th) == *pos).count();
        let (lo, hi) = dexter_sim::experiment::wilson(right, pooled.len());
        accuracy_notes.push(format!(
            "{n} example(s) per class: decision ln B10 > {th} is right for {am:.3} ± {asd:.3} of the objects \
             (pooled {right}/{} = {:.3}, 95 % CI {lo:.3}–{hi:.3})",
            pooled.len(),
            right as f64 / pooled.len().max(1) as f64
        ));
        curves.push(Series {
            label: format!("{n} per class"),
            points: roc(&pooled),
            errors: vec![],
        });
    }
    let dir = &args.output;
    summary.write_csv(
        dir,
        "relevance.csv",
        "examples_per_class,trial,auc,accuracy_at_threshold",
        &csv,
    )?;
    summary.write_csv(
        dir,
        "relevance_objects.csv",
        "examples_per_class,trial,presentation,object,color_class,task_object,log_b10",
        &per_object,
    )?;
    let roc_rows: Vec<String> = curves
        .iter()
        .enumerate()
        .flat_map(|(i, c)| c.points.iter().map(move |(f, t)| format!("{},{f:.6},{t:.6}", i + 1)))
        .collect();
    summary.write_csv(
        dir,
        "roc.csv",
        "examples_per_class,false_positive_rate,true_positive_rate",
        &roc_rows,
    )?;
    summary.add_figure(
        dir,
        "roc.svg",
        Figure::Lines(LineChart {
            title: format!("task relevance of {} (ROC, trials pooled)", classes.join(" + ")),
            x_label: "false positive rate".into(),
            y_label: "true positive rate".into(),
            x_range: (0.0, 1.0),
            y_range: (0.0, 1.02),
            log_y: false,
            series: curves,
            hlines: vec![],
        }),
    );
    summary.measure = "ROC AUC of ln B10 (task objects vs all others)".into();
    summary.notes = accuracy_notes;
    summary.rows.insert(classes.join(" + "), rows);
    Ok(())
}
