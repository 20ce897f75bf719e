//! Bounds on what a map may ask for, checked before anything is built from it, so that a
//! hostile file costs no more than its own size: the readers refuse numbers out of range,
//! and [`limit_problems`] (the first of the map's rules, see `rules.rs`) refuses too many
//! zones or spawn points and more random blocks than the rooms hold.

use crate::geometry::Vec2;
use crate::parts::{DROP_ZONE, MapParts, ZoneKind};
use crate::problem::{Problem, zone_place};

/// No room ever holds more blocks than this (random blocks go elsewhere).
pub const MAX_BLOCKS_PER_ROOM: usize = 10;

/// Largest coordinate or size, in map units, of either sign: far beyond any playable map
/// (the original ones are 50 x 80), and small enough for `f32` positions to stay precise
/// to a thousandth of a unit.
pub const MAX_COORDINATE: f32 = 10_000.0;

/// Most zones in a map: the simulation keeps a route for every pair of zones.
pub const MAX_ZONES: usize = 4096;

/// Most spawn points in a map.
pub const MAX_SPAWNS: usize = 1024;

/// Longest map file read, in bytes (a 40 x 40 generated map takes about 0.5 MB).
pub const MAX_MAP_BYTES: u64 = 16 << 20;

/// What is wrong with `value` as a coordinate or size read from a map file, if anything.
/// Sizes that are not positive are left to the checks, which say so.
pub fn coordinate_problem(value: f64) -> Option<String> {
    let max = MAX_COORDINATE;
    if value.is_nan() {
        Some(format!("NaN is not a number (coordinates and sizes must be from -{max} to {max})"))
    } else if value.abs() > f64::from(max) {
        Some(format!("{} is out of range (coordinates and sizes must be from -{max} to {max})", short(value)))
    } else {
        None
    }
}

/// Whether both of `v`'s numbers are within [`MAX_COORDINATE`] (NaN is not).
pub(crate) fn in_range(v: Vec2) -> bool {
    v.x.abs() <= MAX_COORDINATE && v.y.abs() <= MAX_COORDINATE
}

/// A number as a person would write it: `1e300` rather than three hundred digits.
fn short(value: f64) -> String {
    if value.is_finite() && value.abs() < 1e9 { format!("{value}") } else { format!("{value:e}") }
}

/// Whether `parts` has at most [`MAX_ZONES`] zones and [`MAX_SPAWNS`] spawn points. Past
/// either, checks other than the limits are skipped: they may be costly with the counts.
pub(crate) fn within_counts(parts: &MapParts) -> bool {
    parts.zones.len() <= MAX_ZONES && parts.spawns.len() <= MAX_SPAWNS
}

/// The limits `parts` exceeds, as errors; empty when within every one.
pub(crate) fn limit_problems(parts: &MapParts) -> Vec<Problem> {
    let mut out = Vec::new();
    if parts.zones.len() > MAX_ZONES {
        out.push(Problem::error(
            "map",
            format!("{} zones, at most {MAX_ZONES} are allowed", parts.zones.len()),
        ));
    }
    if parts.spawns.len() > MAX_SPAWNS {
        let n = parts.spawns.len();
        out.push(Problem::error("spawn points", format!("{n}, at most {MAX_SPAWNS} are allowed")));
    }
    let mut range = |place: &str, what: &str, v: Vec2, axes: [&str; 2]| {
        for (axis, x) in axes.into_iter().zip([v.x, v.y]) {
            if let Some(problem) = coordinate_problem(f64::from(x)) {
                out.push(Problem::error(place, format!("{what}{axis}: {problem}")));
            }
        }
    };
    let (point, size) = (["x", "y"], ["width", "height"]);
    range("area", "", parts.area, size);
    for (i, zone) in parts.zones.iter().enumerate() {
        let place = zone_place(i, zone);
        range(&place, "centre ", zone.rect.centre, point);
        range(&place, "size ", zone.rect.size, size);
        for (d, door) in zone.doors.iter().enumerate() {
            range(&place, &format!("door {} ", d + 1), door.centre, point);
        }
    }
    for (i, spawn) in parts.spawns.iter().enumerate() {
        range(&format!("spawn {} '{}'", i + 1, spawn.name), "at ", spawn.pos, point);
    }
    out.extend(random_space_problem(parts));
    out
}

/// Whether the rooms have space for the random blocks: they go to rooms other than the
/// drop zone with fewer than [`MAX_BLOCKS_PER_ROOM`] blocks. This bounds the random content
/// a match draws by the size of the file.
fn random_space_problem(parts: &MapParts) -> Option<Problem> {
    let need = u64::from(parts.random_sequence) + u64::from(parts.random_blocks);
    if need == 0 {
        return None;
    }
    let space: usize = parts
        .zones
        .iter()
        .filter(|z| z.kind == ZoneKind::Room && z.name != DROP_ZONE)
        .map(|z| MAX_BLOCKS_PER_ROOM.saturating_sub(z.blocks.len()))
        .sum();
    (need > space as u64).then(|| {
        Problem::error(
            "random content",
            format!("{need} random blocks, but the rooms (other than the drop zone) have space for {space}"),
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_out_of_range_say_so_with_the_range() {
        assert_eq!(coordinate_problem(10_000.0), None);
        assert_eq!(coordinate_problem(-10_000.0), None);
        assert_eq!(
            coordinate_problem(1e300).as_deref(),
            Some("1e300 is out of range (coordinates and sizes must be from -10000 to 10000)")
        );
        assert!(coordinate_problem(-20_000.5).is_some_and(|m| m.starts_with("-20000.5 is out of range")));
        assert!(coordinate_problem(f64::INFINITY).is_some_and(|m| m.starts_with("inf is out of range")));
        assert!(coordinate_problem(f64::NAN).is_some_and(|m| m.starts_with("NaN is not a number")));
    }
}
