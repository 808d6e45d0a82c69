//! Object catalogs and scenes: the shipped ones load and are sensible; bad input is rejected with
//! errors that name the file and the field.

use dexter_sim::SimError;
use dexter_sim::convert::iso_to_glam;
use dexter_sim::geometry::{support_half_extent, to_parry, volume};
use dexter_sim::scene::{
    BUILTIN_HOUSEHOLD, Catalog, ObjectPlacement, ObjectSpec, REST_CLEARANCE, Scene, Shape, rests_stably,
};
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use control_basis::math::{Rot3, Vec3};

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data").join(name)
}

fn household() -> Catalog {
    Catalog::builtin_household().unwrap_or_else(|e| panic!("built-in catalog: {e}"))
}

fn builtin(name: &str) -> Scene {
    Scene::builtin(name).unwrap_or_else(|e| panic!("built-in scene {name}: {e}"))
}

/// `base` with `from` replaced by `to` (which must occur).
fn edit(base: &str, from: &str, to: &str) -> String {
    assert!(base.contains(from), "fixture does not contain {from:?}");
    base.replacen(from, to, 1)
}

/// Asserts `e` is [`SimError::Invalid`] for `file` and exactly `field`, and that its message
/// (Display) names both and contains each of `words`.
fn assert_invalid(e: &SimError, file: &str, field: &str, words: &[&str]) {
    let shown = e.to_string();
    match e {
        SimError::Invalid { path, field: f, .. } => {
            assert!(
                path.to_string_lossy().contains(file),
                "path {path:?} should name {file}: {shown}"
            );
            assert_eq!(f, field, "{shown}");
        }
        other => panic!("expected Invalid at {field}, got {other:?}"),
    }
    assert!(
        shown.contains(file) && shown.contains(field),
        "message should name file and field: {shown}"
    );
    for w in words {
        assert!(shown.contains(w), "message should contain {w:?}: {shown}");
    }
}

/// Asserts `e` is [`SimError::Parse`] for `file` and that its message contains each of `words`.
fn assert_parse(e: &SimError, file: &str, words: &[&str]) {
    let shown = e.to_string();
    assert!(matches!(e, SimError::Parse { .. }), "expected Parse, got {e:?}");
    assert!(shown.contains(file), "message should name {file}: {shown}");
    for w in words {
        assert!(shown.contains(w), "message should contain {w:?}: {shown}");
    }
}

// ---------------------------------------------------------------------------------------------
// The shipped catalog and scenes
// ---------------------------------------------------------------------------------------------

#[test]
fn shipped_catalog_loads_from_file_and_builtin_alike() {
    let file = Catalog::load(repo().join("assets/objects/household.toml")).unwrap();
    let compiled = household();
    assert_eq!(file.objects, compiled.objects);
    assert_eq!(compiled.path, Path::new(BUILTIN_HOUSEHOLD));
}

#[test]
fn every_shipped_scene_loads_from_file_and_builtin_alike() {
    let files: BTreeSet<String> = std::fs::read_dir(repo().join("assets/scenes"))
        .unwrap()
        .filter_map(|e| e.ok()?.file_name().to_str()?.strip_suffix(".toml").map(str::to_string))
        .collect();
    let builtins: BTreeSet<String> = Scene::builtin_names().iter().map(|s| s.to_string()).collect();
    assert_eq!(files, builtins, "every scene file is compiled in");
    for name in Scene::builtin_names() {
        let compiled = builtin(name);
        let file = Scene::load(repo().join(format!("assets/scenes/{name}.toml"))).unwrap();
        assert_eq!(compiled.spec, file.spec);
        assert_eq!(compiled.spec.name, *name);
        assert_eq!(compiled.path, Path::new(&format!("builtin:{name}")));
        for (a, b) in compiled.resolved.iter().zip(&file.resolved) {
            assert_eq!((a.label.as_str(), a.object), (b.label.as_str(), b.object));
            assert!((a.pose.translation.vector - b.pose.translation.vector).norm() < 1e-12);
        }
        assert_eq!(Scene::open(name).unwrap().spec, compiled.spec);
        assert!((compiled.spec.light.direction.iter().map(|x| x * x).sum::<f64>() - 1.0).abs() < 1e-12);
    }
}

/// Colour family of an HSV colour: the rule the shipped catalog's `color_class` labels follow.
fn family(hsv: [f64; 3]) -> &'static str {
    let [h, s, v] = hsv;
    if v < 0.25 {
        "black"
    } else if s < 0.2 {
        if v >= 0.7 { "white" } else { "grey" }
    } else if !(15.0..320.0).contains(&h) {
        "red"
    } else if h < 45.0 {
        "orange"
    } else if h < 75.0 {
        "yellow"
    } else if h < 170.0 {
        "green"
    } else if h < 260.0 {
        "blue"
    } else {
        "purple"
    }
}

