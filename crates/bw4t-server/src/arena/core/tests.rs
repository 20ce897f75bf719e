//! The core on a simulated clock: events in, actions out, no tokio. Every match the core
//! asks for is made at once (as the shell does) unless a test says otherwise; a match's
//! handle is its run id, so the actions say where each player went.

use std::collections::{BTreeMap, VecDeque};
use std::time::{Duration, Instant};

use bw4t_protocol::{EndReason, MatchResult, Mode, Role};

use super::{
    Action, Core, Event, Facts, Launch, Make, MakeFrom, Outcome, Recipe, Routing, Rules, Seek, Ticket,
};
use crate::arena::{ArenaError, OnEnd};

fn rules(
    name: &str,
    names: &[&str],
    max_running: usize,
    on_end: OnEnd,
    maps: usize,
    open_seats: usize,
) -> Rules {
    Rules {
        name: name.to_string(),
        names: names.iter().map(|n| n.to_string()).collect(),
        max_running,
        on_end,
        maps,
        open_seats,
        invited_only: false,
    }
}

/// A template making matches on demand, of `open_seats` seats each, at most `max` at once.
fn on_demand(name: &str, max: usize, open_seats: usize) -> Rules {
    rules(name, &[], max, OnEnd::Stay, 1, open_seats)
}

fn facts_of(launch: &Launch) -> Facts {
    let seed = match launch.recipe {
        Recipe::Template { seed: Some(seed), .. } => seed,
        Recipe::Template { n, .. } => 5 + n,
        Recipe::Given(_) => 99,
    };
    Facts { map: "Default".into(), mode: Mode::Lockstep, seed, robots: 2, watch_open: true }
}

fn played(ticks: u64) -> Outcome {
    Ok(MatchResult {
        map: "Default".into(),
        seed: 0,
        mode: Some(Mode::Lockstep),
        robots: 2,
        completed: false,
        end_reason: EndReason::MaxTicks,
        ticks,
        completed_tick: None,
        sim_seconds: 0.0,
        wall_ms: 0,
        sequence: Vec::new(),
        sequence_index: 0,
        good_drops: 0,
        wrong_drops: 0,
        messages: 0,
        digest: String::new(),
        per_robot: Vec::new(),
        pauses: 0,
    })
}

fn player_by_template(template: &str) -> Seek {
    Seek {
        match_name: None,
        template: Some(template.into()),
        role: Role::Agent,
        session: false,
        invited: None,
        seed: None,
    }
}

fn player_in(name: &str) -> Seek {
    Seek {
        match_name: Some(name.into()),
        template: None,
        role: Role::Agent,
        session: false,
        invited: None,
        seed: None,
    }
}

fn spectator_of(name: &str) -> Seek {
    Seek {
        match_name: Some(name.into()),
        template: None,
        role: Role::Spectator,
        session: false,
        invited: None,
        seed: None,
    }
}

fn no_name() -> Seek {
    Seek { match_name: None, template: None, role: Role::Agent, session: false, invited: None, seed: None }
}

/// One line per action, so a test compares what the core did with what it should.
fn said(actions: &[Action<String>]) -> Vec<String> {
    actions
        .iter()
        .map(|action| match action {
            Action::Spawn(Launch { id, recipe: Recipe::Template { n, map, seed }, .. }) => {
                let seed = seed.map_or(String::new(), |s| format!(" seed {s}"));
                format!("spawn {id} n{n} map{map}{seed}")
            }
            Action::Spawn(Launch { id, recipe: Recipe::Given(_), .. }) => format!("spawn {id} given"),
            Action::Route { ticket, routing: Routing::Match { handle, claim, .. } } => {
                format!("route {ticket} to {handle}{}", if *claim { " claimed" } else { "" })
            }
            Action::Route { ticket, routing: Routing::Queued { place } } => {
                format!("route {ticket} queued {place}")
            }
            Action::Route { ticket, routing: Routing::Refused((code, _)) } => {
                format!("refuse {ticket} {code}")
            }
            Action::Place { waiter, place } => format!("place {waiter} {place}"),
            Action::Seat { waiter, handle, .. } => format!("seat {waiter} in {handle}"),
            Action::Dismiss { waiter } => format!("dismiss {waiter}"),
            Action::Record { row, .. } => format!("record {} index {} seed {}", row.key, row.index, row.seed),
            Action::Stop { handle } => format!("stop {handle}"),
            Action::StopAll => "stop all".into(),
            Action::Answer { ticket, answer: Ok(what) } => format!("answer {ticket} {what}"),
            Action::Answer { ticket, answer: Err(e) } => format!("answer {ticket} error {e}"),
        })
        .collect()
}

