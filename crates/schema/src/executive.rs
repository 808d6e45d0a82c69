//! The executive: runs a schema (Def. 3.3) on any plant. It observes the predicate vector, decides
//! which state of the schema the world is in, runs π(state) bound to feedback elements and
//! effectors by the procedural policy ψ, and repeats until a goal state is reached — taking the
//! schema's contingencies (a re-grasp after a drop, a hand-to-hand transfer) when the observed state
//! says so. The declarative schema knows nothing of arms or objects; ψ does, so a schema inferred
//! from a right-arm demonstration runs with the left arm when ψ says so.

use serde::{Deserialize, Serialize};

use crate::error::SchemaError;
use crate::library::{Expect, Library, Schema};

/// The procedural binding of one abstract action: its feedback elements and effector (ψ's output).
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Binding {
    /// Effector (arm / hand).
    pub arm: Option<String>,
    /// Object (feedback element of Reach / Grasp).
    pub object: Option<String>,
    /// Place (feedback element of Reach-to-place / Place); for a transfer, the handoff location.
    pub place: Option<String>,
    /// Whether this binding is part of a hand-to-hand transfer.
    pub transfer: bool,
}

/// How running an action ended (an outcome, not an error).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum ActionOutcome {
    /// The controller converged.
    Converged,
    /// It did not; why, as the plant measured it.
    Failed(Failure),
}

/// Why an action did not converge: a typed cause that ψ and the reports match on, the figure the
/// plant measured where the cause has one, and the plant's own words for people. (§3.3.3: a
/// controller that does not converge is information for ψ — which resource failed, and how.)
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Failure {
    /// What went wrong.
    pub cause: FailureCause,
    /// How far (m) the effector still was from the controller's goal when it stopped, for the
    /// causes that have one ([`FailureCause::ApproachNotReached`], [`FailureCause::StoppedShort`],
    /// [`FailureCause::PlaceNotReached`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub distance: Option<f64>,
    /// What the plant says, with its figures (for logs and reports).
    pub message: String,
}

impl Failure {
    /// A failure of `cause`, described by `message`.
    pub fn new(cause: FailureCause, message: impl Into<String>) -> Self {
        Failure {
            cause,
            distance: None,
            message: message.into(),
        }
    }

    /// A failure of `cause` that stopped `distance` (m) from its goal.
    pub fn short_of(cause: FailureCause, distance: f64, message: impl Into<String>) -> Self {
        Failure {
            cause,
            distance: Some(distance),
            message: message.into(),
        }
    }

    /// The effector could not get where the action needed it: no solution for its pose, or its
    /// approach stopped on the way (something in its path) — the resource failed, not the object.
    pub fn effector_blocked(&self) -> bool {
        matches!(self.cause, FailureCause::OutOfReach | FailureCause::ApproachNotReached)
    }
}

impl std::fmt::Display for Failure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

/// The kinds of [`Failure`] a plant reports.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FailureCause {
    /// No pose of the effector solves the action's goal (inverse kinematics found none).
    OutOfReach,
    /// The approach to the object (a pose above it, before the final move) was not reached: the
    /// arm stopped on the way.
    ApproachNotReached,
    /// The final move onto the object stopped short of its goal (on the object or on something
    /// where the fingers should have passed).
    StoppedShort,
    /// The action's object is not seen (no tracked segment, not found by a search).
    NotSeen,
    /// The object left the table, or is nowhere to be seen any more.
    Gone,
    /// The object moved before the hand closed, or may have moved under it.
    Moved,
    /// The hand closed without opposing contacts.
    NoGrasp,
    /// The object was not held after the lift.
    NotLifted,
    /// The carried object was lost on the way.
    Dropped,
    /// The carried object met an obstacle on the way.
    Obstructed,
    /// The place was not reached.
    PlaceNotReached,
    /// The fingertips still feel the object after the hand opened.
    NotReleased,
    /// What the action needs first is not there (nothing grasped to hold, nothing held to place).
    Precondition,
    /// The plant has no controller for the action.
    NoController,
}

