//! Axis-aligned boxes and doors in map units (y grows downwards, as in BW4T).

pub use glam::Vec2;

/// The side of a robot's square, in map units: every robot is 2 x 2.
pub const ROBOT_SIZE: f32 = 2.0;

/// An axis-aligned box, given by its centre and size as in map files.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rect {
    /// Centre point.
    pub centre: Vec2,
    /// Width and height.
    pub size: Vec2,
}

impl Rect {
    /// The box with this centre and size.
    pub fn new(centre: Vec2, size: Vec2) -> Self {
        Self { centre, size }
    }

    /// The corner with the smallest coordinates.
    pub fn min(&self) -> Vec2 {
        self.centre - self.size / 2.0
    }

    /// The corner with the largest coordinates.
    pub fn max(&self) -> Vec2 {
        self.centre + self.size / 2.0
    }

    /// Half-open containment (`min <= p < max` on both axes), so that a point on a shared
    /// edge belongs to exactly one of two touching boxes.
    pub fn contains(&self, p: Vec2) -> bool {
        let (min, max) = (self.min(), self.max());
        min.x <= p.x && p.x < max.x && min.y <= p.y && p.y < max.y
    }

    /// The same box shrunk by `margin` on every side (never below a point at the centre).
    pub fn shrunk(&self, margin: f32) -> Rect {
        Rect::new(self.centre, (self.size - Vec2::splat(2.0 * margin)).max(Vec2::ZERO))
    }

    /// The point of the box nearest to `p` (`p` itself when inside).
    pub fn clamp(&self, p: Vec2) -> Vec2 {
        p.clamp(self.min(), self.max())
    }

    /// Euclidean distance from `p` to the box (0 inside).
    pub fn distance(&self, p: Vec2) -> f32 {
        self.clamp(p).distance(p)
    }

    /// Whether the two boxes share interior area.
    pub fn overlaps(&self, other: &Rect) -> bool {
        let (a0, a1, b0, b1) = (self.min(), self.max(), other.min(), other.max());
        a0.x < b1.x && b0.x < a1.x && a0.y < b1.y && b0.y < a1.y
    }
}

/// Which way a door lies: a horizontal door is 4 x 1 on a top or bottom edge, a vertical
/// one 1 x 4 on a left or right edge.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Orientation {
    /// On a top or bottom edge; robots pass through it vertically.
    Horizontal,
    /// On a left or right edge; robots pass through it horizontally.
    Vertical,
}

/// A door in a room's wall.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Door {
    /// Centre of the door; it lies on the room's boundary.
    pub centre: Vec2,
    /// Which edges it can lie on.
    pub orientation: Orientation,
}

impl Door {
    /// Length of the opening along the wall.
    pub const WIDTH: f32 = 4.0;
    /// Thickness of the door box across the wall.
    pub const DEPTH: f32 = 1.0;

    /// The 4 x 1 (or 1 x 4) box of the door.
    pub fn rect(&self) -> Rect {
        let size = match self.orientation {
            Orientation::Horizontal => Vec2::new(Self::WIDTH, Self::DEPTH),
            Orientation::Vertical => Vec2::new(Self::DEPTH, Self::WIDTH),
        };
        Rect::new(self.centre, size)
    }

    /// The unit vector pointing from the door into `room`.
    pub fn inward(&self, room: &Rect) -> Vec2 {
        match self.orientation {
            Orientation::Horizontal if self.centre.y < room.centre.y => Vec2::Y,
            Orientation::Horizontal => Vec2::NEG_Y,
            Orientation::Vertical if self.centre.x < room.centre.x => Vec2::X,
            Orientation::Vertical => Vec2::NEG_X,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn containment_is_half_open() {
        let r = Rect::new(Vec2::new(15.0, 15.0), Vec2::new(10.0, 10.0));
        assert!(r.contains(Vec2::new(10.0, 10.0)));
        assert!(!r.contains(Vec2::new(20.0, 15.0)));
        assert!(!r.contains(Vec2::new(15.0, 20.0)));
        assert!(r.contains(Vec2::new(19.99, 19.99)));
    }

    #[test]
    fn door_points_into_its_room() {
        let room = Rect::new(Vec2::new(15.0, 15.0), Vec2::new(10.0, 10.0));
        let top = Door { centre: Vec2::new(15.0, 10.0), orientation: Orientation::Horizontal };
        let right = Door { centre: Vec2::new(20.0, 15.0), orientation: Orientation::Vertical };
        assert_eq!(top.inward(&room), Vec2::Y);
        assert_eq!(right.inward(&room), Vec2::NEG_X);
        assert_eq!(right.rect().size, Vec2::new(1.0, 4.0));
    }
}
