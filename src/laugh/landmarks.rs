//! Landmark tracks: a CSV of tracked 2-D facial landmarks, one row per video frame, read into
//! the points the facial parameters need.
//!
//! In: CSV text whose header names the landmark columns, in one of the layouts people have:
//! - [`Layout::OpenFace`]: OpenFace 2's `x_0…x_67, y_0…y_67` (iBUG numbering); its other columns
//!   (`frame`, `confidence`, `X_0`, `eye_lmk_x_0`, AU columns, …) are ignored;
//! - [`Layout::Ibug68`]: dlib / iBUG 300-W 68 points (`x_0…`, `x0…`, `0_x…` or `part_0_x…`);
//! - [`Layout::Seed66`]: the 66-point layout of Saragih's tracker that the seed used: iBUG's 68
//!   without the inner mouth corners 60 and 64 (points 0-59 are iBUG's 0-59);
//! - [`Layout::MediaPipe`]: MediaPipe Face Mesh, 468 or 478 points.
//!
//! The layout comes from the header (the number of landmark columns; OpenFace by its `success`
//! or `confidence` column) or is given. Out: a [`LandmarkTrack`] holding, per frame, the
//! [`NEEDED`] points in iBUG numbering (MediaPipe is mapped through [`MEDIAPIPE_TO_IBUG`]).
//!
//! Invariants: every frame has every needed point, finite; a bad file fails with a
//! [`TrackError`] naming the file, the row (the line number in the file, header = 1) and the
//! column.

use std::collections::BTreeMap;

/// The iBUG-numbered points the facial parameters use (see `params.rs`), in this order.
pub const NEEDED: [usize; 25] = [0, 8, 16, 21, 22, 27, 31, 33, 35, 36, 37, 38, 39, 40, 41, 42, 43, 44, 45, 46, 47, 48, 51, 54, 57];

/// MediaPipe Face Mesh index of each [`NEEDED`] iBUG point (same order). Image left is the
/// person's right: iBUG 36 (right eye, outer corner) is MediaPipe 33; iBUG 45 is 263.
/// Chosen from MediaPipe's canonical mesh: jaw line 234/152/454 (face contour at the eye
/// corners' height and the chin), inner brow ends 107/336 (as analysis/validation/landmarks.py),
/// nasion 168, nostril base 98/2/327, eyelids 33-160-158-133-153-144 and 362-385-387-263-373-380,
/// outer lip corners 61/291, outer lip mid-points 0 (top) and 17 (bottom).
pub const MEDIAPIPE_TO_IBUG: [usize; 25] = [234, 152, 454, 107, 336, 168, 98, 2, 327, 33, 160, 158, 133, 153, 144, 362, 385, 387, 263, 373, 380, 61, 0, 291, 17];

/// How a track's landmarks are numbered.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Layout {
    OpenFace,
    Ibug68,
    Seed66,
    MediaPipe,
}

impl Layout {
    pub fn name(self) -> &'static str {
        match self {
            Layout::OpenFace => "openface",
            Layout::Ibug68 => "ibug68",
            Layout::Seed66 => "seed66",
            Layout::MediaPipe => "mediapipe",
        }
    }

    /// The layout's own index of the `k`-th [`NEEDED`] point.
    fn source_index(self, k: usize) -> usize {
        match self {
            Layout::MediaPipe => MEDIAPIPE_TO_IBUG[k],
            _ => NEEDED[k],
        }
    }
}

/// A bad landmark track; every message names the file and, where there is one, row and column.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TrackError {
    #[error("{file}: cannot read it: {detail}")]
    Read { file: String, detail: String },
    #[error("{file}: row 1 (header): no landmark columns (x_0, y_0, …) found")]
    NoLandmarks { file: String },
    #[error("{file}: row 1 (header): {count} landmarks is no known layout (68 OpenFace/iBUG, 66 seed, 468/478 MediaPipe); give --layout")]
    UnknownLayout { file: String, count: usize },
    #[error("{file}: row 1 (header): landmark {point} of the {layout} layout has no column {column}")]
    MissingColumn { file: String, layout: &'static str, point: usize, column: String },
    #[error("{file}: row {row}: {got} columns, but the header has {expected}")]
    ColumnCount { file: String, row: usize, expected: usize, got: usize },
    #[error("{file}: row {row}, column {column}: landmark {point} is missing (empty cell)")]
    MissingValue { file: String, row: usize, column: String, point: usize },
    #[error("{file}: row {row}, column {column}: {value:?} is not a finite number")]
    NotANumber { file: String, row: usize, column: String, value: String },
    #[error("{file}: {frames} frames; {needed} are needed ({why})")]
    TooFewFrames { file: String, frames: usize, needed: usize, why: String },
}

