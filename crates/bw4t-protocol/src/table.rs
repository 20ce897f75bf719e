//! The protocol's percepts and actions, a row each: name, arguments, how a percept is sent
//! and to whom, whether an action is durative. Exported as `protocol/schema/table.json`
//! with the schemas; the converters, the simulation and the clients are checked against it.

use schemars::JsonSchema;
use serde::Serialize;

/// How a percept is sent (the spec's four types; "send always" is not used).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum SendType {
    /// At the start (and, for `player`, when players join and leave).
    Once,
    /// Whenever its single value changes; never in `not`.
    OnChange,
    /// When it starts to hold, and in `not` when it stops.
    OnChangeWithNegation,
    /// Delivered once, not part of the state.
    Event,
}

/// Who is sent a percept.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Scope {
    /// Only the player it is about.
    Local,
    /// Every player.
    Global,
}

/// One percept.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, JsonSchema)]
pub struct PerceptRow {
    /// The predicate name.
    pub name: &'static str,
    /// Its arguments' kinds, in order (`place`, `player`, `block`, `colour`, `colours`, ...).
    pub args: &'static [&'static str],
    /// How it is sent.
    pub send: SendType,
    /// To whom.
    pub scope: Scope,
}

/// One action.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, JsonSchema)]
pub struct ActionRow {
    /// The action name, as in `act.action`.
    pub name: &'static str,
    /// Its arguments' kinds, in order.
    pub args: &'static [&'static str],
    /// How many of the arguments may be left out, from the end.
    pub optional: usize,
    /// Whether its order ends later with a `result`.
    pub durative: bool,
}

const fn percept(
    name: &'static str,
    args: &'static [&'static str],
    send: SendType,
    scope: Scope,
) -> PerceptRow {
    PerceptRow { name, args, send, scope }
}

/// Every percept, in the order the protocol documents them.
pub const PERCEPTS: &[PerceptRow] = &[
    percept("place", &["place"], SendType::Once, Scope::Global),
    percept("player", &["player"], SendType::Once, Scope::Global),
    percept("ownName", &["player"], SendType::Once, Scope::Local),
    percept("bot", &["robot"], SendType::Once, Scope::Local),
    percept("sequence", &["colours"], SendType::Once, Scope::Global),
    percept("at", &["place"], SendType::OnChange, Scope::Local),
    percept("sequenceIndex", &["index"], SendType::OnChange, Scope::Global),
    percept("state", &["state"], SendType::OnChange, Scope::Local),
    percept("in", &["room"], SendType::OnChangeWithNegation, Scope::Local),
    percept("atBlock", &["block"], SendType::OnChangeWithNegation, Scope::Local),
    percept("occupied", &["room"], SendType::OnChangeWithNegation, Scope::Global),
    percept("color", &["block", "colour"], SendType::OnChangeWithNegation, Scope::Local),
    percept("holding", &["block"], SendType::OnChangeWithNegation, Scope::Local),
    percept("block", &["block"], SendType::OnChangeWithNegation, Scope::Local),
    percept("message", &["player", "text"], SendType::Event, Scope::Local),
];

/// Every action.
pub const ACTIONS: &[ActionRow] = &[
    ActionRow { name: "goTo", args: &["place"], optional: 0, durative: true },
    ActionRow { name: "goToBlock", args: &["block"], optional: 0, durative: true },
    ActionRow { name: "pickUp", args: &["block"], optional: 1, durative: false },
    ActionRow { name: "putDown", args: &[], optional: 0, durative: false },
    ActionRow { name: "sendMessage", args: &["receiver", "text"], optional: 0, durative: false },
];

/// The percept named `name`.
pub fn percept_row(name: &str) -> Option<&'static PerceptRow> {
    PERCEPTS.iter().find(|p| p.name == name)
}

/// The action named `name`.
pub fn action_row(name: &str) -> Option<&'static ActionRow> {
    ACTIONS.iter().find(|a| a.name == name)
}

/// The table as JSON, as exported to `protocol/schema/table.json`.
pub fn table_json() -> serde_json::Value {
    serde_json::json!({
        "$comment": "The percepts and actions of the bw4t protocol (bw4t-protocol/src/table.rs).",
        "percepts": PERCEPTS,
        "actions": ACTIONS,
    })
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use bw4t_map::Colour;
    use bw4t_sim::{MoveState, Percept};
    use serde_json::{Value, json};

    use super::*;
    use crate::convert::{action_from_act, fact_to_percept, percept_to_fact};

    /// One percept of every kind the simulation makes.
    fn every_percept() -> Vec<Percept> {
        let s = |t: &str| -> Arc<str> { t.into() };
        vec![
            Percept::Place(s("RoomA1")),
            Percept::Player(s("Bob")),
            Percept::OwnName(s("Ann")),
            Percept::Bot(0),
            Percept::Sequence(vec![Colour::Red].into()),
            Percept::At(s("RoomA1")),
            Percept::SequenceIndex(1),
            Percept::State(MoveState::Arrived),
            Percept::In(s("RoomA1")),
            Percept::AtBlock(3),
            Percept::Occupied(s("RoomA1")),
            Percept::Color(3, Colour::Red),
            Percept::Holding(3),
            Percept::Block(3),
            Percept::Message { from: s("Bob"), text: s("hi") },
        ]
    }

    #[test]
    fn the_simulation_and_the_converters_agree_with_the_table() {
        let percepts = every_percept();
        assert_eq!(percepts.len(), PERCEPTS.len(), "a percept of every row");
        for percept in percepts {
            let row =
                percept_row(percept.name()).unwrap_or_else(|| panic!("{} is in the table", percept.name()));
            let send = match percept.send_type() {
                bw4t_sim::SendType::Once => SendType::Once,
                bw4t_sim::SendType::OnChange => SendType::OnChange,
                bw4t_sim::SendType::OnChangeWithNegation => SendType::OnChangeWithNegation,
                bw4t_sim::SendType::Event => SendType::Event,
            };
            assert_eq!(send, row.send, "{}", row.name);
            let fact = percept_to_fact(&percept);
            assert_eq!(fact.len(), 1 + row.args.len(), "{}: arity", row.name);
            assert_eq!(fact_to_percept(&fact).ok(), Some(percept), "{} converts back", row.name);
        }
    }

    #[test]
    fn every_action_of_the_table_is_read_with_its_arity_and_no_other() {
        let arg = |kind: &str| match kind {
            "block" => json!(3),
            _ => json!("x"),
        };
        for row in ACTIONS {
            let args: Vec<Value> = row.args.iter().map(|k| arg(k)).collect();
            for left_out in 0..=row.args.len() {
                let given = &args[..args.len() - left_out];
                let read = action_from_act(row.name, given);
                assert_eq!(read.is_ok(), left_out <= row.optional, "{} with {given:?}", row.name);
            }
            let mut extra = args.clone();
            extra.push(json!("extra"));
            assert!(action_from_act(row.name, &extra).is_err(), "{} with one argument too many", row.name);
        }
        assert!(action_from_act("dance", &[]).is_err());
    }
}
