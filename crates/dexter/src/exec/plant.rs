//! The robot as the executive's plant ([`RobotPlant`]): its state, what it sees and remembers, the
//! handoff spots and ways it plans, and the helpers each action uses; the actions themselves are in
//! `act.rs`.

use control_basis::Hardware;
use control_basis::math::{Iso3, Vec3};
use schema::{Binding, Library, MonitorBank, MonitorConfig, Percept, StepEvent};

use crate::actions::{Skill, SkillMap};
use crate::arm::Arm;
use crate::control::{HandControl, ReachControl};
use crate::error::RobotError;
use crate::eyes::Eyes;
use crate::skills::{
    GraspPlan, Held, MIN_LOAD, Observer, SeenObject, TouchState, hand_fingertips, park_pose, release_and_retreat,
    run_until, stow_pose,
};
use crate::watch::Watcher;

use super::workspace::*;

/// The handoff spot of a hand-to-hand transfer: a table region both arms reach.
pub const HANDOFF: &str = "handoff";

/// Smallest horizontal distance (m) from the handoff spot to another object's seen centroid: room
/// for the transferred object, the other object and the open fingers between them.
pub const HANDOFF_CLEARANCE: f64 = 0.16;

/// The least room (m) a handoff spot may have to another object's seen centroid, when every spot
/// with [`HANDOFF_CLEARANCE`] lies near a failed reach (the transferred and the other object of
/// up to 5 cm radius, a hand's fingers between them).
pub const HANDOFF_MIN_CLEARANCE: f64 = 0.12;

/// How far inside its pan and tilt limits (rad) the head must be to look at a handoff spot. Measured
/// in the blocked-arm fault scenes: objects put at spots the head tilts 1.02–1.03 rad for (x ≈ 0.42
/// m, near the parked hands) were seen by one camera at most and never triangulated, so the
/// receiving hand's monitors never saw them; spots at tilts up to 0.95 rad (the band x ≥ 0.5 m the
/// experiments present objects in) are seen by both. The tilt limit is 1.2 rad.
pub(super) const HEAD_LIMIT_MARGIN: f64 = 0.25;

/// A tall thing whose footprint centre lies this close (m, horizontally) to a palm is what the
/// hand holds, not an obstacle (a palm stopped against a post's face is 8 cm or more from its
/// centre).
pub(super) const HELD_UNDER_PALM: f64 = 0.06;

/// How much (m, horizontal) of the line from a handoff spot back to an arm's shoulder the
/// handoff planner checks against the tall things seen: all of it (an arm reaching down to the spot
/// lies over that line, shoulder to palm). Only the forearm's 0.35 m was checked at first: spots
/// it let through lay behind the post from the other shoulder (blocked arm, dev seed 3: 8/26
/// recovered; the whole line: 12/26, and 12/26 on seed 2).
pub(super) const FOREARM_LENGTH: f64 = 1.0;

/// How far (m) an arm's line must keep from a tall thing's footprint: the forearm's radius and a
/// margin.
pub(super) const FOREARM_CLEARANCE: f64 = 0.08;

/// How far (m) a handoff spot keeps from the table's far edge. Was 0.12, as from the near edge:
/// with a post in the middle of the table, spots 8–12 cm from the far edge were taken, and a
/// receiving hand that missed there pushed the object off the table (blocked arm, dev seeds 2
/// and 3: 7 of 24 failures).
pub(super) const HANDOFF_FAR_MARGIN: f64 = 0.18;

/// The other arm's palm within this horizontal distance (m) of an object to reach is moved away
/// first.
pub(super) const CLEAR_RADIUS: f64 = 0.25;

/// Smallest horizontal distance (m) from the handoff spot to where a reach did not converge: the
/// arm that failed there may have to take the object at the handoff spot.
pub(super) const UNREACHED_CLEARANCE: f64 = 0.25;

/// Smallest horizontal distance (m) from where an arm's reach failed to that arm's straight path
/// from its parked pose to the handoff spot.
pub(super) const UNREACHED_PATH_CLEARANCE: f64 = 0.16;

/// How long (s) after an action converged the plant waits at most for its monitor set to see it.
pub(super) const MONITOR_WAIT_SECS: f64 = 1.0;

/// Objects counted up to this height (m) when carrying over them (a segment merged with something
/// above it may measure taller than any object on the table).
pub(super) const MAX_OBSTACLE_HEIGHT: f64 = 0.25;

/// How long (s) the head looks into a place before a spot in it is chosen: a few frames for the
/// tracker to see what lies there.
pub(super) const PLACE_LOOK_SECS: f64 = 0.6;

/// The footprint radius (m) counted for an object seen in a place: objects lying in a bin are not
/// measured on the table's plane, and a coarse silhouette disc may take a bin's wall along.
pub(super) const IN_PLACE_RADIUS: f64 = 0.06;
/// How far (m) above where the place's floor would take it a lowered object may come to rest
/// before it is taken to stand on something unseen and put down elsewhere: a bin's floor stands
/// about 1 cm above the table, and the smallest graspable object is 4 cm across.
pub(super) const PERCHED: f64 = 0.04;
/// The least distance (m) between a perched object's spot and the next worth moving it for.
pub(super) const PERCHED_MOVE: f64 = 0.02;
/// How far (m) beyond the two footprints' radii something known in a place may stand from a
/// lowered object for the object to be taken as perched on it.
pub(super) const PERCHED_BESIDE: f64 = 0.02;
/// How many times a perched object is lifted off and put down elsewhere.
pub(super) const PERCHED_TRIES: usize = 1;
/// The least footprint radius (m) a perched object is taken to have when the next spot is chosen:
/// it reached farther than measured (a footprint 10 cm across).
pub(super) const PERCHED_RADIUS: f64 = 0.05;

/// A tall thing seen only coarsely is remembered when it lies this close (m, horizontally) to where
/// a reach did not get through ([`RobotPlant::tall_things`]): the blocking post stands 7–10 cm from
/// the object's side, its coarse centroid up to 10 cm farther.
pub(super) const UNREACHED_TALL_RADIUS: f64 = 0.25;

/// Half-extents (m) of the obstacle remembered where a carried object met one: across its way and
/// along it ([`RobotPlant::remember_felt_obstacle`]).
pub(super) const FELT_OBSTACLE_HALF: [f64; 2] = [0.06, 0.03];
/// How far above the palm (m) an obstacle the carried object met is taken to reach: the carry
/// goes round it, not over it.
pub(super) const FELT_OBSTACLE_TOP: f64 = 0.10;

