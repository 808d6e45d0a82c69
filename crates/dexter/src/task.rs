//! The robot's task loop (seed §4.3.2, §5.3): look over the table, decide per seen segment (a
//! learned procedural model's relevance and place, or a demonstration's place), bind ψ's arms and
//! run the schema through [`schema::execute`] on each relevant segment, and report per segment what
//! it did and what its own monitors concluded.
//!
//! Everything here is the robot's: it runs on any [`control_basis::Hardware`] through a
//! [`RobotPlant`] and reads only the robot's percepts. A world that wants to judge the outcome (the
//! simulator's evaluator) listens through a [`TaskSink`]: it is told which segment the robot takes
//! up, what it decided and when it is done, and may let time pass then (the robot holding still)
//! before it looks at its own truth.

use std::collections::BTreeMap;

use control_basis::Hardware;
use control_basis::math::Vec3;
use schema::procedural::{Features, ProceduralModel};
use schema::{ExecReport, Library, SegmentPercept};

use crate::Arm;
use crate::actions::{Skill, SkillMap};
use crate::error::RobotError;
use crate::exec::{ArmPolicy, RobotPlant, Workspace};

/// How long (s) the robot looks at each of [`Workspace::scan_points`] when it looks over the table.
pub const SCAN_LOOK_SECS: f64 = 0.6;
/// How long (s) the robot holds still after a schema finished (an object set down may still roll)
/// before it turns to the next segment.
pub const SETTLE_AFTER_SECS: f64 = 0.5;
/// A segment farther than this (m, on the table) from the point a user pointed at is not the one
/// meant ([`Task::only_near`]).
pub const POINTED_RADIUS: f64 = 0.08;

/// How the robot decides per segment.
#[derive(Debug, Clone)]
pub enum Decider<'a> {
    /// Every segment goes to this place (a demonstration's place).
    Place(String),
    /// Every segment is part of the task, which puts nothing anywhere (a demonstration of a schema
    /// with no place: Pick-And-Hold, Hand-Over, Reach-And-Touch).
    Every,
    /// A learned procedural model: relevance and place per segment.
    Model(&'a ProceduralModel),
}

/// What the robot did about one object: the decision per seen segment, as reports and logs name it
/// (serialised in lower case: `execute`, `ignore`, `skip`, `unseen`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Verdict {
    /// Part of the task, and the schema ran on it.
    Execute,
    /// Not part of the task (relevance), or the task has no reference for it.
    Ignore,
    /// Part of the task, but no free arm (pair) reaches what the schema needs.
    Skip,
    /// An object no tracked segment matched (an evaluator's row: the robot never decided on it).
    Unseen,
}

impl Verdict {
    /// The lower-case name (`execute`, `ignore`, `skip`, `unseen`).
    pub fn as_str(self) -> &'static str {
        match self {
            Verdict::Execute => "execute",
            Verdict::Ignore => "ignore",
            Verdict::Skip => "skip",
            Verdict::Unseen => "unseen",
        }
    }
}

impl std::fmt::Display for Verdict {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.pad(self.as_str())
    }
}

/// What to do with one seen segment: a place or a reason to leave it.
#[derive(Debug, Clone)]
pub struct Decision {
    /// The robot's segment (track id).
    pub segment: u32,
    /// Where it was seen (m, world).
    pub at: [f64; 3],
    /// `Ok(place)` to execute — `Ok(None)` for a task that puts nothing anywhere —, `Err(reason)`
    /// to ignore.
    pub place: Result<Option<String>, String>,
    /// Posterior over places.
    pub posterior: BTreeMap<String, f64>,
    /// log B10 of task relevance.
    pub log_bayes_factor: Option<f64>,
    /// The segment's measured size (cm): the geometric mean of its measured footprint and height
    /// (`Features::size_cm`), `None` when they were not measured.
    pub size_cm: Option<f64>,
    /// The arm the model expects the teacher would have used (for a task that puts nothing
    /// anywhere, the model's reference is the arm); ψ binds it first when it can.
    pub arm: Option<Arm>,
    /// Why.
    pub reason: String,
}