/// A core driven as the shell drives it, on a clock the test moves.
struct Sim {
    core: Core<String>,
    now: Instant,
    tickets: Ticket,
}

impl Sim {
    fn new(templates: Vec<Rules>) -> Sim {
        Sim::with(templates, (BTreeMap::new(), 0), None, false)
    }

    fn with(
        templates: Vec<Rules>,
        history: (BTreeMap<String, u64>, u64),
        default: Option<&str>,
        once: bool,
    ) -> Sim {
        let core = Core::new(templates, history, default.map(str::to_string), once).expect("a core");
        Sim { core, now: Instant::now(), tickets: 0 }
    }

    fn ticket(&mut self) -> Ticket {
        self.tickets += 1;
        self.tickets
    }

    fn later(&mut self, seconds: u64) {
        self.now += Duration::from_secs(seconds);
    }

    /// What the core answers to `event` alone.
    fn raw(&mut self, event: Event<String>) -> Vec<Action<String>> {
        self.core.handle(self.now, event)
    }

    /// What the core answers to `event`, every match it asks for being made at once.
    fn feed(&mut self, event: Event<String>) -> Vec<Action<String>> {
        let mut all = Vec::new();
        let mut events = VecDeque::from([event]);
        while let Some(event) = events.pop_front() {
            for action in self.core.handle(self.now, event) {
                if let Action::Spawn(launch) = &action {
                    let (name, id) = (launch.name.clone(), launch.id.clone());
                    events.push_back(Event::Spawned {
                        name,
                        id: id.clone(),
                        handle: id,
                        facts: facts_of(launch),
                    });
                }
                all.push(action);
            }
        }
        all
    }

    /// Routes a `hello`: its ticket and what the core did.
    fn hello(&mut self, seek: Seek) -> (Ticket, Vec<String>) {
        let ticket = self.ticket();
        (ticket, said(&self.feed(Event::Hello { ticket, seek })))
    }

    /// Makes the named matches of the templates, as `Arena::start` does.
    fn start(&mut self, named: &[(&str, &str)]) -> Vec<String> {
        let mut out = Vec::new();
        for (template, name) in named {
            let ticket = self.ticket();
            let make = Make {
                name: Some(name.to_string()),
                template: Some(template.to_string()),
                from: MakeFrom::Template,
                seed: None,
            };
            out.extend(said(&self.feed(Event::Make { ticket, make })));
        }
        out
    }

    fn end(&mut self, name: &str, id: &str) -> Vec<String> {
        said(&self.feed(Event::Ended { name: name.into(), id: id.into(), outcome: played(10) }))
    }
}

