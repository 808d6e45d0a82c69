//! Dexter as a [`schema::SchemaPlant`]: the executive's abstract actions bound to Dexter's arms,
//! hands and the objects it sees, run with the control-basis skills of [`crate::skills`], observed
//! through the same monitors that watch a teacher (§4.2) — so the robot knows which state of the
//! schema it is in from its own sensors. Objects are the segments the robot tracks (their ids);
//! it knows its table and its places ([`Workspace`]), nothing else of the world.
//!
//! | abstract action | what runs |
//! |---|---|
//! | `reach_object` | Reach ◁ Manipulability to the pre-grasp above the seen object (its measured footprint and height), then down |
//! | `grasp` | close until the fingertips squeeze from opposite sides and the fingers are still |
//! | `hold` | lift 10 cm and weigh on the fingertips |
//! | `place` | Reach ◁ Place: carry over the place, lower until the support takes the load; for a transfer, onto the handoff spot and open |
//! | `release` | open and retreat |
//! | `search_track` | look at the object |

use control_basis::Hardware;
use control_basis::math::{Iso3, Vec3};
use schema::{
    ActionOutcome, Binding, Failure, FailureCause, Library, MonitorBank, MonitorConfig, Percept, PlacePercept,
    SchemaPlant, StepEvent,
};
use serde::{Deserialize, Serialize};

use crate::actions::{Skill, SkillMap};
use crate::arm::Arm;
use crate::control::{HandControl, ReachControl};
use crate::error::RobotError;
use crate::eyes::Eyes;
use crate::skills::{
    GraspPlan, Held, MIN_LOAD, Observer, SeenObject, TouchState, approach_grasp, close_grasp, finger_arc,
    hand_fingertips, idle, lift_and_weigh, lower_until_supported, park_pose, plan_top_grasp_among, reachable,
    release_and_retreat, run_until, stow_pose, touch_object, transport_over,
};
use crate::watch::Watcher;

/// A place the robot knows (a bin): name, centre and size of its floor region (m, world), walls.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Place {
    /// Name.
    pub name: String,
    /// Centre (x, y).
    pub center: [f64; 2],
    /// Size (x, y) of the inside.
    pub size: [f64; 2],
    /// Wall height above the table (m).
    pub wall_height: f64,
    /// Wall thickness (m).
    pub wall_thickness: f64,
}

impl Place {
    /// Whether `xy` lies inside the place region.
    pub fn contains(&self, xy: [f64; 2]) -> bool {
        (xy[0] - self.center[0]).abs() <= self.size[0] / 2.0 && (xy[1] - self.center[1]).abs() <= self.size[1] / 2.0
    }
}

/// How far beyond the table's edge a seen centre may lie and still be on the table (m): the
/// measured footprint's error.
pub const TABLE_EDGE_MARGIN: f64 = 0.02;

/// The highest a seen thing's centre may be above the table and still stand on it (m): half the
/// tallest thing a tabletop holds (a 0.8 m post), with room for the measured height's error.
pub const MAX_OBJECT_CENTRE_HEIGHT: f64 = 0.45;

/// What the robot is told about its workspace: the table and its places — never objects.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Workspace {
    /// Table top height (m).
    pub table_z: f64,
    /// Table centre (x, y).
    pub table_center: [f64; 2],
    /// Table size (x, y).
    pub table_size: [f64; 2],
    /// The places.
    pub places: Vec<Place>,
}

impl Workspace {
    /// Whether a seen thing stands on the table: its centre over the table top (within
    /// [`TABLE_EDGE_MARGIN`], for the measured footprint) and no higher above it than
    /// [`MAX_OBJECT_CENTRE_HEIGHT`]. Anything else — a part of the robot's own body that its
    /// self-mask missed, seen beside the table or in the air — is nothing to act on.
    pub fn stands_on_table(&self, centroid: [f64; 3]) -> bool {
        (centroid[0] - self.table_center[0]).abs() <= self.table_size[0] / 2.0 + TABLE_EDGE_MARGIN
            && (centroid[1] - self.table_center[1]).abs() <= self.table_size[1] / 2.0 + TABLE_EDGE_MARGIN
            && centroid[2] - self.table_z <= MAX_OBJECT_CENTRE_HEIGHT
    }

    /// Where the head looks to scan the table: two rows of four points across its width.
    pub fn scan_points(&self) -> Vec<Vec3> {
        let mut out = Vec::new();
        let (cx, cy) = (self.table_center[0], self.table_center[1]);
        let hy = (self.table_size[1] / 2.0 - 0.1).max(0.0);
        for x in [cx - 0.08, cx + 0.1] {
            for k in 0..4 {
                let y = cy - hy + 2.0 * hy * f64::from(k) / 3.0;
                out.push(Vec3::new(x, y, self.table_z + 0.03));
            }
        }
        out
    }