/// A plant the executive can drive: it runs abstract actions bound by ψ and reports the observation
/// vector x over the library's actions (4.19) from its own monitors.
pub trait SchemaPlant {
    /// The plant's error (invalid use, a broken simulator) — not an action's failure.
    type Error: std::error::Error + Send + Sync + 'static;
    /// The observation vector now.
    fn observe(&mut self) -> Result<Vec<bool>, Self::Error>;
    /// Runs `action` with `binding` until it converges, fails or times out.
    fn run(&mut self, action: &str, binding: &Binding) -> Result<ActionOutcome, Self::Error>;
    /// Told where the executive stands before each action (and once at a goal state), for logs
    /// and viewers. The default ignores it.
    fn step(&mut self, _event: &StepEvent<'_>) {}
}

/// Where the executive stands: the state it found the world in from observation `x`, and what it
/// is about to do there (see [`SchemaPlant::step`]).
#[derive(Debug, Clone, Copy)]
pub struct StepEvent<'a> {
    /// The library (its actions name the entries of `x`).
    pub library: &'a Library,
    /// The schema being executed.
    pub schema: &'a Schema,
    /// Index of the state into `schema.states`.
    pub state: usize,
    /// The observation the state was judged from (one entry per library action: its monitor
    /// set converged).
    pub x: &'a [bool],
    /// The action π chose; empty at a goal state.
    pub action: &'a str,
    /// ψ's binding (`None` at a goal state).
    pub binding: Option<&'a Binding>,
    /// The contingency edge taken into this state, if any.
    pub contingency: Option<&'a str>,
}

/// The procedural policy ψ: binds an abstract action in a schema state to resources.
pub trait ProceduralPolicy {
    /// The binding of `action` in `state` (of schema `schema`).
    fn bind(&mut self, schema: &Schema, state: &str, action: &str) -> Binding;

    /// `action`, bound as `binding` in `state`, did not converge (`why`): ψ may bind other resources
    /// next time (another arm, a hand-over; §3.3.3). The default keeps the binding.
    fn failed(&mut self, _schema: &Schema, _state: &str, _action: &str, _binding: &Binding, _why: &Failure) {}
}

/// One step of an execution.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ExecStep {
    /// The state the executive found the world in.
    pub state: String,
    /// The action π chose.
    pub action: String,
    /// ψ's binding.
    pub binding: Binding,
    /// How it went.
    pub outcome: ActionOutcome,
    /// The contingency label of the transition into `state`, if one was taken.
    pub contingency: Option<String>,
}

/// What an execution did.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ExecReport {
    /// The schema.
    pub schema: String,
    /// The steps.
    pub steps: Vec<ExecStep>,
    /// The final state.
    pub final_state: String,
    /// Whether a goal state was reached.
    pub reached_goal: bool,
    /// Contingencies taken (drop → regrasp, transfer).
    pub contingencies: Vec<String>,
}

/// How well observation `x` agrees with state `s` of `schema`: the number of the state's constrained
/// actions whose monitor sets agree, minus the disagreements (actions outside the schema count as
/// expected-0).
fn agreement(library: &Library, schema: &Schema, s: usize, x: &[bool]) -> i64 {
    let mut score = 0;
    for (a, &xa) in x.iter().enumerate().take(library.actions.len()) {
        match schema.expects(s, a) {
            Expect::Converged => score += if xa { 1 } else { -1 },
            Expect::NotConverged => score += if xa { -1 } else { 1 },
            Expect::Either => {}
        }
    }
    score
}

/// How many times one action, bound alike, may fail the same way (cause and message) in one run
/// before [`execute`] gives up.
pub const SAME_FAILURES: usize = 3;