/// One frame's [`NEEDED`] points, (x, y) in the track's units (pixels, y down).
pub type FramePoints = [[f64; 2]; NEEDED.len()];

/// A checked landmark track.
#[derive(Debug, Clone, PartialEq)]
pub struct LandmarkTrack {
    /// The file it came from, as given (used in messages and reports).
    pub file: String,
    pub layout: Layout,
    pub frames: Vec<FramePoints>,
}

impl LandmarkTrack {
    /// The point with iBUG number `ibug` (one of [`NEEDED`]) in frame `frame`.
    pub fn point(&self, frame: usize, ibug: usize) -> [f64; 2] {
        point_of(&self.frames[frame], ibug)
    }

    /// Fails with [`TrackError::TooFewFrames`] when the track is shorter than `needed`.
    pub fn require_frames(&self, needed: usize, why: &str) -> Result<(), TrackError> {
        if self.frames.len() < needed {
            return Err(TrackError::TooFewFrames { file: self.file.clone(), frames: self.frames.len(), needed, why: why.into() });
        }
        Ok(())
    }
}

/// The point with iBUG number `ibug` (one of [`NEEDED`]) among one frame's points.
pub fn point_of(points: &FramePoints, ibug: usize) -> [f64; 2] {
    let k = NEEDED.iter().position(|&n| n == ibug).unwrap_or_else(|| panic!("iBUG point {ibug} is not in NEEDED"));
    points[k]
}

/// The landmark number and axis (0 = x, 1 = y) a column name stands for, if any:
/// `x_12`, `x12`, `12_x`, `p12_x`, `part_12_x` (surrounding spaces ignored, as OpenFace writes).
fn landmark_column(name: &str) -> Option<(usize, usize)> {
    let name = name.trim();
    let axis = |c: &str| match c {
        "x" => Some(0),
        "y" => Some(1),
        _ => None,
    };
    if let Some((head, tail)) = name.split_at_checked(1)
        && let (Some(a), Ok(n)) = (axis(head), tail.trim_start_matches('_').parse::<usize>())
    {
        return Some((n, a));
    }
    let (head, tail) = name.rsplit_once('_')?;
    let number = head.trim_start_matches("part_").trim_start_matches('p');
    Some((number.parse().ok()?, axis(tail)?))
}

/// The layout the header shows: by landmark count, OpenFace by its own columns.
fn detect(file: &str, header: &csv::StringRecord, columns: &BTreeMap<(usize, usize), usize>) -> Result<Layout, TrackError> {
    let count = columns.keys().map(|(n, _)| n + 1).max().ok_or_else(|| TrackError::NoLandmarks { file: file.into() })?;
    let openface = header.iter().any(|h| matches!(h.trim(), "success" | "confidence" | "face_id"));
    match count {
        68 if openface => Ok(Layout::OpenFace),
        68 => Ok(Layout::Ibug68),
        66 => Ok(Layout::Seed66),
        468 | 478 => Ok(Layout::MediaPipe),
        _ => Err(TrackError::UnknownLayout { file: file.into(), count }),
    }
}

/// For each [`NEEDED`] point, the header positions of its x and y columns.
fn needed_columns(file: &str, layout: Layout, columns: &BTreeMap<(usize, usize), usize>) -> Result<Vec<[usize; 2]>, TrackError> {
    (0..NEEDED.len())
        .map(|k| {
            let point = layout.source_index(k);
            let find = |axis: usize| {
                columns.get(&(point, axis)).copied().ok_or_else(|| TrackError::MissingColumn {
                    file: file.into(),
                    layout: layout.name(),
                    point,
                    column: format!("{}_{point}", ["x", "y"][axis]),
                })
            };
            Ok([find(0)?, find(1)?])
        })
        .collect()
}

