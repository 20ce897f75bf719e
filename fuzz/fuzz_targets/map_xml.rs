//! The original BW4T XML map reader, `map check`, the native writer and content generation.

#![no_main]

use bw4t_fuzz::{MapFormat, map_text};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        map_text(text, MapFormat::Xml);
    }
});
