//! The robot's self-mask from its own model: where its body covers each camera's image, from the
//! shapes of its URDF (`<visual>` primitives) at the **measured** joint angles — what a real robot
//! knows of itself, never the renderer's labels.
//!
//! Every primitive is replaced by a point set whose convex hull contains it (a box by its corners,
//! a cylinder by two circumscribed polygons, a sphere or a capsule's caps by a circumscribed
//! polyhedron), inflated by a margin for encoder noise and calibration error. The projection of a
//! convex body is the convex hull of its points' projections, so each primitive is filled as one
//! convex polygon; a primitive partly behind the camera is clipped at a near plane first (the
//! hull of its points in front and of the points where the segments between front and back
//! points cross the plane). A primitive that contains the camera centre (the camera's own housing)
//! is skipped, as the cameras look out of it. The filled mask is dilated by one pixel.
//!
//! The mask is the body's silhouette: pixels where an object stands in front of the robot are
//! masked too (the robot cannot tell from its model what is in front of it); the tracker treats
//! such pixels as hidden, not as empty.

use control_basis::Hardware;
use control_basis::hardware::Camera;
use control_basis::math::{Iso3, Vec3};
use control_basis::model::{RobotModel, VisualGeometry};
use nalgebra::Point3;

use crate::body::Body;
use crate::error::RobotError;

/// Near plane (m, optical z) at which primitives behind the camera are clipped.
const NEAR: f64 = 0.02;

/// The points of one link's primitives in the link frame.
#[derive(Debug)]
struct LinkShapes {
    name: String,
    /// Per primitive: its points (link frame) and its half extents box (in the primitive's frame,
    /// for the contains-the-camera test) with that frame.
    shapes: Vec<(Vec<Vec3>, Iso3, Vec3)>,
}

/// The robot's self-model for masking its own body out of camera images.
#[derive(Debug)]
pub struct SelfModel {
    links: Vec<LinkShapes>,
    body: Body,
    world: Vec<Vec3>,
    front: Vec<(f64, f64)>,
    hull: Vec<(f64, f64)>,
    filled: Vec<bool>,
    wide: Vec<bool>,
    margin: f64,
}

/// Points on a circle of radius `r` (circumscribed `n`-gon) at height `z` about the z axis.
fn ring(out: &mut Vec<Vec3>, r: f64, z: f64, n: usize) {
    let rc = r / (std::f64::consts::PI / n as f64).cos();
    for k in 0..n {
        let a = 2.0 * std::f64::consts::PI * k as f64 / n as f64;
        out.push(Vec3::new(rc * a.cos(), rc * a.sin(), z));
    }
}

/// Points whose hull contains the sphere of radius `r` centred at `(0, 0, z)`: rings of 12 at five
/// latitudes 30° apart and the poles, on a sphere 10 % larger (the hull's faces then clear the
/// sphere; the test checks it against the support function).
fn ball(out: &mut Vec<Vec3>, r: f64, z: f64) {
    let rc = 1.1 * r;
    for lat in [-60.0_f64, -30.0, 0.0, 30.0, 60.0] {
        let (s, c) = lat.to_radians().sin_cos();
        for k in 0..12 {
            let a = std::f64::consts::PI * k as f64 / 6.0;
            out.push(Vec3::new(rc * c * a.cos(), rc * c * a.sin(), z + rc * s));
        }
    }
    out.push(Vec3::new(0.0, 0.0, z + rc));
    out.push(Vec3::new(0.0, 0.0, z - rc));
}

impl SelfModel {
    /// The self-model of `hw`'s robot: every `<visual>` primitive of its URDF (meshes are skipped:
    /// the robot would need their files), inflated by `margin` (m).
    pub fn new(hw: &dyn Hardware, margin: f64) -> Result<Self, RobotError> {
        let model: &RobotModel = hw.model();
        let mut links: Vec<(usize, LinkShapes)> = Vec::new();
        for v in model.visuals() {
            let m = margin.max(0.0);
            let mut pts = Vec::new();
            let half = match v.geometry {
                VisualGeometry::Box { size } => {
                    let h = Vec3::new(size[0] / 2.0 + m, size[1] / 2.0 + m, size[2] / 2.0 + m);
                    for sx in [-1.0, 1.0] {
                        for sy in [-1.0, 1.0] {
                            for sz in [-1.0, 1.0] {
                                pts.push(Vec3::new(sx * h.x, sy * h.y, sz * h.z));
                            }
                        }
                    }
                    h
                }
                VisualGeometry::Cylinder { radius, length } => {
                    let (r, hl) = (radius + m, length / 2.0 + m);
                    ring(&mut pts, r, hl, 16);
                    ring(&mut pts, r, -hl, 16);
                    Vec3::new(r, r, hl)
                }
                VisualGeometry::Capsule { radius, length } => {
                    let r = radius + m;
                    ball(&mut pts, r, length / 2.0);
                    ball(&mut pts, r, -length / 2.0);
                    Vec3::new(r, r, length / 2.0 + r)
                }
                VisualGeometry::Sphere { radius } => {
                    let r = radius + m;
                    ball(&mut pts, r, 0.0);
                    Vec3::new(r, r, r)
                }
                VisualGeometry::Mesh { .. } => continue,
            };
            let pts: Vec<Vec3> = pts
                .iter()
                .map(|p| v.origin * Point3::from(*p))
                .map(|p| p.coords)
                .collect();
            let entry = match links.iter().position(|(l, _)| *l == v.link) {
                Some(k) => k,
                None => {
                    links.push((
                        v.link,
                        LinkShapes {
                            name: model.links[v.link].name.clone(),
                            shapes: Vec::new(),
                        },
                    ));
                    links.len() - 1
                }
            };
            links[entry].1.shapes.push((pts, v.origin, half));
        }
        Ok(SelfModel {
            links: links.into_iter().map(|(_, l)| l).collect(),
            body: Body::new(),
            world: Vec::new(),
            front: Vec::new(),
            hull: Vec::new(),
            filled: Vec::new(),
            wide: Vec::new(),
            margin,
        })
    }

