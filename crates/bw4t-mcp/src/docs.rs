//! What the server tells a model besides tool results: the rules, the map as text and
//! SVG, the goal, the role prompt, and the one sentence that opens each tool result.

use bw4t_map::{Colour, Map, ZoneKind};
use bw4t_protocol::{KINDS, SPOKEN_FIRST_POSITION};
use serde_json::Value;

use crate::echo::echo;

use crate::robot::{Outcome, Report};

/// The server's instructions to the client (the `initialize` result).
pub(crate) const INSTRUCTIONS: &str = "You drive one robot in a Blocks World for Teams match. \
Read bw4t://rules and call look first; the prompt 'play' explains the task and the tools.";

/// The notice of a result that finds the robot in the drop zone with empty hands.
pub(crate) const LEAVE_DROP_ZONE: &str = "Notice: you are in the DropZone holding nothing. \
Leave it now (go_to a room or hall): it holds one robot at a time, so while you stand in it \
no teammate can deliver.";

/// The notice of a result that finds the robot carrying the colour needed next while a
/// teammate is in the drop zone.
pub(crate) const DROP_ZONE_TAKEN: &str = "Notice: the DropZone is occupied by a teammate. \
Wait outside it (wait) until it is free; do not queue in its doorway.";

/// The rule the built-in robots follow when two players claim the same thing in the same
/// tick (`bw4t-agents/src/coop/`: `resolve_claim`, and `going_to`), in words.
pub(crate) const TIE_BREAK: &str = "When two players claim the same thing in the same tick \
(the same position of the goal sequence with `getting_for` or `bringing`, or the same room \
with `going_to`), the player whose name comes first in plain character order (`Agent1` \
before `Agent2` before `Bot1`; capitals before small letters) keeps it, and the other gives \
it up and picks something else. The built-in robots follow this rule; follow it too and \
nobody waits for anybody.";

/// The role prompt's name.
pub(crate) const PROMPT_NAME: &str = "play";
/// What the role prompt is.
pub(crate) const PROMPT_DESCRIPTION: &str =
    "The task, the rules in short and how to use the tools, to start a model's turn.";

/// One resource: its address, name, what it holds and its type.
pub(crate) struct ResourceRow {
    pub uri: &'static str,
    pub name: &'static str,
    pub description: &'static str,
    pub mime: &'static str,
}

/// Every resource.
pub(crate) const RESOURCES: &[ResourceRow] = &[
    ResourceRow {
        uri: "bw4t://rules",
        name: "rules",
        description: "The rules of the game and the message language, in short.",
        mime: "text/markdown",
    },
    ResourceRow {
        uri: "bw4t://map",
        name: "map",
        description: "The map as text: rooms, halls and the drop zone, and which places connect.",
        mime: "text/plain",
    },
    ResourceRow {
        uri: "bw4t://map.svg",
        name: "map.svg",
        description: "The map drawn as SVG.",
        mime: "image/svg+xml",
    },
    ResourceRow {
        uri: "bw4t://goal",
        name: "goal",
        description: "The goal sequence of colours and how far the team is.",
        mime: "text/plain",
    },
];

/// What the server knows of the match beyond the robot's percepts.
pub struct Docs {
    map: Option<Map>,
}

impl Docs {
    /// Documents for a match on `map` (`None`: the map is not known here, e.g. a map file
    /// only the server has).
    pub fn new(map: Option<Map>) -> Docs {
        Docs { map }
    }

    /// An error naming the problem when `place` is not a place of the map.
    pub(crate) fn check_place(&self, place: &str) -> Result<(), String> {
        let Some(map) = &self.map else { return Ok(()) };
        if map.zone_named(place).is_some() {
            return Ok(());
        }
        let names: Vec<&str> = map.zones().iter().map(|z| z.name.as_str()).collect();
        Err(format!(
            "{} is not a place of map '{}'; its places are {}",
            echo(place),
            map.name(),
            names.join(", ")
        ))
    }

