//! Questionnaires over the study's HTTP API: number items in range, matrix items answered
//! row by row (and exported one row each), items shown only under their `show_if`, texts
//! kept to their `maxlength`, items and matrix rows shuffled per participant, and study
//! files with bad questionnaire keys refused naming the page, the item and the key.

use bw4t_protocol::{ErrorReply, ParticipantState, QuestionItem, QuestionKind, StudyPage};
use serde_json::{Value, json};

use crate::study::{StudyRig, arrive, csv_rows, parse, read, stored, temp_dir};

/// A questionnaire of every new kind on a shuffled page, then a trial.
const QUESTIONS: &str = r##"
[study]
name = "questions"
seed = 9
mode = "lockstep"
time_limit_s = 1

[[condition]]
name = "alpha"
teammates = 1
min_active_ticks = 0

[[page]]
kind = "questionnaire"
id = "about"
shuffle = true

[[page.item]]
kind = "number"
id = "age"
text = "Your age?"
min = 18
max = 99
integer = true
unit = "years"

[[page.item]]
kind = "choice"
id = "gamer"
text = "Do you play video games?"
options = ["yes", "no"]

[[page.item]]
kind = "matrix"
id = "tlx"
text = "How was it?"
rows = ["Mental demand", "Physical demand", "Frustration"]
scale = 5
labels = ["low", "high"]
shuffle_rows = true

[[page.item]]
kind = "number"
id = "hours"
text = "Hours a week?"
min = 0
max = 80
show_if = { item = "gamer", equals = "yes" }

[[page.item]]
kind = "text"
id = "note"
text = "Anything else?"
maxlength = 20
required = false

[[page]]
kind = "trial"

[[page]]
kind = "final"
"##;

/// The questionnaire's items as the state shows them.
fn items_of(state: &ParticipantState) -> Vec<QuestionItem> {
    match &state.page {
        Some(StudyPage::Questionnaire { items, .. }) => items.clone(),
        other => panic!("not a questionnaire: {other:?}"),
    }
}

fn ids(items: &[QuestionItem]) -> Vec<String> {
    items.iter().map(|i| i.id.clone()).collect()
}

/// A matrix item's row keys, in the order shown.
fn row_keys(items: &[QuestionItem], id: &str) -> Vec<String> {
    match items.iter().find(|i| i.id == id).map(|i| &i.kind) {
        Some(QuestionKind::Matrix { rows, .. }) => rows.iter().map(|r| r.key.clone()).collect(),
        other => panic!("not a matrix: {other:?}"),
    }
}

