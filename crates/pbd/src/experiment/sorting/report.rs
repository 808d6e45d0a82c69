//! What a run reports: the per-n summary rows, the JSON summary, `summary.md` and the CSV files.

use std::collections::BTreeMap;
use std::path::Path;

use serde::Serialize;

use crate::figure::{Figure, FigureFile, LineChart, Series};

/// The mean and the sample standard deviation (0 for fewer than two values).
pub(super) fn mean_sd(xs: &[f64]) -> (f64, f64) {
    let n = xs.len().max(1) as f64;
    let m = xs.iter().sum::<f64>() / n;
    let v = if xs.len() > 1 {
        xs.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1.0)
    } else {
        0.0
    };
    (m, v.sqrt())
}

/// The median (NaN for none).
pub(super) fn median(xs: &[f64]) -> f64 {
    let mut v = xs.to_vec();
    v.sort_by(f64::total_cmp);
    if v.is_empty() {
        return f64::NAN;
    }
    let m = v.len() / 2;
    if v.len() % 2 == 1 {
        v[m]
    } else {
        0.5 * (v[m - 1] + v[m])
    }
}

/// One row of the per-n summary.
#[derive(Debug, Clone, Serialize)]
pub struct Row {
    /// Examples per class.
    pub examples: usize,
    /// Mean over trials (success rate, AUC or selection accuracy).
    pub mean: f64,
    /// Sample standard deviation over trials.
    pub sd: f64,
    /// Median χ² p-value against a random sorter (sorting experiments).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub median_p: Option<f64>,
    /// Maximum χ² p-value.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_p: Option<f64>,
    /// Trials whose χ² test could be computed (the p-value columns summarise these).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub p_computed: Option<usize>,
    /// Sorting: the success rate pooled over the trials (correct / tested) with its 95 % Wilson
    /// interval.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pooled: Option<(f64, (f64, f64))>,
}

/// The JSON summary.
#[derive(Debug, Serialize)]
pub struct Summary {
    /// Which experiment.
    pub experiment: String,
    /// The catalog.
    pub catalog: String,
    /// Classes (or tasks).
    pub classes: Vec<String>,
    /// Structure choice.
    pub structure: String,
    /// Trials per n.
    pub trials: usize,
    /// Seed.
    pub seed: u64,
    /// What `mean` measures.
    pub measure: String,
    /// Per n (or per task and n for selection).
    pub rows: BTreeMap<String, Vec<Row>>,
    /// Extra findings (e.g. incremental = batch).
    pub notes: Vec<String>,
    /// Files written (and figures to draw, listed in `figures`).
    pub files: Vec<String>,
    /// Figures for the front end to draw, with their files.
    #[serde(skip)]
    pub figures: Vec<FigureFile>,
    /// Seconds for rendering and for the experiment.
    pub seconds: [f64; 2],
    /// `summary.md`.
    #[serde(skip)]
    pub markdown: String,
    /// Set when the run was interrupted: what was finished.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub partial: Option<String>,
}

impl Row {
    /// The row of `examples` examples per class over its trials' `values` (mean and sd), without
    /// p-values.
    pub(super) fn of(examples: usize, values: &[f64]) -> Row {
        let (mean, sd) = mean_sd(values);
        Row {
            examples,
            mean,
            sd,
            median_p: None,
            max_p: None,
            p_computed: None,
            pooled: None,
        }
    }

    /// (examples per class, mean): the row's point in a figure.
    pub(super) fn point(&self) -> (f64, f64) {
        (self.examples as f64, self.mean)
    }
}

impl Summary {
    /// Writes the CSV file `name` in `dir` (the header line, then the rows) and lists it among the
    /// files.
    pub(super) fn write_csv(&mut self, dir: &Path, name: &str, header: &str, rows: &[String]) -> anyhow::Result<()> {
        let path = dir.join(name);
        let mut s = String::from(header);
        s.push('\n');
        for r in rows {
            s.push_str(r);
            s.push('\n');
        }
        crate::files::write_atomic(&path, s.as_bytes())?;
        self.files.push(path.display().to_string());
        Ok(())
    }

    /// Adds a figure for the caller to draw to the file `name` in `dir`, and lists that file.
    pub(super) fn add_figure(&mut self, dir: &Path, name: &str, figure: Figure) {
        let path = dir.join(name);
        self.files.push(path.display().to_string());
        self.figures.push((path, figure));
    }
}

/// A line chart against examples per class, n = 1..=`max_n`; y from 0 to 1.05 (a rate).
pub(super) fn examples_chart(
    title: String,
    y_label: &str,
    max_n: usize,
    series: Vec<Series>,
    hlines: Vec<(f64, String)>,
) -> LineChart {
    LineChart {
        title,
        x_label: "examples per class".into(),
        y_label: y_label.into(),
        x_range: (0.5, max_n as f64 + 0.5),
        y_range: (0.0, 1.05),
        log_y: false,
        series,
        hlines,
    }
}

impl std::fmt::Display for Summary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&markdown(self))
    }
}

pub(super) fn markdown(s: &Summary) -> String {
    let mut md = format!(
        "# pbd experiment sorting --feature {}\n\ncatalog `{}`, classes {}, structure `{}`, {} trials, seed {}; \
         rendering {:.1} s, experiment {:.1} s.\n\nMeasure: {}.\n",
        s.experiment,
        s.catalog,
        s.classes.join(", "),
        s.structure,
        s.trials,
        s.seed,
        s.seconds[0],
        s.seconds[1],
        s.measure
    );
    for (name, rows) in &s.rows {
        md.push_str(&format!("\n## {name}\n\n"));
        let with_p = rows.iter().any(|r| r.p_computed.is_some());
        if with_p {
            md.push_str(
                "| examples per class | mean | sd | pooled (95 % CI) | median χ² p | max χ² p | χ² computed in |\n|---:|---:|---:|---:|---:|---:|---:|\n",
            );
        } else {
            md.push_str("| examples per class | mean | sd |\n|---:|---:|---:|\n");
        }
        for r in rows {
            md.push_str(&format!("| {} | {:.3} | {:.3} |", r.examples, r.mean, r.sd));
            if with_p {
                let p = |v: Option<f64>| v.map_or("n/a".to_string(), |v| format!("{v:.2e}"));
                let pooled = r
                    .pooled
                    .map_or("n/a".to_string(), |(m, (lo, hi))| format!("{m:.3} ({lo:.3}–{hi:.3})"));
                md.push_str(&format!(
                    " {pooled} | {} | {} | {}/{} trials |",
                    p(r.median_p),
                    p(r.max_p),
                    r.p_computed.unwrap_or(0),
                    s.trials
                ));
            }
            md.push('\n');
        }
    }
    if !s.notes.is_empty() {
        md.push_str("\n## Notes\n\n");
        for n in &s.notes {
            md.push_str(&format!("- {n}\n"));
        }
    }
    md
}
