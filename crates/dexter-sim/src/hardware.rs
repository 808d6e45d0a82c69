//! Dexter's hardware in the simulator: [`SimRobot`] implements [`control_basis::Hardware`] on a
//! [`DexterSim`] — encoders (with the simulator's encoder noise), PD motor units, the six fingertip
//! force/torque sensors (from contact impulses, normal and friction), the head and chassis stereo
//! pairs (ray-cast renders of the live scene with pixel noise, and the background of the empty
//! scene), and the clock. This is the only door between the world and the robot side (`dexter`):
//! whatever the robot knows of objects, it saw through [`SimRobot::capture`] or felt through
//! [`SimRobot::read_force_torque`].
//!
//! **Self-mask.** A real robot renders its self-model at the measured joint angles to mask its own
//! body out of the foreground; here the renderer's label buffer supplies the same mask (the robot's
//! links at their true poses). It says nothing about objects.

use control_basis::hardware::{CameraInfo, ForceTorque, Hardware, HardwareError, Image};
use control_basis::math::Iso3;
use control_basis::{CbError, Plant, RobotModel};

use crate::convert::iso_from_glam;
use crate::error::SimError;
use crate::fault::model::Fault;
use crate::physics::DexterSim;
use crate::scene::Scene;
use crate::snapshot::{Arm, FingertipWrench};
use crate::vision::camera::SpecCamera;
use crate::vision::{Camera, ItemLabel, Material, RenderItem, RenderScene, Renderer};
use rand::Rng as _;

/// The cameras: (name, optical frame link).
pub const CAMERAS: [(&str, &str); 4] = [
    ("head/left", "head/left_camera_optical_frame"),
    ("head/right", "head/right_camera_optical_frame"),
    ("chassis/left", "chassis/left_camera_optical_frame"),
    ("chassis/right", "chassis/right_camera_optical_frame"),
];

/// Colour (HSV) of an obstacle put on the table during a run: a dull grey-brown, like a wooden
/// post, unlike the table, the bins and the catalog's objects.
pub const OBSTACLE_HSV: [f64; 3] = [30.0, 0.25, 0.45];

/// The render scene kept in step with the simulator and one noisy renderer per camera.
#[derive(Debug)]
pub struct SimCameras {
    scene: RenderScene,
    /// (render item index, collider) for every robot collider.
    robot_items: Vec<(usize, rapier3d_f64::prelude::ColliderHandle)>,
    /// Render item of each sim object.
    object_items: Vec<usize>,
    /// How many of the world's obstacles ([`DexterSim::obstacles`]) the render scene has.
    obstacles: usize,
    renderers: Vec<Renderer>,
    spec: crate::scene::CameraSpec,
    infos: Vec<CameraInfo>,
    synced_at: Option<u64>,
}

/// Noise seeds of the cameras: the left and right camera of each pair are streams 0 and 1 of the
/// pair's seed (`seed` for the head, `seed ^ 0xC4A5_5150` for the chassis).
fn camera_seed(seed: u64, camera: usize) -> u64 {
    let pair_seed = if camera < 2 { seed } else { seed ^ 0xC4A5_5150 };
    bayes::rng::stream(pair_seed, (camera % 2) as u64).next_u64()
}

