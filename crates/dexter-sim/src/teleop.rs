//! Teleoperation (§4.3.1): the teacher's hand poses and finger flexion, streamed at glove rate, drive
//! Dexter's hands. A stream comes from a file (real glove or mocap data, CSV or JSON lines) or from
//! the scripted, human-like [`Teacher`].
//!
//! ## File formats
//! One sample per line, per hand; time in seconds from the start (non-decreasing per hand), the palm
//! surface pose in the robot's world frame (m, unit quaternion x y z w) and the mean finger flexion
//! (rad, 0 open … 2.4 closed).
//!
//! CSV, with this header line exactly:
//! ```text
//! t,hand,x,y,z,qx,qy,qz,qw,flexion
//! 0.000,right,0.42,-0.32,0.95,1,0,0,0,0.3
//! ```
//! JSON lines:
//! ```text
//! {"t":0.0,"hand":"right","position":[0.42,-0.32,0.95],"orientation":[1,0,0,0],"flexion":0.3}
//! ```
//! Between samples the command is held (a zero-order hold, as a glove delivers it).

use std::path::Path;

use control_basis::math::{Iso3, Rot3, Vec3};
use nalgebra::{Quaternion, Translation3, UnitQuaternion};
use serde::{Deserialize, Serialize};

use crate::error::SimError;
use crate::geometry;
use crate::physics::DexterSim;
use crate::pick_place::plan_top_grasp_shape as plan_top_grasp;
use crate::scene::Scene;
use crate::snapshot::Arm;
use bayes::rng::{Draw, Generator};
use control_basis::Hardware;
use dexter::control::{FLEX_CLOSED, HandControl, ReachControl, top_down_orientation};
use dexter::skills::{GraspPlan, park_pose};

fn finger_arc(sim: &DexterSim, arm: Arm) -> Result<Vec<(f64, f64, f64)>, SimError> {
    dexter::skills::finger_arc(sim.model(), arm).map_err(crate::error::from_robot)
}

/// One glove sample for one hand.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct HandCommand {
    /// Time (s).
    pub t: f64,
    /// Which hand.
    pub hand: Arm,
    /// Palm-surface position (m, world).
    pub position: [f64; 3],
    /// Palm-surface orientation, unit quaternion `[x, y, z, w]`.
    pub orientation: [f64; 4],
    /// Mean finger flexion (rad).
    pub flexion: f64,
}

impl HandCommand {
    /// A command from a pose.
    pub fn new(t: f64, hand: Arm, pose: &Iso3, flexion: f64) -> HandCommand {
        let q = pose.rotation.quaternion();
        let p = pose.translation.vector;
        HandCommand {
            t,
            hand,
            position: [p.x, p.y, p.z],
            orientation: [q.i, q.j, q.k, q.w],
            flexion,
        }
    }

    /// The commanded palm pose.
    pub fn pose(&self) -> Iso3 {
        let [x, y, z, w] = self.orientation;
        let q = UnitQuaternion::from_quaternion(Quaternion::new(w, x, y, z));
        Iso3::from_parts(
            Translation3::new(self.position[0], self.position[1], self.position[2]),
            q,
        )
    }
}

/// Latest sample time (s) a teleop stream may hold: an hour (a recording stops at 600 s).
pub const MAX_STREAM_SECS: f64 = 3600.0;

/// Longest gap (s) between two samples of one hand: a glove streams at tens of hertz, and a gap of
/// 10⁹ s once ran a recording to its time cap on the last command.
pub const MAX_SAMPLE_GAP_SECS: f64 = 60.0;

/// A recorded teleoperation stream: samples per hand in time order.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct TeleopStream {
    /// Samples in file order, both hands interleaved (time non-decreasing per hand).
    pub samples: Vec<HandCommand>,
}

fn bad(path: &Path, line: usize, message: impl Into<String>) -> SimError {
    SimError::Invalid {
        path: path.to_path_buf(),
        field: format!("line {line}"),
        message: message.into(),
    }
}

/// The CSV header a teleop file must start with.
pub const CSV_HEADER: &str = "t,hand,x,y,z,qx,qy,qz,qw,flexion";

impl TeleopStream {
    /// Reads a CSV (`.csv`) or JSON-lines (anything else) teleop file and validates it.
    pub fn load(path: impl AsRef<Path>) -> Result<TeleopStream, SimError> {
        let path = path.as_ref();
        let text = bayes::input::read_text(path).map_err(|e| SimError::Io {
            path: path.to_path_buf(),
            source: e,
        })?;
        TeleopStream::parse(&text, path)
    }

