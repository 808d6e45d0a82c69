//! Centroids of objects resting on a known horizontal support plane (the table).
//!
//! The stereo-triangulated silhouette centroid ([`crate::vision::StereoBlob::raw_centroid`]) is
//! precise across the viewing direction but not along it: at 160×120 one pixel of disparity is
//! about 5 cm of range at table distances, and the centroid disparity of a small or tall segment is
//! off by a few tenths of a pixel (pixel quantisation of the silhouette edges, and the two cameras
//! seeing different faces). Over the 96 random objects of `tests/vision.rs` most of its error lies
//! along the viewing ray (up to 13 mm), little across it.
//!
//! An object resting on the table has its centroid at height `table + h/2` (`h` its height), so
//! it is found more precisely by intersecting each camera's silhouette-centroid ray with that
//! plane — if `h` can be measured. [`SupportEstimator`] measures it from what the cameras see, the
//! camera calibration and the table plane only:
//!
//! * **Prism** (upright boxes, cylinders and other vertical extrusions with a flat top): the lowest
//!   silhouette pixel of each image column lies on the table's plane, so back-projecting it gives
//!   a 3-D point on the near bottom edge. The object's side above that point is vertical; walking
//!   down the image of the vertical line through it from the silhouette's top, the first step in
//!   colour is the top face's near edge (Lambert shading differs between the horizontal top and
//!   the sides), and its height above the bottom point is `h`. The median over the columns of
//!   both images is used. A step is found by two tests, the upper hit winning: neighbouring
//!   pixels (exact for bright faces), and windows of three rows on either side, whose means have
//!   √3 less noise, so the weak step of a dark top shows (a black lid: about 0.06 in RGB, where a
//!   pixel pair's noise is 0.024); the windowed hit is then located pixel by pixel against the
//!   mean of the rows above. A column's step counts only if it is a *shading* step: the side just
//!   below the edge has the top's colour (the topmost colour band runs up to the edge), only
//!   darker (0.25–0.85 of it; the default light gives 0.57–0.66) — a band edge has another hue or
//!   brightness. Accepted when most columns show such a step, the pixels above the steps are
//!   uniform in colour (within 0.06 in RGB or 15 % of the top's colour, but not below the noise)
//!   and their upper and lower halves agree in mean colour (a flat face under a directional light;
//!   a sphere's cap shades gradually, which the pooled halves show even when dark); otherwise the
//!   object is taken as
//! * **Round** (spheres, or anything without a flat, uniformly lit top): a sphere of the segment's
//!   apparent radius resting on the table, centre at `table + r`; `r` from the segment area
//!   (an off-axis sphere images as an ellipse of area `π f² α² / cos³θ`, `α = asin(r / D)`).
//!
//! For a prism, x and y then come from its footprint rather than from the silhouette-centroid rays
//! (whose sideways bias reaches 5–13 mm for tall objects): the cells of the table whose bottom and
//! top points (at the measured height) project into both silhouettes.
//!
//! A dark top above a dark side band once passed for a lower prism (a black-lidded mug measured
//! 5 cm instead of 9.5 cm: its lid's step was not seen and its white band's edge was taken), so
//! dark tops were given no estimate at all. The windowed test sees their step, and the shading
//! test rejects a band edge taken for it; a top darker than the smallest significant windowed step
//! over [`SupportPlane::top_contrast`] (RGB norm below about 0.12; black lids are 0.15) still
//! gives no estimate.
//!
//! The result is checked against the triangulated point: if they disagree by more than
//! [`SupportPlane::max_disagreement`] (the object is not on the table, lies in a bin, is held, is
//! partly hidden, …), the triangulated point is kept — except for a thing lying on its side (a
//! round estimate whose silhouettes are elongated across the image of the vertical in both cameras):
//! its centroid disparity is the least reliable datum it offers (a cap segmented in one camera and
//! not the other moves one centroid along its axis, near the epipolar direction), so the estimate is
//! taken when it differs only along the line of sight, by at most
//! [`SupportPlane::lying_disparity_px`] of disparity, and the thing's bottom edges, cast onto the
//! table, put it there too — a depth cue that needs no disparity. (The stereo matcher then puts such
//! an estimate back where its disparity says when that lies over another thing's footprint: a
//! part of that object, segmented apart.)

use crate::vision::segment::Segment;
use control_basis::hardware::{Camera, Image};
use control_basis::math::Vec3;

