//! `pbd grasp`: visual grasp prototypes (Sweeney 2011, ch. 6) — record demonstrated grasps, learn
//! prototypes, generate pre-grasps for new objects, and evaluate against the naive baseline in the sim.
//!
//! - `pbd grasp record`: the scripted teacher (or a `--teleop` file) grasps each training
//!   presentation in the simulator; grasps that held (hand up 10 cm, object still held) go into a
//!   corpus file (`pbd-grasp-corpus` JSON, see `grasp_topics::Corpus`). The appearance b comes from
//!   the robot's stereo vision and positions are relative to the triangulated centroid.
//! - `pbd grasp learn CORPUS -o prototypes.json`: the Gibbs sampler (or `--nonparametric`).
//! - `pbd grasp generate --model prototypes.json --object NAME`: perceive the presented object,
//!   generate pre-grasps from its appearance, drop those that collide, rank by reach.
//! - `pbd grasp eval`: the §6.5 experiment — train/test split, model vs naive baseline in the sim,
//!   Fig. 6.7, totals, significance, Table 6.1.

use std::fmt;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use dexter_sim::Arm;
use dexter_sim::grasp_trial::{self, GraspTeacher, Percept, PreGraspCommand, TrialOutcome};
use dexter_sim::physics::SimSettings;
use dexter_sim::scene::Scene;
use grasp_topics::{Config, Corpus, DemoGrasp, DpConfig, GraspModel};
use nalgebra::{Matrix2, Vector3};
use serde::{Deserialize, Serialize};

use crate::mcap_log::{McapLog, PreGraspMarker};
use crate::progress::Progress;

pub mod common;
pub mod eval;
pub mod report;

use common::{Presenter, select_candidates};

/// Which arm grasps.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum GraspArm {
    /// The left arm.
    Left,
    /// The right arm (the seed's).
    #[default]
    Right,
}

impl GraspArm {
    /// The arm.
    pub fn arm(self) -> Arm {
        match self {
            GraspArm::Left => Arm::Left,
            GraspArm::Right => Arm::Right,
        }
    }
}

/// Where and how objects are presented (shared by record, generate and eval).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PresentOptions {
    /// Scene whose table, cameras and catalog are used (built-in name or TOML file); its objects are
    /// replaced by the one presented.
    pub scene: String,
    /// Where the object is presented on the table (x, y in m, world).
    pub xy: [f64; 2],
    /// The arm that grasps.
    pub arm: GraspArm,
}

impl Default for PresentOptions {
    fn default() -> Self {
        PresentOptions {
            scene: "pick-place".into(),
            xy: [0.55, 0.0],
            arm: GraspArm::Right,
        }
    }
}

/// Options of [`record`] (`pbd grasp record`).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GraspRecordOptions {
    /// Where and how objects are presented.
    pub present: PresentOptions,
    /// Training presentations (catalog names such as `jif`, `jif-1`); empty: all.
    pub objects: Vec<String>,
    /// Demonstrations attempted per presentation by the scripted teacher.
    pub demos: usize,
    /// Replay teleoperation files instead (CSV or JSON lines, `pbd record` format; one grasp each:
    /// the pre-grasp is the palm pose when the commanded flexion first exceeds 1 rad). Needs exactly
    /// one presentation in `objects`.
    pub teleop: Vec<PathBuf>,
    /// Seed of every random choice (placement jitter, teacher noise, encoder and pixel noise).
    pub seed: u64,
    /// Corpus file to write.
    pub output: PathBuf,
    /// Add to an existing corpus file (grasps of a presentation already there are appended).
    pub append: bool,
}

impl Default for GraspRecordOptions {
    fn default() -> Self {
        GraspRecordOptions {
            present: PresentOptions::default(),
            objects: Vec::new(),
            demos: 4,
            teleop: Vec::new(),
            seed: 0,
            output: PathBuf::from("corpus.json"),
            append: false,
        }
    }
}

