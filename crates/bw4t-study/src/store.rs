//! The study's data: one SQLite database, `DIR/study.sqlite3`, of every participant's
//! records (`flow.rs`'s `Record`s, the only source of their state).
//!
//! The server holds one connection to it, so descriptors do not grow with participants;
//! each request's records are one transaction, committed (and, with `synchronous=FULL`,
//! on the disk) before the request is answered, so what a participant was told is
//! recorded is there after a kill or a power cut. Nothing recorded is changed or deleted:
//! triggers refuse it. The tables are for a researcher too (docs/STUDIES.md):
//! `participants` (one row a participant: their `created` record, seq 1), `records`
//! (everything after it, from seq 2, each record's fields as JSON in `data`), and the
//! views `answers`, `events` and `trials` made with SQLite's JSON functions.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use rusqlite::{Connection, OpenFlags, OptionalExtension, Transaction, params};
use serde_json::{Map, Value};

use super::flow::Record;

/// The database's file in a study's data directory.
pub(crate) const DATABASE: &str = "study.sqlite3";

/// The header's `application_id`: "bw4t" in ASCII, so a file is known as a study's.
const APPLICATION_ID: i64 = 0x6277_3474;
/// The schema's version, in the header's `user_version`.
const SCHEMA_VERSION: i64 = 1;

/// The tables, the views and the triggers that keep every record as it was written.
const SCHEMA: &str = r"
CREATE TABLE participants (
    id TEXT PRIMARY KEY NOT NULL,
    number INTEGER NOT NULL UNIQUE,
    created_ms INTEGER NOT NULL,
    condition_order TEXT NOT NULL CHECK (json_valid(condition_order)),
    params TEXT NOT NULL CHECK (json_valid(params)),
    secret_sha256 TEXT
);
CREATE TABLE records (
    participant TEXT NOT NULL REFERENCES participants (id),
    seq INTEGER NOT NULL CHECK (seq > 1),
    server_ms INTEGER NOT NULL,
    type TEXT NOT NULL,
    data TEXT NOT NULL CHECK (json_valid(data)),
    PRIMARY KEY (participant, seq)
) WITHOUT ROWID;
CREATE TRIGGER participants_unchanged BEFORE UPDATE ON participants
    BEGIN SELECT RAISE(ABORT, 'a study''s records are never changed'); END;
CREATE TRIGGER participants_kept BEFORE DELETE ON participants
    BEGIN SELECT RAISE(ABORT, 'a study''s records are never deleted'); END;
CREATE TRIGGER records_unchanged BEFORE UPDATE ON records
    BEGIN SELECT RAISE(ABORT, 'a study''s records are never changed'); END;
CREATE TRIGGER records_kept BEFORE DELETE ON records
    BEGIN SELECT RAISE(ABORT, 'a study''s records are never deleted'); END;
CREATE VIEW events AS
SELECT participant, seq, server_ms,
       json_extract(data, '$.event.wall_ms') AS wall_ms,
       json_extract(data, '$.event.step') AS step,
       json_extract(data, '$.event.tick') AS tick,
       json_extract(data, '$.event.kind') AS kind,
       json_extract(data, '$.event') AS event
FROM records WHERE type = 'event';
CREATE VIEW answers AS
SELECT r.participant, r.seq, r.server_ms,
       json_extract(r.data, '$.step') AS step,
       json_extract(r.data, '$.page') AS page,
       json_extract(r.data, '$.questionnaire') AS questionnaire,
       a.key AS item,
       CASE a.type WHEN 'true' THEN 'true' WHEN 'false' THEN 'false' ELSE a.value END AS value
FROM records AS r, json_each(r.data, '$.answers') AS a
WHERE r.type = 'answer' AND json_extract(r.data, '$.page') <> 'trial';
CREATE VIEW trials AS
SELECT participant, seq, server_ms, type,
       json_extract(data, '$.step') AS step,
       json_extract(data, '$.trial') AS trial,
       json_extract(data, '$.condition') AS condition,
       json_extract(data, '$.match_id') AS match_id,
       json_extract(data, '$.reason') AS reason,
       json_extract(data, '$.result.end_reason') AS end_reason,
       json_extract(data, '$.result.ticks') AS ticks
FROM records WHERE type IN ('trial_started', 'trial_ended', 'trial_incomplete');
";

const INSERT_PARTICIPANT: &str = "INSERT INTO participants \
    (id, number, created_ms, condition_order, params, secret_sha256) VALUES (?1, ?2, ?3, ?4, ?5, ?6)";
