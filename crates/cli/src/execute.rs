//! `pbd execute`: the robot does a demonstrated task in a new context (§4.3.2).
//!
//! The declarative part — which schema — comes from an inference (`--demo demo.infer.json`, its MAP
//! schema and the places its instances used) or from a learned procedural model (`--model
//! model.json`, which also decides, per object, whether it belongs to the task and which place it
//! goes to). The procedural part is bound now, in the new scene: ψ picks the arm whose workspace holds
//! the object and the place, or a hand-to-hand transfer; the executive follows the schema's policy
//! and takes its contingencies (re-grasp after a drop). Reports per object: the decision, the arm(s),
//! transfer or not, contingencies, the outcome; and an MCAP log.

use std::collections::BTreeMap;
use std::io::Write;
use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::Args;
use dexter_sim::exec::{ExecSink, PickPlacePolicy, SimPlant};
use dexter_sim::perception::Eyes;
use dexter_sim::physics::{DEXTER_URDF, DexterSim, SimSettings};
use dexter_sim::scene::Scene;
use schema::{ExecReport, Library, Percept};
use serde::{Deserialize, Serialize};

use crate::infer::InferFile;
use crate::mcap_log::{LogLevel, McapLog};
use crate::record::{TOPIC_PERCEPT, TOPIC_TRUTH};

/// Arguments of `pbd execute`.
#[derive(Debug, Args)]
pub struct ExecuteArgs {
    /// Scene to act in: a built-in name (pick-place, sorting, sorting-new) or a TOML file.
    #[arg(long, default_value = "sorting-new")]
    pub scene: String,
    /// A learned procedural model (from `pbd learn`): decides relevance and place per object.
    #[arg(long, conflicts_with = "demo")]
    pub model: Option<PathBuf>,
    /// An inference (from `pbd infer`): its MAP schema, with the place its first instance used.
    #[arg(long)]
    pub demo: Option<PathBuf>,
    /// Only this object (scene label); default: every object in the scene.
    #[arg(long)]
    pub object: Option<String>,
    /// Override the place (with --demo).
    #[arg(long)]
    pub place: Option<String>,
    /// Schema library (TOML; default: the built-in library).
    #[arg(long)]
    pub library: Option<PathBuf>,
    /// Seed of every random choice; default: the scene's seed.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Record the execution to this MCAP file.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Print the report as JSON.
    #[arg(long)]
    pub json: bool,
}

/// What happened to one object.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ObjectReport {
    /// Scene label.
    pub object: String,
    /// `execute`, `ignore` (not relevant) or `skip` (unreachable).
    pub decision: String,
    /// Why (posterior, Bayes factor, reachability).
    pub reason: String,
    /// The place chosen.
    pub place: Option<String>,
    /// Posterior over places (from a model).
    pub posterior: BTreeMap<String, f64>,
    /// log Bayes factor of relevance (from a model).
    pub log_bayes_factor: Option<f64>,
    /// Arms used, in order.
    pub arms: Vec<String>,
    /// A hand-to-hand transfer was used.
    pub transfer: bool,
    /// Contingencies taken.
    pub contingencies: Vec<String>,
    /// The executive's report.
    pub execution: Option<ExecReport>,
    /// Where the object ended, and whether it is inside the chosen place.
    pub final_position: [f64; 3],
    /// Object at rest inside the chosen place.
    pub success: bool,
}

/// The whole report.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ExecuteReport {
    /// The scene.
    pub scene: String,
    /// The schema executed.
    pub schema: String,
    /// Per object.
    pub objects: Vec<ObjectReport>,
    /// Relevant objects placed in their chosen place.
    pub placed: usize,
    /// Objects decided relevant.
    pub relevant: usize,
    /// Simulated and wall time (s).
    pub sim_time: f64,
    /// Wall time (s).
    pub wall_time: f64,
    /// The MCAP log.
    pub mcap: Option<String>,
}

struct Sink {
    log: Option<McapLog>,
    header: dexter_sim::snapshot::SnapshotHeader,
    names: Vec<String>,
    next_log: f64,
    error: Option<anyhow::Error>,
    last_activity: String,
    progress: indicatif::ProgressBar,
}

impl Sink {
    fn keep(&mut self, r: Result<()>) {
        if let Err(e) = r {
            self.error.get_or_insert(e);
        }
    }
}

impl ExecSink for Sink {
    fn tick(&mut self, sim: &DexterSim, activity: &str) {
        if activity != self.last_activity {
            self.last_activity = activity.to_string();
            self.progress
                .set_message(format!("{activity} (t = {:.1} s)", sim.time()));
            if let Some(log) = self.log.as_mut() {
                let r = log.log_text(sim.time(), LogLevel::Info, activity);
                self.keep(r);
            }
        }
        self.progress.tick();
        if sim.time() + 1e-9 >= self.next_log {
            self.next_log += 1.0 / 30.0;
            if let Some(log) = self.log.as_mut() {
                let r = log.log_snapshot(&self.header, &sim.snapshot(activity));
                self.keep(r);
            }
        }
    }

