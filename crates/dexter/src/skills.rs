//! Dexter's skills, sequenced from control-basis controllers on what the robot senses:
//! Search-Track → Reach (pre-grasp) → Reach (descend) → Grasp → Reach (lift) → Reach (transport) →
//! Place (lower until the support takes the load) → open → Reach (retreat). Every transition is
//! taken on a controller's convergence predicate or a sensor event — never on a scripted joint
//! trajectory, and never on the world's truth:
//!
//! * grasps are planned from the seen object: the support-plane centroid, the measured height and
//!   the footprint's principal axes ([`SeenObject`], §6.2.1);
//! * the Grasp predicate converges on the fingertip force/torque sensors (opposing, squeezing
//!   contacts, fingers still; §3.1.3.3);
//! * a grasp holds when, lifted 10 cm, the fingertips carry a measured load (§6.5);
//! * Place lowers until the fingertip load falls to half of what was weighed (the support took it).

use control_basis::hardware::{ForceTorque, HardwareError};
use control_basis::math::{Iso3, Vec3};
use control_basis::{Chain, Hardware, IkSettings, inverse_kinematics};
use nalgebra::Translation3;
use schema::{Failure, FailureCause};
use serde::Serialize;

use crate::arm::Arm;
use crate::body::Body;
use crate::control::{FLEX_CLOSED, HandControl, ReachControl, top_down_orientation};
use crate::error::RobotError;
use crate::eyes::{Eyes, Pair, SearchTrack};
use crate::vision::{StereoBlob, StereoCameras};

/// Control rate (Hz): the control-basis stack runs every `1 / CONTROL_HZ` s.
pub const CONTROL_HZ: f64 = 200.0;

/// Height of the palm surface above the table when an arm is parked (m).
const PARK_HEIGHT: f64 = 0.32;

/// A fingertip counts as loaded above this force (N).
pub const CONTACT_FORCE: f64 = 0.25;

/// Smallest load (N) the fingertips must carry after a lift for the grasp to hold: a third of the
/// lightest household object's weight (45 g).
pub const MIN_LOAD: f64 = 0.15;

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
const LYING_ELONGATION: f64 = 1.6;

/// An elongated silhouette whose major axis lies within this angle (rad) of the image of the
/// vertical may be an object standing up ([`lying_footprint`]).
const VERTICAL_SLACK: f64 = 0.35;

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
        let [[a, b], [_, d]] = cov;
        let disc = (0.25 * (a - d) * (a - d) + b * b).sqrt();
        let (l_min, l_max) = (0.5 * (a + d) - disc, 0.5 * (a + d) + disc);
        if l_max.is_nan() || l_max <= LYING_ELONGATION * l_min.max(0.0) {
            return None;
        }
        // The major eigenvector.
        let e = if b.abs() > 1e-12 {
            [b, l_max - a]
        } else if a >= d {
            [1.0, 0.0]
        } else {
            [0.0, 1.0]
        };
        let n = e[0].hypot(e[1]);
        let e = [e[0] / n, e[1] / n];
        // The image of the vertical through the centroid.
        let (u0, v0) = cam.project_unbounded(centroid)?;
        let (u1, v1) = cam.project_unbounded(&(centroid + Vec3::new(0.0, 0.0, 0.05)))?;
        let up = (u1 - u0).hypot(v1 - v0);
        if up > 1e-9 && (e[0] * (u1 - u0) + e[1] * (v1 - v0)).abs() / up > VERTICAL_SLACK.cos() {
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
const AXIS_TIE: f64 = 0.003;

/// How far (m) apart, across the closing direction, the BarrettHand's two side-by-side fingertips
/// (F1, F2) stand in a pre-shape: about 5 cm.
const FINGER_PAIR_HALF_SPACING: f64 = 0.025;

/// [`plan_top_grasp_geometry`], choosing among equally narrow closing directions the one whose
/// pre-shaped fingertips keep farthest from everything else, `room(p)` being the free distance
/// (m) around table point `p` (`None`: the first narrowest). A touch on a block 10 cm from a bin's
/// wall had a fingertip land on the wall's top (development: `any_schema`, Reach-And-Touch in
/// `sorting-new`); turned 90°, the fingers fall clear on both sides.
#[allow(clippy::too_many_arguments)]
pub fn plan_top_grasp_clear_of(
    arc: &[(f64, f64, f64)],
    half_along: &dyn Fn(Vec3) -> f64,
    center: [f64; 2],
    bottom: f64,
    top: f64,
    table_z: f64,
    current: &Iso3,
    room: Option<&dyn Fn([f64; 2]) -> f64>,
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
                    least = least.min(room(p));
                }
            }
            least
        };
        let mut chosen = (clearance(best.0, best.1), best);
        for &(w, d) in &widths {
            if w <= best.0 + AXIS_TIE {
                let c = clearance(w, d);
                if c > chosen.0 + 1e-9 {
                    chosen = (c, (w, d));
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
    }
}

/// A negligible extent (m) added along the footprint's major axis when choosing the closing
/// direction: ties between equally narrow directions go across the major axis.
const TIE_BIAS: f64 = 1e-6;

/// The share of a coarse height the guarded descent of [`plan_top_grasp`] may come down to: the
/// palm's goal is planned for an object this much of the measured height (a centroid 4 cm too high
/// doubles a 10 cm can's coarse height; the palm then stops on the real top).
const COARSE_HEIGHT_FLOOR: f64 = 0.4;

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
    room: Option<&dyn Fn([f64; 2]) -> f64>,
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
        ..plan
    }
}

/// Whether `arm` can put its palm at `pose` (IK within limits).
pub fn reachable(model: &control_basis::RobotModel, arm: Arm, pose: &Iso3, seed: u64) -> Result<bool, RobotError> {
    let chain = Chain::new(model, "world", &crate::control::tool_link(arm))?;
    let settings = IkSettings {
        position_tolerance: 2e-3,
        orientation_tolerance: 2e-2,
        restarts: 20,
        seed,
        ..IkSettings::default()
    };
    let q0 = HOME_ARM_GUESS;
    let sol = inverse_kinematics(&chain, pose, &q0, &settings)?;
    Ok(sol.converged)
}

/// A start for IK near the parked posture. The arms are mirror images under
/// `q_right = S q_left`, `S = diag(−1, 1, −1, 1, −1, 1, −1)` (assets/README-dexter.md), so the guess,
/// symmetric under S, serves both.
pub const HOME_ARM_GUESS: [f64; 7] = [0.0, 0.9, 0.0, 1.6, 0.0, 0.0, 0.0];

/// The stowed pose of an arm's palm: out to its side, beside the near edge of the table and low,
/// where neither the arm nor its elbow crosses the head cameras' view of the table (the parked arm's
/// upper arm hides the table's near corner on its side from the head).
pub fn stow_pose(arm: Arm, table_z: f64) -> Iso3 {
    let s = if arm == Arm::Left { 1.0 } else { -1.0 };
    let rot = top_down_orientation(&Vec3::x(), &control_basis::math::Rot3::identity());
    Iso3::from_parts(Translation3::new(0.30, s * 0.55, table_z + 0.25), rot)
}

