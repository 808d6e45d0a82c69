//! The `pbd grasp eval` report: significance tests, CSV files, Fig. 6.7 (SVG) and a Markdown
//! summary.
//!
//! The figure is returned as data ([`figure`]) for the front end to draw.

use std::fmt;
use std::fmt::Write as _;
use std::path::Path;

use anyhow::Result;
use grasp_topics::GraspModel;
use serde::Serialize;

use super::common::{Method, Rejections};
use crate::figure::Figure;

/// One executed candidate.
#[derive(Debug, Clone, Serialize)]
pub struct Trial {
    /// Test presentation.
    pub object: String,
    /// Generator.
    pub method: Method,
    /// Candidate index (rank order, from 1).
    pub candidate: usize,
    /// Prototype (model candidates).
    pub prototype: Option<usize>,
    /// Palm-surface position in the object frame (m).
    pub position: Option<[f64; 3]>,
    /// Palm-surface orientation `[w, x, y, z]`.
    pub orientation: Option<[f64; 4]>,
    /// Success (§6.5 criterion).
    pub success: bool,
    /// How far the object rose (m).
    pub rose: f64,
    /// What happened.
    pub outcome: String,
    /// Simulated seconds.
    pub sim_time: f64,
}

/// Per test presentation.
#[derive(Debug, Clone, Serialize)]
pub struct ObjectResult {
    /// Presentation.
    pub object: String,
    /// Model successes (of `candidates`).
    pub model: usize,
    /// Naive successes.
    pub naive: usize,
    /// Appearance b seen (px²), if seen.
    pub appearance: Option<[[f64; 2]; 2]>,
    /// Most probable prototype for its appearance (6.28), from 1.
    pub top_prototype: Option<usize>,
    /// Model candidates dropped.
    pub model_rejected: Rejections,
    /// Naive candidates dropped.
    pub naive_rejected: Rejections,
}

/// Significance of the difference.
#[derive(Debug, Clone, Serialize)]
pub struct Significance {
    /// One-sided Fisher exact test, H1: the model succeeds more often.
    pub fisher_one_sided_p: f64,
    /// Pearson χ² on the 2×2 table with Yates' correction (two-sided).
    pub chi2: f64,
    /// Its p-value.
    pub chi2_p: f64,
}

/// `summary.json` / `--json`.
#[derive(Debug, Clone, Serialize)]
pub struct EvalSummary {
    /// Seed.
    pub seed: u64,
    /// Split by object (no presentation of a test object trained on), not by presentation.
    #[serde(default)]
    pub object_split: bool,
    /// The naive baseline's candidates were filtered against the object as the model's are.
    #[serde(default)]
    pub naive_filtered: bool,
    /// Training presentations (with at least one kept grasp).
    pub train: Vec<String>,
    /// Test presentations.
    pub test: Vec<String>,
    /// Candidates per object and method.
    pub candidates: usize,
    /// Demonstrations kept / attempted (when recorded here).
    pub demos_kept: Option<(usize, usize)>,
    /// The model.
    pub model: super::ModelSummary,
    /// Per object.
    pub objects: Vec<ObjectResult>,
    /// Model successes / attempts.
    pub model_total: (usize, usize),
    /// Naive successes / attempts.
    pub naive_total: (usize, usize),
    /// Test.
    pub significance: Significance,
    /// Wall-clock seconds of the whole run.
    pub wall_time: f64,
    /// Files written.
    pub files: Vec<String>,
    /// Set when the run was interrupted: what was finished (the figures are over that).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub partial: Option<String>,
}

/// Fisher (one-sided) and χ² with Yates' correction on model vs naive successes of `n` each.
pub fn significance(model: usize, naive: usize, n: usize) -> Result<Significance> {
    let table = [[model as f64, (n - model) as f64], [naive as f64, (n - naive) as f64]];
    // A zero column (all succeed or all fail) has no χ²: report 0 and p = 1.
    let (chi2, chi2_p) = match bayes::chi2::chi2_contingency(&table, true) {
        Ok(t) => (t.statistic, t.p_value),
        Err(_) => (0.0, 1.0),
    };
    Ok(Significance {
        fisher_one_sided_p: bayes::contingency::fisher_one_sided(model, naive, n),
        chi2,
        chi2_p,
    })
}

fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

fn write(dir: &Path, name: &str, text: &str, files: &mut Vec<String>) -> Result<()> {
    let p = dir.join(name);
    crate::files::write_atomic(&p, text.as_bytes())?;
    files.push(p.display().to_string());
    Ok(())
}

/// Writes trials.csv, objects.csv, sharing.csv and summary.md into `dir` (adding their paths, and
/// that of the figure `fig6_7.svg` the caller draws from [`figure`], to `summary.files`).
pub fn write_files(dir: &Path, summary: &mut EvalSummary, trials: &[Trial], model: &GraspModel) -> Result<()> {
    let mut files = std::mem::take(&mut summary.files);
    let mut t = String::from("object,method,candidate,prototype,x,y,z,qw,qx,qy,qz,success,rose,sim_time,outcome\n");
    for r in trials {
        let p = r
            .position
            .map_or(",,".into(), |p| format!("{:.5},{:.5},{:.5}", p[0], p[1], p[2]));
        let q = r.orientation.map_or(",,,".into(), |q| {
            format!("{:.5},{:.5},{:.5},{:.5}", q[0], q[1], q[2], q[3])
        });
        let _ = writeln!(
            t,
            "{},{},{},{},{p},{q},{},{:.4},{:.2},{}",
            csv_field(&r.object),
            r.method.name(),
            r.candidate,
            r.prototype.map_or(String::new(), |j| j.to_string()),
            r.success as u8,
            r.rose,
            r.sim_time,
            csv_field(&r.outcome)
        );
    }
    write(dir, "trials.csv", &t, &mut files)?;
    let mut o = String::from("object,model,naive,candidates,top_prototype\n");
    for r in &summary.objects {
        let _ = writeln!(
            o,
            "{},{},{},{},{}",
            csv_field(&r.object),
            r.model,
            r.naive,
            summary.candidates,
            r.top_prototype.map_or(String::new(), |j| j.to_string())
        );
    }
    write(dir, "objects.csv", &o, &mut files)?;
    let table = model.sharing_table();
    let k = model.prototypes.len();
    let mut s = String::from("object");
    for j in 1..=k {
        let _ = write!(s, ",p{j}");
    }
    s.push('\n');
    for (name, row) in table.objects.iter().zip(&table.counts) {
        s.push_str(&csv_field(name));
        for c in row {
            let _ = write!(s, ",{c}");
        }
        s.push('\n');
    }
    write(dir, "sharing.csv", &s, &mut files)?;
    files.push(dir.join("fig6_7.svg").display().to_string());
    write(dir, "summary.md", &markdown(summary, model), &mut files)?;
    summary.files = files;
    Ok(())
}

/// Fig. 6.7: successes per test object, naive and model.
pub fn figure(summary: &EvalSummary) -> Figure {
    Figure::GroupedBars {
        title: format!(
            "Grasp success per test object: model {}/{}, naive {}/{} (Fisher p = {:.2e})",
            summary.model_total.0,
            summary.model_total.1,
            summary.naive_total.0,
            summary.naive_total.1,
            summary.significance.fisher_one_sided_p
        ),
        y_label: "successful grasps".into(),
        y_max: summary.candidates as f64 + 0.5,
        categories: summary.objects.iter().map(|o| o.object.clone()).collect(),
        groups: vec![
            ("naive".into(), summary.objects.iter().map(|o| o.naive as f64).collect()),
            (
                "visual grasp prototypes".into(),
                summary.objects.iter().map(|o| o.model as f64).collect(),
            ),
        ],
        intervals: vec![],
    }
}

