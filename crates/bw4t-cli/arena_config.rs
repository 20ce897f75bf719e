//! `bw4t serve --config FILE.toml`: the server's match templates and settings, read and
//! checked into the arena's types. Every problem names the file and the template.

use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::{Context, Result, bail};
use bw4t_agents::{MatchSetup, Seat, Strategy, bot_name};
use bw4t_protocol::Mode;
use bw4t_server::{HostConfig, OnEnd, Template};
use bw4t_sim::MatchConfig;
use serde::Deserialize;

/// The file, as written.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct ArenaFile {
    /// The match or template that a `hello` naming neither joins.
    pub default: Option<String>,
    /// The operator's token (the API's credential; `--operator-token` overrides it).
    pub operator_token: Option<String>,
    /// Where results, the index and replays go (`--results-dir` overrides it), relative
    /// to the file.
    pub results_dir: Option<PathBuf>,
    /// Connections accepted at once.
    pub max_connections: Option<usize>,
    /// Connections one source address may have open at once.
    pub max_per_source: Option<usize>,
    /// Reverse proxies whose `X-Forwarded-For` names a web client's address.
    #[serde(default)]
    pub trusted_proxies: Vec<std::net::IpAddr>,
    /// The templates.
    #[serde(default, rename = "template")]
    pub templates: Vec<TemplateFile>,
}

/// One `[[template]]`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct TemplateFile {
    name: String,
    map: Option<String>,
    maps: Option<Vec<String>>,
    #[serde(default = "three")]
    robots: usize,
    #[serde(default)]
    builtin: usize,
    strategy: Option<String>,
    #[serde(default)]
    names: Vec<String>,
    teams: Option<usize>,
    mode: Option<String>,
    #[serde(default = "twenty")]
    tick_hz: u32,
    max_ticks: Option<u64>,
    seed: Option<u64>,
    token: Option<String>,
    spectator_token: Option<String>,
    #[serde(default)]
    spectators_see_private: bool,
    max_running: Option<usize>,
    on_end: Option<String>,
    start_timeout_s: Option<u64>,
    #[serde(default)]
    fill: bool,
    #[serde(default)]
    replays: bool,
    deadline_ms: Option<u64>,
    grace_s: Option<u64>,
    #[serde(default)]
    robot_collisions: bool,
}

fn three() -> usize {
    3
}

fn twenty() -> u32 {
    20
}

/// A server's settings read from a file.
pub(crate) struct ArenaSettings {
    pub templates: Vec<Template>,
    pub default: Option<String>,
    pub operator_token: Option<String>,
    pub results_dir: Option<PathBuf>,
    pub max_connections: Option<usize>,
    pub max_per_source: Option<usize>,
    pub trusted_proxies: Vec<std::net::IpAddr>,
}

/// Reads and checks `path`; `seed` is the first match's seed of templates that fix none.
pub(crate) fn load(path: &Path, seed: u64) -> Result<ArenaSettings> {
    let text = std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let file: ArenaFile =
        toml::from_str(&text).with_context(|| format!("{}: not a server configuration", path.display()))?;
    let base = path.parent().unwrap_or(Path::new("."));
    if file.templates.is_empty() {
        bail!("{}: no [[template]]: a server needs at least one", path.display());
    }
    let mut templates = Vec::new();
    for t in file.templates {
        let name = t.name.clone();
        let template =
            template(t, base, seed).with_context(|| format!("{}: template '{name}'", path.display()))?;
        if templates.iter().any(|other: &Template| other.name == template.name) {
            bail!("{}: two templates are named '{name}'", path.display());
        }
        templates.push(template);
    }
    if let Some(default) = &file.default {
        let known = templates.iter().any(|t| &t.name == default || t.names.contains(default));
        if !known {
            bail!("{}: default = '{default}' names no template and no match of one", path.display());
        }
    }
    Ok(ArenaSettings {
        default: file
            .default
            .or_else(|| templates.first().map(|t| t.names.first().unwrap_or(&t.name).clone())),
        templates,
        operator_token: file.operator_token,
        results_dir: file.results_dir.map(|d| base.join(d)),
        max_connections: file.max_connections,
        max_per_source: file.max_per_source,
        trusted_proxies: file.trusted_proxies,
    })
}

/// The names `team-a`, `team-b`, ... for `teams = N` (after `z`: `team-aa`, ...).
fn team_names(n: usize) -> Vec<String> {
    (0..n)
        .map(|mut i| {
            let mut letters = Vec::new();
            loop {
                letters.push((b'a' + (i % 26) as u8) as char);
                if i < 26 {
                    break;
                }
                i = i / 26 - 1;
            }
            format!("team-{}", letters.iter().rev().collect::<String>())
        })
        .collect()
}