/// The parked pose of an arm's palm: above the near corner of the table on its own side.
pub fn park_pose(arm: Arm, table_z: f64) -> Iso3 {
    let s = if arm == Arm::Left { 1.0 } else { -1.0 };
    let rot = top_down_orientation(&Vec3::x(), &control_basis::math::Rot3::identity());
    Iso3::from_parts(Translation3::new(0.42, s * 0.32, table_z + PARK_HEIGHT), rot)
}

/// Runs the hardware for `seconds`, ticking `reach` at the control rate and calling the observer
/// after every control step; stops early when `until` returns true. Returns whether `until` fired.
/// A hardware failure stops the loop and is kept in the observer ([`Observer::take_error`]).
pub fn run_until(
    hw: &mut dyn Hardware,
    reach: &mut ReachControl,
    obs: &mut Observer<'_>,
    seconds: f64,
    mut until: impl FnMut(&mut dyn Hardware, &mut ReachControl) -> bool,
) -> bool {
    let dt_c = 1.0 / CONTROL_HZ;
    let n = (seconds * CONTROL_HZ).ceil() as usize;
    for _ in 0..n {
        if obs.error.is_some() {
            return false;
        }
        reach.tick(hw, dt_c);
        if let Err(e) = hw.advance(dt_c) {
            obs.error = Some(e);
            return false;
        }
        (obs.callback)(hw, obs.activity);
        if until(hw, reach) {
            return true;
        }
    }
    false
}

/// Advances the hardware by `seconds` with no controller ticking (references held), observing.
pub fn idle(hw: &mut dyn Hardware, obs: &mut Observer<'_>, seconds: f64) {
    let dt_c = 1.0 / CONTROL_HZ;
    for _ in 0..(seconds * CONTROL_HZ).ceil() as usize {
        if obs.error.is_some() {
            return;
        }
        if let Err(e) = hw.advance(dt_c) {
            obs.error = Some(e);
            return;
        }
        (obs.callback)(hw, obs.activity);
    }
}

/// Receives the head's stereo images (left, right).
pub type ImageCallback<'a> = dyn FnMut(&dyn Hardware, &crate::vision::Image, &crate::vision::Image) + 'a;

/// Receives the hardware after every control tick with a description of the current activity
/// (for logs, progress and visualisation), and keeps the first hardware failure.
pub struct Observer<'a> {
    callback: &'a mut dyn FnMut(&mut dyn Hardware, &str),
    images: Option<&'a mut ImageCallback<'a>>,
    /// What the robot is doing.
    pub activity: &'static str,
    error: Option<HardwareError>,
}

impl std::fmt::Debug for Observer<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Observer").field("activity", &self.activity).finish()
    }
}

impl<'a> Observer<'a> {
    /// An observer calling `callback(hw, activity)` after every control tick.
    pub fn new(callback: &'a mut dyn FnMut(&mut dyn Hardware, &str)) -> Self {
        Observer {
            callback,
            images: None,
            activity: "",
            error: None,
        }
    }

    /// Also receive the head's stereo images (left, right) every time the robot looks.
    pub fn with_images(mut self, images: &'a mut ImageCallback<'a>) -> Self {
        self.images = Some(images);
        self
    }

    /// The first hardware failure, if any (the skills stop at it).
    pub fn take_error(&mut self) -> Option<HardwareError> {
        self.error.take()
    }

    /// `Err` with the first hardware failure, if any.
    pub fn check(&mut self) -> Result<(), RobotError> {
        match self.error.take() {
            Some(e) => Err(e.into()),
            None => Ok(()),
        }
    }
}

/// The fingertip sensors of one hand (F1, F2, F3), world-aligned.
pub fn hand_fingertips(hw: &dyn Hardware, arm: Arm, buf: &mut Vec<ForceTorque>) -> [ForceTorque; 3] {
    buf.resize(hw.force_torque_frames().len(), ForceTorque::default());
    hw.read_force_torque(buf);
    let k = 3 * arm.index();
    if buf.len() < k + 3 {
        return [ForceTorque::default(); 3];
    }
    [buf[k], buf[k + 1], buf[k + 2]]
}

/// What the fingertips of one hand say: loaded fingers, whether F3 opposes F1 or F2 with a squeeze
/// (horizontal forces pointing against each other), and the load they carry (−Σ f_z, N).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TouchState {
    /// Fingers whose force exceeds [`CONTACT_FORCE`].
    pub loaded: usize,
    /// F3 and F1 or F2 loaded, squeezing from opposite sides.
    pub opposed: bool,
    /// Vertical load carried by the fingers (N, positive = the hand holds weight up).
    pub load: f64,
}

impl TouchState {
    /// From the three fingertip readings.
    pub fn of(tips: &[ForceTorque; 3]) -> Self {
        let loaded_tip = |t: &ForceTorque| t.in_contact && t.force_norm() > CONTACT_FORCE;
        let loaded = tips.iter().filter(|t| loaded_tip(t)).count();
        let f3 = tips[2].force;
        let opposed = loaded_tip(&tips[2])
            && tips[..2]
                .iter()
                .any(|t| loaded_tip(t) && t.force[0] * f3[0] + t.force[1] * f3[1] < 0.0);
        let load = -tips.iter().map(|t| t.force[2]).sum::<f64>();
        TouchState { loaded, opposed, load }
    }

    /// Whether the hand holds something: two loaded fingers (the holding test the monitors use).
    pub fn holding(&self) -> bool {
        self.loaded >= 2
    }
}

/// How a grasp-and-lift went (the seed's grasp criterion, §6.5: the hand rises 10 cm and the object
/// is still held), judged on the robot's own sensors.
#[derive(Debug, Clone, Serialize)]
pub struct GraspOutcome {
    /// After the 10 cm lift, two fingertips are loaded and carry at least [`MIN_LOAD`].
    pub lifted: bool,
    /// What happened.
    pub outcome: String,
    /// Why it was not lifted, typed (`None` when it was).
    pub failure: Option<Failure>,
    /// How far the palm rose (m, from the encoders).
    pub rose: f64,
    /// The load the fingertips carried while held still after the lift (N), if it was lifted.
    pub weighed: Option<f64>,
}

/// Reach the pre-grasp 10 cm above `plan.grasp` with the hand pre-shaped, descend, close until the
/// Grasp predicate converges (opposing fingers squeezing, hand still), lift 10 cm, hold still and
/// weigh the object through the fingertip sensors. `phase(name, time)` is told when each phase begins.
pub fn grasp_and_lift(
    hw: &mut dyn Hardware,
    reach: &mut ReachControl,
    hand: &HandControl,
    plan: &GraspPlan,
    obs: &mut Observer<'_>,
    phase: &mut dyn FnMut(&str, f64),
) -> GraspOutcome {
    let fail = |failure: Failure| GraspOutcome {
        lifted: false,
        outcome: failure.message.clone(),
        failure: Some(failure),
        rose: 0.0,
        weighed: None,
    };
    let plan = match approach_grasp(hw, reach, hand, plan, obs, phase) {
        Ok(p) => p,
        Err(why) => return fail(why),
    };
    phase("grasp", hw.time_secs());
    if let Err(why) = close_grasp(hw, reach, hand, obs) {
        return fail(why);
    }
    phase("lift", hw.time_secs());
    lift_and_weigh(hw, reach, &plan, obs)
}

