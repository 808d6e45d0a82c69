//! Controllers C = (σ, ω, φ, τ) (Def. 3.1) and their ranked composition C_k ◁ … ◁ C₁ (3.5–3.7).
//!
//! - [`Sensor`] σ: what the controlled feedback is (joint encoders σ_q, a link's Cartesian pose σ_x by
//!   forward kinematics, fingertip loads σ_f/m).
//! - [`Operator`] ω: the convolution applied to the reference stream f̂ (δ = identity, or a first-order
//!   low-pass like the seed's ω_lp), so that a noisy stereo target (3.8) does not shake the arm.
//! - [`Potential`] φ: the artificial potential (see [`crate::potential`]).
//! - [`MotorUnits`] τ: which degrees of freedom of the chain the controller may move (a synergy).
//!
//! A feedback element f = (σ, ω) is [`FeedbackElement`]. The control law is (3.4),
//! Δu_τ = −κ J† ∂φ/∂f, with J = ∂f/∂u_τ (3.1) and a damped pseudoinverse
//! ([`crate::linalg::DampedLeastSquares`]). κ is a rate (1/s): one tick moves by −κ·dt·J†e.
//!
//! [`ControlStack`] evaluates ranked controllers and composes them by (3.7) generalised to any number of
//! levels: Δu = Σₖ N₁…ₖ₋₁ (−κₖ dt Jₖ† eₖ), where N₁…ₖ₋₁ projects exactly onto the null space of the
//! stacked superior Jacobians ([`crate::linalg::RowSpaceBasis`]). It also tracks each controller's
//! convergence predicate (3.18). One tick allocates nothing.

use nalgebra::{DMatrix, DVector, Matrix6xX};

use crate::chain::{Chain, ChainState, forward_kinematics, jacobian, link_jacobian, point_jacobian};
use crate::error::CbError;
use crate::linalg::{DampedLeastSquares, DlsInfo, DlsSettings, RowSpaceBasis};
use crate::math::{Iso3, Rot3, Vec3};
use crate::potential::{
    Contact, ManipulabilityRows, ManipulabilityWorkspace, force_residual, joint_limit, manipulability,
    manipulability_from_factor, orientation_error, quadratic,
};
use crate::predicate::{Predicate, PredicateSettings, PredicateTracker};

/// σ: the sensor whose signal a controller regulates.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Sensor {
    /// σ_q: the chain's joint encoders (feedback space = configuration space, J_τ = I).
    JointPositions,
    /// σ_x: pose (SE(3)) of a chain link by forward kinematics; `link` indexes [`Chain::links`].
    LinkPose {
        /// Chain link index.
        link: usize,
    },
    /// Position (R³) of a chain link.
    LinkPosition {
        /// Chain link index.
        link: usize,
    },
    /// Orientation (SO(3)) of a chain link.
    LinkOrientation {
        /// Chain link index.
        link: usize,
    },
    /// σ_f/m: contact positions and forces of the links touching a grasped object.
    ContactLoads,
}

/// ω: the operator applied to the reference stream.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Operator {
    /// δ: identity.
    Identity,
    /// First-order low-pass with the given time constant (s).
    LowPass {
        /// Time constant in seconds (> 0).
        time_constant_secs: f64,
    },
}

/// f = (σ, ω): a feedback element.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FeedbackElement {
    /// σ.
    pub sensor: Sensor,
    /// ω.
    pub operator: Operator,
}

/// φ: the artificial potential of a controller.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Potential {
    /// φ_U (3.10): quadratic in the error to a reference; on poses the rotational part is the SO(3)
    /// logarithm scaled by `orientation_weight` (m/rad).
    Quadratic {
        /// Length that one radian of orientation error counts as (m/rad).
        orientation_weight: f64,
    },
    /// φ_M (3.14): negative manipulability of the chain's tip Jacobian.
    Manipulability {
        /// Which rows of J.
        rows: ManipulabilityRows,
    },
    /// Pull towards mid-range of every limited joint.
    JointLimit,
    /// Net-wrench residual of contact forces (§3.1.3.3).
    ForceResidual {
        /// Length that converts moments to forces (m).
        moment_weight: f64,
    },
}

/// τ: the motor units (chain variables) a controller may drive.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct MotorUnits {
    mask: Vec<bool>,
}

impl MotorUnits {
    /// All n variables of a chain.
    pub fn all(n: usize) -> Self {
        MotorUnits { mask: vec![true; n] }
    }
    /// The listed variables of an n-variable chain.
    pub fn subset(indices: &[usize], n: usize) -> Result<Self, CbError> {
        let mut mask = vec![false; n];
        for &i in indices {
            if i >= n {
                return Err(CbError::DimensionMismatch {
                    what: format!("motor unit index {i}"),
                    expected: n,
                    got: i + 1,
                });
            }
            mask[i] = true;
        }
        Ok(MotorUnits { mask })
    }
    /// Whether variable `i` belongs to τ.
    pub fn contains(&self, i: usize) -> bool {
        self.mask.get(i).copied().unwrap_or(false)
    }
    /// Number of chain variables this set was built for.
    pub fn len(&self) -> usize {
        self.mask.len()
    }
    /// True when no variable is included.
    pub fn is_empty(&self) -> bool {
        !self.mask.iter().any(|b| *b)
    }
    /// Indices included.
    pub fn indices(&self) -> impl Iterator<Item = usize> + '_ {
        self.mask.iter().enumerate().filter(|(_, b)| **b).map(|(i, _)| i)
    }
}

