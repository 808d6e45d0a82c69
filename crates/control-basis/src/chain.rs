//! Serial kinematic chains cut from a [`RobotModel`]: forward kinematics of every link and the
//! geometric Jacobian, allocation-free.
//!
//! A [`Chain`] is constant once built (Pinocchio's `Model`); a [`ChainState`] holds the joint values,
//! the forward-kinematics cache and the Jacobian buffer (Pinocchio's `Data`). The algorithms are free
//! functions, [`forward_kinematics`] and [`jacobian`], that write into the state and never allocate.
//!
//! A chain runs between any two links of the tree. Where the path climbs from the base towards the root
//! before descending to the tip, the climbed joints are traversed backwards (their sign is −1), so a chain
//! from the left hand to the right hand through the torso is as valid as one from an arm's base to its
//! wrist. Fixed joints are folded into the neighbouring constant transforms. Joints that `<mimic>` another
//! share its degree of freedom: the chain's variables are the *independent* joints ([`Dof`]), and a
//! mimicking joint contributes `multiplier ×` its own column to its master's Jacobian column. A mimicking
//! joint whose master lies off the chain (the BarrettHand's finger-2 spread, which follows finger 1)
//! still makes the master a variable of the chain.
//!
//! Poses are `base_from_link`: expressed in the chain's base frame. The Jacobian is 6×n with rows
//! (vx, vy, vz, ωx, ωy, ωz): the velocity of the frame origin and the angular velocity, both in axes of
//! the base frame (Pinocchio's `LOCAL_WORLD_ALIGNED` with the base as world).

use std::collections::HashMap;

use nalgebra::{DVector, Matrix6xX, Translation3};

use crate::error::{CbError, check_finite};
use crate::math::{Iso3, Rot3, UnitVec3, Vec3};
use crate::model::{JointKind, JointLimits, RobotModel};

/// One moving joint of a chain.
#[derive(Debug, Clone)]
pub struct ChainJoint {
    /// The URDF joint name.
    pub name: String,
    /// Revolute, continuous or prismatic.
    pub kind: JointKind,
    /// Constant transform from the previous moving joint's frame (or the base) to this joint's frame.
    pub fixed_before: Iso3,
    /// Axis in this joint's frame.
    pub axis: UnitVec3,
    /// +1 when traversed parent → child, −1 when the chain climbs it child → parent.
    pub sign: f64,
    /// The chain variable (independent joint) that drives this joint.
    pub dof: usize,
    /// Joint value = `multiplier · q[dof] + offset` (from `<mimic>`; 1 and 0 otherwise).
    pub multiplier: f64,
    /// See `multiplier`.
    pub offset: f64,
}

/// A variable of the chain: an independent joint of the model.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Dof {
    /// The independent joint's URDF name.
    pub name: String,
    /// Its kind.
    pub kind: JointKind,
    /// Its limits from the URDF.
    pub limits: JointLimits,
}

/// A link on the chain and where its frame is attached.
#[derive(Debug, Clone)]
pub struct ChainLink {
    /// URDF link name.
    pub name: String,
    /// The last moving joint before this link (`None`: rigidly attached to the base).
    pub after: Option<usize>,
    /// `joint_frame_from_link` (or `base_from_link` when `after` is `None`).
    pub offset: Iso3,
    /// `offset` is exactly the identity (the usual case: a joint's child link), so FK copies the frame.
    pub offset_is_identity: bool,
}

/// A serial chain between two links: constant once built.
#[derive(Debug, Clone)]
pub struct Chain {
    base: String,
    tip: String,
    joints: Vec<ChainJoint>,
    dofs: Vec<Dof>,
    links: Vec<ChainLink>,
    tip_offset: Iso3,
}

/// Working state of a chain: joint values, FK cache, Jacobian buffer.
#[derive(Debug, Clone)]
pub struct ChainState {
    q: DVector<f64>,
    /// `base_from_joint_frame` of each moving joint, after its motion.
    frames: Vec<Iso3>,
    /// `base_from_link` of each chain link.
    link_poses: Vec<Iso3>,
    tip: Iso3,
    jacobian: Matrix6xX<f64>,
}

