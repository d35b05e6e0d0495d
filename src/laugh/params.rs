//! Facial parameters and rig controllers (seed 004, Tables 1-2 and Eq. 1), and the declared
//! mapping from controllers to facslab's AU tracks.
//!
//! In: a [`LandmarkTrack`]. Out, per frame: the fifteen facial parameters FP1-FP15
//! ([`FACIAL_PARAMETERS`]), each a distance between landmarks divided by that frame's
//! inter-ocular distance (outer eye corners, iBUG 36-45), so the head's distance from the camera
//! cancels; the seventeen controllers C1-C17 ([`CONTROLLERS`]) by Eq. 1; and AU intensities
//! ([`AU_MAPPING`]) as a [`Curves`].
//!
//! Eq. 1 (the seed prints it as an image; this is the reading used, see docs/laugh-curves.md):
//! `C(i) = clamp((FP(i) - FP₀) / (ε · FP₀), -1, 1)`, FP₀ the neutral value, ε ∈ [0.1, 0.3] the
//! animator's hardness: ε = 0.1 saturates a controller at a 10 % change of its parameter, 0.3 at
//! 30 %. A controller on two parameters (upsetSad, shocked) takes their mean.
//!
//! Sides: the seed's "right" is the image's right, the person's left (FP1 is iBUG 46-47, the
//! person's left lower lid). facslab's L/R are the person's own sides, so the seed's
//! right-hand controllers drive facslab's L tracks.
//!
//! Invariants: every AU value written is in [0, 1]; each AU channel (AU and side) appears once.

use crate::facs::{AuCode, Laterality};
use crate::laugh::curves::{CurveTrack, Curves, FORMAT};
use crate::laugh::landmarks::{point_of, FramePoints, LandmarkTrack};

/// How a facial parameter is measured, on iBUG point numbers.
#[derive(Debug, Clone, Copy)]
pub enum Measure {
    /// Distance between two points.
    Points(usize, usize),
    /// Distance between the midpoints of two pairs of points.
    Midpoints([usize; 2], [usize; 2]),
}

/// One row of the seed's Table 1 with its landmarks from Table 2.
#[derive(Debug, Clone, Copy)]
pub struct FacialParameter {
    pub id: &'static str,
    pub action: &'static str,
    pub measure: Measure,
}

const fn fp(id: &'static str, action: &'static str, measure: Measure) -> FacialParameter {
    FacialParameter { id, action, measure }
}

/// Table 1 and the landmark columns of Table 2. Where the seed's pair cannot measure what its
/// Action says (FP1/FP3 lower lid, FP5/FP6 eye opening, FP11), the measure follows the Action;
/// docs/laugh-curves.md lists each deviation.
pub const FACIAL_PARAMETERS: [FacialParameter; 15] = [
    fp("FP1", "half opening of lower lid (seed's right)", Measure::Midpoints([46, 47], [42, 45])),
    fp("FP2", "inner distance between eyebrow and eyelid (seed's right)", Measure::Points(22, 27)),
    fp("FP3", "half opening of lower lid (seed's left)", Measure::Midpoints([40, 41], [36, 39])),
    fp("FP4", "inner distance between eyebrow and eyelid (seed's left)", Measure::Points(21, 27)),
    fp("FP5", "eye opening (seed's right)", Measure::Midpoints([43, 44], [46, 47])),
    fp("FP6", "eye opening (seed's left)", Measure::Midpoints([37, 38], [40, 41])),
    fp("FP7", "width of mouth", Measure::Points(48, 54)),
    fp("FP8", "mouth corner to nose (seed's right)", Measure::Points(33, 54)),
    fp("FP9", "mouth corner to nose (seed's left)", Measure::Points(33, 48)),
    fp("FP10", "height of mouth", Measure::Points(51, 57)),
    fp("FP11", "vertical between mouth and nose", Measure::Points(33, 51)),
    fp("FP12", "mouth corner to nose wing (seed's right)", Measure::Points(35, 54)),
    fp("FP13", "mouth corner to nose wing (seed's left)", Measure::Points(31, 48)),
    fp("FP14", "vertical between chin and nose", Measure::Points(8, 33)),
    fp("FP15", "width of the face oval", Measure::Points(0, 16)),
];

/// One rig controller of Table 2: its name and the parameters (0-based FP indices) it follows.
#[derive(Debug, Clone, Copy)]
pub struct Controller {
    pub id: &'static str,
    pub name: &'static str,
    pub params: &'static [usize],
}