/// The family covering most of the surface.
fn dominant_family(object: &ObjectSpec) -> &'static str {
    let mut share: BTreeMap<&str, f64> = BTreeMap::new();
    for patch in &object.colors {
        *share.entry(family(patch.hsv)).or_default() += patch.fraction;
    }
    share
        .into_iter()
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(f, _)| f)
        .unwrap()
}

/// Full extents (x, y, z) in the world of `shape` with `orientation`.
fn extents(shape: &Shape, orientation: &Rot3) -> [f64; 3] {
    let along = |axis: Vec3| 2.0 * support_half_extent(shape, &(orientation.inverse() * axis));
    [along(Vec3::x()), along(Vec3::y()), along(Vec3::z())]
}

#[test]
fn catalog_has_the_variety_experiments_need() {
    let catalog = household();
    assert!(catalog.objects.len() >= 30, "{} objects", catalog.objects.len());
    let mut per_family: BTreeMap<&str, usize> = BTreeMap::new();
    let mut sizes: BTreeSet<&str> = BTreeSet::new();
    let mut kinds: BTreeMap<&str, usize> = BTreeMap::new();
    for o in &catalog.objects {
        *per_family
            .entry(o.color_class.as_deref().expect("colour class"))
            .or_default() += 1;
        sizes.insert(o.size_class.as_deref().expect("size class"));
        *kinds.entry(o.shape.kind()).or_default() += 1;
    }
    for f in ["red", "blue", "white", "black", "orange", "green"] {
        assert!(
            per_family.get(f).copied().unwrap_or(0) >= 4,
            "family {f}: {per_family:?}"
        );
    }
    assert_eq!(sizes, BTreeSet::from(["small", "medium", "large"]));
    let with_extra = catalog.objects.iter().filter(|o| !o.presentations.is_empty()).count();
    assert!(with_extra >= 6, "{with_extra} objects with extra presentations");
    assert!(
        kinds.len() == 4 && kinds["sphere"] <= 8 && kinds["capsule"] <= 5,
        "{kinds:?}"
    );
}

#[test]
fn colour_class_is_the_family_covering_most_of_the_surface() {
    for o in &household().objects {
        assert_eq!(o.color_class.as_deref(), Some(dominant_family(o)), "{}", o.name);
    }
}

#[test]
fn size_class_follows_the_bounding_box() {
    for o in &household().objects {
        let [x, y, z] = extents(&o.shape, &Rot3::identity());
        let g = (x * y * z).cbrt();
        let expected = if g < 0.06 {
            "small"
        } else if g < 0.09 {
            "medium"
        } else {
            "large"
        };
        assert_eq!(o.size_class.as_deref(), Some(expected), "{}: g = {g:.4}", o.name);
    }
}

#[test]
fn every_presentation_is_graspable_from_above_and_rests_stably() {
    let catalog = household();
    for name in catalog.presentation_names() {
        let (index, orientation) = catalog.presentation(name).unwrap();
        let shape = &catalog.objects[index].shape;
        let [x, y, z] = extents(shape, &orientation);
        let (narrow, long) = (x.min(y), x.max(y));
        assert!((0.04 - 1e-9..=0.09 + 1e-9).contains(&narrow), "{name}: {narrow} across");
        assert!(long <= 0.14 + 1e-9, "{name}: {long} long");
        assert!((0.04 - 1e-9..=0.20 + 1e-9).contains(&z), "{name}: {z} tall");
        assert!(rests_stably(shape, &orientation), "{name} does not rest stably");
    }
}

#[test]
fn masses_and_frictions_are_plausible() {
    for o in &household().objects {
        let density = o.mass / volume(&o.shape);
        assert!((0.03..=0.6).contains(&o.mass), "{}: {} kg", o.name, o.mass);
        assert!((100.0..=900.0).contains(&density), "{}: {density:.0} kg/m³", o.name);
        assert!((0.6..=1.0).contains(&o.friction), "{}: friction {}", o.name, o.friction);
    }
}

#[test]
fn stability_check_tells_stable_from_unstable() {
    let capsule = Shape::Capsule {
        radius: 0.03,
        height: 0.06,
    };
    let block = Shape::Box {
        size: [0.05, 0.05, 0.05],
    };
    let lying = Rot3::from_euler_angles(std::f64::consts::FRAC_PI_2, 0.0, 0.0);
    assert!(!rests_stably(&capsule, &Rot3::identity()));
    assert!(rests_stably(&capsule, &lying));
    assert!(rests_stably(&block, &Rot3::from_euler_angles(0.0, 0.0, 0.7)));
    assert!(!rests_stably(
        &block,
        &Rot3::from_euler_angles(std::f64::consts::FRAC_PI_4, 0.0, 0.0)
    ));
}

/// Lowest point of a placed object according to parry (independent of the support functions).
fn lowest_z(scene: &Scene, index: usize) -> f64 {
    let r = &scene.resolved[index];
    let (shape, object_from_shape) = to_parry(&scene.catalog.objects[r.object].shape);
    shape.compute_aabb(&iso_to_glam(&(r.pose * object_from_shape))).mins.z
}

