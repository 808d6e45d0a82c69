//! Dexter's eyes: the head's verging stereo pair (and the fixed chassis pair), read through
//! [`Hardware::capture`], turned into segmented, stereo-matched, triangulated blobs (§5.1.2, §6.2.1).
//! The cameras' poses come from the robot's kinematics at the encoder readings.
//!
//! Search-Track (§3.2.2.1) is an image-based servo on the head: pan and tilt move so that the tracked
//! blob's mean image position (over both cameras) is at the image centre, and each camera's vergence
//! centres it in that camera; its convergence predicate says when the blob is foveated.

use std::sync::Arc;

use control_basis::hardware::{Camera, Image};
use control_basis::math::Vec3;
use control_basis::{Hardware, Predicate, PredicateSettings, PredicateTracker};

use crate::body::Body;
use crate::calibration::Calibration;
use crate::error::RobotError;
use crate::vision::{
    Frame, SegmentConfig, SelfModel, StereoBlob, StereoCameras, StereoConfig, StereoPipeline, WarpScratch,
};

/// The backgrounds are warped again when a camera moved by more than this (px at the image scale).
const REWARP_PIXELS: f64 = 0.25;

/// Margin (m) by which the self-model's shapes are inflated (encoder noise, calibration error).
pub(crate) const SELF_MARGIN: f64 = 0.002;

/// Which stereo pair.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pair {
    /// The head's verging pair (moves with pan, tilt, vergence).
    Head,
    /// The fixed pair on the chassis.
    Chassis,
}

impl Pair {
    /// The camera names (left, right) of the pair.
    pub fn camera_names(self) -> (&'static str, &'static str) {
        match self {
            Pair::Head => ("head/left", "head/right"),
            Pair::Chassis => ("chassis/left", "chassis/right"),
        }
    }

    fn index(self) -> usize {
        match self {
            Pair::Head => 0,
            Pair::Chassis => 1,
        }
    }
}

/// One stereo pair's devices and buffers.
#[derive(Debug)]
struct PairState {
    cameras: [usize; 2],
    names: [String; 2],
    frames: [String; 2],
    pipeline: StereoPipeline,
    images: [Image; 2],
    masks: [Vec<bool>; 2],
    /// The background interval of each camera at its current pose (lower, upper).
    backgrounds: [(Image, Image); 2],
    coverage: [f64; 2],
}

/// The stereo pipelines of both pairs with their buffers, and the last blobs.
#[derive(Debug)]
pub struct Eyes {
    pairs: [PairState; 2],
    body: Body,
    blobs: Vec<StereoBlob>,
    calibration: Arc<Calibration>,
    self_model: SelfModel,
    scratch: WarpScratch,
}

impl Eyes {
    /// Eyes on `hw`'s cameras with the backgrounds of `calibration` (every camera of both pairs
    /// must have a bank, and it must have been taken with these cameras:
    /// [`Calibration::check_cameras`]); objects rest on the table plane at `table_z` (their centroids, heights
    /// and footprints come from the support-plane estimate). The self-mask comes from the robot's
    /// own model ([`SelfModel`]).
    pub fn new(hw: &dyn Hardware, table_z: f64, calibration: Arc<Calibration>) -> Result<Self, RobotError> {
        calibration.check_cameras(hw.cameras())?;
        let pair = |p: Pair| -> Result<PairState, RobotError> {
            let (l, r) = p.camera_names();
            for name in [l, r] {
                if calibration.bank(name).is_none_or(|b| b.is_empty()) {
                    return Err(RobotError::invalid(
                        "<calibration>",
                        name,
                        "this camera has no calibration views of the empty workspace",
                    ));
                }
            }
            let cameras = [hw.camera_index(l)?, hw.camera_index(r)?];
            let info = &hw.cameras()[cameras[0]];
            let config = StereoConfig::on_table(table_z, info.pixel_noise);
            Ok(PairState {
                frames: [
                    hw.cameras()[cameras[0]].optical_frame.clone(),
                    hw.cameras()[cameras[1]].optical_frame.clone(),
                ],
                cameras,
                names: [l.to_string(), r.to_string()],
                pipeline: StereoPipeline::new(SegmentConfig::for_noise(info.pixel_noise), config),
                images: [Image::default(), Image::default()],
                masks: [Vec::new(), Vec::new()],
                backgrounds: Default::default(),
                coverage: [0.0; 2],
            })
        };
        Ok(Eyes {
            pairs: [pair(Pair::Head)?, pair(Pair::Chassis)?],
            body: Body::new(),
            blobs: Vec::new(),
            self_model: SelfModel::new(hw, SELF_MARGIN)?,
            calibration,
            scratch: WarpScratch::default(),
        })
    }

    /// The calibration the eyes warp their backgrounds from.
    pub fn calibration(&self) -> &Arc<Calibration> {
        &self.calibration
    }

    /// Fraction of each camera's pixels (left, right) of `pair` that some calibration view covered
    /// at the last warp (pixels outside are never foreground).
    pub fn coverage(&self, pair: Pair) -> [f64; 2] {
        self.pairs[pair.index()].coverage
    }

