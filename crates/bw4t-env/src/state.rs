//! The global state for centralised critics: the whole world's facts (every robot, every
//! block, the goal), not one robot's view; one table of segments, as the observation has.
//!
//! [`STATE_SEGMENTS`] is the one source of the layout: the crate docs' table follows it (a
//! test holds them together) and a binding exports it ([`StateSpace::layout`]).

use bw4t_map::{Colour, Map, ZoneIdx, ZoneKind};
use bw4t_sim::{BlockPlace, Match, MoveState};

use crate::spaces::Segment;

/// The numbers a state segment's length is made of.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StateDims {
    /// `N`: robots (every seat: learners and built-in teammates), in robot-id order.
    pub robots: usize,
    /// `R`: rooms, the drop zone included, in map order.
    pub rooms: usize,
    /// `C`: block colours.
    pub colours: usize,
    /// `L`: the goal sequence's length.
    pub sequence: usize,
}

impl StateDims {
    /// The numbers for `robots` robots on `map`.
    pub fn of(map: &Map, robots: usize) -> StateDims {
        StateDims {
            robots,
            rooms: map.zones().iter().filter(|z| z.kind == ZoneKind::Room).count(),
            colours: Colour::ALL.len(),
            sequence: map.sequence().len() + map.random_sequence() as usize,
        }
    }
}

/// How long a state segment is, as a formula over [`StateDims`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StateSize {
    /// `N*k`: `k` values per robot.
    PerRobot(usize),
    /// `N*(R+1)`.
    RobotRooms,
    /// `N*C`.
    RobotColours,
    /// `R*C`.
    RoomColours,
    /// `L*C`.
    SequenceColours,
    /// `L+1`.
    SequencePlusOne,
    /// `L`.
    Sequence,
    /// A fixed length.
    Fixed(usize),
}

impl StateSize {
    /// The length for `dims`.
    pub fn len(self, d: &StateDims) -> usize {
        match self {
            StateSize::PerRobot(k) => d.robots * k,
            StateSize::RobotRooms => d.robots * (d.rooms + 1),
            StateSize::RobotColours => d.robots * d.colours,
            StateSize::RoomColours => d.rooms * d.colours,
            StateSize::SequenceColours => d.sequence * d.colours,
            StateSize::SequencePlusOne => d.sequence + 1,
            StateSize::Sequence => d.sequence,
            StateSize::Fixed(n) => n,
        }
    }

    /// The formula as the docs write it.
    pub fn formula(self) -> String {
        match self {
            StateSize::PerRobot(k) => format!("N*{k}"),
            StateSize::RobotRooms => "N*(R+1)".into(),
            StateSize::RobotColours => "N*C".into(),
            StateSize::RoomColours => "R*C".into(),
            StateSize::SequenceColours => "L*C".into(),
            StateSize::SequencePlusOne => "L+1".into(),
            StateSize::Sequence => "L".into(),
            StateSize::Fixed(n) => n.to_string(),
        }
    }
}

/// One segment of the state: a name, a length formula, what it holds, and whether its
/// values are counts (unbounded above) rather than in `[0, 1]`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StateRow {
    /// Its name.
    pub name: &'static str,
    /// Its length.
    pub size: StateSize,
    /// What it holds.
    pub meaning: &'static str,
    /// Whether its values are counts.
    pub counts: bool,
}

const fn row(name: &'static str, size: StateSize, meaning: &'static str) -> StateRow {
    StateRow { name, size, meaning, counts: false }
}