    /// Parses and validates a teleop stream held in memory; `path` names it in errors and picks the
    /// format as [`TeleopStream::load`] does (`.csv`: CSV, anything else: JSON lines).
    pub fn parse(text: &str, path: impl AsRef<Path>) -> Result<TeleopStream, SimError> {
        let path = path.as_ref();
        let csv = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("csv"));
        let (stream, lines) = if csv {
            Self::parse_csv(text, path)?
        } else {
            Self::parse_jsonl(text, path)?
        };
        stream.validate_lines(path, &lines)?;
        Ok(stream)
    }

    /// The samples and the file line (1-based) of each.
    fn parse_csv(text: &str, path: &Path) -> Result<(TeleopStream, Vec<usize>), SimError> {
        let mut lines = text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty());
        let Some((_, header)) = lines.next() else {
            return Err(bad(
                path,
                1,
                "empty file (expected the header `t,hand,x,y,z,qx,qy,qz,qw,flexion`)",
            ));
        };
        let header_line = text.lines().position(|l| !l.trim().is_empty()).unwrap_or(0) + 1;
        let header: String = header.chars().filter(|c| !c.is_whitespace()).collect();
        if header != CSV_HEADER {
            return Err(bad(
                path,
                header_line,
                format!("header `{header}` is not `{CSV_HEADER}`"),
            ));
        }
        let mut samples = Vec::new();
        let mut numbers = Vec::new();
        for (i, line) in lines {
            let n = i + 1;
            numbers.push(n);
            let cols: Vec<&str> = line.split(',').map(str::trim).collect();
            if cols.len() != 10 {
                return Err(bad(
                    path,
                    n,
                    format!("{} columns, expected 10 ({CSV_HEADER})", cols.len()),
                ));
            }
            let hand =
                parse_arm(cols[1]).ok_or_else(|| bad(path, n, format!("hand `{}` is not left or right", cols[1])))?;
            let mut v = [0.0; 9];
            for (k, (j, name)) in [0usize, 2, 3, 4, 5, 6, 7, 8, 9]
                .into_iter()
                .zip(["t", "x", "y", "z", "qx", "qy", "qz", "qw", "flexion"])
                .enumerate()
            {
                v[k] = cols[j]
                    .parse::<f64>()
                    .map_err(|_| bad(path, n, format!("{name} = `{}` is not a number", cols[j])))?;
            }
            samples.push(HandCommand {
                t: v[0],
                hand,
                position: [v[1], v[2], v[3]],
                orientation: [v[4], v[5], v[6], v[7]],
                flexion: v[8],
            });
        }
        Ok((TeleopStream { samples }, numbers))
    }

    fn parse_jsonl(text: &str, path: &Path) -> Result<(TeleopStream, Vec<usize>), SimError> {
        let mut samples = Vec::new();
        let mut numbers = Vec::new();
        for (i, line) in text.lines().enumerate() {
            if line.trim().is_empty() {
                continue;
            }
            if let Err(dup) = bayes::input::check_json_keys(line) {
                return Err(bad(
                    path,
                    i + 1,
                    format!(
                        "duplicate key `{}` (second at column {}): a JSON object may give each key only once",
                        dup.path, dup.column
                    ),
                ));
            }
            let s: HandCommand =
                serde_json::from_str(line).map_err(|e| bad(path, i + 1, format!("not a teleop sample: {e}")))?;
            samples.push(s);
            numbers.push(i + 1);
        }
        Ok((TeleopStream { samples }, numbers))
    }

    /// Checks: at least one sample, finite numbers, unit quaternions (within 1e-3; renormalised),
    /// time non-decreasing per hand, flexion within [0, 2.4]. Errors name the sample (1-based).
    pub fn validate(&self, path: &Path) -> Result<(), SimError> {
        self.check(path, &|i| format!("sample {}", i + 1))
    }

    /// [`TeleopStream::validate`] naming the file line of each sample.
    fn validate_lines(&self, path: &Path, lines: &[usize]) -> Result<(), SimError> {
        self.check(path, &|i| format!("line {}", lines.get(i).copied().unwrap_or(i + 1)))
    }

    fn check(&self, path: &Path, at: &dyn Fn(usize) -> String) -> Result<(), SimError> {
        let bad = |_: &Path, n: String, message: String| SimError::Invalid {
            path: path.to_path_buf(),
            field: n,
            message,
        };
        if self.samples.is_empty() {
            return Err(bad(path, "samples".into(), "no samples".into()));
        }
        let mut last = [f64::NEG_INFINITY; 2];
        for (i, s) in self.samples.iter().enumerate() {
            let n = at(i);
            let nums = [s.t, s.flexion].into_iter().chain(s.position).chain(s.orientation);
            if nums.into_iter().any(|v| !v.is_finite()) {
                return Err(bad(path, n, "a value is not a finite number".into()));
            }
            let norm = s.orientation.iter().map(|v| v * v).sum::<f64>().sqrt();
            if (norm - 1.0).abs() > 1e-3 {
                return Err(bad(
                    path,
                    n.clone(),
                    format!("orientation is not a unit quaternion (norm {norm:.4})"),
                ));
            }
            if !(0.0..=FLEX_CLOSED + 1e-9).contains(&s.flexion) {
                return Err(bad(
                    path,
                    n.clone(),
                    format!("flexion {} outside [0, {FLEX_CLOSED}] rad", s.flexion),
                ));
            }
            if !(0.0..=MAX_STREAM_SECS).contains(&s.t) {
                return Err(bad(
                    path,
                    n.clone(),
                    format!("time {} s outside [0, {MAX_STREAM_SECS}] s", s.t),
                ));
            }
            let k = hand_index(s.hand);
            if last[k].is_finite() && s.t - last[k] > MAX_SAMPLE_GAP_SECS {
                return Err(bad(
                    path,
                    n.clone(),
                    format!(
                        "a gap of {:.3} s after the previous {} hand sample (at {} s): at most {MAX_SAMPLE_GAP_SECS} s \
                         between a hand's samples",
                        s.t - last[k],
                        s.hand,
                        last[k]
                    ),
                ));
            }
            if s.t < last[k] {
                return Err(bad(
                    path,
                    n.clone(),
                    format!(
                        "time {} goes backwards for the {} hand (previous {})",
                        s.t, s.hand, last[k]
                    ),
                ));
            }
            last[k] = s.t;
        }
        Ok(())
    }

    /// Writes the stream as JSON lines.
    pub fn to_jsonl(&self) -> String {
        let mut out = String::new();
        for s in &self.samples {
            out.push_str(&serde_json::to_string(s).expect("serialisable"));
            out.push('\n');
        }
        out
    }

    /// Writes the stream as CSV.
    pub fn to_csv(&self) -> String {
        let mut out = String::from(CSV_HEADER);
        out.push('\n');
        for s in &self.samples {
            let [x, y, z] = s.position;
            let [qx, qy, qz, qw] = s.orientation;
            out.push_str(&format!(
                "{},{},{x},{y},{z},{qx},{qy},{qz},{qw},{}\n",
                s.t,
                s.hand.prefix(),
                s.flexion
            ));
        }
        out
    }

    /// Time of the last sample.
    pub fn duration(&self) -> f64 {
        self.samples.iter().map(|s| s.t).fold(0.0, f64::max)
    }
}