impl SimCameras {
    /// The render scene of `scene` with `sim`'s robot and objects; noise from `seed`.
    pub fn new(sim: &DexterSim, scene: &Scene, seed: u64) -> Result<Self, SimError> {
        let mut rs = RenderScene::new();
        for item in RenderScene::from_scene(scene).items {
            if item.label == ItemLabel::Static {
                rs.push(item);
            }
        }
        let mut object_items = Vec::new();
        for (i, o) in sim.objects().iter().enumerate() {
            let spec = &scene.catalog.objects[o.catalog_index];
            object_items.push(rs.push(RenderItem::from_catalog(
                &spec.shape,
                sim.object_state(i).pose,
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
        crate::vision::camera::validate_spec(&spec)?;
        let renderers = (0..CAMERAS.len())
            .map(|k| Renderer::new(spec.pixel_noise, &scene.spec.light, camera_seed(seed, k)))
            .collect::<Result<Vec<_>, _>>()?;
        let infos = CAMERAS
            .iter()
            .map(|(name, frame)| CameraInfo {
                name: name.to_string(),
                optical_frame: frame.to_string(),
                intrinsics: spec.intrinsics(),
                pixel_noise: spec.pixel_noise,
            })
            .collect();
        Ok(SimCameras {
            scene: rs,
            robot_items,
            object_items,
            obstacles: 0,
            renderers,
            spec,
            infos,
            synced_at: None,
        })
    }

    /// Moves every object and robot link of the render scene to where the physics has it, and adds
    /// the obstacles put into the world since the last sync.
    pub fn sync(&mut self, sim: &DexterSim) {
        if self.synced_at == Some(sim.steps()) {
            return;
        }
        for (k, o) in sim.obstacles().iter().enumerate().skip(self.obstacles) {
            let h = o.half_extents;
            self.scene.push(RenderItem::uniform_box(
                [2.0 * h.x, 2.0 * h.y, 2.0 * h.z],
                o.pose,
                OBSTACLE_HSV,
                ItemLabel::Obstacle(k),
            ));
        }
        self.obstacles = sim.obstacles().len();
        for (i, &k) in self.object_items.iter().enumerate() {
            self.scene.items[k].set_object_pose(&sim.object_state(i).pose);
        }
        let world = sim.world();
        for &(k, h) in &self.robot_items {
            if let Some(c) = world.colliders.get(h) {
                self.scene.items[k].world_from_shape = iso_from_glam(c.position());
            }
        }
        self.synced_at = Some(sim.steps());
    }

    /// Camera `k` where the physics has it.
    pub fn camera(&self, sim: &DexterSim, k: usize) -> Result<Camera, SimError> {
        Camera::from_spec(&self.spec, sim.link_pose_by_name(CAMERAS[k].1)?)
    }

    /// The render scene.
    pub fn render_scene(&self) -> &RenderScene {
        &self.scene
    }

    /// The camera calibrations.
    pub fn infos(&self) -> &[CameraInfo] {
        &self.infos
    }

    /// Renders camera `k` into `out`.
    pub fn capture(&mut self, sim: &DexterSim, k: usize, out: &mut Image) -> Result<(), SimError> {
        self.sync(sim);
        let cam = self.camera(sim, k)?;
        let r = &mut self.renderers[k];
        r.render(&cam, &self.scene)?;
        out.copy_from(r.image());
        Ok(())
    }

    /// Renders cameras `ks[0]` and `ks[1]` (two different cameras) into `out`: the images two
    /// [`SimCameras::capture`] calls give, the second on a thread of its own when this run is not
    /// one of a parallel batch (inside rayon's pool every core already runs a scene, and a thread
    /// more per frame slowed a 20-scene experiment by 3.5 %): `pbd execute` 6.4 → 5.8 s.
    pub fn capture_two(&mut self, sim: &DexterSim, ks: [usize; 2], out: [&mut Image; 2]) -> Result<(), SimError> {
        let [oa, ob] = out;
        let in_batch = rayon::current_thread_index().is_some();
        if in_batch || ks[0] == ks[1] || ks[0].max(ks[1]) >= self.renderers.len() {
            self.capture(sim, ks[0], oa)?;
            return self.capture(sim, ks[1], ob);
        }
        self.sync(sim);
        let cams = [self.camera(sim, ks[0])?, self.camera(sim, ks[1])?];
        let (low, high) = (ks[0].min(ks[1]), ks[0].max(ks[1]));
        let (below, above) = self.renderers.split_at_mut(high);
        let (r_low, r_high) = (&mut below[low], &mut above[0]);
        let (ra, rb) = if ks[0] < ks[1] {
            (r_low, r_high)
        } else {
            (r_high, r_low)
        };
        let scene = &self.scene;
        let (a, b) = std::thread::scope(|threads| {
            let other = threads.spawn(|| rb.render(&cams[1], scene).map(|im| ob.copy_from(im)));
            let a = ra.render(&cams[0], scene).map(|im| oa.copy_from(im));
            (a, other.join().unwrap_or_else(|p| std::panic::resume_unwind(p)))
        });
        a.and(b)
    }

    /// The renderer's labels of camera `k`'s last capture, as a mask of the pixels whose first
    /// surface is the robot — **ground truth for evaluating** the robot's own self-mask; it never
    /// reaches the robot.
    pub fn true_self_mask(&self, k: usize, mask: &mut Vec<bool>) {
        crate::vision::stereo_sim::self_mask(self.renderers[k].labels(), mask);
    }
}

/// Receives the world after every advance of the hardware (for truth logs and snapshots).
pub type WorldHook<'a> = Box<dyn FnMut(&DexterSim) + 'a>;

/// Dexter's hardware on a [`DexterSim`]: what the robot side may use of the world.
pub struct SimRobot<'a> {
    sim: &'a mut DexterSim,
    cameras: SimCameras,
    ft_frames: Vec<String>,
    hook: Option<WorldHook<'a>>,
    stop: Option<StopRequest<'a>>,
    fault: Option<Fault>,
}

/// Asked before every advance: `true` ends the run with [`HardwareError::Interrupted`].
pub type StopRequest<'a> = Box<dyn FnMut() -> bool + 'a>;

impl std::fmt::Debug for SimRobot<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SimRobot")
            .field("time", &self.sim.time())
            .finish_non_exhaustive()
    }
}

fn hw_error(e: SimError) -> HardwareError {
    HardwareError::Device {
        device: "simulator".into(),
        message: e.to_string(),
    }
}

impl<'a> SimRobot<'a> {
    /// The hardware of `sim` in `scene`; camera noise from `seed`.
    pub fn new(sim: &'a mut DexterSim, scene: &Scene, seed: u64) -> Result<Self, SimError> {
        let cameras = SimCameras::new(sim, scene, seed)?;
        let ft_frames = (0..6)
            .map(|k| {
                let arm = if k < 3 { Arm::Left } else { Arm::Right };
                format!("{}/bhand/finger_{}/tip_link", arm.prefix(), k % 3 + 1)
            })
            .collect();
        Ok(SimRobot {
            sim,
            cameras,
            ft_frames,
            hook: None,
            stop: None,
            fault: None,
        })
    }

