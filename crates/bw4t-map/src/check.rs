//! Map checking: every problem of a map file, with where it is.
//!
//! [`check_parts`] works on [`MapParts`], so it explains maps that [`Map::new`] refuses (the
//! map's rules, `rules.rs`, are its first errors) as well as maps that load but cannot be
//! played (a room nobody reaches, a sequence colour no block has) or look wrong
//! (warnings). [`parse_parts`] reads either file format without validating, so a file's
//! problems can all be reported at once.
//!
//! [`Map::new`]: crate::Map::new
//! [`parse_parts`]: crate::parse_parts

use std::collections::{BTreeMap, BTreeSet};

use crate::colour::Colour;
use crate::format::{MapLoadError, parse_parts};
use crate::geometry::{Door, Orientation, ROBOT_SIZE, Rect, Vec2};
use crate::limits::{in_range, within_counts};
use crate::parts::{DROP_ZONE, MapParts, Zone, ZoneKind};
use crate::problem::{Problem, point, zone_place};
use crate::rules::{door_on_edge, rule_problems};

/// Reads and checks a map file: the problems of [`parse_parts`] and [`check_parts`],
/// errors first. `robots`, when given, is the number of robots the map must take.
pub fn check_text(text: &str, name: &str, robots: Option<usize>) -> Result<Vec<Problem>, MapLoadError> {
    checked_parts(text, name, robots).map(|(_, problems)| problems)
}

/// The parts of a map file and its problems, as [`check_text`] reports them.
fn checked_parts(
    text: &str,
    name: &str,
    robots: Option<usize>,
) -> Result<(MapParts, Vec<Problem>), MapLoadError> {
    let (parts, mut problems) = parse_parts(text, name)?;
    problems.extend(check_parts(&parts, robots));
    problems.sort_by_key(|p| p.severity);
    Ok((parts, problems))
}

/// A map file refused for play by [`Map::parse_checked`].
///
/// [`Map::parse_checked`]: crate::Map::parse_checked
#[derive(Debug, thiserror::Error)]
pub enum CheckError {
    /// The text cannot be read as a map at all.
    #[error(transparent)]
    Unreadable(#[from] MapLoadError),
    /// The map check finds errors: all of them, in the order `map check` lists them.
    #[error("{}", failed(.0))]
    Failed(Vec<Problem>),
}

fn failed(errors: &[Problem]) -> String {
    let listed: Vec<String> = errors.iter().map(Problem::to_string).collect();
    format!("the map check finds {} error(s): {}", errors.len(), listed.join("; "))
}

impl crate::Map {
    /// Reads a map file in either format, as [`Map::parse`] does, for a match: first it is
    /// checked as `bw4t map check` checks it ([`check_text`]), and any error refuses it with
    /// every error; otherwise the map comes with the check's warnings. `robots`, when
    /// given, is the number of robots the map must take.
    ///
    /// [`Map::parse`]: crate::Map::parse
    pub fn parse_checked(
        text: &str,
        name: &str,
        robots: Option<usize>,
    ) -> Result<(crate::Map, Vec<Problem>), CheckError> {
        let (parts, problems) = checked_parts(text, name, robots)?;
        if problems.iter().any(Problem::is_error) {
            return Err(CheckError::Failed(problems.into_iter().filter(Problem::is_error).collect()));
        }
        // Without errors the readers tolerated nothing, so these are the parts `Map::parse`
        // reads, and the map's rules (among the check's errors) hold.
        let map = crate::Map::new(parts).map_err(|e| CheckError::Failed(e.problems))?;
        Ok((map, problems))
    }
}

/// Every problem of `parts`, errors first, each group in the order checked.
///
/// The map's rules come first: whatever [`Map::new`] refuses is an error here, with the
/// same words. Then a map that cannot be played is an error too: overlapping zones, a
/// room or the drop zone no robot reaches, a fixed sequence without the blocks for it, or
/// (with `robots`) too few spawn points. Warnings name things that load but look
/// unintended. A map with more zones or spawn points than allowed ([`MAX_ZONES`],
/// [`MAX_SPAWNS`]) gets only the limits' errors: the other checks would take time with the
/// counts.
///
/// [`Map::new`]: crate::Map::new
/// [`MAX_ZONES`]: crate::MAX_ZONES
/// [`MAX_SPAWNS`]: crate::MAX_SPAWNS
pub fn check_parts(parts: &MapParts, robots: Option<usize>) -> Vec<Problem> {
    let mut first = BTreeMap::new();
    for (i, z) in parts.zones.iter().enumerate() {
        first.entry(z.name.as_str()).or_insert(i);
    }
    let mut checker = Checker { parts, index: first, out: rule_problems(parts) };
    if !within_counts(parts) {
        return checker.out;
    }
    for (idx, zone) in parts.zones.iter().enumerate() {
        checker.zone(idx, zone);
    }
    checker.overlaps();
    checker.spawns(robots);
    checker.reachability();
    checker.sequence();
    checker.edges();
    let mut out = checker.out;
    out.sort_by_key(|p| p.severity);
    out
}

fn spawn_place(idx: usize, name: &str) -> String {
    format!("spawn {} '{name}'", idx + 1)
}

/// How close a door's centre may come to the end of its edge (half the opening).
const DOOR_HALF: f32 = Door::WIDTH / 2.0;

/// Slack for comparing coordinates that are meant to be equal.
const SLACK: f32 = 1e-3;

struct Checker<'a> {
    parts: &'a MapParts,
    /// The first zone of each name.
    index: BTreeMap<&'a str, usize>,
    out: Vec<Problem>,
}

