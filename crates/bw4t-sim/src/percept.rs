//! Percepts as the spec defines them, the per-robot deltas that carry them, and a belief
//! base that rebuilds the current facts from those deltas.
//!
//! How each send type shows in a [`PerceptDelta`]:
//! - *once* (`place`, `ownName`, `sequence`, `bot`, `player`): in `add` of the first delta
//!   (and of every full snapshot). `player(X)` also arrives when X joins later, and
//!   `not player(X)` when X leaves, so the roster stays true.
//! - *on change* (`at`, `sequenceIndex`, `state`): in `add` whenever the value changes.
//!   They are single-valued: a new `at(P)` replaces the old one. They never appear in `not`.
//! - *on change with negation* (`in`, `atBlock`, `occupied`, `color`, `holding`, `block`):
//!   in `add` when they start to hold, in `not` when they stop.
//! - *events* (`message`): in `add` exactly once; never in `not`, never part of the state.
//!
//! A client keeps the state by applying `not`, then `add`, of each delta in order (a `full`
//! delta first clears everything); `bw4t_protocol::Knowledge` is the model that does.
//!
//! Each percept is described once, beside its variant (`describe_percepts!` below): its
//! name, its arguments' kinds, how it is sent and to whom. [`PERCEPTS`], the protocol's
//! table and the wire conversion all follow from that row.

use std::fmt;
use std::sync::Arc;

use bw4t_map::Colour;

/// A block's id, a natural number unique within a match.
pub type BlockId = u32;

/// The state a robot is in, as in the `state` percept.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum MoveState {
    /// No remaining waypoints (also the initial state).
    Arrived,
    /// On its way.
    Traveling,
    /// The last move failed at a closed door (or another robot); the plan was dropped.
    Collided,
}

impl MoveState {
    /// Every state.
    pub const ALL: [MoveState; 3] = [MoveState::Arrived, MoveState::Traveling, MoveState::Collided];

    /// The state named `name` in the spec's lower case.
    pub fn from_name(name: &str) -> Option<MoveState> {
        MoveState::ALL.into_iter().find(|s| s.name() == name)
    }

    /// The spec's lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            MoveState::Arrived => "arrived",
            MoveState::Traveling => "traveling",
            MoveState::Collided => "collided",
        }
    }
}

/// How the spec sends a percept.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SendType {
    /// At the start (and, for `player`, on joins and leaves).
    Once,
    /// Whenever its single value changes.
    OnChange,
    /// When it starts to hold, and as `not` when it stops.
    OnChangeWithNegation,
    /// Delivered exactly once, not part of the state.
    Event,
}

/// Who perceives a percept.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scope {
    /// Only the player it is about.
    Local,
    /// Every player.
    Global,
}

/// What an argument of a percept names. Its form (a name, a number, a colour, ...) follows
/// from the Rust type of the variant's field.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ArgKind {
    /// A place of the map, by name.
    Place,
    /// A player, by name.
    Player,
    /// A robot's id.
    Robot,
    /// Colours in order.
    Colours,
    /// A position in the sequence.
    Index,
    /// A [`MoveState`].
    State,
    /// A room, by name.
    Room,
    /// A block's id.
    Block,
    /// A colour.
    Colour,
    /// Free text: what a message says.
    Text,
}

impl ArgKind {
    /// The kind's name in the protocol's table.
    pub const fn name(self) -> &'static str {
        match self {
            ArgKind::Place => "place",
            ArgKind::Player => "player",
            ArgKind::Robot => "robot",
            ArgKind::Colours => "colours",
            ArgKind::Index => "index",
            ArgKind::State => "state",
            ArgKind::Room => "room",
            ArgKind::Block => "block",
            ArgKind::Colour => "colour",
            ArgKind::Text => "text",
        }
    }
}

