//! The convergence predicate P_t(C) ∈ {*, ∅, 0, 1} (3.18), its predicate vectors z = [P(C₁)…P(Cₙ)]
//! (Def. 3.2) and the behaviour-level predicate (3.20).
//!
//! The seed declares a controller quiescent when |φ̇| ≤ ε, with φ̇ the finite-difference derivative of
//! the potential. Measured potentials are noisy, and a raw finite difference of a noisy φ makes the
//! predicate chatter between 0 and 1. [`PredicateTracker`] therefore
//! 1. low-pass filters φ̇ (first order, time constant `filter_secs`),
//! 2. requires |φ̇| ≤ ε for `dwell_secs` before entering 1, and
//! 3. leaves 1 only when |φ̇| exceeds `hysteresis · ε` (with `hysteresis` ≥ 1), and
//! 4. optionally scales ε with φ (`relative_epsilon`), so a controller stalled far from its reference
//!    becomes quiescent (0 → 1 at a non-zero φ) instead of creeping for ever.
//!
//! A fresh tracker is in `*`. A missing reference gives `∅` at once (the feedback is absent, so there is
//! nothing to filter); when the reference reappears the filter restarts and the state is 0 until quiescence
//! has been observed for the dwell time.

use crate::error::CbError;

/// One value of the convergence predicate (3.18).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum Predicate {
    /// `*`: the state is unknown (never evaluated).
    #[serde(rename = "*")]
    Unknown,
    /// `∅`: the controller's reference is absent from its feedback.
    #[serde(rename = "∅")]
    NoReference,
    /// `0`: a reference exists and |φ̇| > ε: the controller is still moving.
    #[serde(rename = "0")]
    Converging,
    /// `1`: quiescent, |φ̇| ≤ ε.
    #[serde(rename = "1")]
    Converged,
}

impl Predicate {
    /// The seed's symbol: `*`, `∅`, `0`, `1`.
    pub fn symbol(self) -> &'static str {
        match self {
            Predicate::Unknown => "*",
            Predicate::NoReference => "∅",
            Predicate::Converging => "0",
            Predicate::Converged => "1",
        }
    }
}

impl std::fmt::Display for Predicate {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.symbol())
    }
}

/// Formats a predicate vector z as the seed writes it: `[* 0 ∅]`.
pub fn format_vector(z: &[Predicate]) -> String {
    let inner: Vec<&str> = z.iter().map(|p| p.symbol()).collect();
    format!("[{}]", inner.join(" "))
}

/// The behaviour predicate (3.20): `*` if every element of z is `*`, `∅` if every element is `∅`,
/// `1` if z is a goal state, `0` otherwise.
pub fn behaviour_predicate(z: &[Predicate], is_goal: impl Fn(&[Predicate]) -> bool) -> Predicate {
    if z.iter().all(|p| *p == Predicate::Unknown) {
        Predicate::Unknown
    } else if is_goal(z) {
        Predicate::Converged
    } else if z.iter().all(|p| *p == Predicate::NoReference) {
        Predicate::NoReference
    } else {
        Predicate::Converging
    }
}

/// Settings of a [`PredicateTracker`]; validate with [`PredicateSettings::validate`].
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PredicateSettings {
    /// ε: quiescence threshold on |φ̇| (units of φ per second).
    pub epsilon: f64,
    /// A relative part of the threshold (1/s): quiescent when |φ̇| ≤ ε + ε_rel·φ. The seed's absolute
    /// ε alone never declares a controller stalled at a large φ (an unreachable target approached ever
    /// more slowly); with ε_rel a potential changing by less than ε_rel of itself per second is
    /// quiescent. 0 gives the seed's rule exactly.
    pub relative_epsilon: f64,
    /// Time constant of the first-order filter on φ̇ (s); 0 disables filtering.
    pub filter_secs: f64,
    /// How long |φ̇| must stay ≤ ε before the predicate becomes 1 (s).
    pub dwell_secs: f64,
    /// Leave 1 only when |φ̇| > hysteresis · ε (≥ 1).
    pub hysteresis: f64,
}

