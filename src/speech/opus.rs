//! 48 kHz mono samples → Opus packets for the MP4's sound track: libopus, loaded at run time.
//!
//! In: 16-bit mono samples at 48 kHz (see [`super::audio::resample`]). Out: one Opus packet per
//! 20 ms (960 samples), the input padded with silence to whole packets plus the encoder's
//! look-ahead, so the decoded sound covers every input sample once the decoder drops the
//! pre-skip.
//!
//! Why Opus: every browser plays Opus in MP4, including Debian's Chromium, which lacks the
//! proprietary AAC decoder; `muxide` writes the `Opus`/`dOps` sample entry. Why libopus loaded at
//! run time: libopus0 is present wherever FFmpeg or Chromium is, the build stays free of a system
//! library, and a missing one is a [`SpeechError::Missing`] with the install command.
//!
//! Invariants: the encoder runs at a fixed bitrate (64 kbit/s VBR), complexity 10, signal
//! "voice", one encoder per track, so the same samples give the same packets with the same
//! libopus on the same CPU. The look-ahead must be 312 samples, the pre-skip `muxide` writes into
//! `dOps`; anything else is an error rather than a silently shifted sound track.

use std::ffi::{c_int, c_void};
use std::sync::OnceLock;

use super::SpeechError;

pub const LIBRARY: &str = "libopus.so.0";
pub const INSTALL: &str = "apt-get install libopus0";
/// Opus always decodes at 48 kHz.
pub const SAMPLE_RATE: u32 = 48_000;
/// Samples per packet (20 ms).
pub const PACKET_SAMPLES: usize = 960;
/// The decoder delay `muxide` writes as the `dOps` pre-skip.
pub const PRE_SKIP: usize = 312;

const APPLICATION_AUDIO: c_int = 2049;
const SET_BITRATE: c_int = 4002;
const SET_COMPLEXITY: c_int = 4010;
const SET_SIGNAL: c_int = 4024;
const GET_LOOKAHEAD: c_int = 4027;
const SIGNAL_VOICE: c_int = 3001;
const MAX_PACKET: usize = 4000;

struct Opus {
    _library: libloading::Library,
    create: unsafe extern "C" fn(i32, c_int, c_int, *mut c_int) -> *mut c_void,
    ctl: unsafe extern "C" fn(*mut c_void, c_int, ...) -> c_int,
    encode: unsafe extern "C" fn(*mut c_void, *const i16, c_int, *mut u8, i32) -> i32,
    destroy: unsafe extern "C" fn(*mut c_void),
}

static OPUS: OnceLock<Result<Opus, SpeechError>> = OnceLock::new();

fn load() -> Result<Opus, SpeechError> {
    let missing = |e: libloading::Error| SpeechError::Missing { tool: "libopus", library: LIBRARY.into(), install: INSTALL, detail: e.to_string() };
    // SAFETY: loading libopus runs no initialisers with preconditions; the symbols have the
    // signatures of opus.h.
    unsafe {
        let library = libloading::Library::new(LIBRARY).map_err(missing)?;
        let create = *library.get(b"opus_encoder_create\0").map_err(missing)?;
        let ctl = *library.get(b"opus_encoder_ctl\0").map_err(missing)?;
        let encode = *library.get(b"opus_encode\0").map_err(missing)?;
        let destroy = *library.get(b"opus_encoder_destroy\0").map_err(missing)?;
        Ok(Opus { _library: library, create, ctl, encode, destroy })
    }
}

/// Checks that libopus can be loaded.
pub fn check_available() -> Result<(), SpeechError> {
    OPUS.get_or_init(load).as_ref().map(|_| ()).map_err(Clone::clone)
}

/// Encodes 48 kHz mono `samples` into 20-ms Opus packets (see the module doc for the padding).
pub fn encode(samples: &[i16]) -> Result<Vec<Vec<u8>>, SpeechError> {
    let opus = OPUS.get_or_init(load).as_ref().map_err(Clone::clone)?;
    let fail = |what: &str, code: i32| SpeechError::Opus(format!("{what} failed ({code})"));
    let mut error: c_int = 0;
    // SAFETY: a fresh encoder, used by this call only and destroyed at its end.
    let encoder = unsafe { (opus.create)(SAMPLE_RATE as i32, 1, APPLICATION_AUDIO, &mut error) };
    if encoder.is_null() || error != 0 {
        return Err(fail("opus_encoder_create", error));
    }
    let result = (|| {
        let mut lookahead: c_int = 0;
        // SAFETY: the requests take an int (set) or an int pointer (get), as opus_defines.h says.
        unsafe {
            for (request, value) in [(SET_BITRATE, 64_000), (SET_COMPLEXITY, 10), (SET_SIGNAL, SIGNAL_VOICE)] {
                let code = (opus.ctl)(encoder, request, value as c_int);
                if code != 0 {
                    return Err(fail("opus_encoder_ctl", code));
                }
            }
            (opus.ctl)(encoder, GET_LOOKAHEAD, &mut lookahead as *mut c_int);
        }
        if lookahead as usize != PRE_SKIP {
            return Err(SpeechError::Opus(format!("the encoder's look-ahead is {lookahead} samples; the MP4 track says {PRE_SKIP}")));
        }
        let packets = (samples.len() + PRE_SKIP).div_ceil(PACKET_SAMPLES).max(1);
        let mut padded = samples.to_vec();
        padded.resize(packets * PACKET_SAMPLES, 0);
        let mut out = Vec::with_capacity(packets);
        let mut buffer = vec![0u8; MAX_PACKET];
        for chunk in padded.chunks_exact(PACKET_SAMPLES) {
            // SAFETY: `chunk` holds one packet of samples; `buffer` has MAX_PACKET bytes.
            let n = unsafe { (opus.encode)(encoder, chunk.as_ptr(), PACKET_SAMPLES as c_int, buffer.as_mut_ptr(), MAX_PACKET as i32) };
            if n <= 0 {
                return Err(fail("opus_encode", n));
            }
            out.push(buffer[..n as usize].to_vec());
        }
        Ok(out)
    })();
    // SAFETY: created above, not used after this.
    unsafe { (opus.destroy)(encoder) };
    result
}