fn parse_arm(s: &str) -> Option<Arm> {
    match s {
        "left" => Some(Arm::Left),
        "right" => Some(Arm::Right),
        _ => None,
    }
}

fn hand_index(arm: Arm) -> usize {
    match arm {
        Arm::Left => 0,
        Arm::Right => 1,
    }
}

/// Plays a [`TeleopStream`] back: the latest sample at or before `t` per hand.
#[derive(Debug, Clone)]
pub struct Replay {
    stream: TeleopStream,
    next: usize,
    current: [Option<HandCommand>; 2],
}

impl Replay {
    /// A player at time 0.
    pub fn new(stream: TeleopStream) -> Replay {
        Replay {
            stream,
            next: 0,
            current: [None, None],
        }
    }

    /// Advances to `t` and returns the commands in force, per hand (left, right).
    pub fn at(&mut self, t: f64) -> [Option<HandCommand>; 2] {
        while self.next < self.stream.samples.len() && self.stream.samples[self.next].t <= t {
            let s = self.stream.samples[self.next];
            self.current[hand_index(s.hand)] = Some(s);
            self.next += 1;
        }
        self.current
    }

    /// Whether every sample has been played.
    pub fn finished(&self) -> bool {
        self.next >= self.stream.samples.len()
    }

    /// Duration of the stream.
    pub fn duration(&self) -> f64 {
        self.stream.duration()
    }
}

/// Drives Dexter's hands from hand commands: Reach ◁ Manipulability tracks the commanded palm pose,
/// the hand's motor units take the flexion (a real teleoperation system maps the glove this way).
#[derive(Debug)]
pub struct TeleopDriver {
    reach: [ReachControl; 2],
    hand: [HandControl; 2],
}

impl TeleopDriver {
    /// A driver for both arms of `sim`.
    pub fn new(hw: &dyn Hardware) -> Result<TeleopDriver, SimError> {
        let r = crate::error::from_robot;
        Ok(TeleopDriver {
            reach: [
                ReachControl::new(hw, Arm::Left).map_err(r)?,
                ReachControl::new(hw, Arm::Right).map_err(r)?,
            ],
            hand: [
                HandControl::new(hw, Arm::Left).map_err(r)?,
                HandControl::new(hw, Arm::Right).map_err(r)?,
            ],
        })
    }

    /// One control tick: every hand with a command tracks it.
    pub fn tick(&mut self, hw: &mut dyn Hardware, commands: &[Option<HandCommand>; 2], dt: f64) {
        for (k, command) in commands.iter().enumerate() {
            if let Some(c) = command {
                self.reach[k].track(hw, c.pose());
                self.hand[k].set(hw, c.flexion, 0.0);
            }
            self.reach[k].tick(hw, dt);
        }
    }

    /// The measured palm pose of `arm`.
    pub fn palm_pose(&mut self, hw: &dyn Hardware, arm: Arm) -> Iso3 {
        self.reach[hand_index(arm)].tool_pose(hw)
    }

    /// Mean measured flexion of `arm`'s fingers.
    pub fn flexion(&self, hw: &dyn Hardware, arm: Arm) -> f64 {
        let f = self.hand[hand_index(arm)].flexion(hw);
        (f[0] + f[1] + f[2]) / 3.0
    }
}

/// A task for the scripted teacher.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum TeachTask {
    /// Pick `object` and place it in `place` with `arm`; `retry`: the first grasp closes too early and
    /// is retried.
    PickPlace {
        /// Object (scene label).
        object: String,
        /// Place name.
        place: String,
        /// Arm.
        arm: Arm,
        /// Fail the first grasp and retry.
        retry: bool,
    },
    /// Pick `object` with `arm`, put it down on the table at `handoff`, and let the other arm take it
    /// from there and place it in `place` (a hand-to-hand pass; a schema a user writes).
    PassPlace {
        /// Object (scene label).
        object: String,
        /// Place name.
        place: String,
        /// The arm that picks; the other one places.
        arm: Arm,
        /// Where on the table (x, y in m) the object is put down between the hands.
        handoff: [f64; 2],
    },
    /// Pick `object` up and hold it in the air (rival schema).
    PickHold {
        /// Object.
        object: String,
        /// Arm.
        arm: Arm,
    },
    /// Pick `object` up and give it to the teacher, who takes it from the open hand (rival schema).
    HandOver {
        /// Object.
        object: String,
        /// Arm.
        arm: Arm,
    },
    /// Reach to `object` and touch its top with open fingers (rival schema).
    Touch {
        /// Object.
        object: String,
        /// Arm.
        arm: Arm,
    },
    /// Move the hands about above the table without touching anything (explained by no schema).
    Wander {
        /// Arm.
        arm: Arm,
        /// Duration (s).
        seconds: f64,
    },
}