/// Options of [`learn`] (`pbd grasp learn`).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GraspLearnOptions {
    /// The corpus file (`pbd-grasp-corpus` JSON).
    pub corpus: PathBuf,
    /// Model file to write (`pbd-grasp-model` JSON).
    pub output: PathBuf,
    /// Number of prototypes A of the finite model (the seed used 10).
    pub prototypes: usize,
    /// Infer the number of prototypes (Dirichlet-process mixture, Neal's algorithm 8).
    pub nonparametric: bool,
    /// DP concentration (with `nonparametric`).
    pub concentration: f64,
    /// Number of canonical orientations Q (the seed used 6).
    pub orientations: usize,
    /// Burn-in sweeps.
    pub burn_in: usize,
    /// Chains (run in parallel).
    pub chains: usize,
    /// Seed.
    pub seed: u64,
}

impl Default for GraspLearnOptions {
    fn default() -> Self {
        GraspLearnOptions {
            corpus: PathBuf::from("corpus.json"),
            output: PathBuf::from("prototypes.json"),
            prototypes: 10,
            nonparametric: false,
            concentration: 1.0,
            orientations: 6,
            burn_in: 200,
            chains: 4,
            seed: 0,
        }
    }
}

/// Options of [`generate`] (`pbd grasp generate`).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GenerateOptions {
    /// The model file (`pbd grasp learn` output).
    pub model: PathBuf,
    /// The presentation to present (catalog name such as `jif-1`).
    pub object: String,
    /// Where and how it is presented.
    pub present: PresentOptions,
    /// Number of pre-grasps to return.
    pub n: usize,
    /// Seed.
    pub seed: u64,
    /// Also draw the presented scene, the robot and the ranked pre-grasps into this MCAP file
    /// (`/scene`, `/robot`, `/tf`, `/grasp/candidates`) for Foxglove.
    pub mcap: Option<PathBuf>,
}

impl Default for GenerateOptions {
    fn default() -> Self {
        GenerateOptions {
            model: PathBuf::from("prototypes.json"),
            object: String::new(),
            present: PresentOptions::default(),
            n: 6,
            seed: 0,
            mcap: None,
        }
    }
}

/// One demonstration attempt in a record run.
#[derive(Debug, Clone, Serialize)]
pub struct DemoRecord {
    /// Presentation.
    pub object: String,
    /// `top`, `side` or `teleop`.
    pub kind: String,
    /// Whether the grasp held (kept in the corpus).
    pub kept: bool,
    /// The trial's outcome.
    pub outcome: String,
}

/// Summary of a record run.
#[derive(Debug, Clone, Serialize)]
pub struct RecordSummary {
    /// Corpus file written.
    pub corpus: String,
    /// Presentations with at least one kept grasp.
    pub objects: usize,
    /// Kept grasps.
    pub grasps: usize,
    /// Attempts.
    pub attempts: usize,
    /// Presentations skipped (not seen, or no grasp held), with why.
    pub skipped: Vec<(String, String)>,
    /// Every attempt.
    pub demos: Vec<DemoRecord>,
}

/// What a record run produced: the corpus (presentations with at least one kept grasp), every
/// attempt, and the presentations skipped with why.
pub type Recorded = (Corpus, Vec<DemoRecord>, Vec<(String, String)>);

/// Demonstrates `demos` grasps on each presentation with the scripted teacher; returns the corpus
/// (objects with at least one kept grasp) and the attempt records. `progress` is told after each
/// presentation.
pub fn record_scripted(
    presenter: &Presenter,
    objects: &[String],
    demos: usize,
    seed: u64,
    progress: &dyn Progress,
) -> Result<Recorded> {
    let indexed: Vec<(usize, &String)> = objects.iter().enumerate().collect();
    let results = crate::parallel::map(&indexed, progress, |&(i, name)| -> Result<_> {
        let obj_seed = crate::rng::split(seed, i as u64);
        let (scene, settings) = presenter.scene(name, obj_seed)?;
        let percept = match grasp_trial::perceive(&scene, &settings)? {
            Ok(p) => p,
            Err(why) => {
                progress.message(name);
                return Ok((None, Vec::new(), Some(why)));
            }
        };
        let sim = grasp_trial::parked_sim(&scene, &settings)?;
        let mut teacher = GraspTeacher::new(&sim, presenter.arm, scene.spec.table.height, obj_seed)?;
        let mut grasps = Vec::new();
        let mut records = Vec::new();
        for _ in 0..demos {
            let (kind, cmd) = teacher.demonstrate(&scene, false)?;
            let o = grasp_trial::execute(&scene, &settings, presenter.arm, &cmd, &percept)?;
            if o.success {
                grasps.push(demo_grasp(&o, &percept));
            }
            records.push(DemoRecord {
                object: name.clone(),
                kind: format!("{kind:?}").to_lowercase(),
                kept: o.success,
                outcome: o.outcome,
            });
        }
        progress.message(name);
        Ok((Some((percept, grasps)), records, None))
    })?;
    let mut corpus = Corpus::new();
    let mut all = Vec::new();
    let mut skipped = Vec::new();
    for (name, (found, records, why)) in objects.iter().zip(results) {
        all.extend(records);
        match found {
            Some((p, grasps)) if !grasps.is_empty() => corpus.push_object(name.clone(), &mat2(p.appearance), grasps),
            Some(_) => skipped.push((name.clone(), "no demonstrated grasp held".to_string())),
            None => skipped.push((name.clone(), why.unwrap_or_default())),
        }
    }
    Ok((corpus, all, skipped))
}

