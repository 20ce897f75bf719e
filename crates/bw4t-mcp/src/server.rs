//! The MCP side: the tools, resources and prompt of one robot, answered through its
//! [`Link`]. Arguments are checked here, against the map and the language, each within a
//! documented range and every message within the protocol's line, so a bad one is a tool
//! error result (`isError: true`, outcome `invalid`, counted) naming the problem before
//! anything is sent; what the match refuses is a tool result with outcome `rejected`. The
//! tools' input schemas carry the map's places and the language's colours and kinds as
//! `enum`s. Over HTTP a tool call is refused unless its session drives the robot
//! (`seat.rs`); the rules, map, goal, tool list and prompt stay open to every session.

use std::sync::Arc;
use std::time::Duration;

use bw4t_protocol::{ActId, ClientMessage, KINDS, MAX_LINE, SPOKEN_FIRST_POSITION, Said, Say};
use rmcp::model::{
    CallToolRequestParams, CallToolResponse, CallToolResult, ContentBlock, GetPromptRequestParams,
    GetPromptResponse, GetPromptResult, Implementation, JsonObject, ListPromptsResult, ListResourcesResult,
    ListToolsResult, PaginatedRequestParams, Prompt, PromptMessage, ReadResourceRequestParams,
    ReadResourceResponse, ReadResourceResult, RequestMetaObject, Resource, ResourceContents,
    ServerCapabilities, ServerConfig, Tool, ToolAnnotations,
};
use rmcp::service::RequestContext;
use rmcp::transport::common::http_header::HEADER_SESSION_ID;
use rmcp::{ErrorData, RoleServer, ServerHandler};
use schemars::JsonSchema;
use serde::Deserialize;
use serde::de::DeserializeOwned;
use serde_json::{Value, json};

use crate::answer::{Answer, output_schema};
use crate::docs::{self, Docs};
use crate::echo::{clip_quoted, echo};
use crate::link::{Link, LinkError, Tokens};
use crate::robot::Command;
use crate::seat::Seat;

/// The longest a tool may be given (`wait`'s `seconds`, and `--tool-timeout`).
pub const MAX_TOOL_SECONDS: f64 = 3600.0;
/// The most ticks `wait` may be given (an hour at 20 ticks a second).
pub const MAX_WAIT_TICKS: u64 = 72_000;
/// The longest name a tool takes (a place, a player, a kind, a room, a colour), in bytes.
pub const MAX_NAME_BYTES: usize = 256;
/// The largest `count` or `position` of a message.
pub const MAX_MESSAGE_NUMBER: u32 = 1000;
/// The longest free text `say` sends, in characters. Every teammate reads a message in
/// the results of its next calls (a model pays for it in tokens, and in every transcript):
/// 280 characters is a few sentences, four times the language's longest sentence, so a
/// plan fits and a flood does not.
pub const MAX_FREE_TEXT_CHARS: usize = 280;

/// The MCP server of one robot; every session (stdio, or each HTTP client) shares it, and
/// over HTTP one of them drives.
#[derive(Clone)]
pub struct RobotServer {
    link: Link,
    docs: Arc<Docs>,
    timeout: Duration,
    /// Over HTTP, the session that drives the robot; over stdio there is one session.
    seat: Option<Arc<Seat>>,
    /// The tools, with the map's places in their schemas.
    tools: Arc<Vec<Tool>>,
}

impl RobotServer {
    /// Serves the robot behind `link`; a tool call gives up after `timeout` (wall time).
    pub fn new(link: Link, docs: Docs, timeout: Duration) -> RobotServer {
        let tools = Arc::new(tool_list(&docs));
        RobotServer { link, docs: Arc::new(docs), timeout, seat: None, tools }
    }

    /// The same robot, whose tools only the session holding `seat` may call.
    pub(crate) fn seated(self, seat: Arc<Seat>) -> RobotServer {
        RobotServer { seat: Some(seat), ..self }
    }
}

#[derive(Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
struct NoArgs {}

#[derive(Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
struct GoToArgs {
    /// A place's name: a room (`RoomC1`), a hall, or `DropZone`.
    place: String,
}

