//! The study-design templates shipped in `studies/` (HapFACS Exp. 1–4 and seed 004's rating
//! studies: description match, and motion on two avatars), compiled in so the admin pages can
//! offer them and the tests can check them.

/// (file name, TOML text) of every template.
pub const ALL: [(&str, &str); 7] = [
    ("exp1-coders.toml", include_str!("../../studies/exp1-coders.toml")),
    ("exp2-coders.toml", include_str!("../../studies/exp2-coders.toml")),
    ("exp3-emotions.toml", include_str!("../../studies/exp3-emotions.toml")),
    ("exp4-emotions-video.toml", include_str!("../../studies/exp4-emotions-video.toml")),
    ("rating-motion.toml", include_str!("../../studies/rating-motion.toml")),
    ("laugh-description.toml", include_str!("../../studies/laugh-description.toml")),
    ("laugh-motion.toml", include_str!("../../studies/laugh-motion.toml")),
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

    #[test]
    fn the_laugh_templates_ask_the_seeds_questions_over_the_laugh_types() {
        use crate::study::measure::Scale;
        let design = |name: &str| StudyDesign::from_toml(super::ALL.iter().find(|(n, _)| *n == name).expect("shipped").1).unwrap();
        let description = design("laugh-description.toml");
        assert_eq!(description.labels.id(), "laughs");
        assert_eq!(description.items.iter().map(|i| (i.measure, i.min, i.max)).collect::<Vec<_>>(), [(Scale::DescriptionMatch, 0, 5)]);
        assert_eq!(description.items[0].prompt, "Does the expression correspond to the description?");
        assert_eq!((description.trials_per_participant, description.labels_per_participant), (0, 7), "seven whole types: both videos of each");
        assert!(description.rating.side_by_side, "the real and the generated video on one screen");
        let motion = design("laugh-motion.toml");
        assert_eq!(motion.labels.id(), "laughs");
        assert_eq!(motion.items.iter().map(|i| i.measure).collect::<Vec<_>>(), [Scale::Q1, Scale::Q2]);
        assert!(motion.items[0].prompt.ends_with("Does the motion feel right?") && motion.items[1].prompt.ends_with("Does the motion represent the description?"));
        assert_eq!(motion.trials_per_participant, 0, "within-subject: every video");
        assert!(!motion.rating.side_by_side, "one video per screen");
    }
}