/// A row-major 2×2 array as a matrix.
pub fn mat2(a: [[f64; 2]; 2]) -> Matrix2<f64> {
    Matrix2::new(a[0][0], a[0][1], a[1][0], a[1][1])
}

/// The demonstrated grasp of a trial: the achieved palm pose relative to the seen centroid.
fn demo_grasp(o: &TrialOutcome, p: &Percept) -> DemoGrasp {
    let x = Vector3::from(o.achieved_position) - p.centroid();
    let [w, i, j, k] = o.achieved_orientation;
    let q = nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, i, j, k));
    DemoGrasp::new(&x, &q)
}

/// `pbd grasp record`: demonstrated grasps in the simulator, the ones that held saved as a corpus.
///
/// Errors are [`crate::Error`]s: their [`crate::ErrorKind`] says what went wrong.
pub fn record(args: &GraspRecordOptions, progress: &dyn Progress) -> crate::Result<RecordSummary> {
    record_impl(args, progress).map_err(crate::Error::from)
}

fn record_impl(args: &GraspRecordOptions, progress: &dyn Progress) -> anyhow::Result<RecordSummary> {
    let presenter = Presenter::new(&args.present)?;
    let objects: Vec<String> = if args.objects.is_empty() {
        presenter.presentations()
    } else {
        args.objects.clone()
    };
    for o in &objects {
        presenter.check(o)?;
    }
    if !args.teleop.is_empty() && objects.len() != 1 {
        bail!("teleop replays grasps of one presentation: give exactly one object");
    }
    if args.teleop.is_empty() && args.demos == 0 {
        bail!("demos must be at least 1");
    }
    crate::limits::check_at_most("demos", args.demos, crate::limits::MAX_PER_OBJECT)?;
    let mut corpus = if args.append && args.output.exists() {
        Corpus::load(&args.output)?
    } else {
        Corpus::new()
    };
    let teleops = args
        .teleop
        .iter()
        .map(|p| dexter_sim::teleop::TeleopStream::load(p).map_err(anyhow::Error::from))
        .collect::<Result<Vec<_>>>()?;
    // Run: the corpus is refused as any input (the scene, its catalog, a teleop file).
    let mut io = crate::files::IoPlan::new();
    io.read("--scene", &presenter.base.path)
        .read("the scene's catalog", &presenter.base.catalog.path);
    for t in &args.teleop {
        io.read("--teleop", t);
    }
    io.write("-o", &args.output).check()?;
    crate::files::check_writable(&args.output)?;
    progress.phase("record", Some(objects.len() as u64));
    let (new, demos, skipped) = if teleops.is_empty() {
        record_scripted(&presenter, &objects, args.demos, args.seed, progress)?
    } else {
        common::record_teleop(&presenter, &objects[0], &teleops, args.seed)?
    };
    progress.finish();
    let attempts = demos.len();
    for o in new.objects {
        match corpus.objects.iter_mut().find(|c| c.name == o.name) {
            Some(c) => c.grasps.extend(o.grasps),
            None => corpus.objects.push(o),
        }
    }
    if corpus.num_grasps() == 0 {
        bail!(
            "no demonstrated grasp held ({attempts} attempts); nothing to write to {}",
            args.output.display()
        );
    }
    crate::files::write_atomic(&args.output, corpus.to_json_string()?.as_bytes())?;
    let summary = RecordSummary {
        corpus: args.output.display().to_string(),
        objects: corpus.objects.len(),
        grasps: corpus.num_grasps(),
        attempts,
        skipped,
        demos,
    };
    Ok(summary)
}

