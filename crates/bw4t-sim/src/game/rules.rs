//! Actions and their rules: orders to move, picking up and putting down blocks (and
//! delivering them), and messages between players.

use std::sync::Arc;

use bw4t_map::{Vec2, ZoneIdx, block_area};

use super::{Block, BlockPlace, Match, Robot};
use crate::action::{Accepted, Action, OrderEnd, OrderId, OrderOutcome, Receiver, Rejection, RobotId};
use crate::percept::{BlockId, MoveState, Percept};

/// How close (centre to centre) a robot must be to a block to pick it up.
pub const REACH: f32 = 1.0;

impl Match {
    /// Stops a robot where it stands: its current order ends as superseded.
    pub fn stop(&mut self, id: RobotId) -> Result<(), Rejection> {
        let robot =
            self.robots.get_mut(id.0 as usize).and_then(Option::as_mut).ok_or(Rejection::UnknownRobot(id))?;
        robot.plan.clear();
        if let Some(order) = robot.order.take() {
            robot.state = MoveState::Arrived;
            self.ended.push(OrderEnd { robot: id, order, outcome: OrderOutcome::Superseded });
        }
        Ok(())
    }

    /// Applies one action now. Durative actions are answered later by a [`StepReport`](super::StepReport).
    pub fn handle_action(&mut self, id: RobotId, action: &Action) -> Result<Accepted, Rejection> {
        let robot = self.robot(id).ok_or(Rejection::UnknownRobot(id))?;
        let (from, room) = (robot.at, robot.room);
        match action {
            Action::GoTo(place) => {
                let zone =
                    self.map.zone_named(place).ok_or_else(|| Rejection::UnknownPlace(place.clone()))?;
                let target = self.nav.centre(zone);
                self.start_order(id, from, zone, target).ok_or_else(|| Rejection::Unreachable(place.clone()))
            }
            &Action::GoToBlock(block) => {
                let (zone, pos) = self.visible_block(block, room)?;
                let target = self.nav.standable(zone, pos);
                self.start_order(id, from, zone, target)
                    .ok_or_else(|| Rejection::Unreachable(block.to_string()))
            }
            &Action::PickUp(block) => self.pick_up(id, block),
            Action::PutDown => self.put_down(id),
            Action::SendMessage { to, text } => self.send_message(id, to, text),
        }
    }

    fn start_order(&mut self, id: RobotId, from: ZoneIdx, to: ZoneIdx, target: Vec2) -> Option<Accepted> {
        let mut waypoints = std::mem::take(&mut self.waypoint_scratch);
        let found = self.nav.waypoints(from, to, target, &mut waypoints);
        let order = OrderId(self.next_order);
        let robot = self.robots.get_mut(id.0 as usize).and_then(Option::as_mut);
        let result = match robot {
            Some(robot) if found => {
                if let Some(old) = robot.order.replace(order) {
                    self.ended.push(OrderEnd { robot: id, order: old, outcome: OrderOutcome::Superseded });
                }
                robot.plan.clear();
                robot.plan.extend(waypoints.iter().rev());
                robot.state = MoveState::Traveling;
                self.next_order += 1;
                Some(Accepted { order: Some(order) })
            }
            _ => None,
        };
        self.waypoint_scratch = waypoints;
        result
    }

    /// The block's room and position, if the robot in `room` can see it.
    fn visible_block(&self, block: BlockId, room: Option<ZoneIdx>) -> Result<(ZoneIdx, Vec2), Rejection> {
        let place = self.block(block).ok_or(Rejection::UnknownBlock(block))?.place;
        match place {
            BlockPlace::Room { zone, pos } if Some(zone) == room => Ok((zone, pos)),
            BlockPlace::Gone => Err(Rejection::UnknownBlock(block)),
            _ => Err(Rejection::BlockNotVisible(block)),
        }
    }

    /// The block robot `robot` is at: the nearest within reach in its room (lowest id on ties).
    pub(super) fn block_at(&self, robot: &Robot) -> Option<BlockId> {
        let room = robot.room?;
        let mut best: Option<(f32, BlockId)> = None;
        for &b in &self.room_blocks[room] {
            if let Some(Block { place: BlockPlace::Room { pos, .. }, .. }) = self.block(b) {
                let d = pos.distance(robot.pos);
                if d <= REACH && best.is_none_or(|(bd, _)| d < bd) {
                    best = Some((d, b));
                }
            }
        }
        best.map(|(_, b)| b)
    }