/// Runs `schema` on `plant` with ψ = `policy`, for at most `max_actions` actions.
///
/// The state after each action is the best-agreeing one among the current state and its successors
/// in T (ties: successors first, contingency edges last — unless ψ's last binding was a transfer,
/// which selects the transfer edge).
pub fn execute<P: SchemaPlant>(
    library: &Library,
    schema: &Schema,
    plant: &mut P,
    policy: &mut dyn ProceduralPolicy,
    max_actions: usize,
) -> Result<ExecReport, SchemaError> {
    let plant_error = |e: P::Error| SchemaError::Plant(Box::new(e));
    let mut state = schema.start;
    let mut steps: Vec<ExecStep> = Vec::new();
    let mut contingencies = Vec::new();
    let mut last_transfer = false;
    let mut entered_by: Option<String> = None;
    for _ in 0..max_actions {
        let x = plant.observe().map_err(plant_error)?;
        if x.len() != library.actions.len() {
            return Err(SchemaError::invalid(
                "plant",
                "observation",
                format!("{} entries for {} actions", x.len(), library.actions.len()),
            ));
        }
        // Which state are we in now?
        let mut best = (agreement(library, schema, state, &x), 0i64, state, None::<String>);
        for t in schema.successors(state) {
            let is_transfer = t.contingency.as_deref() == Some("transfer");
            // Prefer plain edges; a transfer edge only after a transfer binding.
            let pref = match (&t.contingency, is_transfer && last_transfer) {
                (_, true) => 2,
                (None, _) => 1,
                (Some(_), _) if is_transfer => -10,
                (Some(_), _) => 0,
            };
            let a = agreement(library, schema, t.to, &x);
            if (a, pref) > (best.0, best.1) {
                best = (a, pref, t.to, t.contingency.clone());
            }
        }
        if best.2 != state {
            tracing::debug!(
                schema = %schema.name,
                from = %schema.states[state].name,
                to = %schema.states[best.2].name,
                "state change"
            );
            state = best.2;
            entered_by = best.3.clone();
            if let Some(c) = &best.3 {
                tracing::info!(schema = %schema.name, state = %schema.states[state].name, "contingency `{c}` taken");
                contingencies.push(c.clone());
            }
        }
        if schema.is_goal(state) {
            plant.step(&StepEvent {
                library,
                schema,
                state,
                x: &x,
                action: "",
                binding: None,
                contingency: entered_by.as_deref(),
            });
            return Ok(ExecReport {
                schema: schema.name.clone(),
                steps,
                final_state: schema.states[state].name.clone(),
                reached_goal: true,
                contingencies,
            });
        }
        let action = &library.actions[schema.policy[state]].name;
        let binding = policy.bind(schema, &schema.states[state].name, action);
        // The same action, bound alike, three times in a row in this state, the world still in it,
        // and the policy binds it alike a fourth time: that changed nothing, give up. (A policy that
        // rebinds after the third failure — another arm — is let run.)
        let n = steps.len();
        if n >= 3
            && steps[n - 3..]
                .iter()
                .all(|s| s.state == schema.states[state].name && s.action == *action && s.binding == binding)
        {
            break;
        }
        last_transfer = binding.transfer;
        plant.step(&StepEvent {
            library,
            schema,
            state,
            x: &x,
            action,
            binding: Some(&binding),
            contingency: entered_by.as_deref(),
        });
        // Each action is a span (`RUST_LOG=schema=info`; the MCAP's `/log` holds them), so that what
        // the plant reports while running it reads in its context.
        let span = tracing::info_span!(
            "action",
            action = %action,
            state = %schema.states[state].name,
            arm = %binding.arm.as_deref().unwrap_or(""),
            object = %binding.object.as_deref().unwrap_or(""),
            place = %binding.place.as_deref().unwrap_or(""),
            transfer = binding.transfer,
        );
        let outcome = span.in_scope(|| {
            let outcome = plant.run(action, &binding);
            match &outcome {
                // A failed action is the schema's to handle (a contingency), not a warning to the user.
                Ok(ActionOutcome::Failed(why)) => tracing::info!("failed: {why}"),
                Ok(o) => tracing::info!("{o:?}"),
                Err(e) => tracing::error!("the plant failed: {e}"),
            }
            outcome
        });
        let outcome = outcome.map_err(plant_error)?;
        if let ActionOutcome::Failed(why) = &outcome {
            policy.failed(schema, &schema.states[state].name, action, &binding, why);
        }
        let step = ExecStep {
            state: schema.states[state].name.clone(),
            action: action.clone(),
            binding,
            outcome,
            contingency: entered_by.take(),
        };
        // The same action, bound alike, failed the same way (cause and message) [`SAME_FAILURES`]
        // times in this run, whatever ran between: retrying changes nothing the plant can see —
        // give up. (A grasp closing on nothing where a stale or merged segment was seen, ten times
        // over with a reach converging between: development seeds 5, 6 and 8 of `pbd experiment
        // execute`; none of these loops ever ended with the object in its place.)
        let repeated = match &step.outcome {
            ActionOutcome::Failed(why) => steps
                .iter()
                .filter(|s| {
                    s.action == step.action
                        && s.binding == step.binding
                        && matches!(&s.outcome, ActionOutcome::Failed(w) if w.cause == why.cause && w.message == why.message)
                })
                .count()
                + 1,
            _ => 0,
        };
        steps.push(step);
        if repeated >= SAME_FAILURES {
            tracing::info!(schema = %schema.name, "the same failure {repeated} times: giving up");
            break;
        }
    }
    Ok(ExecReport {
        schema: schema.name.clone(),
        final_state: schema.states[state].name.clone(),
        steps,
        reached_goal: schema.is_goal(state),
        contingencies,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A toy plant: a world of predicates that actions switch on, with one scripted drop.
    #[derive(Debug)]
    struct Toy {
        lib: Library,
        x: Vec<bool>,
        drop_once: bool,
        /// How many grasps still close on nothing.
        grasp_fails: usize,
        ran: Vec<String>,
    }

    #[derive(Debug, thiserror::Error)]
    #[error("toy")]
    struct ToyError;

    impl Toy {
        fn set(&mut self, name: &str, v: bool) {
            let a = self.lib.action(name).unwrap();
            self.x[a] = v;
        }
    }

    impl SchemaPlant for Toy {
        type Error = ToyError;
        fn observe(&mut self) -> Result<Vec<bool>, ToyError> {
            Ok(self.x.clone())
        }
        fn run(&mut self, action: &str, b: &Binding) -> Result<ActionOutcome, ToyError> {
            self.ran.push(format!("{action}:{}", b.arm.clone().unwrap_or_default()));
            for n in self
                .lib
                .action_names()
                .iter()
                .map(|s| s.to_string())
                .collect::<Vec<_>>()
            {
                self.set(&n, false);
            }
            match action {
                "reach_object" => self.set("reach_object", true),
                "grasp" if self.grasp_fails > 0 => {
                    // Closed on nothing: the hand backs off.
                    self.grasp_fails -= 1;
                    return Ok(ActionOutcome::Failed(Failure::new(
                        FailureCause::NoGrasp,
                        "grasp did not converge (no opposing contacts)",
                    )));
                }
                "grasp" => {
                    self.set("grasp", true);
                    self.set("reach_object", true);
                }
                "hold" => {
                    if self.drop_once {
                        // The object slips out while lifting: nothing is held.
                        self.drop_once = false;
                    } else {
                        self.set("grasp", true);
                        self.set("hold", true);
                    }
                }
                "place" => {
                    self.set("reach_place", true);
                    self.set("place", true);
                }
                "release" => self.set("release", true),
                _ => {}
            }
            Ok(ActionOutcome::Converged)
        }
    }

    struct LeftArm;
    impl ProceduralPolicy for LeftArm {
        fn bind(&mut self, _s: &Schema, _state: &str, _action: &str) -> Binding {
            Binding {
                arm: Some("left".into()),
                ..Binding::default()
            }
        }
    }

    #[test]
    fn pick_and_place_runs_to_its_goal_and_regrasps_after_a_drop() {
        let lib = Library::builtin();
        let k = lib.actions.len();
        let pp = lib.schema("pick_and_place").unwrap().clone();
        for drop in [false, true] {
            let mut toy = Toy {
                lib: lib.clone(),
                x: vec![false; k],
                drop_once: drop,
                grasp_fails: 0,
                ran: vec![],
            };
            let r = execute(&lib, &pp, &mut toy, &mut LeftArm, 30).unwrap();
            assert!(r.reached_goal, "{r:?}");
            assert_eq!(r.final_state, "released");
            assert!(toy.ran.iter().all(|a| a.ends_with(":left")));
            let grasps = toy.ran.iter().filter(|a| a.starts_with("grasp")).count();
            if drop {
                assert!(r.contingencies.contains(&"drop".to_string()), "{r:?}");
                assert_eq!(grasps, 2, "{:?}", toy.ran);
            } else {
                assert!(r.contingencies.is_empty());
                assert_eq!(grasps, 1);
            }
        }
    }

    #[test]
    fn the_same_failure_three_times_gives_up_and_two_do_not() {
        let lib = Library::builtin();
        let k = lib.actions.len();
        let pp = lib.schema("pick_and_place").unwrap().clone();
        for (fails, goal) in [(2, true), (100, false)] {
            let mut toy = Toy {
                lib: lib.clone(),
                x: vec![false; k],
                drop_once: false,
                grasp_fails: fails,
                ran: vec![],
            };
            let r = execute(&lib, &pp, &mut toy, &mut LeftArm, 40).unwrap();
            let grasps = toy.ran.iter().filter(|a| a.starts_with("grasp")).count();
            assert_eq!(r.reached_goal, goal, "{:?}", toy.ran);
            // A reach converges between the failed grasps: no three alike in a row, yet the third
            // identical failure ends the run (40 actions would allow 20 grasps).
            assert_eq!(grasps, 3, "{:?}", toy.ran);
            if !goal {
                let last = r.steps.last().unwrap();
                assert_eq!(last.action, "grasp");
                assert!(matches!(&last.outcome, ActionOutcome::Failed(w) if w.cause == FailureCause::NoGrasp));
            }
        }
    }
}
