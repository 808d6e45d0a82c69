//! `pbd robot`: look at a robot model and evaluate the kinematics of its chains.
//!
//! The model is any URDF given as a positional argument, or Dexter (two WAM arms with BarrettHands and
//! a stereo head, `assets/dexter.urdf`) built into the binary, so that `pbd robot info` works with no
//! files at all. `info` and `fk` live in their own files; this one holds what they share: the argument
//! naming the model and the loading of it.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::Context as _;
use clap::Subcommand;
use control_basis::RobotModel;

mod fk;
mod info;

/// The built-in default model: Dexter, the UMass bimanual humanoid of the dissertation.
pub const DEXTER_URDF: &str = include_str!("../../../assets/dexter.urdf");

/// `pbd robot …` subcommands.
#[derive(Debug, Subcommand)]
pub enum RobotCommand {
    /// Summarise a robot: links, joints, degrees of freedom with limits, mimic couplings and chains.
    Info(info::InfoArgs),
    /// Forward kinematics and Jacobian of the chain BASE -> TIP at joint values Q.
    Fk(fk::FkArgs),
}

/// Runs a `pbd robot` subcommand: config (load and validate), then run (compute and print to `out`).
pub fn main(cmd: RobotCommand, out: &mut dyn Write) -> anyhow::Result<()> {
    match cmd {
        RobotCommand::Info(args) => {
            let config = info::InfoConfig::new(args)?;
            info::run(&config, out)
        }
        RobotCommand::Fk(args) => {
            let config = fk::FkConfig::new(args)?;
            fk::run(&config, out)
        }
    }
}

/// Where a model came from, for the reader of the output.
#[derive(Debug, Clone)]
pub enum ModelSource {
    /// `assets/dexter.urdf`, compiled into the binary.
    BuiltinDexter,
    /// A URDF file named on the command line.
    File(PathBuf),
}

impl ModelSource {
    /// A short label: `built-in:dexter` or the path as given.
    pub fn label(&self) -> String {
        match self {
            ModelSource::BuiltinDexter => "built-in:dexter".into(),
            ModelSource::File(p) => p.display().to_string(),
        }
    }
}

/// A validated model and its origin.
#[derive(Debug)]
pub struct LoadedModel {
    /// Where it came from.
    pub source: ModelSource,
    /// The model.
    pub model: RobotModel,
}

/// Loads the URDF at `path`, or the built-in Dexter model when `path` is `None`.
pub fn load_model(path: Option<&Path>) -> anyhow::Result<LoadedModel> {
    match path {
        // The library's errors already name the file and say what is wrong with it.
        Some(p) => Ok(LoadedModel {
            source: ModelSource::File(p.to_path_buf()),
            model: RobotModel::from_urdf_file(p)?,
        }),
        None => Ok(LoadedModel {
            source: ModelSource::BuiltinDexter,
            model: RobotModel::from_urdf_str(DEXTER_URDF)
                .context("the built-in Dexter model does not load (a bug in this build of pbd)")?,
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builtin_dexter_loads() {
        let m = load_model(None).unwrap();
        assert_eq!(m.model.name, "dexter");
        assert!(m.model.actuated_joints().count() >= 14 + 4);
    }
}
