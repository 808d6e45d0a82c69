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
use crate::physics::{DexterSim, SimSettings};
use crate::scene::{PlaceSpec, Scene, Shape};
use crate::snapshot::Arm;

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
fn finger_arc(sim: &DexterSim, arm: Arm) -> Result<Vec<(f64, f64, f64)>, SimError> {
    let p = arm.prefix();
    let chain = Chain::new(sim.model(), &format!("{p}/bhand/palm_surface_link"), &format!("{p}/bhand/finger_3/tip_link"))?;
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
pub fn plan_top_grasp(
    arc: &[(f64, f64, f64)],
    shape: &Shape,
    pose: &Iso3,
    table_z: f64,
    current: &Iso3,
) -> GraspPlan {
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
    let preshape = arc.iter().rev().find(|a| a.1 >= clear).map(|a| a.0).unwrap_or(0.0).min(0.9);
    let rot = top_down_orientation(&axis, &current.rotation);
    let grasp = Iso3::from_parts(Translation3::new(pose.translation.x, pose.translation.y, palm_z), rot);
    GraspPlan { grasp, preshape, width: 2.0 * half_width }
}

/// Whether `arm` can put its palm at `pose` (IK within limits).
pub fn reachable(sim: &DexterSim, arm: Arm, pose: &Iso3, seed: u64) -> Result<bool, SimError> {
    let chain = Chain::new(sim.model(), "world", &crate::control::tool_link(arm))?;
    let settings = IkSettings { position_tolerance: 2e-3, orientation_tolerance: 2e-2, restarts: 20, seed, ..IkSettings::default() };
    let q0 = home_arm_guess(arm);
    let sol = inverse_kinematics(&chain, pose, &q0, &settings)?;
    Ok(sol.converged)
}

fn home_arm_guess(arm: Arm) -> [f64; 7] {
    let s = if arm == Arm::Left { 1.0 } else { -1.0 };
    [0.0, s * 0.9, 0.0, 1.6, 0.0, 0.0, 0.0]
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
    for arm in Arm::BOTH {
        let chain = Chain::new(sim.model(), "world", &crate::control::tool_link(arm))?;
        let settings = IkSettings { position_tolerance: 1e-4, orientation_tolerance: 1e-3, restarts: 50, seed: 1, ..IkSettings::default() };
        let sol = inverse_kinematics(&chain, &park_pose(arm, table_z), &home_arm_guess(arm), &settings)?;
        if !sol.converged {
            return Err(SimError::Task(format!("cannot park the {arm} arm (IK error {:.3} m)", sol.position_error)));
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
fn run_until(
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

/// Receives the simulator after every control tick with a description of the current activity
/// (for logs, progress and visualisation).
pub struct Observer<'a> {
    callback: &'a mut dyn FnMut(&DexterSim, &str),
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
        Observer { callback, activity: "" }
    }
}

/// One pick-and-place in a fresh simulation of `scene`.
pub fn pick_and_place(scene: &Scene, request: &PickPlaceRequest, settings: SimSettings) -> Result<PickPlaceReport, SimError> {
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
    let pose = sim.object_state(obj).pose;
    let arc_left = finger_arc(sim, Arm::Left)?;
    let arm = match request.arm {
        Some(a) => a,
        None => choose_arm(sim, &request.object, &arc_left, &shape, &pose, &place, table_z)?,
    };
    let arc = finger_arc(sim, arm)?;
    let mut reach = ReachControl::new(sim, arm)?;
    let hand = HandControl::new(sim, arm)?;
    let mut phases: Vec<(String, f64)> = Vec::new();
    let report = |sim: &DexterSim, success: bool, lifted: bool, outcome: String, phases: Vec<(String, f64)>| {
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
        }
    };

    // 1. Pre-grasp: above the object, hand pre-shaped.
    let current = reach.tool_pose(sim);
    let plan = plan_top_grasp(&arc, &shape, &pose, table_z, &current);
    let mut pre = plan.grasp;
    pre.translation.vector.z += 0.10;
    phases.push(("reach pre-grasp".into(), sim.time() - t0));
    obs.activity = "reach pre-grasp";
    hand.set(sim, plan.preshape, 0.0);
    reach.set_goal(sim, pre);
    reach.max_speed = 0.35;
    if !run_until(sim, &mut reach, obs, 6.0, |s, r| r.at_goal(s, 0.01, 0.05)) {
        let (d, _) = reach.goal_error(sim);
        return Ok(report(sim, false, false, format!("pre-grasp not reached ({:.1} cm away)", d * 100.0), phases));
    }
    // 2. Descend.
    phases.push(("reach grasp".into(), sim.time() - t0));
    obs.activity = "reach grasp";
    reach.max_speed = 0.12;
    reach.set_goal(sim, plan.grasp);
    if !run_until(sim, &mut reach, obs, 4.0, |s, r| r.at_goal(s, 0.004, 0.03)) {
        let (d, _) = reach.goal_error(sim);
        return Ok(report(sim, false, false, format!("grasp pose not reached ({:.1} cm away)", d * 100.0), phases));
    }
    // 3. Grasp: close until the fingers on both sides touch and the hand is still.
    phases.push(("grasp".into(), sim.time() - t0));
    obs.activity = "grasp";
    if std::env::var_os("PBD_DEBUG").is_some() {
        eprintln!("plan {:?} width {:.3} preshape {:.2}; tool {:?}; object {:?}", plan.grasp.translation.vector, plan.width, plan.preshape, reach.tool_pose(sim).translation.vector, sim.object_state(obj).pose.translation.vector);
    }
    hand.set(sim, FLEX_CLOSED, 0.0);
    let mut still = 0;
    let grasped = run_until(sim, &mut reach, obs, 3.0, |s, _| {
        let (_, _, parts) = s.hand_wrench_on_object(arm, obj);
        let mut tips = [crate::snapshot::FingertipWrench { arm, finger: 0, force: [0.0; 3], torque: [0.0; 3], in_contact: false }; 6];
        s.fingertip_wrenches(&mut tips);
        let k = if arm == Arm::Left { 0 } else { 3 };
        let opposed = tips[k + 2].in_contact && (tips[k].in_contact || tips[k + 1].in_contact);
        if std::env::var_os("PBD_DEBUG").is_some() && (s.steps() % 100 == 0) {
            eprintln!(
                "t={:.2} flex={:?} parts={parts} tips={:?} obj={:?}",
                s.time(),
                hand.flexion(s),
                tips[k..k + 3].iter().map(|t| (t.in_contact, (t.force[0] * t.force[0] + t.force[1] * t.force[1] + t.force[2] * t.force[2]).sqrt())).collect::<Vec<_>>(),
                s.object_state(obj).pose.translation
            );
            let tipname = format!("{}/bhand/finger_3/tip_link", arm.prefix());
            let palmname = format!("{}/bhand/palm_surface_link", arm.prefix());
            eprintln!("   tip3 {:?} palm {:?} pairs {}", s.link_pose_by_name(&tipname).map(|p| p.translation.vector), s.link_pose_by_name(&palmname).map(|p| p.translation.vector), s.world().narrow_phase.contact_pairs().filter(|p| p.has_any_active_contact()).count());
        }
        if opposed && parts >= 2 && hand.max_flex_speed(s) < 0.1 {
            still += 1;
        } else {
            still = 0;
        }
        still >= 40
    });
    if !grasped {
        return Ok(report(sim, false, false, "grasp did not converge (no opposing contacts)".into(), phases));
    }
    // 4. Lift 10 cm.
    phases.push(("lift".into(), sim.time() - t0));
    obs.activity = "lift";
    let z_before = sim.object_state(obj).pose.translation.z;
    let mut lift = plan.grasp;
    lift.translation.vector.z += 0.10;
    reach.max_speed = 0.10;
    reach.set_goal(sim, lift);
    run_until(sim, &mut reach, obs, 3.0, |s, r| r.at_goal(s, 0.005, 0.03));
    run_until(sim, &mut reach, obs, 0.3, |_, _| false);
    let rose = sim.object_state(obj).pose.translation.z - z_before;
    let (_, _, parts) = sim.hand_wrench_on_object(arm, obj);
    let lifted = rose > 0.08 && parts >= 2;
    if !lifted {
        return Ok(report(sim, false, false, format!("object not held after lift (rose {:.1} cm, {parts} contacts)", rose * 100.0), phases));
    }
    // 5. Transport: up to a safe height, over the place.
    phases.push(("transport".into(), sim.time() - t0));
    obs.activity = "transport";
    let palm_to_object = reach.tool_pose(sim).inverse() * sim.object_state(obj).pose;
    let object_bottom_below_palm = {
        let op = sim.object_state(obj).pose;
        let palm = reach.tool_pose(sim);
        palm.translation.z - (op.translation.z - geometry::support_half_extent(&shape, &(op.rotation.inverse() * -Vec3::z())))
    };
    let safe_z = table_z + place.wall_height + object_bottom_below_palm + 0.08;
    let mut up = reach.tool_pose(sim);
    up.translation.vector.z = up.translation.vector.z.max(safe_z);
    reach.max_speed = 0.25;
    reach.set_goal(sim, up);
    run_until(sim, &mut reach, obs, 3.0, |s, r| r.at_goal(s, 0.01, 0.05));
    // Over the place: object centre above the place centre.
    let mut over = up;
    let obj_offset = (up.rotation * palm_to_object.translation.vector).xy();
    over.translation.vector.x = place.center[0] - obj_offset.x;
    over.translation.vector.y = place.center[1] - obj_offset.y;
    reach.set_goal(sim, over);
    if !run_until(sim, &mut reach, obs, 6.0, |s, r| r.at_goal(s, 0.01, 0.05)) {
        let (d, _) = reach.goal_error(sim);
        return Ok(report(sim, false, true, format!("place not reached ({:.1} cm away)", d * 100.0), phases));
    }
    // 6. Place: lower until the support force reference is met (the bin carries half the weight).
    phases.push(("place".into(), sim.time() - t0));
    obs.activity = "place";
    let mass = sim.objects()[obj].mass;
    let weight = mass * sim.settings().gravity;
    let mut down = over;
    down.translation.vector.z = table_z + 0.002 + object_bottom_below_palm - 0.02;
    reach.max_speed = 0.06;
    reach.set_goal(sim, down);
    let mut supported = 0;
    let touched = run_until(sim, &mut reach, obs, 5.0, |s, _| {
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
    // Hold position where it is, open the hand.
    let here = reach.tool_pose(sim);
    reach.set_goal(sim, here);
    phases.push(("release".into(), sim.time() - t0));
    obs.activity = "release";
    hand.set(sim, 0.3, 0.0);
    run_until(sim, &mut reach, obs, 0.8, |_, _| false);
    // 7. Retreat.
    phases.push(("retreat".into(), sim.time() - t0));
    obs.activity = "retreat";
    let mut away = here;
    away.translation.vector.z += 0.12;
    reach.max_speed = 0.2;
    reach.set_goal(sim, away);
    run_until(sim, &mut reach, obs, 2.0, |s, r| r.at_goal(s, 0.01, 0.05));
    run_until(sim, &mut reach, obs, 1.0, |s, _| s.object_state(obj).linvel.norm() < 0.005);
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
        format!("object ended outside {} at ({:.3}, {:.3}, {:.3})", place.name, p.x, p.y, p.z)
    } else {
        "object still moving".to_string()
    };
    Ok(report(sim, success, true, outcome, phases))
}

/// Chooses an arm that reaches the object's grasp and the place, preferring the one whose shoulder
/// is nearer the object.
fn choose_arm(
    sim: &DexterSim,
    name: &str,
    arc: &[(f64, f64, f64)],
    shape: &Shape,
    pose: &Iso3,
    place: &PlaceSpec,
    table_z: f64,
) -> Result<Arm, SimError> {
    let mut order = Arm::BOTH;
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
    Err(SimError::Task(format!(
        "no single arm can pick `{}` and place it in `{}`: {} (a hand-to-hand transfer is needed)",
        name,
        place.name,
        reasons.join("; ")
    )))
}
