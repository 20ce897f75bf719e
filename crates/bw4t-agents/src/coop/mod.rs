//! The cooperative strategy: explore without duplicating work, tell the team what each
//! room holds, agree (by message) who fetches which position of the sequence, deliver in
//! order, wait for one's turn outside the drop zone, and answer and follow what other
//! players (people included) say in the shared message language.
//!
//! # What it says
//!
//! Every message is a checked [`Said`] of the language (its text form, [`Said::to_text`]),
//! to `all` unless it answers somebody:
//!
//! | when | message |
//! |---|---|
//! | it sets off to look into a room | `going_to ROOM` |
//! | it sees a room for the first time, sees it changed, or was sent there | `empty ROOM`, or one `contains_many ROOM COUNT COLOUR` per colour (all in one tick) |
//! | it will fetch a block for a position | `getting_for COLOUR ROOM POSITION` |
//! | it claims a position for the block in hand | `bringing COLOUR POSITION` |
//! | it gives a claim up | `giving_up POSITION` |
//! | it put a block down in the drop zone | `dropped COLOUR` |
//!
//! A report replaces what the receiver believed about the room: all messages of one report
//! arrive in the same tick from one sender, so the first report message about a room from
//! a sender in a batch means "forget that room, then add". Block ids are not in the
//! language: agents know rooms by counts per colour, and pick a concrete block only in the
//! room they stand in.
//!
//! # What it does with what it hears
//!
//! | heard | reaction |
//! |---|---|
//! | `going_to ROOM` | leaves ROOM to the sender (one room per player; the smaller name wins a tie) |
//! | `empty`, `contains_many` | what the room holds (a report, see above) |
//! | `contains ROOM COLOUR` | ROOM holds at least one COLOUR: a place to fetch from |
//! | `getting_for`, `bringing` | the sender's claim of the position (replacing its previous one) |
//! | `giving_up POSITION` | the sender's claim of it is over |
//! | `will_get COLOUR`, `have COLOUR` | the sender claims the earliest open position of COLOUR in the window; it is left to them |
//! | `could_not` | every claim of the sender is over |
//! | `what_in ROOM` | answers the asker: `empty`/`contains_many` from what it believes, else `dont_know`\* |
//! | `where_is COLOUR` | `have COLOUR` if it holds one, else `contains ROOM COLOUR` for the first room it believes holds one, else `dont_know`\* |
//! | `who_has COLOUR` | `have COLOUR` if it holds one (else silent) |
//! | `anybody_going ROOM` | `going_to ROOM` if its task takes it there (else silent) |
//! | `go_to NAME ROOM` (NAME its own) | `ok`; gives its claim up (`giving_up`, a block in hand is kept), goes there, reports what it sees, then resumes its work; `could_not` for an unknown place |
//! | `get NAME COLOUR` (NAME its own) | `ok` and claims the earliest open position of COLOUR in the window, fetching a block it knows of (or bringing one in hand); `could_not` when no such position is open or its hands are full, `dont_know` when it knows no such block |
//! | requests to another name, anything else | ignored |
//!
//! Answers go to the asker alone. \*A message does not say whether it was sent to one
//! player or to all, so each agent that knows answers; one that does not know says
//! `dont_know` only when the asker and itself are the only players (in a larger team it
//! stays silent rather than add to a flood of answers).
//!
//! A claim of another player lapses after [`CLAIM_LAPSE_TICKS`] ticks (a claim by word
//! alone, `will_get` or `have`, after [`WORD_CLAIM_LAPSE_TICKS`]) in which the sequence
//! did not advance and the claimer did not renew it (people forget), or when the claimer
//! says `could_not`, leaves, or the position is delivered. A room announced with
//! `going_to` is left to its explorer for as long, unless a report on it comes first.
//!
//! The `silent` variant plays the same and listens (it follows `go_to` and `get` too) but
//! sends nothing. The `ignoring` variant talks like this one but hears only the kinds the
//! team sends itself to coordinate (`going_to`, `empty`, `contains_many`, `getting_for`,
//! `bringing`, `giving_up`): it answers no question, follows no request, and takes no
//! `will_get`, `have`, `contains` or `could_not` into account.
//!
//! # The progress rule
//!
//! Makes the team deliver every position (no deadlock): with `n` players on the team, a
//! robot
//! - holds at most one claim, and only on a position in the window `[index, index + n)`,
//!   whether to fetch a block or for a block it already holds;
//! - holds a block only under such a claim, or on its way to put the block back into a
//!   room (a loser of a collision, or a holder whose position was filled or left the
//!   window, first re-claims an open position of its colour in the window, else puts the
//!   block back), or while it follows a `go_to`;
//! - moves its claim to an earlier open position of its block's colour.
//!
//! When two players claim the same position in the same tick, every player lets the
//! lexically smaller name win, so all agree without a leader. Claims name distinct
//! positions, so while nobody has claimed `index` at most `n - 1` robots have claims, and
//! at least one robot is free (after at most one trip to put a block back) to fetch for
//! `index` or look for its colour, unless a holder of that colour moves its claim there
//! first. Whoever claims `index` delivers it, so the sequence advances. The guarantee is for
//! a team that follows this rule; players that do not claim count as free in `n`, and a
//! claim that is not kept lapses. People do not follow it (a person counted as free may
//! not fetch `index`; a claim may lapse while every robot holds a block for a later
//! position), so when `index` stays unclaimed, with no room announced, for
//! [`STALL_TICKS`], each robot with a claim on a later position gives it up and claims only
//! `index` until the sequence advances. An agent asks its driver to wake it
//! ([`Agent::wake_at`](crate::Agent::wake_at)) when a lapse or a stall falls due, since
//! nothing may be perceived then.