/// A smooth move of one hand: minimum-jerk from `from` to `to` over `duration`, then hold.
#[derive(Debug, Clone, Copy)]
struct Move {
    start: f64,
    duration: f64,
    from: Iso3,
    to: Iso3,
    flex_from: f64,
    flex_to: f64,
}

impl Move {
    fn at(&self, t: f64) -> (Iso3, f64) {
        let tau = ((t - self.start) / self.duration).clamp(0.0, 1.0);
        let s = tau * tau * tau * (10.0 - 15.0 * tau + 6.0 * tau * tau);
        let p = self.from.translation.vector.lerp(&self.to.translation.vector, s);
        let r = self.from.rotation.slerp(&self.to.rotation, s);
        (
            Iso3::from_parts(Translation3::from(p), r),
            self.flex_from + (self.flex_to - self.flex_from) * s,
        )
    }

    fn end(&self) -> f64 {
        self.start + self.duration
    }
}

/// The horizontal radius (m) of object `i` as it is posed now: the larger of its half extents along
/// the world's x and y.
fn footprint_radius(sim: &DexterSim, scene: &Scene, i: usize) -> f64 {
    let pose = sim.object_state(i).pose;
    let shape = &scene.catalog.objects[sim.objects()[i].catalog_index].shape;
    let along = |d: Vec3| geometry::support_half_extent(shape, &(pose.rotation.inverse() * d));
    along(Vec3::x()).max(along(Vec3::y()))
}

/// Where in place `place` the scripted teacher puts object `carried` down: the point of a 9 × 9 grid
/// over the place's floor (kept clear of the walls by the object's radius + 1.5 cm) farthest from the
/// objects already in the place (their edges), nearest the centre among equals. The centre when the
/// place is empty. (The teacher is the world: it sees the objects' true poses.)
fn free_spot(sim: &DexterSim, scene: &Scene, place: usize, carried: usize) -> [f64; 2] {
    let spec = &scene.spec.places[place];
    let r = footprint_radius(sim, scene, carried);
    let [cx, cy] = spec.center;
    let [sx, sy] = spec.size;
    let inside = |x: f64, y: f64| (x - cx).abs() <= 0.5 * sx && (y - cy).abs() <= 0.5 * sy;
    let others: Vec<([f64; 2], f64)> = (0..sim.objects().len())
        .filter(|&j| j != carried)
        .filter_map(|j| {
            let p = sim.object_state(j).pose.translation.vector;
            inside(p.x, p.y).then(|| ([p.x, p.y], footprint_radius(sim, scene, j)))
        })
        .collect();
    if others.is_empty() {
        return spec.center;
    }
    let half = |s: f64| (0.5 * s - r - 0.015).max(0.0);
    let (hx, hy) = (half(sx), half(sy));
    let mut best = (f64::NEG_INFINITY, spec.center);
    for i in 0..9 {
        for j in 0..9 {
            let x = cx + hx * (i as f64 / 4.0 - 1.0);
            let y = cy + hy * (j as f64 / 4.0 - 1.0);
            let clear = others
                .iter()
                .map(|(q, rq)| (x - q[0]).hypot(y - q[1]) - rq)
                .fold(f64::INFINITY, f64::min);
            let score = clear - 1e-3 * (x - cx).hypot(y - cy);
            if score > best.0 {
                best = (score, [x, y]);
            }
        }
    }
    best.1
}

/// Steps of the teacher's plan; each is turned into moves when it starts, from what the teacher sees
/// then (a human looks at the scene; the teacher reads true object poses, the robot does not).
#[derive(Debug, Clone, PartialEq)]
enum Step {
    Pause(f64),
    Hover { object: usize },
    Descend { object: usize, early: bool },
    Close,
    Lift { rise: f64 },
    CheckHeld { object: usize },
    OverPlace { place: usize, object: usize },
    OverSpot { xy: [f64; 2] },
    Lower { place: usize, object: usize },
    Open,
    Retreat { rise: f64 },
    TakeAway { object: usize },
    Park,
    TouchTop { object: usize },
    TouchDown { to: Iso3 },
    SwitchArm(Arm),
    WanderTo { target: Vec3 },
    Reopen,
}

