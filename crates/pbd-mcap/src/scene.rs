//! The scene (table, places, objects) as Foxglove scene entities.
//!
//! Static things (table, places) are drawn in `world`; each object is one entity in its own frame
//! `object/<name>` (frame-locked, so it follows the `/tf` updates) made of one primitive per colour
//! band, as the simulator paints them: bands along the object's local z, bottom to top, heights in
//! proportion to the patch fractions.

use anyhow::{Result, bail, ensure};
use dexter_sim::scene::{ColorPatch, ObjectSpec, PlaceSpec, Scene, Shape, TableSpec};
use dexter_sim::snapshot::SnapshotHeader;

use super::messages::{
    Color, CylinderPrimitive, Pose, SceneEntity, SceneUpdate, SizedPrimitive, TextPrimitive, Time, Vector3,
    WORLD_FRAME, object_frame,
};

/// Thickness of the table top (m), as the simulator builds it; the scene gives only its height.
const TABLE_TOP_THICKNESS: f64 = 0.04;
/// Side of a (drawn) table leg (m).
const TABLE_LEG_SIDE: f64 = 0.05;
/// Thickness of a place's floor plate, on the table top (m), as the simulator builds it.
const PLACE_FLOOR_THICKNESS: f64 = 0.002;

/// A scene update that first deletes every entity on the topic, then adds the table, places and
/// objects. `header.object_names` names the objects of `scene.resolved`, in the same order.
pub(super) fn scene_update(scene: &Scene, header: &SnapshotHeader, timestamp: Time) -> Result<SceneUpdate> {
    ensure!(
        header.object_names.len() == scene.resolved.len(),
        "the snapshot header names {} objects but the scene places {}",
        header.object_names.len(),
        scene.resolved.len()
    );
    let mut entities = Vec::with_capacity(1 + scene.spec.places.len() + scene.resolved.len());
    entities.push(table_entity(&scene.spec.table, timestamp));
    let table_top = scene.spec.table.height;
    entities.extend(scene.spec.places.iter().map(|p| place_entity(p, table_top, timestamp)));
    for (name, resolved) in header.object_names.iter().zip(&scene.resolved) {
        let Some(spec) = scene.catalog.objects.get(resolved.object) else {
            bail!(
                "object {name} refers to catalog entry {} that does not exist",
                resolved.object
            );
        };
        entities.push(object_entity(name, &resolved.presentation, spec, timestamp));
    }
    // Deleting everything first removes objects that are gone since the last update.
    Ok(SceneUpdate::replacing_all(timestamp, entities))
}

fn table_entity(table: &TableSpec, timestamp: Time) -> SceneEntity {
    let color = Color::from_hsv(table.hsv, 1.0);
    let [cx, cy] = table.center;
    let [sx, sy] = table.size;
    let top = TABLE_TOP_THICKNESS.min(table.height);
    let mut e = SceneEntity::new(timestamp, WORLD_FRAME, "table".into(), false).with_metadata(&[("kind", "table")]);
    e.cubes.push(SizedPrimitive {
        pose: Pose::at(cx, cy, table.height - top / 2.0),
        size: Vector3 { x: sx, y: sy, z: top },
        color,
    });
    let leg_height = table.height - top;
    if leg_height > 0.0 && sx > 2.0 * TABLE_LEG_SIDE && sy > 2.0 * TABLE_LEG_SIDE {
        let (dx, dy) = (sx / 2.0 - TABLE_LEG_SIDE, sy / 2.0 - TABLE_LEG_SIDE);
        let leg_color = Color::from_hsv([table.hsv[0], table.hsv[1], table.hsv[2] * 0.7], 1.0);
        for (ex, ey) in [(-1.0, -1.0), (-1.0, 1.0), (1.0, -1.0), (1.0, 1.0)] {
            e.cubes.push(SizedPrimitive {
                pose: Pose::at(cx + ex * dx, cy + ey * dy, leg_height / 2.0),
                size: Vector3 {
                    x: TABLE_LEG_SIDE,
                    y: TABLE_LEG_SIDE,
                    z: leg_height,
                },
                color: leg_color,
            });
        }
    }
    e
}

