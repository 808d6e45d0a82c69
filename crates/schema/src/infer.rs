//! Schema inference (§4.2): which schema of the library explains a demonstration, through which
//! states, and — for a long demonstration — which successive schema instances it is made of.
//!
//! ## The HMM of a schema (4.20–4.21), with noisy monitors
//! The hidden state is the schema state; transitions follow the schema's graph T (4.20) with a
//! self-loop for the dwell time (`p_stay = 1 − 1/(dwell_secs · rate)`, the rest shared equally by the
//! successors). The seed's observation model (4.21) is a delta: x_t must equal the state's predicate
//! vector exactly, so one spurious or missed monitor convergence makes a demonstration impossible
//! under the right schema. We use an explicit per-component noise model instead:
//!
//! | the state says about action k | x_k,t−1 agreed with the state | x_k,t−1 did not (an error burst) |
//! |---|---|---|
//! | converged (`1`) | p(x_k,t = 0) = miss | p(x_k,t = 0) = persistence |
//! | not converged (`0`, and every action outside the schema) | p(x_k,t = 1) = false_alarm | p(x_k,t = 1) = persistence |
//! | either (`*`) | background: p(x_k,t = x_k,t−1) = 1 − q, a sticky chain on the observed value | same |
//!
//! Monitor errors come in bursts (a hand pausing near a bin for a few frames), so an error that
//! continues costs ln(persistence), not another ln(false_alarm): a two-frame blip is not twice as
//! damning as a one-frame blip. The delta model is the limit miss, false_alarm → 0. Components a
//! state does not constrain are scored by the same background process the "none" model uses for
//! everything, so likelihoods of schemas with different action sets stay comparable.
//!
//! ## Goals and repetition (the hierarchical extension of §4.3.3)
//! A schema explains a demonstration only if the demonstration *reaches its goal*: the teleological
//! reading of the seed. The model of schema S is S⁺: one or more instances of S separated by gaps
//! (gap states emit with the background process), ending in a goal of S or in a gap after one. A
//! demonstration that sorts five objects is thus explained by Pick-And-Place⁺ with five instances.
//! The alternative "none of these" is the gap process alone. Posterior over the library and none by
//! (4.10–4.12) with a uniform prior.
//!
//! ## Segmentation
//! One composite HMM holds every schema and the gap; its Viterbi path cuts the demonstration into
//! instances, each labelled by its schema and re-scored on its own window for a per-instance
//! posterior. The monitors that converged inside an instance are its procedural facts (§4.2): which
//! object, which place, which arm, and the object's features at the grasp.

use bayes::hmm::{Hmm, SharedModel, forward_shared_linear};
use bayes::special::log_sum_exp;
use serde::{Deserialize, Serialize};

use crate::error::SchemaError;
use crate::library::{ActionKind, Expect, Library};
use crate::monitor::Observation;
use crate::percept::{Percept, SegmentPercept};

/// Settings of inference.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct InferenceConfig {
    /// Observation rate (Hz), for the dwell-time self-loops.
    pub rate_hz: f64,
    /// Switching probability per step of the background process.
    pub background_switch: f64,
    /// Probability that a component is on at the first step under the background process.
    pub background_on: f64,
    /// Probability that a monitor error (miss or false alarm) continues into the next step.
    pub persistence: f64,
}

impl Default for InferenceConfig {
    fn default() -> Self {
        InferenceConfig {
            rate_hz: 10.0,
            background_switch: 0.02,
            background_on: 0.1,
            persistence: 0.4,
        }
    }
}

/// Which part of a composite model a hidden state belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Slot {
    /// Gap before any instance.
    GapBefore,
    /// Gap after an instance.
    GapAfter,
    /// State `state` of schema `schema`.
    State { schema: usize, state: usize },
}

/// A composite HMM: some schemas (repeatable) and the gaps.
#[derive(Debug, Clone)]
struct Composite {
    hmm: Hmm,
    /// The slot of each hidden state; every slot appears twice, as its entry step then its dwell.
    slots: Vec<Slot>,
    /// Final-state mask: goal states and the after-gap.
    accept: Vec<bool>,
    /// The shared emission column of each hidden state (see [`Column`]).
    columns: Vec<usize>,
}

/// One distinct emission distribution of the library: the gap (every action not converged), or a
/// schema state's expectations, on the state's first step (`entry`, errors fresh) or later.
/// Written as the gap's log-likelihood plus the terms of the actions the state expects converged
/// (or does not care about), so a step costs one term per such action instead of one per action.
#[derive(Debug, Clone)]
struct Column {
    /// First step in the slot (0) or a dwell step (1): which error terms apply.
    b: usize,
    /// (action, table column) of every action whose term differs from "not converged".
    deltas: Vec<(usize, usize)>,
}

/// The inference engine for one library (the models are built once).
#[derive(Debug, Clone)]
pub struct Engine {
    library: Library,
    config: InferenceConfig,
    /// S⁺ per schema.
    per_schema: Vec<Composite>,
    /// All schemas together, for segmentation.
    all: Composite,
    /// Per action.
    ln: Vec<Noise>,
    /// The distinct emission distributions shared by all composites (gap entry, gap dwell, then
    /// entry and dwell of each schema state in library order).
    columns: Vec<Column>,
    /// Per action and (x_t, x_{t−1}) pattern: the emission table row (see `table_row`).
    tables: Vec<[[f64; 5]; 6]>,
    /// Per action, pattern, table column and b: exp(table[col] − table[2 + b]).
    ratios: Vec<[[[f64; 2]; 5]; 6]>,
}

#[derive(Debug, Clone, Copy)]
struct Noise {
    on_conv: f64,
    off_conv: f64,
    on_not: f64,
    off_not: f64,
    err_again: f64,
    err_end: f64,
    stay: f64,
    switch: f64,
    first_on: f64,
    first_off: f64,
}

