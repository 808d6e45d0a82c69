//! The plant: what controllers drive. The simulator, a kinematic test plant and a real robot all
//! implement [`Plant`], so the same controllers and schemas run on each.
//!
//! Motor units (§3.1) are the plant's embedded setpoint controllers, one per degree of freedom: the
//! control basis sends them references u_τ (joint positions) and reads back sensors.

use crate::chain::Chain;
use crate::error::CbError;
use crate::model::JointLimits;
use crate::potential::Contact;

/// A robot (simulated or real) driven by motor-unit references.
pub trait Plant {
    /// Names of the plant's degrees of freedom, in its own order.
    fn joint_names(&self) -> &[String];
    /// Number of degrees of freedom.
    fn dof(&self) -> usize {
        self.joint_names().len()
    }
    /// Reads the joint encoders (σ_q) into `q` (length [`Plant::dof`]).
    fn read_joint_positions(&self, q: &mut [f64]);
    /// Current contacts for force sensing (σ_f/m), in the frame the caller's chain uses. Default: none.
    fn contacts(&self) -> &[Contact] {
        &[]
    }
    /// Sends motor-unit references u_τ (joint position setpoints, length [`Plant::dof`]).
    fn command(&mut self, references: &[f64]) -> Result<(), CbError>;
    /// Advances the plant by `dt_secs`.
    fn step(&mut self, dt_secs: f64) -> Result<(), CbError>;
    /// Plant time (s).
    fn time_secs(&self) -> f64;
}

/// Which plant degree of freedom each chain variable is: chain variable `i` is plant DOF `indices[i]`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ChainBinding {
    indices: Vec<usize>,
}

impl ChainBinding {
    /// Binds a chain to a plant by joint names.
    pub fn by_name(chain: &Chain, plant_joint_names: &[String]) -> Result<Self, CbError> {
        let indices = chain
            .dofs()
            .iter()
            .map(|d| {
                plant_joint_names
                    .iter()
                    .position(|n| *n == d.name)
                    .ok_or_else(|| CbError::UnknownJoint { name: d.name.clone() })
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(ChainBinding { indices })
    }
    /// Plant index of chain variable `i`.
    pub fn plant_index(&self, i: usize) -> usize {
        self.indices[i]
    }
    /// Copies the chain's variables out of a plant-ordered vector.
    pub fn gather(&self, plant: &[f64], chain: &mut [f64]) {
        for (c, &i) in chain.iter_mut().zip(&self.indices) {
            *c = plant[i];
        }
    }
    /// Writes the chain's variables into a plant-ordered vector.
    pub fn scatter(&self, chain: &[f64], plant: &mut [f64]) {
        for (c, &i) in chain.iter().zip(&self.indices) {
            plant[i] = *c;
        }
    }
}

/// An ideal kinematic plant: motor units track their setpoints at up to their velocity limits, joints
/// stop at their position limits, encoders are exact or carry seeded Gaussian noise.
#[derive(Debug, Clone)]
pub struct KinematicPlant {
    names: Vec<String>,
    limits: Vec<JointLimits>,
    q: Vec<f64>,
    setpoint: Vec<f64>,
    time: f64,
    encoder_noise: f64,
    rng: bayes::rng::Generator,
    noisy: Vec<f64>,
}

impl KinematicPlant {
    /// A plant with the chain's variables as its degrees of freedom, at `q0`.
    pub fn for_chain(chain: &Chain, q0: &[f64]) -> Result<Self, CbError> {
        chain.check_q(q0)?;
        let limits: Vec<JointLimits> = chain.dofs().iter().map(|d| d.limits).collect();
        let q: Vec<f64> = q0.iter().zip(&limits).map(|(q, l)| q.clamp(l.lower, l.upper)).collect();
        Ok(KinematicPlant {
            names: chain.dofs().iter().map(|d| d.name.clone()).collect(),
            setpoint: q.clone(),
            noisy: q.clone(),
            q,
            limits,
            time: 0.0,
            encoder_noise: 0.0,
            rng: bayes::rng::seeded(0),
        })
    }

    /// Adds zero-mean Gaussian encoder noise with standard deviation `sigma` (rad), seeded.
    pub fn with_encoder_noise(mut self, sigma: f64, seed: u64) -> Result<Self, CbError> {
        if !(sigma >= 0.0 && sigma.is_finite()) {
            return Err(CbError::InvalidParameter {
                name: "encoder_noise",
                value: sigma,
                expected: "a non-negative finite standard deviation",
            });
        }
        self.encoder_noise = sigma;
        self.rng = bayes::rng::seeded(seed);
        Ok(self)
    }

    /// True joint positions (without encoder noise).
    pub fn true_positions(&self) -> &[f64] {
        &self.q
    }
}

impl Plant for KinematicPlant {
    fn joint_names(&self) -> &[String] {
        &self.names
    }
    fn read_joint_positions(&self, q: &mut [f64]) {
        q.copy_from_slice(&self.noisy);
    }
    fn command(&mut self, references: &[f64]) -> Result<(), CbError> {
        if references.len() != self.q.len() {
            return Err(CbError::DimensionMismatch {
                what: "motor unit references".into(),
                expected: self.q.len(),
                got: references.len(),
            });
        }
        crate::error::check_finite("motor unit references", references)?;
        self.setpoint.copy_from_slice(references);
        Ok(())
    }
    fn step(&mut self, dt_secs: f64) -> Result<(), CbError> {
        if !(dt_secs > 0.0 && dt_secs.is_finite()) {
            return Err(CbError::InvalidParameter {
                name: "dt_secs",
                value: dt_secs,
                expected: "a positive finite time step",
            });
        }
        for ((q, s), l) in self.q.iter_mut().zip(&self.setpoint).zip(&self.limits) {
            let max_step = l.velocity * dt_secs;
            let d = (s - *q).clamp(-max_step, max_step);
            *q = (*q + d).clamp(l.lower, l.upper);
        }
        for (n, q) in self.noisy.iter_mut().zip(&self.q) {
            *n = *q
                + if self.encoder_noise > 0.0 {
                    self.encoder_noise * bayes::rng::Draw::normal(&mut self.rng)
                } else {
                    0.0
                };
        }
        self.time += dt_secs;
        Ok(())
    }
    fn time_secs(&self) -> f64 {
        self.time
    }
}
