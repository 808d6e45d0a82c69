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
//!   up the image of the vertical line through it, the first step in colour (Lambert shading
//!   differs between the side and the horizontal top face) is the top face's near edge, and its
//!   height above the bottom point is `h`. The median over the columns of both images is used.
//!   Accepted when most columns show a step and the region above the steps is uniform in colour
//!   (a flat face under a directional light); otherwise the object is taken as
//! * **Round** (spheres, or anything without a flat, uniformly lit top): a sphere of the segment's
//!   apparent radius resting on the table, centre at `table + r`; `r` from the segment area
//!   (an off-axis sphere images as an ellipse of area `π f² α² / cos³θ`, `α = asin(r / D)`).
//!
//! For a prism, x and y then come from its footprint rather than from the silhouette-centroid rays
//! (whose sideways bias reaches 5–13 mm for tall objects): the cells of the table whose bottom and
//! top points (at the measured height) project into both silhouettes.
//!
//! A top too dark for its shading step to stand out of the pixel noise (black lids: RGB norm below
//! `step_threshold / top_contrast`) gives no estimate: a dark top above a dark side band would
//! pass for a lower prism (a black-lidded mug measured 5 cm instead of 9.5 cm).
//!
//! The result is checked against the triangulated point: if they disagree by more than
//! [`SupportPlane::max_disagreement`] (the object is not on the table, lies in a bin, is held, is
//! partly hidden, …), the triangulated point is kept.

use crate::vision::camera::Camera;
use crate::vision::render::Image;
use crate::vision::segment::Segment;
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
    /// Smallest RGB distance (channels in [0, 1]) between neighbouring pixels that counts as the
    /// edge between a side and the top face.
    pub step_threshold: f64,
    /// Shading contrast assumed between the top face and the sides (share of the top's colour):
    /// a top darker than `step_threshold / top_contrast` (RGB norm) cannot show its edge, so its
    /// height is not measured and the triangulated point is kept.
    pub top_contrast: f64,
    /// Share of the walked image columns (both images) that must show a step for the prism model.
    pub min_step_share: f64,
    /// A top-face pixel is uniform when its RGB distance to the top face's mean colour is below this.
    pub uniform_tolerance: f64,
    /// Share of uniform top-face pixels required for the prism model.
    pub min_uniform_share: f64,
}

