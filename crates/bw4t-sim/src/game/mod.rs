//! The match: robots, blocks, doors and rules, advanced one fixed tick at a time.
//!
//! Sans-IO: inputs are [`Match::join`], [`Match::leave`] and [`Match::handle_action`]
//! (applied at once, so drivers apply a tick's actions in robot-id order); time advances
//! only by [`Match::step`]; outputs are polled with [`Match::poll_percepts`].

mod motion;
mod perception;
mod rules;

use std::collections::BTreeSet;
use std::sync::Arc;

use bw4t_map::{Colour, ContentError, Map, Vec2, ZoneIdx};

use self::perception::{SharedFacts, Version};
use crate::action::{OrderEnd, OrderId, Rejection, RobotId};
use crate::config::{ConfigError, MatchConfig};
use crate::digest::Digest;
use crate::nav::Navigator;
use crate::percept::{BlockId, Fact, MoveState, Percept};
use crate::physics::{Physics, RobotBody};
use crate::stats::{MatchStats, RobotStats};

pub use self::rules::REACH;

/// Longest accepted player name, in bytes.
pub const MAX_NAME_LEN: usize = 64;

/// Why a match could not be created.
#[derive(Debug, thiserror::Error)]
pub enum MatchError {
    /// The configuration is out of range.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// The map's random content does not fit.
    #[error(transparent)]
    Content(#[from] ContentError),
}

/// Why a robot could not join.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum JoinError {
    /// Names are alphanumeric and start with a letter.
    #[error(
        "invalid player name '{0}': use letters and digits, starting with a letter (at most {MAX_NAME_LEN})"
    )]
    InvalidName(String),
    /// Another robot in the match has this name.
    #[error("the name '{0}' is taken")]
    NameTaken(String),
    /// Every spawn point is in use.
    #[error("the match is full ({0} spawn points)")]
    Full(usize),
}

/// What one tick did, for the driver to report.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StepReport {
    /// The tick just simulated.
    pub tick: u64,
    /// Durative orders that ended since the previous step, in the order they ended.
    pub ended: Vec<OrderEnd>,
}

/// A robot as a spectator sees it.
#[derive(Clone, Debug, PartialEq)]
pub struct RobotView {
    /// Its id.
    pub id: RobotId,
    /// Its player's name.
    pub name: Arc<str>,
    /// Its centre.
    pub pos: Vec2,
    /// Its state.
    pub state: MoveState,
    /// The block it holds.
    pub holding: Option<BlockId>,
    /// The room it is in.
    pub room: Option<ZoneIdx>,
}

/// Where a block is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BlockPlace {
    /// Lying in a room.
    Room {
        /// The room.
        zone: ZoneIdx,
        /// Its centre.
        pos: Vec2,
    },
    /// Carried by a robot.
    Held(RobotId),
    /// Delivered or dropped in a hall: no longer in the world.
    Gone,
}

#[derive(Clone, Debug)]
struct Block {
    colour: Colour,
    place: BlockPlace,
}

struct Robot {
    id: RobotId,
    name: Arc<str>,
    body: RobotBody,
    spawn: usize,
    pos: Vec2,
    at: ZoneIdx,
    room: Option<ZoneIdx>,
    state: MoveState,
    /// Remaining waypoints, the next one last.
    plan: Vec<Vec2>,
    order: Option<OrderId>,
    holding: Option<BlockId>,
    stats: RobotStats,
    inbox: Vec<Percept>,
    /// The changeable facts of its own this robot's player was last told, sorted.
    told: Vec<Fact>,
    /// The version of the shared facts its player was last told.
    told_shared: Version,
    /// `player` facts of robots that left since this robot was last told: the next delta's
    /// first `not`s. Taken out of `told_shared` at the leave, so a robot that reuses the id
    /// is new.
    left: Vec<Percept>,
    introduced: bool,
}

/// What is kept of a robot that left, until its id is given to a new robot.
struct Departed {
    id: RobotId,
    name: Arc<str>,
    stats: RobotStats,
}

