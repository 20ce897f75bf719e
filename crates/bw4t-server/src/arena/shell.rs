//! The arena's task: the one owner of the [`Core`], fed [`Command`]s through a channel by
//! the [`Arena`](super::Arena) handles, connections (claims and queue places given back)
//! and match tasks (started, ended). It turns each command into core events and performs
//! the core's actions: making a match's host and spawning its driver task, sending on
//! connections' and queued players' channels, writing the results store. Counts, totals
//! and outcomes are published through a `watch`; everything else is asked of the task.

use std::collections::{BTreeMap, VecDeque};
use std::sync::Arc;
use std::time::{Duration, Instant};

use bw4t_host::MatchHost;
use bw4t_map::Map;
use bw4t_protocol::MapLayout;
use bw4t_tournament::Row;
use tokio::sync::{mpsc, oneshot, watch};

use super::core::{self, Action, Core, Facts, Launch, Make, Outcome, Recipe, Refusal, Routing, Seek, Ticket};
use super::route::{Claim, QueueNews, Route, Routed, Waiting};
use super::{ArenaConfig, ArenaError, MatchSpec, Template, Totals};
use crate::config::ServerError;
use crate::driver;
use crate::events::{Control, Event};

/// What the arena's task is asked to do.
pub(crate) enum Command {
    /// Route a `hello`.
    Hello {
        /// What it asks for.
        seek: Seek,
        /// Where it goes.
        reply: oneshot::Sender<Result<Routed, Refusal>>,
    },
    /// A seat claim was given back.
    Released {
        /// The match's name.
        name: String,
        /// Its run's id.
        id: String,
    },
    /// A queued player left its place.
    LeftQueue {
        /// Its ticket.
        waiter: Ticket,
    },
    /// Make a match.
    Make {
        /// Which.
        make: Make,
        /// Its settings, unless its template's recipe makes them.
        spec: Option<Box<MatchSpec>>,
        /// Its name, or why not.
        reply: oneshot::Sender<Result<String, ArenaError>>,
    },
    /// A match played its first tick.
    Started {
        /// Its name.
        name: String,
        /// Its run's id.
        id: String,
    },
    /// A match ended.
    Ended {
        /// Its name.
        name: String,
        /// Its run's id.
        id: String,
        /// How.
        outcome: Outcome,
    },
    /// End a live match.
    Stop {
        /// Its name.
        name: String,
        /// Its run's id once it has ended, or why not.
        reply: oneshot::Sender<Result<String, ArenaError>>,
    },
    /// Read the arena (the lobby, layouts, the server's info): the closure answers itself.
    Look(Box<dyn FnOnce(&mut Shell) + Send>),
    /// The server stops.
    Shutdown,
}

/// How the shell reaches a live match.
#[derive(Clone, Debug)]
pub(super) struct Live {
    /// Its event channel.
    pub events: mpsc::Sender<Event>,
    /// Its map (for `/map.json`).
    pub map: Arc<Map>,
}

/// What the arena's task publishes after each command.
#[derive(Debug, Default)]
pub(super) struct Published {
    /// Matches live now.
    pub live: usize,
    /// Matches ended since the server started.
    pub ended: u64,
    /// How many ended and how, by template (or name).
    pub totals: BTreeMap<String, Totals>,
    /// The outcomes of the last [`core::FINISHED_KEPT`] matches ended, in that order.
    pub outcomes: VecDeque<(String, Outcome)>,
}

/// The arena's task's state: the core and what performing its actions needs.
pub(crate) struct Shell {
    /// The decisions.
    pub(super) core: Core<Live>,
    /// The server's settings.
    pub(super) config: Arc<ArenaConfig>,
    /// For claims, queue places and match tasks to report back (weak: the task ends when
    /// no one can ask it anything any more).
    commands: mpsc::WeakUnboundedSender<Command>,
    tickets: Ticket,
    routes: BTreeMap<Ticket, oneshot::Sender<Result<Routed, Refusal>>>,
    answers: BTreeMap<Ticket, oneshot::Sender<Result<String, ArenaError>>>,
    /// Settings given for matches being made, by their request's ticket.
    specs: BTreeMap<Ticket, MatchSpec>,
    /// Queued players' news channels.
    waiters: BTreeMap<Ticket, mpsc::UnboundedSender<QueueNews>>,
    /// `--replay`'s writer, taken by the first match made.
    first_replay: Option<(Box<dyn std::io::Write + Send>, String)>,
    /// Map layouts (`/map.json`), by map name.
    layouts: BTreeMap<String, Arc<str>>,
    /// Becomes true when the server stops: every match ends.
    shutdown: watch::Sender<bool>,
    published: watch::Sender<Published>,
}

