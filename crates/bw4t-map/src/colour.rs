//! The nine block colours of the spec, with their canonical names.

use std::fmt;
use std::str::FromStr;

/// A block colour. The spec names nine; original BW4T maps use seven of them in upper case.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Colour {
    /// Blue.
    Blue,
    /// Cyan.
    Cyan,
    /// Magenta.
    Magenta,
    /// Orange.
    Orange,
    /// Red.
    Red,
    /// White.
    White,
    /// Green.
    Green,
    /// Yellow.
    Yellow,
    /// Pink.
    Pink,
}

impl Colour {
    /// Every colour, in the spec's order (random content draws from this list).
    pub const ALL: [Colour; 9] = [
        Colour::Blue,
        Colour::Cyan,
        Colour::Magenta,
        Colour::Orange,
        Colour::Red,
        Colour::White,
        Colour::Green,
        Colour::Yellow,
        Colour::Pink,
    ];

    /// The spec's spelling, as used in percepts: `Blue`, `Cyan`, ...
    pub fn name(self) -> &'static str {
        match self {
            Colour::Blue => "Blue",
            Colour::Cyan => "Cyan",
            Colour::Magenta => "Magenta",
            Colour::Orange => "Orange",
            Colour::Red => "Red",
            Colour::White => "White",
            Colour::Green => "Green",
            Colour::Yellow => "Yellow",
            Colour::Pink => "Pink",
        }
    }
}

impl fmt::Display for Colour {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A colour name that is not one of the nine.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error(
    "unknown colour '{0}' (expected one of Blue, Cyan, Magenta, Orange, Red, White, Green, Yellow, Pink)"
)]
pub struct UnknownColour(pub String);

impl FromStr for Colour {
    type Err = UnknownColour;

    /// Case-insensitive, so the upper-case names of original maps parse too.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Colour::ALL
            .into_iter()
            .find(|c| c.name().eq_ignore_ascii_case(s))
            .ok_or_else(|| UnknownColour(s.to_string()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_in_any_case() {
        for c in Colour::ALL {
            assert_eq!(c.name().parse::<Colour>(), Ok(c));
            assert_eq!(c.name().to_uppercase().parse::<Colour>(), Ok(c));
        }
        assert_eq!("Purple".parse::<Colour>(), Err(UnknownColour("Purple".into())));
    }
}