#[test]
fn a_hello_naming_a_match_goes_there_and_holds_a_seat_until_the_start() {
    let mut sim = Sim::new(vec![rules("classroom", &["team-a", "team-b"], 2, OnEnd::Stay, 1, 1)]);
    assert_eq!(
        sim.start(&[("classroom", "team-a"), ("classroom", "team-b")]),
        ["spawn team-a.1 n0 map0", "answer 1 team-a", "spawn team-b.1 n1 map0", "answer 2 team-b"]
    );
    assert_eq!(sim.hello(player_in("team-b")).1, ["route 3 to team-b.1 claimed"]);
    // Watchers and players of a match already playing hold no seat.
    assert_eq!(sim.hello(spectator_of("team-b")).1, ["route 4 to team-b.1"]);
    sim.raw(Event::Started { name: "team-a".into(), id: "team-a.1".into() });
    assert_eq!(sim.hello(player_in("team-a")).1, ["route 5 to team-a.1"]);
    let (_, refused) = sim.hello(player_in("nowhere"));
    assert_eq!(refused, ["refuse 6 unknown_match"]);
    let ticket = sim.ticket();
    let actions = sim.raw(Event::Hello { ticket, seek: player_in("nowhere") });
    let Some(Action::Route { routing: Routing::Refused((_, why)), .. }) = actions.first() else {
        panic!("{:?}", said(&actions))
    };
    assert!(why.contains("'nowhere'") && why.contains("team-a, team-b"), "{why}");
}

#[test]
fn players_by_template_share_a_new_match_then_wait_in_line() {
    let mut sim = Sim::new(vec![on_demand("open", 1, 2)]);
    // The first player's match is made for it; it is routed once the match is.
    let ticket = sim.ticket();
    let asked = sim.raw(Event::Hello { ticket, seek: player_by_template("open") });
    assert_eq!(said(&asked), ["spawn open-1.1 n0 map0"]);
    let Some(Action::Spawn(launch)) = asked.first() else { unreachable!() };
    let spawned = Event::Spawned {
        name: launch.name.clone(),
        id: launch.id.clone(),
        handle: launch.id.clone(),
        facts: facts_of(launch),
    };
    assert_eq!(said(&sim.raw(spawned)), ["route 1 to open-1.1 claimed"]);
    assert_eq!(sim.hello(player_by_template("open")).1, ["route 2 to open-1.1 claimed"]);
    // Both seats are claimed and the template runs one match at most.
    assert_eq!(sim.hello(player_by_template("open")).1, ["route 3 queued 1"]);
    assert_eq!(sim.hello(player_by_template("open")).1, ["route 4 queued 2"]);
    assert_eq!(sim.core.queued("open"), [3, 4]);
}

#[test]
fn a_claim_given_back_before_the_start_seats_the_first_in_line() {
    let mut sim = Sim::new(vec![on_demand("open", 1, 2)]);
    sim.hello(player_by_template("open"));
    sim.hello(player_by_template("open"));
    sim.hello(player_by_template("open"));
    sim.hello(player_by_template("open"));
    let released = sim.feed(Event::Released { name: "open-1".into(), id: "open-1.1".into() });
    assert_eq!(said(&released), ["seat 3 in open-1.1", "place 4 1"]);
    assert_eq!(sim.core.queued("open"), [4]);
    // A claim of an earlier run of the name gives back nothing.
    let stale = sim.feed(Event::Released { name: "open-1".into(), id: "open-1.0".into() });
    assert_eq!(said(&stale), Vec::<String>::new());
    // Once the match has started, a player leaving frees no seat for the line.
    sim.raw(Event::Started { name: "open-1".into(), id: "open-1.1".into() });
    let after = sim.feed(Event::Released { name: "open-1".into(), id: "open-1.1".into() });
    assert_eq!(said(&after), Vec::<String>::new());
    assert_eq!(sim.core.queued("open"), [4]);
}

#[test]
fn queued_players_are_told_their_place_only_when_it_changes() {
    let mut sim = Sim::new(vec![on_demand("open", 1, 1)]);
    sim.hello(player_by_template("open"));
    let places: Vec<_> = (0..3).map(|_| sim.hello(player_by_template("open")).1).collect();
    assert_eq!(places, [["route 2 queued 1"], ["route 3 queued 2"], ["route 4 queued 3"]]);
    // The middle one leaves: only the one behind it moves up.
    assert_eq!(said(&sim.feed(Event::LeftQueue { waiter: 3 })), ["place 4 2"]);
    // The last one leaves: no one else moves.
    assert_eq!(said(&sim.feed(Event::LeftQueue { waiter: 4 })), Vec::<String>::new());
    assert_eq!(sim.core.queued("open"), [2]);
    // Leaving twice (seated, then the connection closes) is harmless.
    assert_eq!(said(&sim.feed(Event::LeftQueue { waiter: 4 })), Vec::<String>::new());
}

