//! One participant's way through the study: their records (kept by `store.rs`), the state
//! those records make (replayed in order, so a restarted server continues where they were),
//! their order of their group's conditions, the seed of each match they play, and the page
//! each step shows.

use bw4t_protocol::{ParticipantState, StudyPage, TrialHello, TrialLanguage};
use serde::{Deserialize, Serialize};
use serde_json::Value;

use super::config::{Condition, Order, Page, Study};

/// One of a participant's records (besides `seq` and `server_ms`, which every one has).
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub(crate) enum Record {
    /// The participant arrived: their number in arrival order (from 0), their order of
    /// the conditions, the link's parameters and the SHA-256 of their credential's secret.
    Created {
        participant: String,
        number: u64,
        order: Vec<String>,
        params: Value,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        secret_sha256: Option<String>,
    },
    /// Their assignment, right after `created` (left out when it is the arrival number's
    /// slot of the only group): the slot, which fixes their group, their order's row and
    /// their matches' seeds, and the group's name.
    Assigned { slot: u64, group: String },
    /// They came back with the link (a reload or a new browser).
    Resumed { params: Value },
    /// A step answered: the step's page kind (and questionnaire id) and the answers; for a
    /// page with a pass mark, whether they passed (failed: the step is not done).
    Answer {
        step: usize,
        page: String,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        questionnaire: Option<String>,
        answers: Value,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        passed: Option<bool>,
        /// A shuffled questionnaire: the order its items (and rows) were shown in.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        shown: Option<super::answers::Shown>,
    },
    /// A trial's (or practice's) match started (the page's word, right after `welcome`).
    TrialStarted {
        step: usize,
        trial: usize,
        condition: String,
        r#match: String,
        match_id: String,
        #[serde(default, skip_serializing_if = "is_false")]
        practice: bool,
        /// The protocol session of the participant's robot (`welcome.session`): any page
        /// of theirs takes the robot back with it.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        session: Option<String>,
    },
    /// A trial's match ended: its result (as recorded when the trial was answered).
    TrialEnded {
        step: usize,
        trial: usize,
        condition: String,
        match_id: String,
        result: Value,
        #[serde(default, skip_serializing_if = "is_false")]
        practice: bool,
    },
    /// A trial's match was lost (the server stopped under it); the trial is given again.
    TrialIncomplete {
        step: usize,
        trial: usize,
        condition: String,
        match_id: String,
        reason: String,
        #[serde(default, skip_serializing_if = "is_false")]
        practice: bool,
    },
    /// They failed a pass mark with no attempt left: the study ends for them.
    ScreenedOut { step: usize, reason: String },
    /// Events the page sent.
    Event { event: Value },
}

/// A participant's state, made by their records.
#[derive(Clone, Debug)]
pub(crate) struct Participant {
    pub id: String,
    pub number: u64,
    /// Condition indices, one per condition.
    pub order: Vec<usize>,
    pub step: usize,
    pub declined: bool,
    /// Their slot (the arrival number, unless assigned otherwise).
    pub slot: u64,
    /// They failed a pass mark with no attempt left.
    pub screened_out: bool,
    /// Attempts failed at the current step.
    pub failed: u32,
    /// The trial match started at the current step and not yet answered: (name, id).
    pub playing: Option<(String, String)>,
    /// The protocol session of their robot in that match, if the page said it.
    pub playing_session: Option<String>,
    /// Match ids already answered for a trial.
    pub used_matches: Vec<String>,
    pub started_ms: u64,
    pub last_ms: u64,
    /// The last `seq` written.
    pub seq: u64,
    /// The SHA-256 of their credential's secret (none in a log of an older version).
    pub secret_sha256: Option<String>,
    /// Events recorded, and their bytes as JSON (the budget's count).
    pub events: u64,
    pub event_bytes: u64,
}

impl Participant {
    /// A participant from their `created` record.
    pub(crate) fn new(id: &str, number: u64, order: Vec<usize>, now: u64) -> Participant {
        Participant {
            id: id.to_string(),
            number,
            order,
            step: 0,
            declined: false,
            slot: number,
            screened_out: false,
            failed: 0,
            playing: None,
            playing_session: None,
            used_matches: Vec::new(),
            started_ms: now,
            last_ms: now,
            seq: 0,
            secret_sha256: None,
            events: 0,
            event_bytes: 0,
        }
    }

