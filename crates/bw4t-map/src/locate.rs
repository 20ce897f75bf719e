//! Point location: which zones contain a point, and which is nearest to it, answered from a
//! grid of buckets so that the cost follows the zones near the point, not the size of the map.

use crate::geometry::{Rect, Vec2};
use crate::parts::{Zone, ZoneIdx, ZoneKind};

/// The zones of a map bucketed by a uniform grid over their bounding box. Each cell lists,
/// in file order, every zone whose box reaches into it, so the first zone of a cell that
/// contains a point is the first zone of the whole map that does.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct ZoneGrid {
    /// The corners of the zones' bounding box.
    origin: Vec2,
    end: Vec2,
    cell: f32,
    columns: usize,
    rows: usize,
    /// Cell `c`'s zones are `members[starts[c]..starts[c + 1]]`.
    starts: Vec<u32>,
    members: Vec<u32>,
    /// The zones that can be nearest to a point of cell `c` (ascending), likewise.
    near_starts: Vec<u32>,
    near_members: Vec<u32>,
}

impl ZoneGrid {
    /// Buckets `zones`: about one cell per zone, square cells.
    pub(crate) fn new(zones: &[Zone]) -> ZoneGrid {
        let (lo, hi) = zones.iter().fold((Vec2::splat(f32::MAX), Vec2::splat(f32::MIN)), |(lo, hi), z| {
            (lo.min(z.rect.min()), hi.max(z.rect.max()))
        });
        let extent = (hi - lo).max(Vec2::ZERO);
        let n = zones.len().max(1) as f32;
        // Cells of the area's share per zone, but never more than `n` along a side, so a
        // long flat map has at most about 3n cells.
        let cell = (extent.x * extent.y / n).sqrt().max(extent.max_element() / n);
        let cell = if cell.is_finite() && cell > 0.0 { cell } else { 1.0 };
        let count = |length: f32| ((length / cell).ceil() as usize).max(1);
        let (columns, rows) = (count(extent.x), count(extent.y));
        let mut grid = ZoneGrid {
            origin: lo,
            end: hi,
            cell,
            columns,
            rows,
            starts: Vec::new(),
            members: Vec::new(),
            near_starts: vec![0],
            near_members: Vec::new(),
        };
        let mut cells = vec![Vec::new(); columns * rows];
        for (i, zone) in zones.iter().enumerate() {
            let ((c0, r0), (c1, r1)) = (grid.cell_of(zone.rect.min()), grid.cell_of(zone.rect.max()));
            for row in r0..=r1 {
                for column in c0..=c1 {
                    cells[row * columns + column].push(i as u32);
                }
            }
        }
        grid.starts.push(0);
        for cell in cells {
            grid.members.extend(cell);
            grid.starts.push(grid.members.len() as u32);
        }
        for row in 0..rows {
            for column in 0..columns {
                let near = grid.nearest_candidates(zones, column, row);
                grid.near_members.extend(near);
                grid.near_starts.push(grid.near_members.len() as u32);
            }
        }
        grid
    }

    /// The zones that may be nearest to some point of a cell: every zone whose box comes
    /// as close to the cell as the farthest point of the cell is from the best zone. A zone
    /// left out is farther than that zone from every point of the cell.
    fn nearest_candidates(&self, zones: &[Zone], column: usize, row: usize) -> Vec<u32> {
        // A point rounds into a cell from a hair outside it: grow the cell by that hair.
        let slack = self.cell * 1e-3;
        let min = self.origin + Vec2::new(column as f32, row as f32) * self.cell - slack;
        let max = min + Vec2::splat(self.cell + 2.0 * slack);
        let corners = [min, max, Vec2::new(min.x, max.y), Vec2::new(max.x, min.y)];
        let farthest = |z: &Zone| corners.iter().map(|&c| z.rect.distance(c)).fold(0.0, f32::max);
        let closest = |z: &Zone| {
            let gap = (z.rect.min() - max).max(min - z.rect.max()).max(Vec2::ZERO);
            gap.length()
        };
        let bound = zones.iter().map(farthest).fold(f32::INFINITY, f32::min);
        let bound = bound + slack + bound * 1e-4;
        (0..zones.len()).filter(|&i| closest(&zones[i]) <= bound).map(|i| i as u32).collect()
    }

