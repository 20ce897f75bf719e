//! The robot's state as a tool result shows it: the description in words and the same
//! facts as a JSON object (`structuredContent`).

use bw4t_map::Colour;
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
        let block =
            |(id, colour): (u32, Option<Colour>)| json!({"block": id, "colour": colour.map(Colour::name)});
        let colours = |list: &[Colour]| list.iter().map(|c| c.name()).collect::<Vec<_>>();
        let state = json!({
            "tick": robot.tick(),
            "started": robot.started(),
            "robot": robot.robot_id(),
            "at": knowledge.at(),
            "in_room": knowledge.room(),
            "holding": knowledge.holding().map(block),
            "at_block": knowledge.at_block().map(block),
            "move_state": knowledge.state().map(|s| s.name()),
            "visible_blocks": knowledge.visible().iter().map(|&(id, c)| block((id, Some(c)))).collect::<Vec<_>>(),
            "sequence": colours(knowledge.sequence()),
            "sequence_index": knowledge.sequence_index(),
            "next_colour": knowledge.next_colour().map(Colour::name),
            "occupied_rooms": knowledge.occupied().collect::<Vec<_>>(),
            "players": knowledge.players().collect::<Vec<_>>(),
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