/// The reference f̂ of a controller at one tick.
#[derive(Debug, Clone, PartialEq)]
pub enum Reference {
    /// No reference in the feedback stream: the predicate is ∅ and the controller does nothing.
    Undefined,
    /// A position (base frame, m).
    Position(Vec3),
    /// An orientation (base frame).
    Orientation(Rot3),
    /// A pose (base frame).
    Pose(Iso3),
    /// A configuration (chain variables).
    Configuration(DVector<f64>),
}

/// Coordinate frame types of a feedback or effector resource, for the declarative type d(C) (3.22).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FrameType {
    /// Configuration space of the motor units.
    Configuration,
    /// R³ positions.
    Position,
    /// SO(3) orientations.
    Orientation,
    /// SE(3) poses.
    Pose,
    /// Contact forces and moments.
    ContactWrench,
}

/// Potential types, without parameters, for the declarative type.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PotentialType {
    /// φ_U.
    Quadratic,
    /// φ_M.
    Manipulability,
    /// Joint-limit potential.
    JointLimit,
    /// Force residual.
    ForceResidual,
}

/// d(C) = (φ, 𝔽_f, 𝔽_τ) (3.22): what a controller does, independent of the resources it is bound to.
/// Controllers with equal declarative types form the abstract action 𝒟_A (3.23).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub struct DeclarativeType {
    /// φ.
    pub potential: PotentialType,
    /// 𝔽_f.
    pub feedback: FrameType,
    /// 𝔽_τ.
    pub effector: FrameType,
}

/// A controller C = (σ, ω, φ, τ) with its gain κ.
#[derive(Debug, Clone, PartialEq)]
pub struct Controller {
    /// A name for reports.
    pub name: String,
    /// f = (σ, ω).
    pub feedback: FeedbackElement,
    /// φ.
    pub potential: Potential,
    /// τ.
    pub motor_units: MotorUnits,
    /// κ (1/s).
    pub gain: f64,
}

impl Controller {
    /// Builds a controller, checking that σ and φ fit together and κ is a positive rate.
    pub fn new(
        name: impl Into<String>,
        feedback: FeedbackElement,
        potential: Potential,
        motor_units: MotorUnits,
        gain: f64,
    ) -> Result<Self, CbError> {
        let name = name.into();
        if !(gain > 0.0 && gain.is_finite()) {
            return Err(CbError::InvalidParameter {
                name: "gain",
                value: gain,
                expected: "a positive finite rate (1/s)",
            });
        }
        if let Operator::LowPass { time_constant_secs } = feedback.operator
            && !(time_constant_secs > 0.0 && time_constant_secs.is_finite())
        {
            return Err(CbError::InvalidParameter {
                name: "time_constant_secs",
                value: time_constant_secs,
                expected: "a positive finite time (s)",
            });
        }
        let ok = match potential {
            Potential::Quadratic { orientation_weight } => {
                if !(orientation_weight > 0.0 && orientation_weight.is_finite()) {
                    return Err(CbError::InvalidParameter {
                        name: "orientation_weight",
                        value: orientation_weight,
                        expected: "a positive finite length (m/rad)",
                    });
                }
                !matches!(feedback.sensor, Sensor::ContactLoads)
            }
            Potential::Manipulability { .. } | Potential::JointLimit => {
                matches!(feedback.sensor, Sensor::JointPositions)
            }
            Potential::ForceResidual { moment_weight } => {
                if !(moment_weight >= 0.0 && moment_weight.is_finite()) {
                    return Err(CbError::InvalidParameter {
                        name: "moment_weight",
                        value: moment_weight,
                        expected: "a non-negative finite length (m)",
                    });
                }
                matches!(feedback.sensor, Sensor::ContactLoads)
            }
        };
        if !ok {
            return Err(CbError::InvalidModel {
                element: "controller",
                name,
                problem: format!("potential {potential:?} cannot act on sensor {:?}", feedback.sensor),
            });
        }
        Ok(Controller {
            name,
            feedback,
            potential,
            motor_units,
            gain,
        })
    }

    /// Reach: φ_U on the pose of chain link `link`, all motor units, κ = `gain`.
    pub fn reach_pose(chain: &Chain, link: usize, gain: f64) -> Result<Self, CbError> {
        Controller::new(
            "reach",
            FeedbackElement {
                sensor: Sensor::LinkPose { link },
                operator: Operator::Identity,
            },
            Potential::Quadratic {
                orientation_weight: 0.2,
            },
            MotorUnits::all(chain.dof()),
            gain,
        )
    }

