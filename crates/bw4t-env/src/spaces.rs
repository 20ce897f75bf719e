//! The observation and action spaces: one table of segments each, sized per map and config.
//!
//! [`OBS_SEGMENTS`] and [`ACTION_SEGMENTS`] are the one source of both spaces: the crate
//! docs' tables follow them (a test holds them together) and a binding exports them as
//! metadata ([`Spaces::obs_layout`], [`Spaces::action_layout`]).

use bw4t_map::{Colour, Map, ZoneKind};
use bw4t_protocol::KINDS;

/// The numbers a segment's length is made of, for one map and config.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Dims {
    /// `P`: places (every zone of the map, in map order).
    pub places: usize,
    /// `R`: rooms (zones of kind room, the drop zone included, in map order).
    pub rooms: usize,
    /// `C`: block colours (9, in the spec's order).
    pub colours: usize,
    /// `K`: visible-block slots.
    pub slots: usize,
    /// `L`: the goal sequence's length (fixed by the map).
    pub sequence: usize,
    /// `M`: kinds of message in the language.
    pub kinds: usize,
}

impl Dims {
    /// The numbers for `map` with `slots` visible-block slots.
    pub fn of(map: &Map, slots: usize) -> Dims {
        Dims {
            places: map.zones().len(),
            rooms: map.zones().iter().filter(|z| z.kind == ZoneKind::Room).count(),
            colours: Colour::ALL.len(),
            slots,
            sequence: map.sequence().len() + map.random_sequence() as usize,
            kinds: KINDS.len(),
        }
    }
}

/// How long a segment is, as a formula over [`Dims`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Size {
    /// A fixed length.
    Fixed(usize),
    /// `P`.
    Places,
    /// `R`.
    Rooms,
    /// `C`.
    Colours,
    /// `K`.
    Slots,
    /// `K*C`.
    SlotColours,
    /// `L`.
    Sequence,
    /// `L*C`.
    SequenceColours,
    /// `L+1`.
    SequencePlusOne,
    /// `M+1`.
    KindsPlusOne,
}

impl Size {
    /// The length for `dims`.
    pub fn len(self, dims: &Dims) -> usize {
        match self {
            Size::Fixed(n) => n,
            Size::Places => dims.places,
            Size::Rooms => dims.rooms,
            Size::Colours => dims.colours,
            Size::Slots => dims.slots,
            Size::SlotColours => dims.slots * dims.colours,
            Size::Sequence => dims.sequence,
            Size::SequenceColours => dims.sequence * dims.colours,
            Size::SequencePlusOne => dims.sequence + 1,
            Size::KindsPlusOne => dims.kinds + 1,
        }
    }

    /// The formula as the docs write it: `P`, `K*C`, `1`.
    pub fn formula(self) -> String {
        match self {
            Size::Fixed(n) => n.to_string(),
            Size::Places => "P".into(),
            Size::Rooms => "R".into(),
            Size::Colours => "C".into(),
            Size::Slots => "K".into(),
            Size::SlotColours => "K*C".into(),
            Size::Sequence => "L".into(),
            Size::SequenceColours => "L*C".into(),
            Size::SequencePlusOne => "L+1".into(),
            Size::KindsPlusOne => "M+1".into(),
        }
    }
}

/// One segment of a space: a name, a length formula and what it holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SegmentRow {
    /// Its name.
    pub name: &'static str,
    /// Its length.
    pub size: Size,
    /// What it holds (observation) or does (action).
    pub meaning: &'static str,
}

const fn row(name: &'static str, size: Size, meaning: &'static str) -> SegmentRow {
    SegmentRow { name, size, meaning }
}