#[test]
fn a_template_runs_at_most_max_running_matches_and_an_end_makes_room() {
    let mut sim = Sim::new(vec![on_demand("open", 2, 1)]);
    assert_eq!(
        sim.hello(player_by_template("open")).1,
        ["spawn open-1.1 n0 map0", "route 1 to open-1.1 claimed"]
    );
    assert_eq!(
        sim.hello(player_by_template("open")).1,
        ["spawn open-2.1 n1 map0", "route 2 to open-2.1 claimed"]
    );
    assert_eq!(sim.hello(player_by_template("open")).1, ["route 3 queued 1"]);
    assert_eq!(sim.hello(player_by_template("open")).1, ["route 4 queued 2"]);
    // A match ends: the line gets a new match, on the template's next seed.
    assert_eq!(
        sim.end("open-1", "open-1.1"),
        ["record open-1.1 index 1 seed 5", "spawn open-3.1 n2 map0", "seat 3 in open-3.1", "place 4 1"]
    );
    assert_eq!(sim.core.live_count(), 2);
}

#[test]
fn restart_plays_the_next_seed_and_next_walks_the_maps() {
    let mut sim = Sim::new(vec![
        rules("ladder", &["ladder"], 1, OnEnd::Restart, 3, 0),
        rules("tour", &["tour"], 1, OnEnd::Next, 3, 0),
    ]);
    assert_eq!(
        sim.start(&[("ladder", "ladder"), ("tour", "tour")]),
        ["spawn ladder.1 n0 map0", "answer 1 ladder", "spawn tour.1 n0 map0", "answer 2 tour"]
    );
    let mut seen = Vec::new();
    for run in 1..=4 {
        seen.extend(sim.end("ladder", &format!("ladder.{run}")));
        seen.extend(sim.end("tour", &format!("tour.{run}")));
    }
    assert_eq!(
        seen,
        [
            "record ladder.1 index 1 seed 5",
            "spawn ladder.2 n1 map0",
            "record tour.1 index 2 seed 5",
            "spawn tour.2 n1 map1",
            "record ladder.2 index 3 seed 6",
            "spawn ladder.3 n2 map0",
            "record tour.2 index 4 seed 6",
            "spawn tour.3 n2 map2",
            "record ladder.3 index 5 seed 7",
            "spawn ladder.4 n3 map0",
            "record tour.3 index 6 seed 7",
            "spawn tour.4 n3 map0",
            "record ladder.4 index 7 seed 8",
            "spawn ladder.5 n4 map0",
            "record tour.4 index 8 seed 8",
            "spawn tour.5 n4 map1",
        ]
    );
    assert_eq!(sim.core.totals()["ladder"].ended, 4);
    assert_eq!(sim.core.totals()["tour"].ticks, 40);
}

#[test]
fn run_ids_and_the_index_go_on_from_the_history() {
    let history = (BTreeMap::from([("ladder".to_string(), 7)]), 12);
    let mut sim =
        Sim::with(vec![rules("ladder", &["ladder"], 1, OnEnd::Restart, 1, 0)], history, None, false);
    assert_eq!(sim.start(&[("ladder", "ladder")]), ["spawn ladder.8 n0 map0", "answer 1 ladder"]);
    let ended = sim.feed(Event::Ended { name: "ladder".into(), id: "ladder.8".into(), outcome: played(3) });
    let Some(Action::Record { row, .. }) = ended.first() else { panic!("{:?}", said(&ended)) };
    assert_eq!((row.key.as_str(), row.index, row.repetition, row.ticks), ("ladder.8", 13, 7, 3));
    assert_eq!(said(&ended)[1], "spawn ladder.9 n1 map0");
}

