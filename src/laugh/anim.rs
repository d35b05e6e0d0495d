//! Maya ASCII `.anim` files: curves out to animation software, and back.
//!
//! In: [`Curves`] (writing) or the text of an `.anim` file (reading). Out: the file's text, or
//! an [`AnimFile`] (header and one [`AnimCurve`] per animated attribute), which
//! [`AnimFile::to_curves`] turns back into curves.
//!
//! Layout written (Maya's animImportExport format): a header of `animVersion`, `mayaVersion`,
//! `timeUnit`, `linearUnit`, `angularUnit`, `startTime`, `endTime`; then per track an
//! `anim ATTR ATTR NODE 0 0 INDEX;` line and an `animData { … keys { TIME VALUE linear linear
//! 1 1 0; … } }` block. The attribute of a track is `AU12`, or `AU12L` / `AU12R` for one side,
//! and `shoulders` for the body's lift when a laugh moves the shoulders;
//! the node is [`NODE`]; frame `f` is keyed at time `f` in the time unit of the curves' frame
//! rate (`ntsc` = 30 fps, `film` = 24, `pal` = 25, `ntscf` = 60, else `Nfps`).
//!
//! Invariants: values are written in Rust's shortest round-trip form, so reading a written
//! file gives back the same keys bit for bit; a malformed file fails with its 1-based line.

use std::fmt::Write;

use crate::facs::{AuCode, Catalog, Laterality};

use super::curves::{CurveTrack, Curves, CurvesError, FORMAT};

/// The node the attributes are written on.
pub const NODE: &str = "facslab_face";
/// The attribute of the shoulders' lift (the body's channel, written after the AUs when a laugh
/// moves the shoulders).
pub const SHOULDERS: &str = "shoulders";
/// Largest `.anim` file read, bytes.
pub const MAX_BYTES: usize = 16 << 20;

/// The header of an `.anim` file.
#[derive(Debug, Clone, PartialEq)]
pub struct AnimHeader {
    pub anim_version: String,
    pub maya_version: String,
    pub time_unit: String,
    pub linear_unit: String,
    pub angular_unit: String,
    pub start_time: f64,
    pub end_time: f64,
}

/// One animated attribute: its names and its keys as (time, value).
#[derive(Debug, Clone, PartialEq)]
pub struct AnimCurve {
    pub attribute: String,
    pub node: String,
    pub keys: Vec<(f64, f64)>,
}

/// A whole `.anim` file.
#[derive(Debug, Clone, PartialEq)]
pub struct AnimFile {
    pub header: AnimHeader,
    pub curves: Vec<AnimCurve>,
}