#[derive(Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
struct BlockArgs {
    /// A block's id, as seen in the room the robot is in.
    block: u32,
}

#[derive(Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
struct PickUpArgs {
    /// The block to take (within reach); without it, the block the robot is at.
    #[serde(default)]
    #[schemars(with = "u32")]
    block: Option<u32>,
}

#[derive(Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
struct SayArgs {
    /// A kind of message of the language (see the `bw4t://rules` resource), e.g.
    /// `contains`, `going_to`, `have`, `who_has`; with its arguments below.
    #[serde(default)]
    #[schemars(with = "String")]
    kind: Option<String>,
    /// A place's name, for kinds about a room.
    #[serde(default)]
    #[schemars(with = "String")]
    room: Option<String>,
    /// A colour's name, for kinds about a colour.
    #[serde(default)]
    #[schemars(with = "String")]
    colour: Option<String>,
    /// A player's name, for requests to one player (`go_to`, `get`).
    #[serde(default)]
    #[schemars(with = "String")]
    player: Option<String>,
    /// A number of blocks (`contains_many`).
    #[serde(default)]
    #[schemars(with = "u32")]
    count: Option<u32>,
    /// A position in the goal sequence, counted as sentences count it (see `minimum`).
    #[serde(default)]
    #[schemars(with = "u32")]
    position: Option<u32>,
    /// Free text instead of a kind, where the match allows it (at most 280 characters).
    #[serde(default)]
    #[schemars(with = "String")]
    text: Option<String>,
    /// A player's name, or `all` (the default).
    #[serde(default)]
    #[schemars(with = "String")]
    to: Option<String>,
}

#[derive(Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
struct WaitArgs {
    /// Give up after this many ticks, 1 to 72000 (20 ticks are one simulated second).
    #[serde(default)]
    #[schemars(with = "u64")]
    ticks: Option<u64>,
    /// Give up after this many seconds, above 0 and at most 3600: simulated seconds in a
    /// lockstep match (the match never runs ahead of them), wall time in a realtime one.
    #[serde(default)]
    #[schemars(with = "f64")]
    seconds: Option<f64>,
}

/// One tool: its name, what it does, its arguments' type, and its hints to the host.
struct ToolRow {
    name: &'static str,
    description: &'static str,
    schema: fn() -> schemars::Schema,
    /// Changes nothing in the match (MCP's `readOnlyHint`).
    read_only: bool,
    /// May destroy something (`destructiveHint`): a block put down in a hall is lost.
    destructive: bool,
}

/// Every tool, in the order they are listed.
const TOOLS: &[ToolRow] = &[
    ToolRow {
        name: "look",
        description: "Describe the robot's situation now: where it is, what it holds and sees, what it knows of each room, what teammates said, what is needed next, the tick and the tick limit. Changes nothing; always the whole situation, also in brief mode.",
        schema: || schemars::schema_for!(NoArgs),
        read_only: true,
        destructive: false,
    },
    ToolRow {
        name: "go_to",
        description: "Travel to a place (a room, a hall or DropZone). Returns when the robot arrives, collides or is stopped, with what changed on the way.",
        schema: || schemars::schema_for!(GoToArgs),
        read_only: false,
        destructive: false,
    },
    ToolRow {
        name: "go_to_block",
        description: "Travel to a block seen in the room the robot is in, so that it can pick it up.",
        schema: || schemars::schema_for!(BlockArgs),
        read_only: false,
        destructive: false,
    },
    ToolRow {
        name: "pick_up",
        description: "Pick up the block the robot is at (or the named block within reach). A robot holds one block at a time.",
        schema: || schemars::schema_for!(PickUpArgs),
        read_only: false,
        destructive: false,
    },
    ToolRow {
        name: "put_down",
        description: "Put the held block down. In the drop zone it is delivered if it is the colour needed next; in a room it stays there; outside rooms it leaves the world.",
        schema: || schemars::schema_for!(NoArgs),
        read_only: false,
        destructive: true,
    },
    ToolRow {
        name: "say",
        description: "Send a message to a teammate or to all: a kind of the message language with its arguments (e.g. kind=contains, room=RoomA1, colour=Red), or free text.",
        schema: || schemars::schema_for!(SayArgs),
        read_only: false,
        destructive: false,
    },
    ToolRow {
        name: "wait",
        description: "Wait until something changes for this robot (a message, a delivery, a room occupied or freed), or until the ticks or seconds given pass (simulated seconds in a lockstep match). Time passes for the whole team meanwhile.",
        schema: || schemars::schema_for!(WaitArgs),
        read_only: false,
        destructive: false,
    },
];

