//! The lobby's summaries of live and finished matches (`/api/matches`): what the core
//! knows of each, and for a live match where its task says it is.

use std::time::Duration;

use bw4t_host::HostStatus;
use bw4t_protocol::{MatchState, MatchSummary, Watch};
use tokio::sync::oneshot;

use super::core::{Finished, LiveMatch};
use super::shell::Live;
use crate::events::{Control, Event};

/// How long a live match has to say where it is.
const STATUS_WAIT: Duration = Duration::from_secs(1);

/// Whether anyone may watch: the summaries' `watch`.
fn watch_of(open: bool) -> Watch {
    if open { Watch::Open } else { Watch::Token }
}

/// A live match's summary before its task says where it is (waiting at tick 0).
fn summary_of_live(name: &str, live: &LiveMatch<Live>, operator: bool) -> MatchSummary {
    MatchSummary {
        name: name.to_string(),
        template: live.template.clone(),
        map: live.facts.map.clone(),
        mode: live.facts.mode,
        state: MatchState::Waiting,
        players: Vec::new(),
        robots: live.facts.robots,
        awaited: 0,
        tick: 0,
        sequence: [0, 0],
        watch: watch_of(live.facts.watch_open),
        paused: None,
        end_reason: None,
        run: live.run,
        seed: operator.then_some(live.facts.seed),
        id: operator.then(|| live.id.clone()),
        connections: None,
        result: None,
    }
}

/// A live match's summary, its status asked of its task (taken without waiting on the
/// task: one whose queue is full is listed as waiting at tick 0).
pub(super) struct StatusAsked {
    summary: MatchSummary,
    answer: Option<oneshot::Receiver<HostStatus>>,
}

impl StatusAsked {
    /// Asks match `name` where it is.
    pub(super) fn of(name: &str, live: &LiveMatch<Live>, operator: bool) -> StatusAsked {
        let (tx, rx) = oneshot::channel();
        let asked = live
            .handle
            .as_ref()
            .is_some_and(|h| h.events.try_send(Event::Control(Control::Status(tx))).is_ok());
        StatusAsked { summary: summary_of_live(name, live, operator), answer: asked.then_some(rx) }
    }

    /// The summary with the status the match gave within [`STATUS_WAIT`].
    pub(super) async fn answered(mut self, operator: bool) -> MatchSummary {
        let status = match self.answer {
            Some(rx) => tokio::time::timeout(STATUS_WAIT, rx).await.ok().and_then(Result::ok),
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

/// A finished match's summary.
pub(super) fn summary_of_finished(f: &Finished, operator: bool) -> MatchSummary {
    MatchSummary {
        name: f.name.clone(),
        template: f.template.clone(),
        map: f.facts.map.clone(),
        mode: f.facts.mode,
        state: MatchState::Finished,
        players: f.players.clone(),
        robots: f.facts.robots,
        awaited: 0,
        tick: f.tick,
        sequence: [f.sequence.0, f.sequence.1],
        watch: watch_of(f.facts.watch_open),
        paused: None,
        end_reason: Some(f.end_reason),
        run: f.run,
        seed: operator.then_some(f.facts.seed),
        id: operator.then(|| f.id.clone()),
        connections: None,
        result: operator.then(|| f.id.clone()),
    }
}
