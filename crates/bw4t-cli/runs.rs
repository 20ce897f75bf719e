//! Where runs write: the default output directory of a run, a replay file, and the
//! command lines a run prints to be run again.

use std::path::PathBuf;

use anyhow::{Context, Result};

/// A new directory for a run's outputs when none is given: `runs/WHAT-SECONDS`.
pub(crate) fn default_out(what: &str) -> PathBuf {
    let secs = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_secs());
    PathBuf::from("runs").join(format!("{what}-{secs}"))
}

/// A buffered file for a replay, or none without a path.
pub(crate) fn replay_writer(
    path: Option<&std::path::Path>,
) -> Result<Option<Box<dyn std::io::Write + Send>>> {
    let Some(path) = path else { return Ok(None) };
    let file = std::fs::File::create(path)
        .with_context(|| format!("cannot create replay file {}", path.display()))?;
    Ok(Some(Box::new(std::io::BufWriter::new(file))))
}

/// `word` as `sh` reads it back: bare when safe, else in single quotes.
pub(crate) fn shell_quote(word: &str) -> String {
    let safe = |c: char| c.is_ascii_alphanumeric() || "_-./:=@%+,".contains(c);
    if !word.is_empty() && word.chars().all(safe) {
        word.to_string()
    } else {
        format!("'{}'", word.replace('\'', "'\\''"))
    }
}
