//! `pbd sim`: run Dexter in simulation.
//!
//! `pbd sim pick-place` does one pick-and-place with control-basis controllers (Reach ◁ Manipulability,
//! Grasp, Place) on a scene (built-in name or TOML file) and reports success, simulated and wall time
//! and the real-time factor; `--mcap` records the run for Foxglove.

use std::cell::RefCell;
use std::fmt;
use std::path::PathBuf;

use dexter_sim::Arm;
use dexter_sim::physics::{DEXTER_URDF, DexterSim, SimSettings};
use dexter_sim::pick_place::{PickPlaceReport, PickPlaceRequest, WorldObserver, pick_and_place_in};
use dexter_sim::scene::Scene;
use dexter_sim::vision::Image;
use serde::{Deserialize, Serialize};

use crate::mcap_log::{LogLevel, McapLog};
use crate::progress::Progress;

/// Which arm: left, right or auto (one that reaches both the object and the place).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum ArmChoice {
    /// The left arm.
    Left,
    /// The right arm.
    Right,
    /// Choose an arm that reaches both the object and the place.
    #[default]
    Auto,
}

impl ArmChoice {
    /// The arm asked for, or `None` for [`ArmChoice::Auto`].
    pub fn arm(self) -> Option<Arm> {
        match self {
            ArmChoice::Left => Some(Arm::Left),
            ArmChoice::Right => Some(Arm::Right),
            ArmChoice::Auto => None,
        }
    }
}

/// Options of [`pick_place`].
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PickPlaceOptions {
    /// Scene: a built-in name (pick-place, sorting, sorting-new) or a TOML file.
    pub scene: String,
    /// Object to pick (presentation name as in the scene; default: the scene's first object).
    pub object: Option<String>,
    /// Place to put it (default: the scene's first place).
    pub place: Option<String>,
    /// Arm to use.
    pub arm: ArmChoice,
    /// Seed of every random choice (encoder noise, placement jitter); default: the scene's seed.
    pub seed: Option<u64>,
    /// Record the run to this MCAP file (open it in Foxglove).
    pub mcap: Option<PathBuf>,
    /// Logging rate of the MCAP file (Hz of simulated time).
    pub log_hz: f64,
}

impl Default for PickPlaceOptions {
    fn default() -> Self {
        PickPlaceOptions {
            scene: "pick-place".into(),
            object: None,
            place: None,
            arm: ArmChoice::Auto,
            seed: None,
            mcap: None,
            log_hz: 30.0,
        }
    }
}

/// The outcome of [`pick_place`], and where it was recorded.
#[derive(Debug, Clone, Serialize)]
pub struct PickPlaceRun {
    /// The evaluator's report.
    #[serde(flatten)]
    pub report: PickPlaceReport,
    /// The MCAP recording, if one was asked for.
    pub mcap: Option<String>,
}

/// `pbd sim pick-place`: one pick-and-place with the robot's own skills, judged by the world.
///
/// Errors are [`crate::Error`]s: their [`crate::ErrorKind`] says what went wrong.
pub fn pick_place(args: &PickPlaceOptions, progress: &dyn Progress) -> crate::Result<PickPlaceRun> {
    pick_place_impl(args, progress).map_err(crate::Error::from)
}

