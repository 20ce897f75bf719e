//! A learner's view as numbers: its observation and its action mask, and an action index
//! back to the action it stands for.

use bw4t_map::{Colour, ZoneIdx, ZoneKind};
use bw4t_protocol::Said;
use bw4t_sim::{Action, Match, MoveState, Receiver};

use crate::seen::Seen;
use crate::spaces::Spaces;

/// Where each segment starts, looked up once.
#[derive(Clone, Debug)]
pub(crate) struct Codec {
    spaces: Spaces,
    /// Per room index: its zone.
    rooms: Vec<ZoneIdx>,
    /// Per zone: whether a robot may go there.
    walkable: Vec<bool>,
    obs: [usize; 14],
    act: [usize; 9],
    /// A learner's view before it is told anything: every learner's starts as a clone, so
    /// the learners of every environment sharing this codec share the map's place names.
    blank: Seen,
}

/// Observation segments by position in the table.
mod o {
    pub(super) const AT: usize = 0;
    pub(super) const IN_ROOM: usize = 1;
    pub(super) const HOLDING: usize = 2;
    pub(super) const HELD_COLOUR: usize = 3;
    pub(super) const ROOM_COLOURS: usize = 4;
    pub(super) const SLOTS: usize = 5;
    pub(super) const AT_BLOCK: usize = 6;
    pub(super) const SEQUENCE: usize = 7;
    pub(super) const SEQUENCE_INDEX: usize = 8;
    pub(super) const DELIVERED: usize = 9;
    pub(super) const OCCUPIED: usize = 10;
    pub(super) const MOVE_STATE: usize = 11;
    pub(super) const MESSAGES: usize = 12;
    pub(super) const TIME: usize = 13;
}

/// Action segments by position in the table.
mod a {
    pub(super) const WAIT: usize = 0;
    pub(super) const GO_TO: usize = 1;
    pub(super) const GO_TO_BLOCK: usize = 2;
    pub(super) const PICK_UP: usize = 3;
    pub(super) const PUT_DOWN: usize = 4;
    pub(super) const WILL_GET: usize = 5;
    pub(super) const CONTAINS: usize = 6;
    pub(super) const EMPTY: usize = 7;
    pub(super) const GOING_TO: usize = 8;
}

impl Codec {
    pub(crate) fn new(spaces: Spaces, map: &bw4t_map::Map) -> Codec {
        let rooms = (0..map.zones().len()).filter(|&z| map.zones()[z].kind == ZoneKind::Room).collect();
        let walkable = map.zones().iter().map(|z| z.kind.is_walkable()).collect();
        let mut obs = [0; 14];
        obs.iter_mut().zip(spaces.obs_layout()).for_each(|(o, s)| *o = s.offset);
        let mut act = [0; 9];
        act.iter_mut().zip(spaces.action_layout()).for_each(|(o, s)| *o = s.offset);
        Codec { spaces, rooms, walkable, obs, act, blank: Seen::new(map) }
    }

    /// A learner's view before it is told anything.
    pub(crate) fn blank_view(&self) -> Seen {
        self.blank.clone()
    }

    pub(crate) fn spaces(&self) -> &Spaces {
        &self.spaces
    }

    /// Writes a learner's observation into `out` (of the observation's length).
    pub(crate) fn observe(&self, seen: &Seen, game: &Match, max_ticks: u64, out: &mut [f32]) {
        let d = &self.spaces.dims;
        let c = d.colours;
        let known = &seen.knowledge;
        out.fill(0.0);
        if let Some(at) = known.at_zone() {
            out[self.obs[o::AT] + at] = 1.0;
        }
        out[self.obs[o::IN_ROOM]] = f32::from(u8::from(known.room_zone().is_some()));
        if let Some((_, colour)) = known.holding() {
            out[self.obs[o::HOLDING]] = 1.0;
            if let Some(colour) = colour {
                out[self.obs[o::HELD_COLOUR] + colour as usize] = 1.0;
            }
        }
        for (k, &(_, colour)) in known.visible().iter().enumerate() {
            out[self.obs[o::ROOM_COLOURS] + colour as usize] += 1.0;
            if k < d.slots {
                out[self.obs[o::SLOTS] + k * c + colour as usize] = 1.0;
            }
        }
        out[self.obs[o::AT_BLOCK]] = f32::from(u8::from(known.at_block().is_some()));
        let sequence = game.sequence();
        for (i, colour) in sequence.iter().take(d.sequence).enumerate() {
            out[self.obs[o::SEQUENCE] + i * c + *colour as usize] = 1.0;
        }
        let index = (game.sequence_index() as usize).min(d.sequence);
        out[self.obs[o::SEQUENCE_INDEX] + index] = 1.0;
        out[self.obs[o::DELIVERED]..self.obs[o::DELIVERED] + index].fill(1.0);
        for (slot, &zone) in self.rooms.iter().enumerate() {
            out[self.obs[o::OCCUPIED] + slot] = f32::from(u8::from(known.zone_occupied(zone)));
        }
        let state = match known.state().unwrap_or(MoveState::Arrived) {
            MoveState::Arrived => 0,
            MoveState::Traveling => 1,
            MoveState::Collided => 2,
        };
        out[self.obs[o::MOVE_STATE] + state] = 1.0;
        for (i, &n) in seen.messages.iter().enumerate() {
            out[self.obs[o::MESSAGES] + i] = n as f32;
        }
        out[self.obs[o::TIME]] = (game.tick() as f64 / max_ticks.max(1) as f64) as f32;
    }

