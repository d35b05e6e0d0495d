//! FACS notation as coders write it: `1+2+4B+L12C+R14`, `12@0.42`, `0` for neutral.
//!
//! Grammar (spaces around `+` are allowed; an optional `AU` prefix is accepted and not printed):
//!
//! ```text
//! expression := "" | "0" | term ("+" term)*
//! term       := ["AU"] [side] code [intensity]
//! side       := "L" | "R"                      (unilateral; none = both sides)
//! intensity  := "A" | "B" | "C" | "D" | "E"    (15/30/55/85/100 %)
//!             | "@" number                     (fraction of the maximum, in [0, 1])
//! ```
//!
//! A term without intensity means "E" for a stimulus and "present" for a coder's answer; the
//! difference is kept ([`Activation::intensity`] is `None`) so printing gives back what was
//! written. Errors name the offending token and its 1-based character column.

use std::fmt;

use super::catalog::{AuCode, Catalog};
use super::intensity::{Intensity, IntensityLevel};

/// Which side of the face an AU acts on (the person's own left and right).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Laterality {
    Both,
    Left,
    Right,
}

impl Laterality {
    fn prefix(self) -> &'static str {
        match self {
            Laterality::Both => "",
            Laterality::Left => "L",
            Laterality::Right => "R",
        }
    }

    fn overlaps(self, other: Laterality) -> bool {
        self == other || self == Laterality::Both || other == Laterality::Both
    }
}

/// One AU in an expression.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Activation {
    pub au: AuCode,
    pub side: Laterality,
    /// `None` when written without a letter or fraction.
    pub intensity: Option<Intensity>,
}

impl Activation {
    /// The intensity to render: the written one, or E when none was written.
    pub fn strength(&self) -> f64 {
        self.intensity.unwrap_or(Intensity::MAX).value()
    }
}

impl fmt::Display for Activation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}{}", self.side.prefix(), self.au)?;
        match self.intensity {
            Some(intensity) => write!(f, "{intensity}"),
            None => Ok(()),
        }
    }
}

/// A set of AU activations: what a face shows, or what a coder says it shows.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Expression {
    activations: Vec<Activation>,
}

impl Expression {
    /// The neutral face.
    pub fn neutral() -> Expression {
        Expression::default()
    }

    /// The activations in the order they were written.
    pub fn activations(&self) -> &[Activation] {
        &self.activations
    }

    pub fn is_neutral(&self) -> bool {
        self.activations.is_empty()
    }

    /// Every activation with its intensity multiplied by `factor` (an emotion at 50 %).
    pub fn scaled(&self, factor: f64) -> Expression {
        let activations = self
            .activations
            .iter()
            .map(|a| Activation { intensity: Some(a.intensity.unwrap_or(Intensity::MAX).scaled(factor)), ..*a })
            .collect();
        Expression { activations }
    }

    /// The distinct AU codes present, ordered by code.
    pub fn codes(&self) -> Vec<AuCode> {
        let mut codes: Vec<AuCode> = self.activations.iter().map(|a| a.au).collect();
        codes.sort();
        codes.dedup();
        codes
    }

    /// Builds an expression from activations already known to be valid for `catalog`.
    pub fn from_activations(activations: Vec<Activation>, catalog: &Catalog) -> Result<Expression, NotationError> {
        let text = Expression { activations }.to_string();
        parse(&text, catalog)
    }
}

impl fmt::Display for Expression {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.activations.is_empty() {
            return write!(f, "0");
        }
        for (i, activation) in self.activations.iter().enumerate() {
            if i > 0 {
                write!(f, "+")?;
            }
            write!(f, "{activation}")?;
        }
        Ok(())
    }
}

/// What was wrong with a piece of notation.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum NotationErrorKind {
    #[error("empty term (two '+' in a row, or a '+' at an end)")]
    EmptyTerm,
    #[error("expected an AU number")]
    MissingCode,
    #[error("AU {0} is not in the catalog")]
    UnknownAu(u16),
    #[error("AU {0} cannot be shown on one side only")]
    NotUnilateral(u16),
    #[error("unexpected '{0}' (an intensity is one of A-E or @ followed by a fraction in [0, 1])")]
    BadIntensity(String),
    #[error("intensity {0} is outside [0, 1]")]
    FractionOutOfRange(String),
    #[error("AU {0} appears twice on the same side")]
    Duplicate(u16),
}