impl fmt::Display for RecordSummary {
    fn fmt(&self, out: &mut fmt::Formatter<'_>) -> fmt::Result {
        let summary = self;
        let kept = summary.demos.iter().filter(|d| d.kept).count();
        writeln!(
            out,
            "recorded {kept} of {} demonstrated grasps; corpus {} has {} presentations, {} grasps",
            summary.attempts, summary.corpus, summary.objects, summary.grasps
        )?;
        for (name, why) in &summary.skipped {
            writeln!(out, "  skipped {name}: {why}")?;
        }
        Ok(())
    }
}

/// The sampler configuration of a learn run.
pub fn learn_config(
    prototypes: usize,
    nonparametric: bool,
    concentration: f64,
    orientations: usize,
    burn_in: usize,
    chains: usize,
    seed: u64,
) -> Config {
    Config {
        prototypes,
        orientations,
        nonparametric: nonparametric.then_some(DpConfig {
            concentration,
            ..DpConfig::default()
        }),
        burn_in,
        chains,
        seed,
        ..Config::default()
    }
}

/// Summary of a learned model for people and `--json`.
#[derive(Debug, Clone, Serialize)]
pub struct ModelSummary {
    /// Model file.
    pub model: String,
    /// Training presentations.
    pub objects: usize,
    /// Training grasps.
    pub grasps: usize,
    /// Occupied prototypes.
    pub prototypes: usize,
    /// Objects per prototype (Table 6.1 columns).
    pub objects_per_prototype: Vec<usize>,
    /// Fraction of prototypes used by ≥ 2 objects.
    pub shared_fraction: f64,
    /// Log joint of the selected sample.
    pub log_joint: f64,
    /// Gelman–Rubin R̂ of the log joint.
    pub r_hat: Option<f64>,
    /// Table 6.1: which objects share which prototypes.
    #[serde(skip)]
    pub sharing_table: String,
}

/// The summary of a learned model saved at `path`.
pub fn model_summary(model: &GraspModel, path: &Path) -> ModelSummary {
    let table = model.sharing_table();
    ModelSummary {
        model: path.display().to_string(),
        objects: model.objects.len(),
        grasps: model.assignments.iter().map(Vec::len).sum(),
        prototypes: model.prototypes.len(),
        objects_per_prototype: table.objects_per_prototype(),
        shared_fraction: table.shared_fraction(),
        log_joint: model.log_joint,
        r_hat: model.diagnostics.r_hat,
        sharing_table: table.to_string(),
    }
}

/// `pbd grasp learn`: grasp prototypes from a corpus (collapsed Gibbs, or a DP mixture), saved.
///
/// Errors are [`crate::Error`]s: their [`crate::ErrorKind`] says what went wrong.
pub fn learn(args: &GraspLearnOptions, progress: &dyn Progress) -> crate::Result<ModelSummary> {
    learn_impl(args, progress).map_err(crate::Error::from)
}

fn learn_impl(args: &GraspLearnOptions, progress: &dyn Progress) -> anyhow::Result<ModelSummary> {
    let corpus = Corpus::load(&args.corpus)?;
    let config = learn_config(
        args.prototypes,
        args.nonparametric,
        args.concentration,
        args.orientations,
        args.burn_in,
        args.chains,
        args.seed,
    );
    config.validate()?;
    crate::files::IoPlan::new()
        .read("--corpus", &args.corpus)
        .write("-o", &args.output)
        .check()?;
    crate::files::check_writable(&args.output)?;
    progress.phase("learn", None);
    progress.message(&format!(
        "{} grasps on {} presentations",
        corpus.num_grasps(),
        corpus.objects.len()
    ));
    let model = GraspModel::learn(&corpus, &config)?;
    progress.finish();
    crate::files::write_atomic(&args.output, model.to_json_string()?.as_bytes())?;
    Ok(model_summary(&model, &args.output))
}