    /// Configuration reach (σ_q, δ, φ_U, τ) over all motor units: drives q to a `Reference::Configuration`.
    pub fn configuration(chain: &Chain, gain: f64) -> Result<Self, CbError> {
        Controller::new(
            "reach_q",
            FeedbackElement {
                sensor: Sensor::JointPositions,
                operator: Operator::Identity,
            },
            Potential::Quadratic {
                orientation_weight: 1.0,
            },
            MotorUnits::all(chain.dof()),
            gain,
        )
    }

    /// Position reach (σ_x, δ, φ_U, τ) of chain link `link` to a `Reference::Position`.
    pub fn reach_position(chain: &Chain, link: usize, gain: f64) -> Result<Self, CbError> {
        Controller::new(
            "reach_position",
            FeedbackElement {
                sensor: Sensor::LinkPosition { link },
                operator: Operator::Identity,
            },
            Potential::Quadratic {
                orientation_weight: 1.0,
            },
            MotorUnits::all(chain.dof()),
            gain,
        )
    }

    /// Joint-limit avoidance (σ_q, δ, φ_L, τ) over all motor units.
    pub fn joint_limits(chain: &Chain, gain: f64) -> Result<Self, CbError> {
        Controller::new(
            "joint_limits",
            FeedbackElement {
                sensor: Sensor::JointPositions,
                operator: Operator::Identity,
            },
            Potential::JointLimit,
            MotorUnits::all(chain.dof()),
            gain,
        )
    }

    /// Manipulability M = (σ_q, δ, φ_M, τ) over all motor units.
    pub fn manipulability(chain: &Chain, rows: ManipulabilityRows, gain: f64) -> Result<Self, CbError> {
        Controller::new(
            "manipulability",
            FeedbackElement {
                sensor: Sensor::JointPositions,
                operator: Operator::Identity,
            },
            Potential::Manipulability { rows },
            MotorUnits::all(chain.dof()),
            gain,
        )
    }

    /// d(C) (3.22).
    pub fn declarative_type(&self) -> DeclarativeType {
        let feedback = match self.feedback.sensor {
            Sensor::JointPositions => FrameType::Configuration,
            Sensor::LinkPose { .. } => FrameType::Pose,
            Sensor::LinkPosition { .. } => FrameType::Position,
            Sensor::LinkOrientation { .. } => FrameType::Orientation,
            Sensor::ContactLoads => FrameType::ContactWrench,
        };
        let potential = match self.potential {
            Potential::Quadratic { .. } => PotentialType::Quadratic,
            Potential::Manipulability { .. } => PotentialType::Manipulability,
            Potential::JointLimit => PotentialType::JointLimit,
            Potential::ForceResidual { .. } => PotentialType::ForceResidual,
        };
        DeclarativeType {
            potential,
            feedback,
            effector: FrameType::Configuration,
        }
    }

    /// Rows of this controller's task for a chain (contacts: 3 per contact, up to `max_contacts`).
    pub fn max_rows(&self, chain: &Chain, max_contacts: usize) -> usize {
        match self.feedback.sensor {
            Sensor::JointPositions => chain.dof(),
            Sensor::LinkPose { .. } => 6,
            Sensor::LinkPosition { .. } | Sensor::LinkOrientation { .. } => 3,
            Sensor::ContactLoads => 3 * max_contacts,
        }
    }

    /// The row weights D of a task whose Jacobian is D times the first rows of its link's Jacobian
    /// (pose: 1, 1, 1 and the orientation weight; position: 1, 1, 1); `None` for other tasks.
    fn tip_row_weights(&self) -> Option<[f64; 6]> {
        match (self.feedback.sensor, self.potential) {
            (Sensor::LinkPose { .. }, Potential::Quadratic { orientation_weight: w }) => Some([1.0, 1.0, 1.0, w, w, w]),
            (Sensor::LinkPosition { .. }, Potential::Quadratic { .. }) => Some([1.0; 6]),
            _ => None,
        }
    }

    fn check_against(&self, chain: &Chain) -> Result<(), CbError> {
        if self.motor_units.len() != chain.dof() {
            return Err(CbError::DimensionMismatch {
                what: format!("motor units of controller '{}'", self.name),
                expected: chain.dof(),
                got: self.motor_units.len(),
            });
        }
        match self.feedback.sensor {
            Sensor::LinkPose { link } | Sensor::LinkPosition { link } | Sensor::LinkOrientation { link }
                if link >= chain.links().len() =>
            {
                Err(CbError::DimensionMismatch {
                    what: format!("link index of controller '{}'", self.name),
                    expected: chain.links().len(),
                    got: link + 1,
                })
            }
            _ => Ok(()),
        }
    }