#[test]
fn resting_poses_put_the_lowest_point_one_millimetre_above_the_table() {
    for name in Scene::builtin_names() {
        let scene = builtin(name);
        for i in 0..scene.resolved.len() {
            let gap = lowest_z(&scene, i) - scene.spec.table.height;
            assert!(
                (gap - REST_CLEARANCE).abs() < 1e-9,
                "{name}/{}: {gap}",
                scene.resolved[i].label
            );
        }
    }
    // Every presentation, at an awkward yaw, on the pick-and-place scene.
    let base = builtin("pick-place");
    for name in base.catalog.presentation_names() {
        let placement = ObjectPlacement {
            presentation: name.to_string(),
            xy: [0.6, 0.0],
            yaw_deg: 37.0,
            z: None,
        };
        let scene = base
            .with_objects(vec![placement])
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        let gap = lowest_z(&scene, 0) - scene.spec.table.height;
        assert!((gap - REST_CLEARANCE).abs() < 1e-9, "{name}: {gap}");
        let pose = base.catalog.rest_pose(name, [0.6, 0.0], 37.0, 0.75).unwrap();
        assert!((pose.translation.vector - scene.resolved[0].pose.translation.vector).norm() < 1e-12);
    }
}

#[test]
fn shipped_scenes_keep_objects_apart_and_clear_of_the_bins() {
    for name in Scene::builtin_names() {
        let scene = builtin(name);
        let n = scene.resolved.len();
        for i in 0..n {
            for j in i + 1..n {
                let gap = scene.object_gap(i, j).unwrap();
                assert!(
                    gap >= 0.05,
                    "{name}: {} – {}: {gap:.3} m",
                    scene.resolved[i].label,
                    scene.resolved[j].label
                );
            }
            for (k, place) in scene.spec.places.iter().enumerate() {
                let gap = scene.place_gap(i, k).unwrap();
                assert!(
                    gap >= 0.05,
                    "{name}: {} – {}: {gap:.3} m",
                    scene.resolved[i].label,
                    place.name
                );
            }
        }
        assert_eq!(scene.object_gap(0, n), None);
        assert_eq!(scene.place_gap(n, 0), None);
    }
}

#[test]
fn sorting_scenes_need_both_arms() {
    let sorting = builtin("sorting");
    let left = sorting.place("bin-left").unwrap();
    let right = sorting.place("bin-right").unwrap();
    // Each bin lies wholly outside the other arm's reach (y ≥ -0.2 for the left arm, ≤ 0.2 for the right).
    assert!(left.center[1] - left.outer_size()[1] / 2.0 > 0.2);
    assert!(right.center[1] + right.outer_size()[1] / 2.0 < -0.2);
    assert!((left.wall_height - 0.06).abs() < 1e-12 && left.size == [0.2, 0.25]);

    let ys = |scene: &Scene| -> Vec<f64> { scene.resolved.iter().map(|r| r.pose.translation.y).collect() };
    for scene in [&sorting, &builtin("sorting-new")] {
        let y = ys(scene);
        assert!((5..=7).contains(&y.len()));
        assert!(y.iter().any(|y| y.abs() < 0.2), "some object both arms reach");
        assert!(
            y.iter().any(|&y| y > 0.2) && y.iter().any(|&y| y < -0.2),
            "objects only one arm reaches"
        );
        for r in &scene.resolved {
            let p = r.pose.translation;
            assert!((0.4..=0.76).contains(&p.x) && p.y.abs() <= 0.3, "{} at {p:?}", r.label);
        }
        let non_default = scene
            .resolved
            .iter()
            .filter(|r| r.presentation != scene.catalog.objects[r.object].name);
        assert!(non_default.count() >= 1);
        let classes: BTreeSet<_> = scene
            .resolved
            .iter()
            .filter_map(|r| scene.catalog.objects[r.object].color_class.clone())
            .collect();
        assert!(classes.contains("red") && classes.contains("blue"));
    }
    let kinds = |scene: &Scene| -> BTreeSet<usize> { scene.resolved.iter().map(|r| r.object).collect() };
    assert!(
        kinds(&sorting).is_disjoint(&kinds(&builtin("sorting-new"))),
        "sorting-new uses other objects"
    );

    let pick = builtin("pick-place");
    assert_eq!(pick.resolved.len(), 1);
    assert!(pick.resolved[0].pose.translation.y.abs() < 0.05);
    for (a, b) in pick.spec.places.iter().zip(&sorting.spec.places) {
        assert_eq!(
            (&a.name, a.center, a.size, a.wall_height),
            (&b.name, b.center, b.size, b.wall_height)
        );
    }
}

// ---------------------------------------------------------------------------------------------
// Look-ups
// ---------------------------------------------------------------------------------------------

