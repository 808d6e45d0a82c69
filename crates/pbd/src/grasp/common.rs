//! Shared by the `pbd grasp` subcommands: presenting one object, choosing collision-free reachable
//! candidates, seeds and a small work pool.

use anyhow::{Result, anyhow, bail};
use dexter_sim::Arm;
use dexter_sim::grasp_trial::{self, Percept};
use dexter_sim::physics::{DexterSim, SimSettings};
use dexter_sim::scene::Scene;
use dexter_sim::teleop::{TeleopDriver, TeleopStream};
use grasp_topics::{Corpus, GraspScene, HandModel, ObjectShape, PreGrasp, RankedPreGrasp, Rejection, filter_and_rank};
use nalgebra::{Matrix2, Vector3};
use serde::Serialize;

use super::{DemoRecord, PresentOptions};

/// Presents one catalog presentation at a time on a scene's table.
#[derive(Debug, Clone)]
pub struct Presenter {
    /// The scene (table, cameras, catalog).
    pub base: Scene,
    /// Where objects are presented (m, world).
    pub xy: [f64; 2],
    /// The grasping arm.
    pub arm: Arm,
}

impl Presenter {
    /// From the command-line options (validated).
    pub fn new(args: &PresentOptions) -> Result<Self> {
        let base = super::open_scene(&args.scene)?;
        let [x, y] = [args.xy[0], args.xy[1]];
        let [x0, x1, y0, y1] = base.spec.table.bounds();
        if !(x.is_finite() && y.is_finite() && x > x0 && x < x1 && y > y0 && y < y1) {
            bail!("xy = ({x}, {y}): not on the table (x in ({x0}, {x1}), y in ({y0}, {y1}))");
        }
        Ok(Presenter {
            base,
            xy: [x, y],
            arm: args.arm.arm(),
        })
    }

    /// Every presentation of the catalog.
    pub fn presentations(&self) -> Vec<String> {
        self.base
            .catalog
            .presentation_names()
            .into_iter()
            .map(String::from)
            .collect()
    }

    /// The catalog object presentation `name` shows (`jif` for `jif-2`); `None` if unknown.
    pub fn object_of(&self, name: &str) -> Option<String> {
        let (i, _) = self.base.catalog.presentation(name).ok()?;
        self.base.catalog.objects.get(i).map(|o| o.name.clone())
    }

    /// Fails with the catalog's suggestions if `name` is not a presentation.
    pub fn check(&self, name: &str) -> Result<()> {
        self.base
            .catalog
            .presentation(name)
            .map(|_| ())
            .map_err(|e| anyhow!("unknown object: {e}"))
    }

    /// The scene with only `name` presented, and simulator settings for `seed`.
    pub fn scene(&self, name: &str, seed: u64) -> Result<(Scene, SimSettings)> {
        let scene = grasp_trial::present(&self.base, name, self.xy, 0.0)?;
        Ok((scene, super::sim_settings(seed)))
    }
}

/// The object as the robot measured it (§6.2.1): a sphere for a round top, otherwise an upright
/// box of its footprint's principal extents and its measured height — never the catalog shape.
pub fn seen_shape(percept: &Percept) -> (ObjectShape, nalgebra::UnitQuaternion<f64>) {
    let e = &percept.extent;
    let yaw = e.major_axis[1].atan2(e.major_axis[0]);
    let rot = nalgebra::UnitQuaternion::from_axis_angle(&nalgebra::Vector3::z_axis(), yaw);
    if e.model == "round" {
        (ObjectShape::Sphere { radius: 0.5 * e.height }, rot)
    } else {
        (
            ObjectShape::Box {
                half_extents: [e.half_major, e.half_minor, 0.5 * e.height],
            },
            rot,
        )
    }
}

/// Which generator a candidate came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Method {
    /// The visual grasp prototype model (opposing grasp: spread 0, §6.4.1).
    Model,
    /// The naive hemisphere baseline (three fingers equidistant: spread π/3, §6.5.1).
    Naive,
}

impl Method {
    /// Finger spread (rad) used with this method's candidates.
    pub fn spread(self) -> f64 {
        match self {
            Method::Model => 0.0,
            Method::Naive => std::f64::consts::FRAC_PI_3,
        }
    }

