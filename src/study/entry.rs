//! Entries of a stimulus set: the stimuli that show one thing (one AU or combination on one
//! identity, at several strengths and as video and stills), so that one trial can show them
//! together (`[au_coding] together = true`; HapFACS Exp. 1 coded a single-AU video with its
//! three stills as one judgement).
//!
//! In: a study's admitted manifest rows, in manifest order. Out: each row's [`Place`]: it leads
//! a trial, or it is shown beside the lead of its entry at a 1-based part. An entry is what the
//! manifest says a stimulus shows apart from its strength: the identity, the AUs with their
//! sides, and the emotion label.
//!
//! Invariants (`study::entry::tests`): every entry has exactly one lead, which takes the trial
//! and the judgement (so the analysis counts the entry once, with the lead's ground truth); the
//! lead is the entry's video, or its strongest still when it has none; the others follow by
//! rising intensity, then manifest order; an entry with two videos is refused (a design keeps
//! one with `intensities`), since one judgement cannot stand for two ground truths.

use std::collections::BTreeMap;

use crate::facs::{AuCode, Catalog, Laterality};
use crate::stimuli::manifest::{ManifestRow, Media};

/// Whether `design` shows each entry's media together in one trial (`[au_coding] together`).
pub fn together(design: &super::StudyDesign) -> bool {
    design.task == super::TaskKind::AuCoding && design.au_coding.together
}

/// Where a stimulus goes when entries are shown together.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Place {
    /// It has a trial of its own and takes the judgement.
    Lead,
    /// It is shown in the trial of the row `lead` (an index into the rows), at `part` (1-based).
    Beside { lead: usize, part: u32 },
}

/// Rows that cannot be grouped into entries.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("stimulus {stimulus_id}: {message}")]
pub struct EntryError {
    pub stimulus_id: String,
    pub message: String,
}

/// What a stimulus shows apart from its strength.
type EntryKey = (String, Vec<(AuCode, Laterality)>, String);

fn key(row: &ManifestRow, catalog: &Catalog) -> Result<EntryKey, EntryError> {
    let expression = catalog.parse(&row.expression).map_err(|e| EntryError { stimulus_id: row.stimulus_id.clone(), message: format!("expression: {e}") })?;
    let mut aus: Vec<(AuCode, Laterality)> = expression.activations().iter().map(|a| (a.au, a.side)).collect();
    aus.sort();
    aus.dedup();
    Ok((row.identity.clone(), aus, row.emotion.clone()))
}

/// The place of every row (see the module doc).
pub fn places(rows: &[ManifestRow]) -> Result<Vec<Place>, EntryError> {
    let catalog = Catalog::built_in();
    let mut entries: BTreeMap<EntryKey, Vec<usize>> = BTreeMap::new();
    for (i, row) in rows.iter().enumerate() {
        entries.entry(key(row, catalog)?).or_default().push(i);
    }
    let mut places = vec![Place::Lead; rows.len()];
    for members in entries.values() {
        let (lead, beside) = arrange(rows, members)?;
        for (k, &i) in beside.iter().enumerate() {
            places[i] = Place::Beside { lead, part: k as u32 + 1 };
        }
    }
    Ok(places)
}

