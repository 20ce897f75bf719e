//! The study file (TOML): the study and its design (within, between or mixed subjects),
//! its conditions (each an arena template of matches made on demand), its pages in order
//! (a practice page plays a template of its own) and its screen-out page, read and
//! checked. Every problem names the file, the condition or page (1-based, as a person
//! counts them) and the key.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Duration;

use bw4t_agents::Strategy;
use bw4t_map::Map;
use bw4t_protocol::{MatrixRow, MessagePolicy, Mode, QuestionKind, ScreenRequirement, ShowIf, StudyInfo};
use serde::Deserialize;
use serde_json::Value;

use super::markdown::to_html;
use super::values::{MAX_TEXT, value_of};
use bw4t_server::{HostConfig, MatchSetup, OnEnd, Seat, Template};

/// The file, as written.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct StudyFile {
    study: StudySection,
    #[serde(default, rename = "condition")]
    conditions: Vec<ConditionFile>,
    #[serde(default, rename = "page")]
    pages: Vec<PageFile>,
    screen_out: Option<ScreenOutFile>,
    bonus: Option<super::bonus::Bonus>,
}

/// `[screen_out]`: what a participant who failed a pass mark sees.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ScreenOutFile {
    title: Option<String>,
    text: Option<String>,
    file: Option<PathBuf>,
    completion_code: Option<String>,
    redirect: Option<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct StudySection {
    name: String,
    title: Option<String>,
    seed: Option<u64>,
    order: Option<String>,
    mode: Option<String>,
    tick_hz: Option<u32>,
    time_limit_s: Option<u64>,
    max_running: Option<usize>,
    partner_timeout_s: Option<u64>,
    assignment: Option<String>,
    balance: Option<String>,
    dropout_after_s: Option<u64>,
    full_text: Option<String>,
    min_screen: Option<[u32; 2]>,
    allow_touch_only: Option<bool>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct ConditionFile {
    name: String,
    title: Option<String>,
    map: Option<String>,
    humans: Option<usize>,
    teammates: Option<usize>,
    strategy: Option<String>,
    time_limit_s: Option<u64>,
    tick_hz: Option<u32>,
    mode: Option<String>,
    kinds: Option<Vec<String>>,
    free_text: Option<bool>,
    view: Option<String>,
    briefing: Option<String>,
    briefing_file: Option<PathBuf>,
    partner_timeout_s: Option<u64>,
    seed: Option<u64>,
    max_running: Option<usize>,
    min_active_ticks: Option<u64>,
    between: Option<String>,
    quota: Option<u64>,
}

/// One `[[page]]`; `kind` says which keys it takes.
// Read once at the start, a page at a time: a practice's many keys cost nothing worth boxing.
#[allow(clippy::large_enum_variant)]
#[derive(Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
enum PageFile {
    Consent {
        title: Option<String>,
        text: Option<String>,
        file: Option<PathBuf>,
        agree: Option<String>,
        decline: Option<String>,
        declined_title: Option<String>,
        declined_text: Option<String>,
        declined_code: Option<String>,
        declined_redirect: Option<String>,
    },
    Instructions {
        title: Option<String>,
        text: Option<String>,
        file: Option<PathBuf>,
    },
    Trial {
        title: Option<String>,
        text: Option<String>,
        file: Option<PathBuf>,
    },
    Practice {
        id: Option<String>,
        title: Option<String>,
        text: Option<String>,
        file: Option<PathBuf>,
        map: Option<String>,
        teammates: Option<usize>,
        strategy: Option<String>,
        time_limit_s: Option<u64>,
        tick_hz: Option<u32>,
        mode: Option<String>,
        kinds: Option<Vec<String>>,
        free_text: Option<bool>,
        view: Option<String>,
        briefing: Option<String>,
        briefing_file: Option<PathBuf>,
        seed: Option<u64>,
        min_active_ticks: Option<u64>,
        pass: Option<String>,
        pass_sequence: Option<u32>,
        attempts: Option<u32>,
    },
    Questionnaire {
        id: Option<String>,
        title: Option<String>,
        text: Option<String>,
        file: Option<PathBuf>,
        pass: Option<usize>,
        attempts: Option<u32>,
        shuffle: Option<bool>,
        #[serde(default, rename = "item")]
        items: Vec<ItemFile>,
    },
    Final {
        title: Option<String>,
        text: Option<String>,
        file: Option<PathBuf>,
        completion_code: Option<String>,
        redirect: Option<String>,
    },
}

#[derive(Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
enum ItemFile {
    Likert {
        id: String,
        text: String,
        scale: Option<u32>,
        labels: Option<Vec<String>>,
        required: Option<bool>,
        show_if: Option<ShowIfFile>,
    },
    Choice {
        id: String,
        text: String,
        options: Vec<String>,
        required: Option<bool>,
        correct: Option<String>,
        show_if: Option<ShowIfFile>,
    },
    Text {
        id: String,
        text: String,
        multiline: Option<bool>,
        maxlength: Option<usize>,
        required: Option<bool>,
        show_if: Option<ShowIfFile>,
    },
    Number {
        id: String,
        text: String,
        min: Option<f64>,
        max: Option<f64>,
        integer: Option<bool>,
        unit: Option<String>,
        required: Option<bool>,
        show_if: Option<ShowIfFile>,
    },
    Matrix {
        id: String,
        text: String,
        rows: Vec<String>,
        scale: Option<u32>,
        labels: Option<Vec<String>>,
        options: Option<Vec<String>>,
        shuffle_rows: Option<bool>,
        required: Option<bool>,
        show_if: Option<ShowIfFile>,
    },
}

/// An item's `show_if = { item = "ID", equals = VALUE }` (or `in = [...]`).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ShowIfFile {
    item: String,
    equals: Option<toml::Value>,
    #[serde(rename = "in")]
    any_of: Option<Vec<toml::Value>>,
}

