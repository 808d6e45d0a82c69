//! Finding an object again (Search-Track, [`locate_object`]) and choosing the arm that reaches it
//! ([`choose_arm`]).

use control_basis::Hardware;
use control_basis::math::Vec3;
use schema::{Failure, FailureCause};

use super::*;
use crate::arm::Arm;
use crate::body::Body;
use crate::error::RobotError;
use crate::eyes::{Eyes, Pair, SearchTrack};

/// Search-Track (§3.2.2.1): points the head at `nominal`, then foveates the blob nearest to the
/// running estimate at the camera rate (`frame_secs`) until the tracking predicate converges, and
/// returns what was seen — the mean triangulated centroid of the last frames, the extent and the
/// appearance feature b of §6.2.1 (the 2×2 second moment averaged over the stereo pair and the
/// frames) — with the cameras' mid-point. `Ok(Err(why))` if the object is not seen.
pub fn locate_object(
    hw: &mut dyn Hardware,
    eyes: &mut Eyes,
    nominal: &Vec3,
    table_z: f64,
    frame_secs: f64,
    obs: &mut Observer<'_>,
) -> Result<Result<Located, Failure>, RobotError> {
    let mut body = Body::new();
    let mut track = SearchTrack::new(hw)?;
    track.look_at(hw, &mut body, nominal)?;
    // Let the head get there (saccade).
    idle(hw, obs, 0.4);
    obs.check()?;
    let mut estimate = *nominal;
    let mut recent: Vec<(Vec3, [[f64; 2]; 2], StereoBlob, StereoCameras)> = Vec::new();
    for _frame in 0..40 {
        let cams = eyes.cameras(hw, Pair::Head)?;
        eyes.perceive(hw, Pair::Head)?;
        if let Some(f) = obs.images.as_mut() {
            let (l, r) = eyes.images(Pair::Head);
            f(hw, l, r);
        }
        let nearest = eyes
            .blobs()
            .iter()
            .filter(|b| b.left.is_some() && b.right.is_some())
            .filter_map(|b| b.centroid.map(|c| (b, (c - estimate).xy().norm())))
            .filter(|(_, d)| *d < 0.12)
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(b, _)| *b);
        match nearest {
            Some(blob) => {
                let o = track.track(hw, &cams, &blob, frame_secs);
                if let Some(c) = o.centroid {
                    estimate = c;
                    if o.error < 4e-4 && !blob.truncated() {
                        recent.push((c, blob.mean_covariance(), blob, cams.clone()));
                    } else {
                        recent.clear();
                    }
                }
            }
            None => recent.clear(),
        }
        if recent.len() >= 3 {
            let n = recent.len() as f64;
            let c = recent.iter().fold(Vec3::zeros(), |a, r| a + r.0) / n;
            let mut b = [[0.0; 2]; 2];
            for (_, m, _, _) in &recent {
                for i in 0..2 {
                    for j in 0..2 {
                        b[i][j] += m[i][j] / n;
                    }
                }
            }
            // Exactly symmetric (the two cameras' matrices are, up to rounding).
            let off = 0.5 * (b[0][1] + b[1][0]);
            b[0][1] = off;
            b[1][0] = off;
            let (_, _, blob, cams) = recent.last().expect("three frames");
            let mut extent = extent_of(blob, cams, table_z).expect("a triangulated blob");
            // The footprint centre from the averaged centroid when it is only a disc.
            if extent.model != "prism" {
                extent.center = [c.x, c.y];
            }
            let eye = 0.5 * (cams.left.position() + cams.right.position());
            return Ok(Ok(Located {
                seen: SeenObject { centroid: c, extent },
                appearance: b,
                eye,
                frames: recent.len(),
            }));
        }
        idle(hw, obs, frame_secs);
        obs.check()?;
    }
    Ok(Err(Failure::new(
        FailureCause::NotSeen,
        format!(
            "search-track: no stereo blob foveated near ({:.2}, {:.2}, {:.2})",
            nominal.x, nominal.y, nominal.z
        ),
    )))
}

/// What Search-Track found.
#[derive(Debug, Clone)]
pub struct Located {
    /// The object as seen.
    pub seen: SeenObject,
    /// b: the 2×2 second-moment matrix of the segment averaged over the stereo pair and the frames
    /// (px², §6.2.1).
    pub appearance: [[f64; 2]; 2],
    /// The cameras' mid-point.
    pub eye: Vec3,
    /// Frames averaged.
    pub frames: usize,
}

/// Chooses an arm among `candidates` that reaches the grasp of `seen` and the place at `place_xy`
/// (walls `wall_height`), preferring the one on the object's side. `Err(reasons)` if none does.
#[allow(clippy::too_many_arguments)]
pub fn choose_arm(
    hw: &dyn Hardware,
    candidates: &[Arm],
    arc: &[(f64, f64, f64)],
    seen: &SeenObject,
    place_xy: [f64; 2],
    wall_height: f64,
    table_z: f64,
) -> Result<Result<Arm, Failure>, RobotError> {
    let mut order = candidates.to_vec();
    if seen.centroid.y < 0.0 {
        order.reverse();
    }
    let mut reasons = Vec::new();
    for arm in order {
        let park = park_pose(arm, table_z);
        let plan = plan_top_grasp(arc, seen, table_z, &park);
        let mut over = plan.grasp;
        over.translation.vector.x = place_xy[0];
        over.translation.vector.y = place_xy[1];
        over.translation.vector.z = table_z + wall_height + 0.15;
        let g = reachable(hw.model(), arm, &plan.grasp, 3)?;
        let p = reachable(hw.model(), arm, &over, 4)?;
        if g && p {
            return Ok(Ok(arm));
        }
        reasons.push(format!(
            "{arm} arm {}",
            match (g, p) {
                (false, false) => "reaches neither the object nor the place",
                (false, true) => "does not reach the object",
                _ => "does not reach the place",
            }
        ));
    }
    Ok(Err(Failure::new(FailureCause::OutOfReach, reasons.join("; "))))
}