#[test]
fn a_server_run_once_starts_nothing_after_an_end() {
    let mut sim = Sim::with(
        vec![rules("ladder", &["ladder"], 1, OnEnd::Restart, 1, 0)],
        (BTreeMap::new(), 0),
        None,
        true,
    );
    sim.start(&[("ladder", "ladder")]);
    assert_eq!(sim.end("ladder", "ladder.1"), ["record ladder.1 index 1 seed 5"]);
    assert_eq!((sim.core.live_count(), sim.core.ended()), (0, 1));
}

#[test]
fn shutdown_lets_the_line_go_stops_every_match_and_makes_no_more() {
    let mut sim =
        Sim::new(vec![rules("ladder", &["ladder"], 1, OnEnd::Restart, 1, 1), on_demand("open", 1, 1)]);
    sim.start(&[("ladder", "ladder")]);
    sim.hello(player_by_template("open"));
    sim.hello(player_by_template("open"));
    sim.hello(player_by_template("open"));
    assert_eq!(said(&sim.feed(Event::Shutdown)), ["dismiss 3", "dismiss 4", "stop all"]);
    assert_eq!(sim.core.queued("open"), Vec::<Ticket>::new());
    assert_eq!(sim.hello(player_in("ladder")).1, ["refuse 5 server_stopping"]);
    let ticket = sim.ticket();
    let make = Make {
        name: Some("late".into()),
        template: None,
        from: MakeFrom::Given { open_seats: 1 },
        seed: None,
    };
    assert_eq!(said(&sim.feed(Event::Make { ticket, make })), ["answer 6 error the server is stopping"]);
    // The ladder ends for good; a queued player's late departure changes nothing.
    assert_eq!(sim.end("ladder", "ladder.1"), ["record ladder.1 index 1 seed 5"]);
    assert_eq!(said(&sim.feed(Event::LeftQueue { waiter: 4 })), Vec::<String>::new());
    assert_eq!(sim.end("open-1", "open-1.1"), ["record open-1.1 index 2 seed 5"]);
    assert_eq!(sim.core.live_count(), 0);
}

#[test]
fn a_taken_name_and_an_unknown_template_are_refused() {
    let mut sim = Sim::new(vec![rules("base", &["base"], 1, OnEnd::Stay, 1, 1)]);
    sim.start(&[("base", "base")]);
    let make = |sim: &mut Sim, name: Option<&str>, template: Option<&str>| {
        let ticket = sim.ticket();
        let from = MakeFrom::Given { open_seats: 1 };
        let make =
            Make { name: name.map(str::to_string), template: template.map(str::to_string), from, seed: None };
        said(&sim.feed(Event::Make { ticket, make }))
    };
    assert_eq!(make(&mut sim, Some("base"), None), ["answer 2 error a match named 'base' is running"]);
    assert_eq!(make(&mut sim, Some("demo"), Some("nope")), ["answer 3 error no template named 'nope'"]);
    // Unnamed, a match takes its template's next number.
    assert_eq!(make(&mut sim, None, Some("base")), ["spawn base-2.1 given", "answer 4 base-2"]);
    let (_, refused) = sim.hello(player_by_template("nope"));
    assert_eq!(refused, ["refuse 5 unknown_template"]);
    // A session is taken back through its match, not a template.
    let seek = Seek { session: true, ..player_by_template("base") };
    assert_eq!(sim.hello(seek).1, ["refuse 6 bad_message"]);
}

