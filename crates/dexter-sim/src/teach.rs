//! A teleoperated demonstration in the simulated world: the teacher (scripted, or a recorded
//! glove stream) drives Dexter's hands through the robot's own Reach and hand controllers, and the
//! robot watches with its own senses ([`dexter::watch::Watcher`] on [`SimRobot`]).

use dexter::eyes::Eyes;
use dexter::teach::{DemoObserver, HandSource, WatchSettings, watch_demonstration};
use dexter::teleop::HandCommand;
use dexter::watch::Watcher;
use schema::Percept;

use crate::error::{SimError, from_robot};
use crate::hardware::{SimRobot, workspace};
use crate::physics::DexterSim;
use crate::scene::Scene;

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

/// The scripted teacher or a replayed stream, as the robot's [`HandSource`]: the teacher sees the
/// world ([`SimRobot::sim_mut`]) as a person at a glove does.
struct SimSource<'a> {
    source: &'a mut TeleopSource,
    scene: &'a Scene,
    finished_at: Option<f64>,
}

impl HandSource<SimRobot<'_>> for SimSource<'_> {
    type Error = SimError;

    fn commands(&mut self, hw: &mut SimRobot<'_>, t: f64) -> Result<[Option<HandCommand>; 2], SimError> {
        Ok(match &mut *self.source {
            TeleopSource::Script(teacher) => {
                let c = teacher.command(hw.sim_mut(), self.scene, t)?;
                if teacher.finished() && self.finished_at.is_none() {
                    self.finished_at = Some(t);
                }
                c
            }
            TeleopSource::Replay(r) => {
                let c = r.at(t);
                if r.finished() && self.finished_at.is_none() {
                    self.finished_at = Some(t.max(r.duration()));
                }
                c
            }
        })
    }

    fn finished_at(&self) -> Option<f64> {
        self.finished_at
    }
}

/// A [`DemoSink`] as the robot's [`DemoObserver`] on the simulator.
struct SinkAdapter<'a>(&'a mut dyn DemoSink);

impl DemoObserver<SimRobot<'_>> for SinkAdapter<'_> {
    fn tick(&mut self, hw: &SimRobot<'_>, t: f64) {
        self.0.tick(hw.sim(), t);
    }
    fn command(&mut self, command: &HandCommand) {
        self.0.command(command);
    }
    fn percept(&mut self, hw: &SimRobot<'_>, eyes: &Eyes, percept: &Percept) {
        self.0.percept(hw.sim(), eyes, percept);
    }
    fn should_stop(&mut self) -> bool {
        self.0.should_stop()
    }
}

/// Runs a teleoperated demonstration on `sim` (already parked) in `scene`: the source's hand
/// commands drive the hands at 200 Hz, the head follows the working hand, and a percept is made at
/// `settings.percept_hz` — the robot's own loop ([`dexter::teach::watch_demonstration`]) on
/// [`SimRobot`], the robot's eyes calibrated in the scene's empty workcell.
pub fn run_demonstration(
    sim: &mut DexterSim,
    scene: &Scene,
    mut source: TeleopSource,
    settings: &DemoSettings,
    sink: &mut dyn DemoSink,
) -> Result<DemoReport, SimError> {
    let s0 = sim.steps();
    let ws = workspace(scene);
    let calibration = crate::calibrate::workcell_calibration(scene)?;
    let mut hw = SimRobot::new(sim, scene, settings.seed)?;
    let mut watcher = Watcher::new(&hw, ws.place_percepts(), ws.table_z, calibration).map_err(from_robot)?;
    let watch = WatchSettings {
        percept_hz: settings.percept_hz,
        max_seconds: settings.max_seconds,
        tail_seconds: settings.tail_seconds,
    };
    let report = {
        let mut hands = SimSource {
            source: &mut source,
            scene,
            finished_at: None,
        };
        watch_demonstration(&mut hw, &mut watcher, &mut hands, &watch, &mut SinkAdapter(sink))?
    };
    let notes = match &source {
        TeleopSource::Script(teacher) => teacher.notes.clone(),
        TeleopSource::Replay(_) => Vec::new(),
    };
    Ok(DemoReport {
        sim_time: report.seconds,
        steps: hw.sim().steps() - s0,
        percepts: report.percepts,
        commands: report.commands,
        interrupted: report.interrupted,
        notes,
    })
}