const INSERT_RECORD: &str =
    "INSERT INTO records (participant, seq, server_ms, type, data) VALUES (?1, ?2, ?3, ?4, ?5)";

/// A record as kept: its number among the participant's records, the server's time.
pub(crate) struct Stored {
    pub seq: u64,
    pub server_ms: u64,
    pub record: Record,
}

/// A study's database, through one connection.
pub(crate) struct Store {
    path: PathBuf,
    connection: Mutex<Connection>,
}

impl Store {
    /// The database of the data directory `dir`, made if missing.
    pub(crate) fn open(dir: &Path) -> std::io::Result<Store> {
        let path = dir.join(DATABASE);
        let connection = Connection::open(&path).map_err(|e| failed(&path, e))?;
        Store::set_up(connection, path, true)
    }

    /// The database at `path` to read only (the export): nothing is made or changed.
    pub(crate) fn open_read_only(path: &Path) -> std::io::Result<Store> {
        let flags = OpenFlags::SQLITE_OPEN_READ_ONLY | OpenFlags::SQLITE_OPEN_NO_MUTEX;
        let connection = Connection::open_with_flags(path, flags).map_err(|e| failed(path, e))?;
        Store::set_up(connection, path.to_path_buf(), false)
    }

    /// An empty database in memory (the export of a directory an older version wrote).
    pub(crate) fn in_memory() -> std::io::Result<Store> {
        let path = PathBuf::from(":memory:");
        let connection = Connection::open_in_memory().map_err(|e| failed(&path, e))?;
        Store::set_up(connection, path, true)
    }

    /// Checks the file is a study's of a schema this version knows, and, when `write`,
    /// makes the schema of a new one and sets how it is written.
    fn set_up(mut connection: Connection, path: PathBuf, write: bool) -> std::io::Result<Store> {
        let e = |e| failed(&path, e);
        let read = |c: &Connection| -> rusqlite::Result<(i64, i64, i64)> {
            let id = c.pragma_query_value(None, "application_id", |r| r.get(0))?;
            let version = c.pragma_query_value(None, "user_version", |r| r.get(0))?;
            let objects = c.query_row("SELECT count(*) FROM sqlite_schema", [], |r| r.get(0))?;
            Ok((id, version, objects))
        };
        let (id, version, objects) = read(&connection).map_err(e)?;
        let fresh = id == 0 && version == 0 && objects == 0;
        if !fresh && id != APPLICATION_ID {
            return Err(std::io::Error::other(format!(
                "{}: not a bw4t study's database (its application_id is {id:#x}, a study's is {APPLICATION_ID:#x})",
                path.display()
            )));
        }
        if version > SCHEMA_VERSION {
            return Err(std::io::Error::other(format!(
                "{}: made by a newer bw4t (schema {version}; this version knows {SCHEMA_VERSION})",
                path.display()
            )));
        }
        if fresh && !write {
            return Err(std::io::Error::other(format!("{}: an empty database", path.display())));
        }
        if write {
            // Readers never block the one writer, and a backup can be taken while serving.
            let mode: String =
                connection.pragma_update_and_check(None, "journal_mode", "WAL", |r| r.get(0)).map_err(e)?;
            if !mode.eq_ignore_ascii_case("wal") && !mode.eq_ignore_ascii_case("memory") {
                return Err(std::io::Error::other(format!(
                    "{}: cannot use write-ahead logging (journal mode {mode})",
                    path.display()
                )));
            }
            // FULL: a commit is synced to the disk before the participant is answered, so
            // an acknowledged answer survives a power cut too, not only a killed server
            // (all NORMAL would give). It costs one sync a request, far below what a disk
            // does at a study's rate of requests.
            connection.pragma_update(None, "synchronous", "FULL").map_err(e)?;
            connection.pragma_update(None, "foreign_keys", true).map_err(e)?;
        }
        // A researcher's own session holding a write lock delays a write, not fails it.
        connection.busy_timeout(std::time::Duration::from_secs(2)).map_err(e)?;
        if fresh {
            let tx = connection.transaction().map_err(e)?;
            tx.execute_batch(SCHEMA).map_err(e)?;
            tx.pragma_update(None, "application_id", APPLICATION_ID).map_err(e)?;
            tx.pragma_update(None, "user_version", SCHEMA_VERSION).map_err(e)?;
            tx.commit().map_err(e)?;
        }
        Ok(Store { path, connection: Mutex::new(connection) })
    }

    /// The database's file.
    pub(crate) fn path(&self) -> &Path {
        &self.path
    }

