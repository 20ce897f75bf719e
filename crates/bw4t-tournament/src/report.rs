//! The summary as text: `summary.md` (Markdown tables) and the fixed-width table printed at
//! the end of a run.
//!
//! Numbers are rounded for reading (rates to 0.1 percentage points, ticks to 0.1, drops
//! and messages to 0.01); `summary.json` keeps them whole.

use std::fmt::Write as _;

use super::stats::{Interval, Summary};
use crate::plural;

/// What Markdown and the terminal show for a figure that does not exist.
const NONE_MD: &str = "–";
const NONE_TERM: &str = "-";
/// Longest team or map name in the terminal table; longer ones are shortened.
const TERM_NAME_MAX: usize = 24;

impl Summary {
    /// The summary as Markdown (`summary.md`): totals, a table per team and map, the paired
    /// differences and the ranking.
    pub fn to_markdown(&self) -> String {
        let mut md = String::from("# Tournament summary\n\n");
        if self.matches == 0 {
            md.push_str("No matches.\n");
            return md;
        }
        let t = &self.totals;
        let _ = writeln!(
            md,
            "**{}**, {} completed ({}%), {} on {}, in {}: **{} matches/min**.\n",
            plural(self.matches, "match"),
            self.completed,
            fixed(100.0 * self.completed as f64 / self.matches as f64, 1),
            plural(t.teams, "team"),
            plural(t.maps, "map"),
            duration(self.wall_seconds),
            fixed(self.matches_per_min, 1),
        );
        let reasons: Vec<String> =
            t.end_reasons.iter().map(|r| format!("{} {}", md_text(r.reason.as_str()), r.matches)).collect();
        let _ = writeln!(
            md,
            "End reasons: {}. Over all matches: {} ticks simulated, {} blocks delivered in order and \
             {} out of order, {} messages, {} late and {} crashed agents, {} s of match wall time.\n",
            reasons.join(", "),
            t.ticks,
            t.good_drops,
            t.wrong_drops,
            t.messages,
            t.late_agents,
            t.crashed_agents,
            fixed(t.match_wall_ms as f64 / 1000.0, 1),
        );
        md.push_str(&self.setup_markdown());
        let _ = writeln!(
            md,
            "Ticks to complete count completed matches only. Intervals are 95%: Wilson score for \
             rates, percentile bootstrap ({} resamples, fixed seed) for means. p90 interpolates \
             linearly between order statistics.\n",
            self.method.bootstrap_resamples
        );

        md.push_str("## Teams by map\n\n");
        md.push_str(
            "| team | map | completed | rate % [95% CI] | mean ticks [95% CI] | median | p90 | \
             wrong drops / match | messages / block | late agents | crashed agents | wall ms / match |\n",
        );
        md.push_str("|---|---|---:|---|---|---:|---:|---:|---:|---:|---:|---:|\n");
        for c in &self.cells {
            let _ = writeln!(
                md,
                "| {} | {} | {}/{} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
                md_text(&c.team),
                md_text(&c.map),
                c.completed,
                c.matches,
                with_interval(
                    Some(100.0 * c.completion_rate),
                    Some(percent(c.completion_interval)),
                    1,
                    NONE_MD
                ),
                with_interval(c.ticks_mean, c.ticks_mean_interval, 1, NONE_MD),
                opt(c.ticks_median, 1, NONE_MD),
                opt(c.ticks_p90, 1, NONE_MD),
                fixed(c.mean_wrong_drops, 2),
                opt(c.messages_per_good_drop, 2, NONE_MD),
                c.late_agents,
                c.crashed_agents,
                fixed(c.mean_wall_ms, 0),
            );
        }

        md.push_str("\n## Paired differences\n\n");
        if self.pairs.is_empty() {
            md.push_str("No two teams played the same map.\n");
        } else {
            md.push_str(
                "Ticks to complete of team A minus team B on the same map, seed and repetition, \
                 where both completed; negative means A was faster.\n\n",
            );
            md.push_str(
                "| team A | team B | map | pairs | mean A − B [95% CI] | only A completed | \
                 only B completed | neither |\n",
            );
            md.push_str("|---|---|---|---:|---|---:|---:|---:|\n");
            for p in &self.pairs {
                let _ = writeln!(
                    md,
                    "| {} | {} | {} | {} | {} | {} | {} | {} |",
                    md_text(&p.team_a),
                    md_text(&p.team_b),
                    md_text(&p.map),
                    p.pairs,
                    with_interval(p.mean_difference, p.difference_interval, 1, NONE_MD),
                    p.only_a,
                    p.only_b,
                    p.neither,
                );
            }
        }

        md.push_str("\n## Ranking\n\n");
        md.push_str(
            "By completion rate over all matches (higher first), then mean ticks to complete over \
             all maps (lower first), then name.\n\n",
        );
        md.push_str("| rank | team | matches | completed | rate % [95% CI] | mean ticks |\n");
        md.push_str("|---:|---|---:|---:|---|---:|\n");
        for r in &self.ranking {
            let _ = writeln!(
                md,
                "| {} | {} | {} | {} | {} | {} |",
                r.rank,
                md_text(&r.team),
                r.matches,
                r.completed,
                with_interval(
                    Some(100.0 * r.completion_rate),
                    Some(percent(r.completion_interval)),
                    1,
                    NONE_MD
                ),
                opt(r.ticks_mean, 1, NONE_MD),
            );
        }
        md
    }