#[test]
fn catalog_lookups() {
    let catalog = household();
    assert_eq!(catalog.object("jif").unwrap().name, "jif");
    let (index, upright) = catalog.presentation("jif").unwrap();
    assert_eq!(catalog.objects[index].name, "jif");
    assert!(upright.angle() < 1e-12);
    let (same, lying) = catalog.presentation("jif-1").unwrap();
    assert_eq!(same, index);
    assert!(
        (lying * Vec3::z()).z.abs() < 1e-12,
        "jif-1 lies with its axis horizontal"
    );
    match catalog.presentation("jiff") {
        Err(SimError::Unknown { kind, name, candidates }) => {
            assert_eq!((kind, name.as_str()), ("presentation", "jiff"));
            assert_eq!(candidates[0], "jif", "closest first");
            assert_eq!(candidates.len(), catalog.presentation_names().len());
        }
        other => panic!("{other:?}"),
    }
    assert!(matches!(
        catalog.object("jif-1"),
        Err(SimError::Unknown { kind: "object", .. })
    ));
}

#[test]
fn scene_lookups_and_duplicates() {
    let scene = builtin("sorting");
    assert_eq!(scene.place("bin-left").unwrap().name, "bin-left");
    let e = scene.place("bin-middle").unwrap_err();
    match &e {
        SimError::Unknown { kind, name, candidates } => {
            assert_eq!((*kind, name.as_str()), ("place", "bin-middle"));
            assert_eq!(candidates.len(), 2);
        }
        other => panic!("{other:?}"),
    }
    assert!(
        e.to_string().contains("bin-middle") && e.to_string().contains("bin-left"),
        "{e}"
    );

    let jif = scene.object_index("jif").unwrap();
    assert_eq!(scene.resolved[jif].presentation, "jif");
    assert!(matches!(
        scene.object_index("jif#2"),
        Err(SimError::Unknown {
            kind: "placed object",
            ..
        })
    ));
    assert_eq!(scene.object_index("jif#1").unwrap(), jif);

    let at = |presentation: &str, x: f64, y: f64| ObjectPlacement {
        presentation: presentation.to_string(),
        xy: [x, y],
        yaw_deg: 0.0,
        z: None,
    };
    let twice = scene
        .with_objects(vec![
            at("red_block", 0.5, 0.0),
            at("jif", 0.5, 0.15),
            at("red_block", 0.7, 0.0),
        ])
        .unwrap();
    let labels: Vec<&str> = twice.resolved.iter().map(|r| r.label.as_str()).collect();
    assert_eq!(labels, ["red_block#1", "jif", "red_block#2"]);
    assert_eq!(twice.object_index("red_block").unwrap(), 0);
    assert_eq!(twice.object_index("red_block#2").unwrap(), 2);
    assert!(twice.object_index("red_block#3").is_err() && twice.object_index("red_block#0").is_err());

    assert!(
        matches!(Scene::builtin("sortnig"), Err(SimError::Unknown { kind: "built-in scene", candidates, .. }) if candidates[0] == "sorting")
    );
}

#[test]
fn stacking_needs_an_explicit_height_and_is_then_allowed() {
    let base = builtin("pick-place");
    let block = |z: Option<f64>| ObjectPlacement {
        presentation: "red_block".into(),
        xy: [0.6, 0.0],
        yaw_deg: 0.0,
        z,
    };
    assert!(base.with_objects(vec![block(None), block(None)]).is_err());
    let stacked = base
        .with_objects(vec![block(None), block(Some(0.75 + 0.05 + 0.025 + 0.002))])
        .unwrap();
    assert!((stacked.resolved[1].pose.translation.z - 0.827).abs() < 1e-12);
}

// ---------------------------------------------------------------------------------------------
// Bad input
// ---------------------------------------------------------------------------------------------

const CATALOG: &str = r#"
version = 1

[[objects]]
name = "can"
shape = { kind = "cylinder", radius = 0.03, height = 0.1 }
mass = 0.2
colors = [{ hsv = [0, 0.9, 0.8], fraction = 0.7 }, { hsv = [0, 0.0, 1.0], fraction = 0.3 }]

[[objects.presentations]]
name = "can-1"
rpy_deg = [90, 0, 0]

[[objects]]
name = "block"
shape = { kind = "box", size = [0.05, 0.05, 0.05] }
mass = 0.07
size_class = "small"
colors = [{ hsv = [220, 0.8, 0.7], fraction = 1 }]
"#;

const CATALOG_FILE: &str = "inline/catalog.toml";

fn catalog(text: &str) -> Result<Catalog, SimError> {
    Catalog::from_toml_str(text, Path::new(CATALOG_FILE))
}

const SCENE: &str = r#"
version = 1
name = "test"
catalog = "builtin:household"

[table]
height = 0.75
center = [0.6, 0.0]
size = [0.6, 1.4]

[[places]]
name = "bin-left"
center = [0.55, 0.45]
size = [0.2, 0.25]
wall_height = 0.06

[[objects]]
presentation = "jif"
xy = [0.5, 0.0]

