//! The arena: every match a server hosts, from its making to its result. Matches are made
//! from templates (at the start, when a player asks for one, when one ends and its
//! template says to go on) or by the operator; each runs as its own host task, so a
//! failing match ends alone. Connections are routed to a match by their `hello`
//! ([`route`]); finished matches go to the results store ([`store`]).

mod route;
mod store;

use std::collections::{BTreeMap, VecDeque};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

use bw4t_agents::{MatchSetup, Player, Seat};
use bw4t_map::Map;
use bw4t_protocol::{
    EndReason, MapLayout, MatchResult, MatchState, MatchSummary, Mode, ServerInfo, TemplateInfo, Watch,
};
use bw4t_tournament::Row;
use tokio::sync::{mpsc, oneshot, watch};

use bw4t_host::{HostConfig, HostStatus, MatchHost};

use crate::config::{ServerConfig, ServerError};
use crate::driver;
use crate::events::{Control, Event};
use crate::lateness::TickLateness;

pub(crate) use route::{QueueNews, Route, Routed};
pub use store::ResultsStore;

/// What a template does when one of its matches ends.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum OnEnd {
    /// The match stays finished.
    #[default]
    Stay,
    /// A new match of the same name starts, on the next seed.
    Restart,
    /// A new match of the same name starts on the next map of the template's list (after
    /// the last, the first again), on the next seed.
    Next,
}

impl OnEnd {
    /// Every value, by its name in a configuration file.
    pub const NAMES: &[(&str, OnEnd)] =
        &[("stay", OnEnd::Stay), ("restart", OnEnd::Restart), ("next", OnEnd::Next)];
}

/// A recipe for matches: what they play and how they are run, which matches to make and
/// what to do when one ends.
#[derive(Clone)]
pub struct Template {
    /// Its name (`hello.template`).
    pub name: String,
    /// What its matches play: `setup.map` is the first map, `setup.seed` the first
    /// match's seed (the n-th match made gets `seed + n`), and `setup.seats` every seat,
    /// built-in ones first and open ones after.
    pub setup: MatchSetup,
    /// How its matches are run.
    pub config: HostConfig,
    /// The maps its matches play in turn (`OnEnd::Next`), the first being `setup.map`.
    pub maps: Vec<Map>,
    /// Matches made at the start under these names (a classroom's teams). Without names,
    /// matches are made when players ask for the template, named `TEMPLATE-N`.
    pub names: Vec<String>,
    /// At most this many of its matches run at once; players beyond wait in a queue.
    pub max_running: usize,
    /// What happens when one of its matches ends.
    pub on_end: OnEnd,
    /// Keep a replay of each match (in the results directory).
    pub replays: bool,
    /// Where its realtime matches' tick lateness is counted, if anywhere.
    pub lateness: Option<Arc<TickLateness>>,
}

impl Template {
    /// A template of one match named `name`, made at the start, of `setup` run as `config`.
    pub fn single(name: &str, setup: MatchSetup, config: HostConfig, on_end: OnEnd) -> Template {
        Template {
            name: name.to_string(),
            maps: vec![setup.map.clone()],
            setup,
            config,
            names: vec![name.to_string()],
            max_running: 1,
            on_end,
            replays: false,
            lateness: None,
        }
    }
}

/// Finds a map by name for matches the operator makes through the API.
pub type MapLookup = Arc<dyn Fn(&str) -> Result<Map, String> + Send + Sync>;

/// How the server runs, besides its templates.
#[derive(Clone)]
pub struct ArenaConfig {
    /// The templates, made into matches at the start when they name them.
    pub templates: Vec<Template>,
    /// What a `hello` that names no match joins: a match's or a template's name.
    pub default: Option<String>,
    /// Where results, the index and replays are written; `None`: kept in memory only.
    pub results: ResultsStore,
    /// How connections are treated: limits, origins, the operator's secret.
    pub server: ServerConfig,
    /// Stop when no match is live any more (after the first has ended): `--once`.
    pub once: bool,
    /// Maps the API may make matches on, by name; `None`: only the templates' maps.
    pub maps: Option<MapLookup>,
    /// Where the replay of the first match made goes (`bw4t serve --replay FILE`).
    pub first_replay: FirstReplay,
}

