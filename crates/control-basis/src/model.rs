//! A robot model parsed from URDF: the kinematic tree with joint limits, validated once.
//!
//! [`RobotModel`] is the constant part of a robot (Pinocchio's `Model`): links, joints, their
//! origins, axes, limits and `<mimic>` couplings. Serial chains between any two links are cut from it
//! with [`crate::Chain::new`].

use std::collections::HashMap;
use std::path::Path;

use crate::error::CbError;
use crate::math::{Iso3, UnitVec3, Vec3, iso_from_xyz_rpy};

/// The kind of a joint, as far as kinematics is concerned.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum JointKind {
    /// Rotation about the axis, with position limits.
    Revolute,
    /// Rotation about the axis, no position limits.
    Continuous,
    /// Translation along the axis.
    Prismatic,
    /// Rigid: folded into neighbouring transforms.
    Fixed,
}

impl JointKind {
    /// Whether the joint has a degree of freedom.
    pub fn is_moving(self) -> bool {
        !matches!(self, JointKind::Fixed)
    }
}

/// Position, velocity and effort limits of one joint (radians or metres; `f64::INFINITY` if absent).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct JointLimits {
    /// Lower position limit.
    pub lower: f64,
    /// Upper position limit.
    pub upper: f64,
    /// Velocity limit (rad/s or m/s), `INFINITY` when the URDF gives none.
    pub velocity: f64,
    /// Effort limit (N·m or N), `INFINITY` when the URDF gives none.
    pub effort: f64,
}

impl JointLimits {
    /// No limits at all.
    pub const UNLIMITED: JointLimits = JointLimits {
        lower: f64::NEG_INFINITY,
        upper: f64::INFINITY,
        velocity: f64::INFINITY,
        effort: f64::INFINITY,
    };
}

/// A `<mimic>` coupling: `q = multiplier · q_master + offset`.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Mimic {
    /// The joint this one follows.
    pub joint: String,
    /// Gear ratio.
    pub multiplier: f64,
    /// Offset (rad or m).
    pub offset: f64,
}

/// One joint of the tree.
#[derive(Debug, Clone)]
pub struct Joint {
    /// Name, unique in the model.
    pub name: String,
    /// Kind.
    pub kind: JointKind,
    /// Index of the parent link in [`RobotModel::links`].
    pub parent: usize,
    /// Index of the child link.
    pub child: usize,
    /// `parent_from_joint` at q = 0.
    pub origin: Iso3,
    /// Axis in the joint frame (unit length).
    pub axis: UnitVec3,
    /// Limits.
    pub limits: JointLimits,
    /// Coupling to another joint, if any.
    pub mimic: Option<Mimic>,
    /// Viscous damping from `<dynamics>` (N·m·s/rad), 0 when absent.
    pub damping: f64,
}

/// One link of the tree.
#[derive(Debug, Clone)]
pub struct Link {
    /// Name, unique in the model.
    pub name: String,
    /// The joint whose child this link is (`None` for the root).
    pub parent_joint: Option<usize>,
    /// Mass in kg (0 when the URDF has no `<inertial>`).
    pub mass: f64,
}

/// The shape of a [`Visual`], in URDF's conventions (cylinders and capsules along local z).
#[derive(Debug, Clone, PartialEq)]
pub enum VisualGeometry {
    /// A box with these full extents (m).
    Box {
        /// x, y, z extents.
        size: [f64; 3],
    },
    /// A cylinder along z, centred on the origin.
    Cylinder {
        /// Radius (m).
        radius: f64,
        /// Length along z (m).
        length: f64,
    },
    /// A capsule along z: a cylinder of `length` with hemispherical caps.
    Capsule {
        /// Radius (m).
        radius: f64,
        /// Length of the cylindrical part (m).
        length: f64,
    },
    /// A sphere.
    Sphere {
        /// Radius (m).
        radius: f64,
    },
    /// A mesh file, as the URDF names it.
    Mesh {
        /// The file name or URI.
        filename: String,
        /// Scale along x, y, z.
        scale: [f64; 3],
    },
}

/// One `<visual>` element of a link ([`RobotModel::visuals`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Visual {
    /// Index of the link into [`RobotModel::links`].
    pub link: usize,
    /// Pose of the shape in the link frame.
    pub origin: Iso3,
    /// The shape.
    pub geometry: VisualGeometry,
    /// Colour (r, g, b, a in [0, 1]), if the material gives one.
    pub rgba: Option<[f64; 4]>,
}

