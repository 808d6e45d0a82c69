//! The simulated world written as an MJCF model, for MuJoCo: the peer side of the side-by-side
//! benchmark (`benches/peers/sim_vs_mujoco.py`).
//!
//! Everything comes from the Rapier world as [`DexterSim`] built it, so the two simulators step the
//! same bodies:
//! - every rigid body with its mass, centre of mass and principal inertia (`<inertial>`); the
//!   robot's bodies nested along their multibody joints, with the joint frames, axes, limits and
//!   damping; the objects as free bodies; the table, floor and bins static;
//! - every collider as the same primitive (box, sphere, capsule, cylinder), its friction, and its
//!   collision groups as `contype` (membership) / `conaffinity` (filter) bits: the groups are
//!   symmetric, so MuJoCo's "either way" rule selects the same pairs as Rapier's "both ways";
//! - gravity compensation of the robot's links (`gravcomp="1"`, Rapier: gravity scale 0);
//! - each motor unit as one `general` actuator with `gainprm = 1` and `biasprm = (0, −kp, −kd)`:
//!   with `ctrl = kp·q_ref + kd·q̇_ref` it applies τ = kp (q_ref − q) + kd (q̇_ref − q̇), clipped to
//!   the same effort limit, exactly the PD of [`DexterSim`];
//! - each mimic joint as a joint equality `q = offset + multiplier · q_master` (Rapier: a DOF
//!   coupling).
//!
//! What differs, by construction of the two engines: the contact model (MuJoCo's soft constraints
//! with its default `solref`/`solimp` against Rapier's 60 Hz contact springs and 2 mm skin), the
//! solver (MuJoCo Newton, default 100 iterations and tolerance; Rapier 4 substeps of soft PGS), the
//! friction combination (MuJoCo: the larger of the two; Rapier: the average) and the objects'
//! angular damping (Rapier only: 1 /s) and rolling resistance (Rapier only, `SimSettings::rolling_resistance`; MuJoCo's
//! own rolling friction is not set).
use std::fmt::Write as _;

use super::*;
use crate::convert::rot_from_glam;

/// `x y z` of a vector.
fn v3(v: &Vec3) -> String {
    format!("{} {} {}", v.x, v.y, v.z)
}

/// `w x y z` of a rotation (MuJoCo's quaternion order).
fn quat(r: &Rot3) -> String {
    let q = r.quaternion();
    format!("{} {} {} {}", q.w, q.i, q.j, q.k)
}

/// `pos=".." quat=".."` of a pose.
fn pose_attrs(p: &Iso3) -> String {
    format!("pos=\"{}\" quat=\"{}\"", v3(&p.translation.vector), quat(&p.rotation))
}

/// An XML-safe name (MuJoCo reserves `world`).
fn xml_name(s: &str) -> String {
    if s == "world" {
        return "robot_world".into();
    }
    s.chars()
        .map(|c| {
            if matches!(c, '"' | '<' | '>' | '&' | '\'') {
                '_'
            } else {
                c
            }
        })
        .collect()
}

