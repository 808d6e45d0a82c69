//! Dexter's eyes in the simulator: the head's stereo pair (and the chassis pair) render the live scene
//! — objects where the physics put them, the robot's own links — and the vision pipeline turns the
//! images into segmented, stereo-matched, triangulated blobs (§5.1.2, §6.2.1).
//!
//! Search-Track (§3.2.2.1) is an image-based servo on the head: pan and tilt move so that the tracked
//! blob's mean image position (over both cameras) is at the image centre, and each camera's vergence
//! centres it in that camera; its convergence predicate says when the blob is foveated.

use control_basis::math::{Iso3, Vec3};
use control_basis::{Predicate, PredicateSettings, PredicateTracker};

use crate::convert::iso_from_glam;
use crate::error::SimError;
use crate::physics::DexterSim;
use crate::scene::Scene;
use crate::vision::{
    Camera, ItemLabel, Material, RenderItem, RenderScene, StereoBlob, StereoCameras, StereoConfig, StereoVision,
    SupportPlane,
};

/// Which stereo pair.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pair {
    /// The head's verging pair (moves with pan, tilt, vergence).
    Head,
    /// The fixed pair on the chassis.
    Chassis,
}

impl Pair {
    fn frames(self) -> (&'static str, &'static str) {
        match self {
            Pair::Head => ("head/left_camera_optical_frame", "head/right_camera_optical_frame"),
            Pair::Chassis => (
                "chassis/left_camera_optical_frame",
                "chassis/right_camera_optical_frame",
            ),
        }
    }
}

/// The render scene kept in step with the simulator, plus one vision pipeline per stereo pair.
#[derive(Debug)]
pub struct Eyes {
    scene: RenderScene,
    /// (render item index, collider world pose source) for every robot collider.
    robot_items: Vec<(usize, rapier3d_f64::prelude::ColliderHandle)>,
    /// Render item of each sim object.
    object_items: Vec<usize>,
    head: StereoVision,
    chassis: StereoVision,
    spec: crate::scene::CameraSpec,
    blobs: Vec<StereoBlob>,
}

impl Eyes {
    /// Builds the render scene of `scene` with `sim`'s robot and objects; noise from `seed`.
    pub fn new(sim: &DexterSim, scene: &Scene, seed: u64) -> Result<Self, SimError> {
        let mut rs = RenderScene::new();
        // Static parts and the objects, as the physics built them.
        let from_scene = RenderScene::from_scene(scene);
        for item in &from_scene.items {
            if item.label == ItemLabel::Static {
                rs.push(item.clone());
            }
        }
        let mut object_items = Vec::new();
        for (i, o) in sim.objects().iter().enumerate() {
            let spec = &scene.catalog.objects[o.catalog_index];
            let pose = sim.object_state(i).pose;
            object_items.push(rs.push(RenderItem::from_catalog(
                &spec.shape,
                pose,
                &spec.colors,
                ItemLabel::Object(i),
            )));
        }
        let mut robot_items = Vec::new();
        let world = sim.world();
        for h in sim.robot_colliders() {
            if let Some(c) = world.colliders.get(h) {
                let item = RenderItem {
                    shape: c.shared_shape().clone(),
                    world_from_shape: iso_from_glam(c.position()),
                    object_from_shape: Iso3::identity(),
                    material: Material::Uniform([210.0, 0.08, 0.55]),
                    label: ItemLabel::Robot,
                };
                robot_items.push((rs.push(item), h));
            }
        }
        let spec = scene.spec.camera.clone();
        // Objects rest on the known table plane: centroids from the support-plane estimate.
        let config = StereoConfig {
            support: Some(SupportPlane::at(scene.spec.table.height)),
            ..StereoConfig::default()
        };
        let mut head = StereoVision::new(&spec, &scene.spec.light, seed)?;
        head.set_config(config);
        let mut chassis = StereoVision::new(&spec, &scene.spec.light, seed ^ 0xC4A5_5150)?;
        chassis.set_config(config);
        Ok(Eyes {
            head,
            chassis,
            scene: rs,
            robot_items,
            object_items,
            spec,
            blobs: Vec::new(),
        })
    }

