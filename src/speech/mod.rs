//! Speaking faces: text → sound, phones and mouth movement, blended with an expression.
//!
//! The pipeline, one stage per module, plain data between them:
//! 1. [`espeak`]: text + [`Voice`] → [`Utterance`] (22,050-Hz samples, IPA phones with times),
//!    from eSpeak NG's C library loaded at run time;
//! 2. [`visemes`]: phones → speech AU channels over time (the data table
//!    `stimuli/engine/visemes.toml`, dominance-model coarticulation);
//! 3. [`performance`]: utterance + [`Face`] → [`Performance`] (one AU timeline for the engine,
//!    the phone and viseme of every frame, the sound padded to the video's length), by the blend
//!    rules in that module's doc, with seeded blinks and head motion;
//! 4. [`audio`] and [`opus`]: the sound resampled to 48 kHz and encoded as Opus packets for the
//!    MP4's sound track ([`encode_sound`]); `engine::video` muxes them beside the H.264 frames.
//!
//! Invariants: no file I/O here (callers write the MP4, WAV and CSV); same text, voice, face and
//! seed → the same samples, phones and timeline (guarded by
//! `speech_is_deterministic`). A missing eSpeak NG or libopus is [`SpeechError::Missing`],
//! raised by [`check_tools`] before a caller renders or writes anything.

pub mod audio;
pub mod espeak;
pub mod opus;
pub mod performance;
pub mod visemes;

pub use espeak::{Phone, Utterance, Voice};
pub use performance::{Face, FrameSpeech, Performance, Staging};

/// Longest text spoken in one video, in characters.
pub const MAX_TEXT_CHARS: usize = 400;
/// Longest speech in one video, in seconds: the timeline has one track per channel and frame
/// step, and a timeline holds at most `timeline::MAX_TRACKS`.
pub const MAX_SPEECH_S: f64 = 12.0;

/// Why speech could not be made.
#[derive(Debug, Clone, thiserror::Error)]
pub enum SpeechError {
    #[error("{tool} is not installed ({library}: {detail}); install it with `{install}`")]
    Missing { tool: &'static str, library: String, install: &'static str, detail: String },
    #[error("unknown or invalid eSpeak NG voice `{0}` (see `espeak-ng --voices`)")]
    Voice(String),
    #[error("rate {0} words per minute is outside 80..=450")]
    Rate(u32),
    #[error("pitch {0} is outside 0..=100")]
    Pitch(u32),
    #[error("{0}")]
    Text(String),
    #[error("eSpeak NG could not synthesise the text (error {0})")]
    Synthesis(i32),
    #[error("the speech lasts {0:.1} s; at most {MAX_SPEECH_S} s fit in one video (shorten the text)")]
    TooLong(f64),
    #[error("speech synthesis process: {0}")]
    Isolation(String),
    #[error("Opus encoder: {0}")]
    Opus(String),
}

/// Checks that eSpeak NG and libopus can be loaded.
pub fn check_tools() -> Result<(), SpeechError> {
    espeak::check_available()?;
    opus::check_available()
}

/// Checks a text before it is spoken: not empty, not too long, no control characters.
pub fn check_text(text: &str) -> Result<(), SpeechError> {
    let count = text.chars().count();
    if text.trim().is_empty() {
        return Err(SpeechError::Text("the text to speak is empty".into()));
    }
    if count > MAX_TEXT_CHARS {
        let start: String = text.chars().take(32).collect();
        return Err(SpeechError::Text(format!("the text \"{start}…\" has {count} characters; at most {MAX_TEXT_CHARS}")));
    }
    if text.chars().any(|c| c.is_control() && !c.is_whitespace()) {
        return Err(SpeechError::Text("the text contains control characters".into()));
    }
    Ok(())
}

/// Speaks `text` with `voice` on `face`: the whole performance.
pub fn speak(text: &str, voice: &Voice, face: &Face, staging: Staging) -> Result<Performance, SpeechError> {
    check_text(text)?;
    let utterance = espeak::synthesize(text, voice)?;
    if utterance.duration_s() > MAX_SPEECH_S {
        return Err(SpeechError::TooLong(utterance.duration_s()));
    }
    Ok(performance::perform(&utterance, face, staging))
}

/// `samples` (at `rate`) resampled to 48 kHz and encoded as the MP4's Opus sound track.
pub fn encode_sound(samples: &[i16], rate: u32) -> Result<crate::engine::video::OpusTrack, SpeechError> {
    let resampled = audio::resample(samples, rate, opus::SAMPLE_RATE);
    let packet_s = opus::PACKET_SAMPLES as f64 / f64::from(opus::SAMPLE_RATE);
    Ok(crate::engine::video::OpusTrack { packets: opus::encode(&resampled)?, packet_s })
}
