//! The protocol's percepts and actions, a row each: name, arguments, how a percept is sent
//! and to whom, whether an action is durative. The percept rows are the simulation's
//! descriptions ([`bw4t_sim::PERCEPTS`]) in the protocol's words. Exported as
//! `protocol/schema/table.json` with the schemas; the converters and the clients are
//! checked against it.

use bw4t_sim::{ArgKind, PerceptKind};
use schemars::JsonSchema;
use serde::{Serialize, Serializer};

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

impl SendType {
    /// The simulation's send type in the protocol's words.
    pub const fn of(send: bw4t_sim::SendType) -> SendType {
        match send {
            bw4t_sim::SendType::Once => SendType::Once,
            bw4t_sim::SendType::OnChange => SendType::OnChange,
            bw4t_sim::SendType::OnChangeWithNegation => SendType::OnChangeWithNegation,
            bw4t_sim::SendType::Event => SendType::Event,
        }
    }
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

impl Scope {
    /// The simulation's scope in the protocol's words.
    pub const fn of(scope: bw4t_sim::Scope) -> Scope {
        match scope {
            bw4t_sim::Scope::Local => Scope::Local,
            bw4t_sim::Scope::Global => Scope::Global,
        }
    }
}

/// One percept.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, JsonSchema)]
pub struct PerceptRow {
    /// The predicate name.
    pub name: &'static str,
    /// Its arguments' kinds, in order (`place`, `player`, `block`, `colour`, `colours`, ...).
    #[serde(serialize_with = "arg_names")]
    #[schemars(with = "Vec<String>")]
    pub args: &'static [ArgKind],
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

impl PerceptRow {
    /// The row of a percept the simulation describes.
    pub const fn of(kind: &PerceptKind) -> PerceptRow {
        PerceptRow {
            name: kind.name,
            args: kind.args,
            send: SendType::of(kind.send),
            scope: Scope::of(kind.scope),
        }
    }
}

/// An argument list as the kinds' names.
fn arg_names<S: Serializer>(args: &&'static [ArgKind], serializer: S) -> Result<S::Ok, S::Error> {
    serializer.collect_seq(args.iter().map(|kind| kind.name()))
}

/// Every percept, in the order the protocol documents them: the simulation's
/// [`bw4t_sim::PERCEPTS`], row for row.
pub const PERCEPTS: [PerceptRow; bw4t_sim::PERCEPTS.len()] = {
    let mut rows = [PerceptRow::of(&bw4t_sim::PERCEPTS[0]); bw4t_sim::PERCEPTS.len()];
    let mut i = 1;
    while i < rows.len() {
        rows[i] = PerceptRow::of(&bw4t_sim::PERCEPTS[i]);
        i += 1;
    }
    rows
};

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
        "percepts": &PERCEPTS[..],
        "actions": ACTIONS,
    })
}

#[cfg(test)]
mod tests {
    use serde_json::{Value, json};

    use super::*;
    use crate::convert::action_from_act;

    #[test]
    fn the_exported_table_has_a_row_for_every_percept_the_simulation_describes_and_no_other() {
        let table = table_json();
        let rows = table["percepts"].as_array().expect("a list of percepts");
        assert_eq!(rows.len(), bw4t_sim::PERCEPTS.len(), "a row of every percept");
        for (row, kind) in rows.iter().zip(bw4t_sim::PERCEPTS) {
            assert_eq!(row["name"], kind.name, "in the simulation's order");
            let args: Vec<&str> = kind.args.iter().map(|a| a.name()).collect();
            assert_eq!(row["args"], json!(args), "{}", kind.name);
            assert_eq!(row["send"], json!(SendType::of(kind.send)), "{}", kind.name);
            assert_eq!(row["scope"], json!(Scope::of(kind.scope)), "{}", kind.name);
            assert_eq!(percept_row(kind.name), Some(&PerceptRow::of(kind)));
        }
        // The words as clients read them.
        let color = rows.iter().find(|r| r["name"] == "color").expect("a color row");
        assert_eq!(
            *color,
            json!({"name": "color", "args": ["block", "colour"], "send": "on_change_with_negation", "scope": "local"})
        );
        assert_eq!(percept_row("fly"), None);
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
