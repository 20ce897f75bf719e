//! Masks are exactly the valid actions: allowed ones are accepted by the match, masked-out
//! ones do nothing (and the match would have refused those it could be asked).

use bw4t_map::SeededRng;
use bw4t_sim::Action;

use super::{Buffers, default_map};
use crate::bench::choose;
use crate::{ActionOutcome, Env, EnvConfig};

#[test]
fn allowed_actions_are_accepted_and_masked_ones_do_nothing() {
    let config = EnvConfig::parallel(default_map(), 3);
    let (mut played, mut twin) = (Env::new(config.clone()).expect("env"), Env::new(config).expect("env"));
    let (mut p, mut t) = (Buffers::for_env(&played), Buffers::for_env(&twin));
    p.reset(&mut played, 5);
    t.reset(&mut twin, 5);
    let n = played.spaces().n_actions();
    let mut rng = SeededRng::new(9);
    let (mut accepted, mut masked) = (0, 0);
    for step in 0..400 {
        assert_eq!(p.obs, t.obs);
        assert_eq!(p.masks, t.masks);
        choose(&mut rng, &p.masks, n, &mut p.actions);
        t.actions.copy_from_slice(&p.actions);
        // Every third step robot 0 of `played` tries an action its mask forbids; its twin waits.
        let forbidden: Vec<u32> = (0..n as u32).filter(|&a| p.masks[a as usize] == 0).collect();
        let cheat = step % 3 == 0 && !forbidden.is_empty();
        if cheat {
            p.actions[0] = forbidden[rng.below(forbidden.len() as u64) as usize];
            t.actions[0] = 0;
        }
        // What the mask forbids of pickUp and putDown the match refuses, changing nothing.
        let robot = twin.robot(0).expect("robot");
        let spaces = twin.spaces().clone();
        for (name, action) in [("pick_up", Action::PickUp(None)), ("put_down", Action::PutDown)] {
            let at = spaces.action_segment(name).expect("segment").offset;
            if t.masks[at] == 0 {
                let before = twin.digest();
                assert!(twin.game_mut().handle_action(robot, &action).is_err(), "{name} at step {step}");
                assert_eq!(twin.digest(), before);
            }
        }
        let actions = p.actions.clone();
        p.step(&mut played);
        t.step(&mut twin);
        assert_eq!(played.digest(), twin.digest(), "step {step}");
        for (agent, outcome) in played.outcomes().enumerate() {
            let action = actions[agent];
            match outcome {
                ActionOutcome::Masked => {
                    assert!(cheat && agent == 0, "step {step}: agent {agent}'s {action} masked");
                    masked += 1;
                }
                ActionOutcome::Waited => assert_eq!(action, 0, "step {step}"),
                ActionOutcome::Accepted => accepted += 1,
                ActionOutcome::Rejected(code) => {
                    let (segment, _) = spaces.action_at(action as usize).expect("in range");
                    assert_eq!((segment, code), ("put_down", "no_space"), "step {step}: agent {agent}");
                }
                ActionOutcome::Dropped => panic!("step {step}: nothing ended the episode"),
            }
        }
    }
    assert!(masked > 100 && accepted > 500, "masked {masked}, accepted {accepted}");
}

#[test]
fn the_mask_follows_what_the_robot_sees() {
    let mut env = Env::new(EnvConfig::parallel(default_map(), 1)).expect("env");
    let mut b = Buffers::for_env(&env);
    b.reset(&mut env, 3);
    let s = env.spaces().clone();
    let at = |name: &str| s.action_segment(name).expect("segment").clone();
    assert_eq!(b.masks[at("wait").offset], 1);
    assert!(b.masks[at("go_to").offset..at("go_to").offset + s.dims.places].iter().all(|&m| m == 1));
    assert_eq!(b.masks[at("pick_up").offset], 0, "not at a block");
    assert_eq!(b.masks[at("put_down").offset], 0, "holding nothing");
    let go_to_block = at("go_to_block");
    assert!(b.masks[go_to_block.offset..go_to_block.offset + go_to_block.len].iter().all(|&m| m == 0));
    // Alone, there is nobody to talk to.
    let says = at("say_will_get").offset;
    assert!(b.masks[says..].iter().all(|&m| m == 0));
}
