//! A questionnaire's items as a participant is shown them (in their own order where the
//! page or a matrix shuffles), and the check of their answers: every shown required item
//! answered (every row of a matrix), each value of its item's kind, a hidden item's answer
//! ignored; and how many were answered correctly, for a pass mark.

use std::collections::BTreeMap;

use bw4t_protocol::{QuestionItem, QuestionKind};
use serde::{Deserialize, Serialize};
use serde_json::{Map, Value};

use super::config::Item;
use super::shuffle::shuffle;
use super::values::{same_answer, value_of};

/// The order a participant was shown a shuffled questionnaire in (kept in their answer's
/// record): every item's id, and each shuffled matrix's row keys.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub(crate) struct Shown {
    /// The items' ids, in the order shown.
    pub(crate) items: Vec<String>,
    /// A matrix's id (those with `shuffle_rows`) and its row keys, in the order shown.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub(crate) rows: BTreeMap<String, Vec<String>>,
}

/// The order the participant `participant` is shown the questionnaire `page` in, drawn
/// from the study's `seed` and their id (`None` when nothing on it shuffles: the file's
/// order). A shuffled page moves an item with `show_if` along with the item it depends on.
pub(crate) fn shown(
    seed: u64,
    participant: &str,
    page: &str,
    items: &[Item],
    shuffled: bool,
) -> Option<Shown> {
    if !shuffled && !items.iter().any(|i| i.shuffle_rows) {
        return None;
    }
    let mut blocks: Vec<Vec<&Item>> = Vec::new();
    for item in items {
        let leader = item
            .show_if
            .as_ref()
            .and_then(|rule| blocks.iter().position(|b| b.iter().any(|earlier| earlier.id == rule.item)));
        match leader {
            Some(at) => blocks[at].push(item),
            None => blocks.push(vec![item]),
        }
    }
    // Each page's order (and each matrix's) is drawn on its own: words apart by a 0 byte.
    let (participant, page, apart) = (participant.as_bytes(), page.as_bytes(), b"\0".as_slice());
    if shuffled {
        shuffle(&mut blocks, seed, &[participant, apart, page]);
    }
    let mut rows = BTreeMap::new();
    for item in items.iter().filter(|i| i.shuffle_rows) {
        if let QuestionKind::Matrix { rows: statements, .. } = &item.kind {
            let mut keys: Vec<String> = statements.iter().map(|r| r.key.clone()).collect();
            shuffle(&mut keys, seed, &[participant, apart, page, apart, item.id.as_bytes()]);
            rows.insert(item.id.clone(), keys);
        }
    }
    let items = blocks.into_iter().flatten().map(|i| i.id.clone()).collect();
    Some(Shown { items, rows })
}

/// The items as the API shows them, in the order `shown` gives (the file's if `None`).
pub(crate) fn items_shown(items: &[Item], shown: Option<&Shown>) -> Vec<QuestionItem> {
    let Some(shown) = shown else { return items.iter().map(|i| item_reply(i, None)).collect() };
    shown
        .items
        .iter()
        .filter_map(|id| items.iter().find(|i| &i.id == id))
        .map(|i| item_reply(i, shown.rows.get(&i.id)))
        .collect()
}

/// An item as the API shows it; a matrix's rows in the order of `row_keys` if given.
fn item_reply(item: &Item, row_keys: Option<&Vec<String>>) -> QuestionItem {
    let mut kind = item.kind.clone();
    if let (QuestionKind::Matrix { rows, .. }, Some(keys)) = (&mut kind, row_keys) {
        rows.sort_by_key(|r| keys.iter().position(|k| *k == r.key));
    }
    QuestionItem {
        id: item.id.clone(),
        text: item.text.clone(),
        required: item.required,
        show_if: item.show_if.clone(),
        kind,
    }
}

/// How many of `items` with a correct answer the checked `answers` give it.
pub(crate) fn correct(items: &[Item], answers: &Value) -> usize {
    let given = |id: &str| answers.get(id).and_then(Value::as_str);
    items.iter().filter(|i| i.correct.is_some() && given(&i.id) == i.correct.as_deref()).count()
}

/// The answers, checked against `items` (in the file's order): unknown ids, missing
/// required items (a matrix's rows: every one) and bad values are refused with a message
/// naming the item. An item whose `show_if` does not hold is hidden: not required, and an
/// answer given to it is ignored (left out). Unanswered optional items (absent or `null`)
/// are left out; texts are trimmed, and an empty text counts as no answer.
pub(crate) fn check(items: &[Item], answers: &Value) -> Result<Value, String> {
    let Some(given) = answers.as_object() else {
        return Err("answers: expected an object of item ids and values".into());
    };
    if let Some(unknown) = given.keys().find(|k| !items.iter().any(|i| &i.id == *k)) {
        return Err(format!("answers: no item '{unknown}' on this page"));
    }
    let mut out = Map::new();
    for item in items {
        if let Some(rule) = &item.show_if {
            let shown = out.get(&rule.item).is_some_and(|v| rule.any_of.iter().any(|w| same_answer(v, w)));
            if !shown {
                continue;
            }
        }
        let value = match given.get(&item.id).filter(|v| !v.is_null()) {
            Some(v) => value_of(&item.id, &item.kind, v)?,
            None => None,
        };
        if let (QuestionKind::Matrix { rows, .. }, true) = (&item.kind, item.required) {
            let answered = |key: &str| value.as_ref().is_some_and(|v| v.get(key).is_some());
            if let Some(row) = rows.iter().find(|r| !answered(&r.key)) {
                return Err(format!(
                    "item '{}': every row needs an answer; row {} ('{}') has none",
                    item.id, row.key, row.text
                ));
            }
        }
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
