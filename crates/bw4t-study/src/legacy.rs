//! Data directories of versions before the database: one JSON-lines log per participant,
//! `DIR/participants/ID.jsonl`, each line a record with its `seq` and `server_ms`. At
//! start every log whose participant the database lacks is imported as it is, in one
//! transaction a log; the files are left untouched.

use std::path::{Path, PathBuf};

use serde_json::Value;

use super::flow::Record;
use super::store::{Store, Stored};

/// The folder of the old logs in a data directory.
pub(crate) const LOGS: &str = "participants";

/// Imports every log in `dir/participants/` whose participant is not in `store` yet;
/// returns how many were. A log that cannot be read or written is logged and left for
/// the next start.
pub(crate) fn import(store: &Store, dir: &Path) -> std::io::Result<usize> {
    let mut imported = 0;
    for path in logs(&dir.join(LOGS))? {
        match import_one(store, &path) {
            Ok(true) => imported += 1,
            Ok(false) => {}
            Err(e) => {
                tracing::error!(target: "bw4t::study", path = %path.display(), error = %e, "cannot import a participant's log");
            }
        }
    }
    if imported > 0 {
        tracing::info!(target: "bw4t::study", imported, database = %store.path().display(), "imported the participants' logs of an older version");
    }
    Ok(imported)
}

/// The `.jsonl` files in `dir`, in order; none if `dir` is missing.
fn logs(dir: &Path) -> std::io::Result<Vec<PathBuf>> {
    let entries = match std::fs::read_dir(dir) {
        Ok(entries) => entries,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(std::io::Error::other(format!("{}: {e}", dir.display()))),
    };
    let mut files: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "jsonl"))
        .collect();
    files.sort();
    Ok(files)
}

fn import_one(store: &Store, path: &Path) -> std::io::Result<bool> {
    // A log is named after its participant: one imported before is not read again.
    if path.file_stem().and_then(|s| s.to_str()).map(|id| store.has(id)).transpose()? == Some(true) {
        return Ok(false);
    }
    let stored = read(path)?;
    let Some(Stored { record: Record::Created { participant, .. }, .. }) = stored.first() else {
        tracing::warn!(target: "bw4t::study", path = %path.display(), "a log that does not begin with its participant's creation is skipped");
        return Ok(false);
    };
    if store.has(participant)? {
        return Ok(false);
    }
    store.import(participant, &stored)?;
    Ok(true)
}

/// A log's records in `seq` order; a line that is not a record (only the last can be,
/// torn by a kill while it was written) is left out.
fn read(path: &Path) -> std::io::Result<Vec<Stored>> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| std::io::Error::other(format!("{}: {e}", path.display())))?;
    let mut stored = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let parsed = serde_json::from_str::<Value>(line).ok().and_then(|v| {
            let seq = v.get("seq")?.as_u64()?;
            let server_ms = v.get("server_ms")?.as_u64()?;
            Some(Stored { seq, server_ms, record: serde_json::from_value::<Record>(v).ok()? })
        });
        match parsed {
            Some(record) => stored.push(record),
            None => {
                tracing::warn!(target: "bw4t::study", path = %path.display(), line = n + 1, "a log line that is not a record is skipped");
            }
        }
    }
    stored.sort_by_key(|s| s.seq);
    Ok(stored)
}