/// The scripted, human-like teacher: glove-rate samples (30 Hz) of smooth minimum-jerk hand motions
/// with sensor noise (1 mm, 0.01 rad), physiological tremor (8–12 Hz, ≈1.5 mm), hesitations before
/// moves, and — when asked — a failed grasp that is retried. Deterministic for a seed.
#[derive(Debug)]
pub struct Teacher {
    arm: Arm,
    steps: Vec<Step>,
    index: usize,
    current: Option<Move>,
    pose: Iso3,
    flex: f64,
    rng: Generator,
    tremor: [(f64, f64, f64); 3],
    glove_period: f64,
    next_sample: f64,
    held: [Option<HandCommand>; 2],
    /// Grasp plan of the current object.
    plan: Option<GraspPlan>,
    /// Object carried: palm-to-object-bottom height (m).
    carry_depth: f64,
    table_z: f64,
    done: bool,
    /// Teleop samples emitted so far.
    pub log: TeleopStream,
    /// Notes on what happened (retries, failures).
    pub notes: Vec<String>,
    /// Objects the teacher took out of the robot's hand (hand-over).
    pub taken: Vec<usize>,
}

const GLOVE_HZ: f64 = 30.0;

impl Teacher {
    /// A teacher for `task` in `scene` on `sim` (already parked), seeded.
    pub fn new(sim: &DexterSim, scene: &Scene, task: &TeachTask, seed: u64) -> Result<Teacher, SimError> {
        Self::with_tasks(sim, scene, std::slice::from_ref(task), seed)
    }

    /// A teacher that does `tasks` one after the other (a sorting demo), each with its own arm; the
    /// teacher parks one hand before using the other.
    pub fn with_tasks(sim: &DexterSim, scene: &Scene, tasks: &[TeachTask], seed: u64) -> Result<Teacher, SimError> {
        let mut rng = bayes::rng::seeded(seed ^ 0x7e4c_11e5);
        let table_z = scene.spec.table.height;
        let mut steps = Vec::new();
        let mut first_arm = None;
        let mut last_arm: Option<Arm> = None;
        for task in tasks {
            let arm = match task {
                TeachTask::PickPlace { arm, .. }
                | TeachTask::PassPlace { arm, .. }
                | TeachTask::PickHold { arm, .. }
                | TeachTask::HandOver { arm, .. }
                | TeachTask::Touch { arm, .. }
                | TeachTask::Wander { arm, .. } => *arm,
            };
            if last_arm.is_some_and(|a| a != arm) {
                steps.push(Step::SwitchArm(arm));
            }
            first_arm = first_arm.or(Some(arm));
            last_arm = Some(arm);
            let hesitate = |rng: &mut Generator| Step::Pause(0.2 + 0.6 * rng.uniform());
            match task {
                TeachTask::PickPlace {
                    object, place, retry, ..
                } => {
                    let o = sim.object(object)?;
                    let p = place_index(scene, place)?;
                    steps.push(hesitate(&mut rng));
                    steps.push(Step::Hover { object: o });
                    if *retry {
                        steps.push(Step::Descend { object: o, early: true });
                        steps.push(Step::Close);
                        steps.push(Step::Lift { rise: 0.06 });
                        steps.push(Step::Pause(0.4));
                        steps.push(Step::Reopen);
                        steps.push(hesitate(&mut rng));
                        steps.push(Step::Hover { object: o });
                    }
                    steps.extend(grasp_and_lift(o));
                    steps.push(Step::OverPlace { place: p, object: o });
                    steps.push(Step::Pause(0.3));
                    steps.push(Step::Lower { place: p, object: o });
                    steps.extend(let_go_and_retreat());
                }
                TeachTask::PassPlace {
                    object, place, handoff, ..
                } => {
                    let o = sim.object(object)?;
                    let p = place_index(scene, place)?;
                    let carry = |steps: &mut Vec<Step>, rng: &mut Generator| {
                        steps.push(hesitate(rng));
                        steps.push(Step::Hover { object: o });
                        steps.extend(grasp_and_lift(o));
                    };
                    // The first hand puts it down between the hands and goes back to its park pose.
                    carry(&mut steps, &mut rng);
                    steps.push(Step::OverSpot { xy: *handoff });
                    steps.push(Step::Pause(0.3));
                    steps.push(Step::Lower { place: p, object: o });
                    steps.extend(let_go_and_retreat());
                    steps.push(Step::Park);
                    steps.push(Step::Pause(0.8));
                    // The other hand takes it from there to the place.
                    steps.push(Step::SwitchArm(arm.other()));
                    carry(&mut steps, &mut rng);
                    steps.push(Step::OverPlace { place: p, object: o });
                    steps.push(Step::Pause(0.3));
                    steps.push(Step::Lower { place: p, object: o });
                    steps.extend(let_go_and_retreat());
                    last_arm = Some(arm.other());
                }
                TeachTask::PickHold { object, .. } => {
                    let o = sim.object(object)?;
                    steps.push(hesitate(&mut rng));
                    steps.extend(pick_up(o, 0.15));
                    steps.push(Step::Pause(2.5));
                }
                TeachTask::HandOver { object, .. } => {
                    let o = sim.object(object)?;
                    steps.push(hesitate(&mut rng));
                    steps.extend(pick_up(o, 0.15));
                    steps.push(Step::Pause(0.8));
                    steps.push(Step::Open);
                    steps.push(Step::TakeAway { object: o });
                    steps.push(Step::Pause(0.5));
                    steps.push(Step::Retreat { rise: 0.10 });
                }
                TeachTask::Touch { object, .. } => {
                    let o = sim.object(object)?;
                    steps.push(hesitate(&mut rng));
                    steps.push(Step::Hover { object: o });
                    steps.push(Step::TouchTop { object: o });
                    steps.push(Step::Pause(0.8));
                    steps.push(Step::Retreat { rise: 0.12 });
                }
                TeachTask::Wander { seconds, .. } => {
                    let s = if arm == Arm::Left { 1.0 } else { -1.0 };
                    let mut t = 0.0;
                    while t < *seconds {
                        // Free space well above anything on the table.
                        let target = Vec3::new(
                            0.35 + 0.25 * rng.uniform(),
                            s * (0.05 + 0.35 * rng.uniform()),
                            table_z + 0.30 + 0.15 * rng.uniform(),
                        );
                        steps.push(Step::WanderTo { target });
                        let pause = 0.3 + 0.8 * rng.uniform();
                        steps.push(Step::Pause(pause));
                        t += 1.8 + pause;
                    }
                }
            }
            if !matches!(task, TeachTask::PickHold { .. }) {
                steps.push(Step::Park);
                steps.push(Step::Pause(0.8));
            }
        }
        let arm = first_arm.ok_or_else(|| SimError::Invalid {
            path: "<teacher>".into(),
            field: "tasks".into(),
            message: "no task for the teacher".into(),
        })?;
        let tremor = std::array::from_fn(|_| {
            (
                8.0 + 4.0 * rng.uniform(),
                std::f64::consts::TAU * rng.uniform(),
                0.0015 * (0.5 + rng.uniform()),
            )
        });
        let pose = park_pose(arm, table_z);
        Ok(Teacher {
            arm,
            steps,
            index: 0,
            current: None,
            pose,
            flex: 0.3,
            rng,
            tremor,
            glove_period: 1.0 / GLOVE_HZ,
            next_sample: 0.0,
            held: [None, None],
            plan: None,
            carry_depth: 0.1,
            table_z,
            done: false,
            log: TeleopStream::default(),
            notes: Vec::new(),
            taken: Vec::new(),
        })
    }

