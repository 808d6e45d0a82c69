//! The calibration file end to end on a real calibration: `pbd::calibrate` of the default scene's
//! workcell writes a file that loads equal to the calibration `pbd execute` computes by itself (the
//! workcell's default seed), bit for bit; a calibration of other cameras is refused by `execute`
//! before anything is written, naming the camera; an unreadable file is a format error naming it.

use std::path::PathBuf;
use std::time::Instant;

use pbd::calibrate::{CalibrateOptions, calibrate};
use pbd::dexter::calibration::Calibration;
use pbd::dexter_sim::scene::Scene;
use pbd::execute::{ExecuteOptions, execute};
use pbd::progress::Quiet;
use pbd::{ErrorKind, Progress};

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("pbd-calibration-file-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn model() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../py/tests/data/sorting-model.json")
}

#[test]
fn the_default_scenes_calibration_round_trips_and_equals_the_one_execute_computes() {
    if cfg!(debug_assertions) {
        eprintln!("SKIPPED: simulation tests run in release mode");
        return;
    }
    let d = dir("round-trip");
    let options = CalibrateOptions {
        output: d.join("workcell.cal"),
        ..CalibrateOptions::default()
    };
    let report = calibrate(&options, &Quiet).unwrap();
    println!("{report}");
    let scene = Scene::open(&options.scene).unwrap();
    let computed = pbd::dexter_sim::calibrate::workcell_calibration(&scene).unwrap();
    assert_eq!(report.views, computed.view_count());
    assert_eq!(report.cameras.len(), computed.banks().len());
    assert_eq!(report.bytes, std::fs::metadata(&options.output).unwrap().len());
    let t = Instant::now();
    let loaded = Calibration::load(&options.output).unwrap();
    let load = t.elapsed().as_secs_f64();
    assert!(
        loaded == *computed,
        "the file differs from the calibration execute computes"
    );
    // Saved again through the robot's own writer: the same bytes.
    let t = Instant::now();
    let again = d.join("again.cal");
    let bytes = loaded.save(&again).unwrap();
    let save = t.elapsed().as_secs_f64();
    assert_eq!(std::fs::read(&again).unwrap(), std::fs::read(&options.output).unwrap());
    println!(
        "{} views, {bytes} bytes; load {load:.3} s, save {save:.3} s (report: save {:.3} s, load {:.3} s)",
        report.views, report.save_time, report.load_time
    );
    let _ = std::fs::remove_dir_all(&d);
}

/// Records the warnings a run gives.
#[derive(Default)]
struct Warnings(std::sync::Mutex<Vec<String>>);

impl Progress for Warnings {
    fn warn(&self, text: &str) {
        self.0.lock().unwrap().push(text.to_string());
    }
}

#[test]
fn execute_refuses_a_calibration_of_other_cameras_and_a_malformed_file() {
    if cfg!(debug_assertions) {
        eprintln!("SKIPPED: simulation tests run in release mode");
        return;
    }
    let d = dir("refused");
    let scene = Scene::open("pick-place").unwrap();
    let good = pbd::dexter_sim::calibrate::workcell_calibration(&scene).unwrap();
    let run = d.join("run.mcap");
    let exec = |cal: &std::path::Path, progress: &dyn Progress| {
        execute(
            &ExecuteOptions {
                scene: "pick-place".into(),
                model: Some(model()),
                calibration: Some(cal.to_path_buf()),
                output: Some(run.clone()),
                ..ExecuteOptions::default()
            },
            progress,
        )
    };
    // A camera the robot does not have.
    let mut banks = good.banks().to_vec();
    banks[0].0 = "head/third_eye".into();
    let renamed = d.join("renamed.cal");
    Calibration::from_banks(banks).save(&renamed).unwrap();
    let e = exec(&renamed, &Quiet).unwrap_err();
    let m = e.chain_message();
    assert!(
        m.contains("not a calibration of this robot's cameras") && m.contains("head/third_eye"),
        "{m}"
    );
    assert_eq!(e.kind(), ErrorKind::Value, "{m}");
    assert!(!run.exists(), "the log was written");
    // Views of another size: the robot's cameras take other images.
    let mut banks = good.banks().to_vec();
    let mut small = pbd::dexter::vision::BackgroundBank::new(banks[0].1.plane_z());
    for v in banks[0].1.views() {
        let mut v = v.clone();
        v.camera.width /= 2;
        v.camera.height /= 2;
        v.image = pbd::dexter::vision::Image::new(v.camera.width, v.camera.height);
        v.valid.clear();
        small.push(v).unwrap();
    }
    banks[0].1 = small;
    let halved = d.join("halved.cal");
    Calibration::from_banks(banks).save(&halved).unwrap();
    let m = exec(&halved, &Quiet).unwrap_err().chain_message();
    assert!(m.contains("px, the robot's camera takes"), "{m}");
    // A file of another kind, and one cut short: format errors naming the file.
    let text = d.join("text.cal");
    std::fs::write(&text, "not a calibration").unwrap();
    let e = exec(&text, &Quiet).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::Format, "{}", e.chain_message());
    assert!(e.chain_message().contains(&text.display().to_string()));
    let cut = d.join("cut.cal");
    let bytes = good.to_bytes().unwrap();
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    let e = exec(&cut, &Quiet).unwrap_err();
    assert!(e.chain_message().contains("ends early"), "{}", e.chain_message());
    // Missing: a file error.
    let e = exec(&d.join("missing.cal"), &Quiet).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::File, "{}", e.chain_message());
    // The calibration as output of `calibrate` over the scene file itself: refused (an input).
    let scene_file = d.join("scene.toml");
    std::fs::write(
        &scene_file,
        std::fs::read_to_string(PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../assets/scenes/pick-place.toml"))
            .unwrap()
            .replace("../objects/household.toml", "builtin:household"),
    )
    .unwrap();
    let before = std::fs::read(&scene_file).unwrap();
    let e = calibrate(
        &CalibrateOptions {
            scene: scene_file.display().to_string(),
            output: scene_file.clone(),
            seed: None,
        },
        &Quiet,
    )
    .unwrap_err();
    assert!(
        e.chain_message().contains("refusing to overwrite an input"),
        "{}",
        e.chain_message()
    );
    assert_eq!(std::fs::read(&scene_file).unwrap(), before);
    // A calibration over another table height is warned about (and used).
    let w = Warnings::default();
    let mut banks = good.banks().to_vec();
    for (_, b) in &mut banks {
        let mut moved = pbd::dexter::vision::BackgroundBank::new(b.plane_z() + 0.1);
        for v in b.views() {
            moved.push(v.clone()).unwrap();
        }
        *b = moved;
    }
    let lifted = d.join("lifted.cal");
    Calibration::from_banks(banks).save(&lifted).unwrap();
    let sim = pbd::dexter_sim::physics::DexterSim::new(&scene, Default::default()).unwrap();
    let cameras = pbd::dexter_sim::hardware::SimCameras::new(&sim, &scene, 0).unwrap();
    let loaded = pbd::calibrate::load_for(&lifted, cameras.infos(), &scene, &w).unwrap();
    assert_eq!(loaded.view_count(), good.view_count());
    let warnings = w.0.lock().unwrap().clone();
    assert!(
        warnings.len() == 1 && warnings[0].contains("calibrated over a table at 0.850 m"),
        "{warnings:?}"
    );
    let _ = std::fs::remove_dir_all(&d);
}