    /// Checks that `reference` is of the kind this controller needs.
    pub fn check_reference(&self, chain: &Chain, reference: &Reference) -> Result<(), CbError> {
        let kind_ok = match (&self.feedback.sensor, reference) {
            (_, Reference::Undefined) => true,
            (Sensor::LinkPose { .. }, Reference::Pose(p)) => p.translation.vector.iter().all(|v| v.is_finite()),
            (Sensor::LinkPosition { .. }, Reference::Position(p)) => p.iter().all(|v| v.is_finite()),
            (Sensor::LinkOrientation { .. }, Reference::Orientation(r)) => r.coords.iter().all(|v| v.is_finite()),
            (Sensor::ContactLoads, Reference::Position(p)) => p.iter().all(|v| v.is_finite()),
            (Sensor::JointPositions, Reference::Configuration(q)) => {
                if q.len() != chain.dof() {
                    return Err(CbError::DimensionMismatch {
                        what: format!("configuration reference of '{}'", self.name),
                        expected: chain.dof(),
                        got: q.len(),
                    });
                }
                q.iter().all(|v| v.is_finite())
            }
            _ => false,
        };
        if kind_ok {
            Ok(())
        } else {
            Err(CbError::InvalidModel {
                element: "controller",
                name: self.name.clone(),
                problem: format!(
                    "reference {reference:?} does not fit sensor {:?} (or is not finite)",
                    self.feedback.sensor
                ),
            })
        }
    }
}

/// Per-controller buffers: filtered reference, gradient e, task Jacobian J (masked by τ).
#[derive(Debug, Clone)]
pub struct TaskBuffers {
    /// Reference after the operator ω.
    pub filtered: Reference,
    /// e = ∂φ/∂f (first `rows` entries valid).
    pub error: DVector<f64>,
    /// J = ∂f/∂u_τ (first `rows` rows valid; columns outside τ are zero).
    pub jacobian: DMatrix<f64>,
    /// Rows valid this tick.
    pub rows: usize,
    /// J is the identity on the motor units (configuration-space potentials): J†e = e on τ.
    pub identity: bool,
    scratch: Matrix6xX<f64>,
    manip: ManipulabilityWorkspace,
}

impl TaskBuffers {
    /// Buffers for `controller` on `chain`.
    pub fn new(controller: &Controller, chain: &Chain, max_contacts: usize) -> Self {
        let rows = controller.max_rows(chain, max_contacts).max(1);
        TaskBuffers {
            filtered: Reference::Undefined,
            error: DVector::zeros(rows),
            jacobian: DMatrix::zeros(rows, chain.dof()),
            rows: 0,
            identity: false,
            scratch: Matrix6xX::zeros(chain.dof()),
            manip: ManipulabilityWorkspace::new(chain),
        }
    }
}

fn filter_reference(op: Operator, raw: &Reference, filtered: &mut Reference, dt: f64) {
    let alpha = match op {
        Operator::Identity => 1.0,
        Operator::LowPass { time_constant_secs } => dt / (time_constant_secs + dt),
    };
    match (raw, &mut *filtered) {
        (Reference::Position(r), Reference::Position(f)) => *f += (r - *f) * alpha,
        (Reference::Orientation(r), Reference::Orientation(f)) => *f = f.slerp(r, alpha),
        (Reference::Pose(r), Reference::Pose(f)) => {
            f.translation.vector += (r.translation.vector - f.translation.vector) * alpha;
            f.rotation = f.rotation.slerp(&r.rotation, alpha);
        }
        (Reference::Configuration(r), Reference::Configuration(f)) if r.len() == f.len() => {
            f.zip_apply(r, |fi, ri| *fi += (ri - *fi) * alpha);
        }
        // Kind changed or reference (re)appeared: start the filter at the raw value.
        _ => filtered.clone_from(raw),
    }
}

/// Evaluates φ, e and J of `controller` at the current chain state (FK and tip Jacobian already computed).
/// Returns `None` when the reference is absent (the predicate's ∅). Allocation-free.
pub fn evaluate(
    controller: &Controller,
    chain: &Chain,
    state: &ChainState,
    contacts: &[Contact],
    reference: &Reference,
    buf: &mut TaskBuffers,
    dt_secs: f64,
) -> Option<f64> {
    evaluate_with(controller, chain, state, contacts, reference, buf, dt_secs, false)
}