/// A replay writer taken by the first match made, once.
pub type FirstReplay = Arc<Mutex<Option<(Box<dyn std::io::Write + Send>, String)>>>;

impl ArenaConfig {
    /// A server with these templates and the default limits (those of [`ServerConfig`]).
    pub fn new(templates: Vec<Template>) -> ArenaConfig {
        ArenaConfig {
            templates,
            default: Some(bw4t_host::DEFAULT_MATCH.to_string()),
            results: ResultsStore::in_memory(),
            server: ServerConfig::default(),
            once: false,
            maps: None,
            first_replay: Arc::default(),
        }
    }
}

/// A match being made: what it plays, how it is run and what it starts with.
pub struct MatchSpec {
    /// What it plays.
    pub setup: MatchSetup,
    /// How it is run, `name` and `template` included.
    pub config: HostConfig,
    /// Where its replay goes, with the program name written into it.
    pub replay: Option<(Box<dyn std::io::Write + Send>, String)>,
    /// Names of reserved seats whose player will not come.
    pub gone_seats: Option<mpsc::Receiver<String>>,
}

/// A match the arena is running.
struct LiveMatch {
    /// Unique among every match the server ever ran: `NAME.RUN`.
    id: String,
    run: u64,
    template: Option<String>,
    events: mpsc::Sender<Event>,
    started: Arc<AtomicBool>,
    /// Players routed to it while it waits whose connections are still open.
    claims: usize,
    /// Players it waits for besides its built-in seats.
    open_seats: usize,
    map: Arc<Map>,
    mode: Mode,
    seed: u64,
    robots: usize,
    watch_open: bool,
    /// Its template's `on_end` applies when it ends (not to matches the operator made).
    goes_on: bool,
}

/// A finished match, as the lobby lists it.
#[derive(Clone, Debug)]
struct Finished {
    name: String,
    id: String,
    run: u64,
    template: Option<String>,
    map: String,
    mode: Mode,
    seed: u64,
    robots: usize,
    players: Vec<String>,
    tick: u64,
    sequence: (usize, usize),
    end_reason: EndReason,
    watch_open: bool,
}

/// Matches ended since the server started, counted together (by template, or by name for a
/// match made without one).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Totals {
    /// Matches ended, those that failed included.
    pub ended: u64,
    /// Matches that completed the sequence.
    pub completed: u64,
    /// Matches that failed inside the server.
    pub failed: u64,
    /// Ticks the ended matches made.
    pub ticks: u64,
}

/// How many finished matches the lobby keeps.
const FINISHED_KEPT: usize = 100;

struct TemplateState {
    template: Arc<Template>,
    /// Matches made so far (the next one's number and seed offset).
    made: u64,
    /// Its matches running now.
    running: usize,
    /// Players waiting for a seat, oldest first.
    queue: VecDeque<mpsc::Sender<QueueNews>>,
}

#[derive(Default)]
struct State {
    templates: BTreeMap<String, TemplateState>,
    live: BTreeMap<String, LiveMatch>,
    finished: VecDeque<Finished>,
    /// Runs per match name.
    runs: BTreeMap<String, u64>,
    /// The n-th match finished (the index's `index`).
    ended: u64,
    /// Whether any match has ended (for `once`).
    any_ended: bool,
    /// Counts of the matches ended, by template (or name).
    totals: BTreeMap<String, Totals>,
    stopping: bool,
}

struct Inner {
    config: ArenaConfig,
    state: Mutex<State>,
    /// Connection ids, for the protocol and web ports alike.
    ids: AtomicU64,
    /// Becomes true when the server stops: every match ends.
    shutdown: watch::Sender<bool>,
    /// Counts live matches, for waiting until all have ended.
    live_count: watch::Sender<usize>,
    /// Counts matches ended.
    ended_count: watch::Sender<u64>,
    /// The outcomes of the last [`FINISHED_KEPT`] matches, in the order they ended (for
    /// `serve` and tests; the results store keeps the rest).
    outcomes: Mutex<VecDeque<(String, Result<MatchResult, String>)>>,
    /// Map layouts (`/map.json`), by map name.
    layouts: Mutex<BTreeMap<String, Arc<str>>>,
}

/// A handle on the server's matches; clones share them.
#[derive(Clone)]
pub struct Arena {
    inner: Arc<Inner>,
}

