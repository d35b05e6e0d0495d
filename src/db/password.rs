//! The rule an admin password must meet.
//!
//! In: a username and a proposed password. Out: `Ok` or the reason it is refused. A password is
//! refused when it is shorter than [`MIN_LEN`] or longer than [`MAX_LEN`] characters, is built
//! from a common password (one of the most used, ignoring case and the digits and symbols
//! people add before or after it), is trivial (few distinct characters, a run such as
//! `abcdefghij` or `9876543210`, a keyboard row), or is mostly the username.

/// Fewest characters.
pub const MIN_LEN: usize = 10;
/// Most characters (argon2 hashes any length, but a form field needs a bound).
pub const MAX_LEN: usize = 256;

/// The cores of the most used passwords (lists of leaked passwords agree on these); a password
/// that is one of them, repeated or with digits and symbols around it, is refused.
const COMMON: &[&str] = &[
    "password", "passw0rd", "p@ssw0rd", "p@ssword", "qwerty", "qwertz", "azerty", "letmein", "welcome", "admin", "administrator", "root", "login",
    "iloveyou", "monkey", "dragon", "football", "baseball", "soccer", "hockey", "basketball", "master", "sunshine", "princess", "shadow", "superman",
    "batman", "trustno1", "starwars", "whatever", "freedom", "secret", "changeme", "default", "computer", "internet", "michael", "jennifer",
    "charlie", "jordan", "hunter", "ranger", "buster", "thomas", "tigger", "robert", "soccer", "killer", "pepper", "ginger", "cheese", "summer",
    "winter", "spring", "autumn", "flower", "hello", "helloworld", "abc", "test", "testing", "guest", "user", "facslab", "study", "research",
    "university", "student", "lab", "access", "mustang", "harley", "matrix", "zaq1zaq1", "1q2w3e4r", "1qaz2wsx", "qazwsx", "asdf", "zxcv",
];

/// Keyboard rows as typed (a password drawn from one row alone is trivial).
const ROWS: &[&str] = &["1234567890", "qwertyuiop", "asdfghjkl", "zxcvbnm", "qwertzuiop", "azertyuiop"];

/// Walks over the keyboard (a password that is a piece of one, either way, is trivial).
const WALKS: &[&str] = &["1234567890", "qwertyuiop", "asdfghjkl", "zxcvbnm", "1qaz2wsx3edc4rfv5tgb6yhn7ujm8ik9ol0p", "1q2w3e4r5t6y7u8i9o0p", "qwertzuiop", "azertyuiop"];

/// Why a password is refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct WeakPassword(&'static str);

/// Checks `password` for the account `username`.
pub fn check(username: &str, password: &str) -> Result<(), WeakPassword> {
    let length = password.chars().count();
    if length < MIN_LEN {
        return Err(WeakPassword("a password needs at least 10 characters"));
    }
    if length > MAX_LEN {
        return Err(WeakPassword("a password has at most 256 characters"));
    }
    let lower = password.to_lowercase();
    if common(&lower) {
        return Err(WeakPassword("this password is one of the most used ones (or one with digits or symbols added); choose another"));
    }
    if trivial(&lower) {
        return Err(WeakPassword("this password is too easy to guess (few different characters, a run such as abcdef or 987654, or a keyboard row)"));
    }
    let user = username.trim().to_lowercase();
    if user.chars().count() >= 3 && lower.replace(&user, "").chars().count() < 6 {
        return Err(WeakPassword("this password is mostly the username"));
    }
    Ok(())
}

/// A common password's core, once or repeated, with only digits, symbols and spaces around it.
fn common(lower: &str) -> bool {
    let core = lower.trim_matches(|c: char| !c.is_alphabetic());
    let core = if core.is_empty() { lower } else { core };
    COMMON.iter().any(|word| {
        let rest = core.replace(word, "");
        core.contains(word) && rest.chars().all(|c| !c.is_alphabetic())
    })
}

/// Few distinct characters, one arithmetic run, or a piece of a keyboard row.
fn trivial(lower: &str) -> bool {
    let chars: Vec<char> = lower.chars().collect();
    let mut distinct = chars.clone();
    distinct.sort_unstable();
    distinct.dedup();
    if distinct.len() < 5 {
        return true;
    }
    let steps: Vec<i64> = chars.windows(2).map(|w| i64::from(u32::from(w[1])) - i64::from(u32::from(w[0]))).collect();
    if steps.iter().all(|s| *s == steps[0]) && steps[0].abs() <= 1 {
        return true;
    }
    let reversed: String = lower.chars().rev().collect();
    WALKS.iter().any(|walk| walk.contains(lower) || walk.contains(reversed.as_str())) || ROWS.iter().any(|row| lower.chars().all(|c| row.contains(c)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn common_and_trivial_passwords_are_refused() {
        for weak in [
            "password", "Password123!", "password1234", "PASSWORDPASSWORD", "qwertyuiop", "Qwerty123456", "1234567890", "0987654321", "abcdefghijk",
            "aaaaaaaaaaaa", "abababababab", "iloveyou2024", "letmein!!!!!", "zxcvbnmzxcvbnm", "alice-alice-1", "admin2026!!!", "1q2w3e4r5t",
        ] {
            assert!(check("alice", weak).is_err(), "{weak} was accepted");
        }
    }

    #[test]
    fn good_passwords_are_accepted() {
        for good in ["correct horse battery", "Tram-Lilac-Otter-41", "9f3c21d07e5a44b1", "my cat eats plums at noon"] {
            assert_eq!(check("alice", good), Ok(()), "{good}");
        }
        assert!(check("alice", &"x7Kp".repeat(70)).is_err(), "too long");
    }
}
