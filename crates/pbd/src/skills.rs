//! The robot's skills one at a time, on a simulation the caller owns: perceive, Search-Track an
//! object, Reach ◁ Grasp and lift it, carry it over a place, put it down — and the whole pick-place
//! schema (§3.3: Search-Track → Reach ◁ Grasp → Transport → Place) on the same world.
//!
//! This is what `pbd.Sim` in Python steps through. Every skill runs on the robot side
//! ([`dexter::skills`]) against the simulator's [`SimRobot`] hardware: it reads encoders, fingertip
//! F/T sensors and the cameras only. The world's truth enters only the whole-schema report (its
//! evaluator, as in `pbd sim pick-place`). Between skills a [`SkillSession`] keeps what the robot
//! knows: the last object it located, the arm that holds something and how (the grasp, its load), and
//! its percept tracks.

use std::fmt;

use control_basis::Hardware;
use dexter::Arm;
use dexter::control::{HandControl, ReachControl};
use dexter::skills::{
    Held, Observer, SeenObject, TouchState, finger_arc, grasp_and_lift, hand_fingertips, locate_object, plan_top_grasp,
    reachable, release_and_retreat, set_down, transport_over,
};
use dexter::watch::Watcher;
use dexter_sim::hardware::{SimRobot, workspace};
use dexter_sim::physics::DexterSim;
use dexter_sim::pick_place::{PickPlaceReport, PickPlaceRequest, WorldObserver, pick_and_place_in};
use dexter_sim::scene::Scene;
use schema::{Percept, SeenExtent};
use serde::Serialize;

use crate::sim::ArmChoice;

/// The skills a [`SkillSession`] runs.
pub const SKILLS: [&str; 5] = ["perceive", "locate", "grasp", "transport", "place"];

/// What one skill did, judged by the robot's own sensors.
#[derive(Debug, Clone, Serialize)]
pub struct SkillReport {
    /// The skill (`locate`, `grasp`, `transport`, `place`).
    pub skill: String,
    /// Whether it converged (located, lifted and holding, over the place, released).
    pub ok: bool,
    /// What happened, in words.
    pub outcome: String,
    /// Why it failed, typed (`not_seen`, `approach_not_reached`, `dropped`, …; see
    /// `schema::FailureCause`), when the skill reported one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cause: Option<schema::FailureCause>,
    /// The arm it used, if any.
    pub arm: Option<Arm>,
    /// Simulated time the skill took (s).
    pub sim_time: f64,
    /// Where the robot saw the object (m, world) — `locate`.
    pub centroid: Option<[f64; 3]>,
    /// Its measured extent (height, footprint) — `locate`.
    pub extent: Option<SeenExtent>,
    /// How far the palm rose in the lift (m, from the encoders) — `grasp`.
    pub rose: Option<f64>,
    /// The load the fingertips carried after the lift (N) — `grasp`.
    pub weighed: Option<f64>,
}

impl SkillReport {
    fn new(skill: &str, ok: bool, outcome: impl Into<String>, arm: Option<Arm>, sim_time: f64) -> Self {
        SkillReport {
            skill: skill.into(),
            ok,
            outcome: outcome.into(),
            cause: None,
            arm,
            sim_time,
            centroid: None,
            extent: None,
            rose: None,
            weighed: None,
        }
    }
}

impl SkillReport {
    fn because(mut self, cause: schema::FailureCause) -> Self {
        self.cause = Some(cause);
        self
    }
}

impl fmt::Display for SkillReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}: {} ({}){} in {:.2} s",
            self.skill,
            if self.ok { "ok" } else { "failed" },
            self.outcome,
            self.arm.map(|a| format!(", {a} arm")).unwrap_or_default(),
            self.sim_time
        )
    }
}

/// What the robot holds in one hand between skills.
#[derive(Debug, Clone)]
struct Holding {
    arm: Arm,
    held: Held,
}

/// The robot's state between skills on one simulation: its percept tracks, the object it last
/// located, what it holds. Create one per [`DexterSim`] and pass the same simulation and scene to
/// every call.
#[derive(Debug)]
pub struct SkillSession {
    seed: u64,
    calls: u64,
    watcher: Option<Watcher>,
    seen: Option<SeenObject>,
    holding: Option<Holding>,
}

type Stop<'a> = &'a (dyn Fn() -> bool + Sync);

impl SkillSession {
    /// A session whose sensor noise streams derive from `seed`.
    pub fn new(seed: u64) -> Self {
        SkillSession {
            seed,
            calls: 0,
            watcher: None,
            seen: None,
            holding: None,
        }
    }

    /// The object the robot last located: centroid (m, world) and measured extent.
    pub fn seen(&self) -> Option<([f64; 3], &SeenExtent)> {
        self.seen
            .as_ref()
            .map(|s| ([s.centroid.x, s.centroid.y, s.centroid.z], &s.extent))
    }

    /// The arm that holds an object, if one does.
    pub fn holding(&self) -> Option<Arm> {
        self.holding.as_ref().map(|h| h.arm)
    }

