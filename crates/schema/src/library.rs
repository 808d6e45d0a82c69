//! The schema library as data: abstract actions d(C) (3.22) and schemas (Def. 3.3) with their state
//! spaces of predicate vectors, goal states, transition graphs T and policies π.
//!
//! Format: `assets/schemas/README.md`. The built-in library is `assets/schemas/library.toml`.

use serde::{Deserialize, Serialize};

use crate::error::SchemaError;

/// The built-in library's TOML text.
pub const BUILTIN_LIBRARY: &str = include_str!("../../../assets/schemas/library.toml");

/// The library format version this crate reads.
pub const LIBRARY_VERSION: u32 = 1;

/// An abstract action: the declarative type d(C) = (φ, F_f, F_τ) of a controller (3.22). Every
/// controller of the control basis with the same type belongs to its monitor set (4.15).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Action {
    /// Unique name; also the monitor-set name in observation vectors.
    pub name: String,
    /// The potential φ: `quadratic`, `force_residual` (an opposing grasp) or `contact` (a
    /// fingertip touching, no opposing force required).
    pub potential: String,
    /// The coordinate frame of the feedback element F_f (e.g. `segment_centroid`, `place_region`).
    pub feedback: String,
    /// The coordinate frame of the effector F_τ (`head`, `arm`, `hand`).
    pub effector: String,
    /// What it means.
    #[serde(default)]
    pub description: String,
    /// This monitor set's miss probability, if it differs from the library's.
    #[serde(default)]
    pub miss: Option<f64>,
    /// This monitor set's false-alarm probability, if it differs from the library's.
    #[serde(default)]
    pub false_alarm: Option<f64>,
}

/// The kinds of abstract action pbd monitors and runs, told apart by their signature d(C) =
/// (potential, feedback frame, effector frame) (3.22) — never by their names: a library may call
/// its actions anything.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ActionKind {
    /// Search-Track: a segment foveated by the head (`segment_image`, `head`).
    SearchTrack,
    /// Reach to a segment (`segment_centroid`, `arm`).
    ReachObject,
    /// Grasp: opposing fingertip contacts (`force_residual`, `fingertip_contacts`, `hand`).
    Grasp,
    /// Hold: the grasped object lifted (`grasped_height`, `arm`).
    Hold,
    /// Reach to a place (`place_region`, `arm`).
    ReachPlace,
    /// Place: the support takes the load (`net_force`, `arm`).
    Place,
    /// Release: the hand opens (`finger_flexion`, `hand`).
    Release,
    /// Touch: fingertip contact without an opposing grasp (`contact`, `fingertip_contacts`,
    /// `hand`).
    Touch,
}

impl ActionKind {
    /// Every kind.
    pub const ALL: [ActionKind; 8] = [
        ActionKind::SearchTrack,
        ActionKind::ReachObject,
        ActionKind::Grasp,
        ActionKind::Hold,
        ActionKind::ReachPlace,
        ActionKind::Place,
        ActionKind::Release,
        ActionKind::Touch,
    ];

    /// The signature (potential, feedback frame, effector frame) of this kind.
    pub fn signature(self) -> (&'static str, &'static str, &'static str) {
        match self {
            ActionKind::SearchTrack => ("quadratic", "segment_image", "head"),
            ActionKind::ReachObject => ("quadratic", "segment_centroid", "arm"),
            ActionKind::Grasp => ("force_residual", "fingertip_contacts", "hand"),
            ActionKind::Hold => ("quadratic", "grasped_height", "arm"),
            ActionKind::ReachPlace => ("quadratic", "place_region", "arm"),
            ActionKind::Place => ("quadratic", "net_force", "arm"),
            ActionKind::Release => ("quadratic", "finger_flexion", "hand"),
            ActionKind::Touch => ("contact", "fingertip_contacts", "hand"),
        }
    }

