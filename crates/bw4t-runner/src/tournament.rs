//! Running a tournament (described by `bw4t-tournament`): matches on a pool of threads,
//! rows appended and flushed as each match ends, resumable, shardable, and shards merged
//! back into one.

use std::collections::{BTreeMap, BTreeSet};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, mpsc};
use std::time::{Duration, Instant};

use bw4t_map::Map;
use bw4t_protocol::{AgentStatus, EndReason, MatchResult, MessagePolicy};
use bw4t_sim::MatchConfig;
use bw4t_tournament::{
    Machine, Manifest, ManifestError, MapLimit, Planned, ReplayPolicy, Resolved, Row, Setup, Shard, Summary,
    seats, summarize,
};

use crate::external::{AgentReport, ServedRun, play_served};
use crate::headless::play;
use crate::limit::TickLimit;
use bw4t_agents::{MatchSetup, Player};

/// How to run a tournament.
#[derive(Clone, Debug)]
pub struct Options {
    /// The output directory.
    pub out: PathBuf,
    /// Matches played at once.
    pub concurrency: usize,
    /// Replays to keep.
    pub replays: ReplayPolicy,
    /// Skip the matches already in `matches.jsonl`.
    pub resume: bool,
    /// Play only this share of the matches.
    pub shard: Option<Shard>,
    /// How long external agents have to connect.
    pub connect_timeout: Duration,
    /// Set (by a signal handler) to stop: no new match starts, matches of external agents
    /// under way are interrupted and not recorded, so `--resume` plays them again.
    pub stop: Arc<AtomicBool>,
}

/// Where a tournament stands, for progress displays.
#[derive(Clone, Debug)]
pub struct Progress {
    /// Matches finished (including those found when resuming).
    pub done: usize,
    /// Matches in this run (including those found when resuming).
    pub total: usize,
    /// Finished matches that did not complete the sequence.
    pub failures: usize,
    /// Time since this run started.
    pub elapsed: Duration,
    /// Matches played in this run so far.
    pub played: usize,
    /// Matches this run has to play.
    pub to_play: usize,
    /// The match that just finished.
    pub last: Option<Row>,
}

/// What a tournament run leaves behind.
#[derive(Clone, Debug)]
pub struct Outcome {
    /// Every row of the directory, in match order.
    pub rows: Vec<Row>,
    /// Matches played in this run.
    pub played: usize,
    /// Matches skipped because they were already done.
    pub skipped: usize,
    /// The summary written.
    pub summary: Summary,
    /// Whether the run was stopped before every match was played.
    pub stopped: bool,
}

/// Why a tournament could not run.
#[derive(Debug, thiserror::Error)]
pub enum TournamentError {
    /// A file could not be read or written.
    #[error("{0}")]
    Io(String),
    /// The output directory holds something else.
    #[error("{0}")]
    Directory(String),
    /// A tournament directory's `manifest.json` cannot be read as one.
    #[error("{} is not a manifest this version of bw4t reads: {problem}", path.display())]
    Manifest {
        /// The file.
        path: PathBuf,
        /// What is wrong with it (said in the message, so not a separate cause).
        problem: ManifestError,
    },
}

fn io(what: impl std::fmt::Display, e: impl std::fmt::Display) -> TournamentError {
    TournamentError::Io(format!("{what}: {e}"))
}