/// What is wrong with an `.anim` file: the line (1-based) and the problem.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum AnimError {
    #[error("line {line}: {message}")]
    Syntax { line: usize, message: String },
    #[error("the .anim file has no {0} line")]
    MissingHeader(&'static str),
    #[error("the .anim file is {0} bytes; at most {MAX_BYTES}")]
    TooLarge(usize),
    #[error("attribute {attribute:?}: {message}")]
    Curve { attribute: String, message: String },
    #[error(transparent)]
    Curves(#[from] CurvesError),
}

/// Maya's names of the frame rates it has names for.
const TIME_UNITS: [(&str, u32); 7] = [("game", 15), ("film", 24), ("pal", 25), ("ntsc", 30), ("show", 48), ("palf", 50), ("ntscf", 60)];

/// The `timeUnit` of a frame rate.
pub fn time_unit(fps: u32) -> String {
    TIME_UNITS.iter().find(|(_, f)| *f == fps).map_or_else(|| format!("{fps}fps"), |(name, _)| name.to_string())
}

/// The frame rate of a `timeUnit`, if it is one.
pub fn fps_of(unit: &str) -> Option<u32> {
    if let Some((_, fps)) = TIME_UNITS.iter().find(|(name, _)| *name == unit) {
        return Some(*fps);
    }
    unit.strip_suffix("fps")?.parse().ok().filter(|f| (1..=120).contains(f))
}

/// The attribute name of an AU on a side.
pub fn attribute(au: AuCode, side: Laterality) -> String {
    let suffix = match side {
        Laterality::Both => "",
        Laterality::Left => "L",
        Laterality::Right => "R",
    };
    format!("AU{au}{suffix}")
}

fn parse_attribute(name: &str) -> Option<(AuCode, Laterality)> {
    let rest = name.strip_prefix("AU")?;
    let (digits, side) = match rest.strip_suffix('L') {
        Some(d) => (d, Laterality::Left),
        None => match rest.strip_suffix('R') {
            Some(d) => (d, Laterality::Right),
            None => (rest, Laterality::Both),
        },
    };
    let code: u16 = digits.parse().ok().filter(|_| digits.bytes().all(|b| b.is_ascii_digit()))?;
    Some((AuCode(code), side))
}

/// The `.anim` text of `curves`.
pub fn to_anim(curves: &Curves) -> String {
    let frames = curves.frame_count();
    let mut out = String::new();
    let header = [
        ("animVersion", "1.1".to_string()),
        ("mayaVersion", "2018".to_string()),
        ("timeUnit", time_unit(curves.fps)),
        ("linearUnit", "cm".to_string()),
        ("angularUnit", "deg".to_string()),
        ("startTime", "0".to_string()),
        ("endTime", frames.saturating_sub(1).to_string()),
    ];
    for (key, value) in header {
        let _ = writeln!(out, "{key} {value};");
    }
    let body = (!curves.shoulders.is_empty()).then(|| (SHOULDERS.to_string(), &curves.shoulders));
    let attributes = curves.tracks.iter().map(|t| (attribute(t.au, t.side), &t.values)).chain(body);
    for (index, (name, values)) in attributes.enumerate() {
        let _ = writeln!(out, "anim {name} {name} {NODE} 0 0 {index};");
        out.push_str("animData {\n  input time;\n  output unitless;\n  weighted 0;\n  preInfinity constant;\n  postInfinity constant;\n  keys {\n");
        for (frame, value) in values.iter().enumerate() {
            let _ = writeln!(out, "    {frame} {value} linear linear 1 1 0;");
        }
        out.push_str("  }\n}\n");
    }
    out
}

/// Where the reader is in the file.
enum State {
    Top,
    /// After an `anim` line, before its `animData {`.
    Anim,
    /// Inside `animData { … }`.
    Data,
    /// Inside `keys { … }`.
    Keys,
}

fn syntax(line: usize, message: impl Into<String>) -> AnimError {
    AnimError::Syntax { line, message: message.into() }
}

/// The words of a statement line without its `;`.
fn statement(line: usize, text: &str) -> Result<Vec<&str>, AnimError> {
    let body = text.strip_suffix(';').ok_or_else(|| syntax(line, format!("{:?} does not end in ';'", excerpt(text))))?;
    Ok(body.split_whitespace().collect())
}

fn excerpt(text: &str) -> String {
    text.chars().take(40).collect()
}

fn number(line: usize, word: &str, what: &str) -> Result<f64, AnimError> {
    word.parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| syntax(line, format!("{what} {:?} is not a number", excerpt(word))))
}

/// Reads an `.anim` file.
pub fn from_anim(text: &str) -> Result<AnimFile, AnimError> {
    if text.len() > MAX_BYTES {
        return Err(AnimError::TooLarge(text.len()));
    }
    let mut header: Vec<(String, String)> = Vec::new();
    let mut curves: Vec<AnimCurve> = Vec::new();
    let mut state = State::Top;
    for (i, raw) in text.lines().enumerate() {
        let (n, line) = (i + 1, raw.trim());
        if line.is_empty() || line.starts_with("//") {
            continue;
        }
        state = match state {
            State::Top => read_top(n, line, &mut header, &mut curves)?,
            State::Anim if line == "animData {" => State::Data,
            State::Anim => return Err(syntax(n, format!("expected \"animData {{\", found {:?}", excerpt(line)))),
            State::Data => read_data(n, line)?,
            State::Keys => read_key(n, line, curves.last_mut().expect("keys follow an anim line"))?,
        };
    }
    if !matches!(state, State::Top) {
        return Err(syntax(text.lines().count(), "the file ends inside an anim block"));
    }
    Ok(AnimFile { header: header_of(&header)?, curves })
}