    /// The kind of `action`, by its signature; `None` for a signature pbd does not know.
    pub fn of(action: &Action) -> Option<ActionKind> {
        let sig = (
            action.potential.as_str(),
            action.feedback.as_str(),
            action.effector.as_str(),
        );
        ActionKind::ALL.into_iter().find(|k| k.signature() == sig)
    }
}

/// What a state says about one of its schema's abstract actions.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Expect {
    /// `1`: the action's monitor set has converged.
    Converged,
    /// `0`: it has not.
    NotConverged,
    /// `*`: either; this state does not depend on it.
    Either,
}

/// One state of a schema: a named predicate vector over the schema's actions.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct State {
    /// Name (unique in the schema).
    pub name: String,
    /// Expected convergence per action of the schema, in the order of [`Schema::actions`].
    pub z: Vec<Expect>,
}

/// An edge of the state graph.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Transition {
    /// From state (index into [`Schema::states`]).
    pub from: usize,
    /// To state.
    pub to: usize,
    /// `Some(label)` for a contingency (drop, regrasp, transfer).
    pub contingency: Option<String>,
}

/// A sensorimotor schema (Def. 3.3) without its procedural policy ψ, which is bound at run time.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Schema {
    /// Unique name.
    pub name: String,
    /// What it is for.
    pub description: String,
    /// Its abstract actions, as indices into [`Library::actions`].
    pub actions: Vec<usize>,
    /// The state space Z.
    pub states: Vec<State>,
    /// The start state.
    pub start: usize,
    /// The goal states G ⊂ Z.
    pub goal: Vec<usize>,
    /// The transition graph T (self-loops are implicit).
    pub transitions: Vec<Transition>,
    /// π: the action to run in each state (index into [`Library::actions`]).
    pub policy: Vec<usize>,
}

impl Schema {
    /// The state with this name.
    pub fn state(&self, name: &str) -> Option<usize> {
        self.states.iter().position(|s| s.name == name)
    }

    /// Whether `state` is a goal state.
    pub fn is_goal(&self, state: usize) -> bool {
        self.goal.contains(&state)
    }

    /// What state `state` expects of library action `action` (`NotConverged` for actions outside the
    /// schema: their convergence is not explained by this schema).
    pub fn expects(&self, state: usize, action: usize) -> Expect {
        match self.actions.iter().position(|&a| a == action) {
            Some(k) => self.states[state].z[k],
            None => Expect::NotConverged,
        }
    }

    /// Successors of `state` in T (without the implicit self-loop).
    pub fn successors(&self, state: usize) -> impl Iterator<Item = &Transition> {
        self.transitions.iter().filter(move |t| t.from == state)
    }
}

