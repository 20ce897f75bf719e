//! The whole-match view for spectators and the browser page: a [`Frame`] of a match now.

use bw4t_sim::{BlockPlace, Match};

use crate::messages::{Frame, FrameBlock, FrameMessage, FrameRobot};

impl Frame {
    /// The god view of `game` now, with the messages sent since the previous frame.
    pub fn of(game: &Match, messages: Vec<FrameMessage>) -> Frame {
        let zones = game.map().zones();
        let robots: Vec<FrameRobot> = game
            .robots()
            .map(|r| FrameRobot {
                id: r.id.0,
                name: r.name.to_string(),
                x: r.pos.x,
                y: r.pos.y,
                state: r.state.into(),
                holding: r.holding,
            })
            .collect();
        let blocks = game
            .blocks()
            .filter_map(|(id, colour, place)| {
                let (x, y, held_by) = match place {
                    BlockPlace::Room { pos, .. } => (pos.x, pos.y, None),
                    BlockPlace::Held(r) => {
                        let holder = robots.iter().find(|fr| fr.id == r.0)?;
                        (holder.x, holder.y, Some(r.0))
                    }
                    BlockPlace::Gone => return None,
                };
                Some(FrameBlock { id, color: colour.name().into(), x, y, held_by })
            })
            .collect();
        let occupied =
            (0..zones.len()).filter(|&z| game.occupant(z).is_some()).map(|z| zones[z].name.clone()).collect();
        Frame {
            tick: game.tick(),
            sim_seconds: game.config().seconds(game.tick()),
            sequence: game.sequence().iter().map(|c| c.name().to_string()).collect(),
            sequence_index: game.sequence_index(),
            robots,
            blocks,
            occupied,
            messages,
        }
    }
}
