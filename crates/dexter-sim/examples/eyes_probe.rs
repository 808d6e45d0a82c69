//! The robot's honest eyes against the world's truth, for debugging: `cargo run --release -p
//! dexter-sim --example eyes_probe -- [scene] [x y [dz]]` (a built-in scene name or a scene TOML file;
//! `PROBE_ARM` offsets the right arm's joints, `PROBE_FLEX` flexes its fingers, `PROBE_POST="x y yaw"`
//! puts the blocked-arm fault's post on the table, `RUST_LOG` prints the
//! vision's traces) looks at a point `dz` above the table and writes the head's
//! left and right images, its predicted background, the self-mask from the robot's model and the renderer's
//! true self-mask as PPM files in `/tmp/eyes_probe/`, and prints their agreement.

use control_basis::hardware::Image;
use control_basis::math::Vec3;
use control_basis::{Hardware, Plant};
use dexter::eyes::{Eyes, Pair, SearchTrack};
use dexter::vision::Side;
use dexter_sim::hardware::{SimRobot, parked_sim};
use dexter_sim::physics::SimSettings;
use dexter_sim::scene::Scene;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    tracing_subscriber::fmt()
        .with_env_filter(tracing_subscriber::EnvFilter::from_default_env())
        .with_writer(std::io::stderr)
        .init();
    let args: Vec<String> = std::env::args().collect();
    let scene = Scene::open(args.get(1).map_or("sorting", String::as_str))?;
    let x: f64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(0.55);
    let y: f64 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(0.0);
    let z: f64 = args.get(4).and_then(|s| s.parse().ok()).unwrap_or(0.03);
    let table_z = scene.spec.table.height;
    let t0 = std::time::Instant::now();
    let calibration = dexter_sim::calibrate::workcell_calibration(&scene)?;
    println!(
        "calibration: {} views in {:.2} s",
        calibration.view_count(),
        t0.elapsed().as_secs_f64()
    );
    let mut sim = parked_sim(&scene, SimSettings::default())?;
    let mut hw = SimRobot::new(&mut sim, &scene, 1)?;
    let mut eyes = Eyes::new(&hw, table_z, calibration)?;
    let head = SearchTrack::new(&hw)?;
    let mut body = dexter::body::Body::new();
    head.look_at(&mut hw, &mut body, &Vec3::new(x, y, table_z + z))?;
    // Optionally move the right arm: `PROBE_ARM="q1 q2 … q7"` offsets (rad) from the parked pose.
    if let Ok(offsets) = std::env::var("PROBE_ARM") {
        let names: Vec<String> = hw
            .joint_names()
            .iter()
            .filter(|n| n.starts_with("right/") && !n.contains("bhand"))
            .cloned()
            .collect();
        for (name, d) in names
            .iter()
            .zip(offsets.split_whitespace().filter_map(|t| t.parse::<f64>().ok()))
        {
            let j = hw.dof_index(name)?;
            let q = hw.joint_positions()[j];
            hw.set_joint_reference(j, q + d, 0.0);
        }
    }
    // Optionally flex the right hand's fingers: `PROBE_FLEX=rad` on every medial joint.
    if let Some(flex) = std::env::var("PROBE_FLEX").ok().and_then(|v| v.parse::<f64>().ok()) {
        let names: Vec<String> = hw
            .joint_names()
            .iter()
            .filter(|n| n.starts_with("right/bhand") && n.ends_with("med_joint"))
            .cloned()
            .collect();
        for name in names {
            let j = hw.dof_index(&name)?;
            hw.set_joint_reference(j, flex, 0.0);
        }
    }
    // Optionally put the blocked-arm fault's 6 × 22 × 50 cm post on the table:
    // `PROBE_POST="x y yaw"` (its 6 cm side along yaw).
    if let Ok(post) = std::env::var("PROBE_POST") {
        let v: Vec<f64> = post.split_whitespace().filter_map(|t| t.parse().ok()).collect();
        if let [x, y, yaw] = v[..] {
            let s = dexter_sim::fault::OBSTACLE_SIZE;
            let half = Vec3::new(0.5 * s[0], 0.5 * s[1], 0.5 * s[2]);
            let pose = control_basis::math::Iso3::from_parts(
                Vec3::new(x, y, table_z + half.z).into(),
                control_basis::math::Rot3::from_axis_angle(&Vec3::z_axis(), yaw),
            );
            hw.sim_mut().add_obstacle(&half, &pose);
        }
    }
    for k in 0..10 {
        hw.advance(0.1)?;
        let blobs = eyes.perceive(&mut hw, Pair::Head)?;
        let sizes: Vec<(usize, usize)> = blobs
            .iter()
            .map(|b| {
                (
                    b.left.map_or(0, |s| s.features.pixel_count),
                    b.right.map_or(0, |s| s.features.pixel_count),
                )
            })
            .collect();
        println!("t={:.1} blobs (left px, right px) {sizes:?}", 0.1 * (k + 1) as f64);
    }
    let blobs = eyes.perceive(&mut hw, Pair::Head)?.to_vec();
    std::fs::create_dir_all("/tmp/eyes_probe")?;
    let (im, _) = eyes.images(Pair::Head);
    im.save_ppm("/tmp/eyes_probe/image.ppm")?;
    eyes.images(Pair::Head).1.save_ppm("/tmp/eyes_probe/image_right.ppm")?;
    let mask = eyes.self_masks(Pair::Head).0.to_vec();
    let mut truth = Vec::new();
    hw.sim_cameras().true_self_mask(0, &mut truth);
    let paint = |m: &[bool], c: usize| {
        let mut out: Image = im.clone();
        for (i, &b) in m.iter().enumerate() {
            if b {
                out.rgb[3 * i + c] = 255;
            }
        }
        out
    };
    paint(&mask, 0).save_ppm("/tmp/eyes_probe/self_mask.ppm")?;
    paint(&truth, 1).save_ppm("/tmp/eyes_probe/true_mask.ppm")?;
    let seg = eyes.pipeline(Pair::Head).segmenter(Side::Left);
    paint(seg.foreground(), 2).save_ppm("/tmp/eyes_probe/foreground.ppm")?;
    if let Some(bg) = seg.background() {
        bg.save_ppm("/tmp/eyes_probe/background_lo.ppm")?;
    }
    let seg_right = eyes.pipeline(Pair::Head).segmenter(Side::Right);
    let (_, im_right) = eyes.images(Pair::Head);
    let mut fg_right = im_right.clone();
    for (i, &b) in seg_right.foreground().iter().enumerate() {
        if b {
            fg_right.rgb[3 * i + 2] = 255;
        }
    }
    fg_right.save_ppm("/tmp/eyes_probe/foreground_right.ppm")?;
    for (name, side) in [("left", Side::Left), ("right", Side::Right)] {
        for s in eyes.pipeline(Pair::Head).segmenter(side).segments() {
            let c = s.features.mean_rgb;
            println!(
                "  {name} segment: {} px at ({:.1}, {:.1}), bbox {:?}, mean rgb ({:.2}, {:.2}, {:.2}), cut {}",
                s.features.pixel_count,
                s.features.centroid[0],
                s.features.centroid[1],
                s.bbox,
                c[0],
                c[1],
                c[2],
                s.cut_off()
            );
        }
    }
    let both = mask.iter().zip(&truth).filter(|(a, b)| **a && **b).count();
    let model_only = mask.iter().zip(&truth).filter(|(a, b)| **a && !**b).count();
    let truth_only = mask.iter().zip(&truth).filter(|(a, b)| !**a && **b).count();
    println!(
        "self-mask: both {both}, model only {model_only}, renderer only {truth_only}; coverage {:?}",
        eyes.coverage(Pair::Head)
    );
    println!(
        "foreground pixels {}, segments {}, blobs {}",
        seg.foreground().iter().filter(|b| **b).count(),
        seg.segments().len(),
        blobs.len()
    );
    for b in &blobs {
        println!("  blob at {:?}", b.centroid);
    }
    for (i, o) in (0..hw.sim().objects().len()).map(|i| (i, hw.sim().object_state(i))) {
        println!("  object {i} at {:?}", o.pose.translation.vector);
    }
    Ok(())
}