/// Log evidence and posterior of one hypothesis.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Hypothesis {
    /// Schema name, or `none`.
    pub schema: String,
    /// log p(x | H) (nats); `-inf` when H cannot explain x (serialised as null).
    pub log_evidence: Option<f64>,
    /// p(H | x) under a uniform prior.
    pub posterior: f64,
}

/// The posterior over the library and "none" (4.10–4.12).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Posterior {
    /// One entry per schema, then `none`, in library order.
    pub hypotheses: Vec<Hypothesis>,
    /// The MAP hypothesis (4.10).
    pub map: String,
    /// Its posterior probability.
    pub map_posterior: f64,
}

/// One visited state.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StateVisit {
    /// Schema (or `gap`).
    pub schema: String,
    /// State name (or `before`/`after` for gaps).
    pub state: String,
    /// Start time (s).
    pub t_start: f64,
    /// End time (s).
    pub t_end: f64,
}

/// A converged monitor's binding, with when it first and last converged in an instance.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Fact {
    /// Abstract action.
    pub action: String,
    /// Arm, segment, place it was bound to.
    pub arm: Option<String>,
    /// Segment id.
    pub segment: Option<u32>,
    /// Place.
    pub place: Option<String>,
    /// First and last time it was converged (s).
    pub first: f64,
    /// Last time.
    pub last: f64,
    /// Steps converged.
    pub steps: usize,
}

/// One schema instance found in a demonstration.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Instance {
    /// The schema.
    pub schema: String,
    /// Start and end (s).
    pub t_start: f64,
    /// End (s).
    pub t_end: f64,
    /// Posterior over the library on this instance's window.
    pub posterior: Posterior,
    /// The converged monitors inside the instance (procedural facts, §4.2).
    pub facts: Vec<Fact>,
    /// The object acted on: the segment the grasp (or touch, or reach) monitor converged on.
    pub object: Option<u32>,
    /// The place: the place where Place converged (else Reach-to-place).
    pub place: Option<String>,
    /// The arm that grasped (the first to, when the object passed from one hand to the other), else
    /// the one that touched or reached.
    pub arm: Option<String>,
    /// The object's features when the grasp (else the touch, else the reach) converged (its
    /// segment percept).
    pub features: Option<SegmentPercept>,
}

/// Everything inferred from one demonstration.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Inference {
    /// Posterior with the whole demonstration as S⁺ (one or more instances of one schema).
    pub posterior: Posterior,
    /// Viterbi state path of the MAP schema (empty if none).
    pub state_path: Vec<StateVisit>,
    /// The instances found by the composite model.
    pub instances: Vec<Instance>,
    /// Observation steps.
    pub steps: usize,
    /// Duration (s).
    pub duration: f64,
}

impl Engine {
    /// Builds the models of `library`.
    pub fn new(library: &Library, config: InferenceConfig) -> Result<Engine, SchemaError> {
        if !(config.rate_hz.is_finite() && config.rate_hz > 0.0) {
            return Err(SchemaError::invalid(
                "inference",
                "rate_hz",
                format!("must be positive, got {}", config.rate_hz),
            ));
        }
        let q = config.background_switch;
        let r = config.background_on;
        if !(q > 0.0 && q < 0.5 && r > 0.0 && r < 1.0 && config.persistence > 0.0 && config.persistence < 1.0) {
            return Err(SchemaError::invalid(
                "inference",
                "background",
                "probabilities out of range",
            ));
        }
        let ln: Vec<Noise> = (0..library.actions.len())
            .map(|a| {
                let (m, f) = library.noise(a);
                Noise {
                    on_conv: (1.0 - m).ln(),
                    off_conv: m.ln(),
                    on_not: f.ln(),
                    off_not: (1.0 - f).ln(),
                    err_again: config.persistence.ln(),
                    err_end: (1.0 - config.persistence).ln(),
                    stay: (1.0 - q).ln(),
                    switch: q.ln(),
                    first_on: r.ln(),
                    first_off: (1.0 - r).ln(),
                }
            })
            .collect();
        let p_stay = (1.0 - 1.0 / (library.dwell_secs * config.rate_hz)).clamp(0.5, 0.999);
        // Before and after a task the teacher may idle for long: gaps, start and terminal states
        // dwell ten times longer than the task's own states.
        let p_idle = (1.0 - 0.1 / (library.dwell_secs * config.rate_hz)).clamp(0.5, 0.9999);
        let per_schema = (0..library.schemas.len())
            .map(|s| composite(library, &[s], p_stay, p_idle))
            .collect::<Result<Vec<_>, _>>()?;
        let everything: Vec<usize> = (0..library.schemas.len()).collect();
        let all = composite(library, &everything, p_stay, p_idle)?;
        let mut columns = vec![
            Column {
                b: 0,
                deltas: Vec::new(),
            },
            Column {
                b: 1,
                deltas: Vec::new(),
            },
        ];
        for sc in &library.schemas {
            for state in 0..sc.states.len() {
                for b in 0..2 {
                    let deltas = (0..library.actions.len())
                        .filter_map(|a| match sc.expects(state, a) {
                            Expect::Converged => Some((a, b)),
                            Expect::Either => Some((a, 4)),
                            Expect::NotConverged => None,
                        })
                        .collect();
                    columns.push(Column { b, deltas });
                }
            }
        }
        let mut engine = Engine {
            library: library.clone(),
            config,
            per_schema,
            all,
            ln,
            columns,
            tables: Vec::new(),
            ratios: Vec::new(),
        };
        for a in 0..library.actions.len() {
            let mut table = [[0.0; 5]; 6];
            let mut ratio = [[[0.0; 2]; 5]; 6];
            for (p, prev) in [None, Some(false), Some(true)].into_iter().enumerate() {
                for x in [false, true] {
                    let k = 2 * p + usize::from(x);
                    table[k] = engine.table_row(a, x, prev);
                    for col in 0..5 {
                        for b in 0..2 {
                            ratio[k][col][b] = (table[k][col] - table[k][2 + b]).exp();
                        }
                    }
                }
            }
            engine.tables.push(table);
            engine.ratios.push(ratio);
        }
        Ok(engine)
    }