    /// An error naming the problem when `room` is not a room of the map (a message's room).
    pub(crate) fn check_room(&self, room: &str) -> Result<(), String> {
        let Some(map) = &self.map else { return Ok(()) };
        let rooms = self.rooms().unwrap_or_default();
        if rooms.contains(&room) {
            return Ok(());
        }
        Err(format!(
            "{} is not a room of map '{}'; its rooms are {}",
            echo(room),
            map.name(),
            rooms.join(", ")
        ))
    }

    /// Every place of the map, in file order (`None`: the map is not known here).
    pub(crate) fn places(&self) -> Option<Vec<&str>> {
        let map = self.map.as_ref()?;
        Some(map.zones().iter().filter(|z| z.kind.is_walkable()).map(|z| z.name.as_str()).collect())
    }

    /// Every room of the map (the drop zone among them), in file order.
    pub(crate) fn rooms(&self) -> Option<Vec<&str>> {
        let map = self.map.as_ref()?;
        Some(map.zones().iter().filter(|z| z.kind == ZoneKind::Room).map(|z| z.name.as_str()).collect())
    }

    /// The text of a resource; `state` is the robot's state now (for the goal).
    pub(crate) fn resource(&self, uri: &str, state: Option<&Value>) -> String {
        match uri {
            "bw4t://rules" => rules(),
            "bw4t://map" => self.map_text(),
            "bw4t://map.svg" => match &self.map {
                Some(map) => bw4t_map::render_svg(map, None),
                None => "<svg xmlns=\"http://www.w3.org/2000/svg\"/>".into(),
            },
            _ => goal_text(state),
        }
    }

    /// The map as text (`bw4t://map`): each place with its kind and the places it
    /// connects to, from the map's graph, so every connection is listed both ways.
    pub fn map_text(&self) -> String {
        let Some(map) = &self.map else {
            return "The map is not known here (it is a file only the server has); the robot's \
                    percepts name the places as it learns them."
                .into();
        };
        let mut text = format!("Map '{}': {} places.\n", map.name(), map.zones().len());
        // Rooms first, then the halls (every other zone a robot can stand in).
        for rooms in [true, false] {
            let zones = map.zones().iter().enumerate();
            for (i, zone) in
                zones.filter(|(_, z)| (z.kind == ZoneKind::Room) == rooms && z.kind.is_walkable())
            {
                let what = match (i == map.drop_zone(), rooms) {
                    (true, _) => "the drop zone, a room",
                    (false, true) => "room",
                    (false, false) => "hall",
                };
                // The map's graph, not the file's lists: a file may name a connection on
                // one side only.
                let neighbours: Vec<&str> =
                    map.neighbours(i).iter().map(|&j| map.zones()[j].name.as_str()).collect();
                text.push_str(&format!("- {} ({what}): connects to {}\n", zone.name, neighbours.join(", ")));
            }
        }
        text
    }

    /// The role prompt: the task, the rules in short, the tools, and the robot's state.
    pub(crate) fn role_prompt(&self, state: Option<&Value>) -> String {
        let mut text = String::from(ROLE);
        text.push_str("\n\n");
        text.push_str(&goal_text(state));
        if let Some(map) = &self.map {
            let rooms: Vec<&str> =
                map.zones().iter().filter(|z| z.kind == ZoneKind::Room).map(|z| z.name.as_str()).collect();
            text.push_str(&format!("\nThe rooms of map '{}': {}.\n", map.name(), rooms.join(", ")));
        }
        text
    }
}

const ROLE: &str = "You are a player in Blocks World for Teams. You drive one robot; your \
teammates drive the others (people, programs or models like you). Together you must bring \
coloured blocks to the DropZone in the order of the goal sequence. You see blocks only \
inside the room you are in, you cannot see the other robots, a room holds one robot at a \
time, and a block put down in a hall is lost.

Tools: look (your situation in words), go_to(place), go_to_block(block), pick_up(block?), \
put_down(), say(kind + arguments, or text; to a player or all), wait(ticks?, seconds?). \
Each result says how the action ended and what changed. A good loop: look; go to a room \
not yet explored; when you see the colour needed next, go_to_block, pick_up, go_to \
DropZone, put_down. Tell teammates what rooms contain and what you are fetching (say \
kind=contains / kind=getting_for) so that nobody fetches the same block. Keep each reply \
short and call one tool at a time. The full rules are in the resource bw4t://rules.";

