//! # pbd — robot programming by demonstration, from the command line
//!
//! `pbd` is the user's door into the workspace: it records demonstrations in the Dexter simulator,
//! infers which schema explains them, learns a procedural model and executes it in a new context
//! (Sweeney 2011). Everything it does lives in the `pbd` library crate (the facade); this binary only
//! turns arguments into the library's options, draws progress bars and plots, and prints reports
//! (as text, or as JSON with `--json`). Usage errors exit with 2, every other error prints `error: …`
//! with its causes and exits with 1.

use std::io::{self, Write};
use std::process::ExitCode;

use clap::{Parser, Subcommand};

mod calibrate;
mod demo;
mod doctor;
mod execute;
mod experiment;
mod grasp;
mod infer;
mod learn;
mod output;
mod progress;
mod record;
mod robot;
mod sim;

/// Robot programming by demonstration (teleological PbD, Sweeney 2011).
#[derive(Debug, Parser)]
#[command(name = "pbd", version, propagate_version = true)]
struct Cli {
    /// Worker threads for parallel trials and scenes [default: one per core, or PBD_THREADS].
    /// Results do not depend on it.
    #[arg(long, global = true, value_name = "N")]
    threads: Option<usize>,
    /// Diagnostics on stderr: -v each action and its outcome, -vv what the robot saw and planned
    /// after each, -vvv every stereo blob. `RUST_LOG` (e.g. `RUST_LOG=dexter::exec=debug`) overrides
    /// it. A run that writes an MCAP file keeps its actions (or what `RUST_LOG` asks for) in `/log`.
    #[arg(short, long, global = true, action = clap::ArgAction::Count)]
    verbose: u8,
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Inspect a robot model (URDF) and evaluate its kinematics.
    #[command(subcommand)]
    Robot(robot::RobotCommand),
    /// Run Dexter in simulation (Rapier physics, control-basis controllers).
    #[command(subcommand)]
    Sim(sim::SimCommand),
    /// Visual grasp prototypes: record grasps, learn prototypes, generate pre-grasps, evaluate.
    #[command(subcommand)]
    Grasp(grasp::GraspCommand),
    /// Infer which schema explains a recorded demonstration, and its instances.
    Infer(infer::InferArgs),
    /// The whole story on the built-in scenes: record, infer, learn, execute (no arguments needed).
    Demo(demo::DemoArgs),
    /// Learn the procedural model of a task from demonstrations (or explain one).
    Learn(learn::LearnArgs),
    /// Do a demonstrated task in a new scene (any arm, transfers, re-grasps).
    Execute(execute::ExecuteArgs),
    /// Calibrate the robot's eyes in the empty workcell and save the calibration to a file.
    Calibrate(calibrate::CalibrateArgs),
    /// Check an MCAP file (and repair one that was cut short).
    Doctor(doctor::DoctorArgs),
    /// The seed's procedural-learning experiments on features rendered from an object catalog.
    #[command(subcommand)]
    Experiment(experiment::ExperimentCommand),
    /// Record a teleoperated demonstration in the simulator (scripted teacher or a glove/mocap file).
    Record(record::RecordArgs),
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            // Usage errors go to stderr with exit code 2, --help / --version to stdout with 0.
            let _ = e.print();
            return ExitCode::from(u8::try_from(e.exit_code()).unwrap_or(2));
        }
    };
    // PBD_THREADS, when set, must be a count (it was once ignored silently when it was not).
    let from_env = match std::env::var("PBD_THREADS") {
        Ok(s) if cli.threads.is_none() && !s.trim().is_empty() => match s.trim().parse::<usize>() {
            Ok(n) => Some(n),
            Err(_) => {
                eprintln!("error: PBD_THREADS={s:?} is not a number of threads (unset it, or give a count such as 2)");
                return ExitCode::FAILURE;
            }
        },
        _ => None,
    };
    let rust_log = std::env::var("RUST_LOG").is_ok_and(|v| !v.trim().is_empty());
    progress::DIAGNOSTICS.store(cli.verbose > 0 || rust_log, std::sync::atomic::Ordering::Relaxed);
    if let Err(e) = pbd::logging::init(cli.verbose) {
        eprintln!("error: cannot install the diagnostics subscriber: {e}");
        return ExitCode::FAILURE;
    }
    let threads = cli.threads.or(from_env);
    if let Some(n) = threads
        && let Err(e) = pbd::parallel::set_threads(n)
    {
        eprintln!("error: {e:#}");
        return ExitCode::FAILURE;
    }
    // A panic anywhere (a library bug, a physics engine failing on a case validation missed) is
    // reported as an error with exit code 1, never an abort with a backtrace.
    let panic_message = std::sync::Arc::new(std::sync::Mutex::new(None::<String>));
    let sink = std::sync::Arc::clone(&panic_message);
    std::panic::set_hook(Box::new(move |info| {
        if let Ok(mut m) = sink.lock()
            && m.is_none()
        {
            *m = Some(info.to_string());
        }
    }));
    let stdout = io::stdout();
    let mut out = stdout.lock();
    let run = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| dispatch(cli.command, &mut out)));
    let result = run.unwrap_or_else(|_| {
        let what = panic_message.lock().ok().and_then(|m| m.clone()).unwrap_or_default();
        Err(anyhow::anyhow!(
            "internal error (a bug in pbd; please report it with the command that caused it): {what}"
        ))
    });
    let result = result.and_then(|()| out.flush().map_err(anyhow::Error::from));
    match result {
        Ok(()) => ExitCode::SUCCESS,
        // `pbd robot info | head` closes the pipe early: not an error worth reporting.
        Err(e) if is_broken_pipe(&e) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            // Stopped by Ctrl-C or SIGTERM: the shell's convention, 128 + SIGINT.
            if progress::interrupted() {
                ExitCode::from(130)
            } else {
                ExitCode::FAILURE
            }
        }
    }
}

fn is_broken_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        c.downcast_ref::<io::Error>()
            .is_some_and(|io| io.kind() == io::ErrorKind::BrokenPipe)
    })
}

fn dispatch(command: Command, out: &mut dyn Write) -> anyhow::Result<()> {
    match command {
        Command::Robot(cmd) => robot::main(cmd, out),
        Command::Sim(cmd) => sim::main(cmd, out),
        Command::Record(args) => record::main(args, out),
        Command::Grasp(cmd) => grasp::main(cmd, out),
        Command::Infer(args) => infer::main(args, out),
        Command::Doctor(args) => doctor::main(args, out),
        Command::Learn(args) => learn::main(args, out),
        Command::Demo(args) => demo::main(args, out),
        Command::Execute(args) => execute::main(args, out),
        Command::Calibrate(args) => calibrate::main(args, out),
        Command::Experiment(cmd) => experiment::main(cmd, out),
    }
}
