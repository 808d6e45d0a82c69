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

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use clap::{Args, Subcommand, ValueEnum};
use dexter_sim::Arm;
use dexter_sim::grasp_trial::{self, GraspTeacher, Percept, PreGraspCommand, TrialOutcome};
use dexter_sim::physics::SimSettings;
use dexter_sim::scene::Scene;
use grasp_topics::{Config, Corpus, DemoGrasp, DpConfig, GraspModel};
use nalgebra::{Matrix2, Vector3};
use serde::Serialize;

pub(crate) mod common;
mod eval;
mod report;

use common::{Presenter, select_candidates};

/// `pbd grasp …` subcommands.
#[derive(Debug, Subcommand)]
pub enum GraspCommand {
    /// Demonstrate grasps on training presentations in the sim (scripted teacher or a teleop file)
    /// and write the grasps that held into a corpus file.
    Record(RecordArgs),
    /// Learn grasp prototypes from a corpus (collapsed Gibbs sampler, or a Dirichlet process).
    Learn(LearnArgs),
    /// Generate pre-grasps for a presented object from its appearance (collision-filtered, ranked).
    Generate(GenerateArgs),
    /// Evaluate the prototype model against the naive baseline in the sim (§6.5, Fig. 6.7).
    Eval(eval::EvalArgs),
}

/// Which arm grasps.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ArmArg {
    /// The left arm.
    Left,
    /// The right arm (the seed's).
    Right,
}

impl ArmArg {
    fn arm(self) -> Arm {
        match self {
            ArmArg::Left => Arm::Left,
            ArmArg::Right => Arm::Right,
        }
    }
}

/// Where and how objects are presented (shared by record, generate and eval).
#[derive(Debug, Clone, Args)]
pub struct PresentArgs {
    /// Scene whose table, cameras and catalog are used (built-in name or TOML file); its objects are
    /// replaced by the one presented.
    #[arg(long, default_value = "pick-place")]
    pub scene: String,
    /// Where the object is presented on the table (x, y in m, world).
    #[arg(long, num_args = 2, value_names = ["X", "Y"], default_values_t = [0.55, 0.0], allow_negative_numbers = true)]
    pub xy: Vec<f64>,
    /// The arm that grasps.
    #[arg(long, value_enum, default_value_t = ArmArg::Right)]
    pub arm: ArmArg,
}

/// Arguments of `pbd grasp record`.
#[derive(Debug, Args)]
pub struct RecordArgs {
    #[command(flatten)]
    pub present: PresentArgs,
    /// Training presentations (catalog names such as `jif`, `jif-1`), comma-separated; default: all.
    #[arg(long, value_delimiter = ',')]
    pub objects: Vec<String>,
    /// Demonstrations attempted per presentation by the scripted teacher.
    #[arg(long, default_value_t = 4)]
    pub demos: usize,
    /// Replay teleoperation files instead (CSV or JSON lines, `pbd record` format; one grasp each:
    /// the pre-grasp is the palm pose when the commanded flexion first exceeds 1 rad). Needs exactly
    /// one `--objects` presentation.
    #[arg(long)]
    pub teleop: Vec<PathBuf>,
    /// Seed of every random choice (placement jitter, teacher noise, encoder and pixel noise).
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Corpus file to write.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Add to an existing corpus file (grasps of a presentation already there are appended).
    #[arg(long)]
    pub append: bool,
    /// Print the summary as JSON.
    #[arg(long)]
    pub json: bool,
}

