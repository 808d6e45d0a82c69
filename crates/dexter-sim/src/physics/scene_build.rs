//! The scene in Rapier: the table, the floor, the bins and the placed objects (with the
//! simulator's placement jitter).

use std::collections::HashMap;

use control_basis::math::{Rot3, Vec3};
use rapier3d_f64::glamx::DVec3;
use rapier3d_f64::prelude::*;

use super::{DexterSim, OBJECT_ANGULAR_DAMPING, SimObject, groups};
use crate::convert::iso_to_glam;
use crate::error::SimError;
use crate::geometry;
use crate::scene::{ObjectSpec, Scene};
use bayes::rng::Draw;

impl DexterSim {
    pub(super) fn build_scene(&mut self, scene: &Scene) -> Result<(), SimError> {
        let spec = &scene.spec;
        let t = &spec.table;
        // Table: a 4 cm slab whose top is at `height`, plus a leg block below it to the floor.
        let table_thickness = 0.04;
        let table = self.world.insert_body(RigidBodyBuilder::fixed().build());
        let skin = self.settings.contact_skin;
        let static_box = |half: DVec3, center: DVec3| {
            ColliderBuilder::cuboid(half.x, half.y, half.z)
                .translation(center)
                .friction(t.friction)
                .contact_skin(skin)
                .collision_groups(InteractionGroups::new(
                    groups::STATIC,
                    groups::OBJECT | groups::HAND,
                    InteractionTestMode::And,
                ))
                .build()
        };
        let top = static_box(
            DVec3::new(t.size[0] / 2.0, t.size[1] / 2.0, table_thickness / 2.0),
            DVec3::new(t.center[0], t.center[1], t.height - table_thickness / 2.0),
        );
        self.world.insert_collider(top, Some(table));
        // The floor, so that a dropped object comes to rest somewhere (and is reported there).
        let floor = ColliderBuilder::cuboid(5.0, 5.0, 0.05)
            .translation(DVec3::new(0.0, 0.0, -0.05))
            .friction(t.friction)
            .collision_groups(InteractionGroups::new(
                groups::STATIC,
                groups::OBJECT,
                InteractionTestMode::And,
            ))
            .build();
        self.world.insert_collider(floor, Some(table));
        // Bins: a floor plate (2 mm, on the table) and four walls.
        for place in &spec.places {
            let (cx, cy) = (place.center[0], place.center[1]);
            let (sx, sy) = (place.size[0], place.size[1]);
            let wall = place.wall_thickness;
            let mut parts = vec![(
                DVec3::new(cx, cy, t.height + 0.001),
                DVec3::new(sx / 2.0, sy / 2.0, 0.001),
            )];
            if place.wall_height > 0.0 {
                let h = place.wall_height;
                let z = t.height + h / 2.0;
                parts.push((
                    DVec3::new(cx + (sx + wall) / 2.0, cy, z),
                    DVec3::new(wall / 2.0, sy / 2.0 + wall, h / 2.0),
                ));
                parts.push((
                    DVec3::new(cx - (sx + wall) / 2.0, cy, z),
                    DVec3::new(wall / 2.0, sy / 2.0 + wall, h / 2.0),
                ));
                parts.push((
                    DVec3::new(cx, cy + (sy + wall) / 2.0, z),
                    DVec3::new(sx / 2.0, wall / 2.0, h / 2.0),
                ));
                parts.push((
                    DVec3::new(cx, cy - (sy + wall) / 2.0, z),
                    DVec3::new(sx / 2.0, wall / 2.0, h / 2.0),
                ));
            }
            for (c, half) in parts {
                self.world.insert_collider(static_box(half, c), Some(table));
            }
        }
        // Objects.
        let mut seen: HashMap<&str, usize> = HashMap::new();
        for (k, placed) in scene.resolved.iter().enumerate() {
            let spec: &ObjectSpec = &scene.catalog.objects[placed.object];
            let count = seen.entry(placed.presentation.as_str()).or_insert(0);
            *count += 1;
            let name = if *count == 1 {
                placed.presentation.clone()
            } else {
                format!("{}#{}", placed.presentation, count)
            };
            let (jp, jy) = self.settings.placement_jitter;
            let dx = jp * (2.0 * self.rng.uniform() - 1.0);
            let dy = jp * (2.0 * self.rng.uniform() - 1.0);
            let dyaw = jy * (2.0 * self.rng.uniform() - 1.0);
            let mut pose = placed.pose;
            pose.translation.vector += Vec3::new(dx, dy, 0.0);
            pose.rotation = Rot3::from_axis_angle(&Vec3::z_axis(), dyaw) * pose.rotation;
            let (shape, object_from_shape) = geometry::to_parry(&spec.shape);
            let volume = geometry::volume(&spec.shape);
            let body = self.world.insert_body(
                RigidBodyBuilder::dynamic()
                    .pose(iso_to_glam(&pose))
                    // Rapier has no rolling resistance: a little angular damping stands in for it,
                    // so that balls and lying cans come to rest in a bin as they do on real surfaces.
                    .angular_damping(OBJECT_ANGULAR_DAMPING)
                    .can_sleep(self.settings.allow_sleep)
                    .user_data((1u128 << 64) | k as u128)
                    .build(),
            );
            let collider = ColliderBuilder::new(shape)
                .position(iso_to_glam(&object_from_shape))
                .density(spec.mass / volume)
                .friction(spec.friction)
                .contact_skin(self.settings.contact_skin)
                .collision_groups(InteractionGroups::new(
                    groups::OBJECT,
                    Group::ALL,
                    InteractionTestMode::And,
                ))
                .build();
            let ch = self.world.insert_collider(collider, Some(body));
            self.object_by_collider.insert(ch, self.objects.len());
            self.header.object_names.push(name.clone());
            self.objects.push(SimObject {
                name,
                catalog_index: placed.object,
                scene_index: k,
                body,
                collider: ch,
                mass: spec.mass,
            });
        }
        Ok(())
    }
}