impl<'a> Checker<'a> {
    fn error(&mut self, place: impl Into<String>, message: impl Into<String>) {
        self.out.push(Problem::error(place, message));
    }

    fn warning(&mut self, place: impl Into<String>, message: impl Into<String>) {
        self.out.push(Problem::warning(place, message));
    }

    /// The area as a box from the origin, when it is a real one.
    fn area_rect(&self) -> Option<Rect> {
        let a = self.parts.area;
        (in_range(a) && a.x > 0.0 && a.y > 0.0).then(|| Rect::new(a / 2.0, a))
    }

    /// Undirected edges (each once, as first named) between zones that exist, without loops.
    fn edges_list(&self) -> Vec<(usize, usize)> {
        let index = &self.index;
        let mut seen = BTreeSet::new();
        let mut edges = Vec::new();
        for (i, zone) in self.parts.zones.iter().enumerate() {
            for n in &zone.neighbours {
                if let Some(&j) = index.get(n.as_str()) {
                    if i != j && seen.insert((i.min(j), i.max(j))) {
                        edges.push((i, j));
                    }
                }
            }
        }
        edges
    }

    /// A zone's warnings: itself as a neighbour, a door past a corner, outside the area.
    fn zone(&mut self, idx: usize, zone: &Zone) {
        let place = zone_place(idx, zone);
        for n in &zone.neighbours {
            if *n == zone.name {
                self.warning(&place, "names itself as a neighbour");
            }
        }
        if zone.kind == ZoneKind::Room {
            for door in &zone.doors {
                self.door(&place, door, &zone.rect);
            }
        }
        let size = zone.rect.size;
        let measurable = in_range(zone.rect.centre) && in_range(size);
        if let Some(area) = self.area_rect() {
            if size.x > 0.0 && size.y > 0.0 && measurable {
                let inside =
                    zone.rect.min().cmpge(area.min()).all() && zone.rect.max().cmple(area.max()).all();
                if !zone.rect.overlaps(&area) {
                    self.warning(
                        &place,
                        format!("lies outside the area ({} x {})", area.size.x, area.size.y),
                    );
                } else if zone.kind == ZoneKind::Room && !inside {
                    self.warning(
                        &place,
                        format!("extends beyond the area ({} x {})", area.size.x, area.size.y),
                    );
                }
            }
        }
    }

    /// A door on its edge whose opening reaches past the edge's end (one off its edge
    /// breaks a rule).
    fn door(&mut self, place: &str, door: &Door, room: &Rect) {
        if !in_range(door.centre) || !door_on_edge(door, room) {
            return;
        }
        // The opening is 4 wide; past the corner it would cut the next wall.
        let (c, min, max) = match door.orientation {
            Orientation::Horizontal => (door.centre.x, room.min().x, room.max().x),
            Orientation::Vertical => (door.centre.y, room.min().y, room.max().y),
        };
        if c - DOOR_HALF < min - SLACK || c + DOOR_HALF > max + SLACK {
            self.warning(place, format!("door at {} reaches past the room's corner", point(door.centre)));
        }
    }

    fn overlaps(&mut self) {
        let zones: &'a [Zone] = &self.parts.zones;
        let proper = |z: &Zone| {
            z.rect.centre.is_finite() && z.rect.size.is_finite() && z.rect.size.cmpgt(Vec2::ZERO).all()
        };
        let mut found = Vec::new();
        for (j, b) in zones.iter().enumerate() {
            for (i, a) in zones.iter().enumerate().take(j) {
                if proper(a) && proper(b) && a.rect.overlaps(&b.rect) {
                    found.push(Problem::error(zone_place(j, b), format!("overlaps {}", zone_place(i, a))));
                }
            }
        }
        self.out.extend(found);
    }