/// How participants' orders of the conditions are chosen.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Order {
    /// Every participant plays the conditions in the file's order.
    Fixed,
    /// The n-th participant to arrive (from 0) plays the rotation of the conditions that
    /// starts at condition n mod k: the rows of a Latin square, in turn.
    Counterbalanced,
    /// A shuffle seeded by the study's seed and the participant's id.
    Random,
}

/// How conditions are given to participants.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Assignment {
    /// Every participant plays every condition (in their order).
    Within,
    /// Every participant plays one condition, on all their trial pages.
    Between,
    /// Every participant plays the conditions of one group (the conditions' `between`
    /// value), in their order.
    Mixed,
}

impl Assignment {
    /// Its word in the file.
    pub fn name(self) -> &'static str {
        match self {
            Assignment::Within => "within",
            Assignment::Between => "between",
            Assignment::Mixed => "mixed",
        }
    }
}

/// What assignments are balanced over.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Balance {
    /// The n-th arrival (from 0) takes slot n: balanced over arrivals.
    Arrivals,
    /// An arrival takes the lowest slot no completer or active participant holds:
    /// balanced over completers and those still going.
    Completers,
}

/// A group of conditions one participant plays (within: all; between: one each; mixed:
/// those of one `between` value).
#[derive(Clone, Debug)]
pub struct Group {
    /// Its name (the condition's, under between; the `between` value, under mixed;
    /// `all`, under within).
    pub name: String,
    /// Its conditions (indices), in the file's order.
    pub conditions: Vec<usize>,
}

/// What passes a practice round.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PracticePass {
    /// The whole sequence delivered.
    Completed,
    /// At least this many blocks of the sequence delivered.
    Sequence(u32),
}

/// What a participant who fails a pass mark sees.
#[derive(Clone, Debug)]
pub struct ScreenOut {
    /// Title.
    pub title: String,
    /// Text, as HTML, with `{participant}` and `{code}` to fill.
    pub html: String,
    /// Its completion code.
    pub completion_code: Option<String>,
    /// Where to send them, with `{participant}` and `{code}` to fill.
    pub redirect: Option<String>,
}

impl Order {
    /// The order's word in the file.
    pub fn name(self) -> &'static str {
        match self {
            Order::Fixed => "fixed",
            Order::Counterbalanced => "counterbalanced",
            Order::Random => "random",
        }
    }
}

/// A checked study.
#[derive(Clone, Debug)]
pub struct Study {
    /// Its name (labels, data).
    pub name: String,
    /// What participants see as its title.
    pub title: String,
    /// The first match's seed of every condition.
    pub seed: u64,
    /// How orders of the conditions are chosen.
    pub order: Order,
    /// How conditions are given to participants.
    pub assignment: Assignment,
    /// What assignments are balanced over.
    pub balance: Balance,
    /// A participant not yet done whose last record is older than this (ms) has dropped
    /// out: their slot goes to the next arrival.
    pub dropout_after_ms: u64,
    /// What an arrival is told when every group is at a condition's quota.
    pub full_text: String,
    /// The conditions, in the file's order.
    pub conditions: Vec<Condition>,
    /// The groups: one is assigned to each participant.
    pub groups: Vec<Group>,
    /// The practice rounds' templates, in page order.
    pub practices: Vec<Condition>,
    /// The pages, in order: a participant's steps.
    pub pages: Vec<Page>,
    /// What a participant who fails a pass mark sees.
    pub screen_out: ScreenOut,
    /// The device a participant needs; others are turned away before consent.
    pub screen: ScreenRequirement,
    /// The file's text, as it was read.
    pub text: String,
}

impl Study {
    /// What `GET /api/study` says of the study.
    pub fn info(&self) -> StudyInfo {
        StudyInfo {
            name: self.name.clone(),
            title: self.title.clone(),
            conditions: self.conditions.iter().map(|c| c.name.clone()).collect(),
            screen: self.screen.clone(),
        }
    }
}

/// The smallest window a trial's view fits in without scrolling (CSS pixels), below the
/// study page's own header.
const DEFAULT_MIN_SCREEN: [u32; 2] = [1024, 640];

/// `min_screen` below this is refused: the trial's view cannot show its panels.
const SMALLEST_SCREEN: [u32; 2] = [640, 400];

/// One condition: the matches of its trials.
#[derive(Clone, Debug)]
pub struct Condition {
    /// Its name, also its template's.
    pub name: String,
    /// What the trial page shows as its title.
    pub title: Option<String>,
    /// The map.
    pub map: Map,
    /// People per match (1 or 2).
    pub humans: usize,
    /// Built-in teammates per match.
    pub teammates: usize,
    /// The teammates' strategy.
    pub strategy: Strategy,
    /// Realtime or lockstep.
    pub mode: Mode,
    /// Ticks per second.
    pub tick_hz: u32,
    /// The trial's length in seconds.
    pub time_limit_s: u64,
    /// Which messages players may send.
    pub language: MessagePolicy,
    /// `own` (what the robot perceives) or `overview`.
    pub view: String,
    /// The briefing, as HTML.
    pub briefing_html: Option<String>,
    /// How long a person waits for a partner before a built-in agent takes the seat.
    pub partner_timeout_s: u64,
    /// Its first match's seed.
    pub seed: u64,
    /// At most this many of its matches at once.
    pub max_running: usize,
    /// A trial counts only if the participant's robot was still in the match at its end
    /// and moved in at least this many ticks (the match's ticks less the robot's idle
    /// ticks); otherwise it is given again.
    pub min_active_ticks: u64,
    /// Under mixed assignment, its group.
    pub between: Option<String>,
    /// At most this many participants (completers and those still going) play it.
    pub quota: Option<u64>,
}

