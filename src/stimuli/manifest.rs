//! The stimulus manifest (design.md §3) and the per-frame ground truth of a video.
//!
//! `manifest.csv` and `manifest.json` hold the same rows, one per stimulus, with exactly the
//! columns of [`COLUMNS`]. In the CSV an absent value (timing, frames and fps of an image) is an
//! empty field; in the JSON it is `null`. Numbers are printed in Rust's shortest round-trip form.
//! `sha256` is the hash of the media file as written (dithered, when the set is); `dither` is the
//! fingerprint of the set's dither key (16 hex digits; empty for a set built with `--no-dither`).
//! A stimulus's `file` is always `media/<name>`: [`is_media_path`] is the check readers apply.
//! A stimulus's kind is a [`Media`] (`image` or `video`) and its id a [`StimulusId`] (16
//! lower-case hex digits): both are parsed once where they enter (the manifest, the database).
//!
//! The per-frame ground truth (`ground_truth/<id>.csv`) has the columns
//! `frame,time_s,AU01_r,AU02_r,…` after the OpenFace convention: one column per AU the video
//! uses, ordered by AU number; a one-sided AU gets `AU12L_r` / `AU12R_r`. **Intensities are
//! fractions of the AU's maximum in [0, 1]** (multiply by 5 for OpenFace's 0–5 scale), exactly
//! the values the frame was rendered with; `time_s = frame / fps`.

use serde::{Deserialize, Serialize};

use crate::engine::timeline::Timeline;
use crate::facs::Laterality;

/// The manifest columns, in order.
pub const COLUMNS: [&str; 18] = [
    "stimulus_id",
    "media",
    "file",
    "identity",
    "expression",
    "emotion",
    "intensity",
    "onset_s",
    "apex_s",
    "offset_s",
    "frames",
    "fps",
    "width",
    "height",
    "sha256",
    "set_seed",
    "engine_version",
    "dither",
];

/// What kind of file a stimulus is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Media {
    /// A still (`media/<id>.png`).
    Image,
    /// A clip (`media/<id>.mp4`).
    Video,
}

impl Media {
    pub fn as_str(self) -> &'static str {
        match self {
            Media::Image => "image",
            Media::Video => "video",
        }
    }

    pub fn parse(text: &str) -> Option<Media> {
        [Media::Image, Media::Video].into_iter().find(|m| m.as_str() == text)
    }

    /// The `Content-Type` its files are served with.
    pub fn content_type(self) -> &'static str {
        match self {
            Media::Image => "image/png",
            Media::Video => "video/mp4",
        }
    }
}

impl std::fmt::Display for Media {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.pad(self.as_str())
    }
}

/// The opaque id of a stimulus: 16 lower-case hex digits (derived from the set seed and the
/// entry index, [`crate::stimuli::stimulus_id`]); also the stem of its file names.
#[derive(Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(try_from = "String", into = "String")]
pub struct StimulusId(String);

/// A text that is not a stimulus id (quoted, at most 40 characters of it).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("\"{0}\" is not a stimulus id (16 lower-case hex digits)")]
pub struct NotAStimulusId(pub String);

impl StimulusId {
    pub fn parse(text: &str) -> Result<StimulusId, NotAStimulusId> {
        let shaped = text.len() == 16 && text.bytes().all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b));
        if shaped { Ok(StimulusId(text.to_string())) } else { Err(NotAStimulusId(text.chars().take(40).collect())) }
    }

    pub fn as_str(&self) -> &str {
        &self.0
    }
}

impl TryFrom<String> for StimulusId {
    type Error = NotAStimulusId;

    fn try_from(text: String) -> Result<StimulusId, NotAStimulusId> {
        StimulusId::parse(&text)
    }
}

impl From<StimulusId> for String {
    fn from(id: StimulusId) -> String {
        id.0
    }
}

impl std::fmt::Display for StimulusId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

/// One stimulus in the manifest.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ManifestRow {
    /// Opaque and random (derived from the set seed and the entry index); also the file stem.
    pub stimulus_id: String,
    pub media: Media,
    /// Path relative to the set directory (`media/<id>.png` or `media/<id>.mp4`).
    pub file: String,
    pub identity: String,
    /// FACS notation at the peak, with intensities and sides; a CPT sequence gives every AU of
    /// its steps once, at its highest intensity (order and timing: timeline and ground truth).
    pub expression: String,
    /// Emotion label (or CPT check name); empty for AU stimuli.
    pub emotion: String,
    /// Peak intensity, 0–1.
    pub intensity: f64,
    pub onset_s: Option<f64>,
    pub apex_s: Option<f64>,
    pub offset_s: Option<f64>,
    pub frames: Option<usize>,
    pub fps: Option<u32>,
    /// Size of the file's pictures (videos: padded to even sides, e.g. 486×480 for 485×480).
    pub width: u32,
    pub height: u32,
    pub sha256: String,
    pub set_seed: u64,
    pub engine_version: String,
    /// Fingerprint of the set's dither key; empty when the media are not dithered (and in
    /// manifests written before sets were dithered).
    #[serde(default)]
    pub dither: String,
    /// How the face is drawn (`realistic`, `cartoon`) where a set compares styles (laugh
    /// groups); empty otherwise, and then the CSV has no `style` column at all.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub style: String,
}

