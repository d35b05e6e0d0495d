//! Render requests: JSON from the page or an application, parsed once into a job the engine can
//! run.
//!
//! In: `{"expression": "1+2+L12C", "identity": "wf1", "size": "485x480"}` for a PNG still, or
//! `{"timeline": {…}}` (the JSON `facslab render --export-timeline` writes) for an MP4.
//! Out: a [`Job`] whose [`Job::render`] gives exactly the bytes `facslab render` writes for the
//! same input, or a [`RequestError`] naming the field (and, for FACS notation, the token and its
//! column; for a timeline, the track and the timeline field at fault, see [`timeline_place`]).
//! Invariant: lengths, sizes and frame counts are checked here, before anything is allocated or
//! rendered; messages quote at most a short excerpt of the input.

use serde::Deserialize;

use crate::engine::identity::{Identity, IdentityTable};
use crate::engine::look::{Backdrop, Look, LookError};
use crate::engine::timeline::{ClipTiming, Timeline, TimelineError};
use crate::engine::{self, FrameSettings};
use crate::facs::{Catalog, Expression, MAX_NOTATION_LEN};

/// The person when a request names none (as `facslab render`).
pub const DEFAULT_IDENTITY: &str = "wm1";
/// Largest image side the API renders (the CLI allows 4096; a live API keeps renders short).
pub const MAX_SIDE: u32 = 2_048;
/// Most frames of a video render (one minute at 30 fps).
pub const MAX_VIDEO_FRAMES: usize = 1_800;

/// A render request as it arrives.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RenderRequest {
    #[serde(default)]
    pub expression: Option<String>,
    #[serde(default)]
    pub identity: Option<String>,
    /// `WIDTHxHEIGHT`.
    #[serde(default)]
    pub size: Option<String>,
    #[serde(default)]
    pub timeline: Option<serde_json::Value>,
    /// With `timeline`: render only this frame (0-based) as a PNG, for scrubbing.
    #[serde(default)]
    pub frame: Option<usize>,
    /// `grey` (default), `black`, `#RRGGBB` or `transparent` (an RGBA PNG; stills only).
    #[serde(default)]
    pub backdrop: Option<String>,
    /// `studio` (default), `soft` or `dramatic`.
    #[serde(default)]
    pub light: Option<String>,
    #[serde(default)]
    pub grayscale: bool,
}

/// A HapFACS clip to turn into a timeline (`POST /api/v1/timeline`), as `facslab render EXPR
/// --video [--onset S --apex S --offset S --fps N --ramp R] --export-timeline FILE` does.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClipRequest {
    pub expression: String,
    #[serde(default)]
    pub identity: Option<String>,
    #[serde(default)]
    pub size: Option<String>,
    #[serde(default)]
    pub timing: Option<ClipTiming>,
    #[serde(default)]
    pub fps: Option<u32>,
}

impl ClipRequest {
    /// The timeline JSON, byte for byte what `--export-timeline` writes.
    pub fn timeline_json(self) -> Result<String, RequestError> {
        let expression = parse_expression(&self.expression)?;
        let person = identity(self.identity.as_deref())?;
        let size = self.size.as_deref().map(parse_size).transpose()?.unwrap_or(engine::DEFAULT_SIZE);
        let timing = self.timing.unwrap_or_default();
        for (what, v) in [("onset_s", timing.onset_s), ("apex_s", timing.apex_s), ("offset_s", timing.offset_s)] {
            if !v.is_finite() || !(0.0..=60.0).contains(&v) {
                return Err(RequestError::field("timing", format!("{what} {v} must be 0 to 60 seconds")));
            }
        }
        let timeline = Timeline::clip(&expression, timing, self.fps.unwrap_or(30), &person.id, size);
        timeline.validate(Catalog::built_in()).map_err(|e| RequestError::field("timing", excerpt(&e.to_string(), 200)))?;
        if timeline.frame_count() > MAX_VIDEO_FRAMES {
            return Err(RequestError::field("timing", format!("{} frames is more than {MAX_VIDEO_FRAMES}", timeline.frame_count())));
        }
        Ok(timeline.to_json())
    }
}