/// A known horizontal support plane and the settings of [`SupportEstimator`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SupportPlane {
    /// Height of the plane (world z, m).
    pub height: f64,
    /// The estimate replaces the triangulated point only if they are at most this far apart (m),
    /// plus [`SupportPlane::disagreement_per_height`] × the height of a prism.
    pub max_disagreement: f64,
    /// Added tolerance per metre of prism height: the triangulated silhouette centroid of a tall
    /// box or cylinder is biased (measured up to 0.34 h over 500 objects); that of a sphere is not.
    pub disagreement_per_height: f64,
    /// Standard deviation of the cameras' pixel noise on each RGB channel in [0, 1]
    /// ([`control_basis::hardware::CameraInfo::pixel_noise`]): sets how small a step can be told from noise.
    pub pixel_noise: f64,
    /// Rows averaged on each side of a candidate step by the windowed test (fewer where the
    /// column ends).
    pub step_window: usize,
    /// A step is significant when the RGB distance between the mean colours above and below it
    /// exceeds this many standard deviations of that distance's noise
    /// (`pixel_noise · √(1/n_above + 1/n_below)` per channel) …
    pub step_sigmas: f64,
    /// … and this share of the brighter mean colour: smooth shading (a sphere's) changes by less
    /// between neighbouring pixels than the side-to-top step, which is at least
    /// [`SupportPlane::top_contrast`].
    pub step_contrast: f64,
    /// Once the windowed test has found a step, the first pixel farther than this many noise
    /// standard deviations from the mean of the pixels above it is the first below the step.
    pub locate_sigmas: f64,
    /// Shading contrast assumed between the top face and the sides (share of the top's colour):
    /// a top darker than the smallest significant step (at full windows) / `top_contrast` (RGB
    /// norm) cannot show its edge, so its height is not measured and the triangulated point is kept.
    pub top_contrast: f64,
    /// Share of the walked image columns (both images) that must show a step for the prism model.
    pub min_step_share: f64,
    /// A top-face pixel is uniform when its RGB distance to the top face's mean colour is below
    /// this, or below [`SupportPlane::uniform_share`] of that colour's RGB norm if that is smaller
    /// (a dark sphere's shading spans less than this absolute tolerance) …
    pub uniform_tolerance: f64,
    /// … but never below [`SupportPlane::uniform_sigmas`] × `pixel_noise`.
    pub uniform_share: f64,
    /// See [`SupportPlane::uniform_share`].
    pub uniform_sigmas: f64,
    /// Range of the side-to-top brightness ratio at the step (the colour just below the step over
    /// the top's, which must be of the same hue): the default light, 70° above the horizon, gives
    /// 0.57–0.66; the range fits lights steeper than about 55°.
    pub side_ratio: [f64; 2],
    /// The colour just below the step may deviate from the top's colour × that ratio by this
    /// share of its RGB norm (plus the noise of its mean).
    pub shading_tolerance: f64,
    /// Share of uniform top-face pixels required for the prism model.
    pub min_uniform_share: f64,
    /// The mean colours of the upper and lower halves of the top-face pixels may differ by
    /// [`SupportPlane::step_sigmas`] noise standard deviations or this share of the top's colour
    /// (RGB norm), whichever is larger; more, and the top is not a flat face.
    pub flat_share: f64,
    /// A round estimate of a thing lying across the image replaces the triangulated point even
    /// farther away than [`SupportPlane::max_disagreement`], if it differs only along the line of
    /// sight, by at most this many pixels of centroid disparity, and the thing's bottom edges put it
    /// there too ([`SupportEstimator::estimate`]).
    pub lying_disparity_px: f64,
}

impl SupportPlane {
    /// The default settings for a plane at `height`, for the default camera (pixel noise σ = 0.01).
    pub fn at(height: f64) -> Self {
        Self {
            height,
            max_disagreement: 0.02,
            disagreement_per_height: 0.4,
            pixel_noise: 0.01,
            step_window: 3,
            step_sigmas: 4.5,
            locate_sigmas: 3.3,
            step_contrast: 0.15,
            top_contrast: 0.3,
            min_step_share: 0.5,
            uniform_tolerance: 0.06,
            uniform_share: 0.15,
            uniform_sigmas: 3.5,
            min_uniform_share: 0.9,
            side_ratio: [0.25, 0.85],
            shading_tolerance: 0.15,
            flat_share: 0.02,
            lying_disparity_px: 3.0,
        }
    }
}

/// Which estimate a blob's centroid is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CentroidSource {
    /// The triangulated silhouette centroid (no support plane, one camera only, or the support
    /// estimate was rejected).
    Triangulated,
    /// An upright prism of the measured height resting on the support plane.
    Prism {
        /// Measured height (m).
        height: f64,
    },
    /// A sphere of the measured radius resting on the support plane.
    Round {
        /// Measured radius (m).
        radius: f64,
    },
    /// A thing too tall to grasp standing on the support plane, located from its vertical
    /// silhouette edges ([`crate::vision::edges`]).
    Standing {
        /// Height of the highest point of its edges both cameras see (m above the plane).
        height: f64,
        /// Whether that is its top (not cut by the image border).
        top_seen: bool,
        /// Whether its footprint was measured whole (the outline of its top seen in both views).
        whole: bool,
    },
}

/// An object's footprint on the support plane, from the table cells under it that both cameras
/// see (a visual hull of its cross-section): centre, principal axes and half extents (m, world).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Footprint {
    /// Centre (x, y).
    pub center: [f64; 2],
    /// Unit direction (x, y) of the major axis.
    pub major_axis: [f64; 2],
    /// Half extent along the major axis (m).
    pub half_major: f64,
    /// Half extent along the minor axis (m).
    pub half_minor: f64,
}

impl Footprint {
    /// A disc of radius `r` about `center`.
    pub fn disc(center: [f64; 2], r: f64) -> Self {
        Footprint {
            center,
            major_axis: [1.0, 0.0],
            half_major: r,
            half_minor: r,
        }
    }

    /// Half extent (m) of the footprint along the horizontal unit direction `d` (an ellipse-free,
    /// rectangle model: the support function of the box with the principal axes).
    pub fn half_extent_along(&self, d: [f64; 2]) -> f64 {
        let [ax, ay] = self.major_axis;
        let c = (d[0] * ax + d[1] * ay).abs();
        let s = (d[0] * -ay + d[1] * ax).abs();
        self.half_major * c + self.half_minor * s
    }
}

/// One camera's view of a blob: the camera, its image, its component map and the segment's
/// component id.
#[derive(Debug)]
pub struct View<'a> {
    /// The camera.
    pub camera: &'a Camera,
    /// Its image.
    pub image: &'a Image,
    /// Its component map (segment `i` has id `i + 1`).
    pub components: &'a [u32],
    /// The segment.
    pub segment: &'a Segment,
    /// The segment's component id.
    pub id: u32,
}

