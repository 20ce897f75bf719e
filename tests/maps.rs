use bw4t_map::{Colour, Map, ZoneKind, spot_is_clear};

use crate::util::shipped_map;

#[test]
fn the_default_map_has_the_spec_layout() {
    let map = shipped_map("default");
    let names: Vec<&str> = map.zones().iter().map(|z| z.name.as_str()).collect();
    for row in ["A", "B", "C"] {
        for col in 1..=3 {
            for prefix in ["Room", "Front"] {
                assert!(names.contains(&format!("{prefix}{row}{col}").as_str()), "{prefix}{row}{col}");
            }
        }
    }
    for side in ["LeftHall", "RightHall"] {
        for row in ["A", "B", "C", "D"] {
            assert!(names.contains(&format!("{side}{row}").as_str()));
        }
    }
    assert!(names.contains(&"FrontDropZone") && names.contains(&"DropZone"));
    assert_eq!(map.area().to_array(), [50.0, 80.0]);
    let rooms = map.zones().iter().filter(|z| z.kind == ZoneKind::Room).count();
    assert_eq!(rooms, 10);
    let front_dz = &map.zones()[map.zone_named("FrontDropZone").expect("FrontDropZone")].rect;
    let near = map.spawns().iter().filter(|s| front_dz.distance(s.pos) <= 10.0).count();
    assert!(near >= 10, "only {near} spawn points in and around FrontDropZone");
}

#[test]
fn default_content_is_six_colours_and_twenty_eight_blocks_from_the_seed() {
    let map = shipped_map("default");
    for seed in 0..50 {
        let content = map.content(seed).expect("content");
        assert_eq!(content.sequence.len(), 6);
        assert_eq!(content.blocks.len(), 28);
        // Every sequence colour has a block, so the map stays solvable.
        for colour in &content.sequence {
            let needed = content.sequence.iter().filter(|c| *c == colour).count();
            let have = content.blocks.iter().filter(|b| b.colour == *colour).count();
            assert!(have >= needed, "seed {seed}: {colour} needed {needed}, have {have}");
        }
        for (idx, zone) in map.zones().iter().enumerate() {
            let here: Vec<_> = content.blocks.iter().filter(|b| b.zone == idx).collect();
            assert!(here.len() <= 10);
            if idx == map.drop_zone() {
                assert!(here.is_empty());
            }
            for (i, b) in here.iter().enumerate() {
                assert_eq!(zone.kind, ZoneKind::Room);
                let others: Vec<_> = here[..i].iter().map(|o| o.pos).collect();
                assert!(spot_is_clear(b.pos, &others), "seed {seed}: blocks too close in {}", zone.name);
                assert!(zone.rect.shrunk(0.5).contains(b.pos) || zone.rect.shrunk(0.5).max() == b.pos);
            }
        }
    }
    assert_eq!(map.content(3), map.content(3));
    assert_ne!(map.content(3), map.content(4));
}

#[test]
fn a_fixed_map_seed_overrides_the_match_seed() {
    let text = std::fs::read_to_string(format!("{}/maps/default.toml", repo_root!())).expect("read");
    let map =
        Map::from_native(&text.replace("random_blocks = 22", "random_blocks = 22\nseed = 5")).expect("map");
    assert_eq!(map.content(1), map.content(2));
}

#[test]
fn the_fixed_map_has_its_fixed_content() {
    let map = shipped_map("fixed");
    let content = map.content(9).expect("content");
    assert_eq!(content.sequence[..2], [Colour::Yellow, Colour::Red]);
    assert_eq!(content.blocks.len(), 17);
}

#[test]
fn every_shipped_map_loads_and_writes_back_unchanged() {
    let dir = format!("{}/maps", repo_root!());
    let mut count = 0;
    for entry in std::fs::read_dir(&dir).expect("maps dir") {
        let path = entry.expect("entry").path();
        if path.extension().is_some_and(|e| e == "toml") {
            let map = Map::from_native(&std::fs::read_to_string(&path).expect("read"))
                .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            assert_eq!(Map::from_native(&map.to_native()).expect("reread"), map);
            count += 1;
        }
    }
    assert!(count >= 2);
}