/// A questionnaire item.
#[derive(Clone, Debug)]
pub struct Item {
    /// Its id (a column of the answers).
    pub id: String,
    /// The question.
    pub text: String,
    /// Whether it must be answered.
    pub required: bool,
    /// What it asks for (the API shows it as it is).
    pub kind: QuestionKind,
    /// The correct answer (a choice's option), for a pass mark.
    pub correct: Option<String>,
    /// Shown (and asked) only when an earlier item of the page has one of these answers.
    pub show_if: Option<ShowIf>,
    /// A matrix whose rows each participant sees in an order of their own.
    pub shuffle_rows: bool,
}

/// One page of the flow.
#[derive(Clone, Debug)]
pub enum Page {
    /// Asks for consent; declining ends the study for the participant.
    Consent {
        /// Title.
        title: String,
        /// Text, as HTML.
        html: String,
        /// The agree button.
        agree: String,
        /// The decline button.
        decline: String,
        /// The title after declining.
        declined_title: String,
        /// The text after declining, as HTML.
        declined_html: String,
        /// The platform's code for those who declined (e.g. Prolific's "no consent").
        declined_code: Option<String>,
        /// Where to send them after declining.
        declined_redirect: Option<String>,
    },
    /// Text to read.
    Instructions {
        /// Title.
        title: String,
        /// Text, as HTML.
        html: String,
    },
    /// The next condition of the participant's order.
    Trial {
        /// Title (default: `Task K of N`).
        title: Option<String>,
        /// Text shown before the condition's briefing, as HTML.
        html: Option<String>,
    },
    /// A practice round: a match of its own template, outside the conditions.
    Practice {
        /// Title.
        title: String,
        /// Text shown before its briefing, as HTML.
        html: Option<String>,
        /// Its template ([`Study::practices`]).
        practice: usize,
        /// What passes it (none: any played match).
        pass: Option<PracticePass>,
        /// How many times it may be failed and played again, this one included.
        attempts: u32,
    },
    /// Questions.
    Questionnaire {
        /// Its id (the answers' `questionnaire`).
        id: String,
        /// Title.
        title: String,
        /// Text above the items, as HTML.
        html: Option<String>,
        /// The items.
        items: Vec<Item>,
        /// At least this many items with a `correct` answer must be answered so.
        pass: Option<usize>,
        /// How many times it may be answered, this one included, while failing.
        attempts: u32,
        /// Whether each participant sees the items in an order of their own (an item with
        /// `show_if` stays right after the item it depends on).
        shuffle: bool,
    },
    /// The end: a completion code and/or a redirect.
    Final {
        /// Title.
        title: String,
        /// Text, as HTML, with `{participant}` and `{code}` to fill.
        html: String,
        /// The completion code.
        completion_code: Option<String>,
        /// Where to send the participant, with `{participant}` and `{code}` to fill.
        redirect: Option<String>,
    },
}

impl Page {
    /// The page's kind word.
    pub fn kind(&self) -> &'static str {
        match self {
            Page::Consent { .. } => "consent",
            Page::Instructions { .. } => "instructions",
            Page::Trial { .. } => "trial",
            Page::Practice { .. } => "practice",
            Page::Questionnaire { .. } => "questionnaire",
            Page::Final { .. } => "final",
        }
    }
}

/// Finds a map by a shipped map's name or a path (already made relative to the study file).
pub type MapLoader<'a> = &'a dyn Fn(&str) -> Result<Map, String>;

/// Reads and checks the study file at `path`; `maps` loads a map (a path in the file is
/// relative to the file).
pub fn load(path: &Path, maps: MapLoader<'_>) -> Result<Study, String> {
    let shown = path.display();
    let text = std::fs::read_to_string(path).map_err(|e| format!("cannot read {shown}: {e}"))?;
    parse(&text, path, maps).map_err(|e| format!("{shown}: {e}"))
}

