//! Figures as data, and as SVG files.
//!
//! The library computes every figure's numbers and says where it belongs (`success.svg`,
//! `roc.svg`, …); [`draw`] writes one as an SVG file (plotters; a text format, so the same numbers
//! give the same file on every platform) — the CLI and the Python module call it — and a notebook
//! can draw the same data with matplotlib instead.

mod svg;

pub use svg::{draw, line_chart, pmf_grid, size_densities, swatches};

use std::path::PathBuf;

use bayes::univariate::StudentT;
use schema::procedural::Features;
use serde::Serialize;

/// One line of a [`LineChart`]: points (x, y) with an optional (low, high) error bar each.
#[derive(Debug, Clone, Serialize)]
pub struct Series {
    /// Legend label.
    pub label: String,
    /// Points.
    pub points: Vec<(f64, f64)>,
    /// Error bars (low, high) per point, or empty.
    pub errors: Vec<(f64, f64)>,
}

/// A line chart.
#[derive(Debug, Clone, Serialize)]
pub struct LineChart {
    /// Title.
    pub title: String,
    /// X axis label.
    pub x_label: String,
    /// Y axis label.
    pub y_label: String,
    /// X range.
    pub x_range: (f64, f64),
    /// Y range (positive when `log_y`).
    pub y_range: (f64, f64),
    /// Logarithmic y axis.
    pub log_y: bool,
    /// The lines.
    pub series: Vec<Series>,
    /// Dashed horizontal reference lines (y, label).
    pub hlines: Vec<(f64, String)>,
}

/// A figure to draw.
#[derive(Debug, Clone)]
pub enum Figure {
    /// Lines with error bars (success curves, p-values, ROC).
    Lines(LineChart),
    /// Colour pmfs per place after each example (Fig. 5.11): (place, pmf per step).
    PmfGrid {
        /// Title.
        title: String,
        /// (place, one pmf over the colour terms per number of examples).
        rows: Vec<(String, Vec<Vec<f64>>)>,
    },
    /// Colour swatches of posterior-predictive samples per place (Fig. 5.12).
    Swatches(Vec<(String, Vec<Features>)>),
    /// Predictive size densities per place (Fig. 5.5), with sampled sizes (place index, size).
    SizeDensities {
        /// (place, Student-t predictive density of the size).
        places: Vec<(String, StudentT)>,
        /// (place index, size) of samples, drawn as ticks.
        samples: Vec<(usize, f64)>,
    },
    /// Grouped bars: per category one bar per group (Fig. 6.7: per object, naive and model).
    GroupedBars {
        /// Title.
        title: String,
        /// Y axis label.
        y_label: String,
        /// Top of the y axis.
        y_max: f64,
        /// Category labels (under the bars).
        categories: Vec<String>,
        /// (group legend, value per category).
        groups: Vec<(String, Vec<f64>)>,
        /// Interval whiskers (low, high) per group and category; empty for none.
        intervals: Vec<Vec<(f64, f64)>>,
    },
}

/// A figure and the file it belongs in.
pub type FigureFile = (PathBuf, Figure);
