//! Finished matches' results: the index (`matches.jsonl`, one tournament row per match,
//! flushed as each ends, so a tournament's summary tools read it), each full result
//! (`results/ID.json`) and replays (`replays/ID.jsonl`), in a directory; or, without one,
//! the latest results in memory.

use std::collections::VecDeque;
use std::fs::{File, OpenOptions};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use bw4t_protocol::MatchResult;
use bw4t_tournament::Row;

/// How many rows and results are kept in memory.
const KEPT: usize = 1000;

/// Where finished matches are kept.
#[derive(Clone)]
pub struct ResultsStore {
    dir: Option<PathBuf>,
    inner: Arc<Mutex<Kept>>,
}

#[derive(Default)]
struct Kept {
    index: Option<File>,
    rows: VecDeque<Row>,
    results: VecDeque<(String, MatchResult)>,
}

impl ResultsStore {
    /// Results kept in memory only (the latest thousand); no replays.
    pub fn in_memory() -> ResultsStore {
        ResultsStore { dir: None, inner: Arc::new(Mutex::new(Kept::default())) }
    }

    /// Results written under `dir` (made if missing); the index is appended to, so a
    /// restarted server adds to it.
    pub fn in_dir(dir: &Path) -> std::io::Result<ResultsStore> {
        std::fs::create_dir_all(dir.join("results"))?;
        std::fs::create_dir_all(dir.join("replays"))?;
        let index = OpenOptions::new().create(true).append(true).open(dir.join("matches.jsonl"))?;
        let kept = Kept { index: Some(index), ..Kept::default() };
        Ok(ResultsStore { dir: Some(dir.to_path_buf()), inner: Arc::new(Mutex::new(kept)) })
    }

    /// The directory, if results are written.
    pub fn dir(&self) -> Option<&Path> {
        self.dir.as_deref()
    }

    fn kept(&self) -> std::sync::MutexGuard<'_, Kept> {
        self.inner.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// A writer for match `id`'s replay, when results go to a directory. A replay already
    /// there (of a run a killed server left unfinished) is never overwritten.
    pub(crate) fn replay_writer(&self, id: &str) -> Option<(Box<dyn Write + Send>, String)> {
        let path = self.dir.as_ref()?.join("replays").join(format!("{id}.jsonl"));
        match OpenOptions::new().write(true).create_new(true).open(&path) {
            Ok(file) => Some((Box::new(BufWriter::new(file)), crate::program())),
            Err(e) => {
                tracing::error!(target: "bw4t::arena", path = %path.display(), error = %e, "cannot write a replay");
                None
            }
        }
    }

    /// The replay's file name relative to the directory, if one was kept.
    pub(crate) fn replay_name(&self, id: &str, kept: bool) -> Option<String> {
        let name = format!("replays/{id}.jsonl");
        (kept && self.dir.as_ref().is_some_and(|d| d.join(&name).is_file())).then_some(name)
    }

    /// Records a finished match: its row in the index (flushed), its result.
    pub(crate) fn record(&self, row: &Row, result: Option<&MatchResult>) {
        let mut kept = self.kept();
        if let Some(index) = kept.index.as_mut() {
            let line = serde_json::to_string(row).unwrap_or_default() + "\n";
            if let Err(e) = index.write_all(line.as_bytes()).and_then(|()| index.flush()) {
                tracing::error!(target: "bw4t::arena", error = %e, "cannot write the index of results");
            }
        }
        if let (Some(dir), Some(result)) = (&self.dir, result) {
            let path = dir.join("results").join(format!("{}.json", row.key));
            let json = serde_json::to_string_pretty(result).unwrap_or_default() + "\n";
            if let Err(e) = std::fs::write(&path, json) {
                tracing::error!(target: "bw4t::arena", path = %path.display(), error = %e, "cannot write a result");
            }
        }
        kept.rows.push_back(row.clone());
        if kept.rows.len() > KEPT {
            kept.rows.pop_front();
        }
        if let Some(result) = result {
            kept.results.push_back((row.key.clone(), result.clone()));
            if kept.results.len() > KEPT {
                kept.results.pop_front();
            }
        }
    }

