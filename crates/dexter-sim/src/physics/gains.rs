//! The motor units' PD gains (§3.1): one table, read by joint name, with the reason for each row.

/// PD gains and limits of one motor unit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotorGains {
    /// Stiffness (N·m/rad).
    pub kp: f64,
    /// Damping (N·m·s/rad).
    pub kd: f64,
    /// Effort limit (N·m).
    pub max_effort: f64,
}

/// Which joints a row of [`GAINS`] sets, by the joint's name.
#[derive(Debug, Clone, Copy)]
enum Joints {
    /// An arm joint: the name ends with this (`left/elbow_pitch_joint`) and is not the hand's (no
    /// `bhand` in it).
    Arm(&'static str),
    /// A hand joint: the name holds `joint` (`med_joint`) and, when given, `finger` (`finger_3`).
    Hand {
        joint: &'static str,
        finger: Option<&'static str>,
    },
    /// Every joint whose name starts with this (`head/`).
    Under(&'static str),
}

impl Joints {
    /// Whether the joint `name` is one of these.
    fn matches(self, name: &str) -> bool {
        match self {
            Joints::Arm(suffix) => name.ends_with(suffix) && !name.contains("bhand"),
            Joints::Hand { joint, finger } => name.contains(joint) && finger.is_none_or(|f| name.contains(f)),
            Joints::Under(prefix) => name.starts_with(prefix),
        }
    }
}

/// One row of [`GAINS`]: the joints it sets and their PD.
#[derive(Debug, Clone, Copy)]
struct Row {
    joints: Joints,
    /// Stiffness (N·m/rad).
    kp: f64,
    /// Damping (N·m·s/rad).
    kd: f64,
    /// The effort limit, at most the URDF's (`None`: the URDF's).
    effort_cap: Option<f64>,
}

/// A WAM joint's row: damping 5 % of the stiffness, the URDF's effort limit.
const fn arm(suffix: &'static str, kp: f64) -> Row {
    Row {
        joints: Joints::Arm(suffix),
        kp,
        kd: 0.05 * kp,
        effort_cap: None,
    }
}

/// Dexter's motor gains; the first row that names a joint sets it, and a joint no row names gets
/// [`OTHER`].
const GAINS: [Row; 11] = [
    // The WAM, from the grasp-physics probe.
    arm("base_yaw_joint", 2500.0),
    arm("shoulder_pitch_joint", 2500.0),
    arm("shoulder_yaw_joint", 1000.0),
    arm("elbow_pitch_joint", 800.0),
    arm("wrist_yaw_joint", 100.0),
    arm("wrist_pitch_joint", 100.0),
    arm("palm_yaw_joint", 20.0),
    // The fingers' closing (medial) joints. Low-kp PD: closes gently and does not squeeze the
    // object out (probe). Finger 3 opposes fingers 1 and 2 together, so it gets twice their
    // stiffness and effort: the squeeze is balanced and the object is not pushed towards F1/F2
    // while the hand closes.
    Row {
        joints: Joints::Hand {
            joint: "med_joint",
            finger: Some("finger_3"),
        },
        kp: 3.0,
        kd: 0.1,
        effort_cap: Some(3.0),
    },
    Row {
        joints: Joints::Hand {
            joint: "med_joint",
            finger: None,
        },
        kp: 1.5,
        kd: 0.05,
        effort_cap: Some(1.5),
    },
    // Spread: a soft PD at the URDF effort. (A stiff, worm-gear-like spread was tried: small balls
    // then wedge against the palm and are not released.)
    Row {
        joints: Joints::Hand {
            joint: "prox_joint",
            finger: None,
        },
        kp: 10.0,
        kd: 0.2,
        effort_cap: None,
    },
    // The head: pan, tilt and the cameras' vergence.
    Row {
        joints: Joints::Under("head/"),
        kp: 20.0,
        kd: 1.0,
        effort_cap: None,
    },
];

/// The gains of a joint no row of [`GAINS`] names.
const OTHER: Row = Row {
    joints: Joints::Under(""), // every joint
    kp: 10.0,
    kd: 0.5,
    effort_cap: None,
};

/// Default gains for a Dexter joint, from its name (WAM gains from the grasp-physics probe); `effort`
/// is the joint's URDF effort limit.
pub fn default_gains(joint: &str, effort: f64) -> MotorGains {
    let row = GAINS.iter().find(|r| r.joints.matches(joint)).unwrap_or(&OTHER);
    MotorGains {
        kp: row.kp,
        kd: row.kd,
        max_effort: row.effort_cap.map_or(effort, |cap| effort.min(cap)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each of Dexter's moving joints with the gains it had when they were chosen by substrings in
    /// code (checked bit for bit against that code, for every joint of the URDF and odd names, when
    /// the table replaced it): kp, kd and the effort limit for a URDF limit of 7 N·m.
    const PINNED: [(&str, f64, f64, f64); 15] = [
        ("base_yaw_joint", 2500.0, 125.0, 7.0),
        ("shoulder_pitch_joint", 2500.0, 125.0, 7.0),
        ("shoulder_yaw_joint", 1000.0, 50.0, 7.0),
        ("elbow_pitch_joint", 800.0, 40.0, 7.0),
        ("wrist_yaw_joint", 100.0, 5.0, 7.0),
        ("wrist_pitch_joint", 100.0, 5.0, 7.0),
        ("palm_yaw_joint", 20.0, 1.0, 7.0),
        ("bhand/finger_1/prox_joint", 10.0, 0.2, 7.0),
        ("bhand/finger_1/med_joint", 1.5, 0.05, 1.5),
        ("bhand/finger_1/dist_joint", 10.0, 0.5, 7.0),
        ("bhand/finger_2/prox_joint", 10.0, 0.2, 7.0),
        ("bhand/finger_2/med_joint", 1.5, 0.05, 1.5),
        ("bhand/finger_2/dist_joint", 10.0, 0.5, 7.0),
        ("bhand/finger_3/med_joint", 3.0, 0.1, 3.0),
        ("bhand/finger_3/dist_joint", 10.0, 0.5, 7.0),
    ];

    #[test]
    fn every_dexter_joint_keeps_its_gains() {
        let bits = |g: MotorGains| [g.kp.to_bits(), g.kd.to_bits(), g.max_effort.to_bits()];
        for (joint, kp, kd, max_effort) in PINNED {
            for arm in ["left", "right"] {
                let name = format!("{arm}/{joint}");
                let want = MotorGains { kp, kd, max_effort };
                assert_eq!(bits(default_gains(&name, 7.0)), bits(want), "{name}");
            }
        }
        for joint in [
            "head/pan_joint",
            "head/tilt_joint",
            "head/left_vergence_joint",
            "head/right_vergence_joint",
        ] {
            let want = MotorGains {
                kp: 20.0,
                kd: 1.0,
                max_effort: 7.0,
            };
            assert_eq!(bits(default_gains(joint, 7.0)), bits(want), "{joint}");
        }
        let other = MotorGains {
            kp: 10.0,
            kd: 0.5,
            max_effort: 7.0,
        };
        assert_eq!(bits(default_gains("chassis/left_camera_joint", 7.0)), bits(other));
        // A cap never raises the URDF's limit.
        assert_eq!(default_gains("left/bhand/finger_3/med_joint", 0.5).max_effort, 0.5);
        // Every moving joint of the URDF is pinned above.
        let model = control_basis::RobotModel::from_urdf_str(super::super::DEXTER_URDF).unwrap();
        for j in model.joints.iter().filter(|j| j.kind.is_moving()) {
            let pinned = PINNED
                .iter()
                .any(|p| j.name.strip_prefix("left/").or(j.name.strip_prefix("right/")) == Some(p.0));
            assert!(pinned || j.name.starts_with("head/"), "{} is not pinned", j.name);
        }
    }
}
