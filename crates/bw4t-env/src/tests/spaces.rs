//! The spaces' tables in code and in the crate docs agree.

use super::default_map;
use crate::{ACTION_SEGMENTS, Dims, EnvConfig, OBS_SEGMENTS, STATE_SEGMENTS, Spaces};

const DOCS: &str = include_str!("../lib.rs");

/// The rows of the doc table whose header starts with `header`, as cells.
fn doc_table(header: &str) -> Vec<Vec<String>> {
    let lines: Vec<&str> = DOCS.lines().map(|l| l.trim_start_matches("//!").trim()).collect();
    let start = lines.iter().position(|l| l.starts_with(header)).expect("the table") + 2;
    lines[start..]
        .iter()
        .take_while(|l| l.starts_with('|'))
        .map(|l| {
            let mut cells: Vec<String> =
                l.trim_matches('|').split(" | ").map(|c| c.trim().to_string()).collect();
            cells[0] = cells[0].trim_matches('`').to_string();
            cells
        })
        .collect()
}

fn default_spaces() -> Spaces {
    let config = EnvConfig::parallel(default_map(), 3);
    Spaces::new(Dims::of(&config.setup.map, config.slots))
}

#[test]
fn the_docs_tables_are_the_code_tables() {
    let obs = doc_table("| segment | size | holds |");
    let rows: Vec<Vec<String>> = OBS_SEGMENTS
        .iter()
        .map(|r| vec![r.name.to_string(), r.size.formula(), r.meaning.to_string()])
        .collect();
    assert_eq!(obs, rows);
    let actions = doc_table("| segment | size | does | allowed when |");
    let rows: Vec<Vec<String>> = ACTION_SEGMENTS
        .iter()
        .map(|r| vec![r.name.to_string(), r.size.formula(), r.meaning.to_string()])
        .collect();
    let documented: Vec<Vec<String>> = actions.iter().map(|r| r[..3].to_vec()).collect();
    assert_eq!(documented, rows);
    let state = doc_table("| state segment | size | holds |");
    let rows: Vec<Vec<String>> = STATE_SEGMENTS
        .iter()
        .map(|r| vec![r.name.to_string(), r.size.formula(), r.meaning.to_string()])
        .collect();
    assert_eq!(state, rows);
}

#[test]
fn the_default_maps_offsets_are_as_documented() {
    let spaces = default_spaces();
    let documented = doc_table("| segment | offset | size |");
    let laid_out: Vec<Vec<String>> = spaces
        .obs_layout()
        .iter()
        .map(|s| vec![s.name.to_string(), s.offset.to_string(), s.len.to_string()])
        .collect();
    assert_eq!(documented, laid_out);
    let flat = DOCS.lines().map(|l| l.trim_start_matches("//!").trim()).collect::<Vec<_>>().join(" ");
    assert!(flat.contains(&format!("the observation is {} long", spaces.obs_len())));
    let starts: Vec<String> =
        spaces.action_layout().iter().map(|s| format!("`{}` {}", s.name, s.offset)).collect();
    let sentence = format!("{} actions ({})", spaces.n_actions(), starts.join(", "));
    assert!(flat.contains(&sentence), "the docs should say: {sentence}");
    let d = spaces.dims;
    let dims = format!("P = {}, R = {}, K = {}, L = {}", d.places, d.rooms, d.slots, d.sequence);
    assert!(DOCS.contains(&dims), "{dims}");
    assert!(DOCS.contains(&format!("`M` = {} kinds", d.kinds)));
}

#[test]
fn segments_tile_the_vectors() {
    let spaces = default_spaces();
    for layout in [spaces.obs_layout(), spaces.action_layout()] {
        let mut next = 0;
        for s in layout {
            assert_eq!(s.offset, next, "{}", s.name);
            next += s.len;
        }
    }
    assert_eq!(spaces.obs_len(), 251);
    assert_eq!(spaces.n_actions(), 70);
    assert_eq!(spaces.action_at(0), Some(("wait", 0)));
    assert_eq!(spaces.action_at(69), Some(("say_going_to", 9)));
    assert_eq!(spaces.action_at(70), None);
}
