//! The contact sensors: fingertip force/torque from the impulses the solver used (normal and
//! friction), the hand's wrench, penetration and point contacts on an object, and the support an
//! object feels from everything but the robot.

use control_basis::math::Vec3;
use rapier3d_f64::prelude::*;

use super::{DexterSim, Part};
use crate::convert::vec_from_glam;
use crate::snapshot::{Arm, FingertipWrench};

impl DexterSim {
    /// Contact points the solver works on now (all pairs, all manifolds): the figure to compare
    /// with another engine's contact count.
    pub fn active_contacts(&self) -> usize {
        self.world
            .narrow_phase
            .contact_pairs()
            .map(|p| {
                p.manifolds()
                    .iter()
                    .map(|m| m.data.solver_contacts.len())
                    .sum::<usize>()
            })
            .sum()
    }

    /// Contact forces on the robot's sensing parts (the six fingers), written into `out` (left F1–F3,
    /// right F1–F3). Each is a 6-axis force/torque sensor at the finger: force and torque about the
    /// fingertip frame, from normal *and* friction impulses of the contacts the solver used.
    pub fn fingertip_wrenches(&self, out: &mut [FingertipWrench; 6]) {
        for (k, w) in out.iter_mut().enumerate() {
            let arm = if k < 3 { Arm::Left } else { Arm::Right };
            *w = FingertipWrench {
                arm,
                finger: (k % 3) as u8 + 1,
                force: [0.0; 3],
                torque: [0.0; 3],
                in_contact: false,
            };
        }
        let mut origins = [Vec3::zeros(); 6];
        for (o, l) in origins.iter_mut().zip(self.tip_links) {
            *o = l.map(|l| self.link_pose(l).translation.vector).unwrap_or_default();
        }
        self.for_each_contact_force(|part, _other, point, force| {
            if let Part::Finger(arm, f) = part {
                let k = if arm == Arm::Left { 0 } else { 3 } + (f as usize - 1);
                let w = &mut out[k];
                let torque = (point - origins[k]).cross(&force);
                for a in 0..3 {
                    w.force[a] += force[a];
                    w.torque[a] += torque[a];
                }
                w.in_contact = true;
            }
        });
    }

    /// The net contact force and torque (about the object's centre of mass) that `arm`'s hand
    /// applies to object `i`, and the number of the hand's parts (palm, fingers) touching it.
    pub fn hand_wrench_on_object(&self, arm: Arm, i: usize) -> (Vec3, Vec3, usize) {
        let obj_collider = self.objects[i].collider;
        let com = vec_from_glam(self.world.bodies[self.objects[i].body].center_of_mass());
        let mut f = Vec3::zeros();
        let mut t = Vec3::zeros();
        let mut parts = [false; 4];
        self.for_each_contact_force(|part, other, point, force| {
            if other != Some(obj_collider) {
                return;
            }
            let slot = match part {
                Part::Palm(a) if a == arm => 0,
                Part::Finger(a, k) if a == arm => k as usize,
                _ => return,
            };
            parts[slot] = true;
            // `force` acts on the robot part; the object feels the opposite.
            f -= force;
            t -= (point - com).cross(&force);
        });
        (f, t, parts.iter().filter(|&&p| p).count())
    }

    /// The deepest penetration (m, ≥ 0) of `arm`'s hand (palm or fingers) into object `i` over the
    /// contact points the solver used in the last step; 0 when they do not overlap.
    pub fn hand_penetration_on_object(&self, arm: Arm, i: usize) -> f64 {
        let obj = self.objects[i].collider;
        let mut deepest = 0.0f64;
        for pair in self.world.narrow_phase.contact_pairs_with(obj) {
            let other = if pair.collider1 == obj {
                pair.collider2
            } else {
                pair.collider1
            };
            match self.collider_part.get(&other) {
                Some(Part::Palm(a)) | Some(Part::Finger(a, _)) if *a == arm => {}
                _ => continue,
            }
            for m in pair.solver_manifolds() {
                for c in m.data.solver_contacts.iter() {
                    if let Some(pt) = m.points.get(c.contact_indices()[0] as usize) {
                        deepest = deepest.max(-pt.dist);
                    }
                }
            }
        }
        deepest
    }

