//! The summary as a chart (`summary.svg`): ticks to complete of every completed match, one
//! panel per map and one column per team, as dots over a box plot, with how many matches
//! each team completed under its column.
//!
//! The document is standalone (no scripts, styles or fonts beyond `sans-serif`) and depends
//! only on the summary: numbers are printed with one decimal, dots are spread sideways by a
//! fixed sequence rather than at random, and values are drawn in ascending order.

use super::report::{fixed, shorten_start};
use super::stats::{Summary, TeamMapStats, quantile};
use crate::plural;

/// One colour per team, in team order, repeating after the last. Okabe and Ito's
/// colour-blind-safe set without its yellow (too faint on white), then a brown.
const PALETTE: [&str; 8] =
    ["#0072b2", "#d55e00", "#009e73", "#cc79a7", "#e69f00", "#56b4e9", "#000000", "#8c564b"];
/// Blank space around everything, in pixels.
const MARGIN: f64 = 16.0;
/// Room left of the plot for the tick labels and the axis title.
const AXIS_WIDTH: f64 = 64.0;
/// Room for the title and the two lines under it.
const TITLE_HEIGHT: f64 = 62.0;
/// Height of a legend row.
const LEGEND_ROW: f64 = 20.0;
/// Height of the plotting area.
const PLOT_HEIGHT: f64 = 300.0;
/// Width of one team's column.
const COLUMN: f64 = 48.0;
/// Blank space at each side of a map's panel.
const PANEL_PAD: f64 = 10.0;
/// Height of the row of completion counts under the plot.
const COUNT_ROW: f64 = 22.0;
/// Height of the row of map names.
const MAP_ROW: f64 = 22.0;
/// A rough width of one character of 11-pixel text; bold 16-pixel text takes 1.45 times it.
const CHAR_WIDTH: f64 = 6.6;
/// Longest map name drawn; longer ones keep their end (paths end in the name).
const MAP_LABEL_MAX: usize = 40;
/// Narrowest chart, so the lines under the title fit.
const MIN_WIDTH: f64 = 560.0;

