//! `pbd robot info [URDF] [--json]`: what a robot model contains, and the chains one would control.
//!
//! A URDF is a tree; what a user drives are serial chains cut from it. So besides the counts, the
//! degrees of freedom and the `<mimic>` couplings, `info` lists two kinds of chains:
//!
//! - **named chains**, recognised from the link naming of the Barrett/Dexter models (works for any URDF
//!   that follows it): `P/base_link → P/wrist_palm_link` is the arm `P`, `H/palm_link →
//!   H/finger_K/tip_link` a finger, `X/base_link → X/S_camera_optical_frame` a camera of the head `X`;
//! - **leaf chains**, the generic view: from the root to every link that has no child.
//!
//! Each chain is cut with [`control_basis::Chain::new`], so its degree-of-freedom count is exactly the
//! number of columns `pbd robot fk` would print for it (a mimicking joint whose master lies off the
//! chain still counts its master).

use std::fmt;
use std::path::Path;

use control_basis::{CbError, Chain, JointKind, RobotModel};
use serde::Serialize;

use super::{LoadedModel, load_model};
use crate::table::{Table, num};

/// Loads the URDF at `urdf` (or the built-in Dexter) and summarises it.
///
/// Errors are [`crate::Error`]s: their [`crate::ErrorKind`] says what went wrong.
pub fn info(urdf: Option<&Path>) -> crate::Result<RobotSummary> {
    info_impl(urdf).map_err(crate::Error::from)
}

fn info_impl(urdf: Option<&Path>) -> anyhow::Result<RobotSummary> {
    RobotSummary::new(&load_model(urdf)?)
}

/// The JSON object of `pbd robot info --json`. Field names are a public interface (README).
#[derive(Debug, Clone, Serialize)]
pub struct RobotSummary {
    /// `built-in:dexter` or the URDF path as given.
    pub source: String,
    /// `<robot name=…>`.
    pub name: String,
    /// The root link.
    pub root: String,
    /// Links.
    pub link_count: usize,
    /// Joints (fixed ones included).
    pub joint_count: usize,
    /// Number of joints of each kind.
    pub joint_kinds: JointKindCounts,
    /// Independent moving joints (not fixed, not mimicking another).
    pub dof_count: usize,
    /// Those degrees of freedom.
    pub dofs: Vec<DofInfo>,
    /// `<mimic>` couplings.
    pub mimic: Vec<MimicInfo>,
    /// Chains recognised from the Barrett/Dexter link naming (arms, fingers, cameras).
    pub named_chains: Vec<NamedChain>,
    /// From the root to every link without a child.
    pub leaf_chains: Vec<LeafChain>,
}

/// Joints per kind.
#[derive(Debug, Clone, Default, Serialize)]
pub struct JointKindCounts {
    /// Revolute joints.
    pub revolute: usize,
    /// Continuous joints.
    pub continuous: usize,
    /// Prismatic joints.
    pub prismatic: usize,
    /// Fixed joints.
    pub fixed: usize,
}

/// One degree of freedom. Absent limits are `null` in JSON (serde_json writes non-finite numbers so).
#[derive(Debug, Clone, Serialize)]
pub struct DofInfo {
    /// Joint name.
    pub name: String,
    /// Kind.
    pub kind: JointKind,
    /// Parent link.
    pub parent: String,
    /// Child link.
    pub child: String,
    /// Lower position limit (rad or m).
    pub lower: f64,
    /// Upper position limit.
    pub upper: f64,
    /// Velocity limit.
    pub velocity: f64,
    /// Effort limit.
    pub effort: f64,
}

/// `q_joint = multiplier · q_follows + offset`.
#[derive(Debug, Clone, Serialize)]
pub struct MimicInfo {
    /// The mimicking joint.
    pub joint: String,
    /// The joint it follows.
    pub follows: String,
    /// Multiplier.
    pub multiplier: f64,
    /// Offset.
    pub offset: f64,
}

/// A chain recognised by name.
#[derive(Debug, Clone, Serialize)]
pub struct NamedChain {
    /// `left arm`, `right hand finger 2`, `head left camera`.
    pub name: String,
    /// Base link.
    pub base: String,
    /// Tip link.
    pub tip: String,
    /// Its variables.
    pub dof: usize,
    /// The chain's variables in `fk` column order.
    pub dof_names: Vec<String>,
}

/// The chain from the root to a link with no child.
#[derive(Debug, Clone, Serialize)]
pub struct LeafChain {
    /// The leaf link.
    pub link: String,
    /// Its variables.
    pub dof: usize,
    /// The chain's variables in `fk` column order.
    pub dof_names: Vec<String>,
}