impl Decision {
    /// The event of this decision as taken: `decision` (`execute`, `ignore`, `skip`), the place and
    /// arms if any, and why.
    pub fn event<'a>(
        &'a self,
        decision: Verdict,
        place: Option<&'a str>,
        arms: Option<[&'a str; 2]>,
        reason: &'a str,
    ) -> DecisionEvent<'a> {
        DecisionEvent {
            segment: self.segment,
            decision,
            place,
            posterior: &self.posterior,
            log_bayes_factor: self.log_bayes_factor,
            arms,
            reason,
        }
    }
}

/// What the robot decided for one seen segment, from its own percepts ([`TaskSink::decided`]).
#[derive(Debug, Clone, Copy)]
pub struct DecisionEvent<'a> {
    /// The robot's segment (track id).
    pub segment: u32,
    /// Execute, ignore (not part of the task) or skip (out of reach).
    pub decision: Verdict,
    /// The place chosen, if any.
    pub place: Option<&'a str>,
    /// Posterior over places (from a model; empty otherwise).
    pub posterior: &'a BTreeMap<String, f64>,
    /// ln B10 of task relevance (from a model).
    pub log_bayes_factor: Option<f64>,
    /// The arm that picks and the arm that places (the same unless it is a hand-to-hand transfer).
    pub arms: Option<[&'a str; 2]>,
    /// Why.
    pub reason: &'a str,
}

/// The procedural model's decision on the robot's own percepts: relevance (ln B10 against the
/// model's threshold, 5.24) and the MAP reference (5.27) for every segment. For a task with a place
/// (`wants_place`) the reference is the place, and one that is not in `places` (this workspace) is
/// a reason to leave the segment; otherwise it is the arm the teacher would have used.
pub fn decide(
    model: &ProceduralModel,
    places: &[String],
    segments: &[SegmentPercept],
    wants_place: bool,
) -> Result<Vec<Decision>, RobotError> {
    let mut out = Vec::with_capacity(segments.len());
    for seg in segments {
        let p = model.predict(&Features::from(seg))?;
        let posterior: BTreeMap<String, f64> = p.places.iter().cloned().collect();
        let lb = p.relevance.bayes_factor.log_b10;
        let place = if !p.relevance.relevant {
            Err(format!(
                "not part of the task (ln B10 = {lb:.1} ≤ {:.1})",
                p.relevance.log_threshold
            ))
        } else if !wants_place {
            Ok(None)
        } else if !places.contains(&p.map_place) {
            Err(format!("its place `{}` is not in this scene", p.map_place))
        } else {
            Ok(Some(p.map_place.clone()))
        };
        let what = if wants_place { "place" } else { "arm" };
        out.push(Decision {
            segment: seg.id,
            at: seg.centroid,
            reason: format!(
                "MAP {what} {} (p = {:.3}), ln B10 = {lb:.1}",
                p.map_place, p.map_probability
            ),
            place,
            posterior,
            log_bayes_factor: Some(lb),
            size_cm: Features::from(seg).size_cm(),
            arm: if wants_place { None } else { Arm::parse(&p.map_place) },
        });
    }
    Ok(out)
}

/// The robot looks over the table ([`Workspace::scan_points`], [`SCAN_LOOK_SECS`] each; the
/// tracker gathers what is there) and returns its tracked segments that stand on the table
/// ([`Workspace::stands_on_table`]) outside the places: what it decides on before a task.
pub fn look_over_table(plant: &mut RobotPlant<'_>) -> Result<Vec<SegmentPercept>, RobotError> {
    let ws = plant.workspace();
    for at in ws.scan_points() {
        plant.look(&at, SCAN_LOOK_SECS)?;
    }
    let seen: Vec<SegmentPercept> = plant
        .last_percept()
        .map(|p| {
            p.segments
                .iter()
                .filter(|s| {
                    ws.stands_on_table(s.centroid)
                        && !ws.places.iter().any(|pl| pl.contains([s.centroid[0], s.centroid[1]]))
                })
                .cloned()
                .collect()
        })
        .unwrap_or_default();
    let seen = one_per_footprint(seen);
    let seen = one_per_footprint(confirm_unseen_coarse(plant, seen)?);
    let seen = measure_coarse_from_chassis(plant, seen)?;
    for s in &seen {
        tracing::debug!(
            "on the table: segment {} at ({:.3}, {:.3}, {:.3}) seen {} extent {:?} colour terms {:?}",
            s.id,
            s.centroid[0],
            s.centroid[1],
            s.centroid[2],
            s.seen,
            s.extent,
            s.colors
        );
    }
    Ok(seen)
}