    fn spawns(&mut self, robots: Option<usize>) {
        let spawns: &'a [crate::parts::Spawn] = &self.parts.spawns;
        if let Some(n) = robots {
            if spawns.len() < n {
                self.error("spawn points", format!("{} for {n} robots: each robot needs one", spawns.len()));
            }
        }
        let zones: &'a [Zone] = &self.parts.zones;
        for (i, spawn) in spawns.iter().enumerate() {
            let place = spawn_place(i, &spawn.name);
            let at = point(spawn.pos);
            if !in_range(spawn.pos) {
                continue; // reported by the limits
            }
            let walled = zones.iter().find(|z| z.kind.is_walled() && z.rect.contains(spawn.pos));
            match walled {
                Some(z) if z.kind == ZoneKind::Blockade => self.warning(
                    &place,
                    format!("at {at} is inside blockade '{}': the robot cannot move", z.name),
                ),
                Some(z) => self.warning(
                    &place,
                    format!("at {at} is inside room '{}', which holds one robot at a time", z.name),
                ),
                None if !zones.iter().any(|z| z.rect.contains(spawn.pos)) => {
                    self.warning(&place, format!("at {at} is in no zone"))
                }
                None => {}
            }
            // Closer than a robot's side on both axes, two robots would start overlapping.
            let earlier =
                spawns[..i].iter().position(|s| (s.pos - spawn.pos).abs().max_element() < ROBOT_SIZE - SLACK);
            if let Some(j) = earlier {
                self.warning(
                    &place,
                    format!("at {at} overlaps {} (robots are 2 x 2)", spawn_place(j, &spawns[j].name)),
                );
            }
        }
    }

    /// Rooms (and the drop zone) that no robot reaches from any spawn point over the
    /// neighbour graph. A blockade is never entered or left, nor is a walled zone without
    /// doors; a robot starts in the zone the simulation puts it in (a room containing it,
    /// else the first zone containing it, else the nearest).
    fn reachability(&mut self) {
        let zones: &'a [Zone] = &self.parts.zones;
        let usable: Vec<usize> =
            (0..self.parts.spawns.len()).filter(|&i| self.parts.spawns[i].pos.is_finite()).collect();
        if zones.is_empty() || usable.is_empty() {
            return;
        }
        let mut adjacency = vec![Vec::new(); zones.len()];
        for (i, j) in self.edges_list() {
            adjacency[i].push(j);
            adjacency[j].push(i);
        }
        let passable = |z: &Zone| z.kind.is_walkable() && !(z.kind.is_walled() && z.doors.is_empty());
        let mut reached = vec![false; zones.len()];
        let mut queue = Vec::new();
        for i in usable {
            let start = start_zone(zones, self.parts.spawns[i].pos);
            if !reached[start] {
                reached[start] = true;
                if passable(&zones[start]) {
                    queue.push(start);
                }
            }
        }
        while let Some(a) = queue.pop() {
            for &b in &adjacency[a] {
                if !reached[b] && passable(&zones[b]) {
                    reached[b] = true;
                    queue.push(b);
                }
            }
        }
        for (i, zone) in zones.iter().enumerate() {
            if reached[i] || !(zone.kind == ZoneKind::Room || zone.name == DROP_ZONE) {
                continue;
            }
            let why = if zone.kind.is_walled() && zone.doors.is_empty() {
                " (it has no doors)"
            } else if adjacency[i].is_empty() {
                " (it has no neighbours)"
            } else {
                ""
            };
            self.error(zone_place(i, zone), format!("no robot can reach it from the spawn points{why}"));
        }
    }

    /// With fixed content only, every sequence colour needs as many blocks as it occurs.
    fn sequence(&mut self) {
        let parts = self.parts;
        if parts.sequence.is_empty() && parts.random_sequence == 0 {
            self.warning("sequence", "is empty: a match is over as soon as it starts");
        }
        // Random content can supply any colour, so only fixed-only maps can be short.
        if parts.random_sequence != 0 || parts.random_blocks != 0 {
            return;
        }
        let mut have: BTreeMap<Colour, usize> = BTreeMap::new();
        for colour in parts.zones.iter().flat_map(|z| &z.blocks) {
            *have.entry(*colour).or_default() += 1;
        }
        let mut seen = BTreeSet::new();
        for &colour in &parts.sequence {
            if !seen.insert(colour) {
                continue;
            }
            let need = parts.sequence.iter().filter(|&&c| c == colour).count();
            let got = have.get(&colour).copied().unwrap_or(0);
            if got < need {
                let s = if need == 1 { "" } else { "s" };
                self.error("sequence", format!("needs {need} {colour} block{s}, the map has {got}"));
            }
        }
    }