fn pick_place_impl(args: &PickPlaceOptions, progress: &dyn Progress) -> anyhow::Result<PickPlaceRun> {
    // Config: every user mistake is reported here.
    let scene = Scene::open(&args.scene)?;
    let object = match &args.object {
        Some(o) => o.clone(),
        None => scene
            .spec
            .objects
            .first()
            .map(|o| o.presentation.clone())
            .ok_or_else(|| anyhow::anyhow!("scene `{}` has no objects to pick (add [[objects]] to it)", args.scene))?,
    };
    let place = match &args.place {
        Some(p) => p.clone(),
        None => scene.spec.places.first().map(|p| p.name.clone()).ok_or_else(|| {
            anyhow::anyhow!(
                "scene `{}` has no places to put an object (add [[places]] to it)",
                args.scene
            )
        })?,
    };
    scene.place(&place)?;
    if !(args.log_hz.is_finite() && args.log_hz > 0.0) {
        anyhow::bail!("log_hz must be a positive number (got {})", args.log_hz);
    }
    let seed = args.seed.unwrap_or(scene.spec.seed);
    let settings = SimSettings {
        seed,
        ..SimSettings::default()
    };
    let mut sim = DexterSim::new(&scene, settings)?;
    sim.object(&object)?;
    let request = PickPlaceRequest {
        object: object.clone(),
        place: place.clone(),
        arm: args.arm.arm(),
    };
    if let Some(path) = &args.mcap {
        crate::files::IoPlan::new()
            .read("--scene", &scene.path)
            .read("the scene's catalog", &scene.catalog.path)
            .write("--mcap", path)
            .check()?;
    }
    let log = match &args.mcap {
        Some(path) => {
            let mut log = McapLog::create(path)?;
            log.attach("dexter.urdf", "application/xml", DEXTER_URDF.as_bytes())?;
            let meta = [
                ("command", "sim pick-place".to_string()),
                ("scene", args.scene.clone()),
                ("object", object.clone()),
                ("place", place.clone()),
                ("seed", seed.to_string()),
            ];
            log.metadata("pbd", meta.into_iter().map(|(k, v)| (k.to_string(), v)).collect())?;
            log.log_scene(&scene, sim.header(), 0.0)?;
            log.log_robot(sim.model(), 0.0)?;
            Some(log)
        }
        None => None,
    };

    // Run.
    progress.phase("pick-place", None);
    let mut next_log = 0.0;
    let mut last_activity = String::new();
    // Both observers write to the one log; errors are kept and reported once the run is over.
    let log = RefCell::new(log);
    let log_error: RefCell<Option<anyhow::Error>> = RefCell::new(None);
    let keep = |r: anyhow::Result<()>| {
        if let Err(e) = r {
            log_error.borrow_mut().get_or_insert(e);
        }
    };
    let log_period = 1.0 / args.log_hz;
    let header = sim.header().clone();
    let mut callback = |s: &DexterSim, activity: &str| {
        let mut log = log.borrow_mut();
        if activity != last_activity {
            last_activity = activity.to_string();
            progress.message(&format!("{activity} (t = {:.1} s)", s.time()));
            if let Some(log) = log.as_mut() {
                keep(log.log_text(s.time(), LogLevel::Info, activity));
            }
        }
        if s.time() + 1e-9 >= next_log {
            next_log += log_period;
            if let Some(log) = log.as_mut() {
                keep(log.log_snapshot(&header, &s.snapshot(activity)));
            }
        }
    };
    let mut on_images = |t: f64, left: &Image, right: &Image| {
        if let Some(log) = log.borrow_mut().as_mut() {
            for (name, img) in [("head_left", left), ("head_right", right)] {
                keep(log.log_image(t, name, img.width, img.height, &img.rgb));
            }
        }
    };
    let report = pick_and_place_in(
        &mut sim,
        &scene,
        &request,
        &mut WorldObserver::new(&mut callback)
            .with_images(&mut on_images)
            .with_stop(&|| progress.should_stop()),
    )?;
    progress.finish();
    if let Some(e) = log_error.into_inner() {
        return Err(e.context("writing the MCAP log"));
    }
    if let Some(mut log) = log.into_inner() {
        log.log_text(
            sim.time(),
            if report.success {
                LogLevel::Info
            } else {
                LogLevel::Warning
            },
            &report.outcome,
        )?;
        log.finish()?;
    }
    Ok(PickPlaceRun {
        report,
        mcap: args.mcap.as_ref().map(|p| p.display().to_string()),
    })
}

