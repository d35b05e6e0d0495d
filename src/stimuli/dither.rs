//! The secret dither key of a stimulus set, and the dither it draws on the pictures participants see.
//!
//! In: a key (32 bytes from the operating system's randomness, kept as `dither.key` in the set
//! directory: 64 hex digits and a newline, mode 0600 on unix) and a picture with its stimulus id and
//! frame index. Out: the picture with each colour channel moved by −1, 0 or +1 (clamped to 0–255),
//! so the media of a set no longer equal, byte for byte, what anyone renders with `facslab render`
//! from the same expression, while no pixel changes by more than 1/255.
//!
//! The offsets come from a keyed stream: SHA-256 over a fixed label, the key, the stimulus id and
//! the frame index gives a seed; SHA-256 over the seed and a block counter gives 32 bytes, 2 bits per
//! offset (`00` → −1, `01` and `11` → 0, `10` → +1), the channels taken in the picture's byte order.
//! Grey pictures get one offset per pixel on all three channels, so they stay grey; a transparent
//! still's alpha is never changed, nor a fully transparent pixel.
//!
//! Invariants: the same key, id, frame and picture give the same bytes on any thread; the key itself
//! is written only to a key file and never printed: `Debug` and every message show at most its
//! fingerprint (SHA-256 over a fixed label and the key), which says nothing about the key.

use std::io::Read;
use std::path::{Path, PathBuf};

use sha2::{Digest, Sha256};

use crate::engine::image::{Frame, RgbImage};

/// The name of the key file in a set directory.
pub const KEY_FILE: &str = "dither.key";

/// Key length in bytes.
const KEY_BYTES: usize = 32;

/// The most bytes read from a key file (a key file is 65).
const MAX_KEY_FILE_BYTES: u64 = 1024;

/// Why a dither key could not be read, made or written.
#[derive(Debug, thiserror::Error)]
pub enum DitherKeyError {
    #[error("{}: {source}", path.display())]
    Io { path: PathBuf, source: std::io::Error },
    #[error("{}: not a dither key: {reason} (a key file holds 64 hex digits, as `facslab stimuli key` writes)", path.display())]
    Invalid { path: PathBuf, reason: String },
    #[error("{}: the file exists already; a new key is never written over another", .0.display())]
    Exists(PathBuf),
    #[error("could not draw a dither key from the operating system's randomness: {0}")]
    Random(String),
}

/// A set's secret dither key.
#[derive(Clone, PartialEq, Eq)]
pub struct DitherKey([u8; KEY_BYTES]);

impl std::fmt::Debug for DitherKey {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "DitherKey(fingerprint {})", self.fingerprint())
    }
}

impl DitherKey {
    /// A new key from the operating system's randomness.
    pub fn generate() -> Result<DitherKey, DitherKeyError> {
        let mut bytes = [0u8; KEY_BYTES];
        getrandom::fill(&mut bytes).map_err(|e| DitherKeyError::Random(e.to_string()))?;
        Ok(DitherKey(bytes))
    }

    /// The key in a key file's text (`path` names the file in errors; the text is never quoted).
    pub fn parse(text: &str, path: &Path) -> Result<DitherKey, DitherKeyError> {
        let invalid = |reason: String| DitherKeyError::Invalid { path: path.to_path_buf(), reason };
        let digits = text.trim();
        if let Some(at) = digits.chars().position(|c| !c.is_ascii_hexdigit()) {
            return Err(invalid(format!("character {} is not a hex digit", at + 1)));
        }
        if digits.len() != 2 * KEY_BYTES {
            return Err(invalid(format!("it has {} hex digits, a key has {}", digits.len(), 2 * KEY_BYTES)));
        }
        let mut bytes = [0u8; KEY_BYTES];
        hex::decode_to_slice(digits, &mut bytes).map_err(|e| invalid(e.to_string()))?;
        Ok(DitherKey(bytes))
    }

    /// Reads a key file.
    pub fn read(path: &Path) -> Result<DitherKey, DitherKeyError> {
        let io = |source| DitherKeyError::Io { path: path.to_path_buf(), source };
        let mut bytes = Vec::new();
        std::fs::File::open(path).and_then(|file| file.take(MAX_KEY_FILE_BYTES + 1).read_to_end(&mut bytes)).map_err(io)?;
        if bytes.len() as u64 > MAX_KEY_FILE_BYTES {
            return Err(DitherKeyError::Invalid { path: path.to_path_buf(), reason: format!("it is longer than {MAX_KEY_FILE_BYTES} bytes") });
        }
        let text = String::from_utf8(bytes).map_err(|_| DitherKeyError::Invalid { path: path.to_path_buf(), reason: "it is not text".into() })?;
        DitherKey::parse(&text, path)
    }