/// Of `tracks`, the coarse ones not seen now are looked at directly ([`SCAN_LOOK_SECS`]) and
/// kept only if seen then: a pair of blobs from two different objects, matched across the cameras
/// for a moment, is triangulated where nothing stands (development seed 1, execute scenes 1 and 17:
/// coarse tracks 28 cm "tall" and 2.7 cm wide between two objects 13 and 16 cm away), and kept
/// unseen by the tracker's object permanence. Only where the head can look well (not near its
/// limits: development seed 3, execute scenes 2, 22 and 27, three real objects at x = 0.44 m, in
/// front of the chest, went unseen when looked at and were dropped); a real object hidden from
/// there by another is dropped too: it is then an object the robot never saw.
///
/// So are the coarse ones seen now with their centroid higher than half the tallest graspable
/// object and a centroid's error ([`COARSE_TOO_HIGH`]): views cut differently by the image border
/// in the two cameras triangulate along the line of sight, too near and too high (development
/// seeds 3, 4 and 8: a green bottle, a lying detergent box and a can seen 8–15 cm nearer and
/// 12–20 cm higher than they stood, each a phantom row while the object went unseen). Looked at
/// directly, the object is seen whole and its new track replaces the cut one: the tracks the look
/// found that were not in `tracks` (standing on the table, outside the places) are added.
fn confirm_unseen_coarse(
    plant: &mut RobotPlant<'_>,
    tracks: Vec<SegmentPercept>,
) -> Result<Vec<SegmentPercept>, RobotError> {
    let ws = plant.workspace();
    let coarse = |s: &SegmentPercept| measured(s).is_none();
    let too_high = |s: &SegmentPercept| s.centroid[2] - ws.table_z > COARSE_TOO_HIGH;
    let known: Vec<u32> = tracks.iter().map(|s| s.id).collect();
    let mut kept = Vec::with_capacity(tracks.len());
    let mut looked = false;
    for s in tracks {
        if (s.seen && !too_high(&s)) || !coarse(&s) || !plant.can_look_at(&Vec3::from(s.centroid))? {
            kept.push(s);
            continue;
        }
        if !looked && s.seen {
            // The arms out of the cameras' view of the table first: a parked upper arm cuts the
            // views of what stands on its side (the green bottle of development seed 4, scene 28,
            // looked at directly with the arms parked, triangulated 7 cm off again).
            plant.stow_free_arms()?;
        }
        looked = true;
        plant.look(&Vec3::from(s.centroid), SCAN_LOOK_SECS)?;
        match plant
            .last_percept()
            .and_then(|p| p.segments.iter().find(|t| t.id == s.id && t.seen))
        {
            Some(now) => kept.push(now.clone()),
            None => tracing::debug!(
                "segment {} at ({:.3}, {:.3}, {:.3}): coarse, not seen when looked at, dropped",
                s.id,
                s.centroid[0],
                s.centroid[1],
                s.centroid[2]
            ),
        }
    }
    if looked && let Some(p) = plant.last_percept() {
        for t in &p.segments {
            let plausible = !coarse(t) || !too_high(t);
            if t.seen
                && plausible
                && !known.contains(&t.id)
                && !kept.iter().any(|k| k.id == t.id)
                && ws.stands_on_table(t.centroid)
                && !ws.places.iter().any(|pl| pl.contains([t.centroid[0], t.centroid[1]]))
            {
                tracing::debug!(
                    "segment {} at ({:.3}, {:.3}, {:.3}): found when looking at a coarse one",
                    t.id,
                    t.centroid[0],
                    t.centroid[1],
                    t.centroid[2]
                );
                kept.push(t.clone());
            }
        }
    }
    Ok(kept)
}