impl Summary {
    /// Ticks to complete per map and team as a standalone SVG document (`summary.svg`).
    ///
    /// Each completed match is a dot in its team's colour; a box spans the quartiles, a
    /// dark line marks the median and whiskers reach the fastest and slowest match. Under
    /// each column is `completed/played`. The same summary always gives the same bytes.
    pub fn to_svg(&self) -> String {
        let mut panels = self.panels();
        let panels_width: f64 = panels.iter().map(|p| p.width).sum();
        let title = "Ticks to complete, by map and team";
        let facts = if self.matches == 0 {
            "No matches.".to_string()
        } else {
            format!(
                "{} on {}, {} completed ({}%).",
                plural(self.matches, "match"),
                plural(self.maps.len(), "map"),
                self.completed,
                fixed(100.0 * self.completed as f64 / self.matches as f64, 1)
            )
        };
        let key =
            "Dots: completed matches. Box: middle half; dark line: median; whiskers: fastest to slowest.";
        let width = (2.0 * MARGIN + AXIS_WIDTH + panels_width)
            .max(2.0 * MARGIN + text_width(title) * 1.45)
            .max(MIN_WIDTH)
            .ceil();
        // The plot takes all the width; panels share what the title or the minimum width add.
        let plot_width = width - 2.0 * MARGIN - AXIS_WIDTH;
        if panels_width > 0.0 {
            let stretch = plot_width / panels_width;
            panels.iter_mut().for_each(|p| p.width *= stretch);
        }

        let legend = self.legend(width - 2.0 * MARGIN);
        let legend_rows = legend.iter().map(|item| item.row + 1).max().unwrap_or(0);
        let plot_top = MARGIN + TITLE_HEIGHT + legend_rows as f64 * LEGEND_ROW + 8.0;
        let plot_bottom = plot_top + PLOT_HEIGHT;
        let plot_left = MARGIN + AXIS_WIDTH;
        let height = (plot_bottom + COUNT_ROW + MAP_ROW + MARGIN).ceil();
        let all_ticks: Vec<u64> =
            self.cells.iter().flat_map(|c| c.completion_ticks.iter().copied()).collect();
        let scale = match (all_ticks.iter().min(), all_ticks.iter().max()) {
            (Some(&lo), Some(&hi)) => Some(Scale::nice(lo as f64, hi as f64)),
            _ => None,
        };
        let y_of = |v: f64| match &scale {
            Some(s) => plot_bottom - (v - s.lo) / (s.hi - s.lo) * PLOT_HEIGHT,
            None => plot_bottom,
        };

        let mut svg = String::new();
        let mut line = |s: String| {
            svg.push_str(&s);
            svg.push('\n');
        };
        line(format!(
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}" font-family="sans-serif" font-size="11">"#,
            w = fixed(width, 0),
            h = fixed(height, 0)
        ));
        line(format!("<title>{}</title>", xml(title)));
        line(r##"<rect width="100%" height="100%" fill="#ffffff"/>"##.to_string());
        line(format!(
            r##"<text x="{}" y="{}" font-size="16" font-weight="bold" fill="#222222">{}</text>"##,
            px(MARGIN),
            px(MARGIN + 16.0),
            xml(title)
        ));
        line(format!(
            r##"<text x="{}" y="{}" fill="#444444">{}</text>"##,
            px(MARGIN),
            px(MARGIN + 36.0),
            xml(&facts)
        ));
        line(format!(
            r##"<text x="{}" y="{}" fill="#444444">{}</text>"##,
            px(MARGIN),
            px(MARGIN + 52.0),
            xml(key)
        ));

        // Legend: a dot and the name of each team, in team order, wrapped into rows.
        for item in &legend {
            let y = MARGIN + TITLE_HEIGHT + item.row as f64 * LEGEND_ROW + 10.0;
            line(format!(
                r#"<circle cx="{}" cy="{}" r="5" fill="{}"/>"#,
                px(MARGIN + item.x + 5.0),
                px(y - 4.0),
                item.colour
            ));
            line(format!(
                r##"<text x="{}" y="{}" fill="#222222">{}</text>"##,
                px(MARGIN + item.x + 14.0),
                px(y),
                xml(&item.name)
            ));
        }

        // Every other panel shaded, so columns read as belonging to their map.
        let mut x = plot_left;
        for (i, panel) in panels.iter().enumerate() {
            if i % 2 == 1 {
                line(format!(
                    r##"<rect x="{}" y="{}" width="{}" height="{}" fill="#f2f2f2"/>"##,
                    px(x),
                    px(plot_top),
                    px(panel.width),
                    px(PLOT_HEIGHT + COUNT_ROW + MAP_ROW)
                ));
            }
            x += panel.width;
        }

        // The axis: grid lines with their labels, and its title.
        if let Some(s) = &scale {
            for k in 0..=s.steps() {
                let v = s.lo + k as f64 * s.step;
                let y = y_of(v);
                line(format!(
                    r##"<line x1="{}" y1="{y}" x2="{}" y2="{y}" stroke="#d0d0d0" stroke-width="1"/>"##,
                    px(plot_left),
                    px(plot_left + plot_width),
                    y = px(y)
                ));
                line(format!(
                    r##"<text x="{}" y="{}" text-anchor="end" fill="#444444">{}</text>"##,
                    px(plot_left - 6.0),
                    px(y + 4.0),
                    fixed(v, 0)
                ));
            }
        } else {
            let note = if self.matches == 0 { "No matches." } else { "No match was completed." };
            line(format!(
                r##"<text x="{}" y="{}" text-anchor="middle" fill="#777777">{note}</text>"##,
                px(plot_left + plot_width / 2.0),
                px(plot_top + PLOT_HEIGHT / 2.0)
            ));
        }
        let axis_mid = plot_top + PLOT_HEIGHT / 2.0;
        line(format!(
            r##"<text x="{x}" y="{y}" transform="rotate(-90 {x} {y})" text-anchor="middle" fill="#222222">ticks to complete</text>"##,
            x = px(MARGIN + 10.0),
            y = px(axis_mid)
        ));
        line(format!(
            r##"<path d="M{l} {t}V{b}H{r}" fill="none" stroke="#888888" stroke-width="1"/>"##,
            l = px(plot_left),
            t = px(plot_top),
            b = px(plot_bottom),
            r = px(plot_left + plot_width)
        ));
        if !panels.is_empty() {
            line(format!(
                r##"<text x="{}" y="{}" text-anchor="end" fill="#444444">completed</text>"##,
                px(plot_left - 6.0),
                px(plot_bottom + 17.0)
            ));
        }

        // The columns, the counts under them and the map names.
        let mut x = plot_left;
        for panel in &panels {
            let first_column = x + (panel.width - panel.cells.len() as f64 * COLUMN) / 2.0;
            for (i, cell) in panel.cells.iter().enumerate() {
                let centre = first_column + (i as f64 + 0.5) * COLUMN;
                let colour = self.colour(&cell.team);
                column(&mut line, cell, centre, colour, &y_of, axis_mid);
                line(format!(
                    r##"<text x="{}" y="{}" text-anchor="middle" fill="#444444">{}/{}</text>"##,
                    px(centre),
                    px(plot_bottom + 17.0),
                    cell.completed,
                    cell.matches
                ));
            }
            line(format!(
                r##"<text x="{}" y="{}" text-anchor="middle" font-size="12" font-weight="bold" fill="#222222"><title>{}</title>{}</text>"##,
                px(x + panel.width / 2.0),
                px(plot_bottom + COUNT_ROW + 14.0),
                xml(panel.map),
                xml(&panel.label)
            ));
            x += panel.width;
        }
        line("</svg>".to_string());
        svg
    }