/// Segments within this distance (m) of the transferred object's position are that object.
pub(super) const MERGE_RADIUS: f64 = 0.05;
/// The scan before a handoff spot is chosen looks at the scan points this close (m, across the
/// table) to the table's centre line.
pub(super) const HANDOFF_SCAN_HALF_WIDTH: f64 = 0.25;
/// Room (m) between the straight carry to a handoff spot and a seen segment's side: the carried
/// object and the fingers around it. The carry is low (8 cm above the table), so a thing on the way
/// would knock the object out of the hand.
pub(super) const CARRY_PATH_ROOM: f64 = 0.08;
/// Horizontal radius (m) assumed for a segment seen without a measured extent.
pub(super) const SEEN_RADIUS: f64 = 0.05;
/// A seen thing taller than this (m) stands in the way of a hand moving at hover height (32 cm or
/// more above the table).
pub(super) const TALL_THING: f64 = 0.25;
/// How far (m) a coarse segment's centroid may lie above half [`TALL_THING`] for it to be a
/// target ([`RobotPlant::may_be_target`]): the error of a triangulated centroid's height.
pub(super) const COARSE_CENTROID_SLACK: f64 = 0.04;

/// How far (m) above the grasp pose the reach of a task that only touches stops
/// ([`RobotPlant::set_touch_task`]).
pub(super) const PRE_TOUCH_HEIGHT: f64 = 0.04;

/// A segment as the handoff planner sees it: centre (x, y), horizontal radius (its measured half
/// length, or [`SEEN_RADIUS`]) and height (measured, or 0), m; and its footprint's long axis (unit,
/// x-y) and half width across it (m; the radius when not measured).
#[derive(Debug, Clone, Copy)]
pub(super) struct SeenThing {
    pub(super) at: [f64; 2],
    pub(super) radius: f64,
    pub(super) height: f64,
    pub(super) axis: [f64; 2],
    pub(super) half_minor: f64,
}

impl SeenThing {
    pub(super) fn of(s: &schema::SegmentPercept) -> Self {
        let e = s.extent.as_ref();
        SeenThing {
            at: [s.centroid[0], s.centroid[1]],
            radius: e.map_or(SEEN_RADIUS, |e| e.half_major),
            height: e.map_or(0.0, |e| e.height),
            axis: e.map_or([1.0, 0.0], |e| e.major_axis),
            half_minor: e.map_or(SEEN_RADIUS, |e| e.half_minor.min(e.half_major)),
        }
    }

    /// Whether the point (x, y) lies on the thing's footprint grown by `margin` (m): the rectangle
    /// along its long axis.
    pub(super) fn covers(&self, x: f64, y: f64, margin: f64) -> bool {
        let (dx, dy) = (x - self.at[0], y - self.at[1]);
        let along = dx * self.axis[0] + dy * self.axis[1];
        let across = -dx * self.axis[1] + dy * self.axis[0];
        along.abs() < self.radius + margin && across.abs() < self.half_minor + margin
    }
}
/// Least overlap of two segments' colour terms ([`colour_overlap`]) for one to look like the other.
pub(super) const LOOKS_ALIKE: f64 = 0.3;

/// The overlap of two colour-term distributions (histogram intersection: the share of pixels whose
/// terms both have), 0 (nothing alike) to 1 (the same).
pub(super) fn colour_overlap(a: &[(u8, f64)], b: &[(u8, f64)]) -> f64 {
    a.iter()
        .map(|&(t, wa)| b.iter().find(|(u, _)| *u == t).map_or(0.0, |&(_, wb)| wa.min(wb)))
        .sum()
}

/// The head cameras' frames: a handoff spot is chosen where neither sees the object hidden behind a
/// seen thing.
pub(super) const HEAD_CAMERA_FRAMES: [&str; 2] = ["head/left_camera_optical_frame", "head/right_camera_optical_frame"];
/// Points sampled along a camera's line of sight to a handoff spot.
pub(super) const SIGHT_SAMPLES: usize = 24;
/// Margin (m) round a seen thing's footprint for the lines of sight to a handoff spot.
pub(super) const SIGHT_MARGIN: f64 = 0.02;

/// A segment this close (m) to a carrying palm is the carried object.
pub(super) const CARRIED_CLEARANCE: f64 = 0.15;

/// After a grasp closed on nothing, the seen segment nearer than this (m) to where the target
/// was is the target (it was pushed).
pub(super) const REACQUIRE_GATE: f64 = 0.2;

/// The tracked segment nearer than this (m) to where the target was last seen is the target.
pub(super) const TARGET_GATE: f64 = 0.08;

/// A lost target is searched for this far (m) from where it was last seen.
pub(super) const SEARCH_GATE: f64 = 0.5;

/// Before a grasp closes: the target seen farther than this (m, horizontally) from where the grasp
/// was planned has moved (a bump moves it 4–8 cm; a resting object's track wanders < 1 cm).
pub(super) const MOVED_GATE: f64 = 0.03;

/// The procedural resources ψ bound the monitors to (§3.3.1: convergence is a property of a
/// controller with its resources), which [`MonitorBinding::x`] reads the set predicates (4.17) over.
#[derive(Debug, Clone, Default)]
pub(super) struct MonitorBinding {
    /// The arms the procedural policy bound (None: all).
    pub(super) arms: Option<Vec<String>>,
    /// The reach monitor set's index and the arm ψ bound to the latest action.
    pub(super) reach: Option<(usize, String)>,
    /// Where the object this instance of the schema works on was last seen (when known).
    pub(super) object_at: Option<[f64; 3]>,
}

/// How far (m, horizontally) from where the bound object was last seen a reach monitor's segment
/// may be and still be that object: twice the reach radius, and a little more than an object
/// pushed by the approaching fingers moves before the approach fails.
pub(super) const BOUND_OBJECT_RADIUS: f64 = 0.10;

impl MonitorBinding {
    /// The set predicates (4.17) over the monitors bound to `arms` (all when `None`); the monitor
    /// set of `reach` = (action index, arm) only over that arm's monitors — the arm ψ bound to the
    /// latest action: a reach is a controller of one arm and its object, and the other, parked hand
    /// resting near some segment (a phantom under it, a wall) is not reaching — and only over
    /// segments within [`BOUND_OBJECT_RADIUS`] of the bound object: a parked hand near another
    /// segment is not at this object (a can in a bin, matched in one camera with a sliver of it in
    /// the other, triangulated beside the parked hand that had just put it there; the executive took
    /// the next object's reach as done and grasped from the parked pose, development seed 2, execute
    /// scene 29).
    pub(super) fn x(&self, o: &schema::monitor::Observation, p: &schema::Percept) -> Vec<bool> {
        let mut x = vec![false; o.x.len()];
        for h in &o.hits {
            if let Some((a, arm)) = &self.reach
                && h.action == *a
            {
                if h.arm.as_ref().is_some_and(|b| b != arm) {
                    continue;
                }
                let elsewhere = |at: &[f64; 3]| {
                    h.segment
                        .and_then(|id| p.segments.iter().find(|s| s.id == id))
                        .is_some_and(|s| (s.centroid[0] - at[0]).hypot(s.centroid[1] - at[1]) > BOUND_OBJECT_RADIUS)
                };
                if self.object_at.as_ref().is_some_and(elsewhere) {
                    continue;
                }
            }
            if self
                .arms
                .as_ref()
                .is_none_or(|arms| h.arm.as_ref().is_none_or(|a| arms.contains(a)))
            {
                x[h.action] = true;
            }
        }
        x
    }
}