/// One percept's description: its predicate name, its arguments' kinds in order, how it is
/// sent and to whom. [`PERCEPTS`] holds one per [`Percept`] variant.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PerceptKind {
    /// The predicate name, as the spec spells it.
    pub name: &'static str,
    /// The arguments' kinds, in order.
    pub args: &'static [ArgKind],
    /// How it is sent.
    pub send: SendType,
    /// To whom.
    pub scope: Scope,
}

/// One percept, with names resolved.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Percept {
    /// `place(PlaceID)`: a place of the map.
    Place(Arc<str>),
    /// `player(PlayerID)`: another player in the match.
    Player(Arc<str>),
    /// `ownName(PlayerID)`: this player's name.
    OwnName(Arc<str>),
    /// `bot(BotID)`: this player's robot id.
    Bot(u32),
    /// `sequence([ColorID])`: the goal colours in order.
    Sequence(Arc<[Colour]>),
    /// `at(PlaceID)`: the place the robot is at (or nearest to, in free space).
    At(Arc<str>),
    /// `sequenceIndex(N)`: the index of the next colour needed.
    SequenceIndex(u32),
    /// `state(State)`: arrived, traveling or collided.
    State(MoveState),
    /// `in(RoomID)`: the robot is in this room.
    In(Arc<str>),
    /// `atBlock(BlockID)`: the robot can pick this block up.
    AtBlock(BlockId),
    /// `occupied(RoomID)`: some robot is in this room.
    Occupied(Arc<str>),
    /// `color(BlockID, ColorID)`: a block visible from this robot's room.
    Color(BlockId, Colour),
    /// `holding(BlockID)`: the block this robot holds.
    Holding(BlockId),
    /// `block(BlockID)`: a block visible from this robot's room.
    Block(BlockId),
    /// `message(Sender, Text)`: a message from another player.
    Message {
        /// The sender's name.
        from: Arc<str>,
        /// The text.
        text: Arc<str>,
    },
}

/// Declares [`PERCEPTS`] and what goes between a percept and its arguments from one row
/// per variant: `Variant { field: ArgKind, ... } "name" SendType Scope;`, fields by
/// position (`0`, `1`) or by name, in argument order.
macro_rules! describe_percepts {
    ($($variant:ident { $($field:tt: $kind:ident),* } $name:literal $send:ident $scope:ident;)*) => {
        /// A variant's row in [`PERCEPTS`].
        #[derive(Clone, Copy)]
        enum Row {
            $($variant),*
        }

        /// Every percept's description, in the order of [`Percept`]'s variants (the order
        /// the protocol documents them).
        pub const PERCEPTS: &[PerceptKind] = &[$(PerceptKind {
            name: $name,
            args: &[$(ArgKind::$kind),*],
            send: SendType::$send,
            scope: Scope::$scope,
        }),*];

        impl Percept {
            fn row(&self) -> Row {
                match self {
                    $(Percept::$variant { .. } => Row::$variant),*
                }
            }

            /// Hands each argument to `f`, in order, with its kind.
            #[inline]
            pub fn for_each_arg<'a>(&'a self, mut f: impl FnMut(ArgKind, ArgRef<'a>)) {
                match self {
                    $(Percept::$variant { .. } => {
                        $(if let Percept::$variant { $field: value, .. } = self {
                            f(ArgKind::$kind, ArgRef::from(value));
                        })*
                    })*
                }
            }

            /// The percept named `name`, its arguments read in order from `reader`; `None`
            /// if no percept has that name or an argument cannot be read.
            #[inline]
            pub fn from_args(name: &str, reader: &mut impl ArgReader) -> Option<Percept> {
                Some(match name {
                    $($name => Percept::$variant {
                        $($field: ReadArg::read(reader, ArgKind::$kind)?),*
                    },)*
                    _ => return None,
                })
            }
        }
    };
}