impl Chain {
    /// Cuts the chain `base` → `tip` out of `model`.
    pub fn new(model: &RobotModel, base: &str, tip: &str) -> Result<Chain, CbError> {
        let b = model.link(base)?;
        let t = model.link(tip)?;
        if b == t {
            return Err(CbError::NoChain {
                base: base.into(),
                tip: tip.into(),
                reason: "base and tip are the same link".into(),
            });
        }
        let from_root_b = model.joints_from_root(b);
        let from_root_t = model.joints_from_root(t);
        let common = from_root_b.iter().zip(&from_root_t).take_while(|(x, y)| x == y).count();

        let mut joints = Vec::new();
        let mut links = vec![ChainLink {
            name: base.to_string(),
            after: None,
            offset: Iso3::identity(),
            offset_is_identity: true,
        }];
        let mut dofs: Vec<Dof> = Vec::new();
        let mut dof_of_root: HashMap<usize, usize> = HashMap::new();
        let mut pending = Iso3::identity();

        let mut push_joint = |j: usize,
                              sign: f64,
                              fixed_before: Iso3,
                              joints: &mut Vec<ChainJoint>,
                              dofs: &mut Vec<Dof>|
         -> Result<(), CbError> {
            let joint = &model.joints[j];
            let (root, multiplier, offset) = model.mimic_root(joint)?;
            let dof = *dof_of_root.entry(root).or_insert_with(|| {
                let r = &model.joints[root];
                dofs.push(Dof {
                    name: r.name.clone(),
                    kind: r.kind,
                    limits: r.limits,
                });
                dofs.len() - 1
            });
            joints.push(ChainJoint {
                name: joint.name.clone(),
                kind: joint.kind,
                fixed_before,
                axis: joint.axis,
                sign,
                dof,
                multiplier,
                offset,
            });
            Ok(())
        };

        // Climb from the base to the common ancestor: each joint child → parent,
        // base_from_parent = (origin · M(θ))⁻¹ = M(−θ) · origin⁻¹.
        for &j in from_root_b[common..].iter().rev() {
            let joint = &model.joints[j];
            if joint.kind.is_moving() {
                push_joint(j, -1.0, pending, &mut joints, &mut dofs)?;
                pending = joint.origin.inverse();
            } else {
                pending *= joint.origin.inverse();
            }
            links.push(ChainLink {
                name: model.links[joint.parent].name.clone(),
                after: joints.len().checked_sub(1),
                offset: pending,
                offset_is_identity: pending == Iso3::identity(),
            });
        }
        // Descend from the common ancestor to the tip.
        for &j in &from_root_t[common..] {
            let joint = &model.joints[j];
            pending *= joint.origin;
            if joint.kind.is_moving() {
                push_joint(j, 1.0, pending, &mut joints, &mut dofs)?;
                pending = Iso3::identity();
            }
            links.push(ChainLink {
                name: model.links[joint.child].name.clone(),
                after: joints.len().checked_sub(1),
                offset: pending,
                offset_is_identity: pending == Iso3::identity(),
            });
        }
        if dofs.is_empty() {
            return Err(CbError::NoChain {
                base: base.into(),
                tip: tip.into(),
                reason: "the path between them has no moving joint".into(),
            });
        }
        Ok(Chain {
            base: base.to_string(),
            tip: tip.to_string(),
            joints,
            dofs,
            links,
            tip_offset: pending,
        })
    }