#[test]
fn questionnaire_keys_are_read_and_bad_ones_are_refused_naming_page_item_and_key() {
    let study = parse(QUESTIONS).expect("the good file loads");
    let Some(bw4t_study::Page::Questionnaire { items, shuffle, .. }) = study.pages.first() else {
        panic!("a questionnaire first")
    };
    assert!(*shuffle);
    let kinds: Vec<&QuestionKind> = items.iter().map(|i| &i.kind).collect();
    assert_eq!(
        kinds[0],
        &QuestionKind::Number { min: Some(18.0), max: Some(99.0), integer: true, unit: Some("years".into()) }
    );
    let QuestionKind::Matrix { rows, scale, labels, options } = kinds[2] else { panic!("a matrix") };
    let rows: Vec<(&str, &str)> = rows.iter().map(|r| (r.key.as_str(), r.text.as_str())).collect();
    assert_eq!(rows, [("1", "Mental demand"), ("2", "Physical demand"), ("3", "Frustration")]);
    assert_eq!((scale, labels.as_ref().map(|l| l[1].as_str()), options), (&Some(5), Some("high"), &None));
    assert!(items[2].shuffle_rows);
    let rule = items[3].show_if.as_ref().expect("hours has a show_if");
    assert_eq!((rule.item.as_str(), &rule.any_of), ("gamer", &vec![json!("yes")]));
    assert_eq!(kinds[4], &QuestionKind::Text { multiline: false, maxlength: Some(20) });

    let cases: [(&str, &str, &str, &[&str]); 12] = [
        (
            "min above max",
            "max = 99",
            "max = 9",
            &["page 1: (questionnaire 'about')", "item 'age'", "min = 18 is above max = 9"],
        ),
        ("a fraction on an integer item", "min = 18", "min = 17.5", &["item 'age'", "min = 17.5", "whole"]),
        ("an empty unit", "unit = \"years\"", "unit = \" \"", &["item 'age'", "unit"]),
        (
            "a matrix without rows",
            "rows = [\"Mental demand\", \"Physical demand\", \"Frustration\"]",
            "rows = []",
            &["item 'tlx'", "rows"],
        ),
        (
            "a row twice",
            "\"Physical demand\", \"Frustration\"]",
            "\"Frustration\", \"Frustration\"]",
            &["item 'tlx'", "rows", "row 3 'Frustration' is there twice"],
        ),
        (
            "options and a scale",
            "scale = 5\n",
            "scale = 5\noptions = [\"a\", \"b\"]\n",
            &["item 'tlx'", "options or a scale"],
        ),
        (
            "shuffle_rows off a matrix",
            "unit = \"years\"",
            "unit = \"years\"\nshuffle_rows = true",
            &["shuffle_rows"],
        ),
        (
            "show_if naming a later item",
            "equals = \"yes\" }",
            "equals = \"yes\" }\n[[page.item]]\nkind = \"text\"\nid = \"why\"\ntext = \"Why?\"\nshow_if = { item = \"late\", equals = \"x\" }\n[[page.item]]\nkind = \"text\"\nid = \"late\"\ntext = \"?\"",
            &["item 'why'", "show_if", "item = 'late'", "not an earlier item"],
        ),
        (
            "show_if with an answer never given",
            "equals = \"yes\" }",
            "equals = \"often\" }",
            &["item 'hours'", "show_if", "equals = \"often\"", "'yes', 'no'"],
        ),
        (
            "show_if with equals and in",
            "equals = \"yes\" }",
            "equals = \"yes\", in = [\"no\"] }",
            &["item 'hours'", "show_if", "not both"],
        ),
        ("show_if on a matrix", "item = \"gamer\"", "item = \"tlx\"", &["item 'hours'", "show_if", "matrix"]),
        (
            "a maxlength past the server's",
            "maxlength = 20",
            "maxlength = 20000",
            &["item 'note'", "maxlength = 20000", "10000"],
        ),
    ];
    for (what, from, to, needles) in cases {
        assert!(QUESTIONS.contains(from), "{what}: the test's file has '{from}'");
        let error =
            parse(&QUESTIONS.replacen(from, to, 1)).err().unwrap_or_else(|| panic!("{what}: accepted"));
        for needle in needles {
            assert!(error.contains(needle), "{what}: '{error}' should name '{needle}'");
        }
    }
    // in = [...] takes several answers; a number item's answers are numbers in its range.
    let several = QUESTIONS.replacen("equals = \"yes\" }", "in = [\"yes\", \"no\"] }", 1);
    parse(&several).expect("in = [...] is taken");
    let on_age = QUESTIONS.replacen("item = \"gamer\", equals = \"yes\"", "item = \"age\", equals = 120", 1);
    let error = parse(&on_age).expect_err("120 is out of the age's range");
    assert!(error.contains("equals = 120") && error.contains("from 18 to 99"), "{error}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_server_checks_numbers_matrices_show_if_and_maxlength_and_exports_a_row_per_matrix_row() {
    let dir = temp_dir("questionnaires");
    let rig = StudyRig::start(&dir, QUESTIONS).await;
    let (status, state) = arrive(&rig, "ann").await;
    assert_eq!(status, 201, "{state}");
    let shown = items_of(&read(&state));

    // Ann's order: a shuffle of the items, hours right after the item it depends on, the
    // same on every look; others get orders of their own.
    let mut sorted = ids(&shown);
    sorted.sort();
    assert_eq!(sorted, ["age", "gamer", "hours", "note", "tlx"]);
    let at = |id: &str| ids(&shown).iter().position(|i| i == id).expect("shown");
    assert_eq!(at("hours"), at("gamer") + 1, "{:?}", ids(&shown));
    let (_, again) = rig.call("GET", "/api/study/participants/ann", None).await;
    assert_eq!(items_of(&read(&again)), shown, "the same order on every look");
    let mut orders = std::collections::BTreeSet::new();
    for other in ["bo", "cy", "di", "ed", "flo", "gus"] {
        let (_, state) = arrive(&rig, other).await;
        let items = items_of(&read(&state));
        orders.insert((ids(&items), row_keys(&items, "tlx")));
    }
    assert!(orders.len() > 1, "participants get orders of their own: {orders:?}");
    let hours = shown.iter().find(|i| i.id == "hours").expect("hours");
    assert_eq!(serde_json::to_value(&hours.show_if).expect("json"), json!({"item": "gamer", "in": ["yes"]}));

    let full =
        json!({"age": 30, "gamer": "yes", "hours": 6, "tlx": {"1": 4, "2": 2, "3": 5}, "note": "fine"});
    let with = |key: &str, value: Value| {
        let mut answers = full.clone();
        match value {
            Value::Null => {
                answers.as_object_mut().expect("object").remove(key);
            }
            value => answers[key] = value,
        }
        answers
    };
    for (answers, needles) in [
        (with("age", json!(17)), ["item 'age'", "a whole number from 18 to 99, got 17"]),
        (with("age", json!(30.5)), ["item 'age'", "a whole number from 18 to 99, got 30.5"]),
        (with("age", json!("30")), ["item 'age'", "a whole number"]),
        (with("tlx", json!({"1": 4, "3": 5})), ["item 'tlx'", "row 2 ('Physical demand') has none"]),
        (with("tlx", json!({"1": 4, "2": 2, "3": 6})), ["item 'tlx' row 3", "from 1 to 5"]),
        (with("tlx", json!({"1": 4, "2": 2, "3": 5, "9": 1})), ["item 'tlx'", "no row '9'"]),
        (with("tlx", json!(4)), ["item 'tlx'", "an object of row keys"]),
        (with("hours", Value::Null), ["item 'hours'", "required"]),
        (with("hours", json!(81)), ["item 'hours'", "a number from 0 to 80"]),
        (with("note", json!("x".repeat(21))), ["item 'note'", "at most 20 characters (this answer has 21)"]),
    ] {
        let body = json!({"step": 0, "answers": answers});
        let (status, bad) = rig.call("POST", "/api/study/participants/ann/answer", Some(body)).await;
        let error = read::<ErrorReply>(&bad).error;
        assert_eq!(status, 400, "{answers}: {bad}");
        for needle in needles {
            assert!(error.contains(needle), "{answers}: '{error}' should say '{needle}'");
        }
    }
    // Not a gamer: hours is hidden, so not required, and an answer to it is ignored.
    let answers =
        json!({"age": 30, "gamer": "no", "hours": 500, "tlx": {"1": 4, "2": 2, "3": 5}, "note": " fine "});
    let state = rig.answer("ann", 0, answers).await;
    assert_eq!(state.step, 1);
    // A gamer's hours count; a fraction is a number.
    let state = rig.answer("bo", 0, with("hours", json!(6.5))).await;
    assert_eq!(state.step, 1);

    // Ann's record keeps what she answered and the order she was shown.
    let records = stored(&dir, "ann");
    let (_, _, answer) = records.iter().find(|(_, kind, _)| kind == "answer").expect("the answer record");
    assert_eq!(
        answer["answers"],
        json!({"age": 30, "gamer": "no", "tlx": {"1": 4, "2": 2, "3": 5}, "note": "fine"})
    );
    assert_eq!(answer["shown"]["items"], json!(ids(&shown)));
    assert_eq!(answer["shown"]["rows"]["tlx"], json!(row_keys(&shown, "tlx")));
    rig.shutdown().await;

    // One row per matrix row, `tlx.KEY`; each at the place it was shown.
    let out = dir.join("export");
    bw4t_study::export(&dir, &out).expect("export");
    let rows = csv_rows(&out.join("answers.csv"));
    let ann: Vec<(&str, &str, &str)> = rows
        .iter()
        .filter(|r| r["participant"] == "ann")
        .map(|r| (r["item"].as_str(), r["value"].as_str(), r["position"].as_str()))
        .collect();
    let place = |id: &str| (at(id) + 1).to_string();
    let row_place = |key: &str| {
        let keys = row_keys(&shown, "tlx");
        (keys.iter().position(|k| k == key).expect("a row") + 1).to_string()
    };
    assert_eq!(
        ann,
        [
            ("age", "30", place("age").as_str()),
            ("gamer", "no", place("gamer").as_str()),
            ("note", "fine", place("note").as_str()),
            ("tlx.1", "4", row_place("1").as_str()),
            ("tlx.2", "2", row_place("2").as_str()),
            ("tlx.3", "5", row_place("3").as_str()),
        ]
    );
    let bo_hours: Vec<&str> = rows
        .iter()
        .filter(|r| r["participant"] == "bo" && r["item"] == "hours")
        .map(|r| r["value"].as_str())
        .collect();
    assert_eq!(bo_hours, ["6.5"]);
    let _ = std::fs::remove_dir_all(&dir);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_unshuffled_questionnaire_is_shown_and_exported_in_the_files_order_without_positions() {
    let text = QUESTIONS.replace("shuffle = true\n", "").replace("shuffle_rows = true\n", "");
    let dir = temp_dir("questionnaires-fixed");
    let rig = StudyRig::start(&dir, &text).await;
    let (_, state) = arrive(&rig, "ann").await;
    let shown = items_of(&read(&state));
    assert_eq!(ids(&shown), ["age", "gamer", "tlx", "hours", "note"]);
    assert_eq!(row_keys(&shown, "tlx"), ["1", "2", "3"]);
    // An optional matrix may be left out; a required one with no row answered may not.
    let answers = json!({"age": 40, "gamer": "no", "tlx": {}});
    let body = json!({"step": 0, "answers": answers});
    let (status, bad) = rig.call("POST", "/api/study/participants/ann/answer", Some(body)).await;
    assert!(status == 400 && read::<ErrorReply>(&bad).error.contains("item 'tlx'"), "{bad}");
    rig.answer("ann", 0, json!({"age": 40, "gamer": "no", "tlx": {"1": 1, "2": 1, "3": 1}})).await;
    let records = stored(&dir, "ann");
    let (_, _, answer) = records.iter().find(|(_, kind, _)| kind == "answer").expect("the answer record");
    assert!(answer.get("shown").is_none(), "nothing shuffled, nothing kept: {answer}");
    rig.shutdown().await;
    let out = dir.join("export");
    bw4t_study::export(&dir, &out).expect("export");
    let rows = csv_rows(&out.join("answers.csv"));
    assert!(rows.iter().all(|r| r["position"].is_empty()), "{rows:?}");
    assert_eq!(rows.iter().filter(|r| r["item"].starts_with("tlx.")).count(), 3);
    let _ = std::fs::remove_dir_all(&dir);
}