    /// The arm the teacher uses now.
    pub fn arm(&self) -> Arm {
        self.arm
    }

    /// Whether the script has finished.
    pub fn finished(&self) -> bool {
        self.done
    }

    /// The glove's output at time `t` (s): the latest sample, refreshed at 30 Hz. The teacher watches
    /// `sim` to decide (a human sees the scene).
    pub fn command(
        &mut self,
        sim: &mut DexterSim,
        scene: &Scene,
        t: f64,
    ) -> Result<[Option<HandCommand>; 2], SimError> {
        self.advance(sim, scene, t)?;
        if t + 1e-12 >= self.next_sample {
            self.next_sample += self.glove_period;
            let mut pose = self.pose;
            let mut d = Vec3::zeros();
            for (k, (f, phase, amp)) in self.tremor.iter().enumerate() {
                d[k] = amp * (std::f64::consts::TAU * f * t + phase).sin() + 0.001 * self.rng.normal();
            }
            pose.translation.vector += d;
            let w = Vec3::new(self.rng.normal(), self.rng.normal(), self.rng.normal()) * 0.01;
            pose.rotation = Rot3::from_scaled_axis(w) * pose.rotation;
            let c = HandCommand::new(t, self.arm, &pose, self.flex.clamp(0.0, FLEX_CLOSED));
            self.log.samples.push(c);
            self.held[hand_index(self.arm)] = Some(c);
        }
        Ok(self.held)
    }

    fn begin(&mut self, t: f64, to: Iso3, flex_to: f64, speed: f64) {
        let dist = (to.translation.vector - self.pose.translation.vector).norm();
        let ang = self.pose.rotation.angle_to(&to.rotation);
        // Humans take longer for longer moves (Fitts); a little variability.
        let duration = (0.4 + dist / speed + ang / 1.5) * (0.9 + 0.2 * self.rng.uniform());
        self.current = Some(Move {
            start: t,
            duration: duration.max((flex_to - self.flex).abs() / 2.0),
            from: self.pose,
            to,
            flex_from: self.flex,
            flex_to,
        });
    }