impl Shell {
    /// A shell around `core`, reporting back through `commands`.
    pub(super) fn new(
        core: Core<Live>,
        config: Arc<ArenaConfig>,
        commands: mpsc::WeakUnboundedSender<Command>,
        published: watch::Sender<Published>,
    ) -> Shell {
        let first_replay = config.first_replay.lock().unwrap_or_else(|p| p.into_inner()).take();
        Shell {
            core,
            config,
            commands,
            tickets: 0,
            routes: BTreeMap::new(),
            answers: BTreeMap::new(),
            specs: BTreeMap::new(),
            waiters: BTreeMap::new(),
            first_replay,
            layouts: BTreeMap::new(),
            shutdown: watch::Sender::new(false),
            published,
        }
    }

    /// Takes commands until no one can send any more.
    pub(super) async fn run(mut self, mut commands: mpsc::UnboundedReceiver<Command>) {
        while let Some(command) = commands.recv().await {
            self.take(command);
        }
    }

    /// Makes a match now, outside the task (at the start): its name, or why not.
    pub(super) fn make_now(&mut self, make: Make) -> Result<String, ArenaError> {
        let (reply, mut answer) = oneshot::channel();
        self.take(Command::Make { make, spec: None, reply });
        answer.try_recv().unwrap_or_else(|_| Err(ArenaError::Bad("the match was not made".into())))
    }

    fn ticket(&mut self) -> Ticket {
        self.tickets += 1;
        self.tickets
    }

    /// Does what `command` asks, then publishes the counts.
    pub(super) fn take(&mut self, command: Command) {
        let event = match command {
            Command::Hello { seek, reply } => {
                let ticket = self.ticket();
                self.routes.insert(ticket, reply);
                core::Event::Hello { ticket, seek }
            }
            Command::Released { name, id } => core::Event::Released { name, id },
            Command::LeftQueue { waiter } => {
                self.waiters.remove(&waiter);
                core::Event::LeftQueue { waiter }
            }
            Command::Make { make, spec, reply } => {
                let ticket = self.ticket();
                self.answers.insert(ticket, reply);
                if let Some(spec) = spec {
                    self.specs.insert(ticket, *spec);
                }
                core::Event::Make { ticket, make }
            }
            Command::Started { name, id } => core::Event::Started { name, id },
            Command::Ended { name, id, outcome } => core::Event::Ended { name, id, outcome },
            Command::Stop { name, reply } => {
                let ticket = self.ticket();
                self.answers.insert(ticket, reply);
                core::Event::Stop { ticket, name }
            }
            Command::Look(look) => return look(self),
            Command::Shutdown => core::Event::Shutdown,
        };
        // What performing an action reports (a match made or not, a seat back) is taken
        // in before the next command.
        let mut events = VecDeque::from([event]);
        while let Some(event) = events.pop_front() {
            for action in self.core.handle(Instant::now(), event) {
                events.extend(self.perform(action));
            }
        }
        self.publish();
    }

