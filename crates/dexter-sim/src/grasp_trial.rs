//! Grasp trials in the simulator: reach a given pre-grasp, close, lift, and judge the grasp by the
//! seed's criterion (§6.5): the hand rises 10 cm and the object is still held.
//!
//! A trial is one fresh simulation of a scene with a single presented object, so every trial starts
//! from the same state for a given seed and trials can run in any order or in parallel:
//!
//! 1. [`perceive`]: park the arms, Search-Track the object with the head and read off what the
//!    robot sees — the triangulated centroid and the appearance feature b of §6.2.1 (the 2×2 second
//!    moment of the segment averaged over the stereo pair), both averaged over the last tracked
//!    frames.
//! 2. [`execute`]: in a fresh simulation with the same seed (so the object rests where it was seen),
//!    pre-shape the hand, move high above an approach pose 10 cm behind the pre-grasp along the palm
//!    normal, descend to it, move along the palm normal to the pre-grasp, flex the fingers until they
//!    hold (or 3 s pass), lift the hand 10 cm and hold it still for 1 s. Success, judged by the robot
//!    on its own sensors as the seed's Dexter did: the Grasp predicate converged on the fingertips
//!    and, after the lift, two fingertips still carry a load (`dexter::skills::MIN_LOAD`). The
//!    world's view (how far the object really rose) is reported beside it.
//!
//! Pre-grasps are palm-surface poses (`bhand/palm_surface_link`: +z = palm normal = approach, finger
//! 3 on +y) in the world frame.

use std::time::Instant;

use control_basis::math::{Iso3, Vec3};
use serde::Serialize;

use control_basis::{Hardware, Plant};
use dexter::control::{FLEX_CLOSED, HandControl, ReachControl};
use dexter::eyes::Eyes;
use dexter::skills::{Observer, TouchState, hand_fingertips};

use crate::error::{SimError, from_robot};
use crate::hardware::{SimRobot, park_robot};
use crate::physics::{DexterSim, SimSettings};
use crate::scene::{ObjectPlacement, Scene, Shape};
use crate::snapshot::Arm;

/// Distance (m) of the approach pose behind the pre-grasp, along the palm normal.
pub const APPROACH_DISTANCE: f64 = 0.10;
/// How far (m) the hand is lifted after closing (§6.5).
pub const LIFT_HEIGHT: f64 = 0.10;
/// The object must rise at least this much (m) with the hand for a success.
pub const LIFT_SUCCESS: f64 = 0.08;

/// The scene of `base` with only `presentation` on the table, at `xy` (m, world) and `yaw_deg`.
pub fn present(base: &Scene, presentation: &str, xy: [f64; 2], yaw_deg: f64) -> Result<Scene, SimError> {
    base.with_objects(vec![ObjectPlacement {
        presentation: presentation.to_string(),
        xy,
        yaw_deg,
        z: None,
    }])
}

/// What the robot saw of the presented object (and, for reports only, where it really was).
#[derive(Debug, Clone, Serialize)]
pub struct Percept {
    /// The presentation name.
    pub presentation: String,
    /// Triangulated centroid (m, world): the origin of the pre-grasp frame.
    pub centroid: [f64; 3],
    /// b: the 2×2 second-moment matrix of the segment averaged over the stereo pair (px²).
    pub appearance: [[f64; 2]; 2],
    /// The measured height and footprint.
    pub extent: schema::SeenExtent,
    /// The table height the object rests on (m).
    pub table_z: f64,
    /// The object's true pose after settling (m, world; translation and quaternion `[w, x, y, z]`),
    /// not used by the robot.
    pub true_position: [f64; 3],
    /// Horizontal distance (m) between the seen and the true centroid.
    pub vision_error: f64,
    /// Frames averaged.
    pub frames: usize,
}

impl Percept {
    /// The centroid as a vector.
    pub fn centroid(&self) -> Vec3 {
        Vec3::from(self.centroid)
    }
}

fn settle(sim: &mut DexterSim, table_z: f64) -> Result<(), SimError> {
    park_robot(sim, table_z)?;
    for _ in 0..200 {
        sim.step();
    }
    Ok(())
}