    /// The tick limits, and a warning for maps whose content ignores the match seed.
    fn setup_markdown(&self) -> String {
        let mut md = String::new();
        let limits: Vec<String> = self
            .setup
            .tick_limits
            .iter()
            .map(|l| {
                let how = l.explanation.as_deref().unwrap_or("from the configuration");
                format!("{} {} ({})", md_text(&l.map), l.max_ticks, md_text(how))
            })
            .collect();
        if !limits.is_empty() {
            let _ = writeln!(md, "Tick limits: {}.\n", limits.join("; "));
        }
        if let Some(warning) = self.setup.fixed_content_warning() {
            let _ = writeln!(md, "**Warning:** {}.\n", md_text(&warning));
        }
        md
    }

    /// A compact fixed-width table for the end of a run: per team and map, completed of
    /// played, completion rate, median and mean ticks to complete, and wrong drops per match.
    pub fn terminal_table(&self) -> String {
        let header = ["team", "map", "done", "rate", "median", "mean", "wrong"];
        let rows: Vec<[String; 7]> = self
            .cells
            .iter()
            .map(|c| {
                [
                    shorten_end(&c.team, TERM_NAME_MAX),
                    // Maps are often paths, whose end says most.
                    shorten_start(&c.map, TERM_NAME_MAX),
                    format!("{}/{}", c.completed, c.matches),
                    format!("{}%", fixed(100.0 * c.completion_rate, 1)),
                    opt(c.ticks_median, 1, NONE_TERM),
                    opt(c.ticks_mean, 1, NONE_TERM),
                    fixed(c.mean_wrong_drops, 2),
                ]
            })
            .collect();
        let mut widths = header.map(|h| h.chars().count());
        for row in &rows {
            for (w, cell) in widths.iter_mut().zip(row) {
                *w = (*w).max(cell.chars().count());
            }
        }
        let mut out = String::new();
        let mut line = |cells: [&str; 7]| {
            let mut text = String::new();
            for (i, (cell, w)) in cells.iter().zip(widths).enumerate() {
                let pad = " ".repeat(w.saturating_sub(cell.chars().count()));
                // Names to the left, numbers to the right.
                if i < 2 {
                    let _ = write!(text, "{cell}{pad}  ");
                } else {
                    let _ = write!(text, "{pad}{cell}  ");
                }
            }
            out.push_str(text.trim_end());
            out.push('\n');
        };
        line(header);
        for row in &rows {
            line(row.each_ref().map(String::as_str));
        }
        if rows.is_empty() {
            out.push_str("(no matches)\n");
        }
        out
    }
}