/// What is wrong with a request.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RequestError {
    #[error("the request is not valid JSON of the render API: {0}")]
    Json(String),
    #[error("`{field}`: {message}")]
    Field { field: &'static str, message: String },
    /// A timeline that fails validation: `key` is the field of the timeline JSON at fault and
    /// `track` the (1-based) entry of `tracks` when the fault is in one.
    #[error("`timeline`: {message}")]
    Timeline { track: Option<usize>, key: &'static str, message: String },
    #[error("expression: token \"{token}\" at column {column}: {message}")]
    Notation { token: String, column: usize, message: String },
    #[error("the render failed: {0}")]
    Render(String),
    #[error("the renderer is shutting down")]
    Unavailable,
}

impl RequestError {
    fn field(field: &'static str, message: impl Into<String>) -> RequestError {
        RequestError::Field { field, message: message.into() }
    }

    /// `{"error": "…", "field": "…", "token": "…", "column": n}` (the last three when known);
    /// for a timeline, `"field": "timeline"` with `"key"` (the timeline's field, such as
    /// `end_s`) and `"track"` (1-based) when the fault is in a track.
    pub fn to_json(&self) -> serde_json::Value {
        let mut json = serde_json::json!({ "error": self.to_string() });
        match self {
            RequestError::Field { field, .. } => json["field"] = (*field).into(),
            RequestError::Timeline { track, key, .. } => {
                json["field"] = "timeline".into();
                json["key"] = (*key).into();
                if let Some(track) = track {
                    json["track"] = (*track).into();
                }
            }
            RequestError::Notation { token, column, .. } => {
                json["field"] = "expression".into();
                json["token"] = token.clone().into();
                json["column"] = (*column).into();
            }
            _ => {}
        }
        json
    }
}

/// At most `max` characters of `text`, with an ellipsis when cut.
fn excerpt(text: &str, max: usize) -> String {
    let mut cut: String = text.chars().take(max).collect();
    if text.chars().nth(max).is_some() {
        cut.push('…');
    }
    cut
}

/// A checked request, ready to render.
#[derive(Debug, Clone)]
pub enum Job {
    /// One picture; `shoulders` is the body's lift of a timeline's frame (0 for an expression).
    Still { expression: Expression, identity: &'static Identity, size: (u32, u32), look: Look, shoulders: f32 },
    Video(Box<Timeline>, Look),
}

/// The look a request asks for, as `facslab render --backdrop --light --grayscale` reads it.
fn look(backdrop: Option<&str>, light: Option<&str>, grayscale: bool) -> Result<Look, RequestError> {
    Look::parse(backdrop, light, grayscale).map_err(|e| {
        let field = match e {
            LookError::Backdrop(_) => "backdrop",
            LookError::Light(_) => "light",
        };
        RequestError::field(field, excerpt(&e.to_string(), 120))
    })
}

fn frame_of(timeline: &Timeline, frame: usize, look: Look) -> Result<Job, RequestError> {
    if frame >= timeline.frame_count() {
        return Err(RequestError::field("frame", format!("frame {frame} is past the last frame ({})", timeline.frame_count().saturating_sub(1))));
    }
    let expression = timeline.frame_expression(frame, Catalog::built_in()).map_err(|e| RequestError::field("timeline", e.to_string()))?;
    let person = identity(Some(&timeline.identity))?;
    let shoulders = timeline.frame_shoulders(frame);
    Ok(Job::Still { expression, identity: person, size: (timeline.size[0], timeline.size[1]), look, shoulders })
}

/// The bytes of a render and what they are.
#[derive(Debug, Clone)]
pub struct Rendered {
    pub bytes: Vec<u8>,
    pub video: bool,
}

impl Rendered {
    pub fn content_type(&self) -> &'static str {
        if self.video { "video/mp4" } else { "image/png" }
    }
}

/// Parses FACS notation, bounded, with the failing token kept for the caller.
pub fn parse_expression(text: &str) -> Result<Expression, RequestError> {
    if text.len() > MAX_NOTATION_LEN {
        return Err(RequestError::field("expression", format!("longer than {MAX_NOTATION_LEN} bytes (\"{}\")", excerpt(text, 24))));
    }
    Catalog::built_in().parse(text).map_err(|e| RequestError::Notation { token: excerpt(&e.token, 24), column: e.column, message: e.kind.to_string() })
}

/// Parses `WIDTHxHEIGHT` as `facslab render --size` does, then holds each side to [`MAX_SIDE`].
pub fn parse_size(text: &str) -> Result<(u32, u32), RequestError> {
    let (w, h) = engine::parse_size(text).map_err(|message| RequestError::field("size", message))?;
    if w > MAX_SIDE || h > MAX_SIDE {
        return Err(RequestError::field("size", format!("{w}x{h} is out of range (each side 16..={MAX_SIDE})")));
    }
    Ok((w, h))
}

fn identity(id: Option<&str>) -> Result<&'static Identity, RequestError> {
    let id = id.unwrap_or(DEFAULT_IDENTITY);
    IdentityTable::active()
        .get(id)
        .map_err(|_| RequestError::field("identity", format!("no person \"{}\" (GET /api/v1/catalog lists them)", excerpt(id, 24))))
}