impl fmt::Display for ModelSummary {
    fn fmt(&self, out: &mut fmt::Formatter<'_>) -> fmt::Result {
        let summary = self;
        writeln!(
            out,
            "learned {} prototypes from {} grasps on {} presentations -> {}",
            summary.prototypes, summary.grasps, summary.objects, summary.model
        )?;
        writeln!(
            out,
            "  shared by >= 2 objects: {:.0} %; log joint {:.1}; R-hat {}",
            100.0 * summary.shared_fraction,
            summary.log_joint,
            summary.r_hat.map_or("-".into(), |r| format!("{r:.3}"))
        )?;
        writeln!(out)?;
        write!(out, "{}", summary.sharing_table)
    }
}

/// One generated pre-grasp for `--json`.
#[derive(Debug, Clone, Serialize)]
pub struct GeneratedPreGrasp {
    /// Rank (1 = nearest to reach).
    pub rank: usize,
    /// Prototype it came from.
    pub prototype: Option<usize>,
    /// Canonical orientation index.
    pub orientation_index: Option<usize>,
    /// Palm-surface position in the object frame (m; origin at the seen centroid, world axes).
    pub position: [f64; 3],
    /// Palm-surface orientation `[w, x, y, z]` (object frame = world axes).
    pub orientation: [f64; 4],
    /// Palm-surface position in the world (m).
    pub world_position: [f64; 3],
    /// Distance from the shoulder (m).
    pub reach_distance: f64,
}

/// `pbd grasp generate --json` output.
#[derive(Debug, Clone, Serialize)]
pub struct GenerateReport {
    /// The presentation.
    pub object: String,
    /// What the robot saw.
    pub percept: Percept,
    /// p(z = j | b_t) per prototype (6.28).
    pub prototype_probabilities: Vec<f64>,
    /// Candidates drawn.
    pub drawn: usize,
    /// Dropped: hand would hit the object / the table / out of reach.
    pub rejected: common::Rejections,
    /// The ranked pre-grasps.
    pub pre_grasps: Vec<GeneratedPreGrasp>,
    /// How many were asked for.
    pub asked: usize,
}

/// `pbd grasp generate`: perceive a presented object and propose ranked, collision-free pre-grasps
/// from its appearance (6.28).
///
/// Errors are [`crate::Error`]s: their [`crate::ErrorKind`] says what went wrong.
pub fn generate(args: &GenerateOptions) -> crate::Result<GenerateReport> {
    generate_impl(args).map_err(crate::Error::from)
}

fn generate_impl(args: &GenerateOptions) -> anyhow::Result<GenerateReport> {
    let presenter = Presenter::new(&args.present)?;
    presenter.check(&args.object)?;
    if args.n == 0 {
        bail!("n must be at least 1");
    }
    crate::limits::check_at_most("n", args.n, grasp_topics::MAX_GENERATE)?;
    if let Some(out) = &args.mcap {
        crate::files::IoPlan::new()
            .read("--model", &args.model)
            .read("--scene", &presenter.base.path)
            .read("the scene's catalog", &presenter.base.catalog.path)
            .write("--mcap", out)
            .check()?;
        crate::files::check_writable(out)?;
    }
    let model = GraspModel::load(&args.model)?;
    let (scene, settings) = presenter.scene(&args.object, args.seed)?;
    let percept = match grasp_trial::perceive(&scene, &settings)? {
        Ok(p) => p,
        Err(why) => bail!("cannot see {}: {why}", args.object),
    };
    let b = mat2(percept.appearance);
    let pz = model.prototype_probabilities(&b)?;
    let reach_sim = grasp_trial::parked_sim(&scene, &settings)?;
    let mut rng = crate::rng::stream(args.seed, 0x6E4E);
    let sel = select_candidates(
        &presenter,
        &scene,
        &reach_sim,
        &percept,
        common::Method::Model,
        args.n,
        false,
        |k, rng| model.generate(&b, k, rng).map_err(anyhow::Error::from),
        &mut rng,
    )?;
    let report = GenerateReport {
        object: args.object.clone(),
        prototype_probabilities: pz,
        drawn: sel.drawn,
        rejected: sel.rejected,
        pre_grasps: sel
            .chosen
            .iter()
            .enumerate()
            .map(|(i, c)| {
                let w = c.world_from_palm.translation.vector;
                GeneratedPreGrasp {
                    rank: i + 1,
                    prototype: c.pre_grasp.prototype,
                    orientation_index: c.pre_grasp.orientation_index,
                    position: c.pre_grasp.position,
                    orientation: c.pre_grasp.orientation,
                    world_position: [w.x, w.y, w.z],
                    reach_distance: c.reach_distance,
                }
            })
            .collect(),
        percept,
        asked: args.n,
    };
    if let Some(out) = &args.mcap {
        let markers: Vec<PreGraspMarker> = sel
            .chosen
            .iter()
            .enumerate()
            .map(|(i, c)| PreGraspMarker {
                rank: i + 1,
                world_from_palm: c.world_from_palm,
                label: match c.pre_grasp.prototype {
                    Some(k) => format!("#{} prototype {k}", i + 1),
                    None => format!("#{}", i + 1),
                },
                group: String::new(),
                held: None,
            })
            .collect();
        draw_pre_grasps(out, &scene, &reach_sim, &markers).with_context(|| format!("writing {}", out.display()))?;
    }
    Ok(report)
}

