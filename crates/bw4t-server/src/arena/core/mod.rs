//! The arena's decisions as one state machine without I/O: which matches exist and under
//! which run ids, who is routed where, the templates' queues and seat claims, what a
//! match's end records and starts next. [`Core::handle`] takes an [`Event`] and the time
//! and answers with [`Action`]s (spawn this match, seat that queued player, record this
//! row, answer this request); the shell (`arena/shell.rs`) performs them and reports back
//! (a match spawned or not, started, ended). No tokio, no clock, no files: tested on a
//! simulated clock in `core/tests.rs`.
//!
//! A match the core asked to spawn is live at once but has no handle until the shell says
//! it was made ([`Event::Spawned`]); whatever waits on it (the hello that asked for it, the
//! queue, a request) is answered then, or otherwise if it could not be made.

mod route;
#[cfg(test)]
mod tests;

use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::time::{Duration, Instant};

use bw4t_protocol::{EndReason, MatchResult, Mode};
use bw4t_tournament::Row;

use super::{ArenaError, OnEnd, Totals};

pub(crate) use route::{Refusal, Routing, Seek};

/// Names a request the shell waits to have answered (a hello, a make, a stop); also a
/// queued player's name in [`Action::Place`], [`Action::Seat`] and [`Action::Dismiss`].
pub(crate) type Ticket = u64;

/// How a match ended inside the server: its result, or why it failed.
pub(crate) type Outcome = Result<MatchResult, String>;

/// How many finished matches the lobby keeps.
pub(crate) const FINISHED_KEPT: usize = 100;

/// What the core knows of a template: enough to name, number, route and restart its
/// matches (the settings themselves stay with the shell).
#[derive(Clone, Debug)]
pub(crate) struct Rules {
    /// Its name.
    pub name: String,
    /// Matches made at the start under these names; none: matches are made on demand.
    pub names: Vec<String>,
    /// At most this many of its matches run at once.
    pub max_running: usize,
    /// What happens when one of its matches ends.
    pub on_end: OnEnd,
    /// How many maps its matches play in turn (`OnEnd::Next`).
    pub maps: usize,
    /// The seats its matches wait for players in (robots less built-in seats).
    pub open_seats: usize,
    /// It seats only players with a seat token granted for it (a study's condition).
    pub invited_only: bool,
}

/// What the lobby and the index say of a match, told by the shell once it is made.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Facts {
    /// The map's name.
    pub map: String,
    /// Its pacing.
    pub mode: Mode,
    /// Its seed.
    pub seed: u64,
    /// Its robots.
    pub robots: usize,
    /// Anyone may watch (no player or spectator token).
    pub watch_open: bool,
}

/// A match to make.
#[derive(Clone, Debug)]
pub(crate) struct Make {
    /// Its name; `None`: `TEMPLATE-N`, the template's next number.
    pub name: Option<String>,
    /// The template it belongs to: it counts against the template's running matches and
    /// takes the template's queued players.
    pub template: Option<String>,
    /// Where its settings come from.
    pub from: MakeFrom,
    /// The seed it plays instead of its template's next (made for an invited player whose
    /// seat token carries one); only for [`MakeFrom::Template`].
    pub seed: Option<u64>,
}

/// Where a match's settings come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum MakeFrom {
    /// The template's recipe (its next seed, its map walk); its `on_end` applies.
    Template,
    /// The shell holds them under the request's ticket (`Arena::spawn`, the API); the
    /// match stays finished when it ends.
    Given {
        /// The seats it waits for players in.
        open_seats: usize,
    },
}

/// A match the shell is to make and run.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct Launch {
    /// Its name.
    pub name: String,
    /// This run's id, `NAME.RUN`, unique among every match the results store has seen.
    pub id: String,
    /// Its run number.
    pub run: u64,
    /// Its template, if any (its replays and lateness apply).
    pub template: Option<String>,
    /// Its settings.
    pub recipe: Recipe,
}

