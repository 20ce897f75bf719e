//! The rapier2d world: room walls, door guards and the robots' kinematic bodies.
//!
//! Walls and guards are static colliders built once from the map. A guard fills a door
//! opening and blocks every robot except its room's occupant while the room is occupied;
//! whether it blocks is decided per query (a filter predicate), so no collider is ever
//! switched on or off and the broad phase stays untouched by door changes.

use bw4t_map::{Map, ROBOT_SIZE, Vec2};

use crate::clearance::Clearance;
use crate::config::Motion;
use rapier2d::control::{CharacterLength, KinematicCharacterController};
use rapier2d::prelude::*;

/// Half the side of a robot's square ([`ROBOT_SIZE`]).
pub const ROBOT_HALF: f32 = ROBOT_SIZE / 2.0;
/// Half the thickness of a wall (walls are centred on their room's edge).
pub(crate) const WALL_HALF: f32 = 0.05;
/// The gap the character controller keeps to obstacles.
pub(crate) const SKIN: f32 = 0.01;
/// How far a move must keep from every wall and guard to skip the character controller:
/// ten skins, so neither the controller's cast nor its rounding could have met anything.
const OPEN_MARGIN: f32 = 10.0 * SKIN;
/// A move shorter than this always goes through the controller, which treats a move of
/// about 1e-5 or less as none (and then resolves penetrations instead).
const OPEN_MIN_MOVE: f32 = 1e-3;

/// What a collider stands for, stored in its `user_data`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Tag {
    /// A piece of a room's wall.
    Wall,
    /// The guard of a door of the room with this zone index.
    Guard(usize),
    /// The robot with this id.
    Robot(u32),
}

impl Tag {
    fn encode(self) -> u128 {
        match self {
            Tag::Wall => 0,
            Tag::Guard(zone) => (1 << 64) | zone as u128,
            Tag::Robot(id) => (2 << 64) | id as u128,
        }
    }

    fn decode(data: u128) -> Tag {
        let index = data as u64;
        match data >> 64 {
            1 => Tag::Guard(index as usize),
            2 => Tag::Robot(index as u32),
            _ => Tag::Wall,
        }
    }
}

/// A robot's kinematic body in rapier, when robots collide (or under [`Motion::Stepped`]);
/// without collisions robots are nothing to any query, so they need no body and the world
/// never changes.
#[derive(Clone, Copy, Debug)]
pub(crate) struct RobotBody {
    body: Option<RigidBodyHandle>,
}

/// What a single move of a robot did.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Moved {
    /// The translation actually applied.
    pub translation: Vec2,
    /// The first guard or robot that stopped the move, if any.
    pub blocked_by: Option<Tag>,
}

/// The physical world of a match.
pub(crate) struct Physics {
    world: PhysicsWorld,
    controller: KinematicCharacterController,
    robot_shape: SharedShape,
    robots_collide: bool,
    /// Whether robots have bodies and the world is stepped every tick.
    stepped: bool,
    /// Where walls and guards are not, for moves that need no controller; none when
    /// every move goes through it (robots collide, or the stepped reference motion).
    open: Option<Clearance>,
}

impl Physics {
    /// Builds walls (with openings at doors) and door guards for every walled zone.
    pub(crate) fn new(map: &Map, robots_collide: bool, motion: Motion) -> Self {
        let mut world = PhysicsWorld::new();
        world.gravity = Vector::ZERO;
        let mut obstacles = Vec::new();
        for (idx, zone) in map.zones().iter().enumerate() {
            if !zone.kind.is_walled() {
                continue;
            }
            // Each edge overhangs its corners by half a wall, so corners close.
            for (centre, half) in bw4t_map::zone_walls(zone, WALL_HALF).iter().map(wall_box) {
                obstacles.push((centre, half));
                let wall =
                    ColliderBuilder::cuboid(half.x, half.y).translation(centre).user_data(Tag::Wall.encode());
                world.insert_collider(wall, None);
            }
            for door in &zone.doors {
                let half = door.rect().size / 2.0;
                obstacles.push((door.centre, half));
                let guard = ColliderBuilder::cuboid(half.x, half.y)
                    .translation(door.centre)
                    .user_data(Tag::Guard(idx).encode());
                world.insert_collider(guard, None);
            }
        }
        world.detect_collisions(&(), &());
        let controller = KinematicCharacterController {
            offset: CharacterLength::Absolute(SKIN),
            slide: true,
            autostep: None,
            // Top-down: there is no ground, so nothing is a slope to climb or slide down.
            max_slope_climb_angle: Real::MAX,
            min_slope_slide_angle: 0.0,
            snap_to_ground: None,
            ..KinematicCharacterController::default()
        };
        let stepped = robots_collide || motion == Motion::Stepped;
        Physics {
            world,
            controller,
            robot_shape: SharedShape::cuboid(ROBOT_HALF, ROBOT_HALF),
            robots_collide,
            stepped,
            open: (!stepped).then(|| Clearance::new(&obstacles, OPEN_MARGIN)),
        }
    }