/// Looks at the single object of `scene` (fresh simulation with `settings`) and returns what the
/// robot sees, or `Ok(Err(why))` if Search-Track finds no stereo blob near where it was presented.
pub fn perceive(scene: &Scene, settings: &SimSettings) -> Result<Result<Percept, String>, SimError> {
    let mut sim = DexterSim::new(scene, settings.clone())?;
    let table_z = scene.spec.table.height;
    settle(&mut sim, table_z)?;
    let name = scene
        .resolved
        .first()
        .map(|r| r.presentation.clone())
        .ok_or_else(|| SimError::Invalid {
            path: "<scene>".into(),
            field: "objects".into(),
            message: "the scene has no object to perceive".into(),
        })?;
    let nominal = scene.resolved[0].pose.translation.vector;
    let calibration = crate::calibrate::workcell_calibration(scene)?;
    let mut hw = SimRobot::new(&mut sim, scene, settings.seed ^ 0xE7E5)?;
    let mut eyes = Eyes::new(&hw, table_z, calibration).map_err(from_robot)?;
    let mut nobody = |_: &mut dyn Hardware, _: &str| {};
    let mut obs = Observer::new(&mut nobody);
    let frame = 1.0 / scene.spec.camera.rate_hz;
    let located =
        dexter::skills::locate_object(&mut hw, &mut eyes, &nominal, table_z, frame, &mut obs).map_err(from_robot)?;
    let located = match located {
        Ok(l) => l,
        Err(why) => return Ok(Err(why.message)),
    };
    let c = located.seen.centroid;
    let truth = hw.sim().object_state(0).pose.translation.vector;
    Ok(Ok(Percept {
        presentation: name,
        centroid: [c.x, c.y, c.z],
        appearance: located.appearance,
        extent: located.seen.extent,
        table_z,
        true_position: [truth.x, truth.y, truth.z],
        vision_error: (c.xy() - truth.xy()).norm(),
        frames: located.frames,
    }))
}

/// A pre-grasp to execute: palm pose, hand pre-shape and spread.
#[derive(Debug, Clone, Copy)]
pub struct PreGraspCommand {
    /// Palm-surface pose in the world at which the fingers start to close.
    pub world_from_palm: Iso3,
    /// Flexion of the pre-shape (rad, 0 = fingers straight out).
    pub preshape: f64,
    /// Spread of fingers 1 and 2 (rad): 0 opposes them to finger 3, π/3 spaces all three equally.
    pub spread: f64,
}

/// How a grasp trial went.
#[derive(Debug, Clone, Serialize)]
pub struct TrialOutcome {
    /// The §6.5 criterion judged on the robot's sensors: the Grasp predicate converged and, after
    /// the 10 cm lift, two fingertips still carry at least `dexter::skills::MIN_LOAD`.
    pub success: bool,
    /// The world's view, for the report only: the object rose ≥ 8 cm and ≥ 2 hand parts touch it.
    pub true_success: bool,
    /// The load the fingertips carried after the lift (N).
    pub load: f64,
    /// What happened (`lifted`, or why not).
    pub outcome: String,
    /// How far the object rose (m; the world's view).
    pub rose: f64,
    /// Distance (m) between the palm and the pre-grasp when the fingers started closing.
    pub pregrasp_error: f64,
    /// The palm pose when the fingers started closing (world; position and quaternion `[w, x, y, z]`):
    /// the pre-grasp the robot actually achieved.
    pub achieved_position: [f64; 3],
    /// Orientation part of the achieved pre-grasp.
    pub achieved_orientation: [f64; 4],
    /// Whether the fingers converged on opposing contacts before the lift.
    pub closed_on_object: bool,
    /// The deepest penetration (m) of the hand into the object, sampled after closing, after the
    /// lift and every 50 ms of the 1 s hold (the world's view).
    pub max_penetration: f64,
    /// Hand parts (palm, fingers) touching the object at the end of the hold (the world's view).
    pub touching_parts: usize,
    /// How far (m) the object sank in the hand between the end of closing and the end of the hold
    /// (its height below the palm grew by this much; the world's view).
    pub sank: f64,
    /// Simulated time (s).
    pub sim_time: f64,
    /// Wall-clock time (s).
    pub wall_time: f64,
}

/// Runs the hardware for up to `seconds`, ticking `reach` at the control rate; stops early when
/// `until` returns true. Returns whether it did. (The skills' loop, with nobody observing.)
fn run_until(
    hw: &mut dyn Hardware,
    reach: &mut ReachControl,
    seconds: f64,
    until: impl FnMut(&mut dyn Hardware, &mut ReachControl) -> bool,
) -> bool {
    let mut nobody = |_: &mut dyn Hardware, _: &str| {};
    dexter::skills::run_until(hw, reach, &mut Observer::new(&mut nobody), seconds, until)
}

