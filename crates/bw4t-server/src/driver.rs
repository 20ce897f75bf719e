//! The tokio driver of a [`MatchHost`]: owns the event channel, the connections' queues,
//! the clock and the timer, and does nothing but carry events in and transmits out (and
//! tell the host how much room the connections' queues have before it hands it
//! anything). A panic inside the host ends this match only: its connections get
//! `match_failed` and the caller the panic's message.

use std::collections::BTreeMap;
use std::future::Future;
use std::sync::Arc;

use bw4t_protocol::MatchResult;
use tokio::sync::{Notify, mpsc, watch};
use tokio::time::{Duration, Instant};

use bw4t_protocol::ErrorCode;

use bw4t_host::{ConnId, HostEvent, MatchHost, Transmit, bye_line, error_line};

use crate::events::{Control, Event, Opened};
use crate::lateness::TickLateness;
use crate::queue::LineQueue;

/// Capacity of the channel from connections to the match task.
pub(crate) const EVENT_QUEUE: usize = 4096;

/// How long the end of a match waits for clients' queues to drain.
const FLUSH_LIMIT: Duration = Duration::from_secs(2);

/// Ticks simulated back to back (lockstep, nobody awaited) before letting other tasks run.
const YIELD_EVERY: u64 = 64;

/// A connection's handles, kept by the driver.
struct Handles {
    tx: LineQueue,
    kill: Arc<Notify>,
    done: watch::Receiver<bool>,
}

/// How a served match ended inside the server.
pub(crate) type Outcome = Result<MatchResult, String>;

/// Runs `host` to its end on the events from `events` (and names of reserved seats whose
/// player will not come from `gone_seats`), or until `shutdown`; calls `started` once the
/// match has started; returns the result once every client's queue has drained (or
/// [`FLUSH_LIMIT`] has passed), or why the host failed.
pub(crate) async fn run(
    mut host: MatchHost,
    mut events: mpsc::Receiver<Event>,
    mut gone_seats: Option<mpsc::Receiver<String>>,
    started: impl FnOnce(),
    lateness: Option<Arc<TickLateness>>,
    shutdown: impl Future<Output = ()>,
) -> Outcome {
    tokio::pin!(shutdown);
    let mut started = Some(started);
    let mut handles: BTreeMap<ConnId, Handles> = BTreeMap::new();
    let mut closing: Vec<watch::Receiver<bool>> = Vec::new();
    let outcome = guarded(|| async {
        let mut back_to_back = 0u64;
        loop {
            flush(&mut host, &mut handles, &mut closing);
            if host.is_over() {
                break;
            }
            if started.is_some() && host.has_started() {
                // The server stops seating players here by template.
                if let Some(started) = started.take() {
                    started();
                }
            }
            let timeout = host.poll_timeout();
            let now = Instant::now();
            if timeout.is_some_and(|t| t <= now.into_std()) {
                // Take in what has arrived, without waiting for anyone, before the boundary.
                while let Ok(event) = events.try_recv() {
                    take(&mut host, event, &mut handles, &mut closing);
                }
                // A stop request must be seen even while ticks run back to back.
                tokio::select! {
                    biased;
                    () = &mut shutdown => host.interrupt(),
                    () = std::future::ready(()) => {}
                }
                rooms(&mut host, &handles);
                host.handle_timeout(Instant::now().into_std());
                record_lateness(&mut host, lateness.as_deref());
                back_to_back += 1;
                if back_to_back.is_multiple_of(YIELD_EVERY) {
                    flush(&mut host, &mut handles, &mut closing);
                    tokio::task::yield_now().await;
                }
                continue;
            }
            back_to_back = 0;
            // Events before the timer: a ready event is taken without arming the timer at all.
            tokio::select! {
                biased;
                () = &mut shutdown => host.interrupt(),
                event = events.recv() => match event {
                    Some(event) => take(&mut host, event, &mut handles, &mut closing),
                    // Every sender is gone only when the acceptor has stopped: end the match.
                    None => host.interrupt(),
                },
                Some(name) = recv_opt(&mut gone_seats) => {
                    rooms(&mut host, &handles);
                    host.handle_event(Instant::now().into_std(), HostEvent::SeatAbandoned { name });
                }
                () = sleep_until_opt(timeout.map(Instant::from_std)) => {
                    rooms(&mut host, &handles);
                    host.handle_timeout(Instant::now().into_std());
                    record_lateness(&mut host, lateness.as_deref());
                }
            }
        }
        rooms(&mut host, &handles);
        let result = host.finish(Instant::now().into_std());
        flush(&mut host, &mut handles, &mut closing);
        result
    })
    .await;
    // Connections routed here as the match ended never joined it: they are told it is over.
    events.close();
    while let Ok(event) = events.try_recv() {
        if let Event::Opened(Opened { tx, kill, done, .. }) = event {
            tx.send(bye_line(bw4t_protocol::Leaving::MatchOver));
            if !tx.close() {
                kill.notify_one();
            }
            closing.push(done);
        }
    }
    if let Err(why) = &outcome {
        // The host cannot be trusted any more: everyone connected is told and let go.
        let error =
            error_line(ErrorCode::MatchFailed, &format!("the match failed in the server: {why}"), true);
        for h in std::mem::take(&mut handles).into_values() {
            h.tx.send_all(vec![error.clone(), bye_line(ErrorCode::MatchFailed)]);
            if !h.tx.close() {
                h.kill.notify_one();
            }
            closing.push(h.done);
        }
    }
    closing.extend(handles.into_values().map(|h| h.done));
    let drained = async {
        for done in &mut closing {
            let _ = done.wait_for(|d| *d).await;
        }
    };
    let _ = tokio::time::timeout(FLUSH_LIMIT, drained).await;
    outcome
}