/// A validated kinematic tree read from URDF.
#[derive(Debug, Clone)]
pub struct RobotModel {
    /// Robot name from the URDF.
    pub name: String,
    /// Links, in file order.
    pub links: Vec<Link>,
    /// Joints, in file order.
    pub joints: Vec<Joint>,
    /// Index of the root link.
    pub root: usize,
    link_index: HashMap<String, usize>,
    joint_index: HashMap<String, usize>,
    /// The parsed URDF, kept for consumers that need geometry and inertia (the simulator).
    pub urdf: urdf_rs::Robot,
}

/// Deepest element nesting a URDF may have (a real one nests 4–5 deep).
pub const MAX_URDF_DEPTH: usize = 64;

/// The deepest element nesting of XML `text`, counted from its tags without parsing it (comments,
/// processing instructions, declarations and self-closing tags do not nest).
pub fn xml_depth(text: &str) -> usize {
    let (mut depth, mut deepest) = (0usize, 0usize);
    let mut rest = text;
    while let Some(i) = rest.find('<') {
        rest = &rest[i + 1..];
        let end = rest.find('>').unwrap_or(rest.len());
        let tag = &rest[..end];
        if tag.starts_with('/') {
            depth = depth.saturating_sub(1);
        } else if !(tag.starts_with('!') || tag.starts_with('?') || tag.ends_with('/')) {
            depth += 1;
            deepest = deepest.max(depth);
        }
        rest = &rest[end.min(rest.len())..];
    }
    deepest
}

