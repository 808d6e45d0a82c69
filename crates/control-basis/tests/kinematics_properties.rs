//! Jacobians against finite differences (property tests), chains through the tree, mimic joints.

use crate::common;

use control_basis::{Chain, RobotModel, check_jacobian_matches_finite_difference, forward_kinematics, jacobian};
use proptest::prelude::*;

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn wam_jacobian_matches_finite_differences(q in proptest::collection::vec(-3.0f64..3.0, 7)) {
        let chain = common::wam_chain();
        let worst = check_jacobian_matches_finite_difference(&chain, &q, 1e-6);
        prop_assert!(worst < 1e-8, "worst {worst:e}");
    }

    #[test]
    fn reversed_and_branched_chain_jacobian_matches_finite_differences(q in proptest::collection::vec(-3.0f64..3.0, 7)) {
        // From the wrist back to the base: every joint climbed child → parent.
        let model = RobotModel::from_urdf_str(common::WAM_URDF).unwrap();
        let chain = Chain::new(&model, "flange", "l2").unwrap();
        prop_assert_eq!(chain.dof(), 5);
        let worst = check_jacobian_matches_finite_difference(&chain, &q[..5], 1e-6);
        prop_assert!(worst < 1e-8, "worst {worst:e}");
    }

    #[test]
    fn prismatic_and_mimic_jacobian_matches_finite_differences(q in proptest::collection::vec(-1.0f64..1.0, 3)) {
        let model = RobotModel::from_urdf_str(MIXED).unwrap();
        let chain = Chain::new(&model, "base", "tip").unwrap();
        prop_assert_eq!(chain.dof(), 3);
        let worst = check_jacobian_matches_finite_difference(&chain, &q, 1e-6);
        prop_assert!(worst < 1e-8, "worst {worst:e}");
    }
}

/// A prismatic joint, a continuous joint, and a revolute joint that mimics the first revolute one.
const MIXED: &str = r#"<robot name="mixed">
  <link name="base"/><link name="a"/><link name="b"/><link name="c"/><link name="d"/><link name="tip"/>
  <joint name="slide" type="prismatic"><parent link="base"/><child link="a"/><origin xyz="0.1 0 0.2" rpy="0.3 0 0"/><axis xyz="1 0 0"/><limit lower="-1" upper="1" effort="10" velocity="1"/></joint>
  <joint name="r1" type="revolute"><parent link="a"/><child link="b"/><origin xyz="0 0.2 0" rpy="0 0.4 0.1"/><axis xyz="0 1 1"/><limit lower="-2" upper="2" effort="10" velocity="1"/></joint>
  <joint name="spin" type="continuous"><parent link="b"/><child link="c"/><origin xyz="0.3 0 0"/><axis xyz="0 0 1"/></joint>
  <joint name="follow" type="revolute"><parent link="c"/><child link="d"/><origin xyz="0.2 0 0"/><axis xyz="0 1 0"/><limit lower="-2" upper="2" effort="10" velocity="1"/><mimic joint="r1" multiplier="0.5" offset="0.1"/></joint>
  <joint name="fixed_tip" type="fixed"><parent link="d"/><child link="tip"/><origin xyz="0.15 0.02 0" rpy="0 0 0.5"/></joint>
</robot>"#;

#[test]
fn mimic_joint_follows_master() {
    let model = RobotModel::from_urdf_str(MIXED).unwrap();
    let chain = Chain::new(&model, "base", "tip").unwrap();
    let names: Vec<&str> = chain.dofs().iter().map(|d| d.name.as_str()).collect();
    assert_eq!(names, ["slide", "r1", "spin"]);
    let follow = chain.joints().iter().find(|j| j.name == "follow").unwrap();
    assert_eq!(follow.dof, 1);
    assert_eq!(follow.multiplier, 0.5);
    assert_eq!(follow.offset, 0.1);
}

#[test]
fn every_link_pose_is_consistent_with_its_own_chain() {
    // The pose of link l5 computed on the long chain equals the tip pose of the chain that ends there.
    let model = RobotModel::from_urdf_str(common::WAM_URDF).unwrap();
    let long = Chain::new(&model, "base", "flange").unwrap();
    let short = Chain::new(&model, "base", "l5").unwrap();
    let mut r = common::rng(7);
    let q = common::random_q(&long, &mut r, 1.0);
    let mut sl = long.new_state();
    sl.set_q(&long, &q).unwrap();
    forward_kinematics(&long, &mut sl);
    let mut ss = short.new_state();
    ss.set_q(&short, &q[..5]).unwrap();
    forward_kinematics(&short, &mut ss);
    jacobian(&short, &mut ss);
    let i = long.link_index("l5").unwrap();
    let d = sl.link_poses()[i].inverse() * ss.tip_pose();
    assert!(d.translation.vector.norm() < 1e-12 && d.rotation.angle() < 1e-12);
}