/// Every tool's definition: schemas generated from the argument types, with the map's
/// places, the colours and the kinds as `enum`s, the hints, and one output schema.
fn tool_list(docs: &Docs) -> Vec<Tool> {
    let output = match output_schema() {
        Value::Object(map) => Arc::new(map),
        _ => Arc::new(JsonObject::new()),
    };
    TOOLS
        .iter()
        .map(|row| {
            let schema = serde_json::to_value((row.schema)()).unwrap_or_default();
            let mut object: JsonObject = match schema {
                Value::Object(map) => map,
                _ => JsonObject::new(),
            };
            if let Some(Value::Object(properties)) = object.get_mut("properties") {
                for property in properties.values_mut().filter_map(Value::as_object_mut) {
                    // An optional argument is simply left out: a `null` default would
                    // contradict its type for strict schema checkers.
                    if property.get("default") == Some(&Value::Null) {
                        property.remove("default");
                    }
                }
                constrain(row.name, properties, docs);
            }
            let hints = ToolAnnotations::new()
                .read_only(row.read_only)
                .destructive(row.destructive)
                .idempotent(row.read_only)
                .open_world(false);
            Tool::new(row.name, row.description, Arc::new(object))
                .with_annotations(hints)
                .with_raw_output_schema(output.clone())
        })
        .collect()
}

/// Puts what the checks enforce into a tool's argument schemas: `enum`s of places, rooms,
/// colours and kinds, and the numbers' ranges.
fn constrain(tool: &str, properties: &mut JsonObject, docs: &Docs) {
    let mut set = |field: &str, key: &str, value: Value| {
        if let Some(Value::Object(property)) = properties.get_mut(field) {
            property.insert(key.into(), value);
        }
    };
    match tool {
        "go_to" => {
            if let Some(places) = docs.places() {
                set("place", "enum", json!(places));
            }
        }
        "say" => {
            if let Some(rooms) = docs.rooms() {
                set("room", "enum", json!(rooms));
            }
            set("colour", "enum", json!(docs::colour_names()));
            set("kind", "enum", json!(KINDS.iter().map(|row| row.word).collect::<Vec<_>>()));
            set("position", "minimum", json!(SPOKEN_FIRST_POSITION));
            set("position", "maximum", json!(MAX_MESSAGE_NUMBER));
            set(
                "position",
                "description",
                json!(format!(
                    "A position in the goal sequence, {SPOKEN_FIRST_POSITION} for the first colour (as the sentences you read count)."
                )),
            );
            set("count", "maximum", json!(MAX_MESSAGE_NUMBER));
            set("text", "maxLength", json!(MAX_FREE_TEXT_CHARS));
            for field in ["to", "player"] {
                set(field, "maxLength", json!(MAX_NAME_BYTES));
            }
        }
        "wait" => {
            set("ticks", "minimum", json!(1));
            set("ticks", "maximum", json!(MAX_WAIT_TICKS));
            set("seconds", "exclusiveMinimum", json!(0));
            set("seconds", "maximum", json!(MAX_TOOL_SECONDS));
        }
        _ => {}
    }
}

/// Why a call's arguments are refused, in words that start with the tool's name.
type Invalid = String;

/// Arguments as `T`, or the problem (what the JSON reader quotes cut short).
fn parse<T: DeserializeOwned>(tool: &str, arguments: Option<JsonObject>) -> Result<T, Invalid> {
    let value = Value::Object(arguments.unwrap_or_default());
    serde_json::from_value(value).map_err(|e| invalid(tool, clip_quoted(&e.to_string())))
}

fn invalid(tool: &str, problem: impl std::fmt::Display) -> Invalid {
    format!("{tool}: {problem}")
}

