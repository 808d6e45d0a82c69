//! Runs one scripted demonstration and prints the monitors' observation vector whenever it changes.
//! `cargo run --release -p dexter-sim --example teach_probe -- pickplace|hold|handover|touch|wander [object] [place] [left|right] [retry]`
use dexter::eyes::Eyes;
use dexter_sim::Arm;
use dexter_sim::physics::{DexterSim, SimSettings};
use dexter_sim::scene::Scene;
use dexter_sim::teach::{DemoSettings, DemoSink, TeleopSource, run_demonstration};
use dexter_sim::teleop::{TeachTask, Teacher};
use schema::{Library, MonitorBank, MonitorConfig, Percept};

struct Sink {
    bank: MonitorBank,
    obs: Vec<schema::Observation>,
    percepts: Vec<Percept>,
    last: Vec<bool>,
    names: Vec<String>,
}

impl DemoSink for Sink {
    fn percept(&mut self, _sim: &DexterSim, _eyes: &Eyes, p: &Percept) {
        let o = self.bank.observe(p);
        self.obs.push(o.clone());
        self.percepts.push(p.clone());
        if std::env::var("PALM").is_ok() {
            println!(
                "  t={:.2} palm z {:.3} f {:?} flex {:.2}",
                p.t, p.hands[0].palm[2], p.hands[0].finger_force, p.hands[0].flexion
            );
        }
        if o.x != self.last {
            let on: Vec<String> = o
                .hits
                .iter()
                .map(|h| {
                    format!(
                        "{}({}{}{})",
                        self.names[h.action],
                        h.arm.clone().unwrap_or_default(),
                        h.segment.map(|s| format!(" s{s}")).unwrap_or_default(),
                        h.place.clone().map(|p| format!(" {p}")).unwrap_or_default()
                    )
                })
                .collect();
            let hands: Vec<String> = p
                .hands
                .iter()
                .map(|h| {
                    format!(
                        "{}: v={:.3} flex={:.2} f=[{:.2} {:.2} {:.2}] load={:.2}",
                        h.arm, h.palm_speed, h.flexion, h.finger_force[0], h.finger_force[1], h.finger_force[2], h.load
                    )
                })
                .collect();
            println!(
                "t={:6.2} segs={} gaze={:?} {:?}\n        {}",
                p.t,
                p.segments.len(),
                p.gaze,
                on,
                hands.join(" | ")
            );
            for sg in p.segments.iter().filter(|_| std::env::var("SEGS").is_ok()) {
                println!(
                    "        s{} at [{:.3} {:.3} {:.3}] seen={} px={:?}",
                    sg.id, sg.centroid[0], sg.centroid[1], sg.centroid[2], sg.seen, sg.pixels
                );
            }
            self.last = o.x;
        }
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let kind = args.get(1).map(String::as_str).unwrap_or("pickplace");
    let scene = Scene::builtin(&std::env::var("SCENE").unwrap_or_else(|_| "pick-place".into())).unwrap();
    let object = args.get(2).cloned().unwrap_or_else(|| scene.resolved[0].label.clone());
    let place = args
        .get(3)
        .cloned()
        .unwrap_or_else(|| scene.spec.places[0].name.clone());
    let arm = match args.get(4).map(String::as_str) {
        Some("right") => Arm::Right,
        _ => Arm::Left,
    };
    let retry = args.get(5).is_some_and(|s| s == "retry");
    let task = match kind {
        "hold" => TeachTask::PickHold { object, arm },
        "handover" => TeachTask::HandOver { object, arm },
        "touch" => TeachTask::Touch { object, arm },
        "wander" => TeachTask::Wander { arm, seconds: 12.0 },
        _ => TeachTask::PickPlace {
            object,
            place,
            arm,
            retry,
        },
    };
    let mut sim = DexterSim::new(&scene, SimSettings::default()).unwrap();
    dexter_sim::hardware::park_robot(&mut sim, scene.spec.table.height).unwrap();
    for _ in 0..200 {
        sim.step();
    }
    let teacher = Teacher::new(&sim, &scene, &task, 7).unwrap();
    let lib = Library::builtin();
    let mut sink = Sink {
        bank: MonitorBank::new(&lib, MonitorConfig::default()),
        obs: vec![],
        percepts: vec![],
        last: vec![],
        names: lib.action_names().iter().map(|s| s.to_string()).collect(),
    };
    let wall = std::time::Instant::now();
    let r = run_demonstration(
        &mut sim,
        &scene,
        TeleopSource::Script(Box::new(teacher)),
        &DemoSettings::default(),
        &mut sink,
    )
    .unwrap();
    println!("{r:?} wall {:.1}s", wall.elapsed().as_secs_f64());
    let engine = schema::Engine::new(&lib, schema::InferenceConfig::default()).unwrap();
    let inf = engine.infer(&sink.obs, &sink.percepts).unwrap();
    for h in &inf.posterior.hypotheses {
        println!(
            "{:>16} log p = {:?} posterior {:.4}",
            h.schema, h.log_evidence, h.posterior
        );
    }
    for v in &inf.state_path {
        println!("  {:>6.1}-{:>6.1} {} {}", v.t_start, v.t_end, v.schema, v.state);
    }
    if let Ok(name) = std::env::var("SCHEMA") {
        for v in engine.state_path(&name, &sink.obs).unwrap() {
            println!(
                "  [{name}] {:>6.1}-{:>6.1} {} {}",
                v.t_start, v.t_end, v.schema, v.state
            );
        }
    }
    for i in &inf.instances {
        println!(
            "instance {} {:.1}-{:.1} object {:?} place {:?} arm {:?} map {} {:.3}",
            i.schema, i.t_start, i.t_end, i.object, i.place, i.arm, i.posterior.map, i.posterior.map_posterior
        );
    }
    for (i, o) in scene.resolved.iter().enumerate() {
        println!(
            "{} at {:?}",
            o.label,
            sim.object_state(i).pose.translation.vector.as_slice()
        );
    }
}