impl DexterSim {
    /// The world as an MJCF document (see the module documentation for what is and is not the same).
    ///
    /// The bodies are written at q = 0 and the objects where they are now; the current joint
    /// positions are the keyframe `now` (`qpos` of the hinge joints in document order, then each
    /// object's free joint).
    pub fn to_mjcf(&self) -> Result<String, SimError> {
        let w = &self.world;
        let mut out = String::new();
        let mut key_qpos: Vec<f64> = Vec::new();
        let s = &self.settings;
        let _ = writeln!(out, "<mujoco model=\"dexter\">");
        let _ = writeln!(
            out,
            "  <!-- Written by dexter_sim::DexterSim::to_mjcf from the Rapier world of the same scene. -->"
        );
        let _ = writeln!(out, "  <compiler angle=\"radian\" autolimits=\"true\"/>");
        let _ = writeln!(
            out,
            "  <option timestep=\"{}\" integrator=\"implicitfast\" solver=\"Newton\" cone=\"pyramidal\" gravity=\"0 0 {}\"/>",
            s.dt, -s.gravity
        );
        let _ = writeln!(out, "  <size memory=\"64M\"/>");
        let _ = writeln!(out, "  <worldbody>");

        // Names of the robot's joints: DOFs and mimic joints by child body.
        let mut joint_name: HashMap<RigidBodyHandle, String> = HashMap::new();
        for d in &self.dofs {
            joint_name.insert(d.body, d.name.clone());
        }
        for (i, m) in self.mimics.iter().enumerate() {
            let l = w.bodies.get(m.body).map(|b| b.user_data as usize);
            let name = l
                .and_then(|l| self.model.links.get(l))
                .and_then(|link| link.parent_joint)
                .map(|j| self.model.joints[j].name.clone())
                .unwrap_or_else(|| format!("mimic_{i}"));
            joint_name.insert(m.body, name);
        }
        let body_name = |h: RigidBodyHandle, fallback: &str| -> String {
            if let Some(o) = self.objects.iter().find(|o| o.body == h) {
                return xml_name(&o.name);
            }
            match self.link_body.iter().position(|(b, _)| *b == h) {
                Some(l) => xml_name(&self.model.links[l].name),
                None => fallback.to_string(),
            }
        };

        let mut static_k = 0usize;
        for (h, body) in w.bodies.iter() {
            let link = w.multibody_joints.rigid_body_link(h).copied();
            match link {
                Some(l) if l.id != 0 => continue, // written under its parent
                Some(l) => {
                    let Some(mb) = w.multibody_joints.get_multibody(l.multibody) else {
                        continue;
                    };
                    let name = body_name(h, &format!("robot_root_{static_k}"));
                    static_k += 1;
                    self.write_link(&mut out, mb, 0, &name, &joint_name, &mut key_qpos, 2)?;
                }
                None if body.is_fixed() => {
                    let name = body_name(h, &format!("static_{static_k}"));
                    static_k += 1;
                    let p = iso_from_glam(body.position());
                    let _ = writeln!(out, "    <body name=\"{name}\" {}>", pose_attrs(&p));
                    self.write_geoms(&mut out, body, 6)?;
                    let _ = writeln!(out, "    </body>");
                }
                None => {} // objects last, after the robot (their free joints come last in qpos)
            }
        }
        for o in &self.objects {
            let Some(body) = w.bodies.get(o.body) else { continue };
            let p = iso_from_glam(body.position());
            let _ = writeln!(out, "    <body name=\"{}\" {}>", xml_name(&o.name), pose_attrs(&p));
            let _ = writeln!(out, "      <freejoint name=\"{}\"/>", xml_name(&o.name));
            self.write_inertial(&mut out, body, 6);
            self.write_geoms(&mut out, body, 6)?;
            let _ = writeln!(out, "    </body>");
            key_qpos.extend(p.translation.vector.iter());
            let q = p.rotation.quaternion();
            key_qpos.extend([q.w, q.i, q.j, q.k]);
        }
        let _ = writeln!(out, "  </worldbody>");

        if !self.mimics.is_empty() {
            let _ = writeln!(out, "  <equality>");
            for m in &self.mimics {
                let master = &self.dofs[m.master].name;
                let _ = writeln!(
                    out,
                    "    <joint joint1=\"{}\" joint2=\"{}\" polycoef=\"{} {} 0 0 0\"/>",
                    xml_name(&joint_name[&m.body]),
                    xml_name(master),
                    m.offset,
                    m.multiplier
                );
            }
            let _ = writeln!(out, "  </equality>");
        }
        let _ = writeln!(out, "  <actuator>");
        for d in &self.dofs {
            let g = d.gains;
            let _ = writeln!(
                out,
                "    <general name=\"{n}\" joint=\"{n}\" gainprm=\"1\" biastype=\"affine\" biasprm=\"0 {} {}\" forcerange=\"{} {}\"/>",
                -g.kp,
                -g.kd,
                -g.max_effort,
                g.max_effort,
                n = xml_name(&d.name)
            );
        }
        let _ = writeln!(out, "  </actuator>");
        let qpos: Vec<String> = key_qpos.iter().map(|x| x.to_string()).collect();
        let _ = writeln!(
            out,
            "  <keyframe>\n    <key name=\"now\" qpos=\"{}\"/>\n  </keyframe>",
            qpos.join(" ")
        );
        let _ = writeln!(out, "</mujoco>");
        Ok(out)
    }