/// A call that is well formed but may not run now (the robot is busy or driven by
/// another session): an MCP error naming the tool and why.
fn refused(tool: &str, problem: impl std::fmt::Display) -> ErrorData {
    ErrorData::invalid_request(format!("{tool}: {problem}"), None)
}

/// The MCP session a request came in, over HTTP (rmcp hands handlers the request's head).
fn session_of(context: &RequestContext<RoleServer>) -> Option<&str> {
    let head = context.extensions.get::<http::request::Parts>()?;
    head.headers.get(HEADER_SESSION_ID)?.to_str().ok()
}

/// The token counts a client put in the request's `_meta` (`bw4t/usage`).
fn reported_tokens(metas: [Option<&RequestMetaObject>; 2]) -> Option<Tokens> {
    metas.into_iter().flatten().find_map(|meta| {
        let usage = meta.0.0.get("bw4t/usage")?;
        let count = |key: &str| usage.get(key).and_then(Value::as_u64);
        Some(Tokens { prompt: count("prompt_tokens")?, completion: count("completion_tokens").unwrap_or(0) })
    })
}

impl RobotServer {
    /// The command a tool call asks for, checked.
    fn command(&self, name: &str, arguments: Option<JsonObject>) -> Result<Command, Invalid> {
        let command = match name {
            "go_to" => {
                let args: GoToArgs = parse(name, arguments)?;
                check_name(name, "place", &args.place)?;
                self.docs.check_place(&args.place).map_err(|e| invalid(name, e))?;
                Command::GoTo(args.place)
            }
            "go_to_block" => Command::GoToBlock(parse::<BlockArgs>(name, arguments)?.block),
            "pick_up" => Command::PickUp(parse::<PickUpArgs>(name, arguments)?.block),
            "put_down" => {
                parse::<NoArgs>(name, arguments)?;
                Command::PutDown
            }
            "say" => say_command(&self.docs, parse(name, arguments)?)?,
            "wait" => {
                let args: WaitArgs = parse(name, arguments)?;
                if args.ticks.is_some_and(|ticks| !(1..=MAX_WAIT_TICKS).contains(&ticks)) {
                    return Err(invalid(name, format!("ticks must be from 1 to {MAX_WAIT_TICKS}")));
                }
                if args.seconds.is_some_and(|seconds| !(seconds > 0.0 && seconds <= MAX_TOOL_SECONDS)) {
                    return Err(invalid(
                        name,
                        format!("seconds must be above 0 and at most {MAX_TOOL_SECONDS}"),
                    ));
                }
                Command::Wait { ticks: args.ticks, seconds: args.seconds }
            }
            other => unreachable!("tool '{other}' is checked against TOOLS before its arguments"),
        };
        Ok(command)
    }
}

