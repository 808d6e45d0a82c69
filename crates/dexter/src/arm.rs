//! Dexter's two arms (and hands).

use serde::{Deserialize, Serialize};

/// Which arm (and hand).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Arm {
    /// The left arm (+y).
    Left,
    /// The right arm (−y).
    Right,
}

impl Arm {
    /// Both arms, left first.
    pub const BOTH: [Arm; 2] = [Arm::Left, Arm::Right];
    /// The URDF prefix (`left`, `right`).
    pub fn prefix(self) -> &'static str {
        match self {
            Arm::Left => "left",
            Arm::Right => "right",
        }
    }
    /// The other arm.
    pub fn other(self) -> Arm {
        match self {
            Arm::Left => Arm::Right,
            Arm::Right => Arm::Left,
        }
    }
    /// 0 for left, 1 for right.
    pub fn index(self) -> usize {
        match self {
            Arm::Left => 0,
            Arm::Right => 1,
        }
    }
    /// Parses `left` / `right`.
    pub fn parse(s: &str) -> Option<Arm> {
        match s {
            "left" => Some(Arm::Left),
            "right" => Some(Arm::Right),
            _ => None,
        }
    }
}

impl std::fmt::Display for Arm {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.prefix())
    }
}
