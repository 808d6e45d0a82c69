//! pbd over ROS 2 across processes, on localhost DDS: the simulated Dexter served in one process
//! (`pbd sim serve --ros2 --lockstep`), the robot in another (`pbd calibrate --hardware ros2` with
//! the workcell emptied, then `pbd execute --hardware ros2`) — and every object ends where the
//! in-process run with the same calibration puts it. Bad mappings and an absent robot are refused
//! with exit code 1 and a message naming the file, field or topic.

use crate::common;

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};

use common::{refused, repo, stderr};
use serde_json::Value;

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("pbd-ros2-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn s(p: &Path) -> String {
    p.display().to_string()
}

/// A DDS domain of this test process's own (several test processes may run at once); `k` keeps
/// the tests of one process apart.
fn domain_k(k: u32) -> String {
    (100 + (std::process::id() % 40) * 3 + k).to_string()
}

fn domain() -> String {
    domain_k(0)
}

fn pbd_on(domain: &str, args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_pbd"))
        .args(args)
        .env("ROS_DOMAIN_ID", domain)
        .output()
        .expect("the pbd binary runs")
}

struct Server(Option<Child>);

impl Server {
    fn start(domain: &str, args: &[&str]) -> Self {
        let child = Command::new(env!("CARGO_BIN_EXE_pbd"))
            .args(["sim", "serve", "--ros2", "--lockstep", "--json"])
            .args(args)
            .env("ROS_DOMAIN_ID", domain)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("pbd sim serve starts");
        Server(Some(child))
    }