    /// The maps in order, each with its teams' cells in team order and its width.
    fn panels(&self) -> Vec<Panel<'_>> {
        self.maps
            .iter()
            .map(|map| {
                let cells: Vec<&TeamMapStats> = self.cells.iter().filter(|c| &c.map == map).collect();
                let label = shorten_start(map, MAP_LABEL_MAX);
                // Wide enough for the columns and for the map's name.
                let width = (cells.len() as f64 * COLUMN).max(text_width(&label) * 1.1) + 2.0 * PANEL_PAD;
                Panel { map, label, cells, width }
            })
            .collect()
    }

    fn legend(&self, room: f64) -> Vec<LegendItem> {
        let mut items = Vec::new();
        let (mut x, mut row) = (0.0, 0);
        for team in &self.teams {
            let item_width = 14.0 + text_width(team) + 18.0;
            if x > 0.0 && x + item_width > room {
                x = 0.0;
                row += 1;
            }
            items.push(LegendItem { name: team.clone(), colour: self.colour(team), x, row });
            x += item_width;
        }
        items
    }

    fn colour(&self, team: &str) -> &'static str {
        let index = self.teams.iter().position(|t| t == team).unwrap_or(0);
        PALETTE[index % PALETTE.len()]
    }
}

/// One map's part of the chart.
struct Panel<'a> {
    map: &'a str,
    label: String,
    cells: Vec<&'a TeamMapStats>,
    width: f64,
}

/// A legend entry, `x` from the left margin, in row `row`.
struct LegendItem {
    name: String,
    colour: &'static str,
    x: f64,
    row: usize,
}

/// A value axis with round steps.
struct Scale {
    lo: f64,
    hi: f64,
    step: f64,
}

impl Scale {
    /// An axis from a multiple of a round step (1, 2, 2.5 or 5 times a power of ten, at
    /// least 1, since ticks are whole) below `min` to one above `max`, about six steps long.
    fn nice(min: f64, max: f64) -> Self {
        let (min, max) = if max > min {
            (min, max)
        } else {
            // One value: centre it in a range a tenth of its size (at least 1 wide).
            let half = (max.abs() * 0.05).max(0.5);
            (min - half, max + half)
        };
        let rough = (max - min) / 6.0;
        // Round steps found by counting rather than by logarithms, whose last bits vary
        // between platforms: the bytes of the chart must not.
        let (mut step, mut power) = (rough.max(1.0), 1.0);
        // 1e40 is beyond any tick count; the bound only keeps a NaN from looping forever.
        for _ in 0..40 {
            // 2.5 only from 25 up, so that labels stay whole.
            let multiples: &[f64] = if power < 10.0 { &[1.0, 2.0, 5.0] } else { &[1.0, 2.0, 2.5, 5.0] };
            if let Some(m) = multiples.iter().map(|m| m * power).find(|&s| s >= rough) {
                step = m;
                break;
            }
            power *= 10.0;
        }
        let lo = (min / step).floor() * step;
        let hi = ((max / step).ceil() * step).max(lo + step);
        Self { lo, hi, step }
    }

    fn steps(&self) -> usize {
        ((self.hi - self.lo) / self.step).round() as usize
    }
}

