//! Text → sound and phonemes with their times: eSpeak NG's C library, loaded at run time.
//!
//! In: a text and a [`Voice`] (eSpeak voice name, rate in words per minute, pitch 0–100).
//! Out: an [`Utterance`]: 16-bit mono samples at eSpeak's rate (22,050 Hz) and the phones in
//! order, each with its IPA symbol and its start and end in seconds.
//!
//! Why the library and not the `espeak-ng` program: the program writes the WAV (`-w`) and the
//! phonemes (`-x`, `--ipa`) but not *when* each phoneme starts (`--pho` works with MBROLA voices
//! only). The library reports an `espeakEVENT_PHONEME` event per phone with its position in the
//! audio, and hands the samples of the same run to a callback, so sound and phones cannot drift.
//! Why loaded at run time (`libloading`) and not linked: the build needs no system library and
//! a machine without eSpeak NG gets [`SpeechError::Missing`] with the install command before
//! anything is written, instead of a binary that does not start.
//!
//! Invariants: same text and voice → the same samples and the same phone times. eSpeak NG has no
//! randomness, but it carries state from one synthesis to the next (function statics such as the
//! pitch flutter's phase; measured: the second "Hello there." of a process is 2 samples shorter
//! and differs from sample 1,384 on). So this process loads and initialises eSpeak once and
//! never synthesises: each synthesis runs in a forked child that starts from that same state,
//! sets every parameter, and sends the samples and phones back through a pipe (Linux/Unix only).

use std::cell::RefCell;
use std::ffi::{CString, c_char, c_int, c_uint, c_void};
use std::sync::{Mutex, OnceLock};

use super::SpeechError;

/// The library file loaded, unless `FACSLAB_ESPEAK_LIBRARY` names another (a path or a name).
pub const LIBRARY: &str = "libespeak-ng.so.1";
/// The environment variable that overrides [`LIBRARY`].
pub const LIBRARY_ENV: &str = "FACSLAB_ESPEAK_LIBRARY";
/// What to install when the library is missing (Debian and Ubuntu).
pub const INSTALL: &str = "apt-get install espeak-ng libespeak-ng1";

/// Words per minute eSpeak accepts.
pub const RATE_RANGE: std::ops::RangeInclusive<u32> = 80..=450;

/// The voice: eSpeak voice name, speaking rate and base pitch.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Voice {
    /// An eSpeak NG voice name (`espeak-ng --voices`), e.g. `en-us`.
    #[serde(default = "default_voice")]
    pub name: String,
    /// Words per minute, 80–450 (eSpeak's default 175).
    #[serde(default = "default_rate")]
    pub rate_wpm: u32,
    /// Base pitch 0–100 (eSpeak's default 50).
    #[serde(default = "default_pitch")]
    pub pitch: u32,
}

fn default_voice() -> String {
    "en-us".into()
}
fn default_rate() -> u32 {
    175
}
fn default_pitch() -> u32 {
    50
}

impl Default for Voice {
    /// eSpeak NG's neutral American English voice at its default rate and pitch.
    fn default() -> Voice {
        Voice { name: default_voice(), rate_wpm: default_rate(), pitch: default_pitch() }
    }
}

impl Voice {
    /// Checks the ranges and that the name is a plain voice name (letters, digits, `-`, `_`, `+`).
    pub fn validate(&self) -> Result<(), SpeechError> {
        let plain = |c: char| c.is_ascii_alphanumeric() || "-_+".contains(c);
        if self.name.is_empty() || self.name.len() > 40 || !self.name.chars().all(plain) {
            return Err(SpeechError::Voice(self.name.chars().take(40).collect()));
        }
        if !RATE_RANGE.contains(&self.rate_wpm) {
            return Err(SpeechError::Rate(self.rate_wpm));
        }
        if self.pitch > 100 {
            return Err(SpeechError::Pitch(self.pitch));
        }
        Ok(())
    }
}

/// One phone of an utterance. `symbol` is IPA (eSpeak's names); empty for a pause.
#[derive(Debug, Clone, PartialEq)]
pub struct Phone {
    pub symbol: String,
    pub start_s: f64,
    pub end_s: f64,
}

/// Synthesised speech: the samples and the phones, on one clock.
#[derive(Debug, Clone, PartialEq)]
pub struct Utterance {
    pub sample_rate: u32,
    pub samples: Vec<i16>,
    pub phones: Vec<Phone>,
}

impl Utterance {
    pub fn duration_s(&self) -> f64 {
        self.samples.len() as f64 / self.sample_rate as f64
    }

