//! The robot in Rapier, built from its URDF (module docs, "How the URDF becomes Rapier bodies"):
//! links merged into bodies, their colliders, multibody joints with their motor units, mimic
//! couplings and joint damping.

use std::collections::HashMap;

use control_basis::RobotModel;
use control_basis::math::{Iso3, Rot3, Vec3};
use nalgebra::{Matrix3, Translation3};
use rapier3d_f64::glamx::{DMat3, DVec3};
use rapier3d_f64::prelude::*;

use super::{DexterSim, Dof, MimicDof, Part, default_gains, groups};
use crate::convert::{iso_to_glam, vec_to_glam};
use crate::error::SimError;
use crate::geometry;
use crate::snapshot::Arm;

fn builtin_path() -> std::path::PathBuf {
    std::path::PathBuf::from("<builtin dexter.urdf>")
}

/// A rotation mapping x onto `axis`.
fn rotation_x_to(axis: &Vec3) -> Rot3 {
    Rot3::rotation_between(&Vec3::x(), axis)
        .unwrap_or_else(|| Rot3::from_axis_angle(&Vec3::z_axis(), std::f64::consts::PI))
}

fn urdf_iso(pose: &urdf_rs::Pose) -> Iso3 {
    control_basis::math::iso_from_xyz_rpy(*pose.xyz, *pose.rpy)
}

impl DexterSim {
    /// Builds the robot from its model: the links grouped into rigid bodies (step 1), their
    /// colliders (step 2), the moving joints as multibody joints with their motor units (step 3);
    /// then the mimic couplings and the joints' damping, and the motor references and snapshot
    /// names.
    pub(super) fn build_robot(&mut self) -> Result<(), SimError> {
        let links = LinkGroups::of(&self.model);
        let handles = self.insert_bodies(&links);
        self.insert_colliders(&links, &handles)?;
        self.link_body = (0..self.model.links.len())
            .map(|l| (handles[&links.body_root[l]], links.link_in_root[l]))
            .collect();
        let masters = self.insert_joints(&links, &handles)?;
        self.couple_mimics(masters)?;
        self.set_joint_damping()?;
        let model = &self.model;
        let nd = self.dofs.len();
        self.q_ref = vec![0.0; nd];
        self.qd_ref = vec![0.0; nd];
        self.q = vec![0.0; nd];
        self.qd = vec![0.0; nd];
        self.header.joint_names = self.dofs.iter().map(|d| d.name.clone()).collect();
        self.header.link_names = model.links.iter().map(|l| l.name.clone()).collect();
        self.header.link_parents = model
            .links
            .iter()
            .map(|l| l.parent_joint.map(|j| model.links[model.joints[j].parent].name.clone()))
            .collect();
        Ok(())
    }

    /// Step 1: one rigid body per group of links (fixed for the roots whose parent joint is fixed
    /// or absent), at its pose for q = 0, with the mass properties of all its links. Returns the
    /// bodies by their first link.
    fn insert_bodies(&mut self, links: &LinkGroups) -> HashMap<usize, RigidBodyHandle> {
        let model = &self.model;
        let n = model.links.len();
        let LinkGroups {
            order,
            body_root,
            link_in_root,
            urdf_link,
        } = links;
        // World poses at q = 0 (bodies are created there, then the joints are set).
        let mut world_pose = vec![Iso3::identity(); n];
        for &l in order {
            if let Some(j) = model.links[l].parent_joint {
                world_pose[l] = world_pose[model.joints[j].parent] * model.joints[j].origin;
            }
        }
        // Fixed bodies: roots whose parent joint is fixed or absent.
        let mut handles: HashMap<usize, RigidBodyHandle> = HashMap::new();
        for &l in order {
            if body_root[l] != l {
                continue;
            }
            let moving = model.links[l]
                .parent_joint
                .is_some_and(|j| model.joints[j].kind.is_moving());
            // Mass properties of every link of the group, in the root frame.
            let mut mprops = MassProperties::default();
            for m in (0..n).filter(|&m| body_root[m] == l) {
                if let Some(u) = urdf_link[m]
                    && let Some(link) = link_mass_properties(&model.urdf.links[u], &link_in_root[m])
                {
                    mprops += link;
                }
            }
            let builder = if moving {
                RigidBodyBuilder::dynamic()
            } else {
                RigidBodyBuilder::fixed()
            };
            let body = builder
                .pose(iso_to_glam(&world_pose[l]))
                .gravity_scale(0.0) // ideal gravity compensation of the robot's own links
                .can_sleep(self.settings.allow_sleep)
                .additional_mass_properties(mprops)
                .user_data(l as u128)
                .build();
            let h = self.world.insert_body(body);
            handles.insert(l, h);
        }
        handles
    }

