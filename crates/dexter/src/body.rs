//! The robot's own body from its model and encoders: link poses by forward kinematics. This is how
//! the robot knows where its palms, forearms and cameras are — never from the world.

use control_basis::math::Iso3;
use control_basis::{Chain, ChainBinding, ChainState, Hardware, RobotModel};

use crate::error::RobotError;

/// Forward kinematics of named links at the encoder readings, with one cached chain per link (a
/// link attached to the world through fixed joints only — the torso, the chassis cameras — has a
/// constant pose).
#[derive(Debug, Default)]
pub struct Body {
    links: Vec<Link>,
}

/// A link's pose: computed from its chain at the measured joints, or fixed. Few links (the ones
/// asked for) are held, so the size of the moving variant does not matter.
#[derive(Debug)]
#[allow(clippy::large_enum_variant)]
enum Pose {
    Moving {
        chain: Chain,
        state: ChainState,
        binding: ChainBinding,
        q: Vec<f64>,
    },
    Fixed(Iso3),
}

#[derive(Debug)]
struct Link {
    name: String,
    pose: Pose,
}

/// The pose of `link` if only fixed joints lie between it and the root.
pub fn fixed_pose(model: &RobotModel, link: usize) -> Option<Iso3> {
    let path = model.joints_from_root(link);
    path.iter().all(|&j| !model.joints[j].kind.is_moving()).then(|| {
        path.iter()
            .fold(Iso3::identity(), |acc, &j| acc * model.joints[j].origin)
    })
}

impl Body {
    /// An empty cache.
    pub fn new() -> Self {
        Self::default()
    }

    /// Index of `link` in the cache (added on first use).
    fn index(&mut self, hw: &dyn Hardware, link: &str) -> Result<usize, RobotError> {
        if let Some(k) = self.links.iter().position(|l| l.name == link) {
            return Ok(k);
        }
        let model = hw.model();
        let pose = match fixed_pose(model, model.link(link)?) {
            Some(p) => Pose::Fixed(p),
            None => {
                let chain = Chain::new(model, "world", link)?;
                let binding = ChainBinding::by_name(&chain, hw.joint_names())?;
                let state = chain.new_state();
                let q = vec![0.0; chain.dof()];
                Pose::Moving {
                    chain,
                    state,
                    binding,
                    q,
                }
            }
        };
        self.links.push(Link {
            name: link.to_string(),
            pose,
        });
        Ok(self.links.len() - 1)
    }

    /// World pose of `link` at the current encoder readings of `hw`.
    pub fn pose(&mut self, hw: &dyn Hardware, link: &str) -> Result<Iso3, RobotError> {
        let k = self.index(hw, link)?;
        match &mut self.links[k].pose {
            Pose::Fixed(p) => Ok(*p),
            Pose::Moving {
                chain,
                state,
                binding,
                q,
            } => {
                binding.gather(hw.joint_positions(), q);
                state.set_q(chain, q)?;
                control_basis::forward_kinematics(chain, state);
                Ok(*state.tip_pose())
            }
        }
    }
}
