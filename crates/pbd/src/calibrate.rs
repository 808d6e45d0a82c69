//! `pbd calibrate`: the robot calibrates its eyes in the empty workcell and the result is kept in a
//! file ([`dexter::calibration::file`]), which `pbd execute --calibration FILE` (and a real robot's
//! every later run) loads instead of calibrating again.
//!
//! [`calibrate()`] runs the robot's own routine ([`Calibration::capture`]) in the simulated
//! workcell of a scene with its objects taken away ([`dexter_sim::calibrate::calibrate`]) and writes
//! the file; by default with the noise seed of the workcell's layout, so that the file holds the
//! very calibration `pbd execute` computes when it is given none. [`calibrate_hardware`] runs the
//! same routine on any [`Hardware`] — a real robot's driver — and returns the calibration to save
//! with [`Calibration::save`].

use std::fmt;
use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context;
use control_basis::Hardware;
use dexter::calibration::{Calibration, CalibrationSettings};
use dexter::exec::Workspace;
use dexter_sim::scene::Scene;
use serde::{Deserialize, Serialize};

use crate::progress::Progress;

/// Options of [`calibrate()`].
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CalibrateOptions {
    /// Scene whose workcell (table, places, robot, cameras, light — not its objects) is calibrated:
    /// a built-in name (pick-place, sorting, sorting-new, sorting-demo) or a TOML file.
    pub scene: String,
    /// The calibration file to write.
    pub output: PathBuf,
    /// Seed of the cameras' noise; default: the workcell's own (derived from its layout), which
    /// gives the calibration `pbd execute` computes without `--calibration`.
    pub seed: Option<u64>,
}

impl Default for CalibrateOptions {
    /// The scene `pbd execute` runs in by default, written to `workcell.cal`.
    fn default() -> Self {
        CalibrateOptions {
            scene: "sorting-new".into(),
            output: PathBuf::from("workcell.cal"),
            seed: None,
        }
    }
}

/// One camera of a calibration.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CalibratedCamera {
    /// The camera's name (`head/left`, …).
    pub name: String,
    /// Views of the empty workspace it took.
    pub views: usize,
    /// Image width (px).
    pub width: u32,
    /// Image height (px).
    pub height: u32,
}

impl CalibratedCamera {
    /// The cameras of `calibration`, in its order.
    pub fn of(calibration: &Calibration) -> Vec<CalibratedCamera> {
        calibration
            .banks()
            .iter()
            .map(|(name, bank)| {
                let (width, height) = bank
                    .views()
                    .first()
                    .map_or((0, 0), |v| (v.camera.width, v.camera.height));
                CalibratedCamera {
                    name: name.clone(),
                    views: bank.views().len(),
                    width,
                    height,
                }
            })
            .collect()
    }
}

/// What [`calibrate()`] did.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct CalibrateReport {
    /// The scene whose workcell was calibrated (as given).
    pub scene: String,
    /// The seed of the cameras' noise.
    pub seed: u64,
    /// Per camera: its views and image size.
    pub cameras: Vec<CalibratedCamera>,
    /// Views over all cameras.
    pub views: usize,
    /// The calibration file written.
    pub file: String,
    /// Its size (bytes).
    pub bytes: u64,
    /// Simulated time the routine took (s).
    pub sim_time: f64,
    /// Wall time of the calibration (s).
    pub wall_time: f64,
    /// Wall time of encoding and writing the file (s).
    pub save_time: f64,
    /// Wall time of reading the written file back and checking it equals the calibration (s).
    pub load_time: f64,
}

impl fmt::Display for CalibrateReport {
    fn fmt(&self, out: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            out,
            "calibrated the empty workcell of `{}` (seed {}): {} cameras, {} views",
            self.scene,
            self.seed,
            self.cameras.len(),
            self.views
        )?;
        let mut t = crate::table::Table::new(["camera", "views", "image"]);
        for c in &self.cameras {
            t.row([c.name.clone(), c.views.to_string(), format!("{}×{}", c.width, c.height)]);
        }
        write!(out, "{}", t.render(2))?;
        writeln!(
            out,
            "  time         {:.1} s simulated, {:.1} s wall",
            self.sim_time, self.wall_time
        )?;
        writeln!(
            out,
            "  file         {} ({:.1} MB; written in {:.3} s, read back in {:.3} s)",
            self.file,
            self.bytes as f64 / 1e6,
            self.save_time,
            self.load_time
        )?;
        writeln!(out, "  use it       pbd execute --calibration {} …", self.file)
    }
}