impl Default for PredicateSettings {
    fn default() -> Self {
        PredicateSettings {
            epsilon: 1e-6,
            relative_epsilon: 0.01,
            filter_secs: 0.05,
            dwell_secs: 0.1,
            hysteresis: 4.0,
        }
    }
}

impl PredicateSettings {
    /// Checks the settings once, at construction.
    pub fn validate(&self) -> Result<(), CbError> {
        let bad = |name, value, expected| Err(CbError::InvalidParameter { name, value, expected });
        if !(self.epsilon > 0.0 && self.epsilon.is_finite()) {
            return bad("epsilon", self.epsilon, "a positive finite number");
        }
        if !(self.relative_epsilon >= 0.0 && self.relative_epsilon.is_finite()) {
            return bad(
                "relative_epsilon",
                self.relative_epsilon,
                "a non-negative finite rate (1/s)",
            );
        }
        if !(self.filter_secs >= 0.0 && self.filter_secs.is_finite()) {
            return bad("filter_secs", self.filter_secs, "a non-negative finite number");
        }
        if !(self.dwell_secs >= 0.0 && self.dwell_secs.is_finite()) {
            return bad("dwell_secs", self.dwell_secs, "a non-negative finite number");
        }
        if !(self.hysteresis >= 1.0 && self.hysteresis.is_finite()) {
            return bad("hysteresis", self.hysteresis, "a finite number >= 1");
        }
        Ok(())
    }
}

/// Tracks P_t(C) for one controller or monitor from successive values of φ.
#[derive(Debug, Clone)]
pub struct PredicateTracker {
    settings: PredicateSettings,
    state: Predicate,
    last_phi: Option<f64>,
    phi_dot: f64,
    quiet_secs: f64,
}

impl PredicateTracker {
    /// A tracker in state `*`.
    pub fn new(settings: PredicateSettings) -> Result<Self, CbError> {
        settings.validate()?;
        Ok(PredicateTracker {
            settings,
            state: Predicate::Unknown,
            last_phi: None,
            phi_dot: 0.0,
            quiet_secs: 0.0,
        })
    }

    /// Back to `*` (e.g. when the controller is re-bound to another reference).
    pub fn reset(&mut self) {
        self.state = Predicate::Unknown;
        self.last_phi = None;
        self.phi_dot = 0.0;
        self.quiet_secs = 0.0;
    }

    /// The current predicate.
    pub fn state(&self) -> Predicate {
        self.state
    }
    /// The filtered φ̇ (0 before two evaluations).
    pub fn phi_dot(&self) -> f64 {
        self.phi_dot
    }
    /// The last φ (None when the reference was absent).
    pub fn phi(&self) -> Option<f64> {
        self.last_phi
    }
    /// The settings.
    pub fn settings(&self) -> &PredicateSettings {
        &self.settings
    }