/// `x` with `decimals` decimals; never `-0.0`.
pub(super) fn fixed(x: f64, decimals: usize) -> String {
    let s = format!("{x:.decimals$}");
    match s.strip_prefix('-') {
        Some(rest) if rest.chars().all(|c| c == '0' || c == '.') => rest.to_string(),
        _ => s,
    }
}

fn opt(x: Option<f64>, decimals: usize, none: &str) -> String {
    x.map_or_else(|| none.to_string(), |x| fixed(x, decimals))
}

/// `value [lo, hi]`, or just the value without an interval.
fn with_interval(value: Option<f64>, interval: Option<Interval>, decimals: usize, none: &str) -> String {
    match (value, interval) {
        (Some(v), Some(i)) => {
            format!("{} [{}, {}]", fixed(v, decimals), fixed(i.lo, decimals), fixed(i.hi, decimals))
        }
        (Some(v), None) => fixed(v, decimals),
        (None, _) => none.to_string(),
    }
}

fn percent(i: Interval) -> Interval {
    Interval { lo: 100.0 * i.lo, hi: 100.0 * i.hi }
}

/// Seconds as `12.3 s`, `4 min 5 s` or `1 h 2 min`.
fn duration(seconds: f64) -> String {
    if seconds < 60.0 {
        return format!("{} s", fixed(seconds, 1));
    }
    let whole = seconds.round() as u64;
    if whole < 3600 {
        format!("{} min {} s", whole / 60, whole % 60)
    } else {
        format!("{} h {} min", whole / 3600, whole % 3600 / 60)
    }
}

/// Text for a Markdown table cell: characters Markdown would act on are backslash-escaped
/// (`|` would end the cell) and line breaks become spaces.
fn md_text(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '\\' | '|' | '*' | '_' | '`' | '[' | ']' | '<' | '>' | '#' => {
                out.push('\\');
                out.push(c);
            }
            '\n' | '\r' => out.push(' '),
            _ => out.push(c),
        }
    }
    out
}

/// At most `max` characters (`max >= 1`), cut at the end.
pub(super) fn shorten_end(s: &str, max: usize) -> String {
    if s.chars().count() <= max {
        return s.to_string();
    }
    let kept: String = s.chars().take(max.saturating_sub(1)).collect();
    format!("{kept}…")
}

/// At most `max` characters (`max >= 1`), cut at the start.
pub(super) fn shorten_start(s: &str, max: usize) -> String {
    let n = s.chars().count();
    if n <= max {
        return s.to_string();
    }
    let kept: String = s.chars().skip(n - max.saturating_sub(1)).collect();
    format!("…{kept}")
}

#[cfg(test)]
mod tests {
    use super::super::stats::summarize;
    use super::super::stats::tests::{row, sample};
    use super::*;

    #[test]
    fn markdown_has_the_figures() {
        let md = summarize(&sample(), 120.0).to_markdown();
        assert!(md.starts_with("# Tournament summary\n"));
        assert!(
            md.contains(
                "**16 matches**, 9 completed (56.2%), 2 teams on 2 maps, in 2 min 0 s: **8.0 matches/min**"
            ),
            "{md}"
        );
        assert!(md.contains("End reasons: completed 9, max\\_ticks 7."), "{md}");
        // coop on default: 4/4, whose Wilson interval for n = 4 is [0.510, 1].
        let coop_default = md.lines().find(|l| l.starts_with("| coop | default |")).unwrap_or_default();
        assert!(coop_default.contains("| 4/4 | 100.0 [51.0, 100.0] | 1150.0 ["), "{coop_default}");
        assert!(coop_default.contains("| 1150.0 | 1270.0 | 0.00 | 5.00 | 0 | 0 | 100 |"), "{coop_default}");
        let baseline_fixed = md.lines().find(|l| l.starts_with("| baseline | fixed |")).unwrap_or_default();
        assert!(
            baseline_fixed.contains("| 0/4 | 0.0 [0.0, 49.0] | – | – | – | 0.00 | 15.00 |"),
            "{baseline_fixed}"
        );
        let pair = md.lines().find(|l| l.starts_with("| coop | baseline | default |")).unwrap_or_default();
        assert!(pair.contains("| 3 | -400.0 [") && pair.ends_with("| 1 | 0 | 0 |"), "{pair}");
        assert!(md.contains("| 1 | coop | 8 | 6 | 75.0 [40.9, 92.9] | 1050.0 |"), "{md}");
        assert!(md.contains("| 2 | baseline | 8 | 3 | 37.5 [13.7, 69.4] | 1500.0 |"), "{md}");
    }

