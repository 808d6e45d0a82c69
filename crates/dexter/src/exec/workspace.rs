//! The robot's workcell: its table and places ([`Workspace`], [`Place`]) and where in a place an
//! object goes ([`free_spot`]).

use control_basis::Hardware;
use control_basis::math::Vec3;
use schema::PlacePercept;
use serde::{Deserialize, Serialize};

use crate::arm::Arm;
use crate::error::RobotError;
use crate::skills::{park_pose, reachable};

/// A place the robot knows (a bin): name, centre and size of its floor region (m, world), walls.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Place {
    /// Name.
    pub name: String,
    /// Centre (x, y).
    pub center: [f64; 2],
    /// Size (x, y) of the inside.
    pub size: [f64; 2],
    /// Wall height above the table (m).
    pub wall_height: f64,
    /// Wall thickness (m).
    pub wall_thickness: f64,
}

impl Place {
    /// Whether `xy` lies inside the place region.
    pub fn contains(&self, xy: [f64; 2]) -> bool {
        (xy[0] - self.center[0]).abs() <= self.size[0] / 2.0 && (xy[1] - self.center[1]).abs() <= self.size[1] / 2.0
    }
}

/// How far beyond the table's edge a seen centre may lie and still be on the table (m): the
/// measured footprint's error.
pub const TABLE_EDGE_MARGIN: f64 = 0.02;

/// The highest a seen thing's centre may be above the table and still stand on it (m): half the
/// tallest thing a tabletop holds (a 0.8 m post), with room for the measured height's error.
pub const MAX_OBJECT_CENTRE_HEIGHT: f64 = 0.45;

/// What the robot is told about its workspace: the table and its places — never objects.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Workspace {
    /// Table top height (m).
    pub table_z: f64,
    /// Table centre (x, y).
    pub table_center: [f64; 2],
    /// Table size (x, y).
    pub table_size: [f64; 2],
    /// The places.
    pub places: Vec<Place>,
}

impl Workspace {
    /// Whether a seen thing stands on the table: its centre over the table top (within
    /// [`TABLE_EDGE_MARGIN`], for the measured footprint) and no higher above it than
    /// [`MAX_OBJECT_CENTRE_HEIGHT`]. Anything else — a part of the robot's own body that its
    /// self-mask missed, seen beside the table or in the air — is nothing to act on.
    pub fn stands_on_table(&self, centroid: [f64; 3]) -> bool {
        (centroid[0] - self.table_center[0]).abs() <= self.table_size[0] / 2.0 + TABLE_EDGE_MARGIN
            && (centroid[1] - self.table_center[1]).abs() <= self.table_size[1] / 2.0 + TABLE_EDGE_MARGIN
            && centroid[2] - self.table_z <= MAX_OBJECT_CENTRE_HEIGHT
    }

    /// Where the head looks to scan the table: two rows of four points across its width.
    pub fn scan_points(&self) -> Vec<Vec3> {
        let mut out = Vec::new();
        let (cx, cy) = (self.table_center[0], self.table_center[1]);
        let hy = (self.table_size[1] / 2.0 - 0.1).max(0.0);
        for x in [cx - 0.08, cx + 0.1] {
            for k in 0..4 {
                let y = cy - hy + 2.0 * hy * f64::from(k) / 3.0;
                out.push(Vec3::new(x, y, self.table_z + 0.03));
            }
        }
        out
    }

