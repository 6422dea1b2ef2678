//! Stable typed ids: names for things in a run that do not depend on `Entity` allocation order.

use bevy_ecs::component::Component;
use serde::{Deserialize, Serialize};
use std::fmt;

/// What kind of thing a [`StableId`] names. The discriminant is part of every RNG stream id, so
/// variants may be added but never reordered.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[repr(u8)]
pub enum IdKind {
    /// A road of the level, by its index in the level file.
    Road = 1,
    /// A vehicle, numbered in spawn order.
    Vehicle = 2,
    /// A spawner, by its index in the level file.
    Spawner = 3,
    /// A destroyer, by its index in the level file.
    Destroyer = 4,
    /// A trigger, by its index in the level file.
    Trigger = 5,
    /// A group of initial vehicles, by its index in the level file.
    InitialVehicles = 6,
    /// Anything a plugin defines for itself.
    Custom = 255,
}

/// A stable identity: a kind plus an index assigned deterministically (file order, spawn order).
#[derive(
    Component, Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize,
)]
pub struct StableId {
    /// What the id names.
    pub kind: IdKind,
    /// The index within its kind.
    pub index: u32,
}

impl StableId {
    /// An id of the given kind and index.
    pub const fn new(kind: IdKind, index: u32) -> StableId {
        StableId { kind, index }
    }

    /// The 64-bit number that selects this id's RNG stream: kind in the top byte, index below.
    pub const fn stream(self) -> u64 {
        ((self.kind as u64) << 56) | self.index as u64
    }
}

impl fmt::Display for StableId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let kind = match self.kind {
            IdKind::Road => "road",
            IdKind::Vehicle => "vehicle",
            IdKind::Spawner => "spawner",
            IdKind::Destroyer => "destroyer",
            IdKind::Trigger => "trigger",
            IdKind::InitialVehicles => "initial",
            IdKind::Custom => "custom",
        };
        write!(f, "{kind}#{}", self.index)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_of_different_kinds_never_collide() {
        let a = StableId::new(IdKind::Vehicle, 7).stream();
        let b = StableId::new(IdKind::Spawner, 7).stream();
        assert_ne!(a, b);
        assert_eq!(StableId::new(IdKind::Vehicle, 7).to_string(), "vehicle#7");
    }
}