    /// The robot's hardware on `sim` for one skill (a fresh noise stream per call).
    fn hardware<'a>(&mut self, sim: &'a mut DexterSim, scene: &Scene, stop: Stop<'a>) -> anyhow::Result<SimRobot<'a>> {
        self.calls += 1;
        let seed = bayes::rng::split(self.seed ^ 0x5C11, self.calls);
        Ok(SimRobot::new(sim, scene, seed)?.with_stop(Box::new(stop)))
    }

    /// One percept of the head's stereo pair (§5.1.2): the tracked segments (centroid, HSV histogram,
    /// colour terms, extent), the hands (palm, fingertip loads), the places.
    pub fn perceive(&mut self, sim: &mut DexterSim, scene: &Scene, stop: Stop<'_>) -> anyhow::Result<Percept> {
        let mut hw = self.hardware(sim, scene, stop)?;
        let watcher = watcher_on(&mut self.watcher, &hw, scene)?;
        let t = control_basis::Plant::time_secs(&hw);
        Ok(watcher.percept(&mut hw, t)?)
    }

    /// Search-Track (§3.3.3): foveate near `near` (m, world; a search hint), triangulate the object
    /// there and measure its height and footprint. The result is kept for [`SkillSession::grasp`].
    pub fn locate(
        &mut self,
        sim: &mut DexterSim,
        scene: &Scene,
        near: [f64; 3],
        stop: Stop<'_>,
    ) -> anyhow::Result<SkillReport> {
        if let Some(i) = near.iter().position(|v| !v.is_finite()) {
            anyhow::bail!("locate: near[{i}] is not a finite number");
        }
        let table_z = scene.spec.table.height;
        let frame_secs = 1.0 / scene.spec.camera.rate_hz;
        let t0 = sim.time();
        let mut hw = self.hardware(sim, scene, stop)?;
        let eyes = watcher_on(&mut self.watcher, &hw, scene)?.eyes_mut();
        let mut nothing = |_: &mut dyn Hardware, _: &str| {};
        let mut obs = Observer::new(&mut nothing);
        let nominal = control_basis::math::Vec3::from(near);
        let located = locate_object(&mut hw, eyes, &nominal, table_z, frame_secs, &mut obs)?;
        obs.check()?;
        let dt = hw.sim().time() - t0;
        Ok(match located {
            Ok(l) => {
                let c = l.seen.centroid;
                let mut r = SkillReport::new("locate", true, "located", None, dt);
                r.centroid = Some([c.x, c.y, c.z]);
                r.extent = Some(l.seen.extent.clone());
                self.seen = Some(l.seen);
                r
            }
            Err(why) => SkillReport::new("locate", false, why.message, None, dt).because(why.cause),
        })
    }

    /// Reach ◁ Grasp (§3.1, §6.5): a top grasp planned from the located object, pre-shape, descend,
    /// close until the grasp predicate converges, lift 10 cm and weigh through the fingertips. `arm`
    /// `auto` takes the arm on the object's side that reaches the grasp — and, when `then_place`
    /// names a place of the scene, the place too (the schema's arm choice, else a hand-over is needed).
    pub fn grasp(
        &mut self,
        sim: &mut DexterSim,
        scene: &Scene,
        arm: ArmChoice,
        then_place: Option<&str>,
        stop: Stop<'_>,
    ) -> anyhow::Result<SkillReport> {
        let Some(seen) = self.seen.clone() else {
            anyhow::bail!("grasp: no object located yet (run locate first)");
        };
        if let Some(h) = &self.holding {
            anyhow::bail!("grasp: the {} hand already holds an object (place it first)", h.arm);
        }
        let place = then_place.map(|p| scene.place(p).cloned()).transpose()?;
        let table_z = scene.spec.table.height;
        let t0 = sim.time();
        let mut hw = self.hardware(sim, scene, stop)?;
        let mut candidates = match arm.arm() {
            Some(a) => vec![a],
            None => Arm::BOTH.to_vec(),
        };
        if arm.arm().is_none() && seen.centroid.y < 0.0 {
            candidates.reverse();
        }
        let mut chosen = None;
        for a in &candidates {
            let arc = finger_arc(hw.model(), *a)?;
            let mut reach = ReachControl::new(&hw, *a)?;
            let plan = plan_top_grasp(&arc, &seen, table_z, &reach.tool_pose(&hw));
            let reaches_place = match &place {
                Some(p) => {
                    let mut over = plan.grasp;
                    over.translation.vector.x = p.center[0];
                    over.translation.vector.y = p.center[1];
                    over.translation.vector.z = table_z + p.wall_height + 0.15;
                    reachable(hw.model(), *a, &over, 4)?
                }
                None => true,
            };
            if reaches_place && reachable(hw.model(), *a, &plan.grasp, 3)? {
                chosen = Some((*a, reach, plan));
                break;
            }
        }
        let Some((a, mut reach, plan)) = chosen else {
            let dt = hw.sim().time() - t0;
            let what = if place.is_some() {
                "the grasp and the place"
            } else {
                "the grasp"
            };
            let which = match arm.arm() {
                Some(a) => format!("the {a} arm does not reach {what}"),
                None => format!("neither arm reaches {what}"),
            };
            return Ok(SkillReport::new("grasp", false, which, None, dt));
        };
        let hand = HandControl::new(&hw, a)?;
        let mut nothing = |_: &mut dyn Hardware, _: &str| {};
        let mut obs = Observer::new(&mut nothing);
        let g = grasp_and_lift(&mut hw, &mut reach, &hand, &plan, &mut obs, &mut |_, _| {});
        obs.check()?;
        let dt = hw.sim().time() - t0;
        let mut r = SkillReport::new("grasp", g.lifted, g.outcome, Some(a), dt);
        r.cause = g.failure.map(|f| f.cause);
        r.rose = Some(g.rose);
        r.weighed = g.weighed;
        if g.lifted {
            self.holding = Some(Holding {
                arm: a,
                held: Held::new(&seen, &plan.grasp, table_z, g.weighed.unwrap_or(0.0)),
            });
        }
        Ok(r)
    }