/// Why the arena could not make a match.
#[derive(Debug, thiserror::Error)]
pub enum ArenaError {
    /// The match's settings or seats are wrong.
    #[error(transparent)]
    Server(#[from] ServerError),
    /// A live match has that name.
    #[error("a match named '{0}' is running")]
    NameTaken(String),
    /// No template of that name.
    #[error("no template named '{0}'")]
    UnknownTemplate(String),
    /// No live match of that name.
    #[error("no live match named '{0}'")]
    UnknownMatch(String),
    /// A bad request: the message says what is wrong.
    #[error("{0}")]
    Bad(String),
    /// The server is stopping.
    #[error("the server is stopping")]
    Stopping,
}

impl Arena {
    /// An arena with `config`; its templates' named matches are made at once. Must be
    /// called inside a tokio runtime.
    pub fn start(config: ArenaConfig) -> Result<Arena, ArenaError> {
        let mut names = std::collections::BTreeSet::new();
        for template in &config.templates {
            if template.maps.is_empty() {
                return Err(ArenaError::Bad(format!("template '{}' has no map", template.name)));
            }
            for name in &template.names {
                if !names.insert(name.clone()) {
                    return Err(ArenaError::Bad(format!("two matches are named '{name}'")));
                }
            }
        }
        let templates = config
            .templates
            .iter()
            .map(|t| {
                let state = TemplateState {
                    template: Arc::new(t.clone()),
                    made: 0,
                    running: 0,
                    queue: VecDeque::new(),
                };
                (t.name.clone(), state)
            })
            .collect();
        // Runs and the index go on from the results already kept, so ids stay unique.
        let (runs, ended) = config.results.history();
        let arena = Arena {
            inner: Arc::new(Inner {
                config,
                state: Mutex::new(State { templates, runs, ended, ..State::default() }),
                ids: AtomicU64::new(1),
                shutdown: watch::Sender::new(false),
                live_count: watch::Sender::new(0),
                ended_count: watch::Sender::new(0),
                outcomes: Mutex::new(VecDeque::new()),
                layouts: Mutex::new(BTreeMap::new()),
            }),
        };
        let starting: Vec<(String, String)> = arena
            .inner
            .config
            .templates
            .iter()
            .flat_map(|t| t.names.iter().map(|n| (t.name.clone(), n.clone())))
            .collect();
        for (template, name) in starting {
            let mut state = arena.lock();
            arena.make_from_template(&mut state, &template, Some(name))?;
        }
        Ok(arena)
    }

    /// Runs a match made from `spec` (not from a template): it stays finished when it ends.
    pub fn spawn(&self, spec: MatchSpec) -> Result<String, ArenaError> {
        let mut state = self.lock();
        self.launch(&mut state, spec, None, false)
    }

    /// The server's settings.
    pub fn config(&self) -> &ArenaConfig {
        &self.inner.config
    }

    /// A new connection id.
    pub(crate) fn next_conn(&self) -> u64 {
        self.inner.ids.fetch_add(1, Ordering::SeqCst)
    }

    fn lock(&self) -> MutexGuard<'_, State> {
        // A panic while the lock was held cannot leave the maps half-changed in a way that
        // matters more than stopping every match would.
        self.inner.state.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
    }

    /// Makes the next match of `template`, named `name` (or `TEMPLATE-N`).
    fn make_from_template(
        &self,
        state: &mut State,
        template: &str,
        name: Option<String>,
    ) -> Result<String, ArenaError> {
        let t =
            state.templates.get_mut(template).ok_or_else(|| ArenaError::UnknownTemplate(template.into()))?;
        let template = t.template.clone();
        let n = t.made;
        t.made += 1;
        let name = name.unwrap_or_else(|| format!("{}-{}", template.name, n + 1));
        let run = state.runs.get(&name).copied().unwrap_or(0) + 1;
        let mut config = template.config.clone();
        let mut setup = template.setup.clone();
        // `Next` walks the list by the match name's runs; otherwise every match plays the first map.
        let map_at =
            if template.on_end == OnEnd::Next { (run as usize - 1) % template.maps.len() } else { 0 };
        setup.map = template.maps[map_at].clone();
        setup.seed = setup.seed.wrapping_add(n);
        config.name = name;
        config.template = Some(template.name.clone());
        let spec = MatchSpec { setup, config, replay: None, gone_seats: None };
        self.launch(state, spec, Some(template), true)
    }