    /// Applies a record written at `server_ms`.
    pub(crate) fn apply(&mut self, record: &Record, server_ms: u64) {
        self.last_ms = self.last_ms.max(server_ms);
        match record {
            Record::Created { secret_sha256, .. } => self.secret_sha256.clone_from(secret_sha256),
            Record::Event { event } => {
                self.events += 1;
                self.event_bytes += event_size(event);
            }
            Record::Resumed { .. } => {}
            Record::Assigned { slot, .. } => self.slot = *slot,
            Record::ScreenedOut { .. } => self.screened_out = true,
            Record::Answer { step, page, answers, passed, .. } if *step == self.step => {
                if page == "consent" && answers.get("consent") == Some(&Value::Bool(false)) {
                    self.declined = true;
                } else if *passed == Some(false) {
                    self.failed += 1;
                } else {
                    self.step += 1;
                    self.failed = 0;
                }
                self.playing = None;
            }
            Record::Answer { .. } => {}
            Record::TrialStarted { step, r#match, match_id, session, .. } if *step == self.step => {
                self.playing = Some((r#match.clone(), match_id.clone()));
                self.playing_session.clone_from(session);
            }
            Record::TrialEnded { match_id, .. } => self.used_matches.push(match_id.clone()),
            Record::TrialIncomplete { match_id, .. } => {
                if self.playing.as_ref().is_some_and(|(_, id)| id == match_id) {
                    self.playing = None;
                }
            }
            Record::TrialStarted { .. } => {}
        }
    }

    /// The name the participant plays under: `P` and their arrival number from 1.
    pub(crate) fn player_name(&self) -> String {
        format!("P{}", self.number + 1)
    }

    /// Whether they reached the final page.
    pub(crate) fn completed(&self, study: &Study) -> bool {
        !self.declined && !self.screened_out && matches!(study.pages.get(self.step), Some(Page::Final { .. }))
    }

    /// Whether the study has ended for them before its final page.
    pub(crate) fn stopped(&self) -> bool {
        self.declined || self.screened_out
    }

    /// Whether they hold their slot at `now_ms`: they completed, or are still going (not
    /// stopped, and a record of theirs is younger than the study's `dropout_after_s`).
    pub(crate) fn holds_slot(&self, study: &Study, now_ms: u64) -> bool {
        self.completed(study)
            || (!self.stopped() && now_ms.saturating_sub(self.last_ms) <= study.dropout_after_ms)
    }

    /// What step `step` plays, if it is a trial or a practice page.
    pub(crate) fn played_at<'s>(&self, study: &'s Study, step: usize) -> Option<Played<'s>> {
        match study.pages.get(step)? {
            Page::Trial { .. } => {
                let (trial, c) = self.trial_at(study, step)?;
                let condition = &study.conditions[c];
                let seed = layout_seed(condition.seed, self.slot, trial as u64);
                Some(Played { condition, trial, practice: false, seed })
            }
            Page::Practice { practice, .. } => {
                let condition = &study.practices[*practice];
                // Positions past every trial's: a practice's layout is its own.
                let seed = layout_seed(condition.seed, self.slot, PRACTICE_POSITIONS + step as u64);
                Some(Played { condition, trial: 0, practice: true, seed })
            }
            _ => None,
        }
    }

    /// The trial at `step` (1-based) and its condition's index, if `step` is a trial page.
    pub(crate) fn trial_at(&self, study: &Study, step: usize) -> Option<(usize, usize)> {
        if !matches!(study.pages.get(step), Some(Page::Trial { .. })) {
            return None;
        }
        let trial = study.pages[..=step].iter().filter(|p| matches!(p, Page::Trial { .. })).count();
        Some((trial, self.order[(trial - 1) % self.order.len()]))
    }

    /// The state the API answers: the step and its page.
    pub(crate) fn state(&self, study: &Study) -> ParticipantState {
        ParticipantState {
            participant: self.id.clone(),
            step: self.step,
            steps: study.pages.len(),
            page: self.page(study),
        }
    }