/// A `say`, checked against the language and the map: a known kind with exactly its
/// arguments, a room of the map, a colour of the game, a position counted from
/// [`SPOKEN_FIRST_POSITION`], free text of at most [`MAX_FREE_TEXT_CHARS`].
fn say_command(docs: &Docs, args: SayArgs) -> Result<Command, Invalid> {
    let to = args.to.unwrap_or_else(|| "all".into());
    check_name("say", "to", &to)?;
    for (field, value) in
        [("kind", &args.kind), ("room", &args.room), ("colour", &args.colour), ("player", &args.player)]
    {
        check_name("say", field, value.as_deref().unwrap_or_default())?;
    }
    if args.count.is_some_and(|n| n > MAX_MESSAGE_NUMBER) {
        return Err(invalid("say", format!("count must be at most {MAX_MESSAGE_NUMBER}")));
    }
    if args.position.is_some_and(|n| !(SPOKEN_FIRST_POSITION..=MAX_MESSAGE_NUMBER).contains(&n)) {
        return Err(invalid(
            "say",
            format!(
                "position must be from {SPOKEN_FIRST_POSITION} (the first colour of the goal sequence) to {MAX_MESSAGE_NUMBER}"
            ),
        ));
    }
    match (args.kind, args.text) {
        (Some(_), Some(_)) => Err(invalid("say", "give a kind (with its arguments) or text, not both")),
        (None, None) => Err(invalid("say", "give a kind (with its arguments) or text")),
        (None, Some(text)) => {
            let stray =
                [args.room.is_some(), args.colour.is_some(), args.player.is_some()].into_iter().any(|x| x)
                    || args.count.is_some()
                    || args.position.is_some();
            if stray {
                return Err(invalid("say", "free text takes no room, colour, player, count or position"));
            }
            if text.trim().is_empty() {
                return Err(invalid("say", "the text is empty"));
            }
            let length = text.chars().count();
            if length > MAX_FREE_TEXT_CHARS {
                return Err(invalid(
                    "say",
                    format!(
                        "the text is {length} characters long; the most is {MAX_FREE_TEXT_CHARS} (every teammate reads it): say less, or use a kind of the language"
                    ),
                ));
            }
            check_line(&to, None, Some(&text))?;
            Ok(Command::Say { to, said: None, text: Some(text) })
        }
        (Some(kind), None) => {
            if bw4t_protocol::kind_row(&kind).is_none() {
                let kinds: Vec<&str> = KINDS.iter().map(|row| row.word).collect();
                return Err(invalid(
                    "say",
                    format!("{} is not a kind of message; the kinds are {}", echo(&kind), kinds.join(", ")),
                ));
            }
            if let Some(room) = &args.room {
                docs.check_room(room).map_err(|e| invalid("say", e))?;
            }
            if let Some(colour) = &args.colour {
                docs::check_colour(colour).map_err(|e| invalid("say", e))?;
            }
            let said = Said {
                kind,
                room: args.room,
                colour: args.colour,
                player: args.player,
                count: args.count,
                // On the wire positions count from 0, as `sequenceIndex` does.
                position: args.position.map(|n| n - SPOKEN_FIRST_POSITION),
            };
            said.check().map_err(|e| invalid("say", e))?;
            check_line(&to, Some(&said), None)?;
            Ok(Command::Say { to, said: Some(said), text: None })
        }
    }
}

/// An error unless `value` (the argument `field` of `tool`) is a name of a sensible length.
fn check_name(tool: &str, field: &str, value: &str) -> Result<(), Invalid> {
    if value.len() > MAX_NAME_BYTES {
        return Err(invalid(
            tool,
            format!("{field} is {} bytes long; the most is {MAX_NAME_BYTES}", value.len()),
        ));
    }
    Ok(())
}

/// An error unless the `say` message fits in one protocol line (the match drops longer
/// lines unread).
fn check_line(to: &str, said: Option<&Said>, text: Option<&str>) -> Result<(), Invalid> {
    let say = Say {
        id: Some(ActId::Number(u64::MAX)),
        to: to.into(),
        text: text.map(Into::into),
        said: said.cloned(),
    };
    let bytes = bw4t_protocol::encode(&ClientMessage::Say(say)).len();
    if bytes > MAX_LINE {
        return Err(invalid(
            "say",
            format!(
                "the message would be a {bytes}-byte line; a line holds at most {MAX_LINE} bytes: shorten the text"
            ),
        ));
    }
    Ok(())
}

/// A tool result as MCP carries it.
fn tool_result(answer: Answer) -> CallToolResult {
    let content = vec![ContentBlock::text(answer.text)];
    let mut result =
        if answer.is_error { CallToolResult::error(content) } else { CallToolResult::success(content) };
    result.structured_content = Some(answer.structured);
    result
}

impl ServerHandler for RobotServer {
    fn get_info(&self) -> ServerConfig {
        let capabilities =
            ServerCapabilities::builder().enable_tools().enable_resources().enable_prompts().build();
        ServerConfig::new(capabilities)
            .with_server_info(Implementation::new("bw4t", env!("CARGO_PKG_VERSION")))
            .with_instructions(docs::INSTRUCTIONS)
    }

    async fn list_tools(
        &self,
        _request: Option<PaginatedRequestParams>,
        _context: RequestContext<RoleServer>,
    ) -> Result<ListToolsResult, ErrorData> {
        Ok(ListToolsResult::with_all_items(self.tools.to_vec()))
    }

    fn get_tool(&self, name: &str) -> Option<Tool> {
        self.tools.iter().find(|t| t.name == name).cloned()
    }