    fn advance(&mut self, sim: &mut DexterSim, scene: &Scene, t: f64) -> Result<(), SimError> {
        if let Some(m) = self.current {
            let (p, f) = m.at(t);
            self.pose = p;
            self.flex = f;
            if t < m.end() {
                return Ok(());
            }
            // A teacher watches the robot: the next move waits until the robot's hand has caught up
            // with the glove (within 1.5 cm and 0.06 rad), or for at most 3 s.
            let palm = sim.link_pose_by_name(&format!("{}/bhand/palm_surface_link", self.arm.prefix()))?;
            let behind = (palm.translation.vector - self.pose.translation.vector).norm() > 0.015
                || palm.rotation.angle_to(&self.pose.rotation) > 0.06;
            if behind && t < m.end() + 3.0 {
                return Ok(());
            }
            self.current = None;
        }
        let Some(step) = self.steps.get(self.index).cloned() else {
            self.done = true;
            return Ok(());
        };
        self.index += 1;
        let here = self.pose;
        match step {
            Step::Pause(s) => self.begin_pause(t, s),
            Step::Hover { object } => {
                let plan = self.grasp_plan(sim, scene, object)?;
                self.plan = Some(plan);
                let mut hover = plan.grasp;
                hover.translation.vector.z += 0.10;
                hover.translation.vector.z = hover.translation.z.max(here.translation.z.min(self.table_z + 0.45));
                self.begin(t, hover, plan.preshape, 0.25);
            }
            Step::Descend { object, early } => {
                let plan = match self.plan {
                    Some(p) => p,
                    None => self.grasp_plan(sim, scene, object)?,
                };
                let mut g = plan.grasp;
                if early {
                    // Closes too early: the fingers shut on air above the object.
                    g.translation.vector.z += 0.12;
                    self.notes
                        .push(format!("t={t:.1}s: grasp closed too early (to be retried)"));
                }
                self.begin(t, g, plan.preshape, 0.12);
            }
            Step::Close => self.begin(t, here, FLEX_CLOSED, 1.0),
            Step::Reopen => {
                let preshape = self.plan.map_or(0.3, |p| p.preshape);
                let mut up = here;
                up.translation.vector.z += 0.04;
                self.begin(t, up, preshape, 0.2);
            }
            Step::Lift { rise } => {
                let mut up = here;
                up.translation.vector.z += rise;
                self.begin(t, up, self.flex, 0.12);
            }
            Step::CheckHeld { object } => {
                let z = sim.object_state(object).pose.translation.z;
                let rest = scene.resolved[sim.objects()[object].scene_index].pose.translation.z;
                if z < rest + 0.05 {
                    self.notes.push(format!(
                        "t={t:.1}s: the object was not lifted; the teacher gives up on it"
                    ));
                    // Skip the rest of this task: open, back off, and go on with the next task.
                    let end = self.steps[self.index..]
                        .iter()
                        .position(|s| *s == Step::Park)
                        .map_or(self.steps.len(), |k| self.index + k);
                    self.steps
                        .splice(self.index..end, [Step::Open, Step::Retreat { rise: 0.1 }]);
                } else {
                    let palm = self.pose.translation.z;
                    let op = sim.object_state(object).pose;
                    let shape = &scene.catalog.objects[sim.objects()[object].catalog_index].shape;
                    let bottom =
                        op.translation.z - geometry::support_half_extent(shape, &(op.rotation.inverse() * -Vec3::z()));
                    self.carry_depth = palm - bottom;
                }
                self.begin_pause(t, 0.05);
            }
            Step::OverPlace { place, object } => {
                let spec = &scene.spec.places[place];
                let z = (self.table_z + spec.wall_height + self.carry_depth + 0.08).max(here.translation.z);
                // The palm over a free spot of the place (the teacher sees what is already in it).
                let spot = free_spot(sim, scene, place, object);
                let to = Iso3::from_parts(Translation3::new(spot[0], spot[1], z), here.rotation);
                self.begin(t, to, self.flex, 0.22);
            }
            Step::OverSpot { xy } => {
                let z = (self.table_z + self.carry_depth + 0.08).max(here.translation.z);
                let to = Iso3::from_parts(Translation3::new(xy[0], xy[1], z), here.rotation);
                self.begin(t, to, self.flex, 0.22);
            }
            Step::Lower { place, object: _ } => {
                let spec = &scene.spec.places[place];
                let _ = spec;
                let mut down = here;
                // Down until the object sits on the floor of the place, pressing a little.
                down.translation.vector.z = self.table_z + 0.002 + self.carry_depth - 0.015;
                self.begin(t, down, self.flex, 0.08);
            }
            Step::Open => self.begin(t, here, 0.3, 1.0),
            Step::TakeAway { object } => {
                // The teacher takes the object out of the open hand and puts it aside, off the table.
                let aside = Iso3::translation(-0.6, 0.0, 0.2);
                sim.teleport_object(object, &aside);
                self.taken.push(object);
                self.notes.push(format!("t={t:.1}s: the teacher took the object"));
                self.begin_pause(t, 0.05);
            }
            Step::Retreat { rise } => {
                let mut up = here;
                up.translation.vector.z += rise;
                self.begin(t, up, 0.3, 0.25);
            }
            Step::Park => {
                let park = park_pose(self.arm, self.table_z);
                self.begin(t, park, 0.3, 0.25);
            }
            Step::TouchTop { object } => {
                // One fingertip (F3) on the object's top, the others beside it: the palm is offset
                // so that F3's tip, at the open-hand flexion, is above the centre.
                let op = sim.object_state(object).pose;
                let shape = &scene.catalog.objects[sim.objects()[object].catalog_index].shape;
                let top = op.translation.z + geometry::support_half_extent(shape, &(op.rotation.inverse() * Vec3::z()));
                let arc = finger_arc(sim, self.arm)?;
                let &(_, lateral, depth) = arc
                    .iter()
                    .min_by(|a, b| (a.0 - 0.3).abs().total_cmp(&(b.0 - 0.3).abs()))
                    .expect("the arc has samples");
                const TIP_RADIUS: f64 = 0.01;
                let mut to = here;
                let f3 = here.rotation * Vec3::new(0.0, lateral, 0.0);
                to.translation.vector.x = op.translation.x - f3.x;
                to.translation.vector.y = op.translation.y - f3.y;
                to.translation.vector.z = top + depth.abs() + TIP_RADIUS - 0.008;
                // First above the touch point, then down onto it.
                let mut above = to;
                above.translation.vector.z += 0.06;
                self.steps.insert(self.index, Step::TouchDown { to });
                self.begin(t, above, 0.3, 0.2);
            }
            Step::TouchDown { to } => self.begin(t, to, 0.3, 0.05),
            Step::SwitchArm(arm) => {
                // The teacher puts the other glove on: that hand starts from where it is parked.
                self.arm = arm;
                self.pose = park_pose(arm, self.table_z);
                self.flex = 0.3;
                self.plan = None;
                self.begin_pause(t, 0.3);
            }
            Step::WanderTo { target } => {
                let to = Iso3::from_parts(Translation3::from(target), here.rotation);
                let flex = 0.3 + 0.3 * self.rng.uniform();
                self.begin(t, to, flex, 0.2);
            }
        }
        Ok(())
    }