/// Runs (or resumes) a tournament. `maps[i]` is `resolved.maps[i]` loaded.
pub fn run_tournament(
    resolved: &Resolved,
    maps: &[Map],
    options: &Options,
    on_progress: &mut dyn FnMut(&Progress),
) -> Result<Outcome, TournamentError> {
    let out = &options.out;
    std::fs::create_dir_all(out).map_err(|e| io(format!("cannot create {}", out.display()), e))?;
    let jsonl = out.join("matches.jsonl");
    let mut previous_elapsed = 0.0;
    let mut rows: Vec<Row> = Vec::new();
    if jsonl.exists() {
        if !options.resume {
            return Err(TournamentError::Directory(format!(
                "{} already holds a tournament: add --resume to finish it, or choose another --out",
                out.display()
            )));
        }
        let old = read_manifest(out)?;
        if old.config != *resolved || old.shard != options.shard {
            return Err(TournamentError::Directory(format!(
                "{} holds a tournament with another configuration or shard; it cannot be resumed with this one",
                out.display()
            )));
        }
        previous_elapsed = old.elapsed_seconds;
        rows = read_rows(&jsonl)?;
    }
    let setup = setup(resolved, maps);
    let mut manifest = Manifest {
        program: crate::program(),
        created_unix: std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_secs()),
        machine: machine(options.concurrency),
        config_hash: resolved.config_hash(),
        config: resolved.clone(),
        setup: setup.clone(),
        shard: options.shard,
        concurrency: options.concurrency,
        replays: options.replays,
        elapsed_seconds: previous_elapsed,
        merged_from: None,
    };
    write_manifest(out, &manifest)?;
    // Rewrite the row files from the rows that survived (a kill can leave half a line).
    rewrite_rows(out, &rows)?;

    let done: BTreeSet<String> = rows.iter().map(|r| r.key.clone()).collect();
    let planned: Vec<Planned> = resolved
        .plan()
        .into_iter()
        .filter(|p| options.shard.is_none_or(|shard| shard.plays(resolved, p)))
        .filter(|p| !done.contains(&p.key))
        .collect();
    let skipped = rows.len();
    let started = Instant::now();
    let total = skipped + planned.len();
    let mut progress = Progress {
        done: skipped,
        total,
        failures: rows.iter().filter(|r| !r.completed).count(),
        elapsed: Duration::ZERO,
        played: 0,
        to_play: planned.len(),
        last: None,
    };
    on_progress(&progress);

    let next = AtomicUsize::new(0);
    let (tx, rx) = mpsc::channel::<(Row, Option<Vec<u8>>)>();
    let mut files = RowFiles::open(out)?;
    let mut write_error = None;
    std::thread::scope(|scope| {
        for _ in 0..options.concurrency.max(1).min(planned.len().max(1)) {
            let tx = tx.clone();
            let (planned, next) = (&planned, &next);
            let limits = &setup.tick_limits;
            scope.spawn(move || {
                while !options.stop.load(Ordering::SeqCst) {
                    let Some(p) = planned.get(next.fetch_add(1, Ordering::SeqCst)) else { break };
                    let max_ticks = limits[p.map].max_ticks;
                    if tx.send(play_one(resolved, maps, p, max_ticks, options)).is_err() {
                        break;
                    }
                }
            });
        }
        drop(tx);
        for (mut row, replay) in rx {
            // A match cut short by a stop is played again on resume, so it leaves no row.
            if options.stop.load(Ordering::SeqCst) && row.end_reason == EndReason::Interrupted {
                continue;
            }
            if let Some(bytes) = replay {
                let keep = match options.replays {
                    ReplayPolicy::All => true,
                    ReplayPolicy::Failed => !row.completed,
                    ReplayPolicy::None => false,
                };
                if keep {
                    let rel = format!("replays/{}.jsonl", file_safe(&row.key));
                    let written = std::fs::create_dir_all(out.join(REPLAYS))
                        .and_then(|()| std::fs::write(out.join(&rel), &bytes));
                    if written.is_ok() {
                        row.replay = Some(rel);
                    }
                }
            }
            if let Err(e) = files.append(&row) {
                write_error.get_or_insert(e);
            }
            progress.done += 1;
            progress.played += 1;
            progress.failures += usize::from(!row.completed);
            progress.elapsed = started.elapsed();
            progress.last = Some(row.clone());
            rows.push(row);
            on_progress(&progress);
        }
    });
    if let Some(e) = write_error {
        return Err(e);
    }
    rows.sort_by_key(|r| r.index);
    let elapsed = previous_elapsed + started.elapsed().as_secs_f64();
    manifest.elapsed_seconds = elapsed;
    write_manifest(out, &manifest)?;
    let stopped = rows.len() < total;
    let summary = write_summary(out, &rows, elapsed, setup)?;
    Ok(Outcome { rows, played: progress.played, skipped, summary, stopped })
}