    /// Step 2: every link's collision elements on its body, in the collision groups of its part
    /// (hand, arm, or the fixed torso and mounts); finger phalanges as capsules.
    fn insert_colliders(
        &mut self,
        links: &LinkGroups,
        handles: &HashMap<usize, RigidBodyHandle>,
    ) -> Result<(), SimError> {
        let model = &self.model;
        for (l, link) in model.links.iter().enumerate() {
            let Some(ul) = links.urdf_link[l].map(|u| &model.urdf.links[u]) else {
                continue;
            };
            let root = links.body_root[l];
            let body = handles[&root];
            let part = part_of(&link.name);
            let fixed = !model.links[root]
                .parent_joint
                .is_some_and(|j| model.joints[j].kind.is_moving());
            let (membership, filter) = collision_groups(part, fixed);
            let is_finger = link.name.contains("/finger_");
            for (ci, c) in ul.collision.iter().enumerate() {
                let local = links.link_in_root[l] * urdf_iso(&c.origin);
                let (shape, shape_offset) = collision_shape(&link.name, ci, c, is_finger)?;
                let collider = ColliderBuilder::new(shape)
                    .position(iso_to_glam(&(local * shape_offset)))
                    .density(0.0)
                    .friction(1.0)
                    .contact_skin(self.settings.contact_skin)
                    .collision_groups(InteractionGroups::new(membership, filter, InteractionTestMode::And))
                    .build();
                let ch = self.world.insert_collider(collider, Some(body));
                self.collider_part.insert(ch, part);
            }
        }
        Ok(())
    }

    /// Step 3: every moving joint as a multibody joint (revolute, with its limits); an independent
    /// one gets its motor unit ([`default_gains`]) and becomes a DOF. Returns the mimic joints as
    /// (their body, joint index), for [`DexterSim::couple_mimics`].
    fn insert_joints(
        &mut self,
        links: &LinkGroups,
        handles: &HashMap<usize, RigidBodyHandle>,
    ) -> Result<Vec<(RigidBodyHandle, usize)>, SimError> {
        let model = &self.model;
        let LinkGroups {
            order,
            body_root,
            link_in_root,
            ..
        } = links;
        let mut masters: Vec<(RigidBodyHandle, usize)> = Vec::new(); // (mimic body, joint index)
        for &l in order {
            let Some(j) = model.links[l].parent_joint else { continue };
            let joint = &model.joints[j];
            if !joint.kind.is_moving() {
                continue;
            }
            if joint.kind == control_basis::model::JointKind::Prismatic {
                return Err(SimError::Invalid {
                    path: builtin_path(),
                    field: format!("joint `{}`", joint.name),
                    message: "prismatic joints are not supported by the simulator".into(),
                });
            }
            let parent_body = handles[&body_root[joint.parent]];
            let child_body = handles[&l];
            let r = rotation_x_to(&joint.axis.into_inner());
            let frame1 = link_in_root[joint.parent] * joint.origin * Iso3::from_parts(Translation3::identity(), r);
            let frame2 = Iso3::from_parts(Translation3::identity(), r);
            let mut builder = GenericJointBuilder::new(JointAxesMask::LOCKED_REVOLUTE_AXES)
                .local_frame1(iso_to_glam(&frame1))
                .local_frame2(iso_to_glam(&frame2))
                .contacts_enabled(false);
            let lim = joint.limits;
            if joint.kind == control_basis::model::JointKind::Revolute && lim.lower.is_finite() && lim.upper.is_finite()
            {
                builder = builder.limits(JointAxis::AngX, [lim.lower, lim.upper]);
            }
            if joint.mimic.is_none() {
                let gains = default_gains(&joint.name, lim.effort);
                builder = builder
                    .motor_model(JointAxis::AngX, MotorModel::ForceBased)
                    .motor_max_force(JointAxis::AngX, gains.max_effort);
                self.dof_index.insert(joint.name.clone(), self.dofs.len());
                self.dofs.push(Dof {
                    name: joint.name.clone(),
                    body: child_body,
                    lower: lim.lower,
                    upper: lim.upper,
                    velocity_limit: lim.velocity,
                    gains,
                });
            } else {
                masters.push((child_body, j));
            }
            if self
                .world
                .insert_multibody_joint(parent_body, child_body, builder.build())
                .is_none()
            {
                return Err(SimError::Invalid {
                    path: builtin_path(),
                    field: format!("joint `{}`", joint.name),
                    message: "Rapier refused the joint (kinematic loop?)".into(),
                });
            }
        }
        Ok(masters)
    }