    /// Writes `records`, numbered from `first_seq` and all at `server_ms`, in one
    /// transaction; returns once it is committed.
    pub(crate) fn append(
        &self,
        participant: &str,
        first_seq: u64,
        server_ms: u64,
        records: &[Record],
    ) -> std::io::Result<()> {
        let rows = records.iter().zip(first_seq..).map(|(record, seq)| (seq, server_ms, record));
        self.write(participant, rows)
    }

    /// Writes records read elsewhere (an older version's log) as they were, in one
    /// transaction.
    pub(crate) fn import(&self, participant: &str, stored: &[Stored]) -> std::io::Result<()> {
        self.write(participant, stored.iter().map(|s| (s.seq, s.server_ms, &s.record)))
    }

    fn write<'a>(
        &self,
        participant: &str,
        rows: impl Iterator<Item = (u64, u64, &'a Record)>,
    ) -> std::io::Result<()> {
        let mut connection = super::lock(&self.connection);
        let written = (|| {
            let tx = connection.transaction()?;
            for (seq, server_ms, record) in rows {
                insert(&tx, participant, seq, server_ms, record)?;
            }
            tx.commit()
        })();
        written.map_err(|e| failed(&self.path, e))
    }

    /// Whether participant `id` has a row.
    pub(crate) fn has(&self, id: &str) -> std::io::Result<bool> {
        let connection = super::lock(&self.connection);
        let found = connection
            .prepare_cached("SELECT 1 FROM participants WHERE id = ?1")
            .and_then(|mut s| s.query_row([id], |_| Ok(())).optional())
            .map_err(|e| failed(&self.path, e))?;
        Ok(found.is_some())
    }

    /// The arrival number of the next participant: one past the highest recorded, so a
    /// participant whose state could not be rebuilt still keeps theirs.
    pub(crate) fn next_number(&self) -> std::io::Result<u64> {
        let connection = super::lock(&self.connection);
        let next: i64 = connection
            .prepare_cached("SELECT coalesce(max(number) + 1, 0) FROM participants")
            .and_then(|mut s| s.query_row([], |r| r.get(0)))
            .map_err(|e| failed(&self.path, e))?;
        Ok(u64_of(next))
    }

    /// Every participant's id, in order.
    pub(crate) fn participants(&self) -> std::io::Result<Vec<String>> {
        let connection = super::lock(&self.connection);
        ids(&connection).map_err(|e| failed(&self.path, e))
    }

    /// Participant `id`'s records in `seq` order, their `created` first; a row that is not
    /// a record this version knows is left out (and logged).
    pub(crate) fn records(&self, id: &str) -> std::io::Result<Vec<Stored>> {
        let connection = super::lock(&self.connection);
        records_of(&connection, &self.path, id).map_err(|e| failed(&self.path, e))
    }

    /// Every participant's records, by id, read in one transaction, so a database being
    /// written while it is read gives one moment's data.
    pub(crate) fn everything(&self) -> std::io::Result<BTreeMap<String, Vec<Stored>>> {
        let mut connection = super::lock(&self.connection);
        let read = (|| {
            let tx = connection.transaction()?;
            let mut all = BTreeMap::new();
            for id in ids(&tx)? {
                let records = records_of(&tx, &self.path, &id)?;
                all.insert(id, records);
            }
            tx.commit()?;
            Ok(all)
        })();
        read.map_err(|e| failed(&self.path, e))
    }
}

/// One record's row: a `created` record is the participant's row, any other one in
/// `records` with its fields as JSON.
fn insert(
    tx: &Transaction<'_>,
    participant: &str,
    seq: u64,
    server_ms: u64,
    record: &Record,
) -> rusqlite::Result<()> {
    let json = |e: serde_json::Error| rusqlite::Error::ToSqlConversionFailure(Box::new(e));
    let (seq, server_ms) = (sql_int(seq), sql_int(server_ms));
    if let Record::Created { participant: id, number, order, params, secret_sha256 } = record {
        let order = serde_json::to_string(order).map_err(json)?;
        let row = params![id, sql_int(*number), server_ms, order, params.to_string(), secret_sha256];
        tx.prepare_cached(INSERT_PARTICIPANT)?.execute(row)?;
        return Ok(());
    }
    let Value::Object(mut fields) = serde_json::to_value(record).map_err(json)? else {
        return Err(rusqlite::Error::ToSqlConversionFailure("a record is a JSON object".into()));
    };
    let kind = match fields.remove("type") {
        Some(Value::String(kind)) => kind,
        _ => return Err(rusqlite::Error::ToSqlConversionFailure("a record has a type".into())),
    };
    let data = Value::Object(fields).to_string();
    tx.prepare_cached(INSERT_RECORD)?.execute(params![participant, seq, server_ms, kind, data])?;
    Ok(())
}