/// [`evaluate`]; with `defer`, a manipulability potential only sets up its rows and J = I and returns
/// `Some(NaN)`: the stack computes φ and e later from the first level's factor.
#[allow(clippy::too_many_arguments)]
fn evaluate_with(
    controller: &Controller,
    chain: &Chain,
    state: &ChainState,
    contacts: &[Contact],
    reference: &Reference,
    buf: &mut TaskBuffers,
    dt_secs: f64,
    defer: bool,
) -> Option<f64> {
    filter_reference(controller.feedback.operator, reference, &mut buf.filtered, dt_secs);
    let n = chain.dof();
    buf.identity = matches!(controller.feedback.sensor, Sensor::JointPositions);
    let q = state.q().as_slice();
    let phi = match (controller.feedback.sensor, controller.potential) {
        (Sensor::JointPositions, Potential::Quadratic { .. }) => {
            let Reference::Configuration(r) = &buf.filtered else {
                return none(buf);
            };
            buf.rows = n;
            let phi = quadratic(q, r.as_slice(), &mut buf.error.as_mut_slice()[..n]);
            set_identity(&mut buf.jacobian, n);
            phi
        }
        (Sensor::JointPositions, Potential::JointLimit) => {
            buf.rows = n;
            set_identity(&mut buf.jacobian, n);
            joint_limit(chain, q, &mut buf.error.as_mut_slice()[..n])
        }
        (Sensor::JointPositions, Potential::Manipulability { rows }) => {
            buf.rows = n;
            set_identity(&mut buf.jacobian, n);
            if defer {
                return Some(f64::NAN);
            }
            let g = &mut buf.error.as_mut_slice()[..n];
            let w = manipulability(chain, state, rows, &mut buf.manip, g);
            // e = ∇φ_M = −∇w.
            g.iter_mut().for_each(|v| *v = -*v);
            -w
        }
        (Sensor::LinkPosition { link }, Potential::Quadratic { .. }) => {
            let Reference::Position(r) = &buf.filtered else {
                return none(buf);
            };
            let src = link_jacobian_or_tip(chain, state, link, &mut buf.scratch);
            let y = state.link_poses()[link].translation.vector;
            buf.rows = 3;
            copy_rows(src, 0, &mut buf.jacobian, 0, 3, 1.0);
            quadratic(y.as_slice(), r.as_slice(), &mut buf.error.as_mut_slice()[..3])
        }
        (Sensor::LinkOrientation { link }, Potential::Quadratic { .. }) => {
            let Reference::Orientation(r) = &buf.filtered else {
                return none(buf);
            };
            let src = link_jacobian_or_tip(chain, state, link, &mut buf.scratch);
            let err = orientation_error(&state.link_poses()[link].rotation, r);
            buf.rows = 3;
            copy_rows(src, 3, &mut buf.jacobian, 0, 3, 1.0);
            buf.error.as_mut_slice()[..3].copy_from_slice(err.as_slice());
            0.5 * err.norm_squared()
        }
        (Sensor::LinkPose { link }, Potential::Quadratic { orientation_weight: w }) => {
            let Reference::Pose(r) = &buf.filtered else {
                return none(buf);
            };
            let src = link_jacobian_or_tip(chain, state, link, &mut buf.scratch);
            let pose = &state.link_poses()[link];
            let ep = pose.translation.vector - r.translation.vector;
            let er = orientation_error(&pose.rotation, &r.rotation) * w;
            buf.rows = 6;
            copy_rows(src, 0, &mut buf.jacobian, 0, 3, 1.0);
            copy_rows(src, 3, &mut buf.jacobian, 3, 3, w);
            let e = buf.error.as_mut_slice();
            e[..3].copy_from_slice(ep.as_slice());
            e[3..6].copy_from_slice(er.as_slice());
            0.5 * (ep.norm_squared() + er.norm_squared())
        }
        (Sensor::ContactLoads, Potential::ForceResidual { moment_weight }) => {
            let max = buf.error.len() / 3;
            let contacts = &contacts[..contacts.len().min(max)];
            if contacts.is_empty() {
                return none(buf);
            }
            let center = match &buf.filtered {
                Reference::Position(c) => *c,
                _ => contacts.iter().map(|c| c.point).sum::<Vec3>() / contacts.len() as f64,
            };
            buf.rows = 3 * contacts.len();
            for (i, c) in contacts.iter().enumerate() {
                let after = chain.links().get(c.link).and_then(|l| l.after);
                point_jacobian(chain, state, after, &c.point, &mut buf.scratch);
                copy_rows(&buf.scratch, 0, &mut buf.jacobian, 3 * i, 3, 1.0);
            }
            force_residual(contacts, &center, moment_weight, buf.error.as_mut_slice())
        }
        _ => return none(buf),
    };
    // τ: columns outside the motor units do not move this controller's feedback.
    for k in 0..n {
        if !controller.motor_units.contains(k) {
            buf.jacobian.column_mut(k).rows_mut(0, buf.rows).fill(0.0);
        }
    }
    Some(phi)
}

/// The Jacobian of chain link `link`: the state's tip Jacobian itself when the link's origin is the tip
/// point on the last joint (the same columns [`link_jacobian`] would compute, bit for bit), else computed
/// into `scratch`.
fn link_jacobian_or_tip<'a>(
    chain: &Chain,
    state: &'a ChainState,
    link: usize,
    scratch: &'a mut Matrix6xX<f64>,
) -> &'a Matrix6xX<f64> {
    let on_tip = chain.links()[link].after == chain.joints().len().checked_sub(1)
        && state.link_poses()[link].translation.vector == state.tip_pose().translation.vector
        && state.jacobian().ncols() == scratch.ncols();
    if on_tip {
        state.jacobian()
    } else {
        link_jacobian(chain, state, link, scratch);
        scratch
    }
}

fn none(buf: &mut TaskBuffers) -> Option<f64> {
    buf.rows = 0;
    None
}

fn set_identity(j: &mut DMatrix<f64>, n: usize) {
    for c in 0..n {
        for r in 0..n {
            j[(r, c)] = if r == c { 1.0 } else { 0.0 };
        }
    }
}

