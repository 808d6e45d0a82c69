//! Canonical hand orientations (§6.2.2): the Q orientations that a prototype's multinomial φ ranges
//! over, learned from the training grasps by k-medoids clustering under the quaternion angle.
//!
//! The seed chose Q = 6 from its training set without saying how. Here the canonical orientations
//! are medoids, i.e. actual demonstrated orientations, so each one is a hand pose a teleoperator
//! really used. The distance is the rotation angle between two orientations,
//! 2·acos |⟨q₁, q₂⟩|, which treats q and −q as the same rotation.

use nalgebra::{Quaternion, UnitQuaternion};
use rand::{Rng, RngExt};
use serde::{Deserialize, Serialize};

use crate::error::{GraspError, Result, invalid};

/// Rotation angle (rad, in [0, π]) between two orientations.
pub fn orientation_distance(a: &UnitQuaternion<f64>, b: &UnitQuaternion<f64>) -> f64 {
    let d = a.coords.dot(&b.coords).abs().min(1.0);
    2.0 * d.acos()
}

/// The Q canonical orientations, as unit quaternions `[w, x, y, z]` in the object frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CanonicalOrientations {
    /// The orientations (medoids of the training orientations).
    pub quaternions: Vec<[f64; 4]>,
}

impl CanonicalOrientations {
    /// Canonical orientations given explicitly (validated: non-empty, unit norm within 1e-3).
    pub fn new(quaternions: Vec<[f64; 4]>) -> Result<Self> {
        if quaternions.is_empty() {
            return Err(invalid("orientations", "at least one canonical orientation is needed"));
        }
        for (i, q) in quaternions.iter().enumerate() {
            crate::error::check_finite(|| format!("orientations[{i}]"), q)?;
            let n = q.iter().map(|v| v * v).sum::<f64>().sqrt();
            if (n - 1.0).abs() > 1e-3 {
                return Err(invalid(
                    format!("orientations[{i}]"),
                    format!("not a unit quaternion (norm {n})"),
                ));
            }
        }
        Ok(Self { quaternions })
    }

    /// Number of canonical orientations Q.
    pub fn len(&self) -> usize {
        self.quaternions.len()
    }

    /// Whether there are none (never true for a validated set).
    pub fn is_empty(&self) -> bool {
        self.quaternions.is_empty()
    }

    /// Canonical orientation `k` as a rotation.
    pub fn get(&self, k: usize) -> Option<UnitQuaternion<f64>> {
        self.quaternions.get(k).map(|&q| to_unit(q))
    }

    /// Index of the canonical orientation nearest to `q` (w_mp of §6.2.2).
    pub fn nearest(&self, q: &UnitQuaternion<f64>) -> usize {
        let mut best = (f64::INFINITY, 0);
        for (k, &c) in self.quaternions.iter().enumerate() {
            let d = orientation_distance(q, &to_unit(c));
            if d < best.0 {
                best = (d, k);
            }
        }
        best.1
    }

    /// Learns `q` canonical orientations from `orientations` by k-medoids (k-medoids++ seeding,
    /// alternating assignment and medoid update, 8 restarts, lowest total angle kept). Deterministic
    /// for a given `seed`. If there are fewer than `q` distinct orientations (angle > 1e-6), all the
    /// distinct ones are returned.
    pub fn learn(orientations: &[UnitQuaternion<f64>], q: usize, seed: u64) -> Result<Self> {
        if q == 0 {
            return Err(invalid("orientations", "Q must be at least 1"));
        }
        if orientations.is_empty() {
            return Err(GraspError::EmptyCorpus {
                reason: "no grasp orientations to cluster".into(),
            });
        }
        // Distinct orientations (keeps the first of each near-duplicate group).
        let mut distinct: Vec<UnitQuaternion<f64>> = Vec::new();
        for o in orientations {
            if distinct.len() <= q && distinct.iter().all(|d| orientation_distance(d, o) > 1e-6) {
                distinct.push(*o);
            }
        }
        if distinct.len() <= q {
            return Ok(Self {
                quaternions: distinct.iter().map(from_unit).collect(),
            });
        }
        let mut rng = bayes::rng::seeded(seed ^ 0x6f72_6965_6e74_6174);
        let mut best: Option<(f64, Vec<usize>)> = None;
        for _ in 0..8 {
            let (cost, medoids) = k_medoids(orientations, q, &mut rng);
            if best.as_ref().is_none_or(|b| cost < b.0 - 1e-12) {
                best = Some((cost, medoids));
            }
        }
        let medoids = best.map(|b| b.1).unwrap_or_default();
        Ok(Self {
            quaternions: medoids.iter().map(|&i| from_unit(&orientations[i])).collect(),
        })
    }
}