/// Arguments of `pbd grasp learn`.
#[derive(Debug, Args)]
pub struct LearnArgs {
    /// The corpus file (`pbd-grasp-corpus` JSON).
    pub corpus: PathBuf,
    /// Model file to write (`pbd-grasp-model` JSON).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Number of prototypes A of the finite model (the seed used 10).
    #[arg(long, default_value_t = 10, conflicts_with = "nonparametric")]
    pub prototypes: usize,
    /// Infer the number of prototypes (Dirichlet-process mixture, Neal's algorithm 8).
    #[arg(long)]
    pub nonparametric: bool,
    /// DP concentration (with --nonparametric).
    #[arg(long, default_value_t = 1.0)]
    pub concentration: f64,
    /// Number of canonical orientations Q (the seed used 6).
    #[arg(long, default_value_t = 6)]
    pub orientations: usize,
    /// Burn-in sweeps.
    #[arg(long, default_value_t = 200)]
    pub burn_in: usize,
    /// Chains (run in parallel).
    #[arg(long, default_value_t = 4)]
    pub chains: usize,
    /// Seed.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Print the summary as JSON.
    #[arg(long)]
    pub json: bool,
}

/// Arguments of `pbd grasp generate`.
#[derive(Debug, Args)]
pub struct GenerateArgs {
    /// The model file (`pbd grasp learn` output).
    #[arg(long)]
    pub model: PathBuf,
    /// The presentation to present (catalog name such as `jif-1`).
    #[arg(long)]
    pub object: String,
    #[command(flatten)]
    pub present: PresentArgs,
    /// Number of pre-grasps to return.
    #[arg(long, default_value_t = 6)]
    pub n: usize,
    /// Seed.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Print the pre-grasps as JSON.
    #[arg(long)]
    pub json: bool,
}

