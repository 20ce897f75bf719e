//! Replay verification and the viewer's frames, by re-simulation: any replay whose ticks
//! stay small either fails to set up, in both, or re-simulates to its last tick.
//!
//! Replays with later ticks are skipped so each input is bounded work; how far a replay may
//! reach is the reader's own limit, checked by the unit tests, not by this target.

#![no_main]

use bw4t_protocol::ReplayLine;
use libfuzzer_sys::fuzz_target;

/// Ticks re-simulated at most per input.
const MAX_TICK: u64 = 300;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let Ok((_, lines)) = bw4t_runner::read_replay(text) else { return };
    let ticks = lines.iter().map(|(_, line)| match line {
        ReplayLine::Header(_) => 0,
        ReplayLine::Tick { tick, .. } | ReplayLine::Digest { tick, .. } | ReplayLine::End { tick, .. } => {
            *tick
        }
    });
    let last = ticks.max().unwrap_or(0);
    if last > MAX_TICK {
        return;
    }
    let verified = bw4t_runner::verify_replay(text);
    let frames = bw4t_runner::ReplayFrames::open(text);
    assert_eq!(verified.is_ok(), frames.is_ok(), "verify: {verified:?}; frames: {:?}", frames.as_ref().err());
    if let Ok(mut frames) = frames {
        assert_eq!(frames.last_tick(), last, "the viewer ends at the last tick recorded");
        // Every tick has a frame, none beyond; going back re-simulates to the same frame.
        let first = frames.frame_json(0);
        assert!(first.is_some(), "no frame at tick 0");
        assert!(frames.frame_json(last).is_some(), "no frame at the last tick {last}");
        assert!(frames.frame_json(last + 1).is_none(), "a frame beyond the last tick");
        assert_eq!(frames.frame_json(0), first, "tick 0 differs when visited again");
    }
});