    /// The zone nearest to `p` (0 inside), the lowest index on ties; zone 0 when there are
    /// none.
    pub(crate) fn nearest(&self, zones: &[Zone], p: Vec2) -> ZoneIdx {
        let dist = |i: &usize| zones[*i].rect.distance(p);
        let nearest = |candidates: &mut dyn Iterator<Item = usize>| {
            candidates.min_by(|a, b| dist(a).total_cmp(&dist(b))).unwrap_or(0)
        };
        let (lo, hi) = (self.origin, self.end);
        if lo.x <= p.x && p.x <= hi.x && lo.y <= p.y && p.y <= hi.y {
            let (column, row) = self.cell_of(p);
            let cell = row * self.columns + column;
            let near =
                &self.near_members[self.near_starts[cell] as usize..self.near_starts[cell + 1] as usize];
            nearest(&mut near.iter().map(|&i| i as usize))
        } else {
            nearest(&mut (0..zones.len()))
        }
    }

    /// The cell whose area holds `p`, clamped to the grid; monotonic in each coordinate,
    /// so a box's corners bound the cells of every point inside it.
    fn cell_of(&self, p: Vec2) -> (usize, usize) {
        let at = |v: f32, o: f32, n: usize| (((v - o) / self.cell).max(0.0) as usize).min(n - 1);
        (at(p.x, self.origin.x, self.columns), at(p.y, self.origin.y, self.rows))
    }

    /// The zones that may contain `p`, ascending; empty for a point off the grid.
    fn candidates(&self, p: Vec2) -> &[u32] {
        let (lo, hi) = (self.origin, self.end);
        // Written so that NaN is off the grid too.
        if !(lo.x <= p.x && p.x <= hi.x && lo.y <= p.y && p.y <= hi.y) {
            return &[];
        }
        let (column, row) = self.cell_of(p);
        let cell = row * self.columns + column;
        &self.members[self.starts[cell] as usize..self.starts[cell + 1] as usize]
    }

    /// The first zone and the first room, in file order, whose box contains `p`: one pass
    /// for both, which a moving robot needs every tick.
    pub(crate) fn first_zone_and_room(&self, zones: &[Zone], p: Vec2) -> (Option<ZoneIdx>, Option<ZoneIdx>) {
        let mut containing =
            self.candidates(p).iter().map(|&i| i as usize).filter(|&i| zones[i].rect.contains(p));
        let Some(zone) = containing.next() else { return (None, None) };
        let room = if is_room(&zones[zone]) { Some(zone) } else { containing.find(|&i| is_room(&zones[i])) };
        (Some(zone), room)
    }

    /// The first zone, in file order, of those `wanted` accepts whose box contains `p`.
    pub(crate) fn first(&self, zones: &[Zone], p: Vec2, wanted: impl Fn(&Zone) -> bool) -> Option<ZoneIdx> {
        let contains = |z: &Zone| wanted(z) && Rect::contains(&z.rect, p);
        self.candidates(p).iter().map(|&i| i as usize).find(|&i| contains(&zones[i]))
    }
}