    /// The inflation margin (m).
    pub fn margin(&self) -> f64 {
        self.margin
    }

    /// Writes the self-mask of `camera` (its pose from the same encoder readings) into `out`:
    /// `true` where the robot's body covers the pixel.
    pub fn mask(&mut self, hw: &dyn Hardware, camera: &Camera, out: &mut Vec<bool>) -> Result<(), RobotError> {
        let (w, h) = (camera.width as usize, camera.height as usize);
        self.filled.clear();
        self.filled.resize(w * h, false);
        let optical_from_world = camera.world_from_optical.inverse();
        for link in &self.links {
            let optical_from_link = optical_from_world * self.body.pose(hw, &link.name)?;
            for (pts, origin, half) in &link.shapes {
                // The camera inside this primitive (its own housing): the camera looks out of it.
                let c = (optical_from_link * origin).inverse_transform_point(&Point3::origin());
                if c.x.abs() <= half.x && c.y.abs() <= half.y && c.z.abs() <= half.z {
                    continue;
                }
                self.world.clear();
                self.world
                    .extend(pts.iter().map(|p| (optical_from_link * Point3::from(*p)).coords));
                project_clipped(&self.world, camera, &mut self.front);
                if self.front.len() < 3 {
                    continue;
                }
                convex_hull(&mut self.front, &mut self.hull);
                fill_convex(&self.hull, w, h, &mut self.filled);
            }
        }
        if w == 0 || h == 0 {
            out.clear();
            return Ok(());
        }
        // One pixel of dilation (3×3), separably: along the rows into `wide`, then down the columns.
        self.wide.clear();
        self.wide.resize(w * h, false);
        for (src, dst) in self.filled.chunks_exact(w).zip(self.wide.chunks_exact_mut(w)) {
            for u in 0..w {
                dst[u] = src[u.saturating_sub(1)] || src[u] || src[(u + 1).min(w - 1)];
            }
        }
        out.clear();
        out.resize(w * h, false);
        for v in 0..h {
            let (up, down) = (v.saturating_sub(1) * w, (v + 1).min(h - 1) * w);
            for u in 0..w {
                out[v * w + u] = self.wide[up + u] || self.wide[v * w + u] || self.wide[down + u];
            }
        }
        Ok(())
    }
}

/// Projects optical-frame points into pixel coordinates, clipping at the near plane: points in
/// front, and the crossings of the near plane by the segments between points in front and behind.
fn project_clipped(pts: &[Vec3], camera: &Camera, out: &mut Vec<(f64, f64)>) {
    out.clear();
    let proj = |p: &Vec3| (camera.fx * p.x / p.z + camera.cx, camera.fy * p.y / p.z + camera.cy);
    for p in pts {
        if p.z >= NEAR {
            out.push(proj(p));
        }
    }
    if out.len() == pts.len() || out.is_empty() {
        return;
    }
    for a in pts.iter().filter(|p| p.z >= NEAR) {
        for b in pts.iter().filter(|p| p.z < NEAR) {
            let t = (a.z - NEAR) / (a.z - b.z);
            out.push(proj(&(a + (b - a) * t)));
        }
    }
}

fn cross(o: (f64, f64), a: (f64, f64), b: (f64, f64)) -> f64 {
    (a.0 - o.0) * (b.1 - o.1) - (a.1 - o.1) * (b.0 - o.0)
}

