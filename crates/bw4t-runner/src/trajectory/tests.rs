//! Trajectories of a headless match agree with the match; bad replays are refused.

use std::io::Write;
use std::sync::{Arc, Mutex};

use bw4t_agents::{MatchSetup, Player, Strategy, named_seats};
use bw4t_env::{RewardMode, Rewards};
use bw4t_protocol::{EnvStep, MatchResult, ReplayEvent, ReplayLine, RobotTick, TrajectoryMeta};
use serde_json::json;

use super::{TrajectoryError, TrajectoryKind, TrajectoryOptions, trajectories};

/// A writer whose bytes the test reads afterwards.
#[derive(Clone, Default)]
struct Shared(Arc<Mutex<Vec<u8>>>);

impl Write for Shared {
    fn write(&mut self, bytes: &[u8]) -> std::io::Result<usize> {
        self.0.lock().expect("lock").extend_from_slice(bytes);
        Ok(bytes.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// A headless match of three cooperative robots, its result and its replay.
fn played() -> (MatchResult, String) {
    let map = bw4t_map::Map::from_native(include_str!("../../../../maps/default.toml")).expect("map");
    let setup = MatchSetup {
        seed: 5,
        seats: named_seats(vec![Player::Builtin(Strategy::Cooperative); 3]),
        max_ticks: Some(20_000),
        ..MatchSetup::new(map)
    };
    let out = Shared::default();
    let (result, _) = crate::play(&setup, Some(Box::new(out.clone()))).expect("played");
    let text = String::from_utf8(out.0.lock().expect("lock").clone()).expect("utf-8");
    (result, text)
}

/// The actions the replay recorded per robot id.
fn recorded_actions(text: &str) -> Vec<usize> {
    let mut per_robot = vec![0; 3];
    for line in text.lines() {
        if let Ok(ReplayLine::Tick { events, .. }) = serde_json::from_str(line) {
            for event in events {
                if let ReplayEvent::Act { robot, .. } = event {
                    per_robot[robot as usize] += 1;
                }
            }
        }
    }
    per_robot
}

fn lines<T: serde::de::DeserializeOwned>(lines: &[String]) -> Vec<T> {
    lines.iter().map(|l| serde_json::from_str(l).expect("a trajectory line")).collect()
}

#[test]
fn symbolic_trajectories_hold_every_action_message_and_the_final_state() {
    let (result, text) = played();
    assert!(result.completed, "the coop team completes seed 5");
    let made = trajectories(&text, "m.jsonl", &TrajectoryOptions::default()).expect("exported");
    let meta: &TrajectoryMeta = &made.meta;
    assert_eq!((meta.ticks, meta.good_drops, meta.sequence_index), (result.ticks, result.good_drops, 6));
    assert_eq!(made.files.len(), 3);
    let recorded = recorded_actions(&text);
    for (i, (file, raw)) in made.files.iter().enumerate() {
        let robot = &result.per_robot[i];
        assert_eq!(file, &format!("{}.jsonl", robot.name));
        let ticks: Vec<RobotTick> = lines(raw);
        assert!(ticks.windows(2).all(|w| w[0].tick < w[1].tick), "one line per tick, in order");
        let actions: usize = ticks.iter().map(|t| t.actions.len()).sum();
        assert_eq!(actions, recorded[i], "{}'s actions", robot.name);
        assert_eq!(meta.robots[i].actions, recorded[i]);
        let sent: usize = ticks.iter().map(|t| t.sent.len()).sum();
        assert_eq!(sent as u32, robot.messages_sent, "{}'s messages", robot.name);
        let received: usize = ticks.iter().map(|t| t.received.len()).sum();
        assert!(received > 0 && ticks.iter().all(|t| t.received.iter().all(|m| m.from != robot.name)));
        // Every robot was told the sequence was done, and its words say so.
        let last = ticks.iter().rev().find_map(|t| t.percepts.as_ref()).expect("percepts");
        assert!(last.add.contains(&vec![json!("sequenceIndex"), json!(6)]), "{last:?}");
        assert!(last.words.as_deref().is_some_and(|w| w.contains("all 6 delivered")), "{:?}", last.words);
        assert!(ticks.last().is_some_and(|t| t.tick <= result.ticks));
    }
}

#[test]
fn env_trajectories_reward_the_deliveries_and_end_where_the_match_did() {
    let (result, text) = played();
    let options = TrajectoryOptions {
        kind: TrajectoryKind::Env,
        ticks_per_step: 1,
        rewards: Rewards { mode: RewardMode::Individual, ..Rewards::default() },
        ..TrajectoryOptions::default()
    };
    let made = trajectories(&text, "m.jsonl", &options).expect("exported");
    let env = made.meta.env.as_ref().expect("the encoding");
    let recorded = recorded_actions(&text);
    for (i, (_, raw)) in made.files.iter().enumerate() {
        let robot = &result.per_robot[i];
        let steps: Vec<EnvStep> = lines(raw);
        // One step per tick from tick 0 to the end: the last line is the final observation.
        assert_eq!(steps.len() as u64, result.ticks + 1);
        assert_eq!(steps.last().map(|s| s.tick), Some(result.ticks));
        assert!(steps.last().is_some_and(|s| s.then.is_none()));
        let taken: Vec<_> = steps.iter().filter_map(|s| s.then.clone()).collect();
        let last = taken.last().expect("steps");
        assert!(last.terminated && !last.truncated, "the sequence was completed");
        assert!(taken.iter().rev().skip(1).all(|t| !t.terminated && !t.truncated));
        // Individual rewards: the robot's own drops, less the cost of every step.
        let sum: f64 = taken.iter().map(|t| f64::from(t.reward)).sum();
        let own = f64::from(robot.good_drops) - 0.5 * f64::from(robot.wrong_drops);
        let expected = own - 0.001 * taken.len() as f64;
        assert!((sum - expected).abs() < 1e-3, "{}: {sum} vs {expected}", robot.name);
        let actions: u32 = taken.iter().map(|t| t.taken).sum();
        assert_eq!(actions as usize, recorded[i]);
        assert!(taken.iter().any(|t| t.action != 0), "some actions have an index");
        for step in &steps {
            assert_eq!((step.observation.len(), step.action_mask.len()), (env.obs_len, env.n_actions));
            if let Some(then) = &step.then {
                assert_eq!(step.action_mask[then.action as usize], 1, "a chosen action is allowed");
                assert!(then.left_out <= then.taken);
            }
        }
    }
}

#[test]
fn replays_that_do_not_verify_or_have_no_end_are_refused() {
    let (_, text) = played();
    // Send the first goTo somewhere else: re-simulation then differs.
    let tampered = text
        .lines()
        .map(|l| {
            if l.contains("\"goTo\"") && !l.contains("RoomC3") {
                let changed = serde_json::from_str::<ReplayLine>(l).expect("line");
                let ReplayLine::Tick { tick, mut events, wall_ms } = changed else { return l.to_string() };
                for e in &mut events {
                    if let ReplayEvent::Act { action, args, .. } = e {
                        if action == "goTo" {
                            *args = vec![json!("RoomC3")];
                        }
                    }
                }
                serde_json::to_string(&ReplayLine::Tick { tick, events, wall_ms }).expect("json")
            } else {
                l.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join("\n")
        + "\n";
    assert_ne!(tampered, text);
    let error = trajectories(&tampered, "t.jsonl", &TrajectoryOptions::default()).expect_err("refused");
    assert!(matches!(error, TrajectoryError::Differs { .. }), "{error}");
    assert!(error.to_string().contains("does not verify"), "{error}");
    // Without its end record.
    let cut: String =
        text.lines().filter(|l| !l.contains("\"type\":\"end\"")).map(|l| format!("{l}\n")).collect();
    let error = trajectories(&cut, "c.jsonl", &TrajectoryOptions::default()).expect_err("refused");
    assert!(
        error.to_string().contains("incomplete") && error.to_string().contains("--incomplete"),
        "{error}"
    );
    let allowed = TrajectoryOptions { allow_incomplete: true, ..TrajectoryOptions::default() };
    assert!(trajectories(&cut, "c.jsonl", &allowed).is_ok_and(|t| t.meta.end_reason.is_none()));
    // Not a replay at all, and an option out of range.
    let error =
        trajectories("{\"type\":\"tick\"}\n", "x.jsonl", &TrajectoryOptions::default()).expect_err("refused");
    assert!(error.to_string().contains("line 1"), "{error}");
    let zero = TrajectoryOptions { ticks_per_step: 0, ..TrajectoryOptions::default() };
    assert!(trajectories(&text, "m.jsonl", &zero).is_err_and(|e| e.to_string().contains("ticks per step")));
}