    fn page(&self, study: &Study) -> Option<StudyPage> {
        if self.screened_out {
            let s = &study.screen_out;
            let (html, completion_code, redirect) = self.filled(&s.html, &s.completion_code, &s.redirect);
            return Some(StudyPage::ScreenedOut { title: s.title.clone(), html, completion_code, redirect });
        }
        let page = match study.pages.get(self.step)? {
            Page::Consent { declined_title, declined_html, declined_code, declined_redirect, .. }
                if self.declined =>
            {
                let (html, completion_code, redirect) =
                    self.filled(declined_html, declined_code, declined_redirect);
                StudyPage::Declined { title: declined_title.clone(), html, completion_code, redirect }
            }
            Page::Consent { title, html, agree, decline, .. } => StudyPage::Consent {
                title: title.clone(),
                html: html.clone(),
                agree: agree.clone(),
                decline: decline.clone(),
            },
            Page::Instructions { title, html } => {
                StudyPage::Instructions { title: title.clone(), html: html.clone() }
            }
            Page::Questionnaire { id, title, html, items, shuffle, .. } => StudyPage::Questionnaire {
                id: id.clone(),
                title: title.clone(),
                html: html.clone(),
                items: super::answers::items_shown(
                    items,
                    super::answers::shown(study.seed, &self.id, id, items, *shuffle).as_ref(),
                ),
            },
            Page::Trial { title, html } => {
                let (trial, c) = self.trial_at(study, self.step)?;
                let condition = &study.conditions[c];
                let trials = study.trials();
                let title = title
                    .clone()
                    .or_else(|| condition.title.clone())
                    .unwrap_or_else(|| format!("Task {trial} of {trials}"));
                let html: Vec<&str> =
                    html.iter().chain(condition.briefing_html.iter()).map(String::as_str).collect();
                StudyPage::Trial {
                    trial,
                    trials,
                    condition: condition.name.clone(),
                    title,
                    html: (!html.is_empty()).then(|| html.concat()),
                    hello: TrialHello {
                        template: condition.name.clone(),
                        name: self.player_name(),
                        seat: None,
                        watch_token: None,
                        match_name: None,
                        session: None,
                    },
                    view: condition.view.clone(),
                    language: TrialLanguage {
                        kinds: condition.language.allowed_kinds(),
                        free_text: condition.language.free_text,
                    },
                    time_limit_s: condition.time_limit_s,
                    humans: condition.humans,
                }
            }
            Page::Practice { title, html, attempts, .. } => {
                let played = self.played_at(study, self.step)?;
                let practice = played.condition;
                let html: Vec<&str> =
                    html.iter().chain(practice.briefing_html.iter()).map(String::as_str).collect();
                StudyPage::Practice {
                    trial: self.failed as usize + 1,
                    trials: *attempts as usize,
                    condition: practice.name.clone(),
                    title: title.clone(),
                    html: (!html.is_empty()).then(|| html.concat()),
                    hello: TrialHello {
                        template: practice.name.clone(),
                        name: self.player_name(),
                        seat: None,
                        watch_token: None,
                        match_name: None,
                        session: None,
                    },
                    view: practice.view.clone(),
                    language: TrialLanguage {
                        kinds: practice.language.allowed_kinds(),
                        free_text: practice.language.free_text,
                    },
                    time_limit_s: practice.time_limit_s,
                    humans: practice.humans,
                }
            }
            Page::Final { title, html, completion_code, redirect } => {
                let (html, completion_code, redirect) = self.filled(html, completion_code, redirect);
                StudyPage::Final { title: title.clone(), html, completion_code, redirect }
            }
        };
        Some(page)
    }

    /// An end page's text, code and redirect with the participant's id and the code in.
    fn filled(
        &self,
        html: &str,
        completion_code: &Option<String>,
        redirect: &Option<String>,
    ) -> (String, Option<String>, Option<String>) {
        let code = completion_code.clone().unwrap_or_default();
        let html = html.replace("{participant}", &self.id).replace("{code}", &code);
        let redirect = redirect.as_deref().map(|url| {
            url.replace("{participant}", &url_encode(&self.id)).replace("{code}", &url_encode(&code))
        });
        (html, completion_code.clone(), redirect)
    }
}