    /// Writes the key file (through a temporary file renamed into place; mode 0600 on unix).
    pub fn write(&self, path: &Path) -> Result<(), DitherKeyError> {
        let partial = path.with_file_name(format!(".{KEY_FILE}.partial"));
        let io = |path: &Path, source| DitherKeyError::Io { path: path.to_path_buf(), source };
        let _ = std::fs::remove_file(&partial);
        let mut options = std::fs::OpenOptions::new();
        options.write(true).create_new(true);
        #[cfg(unix)]
        std::os::unix::fs::OpenOptionsExt::mode(&mut options, 0o600);
        let written = options.open(&partial).and_then(|mut file| {
            std::io::Write::write_all(&mut file, format!("{}\n", hex::encode(self.0)).as_bytes())?;
            file.sync_all()
        });
        written.map_err(|e| io(&partial, e))?;
        std::fs::rename(&partial, path).map_err(|e| io(path, e))
    }

    /// Writes a new key to `path`, which must not exist yet.
    pub fn create_file(path: &Path) -> Result<DitherKey, DitherKeyError> {
        if path.exists() {
            return Err(DitherKeyError::Exists(path.to_path_buf()));
        }
        let key = DitherKey::generate()?;
        key.write(path)?;
        Ok(key)
    }

    /// The key of the set in `dir`: its `dither.key`, made now when there is none.
    pub fn of_set(dir: &Path) -> Result<DitherKey, DitherKeyError> {
        let path = dir.join(KEY_FILE);
        if path.exists() { DitherKey::read(&path) } else { DitherKey::create_file(&path) }
    }

    /// Keeps this key as the key of the set in `dir` (written unless `dither.key` already holds it).
    pub fn keep_in_set(&self, dir: &Path) -> Result<(), DitherKeyError> {
        let path = dir.join(KEY_FILE);
        match DitherKey::read(&path) {
            Ok(kept) if kept == *self => Ok(()),
            _ => self.write(&path),
        }
    }

    /// 16 hex digits of SHA-256 over a fixed label and the key: tells keys apart, reveals nothing.
    pub fn fingerprint(&self) -> String {
        let mut hash = Sha256::new();
        hash.update(b"facslab dither key fingerprint v1\0");
        hash.update(self.0);
        hex::encode(&hash.finalize()[..8])
    }

    /// The offsets of one picture, in channel order (endless; a picture takes what it needs).
    fn offsets(&self, stimulus_id: &str, frame: usize) -> Offsets {
        let mut hash = Sha256::new();
        hash.update(b"facslab dither v1\0");
        hash.update(self.0);
        hash.update((stimulus_id.len() as u64).to_le_bytes());
        hash.update(stimulus_id.as_bytes());
        hash.update((frame as u64).to_le_bytes());
        Offsets { seed: hash.finalize().into(), block: 0, bits: [0; 32], used: OFFSETS_PER_BLOCK }
    }
}

/// Offsets drawn from one 32-byte block.
const OFFSETS_PER_BLOCK: usize = 32 * 4;

/// A picture's stream of offsets.
struct Offsets {
    seed: [u8; 32],
    block: u64,
    bits: [u8; 32],
    used: usize,
}

impl Iterator for Offsets {
    type Item = i16;

    fn next(&mut self) -> Option<i16> {
        if self.used == OFFSETS_PER_BLOCK {
            let mut hash = Sha256::new();
            hash.update(self.seed);
            hash.update(self.block.to_le_bytes());
            self.bits = hash.finalize().into();
            self.block += 1;
            self.used = 0;
        }
        let two_bits = (self.bits[self.used / 4] >> (2 * (self.used % 4))) & 0b11;
        self.used += 1;
        Some(match two_bits {
            0b00 => -1,
            0b10 => 1,
            _ => 0,
        })
    }
}

/// The dither of one stimulus: its set's key, its id, and whether its pictures are grey.
#[derive(Debug, Clone, Copy)]
pub struct Dither<'a> {
    pub key: &'a DitherKey,
    pub stimulus_id: &'a str,
    /// One offset per pixel on all three channels (for a set with the grayscale look).
    pub grey: bool,
}

