//! A robot encoded from outside ([`RecordedView`]) equals the environment's own encoding,
//! and an action's index is the inverse of the action encoding.

use bw4t_agents::Strategy;
use bw4t_map::SeededRng;
use bw4t_sim::{Action, Receiver};

use super::{Buffers, default_map};
use crate::{Env, EnvConfig, RecordedView};

#[test]
fn a_view_fed_the_learners_deltas_encodes_as_the_environment_does_and_inverts_its_actions() {
    let config = EnvConfig::single(default_map(), 2, Strategy::Cooperative);
    let max_ticks = config.setup.max_ticks.expect("a limit");
    let mut env = Env::new(config).expect("env");
    let mut buffers = Buffers::for_env(&env);
    buffers.reset(&mut env, 3);
    let mut view = RecordedView::new(&env.config().setup.map, env.config().slots);
    assert_eq!(view.spaces(), env.spaces());
    let (obs_len, n) = (view.spaces().obs_len(), view.spaces().n_actions());
    let (mut obs, mut mask) = (vec![0.0; obs_len], vec![0; n]);
    let mut rng = SeededRng::new(11);
    let mut inverted = 0;
    for _ in 0..300 {
        view.start_step();
        if let Some(delta) = env.delta(0) {
            view.apply(delta);
        }
        view.observe(env.game(), max_ticks, &mut obs);
        view.mask(true, &mut mask);
        assert_eq!(obs, buffers.obs, "observation at tick {}", env.tick());
        assert_eq!(mask, buffers.masks, "mask at tick {}", env.tick());
        for index in (1..n as u32).filter(|&i| mask[i as usize] == 1) {
            let action = view.action_at(env.game(), index).expect("an allowed index is an action");
            assert_eq!(view.index_of(env.game(), &mask, &action), Some(index), "{action:?}");
            inverted += 1;
        }
        let allowed: Vec<u32> = (0..n as u32).filter(|&i| mask[i as usize] == 1).collect();
        buffers.actions[0] = allowed[rng.below(allowed.len() as u64) as usize];
        if buffers.step(&mut env).done() {
            break;
        }
    }
    assert!(inverted > 1000, "every allowed index of every step was inverted ({inverted})");
    // Actions no index stands for.
    let private = Action::SendMessage { to: Receiver::Player("Bot1".into()), text: "hi".into() };
    let free_text = Action::SendMessage { to: Receiver::All, text: "hello there".into() };
    let far_block = Action::GoToBlock(9999);
    for action in [private, free_text, far_block] {
        assert_eq!(view.index_of(env.game(), &mask, &action), None, "{action:?}");
    }
}