fn to_unit(q: [f64; 4]) -> UnitQuaternion<f64> {
    UnitQuaternion::from_quaternion(Quaternion::new(q[0], q[1], q[2], q[3]))
}

fn from_unit(q: &UnitQuaternion<f64>) -> [f64; 4] {
    // Canonical sign: w ≥ 0, so files do not flip between q and −q.
    let c = q.quaternion();
    let s = if c.w < 0.0 { -1.0 } else { 1.0 };
    [s * c.w, s * c.i, s * c.j, s * c.k]
}

/// One k-medoids run: returns (total distance, medoid indices).
fn k_medoids<R: Rng>(x: &[UnitQuaternion<f64>], k: usize, rng: &mut R) -> (f64, Vec<usize>) {
    let n = x.len();
    // k-medoids++ seeding.
    let mut medoids = vec![rng.random_range(0..n)];
    let mut dmin: Vec<f64> = x.iter().map(|p| orientation_distance(p, &x[medoids[0]])).collect();
    while medoids.len() < k {
        let w: Vec<f64> = dmin.iter().map(|d| d * d).collect();
        let next = if w.iter().sum::<f64>() > 0.0 {
            crate::math::sample_weights(&w, rng)
        } else {
            rng.random_range(0..n)
        };
        medoids.push(next);
        for (d, p) in dmin.iter_mut().zip(x) {
            *d = d.min(orientation_distance(p, &x[next]));
        }
    }
    let mut label = vec![0usize; n];
    let mut cost = f64::INFINITY;
    for _ in 0..100 {
        // Assignment.
        let mut new_cost = 0.0;
        for (i, p) in x.iter().enumerate() {
            let mut best = (f64::INFINITY, 0);
            for (c, &m) in medoids.iter().enumerate() {
                let d = orientation_distance(p, &x[m]);
                if d < best.0 {
                    best = (d, c);
                }
            }
            label[i] = best.1;
            new_cost += best.0;
        }
        // Medoid update: the member with the least total distance to its cluster.
        let mut changed = false;
        for (c, m) in medoids.iter_mut().enumerate() {
            let members: Vec<usize> = (0..n).filter(|&i| label[i] == c).collect();
            let mut best = (f64::INFINITY, *m);
            for &i in &members {
                let s: f64 = members.iter().map(|&j| orientation_distance(&x[i], &x[j])).sum();
                if s < best.0 - 1e-12 {
                    best = (s, i);
                }
            }
            if best.1 != *m {
                *m = best.1;
                changed = true;
            }
        }
        let converged = !changed || new_cost >= cost - 1e-12;
        cost = new_cost;
        if converged {
            break;
        }
    }
    (cost, medoids)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    #[test]
    fn recovers_well_separated_orientations() {
        let centres = [
            UnitQuaternion::identity(),
            UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI),
            UnitQuaternion::from_axis_angle(&Vector3::y_axis(), std::f64::consts::FRAC_PI_2),
        ];
        let mut data = Vec::new();
        for (k, c) in centres.iter().enumerate() {
            for i in 0..10 {
                let e = 0.05 * ((i as f64) - 4.5) / 4.5;
                data.push(c * UnitQuaternion::from_euler_angles(e, -e * 0.5, 0.1 * k as f64 * e));
            }
        }
        let canon = CanonicalOrientations::learn(&data, 3, 7).unwrap();
        assert_eq!(canon.len(), 3);
        for c in &centres {
            let k = canon.nearest(c);
            assert!(orientation_distance(c, &canon.get(k).unwrap()) < 0.1);
        }
        // Same seed, same result.
        assert_eq!(canon, CanonicalOrientations::learn(&data, 3, 7).unwrap());
    }
}
