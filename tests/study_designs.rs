//! Study designs over real sockets: between- and mixed-subjects assignment balanced over
//! completers (a decliner's or a screened-out participant's slot goes to the next
//! arrival), quotas, practice rounds and comprehension checks with pass marks ending in
//! the screen-out page, seeds fixed by the participant's slot and the trial's position
//! whatever ran before, and assignments kept across a restart.

use std::path::Path;

use bw4t_protocol::{ErrorReply, ParticipantList, ParticipantState, StudyPage};
use bw4t_study::StudyBudget;
use serde_json::{Value, json};

use crate::study::{StudyRig, arrive, kind_of, parse, read, stored, temp_dir};
use crate::util::{AutoPlayer, WAIT};

/// Two conditions, each participant in one of them for both trial pages.
const BETWEEN: &str = r##"
[study]
name = "between"
seed = 5
mode = "lockstep"
time_limit_s = 1
assignment = "between"

[[condition]]
name = "alpha"
teammates = 1
min_active_ticks = 0

[[condition]]
name = "beta"
teammates = 1
min_active_ticks = 0

[[page]]
kind = "consent"
text = "Agree?"

[[page]]
kind = "trial"

[[page]]
kind = "trial"

[[page]]
kind = "final"
"##;

/// Arrives as `id` and answers consent with `consent`; the state after.
async fn consented(rig: &StudyRig, id: &str, consent: bool) -> ParticipantState {
    let (status, state) = arrive(rig, id).await;
    assert_eq!(status, 201, "{state}");
    let path = format!("/api/study/participants/{id}/answer");
    let (status, state) =
        rig.call("POST", &path, Some(json!({"step": 0, "answers": {"consent": consent}}))).await;
    assert_eq!(status, 200, "{state}");
    read(&state)
}

/// The condition of the trial or practice the state shows.
fn condition_of(state: &ParticipantState) -> String {
    match &state.page {
        Some(StudyPage::Trial { condition, .. } | StudyPage::Practice { condition, .. }) => condition.clone(),
        other => panic!("not a trial: {other:?}"),
    }
}

/// Plays the trial or practice the state shows to its end with a player that only says
/// `ready`, and answers it: the answer's status and body.
async fn play(rig: &StudyRig, id: &str, state: &ParticipantState) -> (u16, Value) {
    let hello = match &state.page {
        Some(StudyPage::Trial { hello, .. } | StudyPage::Practice { hello, .. }) => hello,
        other => panic!("not a trial: {other:?}"),
    };
    let ended: u64 = rig.arena.totals().values().map(|t| t.ended).sum();
    let mut player = AutoPlayer::join_with(rig.addr, serde_json::to_value(hello).expect("json")).await;
    let (name, match_id) = (player.welcome.match_info.name.clone(), player.welcome.match_info.id.clone());
    let started = json!({"step": state.step, "match": name, "match_id": match_id});
    let (status, answer) =
        rig.call("POST", &format!("/api/study/participants/{id}/trial"), Some(started)).await;
    assert_eq!(status, 200, "{answer}");
    player.wait("the match's end", |s| s.ended.then_some(())).await;
    tokio::time::timeout(WAIT, rig.arena.ended(ended + 1)).await.expect("the match is recorded in time");
    let answer = json!({"step": state.step, "answers": {"match_id": match_id}});
    rig.call("POST", &format!("/api/study/participants/{id}/answer"), Some(answer)).await
}

/// A CSV file's rows as maps of column to cell, quoted cells (with commas, `""`) read.
fn csv_rows(path: &Path) -> Vec<std::collections::BTreeMap<String, String>> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let split = |line: &str| {
        let (mut cells, mut cell, mut quoted, mut chars) =
            (Vec::new(), String::new(), false, line.chars().peekable());
        while let Some(c) = chars.next() {
            match (c, quoted) {
                ('"', true) if chars.peek() == Some(&'"') => {
                    chars.next();
                    cell.push('"');
                }
                ('"', _) => quoted = !quoted,
                (',', false) => cells.push(std::mem::take(&mut cell)),
                _ => cell.push(c),
            }
        }
        cells.push(cell);
        cells
    };
    let mut lines = text.lines();
    let header = split(lines.next().expect("a header"));
    lines.map(|l| header.iter().cloned().zip(split(l)).collect()).collect()
}

