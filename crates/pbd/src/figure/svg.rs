//! Plots for procedural models and experiments (plotters, SVG): success curves with error bars,
//! p-values, ROC curves, colour pmfs (Fig. 5.11), colour swatches of posterior-predictive samples
//! (Fig. 5.12) and size densities (Fig. 5.5).

use std::path::Path;

use super::{Figure, LineChart, Series};
use bayes::univariate::StudentT;
use dexter::vision::color::hsv_to_rgb;
use plotters::prelude::*;
use schema::procedural::{COLORS, Features, term_hsv};

const PALETTE: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(23, 190, 207),
];

/// The drawing colour of a colour term.
fn term_rgb(term: usize) -> RGBColor {
    let [r, g, b] = hsv_to_rgb(term_hsv(term));
    let c = |x: f64| (x.clamp(0.0, 1.0) * 255.0).round() as u8;
    RGBColor(c(r), c(g), c(b))
}

/// Draws a figure of the library to an SVG file.
pub fn draw(path: &Path, figure: &Figure) -> anyhow::Result<()> {
    match figure {
        Figure::Lines(chart) => line_chart(path, chart),
        Figure::PmfGrid { title, rows } => pmf_grid(path, title, rows),
        Figure::Swatches(places) => swatches(path, places),
        Figure::SizeDensities { places, samples } => size_densities(path, places, samples),
        Figure::GroupedBars {
            title,
            y_label,
            y_max,
            categories,
            groups,
            intervals,
        } => grouped_bars(path, title, y_label, *y_max, categories, groups, intervals),
    }
}

/// Grouped bars: per category one bar per group, category names rotated under the bars (Fig. 6.7),
/// with interval whiskers where given.
fn grouped_bars(
    path: &Path,
    title: &str,
    y_label: &str,
    y_max: f64,
    categories: &[String],
    groups: &[(String, Vec<f64>)],
    intervals: &[Vec<(f64, f64)>],
) -> anyhow::Result<()> {
    let n = categories.len();
    let width = (140 + 60 * n as u32).max(480);
    let root = SVGBackend::new(path, (width, 420)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 16))
        .margin(12)
        .x_label_area_size(110)
        .y_label_area_size(40)
        .build_cartesian_2d(0.0..n.max(1) as f64, 0.0..y_max.max(1e-9))?;
    chart
        .configure_mesh()
        .disable_x_mesh()
        .x_labels(0)
        .y_desc(y_label)
        .draw()?;
    let k = groups.len().max(1) as f64;
    let w = 0.8 / k;
    for (g, (label, values)) in groups.iter().enumerate() {
        let color = PALETTE[g % PALETTE.len()];
        let x0 = 0.1 + g as f64 * w;
        chart
            .draw_series(values.iter().enumerate().map(|(i, &v)| {
                let x = i as f64 + x0;
                Rectangle::new([(x, 0.0), (x + w * 0.95, v)], color.filled())
            }))?
            .label(label.as_str())
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 12, y + 5)], color.filled()));
        if let Some(whiskers) = intervals.get(g) {
            for (i, &(lo, hi)) in whiskers.iter().enumerate() {
                let x = i as f64 + x0 + w * 0.475;
                let cap = w * 0.2;
                chart.draw_series(std::iter::once(PathElement::new(
                    vec![(x, lo), (x, hi)],
                    BLACK.stroke_width(2),
                )))?;
                for y in [lo, hi] {
                    chart.draw_series(std::iter::once(PathElement::new(
                        vec![(x - cap, y), (x + cap, y)],
                        BLACK.stroke_width(2),
                    )))?;
                }
            }
        }
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperRight)
        .draw()?;
    let style = ("sans-serif", 11)
        .into_font()
        .transform(FontTransform::Rotate90)
        .color(&BLACK);
    for (i, c) in categories.iter().enumerate() {
        let (px, py) = chart.backend_coord(&(i as f64 + 0.5, 0.0));
        root.draw(&Text::new(c.clone(), (px - 6, py + 6), style.clone()))?;
    }
    root.present()?;
    Ok(())
}