/// True when `file` names a file directly under the set's `media/` directory (no `..`, no
/// absolute path): the only files a manifest may point at, so nothing else of a set directory
/// (its `dither.key`, ground truth, frames) can be served as a stimulus.
pub fn is_media_path(file: &str) -> bool {
    let mut parts = std::path::Path::new(file).components();
    let normal = |part: Option<std::path::Component>| matches!(part, Some(std::path::Component::Normal(_)));
    let first = parts.next();
    first.is_some_and(|c| c.as_os_str() == "media") && normal(first) && normal(parts.next()) && parts.next().is_none()
}

fn opt<T: ToString>(v: &Option<T>) -> String {
    v.as_ref().map(T::to_string).unwrap_or_default()
}

impl ManifestRow {
    fn csv_fields(&self) -> Vec<String> {
        vec![
            self.stimulus_id.clone(),
            self.media.as_str().to_string(),
            self.file.clone(),
            self.identity.clone(),
            self.expression.clone(),
            self.emotion.clone(),
            self.intensity.to_string(),
            opt(&self.onset_s),
            opt(&self.apex_s),
            opt(&self.offset_s),
            opt(&self.frames),
            opt(&self.fps),
            self.width.to_string(),
            self.height.to_string(),
            self.sha256.clone(),
            self.set_seed.to_string(),
            self.engine_version.clone(),
            self.dither.clone(),
        ]
    }
}

/// The optional last column, written only when some row names a style.
pub const STYLE_COLUMN: &str = "style";

/// `manifest.csv`: a header line with [`COLUMNS`] (and [`STYLE_COLUMN`] when a row has a
/// style), then one line per row.
pub fn to_csv(rows: &[ManifestRow]) -> String {
    let styled = rows.iter().any(|r| !r.style.is_empty());
    let mut header: Vec<&str> = COLUMNS.to_vec();
    if styled {
        header.push(STYLE_COLUMN);
    }
    let mut out = crate::tabular::line(header);
    for row in rows {
        let mut fields = row.csv_fields();
        if styled {
            fields.push(row.style.clone());
        }
        crate::tabular::record(&mut out, fields);
    }
    out
}

/// `manifest.json`: an array of objects with exactly the [`COLUMNS`] as keys, in order.
pub fn to_json(rows: &[ManifestRow]) -> String {
    let mut text = serde_json::to_string_pretty(rows).expect("manifest rows serialise");
    text.push('\n');
    text
}

pub fn from_json(text: &str) -> Result<Vec<ManifestRow>, serde_json::Error> {
    serde_json::from_str(text)
}

/// The ground-truth column name of an AU on a side: `AU12_r`, `AU12L_r`, `AU12R_r`.
pub fn ground_truth_column(au: crate::facs::AuCode, side: Laterality) -> String {
    let side = match side {
        Laterality::Both => "",
        Laterality::Left => "L",
        Laterality::Right => "R",
    };
    format!("{}{side}_r", au.column())
}

/// The per-frame ground truth of `timeline` as CSV (see the module docs).
pub fn ground_truth_csv(timeline: &Timeline) -> String {
    ground_truth_csv_with(timeline, None)
}

/// The ground truth of a speaking face: [`ground_truth_csv`] with two more columns, the phone
/// sounding in each frame (IPA, empty in a pause) and its viseme class.
pub fn speech_ground_truth_csv(timeline: &Timeline, speech: &[crate::speech::FrameSpeech]) -> String {
    ground_truth_csv_with(timeline, Some(speech))
}

