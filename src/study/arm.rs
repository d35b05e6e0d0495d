//! Between-subject arms: a study may split its participants into arms, each seeing only the
//! stimuli of its own media and peak intensities (HapFACS Exp. 3 showed four separate groups
//! images 50 %, images 100 %, videos 50 % and videos 100 %; seed 001 §4.2, Table 6).
//!
//! In: the `[[arm]]` tables of a design; the number of participants each arm counts now.
//! Out: validated [`Arm`]s; whether an arm admits a stimulus; the arm a new participant
//! joins ([`choose_arm`]).
//!
//! Invariants: arm names are unique, 1-32 characters of a-z, 0-9, '-' or '_'; a new
//! participant joins an arm with the fewest counted participants (ties broken by the
//! participant's seed), so arm sizes never differ by more than one while participants
//! finish; every arm admits at least one of the study's stimuli (checked when the study is
//! created, `db::studies`).

use serde::Deserialize;

use super::design::{DesignError, MediaFilter, check_intensities, fail};
use crate::seeded::SplitMix64;
use crate::stimuli::manifest::Media;

/// One arm: the stimuli of these media and peak intensities.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Arm {
    pub name: String,
    #[serde(default)]
    pub media: MediaFilter,
    /// Peak intensities in whole percent (empty: every one).
    #[serde(default)]
    pub intensities: Vec<u32>,
}

/// Most arms a design may declare.
pub const MAX_ARMS: usize = 16;

impl Arm {
    /// Whether a stimulus of `media` with peak `intensity` (in [0, 1]) belongs to this arm.
    pub fn admits(&self, media: Media, intensity: f64) -> bool {
        super::design::admits(self.media, &self.intensities, media, intensity)
    }
}

/// Checks the `[[arm]]` tables: names, filters, no repeats, at most [`MAX_ARMS`].
pub fn check_arms(arms: &[Arm]) -> Result<(), DesignError> {
    if arms.len() > MAX_ARMS {
        return Err(fail("arm", format!("{} arms is over the limit of {MAX_ARMS}", arms.len())));
    }
    for (i, arm) in arms.iter().enumerate() {
        let field = format!("arm[{}]", i + 1);
        let name_ok = !arm.name.is_empty() && arm.name.len() <= 32 && arm.name.bytes().all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'-' || b == b'_');
        if !name_ok {
            return Err(fail(format!("{field}.name"), format!("\"{}\" must be 1-32 characters of a-z, 0-9, '-' or '_'", super::excerpt(&arm.name, 32))));
        }
        if arms[..i].iter().any(|a| a.name == arm.name) {
            return Err(fail(format!("{field}.name"), format!("\"{}\" is declared twice", arm.name)));
        }
        check_intensities(&arm.intensities).map_err(|e| fail(format!("{field}.{}", e.field), e.message))?;
    }
    Ok(())
}

/// The arm (index into `counts`) a new participant joins: one with the fewest counted
/// participants, ties broken by `seed`. `counts` must not be empty.
pub fn choose_arm(counts: &[usize], seed: u64) -> usize {
    let fewest = counts.iter().copied().min().unwrap_or(0);
    let tied: Vec<usize> = (0..counts.len()).filter(|&i| counts[i] == fewest).collect();
    let mut rng = SplitMix64(seed ^ 0xA2A2_0000);
    tied.get(rng.below(tied.len())).copied().unwrap_or(0)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn arm(name: &str, media: MediaFilter, intensities: &[u32]) -> Arm {
        Arm { name: name.into(), media, intensities: intensities.to_vec() }
    }

    #[test]
    fn arms_admit_their_media_and_intensities() {
        let a = arm("video-50", MediaFilter::Video, &[50]);
        assert!(a.admits(Media::Video, 0.5));
        assert!(!a.admits(Media::Video, 1.0) && !a.admits(Media::Image, 0.5));
        assert!(arm("all", MediaFilter::All, &[]).admits(Media::Image, 0.3));
    }

    #[test]
    fn bad_arms_are_named() {
        let cases = [
            (vec![arm("Video 50", MediaFilter::Video, &[])], "arm[1].name"),
            (vec![arm("a", MediaFilter::All, &[]), arm("a", MediaFilter::Image, &[])], "arm[2].name"),
            (vec![arm("a", MediaFilter::All, &[150])], "arm[1].intensities"),
            ((0..17).map(|i| arm(&format!("a{i}"), MediaFilter::All, &[])).collect(), "arm"),
        ];
        for (arms, field) in cases {
            assert_eq!(check_arms(&arms).unwrap_err().field, field);
        }
    }

    #[test]
    fn participants_join_the_smallest_arm_and_sizes_stay_within_one() {
        let mut counts = vec![0usize; 4];
        for seed in 0..41u64 {
            let i = choose_arm(&counts, seed.wrapping_mul(0x9E37_79B9_7F4A_7C15));
            assert_eq!(counts[i], *counts.iter().min().unwrap(), "joined a larger arm");
            counts[i] += 1;
            let (min, max) = (counts.iter().min().unwrap(), counts.iter().max().unwrap());
            assert!(max - min <= 1, "{counts:?}");
        }
        assert_eq!(counts.iter().sum::<usize>(), 41);
        assert_eq!(choose_arm(&[3, 1, 2], 7), 1);
        // Ties go either way by seed, not always to the first arm.
        let firsts: std::collections::BTreeSet<usize> = (0..32).map(|s| choose_arm(&[0, 0, 0], s)).collect();
        assert!(firsts.len() > 1, "{firsts:?}");
    }
}