    /// Stops it as Ctrl-C would (SIGTERM) and returns its report.
    fn stop(mut self) -> Value {
        let child = self.0.take().unwrap();
        let pid = child.id().to_string();
        let _ = Command::new("kill").args(["-TERM", &pid]).status();
        let out = child.wait_with_output().unwrap();
        assert!(out.status.success(), "pbd sim serve failed: {}", stderr(&out));
        serde_json::from_slice(&out.stdout).expect("the server's report is JSON")
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        if let Some(mut c) = self.0.take() {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

#[test]
fn the_robot_over_ros2_places_every_object_where_the_in_process_run_places_it() {
    if cfg!(debug_assertions) {
        eprintln!("SKIPPED: simulation end-to-end tests run in release mode");
        return;
    }
    let d = dir("execute");
    let dom = domain();
    let cal = d.join("workcell.cal");
    // The workcell of `pbd demo`'s execution: three objects of the task (one handed from arm to arm) and one
    // to leave alone.
    let scene = "sorting-demo";

    // The workcell cleared: the robot calibrates its eyes over ROS 2.
    let server = Server::start(&dom, &["--scene", scene, "--empty"]);
    let o = pbd_on(
        &dom,
        &[
            "calibrate",
            "--hardware",
            "ros2",
            "--scene",
            scene,
            "-o",
            &s(&cal),
            "--json",
        ],
    );
    let served = server.stop();
    assert!(o.status.success(), "calibrate over ROS 2: {}", stderr(&o));
    assert!(served["objects"].as_array().unwrap().is_empty(), "{served:#}");
    assert!(served["serve"]["images"].as_u64().unwrap() > 60, "{served:#}");

    // The objects placed: the robot does the task over ROS 2, its fingertip sensors publishing in
    // their own frames as real force/torque sensors do.
    let model = s(&repo().join("crates/py/tests/data/sorting-model.json"));
    let server = Server::start(&dom, &["--scene", scene, "--sensor-frames"]);
    let o = pbd_on(
        &dom,
        &[
            "execute",
            "--hardware",
            "ros2",
            "--scene",
            scene,
            "--model",
            &model,
            "--calibration",
            &s(&cal),
            "--json",
        ],
    );
    let served = server.stop();
    assert!(o.status.success(), "execute over ROS 2: {}", stderr(&o));
    let robot: Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(robot["executed"].as_u64().unwrap() >= 1, "{robot:#}");

    // The same task in-process, with the same calibration.
    let o = pbd_on(
        &dom,
        &[
            "execute",
            "--scene",
            scene,
            "--model",
            &model,
            "--calibration",
            &s(&cal),
            "--json",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let local: Value = serde_json::from_slice(&o.stdout).unwrap();
    let mut compared = 0;
    for obj in local["objects"].as_array().unwrap() {
        let label = obj["object"].as_str().unwrap();
        let truth = served["objects"]
            .as_array()
            .unwrap()
            .iter()
            .find(|o| o["object"] == label)
            .unwrap_or_else(|| panic!("{label} not in the server's report: {served:#}"));
        let want = if obj["success"].as_bool() == Some(true) {
            obj["place"].clone()
        } else {
            Value::Null
        };
        if want.is_null() {
            // Not placed in-process: not in a place over ROS 2 either.
            assert!(
                truth["place"].is_null() || truth["place"] != obj["place"],
                "{label}: {truth:#} vs {obj:#}"
            );
        } else {
            assert_eq!(
                truth["place"], want,
                "{label}: over ROS 2 {truth:#}, in-process {obj:#}"
            );
            assert!(
                truth["speed"].as_f64().unwrap() < 0.05,
                "{label} still moving: {truth:#}"
            );
        }
        compared += 1;
    }
    assert!(compared >= 1 && local["placed"].as_u64().unwrap() >= 1, "{local:#}");
    let _ = std::fs::remove_dir_all(&d);
}

/// `pbd record --hardware ros2`: the served world's scripted teacher publishes its glove samples,
/// the robot's hands follow them over ROS 2 and its own eyes watch; the recording (in ROS 2's
/// encoding) infers to the task the in-process recording infers to.
#[test]
fn a_demonstration_recorded_over_ros2_infers_like_the_in_process_one() {
    if cfg!(debug_assertions) {
        eprintln!("SKIPPED: simulation end-to-end tests run in release mode");
        return;
    }
    let d = dir("record");
    let dom = domain_k(1);
    let (cal, demo, local) = (d.join("pp.cal"), d.join("ros2.mcap"), d.join("local.mcap"));
    let server = Server::start(&dom, &["--scene", "pick-place", "--empty"]);
    let o = pbd_on(
        &dom,
        &[
            "calibrate",
            "--hardware",
            "ros2",
            "--scene",
            "pick-place",
            "-o",
            &s(&cal),
        ],
    );
    server.stop();
    assert!(o.status.success(), "calibrate over ROS 2: {}", stderr(&o));

    let server = Server::start(&dom, &["--scene", "pick-place", "--teach", "pick-place"]);
    let o = pbd_on(
        &dom,
        &[
            "record",
            "--ros2",
            "--scene",
            "pick-place",
            "--calibration",
            &s(&cal),
            "--encoding",
            "ros2",
            "-o",
            &s(&demo),
            "--json",
        ],
    );
    let served = server.stop();
    assert!(o.status.success(), "record over ROS 2: {}", stderr(&o));
    let rec: Value = serde_json::from_slice(&o.stdout).unwrap();
    // It ended by itself (the teacher put the glove down), not at --max-seconds.
    let secs = rec["sim_time"].as_f64().unwrap();
    assert!((10.0..40.0).contains(&secs), "{rec:#}");
    assert!(
        rec["percepts"].as_u64().unwrap() > 100 && rec["commands"].as_u64().unwrap() > 100,
        "{rec:#}"
    );
    let jif = &served["objects"][0];
    assert_eq!(
        jif["place"], "bin-left",
        "the robot's hand, following the glove, placed it: {served:#}"
    );

    let o = pbd_on(&dom, &["record", "--scene", "pick-place", "-o", &s(&local)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let mut instances = Vec::new();
    for m in [&demo, &local] {
        let o = pbd_on(&dom, &["infer", &s(m), "--json"]);
        assert!(o.status.success(), "infer {}: {}", m.display(), stderr(&o));
        let v: Value = serde_json::from_slice(&o.stdout).unwrap();
        let inf = &v["inference"];
        assert_eq!(inf["posterior"]["map"], "pick_and_place", "{}: {inf:#}", m.display());
        let i = &inf["instances"][0];
        let n = inf["instances"].as_array().unwrap().len();
        instances.push((i["place"].clone(), i["arm"].clone(), i["object"].clone(), n));
    }
    assert_eq!(instances[0], instances[1]);
    assert_eq!(instances[0].0, "bin-left");
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn bad_mappings_and_an_absent_robot_are_refused_by_name() {
    let d = dir("bad");
    let good = std::fs::read_to_string(repo().join("assets/ros2/dexter.toml")).unwrap();
    let bad = d.join("bad.toml");
    std::fs::write(
        &bad,
        good.replace("topic = \"/joint_states\"", "topic = \"joint states\""),
    )
    .unwrap();
    let cal = d.join("none.cal");
    refused(
        &[
            "calibrate",
            "--hardware",
            "ros2",
            "--config",
            &s(&bad),
            "--scene",
            "pick-place",
            "-o",
            &s(&cal),
        ],
        &["bad.toml", "joint_states.topic"],
    );
    std::fs::write(&bad, good.replace("timeout_ms = 2000", "timeout_ms = 2000\nspeed = 3")).unwrap();
    refused(
        &["sim", "serve", "--ros2", "--config", &s(&bad)],
        &["bad.toml", "speed"],
    );
    refused(
        &["execute", "--config", &s(&bad), "--demo", "x.json"],
        &["--hardware ros2"],
    );
    refused(&["sim", "serve", "--scene", "pick-place"], &["--ros2"]);

    // Nobody on this domain: the robot waits `timeout_ms`, then names the topic.
    let quick = d.join("quick.toml");
    std::fs::write(
        &quick,
        good.replace("timeout_ms = 2000", "timeout_ms = 300")
            .replace("# domain_id = 0", "domain_id = 231"),
    )
    .unwrap();
    refused(
        &[
            "calibrate",
            "--hardware",
            "ros2",
            "--config",
            &s(&quick),
            "--scene",
            "pick-place",
            "-o",
            &s(&cal),
        ],
        &["/joint_states", "300 ms"],
    );
    assert!(!cal.exists(), "nothing is written when the robot is absent");
    let model = s(&repo().join("crates/py/tests/data/sorting-model.json"));
    refused(
        &[
            "execute",
            "--hardware",
            "ros2",
            "--config",
            &s(&quick),
            "--scene",
            "pick-place",
            "--model",
            &model,
        ],
        &["--calibration"],
    );
    let _ = std::fs::remove_dir_all(&d);
}