/// The obstacle a carried object met on its way to `target` (x, y), the palm at `palm` holding
/// it as `held` describes: just ahead of the object along its way, across it
/// ([`FELT_OBSTACLE_HALF`]), up to [`FELT_OBSTACLE_TOP`] above the palm. `None` at the target.
pub(super) fn felt_obstacle(palm: &Vec3, held: &Held, target: [f64; 2]) -> Option<crate::route::Obstacle> {
    let at = [palm.x + held.offset_xy[0], palm.y + held.offset_xy[1]];
    let (dx, dy) = (target[0] - at[0], target[1] - at[1]);
    let l = dx.hypot(dy);
    if l < 1e-6 {
        return None;
    }
    let (ux, uy) = (dx / l, dy / l);
    let ahead = held.radius + FELT_OBSTACLE_HALF[1];
    Some(crate::route::Obstacle {
        center: [at[0] + ux * ahead, at[1] + uy * ahead],
        major_axis: [-uy, ux],
        half: FELT_OBSTACLE_HALF,
        top: palm.z + FELT_OBSTACLE_TOP,
    })
}

/// Which of the tall things seen `now` are remembered ([`RobotPlant::tall_things`]): those measured
/// (their footprint centre among `measured`, from edges or the support plane), and those seen only
/// coarsely within [`UNREACHED_TALL_RADIUS`] of a place where a reach did not get through
/// (`unreached`).
pub(super) fn tall_to_remember(
    now: &[crate::route::Obstacle],
    measured: &[[f64; 2]],
    unreached: &[[f64; 2]],
) -> Vec<crate::route::Obstacle> {
    now.iter()
        .filter(|o| {
            measured.contains(&o.center)
                || unreached
                    .iter()
                    .any(|u| (o.center[0] - u[0]).hypot(o.center[1] - u[1]) < UNREACHED_TALL_RADIUS)
        })
        .copied()
        .collect()
}

/// Receives what happens during an execution (for logs).
pub trait ExecSink {
    /// After every control tick.
    fn tick(&mut self, _hw: &dyn Hardware, _activity: &str) {}
    /// Every percept.
    fn percept(&mut self, _hw: &dyn Hardware, _eyes: &Eyes, _percept: &Percept) {}
    /// Where the executive stands, before each action and at a goal state.
    fn step(&mut self, _hw: &dyn Hardware, _event: &StepEvent<'_>) {}
}

/// A sink that ignores everything.
#[derive(Debug, Default, Clone, Copy)]
pub struct NoSink;

impl ExecSink for NoSink {}

/// Something in a place the robot knows of without seeing it now ([`RobotPlant::put_down`]).
#[derive(Debug, Clone, PartialEq)]
pub(super) struct InPlace {
    /// The place's name.
    pub(super) place: String,
    /// Its centre (x, y).
    pub(super) at: [f64; 2],
    /// Its footprint's radius (m).
    pub(super) radius: f64,
    /// Felt, not put: a lowered object came to rest on it ([`PERCHED`]). Counted even where a
    /// segment is seen nearby.
    pub(super) felt: bool,
}

/// Dexter driven by the executive.
pub struct RobotPlant<'a> {
    /// The hardware.
    pub hw: &'a mut dyn Hardware,
    pub(super) workspace: &'a Workspace,
    pub(super) watcher: Watcher,
    pub(super) bank: MonitorBank,
    pub(super) last_x: Vec<bool>,
    pub(super) reach: [ReachControl; 2],
    pub(super) hand: [HandControl; 2],
    /// The object being manipulated (its track id and what was seen of it), once a reach bound it.
    pub(super) target: Option<(Option<u32>, SeenObject)>,
    /// The target's colour terms when a reach last found it seen (what a search looks for).
    pub(super) target_colors: Vec<(u8, f64)>,
    /// The other objects the task decided on, (track, where it was decided on, left alone)
    /// ([`RobotPlant::set_other_objects`]): never taken for a lost target.
    pub(super) others: Vec<(u32, [f64; 3], bool)>,
    /// The task touches its object without grasping it ([`RobotPlant::set_touch_task`]).
    pub(super) touch_task: bool,
    pub(super) plan: Option<GraspPlan>,
    /// The first track id not yet given when the grasp was planned (tracks from then on are new).
    pub(super) plan_next_id: u32,
    /// Palm pose when the last grasp converged.
    pub(super) grasp_palm: Option<Iso3>,
    pub(super) held: Option<Held>,
    /// The resources ψ bound the monitors to ([`RobotPlant::bind_arms`], [`RobotPlant::bind_object`]).
    pub(super) bound: MonitorBinding,
    pub(super) handoff: [f64; 2],
    /// Where reaches to an object did not converge (x, y): a transfer's handoff spot keeps clear
    /// of them.
    pub(super) unreached: Vec<(Arm, [f64; 2])>,
    /// Where grasp descents stopped short (x, y of the object as seen then): the next grasp of an
    /// object there takes the direction with the most room for its fingers.
    pub(super) stopped_short: Vec<[f64; 2]>,
    /// Tall things measured from their edges, remembered while out of sight or hidden
    /// ([`RobotPlant::tall_things`]).
    pub(super) tall_seen: Vec<crate::route::Obstacle>,
    /// Obstacles the carried object met on its way, felt by the fingertips and not seen
    /// ([`RobotPlant::remember_felt_obstacle`]).
    pub(super) felt: Vec<crate::route::Obstacle>,
    /// What is in a place without being seen now — what this plant put down there, and what an
    /// object lowered there came to rest on ([`PERCHED`]) — taken as still there when the place
    /// is looked into ([`RobotPlant::place_spot`]).
    pub(super) put_down: Vec<InPlace>,
    /// Where the last Place lowered the held object in a place, while it is still in the hand: it
    /// joins [`RobotPlant::put_down`] when the Release lets go of it. (A Place the monitors do not
    /// see succeed is run again, and carries the object elsewhere: remembered at the Place, the
    /// first spot stayed "taken" by nothing, and the second went to the bin's wall, where the
    /// opening fingers pushed a cereal box standing outside it over — development seed 6, execute
    /// scene 35.)
    pub(super) lowered: Option<InPlace>,
    /// Where the object is to end up (the task's place centre, [`RobotPlant::set_destination`]):
    /// after a hand-over the failed arm carries it there from the handoff spot.
    pub(super) destination: Option<[f64; 2]>,
    /// The last grasp closed on nothing (the object may have moved).
    pub(super) missed: bool,
    /// The track whose doubted position ([`Watcher::doubted`]) the robot already looked at again
    /// with the hand out of the way: it is not doubted twice.
    pub(super) doubt_checked: Option<u32>,
    /// The next reach follows a back-off for a doubted track: it takes what it then sees of it.
    pub(super) relook: bool,
    /// The object (as the binding names it) and how many reaches in a row did not see it.
    pub(super) unseen: (Option<String>, usize),
    /// The library's action names (the entries of x).
    pub(super) action_names: Vec<String>,
    /// The library's actions bound to Dexter's skills, by signature.
    pub(super) skills: SkillMap,
    pub(super) sink: &'a mut dyn ExecSink,
    pub(super) t0: f64,
    pub(super) next_percept: f64,
    pub(super) percept_period: f64,
    /// Percepts made, for the record.
    pub percepts: Vec<Percept>,
    /// Arms used, in order.
    pub arms_used: Vec<Arm>,
}