const fn c(id: &'static str, name: &'static str, params: &'static [usize]) -> Controller {
    Controller { id, name, params }
}

/// C1-C17. Table 2 names sixteen controllers and drives `jaw` from two parameters (FP10 and
/// FP14); they are kept apart as C12 `jaw` (lips, FP10) and C16 `jawDrop` (chin, FP14), which
/// makes seventeen, as the seed counts.
pub const CONTROLLERS: [Controller; 17] = [
    c("C1", "rightTwitch", &[0]),
    c("C2", "upsetSad", &[1, 3]),
    c("C3", "shocked", &[1, 3]),
    c("C4", "rightBrowRaise", &[1]),
    c("C5", "leftTwitch", &[2]),
    c("C6", "leftBrowRaise", &[3]),
    c("C7", "rightBlink", &[4]),
    c("C8", "leftBlink", &[5]),
    c("C9", "smileFrown", &[6]),
    c("C10", "rightSmileFrown", &[7]),
    c("C11", "leftSmileFrown", &[8]),
    c("C12", "jaw", &[9]),
    c("C13", "sneer", &[10]),
    c("C14", "rightSneer", &[11]),
    c("C15", "leftSneer", &[12]),
    c("C16", "jawDrop", &[13]),
    c("C17", "neck", &[14]),
];

/// Which way of a controller drives an AU: its growth (+) or its shrinking (−).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Polarity {
    Grows,
    Shrinks,
}

/// One row of the mapping: controller (0-based) in one polarity → AU on a side.
#[derive(Debug, Clone, Copy)]
pub struct MapRow {
    pub controller: usize,
    pub polarity: Polarity,
    pub au: u16,
    pub side: Laterality,
}

const fn m(controller: usize, polarity: Polarity, au: u16, side: Laterality) -> MapRow {
    MapRow { controller, polarity, au, side }
}

use Laterality::{Both, Left, Right};
use Polarity::{Grows, Shrinks};

/// Controllers → AU channels. A channel fed by several rows takes their mean. The reasoning per
/// row is in docs/laugh-curves.md ("Controllers and the mapping to AUs"). Not mapped, but in
/// Table 3: C10/C11 (mouth corner to nose) and C14/C15 (corner to nose wing), because on
/// facslab's faces the corner travels outward more than up in a smile (FP8 grows from 0.359 to
/// 0.380 at AU12 E on wm1, MediaPipe), so they cannot tell a smile from a frown; C17 `neck`
/// (face width), which shrinks for a turn either way and so does not give its direction.
pub const AU_MAPPING: [MapRow; 12] = [
    m(0, Shrinks, 6, Left),   // lower lid pushed up by the cheek
    m(4, Shrinks, 6, Right),
    m(1, Shrinks, 4, Both),   // inner brows down
    m(2, Grows, 2, Both),     // brows up (shocked)
    m(3, Grows, 1, Left),     // inner brow up
    m(5, Grows, 1, Right),
    m(6, Shrinks, 43, Left),  // eye closes
    m(7, Shrinks, 43, Right),
    m(8, Grows, 12, Both),    // mouth widens in a smile
    m(11, Grows, 25, Both),   // lips part
    m(12, Shrinks, 10, Both), // upper lip rises to the nose
    m(15, Grows, 26, Both),   // chin drops
];

/// ε of Eq. 1, only in [0.1, 0.3].
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Epsilon(f64);

/// A refused parameter of the pipeline.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ParamsError {
    #[error("epsilon must be in [0.1, 0.3] (the seed's range), not {0}")]
    Epsilon(f64),
    #[error("{file}: frame {frame}: the outer eye corners coincide, so nothing can be normalised")]
    NoEyeDistance { file: String, frame: usize },
    #[error("{file}: the neutral value of {fp} is 0, so Eq. 1 cannot divide by it")]
    ZeroNeutral { file: String, fp: &'static str },
}

impl Epsilon {
    pub fn new(value: f64) -> Result<Epsilon, ParamsError> {
        if (0.1..=0.3).contains(&value) {
            Ok(Epsilon(value))
        } else {
            Err(ParamsError::Epsilon(value))
        }
    }

    pub fn value(self) -> f64 {
        self.0
    }
}

fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