/// Longest FACS expression (bytes) that any input path accepts: the CLI, set specs, timelines
/// and the studio. Every catalog AU with a side and an intensity is well under this.
pub const MAX_NOTATION_LEN: usize = 512;

/// A notation error with the token and where it starts.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("in FACS expression \"{input}\": token \"{token}\" at column {column}: {kind}")]
pub struct NotationError {
    pub input: String,
    pub token: String,
    /// 1-based character column where the token starts.
    pub column: usize,
    pub kind: NotationErrorKind,
}

/// Parses `text` and validates it against `catalog`.
pub(crate) fn parse(text: &str, catalog: &Catalog) -> Result<Expression, NotationError> {
    let trimmed = text.trim();
    if trimmed.is_empty() || trimmed == "0" {
        return Ok(Expression::neutral());
    }
    let mut activations: Vec<Activation> = Vec::new();
    for (offset, raw) in split_terms(text) {
        let token = raw.trim();
        let column = text[..offset + (raw.len() - raw.trim_start().len())].chars().count() + 1;
        let fail = |kind| NotationError { input: text.to_string(), token: token.to_string(), column, kind };
        let activation = parse_term(token).map_err(fail)?;
        let unit = catalog.get(activation.au).ok_or_else(|| fail(NotationErrorKind::UnknownAu(activation.au.0)))?;
        if activation.side != Laterality::Both && !unit.unilateral {
            return Err(fail(NotationErrorKind::NotUnilateral(activation.au.0)));
        }
        if activations.iter().any(|a| a.au == activation.au && a.side.overlaps(activation.side)) {
            return Err(fail(NotationErrorKind::Duplicate(activation.au.0)));
        }
        activations.push(activation);
    }
    Ok(Expression { activations })
}

/// Splits on `+`, giving each piece with its byte offset.
fn split_terms(text: &str) -> impl Iterator<Item = (usize, &str)> {
    let mut start = 0;
    text.split('+').map(move |piece| {
        let at = start;
        start += piece.len() + 1;
        (at, piece)
    })
}

fn parse_term(token: &str) -> Result<Activation, NotationErrorKind> {
    if token.is_empty() {
        return Err(NotationErrorKind::EmptyTerm);
    }
    let rest = token.strip_prefix("AU").or_else(|| token.strip_prefix("au")).unwrap_or(token);
    let (side, rest) = match rest.as_bytes().first() {
        Some(b'L') => (Laterality::Left, &rest[1..]),
        Some(b'R') => (Laterality::Right, &rest[1..]),
        _ => (Laterality::Both, rest),
    };
    let digits = rest.bytes().take_while(u8::is_ascii_digit).count();
    if digits == 0 {
        return Err(NotationErrorKind::MissingCode);
    }
    let code: u16 = rest[..digits].parse().map_err(|_| NotationErrorKind::UnknownAu(u16::MAX))?;
    let intensity = parse_intensity(&rest[digits..])?;
    Ok(Activation { au: AuCode(code), side, intensity })
}

