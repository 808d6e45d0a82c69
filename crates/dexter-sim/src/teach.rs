//! A teleoperated demonstration in the simulated world: the teacher (scripted, or a recorded
//! glove stream) drives Dexter's hands through the robot's own Reach and hand controllers, and the
//! robot watches with its own senses ([`dexter::watch::Watcher`] on [`SimRobot`]).

use control_basis::Hardware;
use control_basis::math::Vec3;
use dexter::eyes::Eyes;
use dexter::watch::Watcher;
use schema::Percept;

use crate::error::{SimError, from_robot};
use crate::hardware::{SimRobot, workspace};
use crate::physics::DexterSim;
use crate::scene::Scene;
use crate::snapshot::Arm;

/// Where the teacher's hand commands come from.
#[derive(Debug)]
pub enum TeleopSource {
    /// The scripted teacher.
    Script(Box<crate::teleop::Teacher>),
    /// A recorded stream (glove or mocap data).
    Replay(crate::teleop::Replay),
}

/// Settings of a recorded demonstration.
#[derive(Debug, Clone, Copy)]
pub struct DemoSettings {
    /// Observation (camera) rate (Hz).
    pub percept_hz: f64,
    /// Longest demonstration (s).
    pub max_seconds: f64,
    /// Time after the teacher finishes (s), so the last states are seen.
    pub tail_seconds: f64,
    /// Camera noise seed.
    pub seed: u64,
}

impl Default for DemoSettings {
    fn default() -> Self {
        DemoSettings {
            percept_hz: 10.0,
            max_seconds: 600.0,
            tail_seconds: 1.0,
            seed: 0,
        }
    }
}

/// What a demonstration run reports.
#[derive(Debug, Clone, serde::Serialize)]
pub struct DemoReport {
    /// Simulated seconds.
    pub sim_time: f64,
    /// Physics steps.
    pub steps: u64,
    /// Percepts captured.
    pub percepts: usize,
    /// Hand commands played.
    pub commands: usize,
    /// Whether the run was interrupted (signal) before the teacher finished.
    pub interrupted: bool,
    /// The teacher's notes (retries, failures).
    pub notes: Vec<String>,
}

/// Receives what happens during a demonstration.
pub trait DemoSink {
    /// After every control tick (200 Hz).
    fn tick(&mut self, _sim: &DexterSim, _t: f64) {}
    /// Every hand command when it changes (glove rate).
    fn command(&mut self, _command: &crate::teleop::HandCommand) {}
    /// Every percept (observation rate), with the eyes that made it.
    fn percept(&mut self, _sim: &DexterSim, _eyes: &Eyes, _percept: &Percept) {}
    /// Polled every tick: return true to stop (an interrupt); what was captured is kept.
    fn should_stop(&mut self) -> bool {
        false
    }
}

/// Runs a teleoperated demonstration on `sim` (already parked) in `scene`: the source's hand
/// commands drive the hands at 200 Hz, the head follows the working hand, and a percept is made at
/// `settings.percept_hz`.
pub fn run_demonstration(
    sim: &mut DexterSim,
    scene: &Scene,
    mut source: TeleopSource,
    settings: &DemoSettings,
    sink: &mut dyn DemoSink,
) -> Result<DemoReport, SimError> {
    let dt_c = 1.0 / dexter::skills::CONTROL_HZ;
    let t0 = sim.time();
    let s0 = sim.steps();
    let ws = workspace(scene);
    let calibration = crate::calibrate::workcell_calibration(scene)?;
    let mut hw = SimRobot::new(sim, scene, settings.seed)?;
    let mut driver = crate::teleop::TeleopDriver::new(&hw)?;
    let mut watcher = Watcher::new(&hw, ws.place_percepts(), ws.table_z, calibration).map_err(from_robot)?;
    let percept_every = ((dexter::skills::CONTROL_HZ / settings.percept_hz).round() as usize).max(1);
    let mut tick = 0usize;
    let mut percepts = 0usize;
    let mut commands = 0usize;
    let mut last_cmd: [Option<f64>; 2] = [None, None];
    let mut finished_at: Option<f64> = None;
    let mut interrupted = false;
    let mut working = Arm::Left;
    loop {
        let t = hw.sim().time() - t0;
        if t > settings.max_seconds {
            break;
        }
        if sink.should_stop() {
            interrupted = true;
            break;
        }
        let cmds = match &mut source {
            TeleopSource::Script(teacher) => {
                let c = teacher.command(hw.sim_mut(), scene, t)?;
                if teacher.finished() && finished_at.is_none() {
                    finished_at = Some(t);
                }
                c
            }
            TeleopSource::Replay(r) => {
                let c = r.at(t);
                if r.finished() && finished_at.is_none() {
                    finished_at = Some(t.max(r.duration()));
                }
                c
            }
        };
        if finished_at.is_some_and(|f| t > f + settings.tail_seconds) {
            break;
        }
        for (k, c) in cmds.iter().enumerate() {
            if let Some(c) = c
                && last_cmd[k] != Some(c.t)
            {
                last_cmd[k] = Some(c.t);
                commands += 1;
                working = c.hand;
                sink.command(c);
            }
        }
        driver.tick(&mut hw, &cmds, dt_c);
        hw.advance(dt_c)?;
        sink.tick(hw.sim(), t);
        if tick.is_multiple_of(percept_every) {
            // The head follows the working hand (the robot watches the teacher's hand at work).
            let palm = driver.palm_pose(&hw, working).translation.vector;
            let target = Vec3::new(palm.x, palm.y, palm.z.max(watcher.table_z() + 0.03));
            watcher.look_at(&mut hw, &target).map_err(from_robot)?;
            let now = hw.sim().time() - t0;
            let p = watcher.percept(&mut hw, now).map_err(from_robot)?;
            percepts += 1;
            sink.percept(hw.sim(), watcher.eyes(), &p);
        }
        tick += 1;
    }
    let notes = match &source {
        TeleopSource::Script(teacher) => teacher.notes.clone(),
        TeleopSource::Replay(_) => Vec::new(),
    };
    Ok(DemoReport {
        sim_time: hw.sim().time() - t0,
        steps: hw.sim().steps() - s0,
        percepts,
        commands,
        interrupted,
        notes,
    })
}