/// Draws one team's column on one map: whisker, box, dots and median, or a note that
/// nothing was completed.
fn column(
    line: &mut impl FnMut(String),
    cell: &TeamMapStats,
    centre: f64,
    colour: &str,
    y_of: &impl Fn(f64) -> f64,
    mid: f64,
) {
    let values: Vec<f64> = cell.completion_ticks.iter().map(|&t| t as f64).collect();
    let (Some(lo), Some(q1), Some(median), Some(q3), Some(hi)) = (
        quantile(&values, 0.0),
        quantile(&values, 0.25),
        quantile(&values, 0.5),
        quantile(&values, 0.75),
        quantile(&values, 1.0),
    ) else {
        line(format!(
            r##"<text x="{x}" y="{y}" transform="rotate(-90 {x} {y})" text-anchor="middle" fill="#777777">none completed</text>"##,
            x = px(centre + 4.0),
            y = px(mid)
        ));
        return;
    };
    let half_box = COLUMN * 0.3;
    line(format!(
        r#"<g><title>{}: {} of {} completed, median {} ticks</title>"#,
        xml(&cell.team),
        cell.completed,
        cell.matches,
        fixed(median, 1)
    ));
    // Whiskers from the box's ends out to the extremes.
    for (from, to) in [(q3, hi), (q1, lo)] {
        line(format!(
            r#"<line x1="{x}" y1="{}" x2="{x}" y2="{}" stroke="{colour}" stroke-width="1"/>"#,
            px(y_of(from)),
            px(y_of(to)),
            x = px(centre)
        ));
    }
    line(format!(
        r#"<rect x="{}" y="{}" width="{}" height="{}" fill="{colour}" fill-opacity="0.15" stroke="{colour}" stroke-width="1"/>"#,
        px(centre - half_box),
        px(y_of(q3)),
        px(2.0 * half_box),
        px(y_of(q1) - y_of(q3))
    ));
    // Dots spread sideways by the golden-ratio sequence: even, and the same every time.
    for (i, &v) in values.iter().enumerate() {
        let spread = ((i as f64 * 0.618_033_988_75).fract() - 0.5) * COLUMN * 0.5;
        line(format!(
            r##"<circle cx="{}" cy="{}" r="2.6" fill="{colour}" fill-opacity="0.75" stroke="#ffffff" stroke-width="0.5"/>"##,
            px(centre + spread),
            px(y_of(v))
        ));
    }
    line(format!(
        r##"<line x1="{}" y1="{y}" x2="{}" y2="{y}" stroke="#222222" stroke-width="2.5"/>"##,
        px(centre - half_box),
        px(centre + half_box),
        y = px(y_of(median))
    ));
    line("</g>".to_string());
}

/// A coordinate, to a tenth of a pixel.
fn px(x: f64) -> String {
    fixed(x, 1)
}

/// A rough width of `s` in 11-pixel text.
fn text_width(s: &str) -> f64 {
    s.chars().count() as f64 * CHAR_WIDTH
}

