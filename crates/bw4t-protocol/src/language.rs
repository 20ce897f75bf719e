//! The message language players share, in the spirit of the original BW4T client's menu:
//! each kind of message has a structured form (a kind word and named arguments: a room, a
//! colour, a player, a count), which programs read without parsing prose, and one English
//! sentence, which people read. [`KINDS`] is the one table of both.
//!
//! Inside a match a structured message travels as its text form ([`Said::to_text`], the
//! compact JSON of [`Said`]), so the simulation routes it like any text; the protocol shows
//! it to players as the sentence plus the structured form.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// An argument a message kind takes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Slot {
    /// A place's name (a room, usually).
    Room,
    /// A block colour's name.
    Colour,
    /// A player's name.
    Player,
    /// A number of blocks.
    Count,
    /// A position in the goal sequence: on the wire the index as in `sequenceIndex`
    /// (0 is the first colour); sentences count from [`SPOKEN_FIRST_POSITION`].
    Position,
}

/// The number sentences (and `bw4t mcp`'s `say` tool) give the first position of the goal
/// sequence; on the wire it is 0, as `sequenceIndex` counts.
pub const SPOKEN_FIRST_POSITION: u32 = 1;

/// What a kind of message is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Group {
    /// What the sender knows or does about rooms.
    Rooms,
    /// What the sender knows or does about blocks.
    Blocks,
    /// A question or request to the team or to one player.
    Requests,
    /// Answers and how the sender is doing.
    Answers,
}

/// One kind of message: its word on the wire, its arguments, its sentence, its group.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct KindRow {
    /// The kind's word (`said.kind`).
    pub word: &'static str,
    /// The arguments it takes, all required.
    pub slots: &'static [Slot],
    /// Its English sentence, with `{room}`, `{colour}`, `{player}`, `{count}` standing for
    /// the arguments.
    pub sentence: &'static str,
    /// What it is for.
    pub group: Group,
}

const ROOM: &[Slot] = &[Slot::Room];
const COLOUR: &[Slot] = &[Slot::Colour];
const ROOM_COLOUR: &[Slot] = &[Slot::Room, Slot::Colour];
const NONE: &[Slot] = &[];