describe_percepts! {
    Place { 0: Place } "place" Once Global;
    Player { 0: Player } "player" Once Global;
    OwnName { 0: Player } "ownName" Once Local;
    Bot { 0: Robot } "bot" Once Local;
    Sequence { 0: Colours } "sequence" Once Global;
    At { 0: Place } "at" OnChange Local;
    SequenceIndex { 0: Index } "sequenceIndex" OnChange Global;
    State { 0: State } "state" OnChange Local;
    In { 0: Room } "in" OnChangeWithNegation Local;
    AtBlock { 0: Block } "atBlock" OnChangeWithNegation Local;
    Occupied { 0: Room } "occupied" OnChangeWithNegation Global;
    Color { 0: Block, 1: Colour } "color" OnChangeWithNegation Local;
    Holding { 0: Block } "holding" OnChangeWithNegation Local;
    Block { 0: Block } "block" OnChangeWithNegation Local;
    Message { from: Player, text: Text } "message" Event Local;
}

impl Percept {
    /// Its description in [`PERCEPTS`].
    pub fn kind(&self) -> &'static PerceptKind {
        &PERCEPTS[self.row() as usize]
    }

    /// The predicate name, as the spec spells it.
    pub fn name(&self) -> &'static str {
        self.kind().name
    }

    /// How the percept is sent.
    pub fn send_type(&self) -> SendType {
        self.kind().send
    }
}

/// An argument of a percept, borrowed, in its Rust form.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ArgRef<'a> {
    /// A name or a text.
    Text(&'a str),
    /// An id or an index.
    Number(u32),
    /// A colour.
    Colour(Colour),
    /// Colours in order.
    Colours(&'a [Colour]),
    /// A robot's state.
    State(MoveState),
}

impl<'a> From<&'a Arc<str>> for ArgRef<'a> {
    fn from(text: &'a Arc<str>) -> Self {
        ArgRef::Text(text)
    }
}

impl From<&u32> for ArgRef<'_> {
    fn from(n: &u32) -> Self {
        ArgRef::Number(*n)
    }
}

impl From<&Colour> for ArgRef<'_> {
    fn from(colour: &Colour) -> Self {
        ArgRef::Colour(*colour)
    }
}

impl<'a> From<&'a Arc<[Colour]>> for ArgRef<'a> {
    fn from(colours: &'a Arc<[Colour]>) -> Self {
        ArgRef::Colours(colours)
    }
}

impl From<&MoveState> for ArgRef<'_> {
    fn from(state: &MoveState) -> Self {
        ArgRef::State(*state)
    }
}

impl fmt::Display for ArgRef<'_> {
    /// The spec's notation: `FrontC1`, `3`, `Yellow`, `[Red,Blue]`, `arrived`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ArgRef::Text(text) => f.write_str(text),
            ArgRef::Number(n) => write!(f, "{n}"),
            ArgRef::Colour(colour) => f.write_str(colour.name()),
            ArgRef::Colours(colours) => {
                f.write_str("[")?;
                for (i, colour) in colours.iter().enumerate() {
                    if i > 0 {
                        f.write_str(",")?;
                    }
                    f.write_str(colour.name())?;
                }
                f.write_str("]")
            }
            ArgRef::State(state) => f.write_str(state.name()),
        }
    }
}

/// Where [`Percept::from_args`] reads a percept's arguments from, in order: each call reads the
/// next argument, of kind `kind`, in the form asked for, or `None` if it is missing or not
/// of that form.
pub trait ArgReader {
    /// A name or a text.
    fn text(&mut self, kind: ArgKind) -> Option<Arc<str>>;
    /// An id or an index.
    fn number(&mut self, kind: ArgKind) -> Option<u32>;
    /// A colour.
    fn colour(&mut self, kind: ArgKind) -> Option<Colour>;
    /// Colours in order.
    fn colours(&mut self, kind: ArgKind) -> Option<Arc<[Colour]>>;
    /// A robot's state.
    fn state(&mut self, kind: ArgKind) -> Option<MoveState>;
}