/// How far (m, on the table) the chassis pair's measured footprint centre may lie from a coarse
/// track's centroid to be taken as the same object (`measure_coarse_from_chassis`, [`look_over_table`]): the
/// tracker's own gate between two frames — a coarse centroid of a can beside the chest lay 6.9 cm
/// beyond where the chassis pair measured it, 1.6 cm from where it stood (development seed 1,
/// execute scene 21); the chassis blob is found first by its image holding the track's.
pub const CHASSIS_GATE: f64 = 0.08;

/// The tracks the head saw only coarsely (no extent measured on the support plane) and never
/// whole (always cut by the image border or the robot's body) take the
/// colours — and the extent, when it measured one within [`CHASSIS_GATE`] — the fixed chassis
/// pair sees of the object there ([`crate::watch::Watcher::chassis_measure`]: the one chassis
/// blob whose whole view holds the track's image). Near the
/// robot the chest hides the lower part of an object from the head: its silhouette is cut by the
/// body, nothing stands on the table in its view, and what the head sees of it is mostly its top
/// (development seeds 1–4: red coffee cans 0.43–0.47 m in front of the robot seen as 78–91 %
/// black, their lids, and left alone as not red; a cola can seen a quarter grey, its
/// aluminium top). The chassis pair looks from in front of the chest and sees such objects whole.
/// The track's centroid stays the head's (the tracker follows it); only what the decision reads
/// — the extent and the colours — changes. Not for tracks the head saw whole: from farther away
/// the chassis pair sees less well than the head (a lying coffee can 0.72 m away measured 31 cm
/// long).
fn measure_coarse_from_chassis(
    plant: &mut RobotPlant<'_>,
    mut seen: Vec<SegmentPercept>,
) -> Result<Vec<SegmentPercept>, RobotError> {
    let coarse: Vec<usize> = (0..seen.len())
        .filter(|&i| measured(&seen[i]).is_none() && !plant.watcher().seen_whole(seen[i].id))
        .collect();
    if coarse.is_empty() {
        return Ok(seen);
    }
    let points: Vec<[f64; 3]> = coarse.iter().map(|&i| seen[i].centroid).collect();
    let found = plant.chassis_measure(&points, CHASSIS_GATE)?;
    for (&i, m) in coarse.iter().zip(found) {
        let Some(m) = m else {
            continue;
        };
        let s = &mut seen[i];
        tracing::debug!(
            "segment {} at ({:.3}, {:.3}): coarse to the head, seen whole by the chassis pair: extent {:?} colour terms {:?} (were {:?})",
            s.id,
            s.centroid[0],
            s.centroid[1],
            m.extent,
            m.colors,
            s.colors
        );
        if let Some(e) = m.extent.filter(|e| e.model != "coarse") {
            if plant.locate(s.id, &e) {
                s.centroid = [e.center[0], e.center[1], plant.watcher().table_z() + 0.5 * e.height];
            }
            s.extent = Some(e);
        }
        s.colors = m.colors;
    }
    Ok(seen)
}

/// A coarse track's centroid higher than this (m above the table) is looked at directly before a
/// task ([`look_over_table`]): half the tallest graspable object (22 cm) and 5.5 cm of a
/// triangulated centroid's error.
pub const COARSE_TOO_HIGH: f64 = 0.165;

/// The smallest radius (m) of a graspable object's footprint: half the narrowest the hand takes
/// (4 cm across).
pub const MIN_OBJECT_RADIUS: f64 = 0.02;

/// The radius (m) of the circle inside a track's footprint ([`schema::SeenExtent::half_minor`]; a
/// disc's radius): two solid objects cannot stand with these circles overlapping. A coarse
/// footprint (from a silhouette's area, which takes in what hides or touches it: a thermos 4 cm in
/// radius measured 8.6 cm) or none counts [`MIN_OBJECT_RADIUS`].
fn inscribed_radius(s: &SegmentPercept) -> f64 {
    measured(s).map_or(MIN_OBJECT_RADIUS, |e| {
        e.half_minor.min(e.half_major).max(MIN_OBJECT_RADIUS)
    })
}

