//! Pick-and-place in the simulated world, evaluated: the robot side ([`dexter::skills`]) does the
//! task on [`SimRobot`] from what it senses; this module sets the world up, tells the robot where
//! the requested object was presented (a search hint, as a user pointing at it), and afterwards
//! reads the truth to judge and report the outcome.

use std::cell::RefCell;
use std::time::Instant;

use control_basis::math::{Iso3, Vec3};
use control_basis::{Hardware, Plant};
use dexter::control::{HandControl, ReachControl};
use dexter::eyes::Eyes;
use dexter::skills::{
    GraspPlan, Held, Observer, choose_arm, contact_center, finger_arc, grasp_and_lift, locate_object, plan_top_grasp,
    plan_top_grasp_geometry, release_and_retreat, set_down, transport_over,
};
use serde::Serialize;

use crate::error::{SimError, from_robot};
use crate::geometry;
use crate::hardware::{SimRobot, park_robot};
use crate::physics::{DexterSim, SimSettings};
use crate::scene::{PlaceSpec, Scene, Shape};
use crate::snapshot::Arm;
use crate::vision::Image;

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
    /// The object weighed through the fingertip sensors after the lift: (measured, true m·g) in N
    /// (the true weight from the world, for the report only).
    pub weighed: Option<(f64, f64)>,
    /// Horizontal distance between the stereo-triangulated centroid used for the grasp and the true
    /// centroid (m).
    pub vision_error: Option<f64>,
    /// Force closure of the held grasp after the lift, from the world's contacts (for the report
    /// only): (closure, margin, grasp-map rank).
    pub force_closure: Option<(bool, f64, usize)>,
    /// After the lift, where the robot puts the object's centre in its hand against the truth
    /// (horizontal distance, m): `[as the fingertips feel it, as seen before the grasp]`
    /// ([`dexter::skills::contact_center`], [`Held::felt_at`]; the truth for the report only).
    pub in_hand_error: Option<[f64; 2]>,
}

/// Plans a top-down grasp of an object of known `shape` at `pose` (the teacher's view of the world:
/// true shape and pose), for a hand at orientation `current`.
pub fn plan_top_grasp_shape(
    arc: &[(f64, f64, f64)],
    shape: &Shape,
    pose: &Iso3,
    table_z: f64,
    current: &Iso3,
) -> GraspPlan {
    let r = pose.rotation;
    let half = |d: Vec3| geometry::support_half_extent(shape, &(r.inverse() * d));
    let top = pose.translation.z + half(Vec3::z());
    let bottom = pose.translation.z - half(-Vec3::z());
    plan_top_grasp_geometry(
        arc,
        &half,
        [pose.translation.x, pose.translation.y],
        bottom,
        top,
        table_z,
        current,
    )
}

/// Receives the head's images (time, left, right).
pub type WorldImages<'a> = dyn FnMut(f64, &Image, &Image) + 'a;

/// Receives the world during a run: after every control period with the robot's current activity,
/// and the head's images whenever the robot looks (time, left, right).
pub struct WorldObserver<'a> {
    tick: &'a mut dyn FnMut(&DexterSim, &str),
    images: Option<&'a mut WorldImages<'a>>,
    stop: Option<&'a dyn Fn() -> bool>,
}

impl std::fmt::Debug for WorldObserver<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("WorldObserver").finish_non_exhaustive()
    }
}

impl<'a> WorldObserver<'a> {
    /// Calls `tick(sim, activity)` after every control period.
    pub fn new(tick: &'a mut dyn FnMut(&DexterSim, &str)) -> Self {
        WorldObserver {
            tick,
            images: None,
            stop: None,
        }
    }

    /// Ask `stop` every control period; `true` ends the run with an interruption error.
    pub fn with_stop(mut self, stop: &'a dyn Fn() -> bool) -> Self {
        self.stop = Some(stop);
        self
    }