    /// Adds a robot's kinematic body at `pos` (none when the world is not stepped).
    pub(crate) fn add_robot(&mut self, id: u32, pos: Vec2) -> RobotBody {
        if !self.stepped {
            return RobotBody { body: None };
        }
        let body = self.world.insert_body(RigidBodyBuilder::kinematic_position_based().translation(pos));
        let collider = ColliderBuilder::new(self.robot_shape.clone()).user_data(Tag::Robot(id).encode());
        // The broad phase learns of it at the next step, as of any other change.
        self.world.insert_collider(collider, Some(body));
        RobotBody { body: Some(body) }
    }

    /// Removes a robot's body.
    pub(crate) fn remove_robot(&mut self, robot: RobotBody) {
        if let Some(body) = robot.body {
            self.world.remove_body_with_colliders(body, true);
        }
    }

    /// Moves a robot from `pos` by up to `desired`, stopped by walls, by the guards for
    /// which `guard_closed(room)` holds, and (when enabled) by other robots.
    pub(crate) fn move_robot(
        &self,
        id: u32,
        pos: Vec2,
        desired: Vec2,
        guard_closed: &dyn Fn(usize) -> bool,
    ) -> Moved {
        if self.is_open(pos, desired) {
            // The controller casts, finds nothing and adds the whole move to zero.
            return Moved { translation: Vec2::ZERO + desired, blocked_by: None };
        }
        let robots_collide = self.robots_collide;
        let passable = |_: ColliderHandle, c: &Collider| match Tag::decode(c.user_data) {
            Tag::Wall => true,
            Tag::Guard(room) => guard_closed(room),
            Tag::Robot(other) => robots_collide && other != id,
        };
        let filter = QueryFilter::default().predicate(&passable);
        let queries = self.world.broad_phase.as_query_pipeline(
            self.world.narrow_phase.query_dispatcher(),
            &self.world.bodies,
            &self.world.colliders,
            filter,
        );
        let mut blocked_by = None;
        let dt = self.world.integration_parameters.dt;
        let result = self.controller.move_shape(
            dt,
            &queries,
            &*self.robot_shape,
            &Pose::from_translation(pos),
            desired,
            |hit| {
                let tag = self.world.colliders.get(hit.handle).map(|c| Tag::decode(c.user_data));
                if blocked_by.is_none() && matches!(tag, Some(Tag::Guard(_) | Tag::Robot(_))) {
                    blocked_by = tag;
                }
            },
        );
        Moved { translation: result.translation, blocked_by }
    }

    /// Whether a move of a robot from `pos` by `desired` sweeps only open ground: then the
    /// controller would return `desired` untouched, with nothing hit.
    fn is_open(&self, pos: Vec2, desired: Vec2) -> bool {
        let Some(open) = &self.open else { return false };
        let half = Vec2::splat(ROBOT_HALF);
        let (from, to) = (pos, pos + desired);
        desired.length() >= OPEN_MIN_MOVE && open.is_open(from.min(to) - half, from.max(to) + half)
    }

    /// Places a robot's body at its new position for the next step.
    pub(crate) fn place_robot(&mut self, robot: RobotBody, pos: Vec2) {
        if let Some(body) = robot.body.and_then(|body| self.world.bodies.get_mut(body)) {
            body.set_next_kinematic_translation(pos);
        }
    }

    /// Advances rapier by one fixed step, bringing colliders and the broad phase up to date.
    /// Under [`Motion::Kinematic`] without robot collisions the world holds walls and
    /// guards only, which never move: there is nothing to step.
    pub(crate) fn step(&mut self) {
        if self.stepped {
            self.world.step();
        }
    }

    /// Bodies and colliders in the world (walls, guards, robots).
    #[cfg(test)]
    pub(crate) fn object_count(&self) -> (usize, usize) {
        (self.world.bodies.len(), self.world.colliders.len())
    }

    /// The position of a robot's body as rapier holds it; none for a robot without a body.
    pub(crate) fn body_position(&self, robot: RobotBody) -> Option<Vec2> {
        let body = self.world.bodies.get(robot.body?)?;
        Some(body.translation())
    }
}

/// A wall as a box `WALL_HALF` thick: (centre, half extents).
fn wall_box(wall: &bw4t_map::Wall) -> (Vec2, Vec2) {
    let (mid, half_len) = ((wall.from + wall.to) / 2.0, (wall.to - wall.from) / 2.0);
    if wall.horizontal {
        (Vec2::new(mid, wall.fixed), Vec2::new(half_len, WALL_HALF))
    } else {
        (Vec2::new(wall.fixed, mid), Vec2::new(WALL_HALF, half_len))
    }
}