fn read_top(n: usize, line: &str, header: &mut Vec<(String, String)>, curves: &mut Vec<AnimCurve>) -> Result<State, AnimError> {
    let words = statement(n, line)?;
    match words.as_slice() {
        ["anim", attribute, _leaf, node, ..] => {
            curves.push(AnimCurve { attribute: attribute.to_string(), node: node.to_string(), keys: Vec::new() });
            Ok(State::Anim)
        }
        ["anim", ..] => Err(syntax(n, "an anim line names the attribute, its leaf and its node")),
        [key, value] => {
            header.push((key.to_string(), value.to_string()));
            Ok(State::Top)
        }
        _ => Err(syntax(n, format!("expected a header line like \"timeUnit ntsc;\" or an anim line, found {:?}", excerpt(line)))),
    }
}

fn read_data(n: usize, line: &str) -> Result<State, AnimError> {
    if line == "keys {" {
        return Ok(State::Keys);
    }
    if line == "}" {
        return Ok(State::Top);
    }
    match statement(n, line)?.as_slice() {
        [_, _] => Ok(State::Data),
        _ => Err(syntax(n, format!("expected an animData setting like \"input time;\", found {:?}", excerpt(line)))),
    }
}

fn read_key(n: usize, line: &str, curve: &mut AnimCurve) -> Result<State, AnimError> {
    if line == "}" {
        return Ok(State::Data);
    }
    let words = statement(n, line)?;
    if words.len() < 2 {
        return Err(syntax(n, format!("a key is \"TIME VALUE …;\", found {:?}", excerpt(line))));
    }
    let time = number(n, words[0], "time")?;
    let value = number(n, words[1], "value")?;
    if curve.keys.last().is_some_and(|&(t, _)| time <= t) {
        return Err(syntax(n, format!("key time {time} does not come after the previous key's")));
    }
    curve.keys.push((time, value));
    Ok(State::Keys)
}

fn header_of(pairs: &[(String, String)]) -> Result<AnimHeader, AnimError> {
    let get = |key: &'static str| pairs.iter().find(|(k, _)| k == key).map(|(_, v)| v.clone()).ok_or(AnimError::MissingHeader(key));
    let time = |key: &'static str| -> Result<f64, AnimError> {
        let line = pairs.iter().position(|(k, _)| k == key).map_or(0, |p| p + 1);
        number(line, &get(key)?, key)
    };
    Ok(AnimHeader {
        anim_version: get("animVersion")?,
        maya_version: get("mayaVersion")?,
        time_unit: get("timeUnit")?,
        linear_unit: get("linearUnit")?,
        angular_unit: get("angularUnit")?,
        start_time: time("startTime")?,
        end_time: time("endTime")?,
    })
}

impl AnimFile {
    /// The curves of this file for the laugh type `laugh_type`: one track per attribute named
    /// like an AU, sampled at every frame from `startTime` to `endTime` (linear between keys,
    /// held before the first and after the last), checked as every curve set is.
    pub fn to_curves(&self, laugh_type: &str, catalog: &Catalog) -> Result<Curves, AnimError> {
        let fps = fps_of(&self.header.time_unit)
            .ok_or_else(|| AnimError::Curve { attribute: "timeUnit".into(), message: format!("{:?} is not a frame rate", excerpt(&self.header.time_unit)) })?;
        let (start, end) = (self.header.start_time.round(), self.header.end_time.round());
        let frames = (end - start + 1.0).max(0.0) as usize;
        let (mut tracks, mut shoulders) = (Vec::new(), Vec::new());
        for curve in &self.curves {
            let values = || (0..frames.min(super::curves::MAX_FRAMES + 1)).map(|f| sample(&curve.keys, start + f as f64)).collect();
            if curve.attribute == SHOULDERS {
                shoulders = values();
                continue;
            }
            let (au, side) = parse_attribute(&curve.attribute)
                .ok_or_else(|| AnimError::Curve { attribute: excerpt(&curve.attribute), message: "is not an AU attribute like AU12 or AU12L".into() })?;
            if curve.keys.is_empty() {
                return Err(AnimError::Curve { attribute: curve.attribute.clone(), message: "has no keys".into() });
            }
            tracks.push(CurveTrack { au, side, values: values() });
        }
        let source = format!("anim file ({} {})", self.header.maya_version, self.header.time_unit);
        let curves = Curves { format: FORMAT.into(), laugh_type: laugh_type.to_string(), fps, source, tracks, fit: None, shoulders };
        curves.validate(catalog)?;
        Ok(curves)
    }
}

