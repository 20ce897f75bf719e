//! What a routed connection holds (the decisions are the core's, `core/route.rs`): the
//! match's channel and, while the match waits, a [`Claim`] on one of its seats; or a
//! place in a template's queue ([`Waiting`]). Each gives itself back to the arena when
//! dropped, so a connection that closes, however it ends, frees what it held.

use tokio::sync::mpsc;

use super::core::Ticket;
use super::shell::Command;
use crate::events::Event;

/// Where a `hello` goes.
pub(crate) enum Routed {
    /// To this match now.
    Match(Route),
    /// Into a template's queue, at this place (1: next); news comes from the [`Waiting`].
    Queued(Waiting, usize),
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
    held: Option<(mpsc::UnboundedSender<Command>, String, String)>,
}

impl Claim {
    /// A claim on a seat of run `id` of match `name`, given back through `commands`.
    pub(super) fn new(commands: mpsc::UnboundedSender<Command>, name: String, id: String) -> Claim {
        Claim { held: Some((commands, name, id)) }
    }

    /// Takes the claim apart without giving it back: its match's name and run id, for
    /// the arena's task to give back itself.
    pub(super) fn disarm(mut self) -> Option<(String, String)> {
        self.held.take().map(|(_, name, id)| (name, id))
    }
}

impl Drop for Claim {
    fn drop(&mut self) {
        if let Some((commands, name, id)) = self.held.take() {
            let _ = commands.send(Command::Released { name, id });
        }
    }
}

/// A place in a template's queue: news of it comes here; leaving it (dropping this) tells
/// the arena, so the players behind move up.
pub(crate) struct Waiting {
    news: mpsc::UnboundedReceiver<QueueNews>,
    left: Option<(mpsc::UnboundedSender<Command>, Ticket)>,
}

impl Waiting {
    /// The place of queued player `waiter`, whose news comes on `news`.
    pub(super) fn new(
        news: mpsc::UnboundedReceiver<QueueNews>,
        commands: Option<mpsc::UnboundedSender<Command>>,
        waiter: Ticket,
    ) -> Waiting {
        Waiting { news, left: commands.map(|c| (c, waiter)) }
    }

    /// The next news; `None` when the queue is gone (the server is stopping).
    pub(crate) async fn recv(&mut self) -> Option<QueueNews> {
        self.news.recv().await
    }
}

impl Drop for Waiting {
    fn drop(&mut self) {
        if let Some((commands, waiter)) = self.left.take() {
            let _ = commands.send(Command::LeftQueue { waiter });
        }
    }
}
