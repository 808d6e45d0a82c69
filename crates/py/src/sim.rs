//! `pbd.Sim`: the simulated Dexter in a scene — step the physics, read and command the joints, render
//! the cameras into `uint8` arrays, read the fingertip wrenches; and `pbd.pick_place` (one autonomous
//! pick-and-place, `pbd sim pick-place`).

use numpy::ndarray::{Array1, Array2, Array3};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArray3};
use pbd::control_basis::Image;
use pbd::dexter_sim::hardware::{CAMERAS, SimCameras, park_robot};
use pbd::dexter_sim::physics::{DexterSim, SimSettings};
use pbd::dexter_sim::pick_place::PickPlaceRequest;
use pbd::dexter_sim::scene::{BUILTIN_HOUSEHOLD, Catalog, Scene, SceneSpec};
use pbd::dexter_sim::snapshot::FingertipWrench;
use pbd::sim::ArmChoice;
use pbd::skills::SkillSession;
use pyo3::prelude::*;

use crate::arrays::vector;
use crate::errors::{IntoPy, Kind, error, value_error};
use crate::json::{from_python, to_python};
use crate::runner;

fn arm_choice(arm: &str) -> PyResult<ArmChoice> {
    match arm {
        "auto" => Ok(ArmChoice::Auto),
        "left" => Ok(ArmChoice::Left),
        "right" => Ok(ArmChoice::Right),
        other => Err(value_error(format!(
            "arm: expected \"auto\", \"left\" or \"right\", got {other:?}"
        ))),
    }
}

fn iso_array<'py>(py: Python<'py>, pose: &pbd::control_basis::math::Iso3) -> Bound<'py, PyArray2<f64>> {
    let m = pose.to_homogeneous();
    Array2::from_shape_fn((4, 4), |(i, j)| m[(i, j)]).into_pyarray(py)
}

/// The simulated Dexter in a scene (Rapier physics at 1 kHz, PD motor units, fingertip F/T sensing,
/// ray-cast cameras with pixel noise).
///
/// `Sim(scene=None, seed=0, *, catalog=None)`: `scene` is a built-in name (`pick-place`, `sorting`,
/// `sorting-new`, `sorting-demo`; None = `pick-place`), a TOML file, a dict with the fields of the
/// scene TOML (see `Sim(...).scene_spec`; `catalog=` a dict or file then), or TOML text via
/// `Sim.from_toml(text)`. The
/// robot starts parked above the table. The same seed gives the same run.
#[pyclass(module = "pbd", unsendable)]
#[derive(Debug)]
pub struct Sim {
    scene: Scene,
    sim: DexterSim,
    cameras: SimCameras,
    image: Image,
    seed: u64,
    skills: SkillSession,
}

impl Sim {
    fn build(scene: Scene, seed: u64) -> PyResult<Sim> {
        let mut sim = DexterSim::new(&scene, SimSettings::default()).py_err()?;
        park_robot(&mut sim, scene.spec.table.height).py_err()?;
        let cameras = SimCameras::new(&sim, &scene, seed).py_err()?;
        Ok(Sim {
            scene,
            sim,
            cameras,
            image: Image::new(1, 1),
            seed,
            skills: SkillSession::new(seed),
        })
    }

    fn camera_index(&self, camera: &Bound<'_, PyAny>) -> PyResult<usize> {
        if let Ok(k) = camera.extract::<usize>() {
            if k < CAMERAS.len() {
                return Ok(k);
            }
            return Err(value_error(format!(
                "camera index {k} out of range 0..{}",
                CAMERAS.len()
            )));
        }
        let name: String = camera.extract()?;
        CAMERAS.iter().position(|(n, _)| *n == name).ok_or_else(|| {
            error(
                Kind::Lookup,
                format!(
                    "unknown camera `{name}`; known: {}",
                    CAMERAS.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", ")
                ),
            )
        })
    }
}

