//! Tournaments on a cluster: the shard a job-array task plays, read from the variables
//! Slurm or a Kubernetes Indexed Job set; the directory each shard writes; and the hash
//! that tells whether shard directories belong to one configuration.

use crate::config::{Resolved, Shard};

/// Where `--shard auto` found its shard.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AutoShard {
    /// The shard.
    pub shard: Shard,
    /// The variables it came from, as `NAME=value`, for the log.
    pub from: String,
}

/// The variable a Kubernetes Indexed Job's manifest sets to its `completions` (the job
/// itself only gives each pod its index).
pub const SHARDS_VAR: &str = "BW4T_SHARDS";

/// The shard of this task of a job array: Slurm's `SLURM_ARRAY_TASK_ID` among
/// `SLURM_ARRAY_TASK_COUNT` (with `_MIN` and `_STEP` when the array does not start at 0 or
/// step by 1), else a Kubernetes Indexed Job's `JOB_COMPLETION_INDEX` among
/// [`SHARDS_VAR`]. `var` looks a variable up (the process environment, or a test's).
pub fn shard_from_env(var: impl Fn(&str) -> Option<String>) -> Result<AutoShard, String> {
    let number = |name: &str| -> Result<Option<u64>, String> {
        match var(name) {
            None => Ok(None),
            Some(text) => {
                text.trim().parse().map(Some).map_err(|_| format!("{name}={text:?} is not a whole number"))
            }
        }
    };
    if let Some(id) = number("SLURM_ARRAY_TASK_ID")? {
        let count = number("SLURM_ARRAY_TASK_COUNT")?.ok_or(
            "SLURM_ARRAY_TASK_ID is set but SLURM_ARRAY_TASK_COUNT is not (Slurm 20.11 or newer sets both)",
        )?;
        let min = number("SLURM_ARRAY_TASK_MIN")?.unwrap_or(0);
        let step = number("SLURM_ARRAY_TASK_STEP")?.unwrap_or(1).max(1);
        let offset = id
            .checked_sub(min)
            .ok_or(format!("SLURM_ARRAY_TASK_ID {id} is below SLURM_ARRAY_TASK_MIN {min}"))?;
        if offset % step != 0 {
            return Err(format!("SLURM_ARRAY_TASK_ID {id} is not on the array's step {step} from {min}"));
        }
        let from = format!(
            "SLURM_ARRAY_TASK_ID={id}, SLURM_ARRAY_TASK_COUNT={count}, SLURM_ARRAY_TASK_MIN={min}, step {step}"
        );
        return shard(offset / step, count, from);
    }
    if let Some(index) = number("JOB_COMPLETION_INDEX")? {
        let count = number(SHARDS_VAR)?.ok_or(format!(
            "JOB_COMPLETION_INDEX is set but {SHARDS_VAR} is not: the Job's manifest must set it to its completions"
        ))?;
        return shard(index, count, format!("JOB_COMPLETION_INDEX={index}, {SHARDS_VAR}={count}"));
    }
    Err("--shard auto: neither a Slurm array task (SLURM_ARRAY_TASK_ID) nor a Kubernetes Indexed Job \
         (JOB_COMPLETION_INDEX) is set; give --shard i/n"
        .into())
}

fn shard(offset: u64, count: u64, from: String) -> Result<AutoShard, String> {
    if count == 0 || offset >= count {
        return Err(format!("task {offset} of {count} is not a shard ({from})"));
    }
    Ok(AutoShard { shard: Shard { index: offset + 1, count }, from })
}

impl Shard {
    /// The directory this shard writes under a tournament's output directory:
    /// `shard-03-of-10`, numbered from 1 and padded so the names sort in order.
    pub fn dir_name(self) -> String {
        let width = self.count.to_string().len();
        format!("shard-{:0width$}-of-{}", self.index, self.count)
    }