    /// The library.
    pub fn library(&self) -> &Library {
        &self.library
    }

    /// The emission table of action `a` for one (x_t, x_{t−1}) pattern: log p of the observed bit
    /// if the action is expected converged (fresh, in a burst), not converged (fresh, in a burst),
    /// or either (the background) — the emission model (4.19)–(4.21) with the monitors'
    /// miss/false-alarm and burst terms. "Fresh" applies on the first step of a state, where an
    /// error cannot continue one.
    fn table_row(&self, a: usize, x: bool, prev: Option<bool>) -> [f64; 5] {
        let ln = self.ln[a];
        let bg = match prev {
            None => {
                if x {
                    ln.first_on
                } else {
                    ln.first_off
                }
            }
            Some(p) if p == x => ln.stay,
            Some(_) => ln.switch,
        };
        let conv_fresh = if x { ln.on_conv } else { ln.off_conv };
        let not_fresh = if x { ln.on_not } else { ln.off_not };
        // In a burst: the previous step was in error too.
        let conv_burst = match (x, prev) {
            (true, Some(false)) => ln.err_end,
            (false, Some(false)) => ln.err_again,
            _ => conv_fresh,
        };
        let not_burst = match (x, prev) {
            (false, Some(true)) => ln.err_end,
            (true, Some(true)) => ln.err_again,
            _ => not_fresh,
        };
        [conv_fresh, conv_burst, not_fresh, not_burst, bg]
    }

    /// Index of the (x_t, x_{t−1}) pattern of action `a` at step `t` (0..6).
    fn pattern(obs: &[Observation], t: usize, a: usize) -> usize {
        let prev = if t == 0 { 0 } else { 1 + usize::from(obs[t - 1].x[a]) };
        2 * prev + usize::from(obs[t].x[a])
    }

    /// log p(x_t | column, x_{t−1}) for every shared emission column (T×width, row-major).
    fn shared_emissions(&self, obs: &[Observation]) -> Vec<f64> {
        let width = self.columns.len();
        let mut out = Vec::with_capacity(obs.len() * width);
        let mut pat = vec![0usize; self.library.actions.len()];
        for t in 0..obs.len() {
            // The gap (and "none"): every action not converged.
            let mut gap = [0.0, 0.0];
            for (a, p) in pat.iter_mut().enumerate() {
                *p = Self::pattern(obs, t, a);
                let row = &self.tables[a][*p];
                gap[0] += row[2];
                gap[1] += row[3];
            }
            out.extend(self.columns.iter().map(|c| {
                c.deltas.iter().fold(gap[c.b], |acc, &(a, col)| {
                    let row = &self.tables[a][pat[a]];
                    acc + (row[col] - row[2 + c.b])
                })
            }));
        }
        out
    }

    /// The shared emissions in linear form for the forward pass, without an `exp` per column:
    /// column value = exp(gap_b − m_t) · Π over its actions of the precomputed ratio
    /// exp(table[col] − table[not converged]); returns (T×width values, m_t per step, log p(x |
    /// none) = Σ_t gap at t).
    fn shared_linear(&self, obs: &[Observation]) -> (Vec<f64>, Vec<f64>, f64) {
        let width = self.columns.len();
        let mut out = vec![0.0; obs.len() * width];
        let mut scales = Vec::with_capacity(obs.len());
        let mut none = 0.0;
        let mut pat = vec![0usize; self.library.actions.len()];
        for (t, row_out) in out.chunks_exact_mut(width).enumerate() {
            let mut gap = [0.0f64, 0.0];
            for (a, p) in pat.iter_mut().enumerate() {
                *p = Self::pattern(obs, t, a);
                let row = &self.tables[a][*p];
                gap[0] += row[2];
                gap[1] += row[3];
            }
            none += gap[usize::from(t > 0)];
            let m = gap[0].max(gap[1]);
            let g = [(gap[0] - m).exp(), (gap[1] - m).exp()];
            let mut ok = true;
            for (o, c) in row_out.iter_mut().zip(&self.columns) {
                *o = c
                    .deltas
                    .iter()
                    .fold(g[c.b], |acc, &(a, col)| acc * self.ratios[a][pat[a]][col][c.b]);
                ok &= *o <= 1e250;
            }
            if !ok {
                // Very many expected convergences at once: take this row through logs.
                let logs: Vec<f64> = self
                    .columns
                    .iter()
                    .map(|c| {
                        c.deltas.iter().fold(gap[c.b], |acc, &(a, col)| {
                            let row = &self.tables[a][pat[a]];
                            acc + (row[col] - row[2 + c.b])
                        })
                    })
                    .collect();
                let top = logs.iter().copied().fold(f64::NEG_INFINITY, f64::max);
                for (o, l) in row_out.iter_mut().zip(&logs) {
                    *o = (l - top).exp();
                }
                scales.push(top);
            } else {
                scales.push(m);
            }
        }
        (out, scales, none)
    }

    /// log p(x_t | state, x_{t−1}) for every hidden state of `c` (T×n), from the shared columns.
    fn emissions(&self, c: &Composite, shared: &[f64], out: &mut Vec<f64>) {
        for row in shared.chunks_exact(self.columns.len()) {
            out.extend(c.columns.iter().map(|&col| row[col]));
        }
    }