fn copy_rows(src: &Matrix6xX<f64>, from: usize, dst: &mut DMatrix<f64>, to: usize, count: usize, scale: f64) {
    for c in 0..src.ncols() {
        for r in 0..count {
            dst[(to + r, c)] = scale * src[(from + r, c)];
        }
    }
}

/// How a [`ControlStack`] computes and limits its step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StackSettings {
    /// Damped least squares.
    pub dls: DlsSettings,
    /// Convergence predicate.
    pub predicate: PredicateSettings,
    /// Largest number of contacts a force controller handles.
    pub max_contacts: usize,
    /// Scale the whole step down (keeping its direction) so no joint exceeds its URDF velocity limit.
    pub respect_velocity_limits: bool,
    /// Joint clamping at position limits (saturation in the null space, Flacco et al. 2012): a joint
    /// whose step would cross its limit is stopped at the limit and its column removed from every
    /// level, and the composition is recomputed so the remaining joints take over the task. Without it
    /// a pseudoinverse law keeps pushing a joint into its stop and the whole motion stalls.
    pub clamp_position_limits: bool,
}

impl Default for StackSettings {
    fn default() -> Self {
        StackSettings {
            dls: DlsSettings::default(),
            predicate: PredicateSettings::default(),
            max_contacts: 3,
            respect_velocity_limits: true,
            clamp_position_limits: true,
        }
    }
}

/// Ranked controllers on one chain — index 0 is the most superior, so `[C₁, C₂, C₃]` is C₃ ◁ C₂ ◁ C₁ —
/// with their buffers, predicates and the composition workspace.
#[derive(Debug, Clone)]
pub struct ControlStack {
    controllers: Vec<Controller>,
    references: Vec<Reference>,
    buffers: Vec<TaskBuffers>,
    trackers: Vec<PredicateTracker>,
    phis: Vec<Option<f64>>,
    dls_info: Vec<DlsInfo>,
    dls: Vec<DampedLeastSquares>,
    basis: RowSpaceBasis,
    v: DVector<f64>,
    du: DVector<f64>,
    /// Δu of each level before projection (for diagnostics and tests).
    level_steps: Vec<DVector<f64>>,
    settings: StackSettings,
    velocity_limits: Vec<f64>,
    lower: Vec<f64>,
    upper: Vec<f64>,
    clamped: Vec<bool>,
    clamp_to: Vec<f64>,
    /// Manipulability levels (below the first) whose φ and e wait for the first level's factor.
    deferred: Vec<bool>,
    /// How many manipulability evaluations took the first level's factor (diagnostics and tests).
    shared_factor_count: u64,
}

impl ControlStack {
    /// Builds the stack for `chain`; checks every controller against the chain.
    pub fn new(chain: &Chain, controllers: Vec<Controller>, settings: StackSettings) -> Result<Self, CbError> {
        settings.predicate.validate()?;
        if !(settings.dls.lambda_max >= 0.0 && settings.dls.sigma_threshold >= 0.0) {
            return Err(CbError::InvalidParameter {
                name: "dls",
                value: settings.dls.lambda_max,
                expected: "non-negative damping and threshold",
            });
        }
        for c in &controllers {
            c.check_against(chain)?;
        }
        let n = chain.dof();
        let trackers = controllers
            .iter()
            .map(|_| PredicateTracker::new(settings.predicate))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(ControlStack {
            references: vec![Reference::Undefined; controllers.len()],
            buffers: controllers
                .iter()
                .map(|c| TaskBuffers::new(c, chain, settings.max_contacts))
                .collect(),
            trackers,
            phis: vec![None; controllers.len()],
            dls_info: vec![DlsInfo::default(); controllers.len()],
            level_steps: vec![DVector::zeros(n); controllers.len()],
            dls: controllers
                .iter()
                .map(|c| DampedLeastSquares::new(c.max_rows(chain, settings.max_contacts).max(1), settings.dls))
                .collect(),
            basis: RowSpaceBasis::new(n),
            v: DVector::zeros(n),
            du: DVector::zeros(n),
            settings,
            velocity_limits: chain.dofs().iter().map(|d| d.limits.velocity).collect(),
            lower: chain.dofs().iter().map(|d| d.limits.lower).collect(),
            upper: chain.dofs().iter().map(|d| d.limits.upper).collect(),
            clamped: vec![false; n],
            clamp_to: vec![0.0; n],
            deferred: vec![false; controllers.len()],
            shared_factor_count: 0,
            controllers,
        })
    }

    /// The controllers, superior first.
    pub fn controllers(&self) -> &[Controller] {
        &self.controllers
    }

    /// Sets the reference of controller `k` (checked).
    pub fn set_reference(&mut self, chain: &Chain, k: usize, reference: Reference) -> Result<(), CbError> {
        let c = self.controllers.get(k).ok_or(CbError::DimensionMismatch {
            what: "controller index".into(),
            expected: self.controllers.len(),
            got: k + 1,
        })?;
        c.check_reference(chain, &reference)?;
        self.references[k] = reference;
        Ok(())
    }