/// Estimates centroids of objects resting on a [`SupportPlane`]; holds its scratch buffers.
#[derive(Debug, Clone, Default)]
pub struct SupportEstimator {
    /// The walked columns of both images.
    columns: Vec<Column>,
    /// Their pixels' colours, top down, column after column.
    pixels: Vec<[f64; 3]>,
    heights: Vec<f64>,
    top: Vec<[f32; 3]>,
    /// Scratch: cast bottom-edge offsets of one view ([`bottom_agrees`]).
    offsets: Vec<f64>,
}

/// One walked image column: the image of the vertical line over a bottom-edge point `b`, from its
/// topmost silhouette pixel down to (not including) its lowest one.
#[derive(Debug, Clone, Copy)]
struct Column {
    /// Index of its first (topmost) pixel in [`SupportEstimator::pixels`].
    start: usize,
    /// Number of pixels (≥ 2).
    len: usize,
    /// Image row of its first pixel.
    vt: f64,
    /// The image row of `b + z·ẑ` is `(a1 + c1 z) / (a3 + c3 z)` (rows of the projection matrix
    /// applied to `b` and to `ẑ`).
    a1: f64,
    c1: f64,
    a3: f64,
    c3: f64,
}

impl Column {
    /// The height whose image is row `v` (continuous).
    fn height_at(&self, v: f64) -> f64 {
        (self.a1 - v * self.a3) / (v * self.c3 - self.c1)
    }

    /// The height of the boundary above pixel `j` (between pixels `j − 1` and `j`).
    fn boundary_height(&self, j: usize) -> f64 {
        self.height_at(self.vt + j as f64 - 0.5)
    }
}

/// What the columns say about the prism model.
#[derive(Debug, Clone, Copy, Default)]
struct ColumnStats {
    columns: usize,
    steps: usize,
    /// Summed colours and counts of the upper and lower halves of the top pixels of each column.
    upper: [f64; 3],
    lower: [f64; 3],
    /// Summed colour of the first pixel below the step of each column.
    below: [f64; 3],
    n_upper: usize,
    n_lower: usize,
}

impl SupportEstimator {
    /// A new estimator.
    pub fn new() -> Self {
        Self::default()
    }