    /// Number of chain variables n (independent joints).
    pub fn dof(&self) -> usize {
        self.dofs.len()
    }
    /// The chain variables in order: the columns of the Jacobian.
    pub fn dofs(&self) -> &[Dof] {
        &self.dofs
    }
    /// The moving joints, base to tip.
    pub fn joints(&self) -> &[ChainJoint] {
        &self.joints
    }
    /// The links on the chain, base first, tip last.
    pub fn links(&self) -> &[ChainLink] {
        &self.links
    }
    /// Base link name.
    pub fn base(&self) -> &str {
        &self.base
    }
    /// Tip link name.
    pub fn tip(&self) -> &str {
        &self.tip
    }
    /// `last_joint_frame_from_tip`.
    pub fn tip_offset(&self) -> &Iso3 {
        &self.tip_offset
    }
    /// Index of the chain link called `name`.
    pub fn link_index(&self, name: &str) -> Option<usize> {
        self.links.iter().position(|l| l.name == name)
    }
    /// Lower position limits of the variables.
    pub fn lower_limits(&self) -> impl Iterator<Item = f64> + '_ {
        self.dofs.iter().map(|d| d.limits.lower)
    }
    /// Upper position limits of the variables.
    pub fn upper_limits(&self) -> impl Iterator<Item = f64> + '_ {
        self.dofs.iter().map(|d| d.limits.upper)
    }

    /// A fresh working state at q = 0 (clamped into the limits), FK and Jacobian computed.
    pub fn new_state(&self) -> ChainState {
        let n = self.dof();
        let q = DVector::from_iterator(
            n,
            self.dofs.iter().map(|d| 0.0f64.clamp(d.limits.lower, d.limits.upper)),
        );
        let mut s = ChainState {
            q,
            frames: vec![Iso3::identity(); self.joints.len()],
            link_poses: vec![Iso3::identity(); self.links.len()],
            tip: Iso3::identity(),
            jacobian: Matrix6xX::zeros(n),
        };
        forward_kinematics(self, &mut s);
        jacobian(self, &mut s);
        s
    }

    /// Checks a joint vector for this chain: right length, all finite.
    pub fn check_q(&self, q: &[f64]) -> Result<(), CbError> {
        if q.len() != self.dof() {
            return Err(CbError::DimensionMismatch {
                what: format!("joint values for chain {} -> {}", self.base, self.tip),
                expected: self.dof(),
                got: q.len(),
            });
        }
        check_finite("joint values", q)
    }
}

impl ChainState {
    /// Joint values (chain variables).
    pub fn q(&self) -> &DVector<f64> {
        &self.q
    }
    /// Mutable joint values, unchecked (the control tick's path; see [`ChainState::set_q`]).
    pub fn q_mut(&mut self) -> &mut DVector<f64> {
        &mut self.q
    }
    /// Sets the joint values after checking length and finiteness.
    pub fn set_q(&mut self, chain: &Chain, q: &[f64]) -> Result<(), CbError> {
        chain.check_q(q)?;
        self.q.as_mut_slice().copy_from_slice(q);
        Ok(())
    }
    /// `base_from_tip` from the last [`forward_kinematics`].
    pub fn tip_pose(&self) -> &Iso3 {
        &self.tip
    }
    /// `base_from_link` for every chain link (in [`Chain::links`] order).
    pub fn link_poses(&self) -> &[Iso3] {
        &self.link_poses
    }
    /// `base_from_joint_frame` of each moving joint (after its motion).
    pub fn joint_frames(&self) -> &[Iso3] {
        &self.frames
    }
    /// The tip Jacobian from the last [`jacobian`]: 6×n, rows (v, ω), base-aligned.
    pub fn jacobian(&self) -> &Matrix6xX<f64> {
        &self.jacobian
    }
}

#[inline]
fn joint_motion(j: &ChainJoint, qi: f64) -> Iso3 {
    let theta = j.sign * (j.multiplier * qi + j.offset);
    match j.kind {
        JointKind::Prismatic => Iso3::from_parts(Translation3::from(j.axis.into_inner() * theta), Rot3::identity()),
        _ => Iso3::from_parts(Translation3::identity(), Rot3::from_axis_angle(&j.axis, theta)),
    }
}

