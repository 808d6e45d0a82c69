//! `pbd.ControlStack`: controllers of the control basis composed by null-space projection, the
//! superior first (Reach ◁ Manipulability, (3.5)–(3.7)), ticked on a plant.

use numpy::ndarray::{Array1, Array2};
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pbd::control_basis::{
    self as cb, ControlStack as Stack, Controller, KinematicPlant, ManipulabilityRows, Plant, Predicate, Reference,
    StackSettings,
};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::arrays::vector;
use crate::errors::{IntoPy, value_error};

fn predicate_name(p: Predicate) -> String {
    serde_json::to_value(p)
        .ok()
        .and_then(|v| v.as_str().map(String::from))
        .unwrap_or_else(|| format!("{p:?}"))
}

/// Reach ◁ Manipulability on a chain: φ_U (3.10)–(3.13) on the tip's position (or pose) superior,
/// φ_M (3.14)–(3.16) in its null space; one tick is Δu = −κ J† Δφ (3.4) per level, each level
/// projected onto the exact null space of the levels above it; joints stop at their limits.
///
/// Make one with `Chain.control_stack(...)`. `tick(q, dt)` gives Δu for your own plant (send
/// u = q + Δu to the motor units); `run(q0, ...)` steps it on a kinematic plant and returns the
/// trajectory.
#[pyclass(module = "pbd")]
#[derive(Debug)]
pub struct ControlStack {
    chain: cb::Chain,
    state: cb::ChainState,
    stack: Stack,
    pose: bool,
}

impl ControlStack {
    /// Builds the stack on `chain`.
    pub fn create(chain: cb::Chain, pose: bool, reach_gain: f64, manipulability_gain: f64) -> PyResult<Self> {
        let tip = chain.links().len() - 1;
        let reach = if pose {
            Controller::reach_pose(&chain, tip, reach_gain)
        } else {
            Controller::reach_position(&chain, tip, reach_gain)
        }
        .py_err()?;
        let rows = if pose {
            ManipulabilityRows::Full
        } else {
            ManipulabilityRows::Position
        };
        let manip = Controller::manipulability(&chain, rows, manipulability_gain).py_err()?;
        let stack = Stack::new(&chain, vec![reach, manip], StackSettings::default()).py_err()?;
        let state = chain.new_state();
        Ok(ControlStack {
            chain,
            state,
            stack,
            pose,
        })
    }

    fn q_of(&self, q: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<f64>> {
        let v = vector(q, what)?;
        if v.len() != self.chain.dof() {
            return Err(value_error(format!(
                "{what}: expected {} values, got {}",
                self.chain.dof(),
                v.len()
            )));
        }
        if let Some(i) = v.iter().position(|x| !x.is_finite()) {
            return Err(value_error(format!("{what}: entry {i} is not a finite number")));
        }
        Ok(v)
    }
}

#[pymethods]
impl ControlStack {
    /// Sets the Reach reference: a position (3,) in the chain's base frame, or with a pose stack a
    /// 4×4 pose.
    fn set_target(&mut self, target: &Bound<'_, PyAny>) -> PyResult<()> {
        let reference = if self.pose {
            Reference::Pose(crate::arrays::isometry(target)?)
        } else {
            let v = vector(target, "target")?;
            if v.len() != 3 || v.iter().any(|x| !x.is_finite()) {
                return Err(value_error(
                    "target: expected 3 finite numbers (a position in the base frame)",
                ));
            }
            Reference::Position(cb::math::Vec3::new(v[0], v[1], v[2]))
        };
        self.stack.set_reference(&self.chain, 0, reference).py_err()
    }

    /// One control tick at configuration `q` with period `dt` (s): Δu (n,).
    fn tick<'py>(&mut self, py: Python<'py>, q: &Bound<'py, PyAny>, dt: f64) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let q = self.q_of(q, "q")?;
        if !(dt.is_finite() && dt > 0.0) {
            return Err(value_error(format!("dt must be a positive number, got {dt}")));
        }
        self.state.set_q(&self.chain, &q).py_err()?;
        let du = self.stack.tick(&self.chain, &mut self.state, &[], dt);
        Ok(Array1::from_iter(du.iter().copied()).into_pyarray(py))
    }