impl RobotSummary {
    /// Summarises a loaded model.
    pub fn new(loaded: &LoadedModel) -> anyhow::Result<Self> {
        let model = &loaded.model;
        let mut kinds = JointKindCounts::default();
        for j in &model.joints {
            *match j.kind {
                JointKind::Revolute => &mut kinds.revolute,
                JointKind::Continuous => &mut kinds.continuous,
                JointKind::Prismatic => &mut kinds.prismatic,
                JointKind::Fixed => &mut kinds.fixed,
            } += 1;
        }
        let dofs: Vec<DofInfo> = model
            .actuated_joints()
            .map(|j| DofInfo {
                name: j.name.clone(),
                kind: j.kind,
                parent: model.links[j.parent].name.clone(),
                child: model.links[j.child].name.clone(),
                lower: j.limits.lower,
                upper: j.limits.upper,
                velocity: j.limits.velocity,
                effort: j.limits.effort,
            })
            .collect();
        let mimic = model
            .joints
            .iter()
            .filter_map(|j| {
                j.mimic.as_ref().map(|m| MimicInfo {
                    joint: j.name.clone(),
                    follows: m.joint.clone(),
                    multiplier: m.multiplier,
                    offset: m.offset,
                })
            })
            .collect();
        let root = model.links[model.root].name.clone();

        let mut named_chains = Vec::new();
        for (name, base, tip) in named_chain_candidates(model) {
            // Candidates are guesses from link names; one without a moving joint is simply not a chain.
            if let Some(dof_names) = chain_dofs(model, &base, &tip)?.filter(|d| !d.is_empty()) {
                named_chains.push(NamedChain {
                    name,
                    base,
                    tip,
                    dof: dof_names.len(),
                    dof_names,
                });
            }
        }
        let mut has_child = vec![false; model.links.len()];
        for j in &model.joints {
            has_child[j.parent] = true;
        }
        let mut leaf_chains = Vec::new();
        for (i, link) in model.links.iter().enumerate() {
            if has_child[i] || i == model.root {
                continue;
            }
            let dof_names = chain_dofs(model, &root, &link.name)?.unwrap_or_default();
            leaf_chains.push(LeafChain {
                link: link.name.clone(),
                dof: dof_names.len(),
                dof_names,
            });
        }
        Ok(RobotSummary {
            source: loaded.source.label(),
            name: model.name.clone(),
            root,
            link_count: model.links.len(),
            joint_count: model.joints.len(),
            joint_kinds: kinds,
            dof_count: dofs.len(),
            dofs,
            mimic,
            named_chains,
            leaf_chains,
        })
    }
}

/// The variables of the chain `base → tip`; `Some(empty)` when the path has no moving joint, `None` when
/// the two links do not form a chain at all.
fn chain_dofs(model: &RobotModel, base: &str, tip: &str) -> anyhow::Result<Option<Vec<String>>> {
    match Chain::new(model, base, tip) {
        Ok(chain) => Ok(Some(chain.dofs().iter().map(|d| d.name.clone()).collect())),
        Err(CbError::NoChain { .. }) => Ok(Some(Vec::new())),
        Err(e) => Err(anyhow::Error::new(e).context(format!("cutting the chain {base} -> {tip}"))),
    }
}

/// `(name, base, tip)` of the chains recognised from Barrett/Dexter link naming: arms, then fingers,
/// then head cameras, each in file order.
fn named_chain_candidates(model: &RobotModel) -> Vec<(String, String, String)> {
    let has = |name: &str| model.link(name).is_ok();
    let (mut arms, mut fingers, mut cameras) = (Vec::new(), Vec::new(), Vec::new());
    for link in &model.links {
        let tip = link.name.as_str();
        if let Some(prefix) = tip.strip_suffix("/wrist_palm_link") {
            let base = format!("{prefix}/base_link");
            if has(&base) {
                arms.push((format!("{prefix} arm"), base, tip.to_string()));
            }
        }
        if let Some((hand, finger)) = tip.strip_suffix("/tip_link").and_then(|r| r.rsplit_once('/'))
            && finger.starts_with("finger")
        {
            let base = format!("{hand}/palm_link");
            if has(&base) {
                let hand_name = hand
                    .strip_suffix("/bhand")
                    .map(|p| format!("{p} hand"))
                    .unwrap_or(hand.to_string());
                fingers.push((
                    format!("{hand_name} {}", finger.replace('_', " ")),
                    base,
                    tip.to_string(),
                ));
            }
        }
        if let Some((head, frame)) = tip.rsplit_once('/')
            && let Some(side) = frame.strip_suffix("_camera_optical_frame")
        {
            let base = format!("{head}/base_link");
            if has(&base) {
                cameras.push((format!("{head} {side} camera"), base, tip.to_string()));
            }
        }
    }
    arms.into_iter().chain(fingers).chain(cameras).collect()
}

