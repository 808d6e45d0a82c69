//! Resolving a scene's placements against its catalog: each object rests on the table (or stands at
//! its given height) and is checked to be on the table, not in it, clear of the places and of the
//! other objects.

use control_basis::math::{Iso3, Rot3, Vec3};

use super::catalog::Catalog;
use super::check::{Check, in_context, scene_range};
use super::footprint::{Footprint, REST_CLEARANCE, footprint_gap, lowest_point_depth, rect_within, show_rect};
use super::spec::{SceneSpec, place_footprint};
use crate::error::SimError;

/// Overlaps shallower than this (m) are not reported (rounding in the footprint computation).
const OVERLAP_TOLERANCE: f64 = 1e-6;

/// A placed object resolved against the catalog.
#[derive(Debug, Clone)]
pub struct ResolvedObject {
    /// The presentation name (`jif-1`).
    pub presentation: String,
    /// A name unique in the scene: the presentation name, or `jif-1#2` for the second of several
    /// placements of the same presentation (numbered from 1 in file order).
    pub label: String,
    /// Index into `catalog.objects`.
    pub object: usize,
    /// World pose of the object frame, resting on the table (or at the given `z`).
    pub pose: Iso3,
}

/// Resolves each placement against the catalog and checks it: on the table, not in it, clear of
/// places and of the other objects.
pub(super) fn resolve_objects(
    c: &Check<'_>,
    spec: &SceneSpec,
    catalog: &Catalog,
) -> Result<Vec<ResolvedObject>, SimError> {
    let table = &spec.table;
    let bounds = table.bounds();
    let places: Vec<Footprint> = spec.places.iter().map(place_footprint).collect();
    let mut resolved: Vec<ResolvedObject> = Vec::with_capacity(spec.objects.len());
    // Footprint and vertical extent of each object resolved so far.
    let mut placed: Vec<(Footprint, [f64; 2])> = Vec::with_capacity(spec.objects.len());
    for (i, o) in spec.objects.iter().enumerate() {
        let f = format!("objects[{i}]");
        let (index, upright) = catalog.presentation(&o.presentation).map_err(|e| match e {
            SimError::Unknown { name, candidates, .. } => c.invalid(
                format!("{f}.presentation"),
                format!(
                    "unknown presentation `{name}` in catalog {}; closest: {}",
                    catalog.path.display(),
                    candidates
                        .iter()
                        .take(6)
                        .map(|s| format!("`{s}`"))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            ),
            other => other,
        })?;
        let named = |e| in_context(e, &o.presentation);
        c.finite_all(&format!("{f}.xy"), &o.xy).map_err(named)?;
        c.within(&format!("{f}.yaw_deg"), "objects[].yaw_deg", o.yaw_deg)
            .map_err(named)?;
        let shape = &catalog.objects[index].shape;
        let orientation = Rot3::from_axis_angle(&Vec3::z_axis(), o.yaw_deg.to_radians()) * upright;
        let depth = lowest_point_depth(shape, &orientation);
        let z = match o.z {
            None => table.height + depth + REST_CLEARANCE,
            Some(z) => {
                c.finite(&format!("{f}.z"), z).map_err(named)?;
                if z > table.height + scene_range("objects[].z above the table").1 {
                    c.within(&format!("{f}.z"), "objects[].z above the table", z - table.height)
                        .map_err(named)?;
                }
                if z < table.height {
                    return Err(named(c.invalid(
                        format!("{f}.z"),
                        format!("is under the table: z = {z} is below the table top at {}", table.height),
                    )));
                }
                let lowest = z - depth;
                if lowest < table.height - 1e-9 {
                    return Err(named(c.invalid(
                        format!("{f}.z"),
                        format!(
                            "puts the object {:.1} mm into the table (its lowest point would be at z = {lowest:.4}, \
                             the table top is at {}; resting it needs z ≥ {:.4})",
                            (table.height - lowest) * 1e3,
                            table.height,
                            table.height + depth
                        ),
                    )));
                }
                z
            }
        };
        let footprint = Footprint {
            shape: shape.clone(),
            orientation,
            center: o.xy,
        };
        let rect = footprint.rect();
        if !rect_within(&rect, &bounds) {
            return Err(named(c.invalid(
                format!("{f}.xy"),
                format!(
                    "the object {} extends past the table {}",
                    show_rect(&rect),
                    show_rect(&bounds)
                ),
            )));
        }
        for (k, place) in places.iter().enumerate() {
            let gap = footprint_gap(&footprint, place);
            if gap < -OVERLAP_TOLERANCE {
                let name = &spec.places[k].name;
                return Err(named(c.invalid(
                    format!("{f}.xy"),
                    format!(
                        "the object overlaps place `{name}` (places[{k}]) by {:.1} cm",
                        -gap * 100.0
                    ),
                )));
            }
        }
        let vertical = [z - depth, z + depth];
        for (j, (other, other_vertical)) in placed.iter().enumerate() {
            let stacked = vertical[0] >= other_vertical[1] || other_vertical[0] >= vertical[1];
            let gap = footprint_gap(&footprint, other);
            if !stacked && gap < -OVERLAP_TOLERANCE {
                return Err(c.invalid(
                    format!("{f}.xy"),
                    format!(
                        "`{}` (objects[{i}]) overlaps `{}` (objects[{j}]) by {:.1} cm",
                        o.presentation,
                        spec.objects[j].presentation,
                        -gap * 100.0
                    ),
                ));
            }
        }
        placed.push((footprint, vertical));
        resolved.push(ResolvedObject {
            presentation: o.presentation.clone(),
            label: o.presentation.clone(),
            object: index,
            pose: Iso3::from_parts(nalgebra::Translation3::new(o.xy[0], o.xy[1], z), orientation),
        });
    }
    // Number the labels of presentations placed more than once.
    for i in 0..resolved.len() {
        let same = |r: &ResolvedObject| r.presentation == resolved[i].presentation;
        if resolved.iter().filter(|r| same(r)).count() > 1 {
            let k = resolved[..i].iter().filter(|r| same(r)).count() + 1;
            resolved[i].label = format!("{}#{k}", resolved[i].presentation);
        }
    }
    Ok(resolved)
}
