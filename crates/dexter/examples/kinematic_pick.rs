//! Dexter's robot side on hardware that is not the Rapier simulator: a kinematic plant (motor units
//! that track their references at the joints' velocity limits) with a scripted sensor model — a red
//! box on a grey table, rendered by a few lines of ray casting for the four cameras, fingertip sensors
//! that feel the box when the closing fingers meet it, and a box that follows a hand that holds it.
//!
//! The same code that runs on the simulator — vision, tracking, the monitors, the robot's task loop
//! (`dexter::task::run_task`: look over the table, decide, bind ψ, run Pick-And-Place through
//! `schema::execute`) — runs here unchanged, because it reaches the world only through
//! `control_basis::Hardware`.
//!
//! `cargo run --release -p dexter --example kinematic_pick`

use std::cell::RefCell;
use std::sync::Arc;

use control_basis::hardware::{CameraInfo, ForceTorque, Hardware, HardwareError, Image, Intrinsics};
use control_basis::math::{Iso3, Vec3};
use control_basis::{CbError, Chain, IkSettings, JointLimits, Plant, RobotModel, inverse_kinematics};
use dexter::Arm;
use dexter::body::Body;
use dexter::calibration::{Calibration, CalibrationSettings};
use dexter::exec::{NoSink, Place, RobotPlant, Workspace};
use dexter::task::{Decider, NoTaskSink, Taken, Task};

const TABLE_Z: f64 = 0.75;
/// The box: half extents (m) and mass (kg).
const HALF: [f64; 3] = [0.03, 0.03, 0.03];
const MASS: f64 = 0.2;
/// Flexion (rad) at which the closing fingers meet a 6 cm box.
const CONTACT_FLEX: f64 = 1.0;

/// The scripted world and the robot's hardware in one.
/// (Public so that the tests that include this example can build the plant.)
#[allow(missing_debug_implementations)]
pub struct ScriptedDexter {
    model: RobotModel,
    names: Vec<String>,
    limits: Vec<JointLimits>,
    q: Vec<f64>,
    qd: Vec<f64>,
    q_ref: Vec<f64>,
    time: f64,
    cameras: Vec<CameraInfo>,
    ft_frames: Vec<String>,
    body: RefCell<Body>,
    /// The box centre (m, world).
    box_center: Vec3,
    /// The holding hand and the box's offset from its palm.
    held: Option<(Arm, Vec3)>,
    /// Per hand: the fingers rest on the box (the medial joints stop at `CONTACT_FLEX`).
    blocked: [bool; 2],
    /// Whether the box is on the table yet (the robot calibrates its eyes before).
    box_placed: bool,
    med: [[usize; 3]; 2],
}

impl ScriptedDexter {
    pub fn new() -> Result<Self, Box<dyn std::error::Error>> {
        let model = RobotModel::from_urdf_str(include_str!("../../../assets/dexter.urdf"))?;
        let joints: Vec<_> = model.actuated_joints().cloned().collect();
        let names: Vec<String> = joints.iter().map(|j| j.name.clone()).collect();
        let limits = joints.iter().map(|j| j.limits).collect();
        let n = names.len();
        let intrinsics = Intrinsics {
            width: 160,
            height: 120,
            hfov_deg: 60.0,
        };
        let cameras = [
            ("head/left", "head/left_camera_optical_frame"),
            ("head/right", "head/right_camera_optical_frame"),
            ("chassis/left", "chassis/left_camera_optical_frame"),
            ("chassis/right", "chassis/right_camera_optical_frame"),
        ]
        .iter()
        .map(|(name, frame)| CameraInfo {
            name: name.to_string(),
            optical_frame: frame.to_string(),
            intrinsics,
            pixel_noise: 0.0,
        })
        .collect();
        let ft_frames = (0..6)
            .map(|k| format!("{}/bhand/finger_{}/tip_link", Arm::BOTH[k / 3].prefix(), k % 3 + 1))
            .collect();
        let idx = |name: &str| names.iter().position(|n| n == name).ok_or(format!("no joint {name}"));
        let med = [
            [
                idx("left/bhand/finger_1/med_joint")?,
                idx("left/bhand/finger_2/med_joint")?,
                idx("left/bhand/finger_3/med_joint")?,
            ],
            [
                idx("right/bhand/finger_1/med_joint")?,
                idx("right/bhand/finger_2/med_joint")?,
                idx("right/bhand/finger_3/med_joint")?,
            ],
        ];
        let mut hw = ScriptedDexter {
            model,
            names,
            limits,
            q: vec![0.0; n],
            qd: vec![0.0; n],
            q_ref: vec![0.0; n],
            time: 0.0,
            cameras,
            ft_frames,
            body: RefCell::new(Body::new()),
            box_center: Vec3::new(0.55, 0.12, TABLE_Z + HALF[2]),
            held: None,
            blocked: [false; 2],
            box_placed: false,
            med,
        };
        hw.park()?;
        Ok(hw)
    }

