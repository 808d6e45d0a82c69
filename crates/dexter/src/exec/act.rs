//! The executive's abstract actions on Dexter ([`SchemaPlant`] for [`RobotPlant`]): each action bound
//! to its skill, run closed-loop and judged by the robot's own monitors.

use control_basis::math::Vec3;
use schema::{ActionOutcome, Binding, Failure, FailureCause, SchemaPlant, StepEvent};

use crate::actions::Skill;
use crate::arm::Arm;
use crate::error::RobotError;
use crate::skills::{
    FingerRoom, GRASP_FINGER_ROOM, Held, approach_grasp, close_grasp, contact_center, finger_arc, idle, lift_and_weigh,
    park_pose, plan_top_grasp_among, release_and_retreat, run_until, set_down, touch_object, transport_over,
};

use super::plant::*;
use super::workspace::*;

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
        if let (Some(bound), Some(arm)) = (self.bound.arms.as_mut(), binding.arm.as_ref())
            && !bound.contains(arm)
        {
            bound.push(arm.clone());
        }
        if let (Some(a), Some(arm)) = (self.skills.index(Skill::ReachObject), binding.arm.as_ref()) {
            self.bound.reach = Some((a, arm.clone()));
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
                        // A tall thing hides a stretch of table behind it from the head: the
                        // object may lie there rather than have left the table.
                        let mut tall: Vec<[f64; 2]> = Vec::new();
                        for o in self.tall_things() {
                            if tall
                                .iter()
                                .all(|t| (t[0] - o.center[0]).hypot(t[1] - o.center[1]) > 0.05)
                            {
                                tall.push(o.center);
                            }
                        }
                        let hiding: Vec<String> = tall.iter().map(|t| format!("({:.2}, {:.2})", t[0], t[1])).collect();
                        let whereabouts = if hiding.is_empty() {
                            "it left the table".to_string()
                        } else {
                            format!(
                                "it left the table, or lies hidden from the head behind the tall thing at {}",
                                hiding.join(" or ")
                            )
                        };
                        Some(format!(
                            "the object is gone: not seen where it was last seen ({:.2}, {:.2}) nor anywhere on the \
                             table, twice ({whereabouts})",
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
                self.bound.object_at = Some([seen.centroid.x, seen.centroid.y, seen.centroid.z]);
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
                // The fingers come down clear of the places' walls and of the other things seen: a
                // fingertip landing there stops the descent (or, for a touch, touches the wrong
                // thing).
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
                // A touch takes the roomiest direction, and so does a grasp after a descent
                // stopped short there; otherwise a grasp turns only when the first narrowest
                // leaves its fingers too little room (always turning changed how two pinned fault
                // scenes recovered, development seed 1, bump 6 and blocked arm 8), and only across
                // a measured footprint: a coarse one is a disc of the silhouette's area, every
                // direction alike, and turning at the first try closed the hand along a cereal
                // box (development seed 3, execute scene 4) — at the second, it took a sugar box
                // and a coffee can whose first descents had stopped short (seed 1 scene 37,
                // seed 4 scene 17).
                let retry = self
                    .stopped_short
                    .iter()
                    .any(|p| (p[0] - target.x).hypot(p[1] - target.y) < RETRY_RADIUS);
                let room = FingerRoom {
                    free: &room,
                    enough: if self.touch_task || retry {
                        f64::INFINITY
                    } else {
                        GRASP_FINGER_ROOM
                    },
                };
                let coarse = seen.extent.model == "coarse";
                let room = (self.touch_task || retry || !coarse).then_some(room);
                let mut plan = plan_top_grasp_among(&arc, &seen, table_z, &current, room);
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
                            self.stopped_short.push([target.x, target.y]);
                            self.back_off(arm)?;
                        } else if why.effector_blocked() {
                            self.unreached.push((arm, [target.x, target.y]));
                            // An arm stopped on its way (not one that found no pose and stayed)
                            // backs to its park pose, the way it came: left against what stopped
                            // it, it hides that thing's edges from the cameras (a post then seen
                            // as a coarse blob 8 cm nearer the head), and the next plan goes round
                            // the wrong place.
                            if why.cause == FailureCause::ApproachNotReached {
                                self.park(arm)?;
                            }
                        }
                        ActionOutcome::Failed(why)
                    }
                }
            }
            Some(Skill::Grasp) => {
                let arm = parse_arm(action, binding.arm.as_deref())?;
                let k = arm.index();
                self.lowered = None;
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
                        // Where the object sits in the hand: where the fingers feel it, not where
                        // it was seen before they closed.
                        let seen_hold = Held::new(&seen, &grasp_palm, table_z, load);
                        let palm = self.reach[k].tool_pose(self.hw).translation.vector;
                        let held = seen_hold.felt_at(&palm, contact_center(self.hw, arm));
                        tracing::debug!(
                            "held: offset from the palm {:?} as seen, {:?} as felt (palm {:?})",
                            seen_hold.offset_xy,
                            held.offset_xy,
                            [palm.x, palm.y, palm.z]
                        );
                        self.held = Some(held);
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
                self.lowered = None;
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
                let (mut target, wall) = if binding.transfer {
                    if !self.unreached.is_empty() {
                        // A reach failed somewhere: the handoff spot must keep clear of there (the
                        // arm that failed may be the one to take the object).
                        let palm = self.reach[k].tool_pose(self.hw).translation.vector;
                        let seen = self.scan_handoff_region(&palm)?;
                        // Where the object is (the handoff planner's lines of sight go to its top,
                        // twice its centre's height: the palm's height at the grasp, at most).
                        let table_z = self.workspace.table_z;
                        let object = Vec3::new(
                            palm.x + held.offset_xy[0],
                            palm.y + held.offset_xy[1],
                            table_z + 0.5 * held.below,
                        );
                        self.plan_handoff_among(&object, &seen)?;
                    }
                    (self.handoff, 0.0)
                } else {
                    let name = binding.place.as_deref().ok_or_else(|| RobotError::Binding {
                        action: action.into(),
                        message: "no place".into(),
                    })?;
                    let p = self.workspace.place(name)?.clone();
                    (self.place_spot(&p, &held, arm, WALL_ROOM)?, p.wall_height)
                };
                let place_name = (!binding.transfer).then(|| binding.place.clone()).flatten();
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
                    // The way round a tall thing may pass the other arm, parked over the table's
                    // near corner on its side (its parked hand took the carried object's load three
                    // times: development seed 1, blocked arm, scene 25): stowed out to its side
                    // first, if it holds nothing and touches nothing (a hand resting on the carried
                    // object takes part of its load; moving it away, the carry took the change for
                    // the object meeting an obstacle: development seed 1, blocked arm, scene 7).
                    if self.touch(arm.other()).loaded == 0 {
                        self.stow(arm.other())?;
                    }
                }
                let transfer = binding.transfer;
                let r = self.with_observer(|hw, reach, hand, obs| {
                    transport_over(hw, &mut reach[k], &held, target, table_z, clear, obs)?;
                    set_down(hw, &mut reach[k], &hand[k], &held, table_z, obs);
                    if transfer {
                        // The transfer ends with the hand open: the other hand takes it from here.
                        release_and_retreat(hw, &mut reach[k], &hand[k], obs);
                    }
                    Ok::<(), Failure>(())
                })?;
                let mut r = r;
                if let Some(name) = place_name.as_deref() {
                    // The support took the load well above the place's floor: the object stands on
                    // something there the robot did not see, or on the edge of something it saw
                    // (a lying football measured round, 2.8 cm in radius, came to rest on a coffee
                    // can's lid: development seed 1, execute scene 25). Lift it off and put it down
                    // elsewhere in the place, that spot taken as filled and the object as at least
                    // [`PERCHED_RADIUS`] across — [`PERCHED_TRIES`] times, then let go where it
                    // rests (a second try lost two objects the first one placed: development
                    // seed 1 scene 25, seed 5 scene 12).
                    let wide = Held {
                        radius: held.radius.max(PERCHED_RADIUS),
                        ..held
                    };
                    for _ in 0..PERCHED_TRIES {
                        let perched = self.reach[k].tool_pose(self.hw).translation.vector.z - (table_z + held.below);
                        if r.is_err() || perched <= PERCHED {
                            break;
                        }
                        // Only beside something known there: the object may have slid down in the
                        // hand since the grasp, and then it rests on the floor with the palm
                        // higher than the grasp said (a coffee can 6 cm, a cereal box 5.5 cm, each
                        // lowered into an empty bin: development seed 8, execute scenes 14 and 3).
                        let p = self.workspace.place(name)?.clone();
                        let beside = self.known_in_place(&p, arm).iter().any(|(o, ro)| {
                            (o[0] - target[0]).hypot(o[1] - target[1]) < wide.radius + ro + PERCHED_BESIDE
                        });
                        if !beside {
                            tracing::debug!(
                                "the carried object came to rest {perched:.3} m above the table at {target:.3?}, nothing known beside it: on the floor"
                            );
                            break;
                        }
                        tracing::debug!(
                            "the carried object came to rest {perched:.3} m above the table at {target:.3?}: on something; placing it elsewhere"
                        );
                        self.put_down.push(InPlace {
                            place: name.to_string(),
                            at: target,
                            radius: wide.radius,
                            felt: true,
                        });
                        let again = self.place_spot(&p, &wide, arm, TIGHT_WALL_ROOM)?;
                        if (again[0] - target[0]).hypot(again[1] - target[1]) < PERCHED_MOVE {
                            break;
                        }
                        let clear = clear.max(perched + 0.02);
                        r = self.with_observer(|hw, reach, hand, obs| {
                            transport_over(hw, &mut reach[k], &held, again, table_z, clear, obs)?;
                            set_down(hw, &mut reach[k], &hand[k], &held, table_z, obs);
                            Ok::<(), Failure>(())
                        })?;
                        target = again;
                    }
                }
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
                    Ok(()) => {
                        if let Some(name) = place_name {
                            self.lowered = Some(InPlace {
                                place: name,
                                at: target,
                                radius: held.radius,
                                felt: false,
                            });
                        }
                        ActionOutcome::Converged
                    }
                    Err(why) => {
                        if why.cause == FailureCause::Obstructed {
                            self.remember_felt_obstacle(arm, &held, target);
                        }
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
                    self.put_down.extend(self.lowered.take());
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