    /// Runs the stack on a kinematic plant (the motor units track u = q + Δu exactly) from `q0` for
    /// `steps` ticks of `dt`. Returns a dict: `q` ((steps+1)×n trajectory), `tip` ((steps+1)×3 tip
    /// positions), `predicates` (the final [P(Reach), P(Manipulability)], (3.18): `*`, `∅`, `0`, `1`),
    /// `potentials` (final φ per level), `converged_at` (s, when Reach first became `1`, or None).
    #[pyo3(signature = (q0, *, dt=0.01, steps=500))]
    fn run<'py>(
        &mut self,
        py: Python<'py>,
        q0: &Bound<'py, PyAny>,
        dt: f64,
        steps: usize,
    ) -> PyResult<Bound<'py, PyDict>> {
        let q0 = self.q_of(q0, "q0")?;
        if !(dt.is_finite() && dt > 0.0) {
            return Err(value_error(format!("dt must be a positive number, got {dt}")));
        }
        let n = self.chain.dof();
        let (chain, state, stack) = (&self.chain, &mut self.state, &mut self.stack);
        let out = py.detach(|| -> Result<_, cb::CbError> {
            stack.reset_predicates();
            let mut plant = KinematicPlant::for_chain(chain, &q0)?;
            let mut q = vec![0.0; n];
            let mut traj = Vec::with_capacity((steps + 1) * n);
            let mut tips = Vec::with_capacity((steps + 1) * 3);
            let mut converged_at = None;
            for k in 0..=steps {
                plant.read_joint_positions(&mut q);
                state.set_q(chain, &q)?;
                cb::forward_kinematics(chain, state);
                traj.extend_from_slice(&q);
                let p = state.tip_pose().translation.vector;
                tips.extend_from_slice(&[p.x, p.y, p.z]);
                if k == steps {
                    break;
                }
                let du = stack.tick(chain, state, &[], dt);
                let u: Vec<f64> = q.iter().zip(du.iter()).map(|(a, b)| a + b).collect();
                plant.command(&u)?;
                plant.step(dt)?;
                if converged_at.is_none() && stack.predicate(0) == Predicate::Converged {
                    converged_at = Some(plant.time_secs());
                }
            }
            Ok((traj, tips, converged_at))
        });
        let (traj, tips, converged_at) = out.py_err()?;
        let d = PyDict::new(py);
        let traj = Array2::from_shape_vec((steps + 1, n), traj).map_err(|e| value_error(e.to_string()))?;
        let tips = Array2::from_shape_vec((steps + 1, 3), tips).map_err(|e| value_error(e.to_string()))?;
        d.set_item("q", traj.into_pyarray(py))?;
        d.set_item("tip", tips.into_pyarray(py))?;
        d.set_item("predicates", self.predicates())?;
        d.set_item("potentials", self.potentials())?;
        d.set_item("converged_at", converged_at)?;
        Ok(d)
    }

    /// The convergence predicates [P(Reach), P(Manipulability)] (3.18): `*`, `∅`, `0` or `1`.
    #[getter]
    fn predicates(&self) -> Vec<String> {
        let mut z = [Predicate::Unknown; 2];
        self.stack.predicates_into(&mut z);
        z.iter().map(|p| predicate_name(*p)).collect()
    }

    /// The potentials φ of the levels at the last tick (None before the first).
    #[getter]
    fn potentials(&self) -> Vec<Option<f64>> {
        self.stack.potentials().to_vec()
    }

    /// Per level, the step the stack reports for it at the last tick (`ControlStack::level_steps`),
    /// levels × n; the total Δu moves the superior task exactly as its own step does.
    #[getter]
    fn level_steps<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let steps = self.stack.level_steps();
        let n = self.chain.dof();
        let flat: Vec<f64> = steps.iter().flat_map(|s| s.iter().copied()).collect();
        Ok(Array2::from_shape_vec((steps.len(), n), flat)
            .map_err(|e| value_error(e.to_string()))?
            .into_pyarray(py))
    }

    fn __repr__(&self) -> String {
        format!(
            "ControlStack(Reach[{}] ◁ Manipulability on {} -> {}, predicates={:?})",
            if self.pose { "pose" } else { "position" },
            self.chain.base(),
            self.chain.tip(),
            self.predicates()
        )
    }
}
