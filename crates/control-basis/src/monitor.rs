//! Monitors (§4.2): controllers with no effector. A monitor evaluates its potential on *observed* state —
//! the teacher's hand during a demonstration, an object's position — and tracks the convergence predicate,
//! without ever commanding a motor unit. Schema inference reads demonstrations through monitors.

use crate::chain::{Chain, ChainState, forward_kinematics, jacobian};
use crate::controller::{Controller, Reference, TaskBuffers, evaluate};
use crate::error::CbError;
use crate::potential::Contact;
use crate::predicate::{Predicate, PredicateSettings, PredicateTracker};

/// A controller used only to observe: P_t(C) from the observed state.
#[derive(Debug, Clone)]
pub struct Monitor {
    controller: Controller,
    buffers: TaskBuffers,
    tracker: PredicateTracker,
    phi: Option<f64>,
}

impl Monitor {
    /// A monitor of `controller`'s potential on `chain` (its motor units are never driven).
    pub fn new(
        controller: Controller,
        chain: &Chain,
        settings: PredicateSettings,
        max_contacts: usize,
    ) -> Result<Self, CbError> {
        let buffers = TaskBuffers::new(&controller, chain, max_contacts);
        Ok(Monitor {
            tracker: PredicateTracker::new(settings)?,
            controller,
            buffers,
            phi: None,
        })
    }

    /// Evaluates φ on the observed chain configuration `state` (FK is recomputed) and updates P.
    pub fn observe(
        &mut self,
        chain: &Chain,
        state: &mut ChainState,
        contacts: &[Contact],
        reference: &Reference,
        dt_secs: f64,
    ) -> Predicate {
        forward_kinematics(chain, state);
        jacobian(chain, state);
        self.phi = evaluate(
            &self.controller,
            chain,
            state,
            contacts,
            reference,
            &mut self.buffers,
            dt_secs,
        );
        self.tracker.update(self.phi, dt_secs)
    }

    /// Updates P from a potential computed elsewhere (e.g. from a vision feature), `None` = no reference.
    pub fn observe_potential(&mut self, phi: Option<f64>, dt_secs: f64) -> Predicate {
        self.phi = phi;
        self.tracker.update(phi, dt_secs)
    }

    /// The current predicate.
    pub fn predicate(&self) -> Predicate {
        self.tracker.state()
    }
    /// The last φ.
    pub fn potential(&self) -> Option<f64> {
        self.phi
    }
    /// The monitored controller.
    pub fn controller(&self) -> &Controller {
        &self.controller
    }
    /// Back to `*`.
    pub fn reset(&mut self) {
        self.tracker.reset();
        self.phi = None;
    }
}
