//! Between simulation types and wire shapes: percepts as JSON facts, `act` as an action.
//! Percepts convert generically, from the simulation's description of each
//! ([`bw4t_sim::PERCEPTS`]); actions one by one.

use std::sync::Arc;

use bw4t_map::Colour;
use bw4t_sim::{Action, ArgKind, ArgReader, ArgRef, MoveState, Percept, Receiver};
use serde::Deserialize;
use serde_json::{Value, json};

use crate::language::Said;
use crate::messages::{Act, ActId, ClientMessage, Fact};
use crate::vocabulary::AckCode;

/// A percept as a fact array, e.g. `["color",12,"Red"]`: its name, then each argument in
/// the form its Rust type has (a name or text as a string, an id or index as a number, a
/// colour or state by name, colours as a list of names). A text that is a message of the
/// language is followed by its structure: `["message", sender, sentence, said]`; free text
/// is `["message", sender, text]`. Driven by the simulation's description of each percept,
/// so no percept needs code of its own here.
pub fn percept_to_fact(p: &Percept) -> Fact {
    // Room for a message's structure besides the name and arguments.
    let mut fact = Vec::with_capacity(2 + p.kind().args.len());
    fact.push(Value::from(p.name()));
    p.for_each_arg(|kind, arg| match arg {
        ArgRef::Text(text) if kind == ArgKind::Text => match Said::from_text(text) {
            Some(said) => {
                fact.push(json!(said.sentence().unwrap_or_default()));
                fact.push(json!(said));
            }
            None => fact.push(Value::from(text)),
        },
        ArgRef::Text(text) => fact.push(Value::from(text)),
        ArgRef::Number(n) => fact.push(Value::from(n)),
        ArgRef::Colour(colour) => fact.push(Value::from(colour.name())),
        ArgRef::Colours(colours) => fact.push(colours.iter().map(|c| c.name()).collect()),
        ArgRef::State(state) => fact.push(Value::from(state.name())),
    });
    fact
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

/// Reads a fact array back into a percept (the inverse of [`percept_to_fact`]).
pub fn fact_to_percept(fact: &[Value]) -> Result<Percept, FactError> {
    let bad = || FactError(Value::from(fact.to_vec()).to_string());
    let name = fact.first().and_then(Value::as_str).ok_or_else(bad)?;
    let mut args = FactArgs { fact, next: 1 };
    match Percept::from_args(name, &mut args) {
        Some(percept) if args.next == fact.len() => Ok(percept),
        _ => Err(bad()),
    }
}

/// A fact's arguments, read in order.
struct FactArgs<'a> {
    fact: &'a [Value],
    /// The position of the next argument.
    next: usize,
}

impl<'a> FactArgs<'a> {
    fn take(&mut self) -> Option<&'a Value> {
        let value = self.fact.get(self.next)?;
        self.next += 1;
        Some(value)
    }
}

/// A colour by name.
fn colour(value: &Value) -> Option<Colour> {
    value.as_str()?.parse().ok()
}

impl ArgReader for FactArgs<'_> {
    fn text(&mut self, kind: ArgKind) -> Option<Arc<str>> {
        let value = self.take()?;
        // A message of the language: the structure after the sentence is what counts.
        if kind == ArgKind::Text
            && let Some(said @ Value::Object(_)) = self.fact.get(self.next)
        {
            self.next += 1;
            let said = Said::deserialize(said).ok()?;
            said.check().ok()?;
            return Some(said.to_text().into());
        }
        value.as_str().map(Arc::from)
    }

    fn number(&mut self, _: ArgKind) -> Option<u32> {
        self.take()?.as_u64().and_then(|n| u32::try_from(n).ok())
    }

    fn colour(&mut self, _: ArgKind) -> Option<Colour> {
        colour(self.take()?)
    }

    fn colours(&mut self, _: ArgKind) -> Option<Arc<[Colour]>> {
        self.take()?.as_array()?.iter().map(colour).collect()
    }

    fn state(&mut self, _: ArgKind) -> Option<MoveState> {
        MoveState::from_name(self.take()?.as_str()?)
    }
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
    use bw4t_sim::PERCEPTS;

    use super::*;

    /// Gives made-up arguments of the form asked for.
    struct Samples;

    impl ArgReader for Samples {
        fn text(&mut self, kind: ArgKind) -> Option<Arc<str>> {
            Some(if kind == ArgKind::Text { "hi there".into() } else { "RoomA1".into() })
        }
        fn number(&mut self, _: ArgKind) -> Option<u32> {
            Some(12)
        }
        fn colour(&mut self, _: ArgKind) -> Option<Colour> {
            Some(Colour::Red)
        }
        fn colours(&mut self, _: ArgKind) -> Option<Arc<[Colour]>> {
            Some(vec![Colour::Red, Colour::Blue].into())
        }
        fn state(&mut self, _: ArgKind) -> Option<MoveState> {
            Some(MoveState::Collided)
        }
    }

    #[test]
    fn every_percept_round_trips_through_its_fact() {
        for kind in PERCEPTS {
            let percept = Percept::from_args(kind.name, &mut Samples).expect("a percept of every row");
            let fact = percept_to_fact(&percept);
            assert_eq!(fact[0], kind.name);
            assert_eq!(fact.len(), 1 + kind.args.len(), "{}: one value per argument", kind.name);
            assert_eq!(fact_to_percept(&fact), Ok(percept), "{}", kind.name);
            // One value too few or too many is not a percept.
            assert!(fact_to_percept(&fact[..fact.len() - 1]).is_err(), "{} cut short", kind.name);
            let mut longer = fact.clone();
            longer.push(json!(1));
            assert!(fact_to_percept(&longer).is_err(), "{} with an extra value", kind.name);
        }
        let name = |s: &str| Arc::<str>::from(s);
        for (percept, fact) in [
            (Percept::Color(12, Colour::Red), json!(["color", 12, "Red"])),
            (Percept::Sequence(vec![Colour::Red, Colour::Blue].into()), json!(["sequence", ["Red", "Blue"]])),
            (Percept::State(MoveState::Collided), json!(["state", "collided"])),
            (Percept::At(name("FrontA1")), json!(["at", "FrontA1"])),
            (
                Percept::Message { from: name("Bob"), text: name("hi there") },
                json!(["message", "Bob", "hi there"]),
            ),
        ] {
            assert_eq!(Value::from(percept_to_fact(&percept)), fact);
        }
        for wrong in [
            json!(["color", 1]),
            json!(["fly"]),
            json!([]),
            json!([3, 1]),
            json!(["bot", -1]),
            json!(["bot", 4294967296u64]),
            json!(["bot", "3"]),
            json!(["color", 1, "Purple"]),
            json!(["sequence", "Red"]),
            json!(["state", "Arrived"]),
            json!(["at", 3]),
            json!(["message", "Ann", {"kind": "yes"}]),
            json!(["message", "Ann", "Yes.", "yes"]),
        ] {
            assert!(fact_to_percept(wrong.as_array().expect("a list")).is_err(), "{wrong}");
        }
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