    /// Edges robots cannot travel as drawn: between halls, a straight way through walls;
    /// to a room, no door of the room on the neighbour's side.
    fn edges(&mut self) {
        let zones: &'a [Zone] = &self.parts.zones;
        let proper = |z: &Zone| z.rect.centre.is_finite() && z.rect.size.is_finite();
        let mut found = Vec::new();
        for (i, j) in self.edges_list() {
            let (a, b) = (&zones[i], &zones[j]);
            if !proper(a) || !proper(b) {
                continue;
            }
            let free = |z: &Zone| !z.kind.is_walled();
            if free(a) && free(b) {
                let wall = zones.iter().enumerate().find(|&(k, z)| {
                    k != i && k != j && z.kind.is_walled() && crosses(a.rect.centre, b.rect.centre, &z.rect)
                });
                if let Some((k, z)) = wall {
                    found.push(Problem::warning(
                        zone_place(i, a),
                        format!(
                            "the way to neighbour '{}' goes through the walls of {}",
                            b.name,
                            zone_place(k, z)
                        ),
                    ));
                }
            }
            for (room_idx, room, other) in [(i, a, b), (j, b, a)] {
                if room.kind == ZoneKind::Room && !room.doors.is_empty() && !door_leads_to(room, &other.rect)
                {
                    found.push(Problem::warning(
                        zone_place(room_idx, room),
                        format!("no door leads to its neighbour '{}'", other.name),
                    ));
                }
            }
        }
        self.out.extend(found);
    }
}

/// The zone the simulation puts a robot at `p` in: a room containing it, else the first
/// zone containing it, else the nearest (lowest index on ties). `zones` is not empty.
fn start_zone(zones: &[Zone], p: Vec2) -> usize {
    let room = zones.iter().position(|z| z.kind == ZoneKind::Room && z.rect.contains(p));
    room.or_else(|| zones.iter().position(|z| z.rect.contains(p))).unwrap_or_else(|| {
        let dist = |i: &usize| zones[*i].rect.distance(p);
        (0..zones.len()).min_by(|a, b| dist(a).total_cmp(&dist(b))).unwrap_or(0)
    })
}

/// Whether some door of `room` opens onto `other`: the point just outside the door lies in
/// `other` (edges included).
fn door_leads_to(room: &Zone, other: &Rect) -> bool {
    room.doors.iter().any(|door| {
        let outside = door.centre - door.inward(&room.rect) * (Door::DEPTH / 2.0);
        outside.cmpge(other.min() - SLACK).all() && outside.cmple(other.max() + SLACK).all()
    })
}

/// Whether the segment from `a` to `b` passes through the inside of `rect` (touching its
/// edges does not count).
fn crosses(a: Vec2, b: Vec2, rect: &Rect) -> bool {
    let (min, max) = (rect.min() + SLACK, rect.max() - SLACK);
    let d = b - a;
    let (mut t0, mut t1) = (0.0f32, 1.0f32);
    for axis in 0..2 {
        let (p, v, lo, hi) = (a[axis], d[axis], min[axis], max[axis]);
        if v.abs() < f32::EPSILON {
            if p <= lo || p >= hi {
                return false;
            }
            continue;
        }
        let (mut s0, mut s1) = ((lo - p) / v, (hi - p) / v);
        if s0 > s1 {
            std::mem::swap(&mut s0, &mut s1);
        }
        t0 = t0.max(s0);
        t1 = t1.min(s1);
        if t0 >= t1 {
            return false;
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn segments_cross_only_through_the_inside() {
        let r = Rect::new(Vec2::new(5.0, 5.0), Vec2::new(2.0, 2.0));
        assert!(crosses(Vec2::new(0.0, 5.0), Vec2::new(10.0, 5.0), &r));
        assert!(crosses(Vec2::new(0.0, 0.0), Vec2::new(10.0, 10.0), &r));
        assert!(!crosses(Vec2::new(0.0, 4.0), Vec2::new(10.0, 4.0), &r), "along an edge");
        assert!(!crosses(Vec2::new(0.0, 5.0), Vec2::new(3.0, 5.0), &r), "stops short");
        assert!(!crosses(Vec2::new(0.0, 0.0), Vec2::new(10.0, 0.0), &r), "misses");
    }
}
