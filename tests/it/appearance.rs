//! The AU appearance specification: the CLI prints it, and its head and eye angles are the ones
//! the AU basis renders.

use facslab::engine::rig::{AuBasis, Channel};
use facslab::facs::{AppearanceSpec, IntensityLevel};

use crate::cli::{facslab, facslab_ok, stderr};

/// The degree figure in a level text ("about 9 degrees", "a nod of 15 degrees each").
fn stated_degrees(text: &str) -> Option<f32> {
    let words: Vec<&str> = text.split_whitespace().collect();
    let at = words.iter().position(|w| *w == "degrees")?;
    words.get(at.checked_sub(1)?)?.parse().ok()
}

#[test]
fn head_and_eye_levels_state_the_angles_the_basis_renders() {
    let basis = AuBasis::built_in();
    let mut checked = 0;
    for entry in AppearanceSpec::built_in().iter() {
        let Some(rig) = basis.get(entry.code) else { continue };
        let Some(angle) = rig.channels.iter().find(|c| {
            matches!(
                c.channel,
                Channel::HeadYaw | Channel::HeadPitch | Channel::HeadRoll | Channel::EyesYaw | Channel::EyesPitch | Channel::EyesConverge
            )
        }) else {
            continue;
        };
        for level in IntensityLevel::ALL {
            let text = entry.levels.get(level);
            let stated = stated_degrees(text).unwrap_or_else(|| panic!("AU{} level {}: no angle in {text:?}", entry.code, level.letter()));
            let rendered = angle.max.abs() * level.fraction() as f32;
            assert!(
                (stated - rendered).abs() <= 0.5 + f32::EPSILON * 64.0,
                "AU{} level {}: the text says {stated} degrees, the basis renders {rendered}",
                entry.code,
                level.letter()
            );
            checked += 1;
        }
    }
    assert_eq!(checked, 14 * 5, "AUs 51-56 and 59-66 have an angle at each level");
}

#[test]
fn catalog_prints_one_aus_appearance_and_names_a_bad_one() {
    let dir = tempfile::tempdir().expect("temporary directory");
    let out = facslab_ok(dir.path(), &["catalog", "--appearance", "AU6"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.starts_with("## AU6 Cheek Raiser"), "{text}");
    assert!(text.contains("crow's-feet") && text.contains("| E |"), "{text}");
    assert!(!text.contains("## AU7"), "only AU6 is printed: {text}");

    let bad = facslab(dir.path(), &["catalog", "--appearance", "8"]);
    assert!(!bad.status.success());
    assert!(stderr(&bad).contains("`8` is not a catalog AU number"), "{}", stderr(&bad));
}