    /// The posterior over the library and none for `obs` (each schema as S⁺).
    pub fn posterior(&self, obs: &[Observation]) -> Result<Posterior, SchemaError> {
        if obs.is_empty() {
            return Err(SchemaError::Empty("no observations".into()));
        }
        let k = self.library.actions.len();
        if let Some(o) = obs.iter().find(|o| o.x.len() != k) {
            return Err(SchemaError::invalid(
                "observations",
                format!("t={}", o.t),
                format!(
                    "observation vector has {} entries, the library has {k} actions",
                    o.x.len()
                ),
            ));
        }
        let mut names: Vec<String> = self.library.schemas.iter().map(|s| s.name.clone()).collect();
        names.push("none".into());
        // Every schema's S⁺ model scores the demonstration in one pass over shared emissions;
        // log p(x, final state accepted) = log p(x) + log Σ_{accepted j} p(z_T = j | x).
        let (shared, scales, none) = self.shared_linear(obs);
        let models: Vec<SharedModel<'_>> = self
            .per_schema
            .iter()
            .map(|c| SharedModel {
                hmm: &c.hmm,
                columns: &c.columns,
            })
            .collect();
        let forwards = forward_shared_linear(&models, &shared, &scales, self.columns.len())?;
        let mut logs = Vec::with_capacity(names.len());
        for (c, f) in self.per_schema.iter().zip(&forwards) {
            let acc: Vec<f64> = f
                .log_filtered
                .iter()
                .zip(&c.accept)
                .filter(|(_, a)| **a)
                .map(|(l, _)| *l)
                .collect();
            logs.push(f.log_likelihood + log_sum_exp(&acc));
        }
        // log p(x | none): nothing intended, every convergence a false alarm (the gap columns).
        logs.push(none);
        let z = log_sum_exp(&logs);
        let hypotheses: Vec<Hypothesis> = names
            .into_iter()
            .zip(&logs)
            .map(|(schema, &l)| Hypothesis {
                schema,
                log_evidence: l.is_finite().then_some(l),
                posterior: if l.is_finite() { (l - z).exp() } else { 0.0 },
            })
            .collect();
        let best = hypotheses
            .iter()
            .max_by(|a, b| a.posterior.total_cmp(&b.posterior))
            .expect("at least none");
        Ok(Posterior {
            map: best.schema.clone(),
            map_posterior: best.posterior,
            hypotheses: hypotheses.clone(),
        })
    }

    /// Viterbi path through composite `c`, ending in an accepted state. `None` if impossible.
    fn viterbi(&self, c: &Composite, obs: &[Observation]) -> Result<Option<Vec<Slot>>, SchemaError> {
        let n = c.slots.len();
        let mut e = Vec::with_capacity((obs.len() + 1) * n);
        self.emissions(c, &self.shared_emissions(obs), &mut e);
        // A virtual last step that only accepted states can emit: the path must end in one.
        e.extend(c.accept.iter().map(|&a| if a { 0.0 } else { f64::NEG_INFINITY }));
        Ok(c.hmm.viterbi(&e)?.map(|v| {
            let mut path: Vec<Slot> = v.path.iter().map(|&i| c.slots[i]).collect();
            path.pop();
            path
        }))
    }

    /// Full inference: posterior, the MAP schema's state path, and the instances.
    pub fn infer(&self, obs: &[Observation], percepts: &[Percept]) -> Result<Inference, SchemaError> {
        let posterior = self.posterior(obs)?;
        let mut state_path = Vec::new();
        if let Ok(s) = self.library.schema(&posterior.map) {
            let si = self
                .library
                .schemas
                .iter()
                .position(|x| x.name == s.name)
                .expect("found");
            if let Some(path) = self.viterbi(&self.per_schema[si], obs)? {
                state_path = self.visits(&path, obs);
            }
        }
        let instances = self.segment(obs, percepts)?;
        Ok(Inference {
            posterior,
            state_path,
            instances,
            steps: obs.len(),
            duration: obs.last().map_or(0.0, |o| o.t) - obs.first().map_or(0.0, |o| o.t),
        })
    }

    fn slot_names(&self, slot: Slot) -> (String, String) {
        match slot {
            Slot::GapBefore => ("gap".into(), "before".into()),
            Slot::GapAfter => ("gap".into(), "after".into()),
            Slot::State { schema, state } => {
                let s = &self.library.schemas[schema];
                (s.name.clone(), s.states[state].name.clone())
            }
        }
    }

    fn visits(&self, path: &[Slot], obs: &[Observation]) -> Vec<StateVisit> {
        let mut out: Vec<StateVisit> = Vec::new();
        for (t, slot) in path.iter().enumerate() {
            let (schema, state) = self.slot_names(*slot);
            match out.last_mut() {
                Some(v) if v.schema == schema && v.state == state => v.t_end = obs[t].t,
                _ => out.push(StateVisit {
                    schema,
                    state,
                    t_start: obs[t].t,
                    t_end: obs[t].t,
                }),
            }
        }
        out
    }

    /// The Viterbi state path of schema `name` (as S⁺) on `obs`; empty if it cannot explain them.
    pub fn state_path(&self, name: &str, obs: &[Observation]) -> Result<Vec<StateVisit>, SchemaError> {
        self.library.schema(name)?;
        let si = self.library.schemas.iter().position(|x| x.name == name).expect("found");
        Ok(self
            .viterbi(&self.per_schema[si], obs)?
            .map(|p| self.visits(&p, obs))
            .unwrap_or_default())
    }

    /// The state path of the composite model (every schema), as visits.
    pub fn composite_path(&self, obs: &[Observation]) -> Result<Vec<StateVisit>, SchemaError> {
        Ok(self
            .viterbi(&self.all, obs)?
            .map(|p| self.visits(&p, obs))
            .unwrap_or_default())
    }