/// Reads a landmark track from CSV `text`; `file` names it in errors; `layout` overrides the
/// detection from the header.
pub fn read_track(file: &str, text: &str, layout: Option<Layout>) -> Result<LandmarkTrack, TrackError> {
    let mut reader = csv::ReaderBuilder::new().flexible(true).has_headers(true).from_reader(text.as_bytes());
    let header = reader.headers().map_err(|e| TrackError::Read { file: file.into(), detail: e.to_string() })?.clone();
    let mut columns = BTreeMap::new();
    for (i, name) in header.iter().enumerate() {
        if let Some(key) = landmark_column(name) {
            columns.entry(key).or_insert(i);
        }
    }
    let layout = match layout {
        Some(given) => given,
        None => detect(file, &header, &columns)?,
    };
    let wanted = needed_columns(file, layout, &columns)?;
    let mut frames = Vec::new();
    for (i, record) in reader.records().enumerate() {
        let row = i + 2;
        let record = record.map_err(|e| TrackError::Read { file: file.into(), detail: format!("row {row}: {e}") })?;
        if record.len() != header.len() {
            return Err(TrackError::ColumnCount { file: file.into(), row, expected: header.len(), got: record.len() });
        }
        frames.push(frame_points(file, row, layout, &header, &record, &wanted)?);
    }
    Ok(LandmarkTrack { file: file.into(), layout, frames })
}

/// The needed points of one data row.
fn frame_points(file: &str, row: usize, layout: Layout, header: &csv::StringRecord, record: &csv::StringRecord, wanted: &[[usize; 2]]) -> Result<FramePoints, TrackError> {
    let mut points = [[0.0; 2]; NEEDED.len()];
    for (k, cols) in wanted.iter().enumerate() {
        for (axis, &c) in cols.iter().enumerate() {
            let cell = record.get(c).unwrap_or("").trim();
            let column = format!("{} (column {})", header.get(c).unwrap_or("?").trim(), c + 1);
            if cell.is_empty() {
                return Err(TrackError::MissingValue { file: file.into(), row, column, point: layout.source_index(k) });
            }
            match cell.parse::<f64>() {
                Ok(v) if v.is_finite() => points[k][axis] = v,
                _ => return Err(TrackError::NotANumber { file: file.into(), row, column, value: cell.chars().take(24).collect() }),
            }
        }
    }
    Ok(points)
}