impl RobotModel {
    /// Reads and validates a URDF file.
    pub fn from_urdf_file(path: impl AsRef<Path>) -> Result<Self, CbError> {
        let path = path.as_ref();
        let text = bayes::input::read_text(path).map_err(|source| CbError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Self::parse(&text, Some(path))
    }

    /// Parses and validates URDF text.
    pub fn from_urdf_str(text: &str) -> Result<Self, CbError> {
        Self::parse(text, None)
    }

    fn parse(text: &str, origin: Option<&Path>) -> Result<Self, CbError> {
        // The XML parser recurses per nested element: 10⁵ of them overflowed the stack (an abort).
        let depth = xml_depth(text);
        if depth > MAX_URDF_DEPTH {
            return Err(CbError::MalformedUrdf {
                origin: origin.map(Path::to_path_buf),
                message: format!("elements nested {depth} deep; a URDF nests at most {MAX_URDF_DEPTH}"),
            });
        }
        let urdf = urdf_rs::read_from_string(text).map_err(|e| CbError::MalformedUrdf {
            origin: origin.map(Path::to_path_buf),
            message: e.to_string(),
        })?;
        Self::from_urdf(urdf)
    }

    /// Builds and validates the model from a parsed `urdf_rs::Robot`.
    pub fn from_urdf(urdf: urdf_rs::Robot) -> Result<Self, CbError> {
        let invalid = |element: &'static str, name: &str, problem: String| CbError::InvalidModel {
            element,
            name: name.to_string(),
            problem,
        };
        if urdf.links.is_empty() {
            return Err(invalid("robot", &urdf.name, "has no links".into()));
        }
        let mut links = Vec::with_capacity(urdf.links.len());
        let mut link_index = HashMap::new();
        for (i, l) in urdf.links.iter().enumerate() {
            if link_index.insert(l.name.clone(), i).is_some() {
                return Err(invalid("link", &l.name, "defined twice".into()));
            }
            let mass = l.inertial.mass.value;
            if !mass.is_finite() || mass < 0.0 {
                return Err(invalid(
                    "link",
                    &l.name,
                    format!("mass {mass} is not a non-negative number"),
                ));
            }
            links.push(Link {
                name: l.name.clone(),
                parent_joint: None,
                mass,
            });
        }
        let mut joints = Vec::with_capacity(urdf.joints.len());
        let mut joint_index = HashMap::new();
        for (i, j) in urdf.joints.iter().enumerate() {
            if joint_index.insert(j.name.clone(), i).is_some() {
                return Err(invalid("joint", &j.name, "defined twice".into()));
            }
            let parent = *link_index.get(&j.parent.link).ok_or_else(|| {
                invalid(
                    "joint",
                    &j.name,
                    format!("parent link '{}' does not exist", j.parent.link),
                )
            })?;
            let child = *link_index.get(&j.child.link).ok_or_else(|| {
                invalid(
                    "joint",
                    &j.name,
                    format!("child link '{}' does not exist", j.child.link),
                )
            })?;
            if parent == child {
                return Err(invalid("joint", &j.name, "parent and child are the same link".into()));
            }
            if let Some(other) = links[child].parent_joint {
                return Err(invalid(
                    "link",
                    &links[child].name,
                    format!("has two parent joints ('{}' and '{}')", urdf.joints[other].name, j.name),
                ));
            }
            links[child].parent_joint = Some(i);
            let xyz = *j.origin.xyz;
            let rpy = *j.origin.rpy;
            if xyz.iter().chain(rpy.iter()).any(|v| !v.is_finite()) {
                return Err(invalid(
                    "joint",
                    &j.name,
                    format!("origin xyz {xyz:?} rpy {rpy:?} is not finite"),
                ));
            }
            let kind = match j.joint_type {
                urdf_rs::JointType::Revolute => JointKind::Revolute,
                urdf_rs::JointType::Continuous => JointKind::Continuous,
                urdf_rs::JointType::Prismatic => JointKind::Prismatic,
                urdf_rs::JointType::Fixed => JointKind::Fixed,
                ref other => {
                    return Err(invalid(
                        "joint",
                        &j.name,
                        format!("type {other:?} is not supported (revolute, continuous, prismatic and fixed are)"),
                    ));
                }
            };
            let axis_raw = Vec3::from(*j.axis.xyz);
            let axis = if kind.is_moving() {
                let n = axis_raw.norm();
                if !n.is_finite() || n < 1e-12 {
                    return Err(invalid(
                        "joint",
                        &j.name,
                        format!("axis {:?} is zero or not finite", *j.axis.xyz),
                    ));
                }
                UnitVec3::new_normalize(axis_raw)
            } else {
                Vec3::z_axis()
            };
            let limits = match kind {
                JointKind::Fixed => JointLimits::UNLIMITED,
                JointKind::Continuous => JointLimits {
                    lower: f64::NEG_INFINITY,
                    upper: f64::INFINITY,
                    velocity: positive_or_inf(j.limit.velocity),
                    effort: positive_or_inf(j.limit.effort),
                },
                JointKind::Revolute | JointKind::Prismatic => {
                    let (lo, hi) = (j.limit.lower, j.limit.upper);
                    // urdf-rs fills an absent <limit> with zeros; the URDF spec requires one here.
                    if lo == 0.0 && hi == 0.0 && j.limit.effort == 0.0 && j.limit.velocity == 0.0 {
                        return Err(invalid(
                            "joint",
                            &j.name,
                            "a revolute or prismatic joint needs a <limit lower upper effort velocity> element".into(),
                        ));
                    }
                    if !lo.is_finite() || !hi.is_finite() || lo > hi {
                        return Err(invalid(
                            "joint",
                            &j.name,
                            format!("limits lower={lo} upper={hi} must be finite with lower <= upper"),
                        ));
                    }
                    JointLimits {
                        lower: lo,
                        upper: hi,
                        velocity: positive_or_inf(j.limit.velocity),
                        effort: positive_or_inf(j.limit.effort),
                    }
                }
            };
            if j.limit.velocity.is_nan() || j.limit.effort.is_nan() {
                return Err(invalid("joint", &j.name, "velocity or effort limit is NaN".into()));
            }
            let mimic = match &j.mimic {
                Some(m) => {
                    let multiplier = m.multiplier.unwrap_or(1.0);
                    let offset = m.offset.unwrap_or(0.0);
                    if !multiplier.is_finite() || !offset.is_finite() {
                        return Err(invalid("joint", &j.name, "mimic multiplier/offset not finite".into()));
                    }
                    Some(Mimic {
                        joint: m.joint.clone(),
                        multiplier,
                        offset,
                    })
                }
                None => None,
            };
            let damping = j.dynamics.as_ref().map(|d| d.damping).unwrap_or(0.0);
            joints.push(Joint {
                name: j.name.clone(),
                kind,
                parent,
                child,
                origin: iso_from_xyz_rpy(xyz, rpy),
                axis,
                limits,
                mimic,
                damping: if damping.is_finite() { damping } else { 0.0 },
            });
        }
        // Mimic targets must exist, be moving, and not form cycles.
        for j in &joints {
            if let Some(m) = &j.mimic {
                let Some(&t) = joint_index.get(&m.joint) else {
                    return Err(invalid("joint", &j.name, format!("mimics unknown joint '{}'", m.joint)));
                };
                if !joints[t].kind.is_moving() {
                    return Err(invalid("joint", &j.name, format!("mimics fixed joint '{}'", m.joint)));
                }
            }
        }
        let roots: Vec<usize> = (0..links.len()).filter(|&i| links[i].parent_joint.is_none()).collect();
        if roots.len() != 1 {
            let names: Vec<&str> = roots.iter().map(|&i| links[i].name.as_str()).collect();
            return Err(invalid(
                "robot",
                &urdf.name,
                format!("must have exactly one root link, found {}: {names:?}", roots.len()),
            ));
        }
        let root = roots[0];
        let model = RobotModel {
            name: urdf.name.clone(),
            links,
            joints,
            root,
            link_index,
            joint_index,
            urdf,
        };
        // Every link must reach the root (no cycles).
        for i in 0..model.links.len() {
            let mut steps = 0;
            let mut l = i;
            while let Some(j) = model.links[l].parent_joint {
                l = model.joints[j].parent;
                steps += 1;
                if steps > model.links.len() {
                    return Err(invalid(
                        "link",
                        &model.links[i].name,
                        "is part of a kinematic cycle".into(),
                    ));
                }
            }
        }
        for j in &model.joints {
            model.mimic_root(j)?;
        }
        Ok(model)
    }

