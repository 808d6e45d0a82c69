//! `pbd.Robot` and `pbd.Chain`: URDF models, forward kinematics, geometric Jacobians and inverse
//! kinematics on any serial chain, with numpy arrays in and out.

use std::path::PathBuf;
use std::sync::Arc;

use numpy::ndarray::{Array1, Array2};
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pbd::control_basis::{self as cb, IkSettings, JointKind, RobotModel};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::arrays::{check_finite, isometry, vector};
use crate::errors::{IntoPy, value_error};

/// A robot model loaded from a URDF.
///
/// `Robot.from_urdf(None)` is Dexter, built into pbd (two 7-DOF WAM arms with BarrettHands and a
/// 4-DOF stereo head); `Robot.from_urdf("wam7.urdf")` any URDF file. Cut serial chains out of it
/// with [`Robot::chain`].
#[pyclass(module = "pbd", frozen)]
#[derive(Debug, Clone)]
pub struct Robot {
    model: Arc<RobotModel>,
    source: String,
}

#[pymethods]
impl Robot {
    /// Loads a URDF file, or the built-in Dexter model when `path` is None.
    ///
    /// Raises PbdFileError when the file cannot be read and PbdFormatError when it is not a valid
    /// URDF model.
    #[staticmethod]
    #[pyo3(signature = (path=None))]
    fn from_urdf(py: Python<'_>, path: Option<PathBuf>) -> PyResult<Robot> {
        let loaded = py.detach(|| pbd::robot::load_model(path.as_deref())).py_err()?;
        Ok(Robot {
            source: loaded.source.label(),
            model: Arc::new(loaded.model),
        })
    }

    /// Loads a robot from URDF text.
    #[staticmethod]
    fn from_urdf_string(text: &str) -> PyResult<Robot> {
        let model = RobotModel::from_urdf_str(text).py_err()?;
        Ok(Robot {
            model: Arc::new(model),
            source: "string".into(),
        })
    }

    /// The robot's name (`<robot name=...>`).
    #[getter]
    fn name(&self) -> String {
        self.model.name.clone()
    }

    /// Where the model came from: `built-in:dexter` or the path.
    #[getter]
    fn source(&self) -> String {
        self.source.clone()
    }

    /// The names of every link.
    #[getter]
    fn links(&self) -> Vec<String> {
        self.model.links.iter().map(|l| l.name.clone()).collect()
    }

    /// The names of the independent moving joints (neither fixed nor mimic).
    #[getter]
    fn dofs(&self) -> Vec<String> {
        self.model.actuated_joints().map(|j| j.name.clone()).collect()
    }

    /// The model summary of `pbd robot info` as a dict (degrees of freedom, mimic couplings, named
    /// chains, leaf chains).
    fn info(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let loaded = pbd::robot::LoadedModel {
            source: if self.source == "built-in:dexter" {
                pbd::robot::ModelSource::BuiltinDexter
            } else {
                pbd::robot::ModelSource::File(PathBuf::from(&self.source))
            },
            model: (*self.model).clone(),
        };
        let summary = pbd::robot::info::RobotSummary::new(&loaded).py_err()?;
        crate::json::to_python(py, &summary)
    }

    /// The serial chain from link `base` to link `tip` (any two links of the tree).
    ///
    /// Raises PbdLookupError for an unknown link (the message suggests close names).
    fn chain(&self, base: &str, tip: &str) -> PyResult<Chain> {
        let chain = cb::Chain::new(&self.model, base, tip).py_err()?;
        let state = chain.new_state();
        Ok(Chain { chain, state })
    }

    fn __repr__(&self) -> String {
        format!(
            "Robot(name={:?}, source={:?}, links={}, joints={}, dofs={})",
            self.model.name,
            self.source,
            self.model.links.len(),
            self.model.joints.len(),
            self.model.actuated_joints().count()
        )
    }
}