mod says;
#[cfg(test)]
mod tests;

use std::collections::{BTreeMap, BTreeSet};
use std::sync::Arc;

use bw4t_map::Colour;
use bw4t_protocol::{Knowledge, Said};
use bw4t_sim::{Action, OrderOutcome, Receiver};

use crate::view::{DROP_ZONE, View, rotated};
use crate::{Agent, Observation};
use says::Heard;

/// Ticks after which another player's claim (or announced exploration) lapses when the
/// sequence has not advanced and the claimer has not renewed it: two minutes at the
/// default 20 ticks a second (an agent is not told the match's rate).
pub const CLAIM_LAPSE_TICKS: u64 = 2_400;

/// Ticks after which a claim made by word alone (`will_get COLOUR`, `have COLOUR`: a
/// person's, through the message menu) lapses the same way: 45 seconds at the default
/// rate, 90 at a study's 10 ticks a second, longer than a person takes to fetch a block,
/// short enough that one who says it and then does nothing leaves the team time to finish.
pub const WORD_CLAIM_LAPSE_TICKS: u64 = 900;

/// Ticks the next position may stay unclaimed, with nobody announcing a room to look
/// into, before robots with claims on later positions give them up to fetch it themselves
/// (a player counted as free who does not fetch it, or a claim that lapsed, would
/// otherwise leave every robot waiting with a block for a later position). Fifteen seconds
/// at the default rate; a team that follows the progress rule never waits that long.
pub const STALL_TICKS: u64 = 300;

#[derive(Clone, Debug, PartialEq, Eq)]
enum Task {
    Idle,
    Explore(String),
    Fetch {
        pos: usize,
        colour: Colour,
        room: String,
    },
    Deliver {
        pos: usize,
    },
    /// Take the held block back into a room: no position in the window is open for it.
    PutBack,
    /// Go to a place because somebody asked, report what is there, then resume.
    Visit(String),
}

/// One player's claim of a sequence position.
#[derive(Clone, Debug, PartialEq, Eq)]
struct Claim {
    who: String,
    colour: Colour,
    /// The room a fetch is from; `None` for a block in hand or a claim without a plan.
    from: Option<String>,
    /// The tick it was made.
    since: u64,
    /// Ticks without progress or renewal after which it lapses (another player's).
    lapse: u64,
}

/// How much of the language a cooperative player uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Manner {
    /// Speaks, hears everything, answers and follows requests.
    Talkative,
    /// Hears everything and follows requests, says nothing.
    Silent,
    /// Speaks, hears only the team's coordination kinds.
    Ignoring,
}

/// A cooperative player.
pub struct Cooperative {
    name: String,
    manner: Manner,
    /// What its percepts told it, block colours once seen included.
    knowledge: Knowledge,
    /// What rooms are believed to hold, from what it saw and what the team reported, by
    /// the rules above: room -> colour -> count (a room known to be empty maps to nothing).
    rooms: BTreeMap<String, BTreeMap<Colour, u32>>,
    explored: BTreeSet<String>,
    /// Room -> the player exploring it and since when.
    exploring: BTreeMap<String, (String, u64)>,
    /// Sequence position -> its claim.
    claims: BTreeMap<usize, Claim>,
    task: Task,
    /// The current tick, and the tick the sequence last advanced.
    tick: u64,
    index_since: (usize, u64),
    /// Since when the next position has been unclaimed with no room announced.
    open_since: Option<u64>,
    /// The team stalled: claim only the next position until the sequence advances.
    urgent: bool,
    /// [`Cooperative::next_wake`] as of the end of the last decision: everything it reads
    /// changes only in a decision, and the driver asks for it every tick.
    wake: Option<u64>,
    next_action: u64,
    /// The goTo/goToBlock in flight.
    moving: Option<u64>,
    /// A request changed the task: act on it even while moving.
    redirected: bool,
    /// The colour of the block put down in the drop zone, to say `dropped` once it is gone.
    dropping: Option<Colour>,
    /// The corridor the robot was last in (a place to wait when the map has no FrontDropZone).
    last_hall: Option<String>,
    outbox: Vec<(Receiver, Said)>,
}