    /// Cuts a demonstration into schema instances with the composite model's Viterbi path.
    pub fn segment(&self, obs: &[Observation], percepts: &[Percept]) -> Result<Vec<Instance>, SchemaError> {
        let Some(path) = self.viterbi(&self.all, obs)? else {
            return Ok(Vec::new());
        };
        // Runs of one schema that reach one of its goals.
        let mut runs: Vec<(usize, usize, usize, bool)> = Vec::new(); // (schema, start, end inclusive, goal shown)
        let mut t = 0;
        while t < path.len() {
            if let Slot::State { schema, .. } = path[t] {
                let start = t;
                let mut reached = false;
                let mut shown = false;
                while t < path.len() {
                    match path[t] {
                        Slot::State { schema: s, state } if s == schema => {
                            let sc = &self.library.schemas[s];
                            if sc.is_goal(state) {
                                reached = true;
                                shown |= self.goal_shown(s, state, &obs[t], shown);
                            }
                            // A new instance of the same schema begins at its start state after a
                            // goal the demonstration showed: a goal the path only passed through
                            // (the grip flickered while the object was lowered into its place, the
                            // hand never let go) does not end the act.
                            if t > start
                                && state == sc.start
                                && !matches!(path[t - 1], Slot::State { state: p, .. } if p == state)
                                && shown
                            {
                                break;
                            }
                            t += 1;
                        }
                        _ => break,
                    }
                }
                if reached {
                    runs.push((schema, start, t - 1, shown));
                }
            } else {
                t += 1;
            }
        }
        // A run whose goal the demonstration never showed, followed by a run of the same schema on
        // the same object, is one act the path cut in two (a grip that flickered while the object
        // was lowered into its place: the path left the schema for a step, the hand never let go).
        let mut merged: Vec<(usize, usize, usize, bool)> = Vec::with_capacity(runs.len());
        for run in runs {
            if let Some(prev) = merged.last_mut() {
                let object = |a: usize, b: usize| object_of(&self.library, &facts(&self.library, &obs[a..=b]));
                if prev.0 == run.0 && !prev.3 && object(prev.1, prev.2).is_some_and(|o| object(run.1, run.2) == Some(o))
                {
                    prev.2 = run.2;
                    prev.3 = run.3;
                    continue;
                }
            }
            merged.push(run);
        }
        let runs: Vec<(usize, usize, usize)> = merged.into_iter().map(|(s, a, b, _)| (s, a, b)).collect();
        let mut instances = Vec::new();
        for (i, &(schema, a, b)) in runs.iter().enumerate() {
            // Score the instance on its window, extended into the neighbouring gaps halfway.
            let lo = if i == 0 { 0 } else { (runs[i - 1].2 + 1 + a) / 2 };
            let hi = if i + 1 == runs.len() {
                obs.len() - 1
            } else {
                (b + runs[i + 1].1) / 2
            };
            let posterior = self.posterior(&obs[lo..=hi])?;
            let facts = facts(&self.library, &obs[a..=b]);
            let pick = |kind: ActionKind| {
                let name = self.library.action_name_of_kind(kind)?;
                facts.iter().filter(|f| f.action == name).max_by_key(|f| f.steps)
            };
            let grasp = pick(ActionKind::Grasp);
            let object = object_of(&self.library, &facts);
            // The arm that picked: of the hands that held the object for a third of the longest
            // grasp or more, the first to close on it (a pass hands it on to the other hand; a
            // brief grasp is a monitor's false alarm).
            let first_grasp = grasp.and_then(|g| {
                facts
                    .iter()
                    .filter(|f| f.action == g.action && f.segment == g.segment && 3 * f.steps >= g.steps)
                    .min_by(|a, b| a.first.total_cmp(&b.first))
            });
            let arm = first_grasp
                .or(pick(ActionKind::Touch))
                .or(pick(ActionKind::ReachObject))
                .and_then(|f| f.arm.clone());
            let place = pick(ActionKind::Place)
                .or(pick(ActionKind::ReachPlace))
                .and_then(|f| f.place.clone());
            // Features at the grasp (or the touch, or the reach, for a schema without a grasp): the
            // segment's percept when that monitor first converged — the last frame before in which
            // vision measured its extent (a hand touching or closing on it leaves only a coarse
            // silhouette guess: a touched can was "40 cm tall"), else the last frame it was seen.
            let features = grasp
                .or(pick(ActionKind::Touch))
                .or(pick(ActionKind::ReachObject))
                .and_then(|g| {
                    let seg = g.segment?;
                    let k = obs.iter().position(|o| o.t >= g.first)?;
                    let before = percepts.get(..=k.min(percepts.len().saturating_sub(1)))?;
                    let seen = || {
                        before
                            .iter()
                            .rev()
                            .filter_map(|p| p.segments.iter().find(|s| s.id == seg && s.seen))
                    };
                    seen()
                        .find(|s| s.extent.as_ref().is_some_and(|e| e.model != "coarse"))
                        .or_else(|| seen().next())
                        .cloned()
                });
            instances.push(Instance {
                schema: self.library.schemas[schema].name.clone(),
                t_start: obs[a].t,
                t_end: obs[b].t,
                posterior,
                facts,
                object,
                place,
                arm,
                features,
            });
        }
        Ok(instances)
    }

    /// Whether goal `state` of schema `s` is shown by observation `o`: every action the state
    /// expects converged has converged. A goal that expects none (`done`, after `released`) is
    /// shown only after a goal that was (`before`).
    fn goal_shown(&self, s: usize, state: usize, o: &Observation, before: bool) -> bool {
        let mut expects_any = false;
        for (a, &x) in o.x.iter().enumerate() {
            if self.library.schemas[s].expects(state, a) == Expect::Converged {
                expects_any = true;
                if !x {
                    return false;
                }
            }
        }
        expects_any || before
    }

    /// The configuration.
    pub fn config(&self) -> &InferenceConfig {
        &self.config
    }
}

/// Groups the converged monitors of `obs` by binding.
/// The object an instance acted on: the segment of its longest grasp, else touch, else reach.
fn object_of(library: &Library, facts: &[Fact]) -> Option<u32> {
    let pick = |kind: ActionKind| {
        let name = library.action_name_of_kind(kind)?;
        facts.iter().filter(|f| f.action == name).max_by_key(|f| f.steps)
    };
    pick(ActionKind::Grasp)
        .or(pick(ActionKind::Touch))
        .or(pick(ActionKind::ReachObject))
        .and_then(|f| f.segment)
}