    /// Arms a fault ([`crate::fault`]): the world injects it when its trigger fires.
    pub fn with_fault(mut self, fault: Fault) -> Self {
        self.fault = Some(fault);
        self
    }

    /// The armed fault (for the evaluator's report — never for the robot side).
    pub fn fault(&self) -> Option<&Fault> {
        self.fault.as_ref()
    }

    /// Asks `stop` before every [`Hardware::advance`]; when it says `true`, the hardware refuses to
    /// move on ([`HardwareError::Interrupted`]) — the simulated e-stop behind Ctrl-C.
    pub fn with_stop(mut self, stop: StopRequest<'a>) -> Self {
        self.stop = Some(stop);
        self
    }

    /// Calls `hook` with the world after every [`Hardware::advance`] (logging truth and snapshots).
    pub fn with_hook(mut self, hook: WorldHook<'a>) -> Self {
        self.hook = Some(hook);
        self
    }

    /// The world (for the evaluator and the truth log — never for the robot side).
    pub fn sim(&self) -> &DexterSim {
        self.sim
    }

    /// The world, mutable (teleoperation input, fault injection).
    pub fn sim_mut(&mut self) -> &mut DexterSim {
        self.sim
    }

    /// The simulated cameras.
    pub fn sim_cameras(&self) -> &SimCameras {
        &self.cameras
    }
}

impl Plant for SimRobot<'_> {
    fn joint_names(&self) -> &[String] {
        self.sim.joint_names()
    }
    fn read_joint_positions(&self, q: &mut [f64]) {
        Plant::read_joint_positions(&*self.sim, q)
    }
    fn command(&mut self, references: &[f64]) -> Result<(), CbError> {
        Plant::command(self.sim, references)
    }
    fn step(&mut self, dt_secs: f64) -> Result<(), CbError> {
        self.advance(dt_secs).map_err(|e| CbError::Solver(e.to_string()))
    }
    fn time_secs(&self) -> f64 {
        self.sim.time()
    }
}

impl Hardware for SimRobot<'_> {
    fn model(&self) -> &RobotModel {
        self.sim.model()
    }
    fn joint_positions(&self) -> &[f64] {
        match self.fault.as_ref().and_then(Fault::joint_positions) {
            Some(q) => q,
            None => self.sim.joint_positions(),
        }
    }
    fn joint_velocities(&self) -> &[f64] {
        self.sim.joint_velocities()
    }
    fn set_joint_reference(&mut self, dof: usize, q: f64, qd: f64) {
        if self.fault.as_mut().is_some_and(|f| f.command(dof, q, qd)) {
            return;
        }
        self.sim.set_joint_target(dof, q, qd);
    }
    /// Whole physics steps (at least one).
    fn advance(&mut self, dt_secs: f64) -> Result<(), HardwareError> {
        if !(dt_secs.is_finite() && dt_secs >= 0.0) {
            return Err(HardwareError::Model(CbError::NotFinite {
                what: "advance (s)".into(),
                index: 0,
                value: dt_secs,
            }));
        }
        if let Some(stop) = self.stop.as_mut()
            && stop()
        {
            return Err(HardwareError::Interrupted);
        }
        let n = ((dt_secs / self.sim.settings().dt).round() as usize).max(1);
        for _ in 0..n {
            self.sim.step();
        }
        if let Some(f) = self.fault.as_mut() {
            f.after_advance(self.sim);
        }
        if let Some(h) = self.hook.as_mut() {
            h(self.sim);
        }
        Ok(())
    }
    fn force_torque_frames(&self) -> &[String] {
        &self.ft_frames
    }
    fn read_force_torque(&self, out: &mut [ForceTorque]) {
        let mut tips = [FingertipWrench {
            arm: Arm::Left,
            finger: 0,
            force: [0.0; 3],
            torque: [0.0; 3],
            in_contact: false,
        }; 6];
        self.sim.fingertip_wrenches(&mut tips);
        for (o, t) in out.iter_mut().zip(&tips) {
            *o = ForceTorque {
                force: t.force,
                torque: t.torque,
                in_contact: t.in_contact,
            };
        }
        if let Some(f) = self.fault.as_ref() {
            f.perturb_force_torque(self.sim.steps(), out);
        }
    }
    fn cameras(&self) -> &[CameraInfo] {
        self.cameras.infos()
    }
    fn capture(&mut self, camera: usize, out: &mut Image) -> Result<(), HardwareError> {
        if camera >= CAMERAS.len() {
            return Err(HardwareError::NoSuchDevice {
                device: "camera",
                index: camera,
                count: CAMERAS.len(),
            });
        }
        self.cameras.capture(self.sim, camera, out).map_err(hw_error)?;
        if self.fault.as_ref().is_some_and(|f| f.occludes(camera)) {
            Fault::cover(out);
        }
        Ok(())
    }
    fn capture_many(&mut self, cameras: &[usize], out: &mut [Image]) -> Result<(), HardwareError> {
        // A stereo pair is rendered on two cores; anything else one camera after the other.
        let ([a, b], [image_a, image_b]) = (cameras, &mut *out) else {
            return control_basis::hardware::capture_one_by_one(self, cameras, out);
        };
        for &camera in [a, b] {
            if camera >= CAMERAS.len() {
                return Err(HardwareError::NoSuchDevice {
                    device: "camera",
                    index: camera,
                    count: CAMERAS.len(),
                });
            }
        }
        self.cameras
            .capture_two(self.sim, [*a, *b], [&mut *image_a, &mut *image_b])
            .map_err(hw_error)?;
        for (camera, image) in [(*a, image_a), (*b, image_b)] {
            if self.fault.as_ref().is_some_and(|f| f.occludes(camera)) {
                Fault::cover(image);
            }
        }
        Ok(())
    }
}

