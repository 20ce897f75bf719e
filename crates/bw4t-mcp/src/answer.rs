//! What a tool call returns to the model: the text and `structuredContent` of a result
//! (the whole situation, or in brief mode only what changed since the previous result),
//! the clock (tick and tick limit), the notices the rules call for, an invalid call's
//! error, and the estimate of the tokens it costs. One output schema covers every result.

use serde_json::{Map as JsonMap, Value, json};

use crate::docs;
use crate::robot::{Outcome, Report};
use crate::view::View;

/// The outcome word of a call refused for its arguments (`isError: true`).
pub(crate) const INVALID: &str = "invalid";
/// The outcome word of `look`.
pub(crate) const LOOKED: &str = "looked";
/// Estimated tokens of a text given to a model: one per four characters, rounded up (the
/// usual rule of thumb for English under common tokenizers; exact counts need the model's
/// own tokenizer, which `bw4t mcp` does not have).
pub(crate) fn estimate_tokens(text: &str) -> u64 {
    (text.chars().count() as u64).div_ceil(4)
}

/// What a tool call returned: what the model sees, and what the transcript keeps.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Answer {
    /// The text content.
    pub text: String,
    /// The `structuredContent`.
    pub structured: Value,
    /// Whether it is an error result (`isError: true`): the call was refused for its
    /// arguments and nothing was sent to the match.
    pub is_error: bool,
    /// The tick the call started at.
    pub tick_start: u64,
    /// The tick it ended at.
    pub tick_end: u64,
}

impl Answer {
    /// Its outcome word.
    pub(crate) fn outcome(&self) -> &str {
        self.structured["outcome"].as_str().unwrap_or_default()
    }

    /// Estimated tokens of its text ([`estimate_tokens`]).
    pub(crate) fn tokens(&self) -> u64 {
        estimate_tokens(&self.text)
    }
}

/// Shapes results, remembering the last state given so that brief results carry only
/// what changed since.
#[derive(Debug, Default)]
pub(crate) struct Shaper {
    brief: bool,
    last_state: Option<Value>,
}

impl Shaper {
    /// Full results always (`brief` false), or brief ones for every call but `look`.
    pub(crate) fn new(brief: bool) -> Shaper {
        Shaper { brief, last_state: None }
    }

    /// The result of a call that ran (`report`), or of `look` (no report: always the
    /// whole situation).
    pub(crate) fn answer(&mut self, report: Option<&Report>, view: &View, max_ticks: Option<u64>) -> Answer {
        let state = &view.state;
        let tick = state["tick"].as_u64().unwrap_or(0);
        let brief = self.brief && report.is_some();
        let mut text = String::new();
        let (outcome, reason, started, changes, ended) = match report {
            Some(report) => {
                text.push_str(&docs::outcome_sentence(report));
                for line in &report.changes {
                    text.push('\n');
                    text.push_str(line);
                }
                (
                    report.outcome.word(),
                    report.reason.clone(),
                    report.started,
                    report.changes.clone(),
                    report.outcome == Outcome::MatchOver,
                )
            }
            None => (LOOKED, None, tick, Vec::new(), state["ended"].as_bool().unwrap_or(false)),
        };
        let notices = notices(state);
        if !text.is_empty() {
            text.push('\n');
        }
        text.push_str(&clock_sentence(tick, max_ticks));
        for notice in &notices {
            text.push('\n');
            text.push_str(notice);
        }
        let shown_state = match (&self.last_state, brief) {
            (Some(last), true) => changed_fields(last, state),
            _ => state.clone(),
        };
        if !brief {
            text.push_str("\n\n");
            text.push_str(&view.words);
        }
        self.last_state = Some(state.clone());
        let structured = json!({
            "outcome": outcome,
            "reason": reason,
            "tick": tick,
            "started_tick": started,
            "ticks": tick.saturating_sub(started),
            "max_ticks": max_ticks,
            "ticks_left": max_ticks.map(|limit| limit.saturating_sub(tick)),
            "changes": changes,
            "notices": notices,
            "ended": ended,
            "brief": brief,
            "state": shown_state,
        });
        Answer { text, structured, is_error: false, tick_start: started, tick_end: tick }
    }