    /// The two cameras of `pair` where the robot's kinematics put them now.
    pub fn cameras(&mut self, hw: &dyn Hardware, pair: Pair) -> Result<StereoCameras, RobotError> {
        let p = &self.pairs[pair.index()];
        let (il, ir) = (
            &hw.cameras()[p.cameras[0]].intrinsics,
            &hw.cameras()[p.cameras[1]].intrinsics,
        );
        let (fl, fr) = (p.frames[0].clone(), p.frames[1].clone());
        Ok(StereoCameras {
            left: Camera::new(il, self.body.pose(hw, &fl)?)?,
            right: Camera::new(ir, self.body.pose(hw, &fr)?)?,
        })
    }

    /// Captures `pair` and returns the stereo blobs. The backgrounds are predicted from the
    /// calibration views for the cameras' pose ([`crate::vision::BackgroundBank::render`], again
    /// whenever a camera moved by more than a quarter pixel) and the self-masks drawn from the
    /// robot's model at the encoder readings.
    pub fn perceive(&mut self, hw: &mut dyn Hardware, pair: Pair) -> Result<&[StereoBlob], RobotError> {
        let cams = self.cameras(hw, pair)?;
        let p = &mut self.pairs[pair.index()];
        if p.pipeline.background_moved(&cams, REWARP_PIXELS) {
            for (k, cam) in [&cams.left, &cams.right].into_iter().enumerate() {
                let bank = self.calibration.bank(&p.names[k]).ok_or_else(|| {
                    RobotError::invalid("<calibration>", &p.names[k], "this camera was not calibrated")
                })?;
                let (lo, hi) = &mut p.backgrounds[k];
                p.coverage[k] = bank.render(cam, lo, hi, &mut self.scratch);
            }
            let [(l0, l1), (r0, r1)] = &p.backgrounds;
            p.pipeline.set_background_ranges(&cams, (l0, l1), (r0, r1))?;
        }
        // Both views of the pair at one instant (the simulator renders them on two cores).
        hw.capture_many(&p.cameras, &mut p.images)?;
        for (k, cam) in [&cams.left, &cams.right].into_iter().enumerate() {
            self.self_model.mask(hw, cam, &mut p.masks[k])?;
        }
        // A covered (or dead) camera sees nothing — not one object filling the view: no blobs from
        // this frame, so the tracker loses the objects until the view clears.
        if p.images.iter().any(covered) {
            self.blobs.clear();
            return Ok(&self.blobs);
        }
        let frames = [
            Frame {
                image: &p.images[0],
                self_mask: &p.masks[0],
            },
            Frame {
                image: &p.images[1],
                self_mask: &p.masks[1],
            },
        ];
        p.pipeline.process(&cams, frames, &mut self.blobs)?;
        Ok(&self.blobs)
    }

    /// The blobs of the last [`Eyes::perceive`].
    pub fn blobs(&self) -> &[StereoBlob] {
        &self.blobs
    }

    /// The last images of `pair` (left, right).
    pub fn images(&self, pair: Pair) -> (&Image, &Image) {
        let p = &self.pairs[pair.index()];
        (&p.images[0], &p.images[1])
    }

    /// The last self-masks of `pair` (left, right): `true` where the robot's model covers the pixel.
    pub fn self_masks(&self, pair: Pair) -> (&[bool], &[bool]) {
        let p = &self.pairs[pair.index()];
        (&p.masks[0], &p.masks[1])
    }

    /// The pipeline of `pair` (segmenters, settings).
    pub fn pipeline(&self, pair: Pair) -> &StereoPipeline {
        &self.pairs[pair.index()].pipeline
    }

    /// The pipeline of `pair`, to change its settings ([`StereoPipeline::set_config`]).
    pub fn pipeline_mut(&mut self, pair: Pair) -> &mut StereoPipeline {
        &mut self.pairs[pair.index()].pipeline
    }
}

/// Whether an image is (nearly) black throughout — the lens covered: mean brightness below 4 of
/// 255.
pub fn covered(image: &Image) -> bool {
    let n = image.rgb.len().max(1) as u64;
    let sum: u64 = image.rgb.iter().map(|&b| u64::from(b)).sum();
    sum < 4 * n
}

/// Search-Track on the head (§3.2.2.1): foveate a blob with pan, tilt and vergence.
#[derive(Debug, Clone)]
pub struct SearchTrack {
    pan: usize,
    tilt: usize,
    verge: [usize; 2],
    /// Servo gain (1/s).
    pub gain: f64,
    tracker: PredicateTracker,
}

/// What Search-Track saw on one tick.
#[derive(Debug, Clone, Copy)]
pub struct TrackObservation {
    /// The tracked blob's triangulated centroid (if seen by both cameras).
    pub centroid: Option<Vec3>,
    /// Image error (normalised, rad-like units) that the servo drives to zero.
    pub error: f64,
    /// Convergence predicate of the tracking controller.
    pub predicate: Predicate,
}