    /// The index's rows: the whole file when there is one, else those kept in memory.
    pub fn rows(&self) -> Vec<Row> {
        if let Some(dir) = &self.dir {
            let rows = std::fs::read_to_string(dir.join("matches.jsonl")).ok().map(|t| Row::parse_lines(&t));
            if let Some(Ok(rows)) = rows {
                return rows;
            }
        }
        self.kept().rows.iter().cloned().collect()
    }

    /// The last run of each match name in the index and among the replays, and how many
    /// rows the index has: a server restarted on the same directory goes on numbering
    /// from there, past the runs a killed server left without a row, so no id is reused.
    pub(crate) fn history(&self) -> (std::collections::BTreeMap<String, u64>, u64) {
        let rows = if self.dir.is_some() { self.rows() } else { Vec::new() };
        let replays = self.dir.as_ref().and_then(|d| std::fs::read_dir(d.join("replays")).ok());
        let replay_ids: Vec<String> = replays
            .into_iter()
            .flatten()
            .filter_map(|entry| entry.ok()?.file_name().to_str()?.strip_suffix(".jsonl").map(str::to_string))
            .collect();
        let mut runs = std::collections::BTreeMap::new();
        for id in rows.iter().map(|r| r.key.as_str()).chain(replay_ids.iter().map(String::as_str)) {
            if let Some((name, run)) =
                id.rsplit_once('.').and_then(|(n, r)| Some((n, r.parse::<u64>().ok()?)))
            {
                let last = runs.entry(name.to_string()).or_insert(0);
                *last = (*last).max(run);
            }
        }
        let ended = rows.iter().map(|r| r.index).max().unwrap_or(0);
        (runs, ended)
    }

    /// Match `id`'s result.
    pub fn result(&self, id: &str) -> Option<String> {
        if !valid_id(id) {
            return None;
        }
        if let Some(dir) = &self.dir {
            return std::fs::read_to_string(dir.join("results").join(format!("{id}.json"))).ok();
        }
        let kept = self.kept();
        let (_, result) = kept.results.iter().find(|(key, _)| key == id)?;
        serde_json::to_string_pretty(result).ok()
    }

    /// Match `id`'s replay, when kept.
    pub fn replay(&self, id: &str) -> Option<String> {
        let dir = self.dir.as_ref().filter(|_| valid_id(id))?;
        std::fs::read_to_string(dir.join("replays").join(format!("{id}.jsonl"))).ok()
    }
}

/// Whether `id` is a match id (`NAME.RUN`), so that it can name a file and no path.
fn valid_id(id: &str) -> bool {
    !id.is_empty()
        && !id.starts_with('.')
        && id.chars().all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_' || c == '.')
        && !id.contains("..")
}

#[cfg(test)]
mod tests {
    use super::ResultsStore;

    #[test]
    fn a_run_a_killed_server_left_is_neither_renumbered_nor_overwritten() {
        let dir = std::env::temp_dir().join(format!("bw4t-store-killed-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(dir.join("replays")).expect("replays dir");
        // Run 3 of `ladder` was being recorded when its server was killed: no row, a replay.
        let left = dir.join("replays").join("ladder.3.jsonl");
        std::fs::write(&left, "interrupted\n").expect("a replay");
        let store = ResultsStore::in_dir(&dir).expect("store");
        let (runs, ended) = store.history();
        assert_eq!((runs.get("ladder").copied(), ended), (Some(3), 0), "the next run is 4");
        assert!(store.replay_writer("ladder.3").is_none(), "the replay there is kept");
        assert_eq!(std::fs::read_to_string(&left).expect("kept"), "interrupted\n");
        assert!(store.replay_writer("ladder.4").is_some());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
