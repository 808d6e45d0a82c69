//! Injected faults: per kind, one scene in which the fault fires, the robot notices it from its own
//! sensors and reacts, and the trial ends with an outcome — recovered, or a logged reason.
//! Slow in a debug build (a whole pick-and-place with recovery each): `#[ignore]`d; run with
//! `cargo test --release -p dexter-sim --test faults -- --include-ignored`.

use dexter_sim::fault::{FaultKind, FaultTrial, fault_trial};
use dexter_sim::scene::Scene;

fn trial(kind: FaultKind, i: usize) -> FaultTrial {
    let base = Scene::builtin("pick-place").unwrap();
    let library = schema::Library::builtin();
    let t = fault_trial(&base, "pick-place", &library, kind, 1, i).unwrap();
    eprintln!("{}", serde_json::to_string(&t).unwrap());
    t
}

fn check(kind: FaultKind) {
    let n: usize = std::env::var("PBD_FAULT_SCENES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1);
    for i in 0..n {
        let t = trial(kind, i);
        assert!(t.fired, "the fault never fired: {t:?}");
        assert!(
            t.success || !t.reason.is_empty(),
            "an unrecovered trial without a reason: {t:?}"
        );
    }
}

#[test]
#[ignore = "a whole scene; cargo test --release -p dexter-sim --test faults -- --include-ignored"]
fn drop_fires_and_the_robot_regrasps() {
    check(FaultKind::Drop);
}

#[test]
#[ignore = "a whole scene; cargo test --release -p dexter-sim --test faults -- --include-ignored"]
fn bump_fires_and_the_robot_regrasps() {
    check(FaultKind::Bump);
}

#[test]
#[ignore = "a whole scene; cargo test --release -p dexter-sim --test faults -- --include-ignored"]
fn blocked_arm_fires_and_the_robot_uses_the_other_arm() {
    check(FaultKind::BlockedArm);
}

#[test]
#[ignore = "a whole scene; cargo test --release -p dexter-sim --test faults -- --include-ignored"]
fn occlusion_fires_and_the_run_ends() {
    check(FaultKind::Occlusion);
}

#[test]
#[ignore = "a whole scene; cargo test --release -p dexter-sim --test faults -- --include-ignored"]
fn sensor_noise_fires_and_the_run_ends() {
    check(FaultKind::SensorNoise);
}
