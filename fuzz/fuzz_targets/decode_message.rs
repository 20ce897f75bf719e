//! The message decoder: any line decodes to a message or to an error with one of the
//! protocol's codes, and a decoded message encodes to one line that decodes back to it.
//!
//! Numbers with a fraction or exponent are exempt for server messages: their `f32` fields
//! take 1e300 as infinity, which JSON cannot carry back (servers send only finite ones).

#![no_main]

use bw4t_protocol::{DecodeError, decode_client, decode_server, encode};
use libfuzzer_sys::fuzz_target;
use serde_json::Value;

/// The codes `PROTOCOL.md` lists for lines that are not messages.
const CODES: [&str; 3] = ["bad_json", "unknown_type", "bad_message"];

fuzz_target!(|data: &[u8]| {
    let Ok(line) = std::str::from_utf8(data) else { return };
    check(line, decode_client, Floats::Exact);
    check(line, decode_server, Floats::Skip);
});

/// How a message with fractional numbers is checked.
#[derive(PartialEq)]
enum Floats {
    /// It must decode back (values may differ in the last place).
    Exact,
    /// Not checked after encoding.
    Skip,
}

fn check<T>(line: &str, decode: fn(&str) -> Result<T, DecodeError>, floats: Floats)
where
    T: serde::Serialize + PartialEq + std::fmt::Debug,
{
    let message = match decode(line) {
        Ok(message) => message,
        Err(e) => {
            assert!(CODES.contains(&e.code.as_str()), "unexpected code {}", e.code);
            assert!(!e.message.is_empty(), "an error without words");
            return;
        }
    };
    let encoded = encode(&message);
    let body = encoded.strip_suffix('\n').expect("an encoded message ends its line");
    assert!(!body.contains('\n'), "an encoded message is one line: {encoded:?}");
    let fractions = has_fraction(&serde_json::from_str(line).unwrap_or(Value::Null));
    if fractions && floats == Floats::Skip {
        return;
    }
    let again = decode(body).unwrap_or_else(|e| panic!("{body} does not decode back: {e}"));
    // Decimal fractions may come back one unit in the last place off; compare the rest exactly.
    if !fractions {
        assert_eq!(again, message, "{body} decodes to something else");
    }
}

fn has_fraction(value: &Value) -> bool {
    match value {
        Value::Number(n) => n.is_f64(),
        Value::Array(items) => items.iter().any(has_fraction),
        Value::Object(fields) => fields.values().any(has_fraction),
        _ => false,
    }
}