/// Checks a study file's `text`; `path` is where it was read (files it names are relative
/// to it).
pub fn parse(text: &str, path: &Path, maps: MapLoader<'_>) -> Result<Study, String> {
    let file: StudyFile = toml::from_str(text).map_err(|e| format!("not a study file: {e}"))?;
    let base = path.parent().unwrap_or(Path::new("."));
    let s = file.study;
    check_word("study: name", &s.name)?;
    let order = match s.order.as_deref() {
        None | Some("counterbalanced") => Order::Counterbalanced,
        Some("fixed") => Order::Fixed,
        Some("random") => Order::Random,
        Some(other) => {
            return Err(format!(
                "study: order = '{other}': expected \"fixed\", \"counterbalanced\" or \"random\""
            ));
        }
    };
    let defaults = Defaults {
        seed: s.seed.unwrap_or(1),
        mode: parse_mode(s.mode.as_deref()).map_err(|e| format!("study: {e}"))?,
        tick_hz: s.tick_hz.unwrap_or(10),
        time_limit_s: s.time_limit_s.unwrap_or(600),
        max_running: s.max_running.unwrap_or(50),
        partner_timeout_s: s.partner_timeout_s.unwrap_or(120),
    };
    if file.conditions.is_empty() {
        return Err("no [[condition]]: a study needs at least one".into());
    }
    let mut conditions: Vec<Condition> = Vec::new();
    for (i, c) in file.conditions.into_iter().enumerate() {
        let at = format!("condition {} '{}'", i + 1, c.name);
        let condition = condition(c, base, &defaults, maps).map_err(|e| format!("{at}: {e}"))?;
        if conditions.iter().any(|other| other.name == condition.name) {
            return Err(format!("{at}: two conditions are named '{}'", condition.name));
        }
        conditions.push(condition);
    }
    let assignment = match s.assignment.as_deref() {
        None | Some("within") => Assignment::Within,
        Some("between") => Assignment::Between,
        Some("mixed") => Assignment::Mixed,
        Some(other) => {
            return Err(format!(
                "study: assignment = '{other}': expected \"within\", \"between\" or \"mixed\""
            ));
        }
    };
    let balance = match s.balance.as_deref() {
        // Within subjects balanced over arrivals, as studies always were.
        None if assignment == Assignment::Within => Balance::Arrivals,
        None | Some("completers") => Balance::Completers,
        Some("arrivals") => Balance::Arrivals,
        Some(other) => {
            return Err(format!("study: balance = '{other}': expected \"arrivals\" or \"completers\""));
        }
    };
    let groups = groups(&conditions, assignment)?;
    let mut practices: Vec<Condition> = Vec::new();
    let mut pages = Vec::new();
    let count = file.pages.len();
    for (i, p) in file.pages.into_iter().enumerate() {
        let made = page(p, base, i, &defaults, maps).map_err(|e| format!("page {}: {e}", i + 1))?;
        let page = match made {
            Made::Page(page) => *page,
            Made::Practice(page, practice) => {
                let taken = conditions.iter().chain(&practices).any(|c| c.name == practice.name);
                if taken {
                    return Err(format!(
                        "page {} (practice): id = '{}' is taken by a condition or another practice",
                        i + 1,
                        practice.name
                    ));
                }
                let mut page = *page;
                if let Page::Practice { practice: at, .. } = &mut page {
                    *at = practices.len();
                }
                practices.push(*practice);
                page
            }
        };
        let at = format!("page {} ({})", i + 1, page.kind());
        match &page {
            Page::Consent { .. } if i != 0 => return Err(format!("{at}: consent must be the first page")),
            Page::Final { .. } if i + 1 != count => return Err(format!("{at}: final must be the last page")),
            _ => {}
        }
        pages.push(page);
    }
    if !matches!(pages.last(), Some(Page::Final { .. })) {
        return Err("the last [[page]] must be kind = \"final\" (the completion code or redirect)".into());
    }
    let trials = pages.iter().filter(|p| matches!(p, Page::Trial { .. })).count();
    for group in &groups {
        let k = group.conditions.len();
        if trials == 0 || trials % k != 0 {
            let of = match assignment {
                Assignment::Within => String::new(),
                _ => format!(" in group '{}'", group.name),
            };
            return Err(format!(
                "{} and {}{of}: give one trial page per condition (or two, three, ... each: the order \
                 then repeats)",
                plural(trials, "trial page"),
                plural(k, "condition")
            ));
        }
    }
    let screen_out = screen_out(file.screen_out, base)?;
    if let Some(bonus) = &file.bonus {
        bonus.check()?;
    }
    let dropout_after_s = s.dropout_after_s.unwrap_or(30 * 60);
    let [min_width, min_height] = s.min_screen.unwrap_or(DEFAULT_MIN_SCREEN);
    if min_width < SMALLEST_SCREEN[0] || min_height < SMALLEST_SCREEN[1] {
        return Err(format!(
            "study: min_screen = [{min_width}, {min_height}]: the trial's view needs at least \
             [{}, {}] (width, height in CSS pixels)",
            SMALLEST_SCREEN[0], SMALLEST_SCREEN[1]
        ));
    }
    let screen =
        ScreenRequirement { min_width, min_height, allow_touch_only: s.allow_touch_only.unwrap_or(false) };
    let study = Study {
        name: s.name,
        title: s.title.unwrap_or_else(|| "Study".into()),
        seed: defaults.seed,
        order,
        assignment,
        balance,
        dropout_after_ms: dropout_after_s.saturating_mul(1000),
        full_text: s.full_text.unwrap_or_else(|| {
            "This study has all the participants it needs, so it cannot take you. Thank you for your \
             interest."
                .into()
        }),
        conditions,
        groups,
        practices,
        pages,
        screen_out,
        screen,
        text: text.to_string(),
    };
    // What the conditions' matches are run with is in range (partner_timeout_s, ...):
    // said now, not when the first participant's match cannot be made.
    for t in study.templates() {
        let in_range = t.setup.game.validate().map_err(|e| e.to_string()).and_then(|()| t.config.check());
        in_range.map_err(|e| format!("condition '{}': {e}", t.name))?;
    }
    Ok(study)
}

struct Defaults {
    seed: u64,
    mode: Mode,
    tick_hz: u32,
    time_limit_s: u64,
    max_running: usize,
    partner_timeout_s: u64,
}

