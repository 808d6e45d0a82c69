//! Watching a teleoperated demonstration (§4.3.1) on any [`Hardware`]: the teacher's hand commands
//! (a scripted teacher in the simulator, a recorded glove stream, a glove's ROS 2 topics) drive the
//! hands through the robot's own [`TeleopDriver`] at the control rate, the head follows the working
//! hand, and the robot perceives with its own [`Watcher`] at the observation rate — what `pbd record`
//! runs in the simulator and over ROS 2 alike.

use control_basis::Hardware;
use control_basis::math::Vec3;
use schema::Percept;

use crate::arm::Arm;
use crate::error::RobotError;
use crate::eyes::Eyes;
use crate::teleop::{HandCommand, TeleopDriver};
use crate::watch::Watcher;

/// Where the hand commands come from.
pub trait HandSource<H: ?Sized> {
    /// Errors of the source (they end the demonstration); the robot's own convert into it.
    type Error: From<RobotError>;
    /// The commands for time `t` (s since the start of the demonstration): each hand's newest
    /// sample (a command is sent on when its time `t` differs from the last one sent), or none.
    /// Called once per control tick, before the hands move.
    fn commands(&mut self, hw: &mut H, t: f64) -> Result<[Option<HandCommand>; 2], Self::Error>;
    /// When the teacher finished, if it has: the demonstration ends `tail_seconds` later.
    fn finished_at(&self) -> Option<f64>;
}

/// What listens to a demonstration (a log writer).
pub trait DemoObserver<H: ?Sized> {
    /// After every control tick, with the time the tick started.
    fn tick(&mut self, _hw: &H, _t: f64) {}
    /// Every hand command sent on (glove rate).
    fn command(&mut self, _command: &HandCommand) {}
    /// Every percept, with the eyes that made it.
    fn percept(&mut self, _hw: &H, _eyes: &Eyes, _percept: &Percept) {}
    /// Polled every tick: true stops the demonstration (an interrupt); what was seen is kept.
    fn should_stop(&mut self) -> bool {
        false
    }
}

/// Rates and limits of a watched demonstration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WatchSettings {
    /// Observation (camera) rate (Hz).
    pub percept_hz: f64,
    /// Longest demonstration (s).
    pub max_seconds: f64,
    /// Time after the teacher finishes (s), so that the last states are seen.
    pub tail_seconds: f64,
}

/// What a watched demonstration did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WatchReport {
    /// Seconds of hardware time from start to end.
    pub seconds: f64,
    /// Percepts made.
    pub percepts: usize,
    /// Hand commands sent on.
    pub commands: usize,
    /// Whether it was stopped (an interrupt) before the teacher finished.
    pub interrupted: bool,
}

/// Runs a demonstration on `hw` from its current state: each control tick the source's commands
/// drive the hands ([`TeleopDriver`]) and the hardware advances one control period; every
/// `1 / percept_hz` the head looks at the working hand (the one last commanded) and `watcher`
/// makes a percept. Ends `tail_seconds` after the source finished, at `max_seconds`, or when
/// `sink` asks.
pub fn watch_demonstration<H: Hardware, E: From<RobotError>>(
    hw: &mut H,
    watcher: &mut Watcher,
    source: &mut dyn HandSource<H, Error = E>,
    settings: &WatchSettings,
    sink: &mut dyn DemoObserver<H>,
) -> Result<WatchReport, E> {
    let dt_c = 1.0 / crate::skills::CONTROL_HZ;
    let t0 = hw.time_secs();
    let mut driver = TeleopDriver::new(hw)?;
    let percept_every = ((crate::skills::CONTROL_HZ / settings.percept_hz).round() as usize).max(1);
    let mut tick = 0usize;
    let mut report = WatchReport {
        seconds: 0.0,
        percepts: 0,
        commands: 0,
        interrupted: false,
    };
    let mut last_cmd: [Option<f64>; 2] = [None, None];
    let mut working = Arm::Left;
    loop {
        let t = hw.time_secs() - t0;
        if t > settings.max_seconds {
            break;
        }
        if sink.should_stop() {
            report.interrupted = true;
            break;
        }
        let cmds = source.commands(hw, t)?;
        if source.finished_at().is_some_and(|f| t > f + settings.tail_seconds) {
            break;
        }
        for (k, c) in cmds.iter().enumerate() {
            if let Some(c) = c
                && last_cmd[k] != Some(c.t)
            {
                last_cmd[k] = Some(c.t);
                report.commands += 1;
                working = c.hand;
                sink.command(c);
            }
        }
        driver.tick(hw, &cmds, dt_c);
        hw.advance(dt_c).map_err(RobotError::from)?;
        sink.tick(hw, t);
        if tick.is_multiple_of(percept_every) {
            // The head follows the working hand (the robot watches the teacher's hand at work).
            let palm = driver.palm_pose(hw, working).translation.vector;
            let target = Vec3::new(palm.x, palm.y, palm.z.max(watcher.table_z() + 0.03));
            watcher.look_at(hw, &target)?;
            let now = hw.time_secs() - t0;
            let p = watcher.percept(hw, now)?;
            report.percepts += 1;
            sink.percept(hw, watcher.eyes(), &p);
        }
        tick += 1;
    }
    report.seconds = hw.time_secs() - t0;
    Ok(report)
}