fn pct(a: usize, n: usize) -> f64 {
    if n == 0 { 0.0 } else { 100.0 * a as f64 / n as f64 }
}

fn markdown(s: &EvalSummary, model: &GraspModel) -> String {
    let mut m = String::new();
    let _ = writeln!(m, "# Grasp evaluation (§6.5)\n");
    if let Some(p) = &s.partial {
        let _ = writeln!(m, "**PARTIAL: {p}**; the figures below are over those objects.\n");
    }
    let _ = writeln!(
        m,
        "Seed {}; {} training presentations, {} test presentations, {} candidates per object and method.\n",
        s.seed,
        s.train.len(),
        s.test.len(),
        s.candidates
    );
    let _ = writeln!(
        m,
        "Split by {}; naive candidates filtered against {}.\n",
        if s.object_split {
            "object (no presentation of a test object trained on)"
        } else {
            "presentation"
        },
        if s.naive_filtered {
            "the object and the table, as the model's"
        } else {
            "the table only (the seed's baseline)"
        }
    );
    if let Some((k, a)) = s.demos_kept {
        let _ = writeln!(m, "Demonstrations kept (grasp held): {k} of {a}.\n");
    }
    let _ = writeln!(m, "| object | model | naive |\n|---|---:|---:|");
    for o in &s.objects {
        let _ = writeln!(m, "| {} | {} | {} |", o.object, o.model, o.naive);
    }
    let _ = writeln!(
        m,
        "| **total** | **{}/{} ({:.1} %)** | **{}/{} ({:.1} %)** |\n",
        s.model_total.0,
        s.model_total.1,
        pct(s.model_total.0, s.model_total.1),
        s.naive_total.0,
        s.naive_total.1,
        pct(s.naive_total.0, s.naive_total.1)
    );
    let _ = writeln!(
        m,
        "Fisher exact (one-sided, model > naive): p = {:.3e}; χ² (Yates) = {:.2}, p = {:.3e}.\n",
        s.significance.fisher_one_sided_p, s.significance.chi2, s.significance.chi2_p
    );
    let _ = writeln!(
        m,
        "Model: {} prototypes; {:.0} % used by ≥ 2 training objects; objects per prototype {:?}.\n",
        s.model.prototypes,
        100.0 * s.model.shared_fraction,
        s.model.objects_per_prototype
    );
    let _ = writeln!(
        m,
        "## Sharing table (Table 6.1)\n\n```text\n{}```\n",
        model.sharing_table()
    );
    let _ = writeln!(m, "Figure: `fig6_7.svg`. Wall time {:.0} s.", s.wall_time);
    m
}

/// The terminal report.
impl fmt::Display for EvalSummary {
    fn fmt(&self, out: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = self;
        let mut t = crate::table::Table::new(["object", "model", "naive"]);
        for o in &s.objects {
            t.row([o.object.clone(), o.model.to_string(), o.naive.to_string()]);
        }
        write!(out, "{}", t.render(2))?;
        writeln!(
            out,
            "model {}/{} ({:.1} %), naive {}/{} ({:.1} %); Fisher one-sided p = {:.3e}, chi2 (Yates) {:.2}, p = {:.3e}",
            s.model_total.0,
            s.model_total.1,
            pct(s.model_total.0, s.model_total.1),
            s.naive_total.0,
            s.naive_total.1,
            pct(s.naive_total.0, s.naive_total.1),
            s.significance.fisher_one_sided_p,
            s.significance.chi2,
            s.significance.chi2_p
        )?;
        writeln!(
            out,
            "{} prototypes, {:.0} % shared by >= 2 training objects",
            s.model.prototypes,
            100.0 * s.model.shared_fraction
        )?;
        writeln!(out)?;
        write!(out, "{}", s.model.sharing_table)?;
        writeln!(out)?;
        writeln!(out, "wrote {}", s.files.join(", "))?;
        writeln!(out, "wall time {:.0} s", s.wall_time)?;
        Ok(())
    }
}