    fn percept(&mut self, sim: &DexterSim, _eyes: &Eyes, p: &Percept) {
        let Some(log) = self.log.as_mut() else {
            return;
        };
        let schema = serde_json::json!({"type": "object"});
        let objects: Vec<(&str, [f64; 3])> = self
            .names
            .iter()
            .enumerate()
            .map(|(i, n)| {
                let v = sim.object_state(i).pose.translation.vector;
                (n.as_str(), [v.x, v.y, v.z])
            })
            .collect();
        let r = log
            .log_json(TOPIC_PERCEPT, "pbd.Percept", &schema, sim.time(), p)
            .and_then(|()| {
                log.log_json(
                    TOPIC_TRUTH,
                    "pbd.Truth",
                    &schema,
                    sim.time(),
                    &serde_json::json!({"t": sim.time(), "objects": objects}),
                )
            });
        self.keep(r);
    }
}

/// What to do with each object: (label, place) or a reason to leave it.
pub struct Decision {
    /// Scene label.
    pub object: String,
    /// `Ok(place)` to execute, `Err(reason)` to ignore.
    pub place: std::result::Result<String, String>,
    /// Posterior over places.
    pub posterior: BTreeMap<String, f64>,
    /// log B10.
    pub log_bayes_factor: Option<f64>,
    /// Why.
    pub reason: String,
}