#[test]
fn bad_input_is_an_error_not_a_panic() {
    use control_basis::CbError;
    assert!(matches!(
        RobotModel::from_urdf_str("<robot"),
        Err(CbError::MalformedUrdf { .. })
    ));
    assert!(matches!(
        RobotModel::from_urdf_str("not xml at all"),
        Err(CbError::MalformedUrdf { .. })
    ));
    // 10⁵ nested elements once overflowed the XML parser's stack (an abort, exit 134).
    let deep = format!(
        "<robot name=\"r\">{}{}</robot>",
        "<a>".repeat(100_000),
        "</a>".repeat(100_000)
    );
    match RobotModel::from_urdf_str(&deep) {
        Err(CbError::MalformedUrdf { message, .. }) => assert!(message.contains("nested"), "{message}"),
        other => panic!("{other:?}"),
    }
    assert!(control_basis::model::xml_depth(common::WAM_URDF) <= 6);
    let nan = common::WAM_URDF.replace(r#"xyz="0.045 0 0.55""#, r#"xyz="NaN 0 0.55""#);
    assert!(matches!(
        RobotModel::from_urdf_str(&nan),
        Err(CbError::InvalidModel { .. })
    ));
    let dangling = common::WAM_URDF.replace(r#"<child link="l7"/>"#, r#"<child link="nowhere"/>"#);
    assert!(matches!(
        RobotModel::from_urdf_str(&dangling),
        Err(CbError::InvalidModel { .. })
    ));
    let no_limit = common::WAM_URDF.replace(r#"<limit lower="-3" upper="3" effort="10" velocity="2"/>"#, "");
    let err = RobotModel::from_urdf_str(&no_limit).unwrap_err();
    assert!(
        err.to_string().contains("j7") && err.to_string().contains("<limit"),
        "{err}"
    );
    let model = RobotModel::from_urdf_str(common::WAM_URDF).unwrap();
    let err = Chain::new(&model, "base", "l77").unwrap_err();
    assert!(matches!(err, CbError::UnknownLink { .. }));
    assert!(err.to_string().contains("l77"));
    let chain = Chain::new(&model, "base", "l7").unwrap();
    let mut s = chain.new_state();
    assert!(matches!(
        s.set_q(&chain, &[0.0; 6]),
        Err(CbError::DimensionMismatch {
            expected: 7,
            got: 6,
            ..
        })
    ));
    assert!(matches!(
        s.set_q(&chain, &[0.0, 0.0, f64::NAN, 0.0, 0.0, 0.0, 0.0]),
        Err(CbError::NotFinite { index: 2, .. })
    ));
    assert!(matches!(
        RobotModel::from_urdf_file("/nonexistent/robot.urdf"),
        Err(CbError::Io { .. })
    ));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// The whole tree's link poses agree with each chain's forward kinematics (Dexter: both arms,
    /// fingers with their mimic couplings, the head).
    #[test]
    fn whole_tree_link_poses_match_the_chains(q in proptest::collection::vec(-1.0f64..1.0, 40)) {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/dexter.urdf");
        let model = RobotModel::from_urdf_file(path).unwrap();
        let values: std::collections::HashMap<String, f64> = model
            .actuated_joints()
            .zip(q.iter().cycle())
            .map(|(j, &v)| (j.name.clone(), v))
            .collect();
        let mut poses = Vec::new();
        model.link_poses(&|name| values.get(name).copied(), &mut poses);
        prop_assert_eq!(poses.len(), model.links.len());
        let root = model.links[model.root].name.clone();
        for tip in ["left/bhand/finger_2/tip_link", "right/bhand/finger_3/tip_link", "head/left_camera_optical_frame"] {
            let chain = Chain::new(&model, &root, tip).unwrap();
            let mut state = chain.new_state();
            let qv: Vec<f64> = chain.dofs().iter().map(|d| values[&d.name]).collect();
            state.set_q(&chain, &qv).unwrap();
            forward_kinematics(&chain, &mut state);
            let want = *state.tip_pose();
            let got = poses[model.link(tip).unwrap()];
            prop_assert!((got.translation.vector - want.translation.vector).norm() < 1e-12, "{tip}");
            prop_assert!(got.rotation.angle_to(&want.rotation) < 1e-12, "{tip}");
        }
    }
}
