//! Shared fixtures: a 7-DOF WAM written from the published DH table (not the GPL URDF).
#![allow(dead_code)]

use control_basis::{Chain, RobotModel};
use rand::RngExt;

/// WAM 7-DOF from the standard DH table of the WAM manual (a, α, d) with the 0.346 m shoulder offset.
pub const WAM_URDF: &str = r#"<robot name="wam_dh">
  <link name="base"/><link name="l1"/><link name="l2"/><link name="l3"/><link name="l4"/>
  <link name="l5"/><link name="l6"/><link name="l7"/><link name="flange"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><origin xyz="0 0 0.346"/><axis xyz="0 0 1"/><limit lower="-2.6" upper="2.6" effort="60" velocity="2"/></joint>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/><origin rpy="-1.5707963267948966 0 0"/><axis xyz="0 0 1"/><limit lower="-1.985" upper="1.985" effort="60" velocity="2"/></joint>
  <joint name="j3" type="revolute"><parent link="l2"/><child link="l3"/><origin rpy="1.5707963267948966 0 0"/><axis xyz="0 0 1"/><limit lower="-2.8" upper="2.8" effort="45" velocity="2"/></joint>
  <joint name="j4" type="revolute"><parent link="l3"/><child link="l4"/><origin xyz="0.045 0 0.55" rpy="-1.5707963267948966 0 0"/><axis xyz="0 0 1"/><limit lower="-0.9" upper="3.141592653589793" effort="30" velocity="2"/></joint>
  <joint name="j5" type="revolute"><parent link="l4"/><child link="l5"/><origin xyz="-0.045 -0.3 0" rpy="1.5707963267948966 0 0"/><axis xyz="0 0 1"/><limit lower="-4.55" upper="1.25" effort="10" velocity="2"/></joint>
  <joint name="j6" type="revolute"><parent link="l5"/><child link="l6"/><origin rpy="-1.5707963267948966 0 0"/><axis xyz="0 0 1"/><limit lower="-1.5707" upper="1.5707" effort="10" velocity="2"/></joint>
  <joint name="j7" type="revolute"><parent link="l6"/><child link="l7"/><origin rpy="1.5707963267948966 0 0"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="10" velocity="2"/></joint>
  <joint name="jf" type="fixed"><parent link="l7"/><child link="flange"/><origin xyz="0 0 0.06"/></joint>
</robot>"#;

/// The WAM chain base → wrist centre (`l7`).
pub fn wam_chain() -> Chain {
    let model = RobotModel::from_urdf_str(WAM_URDF).unwrap();
    Chain::new(&model, "base", "l7").unwrap()
}

/// A uniformly random configuration within `shrink` × the joint ranges (about their middle).
pub fn random_q(chain: &Chain, rng: &mut bayes::rng::Generator, shrink: f64) -> Vec<f64> {
    chain
        .dofs()
        .iter()
        .map(|d| {
            let mid = 0.5 * (d.limits.lower + d.limits.upper);
            let half = 0.5 * (d.limits.upper - d.limits.lower) * shrink;
            rng.random_range(mid - half..=mid + half)
        })
        .collect()
}

/// A seeded RNG.
pub fn rng(seed: u64) -> bayes::rng::Generator {
    bayes::rng::seeded(seed)
}