/// `pbd calibrate`: the robot calibrates its eyes in the empty workcell of a scene (the simulated
/// one) and the calibration is written to a file, through a temporary file and a rename; the file
/// is then read back and checked to equal the calibration.
///
/// Errors are [`crate::Error`]s: their [`crate::ErrorKind`] says what went wrong.
pub fn calibrate(args: &CalibrateOptions, progress: &dyn Progress) -> crate::Result<CalibrateReport> {
    calibrate_impl(args, progress).map_err(crate::Error::from)
}

fn calibrate_impl(args: &CalibrateOptions, progress: &dyn Progress) -> anyhow::Result<CalibrateReport> {
    let scene = Scene::open(&args.scene)?;
    check_output(&scene, &args.output)?;
    let seed = args
        .seed
        .unwrap_or_else(|| dexter_sim::calibrate::workcell_seed(&scene));
    progress.phase("calibrate", None);
    progress.message(&format!("the empty workcell of `{}`", args.scene));
    let wall = Instant::now();
    let settings = CalibrationSettings::default();
    let (calibration, sim_time) = dexter_sim::calibrate::calibrate_timed(&scene, &settings, seed)?;
    let wall_time = wall.elapsed().as_secs_f64();
    save_and_report(
        &calibration,
        &args.scene,
        seed,
        &args.output,
        sim_time,
        wall_time,
        progress,
    )
}

/// Refuses `output` when it is the scene or its catalog, or cannot be written — before any work.
pub(crate) fn check_output(scene: &Scene, output: &std::path::Path) -> anyhow::Result<()> {
    crate::files::IoPlan::new()
        .read("--scene", &scene.path)
        .read("the scene's catalog", &scene.catalog.path)
        .write("-o", output)
        .check()?;
    crate::files::check_writable(output)
}

/// Writes `calibration` to `output` (a temporary file and a rename), reads it back, checks it is
/// equal, and reports it (how the calibration was made: `scene`, `seed`, `sim_time`, `wall_time`).
pub(crate) fn save_and_report(
    calibration: &Calibration,
    scene: &str,
    seed: u64,
    output: &std::path::Path,
    sim_time: f64,
    wall_time: f64,
    progress: &dyn Progress,
) -> anyhow::Result<CalibrateReport> {
    progress.message(&format!("writing {}", output.display()));
    let t = Instant::now();
    let bytes = calibration.to_bytes()?;
    crate::files::write_atomic(output, &bytes)?;
    let save_time = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let back = Calibration::load(output)?;
    let load_time = t.elapsed().as_secs_f64();
    anyhow::ensure!(
        &back == calibration,
        "{}: the file read back differs from the calibration (a bug in pbd; please report it)",
        output.display()
    );
    progress.finish();
    Ok(CalibrateReport {
        scene: scene.to_string(),
        seed,
        views: calibration.view_count(),
        cameras: CalibratedCamera::of(calibration),
        file: output.display().to_string(),
        bytes: bytes.len() as u64,
        sim_time,
        wall_time,
        save_time,
        load_time,
    })
}

/// Runs the robot's calibration routine ([`Calibration::capture`]) on `hw` — any [`Hardware`]: the
/// simulator's, a real robot's driver — in `workspace`, which must be cleared of objects. Save the
/// result with [`Calibration::save`] and give it to later runs.
///
/// Errors are [`crate::Error`]s: their [`crate::ErrorKind`] says what went wrong.
pub fn calibrate_hardware(
    hw: &mut impl Hardware,
    workspace: &Workspace,
    settings: &CalibrationSettings,
) -> crate::Result<Calibration> {
    Ok(Calibration::capture(hw, workspace, settings)?)
}

/// Loads the calibration file `path` for a run in `scene` with cameras `cameras` (the robot's):
/// refuses a file of other cameras ([`Calibration::check_cameras`]) and warns, through `progress`,
/// when its table plane is not the scene's table height.
pub fn load_for(
    path: &std::path::Path,
    cameras: &[control_basis::hardware::CameraInfo],
    scene: &Scene,
    progress: &dyn Progress,
) -> anyhow::Result<Calibration> {
    let calibration = Calibration::load(path)?;
    calibration.check_cameras(cameras).with_context(|| {
        format!(
            "--calibration {}: not a calibration of this robot's cameras",
            path.display()
        )
    })?;
    let table = scene.spec.table.height;
    if let Some((name, bank)) = calibration
        .banks()
        .iter()
        .find(|(_, b)| (b.plane_z() - table).abs() > 1e-6)
    {
        progress.warn(&format!(
            "--calibration {}: camera `{name}` was calibrated over a table at {:.3} m, the scene's table is at {table:.3} m \
             (a calibration of another workcell: backgrounds will be wrong; run `pbd calibrate` in this one)",
            path.display(),
            bank.plane_z()
        ));
    }
    Ok(calibration)
}