    /// The place named `name`.
    pub fn place(&self, name: &str) -> Result<&Place, RobotError> {
        self.places.iter().find(|p| p.name == name).ok_or_else(|| {
            RobotError::invalid(
                "workspace",
                "place",
                format!(
                    "unknown place `{name}`; known: {}",
                    self.places
                        .iter()
                        .map(|p| p.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            )
        })
    }

    /// The places as the monitors see them.
    pub fn place_percepts(&self) -> Vec<PlacePercept> {
        self.places
            .iter()
            .map(|p| PlacePercept {
                name: p.name.clone(),
                center: [p.center[0], p.center[1], self.table_z],
                half_extents: [p.size[0] / 2.0, p.size[1] / 2.0],
            })
            .collect()
    }
}

/// Horizontal distance from `p` to the segment from `a` to `b`.
pub(super) fn distance_to_segment(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let l2 = dx * dx + dy * dy;
    let t = if l2 > 0.0 {
        (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p[0] - a[0] - t * dx).hypot(p[1] - a[1] - t * dy)
}

/// Room (m) between a placed object and a place's walls: for the opening fingers, and so that a
/// rolling object is not let go on the wall.
pub(super) const WALL_ROOM: f64 = 0.03;

/// Room (m) between a placed object and a place's walls when the object, lowered at a spot
/// [`WALL_ROOM`] allowed, came to rest on something there ([`PERCHED`](super::plant::PERCHED)):
/// the place is crowded, and a finger meeting a wall's top lets go a little high, inside.
pub(super) const TIGHT_WALL_ROOM: f64 = 0.01;

/// A grasp of an object seen within this distance (m) of where a descent stopped short is a
/// retry ([`RobotPlant::stopped_short`](super::plant::RobotPlant)): the backing off and a new look
/// move the seen centre by a few centimetres.
pub(super) const RETRY_RADIUS: f64 = 0.05;

/// Where in a place region (`center`, `size`) to put an object of horizontal radius `radius`
/// among `others` (centre, radius) already there: the point of a 1 cm grid inside the region (the
/// object clear of the walls by [`WALL_ROOM`]) with the widest gap between the object's footprint
/// and theirs, nearest the centre among equals (gaps count to the centimetre) — so objects already
/// in a bin are not landed on. The centre when the region leaves no room to choose. (Preferring
/// a spot clear of the objects over the walls' room, down to 0.5 cm, placed 4 fewer of 198 objects
/// on development seeds 1–3: the fingers met the walls and let go high.)
///
/// An empty region fills from the back: the object goes to the end of the region's longer axis
/// away from `from` (where objects come from), so that the next one has the other end. (In the
/// middle of a 20 × 25 cm bin a 7 cm box left no spot for a 13 cm bottle, which was set on top of
/// it.) Without `from`, or with no room along the axis, the centre.
pub fn free_spot(
    center: [f64; 2],
    size: [f64; 2],
    radius: f64,
    others: &[([f64; 2], f64)],
    from: Option<[f64; 2]>,
) -> [f64; 2] {
    free_spot_within(center, size, radius, others, from, WALL_ROOM)
}

/// [`free_spot`] with the object clear of the walls by `wall_room` (m) instead of [`WALL_ROOM`].
pub fn free_spot_within(
    center: [f64; 2],
    size: [f64; 2],
    radius: f64,
    others: &[([f64; 2], f64)],
    from: Option<[f64; 2]>,
    wall_room: f64,
) -> [f64; 2] {
    let half = [size[0] / 2.0 - radius - wall_room, size[1] / 2.0 - radius - wall_room];
    if half[0] <= 0.0 || half[1] <= 0.0 {
        return center;
    }
    if others.is_empty() {
        let Some(from) = from else {
            return center;
        };
        let long = usize::from(size[1] > size[0]);
        let away = if from[long] > center[long] { -1.0 } else { 1.0 };
        let mut spot = center;
        spot[long] += away * (half[long] / 0.01 + 1e-9).floor() * 0.01;
        return spot;
    }
    let n = [
        (half[0] / 0.01 + 1e-9).floor() as i32,
        (half[1] / 0.01 + 1e-9).floor() as i32,
    ];
    let mut best = (f64::NEG_INFINITY, f64::INFINITY, center);
    for i in -n[0]..=n[0] {
        for j in -n[1]..=n[1] {
            let c = [center[0] + 0.01 * f64::from(i), center[1] + 0.01 * f64::from(j)];
            let gap = others
                .iter()
                .map(|(o, r)| (o[0] - c[0]).hypot(o[1] - c[1]) - r)
                .fold(f64::INFINITY, f64::min);
            let off = (c[0] - center[0]).hypot(c[1] - center[1]);
            let gap = (gap * 100.0).round();
            if (gap, -off) > (best.0, -best.1) {
                best = (gap, off, c);
            }
        }
    }
    best.2
}

/// The horizontal distance (m) from table point `p` to the walls of `place` (0 on a wall).
pub(super) fn wall_distance(place: &Place, p: [f64; 2]) -> f64 {
    // Distance to the rectangle of half size `h` about the place's centre, inside or out.
    let rect = |h: [f64; 2]| {
        let d = [
            (p[0] - place.center[0]).abs() - h[0],
            (p[1] - place.center[1]).abs() - h[1],
        ];
        if d[0] > 0.0 || d[1] > 0.0 {
            d[0].max(0.0).hypot(d[1].max(0.0))
        } else {
            -d[0].max(d[1])
        }
    };
    let inner = [place.size[0] / 2.0, place.size[1] / 2.0];
    let outer = [inner[0] + place.wall_thickness, inner[1] + place.wall_thickness];
    let inside_inner = (p[0] - place.center[0]).abs() < inner[0] && (p[1] - place.center[1]).abs() < inner[1];
    let inside_outer = (p[0] - place.center[0]).abs() <= outer[0] && (p[1] - place.center[1]).abs() <= outer[1];
    if inside_inner {
        rect(inner)
    } else if inside_outer {
        0.0
    } else {
        rect(outer)
    }
}

/// Arms whose palm can reach 15 cm above `point` pointing down (IK within limits).
pub fn arms_reaching(hw: &dyn Hardware, table_z: f64, point: &Vec3) -> Result<Vec<Arm>, RobotError> {
    let mut out = Vec::new();
    for arm in Arm::BOTH {
        let mut over = park_pose(arm, table_z);
        over.translation.vector = Vec3::new(point.x, point.y, point.z.max(table_z) + 0.15);
        if reachable(hw.model(), arm, &over, 5)? {
            out.push(arm);
        }
    }
    Ok(out)
}