fn ids(connection: &Connection) -> rusqlite::Result<Vec<String>> {
    let mut statement = connection.prepare_cached("SELECT id FROM participants ORDER BY id")?;
    statement.query_map([], |r| r.get(0))?.collect()
}

fn records_of(connection: &Connection, path: &Path, id: &str) -> rusqlite::Result<Vec<Stored>> {
    let mut out = Vec::new();
    let mut statement = connection.prepare_cached(
        "SELECT number, created_ms, condition_order, params, secret_sha256 FROM participants WHERE id = ?1",
    )?;
    let created = statement
        .query_row([id], |r| {
            let row: (i64, i64, String, String, Option<String>) =
                (r.get(0)?, r.get(1)?, r.get(2)?, r.get(3)?, r.get(4)?);
            Ok(row)
        })
        .optional()?;
    let Some((number, created_ms, order, params, secret_sha256)) = created else { return Ok(out) };
    out.push(Stored {
        seq: 1,
        server_ms: u64_of(created_ms),
        record: Record::Created {
            participant: id.to_string(),
            number: u64_of(number),
            order: serde_json::from_str(&order).unwrap_or_default(),
            params: serde_json::from_str(&params).unwrap_or(Value::Null),
            secret_sha256,
        },
    });
    let mut statement = connection.prepare_cached(
        "SELECT seq, server_ms, type, data FROM records WHERE participant = ?1 ORDER BY seq",
    )?;
    let rows = statement.query_map([id], |r| {
        let row: (i64, i64, String, String) = (r.get(0)?, r.get(1)?, r.get(2)?, r.get(3)?);
        Ok(row)
    })?;
    for row in rows {
        let (seq, server_ms, kind, data) = row?;
        let mut fields = serde_json::from_str::<Map<String, Value>>(&data).unwrap_or_default();
        fields.insert("type".into(), Value::String(kind));
        match serde_json::from_value::<Record>(Value::Object(fields)) {
            Ok(record) => out.push(Stored { seq: u64_of(seq), server_ms: u64_of(server_ms), record }),
            Err(e) => {
                tracing::warn!(target: "bw4t::study", path = %path.display(), participant = id, seq, error = %e, "a row that is not a record is skipped");
            }
        }
    }
    Ok(out)
}

/// A count or a time as SQLite's integer (which is signed).
fn sql_int(n: u64) -> i64 {
    i64::try_from(n).unwrap_or(i64::MAX)
}

fn u64_of(n: i64) -> u64 {
    u64::try_from(n).unwrap_or(0)
}

/// A database error, naming the file.
fn failed(path: &Path, e: rusqlite::Error) -> std::io::Error {
    std::io::Error::other(format!("{}: {e}", path.display()))
}

#[cfg(test)]
mod tests {
    use std::path::PathBuf;

    use rusqlite::Connection;
    use serde_json::json;

    use super::{DATABASE, Store};
    use crate::flow::Record;

