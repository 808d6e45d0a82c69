//! What the robot perceives at one instant, in robot-neutral terms: the feedback elements its monitors
//! read (§4.2). A plant (the simulated Dexter, a real robot) fills one [`Percept`] per observation step;
//! recordings store them (MCAP channel `/pbd/percept`), and inference reads them back.
//!
//! Frames: every position is in the robot's world frame (m); forces in N.

use serde::{Deserialize, Serialize};

use crate::error::SchemaError;

/// Version of the percept record; written into every recording's metadata.
pub const PERCEPT_VERSION: u32 = 1;

/// One observation step.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Percept {
    /// Time since the start of the demonstration (s).
    pub t: f64,
    /// One entry per arm/hand.
    pub hands: Vec<HandPercept>,
    /// Segmented objects (tracked across frames by id).
    pub segments: Vec<SegmentPercept>,
    /// Places (bins, table regions) the robot knows.
    pub places: Vec<PlacePercept>,
    /// Height of the table surface (m).
    pub table_z: f64,
    /// The segment the head currently foveates with both cameras, if any (the Search-Track stimulus).
    pub gaze: Option<u32>,
}

/// One hand, from kinematics and the fingertip force/torque sensors.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HandPercept {
    /// Arm name (`left`, `right`).
    pub arm: String,
    /// Palm-surface point (m, world).
    pub palm: [f64; 3],
    /// Palm speed (m/s).
    pub palm_speed: f64,
    /// Mean finger flexion (rad; 0 open).
    pub flexion: f64,
    /// Contact force magnitude on each finger (N), from its fingertip sensor.
    pub finger_force: [f64; 3],
    /// Upward force the fingertips exert on what they touch (N): the weight they carry.
    pub load: f64,
}

/// One tracked segment (§5.1.2, §6.2.1).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SegmentPercept {
    /// Track id, stable across frames.
    pub id: u32,
    /// Triangulated centroid (m, world); the last estimate when not `seen`.
    pub centroid: [f64; 3],
    /// Whether both cameras saw it in this frame.
    pub seen: bool,
    /// Pixel count per camera (left, right) when last seen (§5.1.2.2).
    pub pixels: [u32; 2],
    /// The kept bins of the 64-bin HSV histogram (§5.1.2.1), as (bin, weight) with weights summing to 1.
    pub histogram: Vec<(u8, f64)>,
    /// Mean second-moment matrix over the stereo pair (px², §6.2.1), row-major 2×2.
    pub covariance: [f64; 4],
}

/// A place region.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PlacePercept {
    /// Name.
    pub name: String,
    /// Centre of the region's floor (m, world).
    pub center: [f64; 3],
    /// Half extents in x and y (m).
    pub half_extents: [f64; 2],
}

impl Percept {
    /// Checks that every number is finite and every id unique; `origin` names the stream in errors.
    pub fn validate(&self, origin: &str) -> Result<(), SchemaError> {
        let bad = |field: String| SchemaError::invalid(origin, field, "not a finite number");
        if !self.t.is_finite() {
            return Err(bad("t".into()));
        }
        if !self.table_z.is_finite() {
            return Err(bad("table_z".into()));
        }
        for (i, h) in self.hands.iter().enumerate() {
            let nums = h
                .palm
                .iter()
                .chain(&h.finger_force)
                .chain([&h.palm_speed, &h.flexion, &h.load]);
            if nums.into_iter().any(|v| !v.is_finite()) {
                return Err(bad(format!("hands[{i}]")));
            }
        }
        for (i, s) in self.segments.iter().enumerate() {
            if s.centroid.iter().chain(&s.covariance).any(|v| !v.is_finite())
                || s.histogram.iter().any(|(_, w)| !w.is_finite())
            {
                return Err(bad(format!("segments[{i}]")));
            }
            if self.segments[..i].iter().any(|o| o.id == s.id) {
                return Err(SchemaError::invalid(
                    origin,
                    format!("segments[{i}].id"),
                    format!("duplicate id {}", s.id),
                ));
            }
        }
        for (i, p) in self.places.iter().enumerate() {
            if p.center.iter().chain(&p.half_extents).any(|v| !v.is_finite()) {
                return Err(bad(format!("places[{i}]")));
            }
        }
        Ok(())
    }
}

/// Checks a percept stream: non-empty, each percept valid, time strictly increasing.
pub fn validate_stream(percepts: &[Percept], origin: &str) -> Result<(), SchemaError> {
    if percepts.is_empty() {
        return Err(SchemaError::Empty(format!("{origin} holds no percepts")));
    }
    for (i, p) in percepts.iter().enumerate() {
        p.validate(&format!("{origin}: percept {i}"))?;
        if i > 0 && p.t <= percepts[i - 1].t {
            return Err(SchemaError::invalid(
                origin,
                format!("percept {i}.t"),
                format!("time {} does not increase (previous {})", p.t, percepts[i - 1].t),
            ));
        }
    }
    Ok(())
}
