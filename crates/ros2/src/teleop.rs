//! Teleoperation over ROS 2: a teacher's hand samples — the palm surface's pose
//! (`geometry_msgs/PoseStamped`, world frame) and the mean finger flexion (`std_msgs/Float64`) per
//! hand, on the topics of [`crate::config::TeleopConfig`]. The robot reads the newest sample of each
//! hand ([`crate::Ros2Hardware::teleop`]); a served world with a teacher publishes them
//! ([`Teleoperator`], [`crate::serve_with`]).

use ros2_client::Subscription;

use crate::Ros2Error;
use crate::config::TeleopConfig;
use crate::dds::{Endpoint, take};
use crate::msg::{self, types};

/// One hand's sample.
#[derive(Debug, Clone, PartialEq)]
pub struct HandSample {
    /// The hand (`TeleopConfig::hand`: `left`, `right`).
    pub hand: String,
    /// When it was taken (s, the robot's clock).
    pub stamp: f64,
    /// Palm-surface position (m, world).
    pub position: [f64; 3],
    /// Palm-surface orientation, unit quaternion `[x, y, z, w]`.
    pub orientation: [f64; 4],
    /// Mean finger flexion (rad).
    pub flexion: f64,
}

/// A teacher beside a served robot (a person at a glove; in the simulator a scripted teacher who
/// sees the world): asked for new samples after each advance of the world, before its state is
/// published.
pub trait Teleoperator<H: ?Sized> {
    /// Pushes this instant's new samples (none when the hands have not moved on) onto `out`.
    fn samples(&mut self, hw: &mut H, out: &mut Vec<HandSample>) -> Result<(), Ros2Error>;
}

/// The robot side's subscriptions: the newest sample per hand.
pub(crate) struct TeleopInput {
    hands: Vec<TeleopHand>,
    latest: Vec<Option<HandSample>>,
}

struct TeleopHand {
    config: TeleopConfig,
    pose: Subscription<msg::PoseStamped>,
    flexion: Subscription<msg::Float64>,
    last_flexion: f64,
}

impl TeleopInput {
    pub(crate) fn new(endpoint: &mut Endpoint, config: &[TeleopConfig]) -> Result<Self, Ros2Error> {
        let mut hands = Vec::new();
        for c in config {
            hands.push(TeleopHand {
                config: c.clone(),
                pose: endpoint.subscription(&c.pose_topic, types::POSE_STAMPED)?,
                flexion: endpoint.subscription(&c.flexion_topic, types::FLOAT64)?,
                last_flexion: 0.0,
            });
        }
        Ok(TeleopInput {
            latest: vec![None; hands.len()],
            hands,
        })
    }

    /// Takes what arrived: each hand's newest pose with the newest flexion taken before it (a teacher
    /// publishes the flexion, then the pose).
    pub(crate) fn poll(&mut self, world_frame: &str) -> Result<&[Option<HandSample>], Ros2Error> {
        for (h, latest) in self.hands.iter_mut().zip(&mut self.latest) {
            let bad = |topic: &str, message: String| Ros2Error::Message {
                topic: topic.to_string(),
                message,
            };
            while let Some(f) = take(&h.flexion, &h.config.flexion_topic)? {
                if !f.data.is_finite() {
                    return Err(bad(
                        &h.config.flexion_topic,
                        format!("flexion {} is not finite", f.data),
                    ));
                }
                h.last_flexion = f.data;
            }
            while let Some(p) = take(&h.pose, &h.config.pose_topic)? {
                if !(p.header.frame_id.is_empty() || p.header.frame_id == world_frame) {
                    return Err(bad(
                        &h.config.pose_topic,
                        format!(
                            "a pose in frame `{}`; the palm pose must be in `{world_frame}`",
                            p.header.frame_id
                        ),
                    ));
                }
                let (v, q) = (p.pose.position, p.pose.orientation);
                let values = [v.x, v.y, v.z, q.x, q.y, q.z, q.w];
                let norm = (q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w).sqrt();
                if values.iter().any(|x| !x.is_finite()) || !(0.5..=1.5).contains(&norm) {
                    return Err(bad(
                        &h.config.pose_topic,
                        format!("a pose that is not finite or not a unit quaternion: {values:?}"),
                    ));
                }
                *latest = Some(HandSample {
                    hand: h.config.hand.clone(),
                    stamp: p.header.stamp.secs(),
                    position: [v.x, v.y, v.z],
                    // As sent (a robot normalises when it turns it into a rotation).
                    orientation: [q.x, q.y, q.z, q.w],
                    flexion: h.last_flexion,
                });
            }
        }
        Ok(&self.latest)
    }
}
