//! Worker ids from recruitment platforms, normalised and checked.
//!
//! In: the raw value of a platform's worker parameter (`PROLIFIC_PID`, `workerId`, `id`).
//! Out: the one spelling the study stores, or why the value is not an id of that platform.
//! Invariant: two values that a person would read as the same id (case, surrounding spaces,
//! no-break or full-width characters, zero-width and other invisible characters) normalise to
//! the same string, so they find the same participation. Normalisation is Unicode NFKC, then
//! invisible and control characters are removed, then spaces are trimmed; each platform's
//! format fixes the case.

use unicode_normalization::UnicodeNormalization;

use super::Platform;

/// Longest raw value looked at (a real id is far shorter).
pub const MAX_RAW_LEN: usize = 200;

/// Why a worker id was refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("the {param} \"{excerpt}\" is not a {platform} id ({format})")]
pub struct WorkerIdError {
    pub param: &'static str,
    pub platform: &'static str,
    pub excerpt: String,
    pub format: &'static str,
}

/// Characters that show nothing: format characters (zero-width spaces and joiners, bidi
/// controls, the byte-order mark, soft hyphens), variation selectors and fillers.
fn invisible(c: char) -> bool {
    c.is_control()
        || matches!(c as u32,
            0x00AD | 0x034F | 0x061C | 0x115F | 0x1160 | 0x17B4 | 0x17B5 | 0x180B..=0x180F
            | 0x200B..=0x200F | 0x202A..=0x202E | 0x2060..=0x206F | 0x3164 | 0xFE00..=0xFE0F
            | 0xFEFF | 0xFFA0 | 0x1BCA0..=0x1BCA3 | 0x1D173..=0x1D17A | 0xE0000..=0xE0FFF)
}

/// NFKC, without invisible characters, trimmed.
pub fn clean(raw: &str) -> String {
    let text: String = raw.chars().take(MAX_RAW_LEN).nfkc().filter(|c| !invisible(*c)).collect();
    text.trim().to_string()
}

/// A short, printable excerpt of a refused value (at most 24 characters).
fn excerpt(text: &str) -> String {
    let visible: String = text.chars().take(MAX_RAW_LEN).filter(|c| !invisible(*c)).collect();
    super::excerpt(&visible, 24)
}

/// The stored spelling of `raw` as a worker id of `platform`.
pub fn normalise(platform: Platform, raw: &str) -> Result<String, WorkerIdError> {
    let text = clean(raw);
    let (param, format, id) = match platform {
        // Prolific participant ids are 24 hexadecimal digits.
        Platform::Prolific => ("PROLIFIC_PID", "24 hexadecimal digits", Some(text.to_ascii_lowercase()).filter(|t| t.len() == 24 && t.bytes().all(|b| b.is_ascii_hexdigit()))),
        // MTurk worker ids are upper-case letters and digits, starting with A.
        Platform::Mturk => (
            "workerId",
            "10 to 24 letters and digits starting with A",
            Some(text.to_ascii_uppercase()).filter(|t| (10..=24).contains(&t.len()) && t.starts_with('A') && t.bytes().all(|b| b.is_ascii_alphanumeric())),
        ),
        // SONA survey codes are letters and digits.
        Platform::Sona => ("id", "1 to 32 letters and digits", Some(text.to_ascii_lowercase()).filter(|t| (1..=32).contains(&t.len()) && t.bytes().all(|b| b.is_ascii_alphanumeric()))),
        Platform::Local => ("worker id", "any text", Some(text.clone()).filter(|t| !t.is_empty())),
    };
    id.ok_or_else(|| WorkerIdError { param, platform: platform.as_str(), excerpt: excerpt(raw), format })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spellings_of_one_id_are_one_id() {
        let id = "5f1a2b3c4d5e6f708192a3b4";
        for variant in [
            "5F1A2B3C4D5E6F708192A3B4",
            " 5f1a2b3c4d5e6f708192a3b4 ",
            "5f1a2b3c4d5e6f708192a3b4\u{a0}",
            "\u{200b}5f1a2b3c4d5e6f708192a3b4\u{feff}",
            "5f1a2b3c4d5e6f70\u{200d}8192a3b4",
            "５ｆ１ａ2b3c4d5e6f708192a3b4",
        ] {
            assert_eq!(normalise(Platform::Prolific, variant).as_deref(), Ok(id), "{variant:?}");
        }
        assert_eq!(normalise(Platform::Mturk, "a1b2c3d4e5f6g7\u{2060}").as_deref(), Ok("A1B2C3D4E5F6G7"));
        assert_eq!(normalise(Platform::Sona, " 12345\u{200b}").as_deref(), Ok("12345"));
    }

    #[test]
    fn other_shapes_are_refused_with_a_short_excerpt() {
        assert!(normalise(Platform::Prolific, "w1").is_err());
        assert!(normalise(Platform::Prolific, "5f1a2b3c4d5e6f708192a3bZ").is_err());
        assert!(normalise(Platform::Mturk, "B1B2C3D4E5F6G7").is_err());
        assert!(normalise(Platform::Mturk, "A1B2-3D4E5F6G7").is_err());
        assert!(normalise(Platform::Sona, "").is_err());
        let long = "x".repeat(5_000);
        let message = normalise(Platform::Prolific, &long).unwrap_err().to_string();
        assert!(message.len() < 150, "{message}");
    }
}
