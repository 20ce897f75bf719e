//! The JSON replies of the study API (`/api/study/...` under `bw4t study`): the study, a
//! participant's state and the page of their step, the operator's list of participants,
//! recorded events and a refusal at the wrong step. Their schemas are generated into
//! `protocol/schema/http/study/`. The study answers them with their keys in alphabetical
//! order, as serde_json's maps order them.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// `GET /api/study`: the study's name, title and conditions.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct StudyInfo {
    /// The study's name.
    pub name: String,
    /// Its title, for the participants.
    pub title: String,
    /// Its conditions' names, in the study file's order.
    pub conditions: Vec<String>,
    /// The device a participant needs: the page turns others away before consent.
    pub screen: ScreenRequirement,
}

/// The device a study needs (`[study] min_screen`, `allow_touch_only`).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
pub struct ScreenRequirement {
    /// The narrowest browser window taken, in CSS pixels.
    pub min_width: u32,
    /// The lowest browser window taken, in CSS pixels.
    pub min_height: u32,
    /// Whether a device with a touch screen and no mouse (a phone, a tablet) is taken.
    pub allow_touch_only: bool,
}

/// A participant's state: the step they are at and its page. The answer to their arrival,
/// to `GET /api/study/participants/ID` and to each accepted answer, trial start or event.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct ParticipantState {
    /// The participant's id.
    pub participant: String,
    /// Their step, from 0.
    pub step: usize,
    /// The study's pages.
    pub steps: usize,
    /// The page of their step (`null` past the last page).
    pub page: Option<StudyPage>,
}

/// The page a participant is shown, named by `kind`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum StudyPage {
    /// Asks for consent.
    Consent {
        /// Title.
        title: String,
        /// Text, as HTML.
        html: String,
        /// The agree button's label.
        agree: String,
        /// The decline button's label.
        decline: String,
    },
    /// Consent was declined: the study has ended for the participant.
    Declined {
        /// Title.
        title: String,
        /// Text, as HTML.
        html: String,
        /// The platform's code for those who declined (absent if none).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        completion_code: Option<String>,
        /// Where to send them, filled in (absent if nowhere).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        redirect: Option<String>,
    },
    /// Text to read.
    Instructions {
        /// Title.
        title: String,
        /// Text, as HTML.
        html: String,
    },
    /// Questions.
    Questionnaire {
        /// The questionnaire's id.
        id: String,
        /// Title.
        title: String,
        /// Text above the items, as HTML (absent if none).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        html: Option<String>,
        /// The items, in order.
        items: Vec<QuestionItem>,
    },
    /// A match to play: the next condition of the participant's order.
    Trial {
        /// Which trial this is, from 1.
        trial: usize,
        /// The study's trials.
        trials: usize,
        /// The condition's name.
        condition: String,
        /// Title.
        title: String,
        /// The page's text and the condition's briefing, as HTML (`null` if neither).
        html: Option<String>,
        /// What the page's `hello` names.
        hello: TrialHello,
        /// What the player sees: `own` (what the robot perceives) or `overview`.
        view: String,
        /// Which messages the player may send.
        language: TrialLanguage,
        /// The match's time limit, in seconds.
        time_limit_s: u64,
        /// People in each of the condition's matches.
        humans: usize,
    },
    /// A practice round: a match of the practice's own template, outside the conditions
    /// (played as a trial is: `hello`, then the match id answered).
    Practice {
        /// Which attempt this is, from 1.
        trial: usize,
        /// The attempts allowed.
        trials: usize,
        /// The practice's id (its template's name).
        condition: String,
        /// Title.
        title: String,
        /// The page's text and the practice's briefing, as HTML (`null` if neither).
        html: Option<String>,
        /// What the page's `hello` names.
        hello: TrialHello,
        /// What the player sees: `own` or `overview`.
        view: String,
        /// Which messages the player may send.
        language: TrialLanguage,
        /// The match's time limit, in seconds.
        time_limit_s: u64,
        /// People in each match (1).
        humans: usize,
    },
    /// A pass mark was failed: the study has ended for the participant, with the
    /// screen-out's completion code and/or redirect.
    ScreenedOut {
        /// Title.
        title: String,
        /// Text, as HTML, the participant's id and the code filled in.
        html: String,
        /// The screen-out's completion code (`null` if none).
        completion_code: Option<String>,
        /// Where to send the participant, filled in (`null` if nowhere).
        redirect: Option<String>,
    },
    /// The end: a completion code and/or a redirect.
    Final {
        /// Title.
        title: String,
        /// Text, as HTML, the participant's id and the code filled in.
        html: String,
        /// The completion code (`null` if none).
        completion_code: Option<String>,
        /// Where to send the participant, filled in (`null` if nowhere).
        redirect: Option<String>,
    },
}

