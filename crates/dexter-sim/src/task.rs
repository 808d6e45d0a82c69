//! Pick-and-place on the simulated Dexter, sequenced from control-basis controllers:
//! Reach (pre-grasp) → Reach (descend) → Grasp → Reach (lift) → Reach (transport) → Place (lower until
//! the support force reference is met) → open → Reach (retreat). Every transition is taken on a
//! controller's convergence predicate or a sensor event, never on a scripted joint trajectory.

use std::time::Instant;

use control_basis::math::{Iso3, Vec3};
use control_basis::{Chain, IkSettings, inverse_kinematics};
use nalgebra::Translation3;
use serde::Serialize;

use crate::control::{FLEX_CLOSED, HandControl, ReachControl, top_down_orientation};
use crate::error::SimError;
use crate::geometry;
use crate::perception::{Eyes, Pair, SearchTrack};
use crate::physics::{DexterSim, SimSettings};
use crate::scene::{PlaceSpec, Scene, Shape};
use crate::snapshot::{Arm, FingertipWrench};

/// Control rate (Hz): the control-basis stack runs every `1 / CONTROL_HZ` s of simulated time.
pub const CONTROL_HZ: f64 = 200.0;

/// Height of the palm surface above the table when an arm is parked (m).
const PARK_HEIGHT: f64 = 0.32;

/// What a pick-and-place was asked to do.
#[derive(Debug, Clone)]
pub struct PickPlaceRequest {
    /// Object name (presentation, as in the scene).
    pub object: String,
    /// Place name.
    pub place: String,
    /// Arm, or `None` to choose one that reaches both the object and the place.
    pub arm: Option<Arm>,
}

/// How one pick-and-place went.
#[derive(Debug, Clone, Serialize)]
pub struct PickPlaceReport {
    /// The object.
    pub object: String,
    /// The place.
    pub place: String,
    /// The arm used.
    pub arm: Arm,
    /// Object at rest inside the place region at the end.
    pub success: bool,
    /// Phase reached and why it ended.
    pub outcome: String,
    /// Whether the grasp held through the lift (hand 10 cm up, object still held).
    pub lifted: bool,
    /// Phases with their start times (s).
    pub phases: Vec<(String, f64)>,
    /// Simulated time (s).
    pub sim_time: f64,
    /// Physics steps.
    pub steps: u64,
    /// Wall-clock time (s).
    pub wall_time: f64,
    /// Simulated seconds per wall-clock second.
    pub real_time_factor: f64,
    /// Final object position (m, world).
    pub final_position: [f64; 3],
    /// The object weighed through the fingertip sensors after the lift: (measured, true m·g) in N.
    pub weighed: Option<(f64, f64)>,
    /// Horizontal distance between the stereo-triangulated centroid used for the grasp and the true
    /// centroid (m).
    pub vision_error: Option<f64>,
    /// Force closure of the grasp: (closure, margin, grasp-map rank).
    pub force_closure: Option<(bool, f64, usize)>,
}

/// A top-down grasp for an object: where the palm surface goes and how the fingers close.
#[derive(Debug, Clone, Copy)]
pub struct GraspPlan {
    /// Palm-surface pose at the grasp.
    pub grasp: Iso3,
    /// Flexion of the pre-shape (rad).
    pub preshape: f64,
    /// Object width across the fingers (m).
    pub width: f64,
}