impl Dither<'_> {
    /// Frame `frame` of the stimulus, dithered.
    pub fn rgb(&self, image: &RgbImage, frame: usize) -> RgbImage {
        let mut image = image.clone();
        self.apply(&mut image.data, 3, frame);
        image
    }

    /// A still (colour, or colour with alpha), dithered; alpha is left as it is.
    pub fn frame(&self, mut still: Frame, frame: usize) -> Frame {
        match &mut still {
            Frame::Rgb(image) => self.apply(&mut image.data, 3, frame),
            Frame::Rgba(image) => self.apply(&mut image.data, 4, frame),
        }
        still
    }

    /// Dithers pixels of `stride` bytes (RGB, or RGBA with alpha last).
    fn apply(&self, data: &mut [u8], stride: usize, frame: usize) {
        let mut offsets = self.key.offsets(self.stimulus_id, frame);
        let nudge = |value: &mut u8, offset: i16| *value = (i16::from(*value) + offset).clamp(0, 255) as u8;
        for pixel in data.chunks_exact_mut(stride) {
            let transparent = stride == 4 && pixel[3] == 0;
            let colour = &mut pixel[..3];
            if self.grey {
                let offset = offsets.next().unwrap_or(0);
                colour.iter_mut().filter(|_| !transparent).for_each(|v| nudge(v, offset));
            } else {
                for value in colour {
                    let offset = offsets.next().unwrap_or(0);
                    if !transparent {
                        nudge(value, offset);
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::engine::image::RgbaImage;

    fn key(byte: u8) -> DitherKey {
        DitherKey([byte; KEY_BYTES])
    }

    fn grey_ramp() -> RgbImage {
        let mut image = RgbImage::new(64, 8);
        for (i, v) in image.data.iter_mut().enumerate() {
            *v = ((i / 3) % 256) as u8;
        }
        image
    }

    #[test]
    fn key_files_round_trip_and_bad_ones_name_the_file_without_quoting_it() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("set.key");
        let made = DitherKey::create_file(&path).unwrap();
        assert_eq!(DitherKey::read(&path).unwrap(), made);
        assert_eq!(std::fs::read_to_string(&path).unwrap().len(), 65);
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            assert_eq!(std::fs::metadata(&path).unwrap().permissions().mode() & 0o777, 0o600);
        }
        assert!(matches!(DitherKey::create_file(&path), Err(DitherKeyError::Exists(_))), "never written over");
        let secretish = "ab".repeat(31) + "zz";
        for (text, reason) in [
            (secretish.as_str(), "character 63 is not a hex digit"),
            ("abcd\n", "it has 4 hex digits, a key has 64"),
            (&*"0".repeat(66), "it has 66 hex digits"),
            ("", "it has 0 hex digits"),
        ] {
            let err = DitherKey::parse(text, Path::new("keys/k.key")).unwrap_err().to_string();
            assert!(err.starts_with("keys/k.key: not a dither key: ") && err.contains(reason), "{err}");
            assert!(!err.contains("abab"), "the key file's text is not quoted: {err}");
        }
        std::fs::write(dir.path().join("binary.key"), [0xff, 0xfe]).unwrap();
        assert!(DitherKey::read(&dir.path().join("binary.key")).unwrap_err().to_string().contains("binary.key: not a dither key: it is not text"));
        let missing = DitherKey::read(&dir.path().join("none.key")).unwrap_err().to_string();
        assert!(missing.contains("none.key"), "{missing}");
        assert_eq!(DitherKey::parse(&format!("  {}\r\n", "AB".repeat(32)), Path::new("k")).unwrap(), key(0xab));
    }

    #[test]
    fn a_set_keeps_its_key_and_debug_shows_only_the_fingerprint() {
        let dir = tempfile::tempdir().unwrap();
        let first = DitherKey::of_set(dir.path()).unwrap();
        assert_eq!(DitherKey::of_set(dir.path()).unwrap(), first, "reused when present");
        key(3).keep_in_set(dir.path()).unwrap();
        assert_eq!(DitherKey::of_set(dir.path()).unwrap(), key(3));
        let shown = format!("{:?}", key(0xab));
        assert!(!shown.contains("abab") && shown.contains(&key(0xab).fingerprint()), "{shown}");
        assert_ne!(key(1).fingerprint(), key(2).fingerprint());
        assert_eq!(key(1).fingerprint().len(), 16);
    }

    #[test]
    fn the_dither_is_at_most_one_level_deterministic_and_keyed() {
        let image = grey_ramp();
        let colour = Dither { key: &key(1), stimulus_id: "0123456789abcdef", grey: false };
        let a = colour.rgb(&image, 0);
        assert_eq!(a, colour.rgb(&image, 0));
        assert!(a.data.iter().zip(&image.data).all(|(x, y)| x.abs_diff(*y) <= 1));
        let changed = a.data.iter().zip(&image.data).filter(|(x, y)| x != y).count();
        assert!(changed > image.data.len() / 3 && changed < image.data.len() * 2 / 3, "{changed} of {}", image.data.len());
        assert_ne!(a, Dither { key: &key(2), ..colour }.rgb(&image, 0), "another key");
        assert_ne!(a, colour.rgb(&image, 1), "another frame");
        assert_ne!(a, Dither { stimulus_id: "0123456789abcdee", ..colour }.rgb(&image, 0), "another stimulus");
        let grey = Dither { grey: true, ..colour }.rgb(&image, 0);
        assert!(grey.data.chunks(3).all(|p| p[0] == p[1] && p[1] == p[2]), "grey stays grey");
        assert_ne!(grey, image);
        let white = RgbImage { data: vec![255; 48], ..RgbImage::new(4, 4) };
        assert!(colour.rgb(&white, 0).data.iter().all(|&v| v >= 254), "clamped");
    }

    #[test]
    fn alpha_and_fully_transparent_pixels_are_left_alone() {
        let data: Vec<u8> = (0..256u32).flat_map(|i| [100, 150, 200, [0, 128, 255][(i % 3) as usize]]).collect();
        let still = Frame::Rgba(RgbaImage { width: 16, height: 16, data: data.clone() });
        let Frame::Rgba(out) = Dither { key: &key(9), stimulus_id: "x", grey: false }.frame(still, 0) else { panic!("stays RGBA") };
        for (new, old) in out.data.chunks(4).zip(data.chunks(4)) {
            assert_eq!(new[3], old[3]);
            if old[3] == 0 {
                assert_eq!(new, old);
            }
        }
        assert_ne!(out.data, data);
    }
}
