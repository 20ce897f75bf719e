//! The arena: every match a server hosts, from its making to its result. Matches are made
//! from templates (at the start, when a player asks for one, when one ends and its
//! template says to go on) or by the operator; each runs as its own host task, so a
//! failing match ends alone. Connections are routed to a match by their `hello`.
//!
//! Every decision (routing, templates, queues, seat claims, restarts, run numbers) is
//! taken by one sans-IO state machine, [`core`], driven by one task, [`shell`], which
//! performs what it decides; the [`Arena`] handle talks to that task. What a routed
//! connection holds is in [`route`], the lobby's summaries in [`lobby`], finished
//! matches go to the results store ([`store`]).

mod core;
mod invitations;
mod lobby;
mod route;
mod shell;
mod store;

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

use bw4t_agents::{MatchSetup, Player, Seat};
use bw4t_map::Map;
use bw4t_protocol::{ErrorCode, Hello, MatchResult, MatchSummary, Mode, Role, ServerInfo, TemplateInfo};
use tokio::sync::{mpsc, oneshot, watch};

use bw4t_host::HostConfig;

use crate::config::{ServerConfig, ServerError};
use crate::events::{Control, Event};
use crate::lateness::TickLateness;

use self::core::{Core, Make, MakeFrom, Refusal, Rules, Seek};
use self::invitations::{Invitation, Invitations};
use self::lobby::StatusAsked;
use self::shell::{Command, Published, Shell};

pub(crate) use route::{QueueNews, Route, Routed, Waiting};
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
    /// match's seed (the n-th match made gets `seed + n`, unless made for a player whose seat token
    /// carries a seed: [`Arena::invite_seeded`]), and `setup.seats` every seat,
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
    /// Seat only players invited by a seat token ([`Arena::invite`]): a study's condition.
    pub invited_only: bool,
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
            invited_only: false,
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

/// A handle on the server's matches; clones share them. Every decision is taken by the
/// arena's task (`arena/shell.rs`), which owns the state (`arena/core/`); the handle sends it
/// commands and reads what it publishes.
#[derive(Clone)]
pub struct Arena {
    inner: Arc<Inner>,
}

struct Inner {
    config: Arc<ArenaConfig>,
    commands: mpsc::UnboundedSender<Command>,
    /// Connection ids, for the protocol and web ports alike.
    ids: AtomicU64,
    /// Counts, totals and outcomes, as of the last command the task took.
    published: watch::Receiver<Published>,
    /// The seat tokens granted.
    invitations: Invitations,
}

impl Arena {
    /// An arena with `config`; its templates' named matches are made at once. Must be
    /// called inside a tokio runtime.
    pub fn start(config: ArenaConfig) -> Result<Arena, ArenaError> {
        let rules = config.templates.iter().map(rules_of).collect();
        // Runs and the index go on from the results already kept, so ids stay unique.
        let core = Core::new(rules, config.results.history(), config.default.clone(), config.once)?;
        let config = Arc::new(config);
        let (commands, commands_rx) = mpsc::unbounded_channel();
        let (publish, published) = watch::channel(Published::default());
        let mut shell = Shell::new(core, config.clone(), commands.downgrade(), publish);
        let starting =
            config.templates.iter().flat_map(|t| t.names.iter().map(|n| (t.name.clone(), n.clone())));
        for (template, name) in starting {
            shell.make_now(Make {
                name: Some(name),
                template: Some(template),
                from: MakeFrom::Template,
                seed: None,
            })?;
        }
        tokio::spawn(shell.run(commands_rx));
        let invitations = Invitations::default();
        Ok(Arena {
            inner: Arc::new(Inner { config, commands, ids: AtomicU64::new(1), published, invitations }),
        })
    }

    /// Runs a match made from `spec` (not from a template): it stays finished when it ends.
    pub async fn spawn(&self, spec: MatchSpec) -> Result<String, ArenaError> {
        let open_seats = open_seats(&spec.setup);
        let make = Make {
            name: Some(spec.config.name.clone()),
            template: None,
            from: MakeFrom::Given { open_seats },
            seed: None,
        };
        self.make(make, spec).await
    }