    /// Performs one of the core's actions; returns what the core is to hear of it.
    fn perform(&mut self, action: Action<Live>) -> Option<core::Event<Live>> {
        match action {
            Action::Spawn(launch) => return Some(self.spawn(launch)),
            Action::Route { ticket, routing } => {
                let routed = match routing {
                    Routing::Match { handle, name, id, claim } => {
                        let claim = if claim { self.claim(name, id) } else { None };
                        Ok(Routed::Match(Route { events: handle.events, claim }))
                    }
                    Routing::Queued { place } => {
                        let (news, heard) = mpsc::unbounded_channel();
                        self.waiters.insert(ticket, news);
                        Ok(Routed::Queued(Waiting::new(heard, self.commands.upgrade(), ticket), place))
                    }
                    Routing::Refused(refusal) => Err(refusal),
                };
                // A connection gone meanwhile drops the answer, and so gives back its claim or place.
                if let Some(reply) = self.routes.remove(&ticket) {
                    let _ = reply.send(routed);
                }
            }
            Action::Place { waiter, place } => {
                if let Some(news) = self.waiters.get(&waiter) {
                    let _ = news.send(QueueNews::Place(place));
                }
            }
            Action::Seat { waiter, handle, name, id } => {
                let seat = QueueNews::Seat(Route { events: handle.events, claim: self.claim(name, id) });
                let unsent = match self.waiters.remove(&waiter) {
                    Some(news) => news.send(seat).err().map(|e| e.0),
                    None => Some(seat),
                };
                // The player left the queue: its seat goes back at once.
                if let Some(QueueNews::Seat(Route { claim: Some(claim), .. })) = unsent {
                    let (name, id) = claim.disarm()?;
                    return Some(core::Event::Released { name, id });
                }
            }
            Action::Dismiss { waiter } => {
                // The player's news ends: it is told the server is stopping.
                self.waiters.remove(&waiter);
            }
            Action::Record { row, template, outcome, lasted } => self.record(*row, template, outcome, lasted),
            Action::Stop { handle } => {
                let stop = Event::Control(Control::Stop);
                if let Err(mpsc::error::TrySendError::Full(stop)) = handle.events.try_send(stop) {
                    // The match's queue is full: the request waits its turn without holding up the arena.
                    tokio::spawn(async move {
                        let _ = handle.events.send(stop).await;
                    });
                }
            }
            Action::StopAll => {
                self.shutdown.send_replace(true);
            }
            Action::Answer { ticket, answer } => {
                self.specs.remove(&ticket);
                if let Some(reply) = self.answers.remove(&ticket) {
                    let _ = reply.send(answer);
                }
            }
        }
        None
    }

    /// A claim on a seat of run `id` of `name`, given back to this task when dropped.
    fn claim(&self, name: String, id: String) -> Option<Claim> {
        Some(Claim::new(self.commands.upgrade()?, name, id))
    }

