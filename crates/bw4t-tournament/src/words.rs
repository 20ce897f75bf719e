//! Words for counts in messages and reports, so no message says "1 robots".

/// `1 robot`, `2 robots`; by the regular English rules, `2 matches`, `2 entries`.
pub fn plural(n: usize, word: &str) -> String {
    if n == 1 {
        return format!("1 {word}");
    }
    match word.strip_suffix('y') {
        Some(stem) if !stem.ends_with(['a', 'e', 'i', 'o', 'u']) => format!("{n} {stem}ies"),
        _ if ["s", "x", "z", "ch", "sh"].iter().any(|end| word.ends_with(end)) => format!("{n} {word}es"),
        _ => format!("{n} {word}s"),
    }
}

#[cfg(test)]
mod tests {
    use super::plural;

    #[test]
    fn counts_read_as_english() {
        assert_eq!(plural(1, "robot"), "1 robot");
        assert_eq!(plural(0, "map"), "0 maps");
        assert_eq!(plural(3, "team"), "3 teams");
        assert_eq!(plural(2, "entry"), "2 entries");
        assert_eq!(plural(2, "day"), "2 days");
        assert_eq!(plural(8, "match"), "8 matches");
    }
}