#[pymethods]
impl Sim {
    #[new]
    #[pyo3(signature = (scene=None, seed=0, *, catalog=None))]
    fn new(
        py: Python<'_>,
        scene: Option<&Bound<'_, PyAny>>,
        seed: u64,
        catalog: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Sim> {
        let Some(scene) = scene else {
            return Sim::build(Scene::builtin("pick-place").py_err()?, seed);
        };
        if scene.is_instance_of::<pyo3::types::PyDict>() {
            // A scene as data (the fields of the scene TOML); the catalog as data, a file, or the
            // scene's own `catalog` entry (`builtin:household` or a path from the current directory).
            let spec: SceneSpec = from_python(scene, "scene")?;
            let catalog = match catalog {
                Some(c) if c.is_instance_of::<pyo3::types::PyDict>() => from_python::<Catalog>(c, "catalog")?,
                Some(c) => Catalog::load(c.extract::<std::path::PathBuf>()?).py_err()?,
                None if spec.catalog == BUILTIN_HOUSEHOLD => Catalog::builtin_household().py_err()?,
                None => Catalog::load(&spec.catalog).py_err()?,
            };
            let scene = Scene::new(spec, catalog, "dict").py_err()?;
            return Sim::build(scene, seed);
        }
        if catalog.is_some() {
            return Err(value_error("catalog= goes with a scene given as a dict"));
        }
        let name: String = scene
            .extract()
            .map_err(|_| value_error("scene: expected a built-in name, a TOML path or a dict"))?;
        let scene = py.detach(|| Scene::open(&name)).py_err()?;
        Sim::build(scene, seed)
    }

    /// The scene as data (the fields of the scene TOML): edit it and pass it back to `Sim(...)`.
    #[getter]
    fn scene_spec(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let mut spec = self.scene.spec.clone();
        // A built-in scene names the shipped catalog file; as data it is the built-in catalog.
        if self.scene.path.to_string_lossy().starts_with("builtin:") {
            spec.catalog = BUILTIN_HOUSEHOLD.to_string();
        }
        to_python(py, &spec)
    }

    /// The scene's object catalog as data.
    #[getter]
    fn catalog(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        to_python(py, &self.scene.catalog)
    }

    /// A scene from TOML text (the format of `assets/scenes/*.toml`; a relative `catalog` path is read
    /// from the current directory).
    #[staticmethod]
    #[pyo3(signature = (text, seed=0))]
    fn from_toml(text: &str, seed: u64) -> PyResult<Sim> {
        let scene = Scene::from_toml_str(text, "scene.toml").py_err()?;
        Sim::build(scene, seed)
    }

    /// Advances the physics by `n` steps (1 ms each), the GIL released.
    #[pyo3(signature = (n=1))]
    fn step(&mut self, py: Python<'_>, n: i64) -> PyResult<()> {
        let n = usize::try_from(n).map_err(|_| value_error(format!("n must be >= 0, got {n}")))?;
        let sim = &mut self.sim;
        py.detach(|| {
            for _ in 0..n {
                sim.step();
            }
        });
        Ok(())
    }

    /// Simulated time (s).
    #[getter]
    fn time(&self) -> f64 {
        self.sim.time()
    }

    /// Physics steps taken.
    #[getter]
    fn steps(&self) -> u64 {
        self.sim.steps()
    }

    /// The seed (pixel and encoder noise, placement jitter).
    #[getter]
    fn seed(&self) -> u64 {
        self.seed
    }

    /// The scene's name or path.
    #[getter]
    fn scene(&self) -> String {
        self.scene.path.display().to_string()
    }

    /// Names of the independent joints, the order of `q`, `qd` and the targets.
    #[getter]
    fn joint_names(&self) -> Vec<String> {
        self.sim.joint_names().to_vec()
    }

    /// Joint positions (rad / m), an array over `joint_names`.
    #[getter]
    fn q<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        Array1::from_vec(self.sim.joint_positions().to_vec()).into_pyarray(py)
    }

