//! A map's blocks and goal sequence for one seed: fixed content plus the random extras.

use crate::colour::Colour;
use crate::geometry::{Rect, Vec2};
use crate::limits::MAX_BLOCKS_PER_ROOM;
use crate::model::Map;
use crate::parts::{ZoneIdx, ZoneKind};
use crate::rng::SeededRng;

/// Blocks in a room are at least this far apart on one axis.
pub const BLOCK_SPACING: f32 = 2.0;

/// Half the side of a block: a placed block stays this far inside its room's walls.
const BLOCK_HALF: f32 = 0.5;

/// Random spots tried before falling back to a deterministic scan of the room.
const RANDOM_TRIES: usize = 64;

/// A block placed in a room at the start of a match.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlacedBlock {
    /// Its colour.
    pub colour: Colour,
    /// The room it lies in.
    pub zone: ZoneIdx,
    /// Its centre.
    pub pos: Vec2,
}

/// The blocks and sequence of one match. Block `i` of `blocks` gets the id `i + 1`.
#[derive(Clone, Debug, PartialEq)]
pub struct Content {
    /// The goal colours in delivery order.
    pub sequence: Vec<Colour>,
    /// Every block, fixed ones first (in zone order), then the random ones.
    pub blocks: Vec<PlacedBlock>,
}

/// Random content that cannot be placed.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum ContentError {
    /// Random blocks are asked for but every room is full (or there is none).
    #[error("no room (other than the drop zone) has space for another random block")]
    NoRoomWithSpace,
    /// A room is too small for its blocks at the required spacing.
    #[error("room '{0}' has no free spot for another block")]
    RoomFull(String),
}

impl Map {
    /// The content for a match played with `match_seed` (the map's own seed wins if set).
    ///
    /// One generator draws, in order: the random sequence colours, the rooms of their
    /// blocks, the random blocks' colours and rooms, then every block's spot.
    pub fn content(&self, match_seed: u64) -> Result<Content, ContentError> {
        let mut rng = SeededRng::new(self.seed().unwrap_or(match_seed));
        let mut sequence = self.sequence().to_vec();
        let mut owners: Vec<(Colour, ZoneIdx)> = Vec::new();
        for (idx, zone) in self.zones().iter().enumerate() {
            owners.extend(zone.blocks.iter().map(|&c| (c, idx)));
        }
        let eligible: Vec<ZoneIdx> = (0..self.zones().len())
            .filter(|&i| self.zones()[i].kind == ZoneKind::Room && i != self.drop_zone())
            .collect();
        let mut counts = vec![0usize; self.zones().len()];
        owners.iter().for_each(|&(_, z)| counts[z] += 1);
        // Fail as `pick_room` would, before drawing (and holding) a colour per random block.
        let free: u64 = eligible.iter().map(|&z| MAX_BLOCKS_PER_ROOM.saturating_sub(counts[z]) as u64).sum();
        if u64::from(self.random_sequence()) + u64::from(self.random_blocks()) > free {
            return Err(ContentError::NoRoomWithSpace);
        }

        let random_colours = (0..self.random_sequence()).map(|_| Colour::ALL[rng.index(9)]);
        let random_colours: Vec<Colour> = random_colours.collect();
        sequence.extend(&random_colours);
        for colour in random_colours {
            owners.push((colour, pick_room(&eligible, &mut counts, &mut rng)?));
        }
        for _ in 0..self.random_blocks() {
            let colour = Colour::ALL[rng.index(9)];
            owners.push((colour, pick_room(&eligible, &mut counts, &mut rng)?));
        }

        let mut blocks: Vec<PlacedBlock> = Vec::with_capacity(owners.len());
        for (colour, zone) in owners {
            let room = &self.zones()[zone];
            let others: Vec<Vec2> = blocks.iter().filter(|b| b.zone == zone).map(|b| b.pos).collect();
            let pos = random_spot(&room.rect, &others, &mut rng)
                .ok_or_else(|| ContentError::RoomFull(room.name.clone()))?;
            blocks.push(PlacedBlock { colour, zone, pos });
        }
        Ok(Content { sequence, blocks })
    }
}

/// Whether a block at `p` keeps [`BLOCK_SPACING`] on some axis from every block in `others`.
pub fn spot_is_clear(p: Vec2, others: &[Vec2]) -> bool {
    others.iter().all(|o| (p - *o).abs().max_element() >= BLOCK_SPACING)
}

/// The region where a block's centre may lie so that the whole block is inside `room`.
pub fn block_area(room: &Rect) -> Rect {
    room.shrunk(BLOCK_HALF)
}

fn pick_room(
    eligible: &[ZoneIdx],
    counts: &mut [usize],
    rng: &mut SeededRng,
) -> Result<ZoneIdx, ContentError> {
    let open: Vec<ZoneIdx> = eligible.iter().copied().filter(|&z| counts[z] < MAX_BLOCKS_PER_ROOM).collect();
    if open.is_empty() {
        return Err(ContentError::NoRoomWithSpace);
    }
    let zone = open[rng.index(open.len())];
    counts[zone] += 1;
    Ok(zone)
}

fn random_spot(room: &Rect, others: &[Vec2], rng: &mut SeededRng) -> Option<Vec2> {
    let area = block_area(room);
    let (min, max) = (area.min(), area.max());
    for _ in 0..RANDOM_TRIES {
        let p = Vec2::new(rng.range_f32(min.x, max.x), rng.range_f32(min.y, max.y));
        if spot_is_clear(p, others) {
            return Some(p);
        }
    }
    // A crowded room: scan a fine grid so a free spot is found whenever one exists. A block
    // rules out fewer than 10 x 10 of its points, so the first `limit` points hold a free one
    // unless the room is too large for its coordinates to step by 0.5 (or not finite).
    let steps = |lo: f32, hi: f32| (((hi - lo) / 0.5).floor() as u32).saturating_add(1);
    let limit = (others.len() + 1) * 100;
    (0..steps(min.y, max.y))
        .flat_map(|j| {
            (0..steps(min.x, max.x)).map(move |i| Vec2::new(min.x + 0.5 * i as f32, min.y + 0.5 * j as f32))
        })
        .take(limit)
        .find(|p| spot_is_clear(*p, others))
}