    /// The phone sounding at `t` (the last one starting at or before `t`), if any.
    pub fn phone_at(&self, t: f64) -> Option<&Phone> {
        phone_at(&self.phones, t)
    }
}

/// The phone of `phones` (in time order) sounding at `t`, if any.
pub fn phone_at(phones: &[Phone], t: f64) -> Option<&Phone> {
    phones.iter().take_while(|p| p.start_s <= t).last().filter(|p| t < p.end_s)
}

/// eSpeak's `espeak_EVENT` (speak_lib.h, API revision 12).
#[repr(C)]
struct Event {
    kind: c_int,
    unique_identifier: c_uint,
    text_position: c_int,
    length: c_int,
    audio_position: c_int,
    sample: c_int,
    user_data: *mut c_void,
    id: [u8; 8],
}

const EVENT_LIST_TERMINATED: c_int = 0;
const EVENT_PHONEME: c_int = 7;
const AUDIO_OUTPUT_SYNCHRONOUS: c_int = 2;
const INITIALIZE_PHONEME_EVENTS_IPA: c_int = 0x0001 | 0x0002;
const INITIALIZE_DONT_EXIT: c_int = 0x8000;
const POS_CHARACTER: c_int = 1;
const CHARS_UTF8: c_uint = 1;
const RATE: c_int = 1;
const VOLUME: c_int = 2;
const PITCH: c_int = 3;
const RANGE: c_int = 4;

type SynthCallback = unsafe extern "C" fn(*mut i16, c_int, *mut Event) -> c_int;

/// The loaded library and its sample rate.
struct Espeak {
    _library: libloading::Library,
    sample_rate: u32,
    set_voice: unsafe extern "C" fn(*const c_char) -> c_int,
    set_parameter: unsafe extern "C" fn(c_int, c_int, c_int) -> c_int,
    synth: unsafe extern "C" fn(*const c_void, usize, c_uint, c_int, c_uint, c_uint, *mut c_uint, *mut c_void) -> c_int,
}

/// What one synthesis collects: samples, and (audio position in ms, IPA name) per phone event.
#[derive(Default)]
struct Collected {
    samples: Vec<i16>,
    events: Vec<(u32, String)>,
}

thread_local! {
    static COLLECTED: RefCell<Collected> = RefCell::new(Collected::default());
}

/// The synth callback: appends the samples and the phoneme events of one chunk.
unsafe extern "C" fn collect(wav: *mut i16, count: c_int, events: *mut Event) -> c_int {
    COLLECTED.with(|c| {
        let mut c = c.borrow_mut();
        if !wav.is_null() && count > 0 {
            // SAFETY: eSpeak passes `count` valid samples at `wav` for the duration of the call.
            c.samples.extend_from_slice(unsafe { std::slice::from_raw_parts(wav, count as usize) });
        }
        let mut at = events;
        // SAFETY: the event list ends with an EVENT_LIST_TERMINATED entry.
        while !at.is_null() && unsafe { (*at).kind } != EVENT_LIST_TERMINATED {
            let event = unsafe { &*at };
            if event.kind == EVENT_PHONEME {
                let end = event.id.iter().position(|&b| b == 0).unwrap_or(8);
                let name = String::from_utf8_lossy(&event.id[..end]).into_owned();
                c.events.push((event.audio_position.max(0) as u32, name));
            }
            at = unsafe { at.add(1) };
        }
    });
    0
}

fn library_name() -> String {
    std::env::var(LIBRARY_ENV).ok().filter(|v| !v.is_empty()).unwrap_or_else(|| LIBRARY.to_string())
}