/// One BW4T match.
pub struct Match {
    map: Map,
    config: MatchConfig,
    seed: u64,
    tick: u64,
    physics: Physics,
    nav: Navigator,
    zone_names: Vec<Arc<str>>,
    sequence: Arc<[Colour]>,
    sequence_index: u32,
    blocks: Vec<Block>,
    /// Per zone, the ids of the blocks lying in it, ascending.
    room_blocks: Vec<Vec<BlockId>>,
    /// Per zone, the robot occupying it (rooms only).
    occupant: Vec<Option<RobotId>>,
    /// The rooms that have an occupant, ascending.
    occupied: BTreeSet<ZoneIdx>,
    /// The facts every robot perceives alike.
    shared: SharedFacts,
    /// By robot id; `None` while no robot has the id. A joining robot takes the lowest
    /// free id, so this never holds more slots than robots were ever in the match at once.
    /// Boxed, so a robot taken out to move it through `self` is a pointer's move.
    robots: Vec<Option<Box<Robot>>>,
    /// The last robot that left with each id now free, ascending by id.
    departed: Vec<Departed>,
    next_order: u64,
    stats: MatchStats,
    ended: Vec<OrderEnd>,
    facts_scratch: Vec<Fact>,
    waypoint_scratch: Vec<Vec2>,
}

impl Match {
    /// A match on `map` whose random content comes from `seed`.
    pub fn new(map: &Map, config: &MatchConfig, seed: u64) -> Result<Match, MatchError> {
        config.validate()?;
        let content = map.content(seed)?;
        let mut room_blocks = vec![Vec::new(); map.zones().len()];
        let blocks = content
            .blocks
            .iter()
            .enumerate()
            .map(|(i, b)| {
                room_blocks[b.zone].push(i as BlockId + 1);
                Block { colour: b.colour, place: BlockPlace::Room { zone: b.zone, pos: b.pos } }
            })
            .collect();
        // An empty sequence is complete before the first tick.
        let stats =
            MatchStats { completed_at: content.sequence.is_empty().then_some(0), ..MatchStats::default() };
        Ok(Match {
            physics: Physics::new(map, config.robot_collisions, config.motion),
            nav: Navigator::new(map),
            zone_names: map.zones().iter().map(|z| Arc::from(z.name.as_str())).collect(),
            sequence: content.sequence.into(),
            sequence_index: 0,
            blocks,
            room_blocks,
            occupant: vec![None; map.zones().len()],
            occupied: BTreeSet::new(),
            shared: SharedFacts::default(),
            robots: Vec::new(),
            departed: Vec::new(),
            next_order: 0,
            stats,
            ended: Vec::new(),
            facts_scratch: Vec::new(),
            waypoint_scratch: Vec::new(),
            map: map.clone(),
            config: config.clone(),
            seed,
            tick: 0,
        })
    }

    /// Adds a robot for player `name` at the first spawn point no robot holds. It gets the
    /// lowest id no robot in the match has (an id freed by a leave is given again).
    pub fn join(&mut self, name: &str) -> Result<RobotId, JoinError> {
        self.check_name(name)?;
        let spawns = self.map.spawns();
        let spawn = (0..spawns.len())
            .find(|&s| self.live_robots().all(|r| r.spawn != s))
            .ok_or(JoinError::Full(spawns.len()))?;
        let slot = self.robots.iter().position(Option::is_none).unwrap_or(self.robots.len());
        let id = RobotId(slot as u32);
        let pos = spawns[spawn].pos;
        let body = self.physics.add_robot(id.0, pos);
        let mut robot = Box::new(Robot {
            id,
            name: Arc::from(name),
            body,
            spawn,
            pos,
            at: 0,
            room: None,
            state: MoveState::Arrived,
            plan: Vec::new(),
            order: None,
            holding: None,
            stats: RobotStats::default(),
            inbox: Vec::new(),
            told: Vec::new(),
            told_shared: Arc::default(),
            left: Vec::new(),
            introduced: false,
        });
        self.update_place(&mut robot);
        self.shared.changed();
        self.departed.retain(|d| d.id != id);
        if slot == self.robots.len() {
            self.robots.push(Some(robot));
        } else {
            self.robots[slot] = Some(robot);
        }
        Ok(id)
    }

