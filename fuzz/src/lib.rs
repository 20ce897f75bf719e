//! What the fuzz targets check beyond "does not panic": the properties each reader promises.
//!
//! A failed property panics, which libFuzzer reports as a crash with the input saved.

use bw4t_map::{Map, Severity, check_parts, parse_parts};
use bw4t_protocol::{LineBuffer, MAX_LINE};

/// Which reader a map target drives: the format `Map::parse` and `parse_parts` tell apart.
pub use bw4t_map::MapFormat;

/// The match seeds content is generated for (besides a map's own seed, which wins).
const CONTENT_SEEDS: [u64; 2] = [1, 0x9e37_79b9_7f4a_7c15];

/// Reads `text` as a map in `format` (as `bw4t run` and `map check` do), checks it, and for
/// a map that validates generates its content; panics when the reader, the checker and the
/// writer disagree.
pub fn map_text(text: &str, format: MapFormat) {
    // `Map::parse` and `parse_parts` pick the reader by `MapFormat::of`.
    if MapFormat::of(text) != format {
        // Not this target's format: the reader must still not panic.
        if let Ok(map) = read(text, format) {
            content(&map);
        }
        return;
    }
    // The same reader `read` calls, after the same format choice.
    let loaded = Map::parse(text, "fuzz").map_err(|e| e.to_string());
    let parsed = parse_parts(text, "fuzz");
    let checked = parsed.as_ref().map(|(parts, tolerated)| {
        let _ = check_parts(parts, None);
        let mut problems = tolerated.clone();
        problems.extend(check_parts(parts, Some(4)));
        problems
    });
    let clean = match &checked {
        Ok(problems) => !problems.iter().any(|p| p.severity == Severity::Error),
        Err(_) => false,
    };
    // `check_parts` promises that whatever `Map::new` refuses is an error there.
    if let Err(refused) = &loaded {
        assert!(!clean, "refused ({refused}) but `map check` finds no error: {checked:?}");
    }
    // A file `map check` cannot read at all does not load either.
    if checked.is_err() {
        assert!(loaded.is_err(), "`map check` cannot read what the reader loads: {checked:?}");
    }
    if let Ok(map) = loaded {
        if clean {
            round_trip(&map);
        }
        content(&map);
    }
}

fn read(text: &str, format: MapFormat) -> Result<Map, String> {
    match format {
        MapFormat::Native => Map::from_native(text).map_err(|e| e.to_string()),
        MapFormat::Xml => Map::from_bw4t_xml_named(text, "fuzz").map_err(|e| e.to_string()),
    }
}

/// A playable map written in the native format reads back as the same map.
fn round_trip(map: &Map) {
    let written = map.to_native();
    match Map::from_native(&written) {
        Ok(again) => assert_eq!(&again, map, "written map reads back different:\n{written}"),
        Err(e) => panic!("written map does not read back ({e}):\n{written}"),
    }
}

/// Content generation terminates, is deterministic and keeps its promises.
fn content(map: &Map) {
    for seed in CONTENT_SEEDS {
        let first = map.content(seed);
        assert_eq!(first, map.content(seed), "content differs for the same seed");
        let Ok(content) = first else { continue };
        let expected = map.sequence().len() + map.random_sequence() as usize;
        assert_eq!(content.sequence.len(), expected, "sequence length");
        for block in &content.blocks {
            assert!(block.zone < map.zones().len(), "block in zone {} of {}", block.zone, map.zones().len());
        }
    }
}

/// Feeds `stream` to a [`LineBuffer`] cut at `cuts` (offsets, clamped to be increasing) and
/// compares the lines and the bytes left pending with a direct reading of the line rules.
pub fn line_stream(stream: &[u8], cuts: &[usize]) {
    let mut lines = LineBuffer::new();
    let mut got = Vec::new();
    let mut start = 0;
    for &cut in cuts.iter().chain(std::iter::once(&stream.len())) {
        let cut = cut.clamp(start, stream.len());
        got.extend(lines.push(&stream[start..cut]));
        assert!(lines.pending() <= MAX_LINE, "holds {} bytes", lines.pending());
        start = cut;
    }
    let (expected, pending) = expected_lines(stream);
    let codes: Vec<Result<String, &'static str>> =
        got.iter().map(|r| r.clone().map_err(|e| e.code.as_str())).collect();
    assert_eq!(codes, expected, "lines differ from the rules");
    assert_eq!(lines.pending(), pending, "bytes pending");
    for line in got.iter().flatten() {
        let _ = bw4t_protocol::decode_client(line);
    }
}

/// The documented rules, read off the whole stream: lines end at `\n`; a line (without its
/// `\n`) longer than [`MAX_LINE`] is one `line_too_long`, even when unfinished; otherwise one
/// trailing `\r` is dropped, blank lines are skipped and non-UTF-8 is `bad_utf8`. Also the
/// bytes of the unfinished line still held: none once it is too long.
fn expected_lines(stream: &[u8]) -> (Vec<Result<String, &'static str>>, usize) {
    let mut out = Vec::new();
    let mut pieces: Vec<&[u8]> = stream.split(|&b| b == b'\n').collect();
    let unfinished = pieces.pop().unwrap_or_default();
    for raw in pieces {
        if raw.len() > MAX_LINE {
            out.push(Err("line_too_long"));
            continue;
        }
        let line = raw.strip_suffix(b"\r").unwrap_or(raw);
        if line.iter().all(u8::is_ascii_whitespace) {
            continue;
        }
        out.push(String::from_utf8(line.to_vec()).map_err(|_| "bad_utf8"));
    }
    if unfinished.len() > MAX_LINE {
        out.push(Err("line_too_long"));
        return (out, 0);
    }
    (out, unfinished.len())
}