fn mid(points: &FramePoints, pair: [usize; 2]) -> [f64; 2] {
    let (a, b) = (point_of(points, pair[0]), point_of(points, pair[1]));
    [(a[0] + b[0]) / 2.0, (a[1] + b[1]) / 2.0]
}

/// FP1-FP15 of one frame, in inter-ocular distances (None when the eye corners coincide).
pub fn facial_parameters(points: &FramePoints) -> Option<[f64; 15]> {
    let iod = dist(point_of(points, 36), point_of(points, 45));
    // Also refuses NaN.
    if iod.is_nan() || iod <= 0.0 {
        return None;
    }
    Some(FACIAL_PARAMETERS.map(|p| {
        let d = match p.measure {
            Measure::Points(a, b) => dist(point_of(points, a), point_of(points, b)),
            Measure::Midpoints(a, b) => dist(mid(points, a), mid(points, b)),
        };
        d / iod
    }))
}

/// FP1-FP15 of every frame of a track.
pub fn track_parameters(track: &LandmarkTrack) -> Result<Vec<[f64; 15]>, ParamsError> {
    track
        .frames
        .iter()
        .enumerate()
        .map(|(frame, points)| facial_parameters(points).ok_or_else(|| ParamsError::NoEyeDistance { file: track.file.clone(), frame }))
        .collect()
}

/// The neutral FP₀: the mean of the first `frames` frames of `params` (all of them when there
/// are fewer; `params` must not be empty).
pub fn neutral_of(params: &[[f64; 15]], frames: usize) -> [f64; 15] {
    let used = &params[..frames.clamp(1, params.len())];
    std::array::from_fn(|k| used.iter().map(|p| p[k]).sum::<f64>() / used.len() as f64)
}

/// C1-C17 of every frame by Eq. 1 (see the module doc); `file` names the track in errors.
pub fn controllers(file: &str, params: &[[f64; 15]], neutral: &[f64; 15], epsilon: Epsilon) -> Result<Vec<[f64; 17]>, ParamsError> {
    if let Some(k) = neutral.iter().position(|&v| v == 0.0 || v.is_nan()) {
        return Err(ParamsError::ZeroNeutral { file: file.into(), fp: FACIAL_PARAMETERS[k].id });
    }
    let eps = epsilon.value();
    Ok(params
        .iter()
        .map(|fp| {
            CONTROLLERS.map(|c| {
                let n = c.params.len() as f64;
                let value: f64 = c.params.iter().map(|&k| (fp[k] - neutral[k]) / (eps * neutral[k])).sum::<f64>() / n;
                value.clamp(-1.0, 1.0)
            })
        })
        .collect())
}

/// AU channels of the mapping, in first-appearance order, each with its rows.
fn channels() -> Vec<((u16, Laterality), Vec<MapRow>)> {
    let mut out: Vec<((u16, Laterality), Vec<MapRow>)> = Vec::new();
    for row in AU_MAPPING {
        match out.iter_mut().find(|(key, _)| *key == (row.au, row.side)) {
            Some((_, rows)) => rows.push(row),
            None => out.push(((row.au, row.side), vec![row])),
        }
    }
    out
}

