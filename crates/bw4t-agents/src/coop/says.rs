//! The team's sentences in the shared message language: what a cooperative agent says
//! (always a checked [`Said`]) and what it hears, read into the facts its play uses.

use std::collections::BTreeMap;

use bw4t_map::Colour;
use bw4t_protocol::Said;

/// `going_to ROOM`: the sender looks into ROOM; others pick another room.
pub(super) fn going_to(room: &str) -> Said {
    Said { room: Some(room.to_string()), ..Said::new("going_to") }
}

/// What ROOM holds now: `empty ROOM`, or one `contains_many ROOM COUNT COLOUR` per colour.
pub(super) fn report(room: &str, counts: &BTreeMap<Colour, u32>) -> Vec<Said> {
    if counts.is_empty() {
        return vec![Said { room: Some(room.to_string()), ..Said::new("empty") }];
    }
    counts
        .iter()
        .map(|(colour, count)| Said {
            room: Some(room.to_string()),
            count: Some(*count),
            colour: Some(colour.to_string()),
            ..Said::new("contains_many")
        })
        .collect()
}

/// `contains ROOM COLOUR`.
pub(super) fn contains(room: &str, colour: Colour) -> Said {
    Said { room: Some(room.to_string()), colour: Some(colour.to_string()), ..Said::new("contains") }
}

/// `getting_for COLOUR ROOM POS`: a claim to fetch a block from ROOM for position POS.
pub(super) fn getting_for(colour: Colour, room: &str, pos: usize) -> Said {
    Said {
        colour: Some(colour.to_string()),
        room: Some(room.to_string()),
        position: Some(position(pos)),
        ..Said::new("getting_for")
    }
}

/// `bringing COLOUR POS`: a claim of position POS for the block in hand.
pub(super) fn bringing(colour: Colour, pos: usize) -> Said {
    Said { colour: Some(colour.to_string()), position: Some(position(pos)), ..Said::new("bringing") }
}

/// `giving_up POS`: the sender's claim of POS is over.
pub(super) fn giving_up(pos: usize) -> Said {
    Said { position: Some(position(pos)), ..Said::new("giving_up") }
}

/// A kind that takes one colour: `have`, `dropped`.
pub(super) fn with_colour(kind: &str, colour: Colour) -> Said {
    Said { colour: Some(colour.to_string()), ..Said::new(kind) }
}

fn position(pos: usize) -> u32 {
    u32::try_from(pos).unwrap_or(u32::MAX)
}

/// A message of the language, as the cooperative play reads it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(super) enum Heard {
    /// `going_to`: the sender explores the room.
    GoingTo(String),
    /// `empty` (no colour) or one colour of `contains_many`: part of a full report on a room.
    Report { room: String, blocks: Option<(Colour, u32)> },
    /// `contains`: the room holds at least one block of the colour.
    Contains { room: String, colour: Colour },
    /// `getting_for`: a claim to fetch for a position from a room.
    GettingFor { colour: Colour, room: String, pos: usize },
    /// `bringing`: a claim of a position for a block in hand.
    Bringing { colour: Colour, pos: usize },
    /// `giving_up`: the sender's claim of a position is over.
    GivingUp(usize),
    /// `will_get` or `have`: a claim without a position (the earliest open one of the colour).
    Intends(Colour),
    /// `could_not`: whatever the sender claimed is off.
    CouldNot,
    /// `who_has`.
    WhoHas(Colour),
    /// `where_is`.
    WhereIs(Colour),
    /// `what_in`.
    WhatIn(String),
    /// `anybody_going`.
    AnybodyGoing(String),
    /// `go_to`: a request to one player.
    GoTo { player: String, room: String },
    /// `get`: a request to one player.
    Get { player: String, colour: Colour },
}

impl Heard {
    /// What a message says, if it is one the play uses (with a known colour).
    pub(super) fn read(said: &Said) -> Option<Heard> {
        let room = || said.room.clone();
        let colour = || said.colour.as_deref().and_then(|c| c.parse::<Colour>().ok());
        let pos = || said.position.and_then(|p| usize::try_from(p).ok());
        let player = || said.player.clone();
        Some(match said.kind.as_str() {
            "going_to" => Heard::GoingTo(room()?),
            "empty" => Heard::Report { room: room()?, blocks: None },
            "contains_many" => Heard::Report { room: room()?, blocks: Some((colour()?, said.count?)) },
            "contains" => Heard::Contains { room: room()?, colour: colour()? },
            "getting_for" => Heard::GettingFor { colour: colour()?, room: room()?, pos: pos()? },
            "bringing" => Heard::Bringing { colour: colour()?, pos: pos()? },
            "giving_up" => Heard::GivingUp(pos()?),
            "will_get" | "have" => Heard::Intends(colour()?),
            "could_not" => Heard::CouldNot,
            "who_has" => Heard::WhoHas(colour()?),
            "where_is" => Heard::WhereIs(colour()?),
            "what_in" => Heard::WhatIn(room()?),
            "anybody_going" => Heard::AnybodyGoing(room()?),
            "go_to" => Heard::GoTo { player: player()?, room: room()? },
            "get" => Heard::Get { player: player()?, colour: colour()? },
            _ => return None,
        })
    }

    /// Whether it is one of the kinds the built-in team sends itself to coordinate (what
    /// the `ignoring` strategy still hears).
    pub(super) fn is_coordination(&self) -> bool {
        matches!(
            self,
            Heard::GoingTo(_)
                | Heard::Report { .. }
                | Heard::GettingFor { .. }
                | Heard::Bringing { .. }
                | Heard::GivingUp(_)
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn everything_said_is_a_message_of_the_language_and_reads_back() {
        let counts = BTreeMap::from([(Colour::Red, 2), (Colour::Blue, 1)]);
        let mut all = report("RoomA1", &counts);
        all.extend(report("RoomA2", &BTreeMap::new()));
        all.extend([
            going_to("RoomA1"),
            contains("RoomA1", Colour::Red),
            getting_for(Colour::Red, "RoomA1", 3),
            bringing(Colour::Red, 0),
            giving_up(2),
            with_colour("have", Colour::Red),
            with_colour("dropped", Colour::Red),
        ]);
        for said in &all {
            assert!(said.check().is_ok(), "{said:?}: {:?}", said.check());
            assert_eq!(Said::from_text(&said.to_text()).as_ref(), Some(said));
        }
        assert_eq!(
            all.iter().map(|s| Heard::read(s).is_some()).collect::<Vec<_>>(),
            vec![true, true, true, true, true, true, true, true, true, false],
            "only `dropped` is not used"
        );
        assert_eq!(
            Heard::read(&getting_for(Colour::Red, "RoomA1", 3)),
            Some(Heard::GettingFor { colour: Colour::Red, room: "RoomA1".into(), pos: 3 })
        );
        assert_eq!(
            all[0].sentence().as_deref(),
            Ok("RoomA1 contains 1 Blue."),
            "one message per colour, in colour order"
        );
    }
}
