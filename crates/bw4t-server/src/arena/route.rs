//! Which match a `hello` joins: the match it names, the next free seat of the template it
//! names (a new match if the template may run one more, else a place in its queue), or
//! the server's default match.
//!
//! A player routed to a waiting match holds a [`Claim`] on one of its seats while its
//! connection is open, so players arriving together are spread over matches instead of
//! crowding one; a claim given back (the player left before the start) frees the seat
//! for the queue.

use std::sync::atomic::Ordering;

use bw4t_protocol::{ErrorCode, Hello, Role};
use tokio::sync::mpsc;

use super::{Arena, State};
use crate::events::Event;

/// Where a `hello` goes.
pub(crate) enum Routed {
    /// To this match now.
    Match(Route),
    /// Into a template's queue, at this place (1: next); news comes on the receiver.
    Queued(mpsc::Receiver<QueueNews>, usize),
}

/// A match to join.
pub(crate) struct Route {
    /// The match's events.
    pub events: mpsc::Sender<Event>,
    /// The seat held for the player while it waits for the start.
    pub claim: Option<Claim>,
}

/// What a queued player hears.
pub(crate) enum QueueNews {
    /// Its place in the queue changed.
    Place(usize),
    /// A seat was found.
    Seat(Route),
}

/// A seat held in a waiting match; given back when dropped.
pub(crate) struct Claim {
    held: Option<(Arena, String, String)>,
}

impl Drop for Claim {
    fn drop(&mut self) {
        if let Some((arena, name, id)) = self.held.take() {
            let mut state = arena.lock();
            arena.release(&mut state, &name, &id);
        }
    }
}

impl Claim {
    /// Gives the seat back in `state` (already locked) instead of on drop.
    fn release_in(mut self, state: &mut State) {
        if let Some((arena, name, id)) = self.held.take() {
            arena.release(state, &name, &id);
        }
    }
}

/// A routing refusal: the fatal error's code and message.
pub(crate) type Refusal = (ErrorCode, String);

impl Arena {
    /// Where `hello` goes.
    pub(crate) fn route(&self, hello: &Hello) -> Result<Routed, Refusal> {
        let mut state = self.lock();
        if state.stopping {
            return Err((ErrorCode::ServerStopping, "the server is stopping".into()));
        }
        let seated = hello.role == Role::Agent && hello.session.is_none();
        match (&hello.match_name, &hello.template) {
            (Some(_), Some(_)) => Err((ErrorCode::BadMessage, "name a match or a template, not both".into())),
            (None, Some(_)) if hello.role != Role::Agent => {
                Err((ErrorCode::BadMessage, "only players join by template; watchers name a match".into()))
            }
            (None, Some(_)) if hello.session.is_some() => Err((
                ErrorCode::BadMessage,
                "a session belongs to a match: reconnect with hello.match (welcome.match.name)".into(),
            )),
            (Some(name), None) => self.route_to_match(&mut state, name, seated),
            (None, Some(template)) => self.route_to_template(&mut state, template),
            (None, None) => {
                let Some(default) = self.inner.config.default.clone() else {
                    return Err((ErrorCode::UnknownMatch, self.no_match_named(&state, None)));
                };
                let is_template =
                    !state.live.contains_key(&default) && state.templates.contains_key(&default);
                if is_template && seated {
                    self.route_to_template(&mut state, &default)
                } else {
                    let name = self.default_match(&state).unwrap_or(default);
                    self.route_to_match(&mut state, &name, seated)
                }
            }
        }
    }

    fn route_to_match(&self, state: &mut State, name: &str, seated: bool) -> Result<Routed, Refusal> {
        let Some(live) = state.live.get_mut(name) else {
            return Err((ErrorCode::UnknownMatch, self.no_match_named(state, Some(name))));
        };
        let claim = (seated && !live.started.load(Ordering::Relaxed)).then(|| {
            live.claims += 1;
            Claim { held: Some((self.clone(), name.to_string(), live.id.clone())) }
        });
        Ok(Routed::Match(Route { events: live.events.clone(), claim }))
    }