/// How far (horizontally) a palm that stopped on an object's top may be from its planned grasp
/// for the fingers still to close from there ([`approach_grasp`]). Traced in the bump and drop fault
/// scenes (`dexter-sim/examples/fault_probe.rs`): a palm that lands on a knocked-over or dropped object
/// stops 6–15 mm off its goal, and closing from there grasps it (bump scenes 20 and 29); the grasp
/// monitors judge the result, as after any close. Was 6 mm.
const RESTING_XY: f64 = 0.02;

/// How far above its planned grasp such a palm may have stopped ([`approach_grasp`]): 2 cm. Palms
/// stopped 2.5–5 cm above (an object whose measured top was low) were traced too; closing from there
/// did not recover any of them, so the bound stays.
const RESTING_Z: f64 = 0.02;

/// Reach (§3.1) to the pre-grasp 10 cm above `plan.grasp` with the hand pre-shaped — a straight line
/// at hover height, the configuration servo if that stalls — then descend to the grasp pose. Returns
/// the plan actually used (F3 may be on either side: the IK solution nearer the current
/// configuration wins), or why the reach failed.
pub fn approach_grasp(
    hw: &mut dyn Hardware,
    reach: &mut ReachControl,
    hand: &HandControl,
    plan: &GraspPlan,
    obs: &mut Observer<'_>,
    phase: &mut dyn FnMut(&str, f64),
) -> Result<GraspPlan, Failure> {
    // 1. Pre-grasp: above the object, hand pre-shaped.
    obs.activity = "reach pre-grasp";
    hand.set(hw, plan.preshape, 0.0);
    // The hand is symmetric enough that F3 may be on either side: take the IK solution nearest the
    // current configuration among both.
    let mut best: Option<(f64, Iso3)> = None;
    let q_now = reach.chain_configuration(hw);
    for flip in [false, true] {
        let mut g = plan.grasp;
        if flip {
            g.rotation *= control_basis::math::Rot3::from_axis_angle(&Vec3::z_axis(), std::f64::consts::PI);
        }
        let mut pre = g;
        pre.translation.vector.z += 0.10;
        if let Ok(Some(q)) = reach.solve_ik(hw, &pre, 11 + flip as u64) {
            let d = (q - &q_now).amax();
            if best.as_ref().is_none_or(|b| d < b.0) {
                best = Some((d, g));
            }
        }
    }
    let Some((_, grasp_pose)) = best else {
        return Err(Failure::new(
            FailureCause::OutOfReach,
            "pre-grasp out of reach (no IK solution)",
        ));
    };
    let plan = GraspPlan {
        grasp: grasp_pose,
        ..*plan
    };
    let mut pre = plan.grasp;
    pre.translation.vector.z += 0.10;
    // Large motion in configuration space to a hover pose high above the pre-grasp (a joint-space
    // path may dip; high above, it cannot sweep through the objects), then straight down.
    let mut hover = pre;
    hover.translation.vector.z = hover
        .translation
        .vector
        .z
        .max(reach.tool_pose(hw).translation.z)
        .max(pre.translation.z + 0.08);
    // Round the tall things on the way ([`ReachControl::avoid`]), at hover height.
    go_around(
        hw,
        reach,
        obs,
        &hover,
        ROUTE_CLEARANCE,
        crate::sweep::HAND_LENGTH,
        &mut |_, _| false,
    );
    // First a straight line (Cartesian Reach ◁ Manipulability) at hover height; if it stalls (a
    // local minimum or a joint limit), the configuration servo to an IK solution takes over.
    reach.set_goal(hw, hover);
    if !run_until(hw, reach, obs, 5.0, |s, r| r.at_goal(s, 0.015, 0.05)) {
        match reach.set_goal_via_ik(hw, hover, 17) {
            Ok(true) => {}
            _ => {
                return Err(Failure::new(
                    FailureCause::OutOfReach,
                    "hover above the object out of reach (no IK solution)",
                ));
            }
        }
        if !run_until(hw, reach, obs, 8.0, |s, r| r.at_goal(s, 0.015, 0.05)) {
            let (d, _) = reach.goal_error(hw);
            return Err(Failure::short_of(
                FailureCause::ApproachNotReached,
                d,
                format!("hover above the object not reached ({:.1} cm away)", d * 100.0),
            ));
        }
    }
    reach.set_goal(hw, pre);
    if !run_until(hw, reach, obs, 4.0, |s, r| r.at_goal(s, 0.01, 0.05)) {
        let (d, _) = reach.goal_error(hw);
        return Err(Failure::short_of(
            FailureCause::ApproachNotReached,
            d,
            format!("pre-grasp not reached ({:.1} cm away)", d * 100.0),
        ));
    }
    // 2. Descend.
    phase("reach grasp", hw.time_secs());
    obs.activity = "reach grasp";
    reach.max_speed = 0.15;
    // A guarded descent (an uncertain height, [`GraspPlan::guard`]) aims below the planned grasp
    // and stops where the palm rests on the object's top.
    let mut goal_pose = plan.grasp;
    goal_pose.translation.vector.z -= plan.guard;
    reach.set_goal(hw, goal_pose);
    if !run_until(hw, reach, obs, 4.0, |s, r| r.at_goal(s, 0.004, 0.03)) {
        // A palm stopped just above its goal, over the object, rests on the object's top (its
        // measured height was a little high): the fingers can close from there.
        let palm = reach.tool_pose(hw).translation.vector;
        let goal = goal_pose.translation.vector;
        let resting =
            (palm.xy() - goal.xy()).norm() < RESTING_XY && palm.z > goal.z && palm.z - goal.z < RESTING_Z + plan.guard;
        if !resting {
            let (d, _) = reach.goal_error(hw);
            return Err(Failure::short_of(
                FailureCause::StoppedShort,
                d,
                format!("grasp pose not reached ({:.1} cm away)", d * 100.0),
            ));
        }
        // Lift the palm off the top by 5 mm so that it does not press the object into the
        // fingers (which would then carry more than its weight).
        let mut off = reach.tool_pose(hw);
        off.translation.vector.z += 0.005;
        reach.set_goal(hw, off);
        run_until(hw, reach, obs, 0.5, |s, r| r.at_goal(s, 0.002, 0.03));
    }
    if plan.guard > 0.0 {
        // The grasp is where the guarded descent stopped.
        let mut done = plan;
        done.grasp.translation.vector.z = reach.tool_pose(hw).translation.z;
        done.guard = 0.0;
        return Ok(done);
    }
    Ok(plan)
}

/// How far (m) the palm's way keeps from a tall thing's footprint ([`crate::route`]): the
/// spread fingers' reach about the palm (about 10 cm) and a margin for the thing's measured place.
pub const ROUTE_CLEARANCE: f64 = 0.15;

/// How far (m) the whole arm must keep from a tall thing on a way [`plan_way`] takes without
/// further ado: the thing's measured footprint is a centimetre or two off.
pub const SWEEP_MARGIN: f64 = 0.03;

/// How high (m) above a tall thing's measured top the hand's lowest point passes on the way over it.
const OVER_CLEARANCE: f64 = 0.08;

/// A tall thing within this horizontal distance (m) of the straight way counts for the height of
/// the way over ([`Way::Over`]).
const OVER_NEAR: f64 = 0.3;