fn plural(n: usize, what: &str) -> String {
    if n == 1 { format!("1 {what}") } else { format!("{n} {what}s") }
}

fn parse_mode(mode: Option<&str>) -> Result<Mode, String> {
    match mode {
        None | Some("realtime") => Ok(Mode::Realtime),
        Some("lockstep") => Ok(Mode::Lockstep),
        Some(other) => Err(format!("mode = '{other}': expected \"realtime\" or \"lockstep\"")),
    }
}

/// Names that go into URLs, file names and CSV cells unchanged.
fn check_word(what: &str, word: &str) -> Result<(), String> {
    let ok = !word.is_empty()
        && word.len() <= 64
        && word.chars().all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_');
    if ok { Ok(()) } else { Err(format!("{what} = '{word}': use 1 to 64 letters, digits, '-' or '_'")) }
}

fn condition(c: ConditionFile, base: &Path, d: &Defaults, maps: MapLoader<'_>) -> Result<Condition, String> {
    check_word("name", &c.name)?;
    let spec = c.map.unwrap_or_else(|| "default".into());
    // A path is relative to the study file; a shipped name stays a name.
    let path = base.join(&spec);
    let resolved = if path.exists() { path.to_string_lossy().into_owned() } else { spec.clone() };
    let map = maps(&resolved).map_err(|e| format!("map = '{spec}': {e}"))?;
    let humans = c.humans.unwrap_or(1);
    if !(1..=2).contains(&humans) {
        return Err(format!("humans = {humans}: expected 1 or 2"));
    }
    let teammates = c.teammates.unwrap_or(2);
    if humans + teammates > map.spawns().len() {
        return Err(format!(
            "humans + teammates = {} but map '{}' has {} spawn points",
            humans + teammates,
            map.name(),
            map.spawns().len()
        ));
    }
    let strategy = match c.strategy.as_deref() {
        None => Strategy::Cooperative,
        Some(name) => Strategy::named(name).ok_or_else(|| {
            let known: Vec<&str> = Strategy::ALL.iter().map(|s| s.name()).collect();
            format!("strategy = '{name}': expected one of {}", known.join(", "))
        })?,
    };
    let tick_hz = c.tick_hz.unwrap_or(d.tick_hz);
    let game = bw4t_sim::MatchConfig { ticks_per_second: tick_hz, ..bw4t_sim::MatchConfig::default() };
    game.validate().map_err(|e| format!("tick_hz = {tick_hz}: {e}"))?;
    let time_limit_s = c.time_limit_s.unwrap_or(d.time_limit_s);
    if time_limit_s == 0 {
        return Err("time_limit_s = 0: a trial needs a time limit".into());
    }
    let language = MessagePolicy { kinds: c.kinds, free_text: c.free_text.unwrap_or(true) };
    language.check().map_err(|e| format!("kinds: {e}"))?;
    let view = c.view.unwrap_or_else(|| "own".into());
    if view != "own" && view != "overview" {
        return Err(format!("view = '{view}': expected \"own\" or \"overview\""));
    }
    let briefing = markdown(c.briefing, c.briefing_file, base, "briefing")?;
    let max_running = c.max_running.unwrap_or(d.max_running);
    if max_running == 0 {
        return Err("max_running = 0: at least one match must be able to run".into());
    }
    Ok(Condition {
        name: c.name,
        title: c.title,
        map,
        humans,
        teammates,
        strategy,
        mode: parse_mode(c.mode.as_deref()).map(|m| if c.mode.is_some() { m } else { d.mode })?,
        tick_hz,
        time_limit_s,
        language,
        view,
        briefing_html: briefing,
        partner_timeout_s: c.partner_timeout_s.unwrap_or(d.partner_timeout_s),
        seed: c.seed.unwrap_or(d.seed),
        max_running,
        // A robot that never moved was not played (a player who left at once keeps their
        // seat, idle, to the end); a study of talking alone sets 0.
        min_active_ticks: c.min_active_ticks.unwrap_or(1),
        between: c.between,
        quota: c.quota,
    })
}

/// The groups of `conditions` one participant each is given, checked for `assignment`.
fn groups(conditions: &[Condition], assignment: Assignment) -> Result<Vec<Group>, String> {
    let all = (0..conditions.len()).collect::<Vec<_>>();
    for (i, c) in conditions.iter().enumerate() {
        let at = format!("condition {} '{}'", i + 1, c.name);
        match (&c.between, assignment) {
            (Some(group), Assignment::Mixed) => check_word(&format!("{at}: between"), group)?,
            (None, Assignment::Mixed) => {
                return Err(format!(
                    "{at}: between: under assignment = \"mixed\" every condition names its group"
                ));
            }
            (Some(_), _) => {
                return Err(format!("{at}: between: only under assignment = \"mixed\""));
            }
            (None, _) => {}
        }
        if c.quota == Some(0) {
            return Err(format!("{at}: quota = 0: a condition nobody may play"));
        }
    }
    Ok(match assignment {
        Assignment::Within => vec![Group { name: "all".into(), conditions: all }],
        Assignment::Between => conditions
            .iter()
            .enumerate()
            .map(|(i, c)| Group { name: c.name.clone(), conditions: vec![i] })
            .collect(),
        Assignment::Mixed => {
            let mut groups: Vec<Group> = Vec::new();
            for (i, c) in conditions.iter().enumerate() {
                let name = c.between.clone().unwrap_or_default();
                match groups.iter_mut().find(|g| g.name == name) {
                    Some(group) => group.conditions.push(i),
                    None => groups.push(Group { name, conditions: vec![i] }),
                }
            }
            groups
        }
    })
}