impl fmt::Display for PickPlaceRun {
    fn fmt(&self, out: &mut fmt::Formatter<'_>) -> fmt::Result {
        let r = &self.report;
        writeln!(
            out,
            "pick-place `{}` → `{}` with the {} arm: {}",
            r.object,
            r.place,
            r.arm,
            if r.success { "SUCCESS" } else { "FAILED" }
        )?;
        writeln!(out, "  outcome      {}", r.outcome)?;
        writeln!(out, "  lifted       {}", r.lifted)?;
        writeln!(
            out,
            "  final        ({:.3}, {:.3}, {:.3}) m",
            r.final_position[0], r.final_position[1], r.final_position[2]
        )?;
        writeln!(out, "  sim time     {:.2} s in {} steps", r.sim_time, r.steps)?;
        writeln!(
            out,
            "  wall time    {:.2} s (real-time factor {:.2})",
            r.wall_time, r.real_time_factor
        )?;
        let phases: Vec<String> = r.phases.iter().map(|(n, t)| format!("{n} @{t:.2}s")).collect();
        writeln!(out, "  phases       {}", phases.join(", "))?;
        if let Some(p) = &self.mcap {
            writeln!(out, "  recording    {p} (open in Foxglove)")?;
        }
        Ok(())
    }
}

/// Options of [`generate_catalog`].
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CatalogOptions {
    /// Seed of every random choice: the same seed gives the same catalog.
    pub seed: u64,
    /// Objects per colour family (ten families).
    pub per_family: usize,
    /// The catalog file to write (TOML).
    pub output: PathBuf,
}

impl Default for CatalogOptions {
    fn default() -> Self {
        CatalogOptions {
            seed: 1,
            per_family: 8,
            output: PathBuf::from("catalog.toml"),
        }
    }
}

/// What [`generate_catalog`] wrote.
#[derive(Debug, Clone, Serialize)]
pub struct CatalogReport {
    /// The file.
    pub output: PathBuf,
    /// The seed.
    pub seed: u64,
    /// Objects per colour class.
    pub colors: std::collections::BTreeMap<String, usize>,
    /// Objects per size class.
    pub sizes: std::collections::BTreeMap<String, usize>,
    /// Presentations in all.
    pub presentations: usize,
}

impl fmt::Display for CatalogReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let list = |m: &std::collections::BTreeMap<String, usize>| {
            m.iter().map(|(k, v)| format!("{k} {v}")).collect::<Vec<_>>().join(", ")
        };
        writeln!(
            f,
            "catalog of seed {} → {}: {} objects, {} presentations",
            self.seed,
            self.output.display(),
            self.colors.values().sum::<usize>(),
            self.presentations
        )?;
        writeln!(f, "  colour classes: {}", list(&self.colors))?;
        writeln!(f, "  size classes: {}", list(&self.sizes))
    }
}

/// Writes a catalog drawn by [`dexter_sim::scene::generate::generate_catalog`] (colour families after
/// the basic colour terms, shapes and sizes in the hand's envelope, bands with caps and labels, the
/// labels a teacher would give), validated by reading it back.
///
/// Errors are [`crate::Error`]s: their [`crate::ErrorKind`] says what went wrong.
pub fn generate_catalog(args: &CatalogOptions) -> crate::Result<CatalogReport> {
    let run = || -> anyhow::Result<CatalogReport> {
        crate::limits::check_count(
            "per_family",
            args.per_family,
            dexter_sim::scene::MAX_CATALOG_OBJECTS / 10,
        )?;
        crate::files::IoPlan::new().write("-o", &args.output).check()?;
        let options = dexter_sim::scene::generate::GenerateOptions {
            per_family: args.per_family,
            ..Default::default()
        };
        let catalog = dexter_sim::scene::generate::generate_catalog(args.seed, &options);
        let text = format!(
            "# Generated by `pbd sim catalog --seed {} --per-family {}` (format: assets/README-scenes.md).\n{}",
            args.seed,
            args.per_family,
            catalog.to_toml()?
        );
        // What is written must load.
        dexter_sim::scene::Catalog::from_toml_str(&text, &args.output)?;
        crate::files::write_atomic(&args.output, text.as_bytes())?;
        let mut colors = std::collections::BTreeMap::new();
        let mut sizes = std::collections::BTreeMap::new();
        for o in &catalog.objects {
            *colors.entry(o.color_class.clone().unwrap_or_default()).or_insert(0) += 1;
            *sizes.entry(o.size_class.clone().unwrap_or_default()).or_insert(0) += 1;
        }
        Ok(CatalogReport {
            output: args.output.clone(),
            seed: args.seed,
            colors,
            sizes,
            presentations: catalog.presentation_names().len(),
        })
    };
    run().map_err(crate::Error::from)
}