/// Runs the match's loop, turning a panic inside it into the panic's message.
async fn guarded<F, Fut>(body: F) -> Outcome
where
    F: FnOnce() -> Fut,
    Fut: Future<Output = MatchResult>,
{
    use futures_util::FutureExt;
    std::panic::AssertUnwindSafe(body()).catch_unwind().await.map_err(|panic| {
        panic
            .downcast_ref::<&str>()
            .map(|s| (*s).to_string())
            .or_else(|| panic.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "a panic".to_string())
    })
}

/// Hands one event to the host, keeping a connection's handles here; answers a control
/// request itself.
fn take(
    host: &mut MatchHost,
    event: Event,
    handles: &mut BTreeMap<ConnId, Handles>,
    closing: &mut Vec<watch::Receiver<bool>>,
) {
    let from = match &event {
        Event::BadInput { conn } => Some(*conn),
        _ => None,
    };
    let event = match event {
        Event::Opened(Opened { conn, tx, kill, done }) => {
            let room = tx.room();
            handles.insert(conn, Handles { tx, kill, done });
            HostEvent::Opened { conn, room }
        }
        Event::Messages { conn, messages } => {
            // What one read brought arrived together: one room, one time for all of it.
            tell_rooms(host, handles, Some(conn));
            let now = Instant::now().into_std();
            for message in messages {
                host.handle_event(now, HostEvent::Message { conn, message });
            }
            return;
        }
        Event::BadInput { conn } => HostEvent::BadInput { conn },
        Event::Closed { conn } => {
            // The end of the match waits for this writer too, so nothing queued is cut off.
            if let Some(h) = handles.remove(&conn) {
                park(closing, h.done);
            }
            HostEvent::Closed { conn }
        }
        Event::Control(Control::Status(reply)) => {
            let _ = reply.send(host.status());
            return;
        }
        Event::Control(Control::Stop) => return host.interrupt(),
        Event::Control(Control::Pause(paused)) => return host.set_paused(Instant::now().into_std(), paused),
    };
    tell_rooms(host, handles, from);
    host.handle_event(Instant::now().into_std(), event);
}

/// Tells the host the rooms it needs before an event `from` a connection (or from none).
/// While the match plays, what such an event makes goes to its own connection (acks,
/// errors); the lines to everyone go out at ticks, before which every room is told. A
/// waiting match tells everyone who joins and leaves, so every room is told first. (The
/// host counts what it queues after a room is told, so one room serves many events.)
fn tell_rooms(host: &mut MatchHost, handles: &BTreeMap<ConnId, Handles>, from: Option<ConnId>) {
    match from.and_then(|conn| Some((conn, handles.get(&conn)?))) {
        Some((conn, h)) if host.has_started() => {
            host.handle_event(Instant::now().into_std(), HostEvent::Room { conn, room: h.tx.room() });
        }
        _ => rooms(host, handles),
    }
}

/// Tells the host how much room each connection's queue has now.
fn rooms(host: &mut MatchHost, handles: &BTreeMap<ConnId, Handles>) {
    let now = Instant::now().into_std();
    for (conn, h) in handles {
        host.handle_event(now, HostEvent::Room { conn: *conn, room: h.tx.room() });
    }
}

/// Counts how late the tick just made was, where the server counts it.
fn record_lateness(host: &mut MatchHost, lateness: Option<&TickLateness>) {
    if let (Some(lateness), Some((late, skipped))) = (lateness, host.take_lateness()) {
        lateness.record(late, skipped);
    }
}

/// Hands every pending transmit to its connection's queue, each batch of lines at once (one
/// wake-up of the connection's writer). The host only queues a line when it knows there is
/// room, so a line is refused only by a connection already gone.
fn flush(
    host: &mut MatchHost,
    handles: &mut BTreeMap<ConnId, Handles>,
    closing: &mut Vec<watch::Receiver<bool>>,
) {
    while let Some(transmit) = host.poll_transmit() {
        match transmit {
            Transmit::Lines { conn, lines } => {
                if let Some(h) = handles.get(&conn) {
                    h.tx.send_all(lines);
                }
            }
            Transmit::Close { conn } => {
                if let Some(h) = handles.remove(&conn) {
                    if !h.tx.close() {
                        h.kill.notify_one();
                    }
                    park(closing, h.done);
                }
            }
            Transmit::Kill { conn } => {
                if let Some(h) = handles.remove(&conn) {
                    h.kill.notify_one();
                    park(closing, h.done);
                }
            }
        }
    }
}

/// Keeps a closing connection's writer to wait for at the end, forgetting those done.
fn park(closing: &mut Vec<watch::Receiver<bool>>, done: watch::Receiver<bool>) {
    closing.retain(|done| !*done.borrow());
    closing.push(done);
}

async fn recv_opt<T>(rx: &mut Option<mpsc::Receiver<T>>) -> Option<T> {
    match rx {
        Some(rx) => rx.recv().await,
        None => std::future::pending().await,
    }
}

async fn sleep_until_opt(deadline: Option<Instant>) {
    match deadline {
        Some(t) => tokio::time::sleep_until(t).await,
        None => std::future::pending().await,
    }
}