/// A track's extent when it was measured on the support plane (not `coarse`: from a silhouette's
/// size only).
fn measured(s: &SegmentPercept) -> Option<&schema::SeenExtent> {
    s.extent.as_ref().filter(|e| e.model != "coarse")
}

/// One track per object: of tracks whose footprints' inscribed circles overlap — a tall
/// object the tracker followed as two, its silhouette measured from one view and triangulated
/// coarsely from another (development seed 1, execute scenes 33 and 34: a milk carton and a green
/// bottle decided on twice, their centres 1.3 and 3.3 cm apart; a thermos and a bottle side by
/// side on scene 23 lay 10.8 cm apart) — the one measured on the support plane is
/// kept (then one seen now), in the tracks' order. So is a coarse track whose centre lies inside
/// a measured footprint ([`inside_footprint`]): a glass-cleaner bottle measured as an elongated
/// prism and triangulated coarsely 11 cm from its centre, inside it, was decided on twice and its
/// second track grasped at three times where the bottle had been (development seed 2, execute
/// scene 33).
fn one_per_footprint(seen: Vec<SegmentPercept>) -> Vec<SegmentPercept> {
    let rank = |s: &SegmentPercept| (measured(s).is_some(), s.seen);
    let mut order: Vec<usize> = (0..seen.len()).collect();
    order.sort_by_key(|&i| std::cmp::Reverse(rank(&seen[i])));
    let mut keep = vec![false; seen.len()];
    for &i in &order {
        let (a, ra) = (&seen[i], inscribed_radius(&seen[i]));
        let a_coarse = measured(a).is_none();
        let overlaps = (0..seen.len()).filter(|&j| keep[j]).find(|&j| {
            let b = &seen[j];
            let d = (a.centroid[0] - b.centroid[0]).hypot(a.centroid[1] - b.centroid[1]);
            d < ra + inscribed_radius(b) || (a_coarse && inside_footprint(a.centroid, b))
        });
        if let Some(j) = overlaps {
            tracing::debug!(
                "segment {} at ({:.3}, {:.3}) {:?} overlaps segment {}: the same object",
                a.id,
                a.centroid[0],
                a.centroid[1],
                a.extent,
                seen[j].id
            );
        } else {
            keep[i] = true;
        }
    }
    seen.into_iter().zip(keep).filter(|(_, k)| *k).map(|(s, _)| s).collect()
}

/// Whether the point `p` (x, y) lies inside `b`'s measured footprint (the rectangle along its major
/// axis; a coarse footprint, from a silhouette's area, counts as none).
fn inside_footprint(p: [f64; 3], b: &SegmentPercept) -> bool {
    let Some(e) = measured(b) else {
        return false;
    };
    let (dx, dy) = (p[0] - e.center[0], p[1] - e.center[1]);
    let along = dx * e.major_axis[0] + dy * e.major_axis[1];
    let across = -dx * e.major_axis[1] + dy * e.major_axis[0];
    along.abs() <= e.half_major && across.abs() <= e.half_minor
}

/// A task for [`run_task`].
#[derive(Debug, Clone)]
pub struct Task<'a> {
    /// The schema library (actions, schemas).
    pub library: &'a Library,
    /// The schema to run per relevant segment.
    pub schema: &'a str,
    /// How the robot decides per segment.
    pub decider: Decider<'a>,
    /// A user pointed at this spot on the table (m, world x, y): only the seen segment nearest it,
    /// within [`POINTED_RADIUS`], is decided on. `None`: every segment seen.
    pub only_near: Option<[f64; 2]>,
    /// How many actions the executive may take per segment.
    pub max_actions: usize,
}

