//! Why an edit or a save was refused.

use crate::joins::JoinError;
use flockway_level::{ItemKind, ItemRef, LevelError};
use glam::DVec3;

/// Why an edit or a save was refused. The level is unchanged; the text says what and where.
#[derive(Debug, thiserror::Error)]
pub enum EditError {
    /// A list index that does not exist.
    #[error("there is no {what} {index} (the level has {count})")]
    NoSuch {
        /// What the list holds ("road", "spawner", "junction", …).
        what: &'static str,
        /// The index asked for.
        index: usize,
        /// How many there are.
        count: usize,
    },
    /// A control point index that does not exist.
    #[error("road `{road}` has no point {index} (it has {count})")]
    NoPoint {
        /// The road.
        road: String,
        /// The index asked for.
        index: usize,
        /// How many points it has.
        count: usize,
    },
    /// A name that names no item.
    #[error("there is no {0}")]
    Unknown(ItemRef),
    /// An empty name.
    #[error("a {0} needs a name")]
    EmptyName(ItemKind),
    /// A name another item of the same kind has.
    #[error("another {} is named `{}`", .0.kind, .0.name)]
    NameTaken(ItemRef),
    /// A number outside its field's range (the schema's, which validation also uses).
    #[error("{field} {value}{unit}: expected {min} to {max}{unit}")]
    OutOfRange {
        /// The field.
        field: &'static str,
        /// The value given.
        value: f64,
        /// Smallest accepted.
        min: f64,
        /// Largest accepted.
        max: f64,
        /// Its unit, with a leading space (or empty).
        unit: &'static str,
    },
    /// A position that is not finite.
    #[error("position {0} is not finite")]
    NotFinite(DVec3),
    /// An arc position that is negative or not finite.
    #[error("arc position {0} m: expected a finite number of metres from the road's start")]
    BadArc(f64),
    /// A road linked onto itself.
    #[error("a road cannot lead onto itself: close it into a loop instead")]
    OntoItself,
    /// A link between lanes one of the roads does not have.
    #[error(
        "lane {from_lane} onto lane {to_lane}: `{from}` has {from_lanes} lane(s), `{to}` has \
         {to_lanes}"
    )]
    LinkLane {
        /// The road that leads on.
        from: String,
        /// Its lane.
        from_lane: u32,
        /// Its lane count.
        from_lanes: u32,
        /// The road it leads onto.
        to: String,
        /// That road's lane.
        to_lane: u32,
        /// Its lane count.
        to_lanes: u32,
    },
    /// A deletion refused while other items refer to the item.
    #[error(
        "{item} is used by {}: change or remove {} first",
        .by.join(", "),
        if .by.len() == 1 { "it" } else { "them" }
    )]
    InUse {
        /// The item.
        item: ItemRef,
        /// Where it is referred to, in words.
        by: Vec<String>,
    },
    /// A volume destroyer moved along a road.
    #[error("a volume destroyer is not on a road: edit its corners")]
    NotOnRoad,
    /// A [`crate::Command::Set`] naming no item.
    #[error("there is no {0}")]
    NoTarget(crate::Target),
    /// A [`crate::Command::Set`] whose field or value does not fit the item.
    #[error("{target}: cannot set `{field}`: {reason}")]
    BadField {
        /// The item.
        target: crate::Target,
        /// The field's path.
        field: String,
        /// Why.
        reason: String,
    },
    /// A join that cannot be made.
    #[error(transparent)]
    Join(#[from] JoinError),
    /// The edit would add a problem `flockway run` rejects.
    #[error("{0}")]
    AddsProblem(String),
    /// Save without a file.
    #[error("the level has no file yet: use Save As")]
    NoFile,
    /// Saving would write a level that `flockway run` rejects: fix these first.
    #[error("Not saved, because `flockway run` would refuse the level: {0}")]
    Invalid(String),
    /// Reading or writing a file failed.
    #[error(transparent)]
    File(#[from] LevelError),
}

/// `value` if it lies in `range`, else the error that names the field and the range.
pub(crate) fn in_range(
    field: &'static str,
    value: f64,
    range: &std::ops::RangeInclusive<f64>,
    unit: &'static str,
) -> Result<f64, EditError> {
    if range.contains(&value) {
        Ok(value)
    } else {
        Err(EditError::OutOfRange {
            field,
            value,
            min: *range.start(),
            max: *range.end(),
            unit,
        })
    }
}
