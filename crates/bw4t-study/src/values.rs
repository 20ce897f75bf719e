//! What each kind of questionnaire item takes as an answer: the one check of a value, used
//! on a participant's answers and on the study file's `show_if` values.

use bw4t_protocol::QuestionKind;
use serde_json::{Map, Value};

/// The longest text answer kept, in characters (a text item's `maxlength` is at most this).
pub(crate) const MAX_TEXT: usize = 10_000;

/// `v` as an answer to the item `id` of `kind`: the value kept, `None` for no answer (an
/// empty text, a matrix without a row answered), or why it is refused, naming the item.
pub(crate) fn value_of(id: &str, kind: &QuestionKind, v: &Value) -> Result<Option<Value>, String> {
    let at = format!("item '{id}'");
    match kind {
        QuestionKind::Likert { scale, .. } => point(&at, *scale, v).map(Some),
        QuestionKind::Choice { options } => option(&at, options, v).map(Some),
        QuestionKind::Text { maxlength, .. } => {
            let Some(s) = v.as_str() else { return Err(format!("{at}: expected a text, got {v}")) };
            let limit = maxlength.unwrap_or(MAX_TEXT);
            let length = s.chars().count();
            if length > limit {
                return Err(format!("{at}: at most {limit} characters (this answer has {length})"));
            }
            Ok(Some(s.trim()).filter(|s| !s.is_empty()).map(Value::from))
        }
        QuestionKind::Number { min, max, integer, .. } => {
            let range = number_range(*min, *max, *integer);
            let Some(n) = v.as_f64().filter(|n| n.is_finite()) else {
                return Err(format!("{at}: expected {range}, got {v}"));
            };
            let whole = n.fract() == 0.0;
            if min.is_some_and(|min| n < min) || max.is_some_and(|max| n > max) || (*integer && !whole) {
                return Err(format!("{at}: expected {range}, got {v}"));
            }
            // A whole number is kept as an integer (5, not 5.0); else as it was given.
            Ok(Some(if whole && n.abs() < 9.0e15 { Value::from(n as i64) } else { v.clone() }))
        }
        QuestionKind::Matrix { rows, scale, options, .. } => {
            let Some(given) = v.as_object() else {
                return Err(format!(
                    "{at}: expected an object of row keys (\"1\", \"2\", ...) and answers, got {v}"
                ));
            };
            if let Some(unknown) = given.keys().find(|k| !rows.iter().any(|r| &r.key == *k)) {
                return Err(format!("{at}: no row '{unknown}' (its rows are \"1\" to \"{}\")", rows.len()));
            }
            let mut out = Map::new();
            // Rows in key order: "1", "2", ... as the file lists them, whatever was shown.
            let mut keys: Vec<&String> = given.keys().collect();
            keys.sort_by_key(|k| k.parse::<usize>().unwrap_or(usize::MAX));
            for key in keys {
                let value = &given[key];
                if value.is_null() {
                    continue;
                }
                let at = format!("{at} row {key}");
                let kept = match (scale, options) {
                    (_, Some(options)) => option(&at, options, value)?,
                    (scale, None) => point(&at, scale.unwrap_or(7), value)?,
                };
                out.insert(key.clone(), kept);
            }
            Ok((!out.is_empty()).then_some(Value::Object(out)))
        }
    }
}

/// Whether a given answer is one `show_if` names: numbers compare by value (4 is 4.0).
pub(crate) fn same_answer(given: &Value, wanted: &Value) -> bool {
    match (given.as_f64(), wanted.as_f64()) {
        (Some(a), Some(b)) => a == b,
        _ => given == wanted,
    }
}

/// What a number item takes, in words: "a whole number from 18 to 99".
fn number_range(min: Option<f64>, max: Option<f64>, integer: bool) -> String {
    let what = if integer { "a whole number" } else { "a number" };
    match (min, max) {
        (Some(min), Some(max)) => format!("{what} from {min} to {max}"),
        (Some(min), None) => format!("{what} of at least {min}"),
        (None, Some(max)) => format!("{what} of at most {max}"),
        (None, None) => what.to_string(),
    }
}

fn point(at: &str, scale: u32, v: &Value) -> Result<Value, String> {
    match v.as_u64() {
        Some(n) if (1..=u64::from(scale)).contains(&n) => Ok(Value::from(n)),
        _ => Err(format!("{at}: expected an integer from 1 to {scale}, got {v}")),
    }
}

fn option(at: &str, options: &[String], v: &Value) -> Result<Value, String> {
    match v.as_str() {
        Some(s) if options.iter().any(|o| o == s) => Ok(Value::from(s)),
        _ => Err(format!(
            "{at}: expected one of {}, got {v}",
            options.iter().map(|o| format!("'{o}'")).collect::<Vec<_>>().join(", ")
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn number(min: Option<f64>, max: Option<f64>, integer: bool) -> QuestionKind {
        QuestionKind::Number { min, max, integer, unit: None }
    }

    #[test]
    fn numbers_are_taken_in_range_and_whole_when_asked() {
        let age = number(Some(18.0), Some(99.0), true);
        assert_eq!(value_of("age", &age, &json!(30)), Ok(Some(json!(30))));
        assert_eq!(value_of("age", &age, &json!(30.0)), Ok(Some(json!(30))), "30.0 is whole");
        for bad in [json!(17), json!(100), json!(30.5), json!("30")] {
            let why = value_of("age", &age, &bad).expect_err("refused");
            assert!(why.contains("item 'age'") && why.contains("a whole number from 18 to 99"), "{why}");
        }
        let hours = number(Some(0.0), None, false);
        assert_eq!(value_of("h", &hours, &json!(2.5)), Ok(Some(json!(2.5))));
        assert!(value_of("h", &hours, &json!(-1)).expect_err("below").contains("at least 0"));
    }

    #[test]
    fn texts_keep_to_their_maxlength_in_characters() {
        let short = QuestionKind::Text { multiline: false, maxlength: Some(3) };
        assert_eq!(value_of("t", &short, &json!("éé é")).map(|_| ()).ok(), None, "4 characters");
        assert_eq!(value_of("t", &short, &json!("ééé")), Ok(Some(json!("ééé"))));
        let why = value_of("t", &short, &json!("abcd")).expect_err("too long");
        assert_eq!(why, "item 't': at most 3 characters (this answer has 4)");
    }

    #[test]
    fn show_if_compares_numbers_by_value() {
        assert!(same_answer(&json!(4), &json!(4.0)));
        assert!(same_answer(&json!("yes"), &json!("yes")));
        assert!(!same_answer(&json!("4"), &json!(4)));
    }
}