impl Cooperative {
    /// A cooperative agent for player `name`.
    pub fn new(name: &str) -> Self {
        Self::with_manner(name, Manner::Talkative)
    }

    /// The same play, sending no messages (it still listens and follows requests).
    pub fn silent(name: &str) -> Self {
        Self::with_manner(name, Manner::Silent)
    }

    /// The same play and messages, hearing only the team's coordination kinds.
    pub fn ignoring(name: &str) -> Self {
        Self::with_manner(name, Manner::Ignoring)
    }

    fn with_manner(name: &str, manner: Manner) -> Self {
        Cooperative {
            name: name.to_string(),
            manner,
            knowledge: Knowledge::new(),
            rooms: BTreeMap::new(),
            explored: BTreeSet::new(),
            exploring: BTreeMap::new(),
            claims: BTreeMap::new(),
            task: Task::Idle,
            tick: 0,
            index_since: (0, 0),
            open_since: None,
            urgent: false,
            wake: None,
            next_action: 0,
            moving: None,
            redirected: false,
            dropping: None,
            last_hall: None,
            outbox: Vec::new(),
        }
    }

    fn say(&mut self, said: Said) {
        self.tell(Receiver::All, said);
    }

    fn tell(&mut self, to: Receiver, said: Said) {
        debug_assert!(said.check().is_ok(), "{said:?}");
        if self.manner != Manner::Silent {
            self.outbox.push((to, said));
        }
    }

    /// Takes in one batch of messages (those of one percept delta). `reported` holds the
    /// (sender, room) pairs whose report has begun in this batch.
    fn hear_batch(&mut self, v: &View, messages: Vec<bw4t_protocol::Heard>) {
        let mut reported: BTreeSet<(Arc<str>, String)> = BTreeSet::new();
        for message in messages {
            let Some(heard) = message.said().and_then(Heard::read) else { continue };
            let from = message.from;
            if self.manner == Manner::Ignoring && !heard.is_coordination() {
                continue;
            }
            if let Heard::Report { room, .. } = &heard {
                if reported.insert((from.clone(), room.clone())) {
                    self.rooms.insert(room.clone(), BTreeMap::new());
                }
            }
            self.hear(v, &from, heard);
        }
    }

    fn hear(&mut self, v: &View, from: &str, heard: Heard) {
        match heard {
            Heard::GoingTo(room) => {
                // One room per player: announcing another ends the last.
                self.exploring.retain(|_, (who, _)| who != from);
                let holder =
                    self.exploring.entry(room.clone()).or_insert_with(|| (from.to_string(), self.tick));
                if from < holder.0.as_str() {
                    *holder = (from.to_string(), self.tick);
                }
                if self.task == Task::Explore(room) && from < self.name.as_str() {
                    self.task = Task::Idle;
                }
            }
            Heard::Report { room, blocks } => {
                self.explored.insert(room.clone());
                self.exploring.remove(&room);
                let counts = self.rooms.entry(room).or_default();
                if let Some((colour, count)) = blocks.filter(|(_, n)| *n > 0) {
                    counts.insert(colour, count);
                }
            }
            Heard::Contains { room, colour } => {
                let count = self.rooms.entry(room).or_default().entry(colour).or_insert(0);
                *count = (*count).max(1);
            }
            Heard::GettingFor { colour, room, pos } => {
                if pos < v.sequence.len() {
                    self.resolve_claim(from, pos, colour, Some(room));
                }
            }
            Heard::Bringing { colour, pos } => {
                if pos < v.sequence.len() {
                    self.resolve_claim(from, pos, colour, None);
                }
            }
            Heard::GivingUp(pos) => {
                if self.claims.get(&pos).is_some_and(|c| c.who == from) {
                    self.claims.remove(&pos);
                }
            }
            Heard::Intends(colour) => {
                // The earliest open position of the colour, as everyone counts it; the
                // sender's own claim does not stand in the way of its new one.
                let open = Self::window(v)
                    .find(|p| v.sequence[*p] == colour && self.claims.get(p).is_none_or(|c| c.who == from));
                if let Some(pos) = open {
                    self.resolve_claim(from, pos, colour, None);
                    if let Some(claim) = self.claims.get_mut(&pos).filter(|c| c.who == from) {
                        claim.lapse = WORD_CLAIM_LAPSE_TICKS;
                    }
                }
            }
            Heard::CouldNot => self.claims.retain(|_, c| c.who != from),
            Heard::WhoHas(_)
            | Heard::WhereIs(_)
            | Heard::WhatIn(_)
            | Heard::AnybodyGoing(_)
            | Heard::GoTo { .. }
            | Heard::Get { .. } => self.answer(v, from, heard),
        }
    }