fn place_entity(place: &PlaceSpec, table_top: f64, timestamp: Time) -> SceneEntity {
    let [cx, cy] = place.center;
    let [sx, sy] = place.size;
    let walls = place.wall_height > 0.0;
    let kind = if walls { "bin" } else { "region" };
    let mut e = SceneEntity::new(timestamp, WORLD_FRAME, format!("place/{}", place.name), false)
        .with_metadata(&[("kind", kind), ("name", &place.name)]);
    let color = Color::from_hsv(place.hsv, if walls { 1.0 } else { 0.85 });
    e.cubes.push(SizedPrimitive {
        pose: Pose::at(cx, cy, table_top + PLACE_FLOOR_THICKNESS / 2.0),
        size: Vector3 {
            x: sx,
            y: sy,
            z: PLACE_FLOOR_THICKNESS,
        },
        color,
    });
    if walls {
        let (t, h) = (place.wall_thickness, place.wall_height);
        let z = table_top + h / 2.0;
        // Walls sit outside the inner size; the x walls span the corners.
        for side in [-1.0, 1.0] {
            e.cubes.push(SizedPrimitive {
                pose: Pose::at(cx, cy + side * (sy + t) / 2.0, z),
                size: Vector3 {
                    x: sx + 2.0 * t,
                    y: t,
                    z: h,
                },
                color,
            });
            e.cubes.push(SizedPrimitive {
                pose: Pose::at(cx + side * (sx + t) / 2.0, cy, z),
                size: Vector3 { x: t, y: sy, z: h },
                color,
            });
        }
    }
    e.texts.push(TextPrimitive {
        pose: Pose::at(cx, cy, table_top + place.wall_height.max(0.0) + 0.04),
        billboard: true,
        font_size: 0.04,
        scale_invariant: false,
        color: Color {
            r: 1.0,
            g: 1.0,
            b: 1.0,
            a: 1.0,
        },
        text: place.name.clone(),
    });
    e
}

fn object_entity(name: &str, presentation: &str, spec: &ObjectSpec, timestamp: Time) -> SceneEntity {
    let frame = object_frame(name);
    let mut e = SceneEntity::new(timestamp, &frame, frame.clone(), true).with_metadata(&[
        ("kind", "object"),
        ("object", &spec.name),
        ("presentation", presentation),
        ("color_class", spec.color_class.as_deref().unwrap_or("")),
        ("size_class", spec.size_class.as_deref().unwrap_or("")),
    ]);
    match spec.shape {
        Shape::Box { size: [sx, sy, sz] } => {
            for (lo, hi, color) in bands(&spec.colors, -sz / 2.0, sz / 2.0) {
                e.cubes.push(SizedPrimitive {
                    pose: Pose::at(0.0, 0.0, (lo + hi) / 2.0),
                    size: Vector3 {
                        x: sx,
                        y: sy,
                        z: hi - lo,
                    },
                    color,
                });
            }
        }
        Shape::Cylinder { radius, height } => {
            for (lo, hi, color) in bands(&spec.colors, -height / 2.0, height / 2.0) {
                e.cylinders.push(cylinder(radius, lo, hi, color));
            }
        }
        Shape::Sphere { radius } => {
            // A sphere cannot be cut into bands with Foxglove primitives: paint it its dominant colour.
            let d = 2.0 * radius;
            e.spheres.push(SizedPrimitive {
                pose: Pose::at(0.0, 0.0, 0.0),
                size: Vector3 { x: d, y: d, z: d },
                color: dominant_color(&spec.colors),
            });
        }
        Shape::Capsule { radius, height } => {
            // Bands over the whole length; the straight part shows them, each cap takes its end band.
            let half = height / 2.0;
            let all = bands(&spec.colors, -half - radius, half + radius);
            for &(lo, hi, color) in &all {
                let (lo, hi) = (lo.max(-half), hi.min(half));
                if hi > lo {
                    e.cylinders.push(cylinder(radius, lo, hi, color));
                }
            }
            let d = 2.0 * radius;
            let ends = [(-half, all.first()), (half, all.last())];
            for (z, band) in ends {
                let color = band.map_or_else(|| dominant_color(&spec.colors), |b| b.2);
                e.spheres.push(SizedPrimitive {
                    pose: Pose::at(0.0, 0.0, z),
                    size: Vector3 { x: d, y: d, z: d },
                    color,
                });
            }
        }
    }
    e
}