    /// The result of a call refused for its arguments: `problem` in words, the clock, and
    /// nothing else (nothing happened).
    pub(crate) fn invalid(&self, problem: &str, view: &View, max_ticks: Option<u64>) -> Answer {
        let tick = view.state["tick"].as_u64().unwrap_or(0);
        let text = format!("Invalid call, nothing was done: {problem}\n{}", clock_sentence(tick, max_ticks));
        let structured = json!({
            "outcome": INVALID,
            "error": problem,
            "reason": null,
            "tick": tick,
            "started_tick": tick,
            "ticks": 0,
            "max_ticks": max_ticks,
            "ticks_left": max_ticks.map(|limit| limit.saturating_sub(tick)),
            "changes": [],
            "notices": [],
            "ended": view.state["ended"].as_bool().unwrap_or(false),
            "brief": false,
        });
        Answer { text, structured, is_error: true, tick_start: tick, tick_end: tick }
    }
}

/// The clock in words: the tick, the limit and what is left.
fn clock_sentence(tick: u64, max_ticks: Option<u64>) -> String {
    match max_ticks {
        Some(limit) => {
            format!("Tick {tick} of {limit} ({} left; 20 ticks are one second).", limit.saturating_sub(tick))
        }
        None => format!("Tick {tick}; the match has no tick limit."),
    }
}

/// The fields of `now` that differ from `before`.
fn changed_fields(before: &Value, now: &Value) -> Value {
    let Some(fields) = now.as_object() else { return now.clone() };
    let changed: JsonMap<String, Value> = fields
        .iter()
        .filter(|(key, value)| before.get(key.as_str()) != Some(value))
        .map(|(k, v)| (k.clone(), v.clone()))
        .collect();
    Value::Object(changed)
}

/// What the rules ask of the robot now, from its state: leaving the drop zone it blocks,
/// waiting for a drop zone a teammate holds.
fn notices(state: &Value) -> Vec<String> {
    if state["ended"].as_bool().unwrap_or(false) || !state["started"].as_bool().unwrap_or(false) {
        return Vec::new();
    }
    let in_drop_zone = state["in_room"].as_str() == Some(bw4t_map::DROP_ZONE);
    let holding = state["holding"].as_object();
    let mut notices = Vec::new();
    if in_drop_zone && holding.is_none() {
        notices.push(docs::LEAVE_DROP_ZONE.to_string());
    }
    let drop_zone_taken = state["occupied_rooms"]
        .as_array()
        .is_some_and(|rooms| rooms.iter().any(|r| r == bw4t_map::DROP_ZONE));
    let carries_next = holding.and_then(|h| h.get("colour")).is_some_and(|c| *c == state["next_colour"]);
    if !in_drop_zone && drop_zone_taken && carries_next {
        notices.push(docs::DROP_ZONE_TAKEN.to_string());
    }
    notices
}

/// The JSON schema of every result's `structuredContent` (the tools' `outputSchema`).
pub(crate) fn output_schema() -> Value {
    let text_or_null = json!({"type": ["string", "null"]});
    let count = json!({"type": "integer", "minimum": 0});
    let count_or_null = json!({"type": ["integer", "null"], "minimum": 0});
    let texts = json!({"type": "array", "items": {"type": "string"}});
    let block = json!({
        "type": "object",
        "properties": {"block": count, "colour": text_or_null},
        "required": ["block", "colour"],
        "additionalProperties": false,
    });
    let block_or_null = json!({"anyOf": [block, {"type": "null"}]});
    let outcomes: Vec<&str> = Outcome::ALL.iter().map(|o| o.word()).chain([LOOKED, INVALID]).collect();
    let state = json!({
        "type": "object",
        "description": "The robot's situation; in a brief result only the fields that changed since the previous result.",
        "properties": {
            "tick": count, "started": {"type": "boolean"}, "robot": count_or_null,
            "at": text_or_null, "in_room": text_or_null, "holding": block_or_null, "at_block": block_or_null,
            "move_state": text_or_null, "visible_blocks": {"type": "array", "items": block},
            "sequence": texts, "sequence_index": count, "next_colour": text_or_null,
            "occupied_rooms": texts, "players": texts, "ended": {"type": "boolean"},
        },
        "additionalProperties": false,
    });
    json!({
        "type": "object",
        "properties": {
            "outcome": {"type": "string", "enum": outcomes},
            "reason": text_or_null,
            "error": {"type": "string", "description": "Why a call was invalid (outcome invalid)."},
            "tick": count,
            "started_tick": count,
            "ticks": count,
            "max_ticks": count_or_null,
            "ticks_left": count_or_null,
            "changes": texts,
            "notices": texts,
            "ended": {"type": "boolean"},
            "brief": {"type": "boolean"},
            "state": state,
        },
        "required": ["outcome", "tick", "started_tick", "ticks", "max_ticks", "ticks_left", "changes", "notices", "ended", "brief"],
        "additionalProperties": false,
    })
}

#[cfg(test)]
mod tests {
    use serde_json::json;