/// What the robot did with one decision.
#[derive(Debug, Clone)]
pub enum Taken {
    /// Not part of the task (the decision's reason says why).
    Ignored {
        /// Why.
        why: String,
    },
    /// Part of the task, but no free arm reaches the segment, or none reaches the place.
    Skipped {
        /// The place decided, if the task has one.
        place: Option<String>,
        /// Why.
        why: String,
    },
    /// The schema ran on it.
    Executed {
        /// The place decided, if the task has one.
        place: Option<String>,
        /// Arms used, in order (`left`, `right`).
        arms: Vec<String>,
        /// ψ bound a hand-to-hand transfer.
        transfer: bool,
        /// Contingencies the executive took, then ψ's rebindings, in order.
        contingencies: Vec<String>,
        /// The executive's report (its steps; whether its monitors saw the goal state).
        execution: ExecReport,
    },
}

/// One seen segment: the decision and what the robot did with it.
#[derive(Debug, Clone)]
pub struct SegmentRun {
    /// The decision.
    pub decision: Decision,
    /// What was done.
    pub taken: Taken,
}

impl SegmentRun {
    /// The robot's own verdict: the schema ran and its monitors saw the goal state.
    pub fn reached_goal(&self) -> bool {
        matches!(&self.taken, Taken::Executed { execution, .. } if execution.reached_goal)
    }
}

