//! `pbd grasp record | learn | generate | eval`: visual grasp prototypes (Sweeney 2011, ch. 6).

use std::io::Write;
use std::path::PathBuf;

use clap::{Args, Subcommand};
use pbd::grasp::eval::EvalOptions;
use pbd::grasp::{GenerateOptions, GraspArm, GraspLearnOptions, GraspRecordOptions, PresentOptions};

use crate::output::emit;
use crate::progress::Bars;

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
    Eval(EvalArgs),
}

/// Where and how objects are presented (shared by record, generate and eval).
#[derive(Debug, Clone, Args)]
pub struct PresentArgs {
    /// Scene whose table, cameras and catalog are used (built-in name or TOML file); its objects are
    /// replaced by the one presented.
    #[arg(long, default_value = "pick-place")]
    scene: String,
    /// Where the object is presented on the table (x, y in m, world).
    #[arg(long, num_args = 2, value_names = ["X", "Y"], default_values_t = [0.55, 0.0], allow_negative_numbers = true)]
    xy: Vec<f64>,
    /// The arm that grasps.
    #[arg(long, value_enum, default_value_t = GraspArm::Right)]
    arm: GraspArm,
}

impl PresentArgs {
    fn options(&self) -> anyhow::Result<PresentOptions> {
        let [x, y] = self.xy[..] else {
            anyhow::bail!("--xy takes two numbers");
        };
        Ok(PresentOptions {
            scene: self.scene.clone(),
            xy: [x, y],
            arm: self.arm,
        })
    }
}

/// Arguments of `pbd grasp record`.
#[derive(Debug, Args)]
pub struct RecordArgs {
    #[command(flatten)]
    present: PresentArgs,
    /// Training presentations (catalog names such as `jif`, `jif-1`), comma-separated; default: all.
    #[arg(long, value_delimiter = ',')]
    objects: Vec<String>,
    /// Demonstrations attempted per presentation by the scripted teacher.
    #[arg(long, default_value_t = 4)]
    demos: usize,
    /// Replay teleoperation files instead (CSV or JSON lines, `pbd record` format; one grasp each:
    /// the pre-grasp is the palm pose when the commanded flexion first exceeds 1 rad). Needs exactly
    /// one `--objects` presentation.
    #[arg(long)]
    teleop: Vec<PathBuf>,
    /// Seed of every random choice (placement jitter, teacher noise, encoder and pixel noise).
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Corpus file to write.
    #[arg(short, long)]
    output: PathBuf,
    /// Add to an existing corpus file (grasps of a presentation already there are appended).
    #[arg(long)]
    append: bool,
    /// Print the summary as JSON.
    #[arg(long)]
    json: bool,
}

/// Arguments of `pbd grasp learn`.
#[derive(Debug, Args)]
pub struct LearnArgs {
    /// The corpus file (`pbd-grasp-corpus` JSON).
    corpus: PathBuf,
    /// Model file to write (`pbd-grasp-model` JSON).
    #[arg(short, long)]
    output: PathBuf,
    /// Number of prototypes A of the finite model (the seed used 10).
    #[arg(long, default_value_t = 10, conflicts_with = "nonparametric")]
    prototypes: usize,
    /// Infer the number of prototypes (Dirichlet-process mixture, Neal's algorithm 8).
    #[arg(long)]
    nonparametric: bool,
    /// DP concentration (with --nonparametric).
    #[arg(long, default_value_t = 1.0)]
    concentration: f64,
    /// Number of canonical orientations Q (the seed used 6).
    #[arg(long, default_value_t = 6)]
    orientations: usize,
    /// Burn-in sweeps.
    #[arg(long, default_value_t = 200)]
    burn_in: usize,
    /// Chains (run in parallel).
    #[arg(long, default_value_t = 4)]
    chains: usize,
    /// Seed.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Print the summary as JSON.
    #[arg(long)]
    json: bool,
}

/// Arguments of `pbd grasp generate`.
#[derive(Debug, Args)]
pub struct GenerateArgs {
    /// The model file (`pbd grasp learn` output).
    #[arg(long)]
    model: PathBuf,
    /// The presentation to present (catalog name such as `jif-1`).
    #[arg(long)]
    object: String,
    #[command(flatten)]
    present: PresentArgs,
    /// Number of pre-grasps to return.
    #[arg(long, default_value_t = 6)]
    n: usize,
    /// Seed.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Print the pre-grasps as JSON.
    #[arg(long)]
    json: bool,
    /// Also draw the scene, the robot and the ranked pre-grasps into this MCAP file (Foxglove).
    #[arg(long)]
    mcap: Option<PathBuf>,
}

