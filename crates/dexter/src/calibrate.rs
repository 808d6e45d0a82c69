//! The calibration routine ([`Calibration::head_poses`], [`Calibration::capture`]): the head visits a
//! grid of poses over the cleared table and the cameras' views of it become the background banks
//! (`calibration.rs` holds the result, which the eyes read).

use control_basis::Hardware;
use control_basis::hardware::Image;
use control_basis::math::Vec3;

use crate::body::Body;
use crate::calibration::{Calibration, CalibrationSettings};
use crate::error::RobotError;
use crate::exec::Workspace;
use crate::eyes::SELF_MARGIN;
use crate::eyes::{Pair, SearchTrack};
use crate::vision::background::mean_image;
use crate::vision::{BackgroundBank, BackgroundView, Camera, SelfModel};

/// Time between the frames averaged into one view (s): each is a new exposure.
const FRAME_GAP: f64 = 0.02;

impl Calibration {
    /// The head poses (pan, tilt) the calibration visits for `workspace`: a grid over the pan/tilt
    /// range that the table's corners and edge midpoints and the places (at 0.35 m above the table,
    /// where objects are carried) span, widened by the margin.
    pub fn head_poses(
        hw: &dyn Hardware,
        workspace: &Workspace,
        settings: &CalibrationSettings,
    ) -> Result<Vec<(f64, f64)>, RobotError> {
        let head = SearchTrack::new(hw)?;
        let mut body = Body::new();
        let (cx, cy) = (workspace.table_center[0], workspace.table_center[1]);
        let (hx, hy) = (workspace.table_size[0] / 2.0, workspace.table_size[1] / 2.0);
        let z = workspace.table_z;
        let mut targets = Vec::new();
        for sx in [-1.0, 0.0, 1.0] {
            for sy in [-1.0, 0.0, 1.0] {
                targets.push(Vec3::new(cx + sx * hx, cy + sy * hy, z));
            }
        }
        for p in &workspace.places {
            targets.push(Vec3::new(p.center[0], p.center[1], z + 0.35));
        }
        let (mut pan, mut tilt) = ((f64::INFINITY, f64::NEG_INFINITY), (f64::INFINITY, f64::NEG_INFINITY));
        for t in &targets {
            let (p, tl, _) = head.look_angles(hw, &mut body, t)?;
            pan = (pan.0.min(p), pan.1.max(p));
            tilt = (tilt.0.min(tl), tilt.1.max(tl));
        }
        let model = hw.model();
        let limits = |name: &str| -> Result<(f64, f64), RobotError> {
            let l = &model.joints[model.joint(name)?].limits;
            Ok((l.lower, l.upper))
        };
        let (pl, tl) = (limits("head/pan_joint")?, limits("head/tilt_joint")?);
        let grid = |range: (f64, f64), lim: (f64, f64), step: f64| -> Vec<f64> {
            let lo = (range.0 - settings.margin).max(lim.0);
            let hi = (range.1 + settings.margin).min(lim.1);
            if !(lo.is_finite() && hi.is_finite()) || hi <= lo {
                return vec![0.5 * (lim.0 + lim.1)];
            }
            let n = ((hi - lo) / step.max(1e-3)).ceil().max(1.0) as usize;
            (0..=n).map(|k| lo + (hi - lo) * k as f64 / n as f64).collect()
        };
        let pans = grid(pan, pl, settings.pan_step);
        let tilts = grid(tilt, tl, settings.tilt_step);
        // Serpentine order: neighbouring poses follow each other.
        let mut out = Vec::new();
        for (i, &t) in tilts.iter().enumerate() {
            if i % 2 == 0 {
                out.extend(pans.iter().map(|&p| (p, t)));
            } else {
                out.extend(pans.iter().rev().map(|&p| (p, t)));
            }
        }
        Ok(out)
    }

    /// Runs the calibration on `hw` (the workcell cleared of objects): the head visits
    /// [`Calibration::head_poses`], the chassis pair takes one view. Leaves the head at its last
    /// pose.
    pub fn capture(
        hw: &mut dyn Hardware,
        workspace: &Workspace,
        settings: &CalibrationSettings,
    ) -> Result<Calibration, RobotError> {
        let frames = settings.frames.max(1);
        let poses = Self::head_poses(hw, workspace, settings)?;
        let mut body = Body::new();
        let pan = hw.dof_index("head/pan_joint")?;
        let tilt = hw.dof_index("head/tilt_joint")?;
        let verge = [
            hw.dof_index("head/left_vergence_joint")?,
            hw.dof_index("head/right_vergence_joint")?,
        ];
        let mut banks: Vec<(String, BackgroundBank)> = Vec::new();
        let mut shots: Vec<Image> = vec![Image::default(); frames];
        let mut self_model = SelfModel::new(hw, SELF_MARGIN)?;
        let mut mask = Vec::new();
        let mut take = |hw: &mut dyn Hardware,
                        body: &mut Body,
                        banks: &mut Vec<(String, BackgroundBank)>,
                        pair: Pair|
         -> Result<(), RobotError> {
            let (l, r) = pair.camera_names();
            for name in [l, r] {
                let k = hw.camera_index(name)?;
                let info = hw.cameras()[k].clone();
                let camera = Camera::new(&info.intrinsics, body.pose(hw, &info.optical_frame)?)?;
                for (i, shot) in shots.iter_mut().enumerate() {
                    if i > 0 {
                        hw.advance(FRAME_GAP)?;
                    }
                    hw.capture(k, shot)?;
                }
                let image = mean_image(&shots)
                    .ok_or_else(|| RobotError::invalid("<calibration>", name, "the camera's frames changed size"))?;
                self_model.mask(hw, &camera, &mut mask)?;
                let valid = mask.iter().map(|m| !m).collect();
                let bank = match banks.iter().position(|(n, _)| n == name) {
                    Some(i) => &mut banks[i].1,
                    None => {
                        banks.push((name.to_string(), BackgroundBank::new(workspace.table_z)));
                        &mut banks.last_mut().expect("just pushed").1
                    }
                };
                bank.push(BackgroundView { camera, image, valid })?;
            }
            Ok(())
        };
        // The chassis pair first (fixed), then the head over its grid.
        take(hw, &mut body, &mut banks, Pair::Chassis)?;
        let vergence = (0.06_f64 / 1.0).atan();
        for &(p, t) in &poses {
            hw.set_joint_reference(pan, p, 0.0);
            hw.set_joint_reference(tilt, t, 0.0);
            hw.set_joint_reference(verge[0], -vergence, 0.0);
            hw.set_joint_reference(verge[1], vergence, 0.0);
            let mut waited = 0.0;
            loop {
                hw.advance(0.02)?;
                waited += 0.02;
                let q = hw.joint_positions();
                let qd = hw.joint_velocities();
                let err = [(pan, p), (tilt, t), (verge[0], -vergence), (verge[1], vergence)]
                    .iter()
                    .map(|&(j, r)| (q[j] - r).abs().max(0.1 * qd[j].abs()))
                    .fold(0.0, f64::max);
                if err < settings.settle_tolerance || waited >= settings.settle_timeout {
                    break;
                }
            }
            take(hw, &mut body, &mut banks, Pair::Head)?;
        }
        Ok(Calibration { banks })
    }
}