    /// Joint velocities.
    #[getter]
    fn qd<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        Array1::from_vec(self.sim.joint_velocities().to_vec()).into_pyarray(py)
    }

    /// The motor units' position references.
    #[getter]
    fn targets<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        Array1::from_vec(self.sim.joint_targets().to_vec()).into_pyarray(py)
    }

    /// Sets the motor units' references (§3.1: controllers write references u_τ): `q` over every joint
    /// of `joint_names` (or a dict {joint: value} for some), `qd` velocity references (default 0).
    #[pyo3(signature = (q, qd=None))]
    fn set_targets(&mut self, q: &Bound<'_, PyAny>, qd: Option<&Bound<'_, PyAny>>) -> PyResult<()> {
        if let Ok(d) = q.cast::<pyo3::types::PyDict>() {
            for (k, v) in d.iter() {
                let name: String = k.extract()?;
                let value: f64 = v.extract()?;
                if !value.is_finite() {
                    return Err(value_error(format!("target for {name} is not finite")));
                }
                let i = self.sim.dof(&name).py_err()?;
                self.sim.set_joint_target(i, value, 0.0);
            }
            return Ok(());
        }
        let n = self.sim.joint_names().len();
        let q = vector(q, "q")?;
        let qd = match qd {
            Some(v) => vector(v, "qd")?,
            None => vec![0.0; n],
        };
        if q.len() != n || qd.len() != n {
            return Err(value_error(format!(
                "expected {n} values (one per joint of joint_names), got q: {}, qd: {}",
                q.len(),
                qd.len()
            )));
        }
        if let Some(i) = q.iter().chain(&qd).position(|v| !v.is_finite()) {
            return Err(value_error(format!("entry {} is not a finite number", i % n)));
        }
        for i in 0..n {
            self.sim.set_joint_target(i, q[i], qd[i]);
        }
        Ok(())
    }

    /// Teleports the robot to configuration `q` (every joint) at rest, targets included.
    fn set_configuration(&mut self, q: &Bound<'_, PyAny>) -> PyResult<()> {
        let q = vector(q, "q")?;
        if let Some(i) = q.iter().position(|v| !v.is_finite()) {
            return Err(value_error(format!("q entry {i} is not a finite number")));
        }
        self.sim.set_configuration(&q).py_err()
    }

    /// World pose (4×4) of a link.
    fn link_pose<'py>(&self, py: Python<'py>, link: &str) -> PyResult<Bound<'py, PyArray2<f64>>> {
        Ok(iso_array(py, &self.sim.link_pose_by_name(link).py_err()?))
    }

    /// Names of the objects in the scene.
    #[getter]
    fn objects(&self) -> Vec<String> {
        self.sim.objects().iter().map(|o| o.name.clone()).collect()
    }

    /// The true world pose (4×4) of an object — the simulator's truth, for evaluation only (the robot
    /// perceives objects through its cameras).
    fn object_pose<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let i = self.sim.object(name).py_err()?;
        Ok(iso_array(py, &self.sim.object_state(i).pose))
    }

    /// Camera names (`head/left`, `head/right`, `chassis/left`, `chassis/right`).
    #[getter]
    fn cameras(&self) -> Vec<&'static str> {
        CAMERAS.iter().map(|(n, _)| *n).collect()
    }

    /// Renders a camera (index or name) now: an H×W×3 `uint8` RGB array (with pixel noise).
    #[pyo3(signature = (camera=None))]
    fn image<'py>(
        &mut self,
        py: Python<'py>,
        camera: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyArray3<u8>>> {
        let k = match camera {
            Some(c) => self.camera_index(c)?,
            None => 0,
        };
        let (sim, cams, image) = (&self.sim, &mut self.cameras, &mut self.image);
        py.detach(|| cams.capture(sim, k, image)).py_err()?;
        let (w, h) = (image.width as usize, image.height as usize);
        let a = Array3::from_shape_vec((h, w, 3), image.rgb.clone())
            .map_err(|e| error(Kind::Base, format!("image buffer: {e}")))?;
        Ok(a.into_pyarray(py))
    }

    /// The six fingertip force/torque readings: a dict `{"left/1": (force (3,), torque (3,)), …}` in
    /// world axes (N, N·m), from the contact impulses (normal and friction).
    fn fingertip_wrenches(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let mut w = [FingertipWrench {
            arm: pbd::dexter_sim::Arm::Left,
            finger: 0,
            force: [0.0; 3],
            torque: [0.0; 3],
            in_contact: false,
        }; 6];
        self.sim.fingertip_wrenches(&mut w);
        let d = pyo3::types::PyDict::new(py);
        for f in &w {
            let arm = match f.arm {
                pbd::dexter_sim::Arm::Left => "left",
                pbd::dexter_sim::Arm::Right => "right",
            };
            d.set_item(
                format!("{arm}/{}", f.finger),
                (
                    Array1::from_vec(f.force.to_vec()).into_pyarray(py),
                    Array1::from_vec(f.torque.to_vec()).into_pyarray(py),
                ),
            )?;
        }
        Ok(d.into_any().unbind())
    }

    // ---- The robot's skills, one at a time (robot side: encoders, fingertip F/T, cameras only). ----

    /// One percept of the head's stereo pair (§5.1.2), as the robot builds it from its own senses: a
    /// dict with `segments` (track id, triangulated centroid, HSV histogram, colour terms, measured
    /// extent), `hands` (palm, fingertip loads) and `places`.
    fn perceive(&mut self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let (sim, scene, skills) = (&mut self.sim, &self.scene, &mut self.skills);
        let (percept, _) = runner::run(py, None, |p| skills.perceive(sim, scene, &|| p.should_stop()))?;
        to_python(py, &percept)
    }

    /// Search-Track (§3.3.3): foveate the head near `near` (x, y, z in m, a search hint), triangulate
    /// the object there and measure its height and footprint (§6.2.1). Returns a report dict (`ok`,
    /// `outcome`, `centroid`, `extent`, `sim_time`); the robot remembers the object for `grasp`.
    fn locate(&mut self, py: Python<'_>, near: &Bound<'_, PyAny>) -> PyResult<Py<PyAny>> {
        let v = vector(near, "near")?;
        let near: [f64; 3] = v
            .as_slice()
            .try_into()
            .map_err(|_| value_error(format!("near: expected 3 values (x, y, z), got {}", v.len())))?;
        let (sim, scene, skills) = (&mut self.sim, &self.scene, &mut self.skills);
        let (r, _) = runner::run(py, None, |p| skills.locate(sim, scene, near, &|| p.should_stop()))?;
        to_python(py, &r)
    }

    /// Reach ◁ Grasp (§3.1, §6.5) on the located object: a top grasp planned from what vision
    /// measured, pre-shape, descend, close until the grasp predicate converges, lift 10 cm and weigh
    /// it through the fingertips. `arm`: "auto" (the object's side), "left" or "right";
    /// `then_place`: a place the arm must also reach (the schema's arm choice). Returns a report dict
    /// (`ok` = lifted and held, `arm`, `rose`, `weighed` in N).
    #[pyo3(signature = (arm="auto", then_place=None))]
    fn grasp(&mut self, py: Python<'_>, arm: &str, then_place: Option<String>) -> PyResult<Py<PyAny>> {
        let arm = arm_choice(arm)?;
        let (sim, scene, skills) = (&mut self.sim, &self.scene, &mut self.skills);
        let (r, _) = runner::run(py, None, |p| {
            skills.grasp(sim, scene, arm, then_place.as_deref(), &|| p.should_stop())
        })?;
        to_python(py, &r)
    }

    /// Carry the held object up to a safe height and over `place` (a place of the scene), watching
    /// the fingertips. Returns a report dict.
    fn transport(&mut self, py: Python<'_>, place: &str) -> PyResult<Py<PyAny>> {
        let (sim, scene, skills) = (&mut self.sim, &self.scene, &mut self.skills);
        let (r, _) = runner::run(py, None, |p| skills.transport(sim, scene, place, &|| p.should_stop()))?;
        to_python(py, &r)
    }

    /// Lower the held object until the support takes its load, open the hand and retreat. Returns a
    /// report dict.
    fn place(&mut self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let (sim, scene, skills) = (&mut self.sim, &self.scene, &mut self.skills);
        let (r, _) = runner::run(py, None, |p| skills.place(sim, scene, &|| p.should_stop()))?;
        to_python(py, &r)
    }

    /// The arm holding an object ("left" / "right"), or None — the robot's belief from its skills.
    #[getter]
    fn holding(&self) -> Option<String> {
        self.skills.holding().map(|a| a.to_string())
    }

    /// The whole pick-place schema (Search-Track → Reach ◁ Grasp → Transport → Place) on this world,
    /// from where it is now: `object` and `place` default to the scene's first. Returns the report of
    /// `pbd sim pick-place` (the placement judged by the world's evaluator).
    #[pyo3(signature = (object=None, place=None, arm="auto"))]
    fn pick_place(
        &mut self,
        py: Python<'_>,
        object: Option<String>,
        place: Option<String>,
        arm: &str,
    ) -> PyResult<Py<PyAny>> {
        let arm = arm_choice(arm)?.arm();
        let object = match object {
            Some(o) => o,
            None => self
                .scene
                .spec
                .objects
                .first()
                .map(|o| o.presentation.clone())
                .ok_or_else(|| value_error("the scene has no objects"))?,
        };
        let place = match place {
            Some(p) => p,
            None => self
                .scene
                .spec
                .places
                .first()
                .map(|p| p.name.clone())
                .ok_or_else(|| value_error("the scene has no places"))?,
        };
        let request = PickPlaceRequest { object, place, arm };
        let (sim, scene, skills) = (&mut self.sim, &self.scene, &mut self.skills);
        let (r, _) = runner::run(py, None, |p| {
            skills.pick_place(sim, scene, &request, &|| p.should_stop())
        })?;
        to_python(py, &r)
    }

    fn __repr__(&self) -> String {
        format!(
            "Sim(scene={:?}, seed={}, t={:.3} s, objects=[{}])",
            self.scene.path.display().to_string(),
            self.seed,
            self.sim.time(),
            self.sim
                .objects()
                .iter()
                .map(|o| o.name.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        )
    }
}