    async fn make(&self, make: Make, spec: MatchSpec) -> Result<String, ArenaError> {
        let (reply, answer) = oneshot::channel();
        let _ = self.inner.commands.send(Command::Make { make, spec: Some(Box::new(spec)), reply });
        answer.await.unwrap_or(Err(ArenaError::Stopping))
    }

    /// The server's settings.
    pub fn config(&self) -> &ArenaConfig {
        &self.inner.config
    }

    /// A new connection id.
    pub(crate) fn next_conn(&self) -> u64 {
        self.inner.ids.fetch_add(1, Ordering::SeqCst)
    }

    /// The seat token of player `name` in the matches of template `template` (the same
    /// each time asked, new after a restart): the `hello.seat` that seats them in a
    /// template that seats only invited players.
    pub fn invite(&self, template: &str, name: &str) -> Result<String, ArenaError> {
        self.invite_seeded(template, name, None)
    }

    /// [`Arena::invite`] for a seat whose match plays `seed` (if given): a match made for
    /// the player's hello (or made while they are first in its queue) plays that seed
    /// instead of the template's next; one they join because it has a free seat plays
    /// the seed it was made with. Each seed is its own seat token.
    pub fn invite_seeded(&self, template: &str, name: &str, seed: Option<u64>) -> Result<String, ArenaError> {
        if !self.inner.config.templates.iter().any(|t| t.name == template) {
            return Err(ArenaError::UnknownTemplate(template.to_string()));
        }
        Ok(self.inner.invitations.grant(template, name, seed))
    }

    /// Where `hello` goes.
    pub(crate) async fn route(&self, hello: &Hello) -> Result<Routed, Refusal> {
        let (invited, seed) = match &hello.seat {
            None => (None, None),
            Some(token) => {
                let invitation = self.invited(hello, token)?;
                (Some(invitation.template), invitation.seed)
            }
        };
        let (reply, routed) = oneshot::channel();
        let _ = self.inner.commands.send(Command::Hello { seek: Seek::of(hello, invited, seed), reply });
        routed.await.unwrap_or_else(|_| Err((ErrorCode::ServerStopping, "the server is stopping".into())))
    }

    /// What `hello`'s seat token invites its player to, checked against its name.
    fn invited(&self, hello: &Hello, token: &str) -> Result<Invitation, Refusal> {
        let refuse = |why: String| Err((ErrorCode::BadToken, why));
        let Some(invitation) = self.inner.invitations.of(token) else {
            return refuse(
                "hello.seat: this seat token was not granted by this server (after a restart, \
                 reload the page that gave it)"
                    .into(),
            );
        };
        if hello.role != Role::Agent {
            return refuse("hello.seat: a seat token is for a player, not a watcher".into());
        }
        if hello.name.as_deref() != Some(invitation.name.as_str()) {
            return refuse(format!("hello.seat: this seat token is for player '{}'", invitation.name));
        }
        Ok(invitation)
    }

