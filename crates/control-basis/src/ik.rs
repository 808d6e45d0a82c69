//! Inverse kinematics by the control law itself: the reach controller iterated on a virtual copy of the
//! chain, with joint clamping and seeded random restarts.
//!
//! A Cartesian reach controller is a local descent: from an arbitrary start, a joint stop can block the
//! straight-line path to a reachable pose and the controller becomes quiescent short of it (a local
//! minimum of φ_U under joint limits). Solving the pose for a configuration first, then servoing in
//! configuration space — a straight line in the joint box never leaves the box — reaches every reachable
//! target. [`inverse_kinematics`] finds that configuration; the restarts make it global in practice and
//! deterministic for a given seed.

use nalgebra::DVector;

use crate::chain::Chain;
use crate::controller::{ControlStack, Controller, Reference, StackSettings};
use crate::error::{CbError, check_finite};
use crate::math::Iso3;
use crate::predicate::PredicateSettings;

/// Settings of [`inverse_kinematics`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IkSettings {
    /// Accept when the tip is within this distance of the target (m).
    pub position_tolerance: f64,
    /// … and within this angle (rad).
    pub orientation_tolerance: f64,
    /// Iterations per attempt.
    pub max_iterations: usize,
    /// Random restarts after the first attempt from the given start.
    pub restarts: usize,
    /// Seed of the restarts.
    pub seed: u64,
}

impl Default for IkSettings {
    fn default() -> Self {
        IkSettings {
            position_tolerance: 1e-5,
            orientation_tolerance: 1e-4,
            max_iterations: 300,
            restarts: 100,
            seed: 0,
        }
    }
}

/// Result of [`inverse_kinematics`]: the best configuration found, whether it meets the tolerances.
#[derive(Debug, Clone, PartialEq)]
pub struct IkSolution {
    /// Configuration (within the joint limits).
    pub q: DVector<f64>,
    /// Whether both tolerances are met.
    pub converged: bool,
    /// Remaining position error (m).
    pub position_error: f64,
    /// Remaining orientation error (rad).
    pub orientation_error: f64,
    /// Attempts used (1 = the given start sufficed).
    pub attempts: usize,
}

/// Finds q within the joint limits with `base_from_tip(q) = target`, starting from `q_start`.
pub fn inverse_kinematics(
    chain: &Chain,
    target: &Iso3,
    q_start: &[f64],
    settings: &IkSettings,
) -> Result<IkSolution, CbError> {
    chain.check_q(q_start)?;
    check_finite("IK target translation", target.translation.vector.as_slice())?;
    check_finite("IK target rotation", target.rotation.coords.as_slice())?;
    let n = chain.dof();
    let reach = Controller::reach_pose(chain, chain.links().len() - 1, 1.0)?;
    // Light damping: IK moves a virtual chain, so it can afford large steps near singular solutions,
    // where the stronger damping of the real control tick would make final convergence crawl.
    let stack_settings = StackSettings {
        dls: crate::linalg::DlsSettings {
            lambda_max: 2e-3,
            sigma_threshold: 1e-2,
        },
        respect_velocity_limits: false,
        clamp_position_limits: true,
        predicate: PredicateSettings::default(),
        ..StackSettings::default()
    };
    let mut stack = ControlStack::new(chain, vec![reach], stack_settings)?;
    stack.set_reference(chain, 0, Reference::Pose(*target))?;
    let mut state = chain.new_state();
    let mut rng = settings.seed ^ 0x5DEE_CE66_D1CE_4E5B;
    let mut best: Option<IkSolution> = None;
    for attempt in 0..=settings.restarts {
        {
            let q = state.q_mut();
            if attempt == 0 {
                q.as_mut_slice().copy_from_slice(q_start);
            } else {
                for (qi, d) in q.iter_mut().zip(chain.dofs()) {
                    let (lo, hi) = (
                        d.limits.lower.max(-std::f64::consts::PI),
                        d.limits.upper.min(std::f64::consts::PI),
                    );
                    *qi = lo + (hi - lo) * uniform(&mut rng);
                }
            }
            for (qi, d) in q.iter_mut().zip(chain.dofs()) {
                *qi = qi.clamp(d.limits.lower, d.limits.upper);
            }
        }
        for _ in 0..settings.max_iterations {
            let du = stack.tick(chain, &mut state, &[], 1.0);
            // Newton steps can overshoot far from the solution: cap the largest joint step.
            let big = du.amax();
            let scale = if big > 0.5 { 0.5 / big } else { 1.0 };
            let du = du * scale;
            let (pe, re) = errors(&state, target);
            if pe <= settings.position_tolerance && re <= settings.orientation_tolerance {
                break;
            }
            let q = state.q_mut();
            *q += du;
            for (qi, d) in q.iter_mut().zip(chain.dofs()) {
                *qi = qi.clamp(d.limits.lower, d.limits.upper);
            }
        }
        crate::chain::forward_kinematics(chain, &mut state);
        let (pe, re) = errors(&state, target);
        let sol = IkSolution {
            q: state.q().clone(),
            converged: pe <= settings.position_tolerance && re <= settings.orientation_tolerance,
            position_error: pe,
            orientation_error: re,
            attempts: attempt + 1,
        };
        let better = match &best {
            None => true,
            Some(b) => pe + 0.2 * re < b.position_error + 0.2 * b.orientation_error,
        };
        if better {
            best = Some(sol);
        }
        if best.as_ref().is_some_and(|b| b.converged) {
            break;
        }
    }
    let mut best = best.unwrap_or_else(|| IkSolution {
        q: DVector::zeros(n),
        converged: false,
        position_error: f64::INFINITY,
        orientation_error: f64::INFINITY,
        attempts: 0,
    });
    best.attempts = best.attempts.max(1);
    Ok(best)
}

fn errors(state: &crate::chain::ChainState, target: &Iso3) -> (f64, f64) {
    let t = state.tip_pose();
    (
        (t.translation.vector - target.translation.vector).norm(),
        (t.rotation * target.rotation.inverse()).angle(),
    )
}

fn uniform(state: &mut u64) -> f64 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 53) as f64
}