    /// Moves every object and robot link of the render scene to where the physics has it.
    pub fn sync(&mut self, sim: &DexterSim) {
        for (i, &k) in self.object_items.iter().enumerate() {
            let pose = sim.object_state(i).pose;
            self.scene.items[k].set_object_pose(&pose);
        }
        let world = sim.world();
        for &(k, h) in &self.robot_items {
            if let Some(c) = world.colliders.get(h) {
                self.scene.items[k].world_from_shape = iso_from_glam(c.position());
            }
        }
    }

    /// The two cameras of `pair` where the robot's kinematics put them now.
    pub fn cameras(&self, sim: &DexterSim, pair: Pair) -> Result<StereoCameras, SimError> {
        let (l, r) = pair.frames();
        Ok(StereoCameras {
            left: Camera::from_spec(&self.spec, sim.link_pose_by_name(l)?)?,
            right: Camera::from_spec(&self.spec, sim.link_pose_by_name(r)?)?,
        })
    }

    /// Syncs, renders `pair` and returns the stereo blobs.
    pub fn perceive(&mut self, sim: &DexterSim, pair: Pair) -> Result<&[StereoBlob], SimError> {
        self.sync(sim);
        let cams = self.cameras(sim, pair)?;
        let vision = match pair {
            Pair::Head => &mut self.head,
            Pair::Chassis => &mut self.chassis,
        };
        vision.perceive_into(&cams, &self.scene, &mut self.blobs)?;
        Ok(&self.blobs)
    }

    /// The blobs of the last [`Eyes::perceive`].
    pub fn blobs(&self) -> &[StereoBlob] {
        &self.blobs
    }

    /// The last images of `pair` (left, right).
    pub fn images(&self, pair: Pair) -> (&crate::vision::Image, &crate::vision::Image) {
        let v = match pair {
            Pair::Head => &self.head,
            Pair::Chassis => &self.chassis,
        };
        (
            v.renderer(crate::vision::Side::Left).image(),
            v.renderer(crate::vision::Side::Right).image(),
        )
    }

    /// The render scene.
    pub fn render_scene(&self) -> &RenderScene {
        &self.scene
    }
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
    /// The head's motor units of `sim`.
    pub fn new(sim: &DexterSim) -> Result<Self, SimError> {
        Ok(SearchTrack {
            pan: sim.dof("head/pan_joint")?,
            tilt: sim.dof("head/tilt_joint")?,
            verge: [
                sim.dof("head/left_vergence_joint")?,
                sim.dof("head/right_vergence_joint")?,
            ],
            gain: 4.0,
            tracker: PredicateTracker::new(PredicateSettings {
                epsilon: 1e-4,
                ..PredicateSettings::default()
            })?,
        })
    }

    /// Points the head (pan, tilt, symmetric vergence) at the world point `target` — the search
    /// phase, before a blob is foveated.
    pub fn look_at(&self, sim: &mut DexterSim, target: &Vec3) -> Result<(), SimError> {
        let tilt_axis = sim.link_pose_by_name("head/pan_link")?.translation.vector + Vec3::new(0.0, 0.0, 0.1);
        let d = target - tilt_axis;
        let pan = d.y.atan2(d.x);
        let tilt = (-d.z).atan2((d.x * d.x + d.y * d.y).sqrt());
        let dist = d.norm().max(0.1);
        let verge = (0.06 / dist).atan();
        sim.set_joint_target(self.pan, pan, 0.0);
        sim.set_joint_target(self.tilt, tilt, 0.0);
        sim.set_joint_target(self.verge[0], -verge, 0.0);
        sim.set_joint_target(self.verge[1], verge, 0.0);
        Ok(())
    }

    /// One tracking tick of `dt` seconds on `blob`: image-based servo of pan/tilt on the mean image
    /// error and of each vergence on its own camera's error.
    pub fn track(&mut self, sim: &mut DexterSim, cams: &StereoCameras, blob: &StereoBlob, dt: f64) -> TrackObservation {
        let q = sim.joint_positions();
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
            sim.set_joint_target(self.pan, q_pan - k * eu, -self.gain * eu);
            sim.set_joint_target(self.tilt, q_tilt + k * ev, self.gain * ev);
            for (i, e) in errs.iter().enumerate() {
                if let Some((u, _)) = e {
                    // Differential part only: the common part is pan's job.
                    let du = u - eu;
                    sim.set_joint_target(self.verge[i], q_verge[i] - k * du, -self.gain * du);
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