[[objects]]
presentation = "blue_mug"
xy = [0.5, -0.15]

[camera]
width = 160
height = 120
hfov_deg = 60
rate_hz = 10
"#;

const SCENE_FILE: &str = "inline/scene.toml";

fn scene(text: &str) -> Result<Scene, SimError> {
    Scene::from_toml_str(text, SCENE_FILE)
}

#[test]
fn the_inline_fixtures_are_valid() {
    let c = catalog(CATALOG).unwrap();
    assert_eq!(c.objects[0].friction, 0.9, "default friction");
    assert_eq!(c.presentation_names(), ["can", "can-1", "block"]);
    let s = scene(SCENE).unwrap();
    assert_eq!(s.resolved.len(), 2);
}

#[test]
fn unknown_shape_kind_names_the_known_kinds() {
    let path = data("bad-shape-kind.toml");
    let e = Catalog::load(&path).unwrap_err();
    assert_parse(
        &e,
        "bad-shape-kind.toml",
        &["torus", "box", "cylinder", "sphere", "capsule", "line 6"],
    );
}

#[test]
fn malformed_toml_is_a_parse_error_with_line() {
    let e = Catalog::load(data("bad-syntax.toml")).unwrap_err();
    assert_parse(&e, "bad-syntax.toml", &["line 7", "mass"]);
    let e = scene("version = 1\nname = \"x\"\ncatalog = \"builtin:household\"\n[table\n").unwrap_err();
    assert_parse(&e, SCENE_FILE, &["line 4"]);
}

#[test]
fn unknown_and_mistyped_fields_are_parse_errors_naming_the_key() {
    let e = catalog(&edit(CATALOG, "mass = 0.2", "mass = 0.2\nweight = 0.2")).unwrap_err();
    assert_parse(&e, CATALOG_FILE, &["weight"]);
    let e = catalog(&edit(CATALOG, "radius = 0.03", "radious = 0.03")).unwrap_err();
    assert_parse(&e, CATALOG_FILE, &["radious"]);
    let e = catalog(&edit(CATALOG, "mass = 0.2", "mass = \"heavy\"")).unwrap_err();
    assert_parse(&e, CATALOG_FILE, &["mass", "line 7"]);
    let e = scene(&edit(SCENE, "xy = [0.5, 0.0]", "xy = [0.5]")).unwrap_err();
    assert_parse(&e, SCENE_FILE, &["xy"]);
    let e = scene(&edit(SCENE, "width = 160", "width = -160")).unwrap_err();
    assert_parse(&e, SCENE_FILE, &["width"]);
}

#[test]
fn negative_size_names_the_field() {
    let e = Catalog::load(data("bad-negative-size.toml")).unwrap_err();
    assert_invalid(
        &e,
        "bad-negative-size.toml",
        "objects[1].shape.radius",
        &["must be > 0", "-0.02", "can"],
    );
    let e = catalog(&edit(CATALOG, "size = [0.05, 0.05, 0.05]", "size = [0.05, 0.0, 0.05]")).unwrap_err();
    assert_invalid(&e, CATALOG_FILE, "objects[1].shape.size[1]", &["must be > 0"]);
    let e = catalog(&edit(CATALOG, "height = 0.1", "height = -1")).unwrap_err();
    assert_invalid(&e, CATALOG_FILE, "objects[0].shape.height", &["-1"]);
    let e = catalog(&edit(CATALOG, "mass = 0.07", "mass = 0")).unwrap_err();
    assert_invalid(&e, CATALOG_FILE, "objects[1].mass", &["> 0"]);
    let e = catalog(&edit(CATALOG, "mass = 0.2", "mass = 0.2\nfriction = -0.5")).unwrap_err();
    assert_invalid(&e, CATALOG_FILE, "objects[0].friction", &["> 0"]);
}

#[test]
fn a_bad_catalog_behind_a_scene_is_reported_in_the_catalog_file() {
    let e = Scene::load(data("bad-scene-catalog.toml")).unwrap_err();
    assert_invalid(&e, "bad-negative-size.toml", "objects[1].shape.radius", &[]);
    let e = scene(&edit(SCENE, "builtin:household", "no-such-catalog.toml")).unwrap_err();
    assert_invalid(&e, SCENE_FILE, "catalog", &["cannot read", "no-such-catalog.toml"]);
    let e = Scene::load(data("no-such-scene.toml")).unwrap_err();
    assert!(
        matches!(e, SimError::Io { .. }) && e.to_string().contains("no-such-scene.toml"),
        "{e}"
    );
}