    fn begin_pause(&mut self, t: f64, s: f64) {
        self.current = Some(Move {
            start: t,
            duration: s,
            from: self.pose,
            to: self.pose,
            flex_from: self.flex,
            flex_to: self.flex,
        });
    }

    fn grasp_plan(&self, sim: &DexterSim, scene: &Scene, object: usize) -> Result<GraspPlan, SimError> {
        let arc = finger_arc(sim, self.arm)?;
        let shape = &scene.catalog.objects[sim.objects()[object].catalog_index].shape;
        let pose = sim.object_state(object).pose;
        let current = Iso3::from_parts(
            self.pose.translation,
            top_down_orientation(&Vec3::x(), &self.pose.rotation),
        );
        let mut plan = plan_top_grasp(&arc, shape, &pose, self.table_z, &current);
        // F1 and F2 (palm −y) spread wider than F3: put them on the side towards the middle of the
        // table, away from the bins at its sides.
        let f12 = plan.grasp.rotation * -Vec3::y();
        if f12.y * pose.translation.y > 0.0 {
            plan.grasp.rotation *= Rot3::from_axis_angle(&Vec3::z_axis(), std::f64::consts::PI);
        }
        Ok(plan)
    }
}

/// From above object `o`: down to the grasp, close, wait until the grasp feels firm, lift 12 cm,
/// and check that the object came up.
fn grasp_and_lift(o: usize) -> [Step; 6] {
    [
        Step::Descend {
            object: o,
            early: false,
        },
        Step::Close,
        Step::Pause(0.5),
        Step::Lift { rise: 0.12 },
        Step::Pause(0.6),
        Step::CheckHeld { object: o },
    ]
}

/// With the object set down: open the hand and rise 15 cm away from it.
fn let_go_and_retreat() -> [Step; 4] {
    [
        Step::Pause(0.5),
        Step::Open,
        Step::Pause(0.4),
        Step::Retreat { rise: 0.15 },
    ]
}

/// Hover over object `o`, go down to the grasp, close, and lift by `rise` (m).
fn pick_up(o: usize, rise: f64) -> [Step; 4] {
    [
        Step::Hover { object: o },
        Step::Descend {
            object: o,
            early: false,
        },
        Step::Close,
        Step::Lift { rise },
    ]
}

fn place_index(scene: &Scene, name: &str) -> Result<usize, SimError> {
    scene.place(name)?;
    Ok(scene
        .spec
        .places
        .iter()
        .position(|p| p.name == name)
        .expect("scene.place found it"))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(name: &str, text: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("pbd-teleop-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    #[test]
    fn csv_and_jsonl_round_trip() {
        let pose = Iso3::translation(0.4, 0.2, 0.9);
        let s = TeleopStream {
            samples: vec![
                HandCommand::new(0.0, Arm::Left, &pose, 0.3),
                HandCommand::new(0.033, Arm::Left, &pose, 0.5),
            ],
        };
        let a = TeleopStream::load(write("a.csv", &s.to_csv())).unwrap();
        let b = TeleopStream::load(write("a.jsonl", &s.to_jsonl())).unwrap();
        assert_eq!(a, s);
        assert_eq!(b, s);
    }

    #[test]
    fn bad_files_name_the_line() {
        for (name, text, needle) in [
            ("h.csv", "t,hand,x,y,z\n0,left,0,0,0\n", "header"),
            (
                "c.csv",
                "t,hand,x,y,z,qx,qy,qz,qw,flexion\n0,left,0,0,0,0,0,0,1\n",
                "9 columns",
            ),
            (
                "m.csv",
                "t,hand,x,y,z,qx,qy,qz,qw,flexion\n1,left,0,0,0,0,0,0,1,0\n0.5,left,0,0,0,0,0,0,1,0\n",
                "backwards",
            ),
            (
                "q.csv",
                "t,hand,x,y,z,qx,qy,qz,qw,flexion\n0,left,0,0,0,0,0,0,2,0\n",
                "unit quaternion",
            ),
            (
                "n.csv",
                "t,hand,x,y,z,qx,qy,qz,qw,flexion\n0,left,0,nan,0,0,0,0,1,0\n",
                "finite",
            ),
            (
                "a.csv",
                "t,hand,x,y,z,qx,qy,qz,qw,flexion\n0,middle,0,0,0,0,0,0,1,0\n",
                "middle",
            ),
            ("e.jsonl", "", "no samples"),
            ("j.jsonl", "{\"t\":0}\n", "line 1"),
        ] {
            let err = TeleopStream::load(write(name, text)).unwrap_err().to_string();
            assert!(err.contains(name) && err.contains(needle), "{name}: {err}");
        }
    }
}