    fn temp_dir(what: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("bw4t-store-{what}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("temp dir");
        dir
    }

    fn created(id: &str, number: u64) -> Record {
        Record::Created {
            participant: id.into(),
            number,
            order: vec!["b".into(), "a".into()],
            params: json!({"pid": id}),
            secret_sha256: Some("ab".repeat(32)),
        }
    }

    fn as_json(records: &[super::Stored]) -> Vec<(u64, u64, serde_json::Value)> {
        records.iter().map(|s| (s.seq, s.server_ms, serde_json::to_value(&s.record).expect("json"))).collect()
    }

    #[test]
    fn records_read_back_as_written_across_a_reopening() {
        let dir = temp_dir("round-trip");
        let written = [
            created("p1", 0),
            Record::Answer {
                step: 0,
                page: "consent".into(),
                questionnaire: None,
                answers: json!({"consent": true}),
                passed: None,
                shown: None,
            },
            Record::Event { event: json!({"kind": "key", "key": "ü", "tick": null}) },
        ];
        {
            let store = Store::open(&dir).expect("a new database");
            store.append("p1", 1, 10, &written[..1]).expect("created");
            store.append("p1", 2, 20, &written[1..]).expect("one request");
        }
        let store = Store::open(&dir).expect("reopened");
        assert_eq!(store.participants().expect("ids"), ["p1"]);
        let read = store.records("p1").expect("records");
        let expected: Vec<_> = written
            .iter()
            .zip([(1, 10), (2, 20), (3, 20)])
            .map(|(r, (seq, ms))| (seq, ms, serde_json::to_value(r).expect("json")))
            .collect();
        assert_eq!(as_json(&read), expected);
        // A researcher's view of the same file.
        let other = Connection::open(dir.join(DATABASE)).expect("open");
        let kinds: Vec<(i64, String)> = other
            .prepare("SELECT seq, type FROM records ORDER BY seq")
            .and_then(|mut s| s.query_map([], |r| Ok((r.get(0)?, r.get(1)?)))?.collect())
            .expect("rows");
        assert_eq!(kinds, [(2, "answer".to_string()), (3, "event".to_string())]);
        let key: String = other
            .query_row("SELECT kind FROM events WHERE participant = 'p1'", [], |r| r.get(0))
            .expect("view");
        assert_eq!(key, "key");
        let consent: String = other.query_row("SELECT value FROM answers", [], |r| r.get(0)).expect("view");
        assert_eq!(consent, "true");
        let mode: String = other.query_row("PRAGMA journal_mode", [], |r| r.get(0)).expect("mode");
        assert_eq!(mode, "wal");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_request_is_written_whole_or_not_at_all() {
        let dir = temp_dir("atomic");
        let store = Store::open(&dir).expect("a new database");
        assert_eq!(store.next_number().expect("a number"), 0);
        store.append("p1", 1, 10, &[created("p1", 0)]).expect("created");
        assert_eq!(store.next_number().expect("a number"), 1);
        let event = Record::Event { event: json!({"kind": "click"}) };
        store.append("p1", 3, 20, std::slice::from_ref(&event)).expect("seq 3");
        // Seq 2 is new, seq 3 is taken: the request fails, and seq 2 is not kept either.
        let error = store.append("p1", 2, 30, &[event.clone(), event.clone()]).expect_err("a taken seq");
        assert!(error.to_string().contains(DATABASE), "{error}");
        assert_eq!(store.records("p1").expect("records").len(), 2);
        // A second participant with a taken number, or records of no participant: refused.
        assert!(store.append("p2", 1, 40, &[created("p2", 0)]).is_err(), "numbers are unique");
        assert!(store.append("nobody", 2, 40, &[event]).is_err(), "records need their participant");
        assert_eq!(store.participants().expect("ids"), ["p1"]);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn nothing_recorded_can_be_changed_or_deleted() {
        let dir = temp_dir("append-only");
        let store = Store::open(&dir).expect("a new database");
        store
            .append("p1", 1, 10, &[created("p1", 0), Record::Resumed { params: json!({}) }])
            .expect("written");
        let other = Connection::open(dir.join(DATABASE)).expect("open");
        for sql in [
            "UPDATE records SET data = '{}'",
            "DELETE FROM records",
            "UPDATE participants SET secret_sha256 = NULL",
            "DELETE FROM participants",
        ] {
            let error = other.execute(sql, []).expect_err(sql);
            assert!(error.to_string().contains("never"), "{sql}: {error}");
        }
        assert_eq!(store.records("p1").expect("records").len(), 2);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_file_that_is_not_a_study_database_is_refused_naming_it() {
        let dir = temp_dir("foreign");
        let path = dir.join(DATABASE);
        std::fs::write(&path, "participant,step\nann,1\n".repeat(100)).expect("write");
        let error = Store::open(&dir).err().expect("a text file is refused").to_string();
        assert!(error.starts_with(&path.display().to_string()), "{error}");
        assert!(error.contains("not a database"), "{error}");

        std::fs::remove_file(&path).expect("remove");
        Connection::open(&path)
            .and_then(|c| c.execute_batch("CREATE TABLE t (x)"))
            .expect("another program's");
        let error = Store::open(&dir).err().expect("another program's database is refused").to_string();
        assert!(error.starts_with(&path.display().to_string()), "{error}");
        assert!(error.contains("not a bw4t study's database"), "{error}");

        std::fs::remove_file(&path).expect("remove");
        drop(Store::open(&dir).expect("a new database"));
        Connection::open(&path).and_then(|c| c.pragma_update(None, "user_version", 99)).expect("newer");
        let error = Store::open(&dir).err().expect("a newer schema is refused").to_string();
        assert!(error.contains("newer") && error.contains("99"), "{error}");
        let error = Store::open_read_only(&path).err().expect("read only too").to_string();
        assert!(error.contains("newer"), "{error}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