#[test]
fn nan_and_infinity_are_rejected() {
    let e = catalog(&edit(CATALOG, "mass = 0.2", "mass = nan")).unwrap_err();
    assert_invalid(&e, CATALOG_FILE, "objects[0].mass", &["finite", "NaN"]);
    let e = catalog(&edit(CATALOG, "rpy_deg = [90, 0, 0]", "rpy_deg = [90, inf, 0]")).unwrap_err();
    assert_invalid(&e, CATALOG_FILE, "objects[0].presentations[0].rpy_deg[1]", &["inf"]);
    let e = scene(&edit(SCENE, "xy = [0.5, 0.0]", "xy = [nan, 0.0]")).unwrap_err();
    assert_invalid(&e, SCENE_FILE, "objects[0].xy[0]", &["NaN"]);
    let e = scene(&edit(SCENE, "xy = [0.5, 0.0]", "xy = [0.5, 0.0]\nyaw_deg = -inf")).unwrap_err();
    assert_invalid(&e, SCENE_FILE, "objects[0].yaw_deg", &["-inf"]);
    let e = scene(&edit(SCENE, "height = 0.75", "height = nan")).unwrap_err();
    assert_invalid(&e, SCENE_FILE, "table.height", &["NaN"]);
    let e = scene(&edit(
        SCENE,
        "rate_hz = 10",
        "rate_hz = 10\n[light]\ndirection = [0, nan, -1]",
    ))
    .unwrap_err();
    assert_invalid(&e, SCENE_FILE, "light.direction[1]", &["NaN"]);
}

#[test]
fn colour_patches_are_checked() {
    let e = catalog(&edit(CATALOG, "fraction = 0.3", "fraction = 0.2")).unwrap_err();
    assert_invalid(&e, CATALOG_FILE, "objects[0].colors", &["sum to 1", "0.9"]);
    let e = catalog(&edit(CATALOG, "fraction = 0.7", "fraction = 0")).unwrap_err();
    assert_invalid(&e, CATALOG_FILE, "objects[0].colors[0].fraction", &["(0, 1]"]);
    let e = catalog(&edit(CATALOG, "hsv = [220, 0.8, 0.7]", "hsv = [360, 0.8, 0.7]")).unwrap_err();
    assert_invalid(&e, CATALOG_FILE, "objects[1].colors[0].hsv[0]", &["hue", "360"]);
    let e = catalog(&edit(CATALOG, "hsv = [220, 0.8, 0.7]", "hsv = [220, 1.5, 0.7]")).unwrap_err();
    assert_invalid(&e, CATALOG_FILE, "objects[1].colors[0].hsv[1]", &["saturation"]);
    let e = catalog(&edit(
        CATALOG,
        "colors = [{ hsv = [220, 0.8, 0.7], fraction = 1 }]",
        "colors = []",
    ))
    .unwrap_err();
    assert_invalid(&e, CATALOG_FILE, "objects[1].colors", &["at least one"]);
    let e = catalog(&edit(CATALOG, "size_class = \"small\"", "size_class = \"huge\"")).unwrap_err();
    assert_invalid(
        &e,
        CATALOG_FILE,
        "objects[1].size_class",
        &["huge", "small, medium, large"],
    );
    let e = scene(&edit(
        SCENE,
        "size = [0.6, 1.4]",
        "size = [0.6, 1.4]\nhsv = [30, 0.2, -0.1]",
    ))
    .unwrap_err();
    assert_invalid(&e, SCENE_FILE, "table.hsv[2]", &["value"]);
}

#[test]
fn duplicate_names_are_rejected_naming_both() {
    let e = catalog(&edit(CATALOG, "name = \"block\"", "name = \"can\"")).unwrap_err();
    assert_invalid(
        &e,
        CATALOG_FILE,
        "objects[1].name",
        &["duplicate", "`can`", "objects[0].name"],
    );
    let e = catalog(&edit(CATALOG, "name = \"block\"", "name = \"can-1\"")).unwrap_err();
    assert_invalid(
        &e,
        CATALOG_FILE,
        "objects[1].name",
        &["objects[0].presentations[0].name"],
    );
    let e = catalog(&edit(CATALOG, "name = \"block\"", "name = \"my block\"")).unwrap_err();
    assert_invalid(&e, CATALOG_FILE, "objects[1].name", &["contains ` `"]);
    let second_bin = "[[places]]\nname = \"bin-left\"\ncenter = [0.55, -0.45]\nsize = [0.2, 0.25]\n\n[[objects]]";
    let e = scene(&edit(SCENE, "[[objects]]", second_bin)).unwrap_err();
    assert_invalid(&e, SCENE_FILE, "places[1].name", &["duplicate", "places[0].name"]);
}

#[test]
fn wrong_version_is_reported_before_anything_else() {
    let e = Scene::load(data("bad-version.toml")).unwrap_err();
    assert_invalid(
        &e,
        "bad-version.toml",
        "version",
        &["unsupported format version 2", "version 1"],
    );
    let e = catalog(&edit(CATALOG, "version = 1", "version = 0")).unwrap_err();
    assert_invalid(&e, CATALOG_FILE, "version", &["version 0"]);
    let e = catalog(&edit(CATALOG, "version = 1", "")).unwrap_err();
    assert_parse(&e, CATALOG_FILE, &["version"]);
}

