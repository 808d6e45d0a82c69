//! The calibration phase of a workcell: the world **before its objects are placed** — the same
//! table, places, robot, cameras and light, no objects — in which the robot runs its own
//! calibration routine ([`dexter::calibration::Calibration::capture`]) through [`SimRobot`], as it
//! would on a cleared table. This is the only time the world is seen without its objects; during a
//! task the robot predicts its backgrounds from these views.
//!
//! A workcell is calibrated once: [`workcell_calibration`] keeps the result per layout (the scene
//! without its objects, as text) for the process, so that every run in the same workcell shares it,
//! and its camera noise comes from a seed derived from the layout — the same calibration whatever
//! the run's seed or the order of runs.

use std::sync::{Arc, Mutex, OnceLock};

use dexter::calibration::{Calibration, CalibrationSettings};

use crate::error::SimError;
use crate::hardware::{SimRobot, parked_sim, workspace};
use crate::physics::SimSettings;
use crate::scene::Scene;

/// Layouts kept (the oldest is forgotten beyond this).
const CACHE_SIZE: usize = 32;

type Cache = Mutex<Vec<(String, Arc<Calibration>)>>;

fn cache() -> &'static Cache {
    static CACHE: OnceLock<Cache> = OnceLock::new();
    CACHE.get_or_init(|| Mutex::new(Vec::new()))
}

/// The workcell of `scene` without its objects, and its key (the layout as text).
pub fn empty_workcell(scene: &Scene) -> (Scene, String) {
    let mut empty = scene.clone();
    empty.spec.objects.clear();
    empty.resolved.clear();
    let mut layout = empty.spec.clone();
    layout.name.clear();
    layout.seed = 0;
    (empty, format!("{layout:?}"))
}

/// FNV-1a of `text`: the calibration's noise seed from its layout.
fn layout_seed(text: &str) -> u64 {
    text.bytes().fold(0xcbf2_9ce4_8422_2325_u64, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

/// The seed of the camera noise [`workcell_calibration`] calibrates `scene`'s workcell with
/// (derived from its layout: the same for every run in the workcell). [`calibrate`] with
/// the default settings and this seed gives the same calibration as [`workcell_calibration`].
pub fn workcell_seed(scene: &Scene) -> u64 {
    layout_seed(&empty_workcell(scene).1)
}

/// Runs the calibration phase of `scene`'s workcell: a fresh world without objects, the robot
/// parked, its calibration routine with `settings`, camera noise from `seed`.
pub fn calibrate(scene: &Scene, settings: &CalibrationSettings, seed: u64) -> Result<Calibration, SimError> {
    Ok(calibrate_timed(scene, settings, seed)?.0)
}

/// [`calibrate`], and the simulated time the routine took (s).
pub fn calibrate_timed(
    scene: &Scene,
    settings: &CalibrationSettings,
    seed: u64,
) -> Result<(Calibration, f64), SimError> {
    let (empty, _) = empty_workcell(scene);
    let mut sim = parked_sim(
        &empty,
        SimSettings {
            seed,
            ..SimSettings::default()
        },
    )?;
    let ws = workspace(&empty);
    let mut hw = SimRobot::new(&mut sim, &empty, seed)?;
    let t0 = hw.sim().time();
    let calibration = Calibration::capture(&mut hw, &ws, settings).map_err(crate::error::from_robot)?;
    Ok((calibration, hw.sim().time() - t0))
}

/// The calibration of `scene`'s workcell with the default settings, computed once per layout and
/// process ([`calibrate`] with a seed derived from the layout).
pub fn workcell_calibration(scene: &Scene) -> Result<Arc<Calibration>, SimError> {
    let (_, key) = empty_workcell(scene);
    if let Some((_, c)) = cache()
        .lock()
        .ok()
        .and_then(|c| c.iter().find(|(k, _)| *k == key).cloned())
    {
        return Ok(c);
    }
    let c = Arc::new(calibrate(scene, &CalibrationSettings::default(), layout_seed(&key))?);
    // Two threads may have calibrated the same layout at once: every caller gets the kept one.
    let Ok(mut cache) = cache().lock() else {
        return Ok(c);
    };
    if let Some((_, kept)) = cache.iter().find(|(k, _)| *k == key) {
        return Ok(kept.clone());
    }
    if cache.len() >= CACHE_SIZE {
        cache.remove(0);
    }
    cache.push((key, c.clone()));
    Ok(c)
}
