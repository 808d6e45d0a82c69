//! Grasps planned from the seen object (§6.2.1): its measured extent ([`SeenObject`],
//! [`extent_of`], [`lying_footprint`]) and the top grasp across the axis the hand can span, clear of
//! what stands near it ([`plan_top_grasp_among`]).

use control_basis::Chain;
use control_basis::math::{Iso3, Vec3};
use nalgebra::Translation3;

use super::*;
use crate::arm::Arm;
use crate::control::{FLEX_CLOSED, top_down_orientation};
use crate::error::RobotError;

/// A top-down grasp for an object: where the palm surface goes and how the fingers close.
#[derive(Debug, Clone, Copy)]
pub struct GraspPlan {
    /// Palm-surface pose at the grasp.
    pub grasp: Iso3,
    /// Flexion of the pre-shape (rad).
    pub preshape: f64,
    /// Object width across the fingers (m).
    pub width: f64,
    /// How far below `grasp` the descent may go on (m) when the object's height is uncertain (a
    /// coarse extent: a height from the triangulated centroid alone, which a blob that merges with
    /// something above it puts too high): the palm comes down until it rests on the object's top,
    /// a guarded move. 0: the measured height is trusted.
    pub guard: f64,
    /// Planned from a coarse extent (a height from the triangulated centroid alone, wrong either
    /// way): a palm that stops over the object rests on its top ([`crate::skills::approach_grasp`]).
    pub coarse: bool,
}

/// An object as the robot sees it on the table: centroid, height and footprint (§6.2.1), from the
/// support-plane measurement when it applies, else from the silhouette's size.
#[derive(Debug, Clone, PartialEq)]
pub struct SeenObject {
    /// Centroid (m, world).
    pub centroid: Vec3,
    /// Extent (height, footprint).
    pub extent: schema::SeenExtent,
}

impl SeenObject {
    /// What a stereo blob says about a resting object on the table at `table_z`; `None` if it was
    /// not triangulated.
    pub fn from_blob(blob: &StereoBlob, cams: &StereoCameras, table_z: f64) -> Option<SeenObject> {
        let c = blob.centroid?;
        Some(SeenObject {
            centroid: c,
            extent: extent_of(blob, cams, table_z)?,
        })
    }

    /// From a tracked segment's percept (its extent, or a coarse one from its height above the
    /// table).
    pub fn from_percept(s: &schema::SegmentPercept, table_z: f64) -> SeenObject {
        let centroid = Vec3::from(s.centroid);
        let extent = s.extent.clone().unwrap_or_else(|| {
            let h = (2.0 * (centroid.z - table_z)).clamp(0.02, 0.4);
            schema::SeenExtent {
                height: h,
                center: [centroid.x, centroid.y],
                major_axis: [1.0, 0.0],
                half_major: 0.04,
                half_minor: 0.04,
                model: "coarse".into(),
            }
        });
        SeenObject { centroid, extent }
    }

    /// Top of the object (m, world).
    pub fn top(&self, table_z: f64) -> f64 {
        table_z + self.extent.height
    }

    /// Horizontal radius of the footprint (m): a sphere's radius, else the circle around the
    /// footprint's bounding box.
    pub fn radius(&self) -> f64 {
        if self.extent.model == "round" {
            self.extent.half_major
        } else {
            self.extent.half_major.hypot(self.extent.half_minor)
        }
    }
}