#[test]
fn a_match_that_cannot_be_made_is_forgotten_and_its_player_waits_in_line() {
    let mut sim = Sim::new(vec![on_demand("open", 1, 1)]);
    let ticket = sim.ticket();
    assert_eq!(
        said(&sim.raw(Event::Hello { ticket, seek: player_by_template("open") })),
        ["spawn open-1.1 n0 map0"]
    );
    let failed = Event::SpawnFailed {
        name: "open-1".into(),
        id: "open-1.1".into(),
        error: ArenaError::Bad("no".into()),
    };
    assert_eq!(said(&sim.raw(failed)), ["route 1 queued 1"]);
    assert_eq!(sim.core.live_count(), 0);
    // A request's match that cannot be made is answered so, and its run number is not used up.
    let make = || Make {
        name: Some("solo".into()),
        template: None,
        from: MakeFrom::Given { open_seats: 1 },
        seed: None,
    };
    assert_eq!(said(&sim.raw(Event::Make { ticket: 2, make: make() })), ["spawn solo.1 given"]);
    let failed =
        Event::SpawnFailed { name: "solo".into(), id: "solo.1".into(), error: ArenaError::Bad("no".into()) };
    assert_eq!(said(&sim.raw(failed)), ["answer 2 error no"]);
    assert_eq!(said(&sim.raw(Event::Make { ticket: 3, make: make() })), ["spawn solo.1 given"]);
}

#[test]
fn a_stop_is_answered_once_the_match_has_ended() {
    let mut sim = Sim::new(vec![rules("ladder", &["ladder"], 1, OnEnd::Restart, 1, 0)]);
    sim.start(&[("ladder", "ladder")]);
    assert_eq!(said(&sim.feed(Event::Stop { ticket: 7, name: "ladder".into() })), ["stop ladder.1"]);
    assert_eq!(
        sim.end("ladder", "ladder.1"),
        ["record ladder.1 index 1 seed 5", "answer 7 ladder.1", "spawn ladder.2 n1 map0"]
    );
    assert_eq!(
        said(&sim.feed(Event::Stop { ticket: 8, name: "nothing".into() })),
        ["answer 8 error no live match named 'nothing'"]
    );
}

#[test]
fn the_default_is_a_match_or_a_template() {
    let templates = || vec![rules("default", &["default"], 1, OnEnd::Stay, 1, 2), on_demand("open", 1, 1)];
    let mut sim = Sim::with(templates(), (BTreeMap::new(), 0), Some("default"), false);
    sim.start(&[("default", "default")]);
    assert_eq!(sim.hello(no_name()).1, ["route 2 to default.1 claimed"]);
    assert_eq!(sim.core.default_match().as_deref(), Some("default"));
    let mut sim = Sim::with(templates(), (BTreeMap::new(), 0), Some("open"), false);
    assert_eq!(sim.hello(no_name()).1, ["spawn open-1.1 n0 map0", "route 1 to open-1.1 claimed"]);
    assert_eq!(sim.core.default_match().as_deref(), Some("open-1"));
    let mut sim = Sim::new(templates());
    assert_eq!(sim.hello(no_name()).1, ["refuse 1 unknown_match"]);
}

#[test]
fn a_match_s_time_live_is_measured_on_the_clock_it_is_given() {
    let mut sim = Sim::new(vec![rules("base", &["base"], 1, OnEnd::Stay, 1, 1)]);
    sim.later(5);
    sim.start(&[("base", "base")]);
    sim.later(30);
    let ended =
        sim.feed(Event::Ended { name: "base".into(), id: "base.1".into(), outcome: Err("boom".into()) });
    let Some(Action::Record { lasted, row, .. }) = ended.first() else { panic!("{:?}", said(&ended)) };
    assert_eq!(*lasted, Duration::from_secs(30));
    assert_eq!(row.error.as_deref(), Some("the match failed in the server: boom"));
    assert_eq!(sim.core.totals()["base"].failed, 1);
    assert_eq!(sim.core.finished()[0].end_reason, EndReason::Error);
}