fn facts(library: &Library, obs: &[Observation]) -> Vec<Fact> {
    let mut out: Vec<Fact> = Vec::new();
    for o in obs {
        for h in &o.hits {
            let action = &library.actions[h.action].name;
            match out
                .iter_mut()
                .find(|f| &f.action == action && f.arm == h.arm && f.segment == h.segment && f.place == h.place)
            {
                Some(f) => {
                    f.last = o.t;
                    f.steps += 1;
                }
                None => out.push(Fact {
                    action: action.clone(),
                    arm: h.arm.clone(),
                    segment: h.segment,
                    place: h.place.clone(),
                    first: o.t,
                    last: o.t,
                    steps: 1,
                }),
            }
        }
    }
    out
}

/// Builds the composite HMM of `schemas` (each repeatable) with the two gaps. Every slot has an
/// entry step and a dwell: a transition enters a slot at its entry step.
fn composite(library: &Library, schemas: &[usize], p_stay: f64, p_idle: f64) -> Result<Composite, SchemaError> {
    let mut base = vec![Slot::GapBefore, Slot::GapAfter];
    for &s in schemas {
        for state in 0..library.schemas[s].states.len() {
            base.push(Slot::State { schema: s, state });
        }
    }
    let nb = base.len();
    let index = |schema: usize, state: usize| {
        base.iter()
            .position(|x| *x == Slot::State { schema, state })
            .expect("slot exists")
    };
    // Successors and stay probability per base slot.
    let starts: Vec<usize> = schemas.iter().map(|&s| index(s, library.schemas[s].start)).collect();
    let mut succ: Vec<Vec<usize>> = vec![starts.clone(), starts.clone()];
    let mut stay = vec![p_idle, p_idle];
    for &s in schemas {
        let sc = &library.schemas[s];
        for state in 0..sc.states.len() {
            let mut out: Vec<usize> = sc.successors(state).map(|t| index(s, t.to)).collect();
            // The start and terminal states (no successors) are where a teacher idles.
            let terminal = out.is_empty();
            if sc.is_goal(state) {
                // After a goal the demonstration may go on: a gap, then another instance.
                out.push(1);
            }
            stay.push(if state == sc.start || terminal { p_idle } else { p_stay });
            succ.push(out);
        }
    }
    let n = 2 * nb;
    let mut trans = vec![0.0f64; n * n];
    for i in 0..nb {
        for from in [2 * i, 2 * i + 1] {
            if succ[i].is_empty() {
                trans[from * n + 2 * i + 1] = 1.0;
                continue;
            }
            trans[from * n + 2 * i + 1] = stay[i];
            for &j in &succ[i] {
                trans[from * n + 2 * j] += (1.0 - stay[i]) / succ[i].len() as f64;
            }
        }
    }
    let mut start = vec![0.0f64; n];
    start[0] = 0.5;
    for &st in &starts {
        start[2 * st] += 0.5 / starts.len() as f64;
    }
    let mut accept_base = vec![false; nb];
    accept_base[1] = true;
    for &s in schemas {
        for &g in &library.schemas[s].goal {
            accept_base[index(s, g)] = true;
        }
    }
    let hmm = Hmm::new(
        start.iter().map(|p| p.ln()).collect(),
        trans.iter().map(|p| p.ln()).collect(),
    )?;
    // Shared emission columns (Engine::columns): the gap's two, then two per schema state.
    let first_state: Vec<usize> = library
        .schemas
        .iter()
        .scan(0, |acc, sc| {
            let first = *acc;
            *acc += sc.states.len();
            Some(first)
        })
        .collect();
    let columns = base
        .iter()
        .flat_map(|slot| {
            let first = match *slot {
                Slot::GapBefore | Slot::GapAfter => 0,
                Slot::State { schema, state } => 2 + 2 * (first_state[schema] + state),
            };
            [first, first + 1]
        })
        .collect();
    Ok(Composite {
        hmm,
        slots: base.iter().flat_map(|&b| [b, b]).collect(),
        accept: accept_base.iter().flat_map(|&a| [a, a]).collect(),
        columns,
    })
}

/// A name read from a file: not empty, no control characters (they would corrupt tables, CSV and
/// terminals downstream).
fn check_name(path: &str, field: &str, name: &str) -> Result<(), SchemaError> {
    if name.is_empty() {
        return Err(SchemaError::invalid(path, field, "must not be empty"));
    }
    if let Some(c) = name.chars().find(|c| c.is_control()) {
        return Err(SchemaError::invalid(
            path,
            field,
            format!("{name:?} contains the control character U+{:04X}", u32::from(c)),
        ));
    }
    Ok(())
}

fn check_probability(path: &str, field: &str, p: f64) -> Result<(), SchemaError> {
    if !(p.is_finite() && (0.0..=1.0).contains(&p)) {
        return Err(SchemaError::invalid(
            path,
            field,
            format!("must be a probability in [0, 1], got {p}"),
        ));
    }
    Ok(())
}

fn check_interval(path: &str, field: &str, t_start: f64, t_end: f64) -> Result<(), SchemaError> {
    if !(t_start.is_finite() && t_end.is_finite()) {
        return Err(SchemaError::invalid(path, field, "times must be finite numbers"));
    }
    if t_start > t_end {
        return Err(SchemaError::invalid(
            path,
            field,
            format!("starts after it ends (t_start {t_start} > t_end {t_end})"),
        ));
    }
    Ok(())
}