fn template(t: TemplateFile, base: &Path, seed: u64) -> Result<Template> {
    bw4t_server::check_match_name(&t.name).map_err(|e| anyhow::anyhow!("{e}"))?;
    let specs = match (t.map, t.maps) {
        (Some(_), Some(_)) => bail!("give map or maps, not both"),
        (Some(map), None) => vec![map],
        (None, Some(maps)) if !maps.is_empty() => maps,
        (None, Some(_)) => bail!("maps = []: give at least one map"),
        (None, None) => vec!["default".to_string()],
    };
    let maps = specs
        .iter()
        .map(|spec| {
            // A path is relative to the file; a shipped name stays a name.
            let path = base.join(spec);
            let spec = if path.exists() { path.to_string_lossy().into_owned() } else { spec.clone() };
            crate::maps::load(&spec)
        })
        .collect::<Result<Vec<_>>>()?;
    let mut setup = MatchSetup::new(maps[0].clone());
    setup.seed = t.seed.unwrap_or(seed);
    setup.game = MatchConfig {
        ticks_per_second: t.tick_hz,
        robot_collisions: t.robot_collisions,
        ..MatchConfig::default()
    };
    setup.game.validate().context("tick_hz")?;
    let mut config = HostConfig::new();
    config.mode = match t.mode.as_deref() {
        None | Some("realtime") => Mode::Realtime,
        Some("lockstep") => Mode::Lockstep,
        Some(other) => bail!("mode = '{other}': expected \"realtime\" or \"lockstep\""),
    };
    for map in &maps {
        if t.robots == 0 || t.robots > map.spawns().len() {
            bail!("robots = {} but map '{}' has {} spawn points", t.robots, map.name(), map.spawns().len());
        }
    }
    if t.builtin > t.robots {
        bail!(
            "builtin = {} but robots = {}: robots counts every player, built-in ones included",
            t.builtin,
            t.robots
        );
    }
    let strategy = match t.strategy.as_deref() {
        None => Strategy::Cooperative,
        Some(name) => Strategy::named(name).with_context(|| {
            let known: Vec<&str> = Strategy::ALL.iter().map(|s| s.name()).collect();
            format!("strategy = '{name}': expected one of {}", known.join(", "))
        })?,
    };
    setup.max_ticks = match t.max_ticks {
        Some(0) => None,
        Some(ticks) => Some(ticks),
        None => Some(bw4t_runner::TickLimit::for_map(&maps[0], &setup.game).ticks),
    };
    config.deadline = match t.deadline_ms {
        Some(0) => None,
        Some(ms) => Some(Duration::from_millis(ms)),
        None => config.deadline,
    };
    if let Some(grace) = t.grace_s {
        config.grace = Duration::from_secs(grace);
    }
    config.token = t.token;
    config.spectator_token = t.spectator_token;
    config.spectators_see_private = t.spectators_see_private;
    config.start_timeout = t.start_timeout_s.map(Duration::from_secs);
    if t.fill && config.start_timeout.is_none() {
        bail!("fill = true needs start_timeout_s: the seats are filled when the timeout passes");
    }
    config.fill = t.fill.then_some(strategy);
    config.check().map_err(anyhow::Error::msg)?;
    let names = match (t.teams, t.names.is_empty()) {
        (Some(_), false) => bail!("give names or teams, not both"),
        (Some(n), true) => team_names(n),
        (None, _) => t.names,
    };
    for name in &names {
        bw4t_server::check_match_name(name).map_err(|e| anyhow::anyhow!("names: {e}"))?;
    }
    let on_end = match t.on_end.as_deref() {
        None => OnEnd::Stay,
        Some(word) => OnEnd::NAMES
            .iter()
            .find(|(w, _)| *w == word)
            .map(|(_, e)| *e)
            .with_context(|| format!("on_end = '{word}': expected \"stay\", \"restart\" or \"next\""))?,
    };
    let builtin = (0..t.builtin).map(|i| Seat::builtin(bot_name(i), strategy));
    setup.seats = builtin.chain(std::iter::repeat_with(Seat::open)).take(t.robots).collect();
    Ok(Template {
        name: t.name,
        setup,
        config,
        maps,
        max_running: t.max_running.unwrap_or(if names.is_empty() { 100 } else { names.len() }),
        names,
        on_end,
        replays: t.replays,
        lateness: None,
        invited_only: false,
    })
}

#[cfg(test)]
mod tests {
    use super::team_names;

    #[test]
    fn teams_are_named_by_letters() {
        let names = team_names(28);
        assert_eq!(
            (names[0].as_str(), names[25].as_str(), names[26].as_str()),
            ("team-a", "team-z", "team-aa")
        );
        assert_eq!(names[27], "team-ab");
    }
}