    /// The contacts of `arm`'s hand on object `i` as frictional point contacts (world frame, normals
    /// pointing into the object, the combined friction coefficient), for the force-closure check.
    pub fn hand_contacts_on_object(&self, arm: Arm, i: usize) -> Vec<control_basis::grasp::ContactPoint> {
        let obj = self.objects[i].collider;
        let mut out = Vec::new();
        for pair in self.world.narrow_phase.contact_pairs_with(obj) {
            let (other, object_is_2) = if pair.collider1 == obj {
                (pair.collider2, false)
            } else {
                (pair.collider1, true)
            };
            match self.collider_part.get(&other) {
                Some(Part::Palm(a)) | Some(Part::Finger(a, _)) if *a == arm => {}
                _ => continue,
            }
            for m in pair.solver_manifolds() {
                // The manifold normal points from collider 1 to collider 2.
                let n = vec_from_glam(m.data.normal);
                let inward = if object_is_2 { n } else { -n };
                for c in m.data.solver_contacts.iter() {
                    let (w1, w2) = m.data.solver_contact_world_points(c, &self.world.bodies);
                    out.push(control_basis::grasp::ContactPoint {
                        position: vec_from_glam((w1 + w2) * 0.5),
                        normal: inward,
                        friction: m.data.friction,
                    });
                }
            }
        }
        out
    }

    /// Total contact force on object `i` from everything except `arm`'s hand (the table, a bin,
    /// other objects): the support the Place controller waits for.
    pub fn support_force_on_object(&self, i: usize) -> Vec3 {
        let obj = self.objects[i].collider;
        let mut f = Vec3::zeros();
        for pair in self.world.narrow_phase.contact_pairs_with(obj) {
            let other = if pair.collider1 == obj {
                pair.collider2
            } else {
                pair.collider1
            };
            if self.collider_part.contains_key(&other) {
                continue;
            }
            let sign = if pair.collider1 == obj { 1.0 } else { -1.0 };
            for_each_point_force(pair, self.settings.dt, &self.world.bodies, |_, f1| f += sign * f1);
        }
        f
    }

    /// Calls `visit(part, other_collider, world_point, force_on_part)` for every active contact
    /// point on a robot hand part.
    fn for_each_contact_force(&self, mut visit: impl FnMut(Part, Option<ColliderHandle>, Vec3, Vec3)) {
        let dt = self.settings.dt;
        for pair in self.world.narrow_phase.contact_pairs() {
            let p1 = self.collider_part.get(&pair.collider1).copied();
            let p2 = self.collider_part.get(&pair.collider2).copied();
            let (part, other, on_first) = match (p1, p2) {
                (Some(p), None) if p != Part::Other => (p, pair.collider2, true),
                (None, Some(p)) if p != Part::Other => (p, pair.collider1, false),
                _ => continue,
            };
            for_each_point_force(pair, dt, &self.world.bodies, |point, f1| {
                visit(part, Some(other), point, if on_first { f1 } else { -f1 });
            });
        }
    }
}

/// Calls `visit(world_point, force_on_collider1)` for every contact point of `pair` that the solver
/// used in the last step: the normal **and friction** impulses over `dt`, in the tangent basis the
/// solver uses (`../shared/NOTES-grasp-physics.md`). Points the solver did not use are skipped: their
/// stale impulses would count a weight twice.
fn for_each_point_force(pair: &ContactPair, dt: f64, bodies: &RigidBodySet, mut visit: impl FnMut(Vec3, Vec3)) {
    for m in pair.solver_manifolds() {
        let d1 = -m.data.normal;
        let t1 = d1.any_orthonormal_vector();
        let t2 = d1.cross(t1);
        for c in m.data.solver_contacts.iter() {
            let idx = c.contact_indices()[0] as usize;
            let Some(pt) = m.points.get(idx) else { continue };
            let imp = pt.data.impulse * d1 + pt.data.tangent_impulse.x * t1 + pt.data.tangent_impulse.y * t2;
            let (w1, w2) = m.data.solver_contact_world_points(c, bodies);
            visit(vec_from_glam((w1 + w2) * 0.5), vec_from_glam(imp / dt));
        }
    }
}
