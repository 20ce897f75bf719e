//! Which slot an arrival takes. A slot fixes a participant's group (the groups in turn),
//! their order's row (their turn within the group) and their matches' seeds. Balanced over
//! arrivals, the n-th arrival takes slot n; balanced over completers, an arrival takes the
//! lowest slot that nobody holds (a slot is held by a participant who completed or is
//! still going: not declined, not screened out, not silent for `dropout_after_s`), so a
//! slot given up goes to the next arrival. Either way a slot whose group has a condition
//! at its quota (counting the holders who play it) is passed over; with none left, the
//! study is full.

use super::config::{Balance, Study};
use super::flow::group_of;

/// A participant holding a slot: the slot, and the conditions they play.
pub(crate) struct Holder {
    pub slot: u64,
    pub conditions: Vec<usize>,
}

/// The slot the arrival numbered `number` (from 0) takes, given who holds one now;
/// `None` if every group is at a quota.
pub(crate) fn slot_for(study: &Study, number: u64, holders: &[Holder]) -> Option<u64> {
    let groups = study.groups.len() as u64;
    let playing = |c: usize| holders.iter().filter(|h| h.conditions.contains(&c)).count() as u64;
    let full: Vec<bool> = study
        .groups
        .iter()
        .map(|g| g.conditions.iter().any(|c| study.conditions[*c].quota.is_some_and(|q| playing(*c) >= q)))
        .collect();
    let open = |slot: u64| !full[group_of(study, slot)];
    match study.balance {
        // One turn of the groups from the arrival's own slot.
        Balance::Arrivals => (number..number + groups).find(|s| open(*s)),
        Balance::Completers => {
            let held: std::collections::BTreeSet<u64> = holders.iter().map(|h| h.slot).collect();
            // Past the highest held slot, one turn of the groups has every group.
            let end = held.last().map_or(0, |s| s + 1) + groups;
            (0..end).find(|s| !held.contains(s) && open(*s))
        }
    }
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::{Holder, slot_for};
    use crate::flow::{Participant, group_of, order_for};
    use crate::parse;

    /// The conditions slot `slot` plays (its group's), as a holder of it counts them.
    fn conditions_of(study: &crate::Study, slot: u64) -> Vec<usize> {
        order_for(study, slot, "")
    }

    fn default_map(_: &str) -> Result<bw4t_map::Map, String> {
        bw4t_map::Map::from_native(include_str!("../../../maps/default.toml")).map_err(|e| e.to_string())
    }

    fn study(study: &str, conditions: &[&str], trials: usize) -> crate::Study {
        let mut text = format!("[study]\nname = \"s\"\n{study}\n");
        for c in conditions {
            text += &format!("[[condition]]\n{c}\n");
        }
        text += &"[[page]]\nkind = \"trial\"\n".repeat(trials);
        text += "[[page]]\nkind = \"final\"\n";
        parse(&text, Path::new("s.toml"), &default_map).expect("a good study")
    }

    fn held(study: &crate::Study, slots: &[u64]) -> Vec<Holder> {
        slots.iter().map(|s| Holder { slot: *s, conditions: conditions_of(study, *s) }).collect()
    }

    #[test]
    fn between_subjects_fills_the_lowest_slot_given_up_and_keeps_the_groups_even() {
        let s = study("assignment = \"between\"", &["name = \"a\"", "name = \"b\"", "name = \"c\""], 2);
        assert_eq!(slot_for(&s, 0, &[]), Some(0));
        // Slots 0..5 taken; slot 1 (group b) given up: the next arrival takes it.
        assert_eq!(slot_for(&s, 6, &held(&s, &[0, 2, 3, 4, 5])), Some(1));
        assert_eq!(group_of(&s, 1), 1);
        assert_eq!(slot_for(&s, 6, &held(&s, &[0, 1, 2])), Some(3));
        // Each participant plays one condition on every trial page.
        assert_eq!(order_for(&s, 4, "x"), [1]);
    }

    #[test]
    fn mixed_designs_pick_a_group_then_a_row_within_it() {
        let conditions = [
            "name = \"a1\"\nbetween = \"a\"",
            "name = \"b1\"\nbetween = \"b\"",
            "name = \"a2\"\nbetween = \"a\"",
            "name = \"b2\"\nbetween = \"b\"",
        ];
        let s = study("assignment = \"mixed\"", &conditions, 2);
        let orders: Vec<Vec<usize>> = (0..5).map(|slot| order_for(&s, slot, "x")).collect();
        // Groups in turn (a, b, a, b, ...), each group's rows in turn.
        assert_eq!(orders, [vec![0, 2], vec![1, 3], vec![2, 0], vec![3, 1], vec![0, 2]]);
    }

    #[test]
    fn within_subjects_over_arrivals_takes_the_arrival_number_as_always() {
        let s = study("", &["name = \"a\"", "name = \"b\""], 2);
        assert_eq!(slot_for(&s, 5, &held(&s, &[0])), Some(5));
        assert_eq!(order_for(&s, 5, "x"), [1, 0]);
    }

    #[test]
    fn a_group_at_a_quota_is_passed_over_and_all_full_is_full() {
        let s = study("assignment = \"between\"", &["name = \"a\"\nquota = 1", "name = \"b\"\nquota = 2"], 1);
        assert_eq!(slot_for(&s, 1, &held(&s, &[0])), Some(1), "a is full: b");
        assert_eq!(slot_for(&s, 2, &held(&s, &[0, 1])), Some(3), "slot 2 is a's: passed over");
        assert_eq!(slot_for(&s, 3, &held(&s, &[0, 1, 3])), None, "both full");
        // Under within, a condition's quota caps the study.
        let s = study("balance = \"completers\"", &["name = \"a\"\nquota = 2", "name = \"b\""], 2);
        assert_eq!(slot_for(&s, 2, &held(&s, &[0])), Some(1));
        assert_eq!(slot_for(&s, 2, &held(&s, &[0, 1])), None);
    }

    #[test]
    fn a_participant_silent_past_the_dropout_time_gives_up_their_slot() {
        let s = study("assignment = \"between\"\ndropout_after_s = 60", &["name = \"a\"", "name = \"b\""], 1);
        let mut p = Participant::new("p", 0, vec![0], 1_000);
        assert!(p.holds_slot(&s, 61_000), "60 s after their last record they still hold it");
        assert!(!p.holds_slot(&s, 61_001));
        p.declined = true;
        assert!(!p.holds_slot(&s, 1_000), "a decliner holds none");
        let mut done = Participant::new("q", 1, vec![1], 0);
        done.step = 1;
        assert!(done.holds_slot(&s, u64::MAX), "a completer always holds theirs");
        done.screened_out = true;
        assert!(!done.holds_slot(&s, 0), "one screened out holds none");
    }
}