    /// Feeds one evaluation: `phi = None` when the reference is absent; `dt_secs` since the previous one.
    /// A non-finite φ is treated as an absent reference (the feedback is unusable).
    pub fn update(&mut self, phi: Option<f64>, dt_secs: f64) -> Predicate {
        let phi = phi.filter(|p| p.is_finite());
        let Some(phi) = phi else {
            self.state = Predicate::NoReference;
            self.last_phi = None;
            self.phi_dot = 0.0;
            self.quiet_secs = 0.0;
            return self.state;
        };
        let Some(prev) = self.last_phi else {
            // First sample of a (re)appearing reference: no derivative yet.
            self.last_phi = Some(phi);
            self.phi_dot = 0.0;
            self.quiet_secs = 0.0;
            self.state = Predicate::Converging;
            return self.state;
        };
        let dt = if dt_secs > 0.0 && dt_secs.is_finite() {
            dt_secs
        } else {
            1e-3
        };
        let raw = (phi - prev) / dt;
        let alpha = if self.settings.filter_secs > 0.0 {
            dt / (self.settings.filter_secs + dt)
        } else {
            1.0
        };
        self.phi_dot += alpha * (raw - self.phi_dot);
        self.last_phi = Some(phi);
        let mag = self.phi_dot.abs();
        let eps = self.settings.epsilon + self.settings.relative_epsilon * phi.abs();
        match self.state {
            Predicate::Converged => {
                if mag > self.settings.hysteresis * eps {
                    self.state = Predicate::Converging;
                    self.quiet_secs = 0.0;
                }
            }
            _ => {
                if mag <= eps {
                    self.quiet_secs += dt;
                    if self.quiet_secs + 1e-12 >= self.settings.dwell_secs {
                        self.state = Predicate::Converged;
                    } else {
                        self.state = Predicate::Converging;
                    }
                } else {
                    self.quiet_secs = 0.0;
                    self.state = Predicate::Converging;
                }
            }
        }
        self.state
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lifecycle_star_null_zero_one() {
        let mut t = PredicateTracker::new(PredicateSettings::default()).unwrap();
        assert_eq!(t.state(), Predicate::Unknown);
        assert_eq!(t.update(None, 0.01), Predicate::NoReference);
        // Exponential decay φ = e^{-t}: converging, then quiescent once φ̇ is below ε for the dwell time.
        let mut seen_one_at = None;
        for k in 0..4000 {
            let phi = (-(k as f64) * 0.01).exp();
            let p = t.update(Some(phi), 0.01);
            if p == Predicate::Converged && seen_one_at.is_none() {
                seen_one_at = Some(k);
            }
        }
        let k = seen_one_at.expect("converges");
        // |φ̇| = φ ≤ 1e-6 ⇒ t ≥ 13.8 s, plus filter lag and dwell.
        assert!((1380..1450).contains(&k), "converged at tick {k}");
    }

    #[test]
    fn noise_does_not_make_it_chatter() {
        // A quiescent potential with measurement noise whose raw finite difference crosses ε often.
        let s = PredicateSettings {
            epsilon: 1e-3,
            ..Default::default()
        };
        let mut t = PredicateTracker::new(s).unwrap();
        let mut x: u64 = 12345;
        let mut switches = 0;
        let mut raw_crossings = 0;
        let mut prev_state = t.state();
        let mut prev_phi: f64 = 0.5;
        for _ in 0..5000 {
            x = x.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            let u = ((x >> 11) as f64 / (1u64 << 53) as f64) - 0.5;
            let phi = 0.5 + 1e-5 * u;
            if ((phi - prev_phi) / 0.002).abs() > 1e-3 {
                raw_crossings += 1;
            }
            prev_phi = phi;
            let p = t.update(Some(phi), 0.002);
            if p != prev_state {
                switches += 1;
            }
            prev_state = p;
        }
        assert!(
            raw_crossings > 100,
            "the noise should defeat an unfiltered predicate ({raw_crossings})"
        );
        assert_eq!(t.state(), Predicate::Converged);
        assert!(switches <= 2, "{switches} switches");
    }

    #[test]
    fn behaviour_predicate_cases() {
        use Predicate::*;
        let goal = |z: &[Predicate]| z[1] == Converged;
        assert_eq!(behaviour_predicate(&[Unknown, Unknown], goal), Unknown);
        assert_eq!(behaviour_predicate(&[NoReference, NoReference], goal), NoReference);
        assert_eq!(behaviour_predicate(&[Unknown, Converged], goal), Converged);
        assert_eq!(behaviour_predicate(&[Unknown, Converging], goal), Converging);
        assert_eq!(
            format_vector(&[Unknown, NoReference, Converging, Converged]),
            "[* ∅ 0 1]"
        );
    }

    #[test]
    fn invalid_settings_rejected() {
        let s = PredicateSettings {
            epsilon: f64::NAN,
            ..Default::default()
        };
        assert!(PredicateTracker::new(s).is_err());
    }
}
