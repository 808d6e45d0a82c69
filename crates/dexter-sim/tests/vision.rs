//! Stereo vision acceptance tests: rendering, background subtraction, features, matching and
//! triangulation on Dexter's head cameras looking at the table. Run in release mode
//! (`cargo test --release -p dexter-sim --test vision`); everything is deterministic.

use bayes::rng::Draw;
use control_basis::math::{Iso3, Vec3};
use dexter_sim::geometry::bounding_radius;
use dexter_sim::scene::{CameraSpec, LightSpec, Shape};
use dexter_sim::vision::fixtures::*;
use dexter_sim::vision::*;

/// Counts heap allocations per thread, to check that the pipeline reuses its buffers.
struct CountingAlloc;

thread_local! {
    static ALLOCATIONS: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
}

// SAFETY: forwards to the system allocator; only counts.
#[allow(unsafe_code)]
unsafe impl std::alloc::GlobalAlloc for CountingAlloc {
    unsafe fn alloc(&self, layout: std::alloc::Layout) -> *mut u8 {
        let _ = ALLOCATIONS.try_with(|c| c.set(c.get() + 1));
        // SAFETY: same contract as the caller's.
        unsafe { std::alloc::System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: std::alloc::Layout) {
        // SAFETY: same contract as the caller's.
        unsafe { std::alloc::System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: std::alloc::Layout, new_size: usize) -> *mut u8 {
        let _ = ALLOCATIONS.try_with(|c| c.set(c.get() + 1));
        // SAFETY: same contract as the caller's.
        unsafe { std::alloc::System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: CountingAlloc = CountingAlloc;

fn allocations() -> usize {
    ALLOCATIONS.with(|c| c.get())
}

fn default_cams(spec: &CameraSpec) -> StereoCameras {
    head_cameras(spec, Vec3::from(TABLE_FIXATION)).unwrap()
}

/// The ground-truth item label covering most pixels of `seg` in the image of `side`.
fn truth_of(sv: &StereoVision, side: Side, seg_index: usize) -> Option<ItemLabel> {
    let labels = sv.renderer(side).labels();
    let comp = sv.segmenter(side).component_map();
    let mut counts: Vec<(ItemLabel, usize)> = Vec::new();
    for (l, &c) in labels.iter().zip(comp) {
        if c as usize == seg_index + 1
            && let Some(l) = l
        {
            match counts.iter_mut().find(|(k, _)| k == l) {
                Some((_, n)) => *n += 1,
                None => counts.push((*l, 1)),
            }
        }
    }
    counts.into_iter().max_by_key(|&(_, n)| n).map(|(l, _)| l)
}

fn count_label(sv: &StereoVision, side: Side, label: ItemLabel) -> usize {
    sv.renderer(side).labels().iter().filter(|l| **l == Some(label)).count()
}

/// One randomly drawn object (box, cylinder or sphere of 4–14 cm, 1–3 colour bands) alone on the
/// table at x 0.4–0.8, y −0.25–0.25.
struct Trial {
    kind: &'static str,
    shape: Shape,
    truth: Vec3,
    blobs: Vec<StereoBlob>,
    /// Ground-truth visible pixels of the object (left, right).
    visible: (usize, usize),
}

fn single_object_trials(spec: &CameraSpec, config: StereoConfig, n: usize) -> Vec<Trial> {
    let cams = default_cams(spec);
    let mut sv = StereoVision::new(spec, &LightSpec::default(), 7).unwrap();
    sv.set_config(config);
    let base = table_and_bins();
    let mut scene = base.clone();
    let mut out = Vec::with_capacity(n);
    for k in 0..n {
        let mut rng = bayes::rng::seeded(1000 + k as u64);
        let (shape, colors) = random_object(&mut rng);
        let x = 0.4 + 0.4 * rng.uniform();
        let y = -0.25 + 0.5 * rng.uniform();
        let pose = resting_pose(&shape, x, y, rng.uniform() * std::f64::consts::PI);
        scene.items.truncate(base.items.len());
        scene.push(RenderItem::from_catalog(&shape, pose, &colors, ItemLabel::Object(0)));
        let blobs = sv.perceive(&cams, &scene).unwrap();
        let visible = (
            count_label(&sv, Side::Left, ItemLabel::Object(0)),
            count_label(&sv, Side::Right, ItemLabel::Object(0)),
        );
        let kind = match shape {
            Shape::Box { .. } => "box",
            Shape::Cylinder { .. } => "cylinder",
            _ => "sphere",
        };
        out.push(Trial {
            kind,
            shape,
            truth: pose.translation.vector,
            blobs,
            visible,
        });
    }
    out
}

struct ErrorStats {
    n: usize,
    mean: f64,
    p90: f64,
    max: f64,
    within_1cm: usize,
}

fn error_stats(errs: &mut [f64]) -> ErrorStats {
    errs.sort_by(f64::total_cmp);
    let n = errs.len();
    ErrorStats {
        n,
        mean: errs.iter().sum::<f64>() / n as f64,
        p90: errs[(n * 9 / 10).min(n - 1)],
        max: errs[n - 1],
        within_1cm: errs.iter().filter(|&&e| e <= 0.01).count(),
    }
}

fn centroid_errors(trials: &[Trial]) -> Vec<(&'static str, f64)> {
    trials
        .iter()
        .map(|t| {
            let both: Vec<_> = t.blobs.iter().filter(|b| b.visibility == Visibility::Both).collect();
            assert_eq!(
                both.len(),
                1,
                "{} {:?}: {:?}",
                t.kind,
                t.shape,
                t.blobs.iter().map(|b| b.visibility).collect::<Vec<_>>()
            );
            assert_eq!(t.blobs.len(), 1);
            (t.kind, (both[0].centroid.unwrap() - t.truth).norm())
        })
        .collect()
}

fn report(label: &str, errs: &[(&'static str, f64)]) -> ErrorStats {
    let mut all: Vec<f64> = errs.iter().map(|e| e.1).collect();
    let s = error_stats(&mut all);
    let mut line = format!(
        "{label}: n {} mean {:.1} mm, p90 {:.1} mm, max {:.1} mm, within 1 cm {}/{}",
        s.n,
        1e3 * s.mean,
        1e3 * s.p90,
        1e3 * s.max,
        s.within_1cm,
        s.n
    );
    for kind in ["box", "cylinder", "sphere"] {
        let mut v: Vec<f64> = errs.iter().filter(|e| e.0 == kind).map(|e| e.1).collect();
        if !v.is_empty() {
            let k = error_stats(&mut v);
            line += &format!("; {kind} ×{} mean {:.1} max {:.1}", k.n, 1e3 * k.mean, 1e3 * k.max);
        }
    }
    eprintln!("{line}");
    s
}

/// The stereo settings for objects on the table: the known table plane enables the support-plane
/// centroid ([`dexter_sim::vision::support`]).
fn on_table() -> StereoConfig {
    StereoConfig {
        support: Some(SupportPlane::at(TABLE_TOP)),
        ..StereoConfig::default()
    }
}

/// Centroids against the true centroids of 96 random objects (boxes, cylinders and spheres of
/// 4–14 cm with 1–3 colour bands, random yaw) alone on the table at x 0.4–0.8 m, y −0.25–0.25 m:
/// every one within 1 cm (the acceptance of issue 3).
///
/// Measured (mean / p90 / max, within 1 cm):
///
/// | cameras | triangulated silhouette centroid | support-plane centroid (default on the table) |
/// |---|---|---|
/// | 160×120, hfov 60° (default) | 4.5 / 8.4 / 13.1 mm, 90/96 | 1.3 / 2.6 / 4.0 mm, 96/96 |
/// | 320×240 | 2.8 / 6.5 / 11.2 mm, 95/96 | 0.7 / 1.4 / 1.9 mm, 96/96 |
/// | 640×480 | 2.6 / 6.1 / 11.8 mm, 94/96 | 0.4 / 0.7 / 1.2 mm, 96/96 |
///
/// Over 500 objects at 160×120 the support-plane centroid is within 1 cm for all (mean 1.3 mm,
/// max 6.4 mm; boxes 1.6 / 4.8, cylinders 1.6 / 6.3, spheres 0.7 / 2.6 mm); at 320×240 and
/// 640×480 max 2.6 and 2.0 mm.
///
/// Why the triangulated centroid is not enough: 93 % of its error lies along the viewing ray. At
/// 160×120 one pixel of disparity is about 5 cm of range, and the centroid disparity of a small or
/// tall segment is off by a few tenths of a pixel (edge quantisation; the two cameras see different
/// faces and perspective magnifies the nearer ones, so the two silhouette-centroid rays do not
/// pass through one 3-D point). Resolution stops helping beyond 320×240: the remaining error is
/// geometric. Intersecting the centroid rays with the plane at the true centroid height instead
/// gives 1.7 mm mean, 6.0 mm max (what is left is the silhouette centroid's sideways bias); the
/// support-plane estimate measures that height from the images (the step between side and top
/// face above each bottom-edge point for boxes and cylinders, the apparent radius for round
/// objects) and takes x, y of a prism from its footprint (the prism hull of both silhouettes):
/// without the footprint it measured 2.1 / 4.9 / 7.6 mm at 160×120.
///
/// Rejected: pushing the point back along the viewing direction (`DepthCorrection::PushBack`,
/// 0.3 × the apparent radius: mean 15.6 mm, 20/96 within 1 cm); the step heights without the
/// round/flat-top test (spheres with colour bands show steps at band edges: mean 11.6 mm, max 63 mm).
#[test]
fn triangulated_centroid_accuracy() {
    let spec = CameraSpec::default();
    let trials = single_object_trials(&spec, on_table(), 96);
    let errors = centroid_errors(&trials);
    let s = report("160×120 hfov 60°, support plane", &errors);
    assert!(s.mean < 0.002, "mean {}", s.mean);
    assert_eq!(s.within_1cm, s.n, "every object within 1 cm: max {}", s.max);
    // Boxes and cylinders are measured as prisms, spheres as round, all on the table.
    for t in &trials {
        let b = t.blobs.iter().find(|b| b.visibility == Visibility::Both).unwrap();
        let ok = match (t.kind, b.source) {
            ("sphere", CentroidSource::Round { radius }) => (radius - (t.truth.z - TABLE_TOP)).abs() < 0.005,
            (_, CentroidSource::Prism { height }) => (0.5 * height - (t.truth.z - TABLE_TOP)).abs() < 0.01,
            _ => false,
        };
        assert!(ok, "{} {:?}: {:?}", t.kind, t.shape, b.source);
    }

    // The comparisons below take a minute unoptimised; the acceptance tests run in release.
    if cfg!(debug_assertions) {
        return;
    }
    let raw = report(
        "160×120 hfov 60°, triangulated (no support plane)",
        &centroid_errors(&single_object_trials(&spec, StereoConfig::default(), 96)),
    );
    assert!(raw.mean > s.mean && raw.within_1cm < raw.n);
    let push = StereoConfig {
        depth_correction: DepthCorrection::PushBack { factor: 0.3 },
        ..StereoConfig::default()
    };
    let p = report(
        "160×120 hfov 60°, push back 0.3 r",
        &centroid_errors(&single_object_trials(&spec, push, 96)),
    );
    assert!(p.mean > raw.mean, "push-back should not help silhouette triangulation");

    for (w, h) in [(320, 240), (640, 480)] {
        let hi = CameraSpec {
            width: w,
            height: h,
            ..CameraSpec::default()
        };
        let r = report(
            &format!("{w}×{h} hfov 60°, support plane"),
            &centroid_errors(&single_object_trials(&hi, on_table(), 96)),
        );
        assert!(r.mean < 0.0015 && r.max < 0.005, "mean {} max {}", r.mean, r.max);
    }
}

/// The support-plane estimate is not used where its premises fail: an object lifted off the table
/// (held by the hand) or standing in a bin keeps its triangulated centroid.
#[test]
fn support_plane_only_for_objects_on_the_table() {
    let spec = CameraSpec::default();
    let cams = default_cams(&spec);
    let mut sv = StereoVision::new(&spec, &LightSpec::default(), 5).unwrap();
    sv.set_config(on_table());
    let shape = Shape::Box {
        size: [0.06, 0.05, 0.1],
    };
    let red = dexter_sim::scene::ColorPatch {
        hsv: [0.0, 0.8, 0.8],
        fraction: 1.0,
    };
    for lift in [0.0, 0.12] {
        let mut scene = table_and_bins();
        let mut pose = resting_pose(&shape, 0.6, 0.05, 0.4);
        pose.translation.vector.z += lift;
        scene.push(RenderItem::from_catalog(
            &shape,
            pose,
            std::slice::from_ref(&red),
            ItemLabel::Object(0),
        ));
        let blobs = sv.perceive(&cams, &scene).unwrap();
        assert_eq!(blobs.len(), 1);
        let b = blobs[0];
        let e = (b.centroid.unwrap() - pose.translation.vector).norm();
        eprintln!("lifted {lift} m: {:?}, error {:.1} mm", b.source, 1e3 * e);
        if lift == 0.0 {
            assert!(matches!(b.source, CentroidSource::Prism { .. }) && e < 0.01);
        } else {
            assert_eq!(b.source, CentroidSource::Triangulated);
            assert_eq!(b.centroid, b.raw_centroid);
        }
    }
}

/// Left and right segments of one object agree in size and colour.
///
/// Measured over the 96 single-object trials at 160×120: pixel-count ratio smaller/larger ≥ 0.875
/// (all within 12.5 %; median 0.95), histogram intersection ≥ 0.81 (median 0.95) with the objects
/// the SplitMix generator drew; the 96 objects xoshiro256++ draws (issue 15) give a minimum of 0.75
/// (median 0.95), one object whose two faces the cameras see differently. Deviations come
/// from perspective: each camera sees other faces (§5.1.2.2: "Deviations from diagonal in this plot
/// are caused by perspective distortion of the object in the stereo image"). Shading also moves
/// pixels across V-bin boundaries.
#[test]
fn left_and_right_features_agree() {
    let trials = single_object_trials(&CameraSpec::default(), StereoConfig::default(), 96);
    let mut ratios = Vec::new();
    let mut inters = Vec::new();
    for t in &trials {
        let b = t
            .blobs
            .iter()
            .find(|b| b.visibility == Visibility::Both)
            .expect("seen by both");
        let (l, r) = (b.left.unwrap().features, b.right.unwrap().features);
        // Segmentation is complete: the segment is the object's visible pixels, up to pixel noise
        // (an object pixel whose noisy colour falls within the background's threshold is lost):
        // at most one pixel or 1 % per camera.
        for (got, visible) in [(l.pixel_count, t.visible.0), (r.pixel_count, t.visible.1)] {
            let off = (got as f64 - visible as f64).abs();
            assert!(
                off <= (0.01 * visible as f64).max(1.0),
                "{} {:?}: {got} of {visible} visible pixels",
                t.kind,
                t.shape
            );
        }
        ratios.push(l.pixel_count.min(r.pixel_count) as f64 / l.pixel_count.max(r.pixel_count) as f64);
        inters.push(l.histogram.intersection(&r.histogram));
        // The size feature is in deci-pixels (§5.1.2.2).
        assert_eq!(l.deci_pixels(), l.pixel_count as f64 / 10.0);
        // The kept colours are a non-empty subset of the colours present.
        let kept = l.histogram.kept_mask();
        assert!(kept != 0);
        for bin in l.histogram.kept_bins() {
            assert!(l.histogram.counts[bin] > 0);
        }
        // Pixel noise may move a pixel across a bin boundary, so small bins exist; the rule drops them.
        let present = l.histogram.counts.iter().filter(|&&c| c > 0).count();
        assert!(l.histogram.kept_bins().count() <= present);
    }
    ratios.sort_by(f64::total_cmp);
    inters.sort_by(f64::total_cmp);
    let (rmin, rmed) = (ratios[0], ratios[ratios.len() / 2]);
    let (imin, imed) = (inters[0], inters[inters.len() / 2]);
    eprintln!(
        "pixel-count ratio min {rmin:.3} median {rmed:.3}; histogram intersection min {imin:.3} median {imed:.3}"
    );
    assert!(
        rmin >= 0.8 && rmed >= 0.93,
        "pixel counts differ by more than 20 %: {rmin}"
    );
    assert!(imin >= 0.7 && imed >= 0.9, "histogram intersection {imin} / {imed}");
}

/// The moments of a sphere's segment: centroid where the centre projects, isotropic covariance
/// whose trace matches a disk of the segment's area (σ² = A / 4π per axis), and a single hue.
#[test]
fn sphere_segment_moments_and_colour() {
    let spec = CameraSpec {
        width: 320,
        height: 240,
        ..CameraSpec::default()
    };
    let cams = default_cams(&spec);
    let mut scene = table_and_bins();
    let shape = Shape::Sphere { radius: 0.04 };
    let pose = resting_pose(&shape, 0.6, 0.0, 0.0);
    let red = dexter_sim::scene::ColorPatch {
        hsv: [0.0, 0.9, 0.8],
        fraction: 1.0,
    };
    scene.push(RenderItem::from_catalog(&shape, pose, &[red], ItemLabel::Object(0)));
    let mut sv = StereoVision::new(&spec, &LightSpec::default(), 1).unwrap();
    let blobs = sv.perceive(&cams, &scene).unwrap();
    assert_eq!(blobs.len(), 1);
    let f = blobs[0].left.unwrap().features;
    let (u, v) = cams.left.project(&pose.translation.vector).unwrap();
    assert!(
        (f.centroid[0] - u).abs() < 0.3 && (f.centroid[1] - v).abs() < 0.3,
        "{:?} vs {u} {v}",
        f.centroid
    );
    let c = f.covariance;
    let disk = f.pixel_count as f64 / (4.0 * std::f64::consts::PI);
    assert!(
        (c[0][0] - disk).abs() / disk < 0.1 && (c[1][1] - disk).abs() / disk < 0.1,
        "{c:?} vs {disk}"
    );
    assert!(c[0][1].abs() < 0.05 * disk);
    // Red: hue bin 0 (or 3 for hues just below 360° from noise), saturation bin 3.
    for bin in f.histogram.kept_bins() {
        assert!(bin / 16 == 0 || bin / 16 == 3, "bin {bin}");
        assert!((bin / 4) % 4 >= 2, "bin {bin}");
    }
    assert!(
        f.mean_hsv[1] > 0.7 && (f.mean_hsv[0] < 10.0 || f.mean_hsv[0] > 350.0),
        "{:?}",
        f.mean_hsv
    );
    // Colour terms: every pixel of the red sphere is red, or black/grey where shading darkens it.
    let red = usize::from(dexter::vision::color::color_term([0.0, 0.85, 0.85]));
    let total: u32 = f.color_terms.iter().sum();
    assert_eq!(total as usize, f.pixel_count);
    assert!(f.color_terms[red] as f64 > 0.6 * total as f64, "{:?}", f.color_terms);
    for (t, &n) in f.color_terms.iter().enumerate() {
        assert!(n == 0 || [0, 1, 2, red].contains(&t), "term {t}: {n} pixels");
    }
    // §6.2.1 appearance feature: average of left and right second moments.
    let m = blobs[0].mean_covariance();
    let r = blobs[0].right.unwrap().features.covariance;
    assert!((m[0][0] - 0.5 * (c[0][0] + r[0][0])).abs() < 1e-12);
}

/// An object hidden from one camera by a tall static box is reported by the other camera only.
#[test]
fn occluded_from_one_camera_is_one_sided() {
    let spec = CameraSpec::default();
    let cams = default_cams(&spec);
    let cube = Shape::Box {
        size: [0.04, 0.04, 0.04],
    };
    let green = dexter_sim::scene::ColorPatch {
        hsv: [120.0, 0.8, 0.7],
        fraction: 1.0,
    };
    for (edge_side, expect) in [(-1.0, Visibility::LeftOnly), (1.0, Visibility::RightOnly)] {
        let mut scene = table_and_bins();
        // A 35 cm tall, 2 cm thick panel at x = 0.55 whose inner edge is at y = 0: it blocks the
        // rays from the camera on its side to an object at (0.8, 0) and not the other camera's.
        let (h, w) = (0.35, 0.25);
        scene.push(RenderItem::uniform_box(
            [0.02, w, h],
            Iso3::translation(0.55, edge_side * 0.5 * w, TABLE_TOP + 0.5 * h),
            [200.0, 0.1, 0.5],
            ItemLabel::Static,
        ));
        let pose = resting_pose(&cube, 0.8, 0.0, 0.3);
        scene.push(RenderItem::from_catalog(
            &cube,
            pose,
            std::slice::from_ref(&green),
            ItemLabel::Object(0),
        ));
        let mut sv = StereoVision::new(&spec, &LightSpec::default(), 3).unwrap();
        sv.set_config(on_table());
        let blobs = sv.perceive(&cams, &scene).unwrap();
        let (vl, vr) = (
            count_label(&sv, Side::Left, ItemLabel::Object(0)),
            count_label(&sv, Side::Right, ItemLabel::Object(0)),
        );
        eprintln!(
            "panel on {edge_side:+}: visible px left {vl} right {vr}; blobs {:?}",
            blobs.iter().map(|b| b.visibility).collect::<Vec<_>>()
        );
        assert_eq!(blobs.len(), 1);
        assert_eq!(blobs[0].visibility, expect);
        assert!(blobs[0].centroid.is_none() && blobs[0].raw_centroid.is_none());
        match expect {
            Visibility::LeftOnly => assert!(vl > 20 && vr == 0 && blobs[0].left.is_some() && blobs[0].right.is_none()),
            _ => assert!(vr > 20 && vl == 0 && blobs[0].right.is_some() && blobs[0].left.is_none()),
        }
    }
}

/// An object inside one camera's field of view and outside the other's is one-sided.
#[test]
fn outside_one_field_of_view_is_one_sided() {
    let spec = CameraSpec::default();
    let cams = default_cams(&spec);
    let cube = Shape::Box {
        size: [0.03, 0.03, 0.03],
    };
    let blue = dexter_sim::scene::ColorPatch {
        hsv: [230.0, 0.8, 0.7],
        fraction: 1.0,
    };
    let corners = |p: &Iso3| -> Vec<Vec3> {
        (0..8)
            .map(|k| {
                let c = Vec3::new(
                    if k & 1 == 0 { -0.015 } else { 0.015 },
                    if k & 2 == 0 { -0.015 } else { 0.015 },
                    if k & 4 == 0 { -0.015 } else { 0.015 },
                );
                p * nalgebra::Point3::from(c)
            })
            .map(|p| p.coords)
            .collect()
    };
    let mut found = [false, false];
    let mut seen = Vec::new();
    // Walk sideways along the table until the cube's centre is inside one image and all its
    // corners are outside the other. The verged cameras' fields cross: far to the left (+y) only
    // the right camera sees, far to the right only the left one.
    for (sign, x) in [
        (1.0, 0.6),
        (1.0, 0.7),
        (1.0, 0.8),
        (-1.0, 0.6),
        (-1.0, 0.7),
        (-1.0, 0.8),
    ] {
        if found[(sign < 0.0) as usize] {
            continue;
        }
        let si = (sign < 0.0) as usize;
        for step in 0..100 {
            let y = sign * (0.2 + 0.005 * step as f64);
            let pose = resting_pose(&cube, x, y, 0.0);
            let c = corners(&pose);
            let centre = pose.translation.vector;
            let outside = |cam: &Camera| c.iter().all(|p| cam.project(p).is_none());
            let expect = if cams.left.project(&centre).is_some() && outside(&cams.right) {
                Visibility::LeftOnly
            } else if cams.right.project(&centre).is_some() && outside(&cams.left) {
                Visibility::RightOnly
            } else {
                continue;
            };
            let mut scene = table_and_bins();
            scene.push(RenderItem::from_catalog(
                &cube,
                pose,
                std::slice::from_ref(&blue),
                ItemLabel::Object(0),
            ));
            let mut sv = StereoVision::new(&spec, &LightSpec::default(), 5).unwrap();
            let blobs = sv.perceive(&cams, &scene).unwrap();
            eprintln!(
                "cube at ({x}, {y:+.3}): {:?}",
                blobs.iter().map(|b| b.visibility).collect::<Vec<_>>()
            );
            assert_eq!(blobs.len(), 1);
            assert_eq!(blobs[0].visibility, expect);
            assert!(blobs[0].centroid.is_none());
            found[si] = true;
            seen.push(expect);
            break;
        }
    }
    assert_eq!(found, [true, true], "no position seen by one camera only");
    assert!(seen.contains(&Visibility::LeftOnly) && seen.contains(&Visibility::RightOnly));
}

/// Panning and tilting the head changes what is seen; an object out of view disappears.
#[test]
fn moving_the_cameras_changes_what_is_seen() {
    let spec = CameraSpec::default();
    let (scene, truth) = typical_scene(11, 8, false);
    let mut sv = StereoVision::new(&spec, &LightSpec::default(), 9).unwrap();
    let ahead = head_cameras_pan_tilt(&spec, 0.0, 0.85).unwrap();
    let ahead_blobs = sv.perceive(&ahead, &scene).unwrap();
    let both = ahead_blobs.iter().filter(|b| b.visibility == Visibility::Both).count();
    assert_eq!(
        both,
        truth.len(),
        "{:?}",
        ahead_blobs.iter().map(|b| b.visibility).collect::<Vec<_>>()
    );

    // Pan 50° to the left: the objects on the right half of the table leave the view.
    let left = head_cameras_pan_tilt(&spec, 50f64.to_radians(), 0.85).unwrap();
    let left_blobs = sv.perceive(&left, &scene).unwrap();
    let visible: Vec<usize> = (0..truth.len())
        .filter(|&k| count_label(&sv, Side::Left, ItemLabel::Object(k)) > 0)
        .collect();
    assert!(visible.len() < truth.len(), "panning should lose objects");
    let seen_at_all = (0..truth.len())
        .filter(|&k| {
            count_label(&sv, Side::Left, ItemLabel::Object(k)) + count_label(&sv, Side::Right, ItemLabel::Object(k)) > 0
        })
        .count();
    // Every blob is an object that is (at least partly) in view; an object cut by the image
    // borders differently in the two images may give one blob per camera, never a centroid.
    let mut represented = Vec::new();
    for b in &left_blobs {
        for (side, seg) in [(Side::Left, b.left), (Side::Right, b.right)] {
            if let Some(seg) = seg {
                let idx = sv.segmenter(side).segments().iter().position(|s| *s == seg).unwrap();
                if let Some(ItemLabel::Object(k)) = truth_of(&sv, side, idx) {
                    represented.push(k);
                }
            }
        }
        if b.visibility != Visibility::Both {
            assert!(b.centroid.is_none());
        }
    }
    represented.sort_unstable();
    represented.dedup();
    assert!(represented.len() <= seen_at_all && represented.len() < truth.len());
    let out_of_view = (0..truth.len())
        .filter(|&k| count_label(&sv, Side::Right, ItemLabel::Object(k)) == 0 && !visible.contains(&k))
        .count();
    let both_left = left_blobs.iter().filter(|b| b.visibility == Visibility::Both).count();
    eprintln!(
        "panned 50° left: {} of {} objects out of view, {both_left} blobs seen by both",
        out_of_view,
        truth.len()
    );
    assert!(out_of_view >= 2);
    // Tilting up to the horizon: nothing on the table is in view; no blobs.
    let up = head_cameras_pan_tilt(&spec, 0.0, -0.2).unwrap();
    assert!(sv.perceive(&up, &scene).unwrap().is_empty());
    // And back: the same objects again, bit for bit the same segmentation apart from noise.
    let again = sv.perceive(&ahead, &scene).unwrap();
    assert_eq!(again.len(), ahead_blobs.len());
    for (a, b) in again.iter().zip(&ahead_blobs) {
        assert_eq!(a.pixel_counts(), b.pixel_counts());
    }
}

/// Robot pixels are never foreground (the self-filter), in a cluttered scene with the arms over
/// the table; and every stereo match pairs segments of the same object.
#[test]
fn robot_is_never_foreground_and_matches_are_correct() {
    let spec = CameraSpec::default();
    let cams = default_cams(&spec);
    let (scene, truth) = typical_scene(1, 12, true);
    assert_eq!(scene.items.iter().filter(|i| i.label == ItemLabel::Robot).count(), 41);
    let mut sv = StereoVision::new(&spec, &LightSpec::default(), 2).unwrap();
    sv.set_config(on_table());
    let blobs = sv.perceive(&cams, &scene).unwrap();
    for side in [Side::Left, Side::Right] {
        let labels = sv.renderer(side).labels();
        let robot = labels.iter().filter(|l| **l == Some(ItemLabel::Robot)).count();
        assert!(robot > 1000, "the arms should be in view ({robot} px)");
        for (fg, l) in sv.segmenter(side).foreground().iter().zip(labels) {
            assert!(!(*fg && *l == Some(ItemLabel::Robot)));
        }
        // Without the self-filter the arms would be foreground.
        let mut raw = sv.segmenter(side).clone();
        raw.segment(sv.renderer(side).image(), &[]).unwrap();
        let robot_fg = raw
            .foreground()
            .iter()
            .zip(labels)
            .filter(|(f, l)| **f && **l == Some(ItemLabel::Robot))
            .count();
        assert!(robot_fg > robot / 2, "{robot_fg} of {robot}");
    }
    // Which objects the arms hide (partly): compare with the same scene without the robot.
    let (no_robot, _) = typical_scene(1, 12, false);
    let mut clear = vec![true; truth.len()];
    for (side, cam) in [(Side::Left, &cams.left), (Side::Right, &cams.right)] {
        let mut r = Renderer::new(0.0, &LightSpec::default(), 0).unwrap();
        r.render(cam, &no_robot).unwrap();
        for (k, c) in clear.iter_mut().enumerate() {
            let unoccluded = r.labels().iter().filter(|l| **l == Some(ItemLabel::Object(k))).count();
            *c &= unoccluded == count_label(&sv, side, ItemLabel::Object(k));
        }
    }
    let segs_l = sv.segmenter(Side::Left).segments().to_vec();
    let segs_r = sv.segmenter(Side::Right).segments().to_vec();
    // Labels of the pixels of segment `i` of `side`.
    let labels_of = |side: Side, i: usize| -> Vec<Option<ItemLabel>> {
        let comp = sv.segmenter(side).component_map();
        let mut v: Vec<Option<ItemLabel>> = sv
            .renderer(side)
            .labels()
            .iter()
            .zip(comp)
            .filter(|(_, c)| **c as usize == i + 1)
            .map(|(l, _)| *l)
            .collect();
        v.sort_by_key(|l| format!("{l:?}"));
        v.dedup();
        v
    };
    let (mut clear_errors, mut hidden_errors, mut merged_errors) = (Vec::new(), Vec::new(), Vec::new());
    for b in &blobs {
        if let (Some(l), Some(r)) = (b.left, b.right) {
            let li = segs_l.iter().position(|s| *s == l).unwrap();
            let ri = segs_r.iter().position(|s| *s == r).unwrap();
            let (tl, tr) = (truth_of(&sv, Side::Left, li), truth_of(&sv, Side::Right, ri));
            assert_eq!(tl, tr, "blob matched segments of different objects");
            if let Some(ItemLabel::Object(k)) = tl {
                let e = (1e3 * (b.centroid.unwrap() - truth[k].1).norm()).round();
                // Objects whose silhouettes touch merge into one segment (background subtraction
                // cannot split them); their centroid lies between the objects.
                let pure = labels_of(Side::Left, li).len() == 1 && labels_of(Side::Right, ri).len() == 1;
                match (pure, clear[k]) {
                    (false, _) => merged_errors.push(e),
                    (true, true) => clear_errors.push(e),
                    (true, false) => hidden_errors.push(e),
                }
            }
        }
    }
    let both = blobs.iter().filter(|b| b.visibility == Visibility::Both).count();
    eprintln!(
        "12 objects + 41 robot shapes: {} blobs, {both} both; centroid errors (mm): clear {clear_errors:?}, partly hidden by the arms {hidden_errors:?}, merged with a neighbour {merged_errors:?}",
        blobs.len(),
    );
    assert!(both >= 9);
    // Objects clear of the arms and of each other triangulate as well as alone; those cut by the
    // hands or merged with a neighbour do not. How many of the 12 drawn objects are clear depends on
    // the draw (6 with the SplitMix generator, 5 with xoshiro256++): at least 5.
    assert!(clear_errors.len() >= 5, "{clear_errors:?}");
    assert!(clear_errors.iter().all(|&e| e <= 10.0), "{clear_errors:?}");
}

/// Same seed → bit-identical images; another seed → other noise, same scene.
#[test]
fn same_seed_same_images() {
    let spec = CameraSpec::default();
    let cams = default_cams(&spec);
    let (scene, _) = typical_scene(3, 12, true);
    let run = |seed: u64| {
        let mut sv = StereoVision::new(&spec, &LightSpec::default(), seed).unwrap();
        let blobs = sv.perceive(&cams, &scene).unwrap();
        let (l, r) = sv.render_stereo(&cams, &scene).unwrap();
        (l.clone(), r.clone(), blobs)
    };
    let (a, b) = (run(42), run(42));
    assert_eq!(a.0, b.0);
    assert_eq!(a.1, b.1);
    assert_eq!(a.2, b.2);
    let c = run(43);
    assert_ne!(a.0, c.0);
    let differing = a.0.rgb.iter().zip(&c.0.rgb).filter(|(x, y)| x != y).count();
    assert!(differing > a.0.rgb.len() / 2, "noise should differ almost everywhere");
    // Reseeding restarts the sequence.
    let mut sv = StereoVision::new(&spec, &LightSpec::default(), 42).unwrap();
    let first = sv.perceive(&cams, &scene).unwrap();
    sv.reseed(42);
    sv.capture_background(&cams, &scene).unwrap();
    let again = sv.perceive(&cams, &scene).unwrap();
    assert_eq!(first, again);
    // Noise-free rendering is exact: the table top is one colour up to shading.
    let quiet = CameraSpec {
        pixel_noise: 0.0,
        ..CameraSpec::default()
    };
    let mut sv = StereoVision::new(&quiet, &LightSpec::default(), 1).unwrap();
    let (l, _) = sv.render_stereo(&default_cams(&quiet), &table_and_bins()).unwrap();
    let centre = l.pixel(80, 60).unwrap();
    assert_eq!(l.pixel(81, 61).unwrap(), centre);
}

/// Bad input gives errors or empty results, never panics.
#[test]
fn bad_input_is_an_error_not_a_panic() {
    let spec = CameraSpec::default();
    assert!(
        StereoVision::new(
            &CameraSpec {
                width: 0,
                ..spec.clone()
            },
            &LightSpec::default(),
            1
        )
        .is_err()
    );
    assert!(
        StereoVision::new(
            &CameraSpec {
                hfov_deg: 0.0,
                ..spec.clone()
            },
            &LightSpec::default(),
            1
        )
        .is_err()
    );
    assert!(
        StereoVision::new(
            &spec,
            &LightSpec {
                direction: [0.0; 3],
                ..LightSpec::default()
            },
            1
        )
        .is_err()
    );
    assert!(Renderer::new(f64::NAN, &LightSpec::default(), 1).is_err());
    let mut cams = default_cams(&spec);
    let mut sv = StereoVision::new(&spec, &LightSpec::default(), 1).unwrap();
    // An empty scene: nothing to see.
    assert!(sv.perceive(&cams, &RenderScene::new()).unwrap().is_empty());
    // A camera that was built by hand with a zero size or a NaN focal length.
    let mut bad = cams.clone();
    bad.left.width = 0;
    assert!(sv.perceive(&bad, &RenderScene::new()).is_err());
    bad = cams.clone();
    bad.right.fx = f64::NAN;
    assert!(sv.perceive(&bad, &table_and_bins()).is_err());
    // Items with non-finite poses are skipped.
    let (mut scene, truth) = typical_scene(1, 4, false);
    scene.items[truth[0].0].world_from_shape.translation.vector.x = f64::NAN;
    sv.capture_background(&cams, &scene).unwrap();
    let blobs = sv.perceive(&cams, &scene).unwrap();
    assert_eq!(blobs.iter().filter(|b| b.visibility == Visibility::Both).count(), 3);
    // A camera inside a shape does not see that shape (its housing).
    let mut housed = table_and_bins();
    housed.push(RenderItem::uniform_box(
        [0.1, 0.3, 0.1],
        Iso3::translation(0.05, 0.0, 1.5),
        [0.0, 0.0, 0.1],
        ItemLabel::Robot,
    ));
    sv.capture_background(&cams, &housed).unwrap();
    assert!(sv.perceive(&cams, &housed).unwrap().is_empty());
    let l = sv.renderer(Side::Left).labels();
    assert!(l.iter().all(|l| *l != Some(ItemLabel::Robot)));
    // Cameras of different sizes are fine (each has its own background).
    cams.right = Camera::look_at(
        &CameraSpec {
            width: 80,
            height: 60,
            ..spec.clone()
        },
        cams.right.position(),
        Vec3::from(TABLE_FIXATION),
    )
    .unwrap();
    let (scene, _) = typical_scene(2, 4, false);
    let blobs = sv.perceive(&cams, &scene).unwrap();
    assert_eq!(blobs.iter().filter(|b| b.visibility == Visibility::Both).count(), 4);
    // A segmenter without background, or with a mismatched image, errors.
    let mut seg = Segmenter::new(SegmentConfig::default());
    assert!(seg.segment(&Image::new(4, 4), &[]).is_err());
    seg.set_background(&Image::new(4, 4));
    assert!(seg.segment(&Image::new(5, 4), &[]).is_err());
    assert!(seg.segment(&Image::new(4, 4), &[false; 3]).is_err());
    assert!(seg.segment(&Image::new(4, 4), &[]).unwrap().is_empty());
}

/// After the first frame, rendering and perceiving allocate nothing (poses change in place).
#[test]
fn frames_do_not_allocate() {
    let spec = CameraSpec::default();
    let cams = default_cams(&spec);
    let (mut scene, truth) = typical_scene(5, 12, true);
    let mut sv = StereoVision::new(&spec, &LightSpec::default(), 1).unwrap();
    sv.set_config(on_table());
    let mut blobs = Vec::new();
    sv.perceive_into(&cams, &scene, &mut blobs).unwrap();
    // Two passes over the same motion: the first may grow buffers (more segments, fuller tiles),
    // the second must not allocate at all.
    let mut per_pass = Vec::with_capacity(2);
    for _pass in 0..2 {
        let before = allocations();
        for (step, &(idx, p)) in truth.iter().enumerate().take(4) {
            // Move objects, as the simulator does each frame.
            scene.items[idx].set_object_pose(&Iso3::translation(p.x + 0.01 * step as f64, p.y, p.z));
            sv.perceive_into(&cams, &scene, &mut blobs).unwrap();
            sv.render_stereo(&cams, &scene).unwrap();
        }
        for &(idx, p) in truth.iter().take(4) {
            scene.items[idx].set_object_pose(&Iso3::translation(p.x, p.y, p.z));
        }
        per_pass.push(allocations() - before);
    }
    eprintln!("allocations per pass of 4 frames after the first frame: {per_pass:?}");
    assert_eq!(per_pass[1], 0);
    assert!(!blobs.is_empty());
}

/// The debug dump is a valid binary PPM.
#[test]
fn ppm_dump() {
    let mut r = Renderer::new(0.0, &LightSpec::default(), 0).unwrap();
    let cam = Camera::look_at(
        &CameraSpec {
            width: 8,
            height: 6,
            ..CameraSpec::default()
        },
        Vec3::new(0.0, 0.0, 1.5),
        Vec3::new(0.6, 0.0, 0.75),
    )
    .unwrap();
    let img = r.render(&cam, &table_and_bins()).unwrap();
    let mut buf = Vec::new();
    img.write_ppm(&mut buf).unwrap();
    assert!(buf.starts_with(b"P6\n8 6\n255\n"));
    assert_eq!(buf.len(), 11 + 8 * 6 * 3);
    let _ = bounding_radius(&Shape::Sphere { radius: 1.0 });
}

/// The built-in sorting scene, rendered from its scene file: every object (upright and lying
/// cylinders, boxes) is seen by both cameras and located within 1 cm of its resting pose.
#[test]
fn builtin_sorting_scene() {
    let scene = dexter_sim::scene::Scene::builtin("sorting").unwrap();
    let render = RenderScene::from_scene(&scene);
    let spec = scene.spec.camera.clone();
    let cams = default_cams(&spec);
    let mut sv = StereoVision::new(&spec, &scene.spec.light, scene.spec.seed).unwrap();
    sv.set_config(StereoConfig {
        support: Some(SupportPlane::at(scene.spec.table.height)),
        ..StereoConfig::default()
    });
    let blobs = sv.perceive(&cams, &render).unwrap();
    let mut errors = Vec::new();
    for (k, r) in scene.resolved.iter().enumerate() {
        let truth = r.pose.translation.vector;
        let visible = (
            count_label(&sv, Side::Left, ItemLabel::Object(k)),
            count_label(&sv, Side::Right, ItemLabel::Object(k)),
        );
        let e = blobs
            .iter()
            .filter_map(|b| b.centroid)
            .map(|c| (c - truth).norm())
            .fold(f64::INFINITY, f64::min);
        eprintln!(
            "{:>16} visible px {visible:?}: nearest centroid {:.1} mm",
            r.presentation,
            1e3 * e
        );
        errors.push(e);
    }
    assert_eq!(
        blobs.iter().filter(|b| b.visibility == Visibility::Both).count(),
        scene.resolved.len()
    );
    assert!(errors.iter().all(|&e| e < 0.01), "{errors:?}");
}

/// Objects with a dark (black) top: the shading step between side and top of a black lid is
/// about 0.06 in RGB, under the pixel-noise level of a pixel pair, so it is found by averaging
/// (windows along each column) and checked to be a shading step (the side just below has the
/// top's colour, darker). Each upright prism is measured at its true height — the black mug not
/// at its white band's edge (it once measured 5 cm instead of 9.5 cm) — and within 1 cm; the
/// black ball with a white stripe is not taken for a prism ending at its stripe. Fixated a few cm
/// off the object, as the head's Search-Track leaves it.
///
/// Before the averaged step test, every dark-topped object kept its triangulated centroid (the
/// tea tin 23.5 mm off at the first pose).
#[test]
fn dark_topped_objects() {
    let black = [220.0, 0.15, 0.10];
    let white = [40.0, 0.04, 0.96];
    let band = |hsv: [f64; 3], fraction: f64| dexter_sim::scene::ColorPatch { hsv, fraction };
    let objects: [(&str, Shape, Vec<dexter_sim::scene::ColorPatch>); 4] = [
        (
            "tea tin (box, black with a gold band)",
            Shape::Box {
                size: [0.08, 0.08, 0.12],
            },
            vec![band(black, 0.45), band([45.0, 0.7, 0.75], 0.15), band(black, 0.4)],
        ),
        (
            "black mug (cylinder, white band)",
            Shape::Cylinder {
                radius: 0.04,
                height: 0.095,
            },
            vec![band(black, 0.4), band(white, 0.15), band(black, 0.45)],
        ),
        (
            "spice jar (cylinder, black cap)",
            Shape::Cylinder {
                radius: 0.024,
                height: 0.09,
            },
            vec![band([122.0, 0.7, 0.6], 0.7), band(black, 0.3)],
        ),
        (
            "black ball (white stripe)",
            Shape::Sphere { radius: 0.029 },
            vec![band(black, 0.42), band(white, 0.16), band(black, 0.42)],
        ),
    ];
    let spec = CameraSpec::default();
    let mut sv = StereoVision::new(&spec, &LightSpec::default(), 3).unwrap();
    sv.set_config(on_table());
    for (name, shape, colors) in &objects {
        for (k, (x, y, yaw, off)) in [
            (0.55, 0.0, 0.0, [0.0, 0.0, 0.0]),
            (0.55, 0.0, 0.0, [0.02, -0.02, 0.03]),
            (0.5, 0.12, 0.6, [-0.02, 0.01, 0.0]),
            (0.65, -0.1, 1.2, [0.01, 0.02, -0.02]),
            (0.45, -0.2, 0.3, [0.0, 0.03, 0.0]),
        ]
        .into_iter()
        .enumerate()
        {
            let mut scene = table_and_bins();
            let pose = resting_pose(shape, x, y, yaw);
            scene.push(RenderItem::from_catalog(shape, pose, colors, ItemLabel::Object(0)));
            let truth = pose.translation.vector;
            let cams = head_cameras(&spec, truth + Vec3::from(off)).unwrap();
            sv.reseed(10 + k as u64);
            let blobs = sv.perceive(&cams, &scene).unwrap();
            assert_eq!(blobs.len(), 1, "{name} #{k}");
            let b = blobs[0];
            let e = (b.centroid.unwrap() - truth).norm();
            eprintln!("{name} #{k}: {:?}, error {:.1} mm", b.source, 1e3 * e);
            assert!(e < 0.01, "{name} #{k}: error {e}");
            match (shape, b.source) {
                (Shape::Sphere { .. }, source) => {
                    assert!(
                        !matches!(source, CentroidSource::Prism { .. }),
                        "{name} #{k}: {source:?}"
                    )
                }
                (_, CentroidSource::Prism { height }) => {
                    assert!(
                        (height - 2.0 * (truth.z - TABLE_TOP)).abs() < 0.01,
                        "{name} #{k}: height {height}"
                    )
                }
                (_, source) => panic!("{name} #{k}: {source:?}, not measured as a prism"),
            }
        }
    }
}

/// Every presentation of the household catalog alone on the pick-place scene's table, at a few
/// places and yaws, the head verged on it or a few cm off (as Search-Track leaves it): the
/// centroid of every object in its default (upright) presentation, the one the pick-and-place
/// catalog sweep uses, is within 1 cm horizontally. Objects lying on their side are reported,
/// not checked: a lying cylinder or a box with its bands across the top is neither a prism with
/// a uniform top nor round, keeps its triangulated centroid and misses by up to 2 cm.
///
/// Measured (horizontal error): default presentations 172/172 within 1 cm, median 1.1 mm,
/// max 3.4 mm (before the averaged step test: tea tin 11.8 and 13.8 mm, black mug 4.8 mm,
/// spice jar with a black cap 8.3 mm, all triangulated); all presentations 236/260.
#[test]
fn catalog_objects_on_the_table() {
    if cfg!(debug_assertions) {
        eprintln!("SKIPPED: 260 stereo frames; run in release mode (cargo test --release)");
        return;
    }
    let base = dexter_sim::scene::Scene::builtin("pick-place").unwrap();
    let spec = base.spec.camera.clone();
    let mut sv = StereoVision::new(&spec, &base.spec.light, base.spec.seed).unwrap();
    sv.set_config(StereoConfig {
        support: Some(SupportPlane::at(base.spec.table.height)),
        ..StereoConfig::default()
    });
    let names: Vec<String> = base
        .catalog
        .presentation_names()
        .into_iter()
        .map(String::from)
        .collect();
    let mut all = Vec::new();
    let mut upright = Vec::new();
    for name in &names {
        let mut line = format!("{name:>16}:");
        for (k, (xy, yaw, off)) in [
            ([0.55, 0.0], 0.0, [0.0, 0.0, 0.0]),
            ([0.55, 0.0], 0.0, [0.02, -0.02, 0.03]),
            ([0.5, 0.12], 35.0, [-0.02, 0.01, 0.0]),
            ([0.65, -0.1], 70.0, [0.01, 0.02, -0.02]),
        ]
        .into_iter()
        .enumerate()
        {
            let scene = base
                .with_objects(vec![dexter_sim::scene::ObjectPlacement {
                    presentation: name.clone(),
                    xy,
                    yaw_deg: yaw,
                    z: None,
                }])
                .unwrap();
            let truth = scene.resolved[0].pose.translation.vector;
            let cams = head_cameras(&spec, truth + Vec3::from(off)).unwrap();
            sv.reseed(k as u64 + 1);
            let blobs = sv.perceive(&cams, &RenderScene::from_scene(&scene)).unwrap();
            let best = blobs
                .iter()
                .filter_map(|b| b.centroid.map(|c| ((c.xy() - truth.xy()).norm(), b.source)))
                .min_by(|a, b| a.0.total_cmp(&b.0));
            let (e, src) = best.unwrap_or((f64::INFINITY, CentroidSource::Triangulated));
            let tag = match src {
                CentroidSource::Triangulated => "T".to_string(),
                CentroidSource::Prism { height } => format!("P{:.1}", 100.0 * height),
                CentroidSource::Round { radius } => format!("R{:.1}", 100.0 * radius),
                CentroidSource::Standing { height, .. } => format!("S{:.1}", 100.0 * height),
            };
            line += &format!(" {:5.1} mm {tag:<6}", 1e3 * e);
            all.push((e, name.clone()));
            if base.catalog.objects.iter().any(|o| &o.name == name) {
                upright.push((e, name.clone()));
            }
        }
        eprintln!("{line}");
    }
    for (label, errs) in [("all presentations", &mut all), ("default presentations", &mut upright)] {
        errs.sort_by(|a, b| a.0.total_cmp(&b.0));
        let within = errs.iter().filter(|e| e.0 <= 0.01).count();
        let worst = &errs[errs.len() - 1];
        eprintln!(
            "catalog on the table, {label}: n {} median {:.1} mm, max {:.1} mm ({}), within 1 cm {within}/{}",
            errs.len(),
            1e3 * errs[errs.len() / 2].0,
            1e3 * worst.0,
            worst.1,
            errs.len()
        );
    }
    let over: Vec<_> = upright.iter().filter(|e| e.0 > 0.01).collect();
    assert!(over.is_empty(), "over 1 cm: {over:?}");
}