/// Every kind of message, grouped as the page's menu shows them.
pub const KINDS: &[KindRow] = &[
    KindRow { word: "going_to", slots: ROOM, sentence: "I am going to {room}.", group: Group::Rooms },
    KindRow { word: "checked", slots: ROOM, sentence: "{room} has been checked.", group: Group::Rooms },
    KindRow {
        word: "contains",
        slots: ROOM_COLOUR,
        sentence: "{room} contains {colour}.",
        group: Group::Rooms,
    },
    KindRow {
        word: "contains_many",
        slots: &[Slot::Room, Slot::Count, Slot::Colour],
        sentence: "{room} contains {count} {colour}.",
        group: Group::Rooms,
    },
    KindRow { word: "empty", slots: ROOM, sentence: "{room} is empty.", group: Group::Rooms },
    KindRow { word: "in_room", slots: ROOM, sentence: "I am in {room}.", group: Group::Rooms },
    KindRow {
        word: "waiting_outside",
        slots: ROOM,
        sentence: "I am waiting outside {room}.",
        group: Group::Rooms,
    },
    KindRow { word: "have", slots: COLOUR, sentence: "I have {colour}.", group: Group::Blocks },
    KindRow { word: "will_get", slots: COLOUR, sentence: "I will get {colour}.", group: Group::Blocks },
    KindRow {
        word: "getting_from",
        slots: ROOM_COLOUR,
        sentence: "I am getting {colour} from {room}.",
        group: Group::Blocks,
    },
    KindRow { word: "need", slots: COLOUR, sentence: "We need {colour}.", group: Group::Blocks },
    KindRow {
        word: "looking_for",
        slots: COLOUR,
        sentence: "I am looking for {colour}.",
        group: Group::Blocks,
    },
    KindRow { word: "dropped", slots: COLOUR, sentence: "I dropped off {colour}.", group: Group::Blocks },
    KindRow {
        word: "getting_for",
        slots: &[Slot::Colour, Slot::Room, Slot::Position],
        sentence: "I am getting {colour} from {room} for position {position}.",
        group: Group::Blocks,
    },
    KindRow {
        word: "bringing",
        slots: &[Slot::Colour, Slot::Position],
        sentence: "I am bringing {colour} for position {position}.",
        group: Group::Blocks,
    },
    KindRow {
        word: "giving_up",
        slots: &[Slot::Position],
        sentence: "I am no longer getting position {position}.",
        group: Group::Blocks,
    },
    KindRow { word: "who_has", slots: COLOUR, sentence: "Who has {colour}?", group: Group::Requests },
    KindRow { word: "where_is", slots: COLOUR, sentence: "Where is {colour}?", group: Group::Requests },
    KindRow { word: "what_in", slots: ROOM, sentence: "What is in {room}?", group: Group::Requests },
    KindRow {
        word: "anybody_going",
        slots: ROOM,
        sentence: "Is anybody going to {room}?",
        group: Group::Requests,
    },
    KindRow {
        word: "go_to",
        slots: &[Slot::Player, Slot::Room],
        sentence: "{player}, go to {room}.",
        group: Group::Requests,
    },
    KindRow {
        word: "get",
        slots: &[Slot::Player, Slot::Colour],
        sentence: "{player}, get {colour}.",
        group: Group::Requests,
    },
    KindRow { word: "yes", slots: NONE, sentence: "Yes.", group: Group::Answers },
    KindRow { word: "no", slots: NONE, sentence: "No.", group: Group::Answers },
    KindRow { word: "ok", slots: NONE, sentence: "OK.", group: Group::Answers },
    KindRow { word: "wait", slots: NONE, sentence: "Wait.", group: Group::Answers },
    KindRow { word: "dont_know", slots: NONE, sentence: "I don't know.", group: Group::Answers },
    KindRow { word: "on_my_way", slots: NONE, sentence: "I am on my way.", group: Group::Answers },
    KindRow { word: "almost_there", slots: NONE, sentence: "I am almost there.", group: Group::Answers },
    KindRow { word: "could_not", slots: NONE, sentence: "I could not do it.", group: Group::Answers },
];

/// The row of the kind with this word.
pub fn kind_row(word: &str) -> Option<&'static KindRow> {
    KINDS.iter().find(|row| row.word == word)
}

/// A message in the shared language: a kind and its arguments.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Said {
    /// The kind's word (see [`KINDS`]).
    pub kind: String,
    /// A place's name, for kinds that take a room.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub room: Option<String>,
    /// A colour's name, for kinds that take a colour.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub colour: Option<String>,
    /// A player's name, for kinds that address one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub player: Option<String>,
    /// A number of blocks, for kinds that count.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub count: Option<u32>,
    /// A position in the goal sequence (0 is the first colour), for kinds about one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub position: Option<u32>,
}

/// Why a [`Said`] is not a message of the language.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum SaidError {
    /// No kind has this word.
    #[error("'{0}' is not a kind of message")]
    UnknownKind(String),
    /// The kind needs this argument and it is missing.
    #[error("'{kind}' needs a {slot}")]
    Missing {
        /// The kind's word.
        kind: String,
        /// The argument.
        slot: &'static str,
    },
    /// The kind takes no such argument.
    #[error("'{kind}' takes no {slot}")]
    Extra {
        /// The kind's word.
        kind: String,
        /// The argument.
        slot: &'static str,
    },
}

impl Slot {
    /// The argument's name (its field in [`Said`] and its placeholder in sentences).
    pub fn name(self) -> &'static str {
        match self {
            Slot::Room => "room",
            Slot::Colour => "colour",
            Slot::Player => "player",
            Slot::Count => "count",
            Slot::Position => "position",
        }
    }

    const ALL: [Slot; 5] = [Slot::Room, Slot::Colour, Slot::Player, Slot::Count, Slot::Position];
}

impl Said {
    /// A message of kind `kind` with no arguments yet.
    pub fn new(kind: &str) -> Said {
        Said { kind: kind.to_string(), ..Said::default() }
    }