/// `[screen_out]`, checked (a default one if the file has none).
fn screen_out(file: Option<ScreenOutFile>, base: &Path) -> Result<ScreenOut, String> {
    let file = file.unwrap_or(ScreenOutFile {
        title: None,
        text: None,
        file: None,
        completion_code: None,
        redirect: None,
    });
    check_redirect(file.redirect.as_deref()).map_err(|e| format!("screen_out: {e}"))?;
    Ok(ScreenOut {
        title: file.title.unwrap_or_else(|| "Thank you".into()),
        html: markdown(file.text, file.file, base, "screen_out")
            .map_err(|e| format!("screen_out: {e}"))?
            .unwrap_or_else(|| to_html("You cannot go on with this study. Thank you for your time.")),
        completion_code: file.completion_code,
        redirect: file.redirect,
    })
}

fn check_redirect(url: Option<&str>) -> Result<(), String> {
    match url {
        Some(url) if !(url.starts_with("https://") || url.starts_with("http://")) => {
            Err(format!("redirect = '{url}': expected an http(s) URL"))
        }
        _ => Ok(()),
    }
}

/// A page as read: a practice page comes with its template.
enum Made {
    Page(Box<Page>),
    Practice(Box<Page>, Box<Condition>),
}

/// Markdown given inline (`key`) or in a file (`key_file`/`file`), as HTML.
fn markdown(
    inline: Option<String>,
    file: Option<PathBuf>,
    base: &Path,
    key: &str,
) -> Result<Option<String>, String> {
    match (inline, file) {
        (Some(_), Some(_)) => Err(format!("give {key} text or a file, not both")),
        (Some(text), None) => Ok(Some(to_html(&text))),
        (None, Some(file)) => {
            let path = base.join(&file);
            let text = std::fs::read_to_string(&path)
                .map_err(|e| format!("file = '{}': cannot read {}: {e}", file.display(), path.display()))?;
            Ok(Some(to_html(&text)))
        }
        (None, None) => Ok(None),
    }
}

fn page(p: PageFile, base: &Path, index: usize, d: &Defaults, maps: MapLoader<'_>) -> Result<Made, String> {
    let text =
        |text, file, kind: &str| markdown(text, file, base, kind).map_err(|e| format!("({kind}): {e}"));
    let page = match p {
        PageFile::Practice {
            id,
            title,
            text: t,
            file,
            map,
            teammates,
            strategy,
            time_limit_s,
            tick_hz,
            mode,
            kinds,
            free_text,
            view,
            briefing,
            briefing_file,
            seed,
            min_active_ticks,
            pass,
            pass_sequence,
            attempts,
        } => {
            let id = id.unwrap_or_else(|| format!("practice{}", index + 1));
            check_word("(practice): id", &id)?;
            let pass = match (pass.as_deref(), pass_sequence) {
                (Some(_), Some(_)) => return Err("(practice): give pass or pass_sequence, not both".into()),
                (Some("completed"), None) => Some(PracticePass::Completed),
                (Some(other), None) => {
                    return Err(format!("(practice): pass = '{other}': expected \"completed\""));
                }
                (None, Some(0)) => return Err("(practice): pass_sequence = 0: nobody could fail".into()),
                (None, Some(n)) => Some(PracticePass::Sequence(n)),
                (None, None) => None,
            };
            let practice = ConditionFile {
                name: id.clone(),
                map,
                humans: Some(1),
                teammates,
                strategy,
                time_limit_s,
                tick_hz,
                mode,
                kinds,
                free_text,
                view,
                briefing,
                briefing_file,
                seed,
                min_active_ticks,
                ..ConditionFile::default()
            };
            let practice =
                condition(practice, base, d, maps).map_err(|e| format!("(practice '{id}'): {e}"))?;
            let page = Page::Practice {
                title: title.unwrap_or_else(|| "Practice".into()),
                html: text(t, file, "practice")?,
                // Its index is set by the caller, which keeps the list.
                practice: 0,
                pass,
                attempts: attempts_of(attempts, "practice")?,
            };
            return Ok(Made::Practice(Box::new(page), Box::new(practice)));
        }
        other => other,
    };
    Ok(Made::Page(Box::new(match page {
        PageFile::Practice { .. } => unreachable!("taken above"),
        PageFile::Consent {
            title,
            text: t,
            file,
            agree,
            decline,
            declined_title,
            declined_text,
            declined_code,
            declined_redirect,
        } => {
            check_redirect(declined_redirect.as_deref()).map_err(|e| format!("(consent): declined_{e}"))?;
            Page::Consent {
                title: title.unwrap_or_else(|| "Consent".into()),
                html: text(t, file, "consent")?.ok_or("(consent): give the consent form as text or file")?,
                agree: agree.unwrap_or_else(|| "I agree".into()),
                decline: decline.unwrap_or_else(|| "I do not agree".into()),
                declined_title: declined_title.unwrap_or_else(|| "Thank you".into()),
                declined_html: to_html(
                    declined_text
                        .as_deref()
                        .unwrap_or("You did not consent, so the study ends here. You may close this page."),
                ),
                declined_code,
                declined_redirect,
            }
        }
        PageFile::Instructions { title, text: t, file } => Page::Instructions {
            title: title.unwrap_or_else(|| "Instructions".into()),
            html: text(t, file, "instructions")?.ok_or("(instructions): give the text as text or file")?,
        },
        PageFile::Trial { title, text: t, file } => Page::Trial { title, html: text(t, file, "trial")? },
        PageFile::Questionnaire { id, title, text: t, file, items, pass, attempts, shuffle } => {
            let id = id.unwrap_or_else(|| format!("page{}", index + 1));
            check_word("(questionnaire): id", &id)?;
            if items.is_empty() {
                return Err(format!("(questionnaire '{id}'): no [[page.item]]"));
            }
            let mut checked: Vec<Item> = Vec::new();
            for item in items {
                let item = self::item(item, &checked).map_err(|e| format!("(questionnaire '{id}'): {e}"))?;
                if checked.iter().any(|other| other.id == item.id) {
                    return Err(format!("(questionnaire '{id}'): two items are named '{}'", item.id));
                }
                checked.push(item);
            }
            let scored = checked.iter().filter(|i| i.correct.is_some()).count();
            match pass {
                Some(0) => return Err(format!("(questionnaire '{id}'): pass = 0: nobody could fail")),
                Some(n) if n > scored => {
                    return Err(format!(
                        "(questionnaire '{id}'): pass = {n} but only {scored} of its items give a correct answer"
                    ));
                }
                None if attempts.is_some() => {
                    return Err(format!(
                        "(questionnaire '{id}'): attempts: only with a pass mark (pass = N)"
                    ));
                }
                _ => {}
            }
            Page::Questionnaire {
                title: title.unwrap_or_else(|| "Questions".into()),
                html: text(t, file, "questionnaire")?,
                attempts: attempts_of(attempts, &format!("questionnaire '{id}'"))?,
                id,
                items: checked,
                pass,
                shuffle: shuffle.unwrap_or(false),
            }
        }
        PageFile::Final { title, text: t, file, completion_code, redirect } => {
            check_redirect(redirect.as_deref()).map_err(|e| format!("(final): {e}"))?;
            Page::Final {
                title: title.unwrap_or_else(|| "Thank you".into()),
                html: text(t, file, "final")?.unwrap_or_else(|| to_html("Thank you for taking part.")),
                completion_code,
                redirect,
            }
        }
    })))
}

