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
    /// The kept *colour terms* (`dexter::vision::color::color_term`) of the segment's pixels, as (term, share) with
    /// shares summing to 1, the same 20th-percentile rule applied as to the histogram. Empty in
    /// recordings made before the terms were added.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub colors: Vec<(u8, f64)>,
    /// The measured extent of the object on the support plane, when vision could measure it
    /// (§6.2.1): what grasps are planned from. Absent in older recordings.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub extent: Option<SeenExtent>,
}

/// An object's extent as the robot measured it: its height above the support plane and its
/// footprint's principal axes (m, world).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SeenExtent {
    /// Height above the support plane (m).
    pub height: f64,
    /// Footprint centre (x, y).
    pub center: [f64; 2],
    /// Unit direction (x, y) of the footprint's major axis.
    pub major_axis: [f64; 2],
    /// Half extent along the major axis (m).
    pub half_major: f64,
    /// Half extent along the minor axis (m).
    pub half_minor: f64,
    /// `prism` (flat top measured), `round` (a sphere's radius), `lying` (a round cross-section
    /// lying on its side: height its diameter, footprint along its axis), `standing` (a thing too
    /// tall to grasp, from its vertical edges: its depth along the line of sight assumed),
    /// `standing_whole` (the same, its footprint measured whole with the outline of its top) or
    /// `coarse` (from the silhouette size only).
    pub model: String,
}

impl SeenExtent {
    /// Half extent (m) along the horizontal unit direction `d` (the support function of the
    /// footprint's bounding box in its principal axes).
    pub fn half_extent_along(&self, d: [f64; 2]) -> f64 {
        let [ax, ay] = self.major_axis;
        let c = (d[0] * ax + d[1] * ay).abs();
        let s = (d[0] * -ay + d[1] * ax).abs();
        self.half_major * c + self.half_minor * s
    }
}

/// The colour terms, in index order: the basic colour terms of Berlin & Kay (1969) that a pixel
/// of a rendered or photographed household object can take (brown, a dark orange, is not told
/// from orange under shading and is left out).
pub const COLOR_TERMS: [&str; 10] = [
    "black", "grey", "white", "red", "orange", "yellow", "green", "blue", "purple", "pink",
];

/// A representative HSV colour (`[h_deg, s, v]`) of each colour term, for drawing.
pub const COLOR_TERM_HSV: [[f64; 3]; 10] = [
    [0.0, 0.0, 0.1],
    [0.0, 0.0, 0.55],
    [0.0, 0.0, 0.95],
    [0.0, 0.85, 0.85],
    [30.0, 0.9, 0.95],
    [56.0, 0.85, 0.95],
    [120.0, 0.7, 0.7],
    [220.0, 0.85, 0.8],
    [275.0, 0.7, 0.7],
    [330.0, 0.55, 0.92],
];

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
                || s.colors
                    .iter()
                    .any(|(t, w)| !w.is_finite() || usize::from(*t) >= COLOR_TERMS.len())
                || s.extent.as_ref().is_some_and(|e| {
                    [e.height, e.half_major, e.half_minor]
                        .iter()
                        .chain(&e.center)
                        .chain(&e.major_axis)
                        .any(|v| !v.is_finite())
                })
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