/// The measured extent of a blob: prism or sphere from the support-plane estimate (a round
/// cross-section whose silhouettes are elongated in both cameras is an object lying on its side:
/// [`lying_footprint`], model `lying`), else a coarse disc from the silhouette area at the
/// triangulated range and a height from the centroid.
pub fn extent_of(blob: &StereoBlob, cams: &StereoCameras, table_z: f64) -> Option<schema::SeenExtent> {
    use crate::vision::CentroidSource;
    let c = blob.centroid?;
    let mut footprint = blob.footprint;
    let (height, model) = match blob.source {
        CentroidSource::Prism { height } => (height, "prism"),
        CentroidSource::Round { radius } => {
            let views = [(&blob.left, &cams.left), (&blob.right, &cams.right)]
                .map(|(s, cam)| s.as_ref().map(|s| (s.features.centroid, s.features.covariance, cam)));
            match views {
                [Some(l), Some(r)] => match lying_footprint([l, r], &c, radius) {
                    Some(f) => {
                        footprint = Some(f);
                        (2.0 * radius, if f.half_major > radius { "lying" } else { "round" })
                    }
                    None => (2.0 * radius, "round"),
                },
                _ => (2.0 * radius, "round"),
            }
        }
        CentroidSource::Standing {
            height, whole: false, ..
        } => (height, "standing"),
        CentroidSource::Standing {
            height, whole: true, ..
        } => (height, "standing_whole"),
        CentroidSource::Triangulated => ((2.0 * (c.z - table_z)).clamp(0.02, 0.4), "coarse"),
    };
    let f = match footprint {
        Some(f) => f,
        None => {
            let mut r = 0.0;
            let mut n = 0.0;
            for (seg, cam) in [(&blob.left, &cams.left), (&blob.right, &cams.right)] {
                if let Some(s) = seg {
                    let range = (c - cam.position()).dot(&cam.axis()).max(0.05);
                    r += (s.features.pixel_count as f64 / std::f64::consts::PI).sqrt() * cam.metres_per_pixel(range);
                    n += 1.0;
                }
            }
            crate::vision::Footprint::disc([c.x, c.y], if n > 0.0 { r / n } else { 0.04 })
        }
    };
    Some(schema::SeenExtent {
        height,
        center: f.center,
        major_axis: f.major_axis,
        half_major: f.half_major,
        half_minor: f.half_minor,
        model: model.into(),
    })
}

/// Silhouettes whose image covariance has eigenvalues further apart than this factor in both
/// cameras are elongated: a sphere's, stretched by 1/cos θ off-axis, stay below 1.4 in the head's
/// field of view (the vision's own test, `vision::support`, uses the same factor for the radius).
pub(super) const LYING_ELONGATION: f64 = 1.6;

/// An elongated silhouette whose major axis lies within this angle (rad) of the image of the
/// vertical may be an object standing up ([`lying_footprint`]; the vision's lying test uses the same).
pub(super) const VERTICAL_SLACK: f64 = crate::vision::support::VERTICAL_SLACK;

/// One camera's view of a segment for [`lying_footprint`]: its image centroid (px), its
/// covariance (px²) and the camera.
pub type SilhouetteView<'a> = ([f64; 2], [[f64; 2]; 2], &'a control_basis::hardware::Camera);