/// Each map's tick limit (the configuration's, or the map's own) and, when there are several
/// seeds, the maps whose content ignores the match seed. `maps[i]` is `resolved.maps[i]` loaded.
pub fn setup(resolved: &Resolved, maps: &[Map]) -> Setup {
    let tick_limits = resolved
        .maps
        .iter()
        .zip(maps)
        .map(|(spec, map)| match resolved.max_ticks {
            Some(max_ticks) => {
                MapLimit { map: spec.clone(), max_ticks, from: "config".into(), explanation: None }
            }
            None => {
                let limit = TickLimit::for_map(map, &MatchConfig::default());
                MapLimit {
                    map: spec.clone(),
                    max_ticks: limit.ticks,
                    from: "map".into(),
                    explanation: Some(limit.explain()),
                }
            }
        })
        .collect();
    // With one seed there is nothing to tell apart.
    let fixed_content_maps = resolved
        .maps
        .iter()
        .zip(maps)
        .filter(|(_, map)| resolved.seeds.len() > 1 && map.seed().is_some())
        .map(|(spec, _)| spec.clone())
        .collect();
    Setup { tick_limits, fixed_content_maps }
}

/// What a merge found beside the rows.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct MergeReport {
    /// The tournament directories joined (a directory of shards stands for its shards).
    pub sources: Vec<PathBuf>,
    /// The configuration's hash (every source's).
    pub config_hash: String,
    /// Matches of the configuration no source has, by key, in match order.
    pub missing: Vec<String>,
    /// Matches more than one source has with the same digest (one is kept).
    pub duplicates: Vec<String>,
    /// Matches two sources have with different digests (the first source's is kept):
    /// they were not played alike, which a deterministic team never does.
    pub conflicting: Vec<String>,
    /// Matches whose row names a replay outside its source's `replays/` (an absolute path,
    /// `..`, a subfolder): the replay is not copied and the row keeps none.
    pub stray_replays: Vec<String>,
}

/// The folder of a tournament directory that holds its replays.
const REPLAYS: &str = "replays";

/// The file name of a row's `replay` (`replays/FILE`), if it names a file directly in
/// `replays/` and nothing else.
fn replay_file(rel: &str) -> Option<&std::ffi::OsStr> {
    use std::path::Component;
    let mut parts = Path::new(rel).components();
    match (parts.next(), parts.next(), parts.next()) {
        (Some(Component::Normal(folder)), Some(Component::Normal(file)), None) if folder == REPLAYS => {
            Some(file)
        }
        _ => None,
    }
}

/// The tournament directories `dirs` stand for: each directory with a `manifest.json`,
/// and for a directory without one, its `shard-I-of-N` subdirectories (what
/// `--shard auto` writes), in order.
pub fn tournament_dirs(dirs: &[PathBuf]) -> Result<Vec<PathBuf>, TournamentError> {
    let mut found = Vec::new();
    for dir in dirs {
        if dir.join("manifest.json").exists() {
            found.push(dir.clone());
            continue;
        }
        let entries = std::fs::read_dir(dir).map_err(|e| io(format!("cannot read {}", dir.display()), e))?;
        let mut shards: Vec<(Shard, PathBuf)> = entries
            .filter_map(|e| e.ok())
            .filter_map(|e| Some((Shard::from_dir_name(e.file_name().to_str()?)?, e.path())))
            .filter(|(_, path)| path.join("manifest.json").exists())
            .collect();
        if shards.is_empty() {
            return Err(TournamentError::Directory(format!(
                "{} is neither a tournament directory (no manifest.json) nor holds shard directories (shard-I-of-N)",
                dir.display()
            )));
        }
        shards.sort_by_key(|(shard, _)| (shard.count, shard.index));
        found.extend(shards.into_iter().map(|(_, path)| path));
    }
    Ok(found)
}