    /// The `<visual>` elements of every link, for drawing the robot: each a primitive in its link's
    /// frame, with the colour of its material (an inline `<color>`, else the robot-level material of
    /// that name, else `None`). Meshes are listed with their file name and scale; a viewer that
    /// cannot load them may skip them. Elements with non-finite or negative sizes are left out.
    pub fn visuals(&self) -> Vec<Visual> {
        let named = |name: &str| {
            self.urdf
                .materials
                .iter()
                .find(|m| m.name == name)
                .and_then(|m| m.color.as_ref())
                .map(|c| *c.rgba)
        };
        let mut out = Vec::new();
        for (link, l) in self.urdf.links.iter().enumerate() {
            for v in &l.visual {
                let xyz = *v.origin.xyz;
                let rpy = *v.origin.rpy;
                if xyz.iter().chain(rpy.iter()).any(|x| !x.is_finite()) {
                    continue;
                }
                let ok = |x: f64| x.is_finite() && x >= 0.0;
                let geometry = match &v.geometry {
                    urdf_rs::Geometry::Box { size } if size.iter().all(|&x| ok(x)) => {
                        VisualGeometry::Box { size: **size }
                    }
                    urdf_rs::Geometry::Cylinder { radius, length } if ok(*radius) && ok(*length) => {
                        VisualGeometry::Cylinder {
                            radius: *radius,
                            length: *length,
                        }
                    }
                    urdf_rs::Geometry::Capsule { radius, length } if ok(*radius) && ok(*length) => {
                        VisualGeometry::Capsule {
                            radius: *radius,
                            length: *length,
                        }
                    }
                    urdf_rs::Geometry::Sphere { radius } if ok(*radius) => VisualGeometry::Sphere { radius: *radius },
                    urdf_rs::Geometry::Mesh { filename, scale } => VisualGeometry::Mesh {
                        filename: filename.clone(),
                        scale: scale.as_ref().map_or([1.0; 3], |s| **s),
                    },
                    _ => continue,
                };
                let rgba = v
                    .material
                    .as_ref()
                    .and_then(|m| m.color.as_ref().map(|c| *c.rgba).or_else(|| named(&m.name)))
                    .filter(|c| c.iter().all(|x| x.is_finite()));
                out.push(Visual {
                    link,
                    origin: iso_from_xyz_rpy(xyz, rpy),
                    geometry,
                    rgba,
                });
            }
        }
        out
    }

