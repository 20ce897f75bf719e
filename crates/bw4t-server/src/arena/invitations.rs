//! Seat invitations: a secret token the arena grants for one player name in the matches of
//! one template, optionally with the seed a match made for them plays (a study grants one
//! to each participant for each trial). A template that seats only invited players refuses
//! everyone else, so no outsider sits in a participant's match and nobody takes a
//! participant's name there.

use std::collections::HashMap;
use std::sync::Mutex;

/// What a seat token was granted for.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct Invitation {
    /// The template.
    pub template: String,
    /// The player name.
    pub name: String,
    /// The seed a match made for the player plays (none: the template's next).
    pub seed: Option<u64>,
}

/// A seat: template, player name, seed.
type Seat = (String, String, Option<u64>);

/// The tokens granted since the server started, both ways round, so the same seat is
/// always given the same token (a page asking again gets what it was given before).
#[derive(Default)]
pub(crate) struct Invitations {
    granted: Mutex<Granted>,
}

#[derive(Default)]
struct Granted {
    by_token: HashMap<String, Invitation>,
    by_seat: HashMap<Seat, String>,
}

impl Invitations {
    /// The token of player `name`'s seat in `template`'s matches (playing `seed`, if
    /// given), made on first asking.
    pub(crate) fn grant(&self, template: &str, name: &str, seed: Option<u64>) -> String {
        let mut granted = self.granted.lock().unwrap_or_else(|p| p.into_inner());
        let seat = (template.to_string(), name.to_string(), seed);
        if let Some(token) = granted.by_seat.get(&seat) {
            return token.clone();
        }
        let token = crate::secret::random_token();
        let invitation = Invitation { template: seat.0.clone(), name: seat.1.clone(), seed };
        granted.by_token.insert(token.clone(), invitation);
        granted.by_seat.insert(seat, token.clone());
        token
    }

    /// What `token` was granted for, if it was.
    pub(crate) fn of(&self, token: &str) -> Option<Invitation> {
        let granted = self.granted.lock().unwrap_or_else(|p| p.into_inner());
        granted.by_token.get(token).cloned()
    }
}

#[cfg(test)]
mod tests {
    use super::{Invitation, Invitations};

    #[test]
    fn a_seat_keeps_its_token_and_no_two_seats_share_one() {
        let invitations = Invitations::default();
        let p1 = invitations.grant("talking", "P1", None);
        assert_eq!(invitations.grant("talking", "P1", None), p1, "asked again: the same token");
        let others = [
            invitations.grant("talking", "P2", None),
            invitations.grant("silent", "P1", None),
            invitations.grant("talking", "P1", Some(7)),
        ];
        assert!(others.iter().all(|t| t != &p1), "{p1} {others:?}");
        assert_eq!(invitations.grant("talking", "P1", Some(7)), others[2], "a seeded seat keeps its token");
        let expected = Invitation { template: "talking".into(), name: "P1".into(), seed: None };
        assert_eq!(invitations.of(&p1), Some(expected));
        assert_eq!(invitations.of(&others[2]).and_then(|i| i.seed), Some(7));
        assert_eq!(invitations.of("guessed"), None);
    }
}