/// How the shell makes a match's settings.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) enum Recipe {
    /// From its template: the template's seed plus `n` (or `seed`, if given), on the
    /// template's map at `map`.
    Template {
        /// How many of the template's matches were made before this one.
        n: u64,
        /// Which of the template's maps it plays.
        map: usize,
        /// The seed it plays instead of the template's seed plus `n`.
        seed: Option<u64>,
    },
    /// The settings the shell keeps under this ticket.
    Given(Ticket),
}

/// What happens in the arena.
pub(crate) enum Event<M> {
    /// A connection's `hello`, to be routed.
    Hello {
        /// Answered by [`Action::Route`].
        ticket: Ticket,
        /// What it asks for.
        seek: Seek,
    },
    /// A seat claim was given back (its connection closed).
    Released {
        /// The match's name.
        name: String,
        /// Its run's id.
        id: String,
    },
    /// A queued player left the queue (its connection closed or it was seated).
    LeftQueue {
        /// Its ticket.
        waiter: Ticket,
    },
    /// A match is asked for (at the start, by `spawn` or by the API).
    Make {
        /// Answered by [`Action::Answer`]: the match's name.
        ticket: Ticket,
        /// Which.
        make: Make,
    },
    /// The shell made the match of a [`Action::Spawn`]; it runs.
    Spawned {
        /// Its name.
        name: String,
        /// Its run's id.
        id: String,
        /// What the shell reaches it by.
        handle: M,
        /// What the lobby says of it.
        facts: Facts,
    },
    /// The shell could not make the match of a [`Action::Spawn`].
    SpawnFailed {
        /// Its name.
        name: String,
        /// Its run's id.
        id: String,
        /// Why.
        error: ArenaError,
    },
    /// A match played its first tick: it takes no more players by template.
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
        /// Its result, or why it failed.
        outcome: Outcome,
    },
    /// The operator ends a live match.
    Stop {
        /// Answered by [`Action::Answer`] once the match has ended: its run's id.
        ticket: Ticket,
        /// The match's name.
        name: String,
    },
    /// The server stops: queued players are let go, every match ends.
    Shutdown,
}

/// What the shell is to do.
#[derive(Debug)]
pub(crate) enum Action<M> {
    /// Make and run a match; then report [`Event::Spawned`] or [`Event::SpawnFailed`].
    Spawn(Launch),
    /// Where a `hello` goes.
    Route {
        /// The hello's ticket.
        ticket: Ticket,
        /// Where.
        routing: Routing<M>,
    },
    /// Tell a queued player its new place (1: next).
    Place {
        /// The player's ticket.
        waiter: Ticket,
        /// Its place.
        place: usize,
    },
    /// Give a queued player a seat claimed for it in this match.
    Seat {
        /// The player's ticket.
        waiter: Ticket,
        /// The match's handle.
        handle: M,
        /// Its name.
        name: String,
        /// Its run's id.
        id: String,
    },
    /// Tell a queued player the server is stopping.
    Dismiss {
        /// The player's ticket.
        waiter: Ticket,
    },
    /// File a finished match: its row in the index, its outcome.
    Record {
        /// The index's row (`replay` left for the shell, which knows the files).
        row: Box<Row>,
        /// The match's template, if it had one.
        template: Option<String>,
        /// How it ended.
        outcome: Outcome,
        /// How long it was live.
        lasted: Duration,
    },
    /// Ask a match to end now (`interrupted`).
    Stop {
        /// The match's handle.
        handle: M,
    },
    /// End every match now: the server stops.
    StopAll,
    /// A request's answer: a match's name (made) or run id (stopped), or why not.
    Answer {
        /// The request's ticket.
        ticket: Ticket,
        /// The answer.
        answer: Result<String, ArenaError>,
    },
}

/// What waits for a match being spawned.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Purpose {
    /// A request: answered with the name, or the error.
    Answer(Ticket),
    /// A hello by template: seated in it, or queued if it cannot be made.
    Hello(Ticket),
    /// The template's queue.
    Queue,
    /// A match of the same name that ended: then the template's queue.
    Restart,
}