/// The ways [`plan_way`] weighs, in order of preference.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Way {
    /// Straight to the goal.
    Straight,
    /// Round the tall things' footprints ([`crate::route`]) at the goal's height.
    Round,
    /// The same way round with the palm raised to the tall things' tops (the forearm above them),
    /// then down to the goal.
    RoundHigh,
    /// Up over the highest tall thing, across, and down to the goal (an empty hand only).
    Over,
}

/// The way [`plan_way`] chose.
#[derive(Debug, Clone, PartialEq)]
pub struct PlannedWay {
    /// Which of the ways.
    pub way: Way,
    /// The tool poses to pass through, ending with the goal.
    pub poses: Vec<Iso3>,
    /// The least whole-arm clearance (m) on it in the rollout (NaN: not rolled out).
    pub clearance: f64,
    /// Whether it keeps [`SWEEP_MARGIN`] (or, for an arm already nearer than that, comes no nearer).
    pub clear: bool,
}

/// The way for the palm of `reach` (in the configuration `q0`, chain order) to `goal` that keeps
/// the whole arm clearest of the tall things in [`ReachControl::avoid`]: each of [`Way`]'s is
/// rolled out on the robot's own model ([`ReachControl::sweep`], [`crate::sweep::arm_clearance`],
/// the hand reaching `below` under the palm surface); the first in order that keeps
/// [`SWEEP_MARGIN`] (or, for an arm already nearer than that, comes no nearer) is taken, else the
/// one that keeps most. The palm's own way round keeps `clearance` from the footprints. When no
/// way reaches the goal in the rollout: the palm's way round, if any. `None` without tall things.
pub fn plan_way(reach: &ReachControl, q0: &[f64], goal: &Iso3, clearance: f64, below: f64) -> Option<PlannedWay> {
    if reach.avoid.is_empty() {
        return None;
    }
    let mut state = reach.chain().new_state();
    state.set_q(reach.chain(), q0).ok()?;
    control_basis::forward_kinematics(reach.chain(), &mut state);
    let palm = state.tip_pose().translation.vector;
    // An arm already nearer a thing than the margin (stopped against the post it was reaching
    // round) is held only to come no nearer than it is.
    let start = crate::sweep::arm_clearance(reach.chain(), &state, &reach.avoid, f64::NEG_INFINITY, below);
    let margin = SWEEP_MARGIN.min(start - 0.005);
    let g = goal.translation.vector;
    let at = |x: f64, y: f64, z: f64| {
        let mut p = *goal;
        p.translation.vector = Vec3::new(x, y, z);
        p
    };
    // The straight way only when the palm's own way keeps `clearance` too (it holds the fingers'
    // spread and a held object's radius, which the arm's capsules do not).
    let mut ways: Vec<(Way, Vec<Iso3>)> = Vec::new();
    if crate::route::clear_of([palm.x, palm.y], [g.x, g.y], &reach.avoid, clearance) {
        ways.push((Way::Straight, vec![*goal]));
    }
    // The tall things near the straight way (a coarse blob's top, guessed from its centroid, can be
    // high; one far off does not matter).
    let top = reach
        .avoid
        .iter()
        .filter(|o| !crate::route::clear_of([palm.x, palm.y], [g.x, g.y], std::slice::from_ref(*o), OVER_NEAR))
        .map(|o| o.top)
        .fold(f64::NEG_INFINITY, f64::max);
    if let Some(round) =
        crate::route::route_within([palm.x, palm.y], [g.x, g.y], &reach.avoid, clearance, reach.way_region)
        && round.len() > 1
    {
        ways.push((Way::Round, round.iter().map(|c| at(c[0], c[1], g.z)).collect()));
        // The same way with the palm as high as the things' tops: the hand passes beside them,
        // the forearm (which rises from the palm towards the elbow) above them.
        let z = top.max(g.z);
        if top.is_finite() && z > g.z + 0.02 {
            let mut poses = vec![at(palm.x, palm.y, z.max(palm.z))];
            poses.extend(round[..round.len() - 1].iter().map(|c| at(c[0], c[1], z)));
            poses.push(at(g.x, g.y, z));
            poses.push(*goal);
            ways.push((Way::RoundHigh, poses));
        }
    }
    // Over, only with an empty hand: a held object lifted that high slips (the hand tilts as the
    // arm nears the top of its workspace; development seed 2, blocked arm, scenes 15 and 22: the
    // receiving hand's carry over the post dropped the object from 0.6 m above the table).
    if top.is_finite() && below <= crate::sweep::HAND_LENGTH {
        let z = top + below.max(crate::sweep::HAND_LENGTH) + OVER_CLEARANCE;
        if z > g.z.max(palm.z) {
            ways.push((Way::Over, vec![at(palm.x, palm.y, z), at(g.x, g.y, z), *goal]));
        }
    }
    let mut chosen: Option<PlannedWay> = None;
    let mut round = None;
    for (way, poses) in ways {
        let sweep = reach.sweep(q0, &poses, 5.0, &mut |s| {
            crate::sweep::arm_clearance(reach.chain(), s, &reach.avoid, f64::NEG_INFINITY, below)
        });
        tracing::trace!(
            "{way:?} way {:?}: {sweep:?}",
            poses
                .iter()
                .map(|p| p.translation.vector.as_slice().to_vec())
                .collect::<Vec<_>>()
        );
        if way == Way::Round {
            round = Some(poses.clone());
        }
        if !sweep.reached {
            continue;
        }
        let clear = sweep.clearance >= margin;
        if clear || chosen.as_ref().is_none_or(|c| sweep.clearance > c.clearance) {
            chosen = Some(PlannedWay {
                way,
                poses,
                clearance: sweep.clearance,
                clear,
            });
        }
        if clear {
            break;
        }
    }
    chosen.or_else(|| {
        round.map(|poses| PlannedWay {
            way: Way::Round,
            poses,
            clearance: f64::NAN,
            clear: false,
        })
    })
}

/// Moves the palm towards `goal` (not to `goal` itself: the caller's own move ends there) by the
/// way [`plan_way`] chooses. `stop` ends the move early (a carried object lost). Does nothing when
/// that is the straight way or there is none. Each via point gets a few seconds; one not reached
/// (out of the arm's reach) is passed on from where the palm is.
fn go_around(
    hw: &mut dyn Hardware,
    reach: &mut ReachControl,
    obs: &mut Observer<'_>,
    goal: &Iso3,
    clearance: f64,
    below: f64,
    stop: &mut dyn FnMut(&mut dyn Hardware, &mut ReachControl) -> bool,
) {
    let q0 = reach.chain_configuration(hw);
    let Some(planned) = plan_way(reach, q0.as_slice(), goal, clearance, below) else {
        return;
    };
    tracing::debug!(
        "way to {:?} round {:?}: {planned:?}",
        goal.translation.vector.as_slice(),
        reach.avoid
    );
    for pose in &planned.poses[..planned.poses.len() - 1] {
        reach.set_goal(hw, *pose);
        let mut stopped = false;
        run_until(hw, reach, obs, 4.0, |h, r| {
            stopped = stop(h, r);
            stopped || r.at_goal(h, 0.03, 0.1)
        });
        if stopped {
            return;
        }
    }
}

/// How fast (m/s) the palm descends to touch ([`touch_object`]): a fingertip meeting the object
/// stops it within a few millimetres.
const TOUCH_DESCENT_SPEED: f64 = 0.03;

