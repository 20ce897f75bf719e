//! Between simulation types and wire shapes: percepts as JSON facts, `act` as an action.

use std::sync::Arc;

use bw4t_map::Colour;
use bw4t_sim::{Action, MoveState, Percept, Receiver};
use serde_json::{Value, json};

use crate::language::Said;
use crate::messages::{Act, ActId, ClientMessage, Fact};
use crate::vocabulary::AckCode;

/// A percept as a fact array, e.g. `["color",12,"Red"]`. A message of the language is
/// `["message", sender, sentence, said]`; free text is `["message", sender, text]`.
pub fn percept_to_fact(p: &Percept) -> Fact {
    let name = Value::from(p.name());
    let args: Vec<Value> = match p {
        Percept::Place(s) | Percept::Player(s) | Percept::OwnName(s) | Percept::At(s) => vec![json!(&**s)],
        Percept::In(s) | Percept::Occupied(s) => vec![json!(&**s)],
        Percept::Bot(n) | Percept::SequenceIndex(n) => vec![json!(n)],
        Percept::AtBlock(b) | Percept::Holding(b) | Percept::Block(b) => vec![json!(b)],
        Percept::Sequence(colours) => vec![Value::from(colours.iter().map(|c| c.name()).collect::<Vec<_>>())],
        Percept::State(s) => vec![json!(s.name())],
        Percept::Color(b, c) => vec![json!(b), json!(c.name())],
        Percept::Message { from, text } => match Said::from_text(text) {
            Some(said) => {
                vec![json!(&**from), json!(said.sentence().unwrap_or_default()), json!(said)]
            }
            None => vec![json!(&**from), json!(&**text)],
        },
    };
    std::iter::once(name).chain(args).collect()
}

/// A fact that is not a percept of this protocol version.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("not a percept: {0}")]
pub struct FactError(pub String);

/// Reads a `percepts` message back into the delta it was made from: what a remote player
/// applies to its beliefs.
pub fn percepts_delta(percepts: &crate::messages::Percepts) -> Result<bw4t_sim::PerceptDelta, FactError> {
    let facts = |list: &[Fact]| list.iter().map(|f| fact_to_percept(f)).collect::<Result<Vec<_>, _>>();
    Ok(bw4t_sim::PerceptDelta {
        tick: percepts.tick,
        full: percepts.full,
        add: facts(&percepts.add)?,
        not: facts(&percepts.not)?,
    })
}

/// Reads a fact array back into a percept.
pub fn fact_to_percept(fact: &[Value]) -> Result<Percept, FactError> {
    let bad = || FactError(Value::from(fact.to_vec()).to_string());
    let text = |i: usize| fact.get(i).and_then(Value::as_str).map(Arc::<str>::from).ok_or_else(bad);
    let number =
        |i: usize| fact.get(i).and_then(Value::as_u64).and_then(|n| u32::try_from(n).ok()).ok_or_else(bad);
    let colour = |v: &Value| v.as_str().and_then(|s| s.parse::<Colour>().ok()).ok_or_else(bad);
    let name = fact.first().and_then(Value::as_str).ok_or_else(bad)?;
    let arity = match name {
        "color" => 3,
        "message" if fact.len() == 4 => 4,
        "message" => 3,
        _ => 2,
    };
    if fact.len() != arity {
        return Err(bad());
    }
    Ok(match name {
        "place" => Percept::Place(text(1)?),
        "player" => Percept::Player(text(1)?),
        "ownName" => Percept::OwnName(text(1)?),
        "bot" => Percept::Bot(number(1)?),
        "sequence" => {
            let list = fact[1].as_array().ok_or_else(bad)?;
            Percept::Sequence(list.iter().map(colour).collect::<Result<Vec<_>, _>>()?.into())
        }
        "at" => Percept::At(text(1)?),
        "sequenceIndex" => Percept::SequenceIndex(number(1)?),
        "state" => Percept::State(match fact[1].as_str() {
            Some("arrived") => MoveState::Arrived,
            Some("traveling") => MoveState::Traveling,
            Some("collided") => MoveState::Collided,
            _ => return Err(bad()),
        }),
        "in" => Percept::In(text(1)?),
        "atBlock" => Percept::AtBlock(number(1)?),
        "occupied" => Percept::Occupied(text(1)?),
        "color" => Percept::Color(number(1)?, colour(&fact[2])?),
        "holding" => Percept::Holding(number(1)?),
        "block" => Percept::Block(number(1)?),
        "message" if arity == 4 => {
            let said: Said = serde_json::from_value(fact[3].clone()).map_err(|_| bad())?;
            said.check().map_err(|_| bad())?;
            Percept::Message { from: text(1)?, text: said.to_text().into() }
        }
        "message" => Percept::Message { from: text(1)?, text: text(2)? },
        _ => return Err(bad()),
    })
}

/// Why an `act` names no action: `unknown_action` or `bad_args`, and in words.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{message}")]
pub struct ActError {
    /// The `ack` code.
    pub code: AckCode,
    /// What was wrong, in words.
    pub message: String,
}