    /// Answers a question or follows a request of `from` (the requests group).
    fn answer(&mut self, v: &View, from: &str, heard: Heard) {
        let asker = Receiver::Player(from.to_string());
        let held = v.holding.and_then(|b| self.knowledge.colour_of(b));
        // Whether a question without an answer was surely put to this player alone.
        let alone = v.players.iter().all(|p| **p == *from);
        match heard {
            Heard::WhatIn(room) => match self.rooms.get(&room).cloned() {
                Some(counts) => {
                    for said in says::report(&room, &counts) {
                        self.tell(asker.clone(), said);
                    }
                }
                None if alone => self.tell(asker, Said::new("dont_know")),
                None => {}
            },
            Heard::WhereIs(colour) => {
                if held == Some(colour) {
                    self.tell(asker, says::with_colour("have", colour));
                } else if let Some(room) = self.rooms_holding(v, colour, None).into_iter().next() {
                    self.tell(asker, says::contains(&room, colour));
                } else if alone {
                    self.tell(asker, Said::new("dont_know"));
                }
            }
            Heard::WhoHas(colour) if held == Some(colour) => {
                self.tell(asker, says::with_colour("have", colour));
            }
            Heard::AnybodyGoing(room) => {
                let there = match &self.task {
                    Task::Explore(r) | Task::Visit(r) | Task::Fetch { room: r, .. } => *r == room,
                    _ => false,
                };
                if there {
                    self.tell(asker, says::going_to(&room));
                }
            }
            Heard::GoTo { player, room } if player == self.name => {
                if !v.has_place(&room) {
                    return self.tell(asker, Said::new("could_not"));
                }
                self.tell(asker, Said::new("ok"));
                self.give_up_claim();
                self.task = Task::Visit(room);
                self.redirected = true;
            }
            Heard::Get { player, colour } if player == self.name => {
                // The answer goes before what taking it on says (`giving_up`, a claim).
                let at = self.outbox.len();
                let reply = self.take_on(v, colour);
                self.tell(asker, Said::new(reply));
                if let Some(answer) = self.outbox.pop() {
                    self.outbox.insert(at, answer);
                }
            }
            _ => {}
        }
    }