/// A field of a [`Percept`] variant, read in its Rust form.
trait ReadArg: Sized {
    fn read(reader: &mut impl ArgReader, kind: ArgKind) -> Option<Self>;
}

impl ReadArg for Arc<str> {
    fn read(reader: &mut impl ArgReader, kind: ArgKind) -> Option<Self> {
        reader.text(kind)
    }
}

impl ReadArg for u32 {
    fn read(reader: &mut impl ArgReader, kind: ArgKind) -> Option<Self> {
        reader.number(kind)
    }
}

impl ReadArg for Colour {
    fn read(reader: &mut impl ArgReader, kind: ArgKind) -> Option<Self> {
        reader.colour(kind)
    }
}

impl ReadArg for Arc<[Colour]> {
    fn read(reader: &mut impl ArgReader, kind: ArgKind) -> Option<Self> {
        reader.colours(kind)
    }
}

impl ReadArg for MoveState {
    fn read(reader: &mut impl ArgReader, kind: ArgKind) -> Option<Self> {
        reader.state(kind)
    }
}

impl fmt::Display for Percept {
    /// The spec's notation: `at(FrontC1)`, `color(3,Yellow)`, `sequence([Red,Blue])`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}(", self.name())?;
        let (mut written, mut separator) = (Ok(()), "");
        self.for_each_arg(|_, arg| {
            if written.is_ok() {
                written = f.write_str(separator).and_then(|()| fmt::Display::fmt(&arg, f));
                separator = ",";
            }
        });
        written?;
        f.write_str(")")
    }
}

/// What one robot learns in one poll: facts that now hold and facts that stopped holding.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PerceptDelta {
    /// The tick the delta describes.
    pub tick: u64,
    /// A full snapshot: the receiver should forget everything it held before.
    pub full: bool,
    /// Facts that started to hold (or changed value), and new messages.
    pub add: Vec<Percept>,
    /// Facts that stopped holding.
    pub not: Vec<Percept>,
}

impl PerceptDelta {
    /// Whether the delta carries nothing.
    pub fn is_empty(&self) -> bool {
        !self.full && self.add.is_empty() && self.not.is_empty()
    }
}

/// The changeable facts of one robot, in a compact form that is cheap to compare.
/// Variant order is the order facts are generated in, so generated lists come out sorted.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub(crate) enum Fact {
    Player(u32),
    At(u32),
    SequenceIndex(u32),
    State(MoveState),
    In(u32),
    AtBlock(BlockId),
    Occupied(u32),
    Color(BlockId),
    Holding(BlockId),
    Block(BlockId),
}

impl Fact {
    fn single_valued(self) -> bool {
        matches!(self, Fact::At(_) | Fact::SequenceIndex(_) | Fact::State(_))
    }
}