fn ground_truth_csv_with(timeline: &Timeline, speech: Option<&[crate::speech::FrameSpeech]>) -> String {
    let mut channels = timeline.channels();
    channels.sort();
    let mut out = String::from("frame,time_s");
    for &(au, side) in &channels {
        out.push(',');
        out.push_str(&ground_truth_column(au, side));
    }
    if speech.is_some() {
        out.push_str(",phoneme,viseme");
    }
    out.push('\n');
    for frame in 0..timeline.frame_count() {
        let t = timeline.time_of(frame);
        let values = timeline.values_at(t);
        out.push_str(&format!("{frame},{t}"));
        for channel in &channels {
            let value = values.iter().find(|(c, _)| c == channel).map_or(0.0, |&(_, v)| v);
            out.push_str(&format!(",{value}"));
        }
        if let Some(speech) = speech {
            let at = speech.get(frame);
            out.push_str(&format!(",{},{}", at.map_or("", |s| s.phoneme.as_str()), at.map_or("", |s| s.viseme.as_str())));
        }
        out.push('\n');
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::engine::timeline::ClipTiming;
    use crate::facs::Catalog;

    fn row() -> ManifestRow {
        ManifestRow {
            stimulus_id: "0a1b2c3d4e5f6789".into(),
            media: Media::Video,
            file: "media/0a1b2c3d4e5f6789.mp4".into(),
            identity: "wm1".into(),
            expression: "12@1+R14@0.5".into(),
            emotion: String::new(),
            intensity: 1.0,
            onset_s: Some(1.0),
            apex_s: Some(1.0),
            offset_s: Some(1.0),
            frames: Some(90),
            fps: Some(30),
            width: 486,
            height: 480,
            sha256: "ab".repeat(32),
            set_seed: 7,
            engine_version: "0.1.0".into(),
            dither: "0123456789abcdef".into(),
            style: String::new(),
        }
    }

    #[test]
    fn the_style_column_is_written_only_when_a_row_has_a_style() {
        let plain = to_csv(&[row()]);
        assert!(!plain.lines().next().unwrap().contains(STYLE_COLUMN), "{plain}");
        assert!(!to_json(&[row()]).contains("\"style\""));
        let styled = [row(), ManifestRow { style: "cartoon".into(), ..row() }];
        let csv = to_csv(&styled);
        let mut lines = csv.lines();
        assert!(lines.next().unwrap().ends_with(",dither,style"), "{csv}");
        assert!(lines.next().unwrap().ends_with(",0123456789abcdef,"), "{csv}");
        assert!(lines.next().unwrap().ends_with(",0123456789abcdef,cartoon"), "{csv}");
        assert_eq!(from_json(&to_json(&styled)).unwrap(), styled.to_vec());
    }

    #[test]
    fn csv_and_json_have_exactly_the_contract_columns() {
        let csv = to_csv(&[row()]);
        let mut lines = csv.lines();
        assert_eq!(
            lines.next().unwrap(),
            "stimulus_id,media,file,identity,expression,emotion,intensity,onset_s,apex_s,offset_s,frames,fps,width,height,sha256,set_seed,engine_version,dither"
        );
        assert_eq!(lines.next().unwrap().split(',').count(), COLUMNS.len());
        let json: serde_json::Value = serde_json::from_str(&to_json(&[row()])).unwrap();
        let keys: Vec<&String> = json[0].as_object().unwrap().keys().collect();
        let mut expected: Vec<&str> = COLUMNS.to_vec();
        expected.sort();
        let mut keys: Vec<&str> = keys.iter().map(|k| k.as_str()).collect();
        keys.sort();
        assert_eq!(keys, expected);
        assert_eq!(from_json(&to_json(&[row()])).unwrap(), vec![row()]);
    }

    #[test]
    fn older_manifests_without_dither_read_as_undithered_and_files_stay_under_media() {
        let mut json: serde_json::Value = serde_json::from_str(&to_json(&[row()])).unwrap();
        json[0].as_object_mut().unwrap().remove("dither");
        assert_eq!(from_json(&json.to_string()).unwrap()[0].dither, "");
        assert!(is_media_path("media/0a1b2c3d4e5f6789.png"));
        for bad in ["dither.key", "media/../dither.key", "/media/x.png", "media", "media/", "media/a/b.png", "posters/x.png", "./media/x.png", "media/.."] {
            assert!(!is_media_path(bad), "{bad}");
        }
    }

    #[test]
    fn media_and_ids_have_one_spelling() {
        for media in [Media::Image, Media::Video] {
            assert_eq!(Media::parse(media.as_str()), Some(media));
            assert_eq!(serde_json::to_string(&media).unwrap(), format!("\"{}\"", media.as_str()));
        }
        assert_eq!(Media::parse("audio"), None);
        assert_eq!(StimulusId::parse(&crate::stimuli::stimulus_id(7, 3)).map(|id| id.to_string()), Ok(crate::stimuli::stimulus_id(7, 3)));
        for bad in ["0A1B2C3D4E5F6789", "0a1b2c3d4e5f678", "0a1b2c3d4e5f6789a", "../dither.key0000", ""] {
            assert!(StimulusId::parse(bad).is_err(), "{bad}");
        }
        let err = serde_json::from_str::<StimulusId>("\"s01\"").unwrap_err();
        assert!(err.to_string().contains("\"s01\" is not a stimulus id"), "{err}");
    }

    #[test]
    fn image_rows_leave_timing_empty() {
        let image = ManifestRow { media: Media::Image, onset_s: None, apex_s: None, offset_s: None, frames: None, fps: None, ..row() };
        let csv = to_csv(&[image]);
        assert!(csv.lines().nth(1).unwrap().contains(",1,,,,,,486,480,"), "{csv}");
    }

    #[test]
    fn ground_truth_lists_each_au_and_side_per_frame() {
        let e = Catalog::built_in().parse("R14+12C").unwrap();
        let t = Timeline::clip(&e, ClipTiming::default(), 30, "wm1", (64, 64));
        let csv = ground_truth_csv(&t);
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(lines[0], "frame,time_s,AU12_r,AU14R_r");
        assert_eq!(lines.len(), 91);
        assert_eq!(lines[1], "0,0,0,0");
        assert_eq!(lines[46], "45,1.5,0.55,1");
    }
}