/// Runs a `pbd grasp` subcommand.
pub fn main(cmd: GraspCommand, out: &mut dyn Write) -> Result<()> {
    match cmd {
        GraspCommand::Record(a) => record(a, out),
        GraspCommand::Learn(a) => learn(a, out),
        GraspCommand::Generate(a) => generate(a, out),
        GraspCommand::Eval(a) => eval::run(a, out),
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
pub(crate) type Recorded = (Corpus, Vec<DemoRecord>, Vec<(String, String)>);

/// Demonstrates `demos` grasps on each presentation with the scripted teacher; returns the corpus
/// (objects with at least one kept grasp) and the attempt records. `progress` is told after each
/// presentation.
pub(crate) fn record_scripted(
    presenter: &Presenter,
    objects: &[String],
    demos: usize,
    seed: u64,
    progress: &(dyn Fn(&str) + Sync),
) -> Result<Recorded> {
    let results = common::parallel_map(objects, |i, name| -> Result<_> {
        let obj_seed = common::mix(seed, i as u64);
        let (scene, settings) = presenter.scene(name, obj_seed)?;
        let percept = match grasp_trial::perceive(&scene, &settings)? {
            Ok(p) => p,
            Err(why) => {
                progress(name);
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
        progress(name);
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
pub(crate) fn mat2(a: [[f64; 2]; 2]) -> Matrix2<f64> {
    Matrix2::new(a[0][0], a[0][1], a[1][0], a[1][1])
}

/// The demonstrated grasp of a trial: the achieved palm pose relative to the seen centroid.
fn demo_grasp(o: &TrialOutcome, p: &Percept) -> DemoGrasp {
    let x = Vector3::from(o.achieved_position) - p.centroid();
    let [w, i, j, k] = o.achieved_orientation;
    let q = nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, i, j, k));
    DemoGrasp::new(&x, &q)
}

fn record(args: RecordArgs, out: &mut dyn Write) -> Result<()> {
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
        bail!("--teleop replays grasps of one presentation: give exactly one --objects NAME");
    }
    if args.teleop.is_empty() && args.demos == 0 {
        bail!("--demos must be at least 1");
    }
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
    // Run.
    let bar = crate::progress::bar(args.json, objects.len() as u64, "record");
    let (new, demos, skipped) = if teleops.is_empty() {
        let tick = |name: &str| {
            bar.set_message(name.to_string());
            bar.inc(1);
        };
        record_scripted(&presenter, &objects, args.demos, args.seed, &tick)?
    } else {
        common::record_teleop(&presenter, &objects[0], &teleops, args.seed)?
    };
    bar.finish_and_clear();
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
    corpus.save(&args.output)?;
    let summary = RecordSummary {
        corpus: args.output.display().to_string(),
        objects: corpus.objects.len(),
        grasps: corpus.num_grasps(),
        attempts,
        skipped,
        demos,
    };
    if args.json {
        writeln!(out, "{}", serde_json::to_string_pretty(&summary)?)?;
    } else {
        let kept = summary.demos.iter().filter(|d| d.kept).count();
        writeln!(
            out,
            "recorded {kept} of {attempts} demonstrated grasps; corpus {} has {} presentations, {} grasps",
            summary.corpus, summary.objects, summary.grasps
        )?;
        for (name, why) in &summary.skipped {
            writeln!(out, "  skipped {name}: {why}")?;
        }
    }
    Ok(())
}

pub(crate) fn learn_config(
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
}

pub(crate) fn model_summary(model: &GraspModel, path: &Path) -> ModelSummary {
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
    }
}

fn learn(args: LearnArgs, out: &mut dyn Write) -> Result<()> {
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
    let spinner = crate::progress::spinner(args.json, "learn");
    spinner.set_message(format!(
        "{} grasps on {} presentations",
        corpus.num_grasps(),
        corpus.objects.len()
    ));
    let model = GraspModel::learn(&corpus, &config)?;
    spinner.finish_and_clear();
    model
        .save(&args.output)
        .with_context(|| format!("cannot write {}", args.output.display()))?;
    let summary = model_summary(&model, &args.output);
    if args.json {
        writeln!(out, "{}", serde_json::to_string_pretty(&summary)?)?;
    } else {
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
        write!(out, "{}", model.sharing_table())?;
    }
    Ok(())
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
}

fn generate(args: GenerateArgs, out: &mut dyn Write) -> Result<()> {
    let model = GraspModel::load(&args.model)?;
    let presenter = Presenter::new(&args.present)?;
    presenter.check(&args.object)?;
    if args.n == 0 {
        bail!("--n must be at least 1");
    }
    let (scene, settings) = presenter.scene(&args.object, args.seed)?;
    let percept = match grasp_trial::perceive(&scene, &settings)? {
        Ok(p) => p,
        Err(why) => bail!("cannot see {}: {why}", args.object),
    };
    let b = mat2(percept.appearance);
    let pz = model.prototype_probabilities(&b)?;
    let reach_sim = grasp_trial::parked_sim(&scene, &settings)?;
    let mut rng = common::rng(args.seed, 0x6E4E);
    let sel = select_candidates(
        &presenter,
        &scene,
        &reach_sim,
        &percept,
        common::Method::Model,
        args.n,
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
    };
    if args.json {
        writeln!(out, "{}", serde_json::to_string_pretty(&report)?)?;
        return Ok(());
    }
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
    let mut t = crate::output::Table::new([
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
        let f = |v: f64| crate::output::num(v, 3);
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
    t.write(out, 2)?;
    if report.pre_grasps.len() < args.n {
        writeln!(
            out,
            "only {} of {} collision-free, reachable pre-grasps found",
            report.pre_grasps.len(),
            args.n
        )?;
    }
    Ok(())
}

/// The command a candidate is executed with.
pub(crate) fn command_for(c: &grasp_topics::RankedPreGrasp, method: common::Method) -> PreGraspCommand {
    PreGraspCommand {
        world_from_palm: c.world_from_palm,
        preshape: grasp_trial::PRESHAPE,
        spread: method.spread(),
    }
}

/// Checks that a scene opens (for error messages naming the option).
pub(crate) fn open_scene(name: &str) -> Result<Scene> {
    Scene::open(name).with_context(|| format!("--scene {name}"))
}

/// Settings of every simulation of a run.
pub(crate) fn sim_settings(seed: u64) -> SimSettings {
    SimSettings {
        seed,
        ..SimSettings::default()
    }
}