/// The value of linear keys at `time`.
fn sample(keys: &[(f64, f64)], time: f64) -> f64 {
    let after = keys.partition_point(|&(t, _)| t <= time);
    match (after.checked_sub(1).map(|i| keys[i]), keys.get(after)) {
        (Some((_, v)), None) | (None, Some(&(_, v))) => v,
        (Some((t0, v0)), Some(&(t1, v1))) => v0 + (v1 - v0) * (time - t0) / (t1 - t0),
        (None, None) => 0.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::laugh::{perform, LaughTable, Take};

    #[test]
    fn a_written_anim_file_reads_back_into_the_same_keys() {
        let catalog = Catalog::built_in();
        let curves = perform(LaughTable::built_in().get("sly_smile").unwrap(), &Take { fps: 24, ..Take::default() }).unwrap();
        let text = to_anim(&curves);
        assert!(text.starts_with("animVersion 1.1;\nmayaVersion 2018;\ntimeUnit film;\nlinearUnit cm;\nangularUnit deg;\nstartTime 0;\n"));
        assert!(text.contains("anim AU12L AU12L facslab_face 0 0 3;\nanimData {\n  input time;\n"));
        let file = from_anim(&text).unwrap();
        assert_eq!(file.header.end_time as usize, curves.frame_count() - 1);
        assert_eq!(file.curves.len(), curves.tracks.len());
        for (curve, track) in file.curves.iter().zip(&curves.tracks) {
            assert_eq!(curve.attribute, attribute(track.au, track.side));
            let keys: Vec<(f64, f64)> = track.values.iter().enumerate().map(|(f, &v)| (f as f64, v)).collect();
            assert_eq!(curve.keys, keys, "{}", curve.attribute);
        }
        assert_eq!(file.to_curves("sly_smile", catalog).unwrap().tracks, curves.tracks);
        let laugh = perform(LaughTable::built_in().get("laughter").unwrap(), &Take::default()).unwrap();
        assert!(!laugh.shoulders.is_empty());
        let back = from_anim(&to_anim(&laugh)).unwrap();
        assert_eq!(back.curves.last().map(|c| c.attribute.as_str()), Some(SHOULDERS));
        assert_eq!(back.to_curves("laughter", catalog).unwrap(), Curves { source: back.to_curves("laughter", catalog).unwrap().source, ..laugh }, "the shoulders come back too");
    }

    #[test]
    fn malformed_anim_files_name_the_line() {
        let good = "animVersion 1.1;\nmayaVersion 2018;\ntimeUnit ntsc;\nlinearUnit cm;\nangularUnit deg;\nstartTime 0;\nendTime 2;\nanim AU12 AU12 n 0 0 0;\nanimData {\n  input time;\n  keys {\n    0 0 linear linear 1 1 0;\n    2 0.5 linear linear 1 1 0;\n  }\n}\n";
        let file = from_anim(good).unwrap();
        assert_eq!(file.to_curves("x", Catalog::built_in()).unwrap().tracks[0].values, vec![0.0, 0.25, 0.5]);
        let bad = |from: &str, to: &str| from_anim(&good.replace(from, to)).unwrap_err().to_string();
        assert_eq!(bad("2 0.5 linear", "2 half linear"), "line 13: value \"half\" is not a number");
        assert_eq!(bad("    0 0 linear linear 1 1 0;", "    0 0 linear linear 1 1 0"), "line 12: \"0 0 linear linear 1 1 0\" does not end in ';'");
        assert_eq!(bad("    2 0.5", "    0 0.5"), "line 13: key time 0 does not come after the previous key's");
        assert_eq!(bad("animData {", "animData"), "line 9: expected \"animData {\", found \"animData\"");
        assert_eq!(bad("timeUnit ntsc;\n", ""), "the .anim file has no timeUnit line");
        assert_eq!(bad("  }\n}\n", ""), "line 13: the file ends inside an anim block");
        let wrong_au = from_anim(&good.replace("AU12 AU12", "jaw jaw")).unwrap().to_curves("x", Catalog::built_in()).unwrap_err();
        assert_eq!(wrong_au.to_string(), "attribute \"jaw\": is not an AU attribute like AU12 or AU12L");
    }
}