/// How far (m) below where a fingertip met the object the palm's reference stays after a touch's
/// descent.
const TOUCH_DESCENT_PRESS: f64 = 0.003;

/// How fast (rad/s) the fingers close to touch ([`touch_object`]): slow enough that the first
/// finger to meet the object stops on it before the others arrive.
const TOUCH_FLEX_SPEED: f64 = 0.4;
/// How far (rad) past the flexion at first contact the touching fingers' reference stays, so that
/// the finger rests on the object with a light force.
const TOUCH_PRESS: f64 = 0.10;

/// Touch (the Reach-And-Touch schema's last action): from where the reach stopped — clear above the
/// object, `down` the grasp pose to descend to (slowly, [`TOUCH_DESCENT_SPEED`]; a fingertip that
/// meets the object's top on the way ends the touch there) — or from the grasp pose, close the
/// fingers slowly until a fingertip meets the object, and hold them there: contact without an
/// opposing grasp, the Touch predicate.
/// Fingers that met it from both sides (a squeeze) open again until one side lets go. Fails if no
/// fingertip met anything by the time the hand is closed.
pub fn touch_object(
    hw: &mut dyn Hardware,
    reach: &mut ReachControl,
    hand: &HandControl,
    down: Option<&Iso3>,
    obs: &mut Observer<'_>,
) -> Result<(), Failure> {
    let arm = reach.arm();
    obs.activity = "touch";
    let mut buf = Vec::new();
    let dt = 1.0 / CONTROL_HZ;
    if let Some(goal) = down {
        let speed = reach.max_speed;
        reach.max_speed = TOUCH_DESCENT_SPEED;
        reach.set_goal(hw, *goal);
        let met = run_until(hw, reach, obs, 4.0, |h, r| {
            TouchState::of(&hand_fingertips(h, arm, &mut buf)).loaded > 0 || r.at_goal(h, 0.004, 0.03)
        });
        reach.max_speed = speed;
        // Stop where the fingertip met it, the reference a little below so that it keeps resting
        // on the object with a light force (the fingertip touching at the end is the goal).
        let mut here = reach.tool_pose(hw);
        here.translation.vector.z -= TOUCH_DESCENT_PRESS;
        reach.set_goal(hw, here);
        idle(hw, obs, 0.2);
        if met && TouchState::of(&hand_fingertips(hw, arm, &mut buf)).loaded > 0 {
            return Ok(());
        }
    }
    let start = hand.flexion(hw);
    let mut flex = start.iter().copied().fold(f64::INFINITY, f64::min);
    let met = run_until(hw, reach, obs, 4.0, |h, _| {
        let touch = TouchState::of(&hand_fingertips(h, arm, &mut buf));
        if touch.loaded > 0 {
            return true;
        }
        flex = (flex + TOUCH_FLEX_SPEED * dt).min(FLEX_CLOSED);
        hand.set(h, flex, 0.0);
        false
    });
    if !met {
        return Err(Failure::new(
            FailureCause::NoGrasp,
            "no fingertip met the object (the hand closed on nothing)",
        ));
    }
    // Hold the fingers where they met it, the reference a little past the contact so that the
    // finger keeps resting on it.
    flex = (flex + TOUCH_PRESS).min(FLEX_CLOSED);
    hand.set(hw, flex, 0.0);
    idle(hw, obs, 0.3);
    for _ in 0..10 {
        if !TouchState::of(&hand_fingertips(hw, arm, &mut buf)).opposed {
            break;
        }
        flex -= 0.05;
        hand.set(hw, flex, 0.0);
        idle(hw, obs, 0.1);
    }
    let touch = TouchState::of(&hand_fingertips(hw, arm, &mut buf));
    if touch.loaded == 0 {
        // Open again to where the hand started, for another try from the same pose.
        hand.set(hw, start.iter().copied().fold(f64::INFINITY, f64::min), 0.0);
        idle(hw, obs, 0.3);
        return Err(Failure::new(
            FailureCause::Moved,
            "the fingertip lost the object after it met it (it moved away)",
        ));
    }
    Ok(())
}

/// Grasp (§3.1.3.3): close the hand until the Grasp predicate converges on the fingertip sensors —
/// F3 and F1 or F2 loaded and squeezing from opposite sides, the fingers still — for 0.15 s. Returns
/// why it did not converge.
pub fn close_grasp(
    hw: &mut dyn Hardware,
    reach: &mut ReachControl,
    hand: &HandControl,
    obs: &mut Observer<'_>,
) -> Result<(), Failure> {
    let arm = reach.arm();
    obs.activity = "grasp";
    hand.set(hw, FLEX_CLOSED, 0.0);
    let mut still = 0;
    let mut buf = Vec::new();
    let grasped = run_until(hw, reach, obs, 3.0, |h, _| {
        let touch = TouchState::of(&hand_fingertips(h, arm, &mut buf));
        if touch.opposed && hand.max_flex_speed(h) < 0.1 {
            still += 1;
        } else {
            still = 0;
        }
        still >= 30
    });
    if !grasped {
        return Err(Failure::new(
            FailureCause::NoGrasp,
            "grasp did not converge (no opposing contacts)",
        ));
    }
    Ok(())
}

/// Lift 10 cm with the grasp, hold still and weigh the object through the fingertip sensors (the
/// seed's grasp criterion, §6.5: the hand rises 10 cm and the object is still held — here: still
/// loads two fingertips with at least [`MIN_LOAD`]).
pub fn lift_and_weigh(
    hw: &mut dyn Hardware,
    reach: &mut ReachControl,
    plan: &GraspPlan,
    obs: &mut Observer<'_>,
) -> GraspOutcome {
    let arm = reach.arm();
    let mut buf = Vec::new();
    obs.activity = "lift";
    let z_before = reach.tool_pose(hw).translation.z;
    // 10 cm above where the palm closed (a palm resting on the object's top closed above the
    // planned grasp: rising from the plan would fall short of the criterion's 8 cm).
    let mut lift = plan.grasp;
    lift.translation.vector.z = z_before.max(plan.grasp.translation.z) + 0.10;
    reach.max_speed = 0.10;
    reach.set_goal(hw, lift);
    run_until(hw, reach, obs, 3.0, |h, r| r.at_goal(h, 0.005, 0.03));
    // Hold still until the load the fingertips feel settles (the object stops swinging in the
    // hand), then weigh: the fingers carry the object, so Σ f_z = −m·g at rest.
    let mut quiet = 0;
    let mut last = f64::NAN;
    run_until(hw, reach, obs, 1.5, |h, _| {
        let load = TouchState::of(&hand_fingertips(h, arm, &mut buf)).load;
        let steady = (load - last).abs() < 0.002 + 0.003 * load.abs();
        last = load;
        quiet = if steady { quiet + 1 } else { 0 };
        quiet >= 40
    });
    let mut sum = 0.0;
    let mut n = 0usize;
    let mut loaded = usize::MAX;
    run_until(hw, reach, obs, 0.5, |h, _| {
        let t = TouchState::of(&hand_fingertips(h, arm, &mut buf));
        sum += t.load;
        loaded = loaded.min(t.loaded);
        n += 1;
        false
    });
    let rose = reach.tool_pose(hw).translation.z - z_before;
    let load = sum / n.max(1) as f64;
    let lifted = rose > 0.08 && loaded >= 2 && loaded != usize::MAX && load >= MIN_LOAD;
    let outcome: String = if lifted {
        "lifted".into()
    } else if rose <= 0.08 {
        format!("the hand did not rise ({:.1} cm)", rose * 100.0)
    } else {
        format!(
            "object not held after lift ({} loaded fingertips, load {load:.2} N)",
            loaded.min(3)
        )
    };
    GraspOutcome {
        lifted,
        rose,
        weighed: lifted.then_some(load),
        failure: (!lifted).then(|| Failure::new(FailureCause::NotLifted, outcome.clone())),
        outcome,
    }
}