/// Whether a zone is a room, for [`ZoneGrid::first`].
pub(crate) fn is_room(zone: &Zone) -> bool {
    zone.kind == ZoneKind::Room
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::SeededRng;

    fn zone(i: usize, centre: Vec2, size: Vec2, kind: ZoneKind) -> Zone {
        let rect = Rect::new(centre, size);
        Zone { name: format!("Z{i}"), kind, rect, doors: vec![], neighbours: vec![], blocks: vec![] }
    }

    /// Overlapping boxes of every size, some touching, some flat, as a file may give them.
    fn scattered(rng: &mut SeededRng, n: usize) -> Vec<Zone> {
        (0..n)
            .map(|i| {
                let at = |rng: &mut SeededRng| (rng.below(400) as f32) / 4.0;
                let size = |rng: &mut SeededRng| (rng.below(120) as f32) / 4.0;
                let kind = if rng.below(2) == 0 { ZoneKind::Room } else { ZoneKind::Corridor };
                zone(i, Vec2::new(at(rng), at(rng)), Vec2::new(size(rng), size(rng)), kind)
            })
            .collect()
    }

    #[test]
    fn the_grid_finds_what_a_scan_in_file_order_finds() {
        let mut rng = SeededRng::new(7);
        for n in [1, 2, 5, 40, 300] {
            let zones = scattered(&mut rng, n);
            let grid = ZoneGrid::new(&zones);
            assert!(grid.columns * grid.rows <= 3 * n + 1, "{n} zones, {} cells", grid.columns * grid.rows);
            let mut points: Vec<Vec2> = (0..2000)
                .map(|_| Vec2::new(rng.below(440) as f32 / 4.0 - 5.0, rng.below(440) as f32 / 4.0 - 5.0))
                .collect();
            // Every corner and centre: the edges are where half-open containment bites.
            points.extend(zones.iter().flat_map(|z| [z.rect.min(), z.rect.max(), z.rect.centre]));
            points.push(Vec2::NAN);
            for p in points {
                let scan = zones.iter().position(|z| z.rect.contains(p));
                assert_eq!(grid.first(&zones, p, |_| true), scan, "{n} zones, point {p}");
                let room_scan = zones.iter().position(|z| is_room(z) && z.rect.contains(p));
                assert_eq!(grid.first(&zones, p, is_room), room_scan, "{n} zones, room at {p}");
                assert_eq!(grid.first_zone_and_room(&zones, p), (scan, room_scan), "{n} zones, both at {p}");
            }
        }
    }

    #[test]
    fn the_grid_finds_the_nearest_zone_a_scan_finds() {
        let mut rng = SeededRng::new(11);
        for n in [1, 2, 5, 40, 300] {
            let zones = scattered(&mut rng, n);
            let grid = ZoneGrid::new(&zones);
            let mut points: Vec<Vec2> = (0..3000)
                .map(|_| Vec2::new(rng.below(4400) as f32 / 40.0 - 5.0, rng.below(4400) as f32 / 40.0 - 5.0))
                .collect();
            // Where two zones are equally near: midpoints between corners, and the corners.
            points.extend(zones.windows(2).map(|w| (w[0].rect.max() + w[1].rect.min()) / 2.0));
            points.extend(zones.iter().flat_map(|z| [z.rect.min(), z.rect.max()]));
            let candidates = grid.near_members.len() as f32 / (grid.columns * grid.rows) as f32;
            for p in points {
                let dist = |i: &usize| zones[*i].rect.distance(p);
                let scan = (0..zones.len()).min_by(|a, b| dist(a).total_cmp(&dist(b))).unwrap_or(0);
                assert_eq!(grid.nearest(&zones, p), scan, "{n} zones, point {p}");
            }
            assert!(n < 40 || candidates < n as f32 / 4.0, "{n} zones: {candidates} candidates a cell");
        }
    }

    #[test]
    fn a_map_of_flat_or_coincident_boxes_still_locates() {
        let zones = vec![
            zone(0, Vec2::new(5.0, 5.0), Vec2::new(0.0, 10.0), ZoneKind::Corridor),
            zone(1, Vec2::new(5.0, 5.0), Vec2::new(10.0, 10.0), ZoneKind::Room),
            zone(2, Vec2::new(5.0, 5.0), Vec2::new(10.0, 10.0), ZoneKind::Corridor),
        ];
        let grid = ZoneGrid::new(&zones);
        assert_eq!(grid.first(&zones, Vec2::new(5.0, 5.0), |_| true), Some(1));
        assert_eq!(grid.first(&zones, Vec2::new(5.0, 5.0), |z| z.kind == ZoneKind::Corridor), Some(2));
        assert_eq!(grid.first(&zones, Vec2::new(10.0, 5.0), |_| true), None);
        assert!(grid.columns * grid.rows <= 3 * zones.len() + 1);
    }
}