    use super::*;

    fn view(state: Value) -> View {
        View { words: "The whole situation.".into(), state }
    }

    fn state(tick: u64, in_room: &str, holding: Value) -> Value {
        json!({"tick": tick, "started": true, "robot": 0, "at": in_room, "in_room": in_room, "holding": holding,
               "at_block": null, "move_state": "arrived", "visible_blocks": [], "sequence": ["Red", "Blue"],
               "sequence_index": 0, "next_colour": "Red", "occupied_rooms": [in_room], "players": ["Bob"],
               "ended": false})
    }

    fn report(started: u64, tick: u64) -> Report {
        Report {
            outcome: Outcome::Arrived,
            reason: None,
            started,
            tick,
            changes: vec!["I arrived at RoomA1.".into()],
        }
    }

    #[test]
    fn tokens_are_estimated_at_four_characters_each_rounded_up() {
        assert_eq!([estimate_tokens(""), estimate_tokens("abcd"), estimate_tokens("abcde")], [0, 1, 2]);
        assert_eq!(estimate_tokens("éééé"), 1, "characters, not bytes");
    }

    #[test]
    fn every_result_has_the_clock_and_fits_the_output_schema() {
        let mut shaper = Shaper::new(false);
        let answer =
            shaper.answer(Some(&report(10, 50)), &view(state(50, "RoomA1", Value::Null)), Some(2000));
        assert!(
            answer
                .text
                .starts_with("Arrived after 40 ticks.\nI arrived at RoomA1.\nTick 50 of 2000 (1950 left")
        );
        assert!(answer.text.ends_with("The whole situation."));
        let data = &answer.structured;
        assert_eq!(
            (data["tick"].clone(), data["max_ticks"].clone(), data["ticks_left"].clone()),
            (json!(50), json!(2000), json!(1950))
        );
        assert_eq!((answer.tick_start, answer.tick_end, answer.is_error), (10, 50, false));
        let invalid =
            shaper.invalid("go_to: 'X' is not a place", &view(state(50, "RoomA1", Value::Null)), None);
        assert!(invalid.is_error && invalid.text.contains("Tick 50; the match has no tick limit."));
        assert_eq!(invalid.outcome(), INVALID);
        let schema = output_schema();
        for data in [&answer.structured, &invalid.structured] {
            let fields = data.as_object().expect("an object");
            let known = schema["properties"].as_object().expect("properties");
            assert!(fields.keys().all(|k| known.contains_key(k)), "{data}");
            for required in schema["required"].as_array().expect("required") {
                assert!(fields.contains_key(required.as_str().unwrap_or_default()), "{required} in {data}");
            }
        }
    }

    #[test]
    fn brief_results_give_the_changed_fields_and_look_the_whole() {
        let mut shaper = Shaper::new(true);
        let first = shaper.answer(None, &view(state(0, "DropZone", Value::Null)), Some(100));
        assert_eq!(first.structured["brief"], false);
        assert!(first.text.ends_with("The whole situation."));
        let next = shaper.answer(Some(&report(0, 40)), &view(state(40, "RoomA1", Value::Null)), Some(100));
        assert_eq!(next.structured["brief"], true);
        assert!(!next.text.contains("The whole situation."));
        let fields: Vec<&String> = next.structured["state"].as_object().expect("state").keys().collect();
        assert_eq!(fields, ["at", "in_room", "occupied_rooms", "tick"]);
        let look = shaper.answer(None, &view(state(40, "RoomA1", Value::Null)), Some(100));
        assert_eq!(look.structured["state"]["sequence"], json!(["Red", "Blue"]));
    }

    #[test]
    fn a_robot_idle_in_the_drop_zone_is_told_to_leave_it() {
        let mut shaper = Shaper::new(false);
        let idle = shaper.answer(None, &view(state(5, "DropZone", Value::Null)), None);
        assert_eq!(idle.structured["notices"], json!([docs::LEAVE_DROP_ZONE]));
        assert!(idle.text.contains(docs::LEAVE_DROP_ZONE));
        let carrying =
            shaper.answer(None, &view(state(5, "DropZone", json!({"block": 1, "colour": "Red"}))), None);
        assert_eq!(carrying.structured["notices"], json!([]), "it is there to deliver");
        let mut waiting = state(5, "RoomA1", json!({"block": 1, "colour": "Red"}));
        waiting["occupied_rooms"] = json!(["RoomA1", "DropZone"]);
        let told = shaper.answer(None, &view(waiting), None);
        assert_eq!(told.structured["notices"], json!([docs::DROP_ZONE_TAKEN]));
    }
}