#[test]
fn overlapping_objects_are_rejected_naming_both() {
    let e = Scene::load(data("bad-overlap.toml")).unwrap_err();
    assert_invalid(
        &e,
        "bad-overlap.toml",
        "objects[1].xy",
        &["`blue_mug`", "`jif`", "objects[0]", "overlaps"],
    );
    // Oriented footprints: two long boxes side by side do not overlap, rotated into each other they do.
    let boxes = edit(
        SCENE,
        "presentation = \"blue_mug\"\nxy = [0.5, -0.15]",
        "presentation = \"blue_cereal\"\nxy = [0.5, -0.15]",
    );
    let boxes = edit(
        &boxes,
        "presentation = \"jif\"\nxy = [0.5, 0.0]",
        "presentation = \"blue_cereal\"\nxy = [0.5, -0.06]",
    );
    let apart = scene(&boxes).unwrap();
    assert!((apart.object_gap(0, 1).unwrap() - 0.04).abs() < 1e-9);
    let e = scene(&edit(&boxes, "xy = [0.5, -0.06]", "xy = [0.5, -0.06]\nyaw_deg = 90")).unwrap_err();
    assert_invalid(
        &e,
        SCENE_FILE,
        "objects[1].xy",
        &["`blue_cereal` (objects[1]) overlaps `blue_cereal` (objects[0]) by 0.5 cm"],
    );
}

#[test]
fn objects_outside_or_under_the_table_are_rejected() {
    let e = scene(&edit(SCENE, "xy = [0.5, 0.0]", "xy = [1.2, 0.0]")).unwrap_err();
    assert_invalid(&e, SCENE_FILE, "objects[0].xy", &["extends past the table", "jif"]);
    let e = scene(&edit(SCENE, "xy = [0.5, 0.0]", "xy = [0.89, 0.0]")).unwrap_err();
    assert_invalid(&e, SCENE_FILE, "objects[0].xy", &["extends past the table"]);
    let e = Scene::load(data("bad-under-table.toml")).unwrap_err();
    assert_invalid(
        &e,
        "bad-under-table.toml",
        "objects[0].z",
        &["under the table", "0.5", "0.75"],
    );
    let e = scene(&edit(SCENE, "xy = [0.5, 0.0]", "xy = [0.5, 0.0]\nz = 0.78")).unwrap_err();
    assert_invalid(&e, SCENE_FILE, "objects[0].z", &["into the table"]);
    let dropped = scene(&edit(SCENE, "xy = [0.5, 0.0]", "xy = [0.5, 0.0]\nz = 0.9")).unwrap();
    assert_eq!(dropped.resolved[0].pose.translation.z, 0.9);
}

#[test]
fn objects_on_a_bin_and_places_off_the_table_are_rejected() {
    let e = scene(&edit(SCENE, "xy = [0.5, 0.0]", "xy = [0.55, 0.3]")).unwrap_err();
    assert_invalid(
        &e,
        SCENE_FILE,
        "objects[0].xy",
        &["overlaps place `bin-left`", "places[0]"],
    );
    let e = scene(&edit(SCENE, "center = [0.55, 0.45]", "center = [0.55, 0.62]")).unwrap_err();
    assert_invalid(
        &e,
        SCENE_FILE,
        "places[0].center",
        &["bin-left", "extends past the table"],
    );
    let e = scene(&edit(SCENE, "wall_height = 0.06", "wall_height = -0.06")).unwrap_err();
    assert_invalid(&e, SCENE_FILE, "places[0].wall_height", &["[0, 0.5] m"]);
    let second_bin = "[[places]]\nname = \"bin-b\"\ncenter = [0.55, 0.3]\nsize = [0.2, 0.25]\n\n[[objects]]";
    let e = scene(&edit(SCENE, "[[objects]]", second_bin)).unwrap_err();
    assert_invalid(
        &e,
        SCENE_FILE,
        "places[1].center",
        &["`bin-b` overlaps place `bin-left`"],
    );
}

#[test]
fn unknown_presentation_lists_the_closest_names() {
    let e = scene(&edit(SCENE, "presentation = \"jif\"", "presentation = \"jiff\"")).unwrap_err();
    assert_invalid(
        &e,
        SCENE_FILE,
        "objects[0].presentation",
        &["unknown presentation `jiff`", "`jif`", "builtin:household"],
    );
}

#[test]
fn camera_and_light_are_checked() {
    for (from, to, field) in [
        ("width = 160", "width = 0", "camera.width"),
        ("height = 120", "height = 5000", "camera.height"),
        ("hfov_deg = 60", "hfov_deg = 1", "camera.hfov_deg"),
        ("hfov_deg = 60", "hfov_deg = 175", "camera.hfov_deg"),
        ("rate_hz = 10", "rate_hz = 0", "camera.rate_hz"),
        ("rate_hz = 10", "rate_hz = 10\npixel_noise = 2", "camera.pixel_noise"),
        (
            "rate_hz = 10",
            "rate_hz = 10\n[light]\ndirection = [0, 0, 0]",
            "light.direction",
        ),
        ("rate_hz = 10", "rate_hz = 10\n[light]\nambient = 1.5", "light.ambient"),
    ] {
        let e = scene(&edit(SCENE, from, to)).unwrap_err();
        assert_invalid(&e, SCENE_FILE, field, &[]);
    }
}

