//! One scene of the fault experiment: a random presentation and place ([`fault_scene`]), the robot
//! putting the object in its place with the fault armed ([`fault_trial`], through the executor
//! [`crate::execute::execute_scene_with_fault`]), and the evaluator's judgement ([`FaultTrial`]).

use serde::{Deserialize, Serialize};

use super::model::{FaultKind, FaultSpec};
use crate::error::SimError;
use crate::execute::Verdict;
use crate::scene::Scene;
use bayes::rng::Draw;

/// One scene of the fault experiment: what was injected, whether it fired, what the robot did and
/// how it ended.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct FaultTrial {
    /// The fault kind.
    pub kind: FaultKind,
    /// Scene index (within the kind).
    pub scene: usize,
    /// The object (presentation) and where it started (x, y).
    pub object: String,
    /// Where it started (m, world).
    pub start: [f64; 2],
    /// The place it was to go to.
    pub place: String,
    /// The fault fired.
    pub fired: bool,
    /// When (s, simulated).
    pub fired_at: Option<f64>,
    /// What the fault did (the world's account).
    pub fault: String,
    /// The object ended at rest in its place (the evaluator's judgement by the truth).
    pub success: bool,
    /// The fault fired and the object still ended in its place.
    pub recovered: bool,
    /// What the executive did: `re_grasp`, `other_arm`, `hand_over`, `none` (carried on), or
    /// `gave_up`.
    pub response: String,
    /// Contingencies and ψ's rebindings, in order.
    pub contingencies: Vec<String>,
    /// Arms used, in order.
    pub arms: Vec<String>,
    /// Actions run by the executive.
    pub actions: usize,
    /// Why it failed (phase: reason), when it did.
    pub reason: String,
    /// Simulated time (s).
    pub sim_time: f64,
}

/// Scene `i` of the fault experiment for `kind`: one presentation of `base`'s catalog at a random
/// pose in the band both arms reach (x 0.50–0.68 m, |y| ≤ 0.12 m), and a random place of `base`
/// for it. A pure function of (`base`, `kind`, `seed`, `i`).
pub fn fault_scene(base: &Scene, kind: FaultKind, seed: u64, i: usize) -> Result<(Scene, String), SimError> {
    let k = FaultKind::ALL.iter().position(|&x| x == kind).unwrap_or(0) as u64;
    let mut rng = bayes::rng::stream(seed ^ (0xFA17 + k), i as u64);
    let names: Vec<String> = base
        .catalog
        .presentation_names()
        .iter()
        .map(|s| s.to_string())
        .collect();
    if names.is_empty() || base.spec.places.is_empty() {
        return Err(SimError::Invalid {
            path: base.path.clone(),
            field: "objects".into(),
            message: "the fault experiment needs a catalog with presentations and a scene with places".into(),
        });
    }
    let name = names[(rng.uniform() * names.len() as f64) as usize % names.len()].clone();
    let x = 0.50 + 0.18 * rng.uniform();
    let y = -0.12 + 0.24 * rng.uniform();
    let yaw = 360.0 * rng.uniform();
    let place = base.spec.places[(rng.uniform() * base.spec.places.len() as f64) as usize % base.spec.places.len()]
        .name
        .clone();
    let scene = base.with_objects(vec![crate::scene::ObjectPlacement {
        presentation: name,
        xy: [x, y],
        yaw_deg: yaw,
        z: None,
    }])?;
    Ok((scene, place))
}

/// Runs scene `i` of `kind`: the robot puts the object in its place (a demonstration's place, so
/// the decision is not under test) with the fault armed; the evaluator judges by the truth.
pub fn fault_trial(
    base: &Scene,
    base_name: &str,
    library: &schema::Library,
    kind: FaultKind,
    seed: u64,
    i: usize,
) -> Result<FaultTrial, SimError> {
    let (scene, place) = fault_scene(base, kind, seed, i)?;
    let k = FaultKind::ALL.iter().position(|&x| x == kind).unwrap_or(0) as u64;
    let mut seeds = bayes::rng::stream(seed ^ (0x5EED_FA17 + k), i as u64);
    let run_seed = rand::Rng::next_u64(&mut seeds);
    let spec = FaultSpec::new(kind, 0, rand::Rng::next_u64(&mut seeds));
    let task = crate::execute::Task {
        library,
        schema: &library.task_schema()?.name,
        decider: crate::execute::Decider::Place(place.clone()),
        only_near: None,
        max_actions: crate::execute::MAX_ACTIONS,
    };
    let report = crate::execute::execute_scene_with_fault(
        &scene,
        &format!("{base_name}#{kind}-{i}"),
        &task,
        run_seed,
        Some(&spec),
        &mut crate::execute::NoLog,
    )?;
    let record = report.fault.clone().unwrap_or_default();
    // The faulted object's report (the robot may also have acted on a segment that is no object).
    let label = scene.resolved.get(spec.object).map(|r| r.label.as_str());
    let o = report
        .objects
        .iter()
        .find(|o| o.decision == Verdict::Execute && Some(o.object.as_str()) == label)
        .or_else(|| report.objects.iter().find(|o| o.decision == Verdict::Execute))
        .or(report.objects.first());
    let success = o.is_some_and(|o| o.success);
    let contingencies = o.map(|o| o.contingencies.clone()).unwrap_or_default();
    let steps = o
        .and_then(|o| o.execution.as_ref())
        .map(|e| e.steps.as_slice())
        .unwrap_or(&[]);
    let runs = |a: &str| steps.iter().filter(|s| s.action == a).count();
    let has = |c: &str| contingencies.iter().any(|x| x == c);
    let response = if !success {
        "gave_up"
    } else if has("hand_over") || has("transfer") {
        "hand_over"
    } else if has("other_arm") {
        "other_arm"
    } else if has("regrasp") || runs("grasp") > 1 || runs("reach_object") > 1 {
        "re_grasp"
    } else {
        "none"
    };
    let reason = if success {
        String::new()
    } else {
        o.map(|o| match (&o.failure, o.decision) {
            (Some(f), _) => f.clone(),
            (None, Verdict::Execute) => "outcome: not in its place".into(),
            (None, d) => format!("{d}: {}", o.reason),
        })
        .unwrap_or_else(|| "perception: the object was not seen".into())
    };
    let start = scene.spec.objects[0].xy;
    Ok(FaultTrial {
        kind,
        scene: i,
        object: scene.spec.objects[0].presentation.clone(),
        start,
        place,
        fired: record.fired,
        fired_at: record.fired_at,
        fault: record.detail,
        success,
        recovered: record.fired && success,
        response: response.into(),
        contingencies,
        arms: o.map(|o| o.arms.clone()).unwrap_or_default(),
        actions: steps.len(),
        reason,
        sim_time: report.sim_time,
    })
}
