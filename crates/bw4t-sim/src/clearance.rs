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
    /// Bit `c % 64` of word `row * words_per_row + c / 64` is set when an obstacle, grown by
    /// the margin, reaches into cell `(c, row)`: a bit a cell keeps the table of a whole map
    /// within a few cache lines, shared by every robot of the match.
    near: Vec<u64>,
    words_per_row: usize,
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
        let (columns, rows) = (span.x as usize + 1, span.y as usize + 1);
        let words_per_row = columns.div_ceil(64);
        let mut clearance =
            Clearance { origin: lo, columns, rows, near: vec![0; words_per_row * rows], words_per_row };
        for (min, max) in grown {
            let ((c0, r0), (c1, r1)) = (clearance.cell(min), clearance.cell(max));
            for row in r0..=r1 {
                for column in c0..=c1 {
                    clearance.near[row * words_per_row + column / 64] |= 1 << (column % 64);
                }
            }
        }
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
        if self.near.is_empty() {
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
        // The bits of columns c0..=c1 within each 64-column word.
        let words = c0 / 64..=c1 / 64;
        let mask = |word: usize| {
            let (first, last) = (c0.max(word * 64) - word * 64, c1.min(word * 64 + 63) - word * 64);
            (u64::MAX >> (63 - last)) & (u64::MAX << first)
        };
        (r0..=r1).all(|row| words.clone().all(|w| self.near[row * self.words_per_row + w] & mask(w) == 0))
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
        // Over 64 cells across, so rows take more than one word, and boxes wider than a word.
        let coordinate = |rng: &mut SeededRng| rng.below(20_000) as f32 / 100.0 - 5.0;
        let extent = |rng: &mut SeededRng| {
            let most = if rng.below(10) == 0 { 15_000 } else { 300 };
            rng.below(most) as f32 / 100.0
        };
        let (mut open, mut near) = (0, 0);
        for round in 0..200 {
            let obstacles: Vec<(Vec2, Vec2)> = (0..1 + round % 40)
                .map(|_| {
                    let half = Vec2::new(extent(&mut rng), extent(&mut rng)) / 2.0;
                    (Vec2::new(coordinate(&mut rng), coordinate(&mut rng)), half)
                })
                .collect();
            let clearance = Clearance::new(&obstacles, 0.1);
            for _ in 0..400 {
                let min = Vec2::new(coordinate(&mut rng), coordinate(&mut rng));
                let max = min + Vec2::new(extent(&mut rng), extent(&mut rng));
                let touches = obstacles.iter().any(|&o| overlaps(o, 0.1, (min, max)));
                if clearance.is_open(min, max) {
                    assert!(!touches, "round {round}: {min}..{max} is open but near {obstacles:?}");
                    open += 1;
                } else {
                    near += 1;
                }
            }
        }
        assert!(open > 10_000 && near > 2_000, "{open} open, {near} near");
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