    async fn call_tool(
        &self,
        request: CallToolRequestParams,
        context: RequestContext<RoleServer>,
    ) -> Result<CallToolResponse, ErrorData> {
        // Ended when rmcp cancels the request, or when its session leaves the seat; and
        // once the call is over, so that the seat forgets it.
        let call = context.ct.child_token();
        let _over = call.clone().drop_guard();
        if let Some(seat) = &self.seat {
            let session = session_of(&context);
            seat.take(session, &call).await.map_err(|refusal| refused(&request.name, refusal))?;
        }
        let tokens = reported_tokens([request.meta.as_ref(), Some(&context.meta)]);
        let name = request.name.as_ref();
        if !TOOLS.iter().any(|t| t.name == name) {
            // An unknown tool is a protocol error (the MCP spec's "Error Handling").
            let names: Vec<&str> = TOOLS.iter().map(|t| t.name).collect();
            return Err(ErrorData::invalid_params(
                format!("no tool named {}; the tools are {}", echo(name), names.join(", ")),
                None,
            ));
        }
        let given = Value::Object(request.arguments.clone().unwrap_or_default());
        let checked = match name {
            "look" => parse::<NoArgs>(name, request.arguments).map(|_| None),
            _ => self.command(name, request.arguments).map(Some),
        };
        let answer = match checked {
            Ok(None) => self.link.look(tokens).await,
            Ok(Some(command)) => self.link.run(command, given, self.timeout, tokens, &call).await,
            // Input errors are tool results the model sees (`isError`), as the MCP spec asks.
            Err(problem) => self.link.invalid(name, given, problem, tokens).await,
        };
        match answer {
            Ok(answer) => Ok(tool_result(answer).into()),
            Err(LinkError::Busy(busy)) => Err(refused(name, busy)),
            Err(LinkError::Gone) => {
                Err(ErrorData::internal_error("the robot's connection to the match is gone", None))
            }
        }
    }

    async fn list_resources(
        &self,
        _request: Option<PaginatedRequestParams>,
        _context: RequestContext<RoleServer>,
    ) -> Result<ListResourcesResult, ErrorData> {
        let resources = docs::RESOURCES
            .iter()
            .map(|r| Resource::new(r.uri, r.name).with_description(r.description).with_mime_type(r.mime))
            .collect();
        Ok(ListResourcesResult::with_all_items(resources))
    }

    async fn read_resource(
        &self,
        request: ReadResourceRequestParams,
        _context: RequestContext<RoleServer>,
    ) -> Result<ReadResourceResponse, ErrorData> {
        let Some(row) = docs::RESOURCES.iter().find(|r| r.uri == request.uri) else {
            let uris: Vec<&str> = docs::RESOURCES.iter().map(|r| r.uri).collect();
            return Err(ErrorData::resource_not_found(
                format!("no resource '{}'; there are {}", request.uri, uris.join(", ")),
                None,
            ));
        };
        // Only the goal depends on the match; the rest is fixed.
        let goal = match row.uri {
            "bw4t://goal" => self.link.peek().await.ok().map(|view| view.state),
            _ => None,
        };
        let text = self.docs.resource(row.uri, goal.as_ref());
        let contents = ResourceContents::text(text, row.uri).with_mime_type(row.mime);
        Ok(ReadResourceResult::new(vec![contents]).into())
    }

    async fn list_prompts(
        &self,
        _request: Option<PaginatedRequestParams>,
        _context: RequestContext<RoleServer>,
    ) -> Result<ListPromptsResult, ErrorData> {
        let prompt = Prompt::new(docs::PROMPT_NAME, Some(docs::PROMPT_DESCRIPTION), None);
        Ok(ListPromptsResult::with_all_items(vec![prompt]))
    }