/// A match the arena is running.
#[derive(Debug)]
pub(crate) struct LiveMatch<M> {
    /// Unique among every match the server ever ran: `NAME.RUN`.
    pub id: String,
    /// Its run number.
    pub run: u64,
    /// Its template, if any.
    pub template: Option<String>,
    /// What the shell reaches it by; `None` until the shell has made it.
    pub handle: Option<M>,
    /// What the lobby says of it (the default until it is made).
    pub facts: Facts,
    /// It has played its first tick.
    pub started: bool,
    /// Players routed to it while it waits whose connections are still open.
    claims: usize,
    /// Players it waits for besides its built-in seats.
    open_seats: usize,
    /// Its template's `on_end` applies when it ends (not to matches the operator made).
    goes_on: bool,
    /// What waits for it to be made.
    purpose: Option<Purpose>,
    /// The seed it was made to play instead of its template's next (a player's).
    seed: Option<u64>,
    /// When it was made.
    made_at: Instant,
}

impl<M> LiveMatch<M> {
    /// Whether a player routed here now holds a seat until the start.
    fn takes_claims(&self) -> bool {
        self.handle.is_some() && !self.started
    }
}

/// A finished match, as the lobby lists it.
#[derive(Clone, Debug)]
pub(crate) struct Finished {
    /// Its name.
    pub name: String,
    /// Its run's id.
    pub id: String,
    /// Its run number.
    pub run: u64,
    /// Its template, if any.
    pub template: Option<String>,
    /// What the lobby said of it.
    pub facts: Facts,
    /// Its players, in robot order.
    pub players: Vec<String>,
    /// Its last tick.
    pub tick: u64,
    /// Sequence positions delivered, and the sequence's length.
    pub sequence: (usize, usize),
    /// Why it ended.
    pub end_reason: EndReason,
}

/// A template and its counts.
struct TemplateState {
    rules: Rules,
    /// Matches made so far (the next one's number and seed offset).
    made: u64,
    /// Its matches live now (those being made included).
    running: usize,
    /// Players waiting for a seat, oldest first, with the place each was last told and
    /// the seed their seat token carries (a match made for them plays it).
    queue: VecDeque<(Ticket, usize, Option<u64>)>,
}

/// The arena's decision state.
pub(crate) struct Core<M> {
    templates: BTreeMap<String, TemplateState>,
    live: BTreeMap<String, LiveMatch<M>>,
    finished: VecDeque<Finished>,
    /// The last run per match name (from the results store's history on).
    runs: BTreeMap<String, u64>,
    /// The index's count of finished matches (from the history on).
    indexed: u64,
    /// Matches ended since the server started.
    ended: u64,
    /// Counts of the matches ended, by template (or name).
    totals: BTreeMap<String, Totals>,
    /// Stop requests waiting for a run to end, by run id.
    stops: BTreeMap<String, Vec<Ticket>>,
    /// What a `hello` naming no match joins.
    default: Option<String>,
    /// Nothing restarts: the server stops once no match is live.
    once: bool,
    stopping: bool,
}

impl<M: Clone> Core<M> {
    /// A core for these templates, going on from the results store's history: the last
    /// run of each match name and the index's count of rows. Refuses a template without
    /// a map and two matches of one name.
    pub(crate) fn new(
        templates: Vec<Rules>,
        (runs, indexed): (BTreeMap<String, u64>, u64),
        default: Option<String>,
        once: bool,
    ) -> Result<Core<M>, ArenaError> {
        let mut names = BTreeSet::new();
        for rules in &templates {
            if rules.maps == 0 {
                return Err(ArenaError::Bad(format!("template '{}' has no map", rules.name)));
            }
            for name in &rules.names {
                if !names.insert(name.clone()) {
                    return Err(ArenaError::Bad(format!("two matches are named '{name}'")));
                }
            }
        }
        let templates = templates
            .into_iter()
            .map(|rules| {
                let state = TemplateState { rules, made: 0, running: 0, queue: VecDeque::new() };
                (state.rules.name.clone(), state)
            })
            .collect();
        Ok(Core {
            templates,
            live: BTreeMap::new(),
            finished: VecDeque::new(),
            runs,
            indexed,
            ended: 0,
            totals: BTreeMap::new(),
            stops: BTreeMap::new(),
            default,
            once,
            stopping: false,
        })
    }