/// Joins tournament directories (shards, or separate runs of one configuration) into
/// `out`: one row per match, with its replay, and a new summary. Every source must hold
/// the same configuration (its hash is compared); matches none holds, and matches
/// several hold, are reported.
pub fn merge(dirs: &[PathBuf], out: &Path) -> Result<(Outcome, MergeReport), TournamentError> {
    let sources = tournament_dirs(dirs)?;
    if out.join("matches.jsonl").exists() {
        return Err(TournamentError::Directory(format!("{} already holds a tournament", out.display())));
    }
    let mut first: Option<(Manifest, &PathBuf)> = None;
    let mut report = MergeReport { sources: sources.clone(), ..MergeReport::default() };
    let (mut rows, mut digests, mut elapsed) = (Vec::new(), BTreeMap::new(), 0.0);
    let mut reads = Vec::new();
    for dir in &sources {
        let mut m = read_manifest(dir)?;
        if m.config_hash.is_empty() {
            m.config_hash = m.config.config_hash();
        }
        match &first {
            Some((f, fdir)) if m.config_hash != f.config_hash || m.config != f.config => {
                return Err(TournamentError::Directory(format!(
                    "{} holds configuration {} but {} holds {}: they are not shards of one tournament",
                    dir.display(),
                    m.config_hash,
                    fdir.display(),
                    f.config_hash
                )));
            }
            Some(_) => {}
            None => first = Some((m.clone(), dir)),
        }
        elapsed += m.elapsed_seconds;
        reads.push((dir, read_rows(&dir.join("matches.jsonl"))?));
    }
    let Some((first, _)) = first else {
        return Err(TournamentError::Directory("no directories to merge".into()));
    };
    std::fs::create_dir_all(out).map_err(|e| io(format!("cannot create {}", out.display()), e))?;
    for (dir, read) in reads {
        for mut row in read {
            match digests.get(&row.key) {
                Some(digest) if *digest == row.digest => report.duplicates.push(row.key.clone()),
                Some(_) => report.conflicting.push(row.key.clone()),
                None => {
                    digests.insert(row.key.clone(), row.digest.clone());
                    if let Some(rel) = row.replay.take() {
                        // A row is read from a file anyone could have written: only a
                        // file directly in the shard's `replays/` is read, and it is
                        // written to the same place under `out`.
                        let Some(file) = replay_file(&rel) else {
                            report.stray_replays.push(row.key.clone());
                            rows.push(row);
                            continue;
                        };
                        let copied = std::fs::create_dir_all(out.join(REPLAYS)).and_then(|()| {
                            std::fs::copy(dir.join(REPLAYS).join(file), out.join(REPLAYS).join(file))
                        });
                        row.replay = copied.ok().map(|_| rel);
                    }
                    rows.push(row);
                }
            }
        }
    }
    rows.sort_by_key(|r| r.index);
    report.config_hash = first.config_hash.clone();
    report.missing =
        first.config.plan().into_iter().map(|p| p.key).filter(|k| !digests.contains_key(k)).collect();
    let manifest = Manifest {
        shard: None,
        merged_from: Some(sources.iter().map(|d| d.display().to_string()).collect()),
        elapsed_seconds: elapsed,
        ..first
    };
    write_manifest(out, &manifest)?;
    rewrite_rows(out, &rows)?;
    let summary = write_summary(out, &rows, elapsed, manifest.setup)?;
    Ok((Outcome { played: 0, skipped: rows.len(), rows, summary, stopped: false }, report))
}

fn write_summary(out: &Path, rows: &[Row], elapsed: f64, setup: Setup) -> Result<Summary, TournamentError> {
    let summary = summarize(rows, elapsed).with_setup(setup);
    let write = |name: &str, text: String| {
        std::fs::write(out.join(name), text).map_err(|e| io(format!("cannot write {name}"), e))
    };
    write("summary.md", summary.to_markdown())?;
    write("summary.json", serde_json::to_string_pretty(&summary.to_json()).unwrap_or_default() + "\n")?;
    write("summary.svg", summary.to_svg())?;
    Ok(summary)
}

/// The machine this program runs on, playing `concurrency` matches at once.
fn machine(concurrency: usize) -> Machine {
    let host = std::fs::read_to_string("/etc/hostname").map(|h| h.trim().to_string()).unwrap_or_default();
    Machine {
        os: std::env::consts::OS.into(),
        arch: std::env::consts::ARCH.into(),
        cores: std::thread::available_parallelism().map_or(1, |n| n.get()),
        concurrency,
        host,
    }
}

/// The manifest of tournament directory `dir`.
pub fn read_manifest(dir: &Path) -> Result<Manifest, TournamentError> {
    let path = dir.join("manifest.json");
    let text =
        std::fs::read_to_string(&path).map_err(|e| io(format!("cannot read {}", path.display()), e))?;
    Manifest::parse(&text).map_err(|problem| TournamentError::Manifest { path, problem })
}

fn write_manifest(out: &Path, manifest: &Manifest) -> Result<(), TournamentError> {
    let path = out.join("manifest.json");
    std::fs::write(&path, manifest.to_json()).map_err(|e| io(format!("cannot write {}", path.display()), e))
}

/// The rows of a `matches.jsonl`; a torn last line (from a kill) is left out.
/// The rows of a `matches.jsonl` file (a tournament's, or a server's index of results).
pub fn read_rows(path: &Path) -> Result<Vec<Row>, TournamentError> {
    let text = std::fs::read_to_string(path).map_err(|e| io(format!("cannot read {}", path.display()), e))?;
    Row::parse_lines(&text).map_err(|(line, e)| io(format!("{} line {line}", path.display()), e))
}