impl Posterior {
    /// Checks a posterior read from a file: probabilities in [0, 1] summing to 1 (within 1e-6), the
    /// MAP one of the hypotheses with its probability, names without control characters. `path` and
    /// `field` name the place in the file for the message.
    pub fn check(&self, path: &str, field: &str) -> Result<(), SchemaError> {
        let mut sum = 0.0;
        for (i, h) in self.hypotheses.iter().enumerate() {
            let f = format!("{field}.hypotheses[{i}]");
            check_name(path, &format!("{f}.schema"), &h.schema)?;
            check_probability(path, &format!("{f}.posterior"), h.posterior)?;
            if h.log_evidence.is_some_and(|l| l.is_nan() || l == f64::INFINITY) {
                return Err(SchemaError::invalid(
                    path,
                    format!("{f}.log_evidence"),
                    "must be a finite log-likelihood or null",
                ));
            }
            sum += h.posterior;
        }
        if !self.hypotheses.is_empty() && (sum - 1.0).abs() > 1e-6 {
            return Err(SchemaError::invalid(
                path,
                format!("{field}.hypotheses"),
                format!("posteriors must sum to 1, they sum to {sum}"),
            ));
        }
        check_probability(path, &format!("{field}.map_posterior"), self.map_posterior)?;
        if !self.hypotheses.is_empty() {
            match self.hypotheses.iter().find(|h| h.schema == self.map) {
                None => {
                    return Err(SchemaError::invalid(
                        path,
                        format!("{field}.map"),
                        format!("`{}` is not one of the hypotheses", self.map),
                    ));
                }
                Some(h) if (h.posterior - self.map_posterior).abs() > 1e-9 => {
                    return Err(SchemaError::invalid(
                        path,
                        format!("{field}.map_posterior"),
                        format!(
                            "{} disagrees with the posterior of `{}` ({})",
                            self.map_posterior, self.map, h.posterior
                        ),
                    ));
                }
                Some(_) => {}
            }
        }
        Ok(())
    }
}

impl Inference {
    /// Checks an inference read from a file (`path` names it in messages): posteriors (see
    /// [`Posterior::check`]), time intervals in order, names without control characters, the object
    /// features well formed ([`check_segment`]).
    pub fn check(&self, path: &str) -> Result<(), SchemaError> {
        self.posterior.check(path, "inference.posterior")?;
        if !(self.duration.is_finite() && self.duration >= 0.0) {
            return Err(SchemaError::invalid(
                path,
                "inference.duration",
                format!("must be a non-negative number, got {}", self.duration),
            ));
        }
        for (i, v) in self.state_path.iter().enumerate() {
            let f = format!("inference.state_path[{i}]");
            check_name(path, &format!("{f}.schema"), &v.schema)?;
            check_name(path, &format!("{f}.state"), &v.state)?;
            check_interval(path, &f, v.t_start, v.t_end)?;
        }
        for (i, inst) in self.instances.iter().enumerate() {
            let f = format!("inference.instances[{i}]");
            check_name(path, &format!("{f}.schema"), &inst.schema)?;
            check_interval(path, &f, inst.t_start, inst.t_end)?;
            inst.posterior.check(path, &format!("{f}.posterior"))?;
            for (name, value) in [("place", &inst.place), ("arm", &inst.arm)] {
                if let Some(v) = value {
                    check_name(path, &format!("{f}.{name}"), v)?;
                }
            }
            for (j, fact) in inst.facts.iter().enumerate() {
                let ff = format!("{f}.facts[{j}]");
                check_name(path, &format!("{ff}.action"), &fact.action)?;
                check_interval(path, &ff, fact.first, fact.last)?;
            }
            if let Some(seg) = &inst.features {
                check_segment(seg, path, &format!("{f}.features"))?;
            }
        }
        Ok(())
    }
}