    /// Ties each mimic joint to its master DOF by an exact DOF coupling
    /// (`q_mimic = multiplier · q_master + offset`).
    fn couple_mimics(&mut self, masters: Vec<(RigidBodyHandle, usize)>) -> Result<(), SimError> {
        let model = &self.model;
        for (body, j) in masters {
            let (master, multiplier, offset) = model.mimic_root(&model.joints[j])?;
            let master_name = &model.joints[master].name;
            let &m = self.dof_index.get(master_name).ok_or_else(|| SimError::Unknown {
                kind: "mimic master joint",
                name: master_name.clone(),
                candidates: vec![],
            })?;
            self.mimics.push(MimicDof {
                body,
                master: m,
                multiplier,
                offset,
            });
        }
        for mimic in &self.mimics {
            let master_body = self.dofs[mimic.master].body;
            let mb_joints = &mut self.world.multibody_joints;
            let (Some(&l1), Some(&l2)) = (
                mb_joints.rigid_body_link(master_body),
                mb_joints.rigid_body_link(mimic.body),
            ) else {
                continue;
            };
            if l1.multibody != l2.multibody {
                return Err(SimError::Unsupported(
                    "a mimic joint and its master are on different multibodies",
                ));
            }
            if let Some(mb) = mb_joints.get_multibody_mut(l1.multibody) {
                mb.add_dof_coupling(MultibodyDofCoupling {
                    link1: l1.id,
                    dof1: 0,
                    axis1: 3,
                    link2: l2.id,
                    dof2: 0,
                    axis2: 3,
                    coeff: mimic.multiplier,
                    offset: mimic.offset,
                });
            }
        }
        Ok(())
    }

    /// Each DOF's joint damping from the URDF (self-contacts of the multibodies off).
    fn set_joint_damping(&mut self) -> Result<(), SimError> {
        let model = &self.model;
        for dof in &self.dofs {
            let j = model.joint(&dof.name)?;
            let damping = model.joints[j].damping;
            let mb_joints = &mut self.world.multibody_joints;
            if let Some(&id) = mb_joints.rigid_body_link(dof.body)
                && let Some(mb) = mb_joints.get_multibody_mut(id.multibody)
            {
                mb.set_self_contacts_enabled(false);
                let a = mb.link(id.id).map(|l| l.assembly_id());
                if let Some(a) = a {
                    mb.damping_mut()[a] = damping.max(0.0);
                }
            }
        }
        Ok(())
    }
}

/// How the model's links fall into rigid bodies: a link starts a new body unless it hangs on a
/// fixed joint (the arm and head mounting plates, `…/base_link`, start their own).
struct LinkGroups {
    /// The links, each parent before its children.
    order: Vec<usize>,
    /// The first link of each link's body.
    body_root: Vec<usize>,
    /// Each link's pose in the frame of its body's first link.
    link_in_root: Vec<Iso3>,
    /// Each link's entry in the URDF (`model.urdf.links`), looked up by name.
    urdf_link: Vec<Option<usize>>,
}

impl LinkGroups {
    fn of(model: &RobotModel) -> Self {
        let n = model.links.len();
        // 1. Group links into bodies: a link starts a new body unless it hangs on a fixed joint whose
        //    parent is not the world root group boundary we want to keep separate.
        let mut body_root = vec![usize::MAX; n];
        let mut link_in_root = vec![Iso3::identity(); n];
        let order = topological_links(model);
        for &l in &order {
            match model.links[l].parent_joint {
                None => body_root[l] = l,
                Some(j) => {
                    let joint = &model.joints[j];
                    let name = &model.links[l].name;
                    let own_fixed_root = name.ends_with("/base_link"); // arm and head mounting plates
                    if joint.kind.is_moving() || own_fixed_root {
                        body_root[l] = l;
                    } else {
                        body_root[l] = body_root[joint.parent];
                        link_in_root[l] = link_in_root[joint.parent] * joint.origin;
                    }
                }
            }
        }
        let by_name: HashMap<&str, usize> = model
            .urdf
            .links
            .iter()
            .enumerate()
            .map(|(u, l)| (l.name.as_str(), u))
            .collect();
        let urdf_link = model
            .links
            .iter()
            .map(|l| by_name.get(l.name.as_str()).copied())
            .collect();
        LinkGroups {
            order,
            body_root,
            link_in_root,
            urdf_link,
        }
    }
}