/// Arguments of `pbd grasp eval`.
#[derive(Debug, Args)]
pub struct EvalArgs {
    #[command(flatten)]
    present: PresentArgs,
    /// Number of test presentations (the seed used 12).
    #[arg(long, default_value_t = 12)]
    test: usize,
    /// Number of training presentations (the seed used 19); 0 = all the others.
    #[arg(long, default_value_t = 24)]
    train: usize,
    /// Test presentations, comma-separated (default: drawn at random).
    #[arg(long, value_delimiter = ',')]
    objects: Vec<String>,
    /// Demonstrations attempted per training presentation.
    #[arg(long, default_value_t = 4)]
    demos: usize,
    /// Candidates executed per test presentation and method (the seed used 6).
    #[arg(long, default_value_t = 6)]
    candidates: usize,
    /// Use this model instead of recording and learning (test presentations exclude its objects).
    #[arg(long, conflicts_with = "corpus")]
    model: Option<PathBuf>,
    /// Learn from this corpus instead of recording one (test presentations exclude its objects).
    #[arg(long)]
    corpus: Option<PathBuf>,
    /// Number of prototypes A (the seed used 10).
    #[arg(long, default_value_t = 10, conflicts_with = "nonparametric")]
    prototypes: usize,
    /// Infer the number of prototypes (Dirichlet process).
    #[arg(long)]
    nonparametric: bool,
    /// Number of canonical orientations Q (the seed used 6).
    #[arg(long, default_value_t = 6)]
    orientations: usize,
    /// Burn-in sweeps of the sampler.
    #[arg(long, default_value_t = 200)]
    burn_in: usize,
    /// Sampler chains.
    #[arg(long, default_value_t = 4)]
    chains: usize,
    /// Seed of every random choice (split, demonstrations, sampler, candidates, sim noise).
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Split by object: no presentation of a test presentation's object is trained on (and none of
    /// a given model's or corpus's objects is tested).
    #[arg(long)]
    object_split: bool,
    /// Filter the naive baseline's candidates against the object as the model's are (default:
    /// against the table only, as the seed's baseline).
    #[arg(long)]
    naive_filtered: bool,
    /// Directory for the report (trials.csv, objects.csv, sharing.csv, fig6_7.svg, summary.md,
    /// summary.json; corpus.json and prototypes.json when learned here).
    #[arg(short, long, default_value = "grasp-eval")]
    output: PathBuf,
    /// Print the summary as JSON.
    #[arg(long)]
    json: bool,
}

/// Runs a `pbd grasp` subcommand.
pub fn main(cmd: GraspCommand, out: &mut dyn Write) -> anyhow::Result<()> {
    match cmd {
        GraspCommand::Record(a) => {
            anyhow::ensure!(a.demos > 0 || !a.teleop.is_empty(), "--demos must be at least 1");
            let options = GraspRecordOptions {
                present: a.present.options()?,
                objects: a.objects,
                demos: a.demos,
                teleop: a.teleop,
                seed: a.seed,
                output: a.output,
                append: a.append,
            };
            emit(a.json, &pbd::grasp::record(&options, &Bars::new(a.json, true)?)?, out)
        }
        GraspCommand::Learn(a) => {
            let options = GraspLearnOptions {
                corpus: a.corpus,
                output: a.output,
                prototypes: a.prototypes,
                nonparametric: a.nonparametric,
                concentration: a.concentration,
                orientations: a.orientations,
                burn_in: a.burn_in,
                chains: a.chains,
                seed: a.seed,
            };
            emit(a.json, &pbd::grasp::learn(&options, &Bars::new(a.json, false)?)?, out)
        }
        GraspCommand::Generate(a) => {
            anyhow::ensure!(a.n > 0, "--n must be at least 1");
            let options = GenerateOptions {
                model: a.model,
                object: a.object,
                present: a.present.options()?,
                n: a.n,
                seed: a.seed,
                mcap: a.mcap,
            };
            emit(a.json, &pbd::grasp::generate(&options)?, out)
        }
        GraspCommand::Eval(a) => {
            anyhow::ensure!(a.candidates > 0, "--candidates must be at least 1");
            let options = EvalOptions {
                present: a.present.options()?,
                test: a.test,
                train: a.train,
                objects: a.objects,
                demos: a.demos,
                candidates: a.candidates,
                model: a.model,
                corpus: a.corpus,
                prototypes: a.prototypes,
                nonparametric: a.nonparametric,
                orientations: a.orientations,
                burn_in: a.burn_in,
                chains: a.chains,
                seed: a.seed,
                object_split: a.object_split,
                naive_filtered: a.naive_filtered,
                output: a.output,
            };
            let summary = pbd::grasp::eval::run(&options, &Bars::new(a.json, true)?)?;
            pbd::figure::draw(
                &options.output.join("fig6_7.svg"),
                &pbd::grasp::report::figure(&summary),
            )?;
            emit(a.json, &summary, out)
        }
    }
}