/// Text made safe for XML content and attribute values.
fn xml(s: &str) -> String {
    s.chars().fold(String::with_capacity(s.len()), |mut out, c| {
        match c {
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '&' => out.push_str("&amp;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            // Control characters other than tab and line breaks are not allowed in XML 1.0.
            c if c.is_control() && !matches!(c, '\t' | '\n' | '\r') => out.push('\u{fffd}'),
            c => out.push(c),
        }
        out
    })
}

#[cfg(test)]
mod tests {
    use super::super::stats::summarize;
    use super::super::stats::tests::{row, sample};
    use super::*;

    /// Checks that elements nest properly and returns how many there are. Enough for our
    /// own output: no comments, CDATA or `>` inside attribute values.
    fn balanced(svg: &str) -> Result<usize, String> {
        let mut open: Vec<&str> = Vec::new();
        let mut elements = 0;
        let mut rest = svg;
        while let Some(start) = rest.find('<') {
            let Some(len) = rest[start..].find('>') else { return Err("unclosed tag".into()) };
            let tag = &rest[start + 1..start + len];
            rest = &rest[start + len + 1..];
            if let Some(name) = tag.strip_prefix('/') {
                match open.pop() {
                    Some(top) if top == name => {}
                    other => return Err(format!("</{name}> closes {other:?}")),
                }
            } else {
                elements += 1;
                let name = tag.split([' ', '/']).next().unwrap_or_default();
                if !tag.ends_with('/') {
                    open.push(name);
                }
            }
            if open.is_empty() && !rest.trim().is_empty() {
                return Err(format!("content after the root: {rest:?}"));
            }
        }
        if open.is_empty() { Ok(elements) } else { Err(format!("unclosed {open:?}")) }
    }

    #[test]
    fn chart_is_well_formed_and_stable() {
        let s = summarize(&sample(), 60.0);
        let svg = s.to_svg();
        assert!(svg.starts_with("<svg xmlns=\"http://www.w3.org/2000/svg\""), "{svg}");
        assert!(svg.ends_with("</svg>\n"));
        assert!(balanced(&svg).is_ok_and(|n| n > 20), "{:?}", balanced(&svg));
        assert_eq!(svg, summarize(&sample(), 60.0).to_svg());
        // The same rows in another order give the same chart.
        let mut reversed = sample();
        reversed.reverse();
        reversed.sort_by_key(|r| r.team != "coop");
        let mut by_map = reversed.clone();
        by_map.sort_by_key(|r| r.map != "default");
        assert_eq!(svg, summarize(&by_map, 60.0).to_svg());
    }

    #[test]
    fn chart_shows_teams_maps_and_counts() {
        let svg = summarize(&sample(), 60.0).to_svg();
        // One dot per completed match, plus one per team in the legend.
        assert_eq!(svg.matches("<circle").count(), 9 + 2);
        assert!(svg.contains(">coop</text>") && svg.contains(">baseline</text>"));
        assert!(
            svg.contains("<title>default</title>default</text>")
                && svg.contains("<title>fixed</title>fixed</text>")
        );
        assert!(svg.contains(">4/4</text>") && svg.contains(">3/4</text>") && svg.contains(">0/4</text>"));
        assert!(svg.contains(">none completed</text>"));
        assert!(svg.contains(">ticks to complete</text>"));
        // The axis spans the data (800 to 1600) in round steps.
        assert!(svg.contains(">800</text>") && svg.contains(">1600</text>"), "{svg}");
        assert!(
            svg.contains(&format!("fill=\"{}\"", PALETTE[0]))
                && svg.contains(&format!("fill=\"{}\"", PALETTE[1]))
        );
    }

    #[test]
    fn text_is_escaped() {
        let svg = summarize(&[row("a<b & \"c\"", "m'1>", 1, Some(10))], 1.0).to_svg();
        assert!(svg.contains("a&lt;b &amp; &quot;c&quot;") && svg.contains("m&apos;1&gt;"), "{svg}");
        assert!(balanced(&svg).is_ok(), "{:?}", balanced(&svg));
        assert_eq!(xml("x\u{1}y"), "x\u{fffd}y");
    }

    #[test]
    fn empty_and_uncompleted_charts() {
        let svg = summarize(&[], 0.0).to_svg();
        assert!(svg.starts_with("<svg") && svg.contains("No matches.") && balanced(&svg).is_ok(), "{svg}");
        let svg = summarize(&[row("t", "m", 1, None), row("u", "m", 1, None)], 1.0).to_svg();
        assert!(svg.contains("No match was completed.") && balanced(&svg).is_ok(), "{svg}");
    }

    #[test]
    fn many_teams_and_long_names_widen_the_chart() {
        let rows: Vec<_> = (0..12)
            .map(|t| {
                row(
                    &format!("team number {t}"),
                    "../elsewhere/maps/a/b/c/a long, long map name.toml",
                    1,
                    Some(100 + t),
                )
            })
            .collect();
        let svg = summarize(&rows, 1.0).to_svg();
        assert!(balanced(&svg).is_ok(), "{:?}", balanced(&svg));
        // Colours repeat after the palette; the legend wraps onto more rows.
        assert!(svg.matches(&format!("fill=\"{}\"", PALETTE[0])).count() >= 2);
        assert!(svg.contains(">…e/maps/a/b/c/a long, long map name.toml</text>"), "{svg}");
    }

    #[test]
    fn scales_are_round() {
        let s = Scale::nice(1000.0, 1300.0);
        assert_eq!((s.lo, s.hi, s.step, s.steps()), (1000.0, 1300.0, 50.0, 6));
        let s = Scale::nice(903.0, 2096.0);
        assert_eq!((s.lo, s.hi, s.step), (800.0, 2200.0, 200.0));
        // 1400 / 6 = 233: a step of 250.
        let s = Scale::nice(1000.0, 2400.0);
        assert_eq!((s.lo, s.hi, s.step), (1000.0, 2500.0, 250.0));
        // Below 10, no 2.5: 12 / 6 = 2.
        let s = Scale::nice(1.0, 13.0);
        assert_eq!((s.lo, s.hi, s.step), (0.0, 14.0, 2.0));
        let s = Scale::nice(800.0, 1600.0);
        assert_eq!((s.lo, s.hi, s.step), (800.0, 1600.0, 200.0));
        let s = Scale::nice(10.0, 10.0);
        assert!(s.lo < 10.0 && s.hi > 10.0 && s.step >= 1.0);
        let s = Scale::nice(3.0, 4.0);
        assert_eq!((s.lo, s.hi, s.step), (3.0, 4.0, 1.0));
    }
}