/// Writes the presented scene, the parked robot and the ranked pre-grasps to the MCAP file `path`.
pub(crate) fn draw_pre_grasps(
    path: &Path,
    scene: &Scene,
    sim: &dexter_sim::physics::DexterSim,
    markers: &[PreGraspMarker],
) -> Result<()> {
    let mut log = McapLog::create(path)?;
    log.log_scene(scene, sim.header(), 0.0)?;
    log.log_robot(sim.model(), 0.0)?;
    log.log_snapshot(sim.header(), &sim.snapshot("pre-grasps"))?;
    log.log_pre_grasps(0.0, markers)?;
    log.finish()?;
    Ok(())
}

impl fmt::Display for GenerateReport {
    fn fmt(&self, out: &mut fmt::Formatter<'_>) -> fmt::Result {
        let report = self;
        let b = report.percept.appearance;
        writeln!(
            out,
            "{}: centroid ({:.3}, {:.3}, {:.3}) m, appearance b = [[{:.1}, {:.1}], [{:.1}, {:.1}]] px^2",
            report.object,
            report.percept.centroid[0],
            report.percept.centroid[1],
            report.percept.centroid[2],
            b[0][0],
            b[0][1],
            b[1][0],
            b[1][1]
        )?;
        writeln!(
            out,
            "drew {} candidates: {} hit the object, {} the table, {} out of reach",
            report.drawn, report.rejected.hits_object, report.rejected.hits_table, report.rejected.unreachable
        )?;
        let mut t = crate::table::Table::new([
            "rank",
            "prototype",
            "orient",
            "x",
            "y",
            "z",
            "qw",
            "qx",
            "qy",
            "qz",
            "reach",
        ]);
        for g in &report.pre_grasps {
            let f = |v: f64| crate::table::num(v, 3);
            t.row([
                g.rank.to_string(),
                g.prototype.map_or("-".into(), |j| (j + 1).to_string()),
                g.orientation_index.map_or("-".into(), |w| (w + 1).to_string()),
                f(g.position[0]),
                f(g.position[1]),
                f(g.position[2]),
                f(g.orientation[0]),
                f(g.orientation[1]),
                f(g.orientation[2]),
                f(g.orientation[3]),
                f(g.reach_distance),
            ]);
        }
        write!(out, "{}", t.render(2))?;
        if report.pre_grasps.len() < report.asked {
            writeln!(
                out,
                "only {} of {} collision-free, reachable pre-grasps found",
                report.pre_grasps.len(),
                report.asked
            )?;
        }
        Ok(())
    }
}

/// The command a candidate is executed with.
pub fn command_for(c: &grasp_topics::RankedPreGrasp, method: common::Method) -> PreGraspCommand {
    PreGraspCommand {
        world_from_palm: c.world_from_palm,
        preshape: grasp_trial::PRESHAPE,
        spread: method.spread(),
    }
}

/// Checks that a scene opens (for error messages naming the option).
pub fn open_scene(name: &str) -> Result<Scene> {
    Scene::open(name).with_context(|| format!("scene {name}"))
}

/// Settings of every simulation of a run.
pub fn sim_settings(seed: u64) -> SimSettings {
    SimSettings {
        seed,
        ..SimSettings::default()
    }
}
