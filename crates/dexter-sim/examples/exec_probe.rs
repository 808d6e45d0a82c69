//! One scene of the execute experiment, for debugging: `cargo run --release -p dexter-sim --example
//! exec_probe -- <model.json> <seed> <index> [objects]` prints the report, and (with
//! `PBD_DEBUG_TRUTH=1`) every object's true position at each change of the robot's activity. Set
//! `RUST_LOG=schema=info,dexter::exec=debug` to see each action and the monitors after it,
//! `dexter::watch=trace` for every stereo blob; `PBD_DEBUG_MOVES=1` (with `PBD_DEBUG_TRUTH=1`) prints
//! each object's every move of more than 1 cm, with the time and the robot's activity.

use dexter_sim::execute::{Decider, MAX_ACTIONS, RunLog, Task, execute_scene};
use dexter_sim::experiment::random_scene;
use dexter_sim::physics::DexterSim;
use dexter_sim::scene::Scene;
use rand::Rng as _;

/// Prints the truth at activity changes.
struct Truth {
    on: bool,
    last: Vec<(String, [f64; 3])>,
    names: Vec<String>,
    /// `PBD_DEBUG_MOVES=1`: where each object was when its move was last printed.
    moves: Option<Vec<[f64; 3]>>,
    activity: String,
}

impl RunLog for Truth {
    fn world(&mut self, sim: &DexterSim, _activity: &str) {
        if !self.on {
            return;
        }
        if self.names.is_empty() {
            self.names = sim.header().object_names.clone();
        }
        self.last = (0..sim.objects().len())
            .map(|i| {
                let v = sim.object_state(i).pose.translation.vector;
                (self.names[i].clone(), [v.x, v.y, v.z])
            })
            .collect();
        if let Some(moves) = &mut self.moves {
            if moves.len() != self.last.len() {
                *moves = self.last.iter().map(|(_, p)| *p).collect();
            }
            for ((name, p), at) in self.last.iter().zip(moves.iter_mut()) {
                let d = ((p[0] - at[0]).powi(2) + (p[1] - at[1]).powi(2) + (p[2] - at[2]).powi(2)).sqrt();
                if d > 0.01 {
                    // The robot link whose origin is nearest: who may be pushing it.
                    let links = &sim.model().links;
                    let nearest = (0..links.len())
                        .map(|l| {
                            let o = sim.link_pose(l).translation.vector;
                            let d = ((o.x - p[0]).powi(2) + (o.y - p[1]).powi(2) + (o.z - p[2]).powi(2)).sqrt();
                            (d, l)
                        })
                        .min_by(|a, b| a.0.total_cmp(&b.0))
                        .map(|(d, l)| format!("{} at {d:.3} m", links[l].name))
                        .unwrap_or_default();
                    eprintln!(
                        "[{:7.2}] moved ({}; nearest link {nearest}): {name} ({:.3}, {:.3}, {:.3}) → ({:.3}, {:.3}, {:.3})",
                        sim.time(),
                        self.activity,
                        at[0],
                        at[1],
                        at[2],
                        p[0],
                        p[1],
                        p[2]
                    );
                    *at = *p;
                }
            }
        }
    }

    fn activity(&mut self, t: f64, activity: &str) {
        if !self.on {
            return;
        }
        self.activity = activity.to_string();
        let objs: Vec<String> = self
            .last
            .iter()
            .map(|(n, p)| format!("{n} ({:.3}, {:.3}, {:.3})", p[0], p[1], p[2]))
            .collect();
        eprintln!("[{t:7.2}] {activity}: {}", objs.join("; "));
    }
}

fn main() {
    tracing_subscriber::fmt()
        .with_env_filter(tracing_subscriber::EnvFilter::from_default_env())
        .with_writer(std::io::stderr)
        .without_time()
        .init();
    let args: Vec<String> = std::env::args().collect();
    let model = args.get(1).cloned().unwrap_or("pbd-demo/model.json".into());
    let seed: u64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(1);
    let i: usize = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(0);
    let objects: usize = args.get(4).and_then(|s| s.parse().ok()).unwrap_or(3);
    let base = Scene::builtin("sorting-demo").expect("built-in scene");
    let library = schema::Library::builtin();
    let scene = random_scene(&base, objects, &mut bayes::rng::stream(seed, i as u64)).expect("scene");
    for (r, o) in scene.resolved.iter().zip(&scene.spec.objects) {
        eprintln!("object {} at {:?} yaw {:.0}", r.label, o.xy, o.yaw_deg);
    }
    let run_seed = bayes::rng::stream(seed ^ 0x5EED_0F5C_E4E5, i as u64).next_u64();
    let mut log = Truth {
        on: std::env::var_os("PBD_DEBUG_TRUTH").is_some(),
        last: Vec::new(),
        names: Vec::new(),
        moves: std::env::var_os("PBD_DEBUG_MOVES").map(|_| Vec::new()),
        activity: String::new(),
    };
    let model = schema::procedural::ProceduralModel::load(&model).expect("model");
    let task = Task {
        library: &library,
        schema: model.schema_in(&library).expect("the model's schema"),
        decider: Decider::Model(&model),
        only_near: None,
        max_actions: MAX_ACTIONS,
    };
    match execute_scene(&scene, &format!("sorting-demo#{i}"), &task, run_seed, &mut log) {
        Ok(r) => println!("{r}"),
        Err(e) => eprintln!("error: {e}"),
    }
}