impl Espeak {
    fn load() -> Result<Espeak, SpeechError> {
        let name = library_name();
        let missing = |detail: String| SpeechError::Missing { tool: "eSpeak NG", library: name.clone(), install: INSTALL, detail };
        // SAFETY: loading eSpeak NG runs no initialisers with preconditions.
        let library = unsafe { libloading::Library::new(&name) }.map_err(|e| missing(e.to_string()))?;
        // SAFETY: the symbols have the signatures of speak_lib.h.
        unsafe {
            let initialize = *library
                .get::<unsafe extern "C" fn(c_int, c_int, *const c_char, c_int) -> c_int>(b"espeak_Initialize\0")
                .map_err(|e| missing(e.to_string()))?;
            let set_callback = *library.get::<unsafe extern "C" fn(Option<SynthCallback>)>(b"espeak_SetSynthCallback\0").map_err(|e| missing(e.to_string()))?;
            let set_voice = *library.get(b"espeak_SetVoiceByName\0").map_err(|e| missing(e.to_string()))?;
            let set_parameter = *library.get(b"espeak_SetParameter\0").map_err(|e| missing(e.to_string()))?;
            let synth = *library.get(b"espeak_Synth\0").map_err(|e| missing(e.to_string()))?;
            let rate = initialize(AUDIO_OUTPUT_SYNCHRONOUS, 0, std::ptr::null(), INITIALIZE_PHONEME_EVENTS_IPA | INITIALIZE_DONT_EXIT);
            if rate <= 0 {
                return Err(missing(format!("espeak_Initialize failed ({rate}): is espeak-ng-data installed?")));
            }
            set_callback(Some(collect));
            Ok(Espeak { _library: library, sample_rate: rate as u32, set_voice, set_parameter, synth })
        }
    }
}

static ESPEAK: OnceLock<Result<Mutex<Espeak>, SpeechError>> = OnceLock::new();

/// Checks that eSpeak NG can be loaded (and loads it), without synthesising anything.
pub fn check_available() -> Result<(), SpeechError> {
    ESPEAK.get_or_init(|| Espeak::load().map(Mutex::new)).as_ref().map(|_| ()).map_err(Clone::clone)
}

/// Synthesises `text` with `voice`.
pub fn synthesize(text: &str, voice: &Voice) -> Result<Utterance, SpeechError> {
    voice.validate()?;
    let espeak = ESPEAK.get_or_init(|| Espeak::load().map(Mutex::new)).as_ref().map_err(Clone::clone)?;
    let espeak = espeak.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
    let text = CString::new(text).map_err(|_| SpeechError::Text("the text contains a NUL character".into()))?;
    let name = CString::new(voice.name.as_str()).map_err(|_| SpeechError::Voice(voice.name.clone()))?;
    let bytes = isolated(|| encode_run(synthesize_here(&espeak, &text, &name, voice)))?;
    let collected = decode_run(&bytes)
        .ok_or_else(|| SpeechError::Isolation("the synthesis process sent malformed data".into()))?
        .map_err(|e| if let SpeechError::Voice(_) = e { SpeechError::Voice(voice.name.clone()) } else { e })?;
    Ok(utterance(collected, espeak.sample_rate))
}

/// One synthesis in this process. eSpeak keeps state from one synthesis to the next in
/// function statics (the pitch flutter's phase, among others), which nothing resets: a second
/// synthesis of the same text differs from the first. [`synthesize`] therefore runs each in a
/// forked child of a process that never synthesised, so every run starts from the same state.
fn synthesize_here(espeak: &Espeak, text: &CString, name: &CString, voice: &Voice) -> Result<Collected, SpeechError> {
    COLLECTED.with(|c| *c.borrow_mut() = Collected::default());
    // SAFETY: the functions come from the loaded library; the strings outlive the calls.
    let status = unsafe {
        if (espeak.set_voice)(name.as_ptr()) != 0 {
            return Err(SpeechError::Voice(voice.name.clone()));
        }
        for (parameter, value) in [(RATE, voice.rate_wpm as c_int), (PITCH, voice.pitch as c_int), (VOLUME, 100), (RANGE, 50)] {
            (espeak.set_parameter)(parameter, value, 0);
        }
        let bytes = text.as_bytes_with_nul();
        (espeak.synth)(bytes.as_ptr().cast(), bytes.len(), 0, POS_CHARACTER, 0, CHARS_UTF8, std::ptr::null_mut(), std::ptr::null_mut())
    };
    let collected = COLLECTED.with(|c| std::mem::take(&mut *c.borrow_mut()));
    if status != 0 {
        return Err(SpeechError::Synthesis(status));
    }
    Ok(collected)
}

/// A run's result as bytes: a tag (0 = samples and events follow, 1 = voice error, 2 = synthesis
/// error with its code), then little-endian counts and values.
fn encode_run(run: Result<Collected, SpeechError>) -> Vec<u8> {
    let mut out = Vec::new();
    match run {
        Ok(collected) => {
            out.push(0);
            out.extend_from_slice(&(collected.samples.len() as u32).to_le_bytes());
            collected.samples.iter().for_each(|s| out.extend_from_slice(&s.to_le_bytes()));
            out.extend_from_slice(&(collected.events.len() as u32).to_le_bytes());
            for (ms, name) in &collected.events {
                out.extend_from_slice(&ms.to_le_bytes());
                out.push(name.len().min(255) as u8);
                out.extend_from_slice(&name.as_bytes()[..name.len().min(255)]);
            }
        }
        Err(SpeechError::Synthesis(code)) => {
            out.push(2);
            out.extend_from_slice(&code.to_le_bytes());
        }
        Err(_) => out.push(1),
    }
    out
}