/// Draws a line chart to an SVG file.
pub fn line_chart(path: &Path, chart: &LineChart) -> anyhow::Result<()> {
    let root = SVGBackend::new(path, (720, 460)).into_drawing_area();
    root.fill(&WHITE)?;
    let (x0, x1) = chart.x_range;
    let (y0, y1) = chart.y_range;
    let mut builder = ChartBuilder::on(&root);
    builder
        .caption(&chart.title, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60);
    macro_rules! body {
        ($ctx:expr) => {{
            let mut ctx = $ctx;
            ctx.configure_mesh()
                .x_desc(chart.x_label.as_str())
                .y_desc(chart.y_label.as_str())
                .draw()?;
            for (y, label) in &chart.hlines {
                let style = ShapeStyle::from(&BLACK.mix(0.6)).stroke_width(1);
                let n = 40;
                let dash: Vec<_> = (0..n)
                    .step_by(2)
                    .map(|i| {
                        let a = x0 + (x1 - x0) * i as f64 / n as f64;
                        let b = x0 + (x1 - x0) * (i + 1) as f64 / n as f64;
                        PathElement::new(vec![(a, *y), (b, *y)], style)
                    })
                    .collect();
                ctx.draw_series(dash)?;
                ctx.draw_series(std::iter::once(Text::new(
                    label.clone(),
                    (x0 + 0.02 * (x1 - x0), *y),
                    ("sans-serif", 12),
                )))?;
            }
            for (i, s) in chart.series.iter().enumerate() {
                let color = PALETTE[i % PALETTE.len()];
                ctx.draw_series(LineSeries::new(s.points.iter().copied(), color.stroke_width(2)))?
                    .label(s.label.clone())
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2)));
                ctx.draw_series(s.points.iter().map(|&p| Circle::new(p, 3, color.filled())))?;
                ctx.draw_series(
                    s.points
                        .iter()
                        .zip(&s.errors)
                        .map(|(&(x, y), &(lo, hi))| ErrorBar::new_vertical(x, lo, y, hi, color.stroke_width(1), 8)),
                )?;
            }
            if chart.series.len() > 1 || chart.series.iter().any(|s| !s.label.is_empty()) {
                ctx.configure_series_labels()
                    .background_style(WHITE.mix(0.85))
                    .border_style(BLACK)
                    .position(SeriesLabelPosition::LowerRight)
                    .draw()?;
            }
        }};
    }
    if chart.log_y {
        body!(builder.build_cartesian_2d(x0..x1, (y0.max(1e-300)..y1).log_scale())?);
    } else {
        body!(builder.build_cartesian_2d(x0..x1, y0..y1)?);
    }
    root.present()?;
    Ok(())
}

/// Colour pmfs over the colour terms as a grid of bar charts (Fig. 5.11): one row per place, one
/// column per step; each bar is drawn in its term's colour, in term order (black, grey, white,
/// red, orange, yellow, green, blue, purple, pink).
pub fn pmf_grid(path: &Path, title: &str, rows: &[(String, Vec<Vec<f64>>)]) -> anyhow::Result<()> {
    let cols = rows.iter().map(|r| r.1.len()).max().unwrap_or(1).max(1);
    let nrows = rows.len().max(1);
    let root = SVGBackend::new(path, ((220 * cols) as u32 + 20, (170 * nrows) as u32 + 50)).into_drawing_area();
    root.fill(&WHITE)?;
    let root = root.titled(title, ("sans-serif", 20))?;
    let cells = root.split_evenly((nrows, cols));
    for (r, (label, pmfs)) in rows.iter().enumerate() {
        let ymax = pmfs.iter().flatten().copied().fold(0.0, f64::max).max(1e-6) * 1.05;
        for (c, pmf) in pmfs.iter().enumerate() {
            let area = &cells[r * cols + c];
            let mut ctx = ChartBuilder::on(area)
                .caption(
                    format!("{label}, {} example{}", c + 1, if c == 0 { "" } else { "s" }),
                    ("sans-serif", 12),
                )
                .margin(4)
                .x_label_area_size(16)
                .y_label_area_size(30)
                .build_cartesian_2d(0f64..COLORS as f64, 0f64..ymax)?;
            ctx.configure_mesh().disable_mesh().x_labels(3).y_labels(3).draw()?;
            ctx.draw_series(
                pmf.iter()
                    .enumerate()
                    .map(|(b, &p)| Rectangle::new([(b as f64, 0.0), (b as f64 + 0.9, p)], term_rgb(b).filled())),
            )?;
        }
    }
    root.present()?;
    Ok(())
}