fn rewrite_rows(out: &Path, rows: &[Row]) -> Result<(), TournamentError> {
    let _ = std::fs::remove_file(out.join("matches.jsonl"));
    let _ = std::fs::remove_file(out.join("matches.csv"));
    let mut files = RowFiles::open(out)?;
    rows.iter().try_for_each(|r| files.append(r))
}

/// `matches.jsonl` and `matches.csv`, appended and flushed row by row.
struct RowFiles {
    jsonl: std::fs::File,
    csv: csv::Writer<std::fs::File>,
}

impl RowFiles {
    fn open(out: &Path) -> Result<RowFiles, TournamentError> {
        let open = |name: &str| {
            std::fs::OpenOptions::new()
                .create(true)
                .append(true)
                .open(out.join(name))
                .map_err(|e| io(format!("cannot open {name}"), e))
        };
        let csv_new = !out.join("matches.csv").exists();
        let mut csv = csv::WriterBuilder::new().has_headers(false).from_writer(open("matches.csv")?);
        if csv_new {
            csv.write_record(Row::csv_header())
                .and_then(|()| Ok(csv.flush()?))
                .map_err(|e| io("matches.csv", e))?;
        }
        Ok(RowFiles { jsonl: open("matches.jsonl")?, csv })
    }

    fn append(&mut self, row: &Row) -> Result<(), TournamentError> {
        let line = serde_json::to_string(row).map_err(|e| io("row", e))?;
        writeln!(self.jsonl, "{line}")
            .and_then(|()| self.jsonl.flush())
            .map_err(|e| io("matches.jsonl", e))?;
        self.csv.write_record(row.csv_record()).map_err(|e| io("matches.csv", e))?;
        self.csv.flush().map_err(|e| io("matches.csv", e))
    }
}

/// A key made safe as a file name.
fn file_safe(key: &str) -> String {
    key.chars().map(|c| if c.is_ascii_alphanumeric() || c == '-' || c == '.' { c } else { '_' }).collect()
}

/// Plays one planned match; a match that cannot run becomes a row with end reason `error`.
fn play_one(
    resolved: &Resolved,
    maps: &[Map],
    p: &Planned,
    max_ticks: u64,
    options: &Options,
) -> (Row, Option<Vec<u8>>) {
    let team = &resolved.teams[p.team];
    let map = &maps[p.map];
    let buffer = SharedBuffer::default();
    let want_replay = options.replays != ReplayPolicy::None;
    let played: Result<(MatchResult, Vec<AgentReport>, bool), String> = seats(team).and_then(|seats| {
        let external = seats.iter().any(|s| matches!(s.player, Player::Program(_)));
        let setup =
            MatchSetup { seed: p.seed, seats, max_ticks: Some(max_ticks), ..MatchSetup::new(map.clone()) };
        if external {
            let log_dir = options.out.join("logs").join(file_safe(&p.key));
            let replay: Option<Box<dyn Write + Send>> =
                want_replay.then(|| Box::new(buffer.clone()) as Box<dyn Write + Send>);
            play_served(ServedRun {
                setup,
                deadline: (resolved.deadline_ms > 0).then(|| Duration::from_millis(resolved.deadline_ms)),
                connect_timeout: options.connect_timeout,
                log_dir: &log_dir,
                replay,
                stop: Some(options.stop.clone()),
                wall_budget: resolved.wall_budget_s.map(Duration::from_secs),
                language: if resolved.messages { MessagePolicy::default() } else { MessagePolicy::silence() },
            })
            .map(|served| (served.result, served.agents, served.out_of_time))
            .map_err(|e| e.to_string())
        } else {
            let replay = want_replay.then(|| Box::new(buffer.clone()) as Box<dyn Write + Send>);
            let played = play(&setup, replay).map_err(|e| e.to_string())?;
            Ok((played.0, played.1, false))
        }
    });
    // A match that could not run is a row too, with end reason `error`.
    let mut row = Row::unplayed(
        p.key.clone(),
        p.index,
        team.name.clone(),
        resolved.maps[p.map].clone(),
        p.seed,
        team.robots,
    );
    row.repetition = p.repetition;
    match played {
        Ok((result, agents, out_of_time)) => {
            row.record(&result);
            row.out_of_time = out_of_time;
            row.crashed_agents = agents.iter().filter(|a| a.status != AgentStatus::Ok).count() as u32;
        }
        Err(message) => row.error = Some(message),
    }
    let bytes = want_replay.then(|| buffer.take()).filter(|b| !b.is_empty());
    (row, bytes)
}

