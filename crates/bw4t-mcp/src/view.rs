//! The robot's state as a tool result shows it: the description in words and the same
//! facts as a JSON object (`structuredContent`).

use bw4t_sim::Percept;
use serde_json::{Value, json};

use crate::robot::Robot;

/// The robot's state at one moment.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct View {
    /// The description in words.
    pub words: String,
    /// The same, as data.
    pub state: Value,
}

impl View {
    /// What `robot` knows now.
    pub(crate) fn of(robot: &Robot) -> View {
        let knowledge = robot.knowledge();
        let facts = knowledge.beliefs().facts();
        let mut at = None;
        let mut room = None;
        let mut holding = None;
        let mut move_state = None;
        let mut sequence: Vec<&str> = Vec::new();
        let mut index = 0u32;
        let mut occupied = Vec::new();
        let mut players = Vec::new();
        let mut colours = std::collections::BTreeMap::new();
        let mut visible = Vec::new();
        for fact in facts {
            match fact {
                Percept::At(place) => at = Some(place.to_string()),
                Percept::In(place) => room = Some(place.to_string()),
                Percept::Holding(block) => holding = Some(*block),
                Percept::State(state) => move_state = Some(state.name()),
                Percept::Sequence(colours) => sequence = colours.iter().map(|c| c.name()).collect(),
                Percept::SequenceIndex(i) => index = *i,
                Percept::Occupied(place) => occupied.push(place.to_string()),
                Percept::Player(name) => players.push(name.to_string()),
                Percept::Color(block, colour) => {
                    colours.insert(*block, colour.name());
                }
                Percept::Block(block) => visible.push(*block),
                _ => {}
            }
        }
        let block = |id: u32| json!({"block": id, "colour": colours.get(&id)});
        let state = json!({
            "tick": robot.tick(),
            "started": robot.started(),
            "robot": robot.robot_id(),
            "at": at,
            "in_room": room,
            "holding": holding.map(block),
            "move_state": move_state,
            "visible_blocks": visible.iter().map(|id| block(*id)).collect::<Vec<_>>(),
            "sequence": sequence,
            "sequence_index": index,
            "next_colour": sequence.get(index as usize),
            "occupied_rooms": occupied,
            "players": players,
            "ended": robot.ended().is_some(),
        });
        let words = match (robot.started(), robot.ended()) {
            (_, Some(reason)) => format!("{}\nThe match is over ({reason}).", knowledge.describe()),
            (false, None) => "The match has not started yet: it is waiting for its players.".to_string(),
            (true, None) => knowledge.describe(),
        };
        View { words, state }
    }
}