    /// The initial condition: both palms at their parked poses (IK), head looking down.
    fn park(&mut self) -> Result<(), Box<dyn std::error::Error>> {
        for arm in Arm::BOTH {
            let chain = Chain::new(&self.model, "world", &dexter::control::tool_link(arm))?;
            let sol = inverse_kinematics(
                &chain,
                &dexter::skills::park_pose(arm, TABLE_Z),
                &dexter::skills::HOME_ARM_GUESS,
                &IkSettings {
                    restarts: 50,
                    seed: 1,
                    ..IkSettings::default()
                },
            )?;
            let binding = control_basis::ChainBinding::by_name(&chain, &self.names)?;
            binding.scatter(sol.q.as_slice(), &mut self.q);
        }
        let tilt = self.dof_index("head/tilt_joint")?;
        self.q[tilt] = 0.75;
        self.q_ref.copy_from_slice(&self.q);
        Ok(())
    }

    fn palm(&self, arm: Arm) -> Iso3 {
        let link = format!("{}/bhand/palm_surface_link", arm.prefix());
        self.body
            .borrow_mut()
            .pose(self, &link)
            .unwrap_or_else(|_| Iso3::identity())
    }

    fn flexion(&self, arm: Arm) -> f64 {
        self.med[arm.index()].iter().map(|&i| self.q[i]).sum::<f64>() / 3.0
    }

    fn box_top(&self) -> f64 {
        self.box_center.z + HALF[2]
    }

    /// The scripted contact model, after the joints moved.
    fn update_contacts(&mut self) {
        for arm in Arm::BOTH {
            let k = arm.index();
            let palm = self.palm(arm).translation.vector;
            let around = (palm.xy() - self.box_center.xy()).norm() < 0.03
                && palm.z - self.box_top() > -0.06
                && palm.z - self.box_top() < 0.10;
            let flex = self.flexion(arm);
            let holding_here = self.held.is_some_and(|(a, _)| a == arm);
            // Closing on the box: the fingers stop where they meet it.
            self.blocked[k] = (around || holding_here) && flex >= CONTACT_FLEX - 0.02;
            if self.blocked[k] {
                for &i in &self.med[k] {
                    self.q[i] = self.q[i].min(CONTACT_FLEX);
                }
                if self.held.is_none() {
                    self.held = Some((arm, self.box_center - palm));
                }
            }
            // Opening lets go.
            if holding_here && self.q_ref[self.med[k][0]] < CONTACT_FLEX - 0.2 {
                self.held = None;
                self.blocked[k] = false;
            }
        }
        match self.held {
            Some((arm, offset)) => {
                let palm = self.palm(arm).translation.vector;
                self.box_center = palm + offset;
                // The table (or a bin's floor) stops it.
                self.box_center.z = self.box_center.z.max(TABLE_Z + HALF[2]);
            }
            None => self.box_center.z = TABLE_Z + HALF[2],
        }
    }