    /// Index of the link called `name`.
    pub fn link(&self, name: &str) -> Result<usize, CbError> {
        self.link_index.get(name).copied().ok_or_else(|| CbError::UnknownLink {
            name: name.to_string(),
            candidates: self.similar_links(name),
        })
    }

    /// Index of the joint called `name`.
    pub fn joint(&self, name: &str) -> Result<usize, CbError> {
        self.joint_index
            .get(name)
            .copied()
            .ok_or_else(|| CbError::UnknownJoint { name: name.to_string() })
    }

    /// The independent joint a (possibly mimicking) joint finally follows, with the composed
    /// multiplier and offset: `q_joint = m · q_root + o`.
    pub fn mimic_root(&self, joint: &Joint) -> Result<(usize, f64, f64), CbError> {
        let mut idx = self.joint(&joint.name)?;
        let (mut m, mut o) = (1.0, 0.0);
        for _ in 0..=self.joints.len() {
            match &self.joints[idx].mimic {
                None => return Ok((idx, m, o)),
                Some(mm) => {
                    // q_idx = mm.multiplier * q_next + mm.offset
                    o += m * mm.offset;
                    m *= mm.multiplier;
                    idx = self.joint(&mm.joint)?;
                }
            }
        }
        Err(CbError::InvalidModel {
            element: "joint",
            name: joint.name.clone(),
            problem: "mimic couplings form a cycle".into(),
        })
    }

    /// Independent moving joints (not fixed, not mimicking another): the robot's degrees of freedom.
    pub fn actuated_joints(&self) -> impl Iterator<Item = &Joint> {
        self.joints.iter().filter(|j| j.kind.is_moving() && j.mimic.is_none())
    }

    /// Link names that look like `name` (same suffix or containing it), for error messages.
    fn similar_links(&self, name: &str) -> Vec<String> {
        let tail = name.rsplit('/').next().unwrap_or(name);
        let mut out: Vec<String> = self
            .links
            .iter()
            .filter(|l| !tail.is_empty() && (l.name.ends_with(tail) || l.name.contains(name)))
            .map(|l| l.name.clone())
            .collect();
        out.truncate(5);
        out
    }

    /// Every link's pose in the root's frame (in [`RobotModel::links`]' order) for joint values
    /// given by name (`q` of a joint that is not given is 0; a mimic joint follows its root,
    /// `multiplier · q_root + offset`), written into `out` (resized). The whole tree at once: what a
    /// robot's own `/tf` is made from.
    pub fn link_poses(&self, q: &dyn Fn(&str) -> Option<f64>, out: &mut Vec<Iso3>) {
        out.clear();
        out.resize(self.links.len(), Iso3::identity());
        let mut done = vec![false; self.links.len()];
        done[self.root] = true;
        // Parents before children: repeat over the joints until every reachable link is placed.
        let mut placed = 1;
        while placed < self.links.len() {
            let before = placed;
            for j in &self.joints {
                if done[j.child] || !done[j.parent] {
                    continue;
                }
                let value = |name: &str| q(name).filter(|v| v.is_finite()).unwrap_or(0.0);
                let theta = match &j.mimic {
                    Some(m) => m.multiplier * value(&m.joint) + m.offset,
                    None => value(&j.name),
                };
                let motion = match j.kind {
                    JointKind::Fixed => Iso3::identity(),
                    JointKind::Prismatic => Iso3::translation(j.axis.x * theta, j.axis.y * theta, j.axis.z * theta),
                    JointKind::Revolute | JointKind::Continuous => Iso3::from_parts(
                        nalgebra::Translation3::identity(),
                        nalgebra::UnitQuaternion::from_axis_angle(&j.axis, theta),
                    ),
                };
                out[j.child] = out[j.parent] * j.origin * motion;
                done[j.child] = true;
                placed += 1;
            }
            if placed == before {
                break; // links no joint reaches stay at the root
            }
        }
    }

    /// Path from the root to `link`: the joints crossed, root first.
    pub fn joints_from_root(&self, link: usize) -> Vec<usize> {
        let mut out = Vec::new();
        let mut l = link;
        while let Some(j) = self.links[l].parent_joint {
            out.push(j);
            l = self.joints[j].parent;
        }
        out.reverse();
        out
    }
}

fn positive_or_inf(v: f64) -> f64 {
    if v.is_finite() && v > 0.0 { v } else { f64::INFINITY }
}
