//! Which match a `hello` joins: the match it names, the next free seat of the template it
//! names (a new match if the template may run one more, else a place in its queue), or
//! the server's default match.
//!
//! A player routed to a waiting match holds a claim on one of its seats while its
//! connection is open, so players arriving together are spread over matches instead of
//! crowding one; a claim given back (the player left before the start) frees the seat
//! for the queue. Queued players are told their place whenever it changes.

use std::time::Instant;

use bw4t_protocol::{ErrorCode, Hello, Role};

use super::{Action, Core, Make, MakeFrom, Purpose, Ticket};

/// A routing refusal: the fatal error's code and message.
pub(crate) type Refusal = (ErrorCode, String);

/// What a `hello` asks for, as far as routing goes.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct Seek {
    /// The match it names.
    pub match_name: Option<String>,
    /// The template it names.
    pub template: Option<String>,
    /// Its role.
    pub role: Role,
    /// It takes back a session.
    pub session: bool,
    /// The template its seat token was granted for (checked by the arena's handle).
    pub invited: Option<String>,
    /// The seed its seat token carries: a match made for it plays that seed.
    pub seed: Option<u64>,
}

impl Seek {
    /// What `hello` asks for, its seat token being one granted for `invited` with `seed`.
    pub(crate) fn of(hello: &Hello, invited: Option<String>, seed: Option<u64>) -> Seek {
        Seek {
            match_name: hello.match_name.clone(),
            template: hello.template.clone(),
            role: hello.role,
            session: hello.session.is_some(),
            invited,
            seed,
        }
    }

    /// Whether it may take a seat in a match of `template` (`None`: made without one).
    fn admitted_to<M>(&self, core: &Core<M>, template: Option<&str>) -> Result<(), Refusal> {
        let Some(template) = template else { return Ok(()) };
        let invited_only = core.templates.get(template).is_some_and(|t| t.rules.invited_only);
        if !invited_only || self.invited.as_deref() == Some(template) {
            return Ok(());
        }
        Err((
            ErrorCode::NotInvited,
            format!(
                "the matches of '{template}' seat only invited players (a study's participants): join \
                 through the page that invited you, whose hello carries your seat token"
            ),
        ))
    }
}

/// Where a `hello` goes.
#[derive(Debug, PartialEq, Eq)]
pub(crate) enum Routing<M> {
    /// To this match now.
    Match {
        /// The match's handle.
        handle: M,
        /// Its name.
        name: String,
        /// Its run's id.
        id: String,
        /// A seat is held for the player until the start (give it back with
        /// [`super::Event::Released`] when its connection closes).
        claim: bool,
    },
    /// Into its template's queue at this place (1: next).
    Queued {
        /// Its place.
        place: usize,
    },
    /// Nowhere: the fatal error to send.
    Refused(Refusal),
}

impl<M: Clone> Core<M> {
    /// Routes a `hello`: answered now, or once the match made for it is spawned.
    pub(super) fn hello(&mut self, now: Instant, ticket: Ticket, seek: &Seek, out: &mut Vec<Action<M>>) {
        if let Some(routing) = self.route(now, ticket, seek, out) {
            out.push(Action::Route { ticket, routing });
        }
    }

    fn route(
        &mut self,
        now: Instant,
        ticket: Ticket,
        seek: &Seek,
        out: &mut Vec<Action<M>>,
    ) -> Option<Routing<M>> {
        if self.stopping {
            return Some(self.refuse_stopping());
        }
        let refuse = |message: &str| Some(Routing::Refused((ErrorCode::BadMessage, message.to_string())));
        let seated = seek.role == Role::Agent && !seek.session;
        match (&seek.match_name, &seek.template) {
            (Some(_), Some(_)) => refuse("name a match or a template, not both"),
            (None, Some(_)) if seek.role != Role::Agent => {
                refuse("only players join by template; watchers name a match")
            }
            (None, Some(_)) if seek.session => {
                refuse("a session belongs to a match: reconnect with hello.match (welcome.match.name)")
            }
            (Some(name), None) => Some(self.route_to_match(name, seek)),
            (None, Some(template)) => self.route_to_template(now, ticket, template, seek, out),
            (None, None) => {
                let Some(default) = self.default.clone() else {
                    return Some(Routing::Refused((ErrorCode::UnknownMatch, self.no_match_named(None))));
                };
                let is_template = !self.live.contains_key(&default) && self.templates.contains_key(&default);
                if is_template && seated {
                    self.route_to_template(now, ticket, &default, seek, out)
                } else {
                    let name = self.default_match().unwrap_or(default);
                    Some(self.route_to_match(&name, seek))
                }
            }
        }
    }