fn attempts_of(attempts: Option<u32>, page: &str) -> Result<u32, String> {
    match attempts {
        Some(0) => Err(format!("({page}): attempts = 0: at least one")),
        Some(n) => Ok(n),
        None => Ok(1),
    }
}

/// An item, checked; `earlier` are the page's items before it (what `show_if` may name).
fn item(item: ItemFile, earlier: &[Item]) -> Result<Item, String> {
    let mut correct = None;
    let mut shuffle_rows = false;
    let (id, text, required, kind, show_if) = match item {
        ItemFile::Likert { id, text, scale, labels, required, show_if } => {
            let (scale, labels) = likert(&id, scale, labels)?;
            (id, text, required, QuestionKind::Likert { scale, labels }, show_if)
        }
        ItemFile::Choice { id, text, options, required, correct: right, show_if } => {
            if options.len() < 2 {
                return Err(format!("item '{id}': options: give at least 2"));
            }
            if let Some(right) = &right {
                if !options.contains(right) {
                    return Err(format!("item '{id}': correct = '{right}': not one of its options"));
                }
            }
            correct = right;
            (id, text, required, QuestionKind::Choice { options }, show_if)
        }
        ItemFile::Text { id, text, multiline, maxlength, required, show_if } => {
            if let Some(n) = maxlength.filter(|n| !(1..=MAX_TEXT).contains(n)) {
                return Err(format!("item '{id}': maxlength = {n}: expected 1 to {MAX_TEXT} characters"));
            }
            let kind = QuestionKind::Text { multiline: multiline.unwrap_or(false), maxlength };
            (id, text, required, kind, show_if)
        }
        ItemFile::Number { id, text, min, max, integer, unit, required, show_if } => {
            let integer = integer.unwrap_or(false);
            for (key, end) in [("min", min), ("max", max)] {
                match end {
                    Some(n) if !n.is_finite() => {
                        return Err(format!("item '{id}': {key} = {n}: not a number"));
                    }
                    Some(n) if integer && n.fract() != 0.0 => {
                        return Err(format!(
                            "item '{id}': {key} = {n}: an integer item's ends are whole numbers"
                        ));
                    }
                    _ => {}
                }
            }
            if let (Some(min), Some(max)) = (min, max) {
                if min > max {
                    return Err(format!("item '{id}': min = {min} is above max = {max}"));
                }
            }
            if unit.as_deref().is_some_and(|u| u.trim().is_empty()) {
                return Err(format!("item '{id}': unit = '': leave it out or name the unit"));
            }
            (id, text, required, QuestionKind::Number { min, max, integer, unit }, show_if)
        }
        ItemFile::Matrix {
            id,
            text,
            rows,
            scale,
            labels,
            options,
            shuffle_rows: shuffled,
            required,
            show_if,
        } => {
            if rows.is_empty() {
                return Err(format!("item '{id}': rows: give at least 1 statement"));
            }
            if let Some(blank) = rows.iter().position(|r| r.trim().is_empty()) {
                return Err(format!("item '{id}': rows: row {} is empty", blank + 1));
            }
            if let Some((i, row)) = rows.iter().enumerate().find(|(i, r)| rows[..*i].contains(r)) {
                return Err(format!("item '{id}': rows: row {} '{row}' is there twice", i + 1));
            }
            let (scale, labels, options) = match options {
                Some(_) if scale.is_some() || labels.is_some() => {
                    return Err(format!("item '{id}': give options or a scale (scale, labels), not both"));
                }
                Some(options) if options.len() < 2 => {
                    return Err(format!("item '{id}': options: give at least 2"));
                }
                Some(options) => (None, None, Some(options)),
                None => {
                    let (scale, labels) = likert(&id, scale, labels)?;
                    (Some(scale), Some(labels), None)
                }
            };
            shuffle_rows = shuffled.unwrap_or(false);
            let rows = rows
                .into_iter()
                .enumerate()
                .map(|(i, text)| MatrixRow { key: (i + 1).to_string(), text })
                .collect();
            (id, text, required, QuestionKind::Matrix { rows, scale, labels, options }, show_if)
        }
    };
    check_word("item id", &id)?;
    let show_if = match show_if {
        Some(rule) => Some(self::show_if(rule, earlier).map_err(|e| format!("item '{id}': show_if: {e}"))?),
        None => None,
    };
    Ok(Item { id, text, required: required.unwrap_or(true), kind, correct, show_if, shuffle_rows })
}