    /// Takes in `event` at `now`; returns what to do, in order.
    pub(crate) fn handle(&mut self, now: Instant, event: Event<M>) -> Vec<Action<M>> {
        let mut out = Vec::new();
        match event {
            Event::Hello { ticket, seek } => self.hello(now, ticket, &seek, &mut out),
            Event::Released { name, id } => self.release(now, &name, &id, &mut out),
            Event::LeftQueue { waiter } => self.leave_queue(waiter, &mut out),
            Event::Make { ticket, make } => {
                let goes_on = make.from == MakeFrom::Template;
                let made = self.make(now, make, goes_on, Purpose::Answer(ticket), &mut out);
                if let Err(e) = made {
                    out.push(Action::Answer { ticket, answer: Err(e) });
                }
            }
            Event::Spawned { name, id, handle, facts } => {
                self.spawned(now, &name, &id, handle, facts, &mut out)
            }
            Event::SpawnFailed { name, id, error } => self.spawn_failed(now, &name, &id, error, &mut out),
            Event::Started { name, id } => {
                if let Some(live) = self.live.get_mut(&name).filter(|l| l.id == id) {
                    live.started = true;
                }
            }
            Event::Ended { name, id, outcome } => self.end(now, &name, &id, outcome, &mut out),
            Event::Stop { ticket, name } => match self.live.get(&name) {
                Some(LiveMatch { handle: Some(handle), id, .. }) => {
                    self.stops.entry(id.clone()).or_default().push(ticket);
                    out.push(Action::Stop { handle: handle.clone() });
                }
                _ => out.push(Action::Answer { ticket, answer: Err(ArenaError::UnknownMatch(name)) }),
            },
            Event::Shutdown => {
                self.stopping = true;
                for template in self.templates.values_mut() {
                    out.extend(template.queue.drain(..).map(|(waiter, ..)| Action::Dismiss { waiter }));
                }
                out.push(Action::StopAll);
            }
        }
        out
    }

