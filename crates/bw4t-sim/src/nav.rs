//! Path planning: shortest routes over the zone graph, turned into straight-line waypoints.
//!
//! Routes follow the original: Dijkstra over zone centres with Euclidean edge weights.
//! Crossing into or out of a walled zone goes through the door nearest the other zone,
//! lined up on both sides, so robots pass doors head-on instead of grazing a jamb.

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use bw4t_map::{Map, Rect, Vec2, ZoneIdx};

use crate::physics::{ROBOT_HALF, SKIN, WALL_HALF};

/// How far before and after a door a robot lines up with it.
const DOOR_APPROACH: f32 = 1.6;

/// Precomputed shortest routes between every pair of zones of one map.
pub(crate) struct Navigator {
    centres: Vec<Vec2>,
    rects: Vec<Rect>,
    walled: Vec<bool>,
    doors: Vec<Vec<bw4t_map::Door>>,
    /// `toward[to * zones + from]`: the zone after `from` on a shortest route to `to`, or
    /// [`NO_ROUTE`]. One flat table of `u16` (maps have at most `MAX_ZONES` zones), as it
    /// grows with the square of the zones.
    toward: Vec<u16>,
}

/// No route in [`Navigator::toward`].
const NO_ROUTE: u16 = u16::MAX;
const _: () = assert!(bw4t_map::MAX_ZONES < NO_ROUTE as usize, "zone indices must fit below NO_ROUTE");

impl Navigator {
    /// Routes for every pair of zones; blockades and doorless walled zones are never used.
    pub(crate) fn new(map: &Map) -> Self {
        let zones = map.zones();
        let usable: Vec<bool> = zones
            .iter()
            .map(|z| z.kind.is_walkable() && (!z.kind.is_walled() || !z.doors.is_empty()))
            .collect();
        let centres: Vec<Vec2> = zones.iter().map(|z| z.rect.centre).collect();
        let edges: Vec<Vec<(usize, f32)>> = (0..zones.len())
            .map(|a| {
                let near = map.neighbours(a).iter().filter(|&&b| usable[a] && usable[b]);
                near.map(|&b| (b, centres[a].distance(centres[b]))).collect()
            })
            .collect();
        let mut toward = vec![NO_ROUTE; zones.len() * zones.len()];
        for (to, row) in toward.chunks_exact_mut(zones.len().max(1)).enumerate() {
            routes_to(to, &edges, usable[to], row);
        }
        Navigator {
            centres,
            rects: zones.iter().map(|z| z.rect).collect(),
            walled: zones.iter().map(|z| z.kind.is_walled()).collect(),
            doors: zones.iter().map(|z| z.doors.clone()).collect(),
            toward,
        }
    }

    /// The point of `zone` nearest to `p` where a robot's centre can stand clear of walls.
    pub(crate) fn standable(&self, zone: ZoneIdx, p: Vec2) -> Vec2 {
        self.rects[zone].shrunk(ROBOT_HALF + WALL_HALF + 2.0 * SKIN).clamp(p)
    }

    /// The centre of a zone (where `goTo` leads).
    pub(crate) fn centre(&self, zone: ZoneIdx) -> Vec2 {
        self.standable(zone, self.centres[zone])
    }

    /// Fills `out` with the waypoints from zone `from` to `target` inside zone `to`.
    /// Returns false (leaving `out` empty) when no route exists.
    pub(crate) fn waypoints(&self, from: ZoneIdx, to: ZoneIdx, target: Vec2, out: &mut Vec<Vec2>) -> bool {
        out.clear();
        let mut here = from;
        while here != to {
            let next = self.toward[to * self.centres.len() + here];
            if next == NO_ROUTE {
                out.clear();
                return false;
            }
            let next = usize::from(next);
            if self.walled[here] {
                let (door, inward) = self.door_towards(here, next);
                out.extend([door + inward * DOOR_APPROACH, door - inward * DOOR_APPROACH]);
            }
            if self.walled[next] {
                let (door, inward) = self.door_towards(next, here);
                out.extend([door - inward * DOOR_APPROACH, door + inward * DOOR_APPROACH]);
            }
            if next != to {
                out.push(self.centre(next));
            }
            here = next;
        }
        out.push(target);
        true
    }

    /// The door of walled zone `room` nearest to zone `other`, with its inward direction.
    fn door_towards(&self, room: ZoneIdx, other: ZoneIdx) -> (Vec2, Vec2) {
        let rect = &self.rects[room];
        let other_rect = &self.rects[other];
        let door = self.doors[room]
            .iter()
            .min_by(|a, b| other_rect.distance(a.centre).total_cmp(&other_rect.distance(b.centre)))
            .copied();
        // Usable walled zones have a door (see `new`), so this fallback is never taken.
        door.map_or((rect.centre, Vec2::ZERO), |d| (d.centre, d.inward(rect)))
    }
}

/// Dijkstra from `to` over undirected `edges`: fills `next` with, for every zone, the next
/// zone towards `to` (left [`NO_ROUTE`] where there is none).
fn routes_to(to: usize, edges: &[Vec<(usize, f32)>], usable: bool, next: &mut [u16]) {
    let n = edges.len();
    let mut dist = vec![f32::INFINITY; n];
    if !usable {
        return;
    }
    dist[to] = 0.0;
    let mut heap = BinaryHeap::from([Entry { cost: 0.0, zone: to }]);
    while let Some(Entry { cost, zone }) = heap.pop() {
        if cost > dist[zone] {
            continue;
        }
        for &(other, len) in &edges[zone] {
            let through = cost + len;
            // Strictly shorter only, so equal-length routes resolve by a fixed order.
            if through < dist[other] {
                dist[other] = through;
                next[other] = zone as u16;
                heap.push(Entry { cost: through, zone: other });
            }
        }
    }
}

/// A heap entry ordered by lowest cost first, then lowest zone index.
#[derive(PartialEq)]
struct Entry {
    cost: f32,
    zone: usize,
}

impl Eq for Entry {}

impl Ord for Entry {
    fn cmp(&self, other: &Self) -> Ordering {
        other.cost.total_cmp(&self.cost).then_with(|| other.zone.cmp(&self.zone))
    }
}

impl PartialOrd for Entry {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
