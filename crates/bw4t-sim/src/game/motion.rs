//! Movement: a robot follows its plan of waypoints through the physics, and after every
//! move its zone, its room and the rooms' occupancy are brought up to date.

use bw4t_map::ZoneIdx;

use super::{Match, Robot};
use crate::action::{OrderEnd, OrderOutcome, RobotId};
use crate::percept::MoveState;

/// Within this distance a waypoint counts as reached.
const ARRIVE_EPS: f32 = 1e-3;
/// A move that achieves less than this share of its step is stuck against a wall.
const STALL_FRACTION: f32 = 0.05;

impl Match {
    /// Moves one robot along its plan (not empty) for one tick.
    pub(super) fn advance(&mut self, robot: &mut Robot) {
        let start = robot.pos;
        let occupant = &self.occupant;
        let me = robot.id;
        let guard_closed = |room: usize| occupant[room].is_some_and(|o| o != me);
        let mut budget = self.config.speed;
        let mut outcome = None;
        while budget > 0.0 {
            let Some(&waypoint) = robot.plan.last() else { break };
            let to = waypoint - robot.pos;
            let dist = to.length();
            if dist <= ARRIVE_EPS {
                robot.plan.pop();
                continue;
            }
            let step = budget.min(dist);
            let moved = self.physics.move_robot(me.0, robot.pos, to * (step / dist), &guard_closed);
            robot.pos += moved.translation;
            budget -= step;
            if moved.blocked_by.is_some() || moved.translation.length() < step * STALL_FRACTION {
                outcome = Some(OrderOutcome::Collided);
                break;
            }
            if robot.pos.distance(waypoint) <= ARRIVE_EPS {
                robot.pos = waypoint;
                robot.plan.pop();
            }
        }
        if outcome.is_none() && robot.plan.is_empty() {
            outcome = Some(OrderOutcome::Arrived);
        }
        if let Some(outcome) = outcome {
            robot.plan.clear();
            robot.state =
                if outcome == OrderOutcome::Arrived { MoveState::Arrived } else { MoveState::Collided };
            if let Some(order) = robot.order.take() {
                self.ended.push(OrderEnd { robot: me, order, outcome });
            }
        }
        robot.stats.distance += f64::from(start.distance(robot.pos));
        self.physics.place_robot(robot.body, robot.pos);
        self.update_place(robot);
    }

    /// Recomputes where a robot is and updates room occupancy.
    pub(super) fn update_place(&mut self, robot: &mut Robot) {
        let (zone, room) = self.map.zone_and_room_at(robot.pos);
        // In a room, that room (even where another zone overlaps it first); in free space,
        // the nearest zone.
        robot.at = room.or(zone).unwrap_or_else(|| self.map.nearest_zone(robot.pos));
        if room == robot.room {
            return;
        }
        if let Some(old) = robot.room {
            self.vacate(old, robot.id);
        }
        if let Some(new) = room {
            robot.stats.rooms_entered += 1;
            if self.occupant[new].is_none() {
                self.occupant[new] = Some(robot.id);
                self.occupied.insert(new);
                self.shared.changed();
            }
        }
        robot.room = room;
    }

    /// Clears `zone`'s occupant if it was `leaving`, handing the room to any robot still inside.
    pub(super) fn vacate(&mut self, zone: ZoneIdx, leaving: RobotId) {
        if self.occupant[zone] == Some(leaving) {
            let heir = self.live_robots().find(|r| r.id != leaving && r.room == Some(zone)).map(|r| r.id);
            self.occupant[zone] = heir;
            if heir.is_none() {
                self.occupied.remove(&zone);
                self.shared.changed();
            }
        }
    }
}
