//! What the robot's eyes make of a scene, against the truth: the robot looks over the table as it
//! does before a task ([`dexter::exec::Workspace::scan_points`], 0.6 s per look) and the tracker's
//! segments are compared with the objects — centroid, height and footprint errors of the matched
//! ones, objects missed, phantom segments (no object within the gate) and duplicates (a second
//! segment of one object). The robot side sees only its cameras; this module reads the truth only to
//! judge.

use control_basis::math::Vec3;
use dexter::exec::{NoSink, RobotPlant};
use schema::Library;
use serde::Serialize;

use crate::error::{SimError, from_robot};
use crate::geometry::support_half_extent;
use crate::hardware::{SimRobot, parked_sim, workspace};
use crate::physics::SimSettings;
use crate::scene::Scene;

/// A segment within this distance (m, in the table plane) of an object's centre is a view of it
/// (the execute experiment's gate).
pub const MATCH_GATE: f64 = 0.08;

/// One object of a scene, as the robot saw it after its look over the table.
#[derive(Debug, Clone, Serialize)]
pub struct ObjectPerception {
    /// The object's label in the scene.
    pub object: String,
    /// Segments matched to it (0 = missed, 2 or more = duplicates).
    pub segments: usize,
    /// Distance in the table plane (m) from the nearest segment's centroid to the object's centre.
    pub centroid_error_xy: Option<f64>,
    /// Height error (m) of the nearest segment's centroid.
    pub centroid_error_z: Option<f64>,
    /// Measured minus true height above the table (m), when the segment has an extent.
    pub height_error: Option<f64>,
    /// Mean absolute error (m) of the footprint's two half extents (along the measured major axis
    /// and across it) against the object's true half extents along the same directions.
    pub footprint_error: Option<f64>,
}

/// The robot's view of one scene.
#[derive(Debug, Clone, Serialize)]
pub struct ScanReport {
    /// Per object.
    pub objects: Vec<ObjectPerception>,
    /// Segments on the table (not in a place) that match no object.
    pub phantoms: usize,
}

/// Looks over the table of `scene` as the robot does before a task (run seed `seed`) and compares
/// its tracked segments with the truth.
pub fn scan_scene(scene: &Scene, seed: u64) -> Result<ScanReport, SimError> {
    let mut sim = parked_sim(
        scene,
        SimSettings {
            seed,
            ..SimSettings::default()
        },
    )?;
    let table_z = scene.spec.table.height;
    let ws = workspace(scene);
    let calibration = crate::calibrate::workcell_calibration(scene)?;
    // The truth at the start: centre, true height above the table and shape of every object.
    let truth: Vec<(String, Vec3, f64, crate::scene::Shape, control_basis::math::Iso3)> = sim
        .objects()
        .iter()
        .enumerate()
        .map(|(i, o)| {
            let pose = sim.object_state(i).pose;
            let height = sim
                .world()
                .colliders
                .get(o.collider)
                .map_or(0.0, |c| c.compute_aabb().maxs.z - table_z);
            let shape = scene.catalog.objects[o.catalog_index].shape.clone();
            (o.name.clone(), pose.translation.vector, height, shape, pose)
        })
        .collect();
    let library = Library::builtin();
    let mut sink = NoSink;
    let mut hw = SimRobot::new(&mut sim, scene, seed)?;
    let segments = {
        let mut plant = RobotPlant::new(&mut hw, &ws, calibration, &library, &mut sink).map_err(from_robot)?;
        dexter::task::look_over_table(&mut plant).map_err(from_robot)?
    };
    let mut used = vec![false; segments.len()];
    let mut objects = Vec::with_capacity(truth.len());
    for (name, centre, height, shape, pose) in &truth {
        let near: Vec<(f64, usize)> = segments
            .iter()
            .enumerate()
            .map(|(k, s)| ((Vec3::from(s.centroid) - centre).xy().norm(), k))
            .filter(|(d, _)| *d < MATCH_GATE)
            .collect();
        for &(_, k) in &near {
            used[k] = true;
        }
        let best = near
            .iter()
            .min_by(|a, b| a.0.total_cmp(&b.0))
            .map(|&(_, k)| &segments[k]);
        let extent = best.and_then(|s| s.extent.as_ref());
        let footprint_error = extent.map(|e| {
            let along = |d: [f64; 2]| {
                let world = Vec3::new(d[0], d[1], 0.0);
                support_half_extent(shape, &(pose.rotation.inverse() * world))
            };
            let major = e.major_axis;
            let minor = [-major[1], major[0]];
            0.5 * ((e.half_major - along(major)).abs() + (e.half_minor - along(minor)).abs())
        });
        objects.push(ObjectPerception {
            object: name.clone(),
            segments: near.len(),
            centroid_error_xy: best.map(|s| (Vec3::from(s.centroid) - centre).xy().norm()),
            centroid_error_z: best.map(|s| s.centroid[2] - centre.z),
            height_error: extent.map(|e| e.height - height),
            footprint_error,
        });
    }
    Ok(ScanReport {
        objects,
        phantoms: used.iter().filter(|u| !**u).count(),
    })
}