/// Fingertip geometry of the BarrettHand, sampled along the flexion arc of finger 3 in the palm
/// surface frame: (flexion, lateral distance of the tip centre from the palm axis, depth below the
/// palm surface).
pub fn finger_arc(sim: &DexterSim, arm: Arm) -> Result<Vec<(f64, f64, f64)>, SimError> {
    let p = arm.prefix();
    let chain = Chain::new(
        sim.model(),
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

/// Plans a top-down grasp of an object with shape `shape` whose frame is at `pose` resting on a table
/// at `table_z`, for a hand currently at orientation `current`.
pub fn plan_top_grasp(arc: &[(f64, f64, f64)], shape: &Shape, pose: &Iso3, table_z: f64, current: &Iso3) -> GraspPlan {
    const TIP_RADIUS: f64 = 0.01;
    // Horizontal extents of the object along world x and y directions of its own footprint.
    let r = pose.rotation;
    let half = |d: Vec3| geometry::support_half_extent(shape, &(r.inverse() * d));
    // The narrower horizontal axis: test a few directions in the object's footprint.
    let mut best = (f64::INFINITY, Vec3::x());
    for k in 0..36 {
        let a = std::f64::consts::PI * k as f64 / 36.0;
        let d = Vec3::new(a.cos(), a.sin(), 0.0);
        let w = half(d);
        if w < best.0 - 1e-9 {
            best = (w, d);
        }
    }
    let (half_width, axis) = best;
    let top = pose.translation.z + half(Vec3::z());
    let bottom = pose.translation.z - half(-Vec3::z());
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
    let grasp = Iso3::from_parts(Translation3::new(pose.translation.x, pose.translation.y, palm_z), rot);
    GraspPlan {
        grasp,
        preshape,
        width: 2.0 * half_width,
    }
}

/// Whether `arm` can put its palm at `pose` (IK within limits).
pub fn reachable(sim: &DexterSim, arm: Arm, pose: &Iso3, seed: u64) -> Result<bool, SimError> {
    let chain = Chain::new(sim.model(), "world", &crate::control::tool_link(arm))?;
    let settings = IkSettings {
        position_tolerance: 2e-3,
        orientation_tolerance: 2e-2,
        restarts: 20,
        seed,
        ..IkSettings::default()
    };
    let q0 = home_arm_guess(arm);
    let sol = inverse_kinematics(&chain, pose, &q0, &settings)?;
    Ok(sol.converged)
}

/// A start for IK near the parked posture. The arms are mirror images under
/// `q_right = S q_left`, `S = diag(−1, 1, −1, 1, −1, 1, −1)` (assets/README-dexter.md), so the guess,
/// symmetric under S, serves both.
fn home_arm_guess(_arm: Arm) -> [f64; 7] {
    [0.0, 0.9, 0.0, 1.6, 0.0, 0.0, 0.0]
}

/// The parked pose of an arm's palm: above the near corner of the table on its own side.
pub fn park_pose(arm: Arm, table_z: f64) -> Iso3 {
    let s = if arm == Arm::Left { 1.0 } else { -1.0 };
    let rot = top_down_orientation(&Vec3::x(), &control_basis::math::Rot3::identity());
    Iso3::from_parts(Translation3::new(0.42, s * 0.32, table_z + PARK_HEIGHT), rot)
}

/// Puts both arms at their parked poses (IK), hands open; used at the start of a run.
pub fn park_robot(sim: &mut DexterSim, table_z: f64) -> Result<(), SimError> {
    let mut q = sim.joint_positions().to_vec();
    let mut left_solution: Option<nalgebra::DVector<f64>> = None;
    for arm in Arm::BOTH {
        let chain = Chain::new(sim.model(), "world", &crate::control::tool_link(arm))?;
        let settings = IkSettings {
            position_tolerance: 1e-4,
            orientation_tolerance: 1e-3,
            restarts: 50,
            seed: 1,
            ..IkSettings::default()
        };
        // The right arm starts from the mirror image of the left solution, so both park alike.
        let guess = match (arm, left_solution.as_ref()) {
            (Arm::Right, Some(ql)) => {
                let s = [-1.0, 1.0, -1.0, 1.0, -1.0, 1.0, -1.0];
                std::array::from_fn(|i| ql[i] * s[i])
            }
            _ => home_arm_guess(arm),
        };
        let sol = inverse_kinematics(&chain, &park_pose(arm, table_z), &guess, &settings)?;
        if arm == Arm::Left {
            left_solution = Some(sol.q.clone());
        }
        if !sol.converged {
            return Err(SimError::Task(format!(
                "cannot park the {arm} arm (IK error {:.3} m)",
                sol.position_error
            )));
        }
        let binding = control_basis::ChainBinding::by_name(&chain, sim.joint_names())?;
        binding.scatter(sol.q.as_slice(), &mut q);
    }
    // Head: look down at the table centre.
    if let Ok(t) = sim.dof("head/tilt_joint") {
        q[t] = 0.75;
    }
    sim.set_configuration(&q)
}

/// Runs the simulation for `seconds`, ticking `reach` at the control rate and calling `tick` after
/// every control step; stops early when `until` returns true. Returns whether `until` fired.
pub fn run_until(
    sim: &mut DexterSim,
    reach: &mut ReachControl,
    obs: &mut Observer<'_>,
    seconds: f64,
    mut until: impl FnMut(&mut DexterSim, &mut ReachControl) -> bool,
) -> bool {
    let dt_c = 1.0 / CONTROL_HZ;
    let per = ((dt_c / sim.settings().dt).round() as usize).max(1);
    let n = (seconds * CONTROL_HZ).ceil() as usize;
    for _ in 0..n {
        reach.tick(sim, dt_c);
        for _ in 0..per {
            sim.step();
        }
        (obs.callback)(sim, obs.activity);
        if until(sim, reach) {
            return true;
        }
    }
    false
}

/// Receives the head's stereo images (left, right) with the simulator.
pub type ImageCallback<'a> = dyn FnMut(&DexterSim, &crate::vision::Image, &crate::vision::Image) + 'a;

/// Receives the simulator after every control tick with a description of the current activity
/// (for logs, progress and visualisation).
pub struct Observer<'a> {
    callback: &'a mut dyn FnMut(&DexterSim, &str),
    images: Option<&'a mut ImageCallback<'a>>,
    activity: &'static str,
}

impl std::fmt::Debug for Observer<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Observer").field("activity", &self.activity).finish()
    }
}