/// A byte buffer shared with a replay recorder.
#[derive(Clone, Default)]
struct SharedBuffer(Arc<Mutex<Vec<u8>>>);

impl SharedBuffer {
    fn take(&self) -> Vec<u8> {
        self.0.lock().map(|mut b| std::mem::take(&mut *b)).unwrap_or_default()
    }
}

impl Write for SharedBuffer {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let mut inner = self.0.lock().map_err(|_| std::io::Error::other("replay buffer poisoned"))?;
        inner.extend_from_slice(buf);
        Ok(buf.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bw4t_tournament::TournamentConfig;

    /// A fresh directory for one test.
    fn temp(tag: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("bw4t-runner-tournament-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        dir
    }

    fn options(out: &Path) -> Options {
        Options {
            out: out.to_path_buf(),
            concurrency: 1,
            replays: ReplayPolicy::None,
            resume: false,
            shard: None,
            connect_timeout: Duration::from_secs(5),
            stop: Arc::new(AtomicBool::new(false)),
        }
    }

    fn resolved(seeds: &str) -> Resolved {
        let text = format!(
            "maps = [\"fixed\"]\nseeds = {seeds}\nmax_ticks = 200\n[[team]]\nname = \"coop\"\nagents = \"builtin\"\nrobots = 1\n"
        );
        TournamentConfig::parse(&text).and_then(|c| c.resolve()).expect("valid")
    }

    #[test]
    fn the_manifest_is_read_back_by_resume_and_merge_and_a_broken_one_is_named() {
        let dir = temp("manifest");
        let map = Map::parse(include_str!("../../../maps/fixed.toml"), "fixed").expect("the shipped map");
        let maps = [map];
        let (run, merged) = (dir.join("run"), dir.join("merged"));
        let config = resolved("[1, 2]");
        let outcome = run_tournament(&config, &maps, &options(&run), &mut |_| {}).expect("runs");
        assert_eq!(outcome.rows.len(), 2);
        let text = std::fs::read_to_string(run.join("manifest.json")).expect("manifest");
        let manifest = Manifest::parse(&text).expect("a manifest");
        assert_eq!(
            (&manifest.config, manifest.shard, manifest.replays, manifest.setup.tick_limits[0].max_ticks),
            (&config, None, ReplayPolicy::None, 200)
        );
        assert_eq!(manifest.program, crate::program());

        // Resuming with the same configuration plays nothing; with another, it is refused.
        let resume = Options { resume: true, ..options(&run) };
        let again = run_tournament(&config, &maps, &resume, &mut |_| {}).expect("resumes");
        assert_eq!((again.played, again.skipped), (0, 2));
        let other =
            run_tournament(&resolved("[3]"), &maps, &resume, &mut |_| {}).expect_err("another config");
        assert!(other.to_string().contains("another configuration"), "{other}");

        let (outcome, report) = merge(std::slice::from_ref(&run), &merged).expect("merges");
        assert_eq!(
            (outcome.rows.len(), report.missing.len(), report.config_hash),
            (2, 0, config.config_hash())
        );
        let joined =
            Manifest::parse(&std::fs::read_to_string(merged.join("manifest.json")).expect("manifest"))
                .expect("a manifest");
        assert_eq!(joined.merged_from, Some(vec![run.display().to_string()]));
        assert_eq!(joined.config, config);

        // A manifest without its setup (or otherwise broken) is refused, naming file and field.
        let mut json: serde_json::Value = serde_json::from_str(&text).expect("json");
        json.as_object_mut().expect("an object").remove("setup");
        std::fs::write(run.join("manifest.json"), json.to_string()).expect("write");
        let err =
            merge(std::slice::from_ref(&run), &dir.join("merged-again")).expect_err("broken").to_string();
        let path = run.join("manifest.json").display().to_string();
        assert!(err.contains(&path) && err.contains("missing field `setup`"), "{err}");
        let err = run_tournament(&config, &maps, &resume, &mut |_| {}).expect_err("broken").to_string();
        assert!(err.contains(&path) && err.contains("missing field `setup`"), "{err}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