    /// Whether a robot for player `name` could join, as far as the name goes.
    pub fn check_name(&self, name: &str) -> Result<(), JoinError> {
        // `all` addresses every player in `sendMessage`, so no player may be called that.
        let valid = name.len() <= MAX_NAME_LEN
            && name != "all"
            && name.starts_with(|c: char| c.is_ascii_alphabetic())
            && name.chars().all(|c| c.is_ascii_alphanumeric());
        if !valid {
            return Err(JoinError::InvalidName(name.to_string()));
        }
        if self.live_robots().any(|r| &*r.name == name) {
            return Err(JoinError::NameTaken(name.to_string()));
        }
        Ok(())
    }

    /// Removes a robot: its body, its place and everything kept for it, except its name and
    /// statistics (until its id is given to a new robot). A block it holds is put down where
    /// it stands, as by `putDown` (lost if there is no room for it). Orders of its that
    /// ended this tick are not reported.
    pub fn leave(&mut self, id: RobotId) -> Result<(), Rejection> {
        if self.robot(id).is_none() {
            return Err(Rejection::UnknownRobot(id));
        }
        if self.robot(id).is_some_and(|r| r.holding.is_some()) && self.put_down(id).is_err() {
            self.drop_held_block(id);
        }
        if let Some(robot) = self.robots[id.0 as usize].take() {
            if let Some(room) = robot.room {
                self.vacate(room, id);
            }
            self.physics.remove_robot(robot.body);
            self.ended.retain(|end| end.robot != id);
            self.forget_player(id, &robot.name);
            let at = self.departed.partition_point(|d| d.id < id);
            self.departed.insert(at, Departed { id, name: robot.name, stats: robot.stats });
        }
        Ok(())
    }

    /// Simulates one tick: every robot with a plan moves, in robot-id order.
    pub fn step(&mut self) -> StepReport {
        self.tick += 1;
        for idx in 0..self.robots.len() {
            // Idle robots are counted in place: only a moving robot is taken out.
            match &mut self.robots[idx] {
                Some(robot) if robot.plan.is_empty() => {
                    robot.stats.idle_ticks += 1;
                    continue;
                }
                _ => {}
            }
            if let Some(mut robot) = self.robots[idx].take() {
                self.advance(&mut robot);
                self.robots[idx] = Some(robot);
            }
        }
        self.physics.step();
        self.stats.ticks = self.tick;
        // Completion belongs to the first tick whose percepts show it: a delivery applied at
        // the boundary before this tick.
        if self.is_complete() && self.stats.completed_at.is_none() {
            self.stats.completed_at = Some(self.tick);
        }
        StepReport { tick: self.tick, ended: std::mem::take(&mut self.ended) }
    }

    /// A digest of the whole state: equal digests mean equal matches, bit for bit.
    pub fn digest(&self) -> u64 {
        let mut d = Digest::default();
        d.u64(self.tick);
        d.u64(self.seed);
        d.u64(u64::from(self.sequence_index));
        self.sequence.iter().for_each(|c| d.u64(*c as u64));
        for (i, b) in self.blocks.iter().enumerate() {
            d.u64(i as u64);
            d.u64(b.colour as u64);
            match b.place {
                BlockPlace::Room { zone, pos } => {
                    d.u64(zone as u64);
                    d.f32(pos.x);
                    d.f32(pos.y);
                }
                BlockPlace::Held(r) => d.u64(1 << 32 | u64::from(r.0)),
                BlockPlace::Gone => d.u64(u64::MAX),
            }
        }
        for robot in self.live_robots() {
            d.u64(u64::from(robot.id.0));
            d.str(&robot.name);
            // A robot without a body (no robot collisions) is where the body would be after
            // every step: at its position.
            let body = self.physics.body_position(robot.body).unwrap_or(robot.pos);
            [robot.pos.x, robot.pos.y, body.x, body.y].into_iter().for_each(|v| d.f32(v));
            d.u64(robot.state as u64);
            d.u64(robot.holding.map_or(0, u64::from));
            d.u64(robot.order.map_or(u64::MAX, |o| o.0));
            robot.plan.iter().for_each(|p| {
                d.f32(p.x);
                d.f32(p.y);
            });
            let s = &robot.stats;
            [s.good_drops, s.wrong_drops, s.messages_sent, s.rooms_entered]
                .into_iter()
                .for_each(|v| d.u64(v.into()));
            d.u64(s.idle_ticks);
            d.u64(s.distance.to_bits());
        }
        self.occupant.iter().for_each(|o| d.u64(o.map_or(u64::MAX, |r| r.0.into())));
        d.finish()
    }