/// Where a validation error of a timeline is: the track (1-based) when it is in one, and the
/// field of the timeline JSON (the one to correct: for times out of order, the end).
pub fn timeline_place(error: &TimelineError) -> (Option<usize>, &'static str) {
    match *error {
        TimelineError::Fps(_) => (None, "fps"),
        TimelineError::Duration(_) => (None, "duration_s"),
        TimelineError::Tracks(_) => (None, "tracks"),
        TimelineError::Size(..) => (None, "size"),
        TimelineError::Json(_) => (None, "timeline"),
        TimelineError::UnknownAu { track, .. } => (Some(track), "au"),
        TimelineError::NotUnilateral { track, .. } => (Some(track), "side"),
        TimelineError::Intensity { track, what: "start", .. } => (Some(track), "start_intensity"),
        TimelineError::Intensity { track, .. } => (Some(track), "end_intensity"),
        TimelineError::Times { track, start, .. } if !(start.is_finite() && start >= 0.0) => (Some(track), "start_s"),
        TimelineError::Times { track, .. } => (Some(track), "end_s"),
        TimelineError::Overlap { second, .. } => (Some(second), "start_s"),
        TimelineError::Shoulders { .. } => (None, "shoulders"),
    }
}

fn timeline_error(error: TimelineError) -> RequestError {
    let (track, key) = timeline_place(&error);
    RequestError::Timeline { track, key, message: excerpt(&error.to_string(), 200) }
}

fn timeline(value: serde_json::Value) -> Result<Timeline, RequestError> {
    let timeline = Timeline::from_json(&value.to_string()).map_err(timeline_error)?;
    timeline.validate(Catalog::built_in()).map_err(timeline_error)?;
    let whole = |key, message| RequestError::Timeline { track: None, key, message };
    if timeline.size.iter().any(|side| *side > MAX_SIDE) {
        return Err(whole("size", format!("size {}x{} is over {MAX_SIDE} on a side", timeline.size[0], timeline.size[1])));
    }
    if timeline.frame_count() > MAX_VIDEO_FRAMES {
        return Err(whole("duration_s", format!("{} frames is more than the {MAX_VIDEO_FRAMES} a request may render", timeline.frame_count())));
    }
    identity(Some(&timeline.identity)).map_err(|_| whole("identity", format!("no person \"{}\"", excerpt(&timeline.identity, 24))))?;
    Ok(timeline)
}

/// Checks a timeline as a render request would (`POST /api/v1/timeline/check`, for importing a
/// file into the editor): the timeline JSON as the server reads it, defaults filled in, or the
/// refusal naming the track and field.
pub fn check_timeline(body: &[u8]) -> Result<String, RequestError> {
    let value: serde_json::Value = serde_json::from_slice(body).map_err(|e| RequestError::Json(e.to_string()))?;
    let timeline = timeline(value)?;
    if !timeline.shoulders.is_empty() {
        let message = "the editor shapes AU tracks only and would drop the shoulders' lift; render this timeline with `facslab render --timeline` or the render API".to_string();
        return Err(RequestError::Timeline { track: None, key: "shoulders", message });
    }
    Ok(timeline.to_json())
}