impl fmt::Display for RobotSummary {
    fn fmt(&self, out: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = self;
        let k = &s.joint_kinds;
        writeln!(out, "robot   {}   (from {})", s.name, s.source)?;
        writeln!(out, "root    {}", s.root)?;
        writeln!(out, "links   {}", s.link_count)?;
        writeln!(
            out,
            "joints  {}   ({} revolute, {} continuous, {} prismatic, {} fixed)",
            s.joint_count, k.revolute, k.continuous, k.prismatic, k.fixed
        )?;
        writeln!(out)?;
        writeln!(
            out,
            "degrees of freedom: {}   (independent moving joints; {} more follow them through <mimic>)",
            s.dof_count,
            s.mimic.len()
        )?;
        let mut t = Table::new(["joint", "kind", "lower", "upper", "velocity", "effort"]);
        for d in &s.dofs {
            t.row([
                d.name.clone(),
                format!("{:?}", d.kind).to_lowercase(),
                num(d.lower, 4),
                num(d.upper, 4),
                num(d.velocity, 3),
                num(d.effort, 2),
            ]);
        }
        write!(out, "{}", t.render(2))?;
        writeln!(out, "  (rad or m; rad/s or m/s; N·m or N; inf = no limit given)")?;
        if !s.mimic.is_empty() {
            writeln!(out)?;
            writeln!(out, "mimic couplings: q_joint = multiplier * q_follows + offset")?;
            let mut t = Table::new(["joint", "follows", "multiplier", "offset"]);
            for m in &s.mimic {
                t.row([
                    m.joint.clone(),
                    m.follows.clone(),
                    num(m.multiplier, 6),
                    num(m.offset, 6),
                ]);
            }
            write!(out, "{}", t.render(2))?;
        }
        if !s.named_chains.is_empty() {
            writeln!(out)?;
            writeln!(out, "named chains (use with: pbd robot fk --base BASE --tip TIP --q …)")?;
            let mut t = Table::new(["chain", "base", "tip", "dof"]);
            for c in &s.named_chains {
                t.row([c.name.clone(), c.base.clone(), c.tip.clone(), c.dof.to_string()]);
            }
            write!(out, "{}", t.render(2))?;
        }
        writeln!(out)?;
        writeln!(out, "chains from the root '{}' to each leaf link", s.root)?;
        let mut t = Table::new(["leaf link", "dof"]);
        for c in &s.leaf_chains {
            t.row([c.link.clone(), c.dof.to_string()]);
        }
        write!(out, "{}", t.render(2))?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::robot::ModelSource;

    fn dexter() -> RobotSummary {
        RobotSummary::new(&load_model(None).unwrap()).unwrap()
    }

    #[test]
    fn dexter_named_chains_are_found() {
        let s = dexter();
        let find = |name: &str| s.named_chains.iter().find(|c| c.name == name);
        let left = find("left arm").expect("left arm");
        assert_eq!(
            (left.base.as_str(), left.tip.as_str(), left.dof),
            ("left/base_link", "left/wrist_palm_link", 7)
        );
        assert_eq!(find("right arm").unwrap().dof, 7);
        for side in ["left", "right"] {
            for k in 1..=3 {
                let c = find(&format!("{side} hand finger {k}")).unwrap();
                // Spread + flexion for fingers 1 and 2 (2's spread follows 1's), flexion only for finger 3.
                assert_eq!(c.dof, if k == 3 { 1 } else { 2 }, "{}", c.name);
            }
        }
        let cam = find("head left camera").unwrap();
        assert_eq!(cam.tip, "head/left_camera_optical_frame");
        assert_eq!(cam.dof, 3);
    }

    #[test]
    fn leaf_chains_exclude_the_root_and_count_mimic_masters() {
        let s = dexter();
        assert!(s.leaf_chains.iter().all(|c| c.link != s.root));
        // Finger 2's spread mimics finger 1's: the chain to finger 2's tip has 7 arm variables, finger 1's
        // spread (the master) and finger 2's flexion (its distal joint follows it).
        let f2 = s
            .leaf_chains
            .iter()
            .find(|c| c.link == "left/bhand/finger_2/tip_link")
            .unwrap();
        assert_eq!(f2.dof, 9);
        assert!(f2.dof_names.contains(&"left/bhand/finger_1/prox_joint".to_string()));
    }

    #[test]
    fn single_moving_joint_urdf_summarises() {
        let urdf = r#"<robot name="one"><link name="a"/><link name="b"/>
            <joint name="j" type="continuous"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/></joint></robot>"#;
        let loaded = LoadedModel {
            source: ModelSource::File("one.urdf".into()),
            model: RobotModel::from_urdf_str(urdf).unwrap(),
        };
        let s = RobotSummary::new(&loaded).unwrap();
        assert_eq!(s.dof_count, 1);
        assert!(s.named_chains.is_empty());
        assert_eq!(s.leaf_chains.len(), 1);
        assert_eq!(s.leaf_chains[0].dof, 1);
        let json = serde_json::to_value(&s).unwrap();
        assert!(
            json["dofs"][0]["lower"].is_null(),
            "a continuous joint has no position limit"
        );
    }
}