    /// The centroid of the object seen as `views` (left, right), whose triangulated silhouette
    /// centroid is `triangulated`; `None` if neither model applies or the estimate disagrees with
    /// the triangulation.
    pub fn estimate(
        &mut self,
        views: [View<'_>; 2],
        triangulated: &Vec3,
        plane: &SupportPlane,
    ) -> Option<(Vec3, CentroidSource, Option<Footprint>)> {
        if views.iter().any(|v| v.segment.touches_border) || !triangulated.iter().all(|x| x.is_finite()) {
            return None;
        }
        self.columns.clear();
        self.pixels.clear();
        self.heights.clear();
        self.top.clear();
        for v in &views {
            self.walk_columns(v, plane);
        }
        let stats = self.find_step(plane);
        let prism = self.prism_height(&stats, plane)?;
        let (zc, source) = match prism {
            Some(h) => (plane.height + 0.5 * h, CentroidSource::Prism { height: h }),
            None => {
                let r = round_radius(&views, triangulated, plane.height)?;
                (plane.height + r, CentroidSource::Round { radius: r })
            }
        };
        let mut sum = Vec3::zeros();
        for v in &views {
            let c = v.segment.features.centroid;
            let (o, d) = v.camera.ray(c[0], c[1]);
            sum += ray_at_height(&o, &d, zc)?;
        }
        let mut p = 0.5 * sum;
        let mut footprint = None;
        match source {
            CentroidSource::Prism { height } => {
                if let Some(f) = footprint_cells(&views, plane.height, height) {
                    p.x = f.center[0];
                    p.y = f.center[1];
                    footprint = Some(f);
                }
            }
            CentroidSource::Round { radius } => footprint = Some(Footprint::disc([p.x, p.y], radius)),
            CentroidSource::Triangulated | CentroidSource::Standing { .. } => {}
        }
        let tolerance = match source {
            CentroidSource::Prism { height } => plane.max_disagreement + plane.disagreement_per_height * height,
            _ => plane.max_disagreement,
        };
        let disagreement = (p - triangulated).norm();
        let accepted = disagreement <= tolerance
            || (matches!(source, CentroidSource::Round { .. })
                && views.iter().all(|v| lies_across(v, &p))
                && lying_depth_agrees(&views, &p, zc - plane.height, triangulated, plane, &mut self.offsets));
        tracing::trace!(
            "SUPPORT {source:?} at [{:.3}, {:.3}, {:.3}], triangulated [{:.3}, {:.3}, {:.3}]: {:.3} m apart (tolerance {tolerance:.3}): {}",
            p.x,
            p.y,
            p.z,
            triangulated.x,
            triangulated.y,
            triangulated.z,
            disagreement,
            if accepted {
                "taken"
            } else {
                "kept the triangulated point"
            }
        );
        accepted.then_some((p, source, footprint))
    }

    /// `Some(Some(h))` if the prism model applies: at least three and most columns show a shading
    /// step, which the pooled colours below the steps confirm, and the top face above the steps is
    /// uniform and flat; `Some(None)` if it does not; `None` if the top is too dark for its edge
    /// to be seen (no estimate at all: a dark top above a dark side band would pass for a lower
    /// prism).
    fn prism_height(&mut self, stats: &ColumnStats, plane: &SupportPlane) -> Option<Option<f64>> {
        if self.heights.len() < 3 || (stats.steps as f64) < plane.min_step_share * stats.columns as f64 {
            return Some(None);
        }
        let n = self.top.len() as f64;
        let mean = self.top.iter().fold([0.0f64; 3], |a, p| {
            [a[0] + p[0] as f64, a[1] + p[1] as f64, a[2] + p[2] as f64]
        });
        let mean = mean.map(|x| x / n);
        if rgb_dist(&mean, &[0.0; 3]) * plane.top_contrast < plane.min_step() {
            return None;
        }
        // A shading step: the side just below the top edge has the top's colour (the topmost band
        // runs up to the edge), only darker — unlike a band edge, where a dark top over a light
        // band (a sphere's dark cap over its stripe) would pass for a lower prism.
        let below = stats.below.map(|x| x / stats.steps as f64);
        if !plane.is_shading_step(&mean, &below, stats.steps as f64) {
            return Some(None);
        }
        let tolerance = (plane.uniform_share * rgb_dist(&mean, &[0.0; 3]))
            .min(plane.uniform_tolerance)
            .max(plane.uniform_sigmas * plane.pixel_noise);
        let uniform = self
            .top
            .iter()
            .filter(|p| rgb_dist(&[p[0] as f64, p[1] as f64, p[2] as f64], &mean) < tolerance)
            .count();
        if (uniform as f64) < plane.min_uniform_share * n {
            return Some(None);
        }
        // Flat and evenly lit: the upper and lower halves of the top pixels agree in mean colour
        // (pooled over the columns, so a gentle shading gradient — a dark sphere's — shows).
        if stats.n_upper > 0 && stats.n_lower > 0 {
            let (nu, nl) = (stats.n_upper as f64, stats.n_lower as f64);
            let d = rgb_dist(&stats.upper.map(|x| x / nu), &stats.lower.map(|x| x / nl));
            let noise = plane.step_sigmas * plane.pixel_noise * (1.0 / nu + 1.0 / nl).sqrt();
            if d > noise.max(plane.flat_share * rgb_dist(&mean, &[0.0; 3])) {
                return Some(None);
            }
        }
        self.heights.sort_unstable_by(f64::total_cmp);
        Some(Some(self.heights[self.heights.len() / 2]))
    }

    /// Walks the image of the vertical line over each bottom-edge point of `view`'s segment (all
    /// columns but the outermost), storing each column's colours top down.
    fn walk_columns(&mut self, view: &View<'_>, plane: &SupportPlane) {
        let (img, cam) = (view.image, view.camera);
        let (w, h) = (img.width as i64, img.height as i64);
        let inside =
            |u: i64, v: i64| u >= 0 && v >= 0 && u < w && v < h && view.components[(v * w + u) as usize] == view.id;
        let rgb = |u: i64, v: i64| {
            let p = img.px((v * w + u) as usize);
            [p[0] as f64 / 255.0, p[1] as f64 / 255.0, p[2] as f64 / 255.0]
        };
        let [u0, v0, u1, v1] = view.segment.bbox;
        let proj = Projection::of(cam);
        for u in (u0 as i64 + 1)..(u1 as i64) {
            let Some(vb) = (v0 as i64..=v1 as i64).rev().find(|&v| inside(u, v)) else {
                continue;
            };
            // The lower edge of the lowest pixel, back-projected onto the plane: a bottom-edge point.
            let (o, d) = cam.ray(u as f64, vb as f64 + 0.5);
            let Some(b) = ray_at_height(&o, &d, plane.height) else {
                continue;
            };
            // The image of the vertical line over b, as u(v).
            let (Some(pa), Some(pb)) = (proj.project(&b), proj.project(&(b + Vec3::new(0.0, 0.0, 0.4)))) else {
                continue;
            };
            if pb.1.is_nan() || pa.1.is_nan() || pb.1 >= pa.1 - 1e-9 {
                continue;
            }
            let u_at = |v: i64| (pa.0 + (pb.0 - pa.0) * (v as f64 - pa.1) / (pb.1 - pa.1)).round() as i64;
            let mut vt = vb;
            while inside(u_at(vt - 1), vt - 1) {
                vt -= 1;
            }
            if vb - vt < 2 {
                continue;
            }
            let m = &proj.0;
            let row = |r: &[f64; 4]| r[0] * b.x + r[1] * b.y + r[2] * b.z + r[3];
            let start = self.pixels.len();
            // The lowest pixel is left out: it may straddle the bottom edge.
            self.pixels.extend((vt..vb).map(|v| rgb(u_at(v), v)));
            self.columns.push(Column {
                start,
                len: (vb - vt) as usize,
                vt: vt as f64,
                a1: row(&m[1]),
                c1: m[1][2],
                a3: row(&m[2]),
                c3: m[2][2],
            });
        }
    }

    /// Finds the side/top step in each walked column ([`topmost_step`]), filling `heights` (the
    /// height of the step over the column's bottom point) and `top` (the pixels above it).
    fn find_step(&mut self, plane: &SupportPlane) -> ColumnStats {
        let mut stats = ColumnStats {
            columns: self.columns.len(),
            ..ColumnStats::default()
        };
        for c in &self.columns {
            let col = &self.pixels[c.start..c.start + c.len];
            let Some(j) = topmost_step(col, plane) else {
                continue;
            };
            if !plane.is_shading_step(&mean_rgb(&col[..j]).0, &col[j], 1.0) {
                continue;
            }
            stats.steps += 1;
            for (s, x) in stats.below.iter_mut().zip(col[j]) {
                *s += x;
            }
            self.heights.push(c.boundary_height(j));
            for p in &col[..j] {
                self.top.push([p[0] as f32, p[1] as f32, p[2] as f32]);
            }
            // The top's upper and lower halves (flatness test).
            let half = j / 2;
            for (k, p) in col[..j].iter().enumerate() {
                let (sum, n) = if k < half {
                    (&mut stats.upper, &mut stats.n_upper)
                } else if k >= j - half {
                    (&mut stats.lower, &mut stats.n_lower)
                } else {
                    continue;
                };
                for (s, x) in sum.iter_mut().zip(p) {
                    *s += x;
                }
                *n += 1;
            }
        }
        stats
    }
}

/// The significance of a step between `col[..j]` and `col[j..]`: the RGB distance between the
/// mean colours of up to `k` rows above and `k` below, over the larger of its noise threshold
/// ([`SupportPlane::step_sigmas`] standard deviations) and its contrast threshold
/// ([`SupportPlane::step_contrast`] of the brighter mean); a step when > 1.
fn step_score(col: &[[f64; 3]], j: usize, k: usize, plane: &SupportPlane) -> f64 {
    let (a, na) = mean_rgb(&col[j.saturating_sub(k)..j]);
    let (b, nb) = mean_rgb(&col[j..(j + k).min(col.len())]);
    let noise = plane.step_sigmas * plane.pixel_noise * (1.0 / na + 1.0 / nb).sqrt();
    let contrast = plane.step_contrast * rgb_dist(&a, &[0.0; 3]).max(rgb_dist(&b, &[0.0; 3]));
    rgb_dist(&a, &b) / noise.max(contrast)
}

fn mean_rgb(rows: &[[f64; 3]]) -> ([f64; 3], f64) {
    let n = rows.len() as f64;
    let s = rows
        .iter()
        .fold([0.0; 3], |a, p| [a[0] + p[0], a[1] + p[1], a[2] + p[2]]);
    (s.map(|x| x / n), n)
}

/// The first significant step walking down a column's colours `col` (index 0 the topmost pixel):
/// the index `j` of the first pixel below it. Two tests, the upper hit wins:
///
/// * neighbouring pixels: exact where the step stands clear of the noise (bright faces), and
///   right even where a thin band lies just below the top edge;
/// * windows of [`SupportPlane::step_window`] rows on either side: the noise of their means falls
///   by √n, so the weaker shading step of a dark top is seen (a black lid's is about 0.06 in RGB,
///   a pixel pair's noise 0.024). The windowed score rises a few rows before a step, and a band
///   edge just below adds to it, so the step is then located pixel by pixel: the first pixel from
///   one row above the first significant window on that differs from the mean of the rows above
///   it by more than [`SupportPlane::locate_sigmas`] noise standard deviations and the contrast
///   threshold.
fn topmost_step(col: &[[f64; 3]], plane: &SupportPlane) -> Option<usize> {
    let k = plane.step_window.max(1);
    let pixel = (1..col.len()).find(|&j| step_score(col, j, 1, plane) > 1.0);
    let limit = pixel.unwrap_or(col.len());
    let first = (1..limit).find(|&j| step_score(col, j, k, plane) > 1.0);
    let windowed = first.and_then(|first| {
        let from = first.saturating_sub(1).max(1);
        (from..(first + k).min(col.len())).find(|&j| {
            let (a, na) = mean_rgb(&col[..j]);
            let noise = plane.locate_sigmas * plane.pixel_noise * (1.0 + 1.0 / na).sqrt();
            let contrast = plane.step_contrast * rgb_dist(&a, &[0.0; 3]);
            rgb_dist(&col[j], &a) > noise.max(contrast)
        })
    });
    match (pixel, windowed) {
        (Some(a), Some(b)) => Some(a.min(b)),
        (a, b) => a.or(b),
    }
}

/// Whether a segment's silhouette (at least [`LYING_MIN_PIXELS`]) is elongated ([`ELONGATED`])
/// across the image of the vertical through `p` (more than [`VERTICAL_SLACK`] away from it): a thing
/// lying on its side, not one
/// standing up. A standing bottle without a flat top is elongated along the image of the vertical;
/// so is one lying along the line of sight, foreshortened — neither passes.
pub(crate) fn lies_across(v: &View<'_>, p: &Vec3) -> bool {
    if v.segment.features.pixel_count < LYING_MIN_PIXELS {
        return false;
    }
    let (l_min, l_max, e) = principal_axes(v.segment.features.covariance);
    if l_max.is_nan() || l_max <= ELONGATED * l_min.max(0.0) {
        return false;
    }
    cos_to_vertical(v.camera, p, e).is_some_and(|c| c < VERTICAL_SLACK.cos())
}

/// The principal axes of a silhouette's image covariance (px²): its least and largest eigenvalues
/// and the unit major eigenvector.
pub fn principal_axes(cov: [[f64; 2]; 2]) -> (f64, f64, [f64; 2]) {
    let [[a, b], [_, d]] = cov;
    let disc = (0.25 * (a - d) * (a - d) + b * b).sqrt();
    let (l_min, l_max) = (0.5 * (a + d) - disc, 0.5 * (a + d) + disc);
    let e = if b.abs() > 1e-12 {
        [b, l_max - a]
    } else if a >= d {
        [1.0, 0.0]
    } else {
        [0.0, 1.0]
    };
    let n = e[0].hypot(e[1]);
    (l_min, l_max, [e[0] / n, e[1] / n])
}

/// |cos| of the angle between the image direction `e` (unit) and the image, in `cam`, of the
/// vertical through `p` (0 where that image is a point); `None` if `p` does not project.
pub fn cos_to_vertical(cam: &Camera, p: &Vec3, e: [f64; 2]) -> Option<f64> {
    let (u0, v0) = cam.project_unbounded(p)?;
    let (u1, v1) = cam.project_unbounded(&(p + Vec3::new(0.0, 0.0, 0.05)))?;
    let up = (u1 - u0).hypot(v1 - v0);
    Some(if up > 1e-9 {
        (e[0] * (u1 - u0) + e[1] * (v1 - v0)).abs() / up
    } else {
        0.0
    })
}

/// Whether the support-plane estimate `p` (a lying thing of radius `r`) is where the things' bottom
/// edges say it rests, while the triangulated point disagrees only along the line of sight, by at
/// most [`SupportPlane::lying_disparity_px`] of centroid disparity.
///
/// The centroid disparity of a lying thing is the least reliable datum it offers: its axis runs
/// across the image, and a part segmented in one camera and not the other (a white cap against the
/// table, a cut end) moves one centroid along the axis, which is near the epipolar direction. At
/// the table's far corners one pixel of disparity is 5–6 cm of range at 160 × 120: a lying spice
/// jar (development seed 6, execute scene 13) triangulated 8.3 cm short of where its two centroid
/// rays meet the plane of its measured radius, 0.4 cm from the truth. Its depth is then checked
/// against a cue that needs no disparity: the lowest silhouette pixel of each image column, cast
/// onto the table's plane, lies on the near side of a thing resting there, within about its radius
/// of its axis ([`bottom_agrees`]), in both cameras.
fn lying_depth_agrees(
    views: &[View<'_>; 2],
    p: &Vec3,
    r: f64,
    triangulated: &Vec3,
    plane: &SupportPlane,
    offsets: &mut Vec<f64>,
) -> bool {
    let (cl, cr) = (views[0].camera.position(), views[1].camera.position());
    let eye = 0.5 * (cl + cr);
    let sight = triangulated - eye;
    let range = sight.norm();
    let baseline = (cl - cr).norm();
    let f = 0.25 * (views[0].camera.fx + views[0].camera.fy + views[1].camera.fx + views[1].camera.fy);
    if !(range > 1e-6 && baseline > 1e-6) {
        return false;
    }
    let s = sight / range;
    let d = p - triangulated;
    let along = d.dot(&s);
    let across = (d - along * s).norm();
    // Range error per pixel of disparity: range² / (f · baseline).
    let along_px = along.abs() * f * baseline / (range * range);
    let bottoms = [0, 1].map(|k| bottom_agrees(&views[k], p, r, plane.height, offsets));
    tracing::trace!(
        "lying: {along_px:.2} px of disparity along the line of sight, {across:.3} m across; bottom edges agree {bottoms:?}"
    );
    across <= plane.max_disagreement && along_px <= plane.lying_disparity_px && bottoms.iter().all(|b| *b)
}

/// Whether a segment's bottom edge puts a thing of radius `r` resting on the plane at `table` where
/// `p` says: the median over its image columns of the lowest pixel's lower edge, cast onto the plane,
/// lies before `p` along the camera's horizontal line of sight by no more than [`BOTTOM_SLACK`] × `r`
/// (a cylinder's or sphere's lowest silhouette ray grazes its near side and meets the table between
/// its contact line and about `r` nearer the camera), nor beyond it by more than [`BOTTOM_BEYOND`].
fn bottom_agrees(view: &View<'_>, p: &Vec3, r: f64, table: f64, offsets: &mut Vec<f64>) -> bool {
    let (img, cam) = (view.image, view.camera);
    let (w, h) = (img.width as i64, img.height as i64);
    let inside =
        |u: i64, v: i64| u >= 0 && v >= 0 && u < w && v < h && view.components[(v * w + u) as usize] == view.id;
    let c = cam.position();
    let (sx, sy) = (p.x - c.x, p.y - c.y);
    let n = sx.hypot(sy);
    if n <= 1e-9 {
        return false;
    }
    let [u0, v0, u1, v1] = view.segment.bbox;
    offsets.clear();
    for u in u0 as i64..=u1 as i64 {
        let Some(vb) = (v0 as i64..=v1 as i64).rev().find(|&v| inside(u, v)) else {
            continue;
        };
        let (o, d) = cam.ray(u as f64, vb as f64 + 0.5);
        if let Some(b) = ray_at_height(&o, &d, table) {
            offsets.push(((b.x - p.x) * sx + (b.y - p.y) * sy) / n);
        }
    }
    if offsets.is_empty() {
        return false;
    }
    let mid = offsets.len() / 2;
    let median = *offsets.select_nth_unstable_by(mid, f64::total_cmp).1;
    median >= -(BOTTOM_SLACK * r + BOTTOM_BEYOND) && median <= BOTTOM_BEYOND
}

/// See [`bottom_agrees`]: how many radii before a lying thing's centre its cast bottom edge may lie.
const BOTTOM_SLACK: f64 = 1.5;

/// See [`bottom_agrees`] (m): pixel quantisation of the bottom edge, about a pixel at table range.
const BOTTOM_BEYOND: f64 = 0.012;

/// Silhouettes whose covariance eigenvalues differ by more than this factor are elongated (a
/// sphere's, stretched by 1/cos θ off-axis, stay below 1.4 in the field of view of 60°).
const ELONGATED: f64 = 1.6;

/// Least silhouette (px) whose elongation and axis [`lies_across`] reads: a blob of 20 px beside a
/// lying spice jar (4 × 5 px) passed for a thing lying across, and a phantom row with it
/// (development seed 4, execute scene 23); the lying things traced at the far corners showed 59–94.
const LYING_MIN_PIXELS: usize = 40;

/// An elongated silhouette whose major axis lies within this angle (rad) of the image of the
/// vertical may be a thing standing up ([`lies_across`], and the grasp planner's lying footprint).
pub const VERTICAL_SLACK: f64 = 0.35;

/// Cells along the longer side of the window searched for a prism's footprint.
const FOOTPRINT_CELLS: f64 = 64.0;

/// The centroid (x, y) of the footprint of the largest upright prism of height `h` on the plane at
/// `table` consistent with the silhouettes: the cells whose bottom and top points project into the
/// segment in every view. For a convex prism the bottom points alone are its footprint plus the
/// shadow behind it and the top points its footprint plus the band in front of it, so their
/// intersection is the footprint. The window is where the segments' bounding boxes back-project
/// at both heights. `None` if fewer than 4 cells qualify.
fn footprint_cells(views: &[View<'_>; 2], table: f64, h: f64) -> Option<Footprint> {
    let mut lo = [f64::NEG_INFINITY; 2];
    let mut hi = [f64::INFINITY; 2];
    for v in views {
        let [u0, v0, u1, v1] = v.segment.bbox;
        let (mut vlo, mut vhi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for (u, vv) in [(u0, v0), (u1, v0), (u0, v1), (u1, v1)] {
            let (o, d) = v.camera.ray(
                u as f64 + if u == u0 { -0.5 } else { 0.5 },
                vv as f64 + if vv == v0 { -0.5 } else { 0.5 },
            );
            for z in [table, table + h] {
                let p = ray_at_height(&o, &d, z)?;
                for k in 0..2 {
                    vlo[k] = vlo[k].min(p[k]);
                    vhi[k] = vhi[k].max(p[k]);
                }
            }
        }
        for k in 0..2 {
            lo[k] = lo[k].max(vlo[k]);
            hi[k] = hi[k].min(vhi[k]);
        }
    }
    let extent = (hi[0] - lo[0]).max(hi[1] - lo[1]);
    if !(extent.is_finite() && extent > 0.0 && extent < 2.0) {
        return None;
    }
    let cell = extent / FOOTPRINT_CELLS;
    let (nx, ny) = (
        ((hi[0] - lo[0]) / cell).ceil() as usize,
        ((hi[1] - lo[1]) / cell).ceil() as usize,
    );
    let proj = [Projection::of(views[0].camera), Projection::of(views[1].camera)];
    let in_view = |k: usize, p: &Vec3| -> bool {
        let v = &views[k];
        let Some((u, vv)) = proj[k].project(p) else {
            return false;
        };
        let (u, vv) = (u.round(), vv.round());
        let (w, hh) = (v.image.width as f64, v.image.height as f64);
        if !(u >= 0.0 && vv >= 0.0 && u < w && vv < hh) {
            return false;
        }
        v.components[vv as usize * v.image.width as usize + u as usize] == v.id
    };
    let (mut sx, mut sy, mut sxx, mut sxy, mut syy, mut count) = (0.0, 0.0, 0.0, 0.0, 0.0, 0usize);
    for i in 0..nx {
        for j in 0..ny {
            let x = lo[0] + (i as f64 + 0.5) * cell;
            let y = lo[1] + (j as f64 + 0.5) * cell;
            let (b, t) = (Vec3::new(x, y, table), Vec3::new(x, y, table + h));
            if in_view(0, &b) && in_view(1, &b) && in_view(0, &t) && in_view(1, &t) {
                sx += x;
                sy += y;
                sxx += x * x;
                sxy += x * y;
                syy += y * y;
                count += 1;
            }
        }
    }
    if count < 4 {
        return None;
    }
    let n = count as f64;
    let (mx, my) = (sx / n, sy / n);
    let (cxx, cxy, cyy) = (sxx / n - mx * mx, sxy / n - mx * my, syy / n - my * my);
    // Principal axes of the cell cloud; a uniform rectangle of half extent a has variance a²/3
    // along its axis, plus the cell's own a²/12 quantisation.
    let tr = 0.5 * (cxx + cyy);
    let det = (0.25 * (cxx - cyy).powi(2) + cxy * cxy).sqrt();
    let (l1, l2) = (tr + det, (tr - det).max(0.0));
    let angle = 0.5 * (2.0 * cxy).atan2(cxx - cyy);
    let half = |var: f64| (3.0 * (var - cell * cell / 12.0).max(0.0)).sqrt().max(0.5 * cell);
    Some(Footprint {
        center: [mx, my],
        major_axis: [angle.cos(), angle.sin()],
        half_major: half(l1),
        half_minor: half(l2),
    })
}

/// A camera's 3×4 projection matrix `K [Rᵀ | −Rᵀ t]`: pixel coordinates of world points in a few
/// multiply-adds (the footprint search projects thousands of points per object).
#[derive(Debug, Clone, Copy)]
struct Projection([[f64; 4]; 3]);

impl Projection {
    fn of(cam: &Camera) -> Self {
        let r = cam.world_from_optical.rotation.to_rotation_matrix();
        let rt = r.matrix().transpose();
        let t = -(rt * cam.world_from_optical.translation.vector);
        let k = [[cam.fx, 0.0, cam.cx], [0.0, cam.fy, cam.cy], [0.0, 0.0, 1.0]];
        let mut m = [[0.0; 4]; 3];
        for (i, row) in m.iter_mut().enumerate() {
            for (j, x) in row.iter_mut().enumerate() {
                *x = (0..3).map(|l| k[i][l] * if j < 3 { rt[(l, j)] } else { t[l] }).sum();
            }
        }
        Projection(m)
    }

    /// `(u, v)` of a point in front of the camera.
    fn project(&self, p: &Vec3) -> Option<(f64, f64)> {
        let m = &self.0;
        let row = |r: &[f64; 4]| r[0] * p.x + r[1] * p.y + r[2] * p.z + r[3];
        let z = row(&m[2]);
        (z > 1e-9).then(|| (row(&m[0]) / z, row(&m[1]) / z))
    }
}

impl SupportPlane {
    /// Whether the colour `below` (the mean of `n` pixels) just under a step is the colour
    /// `above` it darkened by shading: `below ≈ ratio · above` with `ratio` in
    /// [`SupportPlane::side_ratio`], within [`SupportPlane::shading_tolerance`] of its norm plus
    /// [`SupportPlane::uniform_sigmas`] noise standard deviations of the mean.
    fn is_shading_step(&self, above: &[f64; 3], below: &[f64; 3], n: f64) -> bool {
        let a2 = (0..3).map(|k| above[k] * above[k]).sum::<f64>();
        let ratio = (0..3).map(|k| below[k] * above[k]).sum::<f64>() / a2;
        let off = rgb_dist(below, &above.map(|x| x * ratio));
        (self.side_ratio[0]..=self.side_ratio[1]).contains(&ratio)
            && off
                <= self.shading_tolerance * rgb_dist(below, &[0.0; 3])
                    + self.uniform_sigmas * self.pixel_noise / n.sqrt()
    }

    /// The smallest step (RGB distance) that is significant between full windows.
    fn min_step(&self) -> f64 {
        self.step_sigmas * self.pixel_noise * (2.0 / self.step_window.max(1) as f64).sqrt()
    }
}

fn rgb_dist(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// The point of the ray `o + t·d` (t > 0) at height `z`.
fn ray_at_height(o: &Vec3, d: &Vec3, z: f64) -> Option<Vec3> {
    let t = (z - o.z) / d.z;
    (t.is_finite() && t > 0.0).then(|| o + d * t)
}

/// The radius of a sphere resting on the plane at `table` whose silhouettes are `views`: the mean
/// over the cameras of `D sin α`, α from the segment area and its off-axis angle θ, `D` the distance
/// to where the centroid ray meets the plane `table + r` (three fixed-point iterations from the
/// triangulated point).
fn round_radius(views: &[View<'_>; 2], triangulated: &Vec3, table: f64) -> Option<f64> {
    let mut sum = 0.0;
    for v in views {
        let cam = v.camera;
        let c = v.segment.features.centroid;
        let (o, d) = cam.ray(c[0], c[1]);
        let cos_t = d.dot(&cam.axis()).clamp(1e-6, 1.0);
        let [[a, b], [_, c]] = v.segment.features.covariance;
        let disc = (0.25 * (a - c) * (a - c) + b * b).sqrt();
        let (l_min, l_max) = (0.5 * (a + c) - disc, 0.5 * (a + c) + disc);
        let alpha = if l_max > ELONGATED * l_min {
            // An elongated silhouette (a cylinder or capsule lying down): its width across is the
            // diameter; a band of width w has variance w²/12 across.
            (3.0 * l_min.max(0.0)).sqrt() / (0.5 * (cam.fx + cam.fy))
        } else {
            (v.segment.features.pixel_count as f64 * cos_t.powi(3) / (std::f64::consts::PI * cam.fx * cam.fy)).sqrt()
        }
        .min(1.5);
        let mut dist = (triangulated - o).norm();
        let mut r = dist * alpha.sin();
        for _ in 0..3 {
            let p = ray_at_height(&o, &d, table + r)?;
            dist = (p - o).norm();
            r = dist * alpha.sin();
        }
        sum += r;
    }
    let r = 0.5 * sum;
    (r.is_finite() && r > 0.0).then_some(r)
}

#[cfg(test)]
mod tests {
    use super::*;
    use control_basis::hardware::Intrinsics;

    /// A black lid's step (top 0.15, side 0.6 of it: 0.06 in RGB) with ±0.012 of noise: no pixel
    /// pair stands out, the windows do, and the step is put at the first side pixel, not at the
    /// white band's edge below; that edge is no shading step, the lid's is.
    #[test]
    fn dark_step_is_found_and_located() {
        let top = [0.085, 0.09, 0.1];
        let side = top.map(|x| 0.6 * x);
        let white = [0.55, 0.54, 0.53];
        let noise = [0.012, -0.012, 0.006, -0.006, 0.0, 0.012, -0.012];
        let col: Vec<[f64; 3]> = (0..12)
            .map(|i| {
                let base = if i < 5 {
                    top
                } else if i < 8 {
                    side
                } else {
                    white
                };
                let n = noise[i % noise.len()];
                [base[0] + n, base[1] - n, base[2] + n]
            })
            .collect();
        let plane = SupportPlane::at(0.75);
        assert!((1..5).all(|j| step_score(&col, j, 1, &plane) <= 1.0));
        assert_eq!(topmost_step(&col, &plane), Some(5));
        assert!(plane.is_shading_step(&top, &side, 1.0));
        assert!(!plane.is_shading_step(&side, &white, 1.0));
        // A bright step is found pixel by pixel, even with a thin band just below it.
        let red = [0.8, 0.12, 0.12];
        let col: Vec<[f64; 3]> = [red, red, red, red.map(|x| 0.6 * x), white, white, white].to_vec();
        assert_eq!(topmost_step(&col, &plane), Some(3));
    }

    #[test]
    fn projection_matrix_matches_camera() {
        let intrinsics = Intrinsics {
            width: 160,
            height: 120,
            hfov_deg: 60.0,
        };
        let pose = Camera::pose_looking_at(Vec3::new(0.05, 0.06, 1.5), Vec3::new(0.6, 0.0, 0.8)).unwrap();
        let cam = Camera::new(&intrinsics, pose).unwrap();
        let m = Projection::of(&cam);
        for p in [
            Vec3::new(0.6, 0.0, 0.8),
            Vec3::new(0.45, -0.2, 0.75),
            Vec3::new(0.8, 0.25, 0.9),
        ] {
            let (a, b) = (cam.project_unbounded(&p).unwrap(), m.project(&p).unwrap());
            assert!((a.0 - b.0).abs() < 1e-9 && (a.1 - b.1).abs() < 1e-9, "{a:?} {b:?}");
        }
        assert!(m.project(&Vec3::new(-1.0, 0.0, 1.5)).is_none());
    }
}