    fn pick_up(&mut self, id: RobotId, wanted: Option<BlockId>) -> Result<Accepted, Rejection> {
        let robot = self.robot(id).ok_or(Rejection::UnknownRobot(id))?;
        if let Some(held) = robot.holding {
            return Err(Rejection::AlreadyHolding(held));
        }
        let block = match wanted {
            Some(b) => {
                let (_, pos) = self.visible_block(b, robot.room)?;
                if pos.distance(robot.pos) > REACH {
                    return Err(Rejection::NotAtBlock);
                }
                b
            }
            None => self.block_at(robot).ok_or(Rejection::NotAtBlock)?,
        };
        if let Some(BlockPlace::Room { zone, .. }) = self.block(block).map(|b| b.place) {
            self.room_blocks[zone].retain(|&b| b != block);
        }
        self.blocks[block as usize - 1].place = BlockPlace::Held(id);
        if let Some(robot) = self.robot_mut(id) {
            robot.holding = Some(block);
        }
        Ok(Accepted { order: None })
    }

    pub(super) fn put_down(&mut self, id: RobotId) -> Result<Accepted, Rejection> {
        let robot = self.robot(id).ok_or(Rejection::UnknownRobot(id))?;
        let block = robot.holding.ok_or(Rejection::NotHolding)?;
        let (room, pos) = (robot.room, robot.pos);
        let colour = self.blocks[block as usize - 1].colour;
        let place = match room {
            Some(zone) if zone == self.map.drop_zone() => {
                let needed = self.sequence.get(self.sequence_index as usize);
                let good = needed == Some(&colour);
                if good {
                    self.sequence_index += 1;
                    self.shared.changed();
                    self.stats.sequence_index = self.sequence_index;
                    self.stats.good_drops += 1;
                } else {
                    self.stats.wrong_drops += 1;
                }
                if let Some(robot) = self.robot_mut(id) {
                    if good { robot.stats.good_drops += 1 } else { robot.stats.wrong_drops += 1 }
                }
                BlockPlace::Gone
            }
            Some(zone) => {
                let spot = self.free_spot(zone, pos).ok_or(Rejection::NoSpace)?;
                let list = &mut self.room_blocks[zone];
                let at = list.partition_point(|&b| b < block);
                list.insert(at, block);
                BlockPlace::Room { zone, pos: spot }
            }
            // In a hall (or free space) the block leaves the world.
            None => BlockPlace::Gone,
        };
        self.blocks[block as usize - 1].place = place;
        if let Some(robot) = self.robot_mut(id) {
            robot.holding = None;
        }
        Ok(Accepted { order: None })
    }

    /// Loses a held block when nothing else can be done with it.
    pub(super) fn drop_held_block(&mut self, id: RobotId) {
        if let Some(block) = self.robot_mut(id).and_then(|r| r.holding.take()) {
            self.blocks[block as usize - 1].place = BlockPlace::Gone;
        }
    }

    /// The spot nearest to `near` inside `zone` where a block overlaps no other block.
    fn free_spot(&self, zone: ZoneIdx, near: Vec2) -> Option<Vec2> {
        let area = block_area(&self.map.zones()[zone].rect);
        let others: Vec<Vec2> = self.room_blocks[zone]
            .iter()
            .filter_map(|&b| match self.block(b)?.place {
                BlockPlace::Room { pos, .. } => Some(pos),
                _ => None,
            })
            .collect();
        let clear = |p: Vec2| area.contains(p) && others.iter().all(|o| (p - *o).abs().max_element() >= 1.0);
        // Rings of growing radius on a half-unit grid, nearest first, in a fixed order.
        let start = area.clamp(near);
        (0..=40i32).find_map(|ring| {
            let mut best: Option<(f32, Vec2)> = None;
            for j in -ring..=ring {
                for i in -ring..=ring {
                    if i.abs().max(j.abs()) != ring {
                        continue;
                    }
                    let p = start + Vec2::new(i as f32, j as f32) * 0.5;
                    let d = p.distance(near);
                    if clear(p) && best.is_none_or(|(bd, _)| d < bd) {
                        best = Some((d, p));
                    }
                }
            }
            best.map(|(_, p)| p)
        })
    }

    fn send_message(&mut self, id: RobotId, to: &Receiver, text: &str) -> Result<Accepted, Rejection> {
        let from = self.robot(id).ok_or(Rejection::UnknownRobot(id))?.name.clone();
        let receivers: Vec<usize> = match to {
            Receiver::All => self.live_robots().filter(|r| r.id != id).map(|r| r.id.0 as usize).collect(),
            Receiver::Player(name) => {
                let target = self.live_robots().find(|r| &*r.name == name.as_str() && r.id != id);
                vec![target.ok_or_else(|| Rejection::UnknownReceiver(name.clone()))?.id.0 as usize]
            }
        };
        let message = Percept::Message { from, text: Arc::from(text) };
        for idx in receivers {
            if let Some(robot) = self.robots[idx].as_mut() {
                robot.inbox.push(message.clone());
            }
        }
        self.stats.messages += 1;
        if let Some(robot) = self.robot_mut(id) {
            robot.stats.messages_sent += 1;
        }
        Ok(Accepted { order: None })
    }
}