/// The global state, segment after segment.
pub const STATE_SEGMENTS: &[StateRow] = &[
    row(
        "robot_position",
        StateSize::PerRobot(2),
        "per robot: its centre's x and y over the map's width and height",
    ),
    row("robot_room", StateSize::RobotRooms, "per robot: one-hot, the room it is in (last: none)"),
    row("robot_state", StateSize::PerRobot(3), "per robot: one-hot, arrived, traveling, collided"),
    row("robot_holding", StateSize::RobotColours, "per robot: the held block's colour one-hot (zeros: none)"),
    StateRow {
        name: "room_blocks",
        size: StateSize::RoomColours,
        meaning: "per room: count of the blocks of each colour lying in it",
        counts: true,
    },
    row("sequence", StateSize::SequenceColours, "per position: the goal colour one-hot"),
    row(
        "sequence_index",
        StateSize::SequencePlusOne,
        "one-hot: the index of the next colour needed (L: complete)",
    ),
    row("delivered", StateSize::Sequence, "1 for each position already delivered"),
    row("time", StateSize::Fixed(1), "the tick over the tick limit"),
];

/// The state's layout for one map and seating.
#[derive(Clone, Debug, PartialEq)]
pub struct StateSpace {
    /// The numbers the lengths are made of.
    pub dims: StateDims,
    segments: Vec<Segment>,
    /// Per room index: its zone.
    rooms: Vec<ZoneIdx>,
    /// The map's width and height.
    area: (f32, f32),
}

impl StateSpace {
    /// The layout for `robots` robots on `map`.
    pub fn new(map: &Map, robots: usize) -> StateSpace {
        let dims = StateDims::of(map, robots);
        let mut offset = 0;
        let segments = STATE_SEGMENTS
            .iter()
            .map(|r| {
                let len = r.size.len(&dims);
                let seg = Segment { name: r.name, offset, len };
                offset += len;
                seg
            })
            .collect();
        let rooms = (0..map.zones().len()).filter(|&z| map.zones()[z].kind == ZoneKind::Room).collect();
        let area = map.area();
        StateSpace { dims, segments, rooms, area: (area.x.max(1.0), area.y.max(1.0)) }
    }

    /// The segments, in order.
    pub fn layout(&self) -> &[Segment] {
        &self.segments
    }

    /// The state's length.
    pub fn len(&self) -> usize {
        self.segments.last().map_or(0, |s| s.offset + s.len)
    }

    /// Whether the state is empty (never: every table row has a length).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    fn start(&self, i: usize) -> usize {
        self.segments[i].offset
    }

    /// Writes the state of `game` (truncated at `max_ticks`) into `out`.
    pub(crate) fn write(&self, game: &Match, max_ticks: u64, out: &mut [f32]) {
        assert_eq!(out.len(), self.len(), "the state's length");
        let d = &self.dims;
        let c = d.colours;
        out.fill(0.0);
        let colour_of: Vec<Colour> = game.blocks().map(|(_, colour, _)| colour).collect();
        for (n, robot) in game.robots().take(d.robots).enumerate() {
            out[self.start(0) + 2 * n] = (robot.pos.x / self.area.0).clamp(0.0, 1.0);
            out[self.start(0) + 2 * n + 1] = (robot.pos.y / self.area.1).clamp(0.0, 1.0);
            let room = robot.room.and_then(|z| self.rooms.iter().position(|&r| r == z)).unwrap_or(d.rooms);
            out[self.start(1) + n * (d.rooms + 1) + room] = 1.0;
            let state = MoveState::ALL.iter().position(|&s| s == robot.state).unwrap_or(0);
            out[self.start(2) + 3 * n + state] = 1.0;
            if let Some(colour) = robot.holding.and_then(|b| colour_of.get(b as usize - 1)) {
                out[self.start(3) + n * c + *colour as usize] = 1.0;
            }
        }
        for (_, colour, place) in game.blocks() {
            if let BlockPlace::Room { zone, .. } = place {
                if let Some(r) = self.rooms.iter().position(|&room| room == zone) {
                    out[self.start(4) + r * c + colour as usize] += 1.0;
                }
            }
        }
        for (i, colour) in game.sequence().iter().take(d.sequence).enumerate() {
            out[self.start(5) + i * c + *colour as usize] = 1.0;
        }
        let index = (game.sequence_index() as usize).min(d.sequence);
        out[self.start(6) + index] = 1.0;
        out[self.start(7)..self.start(7) + index].fill(1.0);
        out[self.start(8)] = (game.tick() as f64 / max_ticks.max(1) as f64) as f32;
    }
}