    /// Takes on getting a block of `colour` for its earliest open position in the window,
    /// dropping the current task; the word to answer with.
    fn take_on(&mut self, v: &View, colour: Colour) -> &'static str {
        let mine = self.claims.iter().find(|(_, c)| c.who == self.name).map(|(p, c)| (*p, c.clone()));
        if mine.as_ref().is_some_and(|(_, c)| c.colour == colour) {
            return "ok";
        }
        let open = self
            .own_window(v)
            .find(|p| v.sequence[*p] == colour && self.claims.get(p).is_none_or(|c| c.who == self.name));
        let Some(pos) = open else { return "could_not" };
        match v.holding.map(|b| self.knowledge.colour_of(b)) {
            Some(held) if held == Some(colour) => {
                self.give_up_claim();
                self.claim(pos, colour, None);
                self.task = Task::Deliver { pos };
            }
            Some(_) => return "could_not",
            None => {
                let Some(room) = self.rooms_holding(v, colour, None).into_iter().next() else {
                    return "dont_know";
                };
                self.give_up_claim();
                self.claim(pos, colour, Some(room.clone()));
                self.task = Task::Fetch { pos, colour, room };
            }
        }
        self.redirected = true;
        "ok"
    }

    /// Gives up this player's claim, whatever it is, and its task.
    fn give_up_claim(&mut self) {
        let mine: Vec<usize> =
            self.claims.iter().filter(|(_, c)| c.who == self.name).map(|(p, _)| *p).collect();
        for pos in mine {
            self.release(pos);
        }
        self.task = Task::Idle;
    }

    /// Records `from`'s claim, which replaces its previous one. Where it collides with
    /// another claim on the same position the smaller name wins; every player resolves
    /// the same messages the same way, so all keep the same claims.
    fn resolve_claim(&mut self, from: &str, pos: usize, colour: Colour, source: Option<String>) {
        self.claims.retain(|_, c| c.who != from);
        if let Some(rival) = self.claims.get(&pos) {
            if rival.who.as_str() < from {
                return;
            }
            if rival.who == self.name {
                // Lost the position, even with the block in hand: Idle re-claims within
                // the window or puts the block back, so no robot holds a block unclaimed.
                self.task = Task::Idle;
            }
        }
        self.claims.insert(
            pos,
            Claim {
                who: from.to_string(),
                colour,
                from: source.clone(),
                since: self.tick,
                lapse: CLAIM_LAPSE_TICKS,
            },
        );
        // More players going for a room's blocks of a colour than it holds: those whose
        // names come last look elsewhere (a block in hand is kept; whoever goes for one
        // will find it gone).
        if let Task::Fetch { pos: mine, colour: wanted, room } = &self.task {
            if *wanted == colour && source.as_ref() == Some(room) && *mine != pos {
                let mut fetchers: Vec<&str> = self
                    .claims
                    .values()
                    .filter(|c| c.colour == colour && c.from.as_ref() == Some(room))
                    .map(|c| c.who.as_str())
                    .collect();
                fetchers.sort_unstable();
                let rank = fetchers.iter().position(|w| *w == self.name).unwrap_or(0);
                if rank >= self.count(room, colour) as usize {
                    let mine = *mine;
                    self.release(mine);
                    self.task = Task::Idle;
                }
            }
        }
    }

    /// Claims `pos`, replacing this player's previous claim: a fetch from `from`, or for
    /// the block in hand.
    fn claim(&mut self, pos: usize, colour: Colour, from: Option<String>) {
        self.claims.retain(|_, c| c.who != self.name);
        let said = match &from {
            Some(room) => says::getting_for(colour, room, pos),
            None => says::bringing(colour, pos),
        };
        self.claims.insert(
            pos,
            Claim { who: self.name.clone(), colour, from, since: self.tick, lapse: CLAIM_LAPSE_TICKS },
        );
        self.say(said);
    }

    fn holds_claim(&self, pos: usize) -> bool {
        self.claims.get(&pos).is_some_and(|c| c.who == self.name)
    }

    /// The positions a robot may claim: one ahead per teammate, so while the next position
    /// is not claimed somebody is free to fetch it (the progress rule in the module docs).
    fn window(v: &View) -> std::ops::Range<usize> {
        let team = v.players.len() + 1;
        v.index..(v.index + team).min(v.sequence.len())
    }

    /// The positions this robot may claim. A silent robot cannot tell the team its claims,
    /// so nobody could count on it to leave the next position to others: it claims only
    /// the next position, which keeps a team of silent robots from all waiting with blocks
    /// for later positions.
    /// So does a robot of a stalled team (see [`STALL_TICKS`]).
    fn own_window(&self, v: &View) -> std::ops::Range<usize> {
        if self.manner == Manner::Silent || self.urgent {
            v.index..(v.index + 1).min(v.sequence.len())
        } else {
            Self::window(v)
        }
    }

    /// The first open position in the window for a block of `colour`.
    fn open_position(&self, v: &View, colour: Option<Colour>) -> Option<usize> {
        self.own_window(v).find(|p| Some(v.sequence[*p]) == colour && !self.claims.contains_key(p))
    }

    fn release(&mut self, pos: usize) {
        if self.holds_claim(pos) {
            self.claims.remove(&pos);
            self.say(says::giving_up(pos));
        }
    }

    /// How many blocks of `colour` `room` is believed to hold.
    fn count(&self, room: &str, colour: Colour) -> u32 {
        self.rooms.get(room).and_then(|c| c.get(&colour)).copied().unwrap_or(0)
    }

    /// Rooms believed to hold a block of `colour` that nobody else is going for, best first:
    /// the room the robot is in, then in its own order of rooms.
    fn rooms_holding(&self, v: &View, colour: Colour, skip: Option<&str>) -> Vec<String> {
        let order = self.room_order(v);
        let rank = |room: &str| order.iter().position(|r| r == room).unwrap_or(usize::MAX);
        let mut found: Vec<String> = self
            .rooms
            .keys()
            .filter(|room| Some(room.as_str()) != skip && room.as_str() != DROP_ZONE)
            .filter(|room| {
                let going = self
                    .claims
                    .values()
                    .filter(|c| c.who != self.name && c.colour == colour && c.from.as_ref() == Some(*room))
                    .count();
                self.count(room, colour) as usize > going
            })
            .cloned()
            .collect();
        found.sort_by_key(|room| (v.room.as_ref() != Some(room), rank(room)));
        found
    }

    /// The rooms that may hold blocks, in this robot's own order (spread over the team).
    fn room_order(&self, v: &View) -> Vec<String> {
        rotated(&v.rooms().into_iter().filter(|r| r != DROP_ZONE).collect::<Vec<_>>(), &self.name, &v.players)
    }

    /// What the robot sees in its room is the truth about that room: record it, and tell
    /// the team when it differs from what was believed, on a first visit, or when sent.
    fn observe_room(&mut self, v: &View) {
        let Some(room) = v.room.clone() else { return };
        if room == DROP_ZONE {
            return;
        }
        let mut seen: BTreeMap<Colour, u32> = BTreeMap::new();
        for colour in v.visible.values() {
            *seen.entry(*colour).or_default() += 1;
        }
        let first_visit = self.explored.insert(room.clone());
        if self.exploring.get(&room).is_some_and(|(who, _)| *who == self.name) {
            self.exploring.remove(&room);
        }
        let sent = self.task == Task::Visit(room.clone());
        if sent {
            // Arrived where it was sent (maybe still moving): report, then back to work.
            self.task = Task::Idle;
        }
        if self.rooms.get(&room) != Some(&seen) || first_visit || sent {
            for said in says::report(&room, &seen) {
                self.say(said);
            }
            self.rooms.insert(room, seen);
        }
    }

    fn go(&mut self, actions: &mut Vec<Action>, action: Action) {
        if matches!(action, Action::GoTo(_) | Action::GoToBlock(_)) {
            self.moving = Some(self.next_action + actions.len() as u64);
        }
        actions.push(action);
    }

    /// Runs the task machine until it produces an action or decides to wait.
    fn step(&mut self, v: &View, actions: &mut Vec<Action>) {
        for _ in 0..6 {
            match self.task.clone() {
                Task::Idle => {
                    self.choose(v);
                    if self.task == Task::Idle {
                        return self.wait_outside(v, actions);
                    }
                }
                Task::Explore(room) => {
                    if v.room.as_ref() == Some(&room) || self.explored.contains(&room) {
                        self.task = Task::Idle;
                    } else if v.occupied.contains(&room) {
                        // Someone is inside; it will be seen later or reported.
                        self.exploring.remove(&room);
                        self.task = Task::Idle;
                        return self.choose_other_than(v, &room, actions);
                    } else {
                        return self.go(actions, Action::GoTo(room));
                    }
                }
                Task::Visit(place) => {
                    if v.room.as_ref() == Some(&place) || (v.room.is_none() && v.at.as_ref() == Some(&place))
                    {
                        // Reported on arrival (observe_room); back to work.
                        self.task = Task::Idle;
                    } else if v.occupied.contains(&place) {
                        return self.wait_outside(v, actions);
                    } else {
                        return self.go(actions, Action::GoTo(place));
                    }
                }
                Task::Fetch { pos, colour, room } => {
                    if !self.holds_claim(pos) || !self.own_window(v).contains(&pos) {
                        self.release(pos);
                        self.task = Task::Idle;
                    } else if let Some(held) = v.holding {
                        if self.knowledge.colour_of(held) == Some(colour) {
                            self.task = Task::Deliver { pos };
                        } else {
                            self.release(pos);
                            self.task = Task::Idle;
                        }
                    } else if self.count(&room, colour) == 0 {
                        // Gone (seen or reported): look for another.
                        self.release(pos);
                        self.task = Task::Idle;
                    } else if v.room.as_ref() == Some(&room) {
                        if let Some(block) = v.at_block.filter(|b| v.visible.get(b) == Some(&colour)) {
                            return actions.push(Action::PickUp(Some(block)));
                        }
                        if let Some((block, _)) = v.visible.iter().find(|(_, c)| **c == colour) {
                            return self.go(actions, Action::GoToBlock(*block));
                        }
                        self.release(pos);
                        self.task = Task::Idle;
                    } else if v.occupied.contains(&room) {
                        return self.wait_outside(v, actions);
                    } else {
                        return self.go(actions, Action::GoTo(room));
                    }
                }
                Task::Deliver { pos } => {
                    let Some(held) = v.holding else {
                        self.release(pos);
                        self.task = Task::Idle;
                        continue;
                    };
                    if !self.holds_claim(pos) || !self.own_window(v).contains(&pos) {
                        // Lost, filled some other way, or out of the window (the team
                        // shrank): Idle re-claims within the window or puts the block back.
                        self.release(pos);
                        self.task = Task::Idle;
                        continue;
                    }
                    // An earlier open position of the same colour comes first.
                    let colour = self.knowledge.colour_of(held);
                    let earlier = (v.index..pos)
                        .find(|p| Some(v.sequence[*p]) == colour && !self.claims.contains_key(p));
                    if let (Some(earlier), Some(colour)) = (earlier, colour) {
                        self.release(pos);
                        self.claim(earlier, colour, None);
                        self.task = Task::Deliver { pos: earlier };
                        continue;
                    }
                    if v.in_drop_zone() {
                        if v.index == pos {
                            self.claims.remove(&pos);
                            self.task = Task::Idle;
                            self.dropping = colour;
                            return actions.push(Action::PutDown);
                        }
                        let place = v.waiting_place(self.last_hall.as_ref());
                        return self.go(actions, Action::GoTo(place));
                    }
                    if v.index == pos {
                        if v.occupied.contains(DROP_ZONE) {
                            return self.wait_outside(v, actions);
                        }
                        return self.go(actions, Action::GoTo(DROP_ZONE.to_string()));
                    }
                    let place = v.waiting_place(self.last_hall.as_ref());
                    if v.at.as_ref() != Some(&place) || v.room.is_some() {
                        self.go(actions, Action::GoTo(place));
                    }
                    return;
                }
                Task::PutBack => {
                    let Some(held) = v.holding else {
                        self.task = Task::Idle;
                        continue;
                    };
                    let colour = self.knowledge.colour_of(held);
                    if let (Some(pos), Some(colour)) = (self.open_position(v, colour), colour) {
                        // Needed again on the way: keep it.
                        self.claim(pos, colour, None);
                        self.task = Task::Deliver { pos };
                    } else if v.room.is_some() && !v.in_drop_zone() {
                        self.task = Task::Idle;
                        return actions.push(Action::PutDown);
                    } else {
                        let room = self.put_back_room(v);
                        return self.go(actions, Action::GoTo(room));
                    }
                }
            }
        }
    }

    /// Waiting happens in a hall, never in a room: a robot waiting in a room would keep
    /// out whoever it is waiting for.
    fn wait_outside(&mut self, v: &View, actions: &mut Vec<Action>) {
        if v.room.is_some() {
            let place = if v.in_drop_zone() {
                v.waiting_place(self.last_hall.as_ref())
            } else {
                self.last_hall.clone().unwrap_or_else(|| v.waiting_place(None))
            };
            self.go(actions, Action::GoTo(place));
        }
    }

    /// A room to put a block back into: the first of this robot's rooms nobody is in.
    fn put_back_room(&self, v: &View) -> String {
        let rooms = self.room_order(v);
        rooms.iter().find(|r| !v.occupied.contains(*r)).or(rooms.first()).cloned().unwrap_or_default()
    }

    fn choose_other_than(&mut self, v: &View, skip: &str, actions: &mut Vec<Action>) {
        self.choose_with(v, Some(skip));
        if self.task != Task::Idle {
            self.step(v, actions);
        }
    }

    fn choose(&mut self, v: &View) {
        self.choose_with(v, None);
    }

    /// Picks the next task: use a held block, fetch for the earliest open position, or
    /// explore a room nobody has.
    fn choose_with(&mut self, v: &View, skip: Option<&str>) {
        if let Some(held) = v.holding {
            // A block in hand is bound by the window like a new fetch.
            let colour = self.knowledge.colour_of(held);
            self.task = match (self.open_position(v, colour), colour) {
                (Some(pos), Some(colour)) => {
                    self.claim(pos, colour, None);
                    Task::Deliver { pos }
                }
                _ => Task::PutBack,
            };
            return;
        }
        for pos in self.own_window(v) {
            if self.claims.contains_key(&pos) {
                continue;
            }
            let colour = v.sequence[pos];
            if let Some(room) = self.rooms_holding(v, colour, skip).into_iter().next() {
                self.claim(pos, colour, Some(room.clone()));
                self.task = Task::Fetch { pos, colour, room };
                return;
            }
        }
        let rooms = self.room_order(v);
        let free = rooms.iter().find(|r| {
            !self.explored.contains(*r)
                && self.exploring.get(*r).is_none_or(|(who, _)| *who == self.name)
                && !v.occupied.contains(*r)
                && Some(r.as_str()) != skip
        });
        if let Some(room) = free.cloned() {
            self.exploring.insert(room.clone(), (self.name.clone(), self.tick));
            self.say(says::going_to(&room));
            self.task = Task::Explore(room);
            return;
        }
        // Everything is explored yet the next position has no known block: what rooms hold
        // may have changed unseen, so look again.
        let next_open = v.index < v.sequence.len() && !self.claims.contains_key(&v.index);
        let nobody_exploring = self.exploring.is_empty();
        if next_open && nobody_exploring && rooms.iter().all(|r| self.explored.contains(r)) {
            self.explored.clear();
        }
    }

    /// Forgets claims and explorations that are over: their player left, their position
    /// was delivered, or they lapsed.
    fn forget_stale(&mut self, v: &View) {
        if v.index != self.index_since.0 {
            self.index_since = (v.index, self.tick);
            self.urgent = false;
        }
        let (me, now, advanced) = (&self.name, self.tick, self.index_since.1);
        let present = |who: &String| who == me || v.players.iter().any(|p| **p == **who);
        let lapsed = |who: &String, since: u64, lapse: u64| {
            who != me && now.saturating_sub(since.max(advanced)) > lapse
        };
        self.claims.retain(|p, c| present(&c.who) && *p >= v.index && !lapsed(&c.who, c.since, c.lapse));
        self.exploring.retain(|_, (who, since)| present(who) && !lapsed(who, *since, CLAIM_LAPSE_TICKS));
    }

    /// Notices a stall: the next position unclaimed, nobody looking into a room, for
    /// [`STALL_TICKS`]. A robot with a claim on a later position then gives it up and
    /// claims only the next position until the sequence advances.
    fn notice_stall(&mut self, v: &View) {
        let open =
            v.index < v.sequence.len() && !self.claims.contains_key(&v.index) && self.exploring.is_empty();
        self.open_since = if open { Some(self.open_since.unwrap_or(self.tick)) } else { None };
        let stalled = self.open_since.is_some_and(|since| self.tick >= since + STALL_TICKS);
        let later = self.claims.iter().any(|(p, c)| c.who == self.name && *p > v.index);
        if stalled && !self.urgent && later {
            self.urgent = true;
            self.redirected = true;
        }
    }

    /// The tick by which something may have changed with no percept to tell: a claim of
    /// another player lapses, or the next position has stayed open too long.
    fn next_wake(&self) -> Option<u64> {
        let advanced = self.index_since.1;
        let lapses = self
            .claims
            .values()
            .filter(|c| c.who != self.name)
            .map(|c| (c.since, c.lapse))
            .chain(
                self.exploring
                    .values()
                    .filter(|(who, _)| *who != self.name)
                    .map(|(_, since)| (*since, CLAIM_LAPSE_TICKS)),
            )
            .map(|(since, lapse)| since.max(advanced) + lapse + 1);
        let stall = self.open_since.filter(|_| !self.urgent).map(|since| since + STALL_TICKS);
        lapses.chain(stall).filter(|t| *t > self.tick).min()
    }
}