/// A schema library: the robot's universe of schemas 𝒮 and the abstract actions they use.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Library {
    /// Where it was loaded from (a path, or `<builtin>`).
    pub origin: String,
    /// p(x_k = 0 | the state says converged).
    pub miss: f64,
    /// p(x_k = 1 | the state says not converged).
    pub false_alarm: f64,
    /// Mean dwell time per state (s).
    pub dwell_secs: f64,
    /// Abstract actions; their order is the order of the observation vector x_t (4.19).
    pub actions: Vec<Action>,
    /// Schemas.
    pub schemas: Vec<Schema>,
    /// The library's task (optional `task` field): the schema the pick-and-place experiments run
    /// and the one a procedural model without a `schema` field was learned from.
    #[serde(default)]
    pub task: Option<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawLibrary {
    version: u32,
    miss: f64,
    false_alarm: f64,
    dwell_secs: f64,
    #[serde(default)]
    task: Option<String>,
    #[serde(default)]
    action: Vec<Action>,
    #[serde(default)]
    schema: Vec<RawSchema>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSchema {
    name: String,
    #[serde(default)]
    description: String,
    actions: Vec<String>,
    start: String,
    goal: Vec<String>,
    states: Vec<RawState>,
    #[serde(default)]
    transitions: Vec<RawTransition>,
    policy: std::collections::BTreeMap<String, String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawState {
    name: String,
    z: String,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawTransition {
    from: String,
    to: String,
    contingency: Option<String>,
}

impl Library {
    /// The built-in library (`assets/schemas/library.toml`).
    pub fn builtin() -> Library {
        Library::parse(BUILTIN_LIBRARY, "<builtin>").expect("the built-in schema library is valid")
    }

    /// Reads a library file.
    pub fn open(path: impl AsRef<std::path::Path>) -> Result<Library, SchemaError> {
        let path = path.as_ref();
        let text = bayes::input::read_text(path).map_err(|source| SchemaError::Io {
            path: path.display().to_string(),
            source,
        })?;
        Library::parse(&text, &path.display().to_string())
    }

    /// Parses and validates a library; `origin` names it in errors.
    pub fn parse(text: &str, origin: &str) -> Result<Library, SchemaError> {
        let raw: RawLibrary = toml::from_str(text).map_err(|e| SchemaError::Parse {
            path: origin.to_string(),
            message: e.to_string(),
        })?;
        let inv = |field: String, msg: String| SchemaError::invalid(origin, field, msg);
        if raw.version != LIBRARY_VERSION {
            return Err(inv(
                "version".into(),
                format!(
                    "library format version {} is not supported (this build reads {LIBRARY_VERSION})",
                    raw.version
                ),
            ));
        }
        for (field, v, lo, hi) in [("miss", raw.miss, 0.0, 0.5), ("false_alarm", raw.false_alarm, 0.0, 0.5)] {
            if !(v > lo && v < hi) {
                return Err(inv(field.into(), format!("must be in ({lo}, {hi}), got {v}")));
            }
        }
        if !(raw.dwell_secs.is_finite() && raw.dwell_secs > 0.0) {
            return Err(inv(
                "dwell_secs".into(),
                format!("must be positive, got {}", raw.dwell_secs),
            ));
        }
        if raw.action.is_empty() {
            return Err(inv("action".into(), "the library declares no abstract actions".into()));
        }
        for (i, a) in raw.action.iter().enumerate() {
            if a.name.is_empty() {
                return Err(inv(format!("action[{i}].name"), "empty name".into()));
            }
            if raw.action[..i].iter().any(|b| b.name == a.name) {
                return Err(inv(
                    format!("action[{i}].name"),
                    format!("duplicate action `{}`", a.name),
                ));
            }
            for (field, v) in [("miss", a.miss), ("false_alarm", a.false_alarm)] {
                if let Some(v) = v
                    && !(v > 0.0 && v < 0.5)
                {
                    return Err(inv(
                        format!("action[{i}].{field}"),
                        format!("must be in (0, 0.5), got {v}"),
                    ));
                }
            }
            if !matches!(a.potential.as_str(), "quadratic" | "force_residual" | "contact") {
                return Err(inv(
                    format!("action[{i}].potential"),
                    format!(
                        "unknown potential `{}` (quadratic, force_residual, contact)",
                        a.potential
                    ),
                ));
            }
        }
        if raw.schema.is_empty() {
            return Err(inv("schema".into(), "the library declares no schemas".into()));
        }
        let action_index = |name: &str, field: String| {
            raw.action
                .iter()
                .position(|a| a.name == name)
                .ok_or_else(|| inv(field, format!("unknown action `{name}`")))
        };
        let mut schemas = Vec::new();
        for (si, rs) in raw.schema.iter().enumerate() {
            let f = |rest: &str| format!("schema[{si}].{rest}");
            if schemas.iter().any(|s: &Schema| s.name == rs.name) {
                return Err(inv(f("name"), format!("duplicate schema `{}`", rs.name)));
            }
            let mut actions = Vec::new();
            for (k, a) in rs.actions.iter().enumerate() {
                let idx = action_index(a, f(&format!("actions[{k}]")))?;
                if actions.contains(&idx) {
                    return Err(inv(f(&format!("actions[{k}]")), format!("action `{a}` listed twice")));
                }
                actions.push(idx);
            }
            if actions.is_empty() {
                return Err(inv(f("actions"), "a schema needs at least one action".into()));
            }
            let mut states: Vec<State> = Vec::new();
            for (k, st) in rs.states.iter().enumerate() {
                if states.iter().any(|s| s.name == st.name) {
                    return Err(inv(
                        f(&format!("states[{k}].name")),
                        format!("duplicate state `{}`", st.name),
                    ));
                }
                let z: Result<Vec<Expect>, SchemaError> =
                    st.z.chars()
                        .map(|c| match c {
                            '1' => Ok(Expect::Converged),
                            '0' => Ok(Expect::NotConverged),
                            '*' => Ok(Expect::Either),
                            other => Err(inv(
                                f(&format!("states[{k}].z")),
                                format!("`{other}` is not one of 1, 0, *"),
                            )),
                        })
                        .collect();
                let z = z?;
                if z.len() != actions.len() {
                    return Err(inv(
                        f(&format!("states[{k}].z")),
                        format!("has {} entries but the schema has {} actions", z.len(), actions.len()),
                    ));
                }
                states.push(State {
                    name: st.name.clone(),
                    z,
                });
            }
            if states.is_empty() {
                return Err(inv(f("states"), "a schema needs states".into()));
            }
            let state_index = |name: &str, field: String| {
                states
                    .iter()
                    .position(|s| s.name == name)
                    .ok_or_else(|| inv(field, format!("unknown state `{name}`")))
            };
            let start = state_index(&rs.start, f("start"))?;
            let mut goal = Vec::new();
            for (k, g) in rs.goal.iter().enumerate() {
                goal.push(state_index(g, f(&format!("goal[{k}]")))?);
            }
            if goal.is_empty() {
                return Err(inv(f("goal"), "a schema needs at least one goal state".into()));
            }
            if goal.contains(&start) {
                return Err(inv(f("goal"), "the start state cannot be a goal".into()));
            }
            let mut transitions = Vec::new();
            for (k, t) in rs.transitions.iter().enumerate() {
                let from = state_index(&t.from, f(&format!("transitions[{k}].from")))?;
                let to = state_index(&t.to, f(&format!("transitions[{k}].to")))?;
                if from == to {
                    return Err(inv(f(&format!("transitions[{k}]")), "self-loops are implicit".into()));
                }
                transitions.push(Transition {
                    from,
                    to,
                    contingency: t.contingency.clone(),
                });
            }
            let mut policy = vec![usize::MAX; states.len()];
            for (sname, aname) in &rs.policy {
                let s = state_index(sname, f(&format!("policy.{sname}")))?;
                policy[s] = action_index(aname, f(&format!("policy.{sname}")))?;
            }
            if let Some(k) = policy.iter().position(|&p| p == usize::MAX) {
                return Err(inv(f("policy"), format!("no action for state `{}`", states[k].name)));
            }
            // Every goal must be reachable from the start.
            let mut seen = vec![false; states.len()];
            let mut stack = vec![start];
            while let Some(s) = stack.pop() {
                if std::mem::replace(&mut seen[s], true) {
                    continue;
                }
                stack.extend(transitions.iter().filter(|t| t.from == s).map(|t| t.to));
            }
            if let Some(&g) = goal.iter().find(|&&g| !seen[g]) {
                return Err(inv(
                    f("goal"),
                    format!("goal `{}` is unreachable from the start", states[g].name),
                ));
            }
            schemas.push(Schema {
                name: rs.name.clone(),
                description: rs.description.clone(),
                actions,
                states,
                start,
                goal,
                transitions,
                policy,
            });
        }
        if let Some(task) = &raw.task
            && !schemas.iter().any(|s| &s.name == task)
        {
            return Err(inv(
                "task".into(),
                format!(
                    "`{task}` is not a schema of this library (it has {})",
                    schemas
                        .iter()
                        .map(|s| format!("`{}`", s.name))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            ));
        }
        Ok(Library {
            origin: origin.to_string(),
            miss: raw.miss,
            false_alarm: raw.false_alarm,
            dwell_secs: raw.dwell_secs,
            actions: raw.action,
            schemas,
            task: raw.task,
        })
    }

    /// The library's task ([`Library::task`]): its schema, or an error naming the field when the
    /// library declares none.
    pub fn task_schema(&self) -> Result<&Schema, SchemaError> {
        let name = self.task.as_deref().ok_or_else(|| {
            SchemaError::invalid(
                &self.origin,
                "task",
                "the library names no task (add `task = \"SCHEMA\"`)".to_string(),
            )
        })?;
        self.schema(name)
    }

    /// The index of the first action of `kind` (by signature, [`ActionKind::of`]).
    pub fn action_of_kind(&self, kind: ActionKind) -> Option<usize> {
        self.actions.iter().position(|a| ActionKind::of(a) == Some(kind))
    }

    /// The name of the first action of `kind`.
    pub fn action_name_of_kind(&self, kind: ActionKind) -> Option<&str> {
        self.action_of_kind(kind).map(|i| self.actions[i].name.as_str())
    }

    /// The index of the action with this name.
    pub fn action(&self, name: &str) -> Result<usize, SchemaError> {
        self.actions
            .iter()
            .position(|a| a.name == name)
            .ok_or_else(|| SchemaError::unknown("action", name, self.actions.iter().map(|a| a.name.as_str())))
    }

    /// The schema with this name.
    pub fn schema(&self, name: &str) -> Result<&Schema, SchemaError> {
        self.schemas
            .iter()
            .find(|s| s.name == name)
            .ok_or_else(|| SchemaError::unknown("schema", name, self.schemas.iter().map(|s| s.name.as_str())))
    }

    /// (miss, false alarm) of action `a`'s monitor set.
    pub fn noise(&self, a: usize) -> (f64, f64) {
        let act = &self.actions[a];
        (
            act.miss.unwrap_or(self.miss),
            act.false_alarm.unwrap_or(self.false_alarm),
        )
    }

    /// Names of the actions, in observation-vector order.
    pub fn action_names(&self) -> Vec<&str> {
        self.actions.iter().map(|a| a.name.as_str()).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builtin_library_loads() {
        let lib = Library::builtin();
        assert!(lib.schemas.len() >= 6);
        let pp = lib.schema("pick_and_place").unwrap();
        assert_eq!(lib.task_schema().unwrap().name, "pick_and_place");
        assert!(
            pp.transitions
                .iter()
                .any(|t| t.contingency.as_deref() == Some("transfer"))
        );
        assert!(
            pp.transitions
                .iter()
                .any(|t| t.contingency.as_deref() == Some("regrasp"))
        );
    }

    #[test]
    fn bad_libraries_name_the_field() {
        let good = BUILTIN_LIBRARY;
        for (from, to, needle) in [
            ("version = 1", "version = 7", "version"),
            ("miss = 0.02", "miss = 1.5", "miss"),
            ("z = \"*100000\"", "z = \"*10000\"", "states[1].z"),
            ("z = \"*100000\"", "z = \"*1x0000\"", "states[1].z"),
            ("goal = [\"released\", \"done\"]", "goal = [\"nowhere\"]", "goal[0]"),
            ("to = \"at_object\" }", "to = \"nowhere\" }", "transitions"),
            ("task = \"pick_and_place\"", "task = \"pick_and_plaice\"", "task"),
        ] {
            let text = good.replacen(from, to, 1);
            assert_ne!(text, good, "{from}");
            let err = Library::parse(&text, "lib.toml").unwrap_err().to_string();
            assert!(err.contains("lib.toml") && err.contains(needle), "{err}");
        }
        assert!(
            Library::parse("not toml [", "x.toml")
                .unwrap_err()
                .to_string()
                .contains("x.toml")
        );
    }
}
