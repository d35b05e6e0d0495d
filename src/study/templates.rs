//! The study-design templates shipped in `studies/` (HapFACS Exp. 1–4 and seed 004's rating
//! study), compiled in so the admin pages can offer them and the tests can check them.

/// (file name, TOML text) of every template.
pub const ALL: [(&str, &str); 5] = [
    ("exp1-coders.toml", include_str!("../../studies/exp1-coders.toml")),
    ("exp2-coders.toml", include_str!("../../studies/exp2-coders.toml")),
    ("exp3-emotions.toml", include_str!("../../studies/exp3-emotions.toml")),
    ("exp4-emotions-video.toml", include_str!("../../studies/exp4-emotions-video.toml")),
    ("rating-motion.toml", include_str!("../../studies/rating-motion.toml")),
];

#[cfg(test)]
mod tests {
    use crate::study::StudyDesign;

    #[test]
    fn every_template_is_a_valid_design() {
        for (name, text) in super::ALL {
            if let Err(e) = StudyDesign::from_toml(text) {
                panic!("{name}: {e}");
            }
        }
    }
}
