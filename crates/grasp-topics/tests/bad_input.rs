//! Bad input gives a clear error naming the field, never a panic.

use grasp_topics::{
    Config, Corpus, DemoGrasp, GraspError, GraspModel, GraspScene, HandModel, ObjectShape, filter_and_rank,
    naive_baseline,
};
use nalgebra::{Isometry3, Matrix2, UnitQuaternion, Vector3};

fn good() -> String {
    r#"{"format": "pbd-grasp-corpus", "version": 1, "objects": [
        {"name": "jif", "appearance": [[2.0, 0.1], [0.1, 1.0]],
         "grasps": [{"position": [0.0, 0.0, 0.12], "orientation": [0.0, 1.0, 0.0, 0.0]},
                    {"position": [0.01, 0.0, 0.11], "orientation": [0.0, 1.0, 0.0, 0.0]}]},
        {"name": "coke", "appearance": [[1.0, 0.0], [0.0, 3.0]],
         "grasps": [{"position": [0.08, 0.0, 0.02], "orientation": [0.7071068, 0.0, 0.7071068, 0.0]}]}
    ]}"#
    .to_string()
}

fn err(text: &str) -> String {
    Corpus::from_json_str(text).unwrap_err().to_string()
}

#[test]
fn good_corpus_loads_and_learns() {
    let c = Corpus::from_json_str(&good()).unwrap();
    assert_eq!(c.num_grasps(), 3);
    let cfg = Config {
        prototypes: 2,
        orientations: 2,
        burn_in: 5,
        samples: 1,
        thin: 1,
        chains: 2,
        ..Config::default()
    };
    let m = GraspModel::learn(&c, &cfg).unwrap();
    assert!(!m.prototypes.is_empty());
}

