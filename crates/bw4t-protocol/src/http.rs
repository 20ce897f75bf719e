//! The JSON replies of the web port: the map's layout (`/map.json`), what the server serves
//! (`/info.json`), the matches it lists (`/api/matches`), a stopped match, the results
//! index (`/api/results`) and every error. Their schemas are generated into
//! `protocol/schema/http/` (the study API's replies are `study.rs`).

use bw4t_map::{Map, ROBOT_SIZE, ZoneKind};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::row::ResultRow;
use crate::vocabulary::{EndReason, Mode};

/// `/map.json`: the map's layout for drawing. Zones are top-left boxes in map units (y
/// down), doors carry the opening each makes in its wall, walls are `[x1, y1, x2, y2]`
/// (from [`Map::walls`]). The page draws what it is given.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct MapLayout {
    /// The map's name.
    pub name: String,
    /// Width and height of the map's area (halls may reach beyond it).
    pub area: [f32; 2],
    /// The side of a robot's square.
    pub robot: f32,
    /// Every zone, in the map's order.
    pub zones: Vec<ZoneLayout>,
    /// Every wall segment, `[x1, y1, x2, y2]`.
    pub walls: Vec<[f32; 4]>,
    /// Spawn points, `[x, y]`.
    pub spawns: Vec<[f32; 2]>,
    /// The drop zone's name.
    pub drop_zone: String,
}

/// One zone of a [`MapLayout`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct ZoneLayout {
    /// The zone's name.
    pub name: String,
    /// What kind of zone it is.
    pub kind: ZoneKindWord,
    /// Left edge.
    pub x: f32,
    /// Top edge.
    pub y: f32,
    /// Width.
    pub w: f32,
    /// Height.
    pub h: f32,
    /// Its doors (rooms only).
    pub doors: Vec<DoorLayout>,
}

/// One door of a [`ZoneLayout`]: its box and the opening it makes in the wall.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct DoorLayout {
    /// Left edge.
    pub x: f32,
    /// Top edge.
    pub y: f32,
    /// Width.
    pub w: f32,
    /// Height.
    pub h: f32,
    /// The gap in the wall, `[x1, y1, x2, y2]`.
    pub opening: [f32; 4],
}

/// A zone's kind as the layout names it (the map files' words, [`ZoneKind::name`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum ZoneKindWord {
    /// Walls with doors; holds blocks; one robot at a time.
    Room,
    /// Free space.
    Corridor,
    /// Free space (a recharging place in the original).
    Charging,
    /// Walled off; nobody enters.
    Blockade,
}

impl From<ZoneKind> for ZoneKindWord {
    fn from(kind: ZoneKind) -> Self {
        match kind {
            ZoneKind::Room => ZoneKindWord::Room,
            ZoneKind::Corridor => ZoneKindWord::Corridor,
            ZoneKind::Charging => ZoneKindWord::Charging,
            ZoneKind::Blockade => ZoneKindWord::Blockade,
        }
    }
}

impl MapLayout {
    /// The layout of `map`.
    pub fn of(map: &Map) -> MapLayout {
        let zones = map
            .zones()
            .iter()
            .map(|z| {
                let (min, size) = (z.rect.min(), z.rect.size);
                let doors = z
                    .doors
                    .iter()
                    .map(|d| {
                        let r = d.rect();
                        let (a, b) = d.opening();
                        DoorLayout {
                            x: r.min().x,
                            y: r.min().y,
                            w: r.size.x,
                            h: r.size.y,
                            opening: [a.x, a.y, b.x, b.y],
                        }
                    })
                    .collect();
                ZoneLayout {
                    name: z.name.clone(),
                    kind: z.kind.into(),
                    x: min.x,
                    y: min.y,
                    w: size.x,
                    h: size.y,
                    doors,
                }
            })
            .collect();
        MapLayout {
            name: map.name().to_string(),
            area: [map.area().x, map.area().y],
            robot: ROBOT_SIZE,
            zones,
            walls: map
                .walls()
                .iter()
                .map(|w| {
                    let (a, b) = w.ends();
                    [a.x, a.y, b.x, b.y]
                })
                .collect(),
            spawns: map.spawns().iter().map(|s| [s.pos.x, s.pos.y]).collect(),
            drop_zone: map.zones()[map.drop_zone()].name.clone(),
        }
    }
}

/// `/info.json`: what the server serves, named by `mode`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(tag = "mode", rename_all = "snake_case")]
pub enum ServerInfo {
    /// Live matches.
    Live {
        /// The protocol version ([`VERSION`](crate::VERSION)).
        protocol: u32,
        /// The default match's map, while it is live (`null` otherwise).
        map: Option<String>,
        /// The match a `hello` naming none joins, if it is live or has ended (`null` if none).
        default_match: Option<String>,
        /// Whether the server hosts many matches (the page opens on the lobby).
        lobby: bool,
        /// The templates a player may join by name.
        templates: Vec<TemplateInfo>,
    },
    /// One recorded match, replayed.
    Replay {
        /// The protocol version ([`VERSION`](crate::VERSION)).
        protocol: u32,
        /// The replayed match's map.
        map: String,
    },
}