    /// The argument in `slot`, as a sentence shows it.
    fn value(&self, slot: Slot) -> Option<String> {
        match slot {
            Slot::Room => self.room.clone(),
            Slot::Colour => self.colour.clone(),
            Slot::Player => self.player.clone(),
            Slot::Count => self.count.map(|n| n.to_string()),
            Slot::Position => {
                self.position.map(|n| (u64::from(n) + u64::from(SPOKEN_FIRST_POSITION)).to_string())
            }
        }
    }

    /// The text form a match carries: the compact JSON, fields in a fixed order.
    pub fn to_text(&self) -> String {
        serde_json::to_string(self).unwrap_or_default()
    }

    /// The message a text form stands for, if the text is one (a checked [`Said`] in JSON).
    pub fn from_text(text: &str) -> Option<Said> {
        if !text.starts_with('{') {
            return None;
        }
        let said: Said = serde_json::from_str(text).ok()?;
        said.check().ok()?;
        Some(said)
    }

    /// Its kind's row, once it has exactly the arguments its kind takes.
    pub fn check(&self) -> Result<&'static KindRow, SaidError> {
        let row = kind_row(&self.kind).ok_or_else(|| SaidError::UnknownKind(self.kind.clone()))?;
        for slot in Slot::ALL {
            let wanted = row.slots.contains(&slot);
            match (wanted, self.value(slot).is_some()) {
                (true, false) => {
                    return Err(SaidError::Missing { kind: self.kind.clone(), slot: slot.name() });
                }
                (false, true) => return Err(SaidError::Extra { kind: self.kind.clone(), slot: slot.name() }),
                _ => {}
            }
        }
        Ok(row)
    }

    /// Its English sentence.
    pub fn sentence(&self) -> Result<String, SaidError> {
        let row = self.check()?;
        let mut text = row.sentence.to_string();
        for slot in row.slots {
            let value = self.value(*slot).unwrap_or_default();
            text = text.replace(&format!("{{{}}}", slot.name()), &value);
        }
        Ok(text)
    }
}

/// Which messages a match allows: some or all kinds, and free text or not.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
pub struct MessagePolicy {
    /// The kinds' words allowed, in menu order (`None`: every kind).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kinds: Option<Vec<String>>,
    /// Whether text outside the language may be sent.
    pub free_text: bool,
}

impl Default for MessagePolicy {
    fn default() -> Self {
        MessagePolicy { kinds: None, free_text: true }
    }
}

impl MessagePolicy {
    /// No message at all: no kind of the language and no free text.
    pub fn silence() -> MessagePolicy {
        MessagePolicy { kinds: Some(Vec::new()), free_text: false }
    }

    /// Why the policy refuses a message (a structured one, or free text when `said` is
    /// `None`), or `None` when it is allowed.
    pub fn refuses(&self, said: Option<&Said>) -> Option<String> {
        match (said, &self.kinds) {
            (None, _) if !self.free_text => Some("this match allows only messages of the language".into()),
            (Some(said), Some(kinds)) if !kinds.contains(&said.kind) => {
                Some(format!("this match does not allow '{}' messages", said.kind))
            }
            _ => None,
        }
    }

    /// Whether any message is refused (else checking a message is not needed).
    pub fn restricts(&self) -> bool {
        self.kinds.is_some() || !self.free_text
    }

    /// The kinds allowed, every kind's word when all are.
    pub fn allowed_kinds(&self) -> Vec<String> {
        match &self.kinds {
            Some(kinds) => kinds.clone(),
            None => KINDS.iter().map(|row| row.word.to_string()).collect(),
        }
    }

    /// An unknown kind among those named, if any.
    pub fn check(&self) -> Result<(), SaidError> {
        match self.kinds.iter().flatten().find(|k| kind_row(k).is_none()) {
            Some(unknown) => Err(SaidError::UnknownKind(unknown.clone())),
            None => Ok(()),
        }
    }
}

