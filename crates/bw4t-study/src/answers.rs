//! A questionnaire's items as the page shows them, and the check of a participant's
//! answers to them: every required item answered, each value of its item's kind; and how
//! many were answered correctly, for a pass mark.

use bw4t_protocol::{QuestionItem, QuestionKind};
use serde_json::{Map, Value};

use super::config::Item;

/// An item as the API shows it.
pub(crate) fn item_reply(item: &Item) -> QuestionItem {
    QuestionItem {
        id: item.id.clone(),
        text: item.text.clone(),
        required: item.required,
        kind: item.kind.clone(),
    }
}

/// How many of `items` with a correct answer the checked `answers` give it.
pub(crate) fn correct(items: &[Item], answers: &Value) -> usize {
    let given = |id: &str| answers.get(id).and_then(Value::as_str);
    items.iter().filter(|i| i.correct.is_some() && given(&i.id) == i.correct.as_deref()).count()
}

/// The longest text answer kept, in characters.
const MAX_TEXT: usize = 10_000;

/// The answers, checked against `items`: unknown ids, missing required items and bad
/// values are refused with a message naming the item. Unanswered optional items (absent
/// or `null`) are left out; texts are trimmed, and an empty text counts as no answer.
pub(crate) fn check(items: &[Item], answers: &Value) -> Result<Value, String> {
    let Some(given) = answers.as_object() else {
        return Err("answers: expected an object of item ids and values".into());
    };
    if let Some(unknown) = given.keys().find(|k| !items.iter().any(|i| &i.id == *k)) {
        return Err(format!("answers: no item '{unknown}' on this page"));
    }
    let mut out = Map::new();
    for item in items {
        let value = given.get(&item.id).filter(|v| !v.is_null());
        let value = match (value, &item.kind) {
            (None, _) => None,
            (Some(v), QuestionKind::Likert { scale, .. }) => match v.as_u64() {
                Some(n) if (1..=u64::from(*scale)).contains(&n) => Some(Value::from(n)),
                _ => {
                    return Err(format!(
                        "item '{}': expected an integer from 1 to {scale}, got {v}",
                        item.id
                    ));
                }
            },
            (Some(v), QuestionKind::Choice { options }) => match v.as_str() {
                Some(s) if options.iter().any(|o| o == s) => Some(Value::from(s)),
                _ => {
                    return Err(format!(
                        "item '{}': expected one of {}, got {v}",
                        item.id,
                        options.iter().map(|o| format!("'{o}'")).collect::<Vec<_>>().join(", ")
                    ));
                }
            },
            (Some(v), QuestionKind::Text { .. }) => match v.as_str() {
                Some(s) if s.chars().count() > MAX_TEXT => {
                    return Err(format!("item '{}': at most {MAX_TEXT} characters", item.id));
                }
                Some(s) => Some(s.trim()).filter(|s| !s.is_empty()).map(Value::from),
                None => return Err(format!("item '{}': expected a text, got {v}", item.id)),
            },
        };
        match value {
            Some(value) => {
                out.insert(item.id.clone(), value);
            }
            None if item.required => return Err(format!("item '{}': an answer is required", item.id)),
            None => {}
        }
    }
    Ok(Value::Object(out))
}