/// Checks a segment read from the file `path` (`field` names it): finite centroid and covariance,
/// histogram and colour terms well formed ([`crate::procedural::Features::validate_in`]), shares
/// summing to at most 1, a finite extent.
pub fn check_segment(seg: &SegmentPercept, path: &str, field: &str) -> Result<(), SchemaError> {
    if seg.centroid.iter().chain(&seg.covariance).any(|v| !v.is_finite()) {
        return Err(SchemaError::invalid(
            path,
            format!("{field}.centroid"),
            "centroid and covariance must be finite numbers",
        ));
    }
    crate::procedural::Features::from(seg).validate_in(path, &format!("{field}."))?;
    // The pipeline writes shares of the segment's pixels: each list sums to 1, up to the rounding
    // of each share to 6 decimals (half a millionth each: three shares written 0.327068, 0.240602,
    // 0.432331 sum to 1.000001).
    for (name, list) in [("histogram", &seg.histogram), ("colors", &seg.colors)] {
        let sum: f64 = list.iter().map(|c| c.1).sum();
        if sum > 1.0 + 5e-7 * list.len() as f64 + 1e-9 {
            return Err(SchemaError::invalid(
                path,
                format!("{field}.{name}"),
                format!("shares sum to {sum}; they are fractions of the segment's pixels (at most 1)"),
            ));
        }
    }
    if let Some(e) = &seg.extent {
        let v = [
            e.height,
            e.center[0],
            e.center[1],
            e.major_axis[0],
            e.major_axis[1],
            e.half_major,
            e.half_minor,
        ];
        if v.iter().any(|x| !x.is_finite()) || e.height < 0.0 || e.half_major < 0.0 || e.half_minor < 0.0 {
            return Err(SchemaError::invalid(
                path,
                format!("{field}.extent"),
                "must be finite, with non-negative height and half extents",
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::monitor::Hit;

    /// Shares as the pipeline writes them (each rounded to 6 decimals) may sum to a millionth over
    /// 1: `pbd learn` refused `pbd infer`'s own file (`sizes.infer.json`, untouched object 0: colours
    /// 0.327068 + 0.240602 + 0.432331). A share list that really exceeds 1 is still refused.
    #[test]
    fn shares_rounded_to_six_decimals_pass_and_shares_over_one_do_not() {
        let mut seg = SegmentPercept {
            id: 0,
            centroid: [0.5, 0.0, 0.8],
            seen: true,
            pixels: [120, 118],
            histogram: vec![(3, 0.5), (9, 0.5)],
            covariance: [4.0, 0.0, 0.0, 4.0],
            colors: vec![(1, 0.327068), (2, 0.240602), (3, 0.432331)],
            extent: None,
        };
        check_segment(&seg, "sizes.infer.json", "untouched[0].features").unwrap();
        seg.colors = vec![(1, 0.33), (2, 0.24), (3, 0.44)];
        let err = check_segment(&seg, "sizes.infer.json", "untouched[0].features").unwrap_err();
        assert!(err.to_string().contains("untouched[0].features.colors"), "{err}");
    }

    /// A noisy demonstration: Pick-And-Place-like runs of converged actions with false alarms and
    /// misses, long idle gaps (the gap-before state decays far below 1e-280 and is tracked).
    fn demonstration(lib: &Library, steps: usize, seed: u64) -> Vec<Observation> {
        let k = lib.actions.len();
        let mut r = seed;
        let mut next = move || {
            r ^= r << 13;
            r ^= r >> 7;
            r ^= r << 17;
            (r >> 11) as f64 / (1u64 << 53) as f64
        };
        (0..steps)
            .map(|t| {
                let phase = (t / 40) % (k + 2);
                let x = (0..k)
                    .map(|a| (a == phase || a + 1 == phase) ^ (next() < 0.03))
                    .collect();
                Observation {
                    t: t as f64 * 0.1,
                    x,
                    hits: vec![],
                }
            })
            .collect()
    }

    /// The batched linear pass gives every schema's evidence as the exact log-space filter on that
    /// schema's own emissions does (the pre-batching computation), and "none" as the gap sum.
    #[test]
    fn batched_evidence_equals_the_exact_filter_per_schema() {
        let lib = Library::builtin();
        let engine = Engine::new(&lib, InferenceConfig::default()).unwrap();
        for (steps, seed) in [(1, 3), (25, 5), (700, 7), (4000, 11)] {
            let obs = demonstration(&lib, steps, seed);
            let post = engine.posterior(&obs).unwrap();
            let shared = engine.shared_emissions(&obs);
            for (c, h) in engine.per_schema.iter().zip(&post.hypotheses) {
                let mut e = Vec::new();
                engine.emissions(c, &shared, &mut e);
                let mut f = bayes::hmm::ForwardFilter::new(&c.hmm);
                for row in e.chunks_exact(c.slots.len()) {
                    f.step(&c.hmm, row).unwrap();
                }
                let acc: Vec<f64> = f
                    .log_filtered()
                    .iter()
                    .zip(&c.accept)
                    .filter(|(_, a)| **a)
                    .map(|(l, _)| *l)
                    .collect();
                let want = f.log_likelihood() + log_sum_exp(&acc);
                match h.log_evidence {
                    Some(got) => assert!(
                        (got - want).abs() <= 1e-9 * want.abs().max(1.0),
                        "{} over {steps} steps: {got} vs {want}",
                        h.schema
                    ),
                    None => assert_eq!(want, f64::NEG_INFINITY, "{}", h.schema),
                }
            }
            let none: f64 = shared
                .chunks_exact(engine.columns.len())
                .enumerate()
                .map(|(t, row)| row[usize::from(t > 0)])
                .sum();
            let got = post.hypotheses.last().unwrap().log_evidence.unwrap();
            assert!((got - none).abs() <= 1e-9 * none.abs().max(1.0));
        }
    }
    /// A Pick-And-Place whose grip is lost while the object is lowered into its place (the path
    /// passes through `released` unshown and leaves the schema for a step), then closes again, then
    /// lets go: one instance, not two of the same object.
    #[test]
    fn a_grip_that_flickers_at_the_place_does_not_cut_the_act_in_two() {
        let lib = Library::builtin();
        let engine = Engine::new(&lib, InferenceConfig::default()).unwrap();
        let a = |name: &str| lib.actions.iter().position(|x| x.name == name).unwrap();
        let hit = |name: &str| Hit {
            action: a(name),
            arm: Some("right".into()),
            segment: ["reach_object", "grasp", "touch"].contains(&name).then_some(7),
            place: ["reach_place", "place"]
                .contains(&name)
                .then(|| "bin-right".to_string()),
        };
        // (seconds, converged actions) at the 10 Hz inference rate.
        // The converged actions of a recorded sorting demonstration (red_block into bin-right,
        // seed 3), by phase: the grip is lost for 3 s as the block meets the bin floor (the touch
        // stays), then closes again, then the hand lets go.
        let phases: [(f64, &[&str]); 22] = [
            (3.0, &[]),
            (0.3, &["reach_object"]),
            (0.1, &["reach_object", "touch"]),
            (5.4, &["grasp"]),
            (9.9, &["grasp", "hold"]),
            (1.2, &["grasp"]),
            (0.1, &["grasp", "place"]),
            (0.7, &["grasp"]),
            (1.0, &["grasp", "hold", "reach_place"]),
            (1.0, &["grasp"]),
            (0.1, &["grasp", "place"]),
            (4.4, &["grasp", "reach_place", "place"]),
            (0.1, &["reach_place", "touch"]),
            (3.0, &["reach_object", "reach_place", "touch"]),
            (4.5, &["grasp", "reach_place"]),
            (0.1, &["reach_place", "release", "touch"]),
            (2.5, &["reach_object", "reach_place", "release", "touch"]),
            (0.2, &["release", "touch"]),
            (1.0, &["release"]),
            (1.0, &["reach_place", "release"]),
            (0.7, &["release"]),
            (3.0, &[]),
        ];
        let mut obs = Vec::new();
        for (secs, on) in phases {
            for _ in 0..(secs * 10.0).round() as usize {
                let mut x = vec![false; lib.actions.len()];
                for n in on {
                    x[a(n)] = true;
                }
                obs.push(Observation {
                    t: obs.len() as f64 * 0.1,
                    x,
                    hits: on.iter().map(|n| hit(n)).collect(),
                });
            }
        }
        let got = engine.segment(&obs, &[]).unwrap();
        let summary: Vec<(String, Option<u32>, f64, f64)> = got
            .iter()
            .map(|i| (i.schema.clone(), i.object, i.t_start, i.t_end))
            .collect();
        assert_eq!(got.len(), 1, "{summary:?}");
        assert_eq!(got[0].schema, "pick_and_place");
        assert_eq!(got[0].object, Some(7));
        assert_eq!(got[0].place.as_deref(), Some("bin-right"));
        assert!(got[0].t_end > 36.0, "{summary:?}");
    }
}