impl SearchTrack {
    /// The head's motor units of `hw`.
    pub fn new(hw: &dyn Hardware) -> Result<Self, RobotError> {
        Ok(SearchTrack {
            pan: hw.dof_index("head/pan_joint")?,
            tilt: hw.dof_index("head/tilt_joint")?,
            verge: [
                hw.dof_index("head/left_vergence_joint")?,
                hw.dof_index("head/right_vergence_joint")?,
            ],
            gain: 4.0,
            tracker: PredicateTracker::new(PredicateSettings {
                epsilon: 1e-4,
                ..PredicateSettings::default()
            })?,
        })
    }

    /// Points the head (pan, tilt, symmetric vergence) at the world point `target` — the search
    /// phase, before a blob is foveated. The pan axis comes from the robot's kinematics.
    pub fn look_at(&self, hw: &mut dyn Hardware, body: &mut Body, target: &Vec3) -> Result<(), RobotError> {
        let (pan, tilt, d) = self.look_angles(hw, body, target)?;
        let dist = d.norm().max(0.1);
        let verge = (0.06 / dist).atan();
        hw.set_joint_reference(self.pan, pan, 0.0);
        hw.set_joint_reference(self.tilt, tilt, 0.0);
        hw.set_joint_reference(self.verge[0], -verge, 0.0);
        hw.set_joint_reference(self.verge[1], verge, 0.0);
        Ok(())
    }

    /// The pan and tilt that point the head at `target`, and the vector from the tilt axis to it.
    pub fn look_angles(
        &self,
        hw: &dyn Hardware,
        body: &mut Body,
        target: &Vec3,
    ) -> Result<(f64, f64, Vec3), RobotError> {
        let tilt_axis = body.pose(hw, "head/pan_link")?.translation.vector + Vec3::new(0.0, 0.0, 0.1);
        let d = target - tilt_axis;
        let pan = d.y.atan2(d.x);
        let tilt = (-d.z).atan2((d.x * d.x + d.y * d.y).sqrt());
        Ok((pan, tilt, d))
    }

    /// Whether the head can point at `target` with its pan and tilt at least `margin` (rad) inside
    /// their joint limits: a point the head must strain to the limit for is seen at the image's
    /// edge by one camera at most, and stereo fails there.
    pub fn can_look_at(
        &self,
        hw: &dyn Hardware,
        body: &mut Body,
        target: &Vec3,
        margin: f64,
    ) -> Result<bool, RobotError> {
        let (pan, tilt, _) = self.look_angles(hw, body, target)?;
        let model = hw.model();
        let within = |name: &str, q: f64| -> Result<bool, RobotError> {
            let j = model.joint(name)?;
            let l = &model.joints[j].limits;
            Ok(q >= l.lower + margin && q <= l.upper - margin)
        };
        Ok(within("head/pan_joint", pan)? && within("head/tilt_joint", tilt)?)
    }

    /// One tracking tick of `dt` seconds on `blob`: image-based servo of pan/tilt on the mean image
    /// error and of each vergence on its own camera's error.
    pub fn track(
        &mut self,
        hw: &mut dyn Hardware,
        cams: &StereoCameras,
        blob: &StereoBlob,
        dt: f64,
    ) -> TrackObservation {
        let q = hw.joint_positions();
        let (q_pan, q_tilt, q_verge) = (q[self.pan], q[self.tilt], [q[self.verge[0]], q[self.verge[1]]]);
        let mut errs = [None, None];
        for (k, (seg, cam)) in [(&blob.left, &cams.left), (&blob.right, &cams.right)]
            .into_iter()
            .enumerate()
        {
            if let Some(s) = seg {
                let c = s.features.centroid;
                errs[k] = Some(((c[0] - cam.cx) / cam.fx, (c[1] - cam.cy) / cam.fy));
            }
        }
        let seen = errs.iter().flatten().count();
        let error = if seen == 0 {
            f64::INFINITY
        } else {
            let (eu, ev) = errs.iter().flatten().fold((0.0, 0.0), |a, e| (a.0 + e.0, a.1 + e.1));
            let (eu, ev) = (eu / seen as f64, ev / seen as f64);
            let k = self.gain * dt;
            // Image u grows to the right (pan negative), v downwards (tilt positive looks down).
            hw.set_joint_reference(self.pan, q_pan - k * eu, -self.gain * eu);
            hw.set_joint_reference(self.tilt, q_tilt + k * ev, self.gain * ev);
            for (i, e) in errs.iter().enumerate() {
                if let Some((u, _)) = e {
                    // Differential part only: the common part is pan's job.
                    let du = u - eu;
                    hw.set_joint_reference(self.verge[i], q_verge[i] - k * du, -self.gain * du);
                }
            }
            eu * eu + ev * ev
        };
        let predicate = self
            .tracker
            .update(if error.is_finite() { Some(error) } else { None }, dt);
        TrackObservation {
            centroid: blob.centroid,
            error,
            predicate,
        }
    }
}