/// What the robot knows about an object in its hand: where it sits relative to the palm (from
/// where it was seen when grasped) and its measured weight.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Held {
    /// Horizontal offset (world x, y) of the object's centre from the palm at the grasp (m).
    pub offset_xy: [f64; 2],
    /// How far the object's bottom hangs below the palm surface (m): the palm height at the grasp
    /// above the table the object rested on.
    pub below: f64,
    /// Its weight as the fingertips measured it after the lift (N).
    pub load: f64,
    /// Its footprint radius (m), for room in the place.
    pub radius: f64,
}

impl Held {
    /// What is known after grasping `seen` (resting on the table at `table_z`) with the palm at
    /// `palm_at_grasp`, and weighing `load`.
    pub fn new(seen: &SeenObject, palm_at_grasp: &Iso3, table_z: f64, load: f64) -> Self {
        let p = palm_at_grasp.translation.vector;
        Held {
            offset_xy: [seen.extent.center[0] - p.x, seen.extent.center[1] - p.y],
            below: p.z - table_z,
            load,
            radius: seen.radius(),
        }
    }
}

/// Reach ◁ Grasp: carry the held object up to a safe height (its bottom clearing walls and objects
/// of `wall_height` above the table) and over `target` (x, y of where the object's centre should go): a straight line, the configuration
/// servo if that stalls. Fails if the fingertips lose the object or the place is not reached.
#[allow(clippy::too_many_arguments)]
pub fn transport_over(
    hw: &mut dyn Hardware,
    reach: &mut ReachControl,
    held: &Held,
    target: [f64; 2],
    table_z: f64,
    wall_height: f64,
    obs: &mut Observer<'_>,
) -> Result<(), Failure> {
    obs.activity = "transport";
    let arm = reach.arm();
    let safe_z = table_z + wall_height + held.below + 0.08;
    let mut up = reach.tool_pose(hw);
    up.translation.vector.z = up.translation.vector.z.max(safe_z);
    reach.max_speed = 0.3;
    reach.set_goal(hw, up);
    // Reach ◁ Grasp: the carry stops as soon as the grasp constraint is lost — the fingertips
    // have not felt the object's load for 0.1 s (a short glitch of the sensors is not a drop).
    let mut buf = Vec::new();
    let lost = |h: &dyn Hardware, buf: &mut Vec<ForceTorque>| {
        let touch = TouchState::of(&hand_fingertips(h, arm, buf));
        !touch.holding() || touch.load < 0.3 * held.load.max(MIN_LOAD)
    };
    let mut unloaded = 0usize;
    let dropped = std::cell::Cell::new(false);
    let mut carry = |h: &mut dyn Hardware, r: &mut ReachControl| {
        unloaded = if lost(h, &mut buf) { unloaded + 1 } else { 0 };
        dropped.set(dropped.get() || unloaded >= 20);
        dropped.get() || r.at_goal(h, 0.01, 0.05)
    };
    run_until(hw, reach, obs, 3.0, &mut carry);
    // Over the target: object centre above it, round the tall things on the way.
    let mut over = up;
    over.translation.vector.x = target[0] - held.offset_xy[0];
    over.translation.vector.y = target[1] - held.offset_xy[1];
    if !dropped.get() {
        go_around(
            hw,
            reach,
            obs,
            &over,
            ROUTE_CLEARANCE + held.radius,
            held.below,
            &mut carry,
        );
    }
    if !dropped.get() {
        reach.set_goal(hw, over);
        let straight = run_until(hw, reach, obs, 6.0, &mut carry);
        if !straight && !dropped.get() && reach.set_goal_via_ik(hw, over, 23).unwrap_or(false) {
            run_until(hw, reach, obs, 8.0, &mut carry);
        }
    }
    if dropped.get() || lost(hw, &mut buf) {
        // Stop where the hand is.
        let here = reach.tool_pose(hw);
        reach.set_goal(hw, here);
        if TouchState::of(&hand_fingertips(hw, arm, &mut buf)).holding() {
            // Still in the hand: something took its load (it met an obstacle on the way).
            return Err(Failure::new(
                FailureCause::Obstructed,
                "the carried object met an obstacle (the fingertips felt its load taken)",
            ));
        }
        return Err(Failure::new(
            FailureCause::Dropped,
            "object dropped during transport (the fingertips lost the load)",
        ));
    }
    if !reach.at_goal(hw, 0.01, 0.05) {
        let (d, _) = reach.goal_error(hw);
        return Err(Failure::short_of(
            FailureCause::PlaceNotReached,
            d,
            format!("place not reached ({:.1} cm away)", d * 100.0),
        ));
    }
    Ok(())
}

/// Place (§3.3.3): lower the held object until the support takes the load — the fingertips carry
/// less than half of what they weighed — at most down to the table at `table_z`. Returns whether
/// the reference was met.
pub fn lower_until_supported(
    hw: &mut dyn Hardware,
    reach: &mut ReachControl,
    held: &Held,
    table_z: f64,
    obs: &mut Observer<'_>,
) -> bool {
    obs.activity = "place";
    let arm = reach.arm();
    let mut down = reach.tool_pose(hw);
    let palm_z = down.translation.vector.z;
    down.translation.vector.z = table_z + 0.002 + held.below - 0.02;
    // Fingertips curled below the object's bottom (a ball drawn up into the hand as the fingers
    // closed under it) would reach the table first and be pressed onto it, and as they open they
    // flick the object away: the descent stops with the lowest fingertip just above the table.
    if let Some(tip_z) = lowest_fingertip(hw, arm) {
        let floor = table_z + (palm_z - tip_z) + FINGERTIP_RADIUS + FINGERTIP_CLEARANCE;
        down.translation.vector.z = down.translation.vector.z.max(floor);
    }
    reach.max_speed = 0.09;
    reach.set_goal(hw, down);
    let mut supported = 0;
    let mut buf = Vec::new();
    let threshold = 0.5 * held.load.max(MIN_LOAD);
    let touched = run_until(hw, reach, obs, 5.0, |h, _| {
        let t = TouchState::of(&hand_fingertips(h, arm, &mut buf));
        if t.load < threshold {
            supported += 1;
        } else {
            supported = 0;
        }
        supported >= 4
    });
    // Converged (or out of travel): hold the hand where it is, so that it does not keep pressing
    // the object into the support while the release is prepared.
    let here = reach.tool_pose(hw);
    reach.set_goal(hw, here);
    if !touched {
        // The hand reached its lowest target without the support taking the load (the object
        // rests on a wall or another object, or is still held by friction): release anyway.
        obs.activity = "place (no support felt)";
    }
    touched
}

