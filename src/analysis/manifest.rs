//! The stimulus manifest as the analysis needs it: what each stimulus shows.
//!
//! Reads `manifest.csv` (design.md §3) by column name and uses only `stimulus_id`, `media`,
//! `identity`, `expression`, `emotion` and `intensity`; other columns (files, timing, hashes,
//! seeds) are ignored, so the builder can add columns without breaking the analysis. The
//! `emotion` column names a declared label (`study::labels`): `laughs:sly_smile`, or a bare label
//! of the EmFACS set, as every manifest before label sets. An optional `style` column names how
//! the stimulus was made (seed 004: `realistic` or `cartoon` avatar, `real` for a recording);
//! a manifest without it leaves every style empty. A user's own label sets are read from the
//! `labels/` directory beside the manifest file.

use std::path::Path;

use super::input::{FxHashMap, InputError, TableInput};
use crate::facs::{Catalog, Expression};
use crate::study::labels::{LabelSet, Qualified};

/// Still image or video: the manifest's own type.
pub use crate::stimuli::manifest::Media;

/// One stimulus and its ground truth.
#[derive(Debug, Clone)]
pub struct Stimulus {
    pub id: String,
    pub media: Media,
    pub identity: String,
    /// What the face shows (FACS notation with sides and intensities).
    pub expression: Expression,
    /// The label the stimulus portrays (its id within `labels`), if it portrays one.
    pub emotion: Option<String>,
    /// The label set of `emotion` (EmFACS for a stimulus that portrays none).
    pub labels: LabelSet,
    /// Peak intensity in [0, 1].
    pub intensity: f64,
    /// How the stimulus was made (`realistic`, `cartoon`, `real`; empty when not stated).
    pub style: String,
}

impl Stimulus {
    /// The peak intensity in whole percent (`100`, `50`), the unit the seed's tables use.
    pub fn intensity_percent(&self) -> u32 {
        (self.intensity * 100.0).round() as u32
    }
}

/// Every stimulus of a set, indexed by id.
#[derive(Debug, Clone, Default)]
pub struct Manifest {
    pub stimuli: Vec<Stimulus>,
    index: FxHashMap<Box<str>, usize>,
}

impl Manifest {
    /// Reads and validates a manifest file, after registering the label sets its set carries
    /// (`labels/` beside it, [`crate::stimuli::labels`]).
    pub fn read(path: &Path, catalog: &Catalog) -> Result<Manifest, InputError> {
        let set_dir = path.parent().unwrap_or(Path::new("."));
        crate::stimuli::labels::register_set(set_dir).map_err(|source| InputError::Labels { file: path.to_path_buf(), source })?;
        Self::parse(TableInput::open(path)?, catalog)
    }

    /// Reads a manifest from CSV text (`name` is used in error messages).
    pub fn from_csv(name: &str, text: &str, catalog: &Catalog) -> Result<Manifest, InputError> {
        let bytes = text.as_bytes().to_vec();
        Self::parse(TableInput::from_reader(Path::new(name), Box::new(std::io::Cursor::new(bytes)))?, catalog)
    }

    /// Bare labels are EmFACS, checked through the declared `emfacs` label set, which lists the
    /// same labels as the EmFACS table (`emfacs_labels_follow_the_emotion_table`).
    fn parse(mut input: TableInput, catalog: &Catalog) -> Result<Manifest, InputError> {
        let c_id = input.column("stimulus_id")?;
        let c_media = input.column("media")?;
        let c_identity = input.column("identity")?;
        let c_expr = input.column("expression")?;
        let c_emotion = input.column("emotion")?;
        let c_intensity = input.column("intensity")?;
        let c_style = input.header_names().iter().position(|h| h == "style");
        let mut manifest = Manifest::default();
        let mut rows = Vec::new();
        input.for_each(|r, place| {
            rows.push((r.clone(), place));
            Ok(())
        })?;
        for (r, place) in rows {
            let id = r[c_id].trim();
            if id.is_empty() {
                return Err(input.cell(place, "stimulus_id", "empty stimulus id"));
            }
            let text = r[c_media].trim();
            let media = Media::parse(text).ok_or_else(|| input.cell(place, "media", format!("\"{}\" is not image or video", crate::study::excerpt(text, 32))))?;
            let expression = catalog.parse(&r[c_expr]).map_err(|e| input.cell(place, "expression", e.to_string()))?;
            let (labels, emotion) = match r[c_emotion].trim() {
                "" => (LabelSet::emfacs(), None),
                text => Qualified::split(text).resolve().map(|(set, label)| (set, Some(label.id.clone()))).map_err(|e| input.cell(place, "emotion", e))?,
            };
            let intensity: f64 = r[c_intensity]
                .trim()
                .parse()
                .ok()
                .filter(|v: &f64| (0.0..=1.0).contains(v))
                .ok_or_else(|| input.cell(place, "intensity", format!("\"{}\" is not a number in [0, 1]", &r[c_intensity])))?;
            if manifest.index.insert(id.into(), manifest.stimuli.len()).is_some() {
                return Err(input.cell(place, "stimulus_id", format!("stimulus id \"{id}\" appears twice")));
            }
            manifest.stimuli.push(Stimulus {
                id: id.to_string(),
                media,
                identity: r[c_identity].trim().to_string(),
                expression,
                emotion,
                labels,
                intensity,
                style: c_style.map_or_else(String::new, |c| r[c].trim().to_string()),
            });
        }
        Ok(manifest)
    }

