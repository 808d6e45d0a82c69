//! Plots for procedural models and experiments (plotters): colour swatches, size densities, success
//! curves and ROC curves.