/// The seeds of `id`'s ended trials (and practices), in order.
fn seeds(dir: &Path, id: &str) -> Vec<u64> {
    stored(dir, id)
        .iter()
        .filter(|(_, kind, _)| kind == "trial_ended")
        .map(|(_, _, data)| data["result"]["seed"].as_u64().expect("a seed"))
        .collect()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn between_subjects_gives_each_one_condition_balanced_over_completers_across_a_restart() {
    let dir = temp_dir("between");
    let rig = StudyRig::start(&dir, BETWEEN).await;
    // Ann (slot 0) plays alpha on both trial pages.
    let state = consented(&rig, "ann", true).await;
    assert_eq!(condition_of(&state), "alpha");
    let (status, state) = play(&rig, "ann", &state).await;
    assert_eq!(status, 200, "{state}");
    let state: ParticipantState = read(&state);
    assert_eq!((state.step, condition_of(&state)), (2, "alpha".into()), "the same condition again");
    let (_, state) = play(&rig, "ann", &state).await;
    assert_eq!(kind_of(&read(&state)), "final", "{state}");
    // Bob takes slot 1 (beta) and declines: Cy, next, takes it; Dan the next slot (alpha).
    consented(&rig, "bob", false).await;
    assert_eq!(condition_of(&consented(&rig, "cy", true).await), "beta", "the decliner's slot");
    assert_eq!(condition_of(&consented(&rig, "dan", true).await), "alpha");
    let browser = rig.browser.clone();
    rig.shutdown().await;

    // Restarted: the slots held are read back from the records.
    let rig = StudyRig::start_as(&dir, BETWEEN, browser, StudyBudget::default()).await;
    let (status, cy) = rig.call("GET", "/api/study/participants/cy", None).await;
    assert_eq!((status, condition_of(&read(&cy))), (200, "beta".into()), "{cy}");
    assert_eq!(condition_of(&consented(&rig, "eve", true).await), "beta", "slot 3, not bob's again");
    rig.shutdown().await;

    let records = stored(&dir, "cy");
    assert_eq!(records[0].2["order"], json!(["beta"]), "{records:?}");
    assert_eq!((records[1].1.as_str(), &records[1].2), ("assigned", &json!({"slot": 1, "group": "beta"})));
    let out = dir.join("export");
    bw4t_study::export(&dir, &out).expect("export");
    let people: Vec<(String, String, String, String)> = csv_rows(&out.join("participants.csv"))
        .into_iter()
        .map(|r| (r["participant"].clone(), r["slot"].clone(), r["group"].clone(), r["completed"].clone()))
        .collect();
    let row =
        |id: &str, slot: &str, group: &str, done: &str| (id.into(), slot.into(), group.into(), done.into());
    assert_eq!(
        people,
        [
            row("ann", "0", "alpha", "true"),
            row("bob", "1", "beta", "false"),
            row("cy", "1", "beta", "false"),
            row("dan", "2", "alpha", "false"),
            row("eve", "3", "beta", "false"),
        ]
    );
    let trials = csv_rows(&out.join("trials.csv"));
    assert!(trials.iter().all(|t| t["condition"] == "alpha" && t["practice"] == "false"), "{trials:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_mixed_design_picks_a_group_then_counterbalances_within_it() {
    let text = r##"
[study]
name = "mixed"
mode = "lockstep"
time_limit_s = 1
assignment = "mixed"

[[condition]]
name = "a1"
between = "robots"
[[condition]]
name = "b1"
between = "people"
[[condition]]
name = "a2"
between = "robots"
[[condition]]
name = "b2"
between = "people"

[[page]]
kind = "trial"
[[page]]
kind = "trial"
[[page]]
kind = "final"
"##;
    let dir = temp_dir("mixed");
    let rig = StudyRig::start(&dir, text).await;
    let mut firsts = Vec::new();
    for id in ["p1", "p2", "p3", "p4"] {
        let (status, state) = arrive(&rig, id).await;
        assert_eq!(status, 201, "{state}");
        firsts.push(condition_of(&read(&state)));
    }
    assert_eq!(firsts, ["a1", "b1", "a2", "b2"]);
    rig.shutdown().await;
    let assigned: Vec<(Value, Value)> = ["p1", "p2", "p3", "p4"]
        .iter()
        .map(|id| {
            let records = stored(&dir, id);
            (records[0].2["order"].clone(), records[1].2["group"].clone())
        })
        .collect();
    assert_eq!(
        assigned,
        [
            (json!(["a1", "a2"]), json!("robots")),
            (json!(["b1", "b2"]), json!("people")),
            (json!(["a2", "a1"]), json!("robots")),
            (json!(["b2", "b1"]), json!("people")),
        ]
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn when_every_group_is_at_its_quota_arrivals_are_told_the_study_is_full() {
    let text = BETWEEN
        .replace("name = \"alpha\"", "name = \"alpha\"\nquota = 1")
        .replace("name = \"beta\"", "name = \"beta\"\nquota = 1")
        .replace("[study]\n", "[study]\nfull_text = \"We are full.\"\n");
    let dir = temp_dir("quota");
    let rig = StudyRig::start(&dir, &text).await;
    assert_eq!(condition_of(&consented(&rig, "ann", true).await), "alpha");
    let (status, _) = arrive(&rig, "bob").await;
    assert_eq!(status, 201);
    let (status, full) = arrive(&rig, "cy").await;
    assert_eq!((status, read::<ErrorReply>(&full).error), (503, "We are full.".into()));
    let (_, list) = rig.operator("GET", "/api/study/participants").await;
    assert_eq!(read::<ParticipantList>(&list).participants.len(), 2, "nobody made for a full study");
    // Bob declines: his place (beta) is free again, and Cy, trying again, gets it.
    let (status, _) = rig
        .call(
            "POST",
            "/api/study/participants/bob/answer",
            Some(json!({"step": 0, "answers": {"consent": false}})),
        )
        .await;
    assert_eq!(status, 200);
    assert_eq!(condition_of(&consented(&rig, "cy", true).await), "beta");
    rig.shutdown().await;
    let _ = std::fs::remove_dir_all(&dir);
}

/// A warm-up practice that anyone passes, then one whose pass mark (the whole sequence
/// in a second) nobody reaches, twice allowed; its screen-out has a code and a redirect.
const PRACTICE: &str = r##"
[study]
name = "practice"
mode = "lockstep"
time_limit_s = 1

[[condition]]
name = "alpha"
teammates = 1
min_active_ticks = 0

[[page]]
kind = "practice"
id = "warmup"
teammates = 1
min_active_ticks = 0

[[page]]
kind = "practice"
id = "exam"
teammates = 1
min_active_ticks = 0
pass = "completed"
attempts = 2

[[page]]
kind = "trial"

[[page]]
kind = "final"
completion_code = "DONE"

[screen_out]
text = "Sorry {participant}: {code}"
completion_code = "NOPE"
redirect = "https://example.org/out?cc={code}"
"##;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_failed_practice_pass_mark_ends_in_the_screen_out_with_its_code() {
    let dir = temp_dir("practice");
    let rig = StudyRig::start(&dir, PRACTICE).await;
    let (_, state) = arrive(&rig, "ann").await;
    let state: ParticipantState = read(&state);
    assert_eq!((kind_of(&state), condition_of(&state)), ("practice".into(), "warmup".into()));
    let (status, state) = play(&rig, "ann", &state).await;
    assert_eq!(status, 200, "{state}");
    let state: ParticipantState = read(&state);
    let Some(StudyPage::Practice { condition, trial: 1, trials: 2, .. }) = &state.page else {
        panic!("the exam's first attempt: {state:?}")
    };
    assert_eq!(condition, "exam");
    let (_, state) = play(&rig, "ann", &state).await;
    let state: ParticipantState = read(&state);
    assert!(matches!(state.page, Some(StudyPage::Practice { trial: 2, .. })), "failed once: again {state:?}");
    let (_, state) = play(&rig, "ann", &state).await;
    let expected = json!({
        "kind": "screened_out", "title": "Thank you", "html": "<p>Sorry ann: NOPE</p>\n",
        "completion_code": "NOPE", "redirect": "https://example.org/out?cc=NOPE",
    });
    assert_eq!(state["page"], expected, "{state}");
    let (status, _) =
        rig.call("POST", "/api/study/participants/ann/answer", Some(json!({"step": 1, "answers": {}}))).await;
    assert_eq!(status, 409, "the study has ended for them");
    let (_, list) = rig.operator("GET", "/api/study/participants").await;
    assert_eq!(read::<ParticipantList>(&list).participants[0].page_kind, "screened_out");
    rig.shutdown().await;

    let out = dir.join("export");
    bw4t_study::export(&dir, &out).expect("export");
    let trials: Vec<(String, String, String)> = csv_rows(&out.join("trials.csv"))
        .into_iter()
        .map(|t| (t["condition"].clone(), t["practice"].clone(), t["passed"].clone()))
        .collect();
    let row = |c: &str, passed: &str| (c.to_string(), "true".to_string(), passed.to_string());
    assert_eq!(trials, [row("warmup", ""), row("exam", "false"), row("exam", "false")]);
    let people = csv_rows(&out.join("participants.csv"));
    assert_eq!((people[0]["screened_out"].as_str(), people[0]["completed"].as_str()), ("true", "false"));
    assert_eq!(people[0]["trials_complete"], "0", "practice rounds are not trials");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A comprehension check: both scored items right to pass, two attempts.
const CHECK: &str = r##"
[study]
name = "check"

[[condition]]
name = "alpha"

[[page]]
kind = "questionnaire"
id = "quiz"
pass = 2
attempts = 2

[[page.item]]
id = "goal"
kind = "choice"
text = "What is the goal?"
options = ["blocks", "points"]
correct = "blocks"

[[page.item]]
id = "team"
kind = "choice"
text = "Who helps you?"
options = ["robots", "nobody"]
correct = "robots"

[[page]]
kind = "trial"

[[page]]
kind = "final"

[screen_out]
completion_code = "SCREENED"
"##;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_comprehension_check_is_passed_on_a_second_attempt_or_failed_into_the_screen_out() {
    let dir = temp_dir("check");
    let rig = StudyRig::start(&dir, CHECK).await;
    let quiz = |id: &'static str, goal: &'static str| {
        let rig = &rig;
        async move {
            let body = json!({"step": 0, "answers": {"goal": goal, "team": "robots"}});
            let (status, state) =
                rig.call("POST", &format!("/api/study/participants/{id}/answer"), Some(body)).await;
            assert_eq!(status, 200, "{state}");
            read::<ParticipantState>(&state)
        }
    };
    for id in ["ann", "bob"] {
        let (status, _) = arrive(&rig, id).await;
        assert_eq!(status, 201);
        let again = quiz(id, "points").await;
        assert_eq!((again.step, kind_of(&again)), (0, "questionnaire".into()), "one wrong: asked again");
    }
    let passed = quiz("ann", "blocks").await;
    assert_eq!((passed.step, kind_of(&passed)), (1, "trial".into()));
    let failed = quiz("bob", "points").await;
    let Some(StudyPage::ScreenedOut { completion_code, .. }) = &failed.page else {
        panic!("screened out: {failed:?}")
    };
    assert_eq!(completion_code.as_deref(), Some("SCREENED"));
    rig.shutdown().await;
    let out = dir.join("export");
    bw4t_study::export(&dir, &out).expect("export");
    let passes: Vec<(String, String)> = csv_rows(&out.join("answers.csv"))
        .into_iter()
        .filter(|a| a["item"] == "goal")
        .map(|a| (a["participant"].clone(), a["passed"].clone()))
        .collect();
    let pass = |id: &str, passed: &str| (id.to_string(), passed.to_string());
    assert_eq!(
        passes,
        [pass("ann", "false"), pass("ann", "true"), pass("bob", "false"), pass("bob", "false")]
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// One condition of one trial page, its template's seed 7.
const SEEDS: &str = r##"
[study]
name = "seeds"
seed = 7
mode = "lockstep"
time_limit_s = 1

[[condition]]
name = "alpha"
teammates = 1
min_active_ticks = 0

[[page]]
kind = "trial"

[[page]]
kind = "final"
"##;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_slot_and_trial_position_play_the_same_seed_whatever_ran_before() {
    // Alone: Ann (slot 0) plays her trial.
    let first = temp_dir("seeds-first");
    let rig = StudyRig::start(&first, SEEDS).await;
    let (_, state) = arrive(&rig, "ann").await;
    let (status, _) = play(&rig, "ann", &read(&state)).await;
    assert_eq!(status, 200);
    rig.shutdown().await;
    let alone = seeds(&first, "ann");
    assert_eq!(alone.len(), 1);

    // A stray match of the condition runs first (an invited player outside the study):
    // it plays the template's seed and counts as its first match.
    let second = temp_dir("seeds-second");
    let rig = StudyRig::start(&second, SEEDS).await;
    let token = rig.arena.invite("alpha", "stray").expect("a seat token");
    let mut stray =
        AutoPlayer::join_with(rig.addr, json!({"template": "alpha", "name": "stray", "seat": token})).await;
    stray.wait("the stray match's end", |s| s.ended.then_some(())).await;
    tokio::time::timeout(WAIT, rig.arena.ended(1)).await.expect("recorded");
    let (_, summary) = rig.operator("GET", &format!("/api/matches/{}", stray.welcome.match_info.name)).await;
    assert_eq!(summary["seed"], json!(7), "{summary}");
    let (_, state) = arrive(&rig, "ann").await;
    play(&rig, "ann", &read(&state)).await;
    let (_, state) = arrive(&rig, "bob").await;
    play(&rig, "bob", &read(&state)).await;
    rig.shutdown().await;
    assert_eq!(seeds(&second, "ann"), alone, "the same slot and position: the same layout");
    assert_ne!(seeds(&second, "bob"), alone, "another slot: another layout");
    assert_ne!(alone, [7], "not the template's seed");
    for dir in [first, second] {
        let _ = std::fs::remove_dir_all(&dir);
    }
}

#[test]
fn design_keys_are_checked_naming_the_problem() {
    let refused = |edit: &dyn Fn(&str) -> String, expected: &str| {
        let text = edit(BETWEEN);
        let e = parse(&text).expect_err("refused");
        assert!(e.contains(expected), "{e}");
    };
    refused(
        &|t| t.replace("assignment = \"between\"", "assignment = \"sideways\""),
        "assignment = 'sideways'",
    );
    refused(
        &|t| t.replace("name = \"beta\"", "name = \"beta\"\nbetween = \"x\""),
        "only under assignment = \"mixed\"",
    );
    refused(&|t| t.replace("\"between\"", "\"mixed\""), "every condition names its group");
    refused(&|t| t.replace("name = \"beta\"", "name = \"beta\"\nquota = 0"), "quota = 0");
    refused(
        &|t| t.replace("kind = \"consent\"\ntext = \"Agree?\"", "kind = \"practice\"\nid = \"alpha\""),
        "taken",
    );
    refused(
        &|t| t.replace("kind = \"consent\"\ntext = \"Agree?\"", "kind = \"practice\"\npass = \"most\""),
        "pass = 'most'",
    );
    let quiz = |pass: &str| {
        format!(
            "{BETWEEN}[[page]]\nkind = \"questionnaire\"\n{pass}\n[[page.item]]\nid = \"q\"\nkind = \"choice\"\n\
             text = \"Q?\"\noptions = [\"a\", \"b\"]\ncorrect = \"a\"\n"
        )
        .replace("[[page]]\nkind = \"final\"\n", "")
            + "[[page]]\nkind = \"final\"\n"
    };
    assert!(parse(&quiz("pass = 1")).is_ok());
    let e = parse(&quiz("pass = 2")).expect_err("refused");
    assert!(e.contains("pass = 2 but only 1"), "{e}");
    let e = parse(&quiz("attempts = 2")).expect_err("refused");
    assert!(e.contains("only with a pass mark"), "{e}");
    let e = parse(&quiz("pass = 1").replace("correct = \"a\"", "correct = \"c\"")).expect_err("refused");
    assert!(e.contains("not one of its options"), "{e}");
    // Under between, any number of trial pages; under mixed, a multiple of each group's size.
    assert!(parse(&BETWEEN.replacen("[[page]]\nkind = \"trial\"\n", "", 1)).is_ok());
}