    /// Writes a learner's action mask into `out` (of the number of actions): 1 for each
    /// action that is valid now.
    pub(crate) fn mask(&self, seen: &Seen, others: bool, out: &mut [u8]) {
        let d = &self.spaces.dims;
        let known = &seen.knowledge;
        let (visible, holding) = (known.visible(), known.holding().is_some());
        out.fill(0);
        out[self.act[a::WAIT]] = 1;
        for (p, &ok) in self.walkable.iter().enumerate() {
            out[self.act[a::GO_TO] + p] = u8::from(ok);
        }
        out[self.act[a::GO_TO_BLOCK]..self.act[a::GO_TO_BLOCK] + visible.len().min(d.slots)].fill(1);
        out[self.act[a::PICK_UP]] = u8::from(known.at_block().is_some() && !holding);
        out[self.act[a::PUT_DOWN]] = u8::from(holding);
        if !others {
            return;
        }
        out[self.act[a::WILL_GET]..self.act[a::WILL_GET] + d.colours].fill(1);
        if known.room_zone().is_some() {
            for &(_, colour) in visible {
                out[self.act[a::CONTAINS] + colour as usize] = 1;
            }
            out[self.act[a::EMPTY]] = u8::from(visible.is_empty());
        }
        out[self.act[a::GOING_TO]..self.act[a::GOING_TO] + d.rooms].fill(1);
    }

    /// The action index `action` stands for (`None`: wait). The caller has checked the mask.
    pub(crate) fn action(&self, seen: &Seen, game: &Match, action: usize) -> Option<Action> {
        let (segment, i) = self.segment_of(action)?;
        let zones = game.map().zones();
        let say = |said: Said| Some(Action::SendMessage { to: Receiver::All, text: said.to_text() });
        let known = &seen.knowledge;
        let room_name = || known.room_zone().map(|r| zones[r].name.clone());
        match segment {
            a::GO_TO => Some(Action::GoTo(zones[i].name.clone())),
            a::GO_TO_BLOCK => known.visible().get(i).map(|&(b, _)| Action::GoToBlock(b)),
            a::PICK_UP => Some(Action::PickUp(None)),
            a::PUT_DOWN => Some(Action::PutDown),
            a::WILL_GET => say(Said { colour: Some(Colour::ALL[i].name().into()), ..Said::new("will_get") }),
            a::CONTAINS => say(Said {
                room: room_name(),
                colour: Some(Colour::ALL[i].name().into()),
                ..Said::new("contains")
            }),
            a::EMPTY => say(Said { room: room_name(), ..Said::new("empty") }),
            a::GOING_TO => {
                say(Said { room: Some(zones[self.rooms[i]].name.clone()), ..Said::new("going_to") })
            }
            _ => None,
        }
    }

    /// The index that stands for `action` now (the inverse of [`Codec::action`]): the
    /// first allowed index the mask (`mask`, as [`Codec::mask`] wrote it) allows whose
    /// action is `action`, a message compared by what it says rather than its spelling.
    /// `None`: no index stands for it (a message to one player, free text or a kind the
    /// action space has no segment for, a block beyond the slots, a masked-out action).
    pub(crate) fn index_of(&self, seen: &Seen, game: &Match, mask: &[u8], action: &Action) -> Option<usize> {
        // `pickUp` naming the block within reach picks up what the unnamed one does.
        let at_block = seen.knowledge.at_block().map(|(b, _)| b);
        let unnamed = Action::PickUp(None);
        let action = match action {
            Action::PickUp(Some(b)) if Some(*b) == at_block => &unnamed,
            other => other,
        };
        // Found by encoding each allowed index forwards, so the inverse cannot drift from
        // the encoding; actions are rare beside ticks, and the space is small.
        (1..self.spaces.n_actions())
            .filter(|&i| mask.get(i) == Some(&1))
            .find(|&i| self.action(seen, game, i).is_some_and(|a| same_action(&a, action)))
    }

    /// The segment (by position in the table) and index within it of an action.
    fn segment_of(&self, action: usize) -> Option<(usize, usize)> {
        let seg = self.act.iter().rposition(|&start| start <= action)?;
        let len = self.spaces.action_layout()[seg].len;
        (action - self.act[seg] < len).then_some((seg, action - self.act[seg]))
    }
}

/// Whether two actions do the same: equal, or messages to the same receiver saying the same
/// message of the language however its text is spelt.
fn same_action(a: &Action, b: &Action) -> bool {
    match (a, b) {
        (Action::SendMessage { to: to_a, text: text_a }, Action::SendMessage { to: to_b, text: text_b }) => {
            to_a == to_b
                && (text_a == text_b
                    || Said::from_text(text_a).is_some_and(|said| Said::from_text(text_b) == Some(said)))
        }
        _ => a == b,
    }
}
