//! The colour / size sorting experiment (Figs. 5.2, 5.3, 5.6): success rate and χ² p-value against
//! a random sorter per number of examples per class.

use super::pools::setup;
use super::report::{Row, Summary, mean_sd, median, write_csv};
use super::trial::run_trial;
use crate::experiment::SortingOptions;
use crate::experiment::features::FeatureBank;
use crate::figure::{Figure, LineChart, Series};
use crate::progress::Progress;

pub(super) fn sorting(
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
    let mut not_computed = Vec::new();
    let mut done = 0;
    for n in 1..=max_n {
        let mut rates = Vec::new();
        let mut ps = Vec::new();
        let (mut hits, mut tested) = (0, 0);
        for t in 0..args.trials {
            if progress.should_stop() {
                break;
            }
            done += 1;
            let (r, _, _) = run_trial(args, bank, &setup, n, t)?;
            hits += r.correct;
            tested += r.tested;
            csv.push(format!(
                "{n},{t},{},{},{:.6},{},{},{:.6}",
                r.correct,
                r.tested,
                r.success_rate,
                r.chi2_p_value.map_or("NA".to_string(), |p| format!("{p:.6e}")),
                r.map_structure,
                r.map_structure_probability
            ));
            rates.push(r.success_rate);
            match (r.chi2_p_value, r.chi2_not_computed) {
                (Some(p), _) => ps.push(p),
                (None, why) => not_computed.push(format!(
                    "{n} example(s), trial {t}: χ² not computed ({})",
                    why.unwrap_or_default()
                )),
            }
            progress.advance(1);
        }
        if rates.is_empty() {
            break;
        }
        let (mean, sd) = mean_sd(&rates);
        rows.push(Row {
            examples: n,
            mean,
            sd,
            median_p: (!ps.is_empty()).then(|| median(&ps)),
            max_p: (!ps.is_empty()).then(|| ps.iter().copied().fold(0.0, f64::max)),
            p_computed: Some(ps.len()),
            pooled: Some((
                hits as f64 / tested.max(1) as f64,
                dexter_sim::experiment::wilson(hits, tested),
            )),
        });
    }
    if done < max_n * args.trials {
        summary.partial = Some(format!("interrupted after {done} of {} trials", max_n * args.trials));
    }
    if !not_computed.is_empty() {
        summary.notes.push(format!(
            "the χ² test could not be computed in {} trial(s) (NA in success.csv; the p-value columns summarise the others): {}",
            not_computed.len(),
            not_computed.iter().take(5).cloned().collect::<Vec<_>>().join("; ")
        ));
    }
    progress.finish();
    let dir = &args.output;
    let csv_path = dir.join("success.csv");
    write_csv(
        &csv_path,
        "examples_per_class,trial,correct,tested,success_rate,chi2_p_value,map_structure,map_structure_probability",
        &csv,
    )?;
    let what = classes.join(" vs ");
    let svg = dir.join("success.svg");
    summary.figures.push((
        svg.clone(),
        Figure::Lines(LineChart {
            title: format!("sorting {what}: success rate (mean ± sd, {} trials)", args.trials),
            x_label: "examples per class".into(),
            y_label: "success rate".into(),
            x_range: (0.5, max_n as f64 + 0.5),
            y_range: (0.0, 1.05),
            log_y: false,
            series: vec![Series {
                label: String::new(),
                points: rows.iter().map(|r| (r.examples as f64, r.mean)).collect(),
                errors: rows.iter().map(|r| (r.mean - r.sd, (r.mean + r.sd).min(1.0))).collect(),
            }],
            hlines: vec![(1.0 / classes.len() as f64, "random sorter".into())],
        }),
    ));
    let psvg = dir.join("p_values.svg");
    let floor = 1e-300;
    let lo = rows.iter().filter_map(|r| r.median_p).fold(1.0, f64::min).max(floor) * 0.1;
    summary.figures.push((
        psvg.clone(),
        Figure::Lines(LineChart {
            title: format!("sorting {what}: χ² p-value against a random sorter"),
            x_label: "examples per class".into(),
            y_label: "p-value".into(),
            x_range: (0.5, max_n as f64 + 0.5),
            y_range: (lo, 1.0),
            log_y: true,
            series: vec![
                Series {
                    label: "maximum".into(),
                    points: rows
                        .iter()
                        .filter_map(|r| Some((r.examples as f64, r.max_p?.max(floor))))
                        .collect(),
                    errors: vec![],
                },
                Series {
                    label: "median".into(),
                    points: rows
                        .iter()
                        .filter_map(|r| Some((r.examples as f64, r.median_p?.max(floor))))
                        .collect(),
                    errors: vec![],
                },
            ],
            hlines: vec![(0.05, "5 %".into()), (0.01, "1 %".into())],
        }),
    ));
    summary.measure = "success rate (correctly sorted / tested)".into();
    summary.rows.insert(what, rows);
    summary
        .files
        .extend([csv_path, svg, psvg].map(|p| p.display().to_string()));
    Ok(())
}
