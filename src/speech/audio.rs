//! Sample arithmetic for the sound track: resampling, padding, WAV bytes and loudness.
//!
//! In: 16-bit mono samples. Out: the same sound at another rate ([`resample`], a windowed-sinc
//! interpolator), as a WAV file ([`wav_bytes`]), or as a loudness envelope per video frame
//! ([`rms_per_frame`]). No I/O; integer output of deterministic f64 arithmetic.

/// Half the number of taps of the interpolation kernel.
const HALF_TAPS: i64 = 16;

fn gcd(a: u64, b: u64) -> u64 {
    if b == 0 { a } else { gcd(b, a % b) }
}

/// Windowed sinc (Blackman window) at offset `x` input samples, low-passed at `cutoff` of the
/// input's Nyquist frequency.
fn kernel(x: f64, cutoff: f64) -> f64 {
    let half = HALF_TAPS as f64;
    if x.abs() >= half {
        return 0.0;
    }
    let pi = std::f64::consts::PI;
    let sinc = if x == 0.0 { 1.0 } else { (pi * cutoff * x).sin() / (pi * cutoff * x) };
    let w = (x + half) / (2.0 * half);
    let blackman = 0.42 - 0.5 * (2.0 * pi * w).cos() + 0.08 * (4.0 * pi * w).cos();
    cutoff * sinc * blackman
}

/// `samples` at rate `from` resampled to rate `to` (band-limited at 95 % of the lower Nyquist
/// frequency). The output has `round(len × to / from)` samples. The kernel is tabulated per output
/// phase (`to / gcd(from, to)` phases), so the cost is `2 × 16` multiplications per sample.
pub fn resample(samples: &[i16], from: u32, to: u32) -> Vec<i16> {
    if from == to || samples.is_empty() {
        return samples.to_vec();
    }
    let (from, to) = (u64::from(from), u64::from(to));
    let g = gcd(from, to);
    let (step, phases) = (from / g, to / g);
    let cutoff = 0.95 * (to as f64 / from as f64).min(1.0);
    let table: Vec<Vec<f64>> = (0..phases)
        .map(|p| {
            let frac = p as f64 / phases as f64;
            (-HALF_TAPS + 1..=HALF_TAPS).map(|k| kernel(frac - k as f64, cutoff)).collect()
        })
        .collect();
    let out_len = (samples.len() as u64 * to + from / 2) / from;
    (0..out_len)
        .map(|n| {
            let position = n * step;
            let (base, phase) = ((position / phases) as i64, (position % phases) as usize);
            let sum: f64 = table[phase]
                .iter()
                .zip(-HALF_TAPS + 1..=HALF_TAPS)
                .filter_map(|(w, k)| samples.get(usize::try_from(base + k).ok()?).map(|&s| w * f64::from(s)))
                .sum();
            sum.round().clamp(-32768.0, 32767.0) as i16
        })
        .collect()
}

/// A canonical 44-byte-header PCM WAV file of 16-bit mono `samples` at `rate`.
pub fn wav_bytes(samples: &[i16], rate: u32) -> Vec<u8> {
    let data_len = (samples.len() * 2) as u32;
    let mut out = Vec::with_capacity(44 + samples.len() * 2);
    out.extend_from_slice(b"RIFF");
    out.extend_from_slice(&(36 + data_len).to_le_bytes());
    out.extend_from_slice(b"WAVEfmt ");
    out.extend_from_slice(&16u32.to_le_bytes());
    out.extend_from_slice(&1u16.to_le_bytes()); // PCM
    out.extend_from_slice(&1u16.to_le_bytes()); // mono
    out.extend_from_slice(&rate.to_le_bytes());
    out.extend_from_slice(&(rate * 2).to_le_bytes());
    out.extend_from_slice(&2u16.to_le_bytes());
    out.extend_from_slice(&16u16.to_le_bytes());
    out.extend_from_slice(b"data");
    out.extend_from_slice(&data_len.to_le_bytes());
    for s in samples {
        out.extend_from_slice(&s.to_le_bytes());
    }
    out
}

/// Root-mean-square loudness (full scale = 1) over the `1 / fps` window centred on each frame's
/// time (the instant the frame shows), for `frames` frames (0 past the end of the sound).
pub fn rms_per_frame(samples: &[i16], rate: u32, fps: u32, frames: usize) -> Vec<f64> {
    (0..frames)
        .map(|f| {
            let (rate, fps) = (u64::from(rate), u64::from(fps));
            let start = ((2 * f as u64 * rate).saturating_sub(rate) / (2 * fps)) as usize;
            let end = ((2 * f as u64 * rate + rate) / (2 * fps)) as usize;
            let window = samples.get(start.min(samples.len())..end.min(samples.len())).unwrap_or_default();
            if window.is_empty() {
                return 0.0;
            }
            let power: f64 = window.iter().map(|&s| (f64::from(s) / 32768.0).powi(2)).sum();
            (power / window.len() as f64).sqrt()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resampling_keeps_a_tone_and_the_length() {
        let rate = 22_050;
        let tone: Vec<i16> = (0..rate).map(|i| (10_000.0 * (2.0 * std::f64::consts::PI * 440.0 * i as f64 / rate as f64).sin()) as i16).collect();
        let up = resample(&tone, rate, 48_000);
        assert_eq!(up.len(), 48_000);
        // Away from the edges the resampled tone is the same sine at the new rate.
        let worst = (1000..47_000)
            .map(|i| (f64::from(up[i]) - 10_000.0 * (2.0 * std::f64::consts::PI * 440.0 * i as f64 / 48_000.0).sin()).abs())
            .fold(0.0, f64::max);
        assert!(worst < 60.0, "largest error {worst} of 10000");
    }

    #[test]
    fn wav_header_says_what_follows() {
        let bytes = wav_bytes(&[1, -1, 300], 22_050);
        assert_eq!(bytes.len(), 44 + 6);
        assert_eq!(&bytes[0..4], b"RIFF");
        assert_eq!(u32::from_le_bytes(bytes[24..28].try_into().unwrap()), 22_050);
        assert_eq!(u32::from_le_bytes(bytes[40..44].try_into().unwrap()), 6);
    }
}