    #[test]
    fn markdown_says_the_tick_limits_and_warns_of_fixed_content() {
        use super::super::stats::{MapLimit, Setup};
        let setup = Setup {
            tick_limits: vec![
                MapLimit { map: "default".into(), max_ticks: 500, from: "config".into(), explanation: None },
                MapLimit {
                    map: "fixed".into(),
                    max_ticks: 20000,
                    from: "map".into(),
                    explanation: Some("derived from the map".into()),
                },
            ],
            fixed_content_maps: vec!["fixed".into()],
        };
        let md = summarize(&sample(), 120.0).with_setup(setup).to_markdown();
        assert!(
            md.contains(
                "Tick limits: default 500 (from the configuration); fixed 20000 (derived from the map).\n"
            ),
            "{md}"
        );
        assert!(md.contains("**Warning:** map 'fixed' fixes its own seed"), "{md}");
        assert!(!summarize(&sample(), 120.0).to_markdown().contains("Warning"));
    }

    #[test]
    fn markdown_escapes_names() {
        let md = summarize(&[row("a|b", "x_y", 1, None)], 1.0).to_markdown();
        assert!(md.contains("| a\\|b | x\\_y | 0/1 |"), "{md}");
        assert!(md.contains("No two teams played the same map."));
    }

    #[test]
    fn empty_markdown_and_table() {
        let s = summarize(&[], 0.0);
        assert_eq!(s.to_markdown(), "# Tournament summary\n\nNo matches.\n");
        let table = s.terminal_table();
        assert!(table.starts_with("team  map  done  rate  median  mean  wrong\n"), "{table}");
        assert!(table.ends_with("(no matches)\n"));
    }

    #[test]
    fn terminal_table_is_aligned() {
        let table = summarize(&sample(), 1.0).terminal_table();
        let lines: Vec<&str> = table.lines().collect();
        assert_eq!(lines.len(), 5, "{table}");
        assert_eq!(lines[0], "team      map      done    rate  median    mean  wrong");
        assert_eq!(lines[1], "coop      default   4/4  100.0%  1150.0  1150.0   0.00");
        assert_eq!(lines[4], "baseline  fixed     0/4    0.0%       -       -   0.00");
        // Every line ends where its last column ends.
        assert!(lines.iter().all(|l| l.chars().count() == lines[0].chars().count()), "{table}");
    }

    #[test]
    fn long_names_are_shortened() {
        let long_map = "../original/bw4t-maps/a very long map name indeed";
        let table = summarize(&[row(&"t".repeat(40), long_map, 1, Some(5))], 1.0).terminal_table();
        assert!(table.contains(&format!("{}…", "t".repeat(23))), "{table}");
        assert!(table.contains("  …ry long map name indeed  "), "{table}");
    }

    #[test]
    fn numbers_print_stably() {
        assert_eq!(fixed(-0.0001, 1), "0.0");
        assert_eq!(fixed(-0.25, 1), "-0.2");
        assert_eq!(fixed(2.0, 0), "2");
        assert_eq!(duration(3.04), "3.0 s");
        assert_eq!(duration(125.0), "2 min 5 s");
        assert_eq!(duration(7384.0), "2 h 3 min");
    }
}