    /// Colour seen along a ray: the box (top lit, sides in shade), the table, or dark floor.
    fn shade(o: &Vec3, d: &Vec3, box_center: Option<Vec3>) -> [f64; 3] {
        let c = box_center.unwrap_or(Vec3::new(0.0, 0.0, -10.0));
        let (lo, hi) = (c - Vec3::from(HALF), c + Vec3::from(HALF));
        let (mut t0, mut t1, mut axis) = (0.0f64, f64::INFINITY, 0usize);
        for a in 0..3 {
            let (ta, tb) = ((lo[a] - o[a]) / d[a], (hi[a] - o[a]) / d[a]);
            let (near, far) = (ta.min(tb), ta.max(tb));
            if near > t0 {
                t0 = near;
                axis = a;
            }
            t1 = t1.min(far);
        }
        if t0 <= t1 && t1 > 0.0 {
            return if axis == 2 {
                [0.85, 0.1, 0.1]
            } else {
                [0.51, 0.06, 0.06]
            };
        }
        if d.z < 0.0 {
            let t = (TABLE_Z - o.z) / d.z;
            let p = o + d * t;
            if (p.x - 0.6).abs() < 0.3 && p.y.abs() < 0.7 {
                return [0.55, 0.5, 0.45];
            }
        }
        [0.1, 0.1, 0.1]
    }

    fn render(&self, camera: usize, out: &mut Image, with_box: bool) -> Result<(), HardwareError> {
        let info = &self.cameras[camera];
        let pose = self
            .body
            .borrow_mut()
            .pose(self, &info.optical_frame)
            .map_err(|e| HardwareError::Device {
                device: info.name.clone(),
                message: e.to_string(),
            })?;
        let cam = control_basis::Camera::new(&info.intrinsics, pose)?;
        out.resize(cam.width, cam.height);
        let box_center = with_box.then_some(self.box_center);
        for v in 0..cam.height {
            for u in 0..cam.width {
                let (o, d) = cam.ray(f64::from(u), f64::from(v));
                let c = Self::shade(&o, &d, box_center);
                let i = 3 * (v as usize * cam.width as usize + u as usize);
                for (px, ch) in out.rgb[i..i + 3].iter_mut().zip(c) {
                    *px = (ch * 255.0).round() as u8;
                }
            }
        }
        Ok(())
    }
}

impl Plant for ScriptedDexter {
    fn joint_names(&self) -> &[String] {
        &self.names
    }
    fn read_joint_positions(&self, q: &mut [f64]) {
        q.copy_from_slice(&self.q);
    }
    fn command(&mut self, references: &[f64]) -> Result<(), CbError> {
        self.q_ref.copy_from_slice(references);
        Ok(())
    }
    fn step(&mut self, dt_secs: f64) -> Result<(), CbError> {
        self.advance(dt_secs).map_err(|e| CbError::Solver(e.to_string()))
    }
    fn time_secs(&self) -> f64 {
        self.time
    }
}