/// Every colour's name, in the game's order.
pub(crate) fn colour_names() -> Vec<&'static str> {
    Colour::ALL.iter().map(|c| c.name()).collect()
}

/// An error naming the problem when `colour` is not a colour of the game.
pub(crate) fn check_colour(colour: &str) -> Result<(), String> {
    if Colour::ALL.iter().any(|c| c.name() == colour) {
        return Ok(());
    }
    Err(format!("{} is not a colour; the colours are {}", echo(colour), colour_names().join(", ")))
}

/// The rules, with the message language's table from the one table of kinds.
fn rules() -> String {
    let mut text = String::from(include_str!("rules.md"));
    text.push_str(&format!(
        "\n## Taking turns\n\n- {}\n- {TIE_BREAK}\n- Positions of the goal sequence are counted from \
         {SPOKEN_FIRST_POSITION} (the first colour is position {SPOKEN_FIRST_POSITION}), in the \
         sentences you read and in the `position` of `say` alike.\n",
        LEAVE_DROP_ZONE.trim_start_matches("Notice: ")
    ));
    text.push_str("\n## Messages of the language\n\n| kind | arguments | sentence |\n|---|---|---|\n");
    for row in KINDS {
        let slots: Vec<&str> = row.slots.iter().map(|s| s.name()).collect();
        text.push_str(&format!("| `{}` | {} | {} |\n", row.word, slots.join(", "), row.sentence));
    }
    text
}

/// The goal sequence and how far the team is, from the robot's state.
fn goal_text(state: Option<&Value>) -> String {
    let sequence: Vec<&str> = state
        .and_then(|s| s["sequence"].as_array())
        .map(|a| a.iter().filter_map(Value::as_str).collect())
        .unwrap_or_default();
    if sequence.is_empty() {
        return "The goal sequence is not known yet (the match has not started).".into();
    }
    let done = state.and_then(|s| s["sequence_index"].as_u64()).unwrap_or(0) as usize;
    let mut text = format!("Goal sequence: {}.", sequence.join(", "));
    match sequence.get(done) {
        Some(next) => {
            text.push_str(&format!(" Delivered {done} of {}; needed next: {next}.", sequence.len()))
        }
        None => text.push_str(" Every block has been delivered."),
    }
    text
}

/// The sentence that opens a tool result.
pub(crate) fn outcome_sentence(report: &Report) -> String {
    let ticks = report.tick.saturating_sub(report.started);
    let reason = report.reason.as_deref().unwrap_or("");
    match report.outcome {
        Outcome::Arrived => format!("Arrived after {ticks} ticks."),
        Outcome::Collided => format!("Stopped after {ticks} ticks: the way was blocked (collided)."),
        Outcome::Superseded => "Replaced by a newer order.".into(),
        Outcome::Done => "Done.".into(),
        Outcome::Rejected => format!("Rejected: {reason}."),
        Outcome::Changed => format!("Something changed after {ticks} ticks."),
        Outcome::Timeout if reason.is_empty() => format!("Time is up after {ticks} ticks."),
        Outcome::Timeout => format!("Time is up after {ticks} ticks: {reason}."),
        Outcome::MatchOver => format!("The match is over: {reason}."),
        Outcome::Cancelled if reason.is_empty() => format!("Cancelled after {ticks} ticks."),
        Outcome::Cancelled => format!("Cancelled after {ticks} ticks: {reason}."),
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_rules_state_the_tie_break_the_blocking_and_how_positions_count() {
        let rules = super::rules();
        assert!(rules.contains(super::TIE_BREAK) && rules.contains("in the DropZone holding nothing"));
        assert!(rules.contains("counted from 1 (the first colour is position 1)"), "{rules}");
        assert!(rules.contains("| `giving_up` | position |"), "the language's table follows");
    }
}
