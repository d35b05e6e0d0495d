//! FACS intensity: the letter scale 0/A–E and continuous fractions of an AU's maximum.
//!
//! HapFACS maps the letters to fixed fractions: A = 15 %, B = 30 %, C = 55 %, D = 85 %, E = 100 %.
//! A continuous intensity is any fraction in [0, 1]; it keeps its exact value so that notation
//! round-trips (`12@0.42` prints as `12@0.42`, not as the nearest letter).

use std::fmt;

/// A FACS intensity letter.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize, serde::Deserialize)]
pub enum IntensityLevel {
    A,
    B,
    C,
    D,
    E,
}

impl IntensityLevel {
    pub const ALL: [IntensityLevel; 5] = [Self::A, Self::B, Self::C, Self::D, Self::E];

    /// The fraction of the AU's maximum that HapFACS assigns to this letter.
    pub fn fraction(self) -> f64 {
        match self {
            Self::A => 0.15,
            Self::B => 0.30,
            Self::C => 0.55,
            Self::D => 0.85,
            Self::E => 1.0,
        }
    }

    pub fn from_letter(c: char) -> Option<Self> {
        match c {
            'A' => Some(Self::A),
            'B' => Some(Self::B),
            'C' => Some(Self::C),
            'D' => Some(Self::D),
            'E' => Some(Self::E),
            _ => None,
        }
    }

    pub fn letter(self) -> char {
        match self {
            Self::A => 'A',
            Self::B => 'B',
            Self::C => 'C',
            Self::D => 'D',
            Self::E => 'E',
        }
    }
}

/// How strongly an AU is shown.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Intensity {
    /// One of the FACS letters.
    Level(IntensityLevel),
    /// A fraction of the AU's maximum in [0, 1].
    Fraction(f64),
}

impl Intensity {
    /// Full intensity (E), the default for a stimulus AU written without a letter.
    pub const MAX: Intensity = Intensity::Level(IntensityLevel::E);

    /// A continuous intensity; `None` when `value` is not a finite number in [0, 1].
    pub fn fraction(value: f64) -> Option<Self> {
        (value.is_finite() && (0.0..=1.0).contains(&value)).then_some(Self::Fraction(value))
    }

    /// The fraction of the AU's maximum, in [0, 1].
    pub fn value(self) -> f64 {
        match self {
            Self::Level(level) => level.fraction(),
            Self::Fraction(value) => value,
        }
    }

    /// This intensity scaled by `factor` (e.g. an emotion shown at 50 %), as a fraction.
    pub fn scaled(self, factor: f64) -> Intensity {
        Intensity::Fraction((self.value() * factor).clamp(0.0, 1.0))
    }
}

impl fmt::Display for Intensity {
    /// Prints the suffix as written in notation: `C` or `@0.42`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Level(level) => write!(f, "{}", level.letter()),
            Self::Fraction(value) => write!(f, "@{value}"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn letters_follow_the_hapfacs_scale() {
        let fractions: Vec<f64> = IntensityLevel::ALL.iter().map(|l| l.fraction()).collect();
        assert_eq!(fractions, [0.15, 0.30, 0.55, 0.85, 1.0]);
    }

    #[test]
    fn fractions_outside_the_unit_interval_are_refused() {
        assert!(Intensity::fraction(-0.01).is_none());
        assert!(Intensity::fraction(1.01).is_none());
        assert!(Intensity::fraction(f64::NAN).is_none());
        assert_eq!(Intensity::fraction(0.42).map(Intensity::value), Some(0.42));
    }

    #[test]
    fn suffixes_print_as_written() {
        assert_eq!(Intensity::Level(IntensityLevel::C).to_string(), "C");
        assert_eq!(Intensity::Fraction(0.42).to_string(), "@0.42");
    }
}
