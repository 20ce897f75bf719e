//! The manifest of a tournament directory (`manifest.json`): what was run, how, where and
//! for how long, so a run can be resumed, shards merged and results traced back.

use serde::{Deserialize, Serialize};

use crate::config::{Resolved, Shard};
use crate::stats::Setup;

/// Which replays a tournament keeps; the manifest names it `all`, `failed` or `none`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ReplayPolicy {
    /// Every match's.
    All,
    /// Those of matches that did not complete.
    Failed,
    /// None.
    None,
}

/// The machine a tournament (or its first shard) ran on.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Machine {
    /// The operating system (`linux`, `macos`, ...).
    pub os: String,
    /// The processor architecture (`x86_64`, `aarch64`, ...).
    pub arch: String,
    /// Cores available to the program.
    pub cores: usize,
    /// Matches played at once.
    pub concurrency: usize,
    /// The host's name, empty when unknown.
    pub host: String,
}

/// A tournament directory's `manifest.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    /// The program and version that wrote it (`bw4t 0.1.0`).
    pub program: String,
    /// When the run (the last resume, for a resumed one) started, in seconds since 1970.
    pub created_unix: u64,
    /// Where it ran.
    pub machine: Machine,
    /// The resolved configuration: a resume or merge must have the same.
    pub config: Resolved,
    /// [`Resolved::config_hash`] of `config`, so that shards of one configuration are
    /// known at a glance (empty in manifests written before it was recorded).
    #[serde(default)]
    pub config_hash: String,
    /// Each map's tick limit and the maps whose content ignores the seed.
    pub setup: Setup,
    /// The share of the matches this directory plays; none for the whole tournament (and
    /// for a merge).
    pub shard: Option<Shard>,
    /// Matches played at once.
    pub concurrency: usize,
    /// Which replays are kept.
    pub replays: ReplayPolicy,
    /// Seconds spent playing, over every run that resumed it (summed over shards when
    /// merged).
    pub elapsed_seconds: f64,
    /// The directories a merge joined, as given.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub merged_from: Option<Vec<String>>,
}

/// A manifest that cannot be read.
#[derive(Debug, thiserror::Error)]
pub enum ManifestError {
    /// Not JSON, or a field missing or of the wrong type (with line and column).
    #[error(transparent)]
    Json(#[from] serde_json::Error),
}

impl Manifest {
    /// Reads a manifest's text.
    pub fn parse(text: &str) -> Result<Manifest, ManifestError> {
        Ok(serde_json::from_str(text)?)
    }

    /// The manifest as the file holds it: pretty JSON with a final newline.
    pub fn to_json(&self) -> String {
        // Every field is a plain value, a string-keyed struct or a list: serialising cannot fail.
        serde_json::to_string_pretty(self).unwrap_or_default() + "\n"
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::TournamentConfig;
    use crate::stats::MapLimit;

    fn manifest() -> Manifest {
        let config = TournamentConfig::parse(
            "maps = [\"fixed\"]\nseeds = [4, 5]\n[[team]]\nname = \"coop\"\nagents = [\"builtin\", \"./agent\"]\n",
        )
        .and_then(|c| c.resolve())
        .expect("valid");
        Manifest {
            program: "bw4t 0.1.0".into(),
            created_unix: 1_700_000_000,
            machine: Machine {
                os: "linux".into(),
                arch: "x86_64".into(),
                cores: 8,
                concurrency: 4,
                host: "lab".into(),
            },
            config_hash: config.config_hash(),
            config,
            setup: Setup {
                tick_limits: vec![MapLimit {
                    map: "fixed".into(),
                    max_ticks: 20_000,
                    from: "map".into(),
                    explanation: Some("one robot needs about 900 ticks".into()),
                }],
                fixed_content_maps: Vec::new(),
            },
            shard: Some(Shard { index: 2, count: 3 }),
            concurrency: 4,
            replays: ReplayPolicy::Failed,
            elapsed_seconds: 12.5,
            merged_from: None,
        }
    }

    #[test]
    fn a_manifest_reads_back_as_written_with_the_fields_readers_expect() {
        let written = manifest();
        let text = written.to_json();
        assert_eq!(Manifest::parse(&text).expect("reads back"), written);
        let json: serde_json::Value = serde_json::from_str(&text).expect("json");
        assert_eq!(json["shard"], "2/3");
        assert_eq!(json["replays"], "failed");
        assert_eq!(json["config"]["seeds"], serde_json::json!([4, 5]));
        assert_eq!(json["config"]["teams"][0]["agents"], serde_json::json!(["builtin", "./agent"]));
        assert_eq!(json["machine"]["cores"], 8);
        assert_eq!(json["setup"]["tick_limits"][0]["max_ticks"], 20_000);
        assert!(json.get("merged_from").is_none(), "only a merge names its sources: {json}");
        let merged = Manifest { shard: None, merged_from: Some(vec!["a".into(), "b".into()]), ..written };
        let json: serde_json::Value = serde_json::from_str(&merged.to_json()).expect("json");
        assert_eq!(
            (json["shard"].clone(), json["merged_from"].clone()),
            (serde_json::Value::Null, serde_json::json!(["a", "b"]))
        );
    }

    #[test]
    fn a_broken_or_old_manifest_names_the_problem() {
        let text = manifest().to_json();
        let without_setup = {
            let mut json: serde_json::Value = serde_json::from_str(&text).expect("json");
            json.as_object_mut().expect("object").remove("setup");
            json.to_string()
        };
        let cases = [
            (text.replace("\"2/3\"", "\"3/2\""), "'3/2' is not i/n"),
            (text.replace("\"failed\"", "\"some\""), "unknown variant `some`"),
            (without_setup, "missing field `setup`"),
            (text[..text.len() / 2].to_string(), "EOF while parsing"),
        ];
        for (broken, expected) in cases {
            let err = Manifest::parse(&broken).expect_err(expected).to_string();
            assert!(err.contains(expected), "expected '{expected}' in: {err}");
        }
    }
}