#[test]
fn templates_without_a_map_or_with_two_matches_of_one_name_are_refused() {
    let no_map =
        Core::<String>::new(vec![rules("t", &[], 1, OnEnd::Stay, 0, 1)], (BTreeMap::new(), 0), None, false);
    assert!(no_map.is_err_and(|e| e.to_string().contains("has no map")));
    let twice = vec![rules("a", &["x"], 1, OnEnd::Stay, 1, 1), rules("b", &["x"], 1, OnEnd::Stay, 1, 1)];
    let twice = Core::<String>::new(twice, (BTreeMap::new(), 0), None, false);
    assert!(twice.is_err_and(|e| e.to_string().contains("two matches are named 'x'")));
}

#[test]
fn an_invited_only_template_seats_only_players_invited_to_it() {
    let condition = Rules { invited_only: true, ..on_demand("talking", 2, 1) };
    let mut sim = Sim::new(vec![condition, on_demand("open", 1, 1)]);
    let invited = |template: &str| Seek { invited: Some(template.into()), ..player_by_template("talking") };
    assert_eq!(sim.hello(player_by_template("talking")).1, ["refuse 1 not_invited"]);
    assert_eq!(sim.hello(invited("open")).1, ["refuse 2 not_invited"], "an invitation to another template");
    assert_eq!(
        sim.hello(invited("talking")).1,
        ["spawn talking-1.1 n0 map0", "route 3 to talking-1.1 claimed"]
    );
    // Naming the match is no way round: players need the invitation, watchers do not.
    assert_eq!(sim.hello(player_in("talking-1")).1, ["refuse 4 not_invited"]);
    assert_eq!(sim.hello(spectator_of("talking-1")).1, ["route 5 to talking-1.1"]);
    let back = Seek { session: true, ..player_in("talking-1") };
    assert_eq!(sim.hello(back).1, ["route 6 to talking-1.1"], "a session takes its robot back");
    // Other templates stay open to all.
    assert_eq!(
        sim.hello(player_by_template("open")).1,
        ["spawn open-1.1 n0 map0", "route 7 to open-1.1 claimed"]
    );
}

#[test]
fn a_match_made_for_an_invited_player_plays_the_seed_their_seat_carries() {
    let condition = Rules { invited_only: true, ..on_demand("talking", 1, 2) };
    let mut sim = Sim::new(vec![condition]);
    let seeded = |seed: u64| Seek {
        invited: Some("talking".into()),
        seed: Some(seed),
        ..player_by_template("talking")
    };
    // The hello that makes the match gives its seed; the second player joins its free seat.
    assert_eq!(
        sim.hello(seeded(41)).1,
        ["spawn talking-1.1 n0 map0 seed 41", "route 1 to talking-1.1 claimed"]
    );
    assert_eq!(sim.hello(seeded(42)).1, ["route 2 to talking-1.1 claimed"]);
    // The template may run one match: the next player waits, and the match made for the
    // queue (once the first ends) plays the seed of the player first in line, though the
    // template has made a match before (no seed + n).
    assert_eq!(sim.hello(seeded(43)).1, ["route 3 queued 1"]);
    let ended = sim.end("talking-1", "talking-1.1");
    assert_eq!(ended[..2], ["record talking-1.1 index 1 seed 41", "spawn talking-2.1 n1 map0 seed 43"]);
    // A player joining its free seat plays the seed it was made with.
    let plain = Seek { invited: Some("talking".into()), ..player_by_template("talking") };
    assert_eq!(sim.hello(plain).1, ["route 4 to talking-2.1 claimed"]);
    // Without a seed, a match plays the template's next, as before.
    let mut sim = Sim::new(vec![Rules { invited_only: true, ..on_demand("talking", 1, 1) }]);
    let plain = Seek { invited: Some("talking".into()), ..player_by_template("talking") };
    assert_eq!(sim.hello(plain).1, ["spawn talking-1.1 n0 map0", "route 1 to talking-1.1 claimed"]);
    assert_eq!(sim.end("talking-1", "talking-1.1"), ["record talking-1.1 index 1 seed 5"]);
}