    #[allow(clippy::too_many_arguments)]
    fn write_link(
        &self,
        out: &mut String,
        mb: &Multibody,
        id: usize,
        name: &str,
        joint_name: &HashMap<RigidBodyHandle, String>,
        key_qpos: &mut Vec<f64>,
        depth: usize,
    ) -> Result<(), SimError> {
        let w = &self.world;
        let Some(link) = mb.link(id) else { return Ok(()) };
        let h = link.rigid_body_handle();
        let body = &w.bodies[h];
        let pad = " ".repeat(2 * depth);
        let joint = &link.joint().data;
        let (pose, hinge) = match link.parent_id() {
            None => (iso_from_glam(body.position()), None),
            Some(_) => {
                let f1 = iso_from_glam(&joint.local_frame1);
                let f2 = iso_from_glam(&joint.local_frame2);
                (f1 * f2.inverse(), Some(f2))
            }
        };
        let grav = if body.is_dynamic() { " gravcomp=\"1\"" } else { "" };
        let _ = writeln!(out, "{pad}<body name=\"{name}\" {}{grav}>", pose_attrs(&pose));
        if let Some(f2) = hinge {
            let jn = joint_name.get(&h).cloned().unwrap_or_else(|| format!("{name}_joint"));
            let axis = f2.rotation * Vec3::x();
            let range = joint
                .limits(JointAxis::AngX)
                .map(|l| format!(" range=\"{} {}\"", l.min, l.max))
                .unwrap_or_default();
            let damping = mb.damping().get(link.assembly_id()).copied().unwrap_or(0.0);
            let _ = writeln!(
                out,
                "{pad}  <joint name=\"{}\" type=\"hinge\" pos=\"{}\" axis=\"{}\"{range} damping=\"{damping}\"/>",
                xml_name(&jn),
                v3(&f2.translation.vector),
                v3(&axis)
            );
            let q = self
                .dofs
                .iter()
                .position(|d| d.body == h)
                .map(|i| self.q[i])
                .unwrap_or_else(|| link.joint().coords()[3]);
            key_qpos.push(q);
        }
        if body.is_dynamic() {
            self.write_inertial(out, body, 2 * depth + 2);
        }
        self.write_geoms(out, body, 2 * depth + 2)?;
        for child in mb.links().filter(|l| l.parent_id() == Some(id)) {
            let ch = child.rigid_body_handle();
            let cname = match self.link_body.iter().position(|(b, _)| *b == ch) {
                Some(l) => xml_name(&self.model.links[l].name),
                None => format!("{name}_{}", child.link_id()),
            };
            self.write_link(out, mb, child.link_id(), &cname, joint_name, key_qpos, depth + 1)?;
        }
        let _ = writeln!(out, "{pad}</body>");
        Ok(())
    }

    fn write_inertial(&self, out: &mut String, body: &RigidBody, indent: usize) {
        let m = &body.mass_properties().local_mprops;
        let pad = " ".repeat(indent);
        let mass = m.mass().max(1e-6);
        let inertia = m.principal_inertia();
        let frame = rot_from_glam(m.principal_inertia_local_frame);
        let _ = writeln!(
            out,
            "{pad}<inertial pos=\"{}\" quat=\"{}\" mass=\"{mass}\" diaginertia=\"{} {} {}\"/>",
            v3(&vec_from_glam(m.local_com)),
            quat(&frame),
            inertia.x.max(1e-9),
            inertia.y.max(1e-9),
            inertia.z.max(1e-9)
        );
    }

    fn write_geoms(&self, out: &mut String, body: &RigidBody, indent: usize) -> Result<(), SimError> {
        let pad = " ".repeat(indent);
        for &ch in body.colliders() {
            let c = &self.world.colliders[ch];
            let local = c
                .position_wrt_parent()
                .map(iso_from_glam)
                .unwrap_or_else(Iso3::identity);
            let g = c.collision_groups();
            let common = format!(
                "contype=\"{}\" conaffinity=\"{}\" friction=\"{} 0.005 0.0001\" mass=\"0\"",
                // MuJoCo's bit masks are signed 32-bit integers: bit 31 (unused here) is dropped.
                g.memberships.bits() & 0x7fff_ffff,
                g.filter.bits() & 0x7fff_ffff,
                c.friction()
            );
            let shape = c.shape();
            if let Some(b) = shape.as_ball() {
                let _ = writeln!(
                    out,
                    "{pad}<geom type=\"sphere\" size=\"{}\" {} {common}/>",
                    b.radius,
                    pose_attrs(&local)
                );
            } else if let Some(b) = shape.as_cuboid() {
                let he = vec_from_glam(b.half_extents);
                let _ = writeln!(
                    out,
                    "{pad}<geom type=\"box\" size=\"{}\" {} {common}/>",
                    v3(&he),
                    pose_attrs(&local)
                );
            } else if let Some(cap) = shape.as_capsule() {
                let a = local * nalgebra::Point3::from(vec_from_glam(cap.segment.a));
                let b = local * nalgebra::Point3::from(vec_from_glam(cap.segment.b));
                let _ = writeln!(
                    out,
                    "{pad}<geom type=\"capsule\" size=\"{}\" fromto=\"{} {}\" {common}/>",
                    cap.radius,
                    v3(&a.coords),
                    v3(&b.coords)
                );
            } else if let Some(cyl) = shape.as_cylinder() {
                // Parry's cylinder runs along y, MuJoCo's along z.
                let y_to_z = Rot3::from_axis_angle(&Vec3::x_axis(), -std::f64::consts::FRAC_PI_2);
                let p = Iso3::from_parts(local.translation, local.rotation * y_to_z);
                let _ = writeln!(
                    out,
                    "{pad}<geom type=\"cylinder\" size=\"{} {}\" {} {common}/>",
                    cyl.radius,
                    cyl.half_height,
                    pose_attrs(&p)
                );
            } else {
                return Err(SimError::Unsupported(
                    "MJCF export: a collider shape other than box, sphere, capsule or cylinder",
                ));
            }
        }
        Ok(())
    }
}