/// Andrew's monotone chain: the convex hull of `pts` (sorted in place), counter-clockwise (in
/// image coordinates), into `hull`.
fn convex_hull(pts: &mut [(f64, f64)], hull: &mut Vec<(f64, f64)>) {
    // Unstable: equal keys are equal points, so the order is the stable one's (and nothing is
    // allocated, which the stable sort does beyond 20 points).
    pts.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    hull.clear();
    for &p in pts.iter() {
        while hull.len() >= 2 && cross(hull[hull.len() - 2], hull[hull.len() - 1], p) <= 0.0 {
            hull.pop();
        }
        hull.push(p);
    }
    let lower = hull.len() + 1;
    for &p in pts.iter().rev().skip(1) {
        while hull.len() >= lower && cross(hull[hull.len() - 2], hull[hull.len() - 1], p) <= 0.0 {
            hull.pop();
        }
        hull.push(p);
    }
    hull.pop();
}

/// Sets every pixel whose centre lies inside the convex polygon `hull`.
fn fill_convex(hull: &[(f64, f64)], w: usize, h: usize, mask: &mut [bool]) {
    if hull.len() < 3 {
        return;
    }
    let (mut vmin, mut vmax) = (f64::INFINITY, f64::NEG_INFINITY);
    for p in hull {
        vmin = vmin.min(p.1);
        vmax = vmax.max(p.1);
    }
    let v0 = vmin.ceil().max(0.0);
    let v1 = vmax.floor().min(h as f64 - 1.0);
    // NaN (a degenerate hull) or an empty row range: nothing to fill.
    if v0.is_nan() || v1.is_nan() || v0 > v1 {
        return;
    }
    for v in v0 as usize..=v1 as usize {
        let y = v as f64;
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for i in 0..hull.len() {
            let (a, b) = (hull[i], hull[(i + 1) % hull.len()]);
            if (a.1 <= y && b.1 >= y) || (b.1 <= y && a.1 >= y) {
                let x = if (b.1 - a.1).abs() < 1e-12 {
                    lo = lo.min(a.0.min(b.0));
                    hi = hi.max(a.0.max(b.0));
                    continue;
                } else {
                    a.0 + (y - a.1) * (b.0 - a.0) / (b.1 - a.1)
                };
                lo = lo.min(x);
                hi = hi.max(x);
            }
        }
        let u0 = lo.ceil().max(0.0);
        let u1 = hi.floor().min(w as f64 - 1.0);
        if u0.is_nan() || u1.is_nan() || u0 > u1 {
            continue;
        }
        for u in u0 as usize..=u1 as usize {
            mask[v * w + u] = true;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hull_of_a_square_with_inner_points() {
        let mut pts = vec![(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0), (0.5, 0.5), (0.2, 0.7)];
        let mut hull = Vec::new();
        convex_hull(&mut pts, &mut hull);
        assert_eq!(hull.len(), 4);
        let mut mask = vec![false; 9];
        fill_convex(&[(0.0, 0.0), (1.6, 0.0), (1.6, 1.6), (0.0, 1.6)], 3, 3, &mut mask);
        assert_eq!(mask, vec![true, true, false, true, true, false, false, false, false]);
    }

    #[test]
    fn circumscribed_points_contain_their_primitive() {
        let mut pts = Vec::new();
        ball(&mut pts, 0.1, 0.0);
        // Every direction: the support of the point set reaches at least the radius.
        for k in 0..200 {
            let a = k as f64 * 0.731;
            let b = k as f64 * 0.377;
            let d = Vec3::new(a.cos() * b.cos(), a.sin() * b.cos(), b.sin());
            let support = pts.iter().map(|p| p.dot(&d)).fold(f64::NEG_INFINITY, f64::max);
            assert!(support >= 0.1 - 1e-9, "direction {d:?}: {support}");
        }
        let mut ring_pts = Vec::new();
        ring(&mut ring_pts, 0.05, 0.0, 16);
        for k in 0..100 {
            let a = k as f64 * 0.0628;
            let d = Vec3::new(a.cos(), a.sin(), 0.0);
            let support = ring_pts.iter().map(|p| p.dot(&d)).fold(f64::NEG_INFINITY, f64::max);
            assert!(support >= 0.05 - 1e-9);
        }
    }

    #[test]
    fn a_segment_through_the_near_plane_is_clipped_there() {
        let intr = control_basis::hardware::Intrinsics {
            width: 100,
            height: 100,
            hfov_deg: 90.0,
        };
        let cam = Camera::new(&intr, Iso3::identity()).unwrap();
        let mut out = Vec::new();
        project_clipped(&[Vec3::new(0.1, 0.0, 1.0), Vec3::new(0.1, 0.0, -1.0)], &cam, &mut out);
        assert_eq!(out.len(), 2);
        // The crossing is at z = NEAR, x = 0.1: far to the right, beyond the image.
        assert!(out[1].0 > 100.0);
    }
}