    /// The place named `name`.
    pub fn place(&self, name: &str) -> Result<&Place, RobotError> {
        self.places.iter().find(|p| p.name == name).ok_or_else(|| {
            RobotError::invalid(
                "workspace",
                "place",
                format!(
                    "unknown place `{name}`; known: {}",
                    self.places
                        .iter()
                        .map(|p| p.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            )
        })
    }

    /// The places as the monitors see them.
    pub fn place_percepts(&self) -> Vec<PlacePercept> {
        self.places
            .iter()
            .map(|p| PlacePercept {
                name: p.name.clone(),
                center: [p.center[0], p.center[1], self.table_z],
                half_extents: [p.size[0] / 2.0, p.size[1] / 2.0],
            })
            .collect()
    }
}

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
const HEAD_LIMIT_MARGIN: f64 = 0.25;

/// A tall thing whose footprint centre lies this close (m, horizontally) to a palm is what the
/// hand holds, not an obstacle (a palm stopped against a post's face is 8 cm or more from its
/// centre).
const HELD_UNDER_PALM: f64 = 0.06;

/// How much (m, horizontal) of the line from a handoff spot back to an arm's shoulder the
/// handoff planner checks against the tall things seen: all of it (an arm reaching down to the spot
/// lies over that line, shoulder to palm). Only the forearm's 0.35 m was checked at first: spots
/// it let through lay behind the post from the other shoulder (blocked arm, dev seed 3: 8/26
/// recovered; the whole line: 12/26, and 12/26 on seed 2).
const FOREARM_LENGTH: f64 = 1.0;

/// How far (m) an arm's line must keep from a tall thing's footprint: the forearm's radius and a
/// margin.
const FOREARM_CLEARANCE: f64 = 0.08;

/// How far (m) a handoff spot keeps from the table's far edge. Was 0.12, as from the near edge:
/// with a post in the middle of the table, spots 8–12 cm from the far edge were taken, and a
/// receiving hand that missed there pushed the object off the table (blocked arm, dev seeds 2
/// and 3: 7 of 24 failures).
const HANDOFF_FAR_MARGIN: f64 = 0.18;

/// The other arm's palm within this horizontal distance (m) of an object to reach is moved away
/// first.
const CLEAR_RADIUS: f64 = 0.25;

/// Room (m) between a placed object and a place's walls: for the opening fingers, and so that a
/// rolling object is not let go on the wall.
const WALL_ROOM: f64 = 0.03;

/// Smallest horizontal distance (m) from the handoff spot to where a reach did not converge: the
/// arm that failed there may have to take the object at the handoff spot.
const UNREACHED_CLEARANCE: f64 = 0.25;

/// Smallest horizontal distance (m) from where an arm's reach failed to that arm's straight path
/// from its parked pose to the handoff spot.
const UNREACHED_PATH_CLEARANCE: f64 = 0.16;

/// Horizontal distance from `p` to the segment from `a` to `b`.
fn distance_to_segment(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let l2 = dx * dx + dy * dy;
    let t = if l2 > 0.0 {
        (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p[0] - a[0] - t * dx).hypot(p[1] - a[1] - t * dy)
}

/// Where in a place region (`center`, `size`) to put an object of horizontal radius `radius`
/// among `others` (centre, radius) already there: the point of a 1 cm grid inside the region (the
/// object clear of the walls by [`WALL_ROOM`]) with the widest gap between the object's footprint
/// and theirs, nearest the centre among equals (gaps count to the centimetre) — so objects already
/// in a bin are not landed on. The centre when the region leaves no room to choose. (Preferring
/// a spot clear of the objects over the walls' room, down to 0.5 cm, placed 4 fewer of 198 objects
/// on development seeds 1–3: the fingers met the walls and let go high.)
///
/// An empty region fills from the back: the object goes to the end of the region's longer axis
/// away from `from` (where objects come from), so that the next one has the other end. (In the
/// middle of a 20 × 25 cm bin a 7 cm box left no spot for a 13 cm bottle, which was set on top of
/// it.) Without `from`, or with no room along the axis, the centre.
pub fn free_spot(
    center: [f64; 2],
    size: [f64; 2],
    radius: f64,
    others: &[([f64; 2], f64)],
    from: Option<[f64; 2]>,
) -> [f64; 2] {
    let half = [size[0] / 2.0 - radius - WALL_ROOM, size[1] / 2.0 - radius - WALL_ROOM];
    if half[0] <= 0.0 || half[1] <= 0.0 {
        return center;
    }
    if others.is_empty() {
        let Some(from) = from else {
            return center;
        };
        let long = usize::from(size[1] > size[0]);
        let away = if from[long] > center[long] { -1.0 } else { 1.0 };
        let mut spot = center;
        spot[long] += away * (half[long] / 0.01 + 1e-9).floor() * 0.01;
        return spot;
    }
    let n = [
        (half[0] / 0.01 + 1e-9).floor() as i32,
        (half[1] / 0.01 + 1e-9).floor() as i32,
    ];
    let mut best = (f64::NEG_INFINITY, f64::INFINITY, center);
    for i in -n[0]..=n[0] {
        for j in -n[1]..=n[1] {
            let c = [center[0] + 0.01 * f64::from(i), center[1] + 0.01 * f64::from(j)];
            let gap = others
                .iter()
                .map(|(o, r)| (o[0] - c[0]).hypot(o[1] - c[1]) - r)
                .fold(f64::INFINITY, f64::min);
            let off = (c[0] - center[0]).hypot(c[1] - center[1]);
            let gap = (gap * 100.0).round();
            if (gap, -off) > (best.0, -best.1) {
                best = (gap, off, c);
            }
        }
    }
    best.2
}

/// How long (s) after an action converged the plant waits at most for its monitor set to see it.
const MONITOR_WAIT_SECS: f64 = 1.0;

/// Objects counted up to this height (m) when carrying over them (a segment merged with something
/// above it may measure taller than any object on the table).
const MAX_OBSTACLE_HEIGHT: f64 = 0.25;

/// How long (s) the head looks into a place before a spot in it is chosen: a few frames for the
/// tracker to see what lies there.
const PLACE_LOOK_SECS: f64 = 0.6;

/// The footprint radius (m) counted for an object seen in a place: objects lying in a bin are not
/// measured on the table's plane, and a coarse silhouette disc may take a bin's wall along.
const IN_PLACE_RADIUS: f64 = 0.06;

/// Segments within this distance (m) of the transferred object's position are that object.
const MERGE_RADIUS: f64 = 0.05;
/// The scan before a handoff spot is chosen looks at the scan points this close (m, across the
/// table) to the table's centre line.
const HANDOFF_SCAN_HALF_WIDTH: f64 = 0.25;
/// Room (m) between the straight carry to a handoff spot and a seen segment's side: the carried
/// object and the fingers around it. The carry is low (8 cm above the table), so a thing on the way
/// would knock the object out of the hand.
const CARRY_PATH_ROOM: f64 = 0.08;
/// Horizontal radius (m) assumed for a segment seen without a measured extent.
const SEEN_RADIUS: f64 = 0.05;
/// A seen thing taller than this (m) stands in the way of a hand moving at hover height (32 cm or
/// more above the table).
const TALL_THING: f64 = 0.25;

/// The horizontal distance (m) from table point `p` to the walls of `place` (0 on a wall).
fn wall_distance(place: &Place, p: [f64; 2]) -> f64 {
    // Distance to the rectangle of half size `h` about the place's centre, inside or out.
    let rect = |h: [f64; 2]| {
        let d = [
            (p[0] - place.center[0]).abs() - h[0],
            (p[1] - place.center[1]).abs() - h[1],
        ];
        if d[0] > 0.0 || d[1] > 0.0 {
            d[0].max(0.0).hypot(d[1].max(0.0))
        } else {
            -d[0].max(d[1])
        }
    };
    let inner = [place.size[0] / 2.0, place.size[1] / 2.0];
    let outer = [inner[0] + place.wall_thickness, inner[1] + place.wall_thickness];
    let inside_inner = (p[0] - place.center[0]).abs() < inner[0] && (p[1] - place.center[1]).abs() < inner[1];
    let inside_outer = (p[0] - place.center[0]).abs() <= outer[0] && (p[1] - place.center[1]).abs() <= outer[1];
    if inside_inner {
        rect(inner)
    } else if inside_outer {
        0.0
    } else {
        rect(outer)
    }
}

/// How far (m) above the grasp pose the reach of a task that only touches stops
/// ([`RobotPlant::set_touch_task`]).
const PRE_TOUCH_HEIGHT: f64 = 0.04;

/// A segment as the handoff planner sees it: centre (x, y), horizontal radius (its measured half
/// length, or [`SEEN_RADIUS`]) and height (measured, or 0), m.
#[derive(Debug, Clone, Copy)]
struct SeenThing {
    at: [f64; 2],
    radius: f64,
    height: f64,
}

impl SeenThing {
    fn of(s: &schema::SegmentPercept) -> Self {
        SeenThing {
            at: [s.centroid[0], s.centroid[1]],
            radius: s.extent.as_ref().map_or(SEEN_RADIUS, |e| e.half_major),
            height: s.extent.as_ref().map_or(0.0, |e| e.height),
        }
    }
}
/// Least overlap of two segments' colour terms ([`colour_overlap`]) for one to look like the other.
const LOOKS_ALIKE: f64 = 0.3;

/// The overlap of two colour-term distributions (histogram intersection: the share of pixels whose
/// terms both have), 0 (nothing alike) to 1 (the same).
fn colour_overlap(a: &[(u8, f64)], b: &[(u8, f64)]) -> f64 {
    a.iter()
        .map(|&(t, wa)| b.iter().find(|(u, _)| *u == t).map_or(0.0, |&(_, wb)| wa.min(wb)))
        .sum()
}

/// The head cameras' frames: a handoff spot is chosen where neither sees the object hidden behind a
/// seen thing.
const HEAD_CAMERA_FRAMES: [&str; 2] = ["head/left_camera_optical_frame", "head/right_camera_optical_frame"];
/// Points sampled along a camera's line of sight to a handoff spot.
const SIGHT_SAMPLES: usize = 24;

/// A segment this close (m) to a carrying palm is the carried object.
const CARRIED_CLEARANCE: f64 = 0.15;

/// After a grasp closed on nothing, the seen segment nearer than this (m) to where the target
/// was is the target (it was pushed).
const REACQUIRE_GATE: f64 = 0.2;

/// The tracked segment nearer than this (m) to where the target was last seen is the target.
const TARGET_GATE: f64 = 0.08;

/// A lost target is searched for this far (m) from where it was last seen.
const SEARCH_GATE: f64 = 0.5;

/// Before a grasp closes: the target seen farther than this (m, horizontally) from where the grasp
/// was planned has moved (a bump moves it 4–8 cm; a resting object's track wanders < 1 cm).
const MOVED_GATE: f64 = 0.03;

/// Arms whose palm can reach 15 cm above `point` pointing down (IK within limits).
pub fn arms_reaching(hw: &dyn Hardware, table_z: f64, point: &Vec3) -> Result<Vec<Arm>, RobotError> {
    let mut out = Vec::new();
    for arm in Arm::BOTH {
        let mut over = park_pose(arm, table_z);
        over.translation.vector = Vec3::new(point.x, point.y, point.z.max(table_z) + 0.15);
        if reachable(hw.model(), arm, &over, 5)? {
            out.push(arm);
        }
    }
    Ok(out)
}

/// The set predicates (4.17) over the monitors bound to `arms` (all when `None`); the monitor set
/// of `reach` = (action index, arm) only over that arm's monitors — the arm ψ bound to the latest
/// action: a reach is a controller of one arm and its object, and the other, parked hand resting
/// near some segment (a phantom under it, a wall) is not reaching.
fn bound_x(o: &schema::monitor::Observation, arms: Option<&[String]>, reach: Option<&(usize, String)>) -> Vec<bool> {
    let mut x = vec![false; o.x.len()];
    for h in &o.hits {
        if let Some((a, arm)) = reach
            && h.action == *a
            && h.arm.as_ref().is_some_and(|b| b != arm)
        {
            continue;
        }
        if arms.is_none_or(|arms| h.arm.as_ref().is_none_or(|a| arms.contains(a))) {
            x[h.action] = true;
        }
    }
    x
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

/// Dexter driven by the executive.
pub struct RobotPlant<'a> {
    /// The hardware.
    pub hw: &'a mut dyn Hardware,
    workspace: &'a Workspace,
    watcher: Watcher,
    bank: MonitorBank,
    last_x: Vec<bool>,
    reach: [ReachControl; 2],
    hand: [HandControl; 2],
    /// The object being manipulated (its track id and what was seen of it), once a reach bound it.
    target: Option<(Option<u32>, SeenObject)>,
    /// The target's colour terms when a reach last found it seen (what a search looks for).
    target_colors: Vec<(u8, f64)>,
    /// The other objects the task decided on, (track, where it was decided on, left alone)
    /// ([`RobotPlant::set_other_objects`]): never taken for a lost target.
    others: Vec<(u32, [f64; 3], bool)>,
    /// The task touches its object without grasping it ([`RobotPlant::set_touch_task`]).
    touch_task: bool,
    plan: Option<GraspPlan>,
    /// The first track id not yet given when the grasp was planned (tracks from then on are new).
    plan_next_id: u32,
    /// Palm pose when the last grasp converged.
    grasp_palm: Option<Iso3>,
    held: Option<Held>,
    /// The arms the procedural policy bound (None: all); see [`RobotPlant::bind_arms`].
    bound_arms: Option<Vec<String>>,
    handoff: [f64; 2],
    /// Where reaches to an object did not converge (x, y): a transfer's handoff spot keeps clear
    /// of them.
    unreached: Vec<(Arm, [f64; 2])>,
    /// Where the object is to end up (the task's place centre, [`RobotPlant::set_destination`]):
    /// after a hand-over the failed arm carries it there from the handoff spot.
    destination: Option<[f64; 2]>,
    /// The last grasp closed on nothing (the object may have moved).
    missed: bool,
    /// The track whose doubted position ([`Watcher::doubted`]) the robot already looked at again
    /// with the hand out of the way: it is not doubted twice.
    doubt_checked: Option<u32>,
    /// The next reach follows a back-off for a doubted track: it takes what it then sees of it.
    relook: bool,
    /// The object (as the binding names it) and how many reaches in a row did not see it.
    unseen: (Option<String>, usize),
    /// The library's action names (the entries of x).
    action_names: Vec<String>,
    /// The library's actions bound to Dexter's skills, by signature.
    skills: SkillMap,
    /// The reach monitor set's index and the arm ψ bound to the latest action ([`bound_x`]).
    reach_arm: Option<(usize, String)>,
    sink: &'a mut dyn ExecSink,
    t0: f64,
    next_percept: f64,
    percept_period: f64,
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

fn parse_arm(action: &str, s: Option<&str>) -> Result<Arm, RobotError> {
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
        // 108/118) but recovered 8 of 26 blocked arms on seed 2 against 10.
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
            bound_arms: None,
            handoff: [workspace.table_center[0].min(0.55), 0.0],
            unreached: Vec::new(),
            destination: None,
            missed: false,
            doubt_checked: None,
            relook: false,
            unseen: (None, 0),
            action_names: library.actions.iter().map(|a| a.name.clone()).collect(),
            skills: SkillMap::new(library),
            reach_arm: None,
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
        self.bound_arms = Some(arms.iter().map(|a| a.prefix().to_string()).collect());
        // The first arm acts first.
        if let (Some(a), Some(arm)) = (self.skills.index(Skill::ReachObject), arms.first()) {
            self.reach_arm = Some((a, arm.prefix().to_string()));
        }
        if let Some(p) = self.percepts.last() {
            let p = p.clone();
            let o = self.bank.observe(&p);
            self.last_x = bound_x(&o, self.bound_arms.as_deref(), self.reach_arm.as_ref());
        }
    }

    /// Looks at `at` and takes percepts for `seconds` (to refresh what is seen there).
    pub fn look(&mut self, at: &Vec3, seconds: f64) -> Result<(), RobotError> {
        self.watcher.look_at(self.hw, at)?;
        self.settle(seconds)
    }

    /// The objects the latest percept holds (seen now or remembered), as seen on the table, but
    /// not the one carried by the palm at `carrying_palm`.
    fn seen_objects(&self, carrying_palm: Option<&Vec3>) -> Vec<SeenObject> {
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
    fn tall_things(&mut self) -> Vec<crate::route::Obstacle> {
        let table_z = self.workspace.table_z;
        let Some(p) = self.percepts.last() else {
            return Vec::new();
        };
        // Only a hand that holds something can be seen merged with it: an empty hand stopped
        // beside a post (the arm it blocked) must not hide the post (development seed 2, blocked
        // arm, scene 11: the right palm 14 cm from the post's coarse centroid, no tall thing kept,
        // and the carry went into the post).
        let holding = Arm::BOTH.map(|a| self.touch(a).holding());
        let palms: Vec<Vec3> = self
            .reach
            .iter_mut()
            .zip(holding)
            .filter(|(_, h)| *h)
            .map(|(r, _)| r.tool_pose(self.hw).translation.vector)
            .collect();
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
    fn held_or_felt(&mut self, arm: Arm) -> Option<Held> {
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
        self.held = Some(Held::new(seen, &palm, self.workspace.table_z, touch.load));
        self.held
    }

    /// The objects seen in `place` now (centre (x, y) and footprint radius, m): the tracks of the
    /// latest percept whose centroid lies in the place region (with 5 cm of margin: an object
    /// leaning on a wall), except the one carried by the palm at `carrying_palm`.
    fn seen_in_place(&self, place: &Place, carrying_palm: Option<[f64; 3]>) -> Vec<([f64; 2], f64)> {
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

    /// Where in `place` to put a carried object: looks into the place first (the head sees a part
    /// of the table at a time, and tracks out of view are soon forgotten, so what was seen while
    /// grasping says little about the bin), then [`free_spot`] among the objects seen in it.
    fn place_spot(&mut self, place: &Place, held: &Held, arm: Arm) -> Result<[f64; 2], RobotError> {
        let table_z = self.workspace.table_z;
        self.look(
            &Vec3::new(place.center[0], place.center[1], table_z + 0.03),
            PLACE_LOOK_SECS,
        )?;
        let palm = self.percepts.last().map(|q| q.hands[arm.index()].palm);
        let others = self.seen_in_place(place, palm);
        // Objects come from the table: an empty place fills from its end away from the table's middle.
        let from = Some(self.workspace.table_center);
        let spot = free_spot(place.center, place.size, held.radius, &others, from);
        tracing::debug!("place spot {spot:?} in {} among {others:?}", place.name);
        Ok(spot)
    }

    /// The handoff spot (x, y).
    pub fn handoff(&self) -> [f64; 2] {
        self.handoff
    }

    /// The place the object is to end up in (`None`, or a name the workspace does not know: no
    /// destination). A handoff spot keeps the way from it to there clear of failed reaches.
    pub fn set_destination(&mut self, place: Option<&str>) {
        self.destination = place.and_then(|p| self.workspace.place(p).ok()).map(|p| p.center);
    }

    /// Chooses the handoff spot for a transfer of the object seen near `object_at` (5.32): a free
    /// patch of table that both arms reach pointing down, as seen now — at least
    /// [`HANDOFF_CLEARANCE`] (at least [`HANDOFF_MIN_CLEARANCE`]) from every other segment the cameras see and clear of the places'
    /// walls, and one the head can look at — preferring spots the object can be carried to in a
    /// straight line without passing another seen segment ([`CARRY_PATH_ROOM`]), then spots clear
    /// of where a reach failed
    /// ([`UNREACHED_CLEARANCE`], and the failed arm's ways there from its parked pose and on to the
    /// destination, [`RobotPlant::set_destination`]), then the table's centre line at a
    /// comfortable reach (x = 0.55 m); when no spot is clear, one whose ways are clear, farthest
    /// from the failed reaches; failing that, the one with the clearest ways. Candidates lie on a
    /// 5 cm grid; the first both arms reach is taken. Keeps the previous spot and returns `None` if
    /// none is free.
    pub fn plan_handoff(&mut self, object_at: &Vec3) -> Result<Option<[f64; 2]>, RobotError> {
        self.plan_handoff_among(object_at, &[])
    }

    /// [`RobotPlant::plan_handoff`] keeping clear also of `also_seen` (segments seen elsewhere,
    /// [`RobotPlant::scan_handoff_region`]).
    fn plan_handoff_among(
        &mut self,
        object_at: &Vec3,
        also_seen: &[SeenThing],
    ) -> Result<Option<[f64; 2]>, RobotError> {
        // Whether an arm's forearm, from its palm over spot `c` back towards its shoulder, would
        // lie on a tall thing there (a post beside the spot: the descending forearm rests on it).
        let tall = self.tall_things();
        let mut body = crate::body::Body::new();
        let mut shoulders = Vec::with_capacity(2);
        for a in Arm::BOTH {
            // On the base yaw axis: where it is does not depend on the joint angles.
            let p = body.pose(self.hw, &format!("{}/shoulder_pitch_link", a.prefix()))?;
            shoulders.push([p.translation.x, p.translation.y]);
        }
        tracing::debug!("shoulders {shoulders:?}, tall things {tall:?}");
        let ws = self.workspace;
        let table_z = ws.table_z;
        // Other segments, as seen.
        let sized: Vec<SeenThing> = self
            .percepts
            .last()
            .map(|p| p.segments.iter().map(SeenThing::of).collect::<Vec<_>>())
            .unwrap_or_default()
            .into_iter()
            .chain(also_seen.iter().copied())
            .filter(|t| (t.at[0] - object_at.x).hypot(t.at[1] - object_at.y) > MERGE_RADIUS)
            .collect();
        let others: Vec<[f64; 2]> = sized.iter().map(|t| t.at).collect();
        // Whether the straight carry from `object_at` to spot `c` (low: 8 cm above the table,
        // below most things' tops) passes a seen thing (nearer than it started: an object picked up
        // beside a thing may be carried away from it), or a failed arm's way from its parked pose
        // to `c` (at hover height) passes a thing taller than that.
        let carry_blocked = |c: [f64; 2]| {
            sized.iter().any(|t| {
                let room = t.radius + CARRY_PATH_ROOM;
                let start = (t.at[0] - object_at.x).hypot(t.at[1] - object_at.y);
                let path = distance_to_segment(t.at, [object_at.x, object_at.y], c);
                (path < room && path < start - 0.01)
                    || (t.height > TALL_THING
                        && self.unreached.iter().any(|(arm, _)| {
                            let park = park_pose(*arm, table_z).translation.vector;
                            distance_to_segment(t.at, [park.x, park.y], c) < room
                        }))
            })
        };
        // How far the nearer forearm keeps from a tall thing, up to [`FOREARM_CLEARANCE`].
        let forearm_room = |c: [f64; 2]| {
            shoulders
                .iter()
                .map(|s| {
                    let (dx, dy) = (s[0] - c[0], s[1] - c[1]);
                    let l = dx.hypot(dy).max(1e-9);
                    let reach = FOREARM_LENGTH.min(l);
                    let end = [c[0] + dx / l * reach, c[1] + dy / l * reach];
                    crate::route::clearance_of(c, end, &tall, FOREARM_CLEARANCE)
                })
                .fold(FOREARM_CLEARANCE, f64::min)
        };
        let margin = 0.12;
        let (x0, x1) = (
            ws.table_center[0] - ws.table_size[0] / 2.0 + margin,
            ws.table_center[0] + ws.table_size[0] / 2.0 - HANDOFF_FAR_MARGIN,
        );
        // Per candidate, how far it keeps clear of the failed reaches, each relative to its bound
        // (≥ 0: clear): `(ways, spot)` — the failed arm's ways (from its parked pose to the spot and
        // on from the spot to the destination; an arm that cannot pass there cannot carry the
        // object past it either) and the spot's own distance from them.
        let clearance = |c: [f64; 2]| -> (f64, f64) {
            self.unreached
                .iter()
                .fold((f64::INFINITY, f64::INFINITY), |(ways, spot), (arm, o)| {
                    let park = park_pose(*arm, table_z).translation.vector;
                    let path = distance_to_segment(*o, [park.x, park.y], c) - UNREACHED_PATH_CLEARANCE;
                    let onward = self.destination.map_or(f64::INFINITY, |d| {
                        distance_to_segment(*o, c, d) - UNREACHED_PATH_CLEARANCE
                    });
                    let away = (o[0] - c[0]).hypot(o[1] - c[1]) - UNREACHED_CLEARANCE;
                    (ways.min(path).min(onward), spot.min(away))
                })
        };
        let mut candidates = Vec::new();
        for i in 0..=((x1 - x0) / 0.05).floor() as i32 {
            for j in -6..=6 {
                let c = [x0 + 0.05 * f64::from(i), ws.table_center[1] + 0.05 * f64::from(j)];
                let room = others
                    .iter()
                    .map(|o| (o[0] - c[0]).hypot(o[1] - c[1]))
                    .fold(f64::INFINITY, f64::min);
                let free = room >= HANDOFF_MIN_CLEARANCE
                    && ws.places.iter().all(|p| {
                        (c[0] - p.center[0]).abs() > p.size[0] / 2.0 + p.wall_thickness + 0.08
                            || (c[1] - p.center[1]).abs() > p.size[1] / 2.0 + p.wall_thickness + 0.08
                    });
                if free {
                    candidates.push((
                        c,
                        clearance(c),
                        (forearm_room(c), carry_blocked(c), room < HANDOFF_CLEARANCE),
                    ));
                }
            }
        }
        // Spots clear of the failed reaches in every respect first, by comfort; then those whose
        // ways are clear, the farthest from the failed reaches first; then the rest, the clearest
        // ways first (the failed reach lay where the arms meet). Within each, spots with the full
        // room around them ([`HANDOFF_CLEARANCE`]) before those with less. Spots the object can be
        // carried to without passing a seen thing come before all others, and before those, spots
        // where neither arm's forearm would lie on a tall thing (when there are none, the spots
        // whose forearms keep farthest from one).
        let cost = |c: &[f64; 2]| (c[1] - ws.table_center[1]).abs() + 0.5 * (c[0] - 0.55).abs();
        let rank = |&(ways, spot): &(f64, f64)| u8::from(ways < 0.0) + u8::from(spot < 0.0 || ways < 0.0);
        candidates.sort_by(|a, b| {
            b.2.0
                .total_cmp(&a.2.0)
                .then(a.2.1.cmp(&b.2.1))
                .then(rank(&a.1).cmp(&rank(&b.1)))
                .then(a.2.2.cmp(&b.2.2))
                .then_with(|| match rank(&a.1) {
                    0 => cost(&a.0).total_cmp(&cost(&b.0)),
                    1 => b.1.1.total_cmp(&a.1.1),
                    _ => b.1.0.total_cmp(&a.1.0),
                })
        });
        if tracing::enabled!(tracing::Level::DEBUG) {
            let blocked = candidates.iter().filter(|c| c.2.1).count();
            let forearms = candidates.iter().filter(|c| c.2.0 < FOREARM_CLEARANCE).count();
            tracing::debug!(
                "handoff candidates {} ({forearms} with a forearm on a tall thing, {blocked} with a seen thing on the way), things seen {sized:?}",
                candidates.len(),
            );
        }
        // Whether a seen thing stands between a head camera and the top of the object put down on
        // spot `c` (a tall box in front of it): the object there would be hidden from the head
        // whole, and the receiving hand would not find it. (The cameras move a few cm as the head
        // turns to the spot; the thing's footprint is its seen radius; the object's top is twice
        // its centroid's height.)
        let mut eyes = [Vec3::zeros(); 2];
        for (eye, link) in eyes.iter_mut().zip(HEAD_CAMERA_FRAMES) {
            *eye = body.pose(self.hw, link)?.translation.vector;
        }
        let top_z = table_z + (2.0 * (object_at.z - table_z)).max(0.01);
        let hidden = |c: [f64; 2]| {
            let p = Vec3::new(c[0], c[1], top_z);
            eyes.iter().any(|e| {
                sized.iter().any(|t| {
                    (1..SIGHT_SAMPLES).any(|i| {
                        let q = e + (p - e) * (i as f64 / SIGHT_SAMPLES as f64);
                        (q.x - t.at[0]).hypot(q.y - t.at[1]) < t.radius && q.z < table_z + t.height
                    })
                })
            })
        };
        // Spots the head sees the object on first, to which both arms have a way clear of the
        // tall things (the holding arm's carry, the other's reach; [`crate::skills::plan_way`]);
        // then seen spots; then spots with clear ways; then any.
        for (must_see, must_clear) in [(true, true), (true, false), (false, true), (false, false)] {
            if must_clear && tall.is_empty() {
                continue;
            }
            for (c, _, _) in &candidates {
                let c = *c;
                // The head must turn to the spot (both cameras, for stereo) to find the object there.
                let seen_at = Vec3::new(c[0], c[1], table_z + 0.05);
                if (must_see && hidden(c)) || !self.watcher.can_look_at(self.hw, &seen_at, HEAD_LIMIT_MARGIN)? {
                    continue;
                }
                if arms_reaching(self.hw, table_z, &Vec3::new(c[0], c[1], table_z))?.len() == 2
                    && (!must_clear || self.ways_to_spot_clear(c, &tall))
                {
                    tracing::debug!(
                        "handoff spot {c:?}{}{}",
                        if must_see { "" } else { " (hidden from the head)" },
                        if must_clear || tall.is_empty() {
                            ""
                        } else {
                            " (an arm's way passes a tall thing)"
                        }
                    );
                    self.handoff = c;
                    return Ok(Some(c));
                }
            }
        }
        Ok(None)
    }

    /// Whether both arms have a way to the handoff spot `c` that keeps the whole arm clear of the
    /// `tall` things ([`crate::skills::plan_way`], rolled out from where each arm is now): the arm
    /// that holds the object carrying it over the spot (its bottom [`Held::below`] the palm), the
    /// other reaching above the spot, each at its present height or higher — and on down to the
    /// spot; and no tall thing between the spot and the destination ([`RobotPlant::set_destination`]).
    fn ways_to_spot_clear(&mut self, c: [f64; 2], tall: &[crate::route::Obstacle]) -> bool {
        let table_z = self.workspace.table_z;
        // The receiving hand carries the object on to the destination: a spot beyond a tall thing
        // from there has it carried round (or over) the thing again, high and far.
        if let Some(d) = self.destination
            && !crate::route::clear_of(c, d, tall, crate::skills::ROUTE_CLEARANCE)
        {
            tracing::trace!("handoff spot {c:?}: a tall thing between it and the destination");
            return false;
        }
        for arm in Arm::BOTH {
            let held = self.held.filter(|_| self.touch(arm).holding());
            let (below, offset) = held.map_or((crate::sweep::HAND_LENGTH, [0.0; 2]), |h| (h.below, h.offset_xy));
            let reach = &mut self.reach[arm.index()];
            let mut goal = reach.tool_pose(self.hw);
            let q0 = reach.chain_configuration(self.hw);
            let z = goal.translation.z.max(table_z + below + 0.10);
            goal.translation.vector = Vec3::new(c[0] - offset[0], c[1] - offset[1], z);
            let saved = std::mem::replace(&mut reach.avoid, tall.to_vec());
            let way = crate::skills::plan_way(reach, q0.as_slice(), &goal, crate::skills::ROUTE_CLEARANCE, below);
            // Then down to the spot: the holding hand puts the object on the table, the other
            // grasps it there (its palm about an object's height above the table) — a forearm
            // that comes down onto a post beside the spot stops the hand short.
            let down = way.as_ref().filter(|w| w.clear).map(|w| {
                let mut low = goal;
                low.translation.vector.z = table_z + below.max(0.10);
                let mut poses = w.poses.clone();
                poses.push(low);
                let chain = reach.chain().clone();
                let sweep = reach.sweep(q0.as_slice(), &poses, 5.0, &mut |st| {
                    crate::sweep::arm_clearance(&chain, st, tall, f64::NEG_INFINITY, below)
                });
                sweep.reached && sweep.clearance >= w.clearance.min(crate::skills::SWEEP_MARGIN) - 1e-9
            });
            reach.avoid = saved;
            if way.is_some_and(|w| !w.clear) || down == Some(false) {
                tracing::trace!("handoff spot {c:?}: no clear way for the {arm} arm (down: {down:?})");
                return false;
            }
        }
        true
    }

    /// Looks over the middle of the table, where handoff spots lie (the scan points within
    /// [`HANDOFF_SCAN_HALF_WIDTH`] of its centre line), and returns the centres (x, y), horizontal
    /// radii and heights (m; measured, or [`SEEN_RADIUS`] and 0) of the segments seen there on
    /// the table, but not the one carried by the palm at `carrying_palm`:
    /// the head sees a part of the table at a time (tracks out of view are soon forgotten), and a
    /// spot chosen from the latest view alone may lie on an object out of it.
    fn scan_handoff_region(&mut self, carrying_palm: &Vec3) -> Result<Vec<SeenThing>, RobotError> {
        let table_z = self.workspace.table_z;
        let cy = self.workspace.table_center[1];
        let mut seen = Vec::new();
        for at in self.workspace.scan_points() {
            if (at.y - cy).abs() > HANDOFF_SCAN_HALF_WIDTH {
                continue;
            }
            self.look(&at, 0.6)?;
            let Some(p) = self.percepts.last() else {
                continue;
            };
            for s in p.segments.iter().filter(|s| s.seen) {
                let c = Vec3::from(s.centroid);
                if c.z > table_z - 0.02 && (c - carrying_palm).norm() > CARRIED_CLEARANCE {
                    seen.push(SeenThing::of(s));
                }
            }
        }
        Ok(seen)
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
    fn is_other(&self, s: &schema::SegmentPercept) -> bool {
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

    /// The latest percept.
    pub fn last_percept(&self) -> Option<&Percept> {
        self.percepts.last()
    }

    /// The watcher (its eyes, the places it was told).
    pub fn watcher(&self) -> &Watcher {
        &self.watcher
    }

    fn percept_now(&mut self) -> Result<(), RobotError> {
        let t = self.hw.time_secs() - self.t0;
        let p = self.watcher.percept(self.hw, t)?;
        let o = self.bank.observe(&p);
        self.last_x = bound_x(&o, self.bound_arms.as_deref(), self.reach_arm.as_ref());
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
    fn with_observer<R>(
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
        let bound_arms = self.bound_arms.clone();
        let reach_arm = self.reach_arm.clone();
        let mut callback = |h: &mut dyn Hardware, activity: &str| {
            sink.tick(h, activity);
            let t = h.time_secs() - t0;
            if t + 1e-9 >= *next && error.is_none() {
                match watcher.percept(h, t) {
                    Ok(p) => {
                        let o = bank.observe(&p);
                        *last_x = bound_x(&o, bound_arms.as_deref(), reach_arm.as_ref());
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
    fn resolve_target(&self, binding: &Binding) -> Result<(Option<u32>, SeenObject), RobotError> {
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
                Some(o) => format!("no tracked segment `{o}` (objects are the segments the robot sees)"),
                None => "no object".into(),
            },
        })
    }

    /// After a grasp closed on nothing or a descent stopped short: the object is not where it was
    /// seen. Open, back off and return to the parked pose — out of the cameras' view of where the
    /// object was, so that the next look sees where it is — and take the next target as the seen
    /// segment nearest where it was ([`REACQUIRE_GATE`]).
    fn back_off(&mut self, arm: Arm) -> Result<(), RobotError> {
        self.missed = true;
        let k = arm.index();
        let park = park_pose(arm, self.workspace.table_z);
        self.with_observer(|hw, reach, hand, obs| {
            release_and_retreat(hw, &mut reach[k], &hand[k], obs);
            reach[k].set_goal(hw, park);
            run_until(hw, &mut reach[k], obs, 3.0, |h, r| r.at_goal(h, 0.02, 0.1));
        })
    }

    /// The object was lost from the hand on the way: forget the hold, open, back off and park
    /// ([`RobotPlant::back_off`]), so that the monitors see the hand empty.
    fn let_go(&mut self, arm: Arm) -> Result<(), RobotError> {
        self.held = None;
        self.back_off(arm)
    }

    /// Whether the target moved since the grasp was planned, judged from the head cameras before
    /// the hand closes (closing on where it was would knock it over or away): its track is seen
    /// more than [`MOVED_GATE`] from the planned grasp; or it is not seen and the nearest new
    /// segment, one that appeared after the plan, is seen between [`MOVED_GATE`] and
    /// [`REACQUIRE_GATE`] from the plan. The reason, if so.
    fn object_moved(&self) -> Option<String> {
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
    fn above_table(&self, s: &schema::SegmentPercept) -> bool {
        s.centroid[2] > self.workspace.table_z - 0.02
    }

    /// Whether a segment may be the object the robot is after: [above the table](Self::above_table)
    /// and no taller than [`TALL_THING`] (a post or a wall the hand cannot grasp is an obstacle,
    /// never the target to re-acquire). A coarse extent's height is twice its centroid's height
    /// and doubles any error in it: there the centroid itself must lie lower than that.
    fn may_be_target(&self, s: &schema::SegmentPercept) -> bool {
        self.above_table(s)
            && s.extent.as_ref().is_none_or(|e| {
                if e.model == "coarse" {
                    s.centroid[2] - self.workspace.table_z <= TALL_THING
                } else {
                    e.height <= TALL_THING
                }
            })
    }

    /// Whether `c` lies over the table (within 2 cm of its edges) and not below its top: where an
    /// object the robot can reach may rest.
    fn on_table(&self, c: &Vec3) -> bool {
        let ws = self.workspace;
        (c.x - ws.table_center[0]).abs() <= ws.table_size[0] / 2.0 + TABLE_EDGE_MARGIN
            && (c.y - ws.table_center[1]).abs() <= ws.table_size[1] / 2.0 + TABLE_EDGE_MARGIN
            && c.z > ws.table_z - 0.05
    }

    /// Whether the latest percept sees the track `id`.
    fn seen_now(&self, id: Option<u32>) -> bool {
        let Some(p) = self.percepts.last() else {
            return false;
        };
        id.is_some_and(|id| p.segments.iter().any(|s| s.id == id && s.seen))
    }

    /// Scans the table with the head ([`Workspace::scan_points`]) for a lost target: the seen
    /// segment nearest `last` (where it was last seen) within [`SEARCH_GATE`], on the table (not in
    /// a place, not carried, at the table's height). `None` if nothing is seen there.
    fn search(&mut self, last: &Vec3) -> Result<Option<(Option<u32>, SeenObject)>, RobotError> {
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

    fn search_within(&mut self, last: &Vec3, gate: f64) -> Result<Option<(Option<u32>, SeenObject)>, RobotError> {
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
    fn stow_free_arms(&mut self) -> Result<bool, RobotError> {
        let table_z = self.workspace.table_z;
        let mut moved = false;
        for arm in Arm::BOTH {
            if self.touch(arm).holding() {
                continue;
            }
            let k = arm.index();
            let stow = stow_pose(arm, table_z);
            if (self.reach[k].tool_pose(self.hw).translation.vector - stow.translation.vector).norm() < 0.03 {
                continue;
            }
            self.with_observer(|hw, reach, _, obs| {
                reach[k].set_goal(hw, stow);
                run_until(hw, &mut reach[k], obs, 3.0, |h, r| r.at_goal(h, 0.02, 0.1));
            })?;
            moved = true;
        }
        Ok(moved)
    }

    /// [`RobotPlant::search_within`]'s scan of the table from where the arms are.
    fn scan_for(&mut self, last: &Vec3, gate: f64) -> Result<Option<(Option<u32>, SeenObject)>, RobotError> {
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
            for s in p
                .segments
                .iter()
                .filter(|s| s.seen && self.may_be_target(s) && !self.is_other(s))
            {
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

    fn touch(&self, arm: Arm) -> TouchState {
        let mut buf = Vec::new();
        TouchState::of(&hand_fingertips(self.hw, arm, &mut buf))
    }
}

impl SchemaPlant for RobotPlant<'_> {
    type Error = RobotError;

    fn observe(&mut self) -> Result<Vec<bool>, RobotError> {
        Ok(self.last_x.clone())
    }

    fn step(&mut self, event: &StepEvent<'_>) {
        self.sink.step(&*self.hw, event);
    }

    fn run(&mut self, action: &str, binding: &Binding) -> Result<ActionOutcome, RobotError> {
        let table_z = self.workspace.table_z;
        // ψ bound another arm (after a failure): observe its monitors too.
        if let (Some(bound), Some(arm)) = (self.bound_arms.as_mut(), binding.arm.as_ref())
            && !bound.contains(arm)
        {
            bound.push(arm.clone());
        }
        if let (Some(a), Some(arm)) = (self.skills.index(Skill::ReachObject), binding.arm.as_ref()) {
            self.reach_arm = Some((a, arm.clone()));
        }
        let skill = self.skills.skill(action);
        let outcome = match skill {
            Some(Skill::SearchTrack) => ActionOutcome::Converged,
            Some(Skill::ReachObject) => {
                let arm = parse_arm(action, binding.arm.as_deref())?;
                self.arms_used.push(arm);
                let resolved = match &self.target {
                    Some(t) if binding.object.is_none() => Ok(t.clone()),
                    _ => self.resolve_target(binding),
                };
                // Its track is gone: search for it from where it was last seen.
                let resolved = match (resolved, self.target.clone()) {
                    (Err(e), Some((_, last))) => self.search(&last.centroid)?.ok_or(e),
                    (r, _) => r,
                };
                let (id, seen) = match resolved {
                    Ok(t) => t,
                    Err(e) => {
                        self.settle(0.3)?;
                        return Ok(ActionOutcome::Failed(Failure::new(
                            FailureCause::NotSeen,
                            e.to_string(),
                        )));
                    }
                };
                let target = seen.centroid;
                let k = arm.index();
                self.reach[k].avoid = self.tall_things();
                // An arm that hovers near the object — the other (it just let go of it at the
                // handoff), or this one (its reach is asked for again: the monitors did not see it
                // arrive) — is in the way and in the head's view: back to its parked pose first,
                // so that the look below sees the object whole.
                for a in [1 - k, k] {
                    let palm = self.reach[a].tool_pose(self.hw).translation.vector;
                    if (palm.x - target.x).hypot(palm.y - target.y) < CLEAR_RADIUS {
                        let park = park_pose(Arm::BOTH[a], table_z);
                        self.with_observer(|hw, reach, hand, obs| {
                            if a == k {
                                release_and_retreat(hw, &mut reach[a], &hand[a], obs);
                            }
                            reach[a].set_goal(hw, park);
                            run_until(hw, &mut reach[a], obs, 3.0, |h, r| r.at_goal(h, 0.02, 0.1));
                        })?;
                    }
                }
                // Look at it and let the tracker refresh what is seen there.
                self.look(&target, 0.5)?;
                if std::mem::take(&mut self.relook)
                    && let Some(id) = id
                    && self.watcher.accept_view(id)
                {
                    // Looked again at a doubted track with the hand away: what is seen now is
                    // where it is, even if the robot's body still hides a little of it.
                    self.percept_now()?;
                }
                let (id, seen) = match self.resolve_target(&Binding {
                    object: id.map(|i| i.to_string()),
                    ..binding.clone()
                }) {
                    Ok(t) => t,
                    Err(_) => (id, seen),
                };
                // Not seen where it should be (it rolled, or was knocked away): search the table.
                if self.unseen.0 != binding.object {
                    self.unseen = (binding.object.clone(), 0);
                }
                let (id, seen) = if self.seen_now(id) {
                    self.unseen.1 = 0;
                    (id, seen)
                } else if let Some(found) = self.search(&seen.centroid)? {
                    self.unseen.1 = 0;
                    found
                } else {
                    // Nowhere on the table. Last seen off it: it fell. Else reach where it was last
                    // seen once (the cameras may have been blinded, or an arm hides it); not seen
                    // again, it is gone.
                    self.unseen.1 += 1;
                    let c = seen.centroid;
                    let why = if !self.on_table(&c) {
                        Some(format!(
                            "the object left the table (last seen at ({:.2}, {:.2}, {:.2}), not seen on the table since)",
                            c.x, c.y, c.z
                        ))
                    } else if self.unseen.1 > 1 {
                        Some(format!(
                            "the object is gone: not seen where it was last seen ({:.2}, {:.2}) nor anywhere on the \
                             table, twice (it left the table)",
                            c.x, c.y
                        ))
                    } else {
                        None
                    };
                    if let Some(why) = why {
                        self.settle(0.3)?;
                        return Ok(ActionOutcome::Failed(Failure::new(FailureCause::Gone, why)));
                    }
                    (id, seen)
                };
                self.target = Some((id, seen.clone()));
                if let Some(s) = self
                    .percepts
                    .last()
                    .and_then(|p| p.segments.iter().find(|s| Some(s.id) == id && s.seen))
                {
                    self.target_colors.clone_from(&s.colors);
                }
                self.held = None;
                self.grasp_palm = None;
                let arc = finger_arc(self.hw.model(), arm)?;
                let current = self.reach[k].tool_pose(self.hw);
                // A touch's fingers come down clear of the places' walls and of the other things
                // seen: a fingertip landing there would be a touch of the wrong thing.
                let others: Vec<([f64; 2], f64)> = self
                    .seen_objects(None)
                    .into_iter()
                    .filter(|o| {
                        (o.extent.center[0] - seen.extent.center[0]).hypot(o.extent.center[1] - seen.extent.center[1])
                            > MERGE_RADIUS
                    })
                    .map(|o| (o.extent.center, o.radius()))
                    .collect();
                let places = &self.workspace.places;
                let room = |p: [f64; 2]| {
                    let walls = places.iter().map(|w| wall_distance(w, p)).fold(f64::INFINITY, f64::min);
                    others
                        .iter()
                        .map(|(c, r)| (p[0] - c[0]).hypot(p[1] - c[1]) - r)
                        .fold(walls, f64::min)
                };
                // (For touches only: for grasps the choice changed how two pinned fault scenes
                // recovered, development seed 1, bump 6 and blocked arm 8.)
                let mut plan =
                    plan_top_grasp_among(&arc, &seen, table_z, &current, self.touch_task.then_some(&room as _));
                if self.touch_task {
                    // Stop clear of the object: the Touch makes the contact.
                    plan.grasp.translation.vector.z += PRE_TOUCH_HEIGHT + plan.guard;
                    plan.guard = 0.0;
                }
                tracing::debug!("reach target id {id:?}: {seen:?}");
                self.plan_next_id = self
                    .percepts
                    .last()
                    .and_then(|p| p.segments.iter().map(|s| s.id + 1).max())
                    .unwrap_or(0);
                let r = self.with_observer(|hw, reach, hand, obs| {
                    approach_grasp(hw, &mut reach[k], &hand[k], &plan, obs, &mut |_, _| {})
                })?;
                match r {
                    Ok(p) => {
                        self.plan = Some(p);
                        ActionOutcome::Converged
                    }
                    Err(why) => {
                        if why.cause == FailureCause::StoppedShort {
                            // The descent stopped short, on something where the fingers should
                            // have passed: the object is not where it was seen.
                            self.back_off(arm)?;
                        } else if why.effector_blocked() {
                            self.unreached.push((arm, [target.x, target.y]));
                        }
                        ActionOutcome::Failed(why)
                    }
                }
            }
            Some(Skill::Grasp) => {
                let arm = parse_arm(action, binding.arm.as_deref())?;
                let k = arm.index();
                if self.target.is_none() {
                    ActionOutcome::Failed(Failure::new(
                        FailureCause::Precondition,
                        "no object to grasp (no reach yet)",
                    ))
                } else if let Some(why) = self.object_moved() {
                    self.back_off(arm)?;
                    ActionOutcome::Failed(Failure::new(FailureCause::Moved, why))
                } else if let Some(id) = self.target.as_ref().and_then(|t| t.0)
                    && self.doubt_checked != Some(id)
                    && self.watcher.doubted(id)
                {
                    // What the hand leaves visible of it lies outside where it was seen: it may
                    // have been pushed. Closing on where it was would knock it away; back off, and
                    // the next reach looks with the hand out of the way (once per object).
                    self.doubt_checked = Some(id);
                    self.relook = true;
                    self.back_off(arm)?;
                    ActionOutcome::Failed(Failure::new(
                        FailureCause::Moved,
                        "the object may have moved under the hand (its visible part lies outside where it was \
                         seen): looking again",
                    ))
                } else {
                    let r = self.with_observer(|hw, reach, hand, obs| close_grasp(hw, &mut reach[k], &hand[k], obs))?;
                    match r {
                        Ok(()) => {
                            self.grasp_palm = Some(self.reach[k].tool_pose(self.hw));
                            self.missed = false;
                            ActionOutcome::Converged
                        }
                        Err(why) => {
                            // Closed on nothing: the object is not where it was seen.
                            self.back_off(arm)?;
                            ActionOutcome::Failed(why)
                        }
                    }
                }
            }
            Some(Skill::Hold) => {
                let arm = parse_arm(action, binding.arm.as_deref())?;
                let k = arm.index();
                let (Some((_, seen)), Some(plan), Some(grasp_palm)) = (self.target.clone(), self.plan, self.grasp_palm)
                else {
                    return Ok(ActionOutcome::Failed(Failure::new(
                        FailureCause::Precondition,
                        "nothing grasped to hold (no grasp yet)",
                    )));
                };
                // A hold asked for again while the object is already up (the monitors had not yet
                // seen the first one converge) rises no further: judge it from where it was grasped.
                let palm_z = self.reach[k].tool_pose(self.hw).translation.z;
                let touch = self.touch(arm);
                if self.held.is_some() && palm_z - grasp_palm.translation.z > 0.08 && touch.holding() {
                    ActionOutcome::Converged
                } else {
                    let g = self.with_observer(|hw, reach, _, obs| lift_and_weigh(hw, &mut reach[k], &plan, obs))?;
                    if g.lifted {
                        let load = g.weighed.unwrap_or(0.0);
                        self.held = Some(Held::new(&seen, &grasp_palm, table_z, load));
                        ActionOutcome::Converged
                    } else {
                        // Let go of whatever is left so that a re-grasp starts from an open hand.
                        self.with_observer(|hw, reach, hand, obs| {
                            release_and_retreat(hw, &mut reach[k], &hand[k], obs)
                        })?;
                        self.held = None;
                        ActionOutcome::Failed(
                            g.failure
                                .unwrap_or_else(|| Failure::new(FailureCause::NotLifted, g.outcome)),
                        )
                    }
                }
            }
            Some(Skill::Place) => {
                let arm = parse_arm(action, binding.arm.as_deref())?;
                let k = arm.index();
                // The objects around (the head still looks at the lifted one and its neighbours).
                let palm_now = self.reach[k].tool_pose(self.hw).translation.vector;
                let mut around = self.seen_objects(Some(&palm_now));
                let Some(held) = self.held_or_felt(arm) else {
                    // Nothing in the hand, though a finger may still touch the object (it was lost
                    // on the way): open the hand and back off, so that the monitors see the hand
                    // empty and the schema's contingency (a re-grasp after a drop) takes over.
                    self.let_go(arm)?;
                    return Ok(ActionOutcome::Failed(Failure::new(
                        FailureCause::Precondition,
                        "nothing held to place: the hand opened and backed off (a re-grasp follows)",
                    )));
                };
                let (target, wall) = if binding.transfer {
                    if !self.unreached.is_empty() {
                        // A reach failed somewhere: the handoff spot must keep clear of there (the
                        // arm that failed may be the one to take the object).
                        let palm = self.reach[k].tool_pose(self.hw).translation.vector;
                        let seen = self.scan_handoff_region(&palm)?;
                        self.plan_handoff_among(&palm, &seen)?;
                    }
                    (self.handoff, 0.0)
                } else {
                    let name = binding.place.as_deref().ok_or_else(|| RobotError::Binding {
                        action: action.into(),
                        message: "no place".into(),
                    })?;
                    let p = self.workspace.place(name)?.clone();
                    (self.place_spot(&p, &held, arm)?, p.wall_height)
                };
                // Carry the object's bottom over the walls and over every object seen near its way.
                around.extend(self.seen_objects(Some(&palm_now)));
                let from = [palm_now.x + held.offset_xy[0], palm_now.y + held.offset_xy[1]];
                let clear = around
                    .iter()
                    .filter(|o| distance_to_segment(o.extent.center, from, target) < held.radius + o.radius() + 0.03)
                    .map(|o| o.extent.height.min(MAX_OBSTACLE_HEIGHT))
                    .fold(wall, f64::max);
                if clear > wall {
                    tracing::debug!("carrying over objects up to {clear:.3} m high");
                }
                self.watcher
                    .look_at(self.hw, &Vec3::new(target[0], target[1], table_z + 0.05))?;
                self.reach[k].avoid = self.tall_things();
                if !self.reach[k].avoid.is_empty() {
                    tracing::debug!("carrying round {:?}", self.reach[k].avoid);
                }
                let transfer = binding.transfer;
                let r = self.with_observer(|hw, reach, hand, obs| {
                    transport_over(hw, &mut reach[k], &held, target, table_z, clear, obs)?;
                    lower_until_supported(hw, &mut reach[k], &held, table_z, obs);
                    if transfer {
                        // The transfer ends with the hand open: the other hand takes it from here.
                        release_and_retreat(hw, &mut reach[k], &hand[k], obs);
                    }
                    Ok::<(), Failure>(())
                })?;
                if transfer && r.is_ok() {
                    // The object rests on the handoff spot: the next reach sees it there. (A carry
                    // that failed keeps the hold: the object is still in the hand, and a retry
                    // carries it from where the hand is; forgetting it made the retry recompute
                    // the hold from the spot it never reached, and carry the object back towards
                    // where it was picked: development seed 2, blocked arm, scene 14.)
                    if let Some((_, seen)) = self.target.as_mut() {
                        let dx = target[0] - seen.extent.center[0];
                        let dy = target[1] - seen.extent.center[1];
                        seen.centroid.x += dx;
                        seen.centroid.y += dy;
                        seen.extent.center = target;
                    }
                    self.held = None;
                }
                match r {
                    Ok(()) => ActionOutcome::Converged,
                    Err(why) => {
                        // Forget the hold only if the fingertips lost it (the carry may have stopped
                        // on an obstacle with the object still in the hand); then let go of what a
                        // finger may still touch.
                        if !self.touch(arm).holding() {
                            self.let_go(arm)?;
                        }
                        ActionOutcome::Failed(why)
                    }
                }
            }
            Some(Skill::Release) => {
                let arm = parse_arm(action, binding.arm.as_deref())?;
                let k = arm.index();
                self.with_observer(|hw, reach, hand, obs| release_and_retreat(hw, &mut reach[k], &hand[k], obs))?;
                // An object wedged between the half-opened fingers came up with the hand: open
                // fully, let it drop, and retreat again.
                if self.touch(arm).loaded > 0 {
                    self.with_observer(|hw, reach, hand, obs| {
                        hand[k].set(hw, 0.0, 0.0);
                        idle(hw, obs, 0.6);
                        release_and_retreat(hw, &mut reach[k], &hand[k], obs);
                    })?;
                }
                self.held = None;
                if self.touch(arm).loaded > 0 {
                    ActionOutcome::Failed(Failure::new(
                        FailureCause::NotReleased,
                        "the fingertips still feel the object after opening",
                    ))
                } else {
                    ActionOutcome::Converged
                }
            }
            Some(Skill::Touch) => {
                let arm = parse_arm(action, binding.arm.as_deref())?;
                let k = arm.index();
                if self.target.is_none() {
                    ActionOutcome::Failed(Failure::new(
                        FailureCause::Precondition,
                        "no object to touch (no reach yet)",
                    ))
                } else if let Some(why) = self.object_moved() {
                    self.back_off(arm)?;
                    ActionOutcome::Failed(Failure::new(FailureCause::Moved, why))
                } else {
                    // From the pre-touch pose, down to the grasp pose the reach stopped above.
                    let down = self.plan.filter(|_| self.touch_task).map(|p| {
                        let mut g = p.grasp;
                        g.translation.vector.z -= PRE_TOUCH_HEIGHT;
                        g
                    });
                    match self.with_observer(|hw, reach, hand, obs| {
                        touch_object(hw, &mut reach[k], &hand[k], down.as_ref(), obs)
                    })? {
                        Ok(()) => ActionOutcome::Converged,
                        // The hand stays at the object, open again: the next touch tries from there.
                        Err(why) => ActionOutcome::Failed(why),
                    }
                }
            }
            None => ActionOutcome::Failed(Failure::new(
                FailureCause::NoController,
                format!("Dexter has no controller for `{action}`"),
            )),
        };
        // Let the monitors see the result: a controller's convergence shows in its monitor set
        // within a few percepts (the palm comes to rest, the tracker catches up).
        self.settle(0.3)?;
        let mut outcome = outcome;
        if outcome == ActionOutcome::Converged
            && skill != Some(Skill::SearchTrack)
            && !binding.transfer
            && let Some(a) = self.action_names.iter().position(|n| n == action)
        {
            let mut waited = 0.0;
            while !self.last_x[a] && waited < MONITOR_WAIT_SECS {
                self.settle(0.1)?;
                waited += 0.1;
            }
            if !self.last_x[a] && skill == Some(Skill::ReachObject) {
                // The hand is where the object was seen, and the monitors see no object there:
                // the robot reached for a segment that is gone.
                let id = self.target.as_ref().and_then(|t| t.0);
                let present = self
                    .percepts
                    .last()
                    .is_some_and(|p| id.is_some_and(|id| p.segments.iter().any(|s| s.id == id)));
                if !present {
                    outcome = ActionOutcome::Failed(Failure::new(
                        FailureCause::Gone,
                        "the hand reached where the object was seen, and no object is seen there (it is gone)",
                    ));
                }
            }
        }
        // What the monitors saw after the action (`RUST_LOG=dexter::exec=debug`).
        if tracing::enabled!(tracing::Level::DEBUG)
            && let Some(p) = self.percepts.last()
        {
            tracing::debug!("after {action} ({outcome:?}): x = {:?}", self.last_x);
            if let (Ok(pan), Ok(tilt)) = (
                self.hw.dof_index("head/pan_joint"),
                self.hw.dof_index("head/tilt_joint"),
            ) {
                let q = self.hw.joint_positions();
                tracing::debug!(
                    "head pan {:.3} tilt {:.3} (looking at {:?})",
                    q[pan],
                    q[tilt],
                    self.watcher.gaze_point
                );
            }
            if let Some(plan) = &self.plan {
                tracing::debug!(
                    "plan grasp at {:?} width {:.3}",
                    plan.grasp.translation.vector.as_slice(),
                    plan.width
                );
            }
            for h in &p.hands {
                tracing::debug!(
                    "hand {} palm {:?} speed {:.3} load {:.2} flex {:.2} forces {:.2?}",
                    h.arm,
                    h.palm,
                    h.palm_speed,
                    h.load,
                    h.flexion,
                    h.finger_force
                );
            }
            for sg in &p.segments {
                tracing::debug!(
                    "segment {} at {:?} seen {} extent {:?}",
                    sg.id,
                    sg.centroid,
                    sg.seen,
                    sg.extent
                );
            }
        }
        Ok(outcome)
    }
}

/// Descents to the grasp pose by one arm that stop short before ψ binds another arm.
const SHORT_DESCENTS: usize = 2;

/// The hand-to-hand pass a schema's graph spells out on its main path: a state whose action is a
/// Place and from which the schema's plain edges lead (before any goal) to a state whose action is a
/// reach to the object puts the object down for the other hand (a user's `pass_and_place`); the
/// states reachable after it, and not before it, belong to the other hand. Pick-And-Place's Place
/// leads by plain edges only to its goal (its transfer is a contingency), so it has none.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Passing {
    /// Per state of the schema: its Place puts the object down for the other hand.
    pub handoff: Vec<bool>,
    /// Per state: the other hand acts (after a pass).
    pub after: Vec<bool>,
}

impl Passing {
    /// Reads the pass of `schema` from its graph, its actions bound by `skills`.
    pub fn of(schema: &schema::Schema, skills: &SkillMap) -> Passing {
        let n = schema.states.len();
        let skill = |s: usize| skills.at(schema.policy[s]);
        // States reachable from `from`'s successors (`plain`: by edges without a contingency label
        // only, not going on from a goal).
        let reach = |from: usize, plain: bool| -> Vec<bool> {
            let mut seen = vec![false; n];
            let mut stack: Vec<usize> = vec![from];
            let mut first = true;
            while let Some(s) = stack.pop() {
                if !first && plain && schema.is_goal(s) {
                    continue;
                }
                first = false;
                for t in schema.successors(s) {
                    if (!plain || t.contingency.is_none()) && !seen[t.to] {
                        seen[t.to] = true;
                        stack.push(t.to);
                    }
                }
            }
            seen
        };
        let handoff: Vec<bool> = (0..n)
            .map(|s| {
                skill(s) == Some(Skill::Place)
                    && reach(s, true)
                        .iter()
                        .enumerate()
                        .any(|(t, &r)| r && skill(t) == Some(Skill::ReachObject))
            })
            .collect();
        let mut after = vec![false; n];
        for h in (0..n).filter(|&h| handoff[h]) {
            let later = reach(h, false);
            for (t, a) in after.iter_mut().enumerate() {
                // Not a state the pass can come back to (one before it, or the pass itself).
                let before = t == h || reach(t, false)[h];
                *a |= later[t] && !before;
            }
        }
        Passing { handoff, after }
    }

    /// Whether the schema passes the object from one hand to the other on its main path.
    pub fn passes(&self) -> bool {
        self.handoff.iter().any(|&h| h)
    }
}

/// ψ on Dexter (5.31–5.32) for any schema over its skills: the arm whose workspace holds the
/// object — and the place, when the schema has one — on the object's side first; if no arm reaches
/// both, a transfer: the arm that reaches the object puts it on the handoff spot, and the arm that
/// reaches the place takes it from there. Actions bind by their skill ([`Skill`]), not their names.
#[derive(Debug, Clone)]
pub struct ArmPolicy {
    /// The object (the tracked segment's id, as text).
    pub object: String,
    /// The place, for a schema that puts the object somewhere.
    pub place: Option<String>,
    /// The arm that picks first.
    pub pick_arm: Arm,
    /// The arm that places (differs from `pick_arm` for a transfer).
    pub place_arm: Arm,
    skills: SkillMap,
    transferred: bool,
    /// Arms whose palm reaches above the object, the place and the handoff spot (when decided).
    at_object: Vec<Arm>,
    at_place: Vec<Arm>,
    at_handoff: Vec<Arm>,
    /// The pass the schema's graph spells out (if any): then the arms are always two.
    passing: Passing,
    /// Arms whose reach to the object did not converge.
    failed_arms: Vec<Arm>,
    /// Per arm (left, right): its descents to the grasp pose that stopped short.
    short_descents: [usize; 2],
    /// ψ's rebindings after failures, in order (`other_arm`, `hand_over`, `gave_up: …`).
    pub rebindings: Vec<String>,
}

/// ψ for Pick-And-Place: [`ArmPolicy`] with a place.
pub type PickPlacePolicy = ArmPolicy;

impl ArmPolicy {
    /// Decides the arms for `object` at `object_at` (and `place`, if the schema has one) for the
    /// skills of `library` and the graph of `schema`: one arm if one reaches both, else a transfer
    /// — always two arms for a schema that passes the object from hand to hand ([`Passing`]).
    /// `None` if no arm (pair) reaches what the schema needs.
    #[allow(clippy::too_many_arguments)]
    pub fn decide(
        hw: &dyn Hardware,
        workspace: &Workspace,
        library: &Library,
        schema: &schema::Schema,
        object: &str,
        object_at: &Vec3,
        place: Option<&str>,
        handoff: [f64; 2],
    ) -> Result<Option<ArmPolicy>, RobotError> {
        let table_z = workspace.table_z;
        let at_object = arms_reaching(hw, table_z, object_at)?;
        let at_place = match place {
            Some(place) => {
                let p = workspace.place(place)?;
                arms_reaching(
                    hw,
                    table_z,
                    &Vec3::new(p.center[0], p.center[1], table_z + p.wall_height),
                )?
            }
            None => Arm::BOTH.to_vec(),
        };
        let hand_spot = Vec3::new(handoff[0], handoff[1], table_z);
        let at_handoff = arms_reaching(hw, table_z, &hand_spot)?;
        let skills = SkillMap::new(library);
        let mut policy = ArmPolicy {
            object: object.into(),
            place: place.map(str::to_string),
            pick_arm: Arm::Left,
            place_arm: Arm::Left,
            passing: Passing::of(schema, &skills),
            skills,
            transferred: false,
            at_object,
            at_place,
            at_handoff,
            failed_arms: Vec::new(),
            short_descents: [0; 2],
            rebindings: Vec::new(),
        };
        // Prefer the arm on the object's side.
        let side = if object_at.y >= 0.0 { Arm::Left } else { Arm::Right };
        Ok(policy.assign(side).map(|_| policy))
    }

    /// The same policy with `arm` picking first when it reaches what the task needs (the arm a
    /// model expects the teacher would have used); else unchanged.
    pub fn prefer(mut self, arm: Arm) -> Self {
        let (pick, place) = (self.pick_arm, self.place_arm);
        if self.assign(arm).is_none() || self.pick_arm != arm {
            self.pick_arm = pick;
            self.place_arm = place;
        }
        self
    }

    /// The same policy restricted to the arms in `free` (the others hold something): `None` if
    /// the arms it would need are not among them.
    pub fn among(mut self, free: &[Arm]) -> Option<Self> {
        if free.len() == Arm::BOTH.len() {
            return Some(self);
        }
        self.at_object.retain(|a| free.contains(a));
        self.at_place.retain(|a| free.contains(a));
        self.at_handoff.retain(|a| free.contains(a));
        let side = self.pick_arm;
        self.assign(side).map(|_| self)
    }

    /// Assigns the arms among those not known to fail: one arm that reaches both the object and the
    /// place (`side`'s first), else a transfer through the handoff spot. `None` if neither exists.
    fn assign(&mut self, side: Arm) -> Option<()> {
        let usable: Vec<Arm> = self
            .at_object
            .iter()
            .copied()
            .filter(|a| !self.failed_arms.contains(a))
            .collect();
        if self.passing.passes() {
            // Two arms, whatever one alone reaches: `side` picks if it can.
            let mut picks: Vec<Arm> = usable.iter().copied().filter(|a| self.at_handoff.contains(a)).collect();
            picks.sort_by_key(|&a| a != side);
            let (a, b) = picks.iter().find_map(|&a| {
                let b = a.other();
                (self.at_place.contains(&b) && self.at_handoff.contains(&b)).then_some((a, b))
            })?;
            self.pick_arm = a;
            self.place_arm = b;
            return Some(());
        }
        let both: Vec<Arm> = usable.iter().copied().filter(|a| self.at_place.contains(a)).collect();
        if let Some(arm) = both
            .iter()
            .copied()
            .find(|&a| a == side)
            .or_else(|| both.first().copied())
        {
            self.pick_arm = arm;
            self.place_arm = arm;
            return Some(());
        }
        let a = usable.iter().copied().find(|a| self.at_handoff.contains(a))?;
        let b = self.at_place.iter().copied().find(|b| self.at_handoff.contains(b))?;
        self.pick_arm = a;
        self.place_arm = b;
        Some(())
    }

    /// Whether this assignment needs a transfer.
    pub fn is_transfer(&self) -> bool {
        self.pick_arm != self.place_arm
    }

    /// Whether the object has passed to the placing arm in `state`: a `transfer` contingency was
    /// taken, or the state comes after the schema's own pass ([`Passing`]).
    fn handed(&self, schema: &schema::Schema, state: &str) -> bool {
        self.transferred
            || schema
                .state(state)
                .is_some_and(|s| self.passing.after.get(s).copied().unwrap_or(false))
    }
}

impl schema::ProceduralPolicy for ArmPolicy {
    /// A reach to the object that did not converge (the arm could not get there: its path is
    /// blocked, or the object is out of its reach) binds another arm that reaches the object — the
    /// same arm for the place if it reaches that too, else a hand-over through the handoff spot to
    /// an arm that reaches the place (§3.3.3, 5.31–5.32).
    fn failed(&mut self, schema: &schema::Schema, state: &str, action: &str, binding: &Binding, why: &Failure) {
        // The approach (hover, pre-grasp) failed; a descent stopped short (on the object) is not the
        // arm's failure.
        if self.skills.skill(action) != Some(Skill::ReachObject) || self.handed(schema, state) {
            return;
        }
        let Some(arm) = binding.arm.as_deref().and_then(Arm::parse) else {
            return;
        };
        // … unless it stops short again: the second descent of one arm that stops short
        // (after the first, the arm backed off and looked again) is the arm not getting there —
        // an object knocked over near the edge of its workspace.
        let short = why.cause == FailureCause::StoppedShort;
        if short {
            self.short_descents[arm.index()] += 1;
        }
        let not_reached = why.effector_blocked() || (short && self.short_descents[arm.index()] >= SHORT_DESCENTS);
        if !not_reached {
            return;
        }
        if arm != self.pick_arm || self.failed_arms.contains(&arm) {
            return;
        }
        self.failed_arms.push(arm);
        let (pick, place) = (self.pick_arm, self.place_arm);
        match self.assign(arm) {
            Some(()) if self.pick_arm == self.place_arm => self.rebindings.push("other_arm".into()),
            Some(()) => self.rebindings.push("hand_over".into()),
            None => {
                self.pick_arm = pick;
                self.place_arm = place;
                self.rebindings
                    .push(format!("gave_up: no other arm reaches the object ({why})"));
            }
        }
    }

    fn bind(&mut self, schema: &schema::Schema, state: &str, action: &str) -> Binding {
        // The object was put down on the handoff spot: the state is entered by a `transfer`
        // contingency from a state whose action is a Place (Pick-And-Place's `transfer_placed`,
        // whatever a library calls it).
        let handed = schema.state(state).is_some_and(|s| {
            schema.transitions.iter().any(|t| {
                t.to == s
                    && t.contingency.as_deref() == Some("transfer")
                    && self.skills.at(schema.policy[t.from]) == Some(Skill::Place)
            })
        });
        if handed {
            self.transferred = true;
        }
        let after = self.handed(schema, state);
        let arm = if after { self.place_arm } else { self.pick_arm };
        let transfer = self.skills.skill(action) == Some(Skill::Place) && self.is_transfer() && !after;
        Binding {
            arm: Some(arm.prefix().to_string()),
            object: Some(self.object.clone()),
            place: if transfer {
                Some(HANDOFF.to_string())
            } else {
                self.place.clone()
            },
            transfer,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Red against red-and-orange overlaps by the shared red; red against blue not at all.
    #[test]
    fn colour_overlap_is_the_shared_share() {
        let red = [(3u8, 1.0)];
        let red_orange = [(3u8, 0.6), (4, 0.4)];
        let blue = [(7u8, 0.9), (1, 0.1)];
        assert!((colour_overlap(&red, &red_orange) - 0.6).abs() < 1e-12);
        assert!((colour_overlap(&red_orange, &red_orange) - 1.0).abs() < 1e-12);
        assert_eq!(colour_overlap(&red, &blue), 0.0);
        assert!(colour_overlap(&red_orange, &red) >= LOOKS_ALIKE);
        assert!(colour_overlap(&blue, &red) < LOOKS_ALIKE);
    }

    /// Pick-And-Place's transfer is a contingency: no pass on its main path. The user-written
    /// `pass_and_place` puts the object down in `carrying`; every state from `put_down` on belongs to
    /// the other hand, none before it (its first-half drop and re-grasp included).
    #[test]
    fn the_pass_is_read_from_the_schema_graph() {
        let lib = Library::builtin();
        let skills = SkillMap::new(&lib);
        for s in &lib.schemas {
            assert!(!Passing::of(s, &skills).passes(), "{}", s.name);
        }
        let text = include_str!("../../../assets/schemas/examples/pass-and-place.toml");
        let lib = Library::parse(text, "pass-and-place.toml").unwrap();
        let skills = SkillMap::new(&lib);
        let schema = lib.schema("pass_and_place").unwrap();
        let p = Passing::of(schema, &skills);
        let named = |v: &[bool]| -> Vec<&str> {
            v.iter()
                .enumerate()
                .filter(|(_, b)| **b)
                .map(|(i, _)| schema.states[i].name.as_str())
                .collect()
        };
        assert_eq!(named(&p.handoff), ["carrying"]);
        let mut after = named(&p.after);
        after.sort();
        assert_eq!(
            after,
            [
                "at_object_again",
                "carrying_again",
                "done",
                "dropped_again",
                "grasped_again",
                "placed",
                "put_down",
                "released",
                "waiting"
            ]
        );
    }

    /// A 20 × 25 cm bin: an empty one takes the object at the end of its long side away from the
    /// hand (its middle when the hand is not known); with a can (radius 3 cm)
    /// already in the middle, a 3 cm object goes where the gap between them is widest (a corner:
    /// the bin is small), inside the walls; with objects larger than the room left, the middle stands.
    #[test]
    fn a_free_spot_keeps_clear_of_what_is_seen_in_the_bin() {
        let (center, size) = ([0.55, -0.45], [0.2, 0.25]);
        assert_eq!(free_spot(center, size, 0.03, &[], None), center);
        // The hand comes from the table's middle (y > the bin's): the far end, 6 cm from the middle
        // (12.5 − 3 − 3 cm of room, to the centimetre).
        let first = free_spot(center, size, 0.03, &[], Some([0.5, 0.0]));
        assert!(
            (first[0] - center[0]).abs() < 1e-12 && (first[1] - (center[1] - 0.06)).abs() < 1e-9,
            "{first:?}"
        );
        // The next, as large, then fits at the other end, clear of it.
        let next = free_spot(center, size, 0.03, &[(first, 0.03)], Some([0.5, 0.0]));
        assert!((next[0] - first[0]).hypot(next[1] - first[1]) - 0.06 > 0.05, "{next:?}");
        let spot = free_spot(center, size, 0.03, &[(center, 0.03)], None);
        let gap = (spot[0] - center[0]).hypot(spot[1] - center[1]) - 0.06;
        assert!(gap > 0.005, "spot {spot:?}, gap {gap}");
        for i in 0..2 {
            assert!(
                (spot[i] - center[i]).abs() <= size[i] / 2.0 - 0.03 - WALL_ROOM + 1e-9,
                "{spot:?}"
            );
        }
        // A can near one wall: the spot is on the other side.
        let can = [center[0], center[1] + 0.07];
        let spot = free_spot(center, size, 0.03, &[(can, 0.03)], None);
        assert!(spot[1] < center[1] - 0.02, "{spot:?}");
        assert_eq!(free_spot(center, size, 0.08, &[(can, 0.03)], None), center);
    }
}
