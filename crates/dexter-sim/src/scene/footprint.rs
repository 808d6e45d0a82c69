//! The geometry of resting and of footprints: an object's orientation from roll, pitch and yaw,
//! how deep its lowest point lies, whether it rests stably, and the gap between two footprints
//! (projections on the table plane).

use control_basis::math::{Rot3, Vec3};

use crate::geometry::Shape;
use crate::geometry::support_half_extent;

/// Gap between an object's lowest point and the table top in its computed resting pose (m).
pub const REST_CLEARANCE: f64 = 0.001;

/// Rotation `Rz(yaw)·Ry(pitch)·Rx(roll)` from `[roll, pitch, yaw]` in degrees.
pub fn rot_from_rpy_deg(rpy_deg: [f64; 3]) -> Rot3 {
    Rot3::from_euler_angles(
        rpy_deg[0].to_radians(),
        rpy_deg[1].to_radians(),
        rpy_deg[2].to_radians(),
    )
}

/// How far below the object frame's origin the lowest point of `shape` lies when the object has
/// `orientation` (object → world): its support distance along world −z.
pub fn lowest_point_depth(shape: &Shape, orientation: &Rot3) -> f64 {
    support_half_extent(shape, &(orientation.inverse() * -Vec3::z()))
}

/// Whether `shape` resting on a horizontal plane with `orientation` is in stable or neutral
/// equilibrium: no small tilt (2°, any horizontal axis) lowers its centre, taken as the centre of
/// mass. A box on a face or an upright cylinder is stable, a lying cylinder neutral (it rolls), a
/// capsule on an end or a box on an edge unstable.
pub fn rests_stably(shape: &Shape, orientation: &Rot3) -> bool {
    let height = lowest_point_depth(shape, orientation);
    let tilt = 2f64.to_radians();
    (0..24).all(|k| {
        let a = f64::from(k) * std::f64::consts::TAU / 24.0;
        let axis = nalgebra::Unit::new_normalize(Vec3::new(a.cos(), a.sin(), 0.0));
        let tilted = Rot3::from_axis_angle(&axis, tilt) * orientation;
        lowest_point_depth(shape, &tilted) >= height - 1e-9
    })
}

/// A convex, centrally symmetric shape seen from above.
#[derive(Debug, Clone)]
pub(super) struct Footprint {
    pub(super) shape: Shape,
    pub(super) orientation: Rot3,
    pub(super) center: [f64; 2],
}

impl Footprint {
    /// Support distance of the projection along the horizontal unit direction `d`.
    fn half_width(&self, d: [f64; 2]) -> f64 {
        support_half_extent(&self.shape, &(self.orientation.inverse() * Vec3::new(d[0], d[1], 0.0)))
    }

    /// Axis-aligned bounds `[x_min, x_max, y_min, y_max]`.
    pub(super) fn rect(&self) -> [f64; 4] {
        let hx = self.half_width([1.0, 0.0]);
        let hy = self.half_width([0.0, 1.0]);
        [
            self.center[0] - hx,
            self.center[0] + hx,
            self.center[1] - hy,
            self.center[1] + hy,
        ]
    }

    /// Horizontal directions that separate polygonal projections exactly: the projected local axes
    /// and their normals.
    fn axes(&self) -> impl Iterator<Item = [f64; 2]> + '_ {
        [Vec3::x(), Vec3::y(), Vec3::z()].into_iter().flat_map(move |e| {
            let w = self.orientation * e;
            let n = w.x.hypot(w.y);
            let pair = if n > 1e-9 {
                Some([[w.x / n, w.y / n], [-w.y / n, w.x / n]])
            } else {
                None
            };
            pair.into_iter().flatten()
        })
    }
}

/// Distance between the projections of `a` and `b` on the table plane; negative (minus the
/// penetration depth) when they overlap. Exact for polygons and discs, within 1e-4 of the size
/// otherwise: the maximum over horizontal directions `d` of `|Δc·d| − h_a(d) − h_b(d)`, over
/// 360 sampled directions plus the centre line and the shapes' own axes.
pub(super) fn footprint_gap(a: &Footprint, b: &Footprint) -> f64 {
    let delta = [b.center[0] - a.center[0], b.center[1] - a.center[1]];
    let separation = |d: [f64; 2]| (delta[0] * d[0] + delta[1] * d[1]).abs() - a.half_width(d) - b.half_width(d);
    let samples = (0..360).map(|k| {
        let t = f64::from(k) * std::f64::consts::PI / 360.0;
        [t.cos(), t.sin()]
    });
    let n = delta[0].hypot(delta[1]);
    let centre_line = (n > 1e-12).then(|| [delta[0] / n, delta[1] / n]);
    samples
        .chain(centre_line)
        .chain(a.axes())
        .chain(b.axes())
        .map(separation)
        .fold(f64::NEG_INFINITY, f64::max)
}

pub(super) fn rect_within(inner: &[f64; 4], outer: &[f64; 4]) -> bool {
    const EPS: f64 = 1e-9;
    inner[0] >= outer[0] - EPS && inner[1] <= outer[1] + EPS && inner[2] >= outer[2] - EPS && inner[3] <= outer[3] + EPS
}

pub(super) fn rects_overlap(a: &[f64; 4], b: &[f64; 4]) -> bool {
    a[0] < b[1] && b[0] < a[1] && a[2] < b[3] && b[2] < a[3]
}

pub(super) fn show_rect(r: &[f64; 4]) -> String {
    format!("(x {:.3}..{:.3}, y {:.3}..{:.3})", r[0], r[1], r[2], r[3])
}