/// The lead of one entry (`members`: row indices in manifest order) and the others in order.
fn arrange(rows: &[ManifestRow], members: &[usize]) -> Result<(usize, Vec<usize>), EntryError> {
    let videos: Vec<usize> = members.iter().copied().filter(|&i| rows[i].media == Media::Video).collect();
    if let [first, second, ..] = videos[..] {
        let message = format!(
            "its entry has {} videos (this one and {}); showing an entry together needs one video per entry: keep one peak with the design's `intensities`",
            videos.len(),
            rows[second].stimulus_id
        );
        return Err(EntryError { stimulus_id: rows[first].stimulus_id.clone(), message });
    }
    let by_intensity = |a: &usize, b: &usize| rows[*a].intensity.total_cmp(&rows[*b].intensity).then(a.cmp(b));
    let lead = match videos.first() {
        Some(&video) => video,
        None => *members.iter().max_by(|a, b| by_intensity(a, b).then(b.cmp(a))).expect("an entry has a member"),
    };
    let mut beside: Vec<usize> = members.iter().copied().filter(|&i| i != lead).collect();
    beside.sort_by(by_intensity);
    Ok((lead, beside))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(id: usize, media: Media, identity: &str, expression: &str, intensity: f64) -> ManifestRow {
        ManifestRow {
            stimulus_id: format!("{id:016x}"),
            media,
            file: format!("media/{id:016x}.png"),
            identity: identity.into(),
            expression: expression.into(),
            emotion: String::new(),
            intensity,
            onset_s: None,
            apex_s: None,
            offset_s: None,
            frames: None,
            fps: (media == Media::Video).then_some(30),
            width: 64,
            height: 64,
            sha256: String::new(),
            set_seed: 1,
            engine_version: "0".into(),
            dither: String::new(),
            style: String::new(),
        }
    }

    /// The Exp. 1 shape: per AU one video at 100 % and stills at 30/60/90 %, identities rotating.
    #[test]
    fn exp1_entries_lead_with_the_video_and_show_the_stills_by_rising_intensity() {
        let rows = vec![
            row(0, Media::Video, "wm1", "1@1", 1.0),
            row(1, Media::Image, "wm1", "1@0.9", 0.9),
            row(2, Media::Image, "wm1", "1@0.3", 0.3),
            row(3, Media::Image, "wm1", "1@0.6", 0.6),
            row(4, Media::Video, "wm2", "R14@1", 1.0),
            row(5, Media::Image, "wm2", "R14@0.3", 0.3),
            // Same AU, other side: another entry.
            row(6, Media::Image, "wm2", "L14@0.3", 0.3),
            // Same AU, other identity: another entry.
            row(7, Media::Image, "wm1", "R14@0.6", 0.6),
        ];
        let places = places(&rows).unwrap();
        let beside = |lead, part| Place::Beside { lead, part };
        assert_eq!(places, vec![Place::Lead, beside(0, 3), beside(0, 1), beside(0, 2), Place::Lead, beside(4, 1), Place::Lead, Place::Lead]);
    }

    #[test]
    fn without_a_video_the_strongest_still_leads() {
        let rows = vec![row(0, Media::Image, "bf1", "6+12@0.5", 0.5), row(1, Media::Image, "bf1", "6@1+12@1", 1.0)];
        assert_eq!(places(&rows).unwrap(), vec![Place::Beside { lead: 1, part: 1 }, Place::Lead]);
    }

    #[test]
    fn only_au_coding_designs_show_entries_together() {
        let design = |task: &str, extra: &str| {
            let text = format!("slug = \"t\"\ntitle = \"T\"\ntask = \"{task}\"\nstimuli = \"s\"\nconsent = \"c\"\ninstructions = \"i\"\ndebrief = \"d\"\n{extra}");
            super::super::StudyDesign::from_toml(&text).unwrap()
        };
        assert!(together(&design("au_coding", "[au_coding]\ntogether = true\n")));
        assert!(!together(&design("au_coding", "")));
        assert!(!together(&design("emotion", "[au_coding]\ntogether = true\n")));
    }

    #[test]
    fn two_videos_of_one_entry_are_refused_by_name() {
        let rows = vec![row(0, Media::Video, "wm1", "1@0.5", 0.5), row(1, Media::Video, "wm1", "1@1", 1.0)];
        let e = places(&rows).unwrap_err();
        assert_eq!(e.stimulus_id, "0000000000000000");
        assert!(e.message.contains("2 videos") && e.message.contains("0000000000000001") && e.message.contains("intensities"), "{e}");
    }
}