/// The mass properties of the URDF link `ul` in its body's frame, where the link stands at
/// `link_in_root`; `None` for a link without mass.
fn link_mass_properties(ul: &urdf_rs::Link, link_in_root: &Iso3) -> Option<MassProperties> {
    let inertial = &ul.inertial;
    if inertial.mass.value <= 0.0 {
        return None;
    }
    let i = &inertial.inertia;
    let tensor = Matrix3::new(i.ixx, i.ixy, i.ixz, i.ixy, i.iyy, i.iyz, i.ixz, i.iyz, i.izz);
    let frame = link_in_root * urdf_iso(&inertial.origin);
    // Rotate the tensor into the root frame; the COM goes through `frame`.
    let r = frame.rotation.to_rotation_matrix();
    let t = r.matrix() * tensor * r.matrix().transpose();
    let com = frame.translation.vector;
    Some(MassProperties::with_inertia_matrix(
        vec_to_glam(&com),
        inertial.mass.value,
        DMat3::from_cols_array(&[
            t[(0, 0)],
            t[(1, 0)],
            t[(2, 0)],
            t[(0, 1)],
            t[(1, 1)],
            t[(2, 1)],
            t[(0, 2)],
            t[(1, 2)],
            t[(2, 2)],
        ]),
    ))
}

/// The collision groups (membership, filter) of a robot collider on `part`; `fixed`: on a body that
/// does not move (the torso, the mounting plates).
fn collision_groups(part: Part, fixed: bool) -> (Group, Group) {
    match part {
        Part::Palm(_) | Part::Finger(..) => (groups::HAND, groups::OBJECT | groups::STATIC | groups::OBSTACLE),
        Part::Other if fixed => (groups::STATIC, groups::OBJECT | groups::HAND),
        Part::Other => (groups::ARM, groups::OBJECT | groups::OBSTACLE),
    }
}

/// The shape of collision element `ci` (`c`) of the link `link` and its offset in the element's
/// frame; the boxes of a finger become capsules along their long axis.
fn collision_shape(
    link: &str,
    ci: usize,
    c: &urdf_rs::Collision,
    is_finger: bool,
) -> Result<(SharedShape, Iso3), SimError> {
    Ok(match &c.geometry {
        urdf_rs::Geometry::Box { size } if is_finger => {
            // Finger phalanges as capsules along their long axis (box fingers penetrate
            // up to 11 mm in the probe; capsules ≤ 3 mm).
            let s = [size[0], size[1], size[2]];
            let (ax, len) = s
                .iter()
                .copied()
                .enumerate()
                .fold((0, 0.0), |a, (i, v)| if v > a.1 { (i, v) } else { a });
            let r = s
                .iter()
                .enumerate()
                .filter(|&(i, _)| i != ax)
                .map(|(_, &v)| v)
                .fold(f64::INFINITY, f64::min)
                / 2.0;
            let half = (len / 2.0 - r).max(1e-4);
            let mut a = DVec3::ZERO;
            a[ax] = half;
            (SharedShape::capsule(-a, a, r), Iso3::identity())
        }
        urdf_rs::Geometry::Box { size } => (
            SharedShape::cuboid(size[0] / 2.0, size[1] / 2.0, size[2] / 2.0),
            Iso3::identity(),
        ),
        urdf_rs::Geometry::Cylinder { radius, length } => geometry::to_parry(&crate::scene::Shape::Cylinder {
            radius: *radius,
            height: *length,
        }),
        urdf_rs::Geometry::Capsule { radius, length } => geometry::to_parry(&crate::scene::Shape::Capsule {
            radius: *radius,
            height: *length,
        }),
        urdf_rs::Geometry::Sphere { radius } => (SharedShape::ball(*radius), Iso3::identity()),
        urdf_rs::Geometry::Mesh { filename, .. } => {
            return Err(SimError::Invalid {
                path: builtin_path(),
                field: format!("link `{link}` collision[{ci}]"),
                message: format!("mesh collisions are not supported yet ({filename}); use primitives"),
            });
        }
    })
}

fn part_of(link: &str) -> Part {
    let arm = if link.starts_with("left/") {
        Arm::Left
    } else if link.starts_with("right/") {
        Arm::Right
    } else {
        return Part::Other;
    };
    if let Some(rest) = link.split("/bhand/").nth(1) {
        for f in 1..=3u8 {
            let prefix = format!("finger_{f}/");
            if rest.starts_with(&prefix) {
                return if rest.contains("prox") {
                    Part::Other
                } else {
                    Part::Finger(arm, f)
                };
            }
        }
        return Part::Palm(arm);
    }
    Part::Other
}

/// Links in an order where each parent comes before its children.
fn topological_links(model: &RobotModel) -> Vec<usize> {
    let mut order = vec![model.root];
    let mut i = 0;
    while i < order.len() {
        let l = order[i];
        for j in &model.joints {
            if j.parent == l {
                order.push(j.child);
            }
        }
        i += 1;
    }
    order
}