/// Scene `i` of the perception experiment with seed `seed`: the same random scene and run seed as
/// scene `i` of the execute experiment ([`crate::experiment::run_scene`]), looked over.
pub fn scan_trial(base: &Scene, objects: usize, seed: u64, i: usize) -> Result<ScanReport, SimError> {
    use rand::Rng as _;
    let scene = crate::experiment::random_scene(base, objects, &mut bayes::rng::stream(seed, i as u64))?;
    let run_seed = bayes::rng::stream(seed ^ 0x5EED_0F5C_E4E5, i as u64).next_u64();
    scan_scene(&scene, run_seed)
}

/// Median and maximum of a list of errors (m); `None` when it is empty.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct MedianMax {
    /// Median (m).
    pub median: f64,
    /// Maximum (m).
    pub max: f64,
}

impl MedianMax {
    /// Of `values` (NaN last); `None` if empty.
    pub fn of(mut values: Vec<f64>) -> Option<MedianMax> {
        if values.is_empty() {
            return None;
        }
        values.sort_by(f64::total_cmp);
        let n = values.len();
        let median = if n % 2 == 1 {
            values[n / 2]
        } else {
            0.5 * (values[n / 2 - 1] + values[n / 2])
        };
        Some(MedianMax {
            median,
            max: values[n - 1],
        })
    }
}

/// The perception experiment's figures over many scenes.
#[derive(Debug, Clone, Serialize)]
pub struct PerceptionSummary {
    /// Objects presented.
    pub objects: usize,
    /// Objects with no segment within [`MATCH_GATE`].
    pub missed: usize,
    /// Second and further segments of one object.
    pub duplicates: usize,
    /// Segments on the table matching no object.
    pub phantoms: usize,
    /// Centroid error in the table plane.
    pub centroid_xy: Option<MedianMax>,
    /// Centroid height error (absolute).
    pub centroid_z: Option<MedianMax>,
    /// Object height error (absolute).
    pub height: Option<MedianMax>,
    /// Footprint half-extent error.
    pub footprint: Option<MedianMax>,
}

/// Sums the scenes' reports.
pub fn summarize(reports: &[ScanReport]) -> PerceptionSummary {
    let all = || reports.iter().flat_map(|r| &r.objects);
    PerceptionSummary {
        objects: all().count(),
        missed: all().filter(|o| o.segments == 0).count(),
        duplicates: all().map(|o| o.segments.saturating_sub(1)).sum(),
        phantoms: reports.iter().map(|r| r.phantoms).sum(),
        centroid_xy: MedianMax::of(all().filter_map(|o| o.centroid_error_xy).collect()),
        centroid_z: MedianMax::of(all().filter_map(|o| o.centroid_error_z.map(f64::abs)).collect()),
        height: MedianMax::of(all().filter_map(|o| o.height_error.map(f64::abs)).collect()),
        footprint: MedianMax::of(all().filter_map(|o| o.footprint_error).collect()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_and_max() {
        assert_eq!(MedianMax::of(vec![]), None);
        assert_eq!(
            MedianMax::of(vec![0.3, 0.1, 0.2]),
            Some(MedianMax { median: 0.2, max: 0.3 })
        );
        assert_eq!(
            MedianMax::of(vec![0.4, 0.1, 0.2, 0.3]),
            Some(MedianMax { median: 0.25, max: 0.4 })
        );
    }
}