/// A template of [`ServerInfo::Live`]: joining it seats the player in one of its matches.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct TemplateInfo {
    /// The template's name.
    pub name: String,
    /// Robots in each of its matches.
    pub robots: usize,
    /// The map of its first match.
    pub map: String,
}

/// `/api/matches`: every live match, then the finished ones, newest first.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct MatchList {
    /// The summaries.
    pub matches: Vec<MatchSummary>,
}

/// One match as the lobby lists it (`/api/matches/NAME`). The operator's fields are
/// present only in the operator's answer.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct MatchSummary {
    /// The match's name.
    pub name: String,
    /// The template it was made from, if any (`null` if none).
    pub template: Option<String>,
    /// Its map's name.
    pub map: String,
    /// How it is paced.
    pub mode: Mode,
    /// Where it is.
    pub state: MatchState,
    /// The players in it, in robot order.
    pub players: Vec<String>,
    /// Robots in it.
    pub robots: usize,
    /// Players it still waits for before its first tick.
    pub awaited: usize,
    /// The current (or last) tick.
    pub tick: u64,
    /// Sequence positions delivered, and the sequence's length.
    pub sequence: [usize; 2],
    /// Who may watch it.
    pub watch: Watch,
    /// Whether the operator paused it (live matches only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub paused: Option<bool>,
    /// Why it ended (finished matches only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub end_reason: Option<EndReason>,
    /// Which run of its name it is (1, 2, ...).
    pub run: u64,
    /// Operator only: its seed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
    /// Operator only: its id, unique among every match the server ran (`NAME.RUN`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub id: Option<String>,
    /// Operator only, live matches: connections open.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub connections: Option<usize>,
    /// Operator only, finished matches: its result's id (`/api/results/ID`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub result: Option<String>,
}

/// Where a listed match is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum MatchState {
    /// Waiting for players before its first tick.
    Waiting,
    /// Ticking.
    Playing,
    /// Ended.
    Finished,
}

/// Who may watch a listed match.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Watch {
    /// Anyone.
    Open,
    /// Those with the watch token.
    Token,
}

/// `POST /api/matches/NAME/stop` when the stopped run's summary is no longer kept: what
/// is known of it (its keys in this order, as this answer always had them).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct StoppedMatch {
    /// The stopped run's id (`NAME.RUN`).
    pub id: String,
    /// The match's name.
    pub name: String,
    /// Where it is: `finished`.
    pub state: MatchState,
}

/// `/api/results`: the results index, oldest first.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct ResultList {
    /// One row per finished match, as in `matches.jsonl`.
    pub results: Vec<ResultRow>,
}

/// Every error answer of the web port (a 4xx or 5xx): what is wrong.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct ErrorReply {
    /// What is wrong, for a person to read.
    pub error: String,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zone_kind_words_are_the_map_files_words() {
        for kind in [ZoneKind::Room, ZoneKind::Corridor, ZoneKind::Charging, ZoneKind::Blockade] {
            assert_eq!(serde_json::to_value(ZoneKindWord::from(kind)).ok(), Some(kind.name().into()));
        }
    }

    #[test]
    fn the_layout_tells_the_robot_size() {
        let map = bw4t_map::generate(2, 2, 3, 1).expect("a generated map");
        let layout = serde_json::to_value(MapLayout::of(&map)).expect("json");
        assert_eq!(layout["robot"], serde_json::json!(ROBOT_SIZE));
        assert_eq!(layout["drop_zone"], "DropZone");
    }

    #[test]
    fn a_stopped_match_and_an_error_answer_as_they_always_have() {
        let stopped = StoppedMatch { id: "demo.1".into(), name: "demo".into(), state: MatchState::Finished };
        let text = serde_json::to_string(&stopped).expect("json");
        assert_eq!(text, r#"{"id":"demo.1","name":"demo","state":"finished"}"#);
        assert_eq!(serde_json::from_str::<StoppedMatch>(&text).ok(), Some(stopped));
        let error = serde_json::to_string(&ErrorReply { error: "no \"x\"".into() }).expect("json");
        assert_eq!(error, r#"{"error":"no \"x\""}"#);
    }

    #[test]
    fn absent_operator_fields_are_left_out() {
        let summary = MatchSummary {
            name: "demo".into(),
            template: None,
            map: "Banana".into(),
            mode: Mode::Realtime,
            state: MatchState::Waiting,
            players: Vec::new(),
            robots: 2,
            awaited: 2,
            tick: 0,
            sequence: [0, 3],
            watch: Watch::Open,
            paused: Some(false),
            end_reason: None,
            run: 1,
            seed: None,
            id: None,
            connections: None,
            result: None,
        };
        let json = serde_json::to_value(&summary).expect("json");
        let keys: Vec<&str> = json.as_object().expect("an object").keys().map(String::as_str).collect();
        for absent in ["end_reason", "seed", "id", "connections", "result"] {
            assert!(!keys.contains(&absent), "{absent} in {keys:?}");
        }
        assert_eq!(json["template"], serde_json::Value::Null, "no template is null, not absent");
        assert_eq!(serde_json::from_value::<MatchSummary>(json).ok(), Some(summary));
    }
}