impl RenderRequest {
    /// Checks the request completely; nothing renders yet.
    pub fn parse(self) -> Result<Job, RequestError> {
        let look = look(self.backdrop.as_deref(), self.light.as_deref(), self.grayscale)?;
        match (self.expression, self.timeline) {
            (Some(_), Some(_)) => Err(RequestError::field("timeline", "give either `expression` (a still) or `timeline` (a video), not both")),
            (None, None) => Err(RequestError::field("expression", "missing: give `expression` (a still) or `timeline` (a video)")),
            (None, Some(value)) => {
                if self.identity.is_some() || self.size.is_some() {
                    return Err(RequestError::field("timeline", "the person and size of a video come from its timeline"));
                }
                let timeline = timeline(value)?;
                match self.frame {
                    Some(frame) => frame_of(&timeline, frame, look),
                    None if look.backdrop == Backdrop::Transparent => {
                        Err(RequestError::field("backdrop", "a video cannot have a transparent backdrop"))
                    }
                    None => Ok(Job::Video(Box::new(timeline), look)),
                }
            }
            (Some(_), None) if self.frame.is_some() => Err(RequestError::field("frame", "`frame` goes with `timeline`")),
            (Some(text), None) => {
                let expression = parse_expression(&text)?;
                let identity = identity(self.identity.as_deref())?;
                let size = self.size.as_deref().map(parse_size).transpose()?.unwrap_or(engine::DEFAULT_SIZE);
                Ok(Job::Still { expression, identity, size, look, shoulders: 0.0 })
            }
        }
    }
}