    /// The shard a directory name of [`Shard::dir_name`] stands for.
    pub fn from_dir_name(name: &str) -> Option<Shard> {
        let (index, count) = name.strip_prefix("shard-")?.split_once("-of-")?;
        format!("{index}/{count}").parse().ok()
    }
}

impl Resolved {
    /// A short hash of the configuration as resolved (seeds, teams, maps, limits), the
    /// same for every shard of one tournament and different for any change that would
    /// make their rows incomparable: 64-bit FNV-1a of its canonical JSON, in hex.
    pub fn config_hash(&self) -> String {
        let text = serde_json::to_string(self).unwrap_or_default();
        format!("{:016x}", bw4t_map::fnv1a(text.bytes()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeMap;

    fn env(pairs: &[(&str, &str)]) -> impl Fn(&str) -> Option<String> {
        let map: BTreeMap<String, String> =
            pairs.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect();
        move |name| map.get(name).cloned()
    }

    #[test]
    fn slurm_and_kubernetes_tasks_give_their_shard_and_say_where_it_came_from() {
        let slurm = shard_from_env(env(&[("SLURM_ARRAY_TASK_ID", "2"), ("SLURM_ARRAY_TASK_COUNT", "4")]))
            .expect("slurm");
        assert_eq!(slurm.shard, Shard { index: 3, count: 4 });
        assert!(slurm.from.starts_with("SLURM_ARRAY_TASK_ID=2"), "{}", slurm.from);
        let offset = [
            ("SLURM_ARRAY_TASK_ID", "7"),
            ("SLURM_ARRAY_TASK_COUNT", "3"),
            ("SLURM_ARRAY_TASK_MIN", "3"),
            ("SLURM_ARRAY_TASK_STEP", "2"),
        ];
        assert_eq!(shard_from_env(env(&offset)).expect("stepped").shard, Shard { index: 3, count: 3 });
        let k8s = shard_from_env(env(&[("JOB_COMPLETION_INDEX", "0"), (SHARDS_VAR, "5")])).expect("k8s");
        assert_eq!(
            (k8s.shard, k8s.from.as_str()),
            (Shard { index: 1, count: 5 }, "JOB_COMPLETION_INDEX=0, BW4T_SHARDS=5")
        );
    }

    #[test]
    fn missing_or_inconsistent_variables_are_named() {
        let cases: [(&[(&str, &str)], &str); 5] = [
            (&[], "neither a Slurm array task"),
            (&[("SLURM_ARRAY_TASK_ID", "1")], "SLURM_ARRAY_TASK_COUNT is not"),
            (&[("SLURM_ARRAY_TASK_ID", "x"), ("SLURM_ARRAY_TASK_COUNT", "2")], "SLURM_ARRAY_TASK_ID=\"x\""),
            (&[("SLURM_ARRAY_TASK_ID", "4"), ("SLURM_ARRAY_TASK_COUNT", "4")], "task 4 of 4 is not a shard"),
            (&[("JOB_COMPLETION_INDEX", "1")], "BW4T_SHARDS is not"),
        ];
        for (vars, said) in cases {
            let error = shard_from_env(env(vars)).expect_err("refused");
            assert!(error.contains(said), "{vars:?}: {error}");
        }
    }

    #[test]
    fn shard_directories_are_named_in_order_and_read_back() {
        let names: Vec<String> = (1..=10).map(|i| Shard { index: i, count: 10 }.dir_name()).collect();
        assert_eq!((names[0].as_str(), names[9].as_str()), ("shard-01-of-10", "shard-10-of-10"));
        let mut sorted = names.clone();
        sorted.sort();
        assert_eq!(sorted, names);
        assert_eq!(Shard::from_dir_name("shard-03-of-10"), Some(Shard { index: 3, count: 10 }));
        assert_eq!(Shard::from_dir_name("shard-11-of-10"), None);
        assert_eq!(Shard::from_dir_name("merged"), None);
    }
}