/// The observation of one robot, segment after segment.
pub const OBS_SEGMENTS: &[SegmentRow] = &[
    row("at", Size::Places, "one-hot: the place the robot is at (`at`)"),
    row("in_room", Size::Fixed(1), "1 when the robot is in a room (`in`)"),
    row("holding", Size::Fixed(1), "1 when the robot holds a block"),
    row("held_colour", Size::Colours, "one-hot: the held block's colour"),
    row("room_colours", Size::Colours, "count of the blocks of each colour visible in the robot's room"),
    row(
        "slots",
        Size::SlotColours,
        "per slot k: the colour one-hot of the k-th visible block by id (zeros: empty)",
    ),
    row("at_block", Size::Fixed(1), "1 when a block is within reach (`atBlock`)"),
    row("sequence", Size::SequenceColours, "per position: the goal colour one-hot"),
    row(
        "sequence_index",
        Size::SequencePlusOne,
        "one-hot: the index of the next colour needed (L: complete)",
    ),
    row("delivered", Size::Sequence, "1 for each position already delivered"),
    row("occupied", Size::Rooms, "1 for each room some robot is in (`occupied`)"),
    row("move_state", Size::Fixed(3), "one-hot: arrived, traveling, collided (`state`)"),
    row(
        "messages",
        Size::KindsPlusOne,
        "messages received during the step, per kind of the language; last: free text",
    ),
    row("time", Size::Fixed(1), "the tick over the tick limit"),
];

/// The actions of one robot, segment after segment; the action index runs through them.
pub const ACTION_SEGMENTS: &[SegmentRow] = &[
    row("wait", Size::Fixed(1), "nothing (an order under way goes on)"),
    row("go_to", Size::Places, "`goTo` place p"),
    row("go_to_block", Size::Slots, "`goToBlock` the block in visible slot k"),
    row("pick_up", Size::Fixed(1), "`pickUp` the block the robot is at"),
    row("put_down", Size::Fixed(1), "`putDown` the held block"),
    row("say_will_get", Size::Colours, "to all: `will_get` colour c"),
    row("say_contains", Size::Colours, "to all: `contains` the robot's room, colour c"),
    row("say_empty", Size::Fixed(1), "to all: `empty` the robot's room"),
    row("say_going_to", Size::Rooms, "to all: `going_to` room r"),
];

/// A segment placed in a vector.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Segment {
    /// Its name, from the table.
    pub name: &'static str,
    /// Where it starts.
    pub offset: usize,
    /// How long it is.
    pub len: usize,
}

/// Both spaces for one map and config.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Spaces {
    /// The numbers the lengths are made of.
    pub dims: Dims,
    obs: Vec<Segment>,
    actions: Vec<Segment>,
}

fn lay_out(rows: &[SegmentRow], dims: &Dims) -> Vec<Segment> {
    let mut offset = 0;
    rows.iter()
        .map(|r| {
            let len = r.size.len(dims);
            let seg = Segment { name: r.name, offset, len };
            offset += len;
            seg
        })
        .collect()
}

impl Spaces {
    /// The spaces for `dims`.
    pub fn new(dims: Dims) -> Spaces {
        Spaces { obs: lay_out(OBS_SEGMENTS, &dims), actions: lay_out(ACTION_SEGMENTS, &dims), dims }
    }

    /// The observation's segments, in order.
    pub fn obs_layout(&self) -> &[Segment] {
        &self.obs
    }

    /// The action index's segments, in order.
    pub fn action_layout(&self) -> &[Segment] {
        &self.actions
    }

    /// Length of one robot's observation.
    pub fn obs_len(&self) -> usize {
        self.obs.last().map_or(0, |s| s.offset + s.len)
    }

    /// Number of actions (`Discrete(n)`), also the length of one robot's mask.
    pub fn n_actions(&self) -> usize {
        self.actions.last().map_or(0, |s| s.offset + s.len)
    }

    /// The observation segment called `name`.
    pub fn obs_segment(&self, name: &str) -> Option<&Segment> {
        self.obs.iter().find(|s| s.name == name)
    }

    /// The action segment called `name`.
    pub fn action_segment(&self, name: &str) -> Option<&Segment> {
        self.actions.iter().find(|s| s.name == name)
    }

    /// The segment an action index falls in, and the index within it.
    pub fn action_at(&self, action: usize) -> Option<(&'static str, usize)> {
        self.actions
            .iter()
            .find(|s| (s.offset..s.offset + s.len).contains(&action))
            .map(|s| (s.name, action - s.offset))
    }
}