    /// Starts a match's host task.
    fn launch(
        &self,
        state: &mut State,
        spec: MatchSpec,
        template: Option<Arc<Template>>,
        goes_on: bool,
    ) -> Result<String, ArenaError> {
        if state.stopping {
            return Err(ArenaError::Stopping);
        }
        let MatchSpec { setup, mut config, replay, gone_seats } = spec;
        if state.live.contains_key(&config.name) {
            return Err(ArenaError::NameTaken(config.name));
        }
        if config.operator_token.is_none() {
            config.operator_token.clone_from(&self.inner.config.server.operator_token);
        }
        let name = config.name.clone();
        let run = state.runs.get(&name).copied().unwrap_or(0) + 1;
        let id = format!("{name}.{run}");
        config.id.clone_from(&id);
        // Its own replay, else the one `--replay` asked for (taken by the first match made),
        // else one in the results directory if its template keeps them.
        let replay = replay
            .or_else(|| self.inner.config.first_replay.lock().unwrap_or_else(|p| p.into_inner()).take())
            .or_else(|| {
                let kept = template.as_ref().is_some_and(|t| t.replays);
                kept.then(|| self.inner.config.results.replay_writer(&id)).flatten()
            });
        let open_seats = setup.seats.iter().filter(|s| matches!(s.player, Player::Open)).count();
        let (map, seed, robots) = (Arc::new(setup.map.clone()), setup.seed, setup.robots());
        let host = MatchHost::new(setup, config.clone(), replay, std::time::Instant::now())
            .map_err(ServerError::Host)?;
        state.runs.insert(name.clone(), run);
        let (events, events_rx) = mpsc::channel(driver::EVENT_QUEUE);
        let started = Arc::new(AtomicBool::new(false));
        let live = LiveMatch {
            id: id.clone(),
            run,
            template: template.as_ref().map(|t| t.name.clone()),
            events,
            started: started.clone(),
            claims: 0,
            open_seats,
            map: map.clone(),
            mode: config.mode,
            seed,
            robots,
            watch_open: config.token.is_none() && config.spectator_token.is_none(),
            goes_on,
        };
        if let Some(t) = template.as_ref().and_then(|t| state.templates.get_mut(&t.name)) {
            t.running += 1;
        }
        state.live.insert(name.clone(), live);
        self.inner.live_count.send_modify(|n| *n += 1);
        tracing::info!(target: "bw4t::arena", r#match = %name, id = %id, map = %map.name(), seed, "match made");
        let arena = self.clone();
        let mut stop = self.inner.shutdown.subscribe();
        let task_name = name.clone();
        let lateness = template.as_ref().and_then(|t| t.lateness.clone());
        tokio::spawn(async move {
            let shutdown = async move {
                let _ = stop.wait_for(|s| *s).await;
            };
            let outcome = driver::run(host, events_rx, gone_seats, started, lateness, shutdown).await;
            arena.record_end(&task_name, &id, outcome);
        });
        Ok(name)
    }

    /// Records a match's end and does what its template says next.
    fn record_end(&self, name: &str, id: &str, outcome: Result<MatchResult, String>) {
        let mut state = self.lock();
        let Some(live) = state.live.remove(name).filter(|l| l.id == id) else { return };
        state.ended += 1;
        state.any_ended = true;
        let template =
            live.template.as_ref().and_then(|t| state.templates.get(t)).map(|t| t.template.clone());
        let mut row = Row::unplayed(
            id.to_string(),
            state.ended,
            live.template.clone().unwrap_or_else(|| name.to_string()),
            live.map.name().to_string(),
            live.seed,
            live.robots,
        );
        row.repetition = u32::try_from(live.run.saturating_sub(1)).unwrap_or(u32::MAX);
        let (players, tick, sequence) = match &outcome {
            Ok(result) => {
                row.record(result);
                tracing::info!(target: "bw4t::arena", r#match = %name, id = %id, reason = %result.end_reason, ticks = result.ticks, "match ended");
                let players = result.per_robot.iter().map(|r| r.name.clone()).collect();
                (players, result.ticks, (result.sequence_index as usize, result.sequence.len()))
            }
            Err(why) => {
                row.error = Some(format!("the match failed in the server: {why}"));
                tracing::error!(target: "bw4t::arena", r#match = %name, id = %id, error = %why, "match failed");
                (Vec::new(), 0, (0, 0))
            }
        };
        row.replay = self.inner.config.results.replay_name(id, template.as_ref().is_some_and(|t| t.replays));
        self.inner.config.results.record(&row, outcome.as_ref().ok());
        let totals = state.totals.entry(row.team.clone()).or_default();
        totals.ended += 1;
        totals.completed += u64::from(row.completed);
        totals.failed += u64::from(outcome.is_err());
        totals.ticks += row.ticks;
        state.finished.push_front(Finished {
            name: name.to_string(),
            id: id.to_string(),
            run: live.run,
            template: live.template.clone(),
            map: live.map.name().to_string(),
            mode: live.mode,
            seed: live.seed,
            robots: live.robots,
            players,
            tick,
            sequence,
            end_reason: row.end_reason,
            watch_open: live.watch_open,
        });
        state.finished.truncate(FINISHED_KEPT);
        if let Some(t) = live.template.as_ref().and_then(|t| state.templates.get_mut(t)) {
            t.running = t.running.saturating_sub(1);
        }
        let mut outcomes = self.inner.outcomes.lock().unwrap_or_else(|p| p.into_inner());
        if outcomes.len() == FINISHED_KEPT {
            outcomes.pop_front();
        }
        outcomes.push_back((id.to_string(), outcome));
        drop(outcomes);
        if let Some(template) = template {
            if live.goes_on && template.on_end != OnEnd::Stay && !state.stopping && !self.inner.config.once {
                if let Err(e) = self.make_from_template(&mut state, &template.name, Some(name.to_string())) {
                    tracing::error!(target: "bw4t::arena", r#match = %name, error = %e, "match not restarted");
                }
            }
            self.serve_queue(&mut state, &template.name);
        }
        drop(state);
        self.inner.live_count.send_modify(|n| *n = n.saturating_sub(1));
        self.inner.ended_count.send_modify(|n| *n += 1);
    }

    /// How many matches have ended since the server started.
    pub fn ended_so_far(&self) -> u64 {
        *self.inner.ended_count.borrow()
    }

    /// Resolves once `n` matches have ended (in all, since the server started).
    pub async fn ended(&self, n: u64) {
        let mut count = self.inner.ended_count.subscribe();
        let _ = count.wait_for(|ended| *ended >= n).await;
    }

    /// Where every live and recently finished match is: the live ones by name, then the
    /// finished ones, newest first. Each live
    /// match answers for itself; one that does not answer at once is listed as waiting
    /// at tick 0.
    pub async fn list(&self, operator: bool) -> Vec<MatchSummary> {
        let (asks, finished) = {
            let state = self.lock();
            let asks: Vec<StatusAsked> =
                state.live.iter().map(|(name, live)| StatusAsked::of(name, live, operator)).collect();
            (asks, state.finished.iter().map(|f| summary_of_finished(f, operator)).collect::<Vec<_>>())
        };
        let mut out = Vec::with_capacity(asks.len() + finished.len());
        for asked in asks {
            out.push(asked.answered(operator).await);
        }
        out.extend(finished);
        out
    }

    /// One match's summary: the live one of that name, else the latest finished.
    pub async fn summary(&self, name: &str, operator: bool) -> Option<MatchSummary> {
        let asked = {
            let state = self.lock();
            match state.live.get(name) {
                Some(live) => StatusAsked::of(name, live, operator),
                None => {
                    let finished = state.finished.iter().find(|f| f.name == name);
                    return finished.map(|f| summary_of_finished(f, operator));
                }
            }
        };
        Some(asked.answered(operator).await)
    }

    /// Ends a live match as `interrupted`; returns its id once it has ended.
    pub async fn stop(&self, name: &str) -> Result<String, ArenaError> {
        let (events, id) = {
            let state = self.lock();
            let live = state.live.get(name).ok_or_else(|| ArenaError::UnknownMatch(name.into()))?;
            (live.events.clone(), live.id.clone())
        };
        let _ = events.send(Event::Control(Control::Stop)).await;
        // The match's task holds the other end until it has recorded its end.
        events.closed().await;
        self.wait_live_until(|state, _| state.live.get(name).is_none_or(|l| l.id != id)).await;
        Ok(id)
    }

    /// Waits until `done` (given the state and the number of live matches) holds, checked
    /// at the start and whenever that number changes. The arena's lock is taken only
    /// between looks at the count, never inside `watch::Receiver::wait_for`: a match is
    /// counted under that lock, so taking it while the count is borrowed would deadlock.
    async fn wait_live_until(&self, mut done: impl FnMut(&State, usize) -> bool) {
        let mut count = self.inner.live_count.subscribe();
        loop {
            let live = *count.borrow_and_update();
            let met = done(&self.lock(), live);
            if met || count.changed().await.is_err() {
                return;
            }
        }
    }

    /// Stops a live match's clock (`paused`) or starts it again; players stay connected.
    pub async fn pause(&self, name: &str, paused: bool) -> Result<(), ArenaError> {
        let events = {
            let state = self.lock();
            state.live.get(name).ok_or_else(|| ArenaError::UnknownMatch(name.into()))?.events.clone()
        };
        events
            .send(Event::Control(Control::Pause(paused)))
            .await
            .map_err(|_| ArenaError::UnknownMatch(name.into()))
    }

    /// The summary of the finished match with this id, if the lobby still lists it.
    pub fn finished_summary(&self, id: &str, operator: bool) -> Option<MatchSummary> {
        self.lock().finished.iter().find(|f| f.id == id).map(|f| summary_of_finished(f, operator))
    }

    /// Makes a match from a template (by name) or from the first template, changed by
    /// `changes`; returns its name. For the API.
    pub fn create(&self, request: CreateRequest) -> Result<String, ArenaError> {
        let mut state = self.lock();
        let template =
            match &request.template {
                Some(name) => state
                    .templates
                    .get(name)
                    .map(|t| t.template.clone())
                    .ok_or_else(|| ArenaError::UnknownTemplate(name.clone()))?,
                None => state.templates.values().next().map(|t| t.template.clone()).ok_or_else(|| {
                    ArenaError::Bad("the server has no template to make a match from".into())
                })?,
            };
        let mut config = template.config.clone();
        let mut setup = template.setup.clone();
        setup.map = template.maps[0].clone();
        if let Some(map) = &request.map {
            setup.map = self.find_map(&template, map)?;
        }
        if let Some(seed) = request.seed {
            setup.seed = seed;
        }
        if let Some(mode) = request.mode {
            config.mode = mode;
        }
        if let Some(hz) = request.tick_hz {
            setup.game.ticks_per_second = hz;
            setup.game.validate().map_err(|e| ArenaError::Bad(format!("tick_hz: {e}")))?;
        }
        if let Some(max) = request.max_ticks {
            setup.max_ticks = (max > 0).then_some(max);
        }
        let mut builtin: Vec<Seat> =
            template.setup.seats.iter().filter(|s| !matches!(s.player, Player::Open)).cloned().collect();
        let builtins = request.builtin.unwrap_or(builtin.len());
        let robots = request.robots.unwrap_or(template.setup.robots().max(builtins));
        if robots == 0 || robots > setup.map.spawns().len() {
            return Err(ArenaError::Bad(format!(
                "robots: {robots} but map '{}' has {} spawn points",
                setup.map.name(),
                setup.map.spawns().len()
            )));
        }
        if builtins > robots {
            return Err(ArenaError::Bad(format!("builtin: {builtins} but robots: {robots}")));
        }
        builtin.truncate(builtins);
        let more = builtin.len()..builtins;
        builtin.extend(
            more.map(|i| Seat::builtin(bw4t_agents::bot_name(i), bw4t_agents::Strategy::Cooperative)),
        );
        builtin.resize_with(robots, Seat::open);
        setup.seats = builtin;
        let name = match request.name {
            Some(name) => {
                check_match_name(&name)?;
                name
            }
            None => {
                let t = state.templates.get_mut(&template.name).map(|t| {
                    t.made += 1;
                    t.made
                });
                format!("{}-{}", template.name, t.unwrap_or(1))
            }
        };
        config.name = name;
        config.template = Some(template.name.clone());
        self.launch(
            &mut state,
            MatchSpec { setup, config, replay: None, gone_seats: None },
            Some(template),
            false,
        )
    }

    fn find_map(&self, template: &Template, name: &str) -> Result<Map, ArenaError> {
        if let Some(map) = self
            .inner
            .config
            .templates
            .iter()
            .flat_map(|t| &t.maps)
            .chain(&template.maps)
            .find(|m| m.name() == name)
        {
            return Ok(map.clone());
        }
        match &self.inner.config.maps {
            Some(lookup) => lookup(name).map_err(|e| ArenaError::Bad(format!("map: {e}"))),
            None => Err(ArenaError::Bad(format!("map: no map named '{name}' on this server"))),
        }
    }

    /// The layout (`/map.json`) of a live or finished match's map; without a name, the
    /// default match's.
    pub fn layout(&self, name: Option<&str>) -> Option<Arc<str>> {
        let map = {
            let state = self.lock();
            let name = name.map(str::to_string).or_else(|| self.default_match(&state))?;
            match state.live.get(&name) {
                Some(live) => live.map.clone(),
                None => {
                    let finished = state.finished.iter().find(|f| f.name == name)?;
                    let map = self
                        .inner
                        .config
                        .templates
                        .iter()
                        .flat_map(|t| &t.maps)
                        .find(|m| m.name() == finished.map)?;
                    Arc::new(map.clone())
                }
            }
        };
        let mut layouts = self.inner.layouts.lock().unwrap_or_else(|p| p.into_inner());
        let layout = layouts
            .entry(map.name().to_string())
            .or_insert_with(|| serde_json::to_string(&MapLayout::of(&map)).unwrap_or_default().into());
        Some(layout.clone())
    }

    /// The name of the match a `hello` naming none joins, if it is live or has ended.
    fn default_match(&self, state: &State) -> Option<String> {
        let default = self.inner.config.default.as_ref()?;
        if state.live.contains_key(default) || state.finished.iter().any(|f| &f.name == default) {
            return Some(default.clone());
        }
        // A template's name: its first live match.
        state.live.iter().find(|(_, l)| l.template.as_deref() == Some(default)).map(|(n, _)| n.clone())
    }

    /// `/info.json` of a live server.
    pub fn info(&self) -> ServerInfo {
        let state = self.lock();
        let templates: Vec<_> = self
            .inner
            .config
            .templates
            .iter()
            .filter(|t| t.names.is_empty())
            .map(|t| TemplateInfo {
                name: t.name.clone(),
                robots: t.setup.robots(),
                map: t.maps[0].name().to_string(),
            })
            .collect();
        let default = self.default_match(&state);
        ServerInfo::Live {
            protocol: bw4t_protocol::VERSION,
            map: default.as_ref().and_then(|n| state.live.get(n)).map(|l| l.map.name().to_string()),
            default_match: default,
            lobby: !self.inner.config.once,
            templates,
        }
    }

    /// Ends every match (`interrupted`) and waits until each has recorded its end.
    pub async fn shutdown(&self) {
        {
            let mut state = self.lock();
            state.stopping = true;
            // Players waiting in a queue are told the server is stopping.
            for template in state.templates.values_mut() {
                template.queue.clear();
            }
        }
        self.inner.shutdown.send_replace(true);
        let mut count = self.inner.live_count.subscribe();
        let _ = count.wait_for(|n| *n == 0).await;
    }

    /// Resolves when no match is live any more and at least one has ended.
    pub async fn idle(&self) {
        self.wait_live_until(|state, live| live == 0 && state.any_ended).await;
    }

    /// How many matches have ended, how and in how many ticks, by template (or, for a
    /// match made without one, by name), since the server started.
    pub fn totals(&self) -> BTreeMap<String, Totals> {
        self.lock().totals.clone()
    }

    /// The outcomes of the last hundred matches ended, by match id, in the order they ended.
    pub fn outcomes(&self) -> Vec<(String, Result<MatchResult, String>)> {
        self.inner.outcomes.lock().unwrap_or_else(|p| p.into_inner()).iter().cloned().collect()
    }

    /// The results store.
    pub fn results(&self) -> &ResultsStore {
        &self.inner.config.results
    }
}

/// What the operator asks for in `POST /api/matches`.
#[derive(Clone, Debug, Default, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CreateRequest {
    /// The match's name (default: `TEMPLATE-N`).
    pub name: Option<String>,
    /// The template whose settings to start from (default: the first).
    pub template: Option<String>,
    /// A map's name.
    pub map: Option<String>,
    /// The seed.
    pub seed: Option<u64>,
    /// Players, built-in agents included.
    pub robots: Option<usize>,
    /// Built-in cooperative agents among them.
    pub builtin: Option<usize>,
    /// `realtime` or `lockstep`.
    pub mode: Option<Mode>,
    /// Ticks per second.
    pub tick_hz: Option<u32>,
    /// The tick limit (0: none).
    pub max_ticks: Option<u64>,
}

/// Checks a match name the operator chose: what a URL and a log line carry unchanged.
pub fn check_match_name(name: &str) -> Result<(), ArenaError> {
    let ok = !name.is_empty()
        && name.len() <= 64
        && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_' || c == '.');
    if ok {
        Ok(())
    } else {
        Err(ArenaError::Bad(format!(
            "name: '{name}' is not a match name (1 to 64 letters, digits, '-', '_' or '.')"
        )))
    }
}

/// Whether anyone may watch: the summaries' `watch`.
fn watch_of(open: bool) -> Watch {
    if open { Watch::Open } else { Watch::Token }
}

/// A live match's summary before its task says where it is (waiting at tick 0).
fn summary_of_live(name: &str, live: &LiveMatch, operator: bool) -> MatchSummary {
    MatchSummary {
        name: name.to_string(),
        template: live.template.clone(),
        map: live.map.name().to_string(),
        mode: live.mode,
        state: MatchState::Waiting,
        players: Vec::new(),
        robots: live.robots,
        awaited: 0,
        tick: 0,
        sequence: [0, 0],
        watch: watch_of(live.watch_open),
        paused: None,
        end_reason: None,
        run: live.run,
        seed: operator.then_some(live.seed),
        id: operator.then(|| live.id.clone()),
        connections: None,
        result: None,
    }
}

/// A live match's summary, its status asked of its task (taken without waiting on the
/// task: one whose queue is full is listed as waiting at tick 0).
struct StatusAsked {
    summary: MatchSummary,
    answer: Option<oneshot::Receiver<HostStatus>>,
}

impl StatusAsked {
    fn of(name: &str, live: &LiveMatch, operator: bool) -> StatusAsked {
        let (tx, rx) = oneshot::channel();
        let asked = live.events.try_send(Event::Control(Control::Status(tx))).is_ok();
        StatusAsked { summary: summary_of_live(name, live, operator), answer: asked.then_some(rx) }
    }

    /// The summary with the status the match gave within a second.
    async fn answered(mut self, operator: bool) -> MatchSummary {
        let status = match self.answer {
            Some(rx) => tokio::time::timeout(Duration::from_secs(1), rx).await.ok().and_then(Result::ok),
            None => None,
        };
        fill_status(&mut self.summary, &status.unwrap_or_default(), operator);
        self.summary
    }
}

fn fill_status(summary: &mut MatchSummary, status: &HostStatus, operator: bool) {
    summary.state = if status.started { MatchState::Playing } else { MatchState::Waiting };
    summary.players = status.players.clone();
    summary.awaited = status.awaited;
    summary.tick = status.tick;
    summary.paused = Some(status.paused);
    summary.sequence = [status.sequence.0, status.sequence.1];
    if operator {
        summary.connections = Some(status.connections);
    }
}

fn summary_of_finished(f: &Finished, operator: bool) -> MatchSummary {
    MatchSummary {
        name: f.name.clone(),
        template: f.template.clone(),
        map: f.map.clone(),
        mode: f.mode,
        state: MatchState::Finished,
        players: f.players.clone(),
        robots: f.robots,
        awaited: 0,
        tick: f.tick,
        sequence: [f.sequence.0, f.sequence.1],
        watch: watch_of(f.watch_open),
        paused: None,
        end_reason: Some(f.end_reason),
        run: f.run,
        seed: operator.then_some(f.seed),
        id: operator.then(|| f.id.clone()),
        connections: None,
        result: operator.then(|| f.id.clone()),
    }
}