#[test]
fn no_input_makes_the_loaders_panic() {
    // Every prefix of the shipped texts, and every number in them replaced by awkward values.
    let scene_text = std::fs::read_to_string(repo().join("assets/scenes/sorting.toml")).unwrap();
    let catalog_text = std::fs::read_to_string(repo().join("assets/objects/household.toml")).unwrap();
    let cut = |text: &str, step: usize| -> Vec<String> {
        (0..text.len())
            .step_by(step)
            .filter(|&i| text.is_char_boundary(i))
            .map(|i| text[..i].to_string())
            .collect()
    };
    for t in cut(&scene_text, 7) {
        let _ = Scene::from_toml_str(&t, "prefix.toml");
    }
    for t in cut(&catalog_text, 101) {
        let _ = Catalog::from_toml_str(&t, Path::new("prefix.toml"));
    }
    let numbers: Vec<(usize, usize)> = {
        let bytes = scene_text.as_bytes();
        let mut spans = Vec::new();
        let mut i = 0;
        while i < bytes.len() {
            if bytes[i].is_ascii_digit() {
                let start = i;
                while i < bytes.len() && (bytes[i].is_ascii_digit() || bytes[i] == b'.') {
                    i += 1;
                }
                spans.push((start, i));
            }
            i += 1;
        }
        spans
    };
    for (start, end) in numbers {
        for awkward in ["0", "-1", "1e308", "-0.0", "nan", "inf", "4294967296", "\"x\"", "[]"] {
            let t = format!("{}{awkward}{}", &scene_text[..start], &scene_text[end..]);
            let _ = Scene::from_toml_str(&t, "awkward.toml");
        }
    }
}

/// toml's error text quotes the source over several lines; `pbd` prints one `error:` line
/// (issue 18's bad-input sweep found the multi-line ones).
#[test]
fn toml_errors_are_one_line_with_line_column_and_source() {
    for text in [
        "[[[ = = ]]]",
        "",
        "version = 1\nmass = \"heavy\"\n",
        "version = 1\n[table\n",
    ] {
        let e = Scene::from_toml_str(text, "s.toml").unwrap_err().to_string();
        assert_eq!(e.lines().count(), 1, "{e}");
        let e = Catalog::from_toml_str(text, Path::new("c.toml"))
            .unwrap_err()
            .to_string();
        assert_eq!(e.lines().count(), 1, "{e}");
    }
    let e = Scene::from_toml_str("version = 1\nseed = \"x\"\n", "s.toml").unwrap_err();
    assert_parse(&e, "s.toml", &["line 2", "seed"]);
}

/// Issue 38: every number of a scene lies in a physically meaningful range (`SCENE_RANGES`), and
/// the scene's name holds no control characters — absurd values were accepted (a 1e300 bin wall
/// then failed inside the physics engine).
#[test]
fn absurd_numbers_and_names_are_refused_naming_the_field() {
    for (from, to, field, words) in [
        ("height = 0.75", "height = 1e-300", "table.height", "[0.1, 2] m"),
        (
            "wall_height = 0.06",
            "wall_height = 1e300",
            "places[0].wall_height",
            "[0, 0.5] m",
        ),
        ("rate_hz = 10", "rate_hz = 1e300", "camera.rate_hz", "[0.1, 1000] Hz"),
        (
            "xy = [0.5, 0.0]",
            "xy = [0.5, 0.0]\nyaw_deg = 1e300",
            "objects[0].yaw_deg",
            "[-360, 360]",
        ),
        (
            "xy = [0.5, 0.0]",
            "xy = [0.5, 0.0]\nz = 1e6",
            "objects[0].z",
            "[0, 2] m",
        ),
        (
            "name = \"test\"",
            "name = \"te\\u001bst\"",
            "name",
            "control characters",
        ),
    ] {
        let e = scene(&edit(SCENE, from, to)).unwrap_err();
        assert_invalid(&e, SCENE_FILE, field, &[words]);
    }
}

/// Issue 38: a scene given as a catalog, and an unknown built-in catalog, are named as such.
#[test]
fn a_scene_as_a_catalog_and_an_unknown_builtin_catalog_are_named() {
    let e = Catalog::from_toml_str(SCENE, Path::new("inline/catalog.toml")).unwrap_err();
    assert_parse(&e, "inline/catalog.toml", &["scene file", "not an object catalog"]);
    let e = scene(&edit(
        SCENE,
        "catalog = \"builtin:household\"",
        "catalog = \"builtin:nope\"",
    ))
    .unwrap_err();
    assert_invalid(&e, SCENE_FILE, "catalog", &["no built-in catalog `nope`"]);
}