/// A serial chain `base → tip` of a robot: forward kinematics, the geometric Jacobian and inverse
/// kinematics.
///
/// `q` has one entry per chain variable, base to tip (radians; metres for prismatic joints); a joint
/// that mimics another is not a variable. Poses are `base_from_tip` 4×4 homogeneous matrices; the
/// Jacobian is 6×n with rows (vx, vy, vz, ωx, ωy, ωz) in base axes (Pinocchio's
/// `LOCAL_WORLD_ALIGNED` with the base as world), the J of Δx = J Δq in the control law (3.4).
#[pyclass(module = "pbd")]
#[derive(Debug)]
pub struct Chain {
    chain: cb::Chain,
    state: cb::ChainState,
}

impl Chain {
    fn set_q(&mut self, q: &Bound<'_, PyAny>) -> PyResult<()> {
        let q = vector(q, "q")?;
        let n = self.chain.dof();
        if q.len() != n {
            let names: Vec<&str> = self.chain.dofs().iter().map(|d| d.name.as_str()).collect();
            return Err(value_error(format!(
                "q has {} values, but the chain {} -> {} has {n} joint variables, in this order: {}",
                q.len(),
                self.chain.base(),
                self.chain.tip(),
                names.join(", ")
            )));
        }
        check_finite(&q, "q")?;
        self.state.set_q(&self.chain, &q).py_err()
    }

    fn pose_array<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let m = self.state.tip_pose().to_homogeneous();
        let mut out = Array2::<f64>::zeros((4, 4));
        for i in 0..4 {
            for j in 0..4 {
                out[(i, j)] = m[(i, j)];
            }
        }
        out.into_pyarray(py)
    }

    fn jacobian_array<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let jac = self.state.jacobian();
        let n = self.chain.dof();
        let mut out = Array2::<f64>::zeros((6, n));
        for r in 0..6 {
            for c in 0..n {
                out[(r, c)] = jac[(r, c)];
            }
        }
        out.into_pyarray(py)
    }
}

/// `(pose 4×4, Jacobian 6×n)`.
type PoseJacobian<'py> = (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray2<f64>>);

#[pymethods]
impl Chain {
    /// Number of chain variables n.
    #[getter]
    fn dof(&self) -> usize {
        self.chain.dof()
    }

    /// Base link.
    #[getter]
    fn base(&self) -> String {
        self.chain.base().to_string()
    }

    /// Tip link.
    #[getter]
    fn tip(&self) -> String {
        self.chain.tip().to_string()
    }

    /// The chain variables (joint names) in the order of `q` and of the Jacobian's columns.
    #[getter]
    fn joint_names(&self) -> Vec<String> {
        self.chain.dofs().iter().map(|d| d.name.clone()).collect()
    }

