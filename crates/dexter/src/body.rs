//! The robot's own body from its model and encoders: link poses by forward kinematics. This is how
//! the robot knows where its palms, forearms and cameras are — never from the world.

use control_basis::math::Iso3;
use control_basis::{Chain, ChainBinding, ChainState, Hardware};

use crate::error::RobotError;

/// Forward kinematics of named links at the encoder readings, with one cached chain per link.
#[derive(Debug, Default)]
pub struct Body {
    links: Vec<Link>,
}

#[derive(Debug)]
struct Link {
    name: String,
    chain: Chain,
    state: ChainState,
    binding: ChainBinding,
    q: Vec<f64>,
}

impl Body {
    /// An empty cache.
    pub fn new() -> Self {
        Self::default()
    }

    /// World pose of `link` at the current encoder readings of `hw`.
    pub fn pose(&mut self, hw: &dyn Hardware, link: &str) -> Result<Iso3, RobotError> {
        let k = match self.links.iter().position(|l| l.name == link) {
            Some(k) => k,
            None => {
                let chain = Chain::new(hw.model(), "world", link)?;
                let binding = ChainBinding::by_name(&chain, hw.joint_names())?;
                let state = chain.new_state();
                let q = vec![0.0; chain.dof()];
                self.links.push(Link {
                    name: link.to_string(),
                    chain,
                    state,
                    binding,
                    q,
                });
                self.links.len() - 1
            }
        };
        let l = &mut self.links[k];
        l.binding.gather(hw.joint_positions(), &mut l.q);
        l.state.set_q(&l.chain, &l.q)?;
        control_basis::forward_kinematics(&l.chain, &mut l.state);
        Ok(*l.state.tip_pose())
    }
}