impl<'a> Observer<'a> {
    /// An observer calling `callback(sim, activity)` after every control tick.
    pub fn new(callback: &'a mut dyn FnMut(&DexterSim, &str)) -> Self {
        Observer {
            callback,
            images: None,
            activity: "",
        }
    }

    /// Also receive the head's stereo images (left, right) every time the robot looks.
    pub fn with_images(mut self, images: &'a mut ImageCallback<'a>) -> Self {
        self.images = Some(images);
        self
    }
}

/// How a grasp-and-lift went (the seed's grasp criterion, §6.5: the hand rises 10 cm and the object
/// is still held).
#[derive(Debug, Clone, Serialize)]
pub struct GraspOutcome {
    /// The object rose ≥ 8 cm with the hand and ≥ 2 hand parts still touch it.
    pub lifted: bool,
    /// What happened.
    pub outcome: String,
    /// How far the object rose (m).
    pub rose: f64,
    /// The object weighed through the fingertip sensors while held still after the lift:
    /// (measured N, true m·g N), if it was lifted.
    pub weighed: Option<(f64, f64)>,
    /// Force closure of the grasp when the Grasp predicate converged: (closure, margin, rank of
    /// the grasp map), from the contacts' positions, normals and friction (SOCP).
    pub force_closure: Option<(bool, f64, usize)>,
}

/// Reach the pre-grasp 10 cm above `plan.grasp` with the hand pre-shaped, descend, close until the
/// Grasp predicate converges (opposing fingers in contact, hand still), lift 10 cm, hold still and
/// weigh the object through the fingertip sensors. `phase(name, time)` is told when each phase begins.
pub fn grasp_and_lift(
    sim: &mut DexterSim,
    reach: &mut ReachControl,
    hand: &HandControl,
    obj: usize,
    plan: &GraspPlan,
    obs: &mut Observer<'_>,
    phase: &mut dyn FnMut(&str, f64),
) -> GraspOutcome {
    let fail = |outcome: String| GraspOutcome {
        lifted: false,
        outcome,
        rose: 0.0,
        weighed: None,
        force_closure: None,
    };
    let plan = match approach_grasp(sim, reach, hand, plan, obs, phase) {
        Ok(p) => p,
        Err(why) => return fail(why),
    };
    phase("grasp", sim.time());
    let closure = match close_grasp(sim, reach, hand, obj, obs) {
        Ok(c) => c,
        Err(why) => return fail(why),
    };
    phase("lift", sim.time());
    let mut g = lift_and_weigh(sim, reach, obj, &plan, obs);
    g.force_closure = closure;
    g
}