    /// Sets a configuration reference of controller `k` from `q`, reusing the stored vector when the
    /// reference already is a configuration (allocation-free after the first call): for reference
    /// generators that move a configuration goal every tick.
    pub fn set_configuration_reference(&mut self, chain: &Chain, k: usize, q: &[f64]) -> Result<(), CbError> {
        if let Some(Reference::Configuration(current)) = self.references.get_mut(k)
            && current.len() == q.len()
        {
            crate::error::check_finite("configuration reference", q)?;
            current.copy_from_slice(q);
            return Ok(());
        }
        self.set_reference(chain, k, Reference::Configuration(DVector::from_column_slice(q)))
    }

    /// One control tick: FK + Jacobian of `state`, every controller's φ/e/J, the predicates, and the
    /// composed step Δu (returned; also [`ControlStack::delta_u`]). Allocation-free.
    pub fn tick(&mut self, chain: &Chain, state: &mut ChainState, contacts: &[Contact], dt_secs: f64) -> &DVector<f64> {
        forward_kinematics(chain, state);
        jacobian(chain, state);
        for k in 0..self.controllers.len() {
            let c = &self.controllers[k];
            let buf = &mut self.buffers[k];
            // A manipulability level below the first waits for the first level's factor (`compose`).
            let defer = k > 0 && matches!(c.potential, Potential::Manipulability { .. });
            let phi = evaluate_with(c, chain, state, contacts, &self.references[k], buf, dt_secs, defer);
            self.deferred[k] = defer && phi.is_some();
            self.phis[k] = phi;
            if !self.deferred[k] {
                self.trackers[k].update(phi, dt_secs);
            }
        }
        self.clamped.fill(false);
        self.compose(Some((chain, &*state)), dt_secs);
        if self.settings.clamp_position_limits {
            // At most n rounds: each round clamps at least one more joint or stops.
            for _ in 0..self.clamped.len() {
                let mut newly = false;
                for i in 0..self.du.len() {
                    if self.clamped[i] {
                        continue;
                    }
                    let next = state.q()[i] + self.du[i];
                    if next > self.upper[i] || next < self.lower[i] {
                        self.clamped[i] = true;
                        self.clamp_to[i] = (self.upper[i] - state.q()[i])
                            .min(self.du[i])
                            .max(self.lower[i] - state.q()[i]);
                        newly = true;
                    }
                }
                if !newly {
                    break;
                }
                for buf in &mut self.buffers {
                    for (i, &c) in self.clamped.iter().enumerate() {
                        if c {
                            buf.jacobian.column_mut(i).fill(0.0);
                        }
                    }
                }
                self.compose(None, dt_secs);
            }
            for (i, &c) in self.clamped.iter().enumerate() {
                if c {
                    self.du[i] = self.clamp_to[i];
                }
            }
        }
        if self.settings.respect_velocity_limits && dt_secs > 0.0 {
            let mut worst: f64 = 1.0;
            for (d, v) in self.du.iter().zip(&self.velocity_limits) {
                if v.is_finite() {
                    worst = worst.max(d.abs() / (v * dt_secs));
                }
            }
            if worst > 1.0 {
                self.du /= worst;
            }
        }
        &self.du
    }

    /// Δu = Σₖ N₁…ₖ₋₁ (−κₖ dt Jₖ† eₖ) (3.7) from the evaluated buffers.
    ///
    /// `first`: the chain and state of the tick's first composition, which also evaluates the deferred
    /// manipulability levels (`None` when recomposing after clamping).
    fn compose(&mut self, first: Option<(&Chain, &ChainState)>, dt_secs: f64) {
        self.du.fill(0.0);
        self.basis.clear();
        // Rows of the basis that are Q = L⁻¹J of the first level's own undamped factor (0: none).
        let mut factor_level: Option<(usize, usize)> = None;
        for k in 0..self.controllers.len() {
            if let Some((chain, state)) = first
                && self.deferred[k]
            {
                self.evaluate_deferred(k, factor_level, chain, state, dt_secs);
            }
            let buf = &self.buffers[k];
            self.level_steps[k].fill(0.0);
            if self.phis[k].is_none() || buf.rows == 0 {
                continue;
            }
            // −κ dt J† e, then project out what would disturb the superior levels (3.7).
            if buf.identity {
                // J = I restricted to τ (columns zeroed by τ or clamping): J†e = e on those columns.
                for i in 0..self.v.len() {
                    self.v[i] = if buf.jacobian[(i, i)] != 0.0 { buf.error[i] } else { 0.0 };
                }
                self.dls_info[k] = DlsInfo {
                    sigma_min: 1.0,
                    lambda_sq: 0.0,
                };
            } else {
                self.dls_info[k] =
                    self.dls[k].solve_rows(&buf.jacobian, buf.rows, buf.error.as_slice(), self.v.as_mut_slice());
            }
            self.v *= -self.controllers[k].gain * dt_secs;
            self.level_steps[k].copy_from(&self.v);
            self.basis.project_out(&mut self.v);
            self.du += &self.v;
            if k + 1 < self.controllers.len() {
                // The first level's rows come orthonormal out of its own (undamped) factor.
                let from_factor = !buf.identity && self.basis.start_from_factor(&self.dls[k], &buf.jacobian, buf.rows);
                if from_factor {
                    factor_level = Some((k, buf.rows));
                }
                if !from_factor {
                    self.basis.add_first_rows(&buf.jacobian, buf.rows);
                }
            }
        }
    }