    /// Also receive the head's images.
    pub fn with_images(mut self, images: &'a mut WorldImages<'a>) -> Self {
        self.images = Some(images);
        self
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
    pick_and_place_in(&mut sim, scene, request, &mut WorldObserver::new(&mut nothing))
}

/// One pick-and-place in an existing simulation, reporting every control period to `obs`.
pub fn pick_and_place_in(
    sim: &mut DexterSim,
    scene: &Scene,
    request: &PickPlaceRequest,
    obs: &mut WorldObserver<'_>,
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
    // Where the scene presented the object: the robot's search hint.
    let nominal = scene.resolved[sim.objects()[obj].scene_index].pose.translation.vector;
    let weight = sim.objects()[obj].mass * sim.settings().gravity;
    let seed = sim.settings().seed ^ 0xE7E5;
    let frame_secs = 1.0 / scene.spec.camera.rate_hz;
    let activity = RefCell::new(String::from("search-track"));
    let WorldObserver { tick, images, stop } = obs;
    let mut hook = |s: &DexterSim| tick(s, &activity.borrow());
    let calibration = crate::calibrate::workcell_calibration(scene)?;
    let mut hw = SimRobot::new(sim, scene, seed)?.with_hook(Box::new(&mut hook));
    if let Some(stop) = stop {
        hw = hw.with_stop(Box::new(stop));
    }
    let mut note = |_: &mut dyn Hardware, a: &str| {
        if *activity.borrow() != a {
            *activity.borrow_mut() = a.to_string();
        }
    };
    let mut on_images = |h: &dyn Hardware, l: &Image, r: &Image| {
        if let Some(f) = images.as_mut() {
            f(h.time_secs(), l, r);
        }
    };
    let mut robs = Observer::new(&mut note).with_images(&mut on_images);
    let r = from_robot;
    let mut eyes = Eyes::new(&hw, table_z, calibration).map_err(r)?;
    // Search-Track with the head: foveate the object near where it was presented, triangulate it,
    // measure its height and footprint. The grasp is planned from that alone.
    robs.activity = "search-track";
    let located = locate_object(&mut hw, &mut eyes, &nominal, table_z, frame_secs, &mut robs).map_err(r)?;
    let mut phases: Vec<(String, f64)> = vec![("search-track".into(), 0.0)];
    let report = |hw: &SimRobot<'_>,
                  arm: Arm,
                  success: bool,
                  lifted: bool,
                  outcome: String,
                  phases: Vec<(String, f64)>,
                  weighed: Option<(f64, f64)>,
                  vision_error: Option<f64>,
                  closure: Option<(bool, f64, usize)>,
                  in_hand_error: Option<[f64; 2]>| {
        let s = hw.sim();
        let p = s.object_state(obj).pose.translation.vector;
        let wall_time = wall.elapsed().as_secs_f64();
        let sim_time = s.time() - t0;
        PickPlaceReport {
            object: request.object.clone(),
            place: request.place.clone(),
            arm,
            success,
            outcome,
            lifted,
            phases,
            sim_time,
            steps: s.steps() - s0,
            wall_time,
            real_time_factor: if wall_time > 0.0 { sim_time / wall_time } else { 0.0 },
            final_position: [p.x, p.y, p.z],
            weighed,
            vision_error,
            force_closure: closure,
            in_hand_error,
        }
    };
    let located = match located {
        Ok(l) => l,
        Err(why) => {
            return Ok(report(
                &hw,
                request.arm.unwrap_or(Arm::Left),
                false,
                false,
                why.message,
                phases,
                None,
                None,
                None,
                None,
            ));
        }
    };
    let seen = located.seen;
    let truth = hw.sim().object_state(obj).pose.translation.vector;
    let vision_error = (seen.centroid.xy() - truth.xy()).norm();
    let arc_left = finger_arc(hw.model(), Arm::Left).map_err(r)?;
    let candidates: &[Arm] = match &request.arm {
        Some(a) => std::slice::from_ref(a),
        None => &Arm::BOTH,
    };
    let arm = match choose_arm(
        &hw,
        candidates,
        &arc_left,
        &seen,
        place.center,
        place.wall_height,
        table_z,
    )
    .map_err(r)?
    {
        Ok(a) => a,
        Err(reasons) => {
            let what = if candidates.len() == 1 {
                format!(
                    "the {} arm cannot pick `{}` and place it in `{}`",
                    candidates[0], request.object, place.name
                )
            } else {
                format!(
                    "no single arm can pick `{}` and place it in `{}`",
                    request.object, place.name
                )
            };
            let hint = if candidates.len() == 1 {
                "try --arm auto"
            } else {
                "a hand-to-hand transfer is needed"
            };
            return Err(SimError::Unreachable {
                what,
                reason: format!("{reasons} ({hint})"),
            });
        }
    };
    let arc = finger_arc(hw.model(), arm).map_err(r)?;
    let mut reach = ReachControl::new(&hw, arm).map_err(r)?;
    let hand = HandControl::new(&hw, arm).map_err(r)?;
    let current = reach.tool_pose(&hw);
    let plan = plan_top_grasp(&arc, &seen, table_z, &current);
    phases.push(("reach pre-grasp".into(), hw.time_secs() - t0));
    let g = grasp_and_lift(&mut hw, &mut reach, &hand, &plan, &mut robs, &mut |name, t| {
        phases.push((name.into(), t - t0))
    });
    robs.check().map_err(r)?;
    // For the report only: the world's view of the held grasp.
    let closure = control_basis::grasp::force_closure(
        &hw.sim().hand_contacts_on_object(arm, obj),
        &hw.sim().object_center_of_mass(obj),
    )
    .ok()
    .map(|c| (c.closure, c.margin, c.rank));
    let weighed = g.weighed.map(|w| (w, weight));
    if !g.lifted {
        return Ok(report(
            &hw,
            arm,
            false,
            false,
            g.outcome,
            phases,
            weighed,
            Some(vision_error),
            closure,
            None,
        ));
    }
    // Where the object sits in the hand: where the fingertips feel it (it moves as the fingers
    // close and lift it), else where it was seen.
    let palm = reach.tool_pose(&hw).translation.vector;
    let seen_hold = Held::new(&seen, &plan.grasp, table_z, g.weighed.unwrap_or(0.0));
    let held = seen_hold.felt_at(&palm, contact_center(&hw, arm));
    let now = hw.sim().object_state(obj).pose.translation.vector;
    let off = |h: &Held| (palm.x + h.offset_xy[0] - now.x).hypot(palm.y + h.offset_xy[1] - now.y);
    let in_hand_error = Some([off(&held), off(&seen_hold)]);
    // Transport: up to a safe height, over the place.
    phases.push(("transport".into(), hw.time_secs() - t0));
    if let Err(why) = transport_over(
        &mut hw,
        &mut reach,
        &held,
        place.center,
        table_z,
        place.wall_height,
        &mut robs,
    ) {
        robs.check().map_err(r)?;
        return Ok(report(
            &hw,
            arm,
            false,
            true,
            why.message,
            phases,
            weighed,
            Some(vision_error),
            closure,
            in_hand_error,
        ));
    }
    // Place: lower until the support takes the load.
    phases.push(("place".into(), hw.time_secs() - t0));
    set_down(&mut hw, &mut reach, &hand, &held, table_z, &mut robs);
    phases.push(("release".into(), hw.time_secs() - t0));
    release_and_retreat(&mut hw, &mut reach, &hand, &mut robs);
    robs.check().map_err(r)?;
    drop(robs);
    // The evaluator: let the object come to rest, then judge from the truth.
    phases.push(("retreat".into(), hw.time_secs() - t0));
    for _ in 0..500 {
        if hw.sim().object_state(obj).linvel.norm() < 0.005 {
            break;
        }
        hw.advance(0.005)?;
    }
    let state = hw.sim().object_state(obj);
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
    Ok(report(
        &hw,
        arm,
        success,
        true,
        outcome,
        phases,
        weighed,
        Some(vision_error),
        closure,
        in_hand_error,
    ))
}