    /// Runs `look` on the arena's task; `None` if the task is gone.
    async fn look<T: Send + 'static>(
        &self,
        look: impl FnOnce(&mut Shell) -> T + Send + 'static,
    ) -> Option<T> {
        let (reply, answer) = oneshot::channel();
        let look = Box::new(move |shell: &mut Shell| {
            let _ = reply.send(look(shell));
        });
        self.inner.commands.send(Command::Look(look)).ok()?;
        answer.await.ok()
    }

    /// How many matches have ended since the server started.
    pub fn ended_so_far(&self) -> u64 {
        self.inner.published.borrow().ended
    }

    /// Resolves once `n` matches have ended (in all, since the server started).
    pub async fn ended(&self, n: u64) {
        self.wait_until(|p| p.ended >= n).await;
    }

    /// Waits until what the task published meets `done`, or the task is gone.
    async fn wait_until(&self, done: impl FnMut(&Published) -> bool) {
        let mut published = self.inner.published.clone();
        let _ = published.wait_for(done).await;
    }

    /// Where every live and recently finished match is: the live ones by name, then the
    /// finished ones, newest first. Each live match answers for itself; one that does not
    /// answer at once is listed as waiting at tick 0.
    pub async fn list(&self, operator: bool) -> Vec<MatchSummary> {
        let looked = self.look(move |shell| {
            let live = shell.core.live().iter().filter(|(_, l)| l.handle.is_some());
            let asks: Vec<StatusAsked> = live.map(|(name, l)| StatusAsked::of(name, l, operator)).collect();
            let finished: Vec<MatchSummary> =
                shell.core.finished().iter().map(|f| lobby::summary_of_finished(f, operator)).collect();
            (asks, finished)
        });
        let Some((asks, finished)) = looked.await else { return Vec::new() };
        let mut out = Vec::with_capacity(asks.len() + finished.len());
        for asked in asks {
            out.push(asked.answered(operator).await);
        }
        out.extend(finished);
        out
    }

    /// One match's summary: the live one of that name, else the latest finished.
    pub async fn summary(&self, name: &str, operator: bool) -> Option<MatchSummary> {
        let name = name.to_string();
        let asked =
            self.look(move |shell| match shell.core.live().get(&name).filter(|l| l.handle.is_some()) {
                Some(live) => (Some(StatusAsked::of(&name, live, operator)), None),
                None => {
                    let finished = shell.core.finished().iter().find(|f| f.name == name);
                    (None, finished.map(|f| lobby::summary_of_finished(f, operator)))
                }
            });
        match asked.await? {
            (Some(asked), _) => Some(asked.answered(operator).await),
            (None, finished) => finished,
        }
    }

    /// Ends a live match as `interrupted`; returns its id once it has ended.
    pub async fn stop(&self, name: &str) -> Result<String, ArenaError> {
        let (reply, answer) = oneshot::channel();
        let _ = self.inner.commands.send(Command::Stop { name: name.to_string(), reply });
        answer.await.unwrap_or(Err(ArenaError::Stopping))
    }

    /// Stops a live match's clock (`paused`) or starts it again; players stay connected.
    pub async fn pause(&self, name: &str, paused: bool) -> Result<(), ArenaError> {
        let unknown = || ArenaError::UnknownMatch(name.into());
        let wanted = name.to_string();
        let live = self.look(move |shell| shell.core.live().get(&wanted).and_then(|l| l.handle.clone()));
        let live = live.await.flatten().ok_or_else(unknown)?;
        live.events.send(Event::Control(Control::Pause(paused))).await.map_err(|_| unknown())
    }

    /// The summary of the finished match with this id, if the lobby still lists it.
    pub async fn finished_summary(&self, id: &str, operator: bool) -> Option<MatchSummary> {
        let id = id.to_string();
        let found = self.look(move |shell| {
            shell.core.finished().iter().find(|f| f.id == id).map(|f| lobby::summary_of_finished(f, operator))
        });
        found.await.flatten()
    }

    /// Makes a match from a template (by name) or from the first template, changed by
    /// `changes`; returns its name. For the API.
    pub async fn create(&self, request: CreateRequest) -> Result<String, ArenaError> {
        let templates = &self.inner.config.templates;
        let template = match &request.template {
            Some(name) => templates
                .iter()
                .find(|t| &t.name == name)
                .ok_or_else(|| ArenaError::UnknownTemplate(name.clone()))?,
            // The first by name.
            None => templates
                .iter()
                .min_by(|a, b| a.name.cmp(&b.name))
                .ok_or_else(|| ArenaError::Bad("the server has no template to make a match from".into()))?,
        };
        let mut config = template.config.clone();
        let mut setup = template.setup.clone();
        setup.map = template.maps[0].clone();
        if let Some(map) = &request.map {
            setup.map = self.find_map(template, map)?;
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
        // The template's built-in seats first (more are cooperative `BotN`s), open ones after.
        let mut seats: Vec<Seat> =
            template.setup.seats.iter().filter(|s| !matches!(s.player, Player::Open)).cloned().collect();
        let builtin = request.builtin.unwrap_or(seats.len());
        let robots = request.robots.unwrap_or(template.setup.robots().max(builtin));
        if robots == 0 || robots > setup.map.spawns().len() {
            return Err(ArenaError::Bad(format!(
                "robots: {robots} but map '{}' has {} spawn points",
                setup.map.name(),
                setup.map.spawns().len()
            )));
        }
        if builtin > robots {
            return Err(ArenaError::Bad(format!("builtin: {builtin} but robots: {robots}")));
        }
        if let Some(name) = &request.name {
            check_match_name(name)?;
        }
        config.template = Some(template.name.clone());
        seats.truncate(builtin);
        let more = seats.len()..builtin;
        seats.extend(
            more.map(|i| Seat::builtin(bw4t_agents::bot_name(i), bw4t_agents::Strategy::Cooperative)),
        );
        seats.resize_with(robots, Seat::open);
        setup.seats = seats;
        let make = Make {
            name: request.name,
            template: Some(template.name.clone()),
            from: MakeFrom::Given { open_seats: robots - builtin },
            seed: None,
        };
        self.make(make, MatchSpec { setup, config, replay: None, gone_seats: None }).await
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
    pub async fn layout(&self, name: Option<&str>) -> Option<Arc<str>> {
        let name = name.map(str::to_string);
        self.look(move |shell| shell.layout(name.as_deref())).await.flatten()
    }

    /// `/info.json` of a live server.
    pub async fn info(&self) -> ServerInfo {
        let config = self.inner.config.clone();
        let templates: Vec<_> = config
            .templates
            .iter()
            // Templates whose matches seat only invited players are nobody else's to join.
            .filter(|t| t.names.is_empty() && !t.invited_only)
            .map(|t| TemplateInfo {
                name: t.name.clone(),
                robots: t.setup.robots(),
                map: t.maps[0].name().to_string(),
            })
            .collect();
        let looked = self.look(|shell| {
            let default = shell.core.default_match();
            let map = default.as_ref().and_then(|n| shell.core.live().get(n)).map(|l| l.facts.map.clone());
            (default, map)
        });
        let (default_match, map) = looked.await.unwrap_or_default();
        ServerInfo::Live {
            protocol: bw4t_protocol::VERSION,
            map,
            default_match,
            lobby: !config.once,
            templates,
        }
    }

    /// Ends every match (`interrupted`) and waits until each has recorded its end.
    pub async fn shutdown(&self) {
        // Players waiting in a queue are told the server is stopping.
        let _ = self.inner.commands.send(Command::Shutdown);
        self.wait_until(|p| p.live == 0).await;
    }

    /// Resolves when no match is live any more and at least one has ended.
    pub async fn idle(&self) {
        self.wait_until(|p| p.live == 0 && p.ended > 0).await;
    }

    /// How many matches have ended, how and in how many ticks, by template (or, for a
    /// match made without one, by name), since the server started.
    pub fn totals(&self) -> BTreeMap<String, Totals> {
        self.inner.published.borrow().totals.clone()
    }

    /// The outcomes of the last hundred matches ended, by match id, in the order they ended.
    pub fn outcomes(&self) -> Vec<(String, Result<MatchResult, String>)> {
        self.inner.published.borrow().outcomes.iter().cloned().collect()
    }

    /// The results store.
    pub fn results(&self) -> &ResultsStore {
        &self.inner.config.results
    }
}

/// What the core needs to know of `template`.
fn rules_of(template: &Template) -> Rules {
    Rules {
        name: template.name.clone(),
        names: template.names.clone(),
        max_running: template.max_running,
        on_end: template.on_end,
        maps: template.maps.len(),
        open_seats: open_seats(&template.setup),
        invited_only: template.invited_only,
    }
}

/// How many of a match's seats wait for whoever joins.
fn open_seats(setup: &MatchSetup) -> usize {
    setup.seats.iter().filter(|s| matches!(s.player, Player::Open)).count()
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
