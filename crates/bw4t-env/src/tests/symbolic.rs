//! The symbolic way in (actions as the match's own, percept deltas out) and the drawings.

use bw4t_sim::{Action, Percept};

use super::default_map;
use crate::{ActionOutcome, Env, EnvConfig};

#[test]
fn symbolic_actions_move_the_robot_and_deltas_report_it() {
    let mut env = Env::new(EnvConfig::parallel(default_map(), 2)).expect("env");
    let first = env.delta(0).expect("a snapshot at reset");
    assert!(
        first.add.iter().any(|p| matches!(p, Percept::Sequence(_))),
        "the reset's delta holds everything seen at the start, the sequence included"
    );
    let names: Vec<&str> = env.agent_names().collect();
    assert_eq!(names, ["Agent1", "Agent2"]);
    let mut rewards = [0.0; 2];
    let end = env.step_actions(vec![Some(Action::GoTo("RoomA1".into())), None], &mut rewards);
    assert!(!end.done());
    let outcomes: Vec<ActionOutcome> = env.outcomes().collect();
    assert_eq!(outcomes, [ActionOutcome::Accepted, ActionOutcome::Waited]);
    // Walk until the robot is in the room; the deltas on the way say so.
    let mut arrived = false;
    for _ in 0..200 {
        env.step_actions(vec![None, None], &mut rewards);
        let in_room = |p: &Percept| matches!(p, Percept::In(room) if &**room == "RoomA1");
        if env.delta(0).is_some_and(|d| d.add.iter().any(in_room)) {
            arrived = true;
            break;
        }
    }
    assert!(arrived, "Agent1 reached RoomA1 and its percepts said so");
    // A refused action is reported with the match's code.
    env.step_actions(vec![Some(Action::PickUp(None)), None], &mut rewards);
    let outcome = env.outcomes().next();
    assert!(
        matches!(outcome, Some(ActionOutcome::Accepted | ActionOutcome::Rejected(_))),
        "pickUp is answered: {outcome:?}"
    );
}

#[test]
fn drawings_show_every_robot_and_lying_block() {
    let mut env = Env::new(EnvConfig::parallel(default_map(), 3)).expect("env");
    let mut rewards = [0.0; 3];
    env.step_actions(vec![None, None, None], &mut rewards);
    let svg = env.render_svg();
    assert_eq!(svg.matches(r#"class="robot""#).count(), 3);
    let lying =
        env.game().blocks().filter(|(_, _, p)| matches!(p, bw4t_sim::BlockPlace::Room { .. })).count();
    assert!(lying > 0);
    assert_eq!(svg.matches(r#"class="block""#).count(), lying);
    assert!(svg.contains(&format!("tick {}: 0 of", env.tick())), "the title names the tick and progress");

    let image = env.render_rgb(4.0);
    assert_eq!(image.pixels.len(), image.width * image.height * 3);
    // Each robot's centre is painted in the robot colour.
    let blue = [29, 79, 145];
    let (min_x, min_y) = env
        .game()
        .map()
        .zones()
        .iter()
        .fold((f32::MAX, f32::MAX), |(x, y), z| (x.min(z.rect.min().x), y.min(z.rect.min().y)));
    for robot in env.game().robots() {
        let px = ((robot.pos.x - min_x + 1.0) * 4.0) as usize;
        let py = ((robot.pos.y - min_y + 1.0) * 4.0) as usize;
        let i = (py * image.width + px) * 3;
        assert_eq!(image.pixels[i..i + 3], blue, "robot {} at pixel ({px}, {py})", robot.name);
    }
    assert_eq!(env.render_rgb(4.0), image, "the same state draws the same image");
}