    fn route_to_template(&self, state: &mut State, template: &str) -> Result<Routed, Refusal> {
        if !state.templates.contains_key(template) {
            let known: Vec<&str> = state.templates.keys().map(String::as_str).collect();
            return Err((
                ErrorCode::UnknownTemplate,
                format!("no template named '{template}' (this server has: {})", known.join(", ")),
            ));
        }
        if let Some(route) = self.free_seat(state, template) {
            return Ok(Routed::Match(route));
        }
        let (tx, rx) = mpsc::channel(4);
        let Some(t) = state.templates.get_mut(template) else {
            return Err((ErrorCode::UnknownTemplate, format!("no template named '{template}'")));
        };
        t.queue.retain(|waiter| !waiter.is_closed());
        t.queue.push_back(tx);
        Ok(Routed::Queued(rx, t.queue.len()))
    }

    /// A seat in a waiting match of `template`, claimed: in a match already made, or in a
    /// new one if the template makes matches on demand and may run one more.
    fn free_seat(&self, state: &mut State, template: &str) -> Option<Route> {
        let found = state.live.iter_mut().find(|(_, l)| {
            l.template.as_deref() == Some(template)
                && !l.started.load(Ordering::Relaxed)
                && l.claims < l.open_seats
        });
        let name = match found {
            Some((name, _)) => name.clone(),
            None => {
                let t = state.templates.get(template)?;
                let on_demand = t.template.names.is_empty();
                if !on_demand || t.running >= t.template.max_running {
                    return None;
                }
                match self.make_from_template(state, template, None) {
                    Ok(name) => name,
                    Err(e) => {
                        tracing::error!(target: "bw4t::arena", template, error = %e, "cannot make a match");
                        return None;
                    }
                }
            }
        };
        let live = state.live.get_mut(&name)?;
        live.claims += 1;
        let claim = Claim { held: Some((self.clone(), name, live.id.clone())) };
        Some(Route { events: live.events.clone(), claim: Some(claim) })
    }

    /// Gives a claimed seat back and offers it to the template's queue.
    pub(super) fn release(&self, state: &mut State, name: &str, id: &str) {
        let Some(live) = state.live.get_mut(name).filter(|l| l.id == id) else { return };
        live.claims = live.claims.saturating_sub(1);
        if let Some(template) = live.template.clone() {
            self.serve_queue(state, &template);
        }
    }

    /// Seats queued players of `template` while there are seats, and tells the rest their
    /// new places.
    pub(super) fn serve_queue(&self, state: &mut State, template: &str) {
        loop {
            let waiting = state.templates.get_mut(template).map(|t| {
                t.queue.retain(|waiter| !waiter.is_closed());
                !t.queue.is_empty()
            });
            if waiting != Some(true) {
                break;
            }
            let Some(route) = self.free_seat(state, template) else { break };
            let Some(waiter) = state.templates.get_mut(template).and_then(|t| t.queue.pop_front()) else {
                if let Some(claim) = route.claim {
                    claim.release_in(state);
                }
                break;
            };
            if let Err(e) = waiter.try_send(QueueNews::Seat(route)) {
                // The player left the queue: its seat goes back at once.
                let news = match e {
                    mpsc::error::TrySendError::Full(news) | mpsc::error::TrySendError::Closed(news) => news,
                };
                if let QueueNews::Seat(Route { claim: Some(claim), .. }) = news {
                    claim.release_in(state);
                }
            }
        }
        if let Some(t) = state.templates.get(template) {
            for (place, waiter) in t.queue.iter().enumerate() {
                let _ = waiter.try_send(QueueNews::Place(place + 1));
            }
        }
    }

    /// Why `name` (or, with none, the default) names no live match, with the live ones.
    fn no_match_named(&self, state: &State, name: Option<&str>) -> String {
        let live: Vec<&str> = state.live.keys().take(10).map(String::as_str).collect();
        let more = if state.live.len() > live.len() { ", ..." } else { "" };
        let live = if live.is_empty() { "none".to_string() } else { format!("{}{more}", live.join(", ")) };
        match name {
            Some(name) if state.finished.iter().any(|f| f.name == name) => {
                format!("match '{name}' is over (live matches: {live})")
            }
            Some(name) => format!("no live match named '{name}' (live matches: {live})"),
            None => {
                format!("this server has no default match: name one in hello.match (live matches: {live})")
            }
        }
    }
}
