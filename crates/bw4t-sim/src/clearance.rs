//! Open ground: a grid marking every cell an obstacle (wall or guard) comes near, so a
//! move whose swept box touches no marked cell is known to meet nothing without a query.

use bw4t_map::Vec2;

/// Side of a cell, in map units (half a robot).
const CELL: f32 = 1.0;

/// Cells near any obstacle over the obstacles' bounding box; everything outside is open.
#[derive(Clone, Debug, Default)]
pub(crate) struct Clearance {
    origin: Vec2,
    columns: usize,
    rows: usize,
    /// The marked cells (those an obstacle grown by the margin reaches) above and left of
    /// each grid corner, row-major over `(columns + 1) x (rows + 1)` corners: any box's
    /// count is then four lookups.
    marked_before: Vec<u32>,
}

impl Clearance {
    /// Marks the cells that boxes `(centre, half extents)`, each grown by `margin`, reach.
    pub(crate) fn new(obstacles: &[(Vec2, Vec2)], margin: f32) -> Clearance {
        let grown: Vec<(Vec2, Vec2)> = obstacles
            .iter()
            .map(|&(centre, half)| (centre - half - margin, centre + half + margin))
            .collect();
        let Some(lo) = grown.iter().map(|g| g.0).reduce(Vec2::min) else { return Clearance::default() };
        let hi = grown.iter().map(|g| g.1).fold(lo, Vec2::max);
        let span = ((hi - lo) / CELL).floor();
        let mut clearance = Clearance {
            origin: lo,
            columns: span.x as usize + 1,
            rows: span.y as usize + 1,
            marked_before: Vec::new(),
        };
        let columns = clearance.columns;
        let mut near = vec![false; columns * clearance.rows];
        for (min, max) in grown {
            let ((c0, r0), (c1, r1)) = (clearance.cell(min), clearance.cell(max));
            for row in r0..=r1 {
                near[row * columns..][c0..=c1].fill(true);
            }
        }
        let mut sums = vec![0u32; (columns + 1) * (clearance.rows + 1)];
        for row in 0..clearance.rows {
            for column in 0..columns {
                let at = (row + 1) * (columns + 1) + column + 1;
                sums[at] = u32::from(near[row * columns + column]) + sums[at - 1] + sums[at - columns - 1]
                    - sums[at - columns - 2];
            }
        }
        clearance.marked_before = sums;
        clearance
    }

    /// The cell of `p`, clamped to the grid. Monotonic in each coordinate, so the cells of
    /// a box's corners bound the cells of every point inside it.
    fn cell(&self, p: Vec2) -> (usize, usize) {
        let at = |v: f32, o: f32, n: usize| (((v - o) / CELL).floor().max(0.0) as usize).min(n - 1);
        (at(p.x, self.origin.x, self.columns), at(p.y, self.origin.y, self.rows))
    }

    /// Whether the box from `min` to `max` keeps more than the margin from every obstacle.
    pub(crate) fn is_open(&self, min: Vec2, max: Vec2) -> bool {
        if self.marked_before.is_empty() {
            return true;
        }
        let end = self.origin + Vec2::new(self.columns as f32, self.rows as f32) * CELL;
        // Wholly beside the grid: nothing is there. (Written so that NaN is never open.)
        let beside = max.x < self.origin.x || max.y < self.origin.y || min.x > end.x || min.y > end.y;
        if beside {
            return true;
        }
        if !(min.is_finite() && max.is_finite()) {
            return false;
        }
        let ((c0, r0), (c1, r1)) = (self.cell(min), self.cell(max));
        let before = |column: usize, row: usize| self.marked_before[row * (self.columns + 1) + column];
        before(c1 + 1, r1 + 1) + before(c0, r0) == before(c0, r1 + 1) + before(c1 + 1, r0)
    }
}

#[cfg(test)]
mod tests {
    use super::Clearance;
    use bw4t_map::{SeededRng, Vec2};

    /// Whether two closed boxes, the first grown by `margin`, overlap.
    fn overlaps(a: (Vec2, Vec2), margin: f32, b: (Vec2, Vec2)) -> bool {
        let (a_min, a_max) = (a.0 - a.1 - margin, a.0 + a.1 + margin);
        a_min.x <= b.1.x && b.0.x <= a_max.x && a_min.y <= b.1.y && b.0.y <= a_max.y
    }

    #[test]
    fn a_box_is_open_only_when_it_keeps_the_margin_from_every_obstacle() {
        let mut rng = SeededRng::new(3);
        let coordinate = |rng: &mut SeededRng| rng.below(4000) as f32 / 100.0 - 5.0;
        for round in 0..50 {
            let obstacles: Vec<(Vec2, Vec2)> = (0..1 + round % 7)
                .map(|_| {
                    let half = Vec2::new(rng.below(300) as f32 / 100.0, rng.below(300) as f32 / 100.0);
                    (Vec2::new(coordinate(&mut rng), coordinate(&mut rng)), half)
                })
                .collect();
            let clearance = Clearance::new(&obstacles, 0.1);
            let (mut open, mut near) = (0, 0);
            for _ in 0..400 {
                let min = Vec2::new(coordinate(&mut rng), coordinate(&mut rng));
                let max = min + Vec2::new(rng.below(300) as f32 / 100.0, rng.below(300) as f32 / 100.0);
                let touches = obstacles.iter().any(|&o| overlaps(o, 0.1, (min, max)));
                if clearance.is_open(min, max) {
                    assert!(!touches, "round {round}: {min}..{max} is open but near {obstacles:?}");
                    open += 1;
                } else {
                    near += 1;
                }
            }
            assert!(open > 0 && near > 0, "round {round}: {open} open, {near} near");
        }
    }

    #[test]
    fn no_obstacles_leave_everything_open_but_nan() {
        let clearance = Clearance::new(&[], 0.1);
        assert!(clearance.is_open(Vec2::ZERO, Vec2::ONE));
        let one = Clearance::new(&[(Vec2::ZERO, Vec2::ONE)], 0.1);
        assert!(!one.is_open(Vec2::NAN, Vec2::NAN));
        assert!(!one.is_open(Vec2::splat(0.5), Vec2::splat(0.6)));
        assert!(one.is_open(Vec2::splat(2.0), Vec2::splat(3.0)));
    }
}