/// Radius (m) of a BarrettHand fingertip (the `tip_link` spheres of the robot's model).
pub const FINGERTIP_RADIUS: f64 = 0.01;

/// Least gap (m) kept between the lowest fingertip and the table when an object is lowered onto
/// it ([`lower_until_supported`]).
pub const FINGERTIP_CLEARANCE: f64 = 0.01;

/// The height (m) of the lowest fingertip centre of `arm`'s hand, from the robot's model at the
/// measured joint angles (`None` if the model has no such links).
fn lowest_fingertip(hw: &dyn Hardware, arm: Arm) -> Option<f64> {
    let mut body = Body::new();
    (1..=3)
        .filter_map(|f| {
            body.pose(hw, &format!("{}/bhand/finger_{f}/tip_link", arm.prefix()))
                .ok()
                .map(|p| p.translation.z)
        })
        .reduce(f64::min)
}

/// Release: hold the hand where it is, open it, and retreat 12 cm up.
pub fn release_and_retreat(
    hw: &mut dyn Hardware,
    reach: &mut ReachControl,
    hand: &HandControl,
    obs: &mut Observer<'_>,
) {
    let here = reach.tool_pose(hw);
    reach.set_goal(hw, here);
    obs.activity = "release";
    hand.set(hw, 0.3, 0.0);
    run_until(hw, reach, obs, 0.5, |_, _| false);
    obs.activity = "retreat";
    let mut away = here;
    away.translation.vector.z += 0.12;
    reach.max_speed = 0.3;
    reach.set_goal(hw, away);
    // An object wedged between the half-opened fingers comes up with the hand (the fingertips
    // carry its weight): back down to where it was let go, open fully, and rise again.
    let arm = hand.arm();
    let z0 = here.translation.z;
    let mut tips = Vec::with_capacity(6);
    let mut wedged = false;
    run_until(hw, reach, obs, 2.0, |s, r| {
        let rose = r.tool_pose(s).translation.z - z0;
        if rose > WEDGED_RISE {
            let touch = TouchState::of(&hand_fingertips(s, arm, &mut tips));
            if touch.loaded >= 2 && touch.load > WEDGED_LOAD {
                wedged = true;
                return true;
            }
        }
        r.at_goal(s, 0.01, 0.05)
    });
    if wedged {
        obs.activity = "release";
        reach.set_goal(hw, here);
        run_until(hw, reach, obs, 1.0, |s, r| r.at_goal(s, 0.01, 0.05));
        hand.set(hw, 0.0, 0.0);
        run_until(hw, reach, obs, 0.6, |_, _| false);
        obs.activity = "retreat";
        reach.set_goal(hw, away);
        run_until(hw, reach, obs, 2.0, |s, r| r.at_goal(s, 0.01, 0.05));
    }
}

/// A hand retreating from a release that has risen this far (m) …
const WEDGED_RISE: f64 = 0.02;
/// … with two loaded fingertips carrying more than this (N) has the object wedged in its fingers.
const WEDGED_LOAD: f64 = 0.3;

/// Search-Track (§3.2.2.1): points the head at `nominal`, then foveates the blob nearest to the
/// running estimate at the camera rate (`frame_secs`) until the tracking predicate converges, and
/// returns what was seen — the mean triangulated centroid of the last frames, the extent and the
/// appearance feature b of §6.2.1 (the 2×2 second moment averaged over the stereo pair and the
/// frames) — with the cameras' mid-point. `Ok(Err(why))` if the object is not seen.
pub fn locate_object(
    hw: &mut dyn Hardware,
    eyes: &mut Eyes,
    nominal: &Vec3,
    table_z: f64,
    frame_secs: f64,
    obs: &mut Observer<'_>,
) -> Result<Result<Located, Failure>, RobotError> {
    let mut body = Body::new();
    let mut track = SearchTrack::new(hw)?;
    track.look_at(hw, &mut body, nominal)?;
    // Let the head get there (saccade).
    idle(hw, obs, 0.4);
    obs.check()?;
    let mut estimate = *nominal;
    let mut recent: Vec<(Vec3, [[f64; 2]; 2], StereoBlob, StereoCameras)> = Vec::new();
    for _frame in 0..40 {
        let cams = eyes.cameras(hw, Pair::Head)?;
        eyes.perceive(hw, Pair::Head)?;
        if let Some(f) = obs.images.as_mut() {
            let (l, r) = eyes.images(Pair::Head);
            f(hw, l, r);
        }
        let nearest = eyes
            .blobs()
            .iter()
            .filter(|b| b.left.is_some() && b.right.is_some())
            .filter_map(|b| b.centroid.map(|c| (b, (c - estimate).xy().norm())))
            .filter(|(_, d)| *d < 0.12)
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(b, _)| *b);
        match nearest {
            Some(blob) => {
                let o = track.track(hw, &cams, &blob, frame_secs);
                if let Some(c) = o.centroid {
                    estimate = c;
                    if o.error < 4e-4 && !blob.truncated() {
                        recent.push((c, blob.mean_covariance(), blob, cams.clone()));
                    } else {
                        recent.clear();
                    }
                }
            }
            None => recent.clear(),
        }
        if recent.len() >= 3 {
            let n = recent.len() as f64;
            let c = recent.iter().fold(Vec3::zeros(), |a, r| a + r.0) / n;
            let mut b = [[0.0; 2]; 2];
            for (_, m, _, _) in &recent {
                for i in 0..2 {
                    for j in 0..2 {
                        b[i][j] += m[i][j] / n;
                    }
                }
            }
            // Exactly symmetric (the two cameras' matrices are, up to rounding).
            let off = 0.5 * (b[0][1] + b[1][0]);
            b[0][1] = off;
            b[1][0] = off;
            let (_, _, blob, cams) = recent.last().expect("three frames");
            let mut extent = extent_of(blob, cams, table_z).expect("a triangulated blob");
            // The footprint centre from the averaged centroid when it is only a disc.
            if extent.model != "prism" {
                extent.center = [c.x, c.y];
            }
            let eye = 0.5 * (cams.left.position() + cams.right.position());
            return Ok(Ok(Located {
                seen: SeenObject { centroid: c, extent },
                appearance: b,
                eye,
                frames: recent.len(),
            }));
        }
        idle(hw, obs, frame_secs);
        obs.check()?;
    }
    Ok(Err(Failure::new(
        FailureCause::NotSeen,
        format!(
            "search-track: no stereo blob foveated near ({:.2}, {:.2}, {:.2})",
            nominal.x, nominal.y, nominal.z
        ),
    )))
}

/// What Search-Track found.
#[derive(Debug, Clone)]
pub struct Located {
    /// The object as seen.
    pub seen: SeenObject,
    /// b: the 2×2 second-moment matrix of the segment averaged over the stereo pair and the frames
    /// (px², §6.2.1).
    pub appearance: [[f64; 2]; 2],
    /// The cameras' mid-point.
    pub eye: Vec3,
    /// Frames averaged.
    pub frames: usize,
}