/// The footprint of an object with a round cross-section of `radius` seen at `centroid` (what the
/// support-plane estimate measured as "round"), from its two silhouettes (image centroid, covariance
/// in px², camera). `None` when either silhouette is not elongated ([`LYING_ELONGATION`]): a sphere,
/// whose footprint is the disc of its radius.
///
/// An elongated silhouette whose major axis does not run along the image of the vertical is an
/// object lying on its side, its axis at the centroid's height: each silhouette's major axis, a band
/// of variance L²/12 along it, is cast through its ends onto that horizontal plane, and the two
/// cameras' axes and lengths are averaged. One that runs along the image of the vertical (within
/// [`VERTICAL_SLACK`], in either camera) is either a round-topped object standing up or one lying
/// along the line of sight (foreshortened): the disc of `radius` with its major axis along the line
/// of sight, so that a grasp closes across it (ties go across the major axis, [`plan_top_grasp`]) —
/// right for both.
///
/// The support-plane estimate fits a lying bottle as a sphere of the bottle's radius; its disc
/// footprint hid the bottle's length from the grasp planner, whose fingers then closed along it
/// and stopped on the bottle (a knocked-over soy-sauce bottle, fault scene bump 28).
pub fn lying_footprint(
    views: [SilhouetteView<'_>; 2],
    centroid: &Vec3,
    radius: f64,
) -> Option<crate::vision::Footprint> {
    let mut first: Option<[f64; 2]> = None;
    let mut axis = [0.0; 2];
    let mut half = 0.0;
    let mut upright = false;
    let mut sight = Vec3::zeros();
    for (uv, cov, cam) in views {
        sight += centroid - cam.position();
        let (l_min, l_max, e) = crate::vision::support::principal_axes(cov);
        if l_max.is_nan() || l_max <= LYING_ELONGATION * l_min.max(0.0) {
            return None;
        }
        // Along the image of the vertical through the centroid?
        if crate::vision::support::cos_to_vertical(cam, centroid, e)? > VERTICAL_SLACK.cos() {
            upright = true;
        }
        let h = (3.0 * l_max).sqrt();
        let on_plane = |k: f64| -> Option<Vec3> {
            let (o, dir) = cam.ray(uv[0] + k * h * e[0], uv[1] + k * h * e[1]);
            if dir.z.abs() < 1e-6 {
                return None;
            }
            let t = (centroid.z - o.z) / dir.z;
            (t > 0.0 && t.is_finite()).then(|| o + t * dir)
        };
        let w = on_plane(1.0)? - on_plane(-1.0)?;
        let len = w.xy().norm();
        if len.is_nan() || len <= 1e-6 {
            return None;
        }
        let mut ax = [w.x / len, w.y / len];
        match first {
            Some(f) if f[0] * ax[0] + f[1] * ax[1] < 0.0 => ax = [-ax[0], -ax[1]],
            Some(_) => {}
            None => first = Some(ax),
        }
        axis[0] += ax[0];
        axis[1] += ax[1];
        half += 0.25 * len;
    }
    if upright {
        let n = sight.xy().norm();
        return (n > 1e-9).then(|| crate::vision::Footprint {
            center: [centroid.x, centroid.y],
            major_axis: [sight.x / n, sight.y / n],
            half_major: radius,
            half_minor: radius,
        });
    }
    let n = axis[0].hypot(axis[1]);
    if n.is_nan() || n <= 1e-9 {
        return None;
    }
    Some(crate::vision::Footprint {
        center: [centroid.x, centroid.y],
        major_axis: [axis[0] / n, axis[1] / n],
        half_major: half.max(radius),
        half_minor: radius,
    })
}

/// Fingertip geometry of the BarrettHand, sampled along the flexion arc of finger 3 in the palm
/// surface frame: (flexion, lateral distance of the tip centre from the palm axis, depth below the
/// palm surface).
pub fn finger_arc(model: &control_basis::RobotModel, arm: Arm) -> Result<Vec<(f64, f64, f64)>, RobotError> {
    let p = arm.prefix();
    let chain = Chain::new(
        model,
        &format!("{p}/bhand/palm_surface_link"),
        &format!("{p}/bhand/finger_3/tip_link"),
    )?;
    let mut state = chain.new_state();
    let mut out = Vec::new();
    for k in 0..=100 {
        let m = FLEX_CLOSED * k as f64 / 100.0;
        state.set_q(&chain, &[m])?;
        control_basis::forward_kinematics(&chain, &mut state);
        let t = state.tip_pose().translation.vector;
        out.push((m, t.y, t.z));
    }
    Ok(out)
}

/// Plans a top-down grasp of an object of horizontal half extent `half_along(d)` along unit
/// direction `d`, standing at (`center`) from `bottom` to `top` on a table at `table_z`, for a hand
/// currently at orientation `current`: the fingers close across the narrowest direction, contact at
/// mid-height, the palm above the object and the sweeping tips above the table.
#[allow(clippy::too_many_arguments)]
pub fn plan_top_grasp_geometry(
    arc: &[(f64, f64, f64)],
    half_along: &dyn Fn(Vec3) -> f64,
    center: [f64; 2],
    bottom: f64,
    top: f64,
    table_z: f64,
    current: &Iso3,
) -> GraspPlan {
    plan_top_grasp_clear_of(arc, half_along, center, bottom, top, table_z, current, None)
}

/// Directions whose half width is within this (m) of the narrowest are equally good to close
/// across ([`plan_top_grasp_clear_of`]): a cube's two sides, any direction of a can.
pub(super) const AXIS_TIE: f64 = 0.003;

/// How far (m) apart, across the closing direction, the BarrettHand's two side-by-side fingertips
/// (F1, F2) stand in a pre-shape: about 5 cm.
pub(super) const FINGER_PAIR_HALF_SPACING: f64 = 0.025;

/// Room the pre-shaped fingertips need around the points [`plan_top_grasp_clear_of`] models
/// before a grasp turns away from the first narrowest closing direction (m): the tip sphere's
/// centre is not the finger's widest point, and a hand near its body comes down a little tilted.
/// Development (`any_schema`, the blue block of `sorting-new`, 10 cm from bin-left's wall): the
/// modelled tips kept 3 cm from the wall, and finger 2's distal link landed on the wall's top.
pub const GRASP_FINGER_ROOM: f64 = 0.04;

/// What is around an object for [`plan_top_grasp_clear_of`]: `free(p)` the free distance (m)
/// around table point `p`; a direction other than the first narrowest is chosen only when the
/// latter's fingertips keep less than `enough` (m) from everything (`f64::INFINITY`: always the
/// roomiest).
#[derive(Clone, Copy)]
pub struct FingerRoom<'a> {
    /// Free distance (m) around a table point.
    pub free: &'a dyn Fn([f64; 2]) -> f64,
    /// Room (m) that is enough.
    pub enough: f64,
}