/// The AU curves of per-frame controllers (see [`AU_MAPPING`]) for `laugh_type` at `fps`.
pub fn to_curves(controllers: &[[f64; 17]], laugh_type: &str, fps: u32, source: &str) -> Curves {
    let tracks = channels()
        .into_iter()
        .map(|((au, side), rows)| {
            let values = controllers
                .iter()
                .map(|c| {
                    let sum: f64 = rows.iter().map(|r| match r.polarity {
                        Polarity::Grows => c[r.controller].max(0.0),
                        Polarity::Shrinks => (-c[r.controller]).max(0.0),
                    }).sum();
                    (sum / rows.len() as f64).clamp(0.0, 1.0)
                })
                .collect();
            CurveTrack { au: AuCode(au), side, values }
        })
        .collect();
    Curves { format: FORMAT.into(), laugh_type: laugh_type.into(), fps, source: source.into(), tracks, fit: None, shoulders: Vec::new() }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::facs::Catalog;
    use crate::laugh::landmarks::NEEDED;

    /// A plausible frontal face (iBUG numbering), inter-ocular distance 100.
    pub(crate) fn face() -> FramePoints {
        let at = |n: usize| -> [f64; 2] {
            match n {
                0 => [-75.0, 0.0], 8 => [0.0, 150.0], 16 => [75.0, 0.0],
                21 => [-12.0, -30.0], 22 => [12.0, -30.0], 27 => [0.0, -5.0],
                31 => [-15.0, 55.0], 33 => [0.0, 60.0], 35 => [15.0, 55.0],
                36 => [-50.0, 0.0], 37 => [-40.0, -6.0], 38 => [-30.0, -6.0], 39 => [-20.0, 0.0], 40 => [-30.0, 5.0], 41 => [-40.0, 5.0],
                42 => [20.0, 0.0], 43 => [30.0, -6.0], 44 => [40.0, -6.0], 45 => [50.0, 0.0], 46 => [40.0, 5.0], 47 => [30.0, 5.0],
                48 => [-25.0, 90.0], 51 => [0.0, 82.0], 54 => [25.0, 90.0], 57 => [0.0, 100.0],
                _ => unreachable!(),
            }
        };
        std::array::from_fn(|k| at(NEEDED[k]))
    }

    #[test]
    fn parameters_are_in_inter_ocular_distances_and_scale_free() {
        let fp = facial_parameters(&face()).unwrap();
        assert!((fp[6] - 0.5).abs() < 1e-12, "mouth width 50 of 100: {}", fp[6]);
        assert!((fp[14] - 1.5).abs() < 1e-12, "face width 150 of 100: {}", fp[14]);
        assert!((fp[4] - 0.11).abs() < 1e-12, "eye opening 11 of 100: {}", fp[4]);
        let doubled = face().map(|[x, y]| [2.0 * x + 7.0, 2.0 * y - 3.0]);
        let fp2 = facial_parameters(&doubled).unwrap();
        fp.iter().zip(fp2).for_each(|(a, b)| assert!((a - b).abs() < 1e-12));
        assert!(facial_parameters(&face().map(|_| [1.0, 1.0])).is_none());
    }

    #[test]
    fn epsilon_outside_the_seeds_range_is_refused() {
        assert!(Epsilon::new(0.1).is_ok() && Epsilon::new(0.3).is_ok());
        assert_eq!(Epsilon::new(0.35).unwrap_err().to_string(), "epsilon must be in [0.1, 0.3] (the seed's range), not 0.35");
        assert!(Epsilon::new(0.05).is_err() && Epsilon::new(f64::NAN).is_err());
    }

    #[test]
    fn eq1_scales_the_change_from_neutral_by_epsilon() {
        let neutral = facial_parameters(&face()).unwrap();
        let mut wide = face();
        wide[NEEDED.iter().position(|&n| n == 54).unwrap()][0] += 2.5; // mouth 5 % wider
        let fp = facial_parameters(&wide).unwrap();
        let at = |eps| controllers("t", &[fp], &neutral, Epsilon::new(eps).unwrap()).unwrap()[0][8];
        assert!((at(0.1) - 0.5).abs() < 1e-9, "5 % / 0.1 = 0.5: {}", at(0.1));
        assert!((at(0.25) - 0.2).abs() < 1e-9, "5 % / 0.25 = 0.2: {}", at(0.25));
        let c = controllers("t", &[neutral], &neutral, Epsilon::new(0.2).unwrap()).unwrap();
        assert!(c[0].iter().all(|v| *v == 0.0));
    }

    #[test]
    fn mapping_gives_one_valid_track_per_channel() {
        let mut c = [0.0; 17];
        c[8] = 0.6; // smileFrown grows
        c[0] = -0.4; // rightTwitch shrinks: lower lid up
        c[4] = 0.3; // leftTwitch grows: counts 0
        c[15] = 2.0; // clamped by to_curves
        let curves = to_curves(&[[0.0; 17], c], "laughter", 30, "test");
        curves.validate(Catalog::built_in()).unwrap();
        assert_eq!(curves.tracks.len(), 12, "AU6 L/R, 4, 2, 1 L/R, 43 L/R, 12, 25, 10, 26: {:?}", curves.tracks.iter().map(|t| (t.au.0, t.side)).collect::<Vec<_>>());
        let value = |au: u16, side| curves.tracks.iter().find(|t| t.au.0 == au && t.side == side).unwrap().values[1];
        assert!((value(12, Both) - 0.6).abs() < 1e-12);
        assert!((value(6, Left) - 0.4).abs() < 1e-12);
        assert_eq!(value(6, Right), 0.0);
        assert_eq!(value(26, Both), 1.0);
    }
}
