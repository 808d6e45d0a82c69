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
    /// The kept *colour terms* ([`color_term`]) of the segment's pixels, as (term, share) with
    /// shares summing to 1, the same 20th-percentile rule applied as to the histogram. Empty in
    /// recordings made before the terms were added.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub colors: Vec<(u8, f64)>,
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

/// Hue boundaries (degrees) between the chromatic terms, half-way between their focal hues (red
/// 0°, orange 30°, yellow 55°, green 120°, blue 220°, purple 275°, pink 330°).
const HUE_BOUNDS: [(f64, u8); 7] = [
    (15.0, 3),
    (42.0, 4),
    (85.0, 5),
    (170.0, 6),
    (248.0, 7),
    (302.0, 8),
    (345.0, 9),
];

/// The colour term (index into [`COLOR_TERMS`]) of an HSV colour (`[h_deg, s, v]`, s and v in
/// [0, 1]): black when v < ¼, grey or white when s < ¼ (by v < ¾), otherwise the hue's term.
///
/// **Why terms, not the 64 histogram bins.** The seed's uniform 4 × 4 × 4 HSV partition
/// (§5.1.2.1) cuts hue into 90° cells starting at 0°: red and orange (and yellow) share one cell
/// and a red surface straddles two. The model of ch. 5 needs colour *categories* that shading
/// does not move an object between and that a teacher would name, so it counts pixels by the
/// hue regions people name (the histogram stays for stereo matching and display).
#[inline]
pub fn color_term(hsv: [f64; 3]) -> u8 {
    let (h, s, v) = (hsv[0].rem_euclid(360.0), hsv[1], hsv[2]);
    if v < 0.25 {
        0
    } else if s < 0.25 {
        if v < 0.75 { 1 } else { 2 }
    } else {
        HUE_BOUNDS.iter().find(|b| h < b.0).map_or(3, |b| b.1)
    }
}

/// The count threshold of the 20th-percentile rule of §5.1.2.1: the 20th percentile (nearest
/// rank, the ⌈0.2·n⌉-th smallest) of the n non-zero counts; 0 when every count is 0. No
/// allocation (a rank count per value, for the few dozen bins of a colour feature).
pub fn percentile20_threshold(counts: &[u32]) -> u32 {
    let n = counts.iter().filter(|&&c| c > 0).count();
    if n == 0 {
        return 0;
    }
    let rank = (0.2 * n as f64).ceil().max(1.0) as usize;
    counts
        .iter()
        .copied()
        .filter(|&c| {
            let below = counts.iter().filter(|&&o| o > 0 && o < c).count();
            let upto = counts.iter().filter(|&&o| o > 0 && o <= c).count();
            c > 0 && below < rank && rank <= upto
        })
        .min()
        .unwrap_or(0)
}

/// The kept colour terms of per-term pixel counts: the 20th-percentile rule of §5.1.2.1 (terms
/// whose count is below the ⌈0.2·n⌉-th smallest of the n non-zero counts are dropped), as
/// (term, share of the kept pixels), ascending by term.
pub fn kept_color_terms(counts: &[u32; 10]) -> Vec<(u8, f64)> {
    let threshold = percentile20_threshold(counts);
    if threshold == 0 {
        return Vec::new();
    }
    let kept: Vec<(u8, u32)> = counts
        .iter()
        .enumerate()
        .filter(|(_, c)| **c > 0 && **c >= threshold)
        .map(|(t, &c)| (t as u8, c))
        .collect();
    let total: f64 = kept.iter().map(|k| f64::from(k.1)).sum();
    kept.into_iter().map(|(t, c)| (t, f64::from(c) / total)).collect()
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
                || s.colors
                    .iter()
                    .any(|(t, w)| !w.is_finite() || usize::from(*t) >= COLOR_TERMS.len())
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colour_terms_name_the_catalog_colours() {
        let name = |hsv| COLOR_TERMS[usize::from(color_term(hsv))];
        // Red wraps around 0°: both sides are red; orange and paprika are orange, not red (the
        // 4 × 4 × 4 histogram puts red, orange and yellow in one hue cell).
        assert_eq!(name([2.0, 0.85, 0.8]), "red");
        assert_eq!(name([358.0, 0.85, 0.8]), "red");
        assert_eq!(name([28.0, 0.9, 0.95]), "orange");
        assert_eq!(name([16.0, 0.88, 0.85]), "orange");
        assert_eq!(name([52.0, 0.85, 0.95]), "yellow");
        assert_eq!(name([95.0, 0.7, 0.85]), "green");
        assert_eq!(name([140.0, 0.75, 0.4]), "green");
        assert_eq!(name([200.0, 0.65, 0.92]), "blue");
        assert_eq!(name([220.0, 0.85, 0.75]), "blue");
        assert_eq!(name([275.0, 0.7, 0.7]), "purple");
        assert_eq!(name([335.0, 0.55, 0.92]), "pink");
        // Achromatic: value first, then saturation; hue is ignored.
        assert_eq!(name([220.0, 0.15, 0.10]), "black");
        assert_eq!(name([210.0, 0.06, 0.5]), "grey");
        assert_eq!(name([40.0, 0.04, 0.96]), "white");
        for (t, hsv) in COLOR_TERM_HSV.iter().enumerate() {
            assert_eq!(usize::from(color_term(*hsv)), t, "{}", COLOR_TERMS[t]);
        }
    }

    #[test]
    fn kept_terms_follow_the_20th_percentile_rule() {
        assert!(kept_color_terms(&[0; 10]).is_empty());
        // Five non-zero counts: the rule's threshold is the smallest (rank ⌈0.2·5⌉ = 1), so all
        // five are kept; with six, rank 2 drops the smallest.
        let five = kept_color_terms(&[1, 0, 10, 30, 0, 0, 0, 50, 0, 9]);
        assert_eq!(five.iter().map(|t| t.0).collect::<Vec<_>>(), [0, 2, 3, 7, 9]);
        let six = kept_color_terms(&[1, 2, 10, 30, 0, 0, 0, 50, 0, 9]);
        assert_eq!(six.iter().map(|t| t.0).collect::<Vec<_>>(), [1, 2, 3, 7, 9]);
        let total: f64 = six.iter().map(|t| t.1).sum();
        assert!((total - 1.0).abs() < 1e-12);
        assert!((six[3].1 - 50.0 / 101.0).abs() < 1e-12);
    }
}