    /// Name in reports.
    pub fn name(self) -> &'static str {
        match self {
            Method::Model => "model",
            Method::Naive => "naive",
        }
    }
}

/// Why candidates were dropped.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct Rejections {
    /// The hand would intersect the object.
    pub hits_object: usize,
    /// The hand would intersect the table.
    pub hits_table: usize,
    /// The arm cannot reach the pre-grasp or its approach (IK).
    pub unreachable: usize,
}

/// The outcome of [`select_candidates`].
#[derive(Debug, Clone)]
pub struct Selection {
    /// The chosen candidates (≤ n), in rank order per round.
    pub chosen: Vec<RankedPreGrasp>,
    /// Candidates drawn in all.
    pub drawn: usize,
    /// Dropped and why.
    pub rejected: Rejections,
}

/// Draws candidates (`draw(k, rng)`) in rounds of 4n, drops those whose hand (pre-shaped as the
/// executor will do it) would hit the object (model candidates, and naive ones when
/// `naive_filtered`; see below) or the table, ranks the rest by distance from the
/// grasping arm's shoulder, and keeps the first that the arm can reach (pre-grasp, approach and
/// hover poses), until `n` are chosen or 10 rounds have been drawn. The object's pose for the filter
/// is what the robot knows: the catalog model in its presentation orientation at the seen centroid.
#[allow(clippy::too_many_arguments)]
pub fn select_candidates(
    presenter: &Presenter,
    scene: &Scene,
    reach_sim: &DexterSim,
    percept: &Percept,
    method: Method,
    n: usize,
    naive_filtered: bool,
    mut draw: impl FnMut(usize, &mut bayes::rng::Generator) -> Result<Vec<PreGrasp>>,
    rng: &mut bayes::rng::Generator,
) -> Result<Selection> {
    let c = percept.centroid();
    let (shape, rotation) = seen_shape(percept);
    let world_from_object = nalgebra::Isometry3::from_parts(
        nalgebra::Translation3::new(
            percept.extent.center[0],
            percept.extent.center[1],
            percept.table_z + 0.5 * percept.extent.height,
        ),
        rotation,
    );
    let shoulder = reach_sim
        .link_pose_by_name(&format!("{}/shoulder_yaw_link", presenter.arm.prefix()))?
        .translation
        .vector;
    let gs = GraspScene {
        shape,
        world_from_object,
        centroid: c,
        table_height: scene.spec.table.height,
        reach_origin: shoulder,
    };
    let hand = HandModel {
        spread: method.spread(),
        flexion: grasp_trial::PRESHAPE,
        ..HandModel::default()
    };
    let mut sel = Selection {
        chosen: Vec::new(),
        drawn: 0,
        rejected: Rejections::default(),
    };
    for _round in 0..10 {
        if sel.chosen.len() >= n {
            break;
        }
        let cands = draw(4 * n, rng)?;
        sel.drawn += cands.len();
        let f = filter_and_rank(&cands, &gs, &hand)?;
        let mut kept = f.kept;
        for (c, why) in f.rejected {
            match why {
                // The naive baseline puts the palm on a hemisphere of radius half the longest
                // dimension (§6.5.1), where the open fingers always reach into the object: it is not
                // filtered against the object (the seed's was not), only against the table.
                Rejection::HitsObject if method == Method::Naive && !naive_filtered => {
                    let world_from_palm = nalgebra::Isometry3::from_parts(
                        nalgebra::Translation3::from(c.position() + gs.centroid),
                        c.orientation(),
                    );
                    kept.push(RankedPreGrasp {
                        reach_distance: (world_from_palm.translation.vector - gs.reach_origin).norm(),
                        world_from_palm,
                        pre_grasp: c,
                    });
                }
                Rejection::HitsObject => sel.rejected.hits_object += 1,
                Rejection::HitsTable => sel.rejected.hits_table += 1,
            }
        }
        kept.sort_by(|a, b| a.reach_distance.total_cmp(&b.reach_distance));
        for k in kept {
            if sel.chosen.len() >= n {
                break;
            }
            let (hover, back) = grasp_trial::approach_waypoints(reach_sim, percept, presenter.arm, &k.world_from_palm)?;
            let ok = grasp_trial::pose_reachable(reach_sim, presenter.arm, &k.world_from_palm)?
                && grasp_trial::pose_reachable(reach_sim, presenter.arm, &back)?
                && grasp_trial::pose_reachable(reach_sim, presenter.arm, &hover)?;
            if ok {
                sel.chosen.push(k);
            } else {
                sel.rejected.unreachable += 1;
            }
        }
    }
    Ok(sel)
}

