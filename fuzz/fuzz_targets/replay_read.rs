//! The replay reader: any text is read as replay lines or refused with an error naming the
//! line; every line read writes back as JSON that reads again, and the header's map and the
//! events' actions convert without panic.

#![no_main]

use bw4t_map::Map;
use bw4t_protocol::ReplayLine;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let Ok((header, lines)) = bw4t_runner::read_replay(text) else { return };
    let _ = Map::from_native(&header.map_native);
    let mut previous = 1;
    for (number, line) in &lines {
        assert!(*number > previous, "line numbers not increasing: {number} after {previous}");
        previous = *number;
        if let ReplayLine::Tick { events, .. } = line {
            events.iter().for_each(|event| drop(event.action()));
        }
        let written = serde_json::to_string(line).expect("a replay line serialises");
        let again: Result<ReplayLine, _> = serde_json::from_str(&written);
        assert!(again.is_ok(), "{written} does not read back: {again:?}");
    }
});