/// Reach (§3.1) to the pre-grasp 10 cm above `plan.grasp` with the hand pre-shaped — a straight line
/// at hover height, the configuration servo if that stalls — then descend to the grasp pose. Returns
/// the plan actually used (F3 may be on either side: the IK solution nearer the current
/// configuration wins), or why the reach failed.
pub fn approach_grasp(
    sim: &mut DexterSim,
    reach: &mut ReachControl,
    hand: &HandControl,
    plan: &GraspPlan,
    obs: &mut Observer<'_>,
    phase: &mut dyn FnMut(&str, f64),
) -> Result<GraspPlan, String> {
    // 1. Pre-grasp: above the object, hand pre-shaped.
    obs.activity = "reach pre-grasp";
    hand.set(sim, plan.preshape, 0.0);
    // The hand is symmetric enough that F3 may be on either side: take the IK solution nearest the
    // current configuration among both.
    let mut best: Option<(f64, Iso3)> = None;
    let q_now = reach.chain_configuration(sim);
    for flip in [false, true] {
        let mut g = plan.grasp;
        if flip {
            g.rotation *= control_basis::math::Rot3::from_axis_angle(&Vec3::z_axis(), std::f64::consts::PI);
        }
        let mut pre = g;
        pre.translation.vector.z += 0.10;
        if let Ok(Some(q)) = reach.solve_ik(sim, &pre, 11 + flip as u64) {
            let d = (q - &q_now).amax();
            if best.as_ref().is_none_or(|b| d < b.0) {
                best = Some((d, g));
            }
        }
    }
    let Some((_, grasp_pose)) = best else {
        return Err("pre-grasp out of reach (no IK solution)".into());
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
        .max(reach.tool_pose(sim).translation.z)
        .max(pre.translation.z + 0.08);
    // First a straight line (Cartesian Reach ◁ Manipulability) at hover height; if it stalls (a
    // local minimum or a joint limit), the configuration servo to an IK solution takes over.
    reach.set_goal(sim, hover);
    if !run_until(sim, reach, obs, 5.0, |s, r| r.at_goal(s, 0.015, 0.05)) {
        match reach.set_goal_via_ik(sim, hover, 17) {
            Ok(true) => {}
            _ => return Err("hover above the object out of reach (no IK solution)".into()),
        }
        if !run_until(sim, reach, obs, 8.0, |s, r| r.at_goal(s, 0.015, 0.05)) {
            let (d, _) = reach.goal_error(sim);
            return Err(format!("hover above the object not reached ({:.1} cm away)", d * 100.0));
        }
    }
    reach.set_goal(sim, pre);
    if !run_until(sim, reach, obs, 4.0, |s, r| r.at_goal(s, 0.01, 0.05)) {
        let (d, _) = reach.goal_error(sim);
        return Err(format!("pre-grasp not reached ({:.1} cm away)", d * 100.0));
    }
    // 2. Descend.
    phase("reach grasp", sim.time());
    obs.activity = "reach grasp";
    reach.max_speed = 0.15;
    reach.set_goal(sim, plan.grasp);
    if !run_until(sim, reach, obs, 4.0, |s, r| r.at_goal(s, 0.004, 0.03)) {
        let (d, _) = reach.goal_error(sim);
        return Err(format!("grasp pose not reached ({:.1} cm away)", d * 100.0));
    }
    Ok(plan)
}

/// Grasp: close the hand until the Grasp predicate converges — F3 and F1 or F2 in contact with
/// object `obj`, two hand parts on it, and the fingers still for 0.15 s. Returns the force closure of
/// the converged grasp (closure, margin, grasp-map rank), or why it did not converge.
pub fn close_grasp(
    sim: &mut DexterSim,
    reach: &mut ReachControl,
    hand: &HandControl,
    obj: usize,
    obs: &mut Observer<'_>,
) -> Result<Option<(bool, f64, usize)>, String> {
    let arm = reach.arm();
    // 3. Grasp: close until fingers on both sides touch and the hand is still.
    obs.activity = "grasp";
    hand.set(sim, FLEX_CLOSED, 0.0);
    let mut still = 0;
    let k = if arm == Arm::Left { 0 } else { 3 };
    let mut tips = [FingertipWrench {
        arm,
        finger: 0,
        force: [0.0; 3],
        torque: [0.0; 3],
        in_contact: false,
    }; 6];
    let grasped = run_until(sim, reach, obs, 3.0, |s, _| {
        let (_, _, parts) = s.hand_wrench_on_object(arm, obj);
        s.fingertip_wrenches(&mut tips);
        let opposed = tips[k + 2].in_contact && (tips[k].in_contact || tips[k + 1].in_contact);
        if opposed && parts >= 2 && hand.max_flex_speed(s) < 0.1 {
            still += 1;
        } else {
            still = 0;
        }
        still >= 30
    });
    if !grasped {
        return Err("grasp did not converge (no opposing contacts)".into());
    }
    // Force closure of the converged grasp (SOCP, Murray–Li–Sastry): reported, not required — a
    // BarrettHand grasp with two fingers on one face may lack it and still lift by friction.
    let closure =
        control_basis::grasp::force_closure(&sim.hand_contacts_on_object(arm, obj), &sim.object_center_of_mass(obj))
            .ok();
    Ok(closure.map(|c| (c.closure, c.margin, c.rank)))
}

/// Lift 10 cm with the grasp, hold still and weigh the object through the fingertip sensors (the
/// seed's grasp criterion, §6.5: the hand rises 10 cm and the object is still held).
pub fn lift_and_weigh(
    sim: &mut DexterSim,
    reach: &mut ReachControl,
    obj: usize,
    plan: &GraspPlan,
    obs: &mut Observer<'_>,
) -> GraspOutcome {
    let arm = reach.arm();
    let k = if arm == Arm::Left { 0 } else { 3 };
    let mut tips = [FingertipWrench {
        arm,
        finger: 0,
        force: [0.0; 3],
        torque: [0.0; 3],
        in_contact: false,
    }; 6];
    // 4. Lift 10 cm.
    obs.activity = "lift";
    let z_before = sim.object_state(obj).pose.translation.z;
    let mut lift = plan.grasp;
    lift.translation.vector.z += 0.10;
    reach.max_speed = 0.10;
    reach.set_goal(sim, lift);
    run_until(sim, reach, obs, 3.0, |s, r| r.at_goal(s, 0.005, 0.03));
    // Hold still and weigh: the fingers carry the object, so Σ f_z = −m·g at rest.
    let mut quiet = 0;
    run_until(sim, reach, obs, 1.0, |s, _| {
        quiet = if s.object_state(obj).linvel.norm() < 0.002 {
            quiet + 1
        } else {
            0
        };
        quiet >= 20
    });
    let mut sum = 0.0;
    let mut n = 0usize;
    run_until(sim, reach, obs, 0.5, |s, _| {
        s.fingertip_wrenches(&mut tips);
        sum += -(tips[k].force[2] + tips[k + 1].force[2] + tips[k + 2].force[2]);
        n += 1;
        false
    });
    let rose = sim.object_state(obj).pose.translation.z - z_before;
    let (_, _, parts) = sim.hand_wrench_on_object(arm, obj);
    let lifted = rose > 0.08 && parts >= 2;
    let weight = sim.objects()[obj].mass * sim.settings().gravity;
    GraspOutcome {
        lifted,
        outcome: if lifted {
            "lifted".into()
        } else {
            format!(
                "object not held after lift (rose {:.1} cm, {parts} contacts)",
                rose * 100.0
            )
        },
        rose,
        weighed: lifted.then(|| (sum / n.max(1) as f64, weight)),
        force_closure: None,
    }
}

/// One pick-and-place in a fresh simulation of `scene`.
pub fn pick_and_place(
    scene: &Scene,
    request: &PickPlaceRequest,
    settings: SimSettings,
) -> Result<PickPlaceReport, SimError> {
    let mut sim = DexterSim::new(scene, settings)?;
    let mut nothing = |_: &DexterSim, _: &str| {};
    pick_and_place_in(&mut sim, scene, request, &mut Observer::new(&mut nothing))
}

/// One pick-and-place in an existing simulation, reporting every control tick to `obs`.
pub fn pick_and_place_in(
    sim: &mut DexterSim,
    scene: &Scene,
    request: &PickPlaceRequest,
    obs: &mut Observer<'_>,
) -> Result<PickPlaceReport, SimError> {
    let wall = Instant::now();
    let t0 = sim.time();
    let s0 = sim.steps();
    let table_z = scene.spec.table.height;
    let obj = sim.object(&request.object)?;
    let place: PlaceSpec = scene.place(&request.place)?.clone();
    park_robot(sim, table_z)?;
    // Let objects settle.
    for _ in 0..200 {
        sim.step();
    }
    let shape = scene.catalog.objects[sim.objects()[obj].catalog_index].shape.clone();
    // Search-Track with the head: find the object where the scene presented it, foveate it and
    // triangulate its centroid. The grasp is planned at the *seen* position; the object's shape
    // and resting orientation come from its catalog model.
    obs.activity = "search-track";
    let search_started = sim.time() - t0;
    let truth = sim.object_state(obj).pose;
    let nominal = scene.resolved[sim.objects()[obj].scene_index].pose.translation.vector;
    let seen = match locate_object(sim, scene, &nominal, obs)? {
        Ok(c) => c,
        Err(why) => {
            let p = truth.translation.vector;
            return Ok(PickPlaceReport {
                object: request.object.clone(),
                place: request.place.clone(),
                arm: request.arm.unwrap_or(Arm::Left),
                success: false,
                outcome: why,
                lifted: false,
                phases: vec![("search-track".into(), 0.0)],
                sim_time: sim.time() - t0,
                steps: sim.steps() - s0,
                wall_time: wall.elapsed().as_secs_f64(),
                real_time_factor: 0.0,
                final_position: [p.x, p.y, p.z],
                weighed: None,
                vision_error: None,
                force_closure: None,
            });
        }
    };
    // (Sliding the point along the viewing ray to the model's resting height was tried: it halves the
    // error of some tall boxes and adds 1 cm to tall cylinders, so the plain triangulation is used.)
    let (seen, _eye) = seen;
    let vision_error = (seen.xy() - truth.translation.vector.xy()).norm();
    let mut pose = truth;
    pose.translation.vector.x = seen.x;
    pose.translation.vector.y = seen.y;
    let arc_left = finger_arc(sim, Arm::Left)?;
    let candidates: &[Arm] = match &request.arm {
        Some(a) => std::slice::from_ref(a),
        None => &Arm::BOTH,
    };
    let arm = choose_arm(
        sim,
        &request.object,
        candidates,
        &arc_left,
        &shape,
        &pose,
        &place,
        table_z,
    )?;
    let arc = finger_arc(sim, arm)?;
    let mut reach = ReachControl::new(sim, arm)?;
    let hand = HandControl::new(sim, arm)?;
    let mut phases: Vec<(String, f64)> = vec![("search-track".into(), search_started)];
    let closure_cell = std::cell::Cell::new(None);
    let report = |sim: &DexterSim,
                  success: bool,
                  lifted: bool,
                  outcome: String,
                  phases: Vec<(String, f64)>,
                  weighed: Option<(f64, f64)>| {
        let p = sim.object_state(obj).pose.translation.vector;
        let wall_time = wall.elapsed().as_secs_f64();
        let sim_time = sim.time() - t0;
        PickPlaceReport {
            object: request.object.clone(),
            place: request.place.clone(),
            arm,
            success,
            outcome,
            lifted,
            phases,
            sim_time,
            steps: sim.steps() - s0,
            wall_time,
            real_time_factor: if wall_time > 0.0 { sim_time / wall_time } else { 0.0 },
            final_position: [p.x, p.y, p.z],
            weighed,
            vision_error: Some(vision_error),
            force_closure: closure_cell.get(),
        }
    };

    let current = reach.tool_pose(sim);
    let plan = plan_top_grasp(&arc, &shape, &pose, table_z, &current);
    phases.push(("reach pre-grasp".into(), sim.time() - t0));
    let g = grasp_and_lift(sim, &mut reach, &hand, obj, &plan, obs, &mut |name, t| {
        phases.push((name.into(), t - t0))
    });
    let weighed = g.weighed;
    closure_cell.set(g.force_closure);
    if !g.lifted {
        return Ok(report(sim, false, false, g.outcome, phases, weighed));
    }
    // 5. Transport: up to a safe height, over the place.
    phases.push(("transport".into(), sim.time() - t0));
    if let Err(why) = transport_over(
        sim,
        &mut reach,
        obj,
        &shape,
        [place.center[0], place.center[1]],
        table_z,
        place.wall_height,
        obs,
    ) {
        return Ok(report(sim, false, true, why, phases, weighed));
    }
    // 6. Place: lower until the support force reference is met (the bin carries half the weight).
    phases.push(("place".into(), sim.time() - t0));
    lower_until_supported(sim, &mut reach, obj, &shape, table_z, obs);
    phases.push(("release".into(), sim.time() - t0));
    release_and_retreat(sim, &mut reach, &hand, obs);
    phases.push(("retreat".into(), sim.time() - t0));
    run_until(sim, &mut reach, obs, 2.5, |s, _| {
        s.object_state(obj).linvel.norm() < 0.005
    });
    let state = sim.object_state(obj);
    let p = state.pose.translation.vector;
    let inside = (p.x - place.center[0]).abs() <= place.size[0] / 2.0
        && (p.y - place.center[1]).abs() <= place.size[1] / 2.0
        && p.z < table_z + place.wall_height + 0.2;
    let at_rest = state.linvel.norm() < 0.02;
    let success = inside && at_rest;
    let outcome = if success {
        "placed".to_string()
    } else if !inside {
        format!(
            "object ended outside {} at ({:.3}, {:.3}, {:.3})",
            place.name, p.x, p.y, p.z
        )
    } else {
        "object still moving".to_string()
    };
    Ok(report(sim, success, true, outcome, phases, weighed))
}

/// How far the bottom of grasped object `obj` (of shape `shape`) hangs below the palm surface (m).
fn object_bottom_below_palm(sim: &DexterSim, reach: &mut ReachControl, obj: usize, shape: &Shape) -> f64 {
    let op = sim.object_state(obj).pose;
    let palm = reach.tool_pose(sim);
    palm.translation.z
        - (op.translation.z - geometry::support_half_extent(shape, &(op.rotation.inverse() * -Vec3::z())))
}

/// Reach ◁ Grasp: carry grasped object `obj` up to a safe height (clearing walls of `wall_height`)
/// and over `target` (x, y of where the object's centre should go): a straight line, the
/// configuration servo if that stalls. Fails if the object was dropped or the place not reached.
#[allow(clippy::too_many_arguments)]
pub fn transport_over(
    sim: &mut DexterSim,
    reach: &mut ReachControl,
    obj: usize,
    shape: &Shape,
    target: [f64; 2],
    table_z: f64,
    wall_height: f64,
    obs: &mut Observer<'_>,
) -> Result<(), String> {
    obs.activity = "transport";
    let arm = reach.arm();
    let palm_to_object = reach.tool_pose(sim).inverse() * sim.object_state(obj).pose;
    let below = object_bottom_below_palm(sim, reach, obj, shape);
    let safe_z = table_z + wall_height + below + 0.08;
    let mut up = reach.tool_pose(sim);
    up.translation.vector.z = up.translation.vector.z.max(safe_z);
    reach.max_speed = 0.3;
    reach.set_goal(sim, up);
    run_until(sim, reach, obs, 3.0, |s, r| r.at_goal(s, 0.01, 0.05));
    // Over the target: object centre above it.
    let mut over = up;
    let obj_offset = (up.rotation * palm_to_object.translation.vector).xy();
    over.translation.vector.x = target[0] - obj_offset.x;
    over.translation.vector.y = target[1] - obj_offset.y;
    reach.set_goal(sim, over);
    let straight = run_until(sim, reach, obs, 6.0, |s, r| r.at_goal(s, 0.01, 0.05));
    if !straight && reach.set_goal_via_ik(sim, over, 23).unwrap_or(false) {
        run_until(sim, reach, obs, 8.0, |s, r| r.at_goal(s, 0.01, 0.05));
    }
    let (_, _, parts) = sim.hand_wrench_on_object(arm, obj);
    if parts < 2 {
        return Err("object dropped during transport".into());
    }
    if !reach.at_goal(sim, 0.01, 0.05) {
        let (d, _) = reach.goal_error(sim);
        return Err(format!("place not reached ({:.1} cm away)", d * 100.0));
    }
    Ok(())
}

/// Place (§3.3.3): lower the grasped object until the support force reference is met (the surface
/// carries half its weight), at most down to the table at `table_z`. Returns whether the reference
/// was met.
pub fn lower_until_supported(
    sim: &mut DexterSim,
    reach: &mut ReachControl,
    obj: usize,
    shape: &Shape,
    table_z: f64,
    obs: &mut Observer<'_>,
) -> bool {
    obs.activity = "place";
    let mass = sim.objects()[obj].mass;
    let weight = mass * sim.settings().gravity;
    let below = object_bottom_below_palm(sim, reach, obj, shape);
    let mut down = reach.tool_pose(sim);
    down.translation.vector.z = table_z + 0.002 + below - 0.02;
    reach.max_speed = 0.09;
    reach.set_goal(sim, down);
    let mut supported = 0;
    let touched = run_until(sim, reach, obs, 5.0, |s, _| {
        let f = s.support_force_on_object(obj);
        if f.z > 0.5 * weight {
            supported += 1;
        } else {
            supported = 0;
        }
        supported >= 4
    });
    if !touched {
        // The hand reached its lowest target without the support reference being met (the object
        // rests on a wall or another object, or is still held by friction): release anyway and let
        // the final state decide.
        obs.activity = "place (no support felt)";
    }
    touched
}

/// Release: hold the hand where it is, open it, and retreat 12 cm up.
pub fn release_and_retreat(sim: &mut DexterSim, reach: &mut ReachControl, hand: &HandControl, obs: &mut Observer<'_>) {
    let here = reach.tool_pose(sim);
    reach.set_goal(sim, here);
    obs.activity = "release";
    hand.set(sim, 0.3, 0.0);
    run_until(sim, reach, obs, 0.5, |_, _| false);
    obs.activity = "retreat";
    let mut away = here;
    away.translation.vector.z += 0.12;
    reach.max_speed = 0.3;
    reach.set_goal(sim, away);
    run_until(sim, reach, obs, 2.0, |s, r| r.at_goal(s, 0.01, 0.05));
}

/// Search-Track (§3.2.2.1): points the head at `nominal`, then foveates the blob nearest to the
/// running estimate at the camera rate until the tracking predicate converges, and returns the mean
/// triangulated centroid of the last frames with the cameras' mid-point (the eye it was seen from).
/// `Ok(Err(why))` if the object is not seen.
pub fn locate_object(
    sim: &mut DexterSim,
    scene: &Scene,
    nominal: &Vec3,
    obs: &mut Observer<'_>,
) -> Result<Result<(Vec3, Vec3), String>, SimError> {
    let mut eyes = Eyes::new(sim, scene, sim.settings().seed ^ 0xE7E5)?;
    let mut track = SearchTrack::new(sim)?;
    track.look_at(sim, nominal)?;
    let steps_per_frame = ((1.0 / scene.spec.camera.rate_hz) / sim.settings().dt).round().max(1.0) as usize;
    // Let the head get there (saccade).
    for _ in 0..(0.4 / sim.settings().dt) as usize {
        sim.step();
    }
    (obs.callback)(sim, obs.activity);
    let mut estimate = *nominal;
    let mut recent: Vec<Vec3> = Vec::new();
    let frame_dt = steps_per_frame as f64 * sim.settings().dt;
    for _frame in 0..30 {
        let cams = eyes.cameras(sim, Pair::Head)?;
        eyes.perceive(sim, Pair::Head)?;
        if let Some(f) = obs.images.as_mut() {
            let (l, r) = eyes.images(Pair::Head);
            f(sim, l, r);
        }
        let blobs = eyes.blobs();
        let nearest = blobs
            .iter()
            .filter_map(|b| b.centroid.map(|c| (b, (c - estimate).xy().norm())))
            .filter(|(_, d)| *d < 0.12)
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(b, _)| *b);
        let Some(blob) = nearest else {
            recent.clear();
            for _ in 0..steps_per_frame {
                sim.step();
            }
            continue;
        };
        let o = track.track(sim, &cams, &blob, frame_dt);
        if let Some(c) = o.centroid {
            estimate = c;
            if o.error < 4e-4 {
                recent.push(c);
            }
        }
        if recent.len() >= 3 {
            let mean = recent.iter().fold(Vec3::zeros(), |a, c| a + c) / recent.len() as f64;
            let eye = 0.5 * (cams.left.position() + cams.right.position());
            return Ok(Ok((mean, eye)));
        }
        for _ in 0..steps_per_frame {
            sim.step();
        }
        (obs.callback)(sim, obs.activity);
    }
    Ok(Err(format!(
        "search-track: no stereo blob foveated near ({:.2}, {:.2}, {:.2}) within 3 s",
        nominal.x, nominal.y, nominal.z
    )))
}