    async fn get_prompt(
        &self,
        request: GetPromptRequestParams,
        _context: RequestContext<RoleServer>,
    ) -> Result<GetPromptResponse, ErrorData> {
        if request.name != docs::PROMPT_NAME {
            return Err(ErrorData::invalid_params(
                format!("no prompt '{}'; the prompt is '{}'", request.name, docs::PROMPT_NAME),
                None,
            ));
        }
        let view = self.link.peek().await.ok();
        let text = self.docs.role_prompt(view.as_ref().map(|v| &v.state));
        let result = GetPromptResult::new(vec![PromptMessage::new_text(rmcp::model::Role::User, text)])
            .with_description(docs::PROMPT_DESCRIPTION);
        Ok(result.into())
    }
}

#[cfg(test)]
mod tests {
    use bw4t_protocol::SPOKEN_FIRST_POSITION;
    use serde_json::json;

    use super::*;

    fn fixed() -> Docs {
        let map =
            bw4t_map::Map::from_native(include_str!("../../../maps/fixed.toml")).expect("the fixed map");
        Docs::new(Some(map))
    }

    fn say(docs: &Docs, args: Value) -> Result<Command, Invalid> {
        say_command(docs, serde_json::from_value(args).expect("say's arguments"))
    }

    #[test]
    fn a_position_is_said_as_the_sentences_count_and_sent_as_the_wire_counts() {
        let Ok(Command::Say { said: Some(said), .. }) =
            say(&fixed(), json!({"kind": "giving_up", "position": SPOKEN_FIRST_POSITION}))
        else {
            panic!("a say of the language");
        };
        assert_eq!(said.position, Some(0), "the wire counts from 0, as sequenceIndex does");
        let sentence = said.sentence().expect("a sentence");
        assert!(sentence.ends_with(&format!("position {SPOKEN_FIRST_POSITION}.")), "{sentence}");
        let refused = say(&fixed(), json!({"kind": "giving_up", "position": 0})).expect_err("refused");
        assert!(refused.contains("position must be from 1"), "{refused}");
    }

    #[test]
    fn a_say_names_what_is_not_of_the_map_or_the_language() {
        let docs = fixed();
        let room = say(&docs, json!({"kind": "contains", "room": "LeftHallA", "colour": "Red"}))
            .expect_err("a hall");
        assert!(
            room.starts_with("say: 'LeftHallA' is not a room of map 'fixed'; its rooms are RoomA1"),
            "{room}"
        );
        let colour = say(&docs, json!({"kind": "have", "colour": "red"})).expect_err("not a colour's name");
        assert!(
            colour.contains("'red' is not a colour; the colours are") && colour.contains("Red"),
            "{colour}"
        );
        let kind = say(&docs, json!({"kind": "x".repeat(200)})).expect_err("no such kind");
        assert!(kind.contains("(cut; 200 characters in all) is not a kind") && kind.len() < 600, "{kind}");
        let text = say(&docs, json!({"text": "é".repeat(MAX_FREE_TEXT_CHARS + 1)})).expect_err("too long");
        assert!(text.contains("281 characters long; the most is 280"), "{text}");
        assert!(
            say(&docs, json!({"text": "é".repeat(MAX_FREE_TEXT_CHARS)})).is_ok(),
            "characters, not bytes"
        );
        assert!(say(&docs, json!({"kind": "contains", "room": "DropZone", "colour": "Red"})).is_ok());
    }

    #[test]
    fn the_tools_carry_the_maps_places_and_the_hints() {
        let tools = tool_list(&fixed());
        let go_to = tools.iter().find(|t| t.name == "go_to").expect("go_to");
        let places = &go_to.input_schema["properties"]["place"]["enum"];
        assert!(
            places
                .as_array()
                .is_some_and(|p| p.contains(&json!("LeftHallA")) && p.contains(&json!("DropZone")))
        );
        assert_eq!(go_to.output_schema.as_deref(), output_schema().as_object());
        let unknown_map = tool_list(&Docs::new(None));
        let go_to = unknown_map.iter().find(|t| t.name == "go_to").expect("go_to");
        assert!(go_to.input_schema["properties"]["place"].get("enum").is_none(), "no map, no list");
        let read_only: Vec<&str> = tools
            .iter()
            .filter(|t| t.annotations.as_ref().and_then(|a| a.read_only_hint) == Some(true))
            .map(|t| t.name.as_ref())
            .collect();
        assert_eq!(read_only, ["look"]);
    }
}
