//! How a schema library's abstract actions bind to Dexter's controllers: by their signature
//! d(C) = (potential φ, feedback frame F_f, effector frame F_τ) (3.22), never by their names — a
//! library that calls Reach `approach` runs the same controller, and a schema a user writes from the
//! library's actions runs without code changes.

use schema::library::Action;
use schema::{ActionKind, Library};

/// One of Dexter's closed-loop skills ([`crate::skills`]), as the executive runs it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Skill {
    /// Search-Track (§3.2.2.1): a segment foveated by both head cameras.
    SearchTrack,
    /// Reach to a seen segment: the approach above it, the pre-grasp, the descent to the grasp pose.
    ReachObject,
    /// Grasp: close the hand until opposing fingertips squeeze the object, the fingers still.
    Grasp,
    /// Reach ◁ Grasp to a hold height: lift the grasped object 10 cm and weigh it.
    Hold,
    /// Reach ◁ Place (Fig. 3.8): carry the held object over the place (or the handoff spot) and
    /// lower it until the support takes its load.
    Place,
    /// Release: open the hand and retreat.
    Release,
    /// Touch: fingertip contact with a segment without an opposing grasp, then retreat.
    Touch,
}

impl Skill {
    /// Every skill.
    pub const ALL: [Skill; 7] = [
        Skill::SearchTrack,
        Skill::ReachObject,
        Skill::Grasp,
        Skill::Hold,
        Skill::Place,
        Skill::Release,
        Skill::Touch,
    ];

    /// The skill an action of `kind` binds to; `None` for Reach-to-place, which Dexter never runs
    /// on its own (Pick-And-Place's Place carries the object there).
    pub fn of_kind(kind: ActionKind) -> Option<Skill> {
        match kind {
            ActionKind::SearchTrack => Some(Skill::SearchTrack),
            ActionKind::ReachObject => Some(Skill::ReachObject),
            ActionKind::Grasp => Some(Skill::Grasp),
            ActionKind::Hold => Some(Skill::Hold),
            ActionKind::ReachPlace => None,
            ActionKind::Place => Some(Skill::Place),
            ActionKind::Release => Some(Skill::Release),
            ActionKind::Touch => Some(Skill::Touch),
        }
    }

    /// The signature an abstract action must have to bind to this skill: (potential, feedback
    /// frame, effector frame), as a library spells them ([`ActionKind::signature`]).
    pub fn signature(self) -> (&'static str, &'static str, &'static str) {
        ActionKind::ALL
            .into_iter()
            .find(|&k| Skill::of_kind(k) == Some(self))
            .map(ActionKind::signature)
            .unwrap_or(("", "", ""))
    }

    /// The skill an abstract action binds to, by its signature; `None`: Dexter has no controller
    /// for it (e.g. `reach_place`, which Pick-And-Place never runs on its own: its Place carries).
    pub fn of(action: &Action) -> Option<Skill> {
        ActionKind::of(action).and_then(Skill::of_kind)
    }

    /// The phase of a task the skill is, as failure reports name it: `search`, `reach`, `grasp`,
    /// `hold`, `place`, `release`, `touch`.
    pub fn phase(self) -> &'static str {
        match self {
            Skill::SearchTrack => "search",
            Skill::ReachObject => "reach",
            Skill::Grasp => "grasp",
            Skill::Hold => "hold",
            Skill::Place => "place",
            Skill::Release => "release",
            Skill::Touch => "touch",
        }
    }

    /// Whether the skill moves an arm (and so needs ψ to bind one).
    pub fn uses_arm(self) -> bool {
        !matches!(self, Skill::SearchTrack)
    }
}

/// A library's actions bound to Dexter's skills (by index into `library.actions`).
#[derive(Debug, Clone, Default)]
pub struct SkillMap {
    names: Vec<String>,
    skills: Vec<Option<Skill>>,
}

impl SkillMap {
    /// Binds every action of `library` by its signature.
    pub fn new(library: &Library) -> Self {
        SkillMap {
            names: library.actions.iter().map(|a| a.name.clone()).collect(),
            skills: library.actions.iter().map(Skill::of).collect(),
        }
    }

    /// The skill the action named `action` binds to.
    pub fn skill(&self, action: &str) -> Option<Skill> {
        self.names.iter().position(|n| n == action).and_then(|i| self.skills[i])
    }

    /// The skill the library's action at `index` binds to.
    pub fn at(&self, index: usize) -> Option<Skill> {
        self.skills.get(index).copied().flatten()
    }

    /// The index (into the library's actions, = the entry of x) of the first action bound to
    /// `skill`.
    pub fn index(&self, skill: Skill) -> Option<usize> {
        self.skills.iter().position(|s| *s == Some(skill))
    }

    /// The name of the first action bound to `skill`.
    pub fn name(&self, skill: Skill) -> Option<&str> {
        self.index(skill).map(|i| self.names[i].as_str())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_builtin_library_binds_by_signature_and_a_renamed_action_binds_the_same() {
        let lib = Library::builtin();
        let map = SkillMap::new(&lib);
        assert_eq!(map.skill("reach_object"), Some(Skill::ReachObject));
        assert_eq!(map.skill("grasp"), Some(Skill::Grasp));
        assert_eq!(map.skill("touch"), Some(Skill::Touch));
        assert_eq!(map.skill("place"), Some(Skill::Place));
        assert_eq!(map.skill("reach_place"), None);
        assert_eq!(map.skill("no_such_action"), None);
        // Every skill has exactly one action in the built-in library.
        for s in Skill::ALL {
            assert_eq!(
                lib.actions.iter().filter(|a| Skill::of(a) == Some(s)).count(),
                1,
                "{s:?}"
            );
        }
        // The name does not matter, the signature does.
        let mut renamed = lib.actions[lib.action("reach_object").unwrap()].clone();
        renamed.name = "approach".into();
        assert_eq!(Skill::of(&renamed), Some(Skill::ReachObject));
        renamed.effector = "head".into();
        assert_eq!(Skill::of(&renamed), None);
    }
}
