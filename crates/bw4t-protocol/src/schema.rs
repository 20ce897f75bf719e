//! JSON Schemas of every message, generated from the Rust types (`protocol/schema/`).

use schemars::generate::SchemaSettings;
use schemars::{JsonSchema, Schema, schema_for};
use serde_json::{Value, json};

use crate::http::{ErrorReply, MapLayout, MatchList, MatchSummary, ResultList, ServerInfo, StoppedMatch};
use crate::messages::{ClientMessage, ServerMessage};
use crate::study::{
    EventsRecorded, ParticipantList, ParticipantState, StepConflict, StudyExported, StudyInfo,
};
use crate::trajectory::{EnvStep, RobotTick, TrajectoryMeta};
use crate::vocabulary::{AckCode, AgentStatus, ByeReason, EndReason, ErrorCode, Leaving, MoveState, Outcome};

/// Every message's schema as (relative path, schema): `client/hello.json`, `server/welcome.json`, ...,
/// `vocabulary.json`, every word list of the protocol and of bw4t's result files, and
/// `table.json`, the percepts and actions ([`PERCEPTS`](crate::PERCEPTS), [`ACTIONS`](crate::ACTIONS)),
/// and the web port's JSON replies under `http/` ([`MapLayout`], [`ServerInfo`], [`MatchList`],
/// [`MatchSummary`], [`StoppedMatch`], [`ResultList`], [`ErrorReply`]; the study API's under
/// `http/study/`), and the trajectory files under `trajectory/`.
pub fn schemas() -> Vec<(String, Value)> {
    let mut out = vec![
        ("vocabulary.json".to_string(), vocabulary()),
        ("table.json".to_string(), crate::table::table_json()),
        ("language.json".to_string(), crate::language::language_json()),
    ];
    for (side, whole) in [
        ("client", serde_json::to_value(schema_for!(ClientMessage))),
        ("server", serde_json::to_value(schema_for!(ServerMessage))),
    ] {
        // Generating a schema from these types cannot fail.
        let whole = whole.unwrap_or_default();
        let defs = whole.get("$defs").cloned().unwrap_or_else(|| json!({}));
        for branch in whole.get("oneOf").and_then(Value::as_array).into_iter().flatten() {
            let Some(name) = branch.pointer("/properties/type/const").and_then(Value::as_str) else {
                continue;
            };
            let mut schema = json!({
                "$schema": "https://json-schema.org/draft/2020-12/schema",
                "$id": format!("https://bw4t.invalid/protocol/v1/{side}/{name}.json"),
                "title": format!("{name} ({side} to {})", if side == "client" { "server" } else { "client" }),
            });
            let object = schema.as_object_mut().expect("a JSON object literal");
            for (key, value) in branch.as_object().into_iter().flatten() {
                object.insert(key.clone(), value.clone());
            }
            // Keep only the definitions this message refers to, so each file reads alone.
            let used: serde_json::Map<String, Value> = defs
                .as_object()
                .into_iter()
                .flatten()
                .filter(|(key, _)| refers_to(branch, key, &defs))
                .map(|(k, v)| (k.clone(), v.clone()))
                .collect();
            if !used.is_empty() {
                object.insert("$defs".into(), Value::Object(used));
            }
            out.push((format!("{side}/{name}.json"), schema));
        }
    }
    out.extend(http());
    out.extend(trajectory());
    let mut row = serde_json::to_value(reply::<crate::LeaderboardRow>()).unwrap_or_default();
    if let Some(object) = row.as_object_mut() {
        object.insert("$id".into(), "https://bw4t.invalid/protocol/v1/eval/row.json".into());
        object.insert("title".into(), "a leaderboard row of `bw4t eval`".into());
    }
    out.push(("eval/row.json".to_string(), row));
    out
}

/// The files `bw4t replay trajectories` writes: `trajectory/robot.json` (a line of
/// `NAME.jsonl`), `trajectory/env.json` (a line of `NAME.env.jsonl`), `trajectory/meta.json`.
fn trajectory() -> Vec<(String, Value)> {
    [
        ("robot", "a line of a robot's trajectory (NAME.jsonl)", reply::<RobotTick>()),
        ("env", "a line of a robot's environment trajectory (NAME.env.jsonl)", reply::<EnvStep>()),
        ("meta", "meta.json: what an exported replay's trajectories hold", reply::<TrajectoryMeta>()),
    ]
    .into_iter()
    .map(|(name, title, schema)| {
        (format!("trajectory/{name}.json"), titled(schema, &format!("trajectory/{name}"), title))
    })
    .collect()
}