/// The language as JSON, for `protocol/schema/language.json`: every kind with its word,
/// arguments, sentence and group, in menu order.
pub fn language_json() -> serde_json::Value {
    let kinds: Vec<serde_json::Value> = KINDS
        .iter()
        .map(|row| {
            serde_json::json!({
                "kind": row.word,
                "slots": row.slots,
                "sentence": row.sentence,
                "group": row.group,
            })
        })
        .collect();
    serde_json::json!({ "kinds": kinds })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A message of `row`'s kind with a value in every slot.
    fn filled(row: &KindRow) -> Said {
        let mut said = Said::new(row.word);
        for slot in row.slots {
            match slot {
                Slot::Room => said.room = Some("RoomB2".into()),
                Slot::Colour => said.colour = Some("Red".into()),
                Slot::Player => said.player = Some("Bot1".into()),
                Slot::Count => said.count = Some(2),
                Slot::Position => said.position = Some(4),
            }
        }
        said
    }

    #[test]
    fn every_kind_has_a_unique_word_and_a_sentence_naming_each_argument_once() {
        let mut words: Vec<&str> = KINDS.iter().map(|r| r.word).collect();
        words.sort_unstable();
        words.dedup();
        assert_eq!(words.len(), KINDS.len(), "kind words repeat");
        for row in KINDS {
            for slot in Slot::ALL {
                let placeholder = format!("{{{}}}", slot.name());
                let times = row.sentence.matches(&placeholder).count();
                assert_eq!(times, usize::from(row.slots.contains(&slot)), "{}: {placeholder}", row.word);
            }
            let sentence = filled(row).sentence().expect("a sentence");
            assert!(!sentence.contains('{') && sentence.ends_with(['.', '?']), "{sentence}");
        }
    }

    #[test]
    fn sentences_read_as_english() {
        let mut said = Said::new("contains");
        said.room = Some("RoomB2".into());
        said.colour = Some("Red".into());
        assert_eq!(said.sentence().as_deref(), Ok("RoomB2 contains Red."));
        let mut said = Said::new("go_to");
        said.player = Some("Bot1".into());
        said.room = Some("RoomC3".into());
        assert_eq!(said.sentence().as_deref(), Ok("Bot1, go to RoomC3."));
        assert_eq!(Said::new("dont_know").sentence().as_deref(), Ok("I don't know."));
        let mut said = Said::new("bringing");
        said.colour = Some("Blue".into());
        said.position = Some(0);
        assert_eq!(said.sentence().as_deref(), Ok("I am bringing Blue for position 1."));
    }

    #[test]
    fn the_text_form_round_trips_and_free_text_is_not_taken_for_it() {
        for row in KINDS {
            let said = filled(row);
            assert_eq!(Said::from_text(&said.to_text()), Some(said.clone()), "{}", row.word);
        }
        assert_eq!(Said::from_text("room RoomA1 3:Red"), None);
        assert_eq!(Said::from_text(r#"{"kind":"will_get"}"#), None, "a colour is missing");
        assert_eq!(Said::from_text(r#"{"kind":"yes"} "#).map(|s| s.kind), Some("yes".into()));
    }

    #[test]
    fn wrong_arguments_are_named() {
        assert_eq!(Said::new("dance").check(), Err(SaidError::UnknownKind("dance".into())));
        let missing = Said::new("will_get").check().expect_err("no colour");
        assert_eq!(missing.to_string(), "'will_get' needs a colour");
        let mut extra = Said::new("yes");
        extra.room = Some("RoomA1".into());
        assert_eq!(extra.check().expect_err("a room").to_string(), "'yes' takes no room");
    }

    #[test]
    fn the_json_form_names_only_the_arguments_given() {
        let mut said = Said::new("getting_from");
        said.room = Some("RoomA1".into());
        said.colour = Some("Blue".into());
        let json = serde_json::to_string(&said).expect("json");
        assert_eq!(json, r#"{"kind":"getting_from","room":"RoomA1","colour":"Blue"}"#);
        assert_eq!(serde_json::from_str::<Said>(&json).expect("back"), said);
        assert!(serde_json::from_str::<Said>(r#"{"kind":"yes","colour_":"Red"}"#).is_err());
    }
}