fn cylinder(radius: f64, lo: f64, hi: f64, color: Color) -> CylinderPrimitive {
    let d = 2.0 * radius;
    CylinderPrimitive {
        pose: Pose::at(0.0, 0.0, (lo + hi) / 2.0),
        size: Vector3 { x: d, y: d, z: hi - lo },
        bottom_scale: 1.0,
        top_scale: 1.0,
        color,
    }
}

const NO_COLOR: Color = Color {
    r: 0.6,
    g: 0.6,
    b: 0.6,
    a: 1.0,
};

/// The colour bands between `z_lo` and `z_hi`, bottom to top: `(lo, hi, colour)`. Fractions are
/// normalised by their sum; empty bands are left out.
fn bands(colors: &[ColorPatch], z_lo: f64, z_hi: f64) -> Vec<(f64, f64, Color)> {
    let total: f64 = colors.iter().map(|c| c.fraction.max(0.0)).sum();
    if colors.is_empty() || total <= 0.0 {
        return vec![(z_lo, z_hi, NO_COLOR)];
    }
    let mut out = Vec::with_capacity(colors.len());
    let mut lo = z_lo;
    for (i, patch) in colors.iter().enumerate() {
        let hi = if i + 1 == colors.len() {
            z_hi
        } else {
            lo + (z_hi - z_lo) * patch.fraction.max(0.0) / total
        };
        if hi > lo {
            out.push((lo, hi, Color::from_hsv(patch.hsv, 1.0)));
        }
        lo = hi;
    }
    out
}

/// The colour of the largest patch.
fn dominant_color(colors: &[ColorPatch]) -> Color {
    colors
        .iter()
        .max_by(|a, b| a.fraction.total_cmp(&b.fraction))
        .map_or(NO_COLOR, |c| Color::from_hsv(c.hsv, 1.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn patch(h: f64, fraction: f64) -> ColorPatch {
        ColorPatch {
            hsv: [h, 1.0, 1.0],
            fraction,
        }
    }

    #[test]
    fn bands_tile_the_extent_in_proportion() {
        let b = bands(&[patch(0.0, 0.25), patch(120.0, 0.75)], -0.1, 0.1);
        assert_eq!(b.len(), 2);
        assert!((b[0].0 + 0.1).abs() < 1e-15 && (b[0].1 - (-0.05)).abs() < 1e-12);
        assert_eq!(b[1].1, 0.1);
        assert_eq!(
            b[0].2,
            Color {
                r: 1.0,
                g: 0.0,
                b: 0.0,
                a: 1.0
            }
        );
        assert_eq!(
            b[1].2,
            Color {
                r: 0.0,
                g: 1.0,
                b: 0.0,
                a: 1.0
            }
        );
    }

    #[test]
    fn hsv_primaries_and_grey() {
        let c = |h, s, v| {
            let c = Color::from_hsv([h, s, v], 1.0);
            [c.r, c.g, c.b].map(|x| (x * 1000.0).round() / 1000.0)
        };
        assert_eq!(c(240.0, 1.0, 1.0), [0.0, 0.0, 1.0]);
        assert_eq!(c(60.0, 1.0, 1.0), [1.0, 1.0, 0.0]);
        assert_eq!(c(300.0, 1.0, 0.5), [0.5, 0.0, 0.5]);
        assert_eq!(c(-60.0, 1.0, 1.0), [1.0, 0.0, 1.0]);
        assert_eq!(c(30.0, 0.0, 0.35), [0.35, 0.35, 0.35]);
    }
}