fn decode_run(bytes: &[u8]) -> Option<Result<Collected, SpeechError>> {
    let mut at = 1;
    let mut take = |n: usize| -> Option<&[u8]> {
        let slice = bytes.get(at..at + n)?;
        at += n;
        Some(slice)
    };
    let u32_of = |b: &[u8]| u32::from_le_bytes([b[0], b[1], b[2], b[3]]);
    match bytes.first()? {
        1 => return Some(Err(SpeechError::Voice(String::new()))),
        2 => return Some(Err(SpeechError::Synthesis(u32_of(take(4)?) as i32))),
        _ => {}
    }
    let count = u32_of(take(4)?) as usize;
    let samples = take(count * 2)?.chunks_exact(2).map(|b| i16::from_le_bytes([b[0], b[1]])).collect();
    let events = (0..u32_of(take(4)?))
        .map(|_| {
            let ms = u32_of(take(4)?);
            let len = take(1)?[0] as usize;
            Some((ms, String::from_utf8_lossy(take(len)?).into_owned()))
        })
        .collect::<Option<Vec<_>>>()?;
    Some(Ok(Collected { samples, events }))
}

/// Runs `work` in a forked child and returns the bytes it produced. The child only calls
/// eSpeak (already loaded and initialised by the parent), allocates and writes to a pipe, then
/// leaves with `_exit`; glibc's `fork` keeps `malloc` usable in the child.
fn isolated(work: impl FnOnce() -> Vec<u8>) -> Result<Vec<u8>, SpeechError> {
    let fail = |what: &str| SpeechError::Isolation(format!("{what}: {}", std::io::Error::last_os_error()));
    let mut fds = [0 as c_int; 2];
    // SAFETY: plain POSIX calls on descriptors this function owns; the child never returns.
    unsafe {
        if libc::pipe(fds.as_mut_ptr()) != 0 {
            return Err(fail("pipe"));
        }
        let pid = libc::fork();
        if pid < 0 {
            libc::close(fds[0]);
            libc::close(fds[1]);
            return Err(fail("fork"));
        }
        if pid == 0 {
            libc::close(fds[0]);
            let bytes = std::panic::catch_unwind(std::panic::AssertUnwindSafe(work)).unwrap_or_default();
            let mut written = 0;
            while written < bytes.len() {
                let n = libc::write(fds[1], bytes[written..].as_ptr().cast(), bytes.len() - written);
                if n <= 0 {
                    libc::_exit(1);
                }
                written += n as usize;
            }
            libc::_exit(0);
        }
        libc::close(fds[1]);
        let mut out = Vec::new();
        let mut buffer = [0u8; 65536];
        loop {
            let n = libc::read(fds[0], buffer.as_mut_ptr().cast(), buffer.len());
            if n < 0 && std::io::Error::last_os_error().kind() == std::io::ErrorKind::Interrupted {
                continue;
            }
            if n <= 0 {
                break;
            }
            out.extend_from_slice(&buffer[..n as usize]);
        }
        libc::close(fds[0]);
        let mut status = 0;
        libc::waitpid(pid, &mut status, 0);
        if !(libc::WIFEXITED(status) && libc::WEXITSTATUS(status) == 0) {
            return Err(SpeechError::Isolation(format!("the synthesis process failed (status {status})")));
        }
        Ok(out)
    }
}

/// Phones from the events: each lasts until the next one starts; the last until the end.
fn utterance(collected: Collected, sample_rate: u32) -> Utterance {
    let Collected { samples, events } = collected;
    let total_s = samples.len() as f64 / sample_rate as f64;
    let mut phones: Vec<Phone> = Vec::with_capacity(events.len());
    for (i, (ms, symbol)) in events.iter().enumerate() {
        let start_s = (*ms as f64 / 1000.0).min(total_s);
        let end_s = events.get(i + 1).map_or(total_s, |(next, _)| (*next as f64 / 1000.0).min(total_s));
        if end_s > start_s {
            phones.push(Phone { symbol: symbol.clone(), start_s, end_s });
        }
    }
    Utterance { sample_rate, samples, phones }
}