    /// The map being played.
    pub fn map(&self) -> &Map {
        &self.map
    }

    /// The configuration in force.
    pub fn config(&self) -> &MatchConfig {
        &self.config
    }

    /// The seed the match was created with.
    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// Ticks simulated so far.
    pub fn tick(&self) -> u64 {
        self.tick
    }

    /// The goal colours in order.
    pub fn sequence(&self) -> &[Colour] {
        &self.sequence
    }

    /// The index of the next colour needed (the sequence's length once complete).
    pub fn sequence_index(&self) -> u32 {
        self.sequence_index
    }

    /// Whether every colour of the sequence has been delivered.
    pub fn is_complete(&self) -> bool {
        self.sequence_index as usize >= self.sequence.len()
    }

    /// Match-wide statistics.
    pub fn stats(&self) -> &MatchStats {
        &self.stats
    }

    /// One robot's statistics (also after it has left, until its id is given again).
    pub fn robot_stats(&self, id: RobotId) -> Option<&RobotStats> {
        self.robot(id).map(|r| &r.stats).or_else(|| self.departed(id).map(|d| &d.stats))
    }

    /// Per robot id ever used, by id: the robot that has it now, or else the last one that
    /// had it; its name, statistics and whether it is still in the match.
    pub fn all_robot_stats(&self) -> impl Iterator<Item = (RobotId, &str, &RobotStats, bool)> + '_ {
        self.robots.iter().enumerate().filter_map(|(i, slot)| match slot {
            Some(r) => Some((r.id, &*r.name, &r.stats, true)),
            None => self.departed(RobotId(i as u32)).map(|d| (d.id, &*d.name, &d.stats, false)),
        })
    }

    fn departed(&self, id: RobotId) -> Option<&Departed> {
        self.departed.binary_search_by_key(&id, |d| d.id).ok().map(|at| &self.departed[at])
    }

    /// Simulated seconds until the sequence was completed, if it was.
    pub fn completion_seconds(&self) -> Option<f64> {
        self.stats.completed_at.map(|t| self.config.seconds(t))
    }

    /// Every robot in the match, by id.
    pub fn robots(&self) -> impl Iterator<Item = RobotView> + '_ {
        self.live_robots().map(|r| RobotView {
            id: r.id,
            name: r.name.clone(),
            pos: r.pos,
            state: r.state,
            holding: r.holding,
            room: r.room,
        })
    }

    /// The robot whose player has this name.
    pub fn robot_named(&self, name: &str) -> Option<RobotId> {
        self.live_robots().find(|r| &*r.name == name).map(|r| r.id)
    }

    /// Every block ever placed, by id, with its colour and where it is now.
    pub fn blocks(&self) -> impl Iterator<Item = (BlockId, Colour, BlockPlace)> + '_ {
        self.blocks.iter().enumerate().map(|(i, b)| (i as BlockId + 1, b.colour, b.place))
    }

    /// The robot occupying a room, if any.
    pub fn occupant(&self, zone: ZoneIdx) -> Option<RobotId> {
        self.occupant.get(zone).copied().flatten()
    }

    fn live_robots(&self) -> impl Iterator<Item = &Robot> + '_ {
        self.robots.iter().flatten().map(|robot| &**robot)
    }

    fn robot(&self, id: RobotId) -> Option<&Robot> {
        self.robots.get(id.0 as usize).and_then(Option::as_deref)
    }

    fn robot_mut(&mut self, id: RobotId) -> Option<&mut Robot> {
        self.robots.get_mut(id.0 as usize).and_then(Option::as_deref_mut)
    }

    fn block(&self, id: BlockId) -> Option<&Block> {
        id.checked_sub(1).and_then(|i| self.blocks.get(i as usize))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::action::Action;

    /// The workspace's two-room test map: a hall, the drop zone and RoomA, two spawn points.
    const MAP: &str = include_str!("../../../../tests/fixtures/two-rooms.toml");

    fn game() -> Match {
        let map = Map::from_native(MAP).expect("map");
        Match::new(&map, &MatchConfig::default(), 1).expect("match")
    }

    /// Everything a tick walks over or a join searches: robot slots, departed records,
    /// rapier's bodies and colliders.
    fn footprint(game: &Match) -> (usize, usize, (usize, usize)) {
        (game.robots.len(), game.departed.len(), game.physics.object_count())
    }

    /// `game()` with robot collisions, so robots have bodies in rapier.
    fn colliding_game() -> Match {
        let map = Map::from_native(MAP).expect("map");
        let config = MatchConfig { robot_collisions: true, ..MatchConfig::default() };
        Match::new(&map, &config, 1).expect("match")
    }

    #[test]
    fn join_leave_churn_leaves_no_trace() {
        let mut churned = game();
        let mut calm = game();
        let ann = churned.join("Ann").expect("Ann");
        assert_eq!(calm.join("Ann"), Ok(ann));
        churned.handle_action(ann, &Action::GoTo("RoomA".into())).expect("go");
        calm.handle_action(ann, &Action::GoTo("RoomA".into())).expect("go");
        // One churner, so the footprint has its largest size from the start.
        let first = churned.join("Guest0").expect("guest");
        churned.leave(first).expect("leave");
        let size = footprint(&churned);
        for i in 1..3000 {
            let guest = churned.join(&format!("Guest{i}")).expect("guest");
            assert_eq!(guest, first, "a freed id is given again");
            churned.handle_action(guest, &Action::GoTo("DropZone".into())).expect("go");
            churned.step();
            calm.step();
            churned.poll_percepts(ann);
            churned.leave(guest).expect("leave");
            assert_eq!(footprint(&churned), size, "after {i} guests");
        }
        // Ann's slot and the guest's; the guest's record; no bodies (robots do not collide).
        assert_eq!(size, (2, 1, footprint(&game()).2));
        // The world is as if nobody else had ever come: the same digest, bit for bit.
        assert_eq!(churned.robots().count(), 1);
        assert_eq!(churned.digest(), calm.digest());
    }

    #[test]
    fn colliding_robots_leave_no_body_behind() {
        let mut game = colliding_game();
        let empty = game.physics.object_count();
        let ann = game.join("Ann").expect("Ann");
        for i in 0..500 {
            let guest = game.join(&format!("Guest{i}")).expect("guest");
            game.handle_action(guest, &Action::GoTo("DropZone".into())).expect("go");
            game.step();
            game.leave(guest).expect("leave");
            // Ann's body and collider, nobody else's.
            assert_eq!(game.physics.object_count(), (empty.0 + 1, empty.1 + 1), "after {i} guests");
        }
        game.leave(ann).expect("leave");
        game.step();
        assert_eq!(game.physics.object_count(), empty);
    }

    #[test]
    fn a_reused_id_is_a_new_player_to_the_others() {
        let mut game = game();
        let ann = game.join("Ann").expect("Ann");
        let bob = game.join("Bob").expect("Bob");
        game.poll_percepts(ann);
        game.poll_percepts(bob);
        game.leave(bob).expect("leave");
        let cat = game.join("Cat").expect("Cat");
        assert_eq!(cat, bob, "Cat takes the id Bob freed");
        let delta = game.poll_percepts(ann).expect("Ann");
        assert_eq!(delta.not, [Percept::Player("Bob".into())]);
        assert!(delta.add.contains(&Percept::Player("Cat".into())), "{delta:?}");
        let names: Vec<(u32, String, bool)> =
            game.all_robot_stats().map(|(id, name, _, present)| (id.0, name.to_string(), present)).collect();
        assert_eq!(names, [(0, "Ann".to_string(), true), (1, "Cat".to_string(), true)]);
    }
}
