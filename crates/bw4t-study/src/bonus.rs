//! A study's performance bonus (`[bonus]`): an amount per block the participant delivered
//! in order and per block their team delivered, over the trials that count (practice
//! rounds apart), up to a maximum; the export's `participants.csv` gives it per person.

use serde::Deserialize;

/// `[bonus]`: how a participant's bonus is reckoned (amounts in the study's currency).
#[derive(Clone, Debug, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct Bonus {
    /// Per block the participant's own robot delivered in order.
    #[serde(default)]
    pub(crate) per_own_block: f64,
    /// Per block the team delivered in order.
    #[serde(default)]
    pub(crate) per_team_block: f64,
    /// At most this much in all.
    pub(crate) max: Option<f64>,
}

impl Bonus {
    /// The study file's `[bonus]`, checked: every amount a finite number, none negative.
    pub(crate) fn check(&self) -> Result<(), String> {
        let amounts =
            [("per_own_block", Some(self.per_own_block)), ("per_team_block", Some(self.per_team_block))];
        for (key, value) in amounts.into_iter().chain([("max", self.max)]) {
            if let Some(v) = value.filter(|v| !(v.is_finite() && *v >= 0.0)) {
                return Err(format!("bonus: {key} = {v}: expected an amount of 0 or more"));
            }
        }
        Ok(())
    }

    /// The `[bonus]` of a study file's table, if it has one that reads.
    pub(crate) fn of(study: &toml::Table) -> Option<Bonus> {
        study.get("bonus").and_then(|b| b.clone().try_into().ok())
    }

    /// The bonus for `own` blocks of the participant's and `team` of their teams', to the
    /// cent.
    pub(crate) fn amount(&self, own: u64, team: u64) -> f64 {
        let earned = self.per_own_block * own as f64 + self.per_team_block * team as f64;
        let capped = self.max.map_or(earned, |max| earned.min(max));
        (capped * 100.0).round() / 100.0
    }
}

#[cfg(test)]
mod tests {
    use super::Bonus;

    #[test]
    fn the_bonus_counts_own_and_team_blocks_up_to_the_maximum() {
        let bonus = Bonus { per_own_block: 0.1, per_team_block: 0.05, max: Some(1.0) };
        assert_eq!(bonus.amount(3, 6), 0.6);
        assert_eq!(bonus.amount(10, 12), 1.0, "capped");
        assert_eq!(Bonus::default().amount(5, 5), 0.0);
        assert!(Bonus { per_own_block: -1.0, ..Bonus::default() }.check().is_err());
        assert!(Bonus { max: Some(f64::NAN), ..Bonus::default() }.check().is_err());
        assert!(bonus.check().is_ok());
    }
}
