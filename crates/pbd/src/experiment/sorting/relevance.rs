//! The task-relevance experiment (Figs. 5.8, 5.10): ROC of ln B10, task objects against all others.

use bayes::roc::roc;

use super::pools::setup;
use super::report::{Row, Summary, mean_sd, write_csv};
use super::trial::run_trial;
use crate::experiment::SortingOptions;
use crate::experiment::features::FeatureBank;
use crate::figure::{Figure, LineChart, Series};
use crate::progress::Progress;

pub(super) fn relevance(
    args: &SortingOptions,
    progress: &dyn Progress,
    bank: &FeatureBank,
    test: Option<&FeatureBank>,
    classes: &[String],
    summary: &mut Summary,
) -> anyhow::Result<()> {
    let setup = setup(args, bank, test)?;
    let max_n = setup.max_n;
    progress.phase("trials", Some((max_n * args.trials) as u64));
    let mut csv = Vec::new();
    let mut rows = Vec::new();
    let mut curves = Vec::new();
    let mut accuracy_notes = Vec::new();
    let mut per_object = Vec::new();
    for n in 1..=max_n {
        let mut aucs = Vec::new();
        let mut pooled = Vec::new();
        let mut acc = Vec::new();
        for t in 0..args.trials {
            if progress.should_stop() {
                break;
            }
            let (r, scores, scored) = run_trial(args, bank, &setup, n, t)?;
            let names = setup.test.as_ref().map_or(bank, |t| t.0);
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
            progress.advance(1);
        }
        if aucs.is_empty() {
            break;
        }
        let (mean, sd) = mean_sd(&aucs);
        rows.push(Row {
            examples: n,
            mean,
            sd,
            median_p: None,
            max_p: None,
            p_computed: None,
            pooled: None,
        });
        let (am, asd) = mean_sd(&acc);
        let th = setup.hyper.relevance_log_threshold;
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
    progress.finish();
    if csv.len() < max_n * args.trials {
        summary.partial = Some(format!(
            "interrupted after {} of {} trials",
            csv.len(),
            max_n * args.trials
        ));
    }
    let dir = &args.output;
    let csv_path = dir.join("relevance.csv");
    write_csv(&csv_path, "examples_per_class,trial,auc,accuracy_at_threshold", &csv)?;
    let objects_csv = dir.join("relevance_objects.csv");
    write_csv(
        &objects_csv,
        "examples_per_class,trial,presentation,object,color_class,task_object,log_b10",
        &per_object,
    )?;
    let roc_csv = dir.join("roc.csv");
    let roc_rows: Vec<String> = curves
        .iter()
        .enumerate()
        .flat_map(|(i, c)| c.points.iter().map(move |(f, t)| format!("{},{f:.6},{t:.6}", i + 1)))
        .collect();
    write_csv(
        &roc_csv,
        "examples_per_class,false_positive_rate,true_positive_rate",
        &roc_rows,
    )?;
    let svg = dir.join("roc.svg");
    summary.figures.push((
        svg.clone(),
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
    ));
    summary.measure = "ROC AUC of ln B10 (task objects vs all others)".into();
    summary.notes = accuracy_notes;
    summary.rows.insert(classes.join(" + "), rows);
    summary
        .files
        .extend([csv_path, objects_csv, roc_csv, svg].map(|p| p.display().to_string()));
    Ok(())
}