impl Job {
    /// Renders the job: the PNG `facslab render EXPR --identity ID --size WxH` writes, or the
    /// MP4 `facslab render --timeline FILE` writes.
    pub fn render(self) -> Result<Rendered, RequestError> {
        match self {
            Job::Still { expression, identity, size, look, shoulders } => {
                let settings = FrameSettings { width: size.0, height: size.1, threads: None, look, shoulders, ..Default::default() };
                let frame = engine::render_frame(&expression, identity, settings).map_err(|e| RequestError::Render(e.to_string()))?;
                Ok(Rendered { bytes: frame.encode_png(), video: false })
            }
            Job::Video(timeline, look) => {
                let settings = FrameSettings { width: timeline.size[0], height: timeline.size[1], threads: Some(1), look, ..Default::default() };
                let bytes = crate::stimuli::render_video(&timeline, settings, None, true, None, None, None, &mut |_, _| {})
                    .map_err(|e| RequestError::Render(e.to_string()))?;
                Ok(Rendered { bytes, video: true })
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn request(json: serde_json::Value) -> Result<Job, RequestError> {
        serde_json::from_value::<RenderRequest>(json).map_err(|e| RequestError::Json(e.to_string()))?.parse()
    }

    #[test]
    fn a_bad_token_is_named_with_its_column() {
        let err = request(serde_json::json!({ "expression": "1+2+L99C+26" })).unwrap_err();
        assert_eq!(err.to_json()["token"], "L99C");
        assert_eq!(err.to_json()["column"], 5);
        assert_eq!(err.to_json()["field"], "expression");
    }

    #[test]
    fn limits_are_checked_and_quote_only_an_excerpt() {
        let long = "1+".repeat(50_000);
        let err = request(serde_json::json!({ "expression": long })).unwrap_err();
        assert!(err.to_string().len() < 120, "{err}");
        let err = request(serde_json::json!({ "expression": "12", "size": "4096x4096" })).unwrap_err();
        assert_eq!(err.to_json()["field"], "size");
        let err = request(serde_json::json!({ "expression": "12", "identity": "nobody" })).unwrap_err();
        assert_eq!(err.to_json()["field"], "identity");
        let long = serde_json::json!({ "fps": 30, "duration_s": 1e12, "tracks": [] });
        let err = request(serde_json::json!({ "timeline": long })).unwrap_err();
        assert_eq!(err.to_json()["field"], "timeline", "{err}");
    }

    #[test]
    fn timeline_errors_name_the_track_and_its_field() {
        let track = |au: u16, from: f64, to: f64, start: f64, end: f64| {
            serde_json::json!({ "au": au, "start_intensity": from, "end_intensity": to, "start_s": start, "end_s": end })
        };
        let refusal = |tracks: Vec<serde_json::Value>| {
            let timeline = serde_json::json!({ "duration_s": 2.0, "size": [64, 64], "tracks": tracks });
            request(serde_json::json!({ "timeline": timeline, "frame": 0 })).unwrap_err().to_json()
        };
        let good = || track(1, 0.0, 1.0, 0.0, 1.0);
        let cases = [
            (vec![good(), track(12, 0.0, 1.5, 0.0, 1.0)], 2, "end_intensity"),
            (vec![good(), track(12, -0.1, 1.0, 0.0, 1.0)], 2, "start_intensity"),
            (vec![track(12, 0.0, 1.0, 1.0, 0.5)], 1, "end_s"),
            (vec![track(12, 0.0, 1.0, 0.5, 2.5)], 1, "end_s"),
            (vec![track(12, 0.0, 1.0, -1.0, 0.5)], 1, "start_s"),
            (vec![good(), track(99, 0.0, 1.0, 0.0, 1.0)], 2, "au"),
            (vec![track(12, 0.0, 1.0, 0.0, 1.0), good(), track(12, 1.0, 0.0, 0.5, 2.0)], 3, "start_s"),
        ];
        for (tracks, number, key) in cases {
            let json = refusal(tracks);
            assert_eq!((json["field"].as_str(), json["track"].as_u64(), json["key"].as_str()), (Some("timeline"), Some(number), Some(key)), "{json}");
            assert!(json["error"].as_str().unwrap().contains(&format!("{number} (AU ")), "the message names the track: {json}");
        }
        let mut one_sided = track(26, 0.0, 1.0, 0.0, 1.0);
        one_sided["side"] = "left".into();
        assert_eq!(refusal(vec![one_sided])["key"], "side");
        let slow = serde_json::json!({ "fps": 0, "duration_s": 1.0, "tracks": [] });
        let json = request(serde_json::json!({ "timeline": slow })).unwrap_err().to_json();
        assert_eq!((json["key"].as_str(), json.get("track")), (Some("fps"), None), "{json}");
    }

    #[test]
    fn a_still_or_a_video_but_not_both() {
        assert!(matches!(request(serde_json::json!({ "expression": "12" })), Ok(Job::Still { size: (485, 480), .. })));
        let err = request(serde_json::json!({ "expression": "12", "backdrop": "plaid" })).unwrap_err();
        assert_eq!(err.to_json()["field"], "backdrop");
        let both = serde_json::json!({ "expression": "12", "timeline": { "duration_s": 1.0, "tracks": [] } });
        assert!(request(both).is_err());
        assert!(request(serde_json::json!({})).is_err());
        assert!(matches!(request(serde_json::json!({ "expresion": "12" })), Err(RequestError::Json(_))));
    }

    #[test]
    fn a_checked_timeline_comes_back_with_its_defaults_or_is_refused_by_track_and_field() {
        let checked = check_timeline(br#"{"duration_s": 1, "tracks": [{"au": 12, "start_intensity": 0, "end_intensity": 1, "start_s": 0, "end_s": 1}]}"#).unwrap();
        let timeline = Timeline::from_json(&checked).unwrap();
        assert_eq!((timeline.fps, timeline.identity.as_str(), timeline.size), (30, DEFAULT_IDENTITY, [485, 480]));
        assert!(checked.contains("\"side\": \"both\"") && checked.contains("\"ramp\": \"linear\""), "{checked}");
        let bad = check_timeline(br#"{"duration_s": 1, "tracks": [{"au": 12, "start_intensity": 0, "end_intensity": 1.5, "start_s": 0, "end_s": 1}]}"#).unwrap_err();
        assert_eq!((bad.to_json()["track"].clone(), bad.to_json()["key"].clone()), (1.into(), "end_intensity".into()), "{bad}");
        assert!(matches!(check_timeline(b"{not json"), Err(RequestError::Json(_))));
        let shrug = check_timeline(br#"{"duration_s": 1, "tracks": [], "shoulders": [[0, 0], [0.5, 0.4]]}"#).unwrap_err();
        assert_eq!(shrug.to_json()["key"], "shoulders", "the editor would drop the shoulders, so it does not import them: {shrug}");
        let bad = check_timeline(br#"{"duration_s": 1, "tracks": [], "shoulders": [[0.5, 0.4], [0.2, 0.1]]}"#).unwrap_err();
        assert!(bad.to_string().contains("shoulders key 2: time 0.2 s must be in [0, 1] and not before the key before it"), "{bad}");
    }
}