impl SupportPlane {
    /// The default settings for a plane at `height` (pixel noise σ ≈ 0.01).
    pub fn at(height: f64) -> Self {
        Self {
            height,
            max_disagreement: 0.02,
            disagreement_per_height: 0.4,
            step_threshold: 0.12,
            top_contrast: 0.3,
            min_step_share: 0.5,
            uniform_tolerance: 0.06,
            min_uniform_share: 0.9,
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
    heights: Vec<f64>,
    top: Vec<[f32; 3]>,
}

/// What one image says about the prism model.
#[derive(Debug, Clone, Copy, Default)]
struct ColumnStats {
    columns: usize,
    steps: usize,
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
    ) -> Option<(Vec3, CentroidSource)> {
        if views.iter().any(|v| v.segment.touches_border) || !triangulated.iter().all(|x| x.is_finite()) {
            return None;
        }
        self.heights.clear();
        self.top.clear();
        let mut stats = ColumnStats::default();
        for v in &views {
            let s = self.prism_columns(v, plane);
            stats.columns += s.columns;
            stats.steps += s.steps;
        }
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
        if let CentroidSource::Prism { height } = source
            && let Some(xy) = footprint_centroid(&views, plane.height, height)
        {
            p.x = xy[0];
            p.y = xy[1];
        }
        let tolerance = match source {
            CentroidSource::Prism { height } => plane.max_disagreement + plane.disagreement_per_height * height,
            _ => plane.max_disagreement,
        };
        ((p - triangulated).norm() <= tolerance).then_some((p, source))
    }

    /// `Some(Some(h))` if the prism model applies: most columns show a step, the top face above
    /// the steps is uniform, and there are at least three height samples; `Some(None)` if it does
    /// not; `None` if the top is too dark for its edge to be seen (no estimate at all: a dark top
    /// above a dark side band would pass for a lower prism).
    fn prism_height(&mut self, stats: &ColumnStats, plane: &SupportPlane) -> Option<Option<f64>> {
        if self.heights.len() < 3 || (stats.steps as f64) < plane.min_step_share * stats.columns as f64 {
            return Some(None);
        }
        let n = self.top.len() as f64;
        let mean = self.top.iter().fold([0.0f64; 3], |a, p| {
            [a[0] + p[0] as f64, a[1] + p[1] as f64, a[2] + p[2] as f64]
        });
        let mean = mean.map(|x| x / n);
        if rgb_dist(&mean, &[0.0; 3]) * plane.top_contrast < plane.step_threshold {
            return None;
        }
        let uniform = self
            .top
            .iter()
            .filter(|p| rgb_dist(&[p[0] as f64, p[1] as f64, p[2] as f64], &mean) < plane.uniform_tolerance)
            .count();
        if (uniform as f64) < plane.min_uniform_share * n {
            return Some(None);
        }
        self.heights.sort_unstable_by(f64::total_cmp);
        Some(Some(self.heights[self.heights.len() / 2]))
    }

    /// Walks the image of the vertical line over each bottom-edge point of `view`'s segment (all
    /// columns but the outermost), appending one height per column with a side/top step and the
    /// top-face pixels above the steps.
    fn prism_columns(&mut self, view: &View<'_>, plane: &SupportPlane) -> ColumnStats {
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
        let mut stats = ColumnStats::default();
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
            stats.columns += 1;
            let Some(ve) =
                (vt + 1..vb).find(|&v| rgb_dist(&rgb(u_at(v), v), &rgb(u_at(v - 1), v - 1)) > plane.step_threshold)
            else {
                continue;
            };
            stats.steps += 1;
            for v in vt..ve {
                let p = rgb(u_at(v), v);
                self.top.push([p[0] as f32, p[1] as f32, p[2] as f32]);
            }
            // The height over b whose image is the step (between rows ve − 1 and ve).
            let target = ve as f64 - 0.5;
            let (mut lo, mut hi) = (0.0, 0.4);
            for _ in 0..30 {
                let m = 0.5 * (lo + hi);
                match proj.project(&(b + Vec3::new(0.0, 0.0, m))) {
                    Some((_, vm)) if vm > target => lo = m,
                    _ => hi = m,
                }
            }
            self.heights.push(0.5 * (lo + hi));
        }
        stats
    }
}

/// Silhouettes whose covariance eigenvalues differ by more than this factor are elongated (a
/// sphere's, stretched by 1/cos θ off-axis, stay below 1.4 in the field of view of 60°).
const ELONGATED: f64 = 1.6;

/// Cells along the longer side of the window searched for a prism's footprint.
const FOOTPRINT_CELLS: f64 = 64.0;

/// The centroid (x, y) of the footprint of the largest upright prism of height `h` on the plane at
/// `table` consistent with the silhouettes: the cells whose bottom and top points project into the
/// segment in every view. For a convex prism the bottom points alone are its footprint plus the
/// shadow behind it and the top points its footprint plus the band in front of it, so their
/// intersection is the footprint. The window is where the segments' bounding boxes back-project
/// at both heights. `None` if fewer than 4 cells qualify.
fn footprint_centroid(views: &[View<'_>; 2], table: f64, h: f64) -> Option<[f64; 2]> {
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
    let (mut sx, mut sy, mut count) = (0.0, 0.0, 0usize);
    for i in 0..nx {
        for j in 0..ny {
            let x = lo[0] + (i as f64 + 0.5) * cell;
            let y = lo[1] + (j as f64 + 0.5) * cell;
            let (b, t) = (Vec3::new(x, y, table), Vec3::new(x, y, table + h));
            if in_view(0, &b) && in_view(1, &b) && in_view(0, &t) && in_view(1, &t) {
                sx += x;
                sy += y;
                count += 1;
            }
        }
    }
    (count >= 4).then(|| [sx / count as f64, sy / count as f64])
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
    use crate::scene::CameraSpec;

    #[test]
    fn projection_matrix_matches_camera() {
        let cam = Camera::look_at(
            &CameraSpec::default(),
            Vec3::new(0.05, 0.06, 1.5),
            Vec3::new(0.6, 0.0, 0.8),
        )
        .unwrap();
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
