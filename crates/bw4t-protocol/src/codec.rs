//! The line codec: UTF-8 JSON, one object per line, each line at most [`MAX_LINE`] bytes.

use serde::Serialize;
use serde_json::Value;

use crate::messages::{ClientMessage, ServerMessage};
use crate::vocabulary::ErrorCode;

/// The longest line accepted, in bytes, without its newline.
pub const MAX_LINE: usize = 64 * 1024;

const CLIENT_TYPES: &[&str] = &["hello", "act", "say", "ready", "resync", "ping", "bye", "report"];
const SERVER_TYPES: &[&str] =
    &["welcome", "percepts", "ack", "result", "error", "pong", "match_end", "bye", "frame", "lobby", "pause"];

/// A line that is not a valid message, with the protocol's error code.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{message}")]
pub struct DecodeError {
    /// `bad_json`, `unknown_type`, `bad_message`, `line_too_long` or `bad_utf8`.
    pub code: ErrorCode,
    /// What was wrong, in words.
    pub message: String,
}

impl DecodeError {
    /// An error with `code` and `message`.
    pub fn new(code: ErrorCode, message: impl Into<String>) -> Self {
        DecodeError { code, message: message.into() }
    }
}

/// One message as a line, newline included.
pub fn encode<T: Serialize>(message: &T) -> String {
    // Serialising these types cannot fail: every map key is a string.
    let mut line = serde_json::to_string(message).unwrap_or_default();
    line.push('\n');
    line
}

/// Parses a line from a client.
pub fn decode_client(line: &str) -> Result<ClientMessage, DecodeError> {
    decode(line, CLIENT_TYPES)
}

/// Parses a line from the server.
pub fn decode_server(line: &str) -> Result<ServerMessage, DecodeError> {
    decode(line, SERVER_TYPES)
}

fn decode<T: serde::de::DeserializeOwned>(line: &str, known: &[&str]) -> Result<T, DecodeError> {
    // A good line parses straight into its message; only a bad one is parsed again, as a
    // `Value`, to say what is wrong with it. (Everything the second way accepts, the first
    // accepts too or hands over to it.)
    if let Ok(message) = serde_json::from_str(line) {
        return Ok(message);
    }
    let value: Value = serde_json::from_str(line)
        .map_err(|e| DecodeError::new(ErrorCode::BadJson, format!("not JSON: {e}")))?;
    let Some(object) = value.as_object() else {
        return Err(DecodeError::new(ErrorCode::BadMessage, "a message must be a JSON object"));
    };
    let Some(kind) = object.get("type").and_then(Value::as_str) else {
        return Err(DecodeError::new(ErrorCode::BadMessage, "a message needs a string field `type`"));
    };
    if !known.contains(&kind) {
        return Err(DecodeError::new(ErrorCode::UnknownType, format!("unknown message type '{kind}'")));
    }
    let kind = kind.to_string();
    serde_json::from_value(value)
        .map_err(|e| DecodeError::new(ErrorCode::BadMessage, format!("bad '{kind}' message: {e}")))
}

/// Splits a byte stream into lines without ever holding more than [`MAX_LINE`] bytes:
/// an over-long line is reported once and skipped up to its newline.
#[derive(Debug, Default)]
pub struct LineBuffer {
    buf: Vec<u8>,
    discarding: bool,
}

impl LineBuffer {
    /// An empty buffer.
    pub fn new() -> Self {
        Self::default()
    }

    /// Feeds bytes; returns the complete lines (without `\n` or a trailing `\r`, empty
    /// lines skipped) and errors for over-long or non-UTF-8 lines, in stream order.
    pub fn push(&mut self, mut data: &[u8]) -> Vec<Result<String, DecodeError>> {
        let mut out = Vec::new();
        while !data.is_empty() {
            let newline = data.iter().position(|&b| b == b'\n');
            let (chunk, rest) = match newline {
                Some(i) => (&data[..i], &data[i + 1..]),
                None => (data, &[][..]),
            };
            if !self.discarding {
                if self.buf.len() + chunk.len() > MAX_LINE {
                    self.buf.clear();
                    self.discarding = true;
                    out.push(Err(DecodeError::new(
                        ErrorCode::LineTooLong,
                        format!("line longer than {MAX_LINE} bytes; skipped up to its newline"),
                    )));
                } else {
                    self.buf.extend_from_slice(chunk);
                }
            }
            if newline.is_some() {
                if !self.discarding {
                    let mut line = std::mem::take(&mut self.buf);
                    if line.last() == Some(&b'\r') {
                        line.pop();
                    }
                    if !line.iter().all(u8::is_ascii_whitespace) {
                        out.push(
                            String::from_utf8(line)
                                .map_err(|_| DecodeError::new(ErrorCode::BadUtf8, "line is not valid UTF-8")),
                        );
                    }
                }
                self.discarding = false;
            }
            data = rest;
        }
        out
    }

    /// Bytes held for an unfinished line.
    pub fn pending(&self) -> usize {
        self.buf.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splits_lines_across_chunks_and_skips_long_ones() {
        let mut lines = LineBuffer::new();
        assert!(lines.push(b"{\"a\":").is_empty());
        let got = lines.push(b"1}\r\n\n{\"b\":2}\n{\"c\"");
        assert_eq!(got, vec![Ok("{\"a\":1}".to_string()), Ok("{\"b\":2}".to_string())]);
        let long = vec![b'x'; MAX_LINE + 10];
        let got = lines.push(&long);
        assert_eq!(got.len(), 1);
        assert_eq!(got[0].as_ref().map_err(|e| e.code.as_str()), Err("line_too_long"));
        assert_eq!(lines.pending(), 0);
        assert!(lines.push(&long).is_empty(), "reported once per line");
        assert_eq!(lines.push(b"tail\nok\n"), vec![Ok("ok".to_string())]);
        assert_eq!(lines.push(b"\xff\n")[0].as_ref().map_err(|e| e.code.as_str()), Err("bad_utf8"));
    }

    #[test]
    fn decoding_names_what_is_wrong() {
        let code = |line: &str| decode_client(line).map(|_| ()).map_err(|e| e.code.as_str());
        assert_eq!(code("{not json"), Err("bad_json"));
        assert_eq!(code("[1,2]"), Err("bad_message"));
        assert_eq!(code("{\"type\":\"dance\"}"), Err("unknown_type"));
        assert_eq!(code("{\"type\":\"ready\",\"tick\":\"soon\"}"), Err("bad_message"));
        assert_eq!(code("{\"type\":\"ready\",\"tick\":3,\"extra\":true}"), Ok(()));
    }
}
