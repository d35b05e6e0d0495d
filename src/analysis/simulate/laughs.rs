//! Seed 004's two rating studies, simulated: the 13 laugh and smile types of the `laughs` label
//! set, each stimulus with its `style`.
//!
//! - `laugh-description` (study 1): per type a real recording (`style = real`) and a generated
//!   video (`realistic`); each participant rates a random 6 or 7 of the 13 types, both videos of
//!   each, on description match (0–5). True means: real 4.3, generated 3.4 (the seed's grand
//!   means), plus a per-type offset.
//! - `laugh-motion` (study 2): the 13 types on the realistic and the cartoon avatar (26 videos);
//!   every participant rates every video on q1 and q2 (0–5). True means: 3.3 plus the type's
//!   offset (the seed's best and worst types: sly and closed-mouth smiles high, ingratiating and
//!   eager smiles low), with the seed's interaction: the melancholy smile better on the
//!   realistic avatar, false laughter better on the cartoon one.
//!
//! A rating is round(mean + participant leniency (sd 0.4) + noise (sd 0.9)) clamped to 0–5;
//! judgements are dropped with probability `missing`. Deterministic (the caller's SplitMix64).

use super::{SimStimulus, Simulation, demographics, long_row, manifest_row};
use crate::study::labels::{LabelSet, Qualified};
use crate::study::measure::{Measure, Scale};

/// The manifest header of the laugh designs: the standard columns and `style`.
pub(super) const MANIFEST_HEADER: &str =
    "stimulus_id,media,file,identity,expression,emotion,intensity,onset_s,apex_s,offset_s,frames,fps,width,height,sha256,set_seed,engine_version,style\n";

/// Offsets from the grand mean per type (declared order of the `laughs` set).
const TYPE_OFFSET: [f64; 13] = [0.2, 0.3, 0.4, 0.8, 0.0, -0.1, -0.45, -0.85, 0.8, -0.2, 0.1, -0.3, 0.0];

/// The style × type interaction: (type, style, shift).
const INTERACTION: [(&str, &str, f64); 4] = [("melancholy_smile", "realistic", 0.4), ("melancholy_smile", "cartoon", -0.4), ("false_laughter", "realistic", -0.4), ("false_laughter", "cartoon", 0.4)];

/// A simulated laugh stimulus: its type index and style, and the rating mean it draws from.
struct LaughStimulus {
    stimulus: SimStimulus,
    label: usize,
    mean: f64,
}

impl Simulation<'_> {
    /// Writes the manifest rows of `styles` × the 13 types; `base` gives each style's mean.
    fn laugh_stimuli(&mut self, styles: &[(&str, f64)]) -> Vec<LaughStimulus> {
        let laughs = LabelSet::find("laughs").expect("the laughs label set is built in");
        let mut out = Vec::new();
        for (label, declared) in laughs.table().labels.iter().enumerate() {
            for (k, &(style, base)) in styles.iter().enumerate() {
                let shift: f64 = INTERACTION.iter().filter(|(t, s, _)| *t == declared.id && *s == style).map(|(_, _, d)| d).sum();
                let stimulus = SimStimulus { id: self.rng.id(), expression: "6+12+25".into(), emotion: Some(Qualified::text(laughs.id(), &declared.id)) };
                manifest_row(&mut self.manifest, &stimulus, true, super::EVALUATION_PEOPLE[k % super::EVALUATION_PEOPLE.len()], 1.0, self.o.seed);
                self.manifest.pop();
                self.manifest.push_str(&format!(",{style}\n"));
                out.push(LaughStimulus { stimulus, label, mean: base + TYPE_OFFSET[label] + shift });
            }
        }
        out
    }

    fn laugh_rating(&mut self, mean: f64, leniency: f64) -> u8 {
        (mean + leniency + 0.9 * self.rng.normal()).round().clamp(0.0, 5.0) as u8
    }

    /// Study 1: description match of the real and the generated video of 6 or 7 types.
    pub(super) fn laugh_description(&mut self) {
        let stimuli = self.laugh_stimuli(&[("real", 4.3), ("realistic", 3.4)]);
        for p in 0..self.o.participants {
            let pid = format!("p{:04}", p + 1);
            demographics(&mut self.responses, &mut self.rng, &pid, "raters");
            let leniency = 0.4 * self.rng.normal();
            let mut types: Vec<usize> = (0..13).collect();
            self.rng.shuffle(&mut types);
            types.truncate(6 + self.rng.below(2));
            let mut trial = 0;
            for s in stimuli.iter().filter(|s| types.contains(&s.label)) {
                trial += 1;
                let v = self.laugh_rating(s.mean, leniency);
                if self.rng.unit() >= self.o.missing {
                    long_row(&mut self.responses, &pid, "raters", Some((&s.stimulus.id, trial)), Measure::Scale(Scale::DescriptionMatch), &v.to_string(), None);
                }
            }
        }
    }

    /// Study 2: q1 and q2 on all 26 videos (13 types × realistic and cartoon avatar).
    pub(super) fn laugh_motion(&mut self) {
        let stimuli = self.laugh_stimuli(&[("realistic", 3.3), ("cartoon", 3.3)]);
        for p in 0..self.o.participants {
            let pid = format!("p{:04}", p + 1);
            demographics(&mut self.responses, &mut self.rng, &pid, "raters");
            let leniency = 0.4 * self.rng.normal();
            let mut order: Vec<usize> = (0..stimuli.len()).collect();
            self.rng.shuffle(&mut order);
            for (trial, &i) in order.iter().enumerate() {
                let s = &stimuli[i];
                for scale in [Scale::Q1, Scale::Q2] {
                    let v = self.laugh_rating(s.mean, leniency);
                    if self.rng.unit() >= self.o.missing {
                        long_row(&mut self.responses, &pid, "raters", Some((&s.stimulus.id, trial + 1)), Measure::Scale(scale), &v.to_string(), None);
                    }
                }
            }
        }
    }
}