/// Chooses an arm that reaches the object's grasp and the place, preferring the one whose shoulder
/// is nearer the object.
#[allow(clippy::too_many_arguments)]
fn choose_arm(
    sim: &DexterSim,
    name: &str,
    candidates: &[Arm],
    arc: &[(f64, f64, f64)],
    shape: &Shape,
    pose: &Iso3,
    place: &PlaceSpec,
    table_z: f64,
) -> Result<Arm, SimError> {
    let mut order = candidates.to_vec();
    if pose.translation.y < 0.0 {
        order.reverse();
    }
    let mut reasons = Vec::new();
    for arm in order {
        let park = park_pose(arm, table_z);
        let plan = plan_top_grasp(arc, shape, pose, table_z, &park);
        let mut over = plan.grasp;
        over.translation.vector.x = place.center[0];
        over.translation.vector.y = place.center[1];
        over.translation.vector.z = table_z + place.wall_height + 0.15;
        let g = reachable(sim, arm, &plan.grasp, 3)?;
        let p = reachable(sim, arm, &over, 4)?;
        if g && p {
            return Ok(arm);
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
    let what = if candidates.len() == 1 {
        format!(
            "the {} arm cannot pick `{name}` and place it in `{}`",
            candidates[0], place.name
        )
    } else {
        format!("no single arm can pick `{name}` and place it in `{}`", place.name)
    };
    let hint = if candidates.len() == 1 {
        "try --arm auto"
    } else {
        "a hand-to-hand transfer is needed"
    };
    Err(SimError::Task(format!("{what}: {} ({hint})", reasons.join("; "))))
}