/// Whether `arm` can put its palm at `pose` (IK within the joint limits, from the parked posture).
pub fn pose_reachable(sim: &DexterSim, arm: Arm, pose: &Iso3) -> Result<bool, SimError> {
    dexter::skills::reachable(sim.model(), arm, pose, 5).map_err(from_robot)
}

/// The waypoints before a pre-grasp `pre` (world palm pose): a hover pose and the approach pose
/// [`APPROACH_DISTANCE`] behind `pre` along the palm normal, both with `pre`'s orientation. The hand
/// reaches the hover pose first, then moves in straight lines to the approach pose and the
/// pre-grasp. When the approach pose lies on the arm's side of the object and outside its footprint,
/// the hover pose is the approach pose itself (a side approach from the robot); otherwise it is
/// high above it (12 cm above the object's top), so the arm cannot sweep through the object. The
/// object's centre, footprint and top are as the robot saw them (`seen`).
pub fn approach_waypoints(sim: &DexterSim, seen: &Percept, arm: Arm, pre: &Iso3) -> Result<(Iso3, Iso3), SimError> {
    let approach_dir = pre.rotation * Vec3::z();
    let mut back = *pre;
    back.translation.vector -= approach_dir * APPROACH_DISTANCE;
    let shoulder = sim
        .link_pose_by_name(&format!("{}/shoulder_yaw_link", arm.prefix()))?
        .translation
        .vector;
    let e = &seen.extent;
    let centre = Vec3::new(e.center[0], e.center[1], seen.table_z + 0.5 * e.height);
    let radius = e.half_major.hypot(e.half_minor);
    let rel = (back.translation.vector - centre).xy();
    let towards_arm = (shoulder - centre).xy();
    let near_side = rel.dot(&towards_arm) > 0.0 && rel.norm() > radius + 0.06;
    let mut hover = back;
    if !near_side {
        hover.translation.vector.z = back.translation.z.max(seen.table_z + e.height + 0.12);
    }
    Ok((hover, back))
}

fn quat(q: &control_basis::math::Rot3) -> [f64; 4] {
    let c = q.quaternion();
    [c.w, c.i, c.j, c.k]
}