    fn route_to_match(&mut self, name: &str, seek: &Seek) -> Routing<M> {
        let seated = seek.role == Role::Agent && !seek.session;
        let Some(template) = self.live.get(name).filter(|l| l.handle.is_some()).map(|l| l.template.clone())
        else {
            return Routing::Refused((ErrorCode::UnknownMatch, self.no_match_named(Some(name))));
        };
        if seated && let Err(refusal) = seek.admitted_to(self, template.as_deref()) {
            return Routing::Refused(refusal);
        }
        let Some(live) = self.live.get_mut(name) else {
            return Routing::Refused((ErrorCode::UnknownMatch, self.no_match_named(Some(name))));
        };
        let claim = seated && live.takes_claims();
        if claim {
            live.claims += 1;
        }
        match &live.handle {
            Some(handle) => {
                Routing::Match { handle: handle.clone(), name: name.to_string(), id: live.id.clone(), claim }
            }
            None => Routing::Refused((ErrorCode::UnknownMatch, format!("no live match named '{name}'"))),
        }
    }

    /// A free seat of `template`, a new match for the player (answered when it is
    /// spawned: `None`), or a place in the queue.
    fn route_to_template(
        &mut self,
        now: Instant,
        ticket: Ticket,
        template: &str,
        seek: &Seek,
        out: &mut Vec<Action<M>>,
    ) -> Option<Routing<M>> {
        if !self.templates.contains_key(template) {
            let known: Vec<&str> = self.templates.keys().map(String::as_str).collect();
            return Some(Routing::Refused((
                ErrorCode::UnknownTemplate,
                format!("no template named '{template}' (this server has: {})", known.join(", ")),
            )));
        }
        if let Err(refusal) = seek.admitted_to(self, Some(template)) {
            return Some(Routing::Refused(refusal));
        }
        if let Some(routing) = self.free_seat(template).and_then(|name| self.claim(&name)) {
            return Some(routing);
        }
        if self.may_make(template) {
            // The match plays the seed of the player whose hello made it, if theirs has one.
            let make = Make {
                name: None,
                template: Some(template.to_string()),
                from: MakeFrom::Template,
                seed: seek.seed,
            };
            // A name the operator took meanwhile: the player waits in line instead.
            if self.make(now, make, true, Purpose::Hello(ticket), out).is_ok() {
                return None;
            }
        }
        Some(self.enqueue(ticket, template, seek.seed))
    }

    /// A waiting match of `template` with a seat neither taken nor claimed.
    fn free_seat(&self, template: &str) -> Option<String> {
        let free = |l: &super::LiveMatch<M>| {
            l.template.as_deref() == Some(template) && l.takes_claims() && l.claims < l.open_seats
        };
        self.live.iter().find(|(_, l)| free(l)).map(|(name, _)| name.clone())
    }

    /// Whether `template` makes matches on demand and may run one more now.
    fn may_make(&self, template: &str) -> bool {
        self.templates
            .get(template)
            .is_some_and(|t| t.rules.names.is_empty() && t.running < t.rules.max_running)
    }

    /// Claims a seat of live match `name` for a player.
    pub(super) fn claim(&mut self, name: &str) -> Option<Routing<M>> {
        let live = self.live.get_mut(name)?;
        let handle = live.handle.clone()?;
        live.claims += 1;
        Some(Routing::Match { handle, name: name.to_string(), id: live.id.clone(), claim: true })
    }

    /// Puts a player (whose seat token carries `seed`) at the end of `template`'s queue.
    pub(super) fn enqueue(&mut self, ticket: Ticket, template: &str, seed: Option<u64>) -> Routing<M> {
        match self.templates.get_mut(template) {
            Some(t) => {
                let place = t.queue.len() + 1;
                t.queue.push_back((ticket, place, seed));
                Routing::Queued { place }
            }
            None => Routing::Refused((ErrorCode::UnknownTemplate, format!("no template named '{template}'"))),
        }
    }