    /// Joint kinds of the chain variables: `revolute`, `continuous` or `prismatic`.
    #[getter]
    fn joint_kinds(&self) -> Vec<&'static str> {
        self.chain
            .dofs()
            .iter()
            .map(|d| match d.kind {
                JointKind::Revolute => "revolute",
                JointKind::Continuous => "continuous",
                JointKind::Prismatic => "prismatic",
                JointKind::Fixed => "fixed",
            })
            .collect()
    }

    /// Lower joint limits (n,) (`-inf` where unlimited).
    #[getter]
    fn lower<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        Array1::from_iter(self.chain.lower_limits()).into_pyarray(py)
    }

    /// Upper joint limits (n,) (`inf` where unlimited).
    #[getter]
    fn upper<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        Array1::from_iter(self.chain.upper_limits()).into_pyarray(py)
    }

    /// Forward kinematics: the 4×4 pose `base_from_tip` at `q` (n,).
    ///
    /// Raises PbdValueError when `q` has the wrong length or a non-finite entry.
    fn fk<'py>(&mut self, py: Python<'py>, q: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        self.set_q(q)?;
        cb::forward_kinematics(&self.chain, &mut self.state);
        Ok(self.pose_array(py))
    }

    /// The geometric Jacobian at `q`: 6×n, rows (vx, vy, vz, ωx, ωy, ωz) of the tip origin in base axes,
    /// the J of the control law Δu = −κ J† Δφ (3.4).
    fn jacobian<'py>(&mut self, py: Python<'py>, q: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        self.set_q(q)?;
        cb::forward_kinematics(&self.chain, &mut self.state);
        cb::jacobian(&self.chain, &mut self.state);
        Ok(self.jacobian_array(py))
    }

    /// Both at once: `(pose 4×4, jacobian 6×n)` at `q`, one traversal of the chain.
    fn fk_jacobian<'py>(&mut self, py: Python<'py>, q: &Bound<'py, PyAny>) -> PyResult<PoseJacobian<'py>> {
        self.set_q(q)?;
        cb::forward_kinematics(&self.chain, &mut self.state);
        cb::jacobian(&self.chain, &mut self.state);
        Ok((self.pose_array(py), self.jacobian_array(py)))
    }

    /// Inverse kinematics: `q` inside the joint limits with `fk(q) = target` (4×4), by the reach law
    /// (3.4) iterated on a virtual chain with joint clamping and seeded random restarts.
    ///
    /// Returns a dict: `q` (n,), `converged`, `position_error` (m), `orientation_error` (rad),
    /// `attempts`. `q0` is the start (default: all zeros clamped into the limits).
    #[pyo3(signature = (target, q0=None, *, position_tolerance=1e-5, orientation_tolerance=1e-4,
                        max_iterations=300, restarts=100, seed=0))]
    #[allow(clippy::too_many_arguments)]
    fn ik<'py>(
        &self,
        py: Python<'py>,
        target: &Bound<'py, PyAny>,
        q0: Option<&Bound<'py, PyAny>>,
        position_tolerance: f64,
        orientation_tolerance: f64,
        max_iterations: usize,
        restarts: usize,
        seed: u64,
    ) -> PyResult<Bound<'py, PyDict>> {
        let target = isometry(target)?;
        let n = self.chain.dof();
        let q0 = match q0 {
            Some(q) => {
                let v = vector(q, "q0")?;
                if v.len() != n {
                    return Err(value_error(format!("q0: expected {n} values, got {}", v.len())));
                }
                check_finite(&v, "q0")?;
                v
            }
            None => self
                .chain
                .dofs()
                .iter()
                .map(|d| 0.0f64.clamp(d.limits.lower, d.limits.upper))
                .collect(),
        };
        for (name, v) in [
            ("position_tolerance", position_tolerance),
            ("orientation_tolerance", orientation_tolerance),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(value_error(format!("{name} must be a positive number, got {v}")));
            }
        }
        let settings = IkSettings {
            position_tolerance,
            orientation_tolerance,
            max_iterations,
            restarts,
            seed,
        };
        let chain = &self.chain;
        let sol = py
            .detach(|| cb::inverse_kinematics(chain, &target, &q0, &settings))
            .py_err()?;
        let d = PyDict::new(py);
        d.set_item("q", Array1::from_iter(sol.q.iter().copied()).into_pyarray(py))?;
        d.set_item("converged", sol.converged)?;
        d.set_item("position_error", sol.position_error)?;
        d.set_item("orientation_error", sol.orientation_error)?;
        d.set_item("attempts", sol.attempts)?;
        Ok(d)
    }

    /// The controller stack Reach ◁ Manipulability on this chain (a `ControlStack`): `pose=False`
    /// reaches a position with positional manipulability, `pose=True` a full pose; κ gains in 1/s.
    #[pyo3(signature = (*, pose=false, reach_gain=4.0, manipulability_gain=2.0))]
    fn control_stack(
        &self,
        pose: bool,
        reach_gain: f64,
        manipulability_gain: f64,
    ) -> PyResult<crate::control::ControlStack> {
        crate::control::ControlStack::create(self.chain.clone(), pose, reach_gain, manipulability_gain)
    }

    fn __repr__(&self) -> String {
        format!(
            "Chain({} -> {}, dof={}, joints=[{}])",
            self.chain.base(),
            self.chain.tip(),
            self.chain.dof(),
            self.chain
                .dofs()
                .iter()
                .map(|d| d.name.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        )
    }

    fn __len__(&self) -> usize {
        self.chain.dof()
    }
}
