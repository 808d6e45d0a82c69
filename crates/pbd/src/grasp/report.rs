//! The `pbd grasp eval` report: significance tests, CSV files, Fig. 6.7 (SVG) and a Markdown
//! summary.
//!
//! The figure is drawn with `plotters` (SVG backend only, no default features): it writes a
//! self-contained SVG with text as SVG text, so no font files or system libraries are needed, and the
//! same crate can later draw the other figures of the notes (ROC, learning curves).

use std::fmt::Write as _;
use std::io::Write;
use std::path::Path;

use anyhow::{Context, Result};
use grasp_topics::GraspModel;
use plotters::prelude::*;

use serde::Serialize;

use super::common::{Method, Rejections};

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
}

/// One-sided Fisher exact test (H1: the first group succeeds more often) on successes `a` of `n`
/// against `c` of `n`: P(X ≥ a) under the hypergeometric law with the table's margins.
pub fn fisher_one_sided(a: usize, c: usize, n: usize) -> f64 {
    let (n1, n2) = (n, n);
    let k = a + c; // successes in all
    let total = n1 + n2;
    let ln_choose = |n: usize, k: usize| -> f64 {
        bayes::special::ln_gamma(n as f64 + 1.0)
            - bayes::special::ln_gamma(k as f64 + 1.0)
            - bayes::special::ln_gamma((n - k) as f64 + 1.0)
    };
    let denom = ln_choose(total, k);
    let hi = k.min(n1);
    let mut p = 0.0;
    for x in a..=hi {
        if k - x > n2 {
            continue;
        }
        p += (ln_choose(n1, x) + ln_choose(n2, k - x) - denom).exp();
    }
    p.min(1.0)
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
        fisher_one_sided_p: fisher_one_sided(model, naive, n),
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
    std::fs::write(&p, text).with_context(|| format!("cannot write {}", p.display()))?;
    files.push(p.display().to_string());
    Ok(())
}

/// Writes trials.csv, objects.csv, sharing.csv, fig6_7.svg and summary.md into `dir` (adding
/// their paths to `summary.files`).
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
    let svg = plot_svg(summary)?;
    write(dir, "fig6_7.svg", &svg, &mut files)?;
    write(dir, "summary.md", &markdown(summary, model), &mut files)?;
    summary.files = files;
    Ok(())
}

/// Fig. 6.7: successes per test object, naive (blue) and model (red).
fn plot_svg(summary: &EvalSummary) -> Result<String> {
    let mut buf = String::new();
    let n = summary.objects.len();
    let width = (140 + 60 * n as u32).max(480);
    {
        let root = SVGBackend::with_string(&mut buf, (width, 420)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| anyhow::anyhow!("plot: {e}"))?;
        let title = format!(
            "Grasp success per test object: model {}/{}, naive {}/{} (Fisher p = {:.2e})",
            summary.model_total.0,
            summary.model_total.1,
            summary.naive_total.0,
            summary.naive_total.1,
            summary.significance.fisher_one_sided_p
        );
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 16))
            .margin(12)
            .x_label_area_size(110)
            .y_label_area_size(40)
            .build_cartesian_2d(0.0..n as f64, 0.0..summary.candidates as f64 + 0.5)
            .map_err(|e| anyhow::anyhow!("plot: {e}"))?;
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_labels(0)
            .y_desc("successful grasps")
            .draw()
            .map_err(|e| anyhow::anyhow!("plot: {e}"))?;
        let blue = RGBColor(60, 90, 200);
        let red = RGBColor(210, 50, 40);
        chart
            .draw_series(summary.objects.iter().enumerate().map(|(i, o)| {
                let x = i as f64;
                Rectangle::new([(x + 0.1, 0.0), (x + 0.48, o.naive as f64)], blue.filled())
            }))
            .map_err(|e| anyhow::anyhow!("plot: {e}"))?
            .label("naive")
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 12, y + 5)], blue.filled()));
        chart
            .draw_series(summary.objects.iter().enumerate().map(|(i, o)| {
                let x = i as f64;
                Rectangle::new([(x + 0.52, 0.0), (x + 0.9, o.model as f64)], red.filled())
            }))
            .map_err(|e| anyhow::anyhow!("plot: {e}"))?
            .label("visual grasp prototypes")
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 12, y + 5)], red.filled()));
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .position(SeriesLabelPosition::UpperRight)
            .draw()
            .map_err(|e| anyhow::anyhow!("plot: {e}"))?;
        // Object names under their bars, rotated (drawn on the root area, outside the plot).
        let style = ("sans-serif", 11)
            .into_font()
            .transform(FontTransform::Rotate90)
            .color(&BLACK);
        for (i, o) in summary.objects.iter().enumerate() {
            let (px, py) = chart.backend_coord(&(i as f64 + 0.5, 0.0));
            root.draw(&Text::new(o.object.clone(), (px - 6, py + 6), style.clone()))
                .map_err(|e| anyhow::anyhow!("plot: {e}"))?;
        }
        root.present().map_err(|e| anyhow::anyhow!("plot: {e}"))?;
    }
    Ok(buf)
}

fn pct(a: usize, n: usize) -> f64 {
    if n == 0 { 0.0 } else { 100.0 * a as f64 / n as f64 }
}

fn markdown(s: &EvalSummary, model: &GraspModel) -> String {
    let mut m = String::new();
    let _ = writeln!(m, "# Grasp evaluation (§6.5)\n");
    let _ = writeln!(
        m,
        "Seed {}; {} training presentations, {} test presentations, {} candidates per object and method.\n",
        s.seed,
        s.train.len(),
        s.test.len(),
        s.candidates
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
pub fn print(out: &mut dyn Write, s: &EvalSummary, model: &GraspModel) -> Result<()> {
    let mut t = crate::output::Table::new(["object", "model", "naive"]);
    for o in &s.objects {
        t.row([o.object.clone(), o.model.to_string(), o.naive.to_string()]);
    }
    t.write(out, 2)?;
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
    write!(out, "{}", model.sharing_table())?;
    writeln!(out)?;
    writeln!(out, "wrote {}", s.files.join(", "))?;
    writeln!(out, "wall time {:.0} s", s.wall_time)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fisher_matches_scipy() {
        // The seed's counts: scipy.stats.fisher_exact([[53, 19], [43, 29]], alternative="greater")
        // gives p = 0.055573 (exact hypergeometric sum).
        let p = fisher_one_sided(53, 43, 72);
        assert!((p - 0.055_573_479).abs() < 1e-7, "{p}");
        assert!((fisher_one_sided(6, 0, 6) - 0.0011).abs() < 1e-3);
        assert_eq!(fisher_one_sided(0, 0, 6), 1.0);
    }
}