    /// Gives a claimed seat back and offers it to the template's queue.
    pub(super) fn release(&mut self, now: Instant, name: &str, id: &str, out: &mut Vec<Action<M>>) {
        let Some(live) = self.live.get_mut(name).filter(|l| l.id == id) else { return };
        live.claims = live.claims.saturating_sub(1);
        if let Some(template) = live.template.clone() {
            self.serve_queue(now, &template, out);
        }
    }

    /// Takes a player out of its queue; those behind it move up.
    pub(super) fn leave_queue(&mut self, waiter: Ticket, out: &mut Vec<Action<M>>) {
        let found = self.templates.iter_mut().find_map(|(name, t)| {
            let at = t.queue.iter().position(|(w, ..)| *w == waiter)?;
            t.queue.remove(at);
            Some(name.clone())
        });
        if let Some(template) = found {
            self.tell_places(&template, out);
        }
    }

    /// Seats queued players of `template` while there are seats (making a match if it may
    /// run one more: the rest are seated once it is spawned), and tells the rest their
    /// new places.
    pub(super) fn serve_queue(&mut self, now: Instant, template: &str, out: &mut Vec<Action<M>>) {
        loop {
            if self.templates.get(template).is_none_or(|t| t.queue.is_empty()) {
                break;
            }
            if let Some(name) = self.free_seat(template) {
                let Some(Routing::Match { handle, name, id, .. }) = self.claim(&name) else { break };
                let Some((waiter, ..)) = self.templates.get_mut(template).and_then(|t| t.queue.pop_front())
                else {
                    break;
                };
                out.push(Action::Seat { waiter, handle, name, id });
                continue;
            }
            let being_made =
                self.live.values().any(|l| l.handle.is_none() && l.template.as_deref() == Some(template));
            if self.may_make(template) && !being_made {
                // Made for the player first in line: it plays their seed.
                let seed = self.templates.get(template).and_then(|t| t.queue.front()).and_then(|q| q.2);
                let make =
                    Make { name: None, template: Some(template.to_string()), from: MakeFrom::Template, seed };
                let _ = self.make(now, make, true, Purpose::Queue, out);
            }
            break;
        }
        self.tell_places(template, out);
    }

    /// Tells each queued player of `template` whose place changed its new place.
    fn tell_places(&mut self, template: &str, out: &mut Vec<Action<M>>) {
        let Some(t) = self.templates.get_mut(template) else { return };
        for (at, (waiter, told, _)) in t.queue.iter_mut().enumerate() {
            if *told != at + 1 {
                *told = at + 1;
                out.push(Action::Place { waiter: *waiter, place: at + 1 });
            }
        }
    }

    pub(super) fn refuse_stopping(&self) -> Routing<M> {
        Routing::Refused((ErrorCode::ServerStopping, "the server is stopping".into()))
    }

    /// The name of the match a `hello` naming none joins, if it is live or has ended.
    pub(crate) fn default_match(&self) -> Option<String> {
        let default = self.default.as_ref()?;
        if self.live.contains_key(default) || self.finished.iter().any(|f| &f.name == default) {
            return Some(default.clone());
        }
        // A template's name: its first live match.
        self.live.iter().find(|(_, l)| l.template.as_deref() == Some(default)).map(|(n, _)| n.clone())
    }

    /// Why `name` (or, with none, the default) names no live match, with the live ones.
    fn no_match_named(&self, name: Option<&str>) -> String {
        let live: Vec<&str> = self.live.keys().take(10).map(String::as_str).collect();
        let more = if self.live.len() > live.len() { ", ..." } else { "" };
        let live = if live.is_empty() { "none".to_string() } else { format!("{}{more}", live.join(", ")) };
        match name {
            Some(name) if self.finished.iter().any(|f| f.name == name) => {
                format!("match '{name}' is over (live matches: {live})")
            }
            Some(name) => format!("no live match named '{name}' (live matches: {live})"),
            None => {
                format!("this server has no default match: name one in hello.match (live matches: {live})")
            }
        }
    }
}