/// A Likert scale's points (2 to 11, 7 if not given) and end labels (none if not given).
fn likert(id: &str, scale: Option<u32>, labels: Option<Vec<String>>) -> Result<(u32, [String; 2]), String> {
    let scale = scale.unwrap_or(7);
    if !(2..=11).contains(&scale) {
        return Err(format!("item '{id}': scale = {scale}: expected 2 to 11 points"));
    }
    let labels = match labels {
        None => [String::new(), String::new()],
        Some(labels) => <[String; 2]>::try_from(labels)
            .map_err(|l| format!("item '{id}': labels: give 2 (left and right), not {}", l.len()))?,
    };
    Ok((scale, labels))
}

/// A `show_if`, checked: it names an earlier item of the page (not a matrix), and each of
/// its answers is one that item takes.
fn show_if(rule: ShowIfFile, earlier: &[Item]) -> Result<ShowIf, String> {
    let Some(target) = earlier.iter().find(|i| i.id == rule.item) else {
        return Err(format!("item = '{}': not an earlier item of this page", rule.item));
    };
    if matches!(target.kind, QuestionKind::Matrix { .. }) {
        return Err(format!("item = '{}': a matrix's answer cannot be compared", rule.item));
    }
    let (key, any_of) = match (rule.equals, rule.any_of) {
        (Some(_), Some(_)) => return Err("give equals or in, not both".into()),
        (None, None) => return Err("give equals = VALUE or in = [VALUE, ...]".into()),
        (None, Some(list)) if list.is_empty() => return Err("in = []: give at least one answer".into()),
        (Some(one), None) => ("equals", vec![one]),
        (None, Some(list)) => ("in", list),
    };
    any_of
        .into_iter()
        .map(|wanted| {
            let shown = wanted.to_string();
            let value = serde_json::to_value(wanted).map_err(|e| format!("{key} = {shown}: {e}"))?;
            match value_of(&target.id, &target.kind, &value) {
                Ok(Some(_)) => Ok(value),
                Ok(None) => Err(format!("{key} = {shown}: an empty answer is no answer")),
                Err(why) => {
                    Err(format!("{key} = {shown}: item '{}' never has this answer ({why})", target.id))
                }
            }
        })
        .collect::<Result<Vec<Value>, String>>()
        .map(|any_of| ShowIf { item: target.id.clone(), any_of })
}

impl Study {
    /// The arena's templates: one per condition, named as it, its matches made as
    /// participants ask (`hello.template`), labelled with the study and the condition,
    /// replays kept.
    pub fn templates(&self) -> Vec<Template> {
        self.conditions.iter().chain(&self.practices).map(|c| self.template(c)).collect()
    }

    fn template(&self, c: &Condition) -> Template {
        let mut setup = MatchSetup::builtin_team(c.map.clone(), c.teammates, c.strategy);
        setup.seed = c.seed;
        setup.game.ticks_per_second = c.tick_hz;
        setup.max_ticks = Some(c.time_limit_s * u64::from(c.tick_hz));
        setup.seats.extend(std::iter::repeat_with(Seat::open).take(c.humans));
        let mut config = HostConfig::new();
        config.name = c.name.clone();
        // Nobody watches a condition's match but the operator, and the participants of a
        // condition whose view is the whole map (their trial page gives them this token).
        config.spectator_token = Some(bw4t_server::random_token());
        config.mode = c.mode;
        config.language = c.language.clone();
        config.labels =
            BTreeMap::from([("study".into(), self.name.clone()), ("condition".into(), c.name.clone())]);
        if c.humans > 1 {
            // A person whose partner does not come plays with a built-in agent instead.
            config.start_timeout = Some(Duration::from_secs(c.partner_timeout_s));
            config.fill = Some(c.strategy);
        }
        Template {
            name: c.name.clone(),
            maps: vec![c.map.clone()],
            setup,
            config,
            names: Vec::new(),
            max_running: c.max_running,
            on_end: OnEnd::Stay,
            replays: true,
            lateness: None,
            invited_only: true,
        }
    }

    /// How many trial pages there are.
    pub fn trials(&self) -> usize {
        self.pages.iter().filter(|p| matches!(p, Page::Trial { .. })).count()
    }
}