    /// Makes a match: names and numbers it, counts it live and asks the shell for it.
    fn make(
        &mut self,
        now: Instant,
        make: Make,
        goes_on: bool,
        purpose: Purpose,
        out: &mut Vec<Action<M>>,
    ) -> Result<String, ArenaError> {
        let template = match &make.template {
            Some(name) => {
                Some(self.templates.get_mut(name).ok_or_else(|| ArenaError::UnknownTemplate(name.clone()))?)
            }
            None if make.from == MakeFrom::Template => {
                return Err(ArenaError::Bad("a match made from a template needs the template".into()));
            }
            None => None,
        };
        // Every match made from a template, or named after it, takes the template's next number.
        let n = template.as_ref().map_or(0, |t| t.made);
        let counted = make.from == MakeFrom::Template || make.name.is_none();
        if let Some(t) = template.filter(|_| counted) {
            t.made += 1;
        }
        let name = match (make.name, &make.template) {
            (Some(name), _) => name,
            (None, Some(template)) => format!("{template}-{}", n + 1),
            (None, None) => return Err(ArenaError::Bad("a match needs a name or a template".into())),
        };
        if self.stopping {
            return Err(ArenaError::Stopping);
        }
        if self.live.contains_key(&name) {
            return Err(ArenaError::NameTaken(name));
        }
        let run = self.runs.get(&name).copied().unwrap_or(0) + 1;
        let id = format!("{name}.{run}");
        let (recipe, open_seats) = match (make.from, &make.template) {
            (MakeFrom::Given { open_seats }, _) => {
                let Purpose::Answer(ticket) = purpose else {
                    return Err(ArenaError::Bad("given settings answer a request".into()));
                };
                (Recipe::Given(ticket), open_seats)
            }
            (MakeFrom::Template, template) => {
                let Some(rules) = template.as_ref().and_then(|t| self.templates.get(t)).map(|t| &t.rules)
                else {
                    return Err(ArenaError::Bad("a match made from a template needs the template".into()));
                };
                // `Next` walks the list by the match name's runs; otherwise every match plays the first map.
                let map = if rules.on_end == OnEnd::Next { (run as usize - 1) % rules.maps } else { 0 };
                (Recipe::Template { n, map, seed: make.seed }, rules.open_seats)
            }
        };
        self.runs.insert(name.clone(), run);
        if let Some(t) = make.template.as_ref().and_then(|t| self.templates.get_mut(t)) {
            t.running += 1;
        }
        let live = LiveMatch {
            id: id.clone(),
            run,
            template: make.template.clone(),
            handle: None,
            facts: Facts { map: String::new(), mode: Mode::Realtime, seed: 0, robots: 0, watch_open: true },
            started: false,
            claims: 0,
            open_seats,
            goes_on,
            purpose: Some(purpose),
            seed: make.seed,
            made_at: now,
        };
        self.live.insert(name.clone(), live);
        out.push(Action::Spawn(Launch { name: name.clone(), id, run, template: make.template, recipe }));
        Ok(name)
    }

    /// A match the shell made: it runs, and what waited for it is answered.
    fn spawned(
        &mut self,
        now: Instant,
        name: &str,
        id: &str,
        handle: M,
        facts: Facts,
        out: &mut Vec<Action<M>>,
    ) {
        let Some(live) = self.live.get_mut(name).filter(|l| l.id == id && l.handle.is_none()) else { return };
        live.handle = Some(handle.clone());
        live.facts = facts;
        live.made_at = now;
        let template = live.template.clone();
        if self.stopping {
            // Made as the server stopped: it ends with the rest.
            out.push(Action::Stop { handle });
        }
        match live.purpose.take() {
            Some(Purpose::Answer(ticket)) => {
                out.push(Action::Answer { ticket, answer: Ok(name.to_string()) })
            }
            Some(Purpose::Hello(ticket)) => {
                let routing = self.claim(name).unwrap_or_else(|| self.refuse_stopping());
                out.push(Action::Route { ticket, routing });
                // Its other seats go to players already in line, if any.
                if let Some(template) = template {
                    self.serve_queue(now, &template, out);
                }
            }
            Some(Purpose::Queue | Purpose::Restart) => {
                if let Some(template) = template {
                    self.serve_queue(now, &template, out);
                }
            }
            None => {}
        }
    }

    /// A match the shell could not make: forgotten as if never asked for, and what waited
    /// for it is answered otherwise.
    fn spawn_failed(
        &mut self,
        now: Instant,
        name: &str,
        id: &str,
        error: ArenaError,
        out: &mut Vec<Action<M>>,
    ) {
        let Some(live) = self.live.remove(name) else { return };
        if live.id != id || live.handle.is_some() {
            self.live.insert(name.to_string(), live);
            return;
        }
        // Its run number goes to the next match of the name.
        match live.run - 1 {
            0 => self.runs.remove(name),
            last => self.runs.insert(name.to_string(), last),
        };
        if let Some(t) = live.template.as_ref().and_then(|t| self.templates.get_mut(t)) {
            t.running = t.running.saturating_sub(1);
        }
        match (live.purpose, live.template) {
            (Some(Purpose::Answer(ticket)), _) => out.push(Action::Answer { ticket, answer: Err(error) }),
            (Some(Purpose::Hello(ticket)), Some(template)) => {
                let routing = self.enqueue(ticket, &template, live.seed);
                out.push(Action::Route { ticket, routing });
            }
            // The queue waits for a seat another way (a claim given back, a match's end).
            (Some(Purpose::Queue), _) => {}
            (Some(Purpose::Restart), Some(template)) => self.serve_queue(now, &template, out),
            _ => {}
        }
    }

