//! Repeating what a caller gave in an error message, cut short: enough to recognise it,
//! never a megabyte sent back to the model.

/// The longest a value given by the caller is repeated in an error, in characters: enough
/// to recognise it, never a megabyte sent back.
pub(crate) const MAX_ECHO_CHARS: usize = 60;

/// `value` as an error repeats it: quoted, and cut to [`MAX_ECHO_CHARS`] with a note of
/// how long it was.
pub(crate) fn echo(value: &str) -> String {
    let length = value.chars().count();
    if length <= MAX_ECHO_CHARS {
        return format!("'{value}'");
    }
    let head: String = value.chars().take(MAX_ECHO_CHARS).collect();
    format!("'{head}...' (cut; {length} characters in all)")
}

/// `message` (a JSON reader's complaint about the arguments) with every value it quotes
/// (`"..."` or `` `...` ``) cut as [`echo`] cuts one, so that no error repeats a long
/// argument whole.
pub(crate) fn clip_quoted(message: &str) -> String {
    let mut out = String::with_capacity(message.len().min(1024));
    let mut rest = message;
    while let Some(open) = rest.find(['"', '`']) {
        let quote = rest[open..].chars().next().unwrap_or('"');
        out.push_str(&rest[..=open]);
        let after = &rest[open + 1..];
        let Some(close) = after.find(quote) else {
            rest = after;
            break;
        };
        let inner = &after[..close];
        let length = inner.chars().count();
        if length > MAX_ECHO_CHARS {
            out.extend(inner.chars().take(MAX_ECHO_CHARS));
            out.push_str(&format!("...{quote} (cut; {length} characters in all)"));
        } else {
            out.push_str(inner);
            out.push(quote);
        }
        rest = &after[close + 1..];
    }
    // An unclosed quote's tail is cut too.
    let length = rest.chars().count();
    if length > 4 * MAX_ECHO_CHARS {
        out.extend(rest.chars().take(MAX_ECHO_CHARS));
        out.push_str(&format!("... (cut; {length} characters in all)"));
    } else {
        out.push_str(rest);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn echoes_and_quoted_values_are_cut_short() {
        assert_eq!(echo("RoomZ9"), "'RoomZ9'");
        let long = "y".repeat(1000);
        let echoed = echo(&long);
        assert!(echoed.len() < 120 && echoed.ends_with("(cut; 1000 characters in all)"), "{echoed}");
        let message = format!("invalid type: string \"{long}\", expected u32 at `{long}`");
        let clipped = clip_quoted(&message);
        assert_eq!(clipped.matches("(cut; 1000 characters in all)").count(), 2, "{clipped}");
        assert!(clipped.starts_with("invalid type: string \"yyy") && clipped.len() < 300, "{clipped}");
        assert_eq!(clip_quoted("missing field `place`"), "missing field `place`");
    }
}
