//! Features of every presentation of a catalog, rendered with the simulator's vision pipeline:
//! the object alone on the table (with the two bins) in front of Dexter's head cameras, segmented
//! by background subtraction, matched in stereo with the table's plane known (the robot's own
//! settings), and reduced to the kept bins of the 64-colour histogram, the colour terms weighed by
//! the surface each pixel stands for (`dexter::vision::color::surface_color_terms`), the left/right
//! pixel counts and the measured extent on the support plane (the metric size) — what `pbd record`
//! stores per segment.
//!
//! Each presentation is rendered in several *variants* (seeded position jitter, yaw and pixel
//! noise), so trials see the object as it would be presented again: not the same pixels twice.

use anyhow::{Context, bail};
use bayes::rng::Draw;
use dexter::vision::color::surface_color_terms;
use dexter::vision::stereo::Side;
use dexter::vision::{SegmentConfig, StereoConfig};
use dexter_sim::scene::{CameraSpec, Catalog, LightSpec};
use dexter_sim::vision::fixtures::{TABLE_FIXATION, TABLE_TOP, head_cameras, table_and_bins};
use dexter_sim::vision::{ItemLabel, RenderItem, StereoVision};
use nalgebra::Vector3;
use rand::Rng as _;
use schema::SegmentPercept;
use schema::procedural::Features;
use serde::{Deserialize, Serialize};

/// One presentation of a catalog object and its hand labels.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Presentation {
    /// Presentation name (`jif-1`).
    pub name: String,
    /// Object name (`jif`).
    pub object: String,
    /// The catalog's colour class, if labelled.
    pub color_class: Option<String>,
    /// The catalog's size class, if labelled.
    pub size_class: Option<String>,
}

/// Rendered features: `features[p][v]` is variant v of presentation p.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FeatureBank {
    /// Where the catalog came from.
    pub catalog: String,
    /// Seed of the renders.
    pub seed: u64,
    /// The presentations, in catalog order.
    pub presentations: Vec<Presentation>,
    /// Features per presentation and variant.
    pub features: Vec<Vec<Features>>,
}

impl FeatureBank {
    /// Number of variants per presentation.
    pub fn variants(&self) -> usize {
        self.features.first().map_or(0, Vec::len)
    }
}

/// Renders `variants` views of every presentation in `catalog`; `tick` is called after each one.
pub fn render_bank(
    catalog: &Catalog,
    variants: usize,
    seed: u64,
    mut tick: impl FnMut(),
) -> anyhow::Result<FeatureBank> {
    let spec = CameraSpec::default();
    let light = LightSpec::default();
    let cams = head_cameras(&spec, Vector3::from(TABLE_FIXATION))?;
    let base = table_and_bins();
    // The robot's own settings (`dexter::eyes`): segmentation for the cameras' pixel noise and the
    // table's plane known, so that objects standing on it are measured on it (height, footprint).
    let stereo = StereoConfig::on_table(TABLE_TOP, spec.pixel_noise);
    let mut vision =
        StereoVision::with_config(&spec, &light, seed, SegmentConfig::for_noise(spec.pixel_noise), stereo)?;
    vision.capture_background(&cams, &base)?;
    let mut presentations = Vec::new();
    let mut features = Vec::new();
    let mut blobs = Vec::new();
    for name in catalog.presentation_names() {
        let (index, _) = catalog.presentation(name)?;
        let object = &catalog.objects[index];
        let mut views = Vec::with_capacity(variants);
        for v in 0..variants {
            let k = (presentations.len() as u64) << 16 | v as u64;
            let mut rng = crate::rng::stream(seed, k);
            let x = 0.6 + 0.08 * (rng.uniform() - 0.5);
            let y = 0.16 * (rng.uniform() - 0.5);
            let yaw = 360.0 * rng.uniform();
            let pose = catalog.rest_pose(name, [x, y], yaw, TABLE_TOP)?;
            let mut scene = base.clone();
            scene.push(RenderItem::from_catalog(
                &object.shape,
                pose,
                &object.colors,
                ItemLabel::Object(0),
            ));
            vision.reseed(rng.next_u64());
            vision.perceive_into(&cams, &scene, &mut blobs)?;
            let best = blobs
                .iter()
                .filter_map(|b| {
                    let l = b.left.map_or(0, |s| s.features.pixel_count);
                    let r = b.right.map_or(0, |s| s.features.pixel_count);
                    (l + r > 0).then_some((l + r, b))
                })
                .max_by_key(|(n, _)| *n)
                .map(|(_, b)| b);
            let Some(blob) = best else {
                bail!("presentation {name}: the object is not visible to the head cameras");
            };
            let (seg, side, cam) = match (blob.left, blob.right) {
                (Some(l), _) => (l, Side::Left, &cams.left),
                (None, Some(r)) => (r, Side::Right, &cams.right),
                (None, None) => bail!("presentation {name}: a blob without segments"),
            };
            let h = &seg.features.histogram;
            let kept: Vec<usize> = h.kept_bins().collect();
            let total: f64 = kept.iter().map(|&i| f64::from(h.counts[i])).sum();
            let histogram = kept
                .iter()
                .map(|&i| (i as u8, f64::from(h.counts[i]) / total.max(1.0)))
                .collect();
            // The robot's measurement of the object on the support plane (the metric size), and
            // its colours by surface where that measurement gives the top and the sides (what the
            // robot's watch computes: `dexter::vision::color::surface_color_terms`).
            let extent = dexter::skills::extent_of(blob, &cams, TABLE_TOP);
            let terms = extent
                .as_ref()
                .and_then(|e| {
                    surface_color_terms(
                        &seg,
                        vision.segmenter(side),
                        vision.renderer(side).image(),
                        cam,
                        e,
                        TABLE_TOP,
                    )
                })
                .unwrap_or(seg.features.color_terms);
            let percept = SegmentPercept {
                id: 0,
                centroid: blob.centroid.map_or([0.0; 3], |c| [c.x, c.y, c.z]),
                seen: blob.left.is_some() && blob.right.is_some(),
                pixels: [
                    blob.left.map_or(0, |s| s.features.pixel_count as u32),
                    blob.right.map_or(0, |s| s.features.pixel_count as u32),
                ],
                histogram,
                covariance: [0.0; 4],
                colors: dexter::vision::color::kept_color_terms(&terms),
                extent,
            };
            views.push(Features::from(&percept));
            tick();
        }
        presentations.push(Presentation {
            name: name.to_string(),
            object: object.name.clone(),
            color_class: object.color_class.clone(),
            size_class: object.size_class.clone(),
        });
        features.push(views);
    }
    Ok(FeatureBank {
        catalog: catalog.path.display().to_string(),
        seed,
        presentations,
        features,
    })
}

/// Reads a feature bank written by `pbd experiment sorting --dump-features FILE`.
pub fn load_bank(path: &std::path::Path) -> anyhow::Result<FeatureBank> {
    let text = bayes::input::read_text(path).with_context(|| format!("cannot read {}", path.display()))?;
    if let Err(dup) = bayes::input::check_json_keys(&text) {
        bail!("{}: {dup}", path.display());
    }
    let bank: FeatureBank =
        serde_json::from_str(&text).with_context(|| format!("{} is not a feature bank", path.display()))?;
    if bank.presentations.len() != bank.features.len() || bank.features.iter().any(Vec::is_empty) {
        bail!(
            "{}: {} presentations but {} feature lists (each needs at least one view)",
            path.display(),
            bank.presentations.len(),
            bank.features.len()
        );
    }
    Ok(bank)
}