/// Colour swatches of synthetic instances (Fig. 5.12): one row per place, one block per instance,
/// each block striped by the instance's colour terms in proportion to their shares.
pub fn swatches(path: &Path, places: &[(String, Vec<Features>)]) -> anyhow::Result<()> {
    let per_row = places.iter().map(|p| p.1.len()).max().unwrap_or(1).clamp(1, 36);
    let block = 28i32;
    let label_w = 140i32;
    let w = label_w + per_row as i32 * (block + 4) + 10;
    let h = places.len() as i32 * (block + 12) + 40;
    let root = SVGBackend::new(path, (w as u32, h.max(60) as u32)).into_drawing_area();
    root.fill(&WHITE)?;
    root.draw(&Text::new("posterior-predictive samples", (10, 8), ("sans-serif", 16)))?;
    for (r, (name, inst)) in places.iter().enumerate() {
        let y = 34 + r as i32 * (block + 12);
        root.draw(&Text::new(name.clone(), (10, y + block / 3), ("sans-serif", 13)))?;
        for (i, f) in inst.iter().take(per_row).enumerate() {
            let x = label_w + i as i32 * (block + 4);
            let total: f64 = f.colors.iter().map(|h| h.1).sum::<f64>().max(1e-12);
            let mut acc = 0.0;
            for &(b, wgt) in &f.colors {
                let a = y + (acc / total * block as f64) as i32;
                acc += wgt;
                let e = y + (acc / total * block as f64).round() as i32;
                root.draw(&Rectangle::new(
                    [(x, a), (x + block, e.max(a + 1))],
                    term_rgb(usize::from(b)).filled(),
                ))?;
            }
            root.draw(&Rectangle::new([(x, y), (x + block, y + block)], BLACK.mix(0.3)))?;
        }
    }
    root.present()?;
    Ok(())
}

/// Posterior-predictive size densities per place (Fig. 5.5), with optional sample ticks.
pub fn size_densities(path: &Path, places: &[(String, StudentT)], samples: &[(usize, f64)]) -> anyhow::Result<()> {
    let lo = places
        .iter()
        .map(|(_, t)| t.loc() - 4.0 * t.scale())
        .fold(f64::INFINITY, f64::min)
        .max(0.0);
    let hi = places
        .iter()
        .map(|(_, t)| t.loc() + 4.0 * t.scale())
        .fold(f64::NEG_INFINITY, f64::max);
    let (lo, hi) = if lo.is_finite() && hi.is_finite() && hi > lo {
        (lo, hi)
    } else {
        (0.0, 1.0)
    };
    let xs: Vec<f64> = (0..=300).map(|i| lo + (hi - lo) * i as f64 / 300.0).collect();
    let curves: Vec<Vec<(f64, f64)>> = places
        .iter()
        .map(|(_, t)| xs.iter().map(|&x| (x, t.log_pdf(x).exp())).collect())
        .collect();
    let ymax = curves.iter().flatten().map(|p| p.1).fold(0.0, f64::max).max(1e-12) * 1.1;
    let chart = LineChart {
        title: "posterior-predictive size density".into(),
        x_label: "size (the model's unit: cm, or the seed's deci-pixels)".into(),
        y_label: "density".into(),
        x_range: (lo, hi),
        y_range: (0.0, ymax),
        log_y: false,
        series: places
            .iter()
            .zip(curves)
            .map(|((n, _), points)| Series {
                label: n.clone(),
                points,
                errors: vec![],
            })
            .collect(),
        hlines: vec![],
    };
    let root = SVGBackend::new(path, (720, 460)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut ctx = ChartBuilder::on(&root)
        .caption(&chart.title, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(lo..hi, 0.0..ymax)?;
    ctx.configure_mesh()
        .x_desc(chart.x_label.as_str())
        .y_desc(chart.y_label.as_str())
        .draw()?;
    for (i, s) in chart.series.iter().enumerate() {
        let color = PALETTE[i % PALETTE.len()];
        ctx.draw_series(LineSeries::new(s.points.iter().copied(), color.stroke_width(2)))?
            .label(s.label.clone())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2)));
    }
    ctx.draw_series(samples.iter().map(|&(k, x)| {
        let color = PALETTE[k % PALETTE.len()];
        PathElement::new(vec![(x, 0.0), (x, 0.04 * ymax)], color.stroke_width(1))
    }))?;
    ctx.configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()?;
    root.present()?;
    Ok(())
}