/// Executes one pre-grasp with `arm` on the single object of `scene` (seen as `seen`) in a fresh
/// simulation with `settings` (see the module docs for the phases). Errors only for an unusable scene
/// or robot; a failed grasp is an outcome.
pub fn execute(
    scene: &Scene,
    settings: &SimSettings,
    arm: Arm,
    cmd: &PreGraspCommand,
    seen: &Percept,
) -> Result<TrialOutcome, SimError> {
    let wall = Instant::now();
    let mut sim = DexterSim::new(scene, settings.clone())?;
    let table_z = scene.spec.table.height;
    settle(&mut sim, table_z)?;
    let t0 = sim.time();
    let obj = 0;
    let pre = cmd.world_from_palm;
    let (hover, back) = approach_waypoints(&sim, seen, arm, &pre)?;
    let mut hw = SimRobot::new(&mut sim, scene, settings.seed ^ 0xE7E5)?;
    let r = from_robot;
    let mut reach = ReachControl::new(&hw, arm).map_err(r)?;
    let hand = HandControl::new(&hw, arm).map_err(r)?;
    let mut out = TrialOutcome {
        success: false,
        true_success: false,
        load: 0.0,
        outcome: String::new(),
        rose: 0.0,
        pregrasp_error: f64::NAN,
        achieved_position: [f64::NAN; 3],
        achieved_orientation: [f64::NAN; 4],
        closed_on_object: false,
        max_penetration: 0.0,
        sank: 0.0,
        touching_parts: 0,
        sim_time: 0.0,
        wall_time: 0.0,
    };
    let finish = |mut o: TrialOutcome, hw: &SimRobot<'_>, why: String| {
        o.outcome = why;
        o.sim_time = hw.time_secs() - t0;
        o.wall_time = wall.elapsed().as_secs_f64();
        o
    };
    hand.set(&mut hw, cmd.preshape, cmd.spread);
    reach.max_speed = 0.3;
    reach.set_goal(&hw, hover);
    if !run_until(&mut hw, &mut reach, 5.0, |h, r| r.at_goal(h, 0.015, 0.05)) {
        match reach.set_goal_via_ik(&hw, hover, 17) {
            Ok(true) => {}
            _ => return Ok(finish(out, &hw, "approach out of reach (no IK solution)".into())),
        }
        if !run_until(&mut hw, &mut reach, 8.0, |h, r| r.at_goal(h, 0.015, 0.05)) {
            let (d, _) = reach.goal_error(&hw);
            return Ok(finish(
                out,
                &hw,
                format!("approach not reached ({:.1} cm away)", d * 100.0),
            ));
        }
    }
    reach.max_speed = 0.2;
    reach.set_goal(&hw, back);
    if !run_until(&mut hw, &mut reach, 4.0, |h, r| r.at_goal(h, 0.01, 0.05)) {
        let (d, _) = reach.goal_error(&hw);
        return Ok(finish(
            out,
            &hw,
            format!("approach pose not reached ({:.1} cm away)", d * 100.0),
        ));
    }
    // Along the palm normal to the pre-grasp. If the hand meets the object first it pushes it; after
    // 3 s the fingers close wherever the hand is (the robot "achieved the pre-grasp" as well as it could).
    reach.max_speed = 0.12;
    reach.set_goal(&hw, pre);
    run_until(&mut hw, &mut reach, 3.0, |h, r| r.at_goal(h, 0.004, 0.03));
    let achieved = reach.tool_pose(&hw);
    out.pregrasp_error = (achieved.translation.vector - pre.translation.vector).norm();
    let a = achieved.translation.vector;
    out.achieved_position = [a.x, a.y, a.z];
    out.achieved_orientation = quat(&achieved.rotation);
    // Close: flex until the Grasp predicate converges on the fingertips (two fingers loaded, F3
    // opposing, the fingers still).
    hand.set(&mut hw, FLEX_CLOSED, cmd.spread);
    let mut still = 0;
    let mut buf = Vec::new();
    out.closed_on_object = run_until(&mut hw, &mut reach, 3.0, |h, _| {
        let t = TouchState::of(&hand_fingertips(h, arm, &mut buf));
        if t.holding() && hand.max_flex_speed(h) < 0.1 {
            still += 1;
        } else {
            still = 0;
        }
        still >= 30
    });
    // Lift 10 cm straight up, then hold still and weigh on the fingertips.
    let z_before = hw.sim().object_state(obj).pose.translation.z;
    let below_palm = |hw: &SimRobot<'_>, reach: &mut ReachControl| {
        reach.tool_pose(hw).translation.z - hw.sim().object_state(obj).pose.translation.z
    };
    let below_at_close = below_palm(&hw, &mut reach);
    let mut deepest = hw.sim().hand_penetration_on_object(arm, obj);
    let mut lift = reach.tool_pose(&hw);
    lift.translation.vector.z += LIFT_HEIGHT;
    reach.max_speed = 0.10;
    reach.set_goal(&hw, lift);
    run_until(&mut hw, &mut reach, 3.0, |h, r| r.at_goal(h, 0.005, 0.03));
    deepest = deepest.max(hw.sim().hand_penetration_on_object(arm, obj));
    for _ in 0..10 {
        run_until(&mut hw, &mut reach, 0.05, |_, _| false);
        deepest = deepest.max(hw.sim().hand_penetration_on_object(arm, obj));
    }
    let (mut load, mut loaded, mut n) = (0.0, usize::MAX, 0.0);
    for _ in 0..10 {
        run_until(&mut hw, &mut reach, 0.05, |h, _| {
            let t = TouchState::of(&hand_fingertips(h, arm, &mut buf));
            load += t.load;
            loaded = loaded.min(t.loaded);
            n += 1.0;
            false
        });
        deepest = deepest.max(hw.sim().hand_penetration_on_object(arm, obj));
    }
    out.max_penetration = deepest;
    out.sank = below_palm(&hw, &mut reach) - below_at_close;
    let load = load / f64::max(n, 1.0);
    let loaded = if loaded == usize::MAX { 0 } else { loaded };
    let rose = hw.sim().object_state(obj).pose.translation.z - z_before;
    let (_, _, parts) = hw.sim().hand_wrench_on_object(arm, obj);
    out.rose = rose;
    out.touching_parts = parts;
    out.load = load;
    out.true_success = rose > LIFT_SUCCESS && parts >= 2;
    out.success = out.closed_on_object && loaded >= 2 && load >= dexter::skills::MIN_LOAD;
    let why = if out.success {
        "lifted".to_string()
    } else if !out.closed_on_object {
        format!("the fingers closed without a grasp ({loaded} loaded fingertips, load {load:.2} N)")
    } else {
        format!("not held after the lift ({loaded} loaded fingertips, load {load:.2} N)")
    };
    Ok(finish(out, &hw, why))
}