impl Agent for Cooperative {
    fn decide(&mut self, obs: &Observation) -> Vec<Action> {
        self.tick = obs.tick;
        let mut batches = Vec::new();
        for delta in &obs.percepts {
            self.knowledge.apply(delta.tick, delta);
            batches.push(self.knowledge.latest_messages().to_vec());
        }
        for ack in &obs.acks {
            if ack.result.is_err() && Some(ack.action) == self.moving {
                self.moving = None;
            }
        }
        for done in &obs.done {
            if Some(done.action) == self.moving {
                self.moving = None;
                if done.outcome == OrderOutcome::Collided {
                    if let Task::Explore(room) = &self.task {
                        self.exploring.remove(room);
                        self.task = Task::Idle;
                    }
                }
            }
        }
        let v = View::read(&self.knowledge);
        if v.room.is_none() {
            self.last_hall.clone_from(&v.at);
        }
        self.forget_stale(&v);
        for batch in batches {
            self.hear_batch(&v, batch);
        }
        if let Some(colour) = self.dropping.take() {
            if v.holding.is_none() {
                self.say(says::with_colour("dropped", colour));
            }
        }
        self.notice_stall(&v);
        self.observe_room(&v);
        let mut actions = Vec::new();
        if !v.complete() {
            if self.moving.is_none() || std::mem::take(&mut self.redirected) {
                self.step(&v, &mut actions);
            } else if self.task == Task::Idle {
                // On the way somewhere without a task (or a message took it away): take up
                // new work if there is some, else keep going.
                self.choose(&v);
                if self.task != Task::Idle {
                    self.step(&v, &mut actions);
                }
            }
        }
        self.redirected = false;
        let messages: Vec<Action> = std::mem::take(&mut self.outbox)
            .into_iter()
            .map(|(to, said)| Action::SendMessage { to, text: said.to_text() })
            .collect();
        if !messages.is_empty() {
            // Messages go first; a move decided above keeps its number after them.
            if let Some(m) = self.moving.as_mut().filter(|m| **m >= self.next_action) {
                *m += messages.len() as u64;
            }
            actions.splice(0..0, messages);
        }
        self.next_action += actions.len() as u64;
        self.wake = self.next_wake();
        actions
    }

    fn wake_at(&self) -> Option<u64> {
        self.wake
    }
}