/// What the robot is told of `scene`: the table and its places (never objects).
pub fn workspace(scene: &Scene) -> dexter::exec::Workspace {
    let t = &scene.spec.table;
    dexter::exec::Workspace {
        table_z: t.height,
        table_center: [t.center[0], t.center[1]],
        table_size: [t.size[0], t.size[1]],
        places: scene
            .spec
            .places
            .iter()
            .map(|p| dexter::exec::Place {
                name: p.name.clone(),
                center: p.center,
                size: p.size,
                wall_height: p.wall_height,
                wall_thickness: p.wall_thickness,
            })
            .collect(),
    }
}

/// Puts both arms at their parked poses (IK on the robot's model), hands open, head looking down
/// at the table: the initial condition of every run (set in the world, not servoed).
pub fn park_robot(sim: &mut DexterSim, table_z: f64) -> Result<(), SimError> {
    use control_basis::{Chain, IkSettings, inverse_kinematics};
    use dexter::skills::park_pose;
    let mut q = sim.joint_positions().to_vec();
    let mut left_solution: Option<nalgebra::DVector<f64>> = None;
    for arm in Arm::BOTH {
        let chain = Chain::new(sim.model(), "world", &dexter::control::tool_link(arm))?;
        let settings = IkSettings {
            position_tolerance: 1e-4,
            orientation_tolerance: 1e-3,
            restarts: 50,
            seed: 1,
            ..IkSettings::default()
        };
        // The right arm starts from the mirror image of the left solution, so both park alike.
        let guess: [f64; 7] = match (arm, left_solution.as_ref()) {
            (Arm::Right, Some(ql)) => {
                let s = [-1.0, 1.0, -1.0, 1.0, -1.0, 1.0, -1.0];
                std::array::from_fn(|i| ql[i] * s[i])
            }
            _ => dexter::skills::HOME_ARM_GUESS,
        };
        let sol = inverse_kinematics(&chain, &park_pose(arm, table_z), &guess, &settings)?;
        if arm == Arm::Left {
            left_solution = Some(sol.q.clone());
        }
        if !sol.converged {
            return Err(SimError::Unreachable {
                what: format!("parking the {arm} arm"),
                reason: format!("IK did not converge (error {:.3} m)", sol.position_error),
            });
        }
        let binding = control_basis::ChainBinding::by_name(&chain, sim.joint_names())?;
        binding.scatter(sol.q.as_slice(), &mut q);
    }
    // Head: look down at the table centre.
    if let Ok(t) = sim.dof("head/tilt_joint") {
        q[t] = 0.75;
    }
    sim.set_configuration(&q)
}

/// A fresh simulation of `scene` with `settings`, the robot parked ([`park_robot`]) and the objects
/// settled for 0.2 s: the start of every run.
pub fn parked_sim(scene: &Scene, settings: crate::physics::SimSettings) -> Result<DexterSim, SimError> {
    let mut sim = DexterSim::new(scene, settings)?;
    park_robot(&mut sim, scene.spec.table.height)?;
    for _ in 0..200 {
        sim.step();
    }
    Ok(sim)
}