/// What a trial or practice page plays: its condition (or practice), the trial's number
/// (0 for a practice), and the seed its match plays.
pub(crate) struct Played<'s> {
    pub condition: &'s Condition,
    pub trial: usize,
    pub practice: bool,
    pub seed: u64,
}

/// Where a practice's positions start (a trial's position is its number).
const PRACTICE_POSITIONS: u64 = 1 << 32;

/// The seed of the match at trial position `position` of the participant in `slot`: the
/// condition's seed plus a hash of both, so the same slot and position always play the same
/// layout, whatever other matches ran before.
pub(crate) fn layout_seed(base: u64, slot: u64, position: u64) -> u64 {
    base.wrapping_add(splitmix(splitmix(slot) ^ position))
}

/// One splitmix64 step: a good 64-bit mix.
fn splitmix(x: u64) -> u64 {
    let mut z = x.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

fn is_false(b: &bool) -> bool {
    !*b
}

/// An event's size in the budget: its bytes as compact JSON.
pub(crate) fn event_size(event: &Value) -> u64 {
    serde_json::to_string(event).map_or(0, |text| text.len() as u64)
}

/// Percent-encodes what is not unreserved in a URL.
fn url_encode(text: &str) -> String {
    text.bytes()
        .map(|b| match b {
            b'A'..=b'Z' | b'a'..=b'z' | b'0'..=b'9' | b'-' | b'_' | b'.' | b'~' => (b as char).to_string(),
            _ => format!("%{b:02X}"),
        })
        .collect()
}

/// The group (index) of slot `slot`: the groups in turn.
pub(crate) fn group_of(study: &Study, slot: u64) -> usize {
    (slot % study.groups.len() as u64) as usize
}

/// The order (condition indices) of the participant with `id` in slot `slot`: their
/// group's conditions, in the row of a Latin square the slot's turn in its group gives
/// (counterbalanced), as in the file (fixed), or shuffled by the id (random).
pub(crate) fn order_for(study: &Study, slot: u64, id: &str) -> Vec<usize> {
    let mut order = study.groups[group_of(study, slot)].conditions.clone();
    let k = order.len();
    let turn = slot / study.groups.len() as u64;
    match study.order {
        Order::Fixed => {}
        Order::Counterbalanced => order.rotate_left((turn % k as u64) as usize),
        Order::Random => super::shuffle::shuffle(&mut order, study.seed, &[id.as_bytes()]),
    }
    order
}

/// Whether `id` is a participant id: 1 to 64 letters, digits, `-` or `_`.
pub(crate) fn valid_id(id: &str) -> bool {
    !id.is_empty() && id.len() <= 64 && id.chars().all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::{Participant, order_for};
    use crate::{Order, parse};

    fn default_map(_: &str) -> Result<bw4t_map::Map, String> {
        bw4t_map::Map::from_native(include_str!("../../../maps/default.toml")).map_err(|e| e.to_string())
    }

    fn study(order: &str, conditions: usize) -> crate::Study {
        let mut text = format!("[study]\nname = \"s\"\norder = \"{order}\"\n");
        for i in 0..conditions {
            text += &format!("[[condition]]\nname = \"c{i}\"\n[[page]]\nkind = \"trial\"\n");
        }
        text += "[[page]]\nkind = \"final\"\n";
        parse(&text, Path::new("s.toml"), &default_map).expect("a good study")
    }

    /// Every kind of page, each field the API shows set.
    const EVERY_PAGE: &str = r#"
[study]
name = "s"
[[condition]]
name = "alpha"
kinds = ["have"]
free_text = false
briefing = "Be *quick*."
[[page]]
kind = "consent"
text = "Agree?"
[[page]]
kind = "instructions"
text = "Read."
[[page]]
kind = "questionnaire"
id = "q"
text = "Say."
[[page.item]]
id = "l"
kind = "likert"
text = "L?"
scale = 5
labels = ["no", "yes"]
[[page.item]]
id = "c"
kind = "choice"
text = "C?"
options = ["a", "b"]
[[page.item]]
id = "t"
kind = "text"
text = "T?"
required = false
[[page]]
kind = "trial"
[[page]]
kind = "final"
text = "Code {code} for {participant}."
completion_code = "C 1"
redirect = "https://x.invalid/?c={code}&p={participant}"
"#;

    /// The state of each step as the API answers it, byte for byte: keys in alphabetical
    /// order, absent and `null` fields as they have always been.
    #[test]
    fn every_page_is_answered_with_the_same_bytes() {
        let study = parse(EVERY_PAGE, Path::new("s.toml"), &default_map).expect("a good study");
        let mut p = Participant::new("p-1", 0, vec![0], 0);
        let mut answered = Vec::new();
        for step in 0..=study.pages.len() {
            p.step = step;
            answered.push(crate::api::reply_body(&p.state(&study)).expect("json"));
        }
        p.step = 0;
        p.declined = true;
        answered.push(crate::api::reply_body(&p.state(&study)).expect("json"));
        let expected = [
            r#"{"page":{"agree":"I agree","decline":"I do not agree","html":"<p>Agree?</p>\n","kind":"consent","title":"Consent"},"participant":"p-1","step":0,"steps":5}"#,
            r#"{"page":{"html":"<p>Read.</p>\n","kind":"instructions","title":"Instructions"},"participant":"p-1","step":1,"steps":5}"#,
            r#"{"page":{"html":"<p>Say.</p>\n","id":"q","items":[{"id":"l","kind":"likert","labels":["no","yes"],"required":true,"scale":5,"text":"L?"},{"id":"c","kind":"choice","options":["a","b"],"required":true,"text":"C?"},{"id":"t","kind":"text","multiline":false,"required":false,"text":"T?"}],"kind":"questionnaire","title":"Questions"},"participant":"p-1","step":2,"steps":5}"#,
            r#"{"page":{"condition":"alpha","hello":{"name":"P1","template":"alpha"},"html":"<p>Be <em>quick</em>.</p>\n","humans":1,"kind":"trial","language":{"free_text":false,"kinds":["have"]},"time_limit_s":600,"title":"Task 1 of 1","trial":1,"trials":1,"view":"own"},"participant":"p-1","step":3,"steps":5}"#,
            r#"{"page":{"completion_code":"C 1","html":"<p>Code C 1 for p-1.</p>\n","kind":"final","redirect":"https://x.invalid/?c=C%201&p=p-1","title":"Thank you"},"participant":"p-1","step":4,"steps":5}"#,
            r#"{"page":null,"participant":"p-1","step":5,"steps":5}"#,
            r#"{"page":{"html":"<p>You did not consent, so the study ends here. You may close this page.</p>\n","kind":"declined","title":"Thank you"},"participant":"p-1","step":0,"steps":5}"#,
        ];
        assert_eq!(answered, expected);
    }

    #[test]
    fn counterbalanced_orders_are_the_rotations_in_turn() {
        let s = study("counterbalanced", 3);
        let orders: Vec<Vec<usize>> = (0..4).map(|n| order_for(&s, n, "x")).collect();
        assert_eq!(orders, [vec![0, 1, 2], vec![1, 2, 0], vec![2, 0, 1], vec![0, 1, 2]]);
        assert_eq!(order_for(&study("fixed", 3), 1, "x"), [0, 1, 2]);
    }

    #[test]
    fn random_orders_are_permutations_fixed_by_seed_and_id() {
        let s = study("random", 4);
        assert_eq!(s.order, Order::Random);
        let mut seen = std::collections::BTreeSet::new();
        for id in ["a", "b", "c", "d", "e", "f", "g", "h"] {
            let order = order_for(&s, 0, id);
            assert_eq!(order, order_for(&s, 9, id), "the arrival number does not matter");
            let mut sorted = order.clone();
            sorted.sort_unstable();
            assert_eq!(sorted, [0, 1, 2, 3]);
            seen.insert(order);
        }
        assert!(seen.len() > 1, "ids give different orders");
    }
}