/// The action an `act` asks for; errors carry `unknown_action` or `bad_args`.
pub fn action_from_act(action: &str, args: &[Value]) -> Result<Action, ActError> {
    let usage = |shape: &str| ActError {
        code: AckCode::BadArgs,
        message: format!("{action} takes {shape}, got {}", Value::from(args.to_vec())),
    };
    let block = |v: &Value| v.as_u64().and_then(|n| u32::try_from(n).ok());
    match (action, args) {
        ("goTo", [Value::String(place)]) => Ok(Action::GoTo(place.clone())),
        ("goTo", _) => Err(usage("[place name]")),
        ("goToBlock", [id]) => block(id).map(Action::GoToBlock).ok_or_else(|| usage("[block id]")),
        ("goToBlock", _) => Err(usage("[block id]")),
        ("pickUp", []) => Ok(Action::PickUp(None)),
        ("pickUp", [id]) => {
            block(id).map(|b| Action::PickUp(Some(b))).ok_or_else(|| usage("[] or [block id]"))
        }
        ("pickUp", _) => Err(usage("[] or [block id]")),
        ("putDown", []) => Ok(Action::PutDown),
        ("putDown", _) => Err(usage("no arguments")),
        ("sendMessage", [Value::String(to), Value::String(text)]) => {
            Ok(Action::SendMessage { to: receiver(to), text: message_text(Some(text), None)? })
        }
        ("sendMessage", [Value::String(to), said @ Value::Object(_)]) => {
            let said: Said = serde_json::from_value(said.clone()).map_err(|e| ActError {
                code: AckCode::BadArgs,
                message: format!("not a message of the language: {e}"),
            })?;
            Ok(Action::SendMessage { to: receiver(to), text: message_text(None, Some(&said))? })
        }
        ("sendMessage", _) => Err(usage("[receiver, text or said]")),
        _ => Err(ActError {
            code: AckCode::UnknownAction,
            message: format!("unknown action '{action}' (goTo, goToBlock, pickUp, putDown, sendMessage)"),
        }),
    }
}

/// The text a match carries for a message given as free `text` or as a `said` (exactly
/// one). Text that is the text form of a message of the language is that
/// message, in its canonical form, so a message has one form whichever way it was sent.
pub fn message_text(text: Option<&str>, said: Option<&Said>) -> Result<String, ActError> {
    let bad = |message: String| ActError { code: AckCode::BadArgs, message };
    match (text, said) {
        (Some(text), None) => {
            Ok(Said::from_text(text).map_or_else(|| text.to_string(), |said| said.to_text()))
        }
        (None, Some(said)) => {
            said.check().map_err(|e| bad(e.to_string()))?;
            Ok(said.to_text())
        }
        (Some(_), Some(_)) => Err(bad("a message has text or said, not both".into())),
        (None, None) => Err(bad("a message needs text or said".into())),
    }
}

/// An action as the `action` name and `args` of an `act` (the inverse of [`action_from_act`]).
pub fn action_to_act(action: &Action) -> (&'static str, Vec<Value>) {
    let args = match action {
        Action::GoTo(place) => vec![json!(place)],
        Action::GoToBlock(b) => vec![json!(b)],
        Action::PickUp(None) | Action::PutDown => vec![],
        Action::PickUp(Some(b)) => vec![json!(b)],
        Action::SendMessage { to, text } => {
            let to = match to {
                Receiver::All => "all".to_string(),
                Receiver::Player(name) => name.clone(),
            };
            let message = match Said::from_text(text) {
                Some(said) => json!(said),
                None => json!(text),
            };
            vec![json!(to), message]
        }
    };
    (action.name(), args)
}

/// The `act` message for `action`, numbered `id`.
pub fn act_message(id: u64, action: &Action) -> ClientMessage {
    let (name, args) = action_to_act(action);
    ClientMessage::Act(Act { id: ActId::Number(id), action: name.to_string(), args })
}

