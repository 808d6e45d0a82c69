//! Pre-grasp candidates drawn in the 3D panel (`/grasp/candidates`, `foxglove.SceneUpdate`): per
//! candidate, an arrow along the approach (the palm's +z) ending at the pre-grasp palm pose, a short
//! arrow along the palm's +x (the axis the fingers spread about), and a label; coloured by outcome
//! when it was tried (green held, red not), else by rank, green (first) to red (last).

use control_basis::math::{Iso3, Rot3, Vec3};

use super::messages::{ArrowPrimitive, Color, Pose, SceneEntity, SceneUpdate, TextPrimitive, Time, WORLD_FRAME};

/// Length of the approach arrow (m): the palm comes in along it.
const APPROACH_ARROW: f64 = 0.10;
/// Length of the finger-spread arrow (m).
const SPREAD_ARROW: f64 = 0.04;

/// One pre-grasp to draw.
#[derive(Debug, Clone, PartialEq)]
pub struct PreGraspMarker {
    /// Rank among the candidates (1 = best).
    pub rank: usize,
    /// The palm pose of the pre-grasp (world).
    pub world_from_palm: Iso3,
    /// Text shown next to it (e.g. `#1 prototype 2`).
    pub label: String,
    /// The candidate's group (e.g. the method that proposed it), part of the entity id
    /// `pre-grasp/<group>/<rank>`; empty: `pre-grasp/<rank>`.
    pub group: String,
    /// Whether the grasp held when it was executed; `None`: not executed (coloured by rank).
    pub held: Option<bool>,
}

fn arrow(origin: Vec3, dir: Vec3, length: f64, diameter: f64, color: Color) -> Option<ArrowPrimitive> {
    let d = dir.try_normalize(1e-9)?;
    // The arrow points along its pose's +x.
    let rotation = Rot3::rotation_between(&Vec3::x(), &d).unwrap_or_else(|| {
        // Opposite to +x: a half turn about z.
        Rot3::from_axis_angle(&Vec3::z_axis(), std::f64::consts::PI)
    });
    let head = (0.3 * length).min(0.03);
    Some(ArrowPrimitive {
        pose: Pose::of(&Iso3::from_parts(origin.into(), rotation)),
        shaft_length: length - head,
        shaft_diameter: diameter,
        head_length: head,
        head_diameter: 2.5 * diameter,
        color,
    })
}

/// The scene update that replaces every drawn candidate with `markers`.
pub(super) fn pre_grasp_update(markers: &[PreGraspMarker], timestamp: Time) -> SceneUpdate {
    let n = markers.iter().map(|m| m.rank).max().unwrap_or(1).max(2);
    let entities = markers
        .iter()
        .map(|m| {
            // Hue 120° (green) for rank 1 down to 0° (red) for the last; or held / not held.
            let share = match m.held {
                Some(held) => f64::from(u8::from(!held)),
                None => (m.rank.saturating_sub(1)) as f64 / (n - 1) as f64,
            };
            let color = Color::from_hsv([120.0 * (1.0 - share.clamp(0.0, 1.0)), 0.9, 0.95], 0.9);
            let id = if m.group.is_empty() {
                format!("pre-grasp/{}", m.rank)
            } else {
                format!("pre-grasp/{}/{}", m.group, m.rank)
            };
            let palm = m.world_from_palm.translation.vector;
            let approach = m.world_from_palm.rotation * Vec3::z();
            let spread = m.world_from_palm.rotation * Vec3::x();
            let mut e = SceneEntity::new(timestamp, WORLD_FRAME, id, false).with_metadata(&[
                ("rank", &m.rank.to_string()),
                ("label", &m.label),
                ("group", &m.group),
            ]);
            e.arrows.extend(arrow(
                palm - approach * APPROACH_ARROW,
                approach,
                APPROACH_ARROW,
                0.006,
                color,
            ));
            e.arrows.extend(arrow(palm, spread, SPREAD_ARROW, 0.004, color));
            e.texts.push(TextPrimitive {
                pose: Pose::at(palm.x, palm.y, palm.z + 0.02),
                billboard: true,
                font_size: 12.0,
                scale_invariant: true,
                color,
                text: m.label.clone(),
            });
            e
        })
        .collect();
    SceneUpdate::replacing_all(timestamp, entities)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_candidate_is_an_approach_arrow_ending_at_the_palm_coloured_by_rank() {
        // A palm 30 cm above the origin, pointing down (+z of the palm = −z of the world).
        let down = Rot3::from_axis_angle(&Vec3::x_axis(), std::f64::consts::PI);
        let markers: Vec<PreGraspMarker> = (1..=3)
            .map(|rank| PreGraspMarker {
                rank,
                world_from_palm: Iso3::from_parts(Vec3::new(0.5, 0.0, 0.3).into(), down),
                label: format!("#{rank}"),
                group: String::new(),
                held: None,
            })
            .collect();
        let u = pre_grasp_update(&markers, Time::from_ns(0));
        assert_eq!(u.entities.len(), 3);
        assert!(u.replace_all.is_some());
        let a = &u.entities[0].arrows[0];
        // Starts 10 cm above the palm and points down.
        assert!((a.pose.position.z - 0.4).abs() < 1e-9, "{:?}", a.pose.position);
        let q = &a.pose.orientation;
        let rot = Rot3::from_quaternion(nalgebra::Quaternion::new(q.w, q.x, q.y, q.z));
        let dir = rot * Vec3::x();
        assert!((dir - Vec3::new(0.0, 0.0, -1.0)).norm() < 1e-9, "{dir:?}");
        assert!((a.shaft_length + a.head_length - APPROACH_ARROW).abs() < 1e-12);
        // Rank 1 green, the last red.
        let (first, last) = (&u.entities[0].arrows[0].color, &u.entities[2].arrows[0].color);
        assert!(first.g > first.r && last.r > last.g, "{first:?} {last:?}");
        assert_eq!(u.entities[1].texts[0].text, "#2");
        assert_eq!(u.entities[1].id, "pre-grasp/2");
    }

    #[test]
    fn executed_candidates_are_coloured_by_outcome_and_named_by_group() {
        let m = |rank, held| PreGraspMarker {
            rank,
            world_from_palm: Iso3::identity(),
            label: String::new(),
            group: "naive".into(),
            held: Some(held),
        };
        let u = pre_grasp_update(&[m(1, false), m(2, true)], Time::from_ns(0));
        let (first, second) = (&u.entities[0].arrows[0].color, &u.entities[1].arrows[0].color);
        assert!(first.r > first.g && second.g > second.r, "{first:?} {second:?}");
        assert_eq!(u.entities[0].id, "pre-grasp/naive/1");
    }
}