/// Replays teleoperation streams (one grasp each) on presentation `name`: the pre-grasp is the
/// measured palm pose when the commanded flexion first exceeds 1 rad; the grasp counts if, when the
/// stream ends (and 1 s later), the object has risen ≥ 8 cm and ≥ 2 hand parts touch it.
pub fn record_teleop(
    presenter: &Presenter,
    name: &str,
    streams: &[TeleopStream],
    seed: u64,
) -> Result<super::Recorded> {
    let (scene, settings) = presenter.scene(name, seed)?;
    let percept = match grasp_trial::perceive(&scene, &settings)? {
        Ok(p) => p,
        Err(why) => bail!("cannot see {name}: {why}"),
    };
    let mut grasps = Vec::new();
    let mut records = Vec::new();
    for stream in streams {
        let mut sim = DexterSim::new(&scene, settings.clone())?;
        dexter_sim::hardware::park_robot(&mut sim, scene.spec.table.height)?;
        for _ in 0..200 {
            sim.step();
        }
        let z0 = sim.object_state(0).pose.translation.z;
        let mut hw = dexter_sim::hardware::SimRobot::new(&mut sim, &scene, settings.seed)?;
        let mut driver = TeleopDriver::new(&hw)?;
        let mut replay = dexter_sim::teleop::Replay::new(stream.clone());
        let dt_c = 1.0 / dexter::skills::CONTROL_HZ;
        let mut pre: Option<(Arm, nalgebra::Isometry3<f64>)> = None;
        let end = replay.duration() + 1.0;
        let mut t = 0.0;
        while t <= end {
            let cmds = replay.at(t);
            if pre.is_none() {
                for c in cmds.iter().flatten() {
                    if c.flexion > 1.0 {
                        pre = Some((c.hand, driver.palm_pose(&hw, c.hand)));
                        break;
                    }
                }
            }
            driver.tick(&mut hw, &cmds, dt_c);
            control_basis::Hardware::advance(&mut hw, dt_c)?;
            t += dt_c;
        }
        let rose = hw.sim().object_state(0).pose.translation.z - z0;
        let Some((arm, palm)) = pre else {
            records.push(DemoRecord {
                object: name.to_string(),
                kind: "teleop".into(),
                kept: false,
                outcome: "the hand never closed (flexion never above 1 rad)".into(),
            });
            continue;
        };
        // Kept when the robot feels the object held at the end: two loaded fingertips carrying a
        // load (its own sensors, as for its own grasps).
        let touch = dexter::skills::TouchState::of(&dexter::skills::hand_fingertips(&hw, arm, &mut Vec::new()));
        let kept = touch.holding() && touch.load >= dexter::skills::MIN_LOAD;
        let parts = touch.loaded;
        if kept {
            let x = palm.translation.vector - percept.centroid();
            grasps.push(grasp_topics::DemoGrasp::new(
                &Vector3::new(x.x, x.y, x.z),
                &palm.rotation,
            ));
        }
        records.push(DemoRecord {
            object: name.to_string(),
            kind: "teleop".into(),
            kept,
            outcome: if kept {
                "lifted".into()
            } else {
                format!(
                    "object not held ({parts} loaded fingertips, load {:.2} N; rose {:.1} cm)",
                    touch.load,
                    rose * 100.0
                )
            },
        });
    }
    let mut corpus = Corpus::new();
    let mut skipped = Vec::new();
    if grasps.is_empty() {
        skipped.push((name.to_string(), "no replayed grasp held".to_string()));
    } else {
        let a = percept.appearance;
        corpus.push_object(name, &Matrix2::new(a[0][0], a[0][1], a[1][0], a[1][1]), grasps);
    }
    Ok((corpus, records, skipped))
}
