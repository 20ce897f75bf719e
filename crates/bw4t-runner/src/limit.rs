//! The default tick limit of a match: it follows the map, so that one robot can finish on a
//! large map, and never falls below the customary 20,000 ticks on small ones.
//!
//! The estimate is of one robot's work, not of a team's: more robots only finish sooner,
//! and a team whose other members crash must still be able to finish with one.

use bw4t_map::{Map, Vec2, ZoneKind};
use bw4t_sim::MatchConfig;
use serde::Serialize;

/// The limit on small maps, and the least the derived one can be: 1000 simulated seconds at
/// the default 20 ticks per second.
pub const MIN_DEFAULT_TICKS: u64 = 20_000;
/// The limit is this many times the estimate of one robot's ticks.
const MARGIN: f64 = 2.0;
/// Derived limits are rounded up to a multiple of this, to read well.
const ROUND_TO: u64 = 1_000;

/// The default tick limit of a match on a map, and the estimate it came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct TickLimit {
    /// The last tick.
    pub ticks: u64,
    /// Estimated ticks one robot needs, exploring every room and fetching every sequence
    /// colour from the farthest room.
    pub one_robot_estimate: u64,
}

impl TickLimit {
    /// The default limit for `map` played with `config`:
    /// `max(20000, 2 × (tour + 2 × L × far) / speed)`, rounded up to a multiple of 1000,
    /// where `tour` is a nearest-neighbour tour from the drop zone through every room and
    /// back, `far` the farthest room from the drop zone (both by Manhattan distance between
    /// zone centres), `L` the sequence's length and `speed` the map units a robot travels
    /// per tick.
    pub fn for_map(map: &Map, config: &MatchConfig) -> TickLimit {
        let drop = map.zones()[map.drop_zone()].rect.centre;
        let rooms: Vec<Vec2> = map
            .zones()
            .iter()
            .enumerate()
            .filter(|(i, z)| z.kind == ZoneKind::Room && *i != map.drop_zone())
            .map(|(_, z)| z.rect.centre)
            .collect();
        let far = rooms.iter().map(|&r| manhattan(drop, r)).fold(0.0, f64::max);
        let sequence = map.sequence().len() as f64 + f64::from(map.random_sequence());
        let units = nearest_neighbour_tour(drop, &rooms) + 2.0 * sequence * far;
        let one_robot = units / f64::from(config.speed.max(f32::MIN_POSITIVE));
        let derived = (MARGIN * one_robot).ceil();
        // `as` saturates: an absurd map gets the largest limit, not a wrapped one.
        let rounded = (derived as u64).div_ceil(ROUND_TO).saturating_mul(ROUND_TO);
        TickLimit { ticks: rounded.max(MIN_DEFAULT_TICKS), one_robot_estimate: one_robot.ceil() as u64 }
    }

    /// Says how the limit was found, for summaries: `derived from the map: ...`.
    pub fn explain(&self) -> String {
        if self.ticks == MIN_DEFAULT_TICKS {
            format!(
                "derived from the map: one robot needs about {} ticks here, so the least default, {MIN_DEFAULT_TICKS}",
                self.one_robot_estimate
            )
        } else {
            format!("derived from the map: twice the {} ticks one robot needs", self.one_robot_estimate)
        }
    }
}

fn manhattan(a: Vec2, b: Vec2) -> f64 {
    f64::from((a.x - b.x).abs()) + f64::from((a.y - b.y).abs())
}

/// The length of a tour from `start` through every point, always to the nearest one not
/// yet visited (ties to the earliest), and back to `start`.
fn nearest_neighbour_tour(start: Vec2, points: &[Vec2]) -> f64 {
    let mut visited = vec![false; points.len()];
    let (mut here, mut length) = (start, 0.0);
    for _ in 0..points.len() {
        let next = (0..points.len())
            .filter(|&i| !visited[i])
            .min_by(|&a, &b| manhattan(here, points[a]).total_cmp(&manhattan(here, points[b])));
        let Some(next) = next else { break };
        visited[next] = true;
        length += manhattan(here, points[next]);
        here = points[next];
    }
    length + manhattan(here, start)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shipped(name: &str) -> Map {
        let path = format!("{}/../../maps/{name}.toml", env!("CARGO_MANIFEST_DIR"));
        Map::from_native(&std::fs::read_to_string(path).expect("shipped map")).expect("valid")
    }

    #[test]
    fn small_maps_keep_the_customary_limit() {
        for name in ["default", "fixed", "side-doors", "rooms12", "rooms24", "rooms100"] {
            let limit = TickLimit::for_map(&shipped(name), &MatchConfig::default());
            assert_eq!(limit.ticks, MIN_DEFAULT_TICKS, "{name}: {limit:?}");
            assert!(limit.one_robot_estimate > 0, "{name}");
        }
    }

    #[test]
    fn large_maps_get_more_and_slower_robots_more_still() {
        let map = bw4t_map::generate(40, 26, 1, 1).expect("generated");
        let normal = TickLimit::for_map(&map, &MatchConfig::default());
        assert!(normal.ticks > MIN_DEFAULT_TICKS && normal.ticks.is_multiple_of(ROUND_TO), "{normal:?}");
        assert!(normal.ticks >= 2 * normal.one_robot_estimate, "{normal:?}");
        let slow = TickLimit::for_map(&map, &MatchConfig { speed: 0.25, ..MatchConfig::default() });
        assert!(slow.ticks > normal.ticks, "{slow:?} vs {normal:?}");
    }

    #[test]
    fn a_tour_visits_every_point_and_returns() {
        let points = [Vec2::new(10.0, 0.0), Vec2::new(0.0, 10.0), Vec2::new(10.0, 10.0)];
        assert_eq!(nearest_neighbour_tour(Vec2::ZERO, &points), 40.0);
        assert_eq!(nearest_neighbour_tour(Vec2::ZERO, &[]), 0.0);
    }
}