/// `all` or a player's name.
pub fn receiver(to: &str) -> Receiver {
    if to == "all" { Receiver::All } else { Receiver::Player(to.to_string()) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_percept_round_trips_through_its_fact() {
        let name = |s: &str| Arc::<str>::from(s);
        let all = [
            Percept::Place(name("RoomA1")),
            Percept::Player(name("Bob")),
            Percept::OwnName(name("Ann")),
            Percept::Bot(3),
            Percept::Sequence(vec![Colour::Red, Colour::Blue].into()),
            Percept::At(name("FrontA1")),
            Percept::SequenceIndex(2),
            Percept::State(MoveState::Collided),
            Percept::In(name("RoomC1")),
            Percept::AtBlock(4),
            Percept::Occupied(name("DropZone")),
            Percept::Color(12, Colour::Red),
            Percept::Holding(4),
            Percept::Block(12),
            Percept::Message { from: name("Bob"), text: name("hi there") },
        ];
        for p in all {
            let fact = percept_to_fact(&p);
            assert_eq!(fact_to_percept(&fact), Ok(p));
        }
        assert_eq!(
            percept_to_fact(&Percept::Color(12, Colour::Red)),
            vec![json!("color"), json!(12), json!("Red")]
        );
        assert!(fact_to_percept(&[json!("color"), json!(1)]).is_err());
        assert!(fact_to_percept(&[json!("fly")]).is_err());
    }

    #[test]
    fn acts_become_actions_or_say_what_is_wrong() {
        let code = |a: &str, args: Value| {
            action_from_act(a, args.as_array().expect("array")).map(|_| ()).map_err(|e| e.code.as_str())
        };
        assert_eq!(action_from_act("goTo", &[json!("RoomA1")]), Ok(Action::GoTo("RoomA1".into())));
        assert_eq!(action_from_act("pickUp", &[json!(3)]), Ok(Action::PickUp(Some(3))));
        assert_eq!(code("goTo", json!([])), Err("bad_args"));
        assert_eq!(code("goToBlock", json!(["x"])), Err("bad_args"));
        assert_eq!(code("goToBlock", json!([-1])), Err("bad_args"));
        assert_eq!(code("putDown", json!([1])), Err("bad_args"));
        assert_eq!(code("sendMessage", json!(["all"])), Err("bad_args"));
        assert_eq!(code("fly", json!([])), Err("unknown_action"));
        assert_eq!(code("sendMessage", json!(["all", "hi"])), Ok(()));
        for action in [
            Action::GoTo("RoomA1".into()),
            Action::GoToBlock(4),
            Action::PickUp(None),
            Action::PickUp(Some(2)),
            Action::PutDown,
            Action::SendMessage { to: Receiver::All, text: "hi".into() },
            Action::SendMessage { to: Receiver::Player("Bob".into()), text: "yo".into() },
        ] {
            let (name, args) = action_to_act(&action);
            assert_eq!(action_from_act(name, &args), Ok(action));
        }
    }

    #[test]
    fn messages_of_the_language_travel_as_sentence_and_structure() {
        let said = json!({"kind": "contains", "room": "RoomB2", "colour": "Red"});
        let action = action_from_act("sendMessage", &[json!("all"), said.clone()]).expect("a message");
        let Action::SendMessage { text, .. } = action.clone() else { panic!("{action:?}") };
        assert_eq!(text, r#"{"kind":"contains","room":"RoomB2","colour":"Red"}"#);
        assert_eq!(action_to_act(&action).1, vec![json!("all"), said.clone()]);
        // The same message sent as its text form is the same message.
        let as_text = action_from_act(
            "sendMessage",
            &[json!("all"), json!(r#"{"colour":"Red","kind":"contains","room":"RoomB2"}"#)],
        );
        assert_eq!(as_text, Ok(action));

        let percept = Percept::Message { from: Arc::from("Ann"), text: Arc::from(text.as_str()) };
        let fact = percept_to_fact(&percept);
        assert_eq!(fact, vec![json!("message"), json!("Ann"), json!("RoomB2 contains Red."), said]);
        assert_eq!(fact_to_percept(&fact), Ok(percept));

        let error = action_from_act("sendMessage", &[json!("all"), json!({"kind": "will_get"})])
            .expect_err("no colour");
        assert_eq!((error.code, error.message.as_str()), (AckCode::BadArgs, "'will_get' needs a colour"));
        let error = action_from_act("sendMessage", &[json!("all"), json!({"kind": "yes", "mood": 1})])
            .expect_err("extra");
        assert!(error.message.contains("mood"), "{}", error.message);
        assert!(
            fact_to_percept(&[json!("message"), json!("Ann"), json!("Hi."), json!({"kind": "dance"})])
                .is_err()
        );
    }

    #[test]
    fn every_kind_of_message_has_its_wire_form_and_sentence() {
        for row in crate::KINDS {
            let mut said = json!({ "kind": row.word });
            for slot in row.slots {
                said[slot.name()] = match slot {
                    crate::Slot::Room => json!("RoomC3"),
                    crate::Slot::Colour => json!("Blue"),
                    crate::Slot::Player => json!("Bot2"),
                    crate::Slot::Count | crate::Slot::Position => json!(2),
                };
            }
            let action = action_from_act("sendMessage", &[json!("all"), said.clone()]).expect(row.word);
            let Action::SendMessage { text, .. } = action else { panic!("{}", row.word) };
            let percept = Percept::Message { from: Arc::from("Ann"), text: Arc::from(text.as_str()) };
            let fact = percept_to_fact(&percept);
            assert_eq!(fact[3], said, "{}: the structure as sent", row.word);
            assert_eq!(fact_to_percept(&fact), Ok(percept), "{}", row.word);
            let sentence = fact[2].as_str().expect("a sentence");
            assert!(!sentence.contains('{') && sentence.ends_with(['.', '?']), "{}: {sentence}", row.word);
            for slot in row.slots {
                // Positions count from 1 in sentences.
                let shown = match slot {
                    crate::Slot::Position => "3".to_string(),
                    _ => said[slot.name()].to_string().trim_matches('"').to_string(),
                };
                assert!(sentence.contains(&shown), "{}: '{sentence}' lacks {shown}", row.word);
            }
        }
    }
}