impl Hardware for ScriptedDexter {
    fn model(&self) -> &RobotModel {
        &self.model
    }
    fn joint_positions(&self) -> &[f64] {
        &self.q
    }
    fn joint_velocities(&self) -> &[f64] {
        &self.qd
    }
    fn set_joint_reference(&mut self, dof: usize, q: f64, _qd: f64) {
        if let Some(r) = self.q_ref.get_mut(dof) {
            *r = q;
        }
    }
    fn advance(&mut self, dt_secs: f64) -> Result<(), HardwareError> {
        for i in 0..self.q.len() {
            let l = &self.limits[i];
            let max = if l.velocity.is_finite() { l.velocity } else { 2.0 } * dt_secs;
            let before = self.q[i];
            self.q[i] = (before + (self.q_ref[i] - before).clamp(-max, max)).clamp(l.lower, l.upper);
            self.qd[i] = (self.q[i] - before) / dt_secs;
        }
        self.update_contacts();
        for k in 0..2 {
            if self.blocked[k] {
                for &i in &self.med[k] {
                    self.qd[i] = 0.0;
                }
            }
        }
        self.time += dt_secs;
        Ok(())
    }
    fn force_torque_frames(&self) -> &[String] {
        &self.ft_frames
    }
    fn read_force_torque(&self, out: &mut [ForceTorque]) {
        out.iter_mut().for_each(|o| *o = ForceTorque::default());
        for arm in Arm::BOTH {
            let k = arm.index();
            if !self.blocked[k] {
                continue;
            }
            // Squeeze along the palm's y axis (F3 on +y), and the box's weight unless the table
            // carries it.
            let y = self.palm(arm).rotation * Vec3::y();
            let lifted = self.held.is_some_and(|(a, _)| a == arm) && self.box_center.z > TABLE_Z + HALF[2] + 1e-4;
            let fz = if lifted { -MASS * 9.81 / 3.0 } else { 0.0 };
            let squeeze = [-1.0, -1.0, 2.0];
            for f in 0..3 {
                out[3 * k + f] = ForceTorque {
                    force: [squeeze[f] * y.x, squeeze[f] * y.y, fz],
                    torque: [0.0; 3],
                    in_contact: true,
                };
            }
        }
    }
    fn cameras(&self) -> &[CameraInfo] {
        &self.cameras
    }
    fn capture(&mut self, camera: usize, out: &mut Image) -> Result<(), HardwareError> {
        self.render(camera, out, self.box_placed)
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let (reached, inside) = run()?;
    if !(reached && inside) {
        return Err("the task was not done".into());
    }
    Ok(())
}

/// Runs the task; returns whether the schema's goal was reached and the box is inside bin-right.
pub fn run() -> Result<(bool, bool), Box<dyn std::error::Error>> {
    let mut hw = ScriptedDexter::new()?;
    let workspace = Workspace {
        table_z: TABLE_Z,
        table_center: [0.6, 0.0],
        table_size: [0.6, 1.4],
        places: vec![
            Place {
                name: "bin-left".into(),
                center: [0.55, 0.45],
                size: [0.2, 0.25],
                wall_height: 0.06,
                wall_thickness: 0.01,
            },
            Place {
                name: "bin-right".into(),
                center: [0.55, -0.45],
                size: [0.2, 0.25],
                wall_height: 0.06,
                wall_thickness: 0.01,
            },
        ],
    };
    let library = schema::Library::builtin();
    let mut sink = NoSink;
    // Calibration on the cleared table, then the box is put down.
    let calibration = Calibration::capture(&mut hw, &workspace, &CalibrationSettings::default())?;
    hw.box_placed = true;
    let runs = {
        let mut plant = RobotPlant::new(&mut hw, &workspace, Arc::new(calibration), &library, &mut sink)?;
        // The robot's own task loop: it looks over the table, decides (here: everything it sees goes
        // to bin-right, as a demonstration would have it), finds the segment again, lets ψ bind the
        // arms and runs the schema.
        let task = Task {
            library: &library,
            schema: "pick_and_place",
            decider: Decider::Place("bin-right".into()),
            only_near: None,
            max_actions: 20,
        };
        dexter::task::run_task(&mut plant, &task, &mut NoTaskSink)?
    };
    let run = runs.first().ok_or("the robot sees no object")?;
    println!(
        "seen segment {} at ({:.3}, {:.3}, {:.3})",
        run.decision.segment, run.decision.at[0], run.decision.at[1], run.decision.at[2]
    );
    let Taken::Executed { execution: report, .. } = &run.taken else {
        return Err(format!("the robot did not execute: {:?}", run.taken).into());
    };
    for s in &report.steps {
        println!(
            "  {:<16} {:<13} {:<6} {:?}",
            s.state,
            s.action,
            s.binding.arm.as_deref().unwrap_or("-"),
            s.outcome
        );
    }
    let inside = workspace.places[1].contains([hw.box_center.x, hw.box_center.y]);
    println!(
        "goal reached: {}; the box is at ({:.3}, {:.3}, {:.3}), {} bin-right; contingencies: {:?}",
        report.reached_goal,
        hw.box_center.x,
        hw.box_center.y,
        hw.box_center.z,
        if inside { "inside" } else { "outside" },
        report.contingencies
    );
    Ok((report.reached_goal && runs.len() == 1, inside))
}