/// Chooses an arm among `candidates` that reaches the grasp of `seen` and the place at `place_xy`
/// (walls `wall_height`), preferring the one on the object's side. `Err(reasons)` if none does.
#[allow(clippy::too_many_arguments)]
pub fn choose_arm(
    hw: &dyn Hardware,
    candidates: &[Arm],
    arc: &[(f64, f64, f64)],
    seen: &SeenObject,
    place_xy: [f64; 2],
    wall_height: f64,
    table_z: f64,
) -> Result<Result<Arm, Failure>, RobotError> {
    let mut order = candidates.to_vec();
    if seen.centroid.y < 0.0 {
        order.reverse();
    }
    let mut reasons = Vec::new();
    for arm in order {
        let park = park_pose(arm, table_z);
        let plan = plan_top_grasp(arc, seen, table_z, &park);
        let mut over = plan.grasp;
        over.translation.vector.x = place_xy[0];
        over.translation.vector.y = place_xy[1];
        over.translation.vector.z = table_z + wall_height + 0.15;
        let g = reachable(hw.model(), arm, &plan.grasp, 3)?;
        let p = reachable(hw.model(), arm, &over, 4)?;
        if g && p {
            return Ok(Ok(arm));
        }
        reasons.push(format!(
            "{arm} arm {}",
            match (g, p) {
                (false, false) => "reaches neither the object nor the place",
                (false, true) => "does not reach the object",
                _ => "does not reach the place",
            }
        ));
    }
    Ok(Err(Failure::new(FailureCause::OutOfReach, reasons.join("; "))))
}

#[cfg(test)]
mod tests {
    use super::*;
    use control_basis::hardware::Camera;
    use nalgebra::Point3;

    /// A head camera (160 × 120, the head's focal length) at `eye`, looking at the table.
    fn camera(eye: [f64; 3]) -> Camera {
        let world_from_optical = Iso3::face_towards(
            &Point3::from(eye),
            &Point3::new(0.6, 0.0, 0.75),
            &Vec3::new(0.0, 0.0, -1.0),
        );
        Camera {
            world_from_optical,
            width: 160,
            height: 120,
            fx: 160.0,
            fy: 160.0,
            cx: 80.0,
            cy: 60.0,
        }
    }

    /// A capped cylinder of `radius` and half length `half` with its axis `axis` through `center`.
    fn cylinder(center: Vec3, axis: Vec3, radius: f64, half: f64) -> impl Fn(Vec3) -> bool {
        move |p: Vec3| {
            let d = p - center;
            let along = d.dot(&axis);
            along.abs() <= half && (d - along * axis).norm() <= radius
        }
    }

    /// The silhouette (image centroid, covariance) of the solid `inside`, rasterised by marching
    /// every pixel's ray.
    fn silhouette(cam: &Camera, inside: impl Fn(Vec3) -> bool) -> ([f64; 2], [[f64; 2]; 2]) {
        let (mut n, mut su, mut sv, mut suu, mut suv, mut svv) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        for v in 0..cam.height {
            for u in 0..cam.width {
                let (o, d) = cam.ray(f64::from(u), f64::from(v));
                let hit = (0..700).any(|k| inside(o + (0.3 + 0.002 * f64::from(k)) * d));
                if hit {
                    let (u, v) = (f64::from(u), f64::from(v));
                    n += 1.0;
                    su += u;
                    sv += v;
                    suu += u * u;
                    suv += u * v;
                    svv += v * v;
                }
            }
        }
        assert!(n > 20.0, "the cylinder is in view");
        let (mu, mv) = (su / n, sv / n);
        let cuv = suv / n - mu * mv;
        ([mu, mv], [[suu / n - mu * mu, cuv], [cuv, svv / n - mv * mv]])
    }

    /// A bottle (radius 3.5 cm, 18 cm long) lying on the table at four headings: its footprint
    /// runs along its axis, about its length, and the planned grasp closes across it. A ball is
    /// not elongated: no footprint (the disc of its radius stands).
    #[test]
    fn a_lying_bottle_is_grasped_across_its_axis() {
        let (l, r) = (camera([0.05, 0.03, 1.45]), camera([0.05, -0.03, 1.45]));
        let (radius, half, table_z) = (0.035, 0.09, 0.75);
        let center = Vec3::new(0.6, 0.08, table_z + radius);
        let arc: Vec<(f64, f64, f64)> = (0..=100)
            .map(|k| {
                let m = FLEX_CLOSED * f64::from(k) / 100.0;
                (m, 0.09 - 0.06 * m / FLEX_CLOSED, 0.02 + 0.08 * m / FLEX_CLOSED)
            })
            .collect();
        for deg in [0.0_f64, 45.0, 90.0, 135.0] {
            let axis = Vec3::new(deg.to_radians().cos(), deg.to_radians().sin(), 0.0);
            let (ul, cl) = silhouette(&l, cylinder(center, axis, radius, half));
            let (ur, cr) = silhouette(&r, cylinder(center, axis, radius, half));
            let f = lying_footprint([(ul, cl, &l), (ur, cr, &r)], &center, radius)
                .unwrap_or_else(|| panic!("{deg}°: a lying bottle is elongated"));
            let along = (f.major_axis[0] * axis.x + f.major_axis[1] * axis.y).abs();
            assert!(along > 0.98, "{deg}°: major axis {:?}", f.major_axis);
            if deg > 0.0 {
                assert!(
                    (0.065..0.12).contains(&f.half_major),
                    "{deg}°: half length {}",
                    f.half_major
                );
            } else {
                // Along the line of sight: it might as well stand.
                assert_eq!(f.half_major, radius);
            }
            let seen = SeenObject {
                centroid: center,
                extent: schema::SeenExtent {
                    height: 2.0 * radius,
                    center: f.center,
                    major_axis: f.major_axis,
                    half_major: f.half_major,
                    half_minor: f.half_minor,
                    model: "lying".into(),
                },
            };
            let plan = plan_top_grasp(&arc, &seen, table_z, &Iso3::identity());
            let closing = plan.grasp.rotation * Vec3::y();
            assert!(
                closing.dot(&axis).abs() < 0.26,
                "{deg}°: fingers close along {closing:?}"
            );
            assert!(plan.width < 0.08, "{deg}°: width {}", plan.width);
        }
        // A jar standing up (round-topped): the disc of its radius, across the line of sight.
        for (x, y) in [(0.6, 0.08), (0.75, 0.0), (0.45, -0.2)] {
            let c = Vec3::new(x, y, table_z + 0.0475);
            let standing = |p: Vec3| {
                let d = p - c;
                d.z.abs() <= 0.0475 && d.xy().norm() <= 0.04
            };
            let ((ul, cl), (ur, cr)) = (silhouette(&l, standing), silhouette(&r, standing));
            let f = lying_footprint([(ul, cl, &l), (ur, cr, &r)], &Vec3::new(x, y, table_z + 0.04), 0.04)
                .expect("a standing jar's silhouette is elongated");
            assert_eq!((f.half_major, f.half_minor), (0.04, 0.04), "at ({x}, {y})");
        }
        let ball = Vec3::new(0.6, 0.08, table_z + 0.04);
        let sphere = |p: Vec3| (p - ball).norm() <= 0.04;
        let ((ul, cl), (ur, cr)) = (silhouette(&l, sphere), silhouette(&r, sphere));
        assert!(lying_footprint([(ul, cl, &l), (ur, cr, &r)], &ball, 0.04).is_none());
    }
}