impl std::fmt::Debug for FingerRoom<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FingerRoom")
            .field("enough", &self.enough)
            .finish_non_exhaustive()
    }
}

/// [`plan_top_grasp_geometry`], choosing among equally narrow closing directions the one whose
/// pre-shaped fingertips keep farthest from everything else ([`FingerRoom`]; `None`: the first
/// narrowest). A touch on a block 10 cm from a bin's wall had a fingertip land on the wall's top
/// (development: `any_schema`, Reach-And-Touch in `sorting-new`); turned 90°, the fingers fall
/// clear on both sides.
#[allow(clippy::too_many_arguments)]
pub fn plan_top_grasp_clear_of(
    arc: &[(f64, f64, f64)],
    half_along: &dyn Fn(Vec3) -> f64,
    center: [f64; 2],
    bottom: f64,
    top: f64,
    table_z: f64,
    current: &Iso3,
    room: Option<FingerRoom<'_>>,
) -> GraspPlan {
    const TIP_RADIUS: f64 = 0.01;
    // The narrower horizontal axis: test a few directions in the object's footprint.
    let widths: [(f64, Vec3); 36] = std::array::from_fn(|k| {
        let a = std::f64::consts::PI * k as f64 / 36.0;
        let d = Vec3::new(a.cos(), a.sin(), 0.0);
        (half_along(d), d)
    });
    let mut best = (f64::INFINITY, Vec3::x());
    for &(w, d) in &widths {
        if w < best.0 - 1e-9 {
            best = (w, d);
        }
    }
    if let Some(room) = room {
        // Where the pre-shaped fingertips come down, on either side (the hand may turn 180°).
        let clearance = |w: f64, d: Vec3| {
            let lateral = w + TIP_RADIUS + 0.025;
            let n = [-d.y, d.x];
            let mut least = f64::INFINITY;
            for side in [-1.0, 1.0] {
                for pair in [-1.0, 0.0, 1.0] {
                    let p = [
                        center[0] + side * lateral * d.x + pair * FINGER_PAIR_HALF_SPACING * n[0],
                        center[1] + side * lateral * d.y + pair * FINGER_PAIR_HALF_SPACING * n[1],
                    ];
                    least = least.min((room.free)(p));
                }
            }
            least
        };
        let mut chosen = (clearance(best.0, best.1), best);
        if chosen.0 < room.enough {
            for &(w, d) in &widths {
                if w <= best.0 + AXIS_TIE {
                    let c = clearance(w, d);
                    if c > chosen.0 + 1e-9 {
                        chosen = (c, (w, d));
                    }
                }
            }
        }
        best = chosen.1;
    }
    let (half_width, axis) = best;
    let height = top - bottom;
    // Depth below the palm at which the tip first comes within the object's half width.
    let target_lateral = half_width + TIP_RADIUS - 0.004; // a little squeeze
    let max_depth = arc.iter().map(|a| a.2).fold(f64::NEG_INFINITY, f64::max) + TIP_RADIUS;
    let contact_depth = arc
        .iter()
        .find(|a| a.1 <= target_lateral)
        .map(|a| a.2)
        .unwrap_or(max_depth - TIP_RADIUS);
    // Contact at mid-height, but keep the palm above the object and the sweeping tips above the table.
    let mid = bottom + 0.5 * height;
    let mut palm_z = (mid + contact_depth).max(top + 0.008);
    palm_z = palm_z.max(table_z + max_depth + 0.004);
    // Pre-shape: open enough to clear the object by 2.5 cm on each side.
    let clear = half_width + TIP_RADIUS + 0.025;
    let preshape = arc
        .iter()
        .rev()
        .find(|a| a.1 >= clear)
        .map(|a| a.0)
        .unwrap_or(0.0)
        .min(0.9);
    let rot = top_down_orientation(&axis, &current.rotation);
    let grasp = Iso3::from_parts(Translation3::new(center[0], center[1], palm_z), rot);
    GraspPlan {
        grasp,
        preshape,
        width: 2.0 * half_width,
        guard: 0.0,
        coarse: false,
    }
}