/// A schema with its `$id` (under the protocol's, at `path`) and title.
fn titled(schema: Schema, path: &str, title: &str) -> Value {
    let mut schema = serde_json::to_value(schema).unwrap_or_default();
    if let Some(object) = schema.as_object_mut() {
        object.insert("$id".into(), format!("https://bw4t.invalid/protocol/v1/{path}.json").into());
        object.insert("title".into(), title.into());
    }
    schema
}

/// The web port's replies: `http/map.json`, `http/info.json`, `http/matches.json`,
/// `http/match.json`, `http/stopped.json`, `http/results.json`, `http/error.json`, and the
/// study API's under `http/study/`.
fn http() -> Vec<(String, Value)> {
    [
        ("map", "GET /map.json: the map's layout", reply::<MapLayout>()),
        ("info", "GET /info.json: what the server serves", reply::<ServerInfo>()),
        ("matches", "GET /api/matches: the matches listed", reply::<MatchList>()),
        ("match", "GET /api/matches/NAME: one match's summary", reply::<MatchSummary>()),
        ("stopped", "POST /api/matches/NAME/stop: a stopped match no longer kept", reply::<StoppedMatch>()),
        ("results", "GET /api/results: the results index", reply::<ResultList>()),
        ("error", "every error answer of the web port", reply::<ErrorReply>()),
        ("study/info", "GET /api/study: the study", reply::<StudyInfo>()),
        ("study/participant", "a participant's state and page", reply::<ParticipantState>()),
        ("study/participants", "GET /api/study/participants: everyone", reply::<ParticipantList>()),
        (
            "study/events",
            "POST /api/study/participants/ID/events: events recorded",
            reply::<EventsRecorded>(),
        ),
        ("study/conflict", "409 at a step not the participant's current one", reply::<StepConflict>()),
        ("study/exported", "POST /api/study/export: the export made", reply::<StudyExported>()),
    ]
    .into_iter()
    .map(|(name, title, schema)| {
        (format!("http/{name}.json"), titled(schema, &format!("http/{name}"), title))
    })
    .collect()
}

/// The schema of a reply the server writes: every field it always writes is required, a
/// `null` one too (the schema of what is serialised, not of what would be read).
fn reply<T: JsonSchema>() -> Schema {
    SchemaSettings::draft2020_12().for_serialize().into_generator().into_root_schema_for::<T>()
}

/// One schema whose `$defs` are the word lists ([`crate::vocabulary`]).
fn vocabulary() -> Value {
    let words = [
        ("ErrorCode", schema_for!(ErrorCode)),
        ("AckCode", schema_for!(AckCode)),
        ("ByeReason", schema_for!(ByeReason)),
        ("Leaving", schema_for!(Leaving)),
        ("EndReason", schema_for!(EndReason)),
        ("Outcome", schema_for!(Outcome)),
        ("MoveState", schema_for!(MoveState)),
        ("AgentStatus", schema_for!(AgentStatus)),
    ];
    let mut defs = serde_json::Map::new();
    for (name, schema) in words {
        let mut schema = serde_json::to_value(schema).unwrap_or_default();
        let Some(object) = schema.as_object_mut() else { continue };
        object.remove("$schema");
        object.remove("title");
        if let Some(Value::Object(inner)) = object.remove("$defs") {
            defs.extend(inner);
        }
        defs.insert(name.to_string(), schema);
    }
    json!({
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "$id": "https://bw4t.invalid/protocol/v1/vocabulary.json",
        "title": "the words of the bw4t protocol and result files",
        "$defs": defs,
    })
}

/// Whether `value` refers to definition `key`, directly or through other definitions.
fn refers_to(value: &Value, key: &str, defs: &Value) -> bool {
    let mut seen = Vec::new();
    reaches(value, key, defs, &mut seen)
}

fn reaches(value: &Value, key: &str, defs: &Value, seen: &mut Vec<String>) -> bool {
    match value {
        Value::Object(map) => map.iter().any(|(k, v)| {
            if k == "$ref" {
                let Some(target) = v.as_str().and_then(|r| r.strip_prefix("#/$defs/")) else { return false };
                if target == key {
                    return true;
                }
                if seen.iter().any(|s| s == target) {
                    return false;
                }
                seen.push(target.to_string());
                defs.get(target).is_some_and(|d| reaches(d, key, defs, seen))
            } else {
                reaches(v, key, defs, seen)
            }
        }),
        Value::Array(items) => items.iter().any(|v| reaches(v, key, defs, seen)),
        _ => false,
    }
}