    /// Records a match's end and does what its template says next.
    fn end(&mut self, now: Instant, name: &str, id: &str, outcome: Outcome, out: &mut Vec<Action<M>>) {
        if !self.live.get(name).is_some_and(|l| l.id == id && l.handle.is_some()) {
            return;
        }
        let Some(live) = self.live.remove(name) else { return };
        self.indexed += 1;
        self.ended += 1;
        let facts = live.facts;
        let mut row = Row::unplayed(
            id.to_string(),
            self.indexed,
            live.template.clone().unwrap_or_else(|| name.to_string()),
            facts.map.clone(),
            facts.seed,
            facts.robots,
        );
        row.repetition = u32::try_from(live.run.saturating_sub(1)).unwrap_or(u32::MAX);
        let (players, tick, sequence) = match &outcome {
            Ok(result) => {
                row.record(result);
                let players = result.per_robot.iter().map(|r| r.name.clone()).collect();
                (players, result.ticks, (result.sequence_index as usize, result.sequence.len()))
            }
            Err(why) => {
                row.error = Some(format!("the match failed in the server: {why}"));
                (Vec::new(), 0, (0, 0))
            }
        };
        let totals = self.totals.entry(row.team.clone()).or_default();
        totals.ended += 1;
        totals.completed += u64::from(row.completed);
        totals.failed += u64::from(outcome.is_err());
        totals.ticks += row.ticks;
        self.finished.push_front(Finished {
            name: name.to_string(),
            id: id.to_string(),
            run: live.run,
            template: live.template.clone(),
            facts,
            players,
            tick,
            sequence,
            end_reason: row.end_reason,
        });
        self.finished.truncate(FINISHED_KEPT);
        let lasted = now.saturating_duration_since(live.made_at);
        out.push(Action::Record { row: Box::new(row), template: live.template.clone(), outcome, lasted });
        for ticket in self.stops.remove(id).unwrap_or_default() {
            out.push(Action::Answer { ticket, answer: Ok(id.to_string()) });
        }
        let Some(template) = live.template else { return };
        let Some(t) = self.templates.get_mut(&template) else { return };
        t.running = t.running.saturating_sub(1);
        if live.goes_on && t.rules.on_end != OnEnd::Stay && !self.stopping && !self.once {
            let again = Make {
                name: Some(name.to_string()),
                template: Some(template.clone()),
                from: MakeFrom::Template,
                seed: None,
            };
            // The queue is served once the new run is made (its seats first).
            if self.make(now, again, true, Purpose::Restart, out).is_ok() {
                return;
            }
        }
        self.serve_queue(now, &template, out);
    }

    /// Matches live now (those being made included).
    pub(crate) fn live_count(&self) -> usize {
        self.live.len()
    }

    /// Matches ended since the server started.
    pub(crate) fn ended(&self) -> u64 {
        self.ended
    }

    /// The live matches, by name.
    pub(crate) fn live(&self) -> &BTreeMap<String, LiveMatch<M>> {
        &self.live
    }

    /// The last [`FINISHED_KEPT`] finished matches, newest first.
    pub(crate) fn finished(&self) -> &VecDeque<Finished> {
        &self.finished
    }

    /// How many matches have ended and how, by template (or name).
    pub(crate) fn totals(&self) -> &BTreeMap<String, Totals> {
        &self.totals
    }

    /// The players waiting in `template`'s queue, oldest first.
    #[cfg(test)]
    pub(crate) fn queued(&self, template: &str) -> Vec<Ticket> {
        self.templates.get(template).map(|t| t.queue.iter().map(|(w, ..)| *w).collect()).unwrap_or_default()
    }
}