    /// Reach ◁ Grasp with the held object: up to a safe height and over the place `place` (a place of
    /// the scene), watching the fingertips.
    pub fn transport(
        &mut self,
        sim: &mut DexterSim,
        scene: &Scene,
        place: &str,
        stop: Stop<'_>,
    ) -> anyhow::Result<SkillReport> {
        let Some(h) = self.holding.clone() else {
            anyhow::bail!("transport: the robot holds nothing (run grasp first)");
        };
        let p = scene.place(place)?.clone();
        let table_z = scene.spec.table.height;
        let t0 = sim.time();
        let mut hw = self.hardware(sim, scene, stop)?;
        let mut reach = ReachControl::new(&hw, h.arm)?;
        let mut nothing = |_: &mut dyn Hardware, _: &str| {};
        let mut obs = Observer::new(&mut nothing);
        let done = transport_over(&mut hw, &mut reach, &h.held, p.center, table_z, p.wall_height, &mut obs);
        obs.check()?;
        let dt = hw.sim().time() - t0;
        Ok(match done {
            Ok(()) => SkillReport::new("transport", true, format!("over {place}"), Some(h.arm), dt),
            Err(why) => {
                // The place was not reached, or the fingertips lost the object: ask them.
                let mut buf = Vec::new();
                if !TouchState::of(&hand_fingertips(&hw, h.arm, &mut buf)).holding() {
                    self.holding = None;
                }
                SkillReport::new("transport", false, why.message, Some(h.arm), dt).because(why.cause)
            }
        })
    }

    /// Place: lower the held object until the support takes its load (fingertip load drops), open
    /// the hand and retreat 12 cm.
    pub fn place(&mut self, sim: &mut DexterSim, scene: &Scene, stop: Stop<'_>) -> anyhow::Result<SkillReport> {
        let Some(h) = self.holding.clone() else {
            anyhow::bail!("place: the robot holds nothing (run grasp first)");
        };
        let table_z = scene.spec.table.height;
        let t0 = sim.time();
        let mut hw = self.hardware(sim, scene, stop)?;
        let mut reach = ReachControl::new(&hw, h.arm)?;
        let hand = HandControl::new(&hw, h.arm)?;
        let mut nothing = |_: &mut dyn Hardware, _: &str| {};
        let mut obs = Observer::new(&mut nothing);
        let supported = set_down(&mut hw, &mut reach, &hand, &h.held, table_z, &mut obs);
        release_and_retreat(&mut hw, &mut reach, &hand, &mut obs);
        obs.check()?;
        self.holding = None;
        let dt = hw.sim().time() - t0;
        let outcome = if supported {
            "released on a support"
        } else {
            "released without feeling a support"
        };
        Ok(SkillReport::new("place", supported, outcome, Some(h.arm), dt))
    }

    /// The whole pick-place schema on this simulation (parks the robot first; the world's evaluator
    /// judges the placement). Clears what the session held.
    pub fn pick_place(
        &mut self,
        sim: &mut DexterSim,
        scene: &Scene,
        request: &PickPlaceRequest,
        stop: Stop<'_>,
    ) -> anyhow::Result<PickPlaceReport> {
        self.holding = None;
        self.seen = None;
        let mut nothing = |_: &DexterSim, _: &str| {};
        let mut obs = WorldObserver::new(&mut nothing).with_stop(stop);
        Ok(pick_and_place_in(sim, scene, request, &mut obs)?)
    }
}

/// The session's watcher, made on first use with the eyes calibrated in `scene`'s workcell.
fn watcher_on<'w>(
    watcher: &'w mut Option<Watcher>,
    hw: &dyn Hardware,
    scene: &Scene,
) -> anyhow::Result<&'w mut Watcher> {
    if watcher.is_none() {
        *watcher = Some(Watcher::new(
            hw,
            workspace(scene).place_percepts(),
            scene.spec.table.height,
            dexter_sim::calibrate::workcell_calibration(scene)?,
        )?);
    }
    Ok(watcher.as_mut().expect("made above"))
}