fn parse_intensity(suffix: &str) -> Result<Option<Intensity>, NotationErrorKind> {
    if suffix.is_empty() {
        return Ok(None);
    }
    if let Some(number) = suffix.strip_prefix('@') {
        let value: f64 = number.parse().map_err(|_| NotationErrorKind::BadIntensity(suffix.to_string()))?;
        return Intensity::fraction(value)
            .map(Some)
            .ok_or_else(|| NotationErrorKind::FractionOutOfRange(number.to_string()));
    }
    let mut chars = suffix.chars();
    match (chars.next().and_then(IntensityLevel::from_letter), chars.next()) {
        (Some(level), None) => Ok(Some(Intensity::Level(level))),
        _ => Err(NotationErrorKind::BadIntensity(suffix.to_string())),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn parse(text: &str) -> Result<Expression, NotationError> {
        Catalog::built_in().parse(text)
    }

    #[test]
    fn parses_the_canonical_example() {
        let e = parse("1+2+4B+L12C+R14").unwrap();
        let a = e.activations();
        assert_eq!(a.len(), 5);
        assert_eq!(a[2].intensity, Some(Intensity::Level(IntensityLevel::B)));
        assert_eq!((a[3].side, a[3].au), (Laterality::Left, AuCode(12)));
        assert_eq!(a[4].side, Laterality::Right);
        assert_eq!(a[4].strength(), 1.0);
        assert_eq!(e.to_string(), "1+2+4B+L12C+R14");
    }

    #[test]
    fn continuous_intensity_and_spaces() {
        let e = parse(" 12@0.42 + 25 ").unwrap();
        assert_eq!(e.activations()[0].strength(), 0.42);
        assert_eq!(e.to_string(), "12@0.42+25");
        assert_eq!(parse("AU6+AU12").unwrap().to_string(), "6+12");
    }

    #[test]
    fn neutral_forms() {
        assert!(parse("").unwrap().is_neutral());
        assert!(parse("0").unwrap().is_neutral());
        assert_eq!(Expression::neutral().to_string(), "0");
    }

    #[test]
    fn errors_name_the_token_and_column() {
        let err = parse("1+2+99C").unwrap_err();
        assert_eq!((err.token.as_str(), err.column), ("99C", 5));
        assert_eq!(err.kind, NotationErrorKind::UnknownAu(99));
        let err = parse("1 + L26").unwrap_err();
        assert_eq!((err.token.as_str(), err.column, err.kind), ("L26", 5, NotationErrorKind::NotUnilateral(26)));
        assert_eq!(parse("1++2").unwrap_err().kind, NotationErrorKind::EmptyTerm);
        assert_eq!(parse("12F").unwrap_err().kind, NotationErrorKind::BadIntensity("F".into()));
        assert_eq!(parse("12@1.5").unwrap_err().kind, NotationErrorKind::FractionOutOfRange("1.5".into()));
        assert_eq!(parse("12+L12").unwrap_err().kind, NotationErrorKind::Duplicate(12));
        assert_eq!(parse("x").unwrap_err().kind, NotationErrorKind::MissingCode);
        assert!(parse("L12+R12B").is_ok());
    }

    #[test]
    fn scaling_halves_every_intensity() {
        let e = parse("12+R14C").unwrap().scaled(0.5);
        assert_eq!(e.to_string(), "12@0.5+R14@0.275");
    }

    fn activation() -> impl Strategy<Value = Activation> {
        let units: Vec<_> = Catalog::built_in().iter().cloned().collect();
        let intensity = prop_oneof![
            Just(None),
            proptest::sample::select(IntensityLevel::ALL.to_vec()).prop_map(|l| Some(Intensity::Level(l))),
            (0.0f64..=1.0).prop_map(|v| Some(Intensity::Fraction(v))),
        ];
        (proptest::sample::select(units), any::<u8>(), intensity).prop_map(|(unit, s, intensity)| {
            let side = match (unit.unilateral, s % 3) {
                (true, 1) => Laterality::Left,
                (true, 2) => Laterality::Right,
                _ => Laterality::Both,
            };
            Activation { au: unit.code, side, intensity }
        })
    }

    proptest! {
        #[test]
        fn printing_then_parsing_gives_the_same_expression(list in proptest::collection::vec(activation(), 0..8)) {
            let mut kept: Vec<Activation> = Vec::new();
            for a in list {
                if !kept.iter().any(|k| k.au == a.au && k.side.overlaps(a.side)) {
                    kept.push(a);
                }
            }
            let expression = Expression { activations: kept };
            let text = expression.to_string();
            let back = parse(&text).unwrap();
            prop_assert_eq!(&back, &expression);
            prop_assert_eq!(back.to_string(), text);
        }
    }
}