/// Writes frames of iBUG-numbered [`NEEDED`] points as an iBUG-68 CSV (`frame,x_0…x_67,y_0…y_67`;
/// points outside [`NEEDED`] are written as 0). Used to make tracks for tests and examples.
pub fn write_ibug68(frames: &[FramePoints]) -> String {
    let mut out = String::from("frame");
    for axis in ["x", "y"] {
        for n in 0..68 {
            out.push_str(&format!(",{axis}_{n}"));
        }
    }
    out.push('\n');
    for (f, points) in frames.iter().enumerate() {
        out.push_str(&f.to_string());
        for axis in [0, 1] {
            for n in 0..68 {
                let v = NEEDED.iter().position(|&p| p == n).map_or(0.0, |k| points[k][axis]);
                out.push_str(&format!(",{v:.3}"));
            }
        }
        out.push('\n');
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ibug_text(frames: usize) -> String {
        let frame: FramePoints = std::array::from_fn(|k| [NEEDED[k] as f64, 100.0 + NEEDED[k] as f64]);
        write_ibug68(&vec![frame; frames])
    }

    #[test]
    fn column_names_of_the_common_layouts_are_understood() {
        assert_eq!(landmark_column(" x_12"), Some((12, 0)));
        assert_eq!(landmark_column("y7"), Some((7, 1)));
        assert_eq!(landmark_column("12_x"), Some((12, 0)));
        assert_eq!(landmark_column("part_3_y"), Some((3, 1)));
        assert_eq!(landmark_column("p3_y"), Some((3, 1)));
        assert_eq!(landmark_column("eye_lmk_x_0"), None);
        assert_eq!(landmark_column("X_0"), None);
        assert_eq!(landmark_column("frame"), None);
    }

    #[test]
    fn layouts_are_detected_from_the_header() {
        let track = read_track("a.csv", &ibug_text(3), None).unwrap();
        assert_eq!((track.layout, track.frames.len()), (Layout::Ibug68, 3));
        assert_eq!(track.point(2, 54), [54.0, 154.0]);
        let openface = ibug_text(2).replacen("frame", "frame, face_id, timestamp, confidence, success", 1).replace("\n0,", "\n0,0,0.0,0.98,1,").replace("\n1,", "\n1,0,0.03,0.98,1,");
        assert_eq!(read_track("o.csv", &openface, None).unwrap().layout, Layout::OpenFace);
        let header66: Vec<String> = (0..66).map(|n| format!("x{n}")).chain((0..66).map(|n| format!("y{n}"))).collect();
        let row: Vec<String> = (0..132).map(|v| v.to_string()).collect();
        let seed = format!("{}\n{}\n", header66.join(","), row.join(","));
        let track = read_track("s.csv", &seed, None).unwrap();
        assert_eq!((track.layout, track.point(0, 57)), (Layout::Seed66, [57.0, 123.0]));
        let mp: Vec<String> = (0..478).map(|n| format!("x_{n}")).chain((0..478).map(|n| format!("y_{n}"))).collect();
        let values: Vec<String> = (0..956).map(|v| v.to_string()).collect();
        let track = read_track("m.csv", &format!("{}\n{}\n", mp.join(","), values.join(",")), None).unwrap();
        assert_eq!((track.layout, track.point(0, 54)), (Layout::MediaPipe, [291.0, 478.0 + 291.0]));
    }

    #[test]
    fn wrong_column_count_is_named_with_file_and_row() {
        let mut text = ibug_text(3);
        text.push_str("3,1,2\n");
        let err = read_track("take.csv", &text, None).unwrap_err();
        assert_eq!(err.to_string(), "take.csv: row 5: 3 columns, but the header has 137");
    }

    #[test]
    fn a_missing_landmark_is_named_with_its_column() {
        let text = ibug_text(2).replacen(",x_48,", ",x_48b,", 1);
        let err = read_track("take.csv", &text, Some(Layout::Ibug68)).unwrap_err();
        assert_eq!(err.to_string(), "take.csv: row 1 (header): landmark 48 of the ibug68 layout has no column x_48");
        let mut lines: Vec<String> = ibug_text(2).lines().map(String::from).collect();
        let mut cells: Vec<&str> = lines[2].split(',').collect();
        cells[1 + 68 + 54] = "";
        lines[2] = cells.join(",");
        let err = read_track("take.csv", &lines.join("\n"), None).unwrap_err();
        assert_eq!(err.to_string(), "take.csv: row 3, column y_54 (column 124): landmark 54 is missing (empty cell)");
    }

    #[test]
    fn nan_is_named_with_row_and_column() {
        let mut lines: Vec<String> = ibug_text(4).lines().map(String::from).collect();
        let mut cells: Vec<&str> = lines[4].split(',').collect();
        cells[1 + 8] = "NaN";
        lines[4] = cells.join(",");
        let err = read_track("t.csv", &lines.join("\n"), None).unwrap_err();
        assert_eq!(err.to_string(), "t.csv: row 5, column x_8 (column 10): \"NaN\" is not a finite number");
    }

    #[test]
    fn unknown_layouts_and_short_tracks_are_refused() {
        let err = read_track("u.csv", "frame,x_0,y_0,x_1,y_1\n0,1,2,3,4\n", None).unwrap_err();
        assert!(matches!(err, TrackError::UnknownLayout { count: 2, .. }), "{err}");
        assert!(matches!(read_track("n.csv", "frame,a\n0,1\n", None), Err(TrackError::NoLandmarks { .. })));
        let track = read_track("s.csv", &ibug_text(3), None).unwrap();
        let err = track.require_frames(6, "the neutral's 5 frames and one more").unwrap_err();
        assert_eq!(err.to_string(), "s.csv: 3 frames; 6 are needed (the neutral's 5 frames and one more)");
    }
}