/// A negligible extent (m) added along the footprint's major axis when choosing the closing
/// direction: ties between equally narrow directions go across the major axis.
pub(super) const TIE_BIAS: f64 = 1e-6;

/// The share of a coarse height the guarded descent of [`plan_top_grasp`] may come down to: the
/// palm's goal is planned for an object this much of the measured height (a centroid 4 cm too high
/// doubles a 10 cm can's coarse height; the palm then stops on the real top).
pub(super) const COARSE_HEIGHT_FLOOR: f64 = 0.4;

/// Plans a top-down grasp of a seen object resting on the table at `table_z` (its footprint's
/// principal axes and measured height; §6.2.1), for a hand at orientation `current`.
pub fn plan_top_grasp(arc: &[(f64, f64, f64)], seen: &SeenObject, table_z: f64, current: &Iso3) -> GraspPlan {
    plan_top_grasp_among(arc, seen, table_z, current, None)
}

/// [`plan_top_grasp`] with the fingers kept clear of what is around (`room`, as in
/// [`plan_top_grasp_clear_of`]).
pub fn plan_top_grasp_among(
    arc: &[(f64, f64, f64)],
    seen: &SeenObject,
    table_z: f64,
    current: &Iso3,
    room: Option<FingerRoom<'_>>,
) -> GraspPlan {
    let e = &seen.extent;
    // Among equally narrow directions (a disc), the fingers close across the major axis.
    let half =
        |d: Vec3| e.half_extent_along([d.x, d.y]) + TIE_BIAS * (d.x * e.major_axis[0] + d.y * e.major_axis[1]).abs();
    let plan = plan_top_grasp_clear_of(
        arc,
        &half,
        e.center,
        table_z,
        table_z + e.height,
        table_z,
        current,
        room,
    );
    if e.model != "coarse" {
        return plan;
    }
    let low = plan_top_grasp_clear_of(
        arc,
        &half,
        e.center,
        table_z,
        table_z + COARSE_HEIGHT_FLOOR * e.height,
        table_z,
        current,
        room,
    );
    GraspPlan {
        guard: (plan.grasp.translation.z - low.grasp.translation.z).max(0.0),
        coarse: true,
        ..plan
    }
}