/// The world pose of link `name` after parking the arms of a fresh simulation of `scene` (e.g. the
/// shoulder that candidate pre-grasps are ranked from).
pub fn parked_link_pose(scene: &Scene, settings: &SimSettings, name: &str) -> Result<Iso3, SimError> {
    let mut sim = DexterSim::new(scene, settings.clone())?;
    park_robot(&mut sim, scene.spec.table.height)?;
    sim.link_pose_by_name(name)
}

/// A robot to test reachability with (parked, no stepping).
pub fn parked_sim(scene: &Scene, settings: &SimSettings) -> Result<DexterSim, SimError> {
    let mut sim = DexterSim::new(scene, settings.clone())?;
    park_robot(&mut sim, scene.spec.table.height)?;
    Ok(sim)
}

/// The kind of grasp the scripted teacher demonstrates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum DemoKind {
    /// Palm down over the object, fingers closing across its narrow horizontal axis.
    Top,
    /// Palm facing the object from the robot's side, fingers closing horizontally around it.
    Side,
}

/// Flexion (rad) of the pre-shape used for every executed pre-grasp: wide open, so the hand can
/// approach any catalog object.
pub const PRESHAPE: f64 = 0.3;

/// The scripted, human-like grasp teacher (§6.5: grasps demonstrated by teleoperation). It sees
/// the object as a person does (its true shape and pose) and demonstrates what a person would: a
/// side grasp at mid-height for tall objects (height ≥ 13 cm and ≥ 1.4 × the wider horizontal
/// extent), otherwise a top-down grasp across the narrow horizontal axis with the palm just above
/// the object, deep enough for the fingertips to close at mid-height (as in
/// [`crate::pick_place::plan_top_grasp_shape`]). Each demonstration jitters the hand like a person does: position
/// σ 6 mm horizontally and 4 mm vertically, yaw σ 5°.
#[derive(Debug, Clone)]
pub struct GraspTeacher {
    arm: Arm,
    arc: Vec<(f64, f64, f64)>,
    shoulder: Vec3,
    park: Iso3,
    rng: bayes::rng::Generator,
}

impl GraspTeacher {
    /// A teacher demonstrating with `arm` of a parked `sim` over a table at `table_z`; noise from
    /// `seed`.
    pub fn new(sim: &DexterSim, arm: Arm, table_z: f64, seed: u64) -> Result<Self, SimError> {
        Ok(GraspTeacher {
            arm,
            arc: dexter::skills::finger_arc(sim.model(), arm).map_err(from_robot)?,
            shoulder: sim
                .link_pose_by_name(&format!("{}/shoulder_yaw_link", arm.prefix()))?
                .translation
                .vector,
            park: dexter::skills::park_pose(arm, table_z),
            rng: bayes::rng::seeded(seed ^ 0x7EAC_4E55),
        })
    }

    /// The kind of grasp this teacher demonstrates on the single object of `scene`.
    pub fn kind(scene: &Scene) -> DemoKind {
        let Some(r) = scene.resolved.first() else {
            return DemoKind::Top;
        };
        let shape = &scene.catalog.objects[r.object].shape;
        let inv = r.pose.rotation.inverse();
        let h = 2.0 * crate::geometry::support_half_extent(shape, &(inv * Vec3::z()));
        let wx = 2.0 * crate::geometry::support_half_extent(shape, &(inv * Vec3::x()));
        let wy = 2.0 * crate::geometry::support_half_extent(shape, &(inv * Vec3::y()));
        if h >= 0.13 && h >= 1.4 * wx.max(wy) {
            DemoKind::Side
        } else {
            DemoKind::Top
        }
    }

    /// One demonstrated pre-grasp on the single object of `scene` (without noise if `exact`).
    pub fn demonstrate(&mut self, scene: &Scene, exact: bool) -> Result<(DemoKind, PreGraspCommand), SimError> {
        let r = scene.resolved.first().ok_or_else(|| SimError::Invalid {
            path: "<scene>".into(),
            field: "objects".into(),
            message: "the scene has no object to grasp".into(),
        })?;
        let shape = scene.catalog.objects[r.object].shape.clone();
        let pose = r.pose;
        let table_z = scene.spec.table.height;
        let kind = Self::kind(scene);
        let mut noise = [0.0; 4];
        if !exact {
            for n in noise.iter_mut() {
                *n = bayes::rng::Draw::normal(&mut self.rng);
            }
        }
        let (dx, dy, dz, dyaw) = (
            0.006 * noise[0],
            0.006 * noise[1],
            0.004 * noise[2],
            5f64.to_radians() * noise[3],
        );
        let mut palm = match kind {
            DemoKind::Top => {
                let plan = crate::pick_place::plan_top_grasp_shape(&self.arc, &shape, &pose, table_z, &self.park);
                let mut g = plan.grasp;
                g.translation.vector.z += dz.abs();
                g
            }
            DemoKind::Side => self.side_grasp(&shape, &pose, table_z, dz),
        };
        palm.translation.vector.x += dx;
        palm.translation.vector.y += dy;
        palm.rotation = control_basis::math::Rot3::from_axis_angle(&Vec3::z_axis(), dyaw) * palm.rotation;
        Ok((
            kind,
            PreGraspCommand {
                world_from_palm: palm,
                preshape: PRESHAPE,
                spread: 0.0,
            },
        ))
    }

