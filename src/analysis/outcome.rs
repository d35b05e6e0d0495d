//! A statistic that the data may leave undefined, as the report states it.
//!
//! In: the `Result` of a statistic. Out: either the statistic itself or `{"undefined": "why"}`
//! in `report.json` (no serde `Ok`/`Err` wrappers). Invariant: an undefined statistic always
//! says why.

use serde::Serialize;

/// A computed statistic, or the reason it is undefined on these data.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(untagged)]
pub enum Outcome<T> {
    Defined(T),
    Undefined { undefined: String },
}

impl<T> Outcome<T> {
    /// The statistic, or the reason it is undefined.
    pub fn as_result(&self) -> Result<&T, &str> {
        match self {
            Outcome::Defined(value) => Ok(value),
            Outcome::Undefined { undefined } => Err(undefined),
        }
    }

    pub fn map<U>(self, f: impl FnOnce(T) -> U) -> Outcome<U> {
        match self {
            Outcome::Defined(value) => Outcome::Defined(f(value)),
            Outcome::Undefined { undefined } => Outcome::Undefined { undefined },
        }
    }
}

impl<T, E: std::fmt::Display> From<Result<T, E>> for Outcome<T> {
    fn from(result: Result<T, E>) -> Outcome<T> {
        match result {
            Ok(value) => Outcome::Defined(value),
            Err(e) => Outcome::Undefined { undefined: e.to_string() },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn serialises_without_wrappers() {
        let defined: Outcome<f64> = Ok::<_, String>(1.5).into();
        let undefined: Outcome<f64> = Err::<f64, _>("zero variance").into();
        assert_eq!(serde_json::to_string(&defined).unwrap(), "1.5");
        assert_eq!(serde_json::to_string(&undefined).unwrap(), r#"{"undefined":"zero variance"}"#);
        assert_eq!(undefined.as_result(), Err("zero variance"));
    }
}