impl std::fmt::Debug for RobotPlant<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RobotPlant")
            .field("target", &self.target)
            .finish_non_exhaustive()
    }
}

pub(super) fn parse_arm(action: &str, s: Option<&str>) -> Result<Arm, RobotError> {
    s.and_then(Arm::parse).ok_or_else(|| RobotError::Binding {
        action: action.to_string(),
        message: format!("no known arm ({s:?})"),
    })
}

impl<'a> RobotPlant<'a> {
    /// A plant on `hw` (parked, settled) in `workspace`, observing with `library`'s monitors and
    /// seeing with the backgrounds of `calibration` (taken in this workspace before the task).
    pub fn new(
        hw: &'a mut dyn Hardware,
        workspace: &'a Workspace,
        calibration: std::sync::Arc<crate::calibration::Calibration>,
        library: &Library,
        sink: &'a mut dyn ExecSink,
    ) -> Result<RobotPlant<'a>, RobotError> {
        let watcher = Watcher::new(hw, workspace.place_percepts(), workspace.table_z, calibration)?;
        // Ways round tall things may leave the table top (`ReachControl::way_region` stays `None`):
        // keeping them over it placed one more object on development seeds 2–3 (109/117 against
        // 108/118) but recovered 8 of 26 blocked arms on seed 2 against 10; tried again once a
        // stopped arm parks (session 51): 18 of 52 blocked arms on seeds 2–3 against 34.
        let reach = [ReachControl::new(hw, Arm::Left)?, ReachControl::new(hw, Arm::Right)?];
        let hand = [HandControl::new(hw, Arm::Left)?, HandControl::new(hw, Arm::Right)?];
        let t0 = hw.time_secs();
        let mut p = RobotPlant {
            hw,
            workspace,
            watcher,
            bank: MonitorBank::new(library, MonitorConfig::default()),
            last_x: vec![false; library.actions.len()],
            reach,
            hand,
            target: None,
            target_colors: Vec::new(),
            others: Vec::new(),
            touch_task: false,
            plan: None,
            grasp_palm: None,
            held: None,
            bound: MonitorBinding::default(),
            handoff: [workspace.table_center[0].min(0.55), 0.0],
            unreached: Vec::new(),
            stopped_short: Vec::new(),
            tall_seen: Vec::new(),
            felt: Vec::new(),
            put_down: Vec::new(),
            lowered: None,
            destination: None,
            missed: false,
            doubt_checked: None,
            relook: false,
            unseen: (None, 0),
            action_names: library.actions.iter().map(|a| a.name.clone()).collect(),
            skills: SkillMap::new(library),
            plan_next_id: 0,
            sink,
            t0,
            next_percept: 0.0,
            percept_period: 0.1,
            percepts: Vec::new(),
            arms_used: Vec::new(),
        };
        p.percept_now()?;
        Ok(p)
    }

    /// Observe only the monitors bound to `arms` (and those of no arm, e.g. the head's): the
    /// executive estimates the state of *this* instance of the schema from the controllers ψ bound
    /// (§3.3.1: convergence is a property of a controller with its procedural resources), so a hand
    /// still holding something from an earlier task does not pass for this task's grasp.
    pub fn bind_arms(&mut self, arms: &[Arm]) {
        self.bound.arms = Some(arms.iter().map(|a| a.prefix().to_string()).collect());
        // The first arm acts first.
        if let (Some(a), Some(arm)) = (self.skills.index(Skill::ReachObject), arms.first()) {
            self.bound.reach = Some((a, arm.prefix().to_string()));
        }
        if let Some(p) = self.percepts.last() {
            let p = p.clone();
            let o = self.bank.observe(&p);
            self.last_x = self.bound.x(&o, &p);
        }
    }

    /// Binds the reach monitors to the object at `at` (where it was last seen; each reach to it
    /// moves the binding to where it is then seen): a hand near another segment is not at it
    /// (the reach monitors of this instance, §3.3.1).
    pub fn bind_object(&mut self, at: &Vec3) {
        self.bound.object_at = Some([at.x, at.y, at.z]);
        if let Some(p) = self.percepts.last() {
            let p = p.clone();
            let o = self.bank.observe(&p);
            self.last_x = self.bound.x(&o, &p);
        }
    }

    /// Whether the head can turn to look at `at` with both cameras, keeping 0.25
    /// (rad) from its joint limits.
    pub fn can_look_at(&mut self, at: &Vec3) -> Result<bool, RobotError> {
        self.watcher.can_look_at(self.hw, at, HEAD_LIMIT_MARGIN)
    }

    /// Looks at `at` and takes percepts for `seconds` (to refresh what is seen there).
    pub fn look(&mut self, at: &Vec3, seconds: f64) -> Result<(), RobotError> {
        self.watcher.look_at(self.hw, at)?;
        self.settle(seconds)
    }

    /// The objects the latest percept holds (seen now or remembered), as seen on the table, but
    /// not the one carried by the palm at `carrying_palm`.
    pub(super) fn seen_objects(&self, carrying_palm: Option<&Vec3>) -> Vec<SeenObject> {
        let table_z = self.workspace.table_z;
        let Some(p) = self.percepts.last() else {
            return Vec::new();
        };
        p.segments
            .iter()
            .filter(|s| carrying_palm.is_none_or(|h| (Vec3::from(s.centroid) - h).norm() > CARRIED_CLEARANCE))
            .map(|s| SeenObject::from_percept(s, table_z))
            .collect()
    }

    /// The tall things seen on the table, which a palm goes around rather than over
    /// ([`ReachControl::avoid`]): segments measured standing from their edges, and segments whose
    /// coarse centroid lies higher than [`TALL_THING`] above the table (not within
    /// [`CARRIED_CLEARANCE`] of a holding hand's palm: a hand seen merged with what it holds) — but
    /// none whose footprint centre lies within [`HELD_UNDER_PALM`] of a holding hand's palm.
    /// Those measured from their edges are remembered ([`RobotPlant::tall_seen`]): a tall thing
    /// does not walk away, but its track is forgotten when the cameras fail to match it for a
    /// while (beside an arm that hides half of it: development seed 2, blocked arm, scene 8, the
    /// post forgotten and the next reach went straight into it). A remembered footprint grows to
    /// take in each measurement of the thing on it, and is dropped when something short is
    /// measured standing on it (the tall thing is gone).
    pub(super) fn tall_things(&mut self) -> Vec<crate::route::Obstacle> {
        let palms = self.holding_palms();
        let now = self.tall_things_now(&palms);
        let Some(p) = self.percepts.last() else {
            return now;
        };
        let measured: Vec<&schema::SeenExtent> = p
            .segments
            .iter()
            .filter(|s| s.seen)
            .filter_map(|s| s.extent.as_ref())
            .filter(|e| e.model != "coarse")
            .collect();
        let on = |o: &crate::route::Obstacle, c: [f64; 2], r: f64| {
            (o.center[0] - c[0]).hypot(o.center[1] - c[1]) < o.half[0] + r
        };
        // Something short measured standing on a remembered footprint, or a hand holding what
        // stood there: the tall thing is gone.
        self.tall_seen.retain(|o| {
            !measured.iter().any(|e| e.height < TALL_THING && on(o, e.center, 0.0))
                && !palms
                    .iter()
                    .any(|h| (o.center[0] - h.x).hypot(o.center[1] - h.y) < HELD_UNDER_PALM)
        });
        // Each tall thing measured now widens the one remembered there (a view cut by an arm or by
        // the image border measures a part of it), or is remembered; so does one seen only coarsely
        // within [`UNREACHED_TALL_RADIUS`] of where a reach did not get through — what stopped the
        // arm is no phantom (development seed 3, blocked arm, scene 18: the post, seen only as a
        // coarse blob after the reach it stopped, was hidden by the arm holding the object when the
        // carry was planned, and the carry went straight into it).
        let centers: Vec<[f64; 2]> = measured.iter().map(|e| e.center).collect();
        let unreached: Vec<[f64; 2]> = self.unreached.iter().map(|(_, u)| *u).collect();
        for n in &tall_to_remember(&now, &centers, &unreached) {
            match self.tall_seen.iter_mut().find(|o| on(o, n.center, n.half[0])) {
                Some(o) => *o = o.union(n),
                None => self.tall_seen.push(*n),
            }
        }
        let now_n = now.len();
        let mut all = now;
        for o in self.tall_seen.iter().chain(&self.felt) {
            if !all.contains(o) {
                all.push(*o);
            }
        }
        tracing::trace!("tall things now {now_n}, remembered {:?}", self.tall_seen);
        all
    }

    /// The carried object met an obstacle on its way to `target` (x, y of where its centre was to
    /// go), which the cameras did not show where it stands (a post that the carrying arm hides half
    /// of, measured 8 cm nearer the head than it stood: the carry went round the wrong place and
    /// met the post three times in a row, development seed 2, blocked arm, scene 26). What the
    /// fingertips felt is remembered as a tall thing just ahead of the object, across its way
    /// ([`FELT_OBSTACLE_HALF`]), up to [`FELT_OBSTACLE_TOP`] above the palm: the next carry goes round
    /// it ([`RobotPlant::tall_things`]).
    pub(super) fn remember_felt_obstacle(&mut self, arm: Arm, held: &Held, target: [f64; 2]) {
        let palm = self.reach[arm.index()].tool_pose(self.hw).translation.vector;
        if let Some(felt) = felt_obstacle(&palm, held, target) {
            tracing::debug!("felt an obstacle on the way: {felt:?}");
            self.felt.push(felt);
        }
    }

    /// Where the palms of the hands that hold something are.
    fn holding_palms(&mut self) -> Vec<Vec3> {
        let holding = Arm::BOTH.map(|a| self.touch(a).holding());
        self.reach
            .iter_mut()
            .zip(holding)
            .filter(|(_, h)| *h)
            .map(|(r, _)| r.tool_pose(self.hw).translation.vector)
            .collect()
    }

    /// [`RobotPlant::tall_things`] as the latest percept shows them.
    /// `palms`: those of the hands that hold something ([`RobotPlant::holding_palms`]).
    fn tall_things_now(&self, palms: &[Vec3]) -> Vec<crate::route::Obstacle> {
        let table_z = self.workspace.table_z;
        let Some(p) = self.percepts.last() else {
            return Vec::new();
        };
        // Only a hand that holds something can be seen merged with it: an empty hand stopped
        // beside a post (the arm it blocked) must not hide the post (development seed 2, blocked
        // arm, scene 11: the right palm 14 cm from the post's coarse centroid, no tall thing kept,
        // and the carry went into the post).
        // Tall things measured from their edges: a coarse segment overlapping one is the same
        // thing seen again, cut (its centroid 7–10 cm nearer the head; development seed 1, blocked
        // arm, scene 2: kept as a second post, it moved the handoff spot where the grasp failed).
        let standing: Vec<&schema::SeenExtent> = p
            .segments
            .iter()
            .filter_map(|s| s.extent.as_ref())
            .filter(|e| e.model.starts_with("standing"))
            .collect();
        p.segments
            .iter()
            .filter(|s| self.above_table(s))
            .filter_map(|s| {
                let e = s.extent.as_ref()?;
                if e.model == "coarse"
                    && standing.iter().any(|t| {
                        (e.center[0] - t.center[0]).hypot(e.center[1] - t.center[1]) < e.half_major + t.half_major
                    })
                {
                    return None;
                }
                // Right under a palm: what the hand holds.
                if palms
                    .iter()
                    .any(|h| (e.center[0] - h.x).hypot(e.center[1] - h.y) < HELD_UNDER_PALM)
                {
                    return None;
                }
                let tall = match e.model.as_str() {
                    "standing" | "standing_whole" => true,
                    "coarse" => {
                        s.centroid[2] - table_z > TALL_THING
                            && palms
                                .iter()
                                .all(|h| (Vec3::from(s.centroid) - h).norm() > CARRIED_CLEARANCE)
                    }
                    _ => e.height > TALL_THING,
                };
                // A coarse segment's centroid lies half-way up what it saw.
                let top = match e.model.as_str() {
                    "coarse" => table_z + 2.0 * (s.centroid[2] - table_z),
                    _ => table_z + e.height,
                };
                tall.then_some(crate::route::Obstacle {
                    center: e.center,
                    major_axis: e.major_axis,
                    half: [e.half_major, e.half_minor],
                    top,
                })
            })
            .collect()
    }

    /// What the hand of `arm` holds: the hold the last `hold` measured; or, when that was given up
    /// (a carry that stopped) while the fingertips still hold the grasped object, the same object
    /// weighed again now. `None` if the hand holds nothing.
    pub(super) fn held_or_felt(&mut self, arm: Arm) -> Option<Held> {
        if self.held.is_some() {
            return self.held;
        }
        let touch = self.touch(arm);
        let (Some((_, seen)), Some(palm)) = (self.target.as_ref(), self.grasp_palm) else {
            return None;
        };
        if !touch.holding() || touch.load < MIN_LOAD {
            return None;
        }
        let now = self.reach[arm.index()].tool_pose(self.hw).translation.vector;
        let felt = crate::skills::contact_center(self.hw, arm);
        self.held = Some(Held::new(seen, &palm, self.workspace.table_z, touch.load).felt_at(&now, felt));
        self.held
    }

    /// The objects seen in `place` now (centre (x, y) and footprint radius, m): the tracks of the
    /// latest percept whose centroid lies in the place region (with 5 cm of margin: an object
    /// leaning on a wall), except the one carried by the palm at `carrying_palm`.
    pub(super) fn seen_in_place(&self, place: &Place, carrying_palm: Option<[f64; 3]>) -> Vec<([f64; 2], f64)> {
        let table_z = self.workspace.table_z;
        let Some(p) = self.percepts.last() else {
            return Vec::new();
        };
        p.segments
            .iter()
            .filter(|s| {
                (s.centroid[0] - place.center[0]).abs() <= place.size[0] / 2.0 + 0.05
                    && (s.centroid[1] - place.center[1]).abs() <= place.size[1] / 2.0 + 0.05
                    && carrying_palm.is_none_or(|h| {
                        (0..3).map(|i| (s.centroid[i] - h[i]).powi(2)).sum::<f64>().sqrt() > CARRIED_CLEARANCE
                    })
            })
            .map(|s| {
                let seen = SeenObject::from_percept(s, table_z);
                (seen.extent.center, seen.radius().min(IN_PLACE_RADIUS))
            })
            .collect()
    }

    /// Whether `arm`'s hand holds something: two fingertips loaded with at least [`MIN_LOAD`]
    /// between them (an object a schema left in it, e.g. Pick-And-Hold's).
    pub fn holds(&self, arm: Arm) -> bool {
        let t = self.touch(arm);
        t.holding() && t.load >= MIN_LOAD
    }

    /// The other objects the task decided on — (track, where it was decided on, whether the robot
    /// leaves it alone) —: a search for a lost target never takes one of their tracks (a sugar box
    /// 40 cm away that looks like the red can that fell off the table is the sugar box), nor a
    /// segment within [`TARGET_GATE`] of where one it leaves alone stands (its track may have been
    /// renamed meanwhile).
    pub fn set_other_objects(&mut self, others: Vec<(u32, [f64; 3], bool)>) {
        self.others = others;
    }

    /// Whether the task touches its object without grasping it (Reach-And-Touch): its reach then
    /// stops [`PRE_TOUCH_HEIGHT`] above the grasp pose, clear of the object, and the Touch descends
    /// from there until a fingertip meets it. A reach all the way down to the grasp pose pressed
    /// the fingers into a block's top (68–86 N), so the monitors saw a touch before the Touch ran.
    pub fn set_touch_task(&mut self, touch: bool) {
        self.touch_task = touch;
    }

    /// Whether seen segment `s` is one of the other objects ([`RobotPlant::set_other_objects`]).
    pub(super) fn is_other(&self, s: &schema::SegmentPercept) -> bool {
        self.others.iter().any(|&(id, at, alone)| {
            id == s.id || (alone && (s.centroid[0] - at[0]).hypot(s.centroid[1] - at[1]) < TARGET_GATE)
        })
    }

    /// Opens and retreats every hand that touches something it does not hold (a touch a schema
    /// ended on): the next segment's monitors must not see that touch as theirs.
    pub fn let_go_of_touches(&mut self) -> Result<(), RobotError> {
        for arm in Arm::BOTH {
            let t = self.touch(arm);
            if t.loaded > 0 && !self.holds(arm) {
                let k = arm.index();
                self.with_observer(|hw, reach, hand, obs| release_and_retreat(hw, &mut reach[k], &hand[k], obs))?;
            }
        }
        Ok(())
    }

    /// The workspace the robot was told (table, places).
    pub fn workspace(&self) -> &'a Workspace {
        self.workspace
    }

    /// What the fixed chassis pair sees of the objects at `points` ([`Watcher::chassis_measure`]).
    pub fn chassis_measure(
        &mut self,
        points: &[[f64; 3]],
        gate: f64,
    ) -> Result<Vec<Option<crate::watch::ChassisMeasure>>, RobotError> {
        self.watcher.chassis_measure(self.hw, points, gate)
    }

    /// Puts track `id` where the chassis pair measured it ([`Watcher::locate`]).
    pub fn locate(&mut self, id: u32, extent: &schema::SeenExtent) -> bool {
        self.watcher.locate(id, extent)
    }

    /// The latest percept.
    pub fn last_percept(&self) -> Option<&Percept> {
        self.percepts.last()
    }

    /// The watcher (its eyes, the places it was told).
    pub fn watcher(&self) -> &Watcher {
        &self.watcher
    }

    pub(super) fn percept_now(&mut self) -> Result<(), RobotError> {
        let t = self.hw.time_secs() - self.t0;
        let p = self.watcher.percept(self.hw, t)?;
        let o = self.bank.observe(&p);
        self.last_x = self.bound.x(&o, &p);
        self.sink.percept(self.hw, self.watcher.eyes(), &p);
        self.percepts.push(p);
        self.next_percept = t + self.percept_period;
        Ok(())
    }

    /// Runs the hardware for `seconds` with no new references, observing.
    pub fn settle(&mut self, seconds: f64) -> Result<(), RobotError> {
        let dt = 1.0 / crate::skills::CONTROL_HZ;
        let steps = (seconds / dt).round() as usize;
        for _ in 0..steps {
            self.hw.advance(dt)?;
            self.sink.tick(self.hw, "");
            if self.hw.time_secs() - self.t0 + 1e-9 >= self.next_percept {
                self.percept_now()?;
            }
        }
        Ok(())
    }

    /// Runs a skill with an observer that feeds the monitors at the percept rate.
    pub(super) fn with_observer<R>(
        &mut self,
        f: impl FnOnce(&mut dyn Hardware, &mut [ReachControl; 2], &[HandControl; 2], &mut Observer<'_>) -> R,
    ) -> Result<R, RobotError> {
        let mut error: Option<RobotError> = None;
        let t0 = self.t0;
        let period = self.percept_period;
        let watcher = &mut self.watcher;
        let bank = &mut self.bank;
        let last_x = &mut self.last_x;
        let percepts = &mut self.percepts;
        let next = &mut self.next_percept;
        let sink = &mut *self.sink;
        let bound = self.bound.clone();
        let mut callback = |h: &mut dyn Hardware, activity: &str| {
            sink.tick(h, activity);
            let t = h.time_secs() - t0;
            if t + 1e-9 >= *next && error.is_none() {
                match watcher.percept(h, t) {
                    Ok(p) => {
                        let o = bank.observe(&p);
                        *last_x = bound.x(&o, &p);
                        sink.percept(h, watcher.eyes(), &p);
                        percepts.push(p);
                    }
                    Err(e) => error = Some(e),
                }
                *next = t + period;
            }
        };
        let mut obs = Observer::new(&mut callback);
        let r = f(&mut *self.hw, &mut self.reach, &self.hand, &mut obs);
        let hw_error = obs.take_error();
        drop(obs);
        if let Some(e) = hw_error {
            return Err(e.into());
        }
        match error {
            Some(e) => Err(e),
            None => Ok(r),
        }
    }

    /// The object the binding names: the tracked segment with that id in the latest percept; else
    /// the target already bound, at the segment now seen nearest where it was.
    pub(super) fn resolve_target(&self, binding: &Binding) -> Result<(Option<u32>, SeenObject), RobotError> {
        let table_z = self.workspace.table_z;
        let id: Option<u32> = binding.object.as_deref().and_then(|s| s.parse().ok());
        let segments = self.percepts.last().map(|p| p.segments.as_slice()).unwrap_or(&[]);
        let by_id = segments.iter().find(|s| Some(s.id) == id);
        if let Some(s) = by_id
            && (s.seen || !self.missed)
        {
            return Ok((id, SeenObject::from_percept(s, table_z)));
        }
        // A grasp closed on nothing where the object was seen, and its track is not seen now: the
        // object moved. Take the seen segment nearest where it was, within a wider gate.
        if self.missed {
            let last = by_id
                .map(|s| Vec3::from(s.centroid))
                .or_else(|| self.target.as_ref().map(|t| t.1.centroid));
            if let Some(c) = last
                && let Some((_, s)) = segments
                    .iter()
                    .filter(|s| s.seen && self.may_be_target(s))
                    .map(|s| ((Vec3::from(s.centroid) - c).xy().norm(), s))
                    .filter(|(d, _)| *d < REACQUIRE_GATE)
                    .min_by(|a, b| a.0.total_cmp(&b.0))
            {
                return Ok((Some(s.id), SeenObject::from_percept(s, table_z)));
            }
            if let Some(s) = by_id {
                return Ok((id, SeenObject::from_percept(s, table_z)));
            }
        }
        if let Some((tid, seen)) = &self.target
            && (id.is_none() || *tid == id)
        {
            let near = segments
                .iter()
                .filter(|s| s.seen && self.may_be_target(s))
                .map(|s| ((Vec3::from(s.centroid) - seen.centroid).xy().norm(), s))
                .filter(|(d, _)| *d < TARGET_GATE)
                .min_by(|a, b| a.0.total_cmp(&b.0))
                .map(|(_, s)| SeenObject::from_percept(s, table_z));
            return Ok((*tid, near.unwrap_or_else(|| seen.clone())));
        }
        Err(RobotError::Binding {
            action: self.skills.name(Skill::ReachObject).unwrap_or("reach").into(),
            message: match &binding.object {
                Some(o) => match self.target.as_ref().map(|t| t.1.centroid) {
                    // The object was followed, and its track is gone: not seen where it was (a
                    // search after a failed hold found nothing there).
                    Some(c) => format!(
                        "no tracked segment `{o}`: the object is no longer seen (last seen at ({:.2}, {:.2}))",
                        c.x, c.y
                    ),
                    None => format!("no tracked segment `{o}` (objects are the segments the robot sees)"),
                },
                None => "no object".into(),
            },
        })
    }

    /// After a grasp closed on nothing or a descent stopped short: the object is not where it was
    /// seen. Open, back off and return to the parked pose — out of the cameras' view of where the
    /// object was, so that the next look sees where it is — and take the next target as the seen
    /// segment nearest where it was ([`REACQUIRE_GATE`]).
    pub(super) fn back_off(&mut self, arm: Arm) -> Result<(), RobotError> {
        self.missed = true;
        let k = arm.index();
        let park = park_pose(arm, self.workspace.table_z);
        self.with_observer(|hw, reach, hand, obs| {
            release_and_retreat(hw, &mut reach[k], &hand[k], obs);
            reach[k].set_goal(hw, park);
            run_until(hw, &mut reach[k], obs, 3.0, |h, r| r.at_goal(h, 0.02, 0.1));
        })
    }

    /// Moves `arm` to its park pose (the hand as it is), for up to 3 s.
    pub(super) fn park(&mut self, arm: Arm) -> Result<(), RobotError> {
        let k = arm.index();
        let park = park_pose(arm, self.workspace.table_z);
        self.with_observer(|hw, reach, _, obs| {
            reach[k].set_goal(hw, park);
            run_until(hw, &mut reach[k], obs, 3.0, |h, r| r.at_goal(h, 0.02, 0.1));
        })
    }

    /// The object was lost from the hand on the way: forget the hold, open, back off and park
    /// ([`RobotPlant::back_off`]), so that the monitors see the hand empty.
    pub(super) fn let_go(&mut self, arm: Arm) -> Result<(), RobotError> {
        self.held = None;
        self.back_off(arm)
    }

    /// Whether the target moved since the grasp was planned, judged from the head cameras before
    /// the hand closes (closing on where it was would knock it over or away): its track is seen
    /// more than [`MOVED_GATE`] from the planned grasp; or it is not seen and the nearest new
    /// segment, one that appeared after the plan, is seen between [`MOVED_GATE`] and
    /// [`REACQUIRE_GATE`] from the plan. The reason, if so.
    pub(super) fn object_moved(&self) -> Option<String> {
        let plan = self.plan.as_ref()?;
        let (id, _) = self.target.as_ref()?;
        let p = self.percepts.last()?;
        let g = plan.grasp.translation.vector;
        let off = |s: &schema::SegmentPercept| (s.centroid[0] - g.x).hypot(s.centroid[1] - g.y);
        let track = id.and_then(|id| p.segments.iter().find(|s| s.id == id));
        match track {
            Some(s) if s.seen => {
                let d = off(s);
                (d > MOVED_GATE).then(|| {
                    format!(
                        "the object moved before the hand closed (seen {:.1} cm from the planned grasp)",
                        100.0 * d
                    )
                })
            }
            // Its track lost, the nearest new segment tells: where the grasp was planned (within
            // [`MOVED_GATE`]), it is the object still there — a new track of it; farther, moved.
            _ => p
                .segments
                .iter()
                .filter(|s| s.seen && s.id >= self.plan_next_id && self.may_be_target(s))
                .map(off)
                .filter(|d| *d < REACQUIRE_GATE)
                .min_by(f64::total_cmp)
                .filter(|d| *d > MOVED_GATE)
                .map(|d| {
                    format!(
                        "the object is not seen under the hand and a new segment is {:.1} cm away",
                        100.0 * d
                    )
                }),
        }
    }

    /// Whether a segment's centroid is above the table top (within 2 cm): an object on the table or
    /// in a place. A stereo mismatch triangulates a blob below the table, where no object the
    /// robot could grasp can be.
    pub(super) fn above_table(&self, s: &schema::SegmentPercept) -> bool {
        s.centroid[2] > self.workspace.table_z - 0.02
    }

    /// Whether a segment may be the object the robot is after: [above the table](Self::above_table)
    /// and no taller than [`TALL_THING`] (a post or a wall the hand cannot grasp is an obstacle,
    /// never the target to re-acquire). A coarse extent's height is twice its centroid's height
    /// and doubles any error in it: there the centroid must lie no higher than half that height
    /// and [`COARSE_CENTROID_SLACK`] (the robot's own upper arm, parked above the table where its
    /// self-model leaves a sliver unmasked, is seen as a coarse blob with its centroid 18–21 cm
    /// up — and was re-acquired as a lost can ten times over: development seed 5, scene 20).
    pub(super) fn may_be_target(&self, s: &schema::SegmentPercept) -> bool {
        self.above_table(s)
            && s.extent.as_ref().is_none_or(|e| {
                if e.model == "coarse" {
                    s.centroid[2] - self.workspace.table_z <= TALL_THING / 2.0 + COARSE_CENTROID_SLACK
                } else {
                    e.height <= TALL_THING
                }
            })
    }

    /// Whether `c` lies over the table (within 2 cm of its edges) and not below its top: where an
    /// object the robot can reach may rest.
    pub(super) fn on_table(&self, c: &Vec3) -> bool {
        let ws = self.workspace;
        (c.x - ws.table_center[0]).abs() <= ws.table_size[0] / 2.0 + TABLE_EDGE_MARGIN
            && (c.y - ws.table_center[1]).abs() <= ws.table_size[1] / 2.0 + TABLE_EDGE_MARGIN
            && c.z > ws.table_z - 0.05
    }

    /// Whether the latest percept sees the track `id`.
    pub(super) fn seen_now(&self, id: Option<u32>) -> bool {
        let Some(p) = self.percepts.last() else {
            return false;
        };
        id.is_some_and(|id| p.segments.iter().any(|s| s.id == id && s.seen))
    }

    /// Scans the table with the head ([`Workspace::scan_points`]) for a lost target: the seen
    /// segment nearest `last` (where it was last seen) within [`SEARCH_GATE`], on the table (not in
    /// a place, not carried, at the table's height). `None` if nothing is seen there.
    pub(super) fn search(&mut self, last: &Vec3) -> Result<Option<(Option<u32>, SeenObject)>, RobotError> {
        self.search_within(last, SEARCH_GATE)
    }

    /// The tracked segment the robot decided on at `at` before it acts on it: the one seen within
    /// [`TARGET_GATE`] of `at` after looking there, else the nearest within [`TARGET_GATE`] found
    /// by a scan of the table ([`Workspace::scan_points`]) — its track may have been lost while
    /// the robot worked on other objects. Its id and centroid, or `None` if it is not seen there.
    pub fn find(&mut self, at: &Vec3) -> Result<Option<(u32, Vec3)>, RobotError> {
        self.look(at, 0.6)?;
        let near = self.percepts.last().and_then(|p| {
            p.segments
                .iter()
                .filter(|s| s.seen && self.may_be_target(s) && !self.is_other(s))
                .map(|s| ((Vec3::from(s.centroid) - at).xy().norm(), s))
                .filter(|(d, _)| *d < TARGET_GATE)
                .min_by(|a, b| a.0.total_cmp(&b.0))
                .map(|(_, s)| (s.id, Vec3::from(s.centroid)))
        });
        if near.is_some() {
            return Ok(near);
        }
        Ok(self
            .search_within(at, TARGET_GATE)?
            .and_then(|(id, seen)| id.map(|id| (id, seen.centroid))))
    }

    pub(super) fn search_within(
        &mut self,
        last: &Vec3,
        gate: f64,
    ) -> Result<Option<(Option<u32>, SeenObject)>, RobotError> {
        let found = self.scan_for(last, gate)?;
        if found.is_some() {
            return Ok(found);
        }
        // Not seen anywhere: the robot's own arms may hide it (a parked arm's upper arm crosses the
        // head cameras' view of its side of the table). Stow the free arms out to the sides and
        // scan again.
        if self.stow_free_arms()? {
            self.scan_for(last, gate)
        } else {
            Ok(None)
        }
    }

    /// Moves each arm that holds nothing to its stowed pose ([`stow_pose`]), out of the head's view
    /// of the table. Whether any arm moved.
    pub(crate) fn stow_free_arms(&mut self) -> Result<bool, RobotError> {
        let mut moved = false;
        for arm in Arm::BOTH {
            moved |= self.stow(arm)?;
        }
        Ok(moved)
    }

    /// Moves `arm` to its stowed pose ([`stow_pose`]) unless it holds something or is there
    /// already. Whether it moved.
    pub(crate) fn stow(&mut self, arm: Arm) -> Result<bool, RobotError> {
        if self.touch(arm).holding() {
            return Ok(false);
        }
        let k = arm.index();
        let stow = stow_pose(arm, self.workspace.table_z);
        if (self.reach[k].tool_pose(self.hw).translation.vector - stow.translation.vector).norm() < 0.03 {
            return Ok(false);
        }
        self.with_observer(|hw, reach, _, obs| {
            reach[k].set_goal(hw, stow);
            run_until(hw, &mut reach[k], obs, 3.0, |h, r| r.at_goal(h, 0.02, 0.1));
        })?;
        Ok(true)
    }

    /// [`RobotPlant::search_within`]'s scan of the table from where the arms are.
    pub(super) fn scan_for(&mut self, last: &Vec3, gate: f64) -> Result<Option<(Option<u32>, SeenObject)>, RobotError> {
        let table_z = self.workspace.table_z;
        // Segments that look like the target first (its colour terms overlap by
        // [`LOOKS_ALIKE`]: a rolled object is found beside a nearer one of another colour), then
        // tracks seen whole (one only ever seen cut by the image border or an arm has a biased
        // centroid: the visible piece of another object), then by distance.
        let mut best: Option<((bool, bool, f64), u32, SeenObject)> = None;
        for at in self.workspace.scan_points() {
            self.look(&at, 0.6)?;
            let Some(p) = self.percepts.last() else {
                continue;
            };
            tracing::debug!(
                "search from {:.2?}: {} tracks, {} seen",
                [at.x, at.y],
                p.segments.len(),
                p.segments.iter().filter(|s| s.seen).count()
            );
            for s in p.segments.iter().filter(|s| s.seen) {
                if !self.may_be_target(s) || self.is_other(s) {
                    tracing::debug!(
                        "search from {:.2?}: segment {} at {:.3?} passed over ({})",
                        [at.x, at.y],
                        s.id,
                        s.centroid,
                        if self.is_other(s) {
                            "another object's"
                        } else {
                            "not a target's size or height"
                        }
                    );
                    continue;
                }
                let c = Vec3::from(s.centroid);
                let d = (c - last).xy().norm();
                let on_table = c.z > table_z && c.z < table_z + 0.4;
                let in_place = self.workspace.places.iter().any(|pl| pl.contains([c.x, c.y]));
                let carried = p
                    .hands
                    .iter()
                    .any(|h| (Vec3::from(h.palm) - c).norm() < 0.12 && h.load.abs() > 0.5);
                let unlike = !self.target_colors.is_empty()
                    && !s.colors.is_empty()
                    && colour_overlap(&self.target_colors, &s.colors) < LOOKS_ALIKE;
                let key = (unlike, !self.watcher.seen_whole(s.id), d);
                tracing::debug!(
                    "search from {:.2?}: segment {} at {:.3?}, {d:.3} m from the last sighting, on table {on_table}, in a place {in_place}, carried {carried}, unlike {unlike}",
                    [at.x, at.y],
                    s.id,
                    s.centroid
                );
                if d < gate && on_table && !in_place && !carried && best.as_ref().is_none_or(|b| key < b.0) {
                    best = Some((key, s.id, SeenObject::from_percept(s, table_z)));
                }
            }
        }
        // Keep the head on what was found: the scan left it looking at its last point, and an
        // object out of view while the arm approaches is lost to the tracker (and to the monitors).
        if let Some((_, _, seen)) = &best {
            let at = seen.centroid;
            self.look(&at, 0.5)?;
        }
        Ok(best.map(|(_, id, seen)| (Some(id), seen)))
    }

    pub(super) fn touch(&self, arm: Arm) -> TouchState {
        let mut buf = Vec::new();
        TouchState::of(&hand_fingertips(self.hw, arm, &mut buf))
    }
}
