//! The export from the dashboard: `POST /api/study/export` makes it into the data
//! directory's `export/` (as `bw4t study export DIR` does, one at a time), and
//! `GET /api/study/export/NAME.csv` gives one of its CSV files to save.

use bw4t_protocol::StudyExported;
use http::StatusCode;

use super::StudyServer;
use super::api::{Answer, error, reply};

/// The files the export makes that the dashboard offers.
const FILES: [&str; 4] = ["participants.csv", "trials.csv", "answers.csv", "events.csv"];

impl StudyServer {
    /// The study's data directory (the database's).
    fn data_dir(&self) -> std::path::PathBuf {
        let db = self.inner.store.path();
        db.parent().map_or_else(|| std::path::PathBuf::from("."), std::path::Path::to_path_buf)
    }

    /// `POST /api/study/export`: exports now, off the runtime's threads.
    pub(crate) async fn export_now(&self) -> Answer {
        // One export at a time: two would write the same files.
        let _one = self.inner.exporting.lock().await;
        let dir = self.data_dir();
        let made = tokio::task::spawn_blocking(move || super::export(&dir, &dir.join("export"))).await;
        match made {
            Ok(Ok(summary)) => reply(
                StatusCode::OK,
                &StudyExported {
                    counts: summary.counts,
                    files: FILES.iter().map(|f| f.to_string()).collect(),
                },
            ),
            Ok(Err(why)) => error(StatusCode::INTERNAL_SERVER_ERROR, format!("the export failed: {why}")),
            Err(e) => error(StatusCode::INTERNAL_SERVER_ERROR, format!("the export failed: {e}")),
        }
    }

    /// `GET /api/study/export/NAME.csv`: a file of the latest export.
    pub(crate) fn exported(&self, file: &str) -> Answer {
        if !FILES.contains(&file) {
            return error(
                StatusCode::NOT_FOUND,
                format!("no export file '{file}' (there are: {})", FILES.join(", ")),
            );
        }
        match std::fs::read_to_string(self.data_dir().join("export").join(file)) {
            Ok(text) => Answer::Download(format!("{}-{file}", self.study().name), text),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                error(StatusCode::NOT_FOUND, "nothing exported yet: POST /api/study/export first")
            }
            Err(e) => {
                error(StatusCode::INTERNAL_SERVER_ERROR, format!("cannot read the export's {file}: {e}"))
            }
        }
    }
}