/// The `hello` of a trial: the condition's template and the participant's player name.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct TrialHello {
    /// The template to join (the condition's name).
    pub template: String,
    /// The name to play under.
    pub name: String,
    /// The seat token that binds the seat to the participant (`hello.seat`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seat: Option<String>,
    /// A condition whose view is the whole map: the spectator token of its matches, for
    /// the overview beside the player's own view.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub watch_token: Option<String>,
    /// The trial's match under way (the page said it started), to go back into.
    #[serde(default, rename = "match", skip_serializing_if = "Option::is_none")]
    pub match_name: Option<String>,
    /// The session of the participant's robot in it (`hello.session`), to take it back.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub session: Option<String>,
}

/// The messages a trial's player may send.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct TrialLanguage {
    /// The kinds of message allowed.
    pub kinds: Vec<String>,
    /// Whether free text may be sent.
    pub free_text: bool,
}

/// One item of a questionnaire.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct QuestionItem {
    /// Its id (a key of the answers).
    pub id: String,
    /// The question.
    pub text: String,
    /// Whether it must be answered (when shown).
    pub required: bool,
    /// Shown (and asked) only when an earlier item of the page has one of these answers
    /// (absent: always shown).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub show_if: Option<ShowIf>,
    /// What it asks for.
    #[serde(flatten)]
    pub kind: QuestionKind,
}

/// When a [`QuestionItem`] is shown: an earlier item of the same page has one of `in`'s
/// answers (numbers compare by value). Hidden, it is not asked and its answer is ignored.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct ShowIf {
    /// The earlier item's id.
    pub item: String,
    /// The answers that show the item.
    #[serde(rename = "in")]
    pub any_of: Vec<serde_json::Value>,
}

/// One statement of a matrix item.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct MatrixRow {
    /// Its key in the answer: its place in the study file's list, from 1 (`"1"`, `"2"`,
    /// ...), whatever order it is shown in.
    pub key: String,
    /// The statement.
    pub text: String,
}

/// What a [`QuestionItem`] asks for, named by `kind`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum QuestionKind {
    /// An integer from 1 to `scale`.
    Likert {
        /// Points on the scale.
        scale: u32,
        /// The left and right ends' labels.
        labels: [String; 2],
    },
    /// One of the options.
    Choice {
        /// The options.
        options: Vec<String>,
    },
    /// A text.
    Text {
        /// Whether it has several lines.
        multiline: bool,
        /// The most characters taken (absent: the server's own limit, 10,000).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        maxlength: Option<usize>,
    },
    /// A number from `min` to `max` (either end absent: open), whole if `integer`.
    Number {
        /// The smallest number taken.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        min: Option<f64>,
        /// The largest number taken.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        max: Option<f64>,
        /// Whether only whole numbers are taken.
        integer: bool,
        /// The unit shown after the field (`years`, `hours`).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        unit: Option<String>,
    },
    /// One question over several statements (a grid): each row takes a point of a shared
    /// Likert scale (`scale`, `labels`) or one of shared `options`. The answer is an object
    /// of row keys and values.
    Matrix {
        /// The statements, in the order shown.
        rows: Vec<MatrixRow>,
        /// Points on the scale (absent when the rows take `options`).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        scale: Option<u32>,
        /// The scale's left and right ends' labels.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        labels: Option<[String; 2]>,
        /// The options each row takes (absent on a scale).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        options: Option<Vec<String>>,
    },
}