/// Walks two sorted fact lists, reporting facts new in `now` and negatable facts gone from `before`.
pub(crate) fn diff(
    before: &[Fact],
    now: &[Fact],
    mut added: impl FnMut(Fact),
    mut removed: impl FnMut(Fact),
) {
    let (mut i, mut j) = (0, 0);
    while i < before.len() || j < now.len() {
        match (before.get(i), now.get(j)) {
            (Some(a), Some(b)) if a == b => {
                i += 1;
                j += 1;
            }
            (Some(a), Some(b)) if a < b => {
                if !a.single_valued() {
                    removed(*a);
                }
                i += 1;
            }
            (Some(a), None) => {
                if !a.single_valued() {
                    removed(*a);
                }
                i += 1;
            }
            (_, Some(b)) => {
                added(*b);
                j += 1;
            }
            (None, None) => break,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn diff_reports_changes_and_negates_only_negatable_facts() {
        let before = [Fact::At(1), Fact::In(4), Fact::Occupied(4), Fact::Color(7)];
        let now = [Fact::At(2), Fact::Occupied(4), Fact::Holding(7)];
        let (mut added, mut removed) = (Vec::new(), Vec::new());
        diff(&before, &now, |f| added.push(f), |f| removed.push(f));
        assert_eq!(added, [Fact::At(2), Fact::Holding(7)]);
        assert_eq!(removed, [Fact::In(4), Fact::Color(7)]);
    }

    /// Reads made-up arguments, noting the kinds asked for and the forms they were read in.
    #[derive(Default)]
    struct Samples {
        asked: Vec<ArgKind>,
        forms: Vec<(ArgKind, &'static str)>,
    }

    impl Samples {
        fn note(&mut self, kind: ArgKind, form: &'static str) {
            self.asked.push(kind);
            self.forms.push((kind, form));
        }
    }

    impl ArgReader for Samples {
        fn text(&mut self, kind: ArgKind) -> Option<Arc<str>> {
            self.note(kind, "text");
            Some(kind.name().into())
        }
        fn number(&mut self, kind: ArgKind) -> Option<u32> {
            self.note(kind, "number");
            Some(self.asked.len() as u32)
        }
        fn colour(&mut self, kind: ArgKind) -> Option<Colour> {
            self.note(kind, "colour");
            Some(Colour::Yellow)
        }
        fn colours(&mut self, kind: ArgKind) -> Option<Arc<[Colour]>> {
            self.note(kind, "colours");
            Some(vec![Colour::Red, Colour::Blue].into())
        }
        fn state(&mut self, kind: ArgKind) -> Option<MoveState> {
            self.note(kind, "state");
            Some(MoveState::Collided)
        }
    }

    /// The one form each kind of argument has, whatever percept it belongs to: clients read
    /// an argument by its kind's name in the table.
    fn form_of(kind: ArgKind) -> &'static str {
        match kind {
            ArgKind::Place | ArgKind::Player | ArgKind::Room | ArgKind::Text => "text",
            ArgKind::Robot | ArgKind::Index | ArgKind::Block => "number",
            ArgKind::Colour => "colour",
            ArgKind::Colours => "colours",
            ArgKind::State => "state",
        }
    }

    #[test]
    fn every_description_makes_its_percept_with_the_arguments_it_lists() {
        for kind in PERCEPTS {
            let mut samples = Samples::default();
            let percept =
                Percept::from_args(kind.name, &mut samples).unwrap_or_else(|| panic!("{}", kind.name));
            assert_eq!(samples.asked, kind.args, "{}: the arguments read", kind.name);
            for (arg, form) in samples.forms {
                assert_eq!(form, form_of(arg), "{}: a {} argument's form", kind.name, arg.name());
            }
            assert_eq!(percept.kind(), kind, "{} describes itself", kind.name);
            let mut given = Vec::new();
            percept.for_each_arg(|kind, _| given.push(kind));
            assert_eq!(given, kind.args, "{}: the arguments given", kind.name);
        }
        assert_eq!(Percept::from_args("fly", &mut Samples::default()), None);
        let mut names: Vec<&str> = PERCEPTS.iter().map(|k| k.name).collect();
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), PERCEPTS.len(), "names are unique");
    }

    #[test]
    fn percepts_show_in_the_spec_notation() {
        let text = |s: &str| Arc::<str>::from(s);
        let shown = [
            Percept::At(text("FrontC1")),
            Percept::Color(3, Colour::Yellow),
            Percept::Sequence(vec![Colour::Red, Colour::Blue].into()),
            Percept::State(MoveState::Traveling),
            Percept::Message { from: text("Bob"), text: text("hi there") },
        ]
        .map(|p| p.to_string());
        assert_eq!(
            shown,
            [
                "at(FrontC1)",
                "color(3,Yellow)",
                "sequence([Red,Blue])",
                "state(traveling)",
                "message(Bob,hi there)"
            ]
        );
        for state in MoveState::ALL {
            assert_eq!(MoveState::from_name(state.name()), Some(state));
        }
        assert_eq!(MoveState::from_name("Arrived"), None);
    }
}