/// Forward kinematics: every joint frame, every link pose and the tip pose, in the base frame.
/// Allocation-free.
pub fn forward_kinematics(chain: &Chain, state: &mut ChainState) {
    let mut t = Iso3::identity();
    for (i, j) in chain.joints.iter().enumerate() {
        t = t * j.fixed_before * joint_motion(j, state.q[j.dof]);
        state.frames[i] = t;
    }
    for (pose, link) in state.link_poses.iter_mut().zip(&chain.links) {
        *pose = match link.after {
            Some(a) if link.offset_is_identity => state.frames[a],
            Some(a) => state.frames[a] * link.offset,
            None => link.offset,
        };
    }
    state.tip = match chain.joints.len() {
        0 => chain.tip_offset,
        n => state.frames[n - 1] * chain.tip_offset,
    };
}

/// The tip Jacobian into `state` (6×n, rows v then ω, base-aligned). Call after [`forward_kinematics`].
pub fn jacobian(chain: &Chain, state: &mut ChainState) {
    let p = state.tip.translation.vector;
    let mut jac = std::mem::replace(&mut state.jacobian, Matrix6xX::zeros(0));
    point_jacobian(chain, state, chain.joints.len().checked_sub(1), &p, &mut jac);
    state.jacobian = jac;
}

/// Jacobian of a point rigidly attached after moving joint `after` (`None`: attached to the base), at
/// `point` (base coordinates): 6×n, rows v then ω, base-aligned. Columns of joints past `after` are zero.
/// Used for link frames and contact points. Allocation-free; `out` must be 6×n.
pub fn point_jacobian(chain: &Chain, state: &ChainState, after: Option<usize>, point: &Vec3, out: &mut Matrix6xX<f64>) {
    debug_assert_eq!(out.ncols(), chain.dof());
    out.fill(0.0);
    let Some(last) = after else { return };
    for (j, frame) in chain.joints[..=last].iter().zip(&state.frames) {
        let z = frame.rotation * j.axis.into_inner();
        let s = j.sign * j.multiplier;
        let mut col = out.column_mut(j.dof);
        match j.kind {
            JointKind::Prismatic => {
                col[0] += s * z.x;
                col[1] += s * z.y;
                col[2] += s * z.z;
            }
            _ => {
                let v = z.cross(&(point - frame.translation.vector));
                col[0] += s * v.x;
                col[1] += s * v.y;
                col[2] += s * v.z;
                col[3] += s * z.x;
                col[4] += s * z.y;
                col[5] += s * z.z;
            }
        }
    }
}

/// Jacobian of chain link `link` (index into [`Chain::links`]) at its frame origin.
pub fn link_jacobian(chain: &Chain, state: &ChainState, link: usize, out: &mut Matrix6xX<f64>) {
    let p = state.link_poses[link].translation.vector;
    point_jacobian(chain, state, chain.links[link].after, &p, out);
}

/// Checks the tip Jacobian against central finite differences of FK at `q`; returns the largest absolute
/// difference. Shared test checker (also useful to users validating their own URDFs).
pub fn check_jacobian_matches_finite_difference(chain: &Chain, q: &[f64], h: f64) -> f64 {
    let mut s = chain.new_state();
    s.q.as_mut_slice().copy_from_slice(q);
    forward_kinematics(chain, &mut s);
    jacobian(chain, &mut s);
    let jac = s.jacobian.clone();
    let mut worst: f64 = 0.0;
    for k in 0..chain.dof() {
        let mut sp = s.clone();
        let mut sm = s.clone();
        sp.q[k] += h;
        sm.q[k] -= h;
        forward_kinematics(chain, &mut sp);
        forward_kinematics(chain, &mut sm);
        let dp = (sp.tip.translation.vector - sm.tip.translation.vector) / (2.0 * h);
        // ω from dR Rᵀ: the rotation from minus to plus, as a rotation vector in base axes.
        let dw = (sp.tip.rotation * sm.tip.rotation.inverse()).scaled_axis() / (2.0 * h);
        for r in 0..3 {
            worst = worst.max((jac[(r, k)] - dp[r]).abs());
            worst = worst.max((jac[(r + 3, k)] - dw[r]).abs());
        }
    }
    worst
}
