//! `pbd robot`: look at a robot model and evaluate the kinematics of its chains.
//!
//! The model is any URDF given as a positional argument, or Dexter (two WAM arms with BarrettHands and
//! a stereo head, `assets/dexter.urdf`) built into the binary, so that `pbd robot info` works with no
//! files at all. `info` and `fk` live in their own modules; this one holds what they share: loading
//! the model.

use std::path::{Path, PathBuf};

use anyhow::Context as _;
use control_basis::RobotModel;

pub mod fk;
pub mod info;

pub use fk::{FkOptions, FkReport, fk};
pub use info::{RobotSummary, info};

/// The built-in default model: Dexter, the UMass bimanual humanoid of the dissertation.
pub const DEXTER_URDF: &str = dexter_sim::physics::DEXTER_URDF;

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
