//! The colour / size sorting experiment (Figs. 5.2, 5.3, 5.6): success rate and χ² p-value against
//! a random sorter per number of examples per class.

use super::report::{Row, Summary, examples_chart, median};
use super::trial::Run;
use crate::experiment::SortingOptions;
use crate::figure::{Figure, LineChart, Series};

/// Its report on the trials `run`: `success.csv`, `success.svg`, `p_values.svg`, a row per n.
pub(super) fn sorting(
    args: &SortingOptions,
    run: Run,
    classes: &[String],
    summary: &mut Summary,
) -> anyhow::Result<()> {
    let max_n = run.setup.max_n;
    let mut csv = Vec::new();
    let mut rows = Vec::new();
    let mut not_computed = Vec::new();
    for (n, trials) in run.by_n {
        let mut rates = Vec::new();
        let mut ps = Vec::new();
        let (mut hits, mut tested) = (0, 0);
        for (r, _, _) in trials {
            let t = r.trial;
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
        }
        rows.push(Row {
            median_p: (!ps.is_empty()).then(|| median(&ps)),
            max_p: (!ps.is_empty()).then(|| ps.iter().copied().fold(0.0, f64::max)),
            p_computed: Some(ps.len()),
            pooled: Some((
                hits as f64 / tested.max(1) as f64,
                dexter_sim::experiment::wilson(hits, tested),
            )),
            ..Row::of(n, &rates)
        });
    }
    if !not_computed.is_empty() {
        summary.notes.push(format!(
            "the χ² test could not be computed in {} trial(s) (NA in success.csv; the p-value columns summarise the others): {}",
            not_computed.len(),
            not_computed.iter().take(5).cloned().collect::<Vec<_>>().join("; ")
        ));
    }
    let dir = &args.output;
    summary.write_csv(
        dir,
        "success.csv",
        "examples_per_class,trial,correct,tested,success_rate,chi2_p_value,map_structure,map_structure_probability",
        &csv,
    )?;
    let what = classes.join(" vs ");
    let rates = Series {
        label: String::new(),
        points: rows.iter().map(Row::point).collect(),
        errors: rows.iter().map(|r| (r.mean - r.sd, (r.mean + r.sd).min(1.0))).collect(),
    };
    summary.add_figure(
        dir,
        "success.svg",
        Figure::Lines(examples_chart(
            format!("sorting {what}: success rate (mean ± sd, {} trials)", args.trials),
            "success rate",
            max_n,
            vec![rates],
            vec![(1.0 / classes.len() as f64, "random sorter".into())],
        )),
    );
    let floor = 1e-300;
    let lo = rows.iter().filter_map(|r| r.median_p).fold(1.0, f64::min).max(floor) * 0.1;
    let p_series = |label: &str, p: fn(&Row) -> Option<f64>| Series {
        label: label.into(),
        points: rows
            .iter()
            .filter_map(|r| Some((r.examples as f64, p(r)?.max(floor))))
            .collect(),
        errors: vec![],
    };
    let p_values = vec![p_series("maximum", |r| r.max_p), p_series("median", |r| r.median_p)];
    summary.add_figure(
        dir,
        "p_values.svg",
        Figure::Lines(LineChart {
            y_range: (lo, 1.0),
            log_y: true,
            ..examples_chart(
                format!("sorting {what}: χ² p-value against a random sorter"),
                "p-value",
                max_n,
                p_values,
                vec![(0.05, "5 %".into()), (0.01, "1 %".into())],
            )
        }),
    );
    summary.measure = "success rate (correctly sorted / tested)".into();
    summary.rows.insert(what, rows);
    Ok(())
}