    /// φ_M and e = −∇w of the deferred manipulability level `k` (3.14–3.16). When the first level's
    /// rows are the first M rows of the tip Jacobian up to fixed row weights, J₀ = D J (checked entry by
    /// entry: a pose task on the tip, D = diag(1, 1, 1, w, w, w), for M = 6; a position task for M = 3),
    /// and its solve was undamped, its Cholesky factor L₀ = D L of J₀J₀ᵀ and the basis rows
    /// Q = L₀⁻¹J₀ = L⁻¹J already hold what w = Π L₀ᵢᵢ / det D and B = A⁻¹J = D L₀⁻ᵀ Q need
    /// ([`manipulability_from_factor`]); otherwise the potential computes its own.
    fn evaluate_deferred(
        &mut self,
        k: usize,
        factor_level: Option<(usize, usize)>,
        chain: &Chain,
        state: &ChainState,
        dt_secs: f64,
    ) {
        let Potential::Manipulability { rows } = self.controllers[k].potential else {
            return;
        };
        let n = chain.dof();
        let m = rows.count();
        let tip = state.jacobian().as_slice();
        let shared = factor_level.and_then(|(level, rows_used)| {
            let weights = self.controllers[level].tip_row_weights()?;
            let src = &self.buffers[level];
            let stride = src.jacobian.nrows();
            let js = src.jacobian.as_slice();
            let same = rows_used == m
                && src.jacobian.ncols() == n
                && (0..n).all(|c| (0..m).all(|r| js[c * stride + r] == weights[r] * tip[c * 6 + r]));
            if !same {
                return None;
            }
            let (l, inv) = self.dls[level].undamped_factor(m)?;
            Some((l, inv, weights))
        });
        let buf = &mut self.buffers[k];
        let g = &mut buf.error.as_mut_slice()[..n];
        let q_rows = self.basis.rows();
        let w = match (shared, rows) {
            (Some((l, inv, d)), ManipulabilityRows::Full) => {
                manipulability_from_factor::<6>(chain, state, l, inv, &d, q_rows, &mut buf.manip, g)
            }
            (Some((l, inv, d)), ManipulabilityRows::Position) => {
                manipulability_from_factor::<3>(chain, state, l, inv, &d, q_rows, &mut buf.manip, g)
            }
            (None, _) => manipulability(chain, state, rows, &mut buf.manip, g),
        };
        self.shared_factor_count += u64::from(shared.is_some());
        g.iter_mut().for_each(|v| *v = -*v);
        self.phis[k] = Some(-w);
        self.trackers[k].update(self.phis[k], dt_secs);
    }

    /// How many manipulability levels so far reused the first level's Cholesky factor of J Jᵀ instead of
    /// forming their own (a diagnostic: the results are the same to rounding).
    pub fn shared_factor_count(&self) -> u64 {
        self.shared_factor_count
    }

    /// Which joints were clamped at a position limit in the last tick.
    pub fn clamped(&self) -> &[bool] {
        &self.clamped
    }

    /// Δu of the last tick.
    pub fn delta_u(&self) -> &DVector<f64> {
        &self.du
    }
    /// Each level's own step −κ dt Jₖ†eₖ before null-space projection (last tick).
    pub fn level_steps(&self) -> &[DVector<f64>] {
        &self.level_steps
    }
    /// φ of each controller at the last tick (None: no reference).
    pub fn potentials(&self) -> &[Option<f64>] {
        &self.phis
    }
    /// P(Cₖ) of each controller.
    pub fn predicate(&self, k: usize) -> Predicate {
        self.trackers[k].state()
    }
    /// Writes the predicate vector z = [P(C₁)…P(Cₙ)] into `z`.
    pub fn predicates_into(&self, z: &mut [Predicate]) {
        for (zi, t) in z.iter_mut().zip(&self.trackers) {
            *zi = t.state();
        }
    }
    /// The predicate trackers.
    pub fn trackers(&self) -> &[PredicateTracker] {
        &self.trackers
    }
    /// The task buffers (e, J) of the last tick.
    pub fn buffers(&self) -> &[TaskBuffers] {
        &self.buffers
    }
    /// Each level's damped least-squares workspace (holding its last undamped factor).
    pub(crate) fn dls_workspaces(&self) -> &[DampedLeastSquares] {
        &self.dls
    }
    /// Damping used by each level at the last tick.
    pub fn dls_info(&self) -> &[DlsInfo] {
        &self.dls_info
    }
    /// Resets every predicate to `*`.
    pub fn reset_predicates(&mut self) {
        self.trackers.iter_mut().for_each(PredicateTracker::reset);
    }
    /// The settings.
    pub fn settings(&self) -> &StackSettings {
        &self.settings
    }
}