/// Listens to [`run_task`]. Every method has a default that ignores it.
pub trait TaskSink {
    /// The robot takes up `decision` (before anything is done about it).
    fn begin(&mut self, _hw: &dyn Hardware, _decision: &Decision) {}
    /// The robot decided what to do with the segment, before it acts on it.
    fn decided(&mut self, _hw: &dyn Hardware, _event: &DecisionEvent<'_>) {}
    /// The robot turns to the segment to act on it (to put it in `place`, if the task has one;
    /// it looks there next).
    fn acting(&mut self, _hw: &dyn Hardware, _decision: &Decision, _place: Option<&str>) {}
    /// The robot is done with one segment (after [`SETTLE_AFTER_SECS`] when it acted). A listener
    /// may let time pass here with `plant.settle` (the robot holds still), e.g. to judge an outcome.
    fn done(&mut self, _plant: &mut RobotPlant<'_>, _run: &SegmentRun) -> Result<(), RobotError> {
        Ok(())
    }
}

/// A [`TaskSink`] that ignores everything.
#[derive(Debug, Default, Clone, Copy)]
pub struct NoTaskSink;

impl TaskSink for NoTaskSink {}

/// Runs `task` on `plant`: looks over the table, decides per seen segment, and for each relevant
/// one looks where it was decided on, finds its track again (the tracker may have lost or
/// re-identified it while the robot worked elsewhere), plans the handoff spot, lets ψ bind the arms
/// ([`ArmPolicy`]: one arm, or a hand-to-hand transfer) and runs the schema. Returns, per
/// decision in order, what the robot did.
pub fn run_task(
    plant: &mut RobotPlant<'_>,
    task: &Task<'_>,
    sink: &mut dyn TaskSink,
) -> Result<Vec<SegmentRun>, RobotError> {
    let schema = task.library.schema(task.schema)?.clone();
    runnable(task.library, &schema).map_err(|message| RobotError::Binding {
        action: task.schema.to_string(),
        message,
    })?;
    plant.set_touch_task(touches_without_grasp(task.library, &schema));
    let ws: &Workspace = plant.workspace();
    let mut seen = look_over_table(plant)?;
    if let Some(p) = task.only_near {
        let d = |s: &SegmentPercept| (s.centroid[0] - p[0]).hypot(s.centroid[1] - p[1]);
        seen.retain(|s| d(s) < POINTED_RADIUS);
        seen.sort_by(|a, b| d(a).total_cmp(&d(b)));
        seen.truncate(1);
    }
    let place_names: Vec<String> = ws.places.iter().map(|p| p.name.clone()).collect();
    let decisions = match &task.decider {
        Decider::Place(p) => seen
            .iter()
            .map(|s| Decision {
                segment: s.id,
                at: s.centroid,
                place: Ok(Some(p.clone())),
                posterior: BTreeMap::new(),
                log_bayes_factor: None,
                size_cm: Features::from(s).size_cm(),
                arm: None,
                reason: format!("the demonstration placed its object in {p}"),
            })
            .collect(),
        Decider::Every => seen
            .iter()
            .map(|s| Decision {
                segment: s.id,
                at: s.centroid,
                place: Ok(None),
                posterior: BTreeMap::new(),
                log_bayes_factor: None,
                size_cm: Features::from(s).size_cm(),
                arm: None,
                reason: format!("the demonstration's `{}` is done to every object seen", task.schema),
            })
            .collect(),
        Decider::Model(model) => decide(model, &place_names, &seen, has_place(task.library, &schema))?,
    };
    let mut runs = Vec::with_capacity(decisions.len());
    let decided: Vec<(u32, [f64; 3], bool)> = decisions.iter().map(|d| (d.segment, d.at, d.place.is_err())).collect();
    for d in decisions {
        plant.set_other_objects(decided.iter().copied().filter(|o| o.0 != d.segment).collect());
        sink.begin(&*plant.hw, &d);
        let taken = run_one(plant, task, &schema, &d, sink)?;
        let run = SegmentRun { decision: d, taken };
        sink.done(plant, &run)?;
        plant.let_go_of_touches()?;
        runs.push(run);
    }
    plant.set_other_objects(Vec::new());
    Ok(runs)
}

/// Whether `schema` touches its object without grasping it: one of its actions binds to
/// [`Skill::Touch`] and none to [`Skill::Grasp`] (its reach stops clear of the object, and the
/// Touch makes the contact: [`RobotPlant::set_touch_task`]).
pub fn touches_without_grasp(library: &Library, schema: &schema::Schema) -> bool {
    let skills = SkillMap::new(library);
    let has = |k: Skill| schema.actions.iter().any(|&a| skills.at(a) == Some(k));
    has(Skill::Touch) && !has(Skill::Grasp)
}

/// Whether `schema` puts its object somewhere: one of its actions binds to [`Skill::Place`].
pub fn has_place(library: &Library, schema: &schema::Schema) -> bool {
    let skills = SkillMap::new(library);
    schema.actions.iter().any(|&a| skills.at(a) == Some(Skill::Place))
}

/// Whether Dexter can run `schema`: every action its policy π runs binds to one of its skills.
/// `Err` names the first that does not.
pub fn runnable(library: &Library, schema: &schema::Schema) -> Result<(), String> {
    let skills = SkillMap::new(library);
    for &a in schema.policy.iter() {
        if skills.at(a).is_none() {
            let act = &library.actions[a];
            let name = &act.name;
            return Err(format!(
                "schema `{}` runs `{name}` ({}, {}, {}), which binds to none of Dexter's skills",
                schema.name, act.potential, act.feedback, act.effector
            ));
        }
    }
    Ok(())
}

/// One decision of [`run_task`].
fn run_one(
    plant: &mut RobotPlant<'_>,
    task: &Task<'_>,
    schema: &schema::Schema,
    d: &Decision,
    sink: &mut dyn TaskSink,
) -> Result<Taken, RobotError> {
    let place = match &d.place {
        Err(why) => {
            sink.decided(&*plant.hw, &d.event(Verdict::Ignore, None, None, why));
            return Ok(Taken::Ignored { why: why.clone() });
        }
        Ok(p) => p.clone(),
    };
    let wants_place = has_place(task.library, schema);
    if wants_place && place.is_none() {
        let why = format!("`{}` puts its object in a place, and none was decided", schema.name);
        sink.decided(&*plant.hw, &d.event(Verdict::Ignore, None, None, &why));
        return Ok(Taken::Ignored { why });
    }
    let place = if wants_place { place } else { None };
    // A hand still holding what an earlier segment's schema left in it (Pick-And-Hold) is not free.
    let free: Vec<Arm> = Arm::BOTH.into_iter().filter(|&a| !plant.holds(a)).collect();
    if free.is_empty() {
        let why = "both hands hold an object from this task".to_string();
        sink.decided(&*plant.hw, &d.event(Verdict::Skip, place.as_deref(), None, &why));
        return Ok(Taken::Skipped { place, why });
    }
    sink.acting(&*plant.hw, d, place.as_deref());
    // Look where it was decided on, then find it: its track, or the seen segment nearest where it
    // was decided on, looking there and, failing that, over the table.
    plant.look(&Vec3::from(d.at), SCAN_LOOK_SECS)?;
    let by_id = plant.last_percept().and_then(|p| {
        p.segments
            .iter()
            .find(|s| s.id == d.segment)
            .map(|s| (s.id, Vec3::from(s.centroid)))
    });
    let now = match by_id {
        Some(found) => Some(found),
        None => plant.find(&Vec3::from(d.at))?,
    };
    let (segment_now, at) = now.unwrap_or((d.segment, Vec3::from(d.at)));
    plant.set_destination(place.as_deref());
    plant.plan_handoff(&at)?;
    let handoff = plant.handoff();
    let policy = ArmPolicy::decide(
        &*plant.hw,
        plant.workspace(),
        task.library,
        schema,
        &segment_now.to_string(),
        &at,
        place.as_deref(),
        handoff,
    )?
    .and_then(|p| p.among(&free))
    .map(|p| match d.arm {
        Some(arm) => p.prefer(arm),
        None => p,
    });
    let Some(mut policy) = policy else {
        let why = match &place {
            Some(place) => format!("no free arm reaches segment {}, or none reaches `{place}`", d.segment),
            None => format!("no free arm reaches segment {}", d.segment),
        };
        sink.decided(&*plant.hw, &d.event(Verdict::Skip, place.as_deref(), None, &why));
        return Ok(Taken::Skipped { place, why });
    };
    let arms = [policy.pick_arm.prefix(), policy.place_arm.prefix()];
    sink.decided(
        &*plant.hw,
        &d.event(Verdict::Execute, place.as_deref(), Some(arms), &d.reason),
    );
    plant.bind_arms(&[policy.pick_arm, policy.place_arm]);
    plant.bind_object(&at);
    let arms_before = plant.arms_used.len();
    let execution = schema::execute(task.library, schema, plant, &mut policy, task.max_actions)?;
    let arms: Vec<String> = plant.arms_used[arms_before..]
        .iter()
        .map(|a| a.prefix().to_string())
        .collect();
    plant.settle(SETTLE_AFTER_SECS)?;
    Ok(Taken::Executed {
        place,
        arms,
        transfer: policy.is_transfer(),
        contingencies: execution
            .contingencies
            .iter()
            .chain(&policy.rebindings)
            .cloned()
            .collect(),
        execution,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use schema::SeenExtent;

    fn track(id: u32, at: [f64; 2], extent: Option<(&str, [f64; 2], f64, f64)>) -> SegmentPercept {
        SegmentPercept {
            id,
            centroid: [at[0], at[1], 0.85],
            seen: true,
            pixels: [100, 100],
            histogram: Vec::new(),
            covariance: [0.0; 4],
            colors: Vec::new(),
            extent: extent.map(|(model, axis, half_major, half_minor)| SeenExtent {
                height: 0.18,
                center: at,
                major_axis: axis,
                half_major,
                half_minor,
                model: model.to_string(),
            }),
        }
    }

    /// A coarse track whose centre lies in a measured footprint is that object seen again (a tall
    /// bottle triangulated coarsely 11 cm from the centre of its measured, elongated footprint,
    /// development seed 2, execute scene 33); a measured track there, or a coarse one beside the
    /// footprint, is another object.
    #[test]
    fn a_coarse_track_inside_a_measured_footprint_is_the_same_object() {
        let axis = [0.988, -0.156];
        let long = track(2, [0.649, 0.089], Some(("prism", axis, 0.168, 0.028)));
        let coarse_inside = track(0, [0.542, 0.092], Some(("coarse", [1.0, 0.0], 0.059, 0.059)));
        let measured_inside = track(3, [0.793, 0.075], Some(("prism", [0.27, -0.96], 0.02, 0.012)));
        let coarse_beside = track(4, [0.60, 0.16], None);
        let kept: Vec<u32> = one_per_footprint(vec![coarse_inside, long, measured_inside, coarse_beside])
            .iter()
            .map(|s| s.id)
            .collect();
        assert_eq!(kept, vec![2, 3, 4]);
    }
}