    /// The label set the stimuli portray labels of, which a forced choice on them offers: the
    /// set of the first labelled stimulus, EmFACS when none is labelled.
    pub fn label_set(&self) -> LabelSet {
        self.stimuli.iter().find(|s| s.emotion.is_some()).map_or_else(LabelSet::emfacs, |s| s.labels)
    }

    /// The position of a stimulus id in [`Manifest::stimuli`].
    pub fn position(&self, id: &str) -> Option<usize> {
        self.index.get(id).copied()
    }

    pub fn len(&self) -> usize {
        self.stimuli.len()
    }

    pub fn is_empty(&self) -> bool {
        self.stimuli.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const HEADER: &str = "stimulus_id,media,file,identity,expression,emotion,intensity,onset_s,apex_s,offset_s,frames,fps,width,height,sha256,set_seed,engine_version";

    fn read(text: &str) -> Result<Manifest, InputError> {
        Manifest::from_csv("m.csv", text, Catalog::built_in())
    }

    #[test]
    fn reads_the_columns_it_needs_and_ignores_the_rest() {
        let text = format!("{HEADER},extra\na1,video,a1.mp4,wm1,1+2+R14C,,1,1,1,1,90,30,486,480,00,7,0.1,x\nb2,image,b2.png,bf1,6+12+25,happiness,0.5,,,,1,,485,480,00,7,0.1,y\n");
        let m = read(&text).unwrap();
        assert_eq!(m.len(), 2);
        assert_eq!(m.stimuli[0].expression.to_string(), "1+2+R14C");
        assert_eq!(m.stimuli[1].emotion.as_deref(), Some("happiness"));
        assert_eq!(m.stimuli[1].intensity_percent(), 50);
        assert_eq!(m.position("b2"), Some(1));
    }

    #[test]
    fn errors_name_row_line_and_column() {
        let text = format!("{HEADER}\na1,video,a1.mp4,wm1,1+2,,1,,,,,,,,,,\nb2,image,b2.png,wm1,1+99,,1,,,,,,,,,,\n");
        let err = read(&text).unwrap_err().to_string();
        assert!(err.contains("row 2 (line 3), column \"expression\""), "{err}");
        assert!(err.contains("AU 99"), "{err}");
        let err = read("stimulus_id,media,identity,expression,intensity\n").unwrap_err().to_string();
        assert!(err.contains("missing column \"emotion\""), "{err}");
        let text = format!("{HEADER}\na1,video,a1.mp4,wm1,1,,1.5,,,,,,,,,,\n");
        assert!(read(&text).unwrap_err().to_string().contains("column \"intensity\""));
        let text = format!("{HEADER}\na1,video,a1.mp4,wm1,1,,1,,,,,,,,,,\na1,video,a1.mp4,wm1,2,,1,,,,,,,,,,\n");
        assert!(read(&text).unwrap_err().to_string().contains("appears twice"));
    }

    #[test]
    fn labels_name_their_set_and_bare_ones_mean_emfacs() {
        let text = format!("{HEADER}\na1,video,a1.mp4,wm1,6+12,laughs:sly_smile,1,,,,,,,,,,\nb2,image,b2.png,wm1,6+12+25,happiness,1,,,,,,,,,,\nc3,image,c3.png,wm1,0,,1,,,,,,,,,,\n");
        let m = read(&text).unwrap();
        assert_eq!((m.stimuli[0].labels.id(), m.stimuli[0].emotion.as_deref()), ("laughs", Some("sly_smile")));
        assert_eq!((m.stimuli[1].labels.id(), m.stimuli[1].emotion.as_deref()), ("emfacs", Some("happiness")));
        assert_eq!((m.stimuli[2].labels.id(), m.stimuli[2].emotion.as_deref()), ("emfacs", None));
        assert!(m.stimuli.iter().all(|s| s.style.is_empty()), "no style column, no style");
        let styled = read(&format!("{HEADER},style\na1,video,a1.mp4,wm1,6+12,laughs:laughter,1,,,,,,,,,,, cartoon\n")).unwrap();
        assert_eq!(styled.stimuli[0].style, "cartoon");
        for (label, expected) in [("sly_smile", "not a label of the emfacs label set"), ("laughs:happiness", "not a label of the laughs label set"), ("moods:joy", "not a declared label set")] {
            let text = format!("{HEADER}\na1,video,a1.mp4,wm1,6+12,{label},1,,,,,,,,,,\n");
            let err = read(&text).unwrap_err().to_string();
            assert!(err.contains("column \"emotion\"") && err.contains(expected), "{err}");
        }
    }
}
