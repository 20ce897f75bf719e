//! The line splitter (`LineBuffer`): any byte stream, cut into chunks anywhere, gives the
//! lines the rules say, holds at most `MAX_LINE` bytes, and every line decodes without panic.
//!
//! Input: the stream's bytes, except that 0xFE starts a command: `FE 00` cuts the stream
//! into another chunk here, `FE 01 b hi lo` appends byte `b` repeated `2 * (hi << 8 | lo)`
//! times (so lines around the 64 KiB limit cost a few input bytes), any other `FE x` is the
//! byte 0xFE.

#![no_main]

use libfuzzer_sys::fuzz_target;

/// The longest stream built from one input: room for two lines over the limit, and short
/// enough that each input is quick.
const MAX_STREAM: usize = 2 * bw4t_protocol::MAX_LINE + 4096;

const ESCAPE: u8 = 0xFE;

fuzz_target!(|data: &[u8]| {
    let (stream, cuts) = build(data);
    bw4t_fuzz::line_stream(&stream, &cuts);
});

fn build(mut data: &[u8]) -> (Vec<u8>, Vec<usize>) {
    let mut stream = Vec::new();
    let mut cuts = Vec::new();
    while let Some((&byte, rest)) = data.split_first() {
        data = rest;
        match (byte, data) {
            (ESCAPE, [0, rest @ ..]) => {
                cuts.push(stream.len());
                data = rest;
            }
            (ESCAPE, [1, fill, hi, lo, rest @ ..]) => {
                let count = 2 * (usize::from(*hi) << 8 | usize::from(*lo));
                let count = count.min(MAX_STREAM - stream.len());
                stream.resize(stream.len() + count, *fill);
                data = rest;
            }
            _ => stream.push(byte),
        }
        if stream.len() >= MAX_STREAM {
            break;
        }
    }
    (stream, cuts)
}