/// Runs `pbd execute`.
pub fn main(args: ExecuteArgs, out: &mut dyn Write) -> Result<()> {
    let library = match &args.library {
        Some(p) => Library::open(p)?,
        None => Library::builtin(),
    };
    let scene = Scene::open(&args.scene)?;
    let seed = args.seed.unwrap_or(scene.spec.seed);
    let labels: Vec<String> = match &args.object {
        Some(o) => {
            scene.object_index(o)?;
            vec![o.clone()]
        }
        None => scene.resolved.iter().map(|r| r.label.clone()).collect(),
    };
    // Decide per object.
    let (schema_name, decisions): (String, Vec<Decision>) = match (&args.demo, &args.model) {
        (Some(path), _) => {
            let text = std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
            let file: InferFile =
                serde_json::from_str(&text).with_context(|| format!("{} is not an inference file", path.display()))?;
            if file.format != crate::infer::INFER_FORMAT || file.version != crate::infer::INFER_VERSION {
                bail!(
                    "{}: format {} v{} is not {} v{}",
                    path.display(),
                    file.format,
                    file.version,
                    crate::infer::INFER_FORMAT,
                    crate::infer::INFER_VERSION
                );
            }
            let schema = file.inference.posterior.map.clone();
            if schema != "pick_and_place" {
                bail!(
                    "{}: the demonstration was explained by `{schema}`; `pbd execute` runs pick_and_place",
                    path.display()
                );
            }
            let place = match &args.place {
                Some(p) => p.clone(),
                None => file
                    .inference
                    .instances
                    .iter()
                    .find_map(|i| i.place.clone())
                    .context("the inference has no instance with a place; pass --place")?,
            };
            scene.place(&place)?;
            let d = labels
                .iter()
                .map(|l| Decision {
                    object: l.clone(),
                    place: Ok(place.clone()),
                    posterior: BTreeMap::new(),
                    log_bayes_factor: None,
                    reason: format!("the demonstration placed its object in {place}"),
                })
                .collect();
            (schema, d)
        }
        (None, Some(path)) => crate::learn::decide(path, &scene, seed, &labels)?,
        (None, None) => bail!("pass --demo demo.infer.json or --model model.json"),
    };
    let schema = library.schema(&schema_name)?.clone();

    let mut sim = DexterSim::new(
        &scene,
        SimSettings {
            seed,
            ..SimSettings::default()
        },
    )?;
    let table_z = scene.spec.table.height;
    dexter_sim::task::park_robot(&mut sim, table_z)?;
    for _ in 0..200 {
        sim.step();
    }
    let log = match &args.output {
        Some(p) => {
            let mut log = McapLog::create(p)?;
            log.attach("dexter.urdf", "application/xml", DEXTER_URDF.as_bytes())?;
            let mut meta = BTreeMap::new();
            meta.insert("command".to_string(), "execute".to_string());
            meta.insert("scene".to_string(), args.scene.clone());
            meta.insert("seed".to_string(), seed.to_string());
            meta.insert("schema".to_string(), schema_name.clone());
            log.metadata("pbd", meta)?;
            log.log_scene(&scene, sim.header(), sim.time())?;
            Some(log)
        }
        None => None,
    };
    let mut sink = Sink {
        log,
        header: sim.header().clone(),
        names: sim.header().object_names.clone(),
        next_log: 0.0,
        error: None,
        last_activity: String::new(),
        progress: crate::progress::spinner(args.json, "execute"),
    };
    let wall = std::time::Instant::now();
    let t_start = sim.time();
    let mut reports = Vec::new();
    for d in decisions {
        let obj = sim.object(&d.object)?;
        let place = match d.place {
            Err(why) => {
                let p = sim.object_state(obj).pose.translation.vector;
                reports.push(ObjectReport {
                    object: d.object.clone(),
                    decision: "ignore".into(),
                    reason: why,
                    place: None,
                    posterior: d.posterior,
                    log_bayes_factor: d.log_bayes_factor,
                    arms: vec![],
                    transfer: false,
                    contingencies: vec![],
                    execution: None,
                    final_position: [p.x, p.y, p.z],
                    success: false,
                });
                continue;
            }
            Ok(p) => p,
        };
        sink.progress.set_message(format!("{} → {place}", d.object));
        let mut plant = SimPlant::new(&mut sim, &scene, &library, seed, &mut sink)?;
        let at = plant.sim.object_state(obj).pose.translation.vector;
        plant.plan_handoff(&at)?;
        let policy = PickPlacePolicy::decide(plant.sim, &scene, &d.object, &at, &place, plant.handoff())?;
        let Some(mut policy) = policy else {
            drop(plant);
            reports.push(ObjectReport {
                object: d.object.clone(),
                decision: "skip".into(),
                reason: format!("no arm reaches `{}`, or none reaches `{place}`", d.object),
                place: Some(place),
                posterior: d.posterior,
                log_bayes_factor: d.log_bayes_factor,
                arms: vec![],
                transfer: false,
                contingencies: vec![],
                execution: None,
                final_position: [at.x, at.y, at.z],
                success: false,
            });
            continue;
        };
        let transfer = policy.is_transfer();
        plant.bind_arms(&[policy.pick_arm, policy.place_arm]);
        let exec = schema::execute(&library, &schema, &mut plant, &mut policy, 20)?;
        let arms: Vec<String> = plant.arms_used.iter().map(|a| a.prefix().to_string()).collect();
        drop(plant);
        // Let the object come to rest, then judge.
        for _ in 0..500 {
            sim.step();
        }
        let state = sim.object_state(obj);
        let p = state.pose.translation.vector;
        let spec = scene.place(&place)?;
        let success = spec.contains([p.x, p.y]) && state.linvel.norm() < 0.02 && p.z < table_z + spec.wall_height + 0.2;
        reports.push(ObjectReport {
            object: d.object.clone(),
            decision: "execute".into(),
            reason: d.reason,
            place: Some(place),
            posterior: d.posterior,
            log_bayes_factor: d.log_bayes_factor,
            arms,
            transfer,
            contingencies: exec.contingencies.clone(),
            execution: Some(exec),
            final_position: [p.x, p.y, p.z],
            success,
        });
        if let Some(log) = sink.log.as_mut() {
            let r = log.log_text(
                sim.time(),
                if success { LogLevel::Info } else { LogLevel::Warning },
                &format!("{}: {}", d.object, if success { "placed" } else { "not placed" }),
            );
            sink.keep(r);
        }
    }
    sink.progress.finish_and_clear();
    if let Some(e) = sink.error.take() {
        return Err(e.context("writing the MCAP log"));
    }
    if let Some(log) = sink.log.take() {
        log.finish()?;
    }
    let relevant = reports.iter().filter(|r| r.decision != "ignore").count();
    let placed = reports.iter().filter(|r| r.success).count();
    let report = ExecuteReport {
        scene: args.scene.clone(),
        schema: schema_name,
        objects: reports,
        placed,
        relevant,
        sim_time: sim.time() - t_start,
        wall_time: wall.elapsed().as_secs_f64(),
        mcap: args.output.as_ref().map(|p| p.display().to_string()),
    };
    if args.json {
        writeln!(out, "{}", serde_json::to_string_pretty(&report)?)?;
        return Ok(());
    }
    print_report(&report, out)
}

/// Prints an execution report as a table.
pub fn print_report(r: &ExecuteReport, out: &mut dyn Write) -> Result<()> {
    writeln!(out, "{} on scene {}:", r.schema, r.scene)?;
    for o in &r.objects {
        let arms = if o.arms.is_empty() {
            "-".to_string()
        } else {
            o.arms.join("→")
        };
        writeln!(
            out,
            "  {:<16} {:<8} {:<10} arms {:<12} {:<9} {:<24} {}",
            o.object,
            o.decision,
            o.place.as_deref().unwrap_or("-"),
            arms,
            if o.transfer { "transfer" } else { "" },
            if o.contingencies.is_empty() {
                String::new()
            } else {
                format!("contingencies: {}", o.contingencies.join(", "))
            },
            match o.decision.as_str() {
                "execute" =>
                    if o.success {
                        "PLACED".to_string()
                    } else {
                        "FAILED".to_string()
                    },
                _ => o.reason.clone(),
            }
        )?;
    }
    writeln!(
        out,
        "placed {}/{} relevant objects in {:.1} s simulated ({:.1} s wall){}",
        r.placed,
        r.relevant,
        r.sim_time,
        r.wall_time,
        r.mcap.as_ref().map(|m| format!("; log {m}")).unwrap_or_default()
    )?;
    Ok(())
}