    fn side_grasp(&self, shape: &Shape, pose: &Iso3, table_z: f64, dz: f64) -> Iso3 {
        const TIP_RADIUS: f64 = 0.01;
        let c = pose.translation.vector;
        // Approach horizontally from the shoulder's side.
        let mut a = c - self.shoulder;
        a.z = 0.0;
        let a = a.try_normalize(1e-9).unwrap_or_else(Vec3::x);
        let h = Vec3::z().cross(&a);
        let inv = pose.rotation.inverse();
        let half_width = crate::geometry::support_half_extent(shape, &(inv * h));
        let half_depth = crate::geometry::support_half_extent(shape, &(inv * a));
        let half_height = crate::geometry::support_half_extent(shape, &(inv * Vec3::z()));
        let target_lateral = half_width + TIP_RADIUS - 0.004;
        let max_depth = self.arc.iter().map(|p| p.2).fold(f64::NEG_INFINITY, f64::max);
        let contact_depth = self
            .arc
            .iter()
            .find(|p| p.1 <= target_lateral)
            .map(|p| p.2)
            .unwrap_or(max_depth);
        let d = contact_depth.max(half_depth + 0.008);
        // Palm at mid-height, a little above for short ones so the palm box clears the table.
        let bottom = c.z - half_height;
        let z = (bottom + half_height + dz).max(table_z + 0.055);
        let p = c - a * d;
        // Finger 3 on ±h, whichever turns the hand less from the parked pose.
        let mut best = (f64::INFINITY, control_basis::math::Rot3::identity());
        for s in [1.0, -1.0] {
            let y = h * s;
            let x = y.cross(&a);
            let r = control_basis::math::Rot3::from_matrix(&nalgebra::Matrix3::from_columns(&[x, y, a]));
            let ang = r.angle_to(&self.park.rotation);
            if ang < best.0 {
                best = (ang, r);
            }
        }
        Iso3::from_parts(nalgebra::Translation3::new(p.x, p.y, z), best.1)
    }

    /// The arm.
    pub fn arm(&self) -> Arm {
        self.arm
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Probe (release, by hand): teacher demonstrations on a few presentations.
    #[test]
    #[ignore = "a probe to run by hand (release): the grasp teacher on a few presentations"]
    fn probe_teacher() {
        let base = Scene::builtin("pick-place").unwrap();
        let settings = SimSettings {
            seed: 1,
            ..SimSettings::default()
        };
        let names: Vec<String> = std::env::var("PROBE")
            .unwrap_or_else(|_| "jif,black_thermos,pink_drano,blue_ball,blue_cereal,cucumber".into())
            .split(',')
            .map(String::from)
            .collect();
        for name in names {
            let scene = present(&base, &name, [0.55, 0.0], 0.0).unwrap();
            let t = Instant::now();
            let p = perceive(&scene, &settings).unwrap().unwrap();
            let tp = t.elapsed().as_secs_f64();
            let sim = parked_sim(&scene, &settings).unwrap();
            let mut teacher = GraspTeacher::new(&sim, Arm::Right, 0.75, 3).unwrap();
            for k in 0..2 {
                let (kind, cmd) = teacher.demonstrate(&scene, k == 0).unwrap();
                let o = execute(&scene, &settings, Arm::Right, &cmd, &p).unwrap();
                println!(
                    "{name}: b {:?} err {:.4} perceive {tp:.1}s | {kind:?} {} rose {:.3} pre-err {:.3} sim {:.1}s wall {:.1}s",
                    p.appearance, p.vision_error, o.outcome, o.rose, o.pregrasp_error, o.sim_time, o.wall_time
                );
            }
        }
    }
}