#[test]
fn corpus_errors_name_the_field() {
    let no_grasps = good().replace(
        r#""grasps": [{"position": [0.08, 0.0, 0.02], "orientation": [0.7071068, 0.0, 0.7071068, 0.0]}]"#,
        r#""grasps": []"#,
    );
    let e = err(&no_grasps);
    assert!(e.contains("objects[1]") && e.contains("no grasps"), "{e}");

    let no_objects = r#"{"format": "pbd-grasp-corpus", "version": 1, "objects": []}"#;
    assert!(err(no_objects).contains("no objects"), "{}", err(no_objects));

    let short = good().replace("[0.01, 0.0, 0.11]", "[0.01, 0.0]");
    let e = err(&short);
    assert!(
        e.contains("objects[0].grasps[1].position") && e.contains("expected 3"),
        "{e}"
    );

    let wide = good().replace("[[1.0, 0.0], [0.0, 3.0]]", "[[1.0, 0.0, 0.0], [0.0, 3.0, 0.0]]");
    let e = err(&wide);
    assert!(
        e.contains("objects[1].appearance[0]") && e.contains("expected 2"),
        "{e}"
    );

    let not_pd = good().replace("[[2.0, 0.1], [0.1, 1.0]]", "[[1.0, 2.0], [2.0, 1.0]]");
    let e = err(&not_pd);
    assert!(
        e.contains("objects[0].appearance") && e.contains("positive definite"),
        "{e}"
    );

    let asym = good().replace("[[2.0, 0.1], [0.1, 1.0]]", "[[2.0, 0.5], [0.1, 1.0]]");
    assert!(err(&asym).contains("asymmetric"), "{}", err(&asym));

    let not_unit = good().replace("[0.0, 1.0, 0.0, 0.0]}]}", "[0.0, 2.0, 0.0, 0.0]}]}");
    let e = err(&not_unit);
    assert!(e.contains("orientation") && e.contains("unit quaternion"), "{e}");

    let version = good().replace(r#""version": 1"#, r#""version": 7"#);
    assert!(err(&version).contains("unsupported"), "{}", err(&version));

    let dup = good().replace(r#""coke""#, r#""jif""#);
    assert!(err(&dup).contains("duplicate"), "{}", err(&dup));

    let missing = good().replace(r#""name": "coke", "#, "");
    assert!(err(&missing).contains("objects[1].name: missing"), "{}", err(&missing));

    assert!(err("{not json").contains("grasp corpus"), "{}", err("{not json"));
}

#[test]
fn nan_and_unknown_object_are_errors() {
    let mut c = Corpus::new();
    let q = UnitQuaternion::identity();
    c.push_object(
        "a",
        &Matrix2::new(1.0, 0.0, 0.0, 1.0),
        vec![DemoGrasp::new(&Vector3::new(f64::NAN, 0.0, 0.0), &q)],
    );
    let e = c.validate().unwrap_err();
    assert!(matches!(e, GraspError::NonFinite { .. }), "{e}");
    assert!(e.to_string().contains("objects[0].grasps[0].position[0]"), "{e}");
    assert!(GraspModel::learn(&c, &Config::default()).is_err());

    let mut c = Corpus::new();
    c.push_object(
        "a",
        &Matrix2::new(f64::NAN, 0.0, 0.0, 1.0),
        vec![DemoGrasp::new(&Vector3::zeros(), &q)],
    );
    assert!(c.validate().unwrap_err().to_string().contains("objects[0].appearance"));

    assert!(Corpus::new().validate().is_err());
    let c = Corpus::from_json_str(&good()).unwrap();
    let e = c.object_index("mallet").unwrap_err();
    assert!(e.to_string().contains("unknown object \"mallet\""), "{e}");
}

#[test]
fn bad_config_model_and_generation_inputs() {
    let c = Corpus::from_json_str(&good()).unwrap();
    for (cfg, field) in [
        (
            Config {
                prototypes: 0,
                ..Config::default()
            },
            "config.prototypes",
        ),
        (
            Config {
                chains: 0,
                ..Config::default()
            },
            "config.chains",
        ),
        (
            Config {
                orientations: 0,
                ..Config::default()
            },
            "config.orientations",
        ),
    ] {
        let e = GraspModel::learn(&c, &cfg).unwrap_err().to_string();
        assert!(e.contains(field), "{e}");
    }
    let cfg = Config {
        prototypes: 2,
        orientations: 2,
        burn_in: 2,
        samples: 1,
        thin: 1,
        chains: 1,
        ..Config::default()
    };
    let mut bad_h = grasp_topics::Hyperparameters::from_data(
        &grasp_topics::Dataset::from_corpus(
            &c,
            &grasp_topics::CanonicalOrientations::new(vec![[1.0, 0.0, 0.0, 0.0]]).unwrap(),
        )
        .unwrap(),
    );
    bad_h.alpha = -1.0;
    let e = GraspModel::learn(
        &c,
        &Config {
            hyperparameters: Some(bad_h),
            ..cfg.clone()
        },
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("hyperparameters.alpha"), "{e}");

    let m = GraspModel::learn(&c, &cfg).unwrap();
    let mut rng = bayes::rng::seeded(0);
    let e = m.generate(&Matrix2::new(1.0, 0.0, 0.0, -1.0), 3, &mut rng).unwrap_err();
    assert!(matches!(e, GraspError::NotPositiveDefinite { .. }), "{e}");

    // A model file with a wrong version or broken prototype is refused.
    let text = m.to_json_string().unwrap();
    let e = GraspModel::from_json_str(&text.replace(r#""version": 1"#, r#""version": 2"#)).unwrap_err();
    assert!(e.to_string().contains("unsupported"), "{e}");
    assert!(GraspModel::from_json_str("[]").is_err());

    assert!(naive_baseline(&Vector3::new(0.1, 0.0, 0.1), 3, &mut rng).is_err());
    assert!(naive_baseline(&Vector3::new(0.1, f64::NAN, 0.1), 3, &mut rng).is_err());

    let scene = GraspScene {
        shape: ObjectShape::Sphere { radius: -0.1 },
        world_from_object: Isometry3::identity(),
        centroid: Vector3::zeros(),
        table_height: 0.0,
        reach_origin: Vector3::zeros(),
    };
    assert!(filter_and_rank(&[], &scene, &HandModel::default()).is_err());
}

#[test]
fn naive_baseline_is_on_the_hemisphere_facing_the_centroid() {
    let mut rng = bayes::rng::seeded(3);
    let dims = Vector3::new(0.06, 0.1, 0.2);
    let g = naive_baseline(&dims, 200, &mut rng).unwrap();
    for p in &g {
        let x = p.position();
        assert!((x.norm() - 0.1).abs() < 1e-12);
        assert!(x.z >= 0.0);
        let approach = p.orientation() * Vector3::z();
        assert!((approach + x.normalize()).norm() < 1e-9, "palm must face the centroid");
    }
    // The roll is random: hand x axes differ.
    let xs: Vec<Vector3<f64>> = g.iter().map(|p| p.orientation() * Vector3::x()).collect();
    assert!(xs.windows(2).any(|w| (w[0] - w[1]).norm() > 0.1));
}