    /// Makes a match's host and runs it as its own task.
    fn spawn(&mut self, launch: Launch) -> core::Event<Live> {
        let Launch { name, id, recipe, template, .. } = launch;
        match self.launch(&name, &id, recipe, template.as_deref()) {
            Ok((handle, facts)) => {
                tracing::info!(target: "bw4t::arena", r#match = %name, id = %id, map = %facts.map, seed = facts.seed, "match made");
                core::Event::Spawned { name, id, handle, facts }
            }
            Err(error) => {
                tracing::error!(target: "bw4t::arena", r#match = %name, error = %error, "cannot make a match");
                core::Event::SpawnFailed { name, id, error }
            }
        }
    }

    fn launch(
        &mut self,
        name: &str,
        id: &str,
        recipe: Recipe,
        template: Option<&str>,
    ) -> Result<(Live, Facts), ArenaError> {
        let config = self.config.clone();
        let template = template.and_then(|name| config.templates.iter().find(|t| t.name == name));
        let spec = match recipe {
            Recipe::Template { n, map, seed } => {
                let template = template.ok_or_else(|| ArenaError::UnknownTemplate(name.into()))?;
                let mut spec = spec_of_template(template, n, map)?;
                if let Some(seed) = seed {
                    // Made for an invited player whose seat carries its seed.
                    spec.setup.seed = seed;
                }
                spec
            }
            Recipe::Given(ticket) => self
                .specs
                .remove(&ticket)
                .ok_or_else(|| ArenaError::Bad("the match's settings were not given".into()))?,
        };
        let MatchSpec { setup, mut config, replay, gone_seats } = spec;
        config.name = name.to_string();
        config.id = id.to_string();
        if config.operator_token.is_none() {
            config.operator_token.clone_from(&self.config.server.operator_token);
        }
        // Its own replay, else the one `--replay` asked for (taken by the first match made),
        // else one in the results directory if its template keeps them.
        let replay = replay.or_else(|| self.first_replay.take()).or_else(|| {
            let kept = template.is_some_and(|t| t.replays);
            kept.then(|| self.config.results.replay_writer(id)).flatten()
        });
        let facts = Facts {
            map: setup.map.name().to_string(),
            mode: config.mode,
            seed: setup.seed,
            robots: setup.robots(),
            watch_open: config.token.is_none() && config.spectator_token.is_none(),
        };
        let map = Arc::new(setup.map.clone());
        let host = MatchHost::new(setup, config, replay, Instant::now()).map_err(ServerError::Host)?;
        let (events, events_rx) = mpsc::channel(driver::EVENT_QUEUE);
        let commands = self.commands.upgrade();
        let mut stop = self.shutdown.subscribe();
        let lateness = template.and_then(|t| t.lateness.clone());
        let (name, id) = (name.to_string(), id.to_string());
        tokio::spawn(async move {
            let shutdown = async move {
                let _ = stop.wait_for(|s| *s).await;
            };
            let started = {
                let (commands, name, id) = (commands.clone(), name.clone(), id.clone());
                move || {
                    if let Some(commands) = commands {
                        let _ = commands.send(Command::Started { name, id });
                    }
                }
            };
            let outcome = driver::run(host, events_rx, gone_seats, started, lateness, shutdown).await;
            // A match task never waits on the arena: it reports its end and is gone.
            if let Some(commands) = commands {
                let _ = commands.send(Command::Ended { name, id, outcome });
            }
        });
        Ok((Live { events, map }, facts))
    }

    /// Files a finished match: its row (with its replay's file) and result in the store,
    /// its outcome among those published.
    fn record(&mut self, mut row: Row, template: Option<String>, outcome: Outcome, lasted: Duration) {
        let replays = template
            .and_then(|t| self.config.templates.iter().find(|x| x.name == t))
            .is_some_and(|t| t.replays);
        row.replay = self.config.results.replay_name(&row.key, replays);
        self.config.results.record(&row, outcome.as_ref().ok());
        let id = row.key;
        let name = id.rsplit_once('.').map_or(id.as_str(), |(name, _)| name);
        match &outcome {
            Ok(result) => {
                tracing::info!(target: "bw4t::arena", r#match = %name, id = %id, reason = %result.end_reason, ticks = result.ticks, secs = lasted.as_secs_f64(), "match ended");
            }
            Err(why) => {
                tracing::error!(target: "bw4t::arena", r#match = %name, id = %id, error = %why, "match failed")
            }
        }
        self.published.send_modify(|published| {
            if published.outcomes.len() == core::FINISHED_KEPT {
                published.outcomes.pop_front();
            }
            published.outcomes.push_back((id, outcome));
        });
    }

    /// Publishes the counts and totals if they changed.
    fn publish(&self) {
        let (live, ended) = (self.core.live_count(), self.core.ended());
        self.published.send_if_modified(|published| {
            if (published.live, published.ended) == (live, ended) {
                return false;
            }
            if published.ended != ended {
                published.totals.clone_from(self.core.totals());
            }
            (published.live, published.ended) = (live, ended);
            true
        });
    }

    /// The layout (`/map.json`) of a live or finished match's map; without a name, the
    /// default match's.
    pub(super) fn layout(&mut self, name: Option<&str>) -> Option<Arc<str>> {
        let name = name.map(str::to_string).or_else(|| self.core.default_match())?;
        let map_name = match self.core.live().get(&name) {
            Some(live) => live.facts.map.clone(),
            None => self.core.finished().iter().find(|f| f.name == name)?.facts.map.clone(),
        };
        if let Some(layout) = self.layouts.get(&map_name) {
            return Some(layout.clone());
        }
        let map = match self.core.live().get(&name).and_then(|l| l.handle.as_ref()) {
            Some(live) => live.map.clone(),
            None => Arc::new(
                self.config.templates.iter().flat_map(|t| &t.maps).find(|m| m.name() == map_name)?.clone(),
            ),
        };
        let layout: Arc<str> = serde_json::to_string(&MapLayout::of(&map)).unwrap_or_default().into();
        self.layouts.insert(map_name, layout.clone());
        Some(layout)
    }
}

/// The settings of `template`'s match made after `n` others, on its map at `map`: the
/// template's seed plus `n`, its built-in seats.
fn spec_of_template(template: &Template, n: u64, map: usize) -> Result<MatchSpec, ArenaError> {
    let mut config = template.config.clone();
    let mut setup = template.setup.clone();
    setup.map = template
        .maps
        .get(map)
        .ok_or_else(|| ArenaError::Bad(format!("template '{}' has no map {map}", template.name)))?
        .clone();
    setup.seed = setup.seed.wrapping_add(n);
    config.template = Some(template.name.clone());
    Ok(MatchSpec { setup, config, replay: None, gone_seats: None })
}