/// `409` to an answer or trial start at a step that is not the participant's current one
/// (or that takes none): why, and the participant's state.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct StepConflict {
    /// What is wrong.
    pub error: String,
    /// The participant's state.
    pub state: ParticipantState,
}

/// `POST /api/study/participants/ID/events`: how many events were recorded.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct EventsRecorded {
    /// The events recorded.
    pub recorded: usize,
}

/// What an export wrote: how many of each thing.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
pub struct ExportCounts {
    /// Participants exported.
    pub participants: usize,
    /// Trials (attempts) exported, complete or not.
    pub trials: usize,
    /// Of those, the trials that do not count.
    pub incomplete: usize,
    /// Answers exported (one per item).
    pub answers: usize,
    /// Events exported.
    pub events: usize,
    /// Replays copied.
    pub replays: usize,
}

/// `POST /api/study/export` (operator): the export made into the data directory's
/// `export/`, whose CSV files `GET /api/study/export/NAME.csv` gives.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct StudyExported {
    /// What it wrote.
    #[serde(flatten)]
    pub counts: ExportCounts,
    /// The CSV files, each at `GET /api/study/export/FILE`.
    pub files: Vec<String>,
}

/// `GET /api/study/participants` (operator): everyone, by id.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct ParticipantList {
    /// One row per participant, by id.
    pub participants: Vec<ParticipantRow>,
}

/// One participant as the operator's list shows them.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct ParticipantRow {
    /// The participant's id.
    pub participant: String,
    /// Their arrival number, from 0.
    pub number: u64,
    /// Their step, from 0.
    pub step: usize,
    /// The study's pages.
    pub steps: usize,
    /// The kind of their step's page (`declined` after declining consent).
    pub page_kind: String,
    /// Whether they reached the final page.
    pub completed: bool,
    /// When they arrived, in milliseconds since the Unix epoch.
    pub started_ms: u64,
    /// When they were last heard from, in milliseconds since the Unix epoch.
    pub last_ms: u64,
    /// The condition of their step, when it is a trial.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub condition: Option<String>,
    /// The name of the trial's match they play, while it is live.
    #[serde(default, rename = "match", skip_serializing_if = "Option::is_none")]
    pub match_name: Option<String>,
    /// The id of the trial's match they started and have not answered with.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub match_id: Option<String>,
    /// The conditions they are given, in their order (one, between subjects).
    #[serde(default)]
    pub conditions: Vec<String>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_item_is_one_object_named_by_kind() {
        let item = QuestionItem {
            id: "load".into(),
            text: "How hard?".into(),
            required: true,
            show_if: None,
            kind: QuestionKind::Choice { options: vec!["easy".into(), "hard".into()] },
        };
        let json = serde_json::to_value(&item).expect("json");
        assert_eq!(
            json,
            serde_json::json!({"id": "load", "text": "How hard?", "required": true, "kind": "choice", "options": ["easy", "hard"]})
        );
        assert_eq!(serde_json::from_value::<QuestionItem>(json).ok(), Some(item));
    }

    #[test]
    fn a_page_without_a_state_is_null_and_absent_fields_are_left_out() {
        let state = ParticipantState { participant: "p".into(), step: 3, steps: 3, page: None };
        assert_eq!(serde_json::to_value(&state).expect("json")["page"], serde_json::Value::Null);
        let row = ParticipantRow {
            participant: "p".into(),
            number: 0,
            step: 1,
            steps: 3,
            page_kind: "trial".into(),
            completed: false,
            started_ms: 1,
            last_ms: 2,
            condition: Some("alpha".into()),
            match_name: None,
            match_id: Some("m.1".into()),
            conditions: vec!["alpha".into(), "beta".into()],
        };
        let json = serde_json::to_value(&row).expect("json");
        assert!(json.get("match").is_none() && json["match_id"] == "m.1", "{json}");
        assert_eq!(serde_json::from_value::<ParticipantRow>(json).ok(), Some(row));
    }
}
