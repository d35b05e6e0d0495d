//! Synthetic studies with a known answer model, shaped like the seed's experiments, so every
//! report can be exercised (and power estimated) before real data exist.
//!
//! - `exp1`: one video per HapFACS AU (49), coders mark AUs.
//! - `exp2`: one video per AU combination of HapFACS Table 4 (54), coders mark AUs.
//! - `exp3`: EmFACS emotions × {100 %, 50 %} × {video, image} × identities; each rater sees one
//!   media × intensity condition, chooses an emotion and rates believability (1–5, facslab's
//!   default scale).
//! - `exp4`: the Exp. 3 task on the videos at 100 % only (HapFACS Exp. 4 showed ten speaking
//!   videos, one per emotion: use `identities = 1`); every rater sees every video.
//!
//! Answer model: a shown AU (or emotion) is given correctly with probability `accuracy` (for
//! emotions at 50 % intensity, `accuracy − 0.1`); otherwise a "similar" one (HapFACS Table 2
//! for AUs; a fixed confusion map for emotions) or, with `Confusion::Uniform`, a uniformly drawn
//! other one. With `group_difference`, the believability of the raters of every group after
//! the first is shifted by that many scale points. Coders also add a random unshown AU with
//! probability `false_positive`. Each judgement is dropped with probability `missing`.
//! - `laugh-description`, `laugh-motion`: seed 004's two rating studies on the 13 laugh types
//!   (`simulate::laughs`, which states their model).
//!
//! Deterministic: the same options give the same bytes (SplitMix64, no other source of
//! randomness).

use std::fmt::Write;

mod laughs;

use crate::engine::identity::EVALUATION_PEOPLE;
use crate::facs::{Catalog, EmotionTable, Expression, Laterality};
use crate::seeded::SplitMix64;
use crate::study::measure::{Demographic, LabelSet, Measure, Scale};

/// Which experiment to imitate.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Design {
    Exp1,
    Exp2,
    Exp3,
    Exp4,
    /// Seed 004 study 1: description match of real and generated laughs.
    LaughDescription,
    /// Seed 004 study 2: q1/q2 of the 13 laugh types on two avatars.
    LaughMotion,
}

impl Design {
    /// The name the command line and the outputs use.
    pub fn name(self) -> &'static str {
        match self {
            Design::Exp1 => "exp1",
            Design::Exp2 => "exp2",
            Design::Exp3 => "exp3",
            Design::Exp4 => "exp4",
            Design::LaughDescription => "laugh-description",
            Design::LaughMotion => "laugh-motion",
        }
    }
}

/// Where wrong answers go.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Confusion {
    Similar,
    Uniform,
}

/// Simulation settings.
#[derive(Debug, Clone)]
pub struct SimOptions {
    pub design: Design,
    pub seed: u64,
    /// Coders (exp1, exp2).
    pub coders: usize,
    /// Raters per media × intensity condition (exp3).
    pub participants: usize,
    /// Identities per emotion × intensity × media (exp3).
    pub identities: usize,
    pub accuracy: f64,
    pub false_positive: f64,
    pub confusion: Confusion,
    pub groups: Vec<String>,
    pub missing: f64,
    /// Believability shift (scale points) of the raters of every group after the first (exp3):
    /// the true group difference a t-test should find.
    pub group_difference: f64,
}

impl Default for SimOptions {
    fn default() -> Self {
        SimOptions {
            design: Design::Exp1,
            seed: 1,
            coders: 3,
            participants: 20,
            identities: 2,
            accuracy: 0.85,
            false_positive: 0.1,
            confusion: Confusion::Similar,
            groups: vec!["local".into(), "amt".into()],
            missing: 0.0,
            group_difference: 0.0,
        }
    }
}

/// The AU combinations of HapFACS Table 4.
pub const TABLE4_COMBINATIONS: [&str; 54] = [
    "1+2", "1+4", "1+2+4", "1+2+5", "4+5", "5+7", "6+43", "6+7+12", "6+12+15", "6+12+15+17", "6+12+17+23", "7+12", "7+43", "9+17", "9+16+25",
    "10+14", "10+15", "10+17", "10+12+25", "10+15+17", "10+16+25", "10+17+23", "10+20+25", "10+23+25", "10+12+16+25", "12+15", "12+17", "12+23",
    "12+24", "12+25+26", "12+25+27", "12+15+17", "12+16+25", "12+17+23", "20+23+25", "22+23+25", "23+25+26", "14+17", "14+23", "15+17", "15+23",
    "17+23", "17+24", "18+23", "20+25+26", "20+25+27", "4+5+7+24", "10+16+25+26", "14+54+62+64", "1+2+4+5+20+25+26", "6+12", "12+53+64", "1+4+15",
    "1+2+5+25+27",
];

/// AUs coders confuse (HapFACS Table 2: shown → mistaken for).
const SIMILAR_AUS: [(u16, u16); 8] = [(11, 38), (13, 14), (14, 12), (16, 25), (20, 24), (41, 43), (42, 4), (44, 4)];

/// Emotions raters confuse (shown → chosen instead).
const SIMILAR_EMOTIONS: [(&str, &str); 10] = [
    ("anger", "sadness"),
    ("contempt", "happiness"),
    ("disgust", "anger"),
    ("embarrassment", "none"),
    ("fear", "surprise"),
    ("happiness", "pride"),
    ("pride", "happiness"),
    ("sadness", "none"),
    ("surprise", "fear"),
    ("neutral", "none"),
];

const MANIFEST_HEADER: &str =
    "stimulus_id,media,file,identity,expression,emotion,intensity,onset_s,apex_s,offset_s,frames,fps,width,height,sha256,set_seed,engine_version\n";
const RESPONSES_HEADER: &str = "participant_id,group,stimulus_id,trial,measure,value,rt_ms\n";

struct SimStimulus {
    id: String,
    expression: String,
    emotion: Option<String>,
}

/// One media × intensity condition: whether it shows videos, its intensity, and its stimuli,
/// each with its believability offset.
type Condition = (bool, f64, Vec<(SimStimulus, f64)>);

fn manifest_row(out: &mut String, s: &SimStimulus, video: bool, identity: &str, intensity: f64, seed: u64) {
    let (media, ext, timing, frames) = if video { ("video", "mp4", "1,1,1", 90) } else { ("image", "png", ",,", 1) };
    let fps = if video { "30" } else { "" };
    let _ = writeln!(
        out,
        "{id},{media},{id}.{ext},{identity},{expr},{emotion},{intensity},{timing},{frames},{fps},486,480,,{seed},simulated",
        id = s.id,
        expr = s.expression,
        emotion = s.emotion.as_deref().unwrap_or(""),
    );
}

/// Writes one row of the long format; `stimulus` and `trial` are empty for rows about the
/// participant.
fn long_row(out: &mut String, pid: &str, group: &str, place: Option<(&str, usize)>, measure: Measure, value: &str, rt: Option<u64>) {
    let (sid, trial) = place.map_or((String::new(), String::new()), |(s, t)| (s.to_string(), t.to_string()));
    let rt = rt.map(|v| v.to_string()).unwrap_or_default();
    let _ = writeln!(out, "{pid},{group},{sid},{trial},{},{value},{rt}", measure.name());
}

fn demographics(out: &mut String, rng: &mut SplitMix64, pid: &str, group: &str) {
    const GENDERS: [&str; 2] = ["female", "male"];
    const ETHNICITIES: [&str; 4] = ["white", "black", "asian", "hispanic"];
    const EDUCATION: [&str; 3] = ["high school", "bachelor", "graduate"];
    let about = |out: &mut String, d: Demographic, value: &str| long_row(out, pid, group, None, Measure::Demographic(d), value, None);
    about(out, Demographic::Age, &(18 + rng.below(43)).to_string());
    about(out, Demographic::Gender, GENDERS[rng.below(2)]);
    let eth = [0.58, 0.08, 0.12, 0.22];
    let (mut u, mut k) = (rng.unit(), 0);
    while k < 3 && u >= eth[k] {
        u -= eth[k];
        k += 1;
    }
    about(out, Demographic::Ethnicity, ETHNICITIES[k]);
    about(out, Demographic::Education, EDUCATION[rng.below(3)]);
}

/// Runs a simulation; returns (manifest CSV, responses CSV).
pub fn simulate(o: &SimOptions) -> (String, String) {
    let header = if matches!(o.design, Design::LaughDescription | Design::LaughMotion) { laughs::MANIFEST_HEADER } else { MANIFEST_HEADER };
    let mut sim = Simulation { o, rng: SplitMix64(o.seed), manifest: String::from(header), responses: String::from(RESPONSES_HEADER) };
    match o.design {
        Design::Exp1 | Design::Exp2 => sim.coders(),
        Design::Exp3 | Design::Exp4 => sim.raters(),
        Design::LaughDescription => sim.laugh_description(),
        Design::LaughMotion => sim.laugh_motion(),
    }
    (sim.manifest, sim.responses)
}

/// One simulation's options, random stream and output.
struct Simulation<'a> {
    o: &'a SimOptions,
    rng: SplitMix64,
    manifest: String,
    responses: String,
}

impl Simulation<'_> {
    /// Exp. 1–2: coders mark the AUs of each video.
    fn coders(&mut self) {
        let catalog = Catalog::built_in();
        let hapfacs: Vec<u16> = catalog.iter().filter(|u| u.hapfacs).map(|u| u.code.0).collect();
        let shown: Vec<String> = match self.o.design {
            Design::Exp1 => hapfacs.iter().map(u16::to_string).collect(),
            _ => TABLE4_COMBINATIONS.iter().map(|s| s.to_string()).collect(),
        };
        let stimuli: Vec<SimStimulus> = shown.into_iter().map(|expression| SimStimulus { id: self.rng.id(), expression, emotion: None }).collect();
        for (i, s) in stimuli.iter().enumerate() {
            manifest_row(&mut self.manifest, s, true, EVALUATION_PEOPLE[i % EVALUATION_PEOPLE.len()], 1.0, self.o.seed);
        }
        for c in 0..self.o.coders {
            let pid = format!("coder{}", c + 1);
            let group = "coders";
            demographics(&mut self.responses, &mut self.rng, &pid, group);
            let mut order: Vec<usize> = (0..stimuli.len()).collect();
            self.rng.shuffle(&mut order);
            for (trial, &si) in order.iter().enumerate() {
                let s = &stimuli[si];
                let truth = catalog.parse(&s.expression).expect("simulated expressions are valid");
                let marked = self.coded(&truth, &hapfacs);
                if self.rng.unit() < self.o.missing {
                    continue;
                }
                let rt = 3000 + self.rng.below(12000);
                long_row(&mut self.responses, &pid, group, Some((&s.id, trial + 1)), Measure::Aus, &marked, Some(rt as u64));
            }
        }
    }

    /// The AUs one coder marks on a stimulus showing `truth`, as notation.
    fn coded(&mut self, truth: &Expression, hapfacs: &[u16]) -> String {
        let mut marked: Vec<(u16, Laterality)> = Vec::new();
        let shown: Vec<u16> = truth.codes().iter().map(|c| c.0).collect();
        for a in truth.activations() {
            let code = a.au.0;
            let given = if self.rng.unit() < self.o.accuracy {
                Some((code, a.side))
            } else {
                let other = match self.o.confusion {
                    Confusion::Similar => SIMILAR_AUS.iter().find(|(s, _)| *s == code).map(|(_, m)| *m).or_else(|| {
                        let k = hapfacs.iter().position(|&h| h == code).unwrap_or(0);
                        hapfacs.get(k + 1).copied()
                    }),
                    Confusion::Uniform => Some(hapfacs[self.rng.below(hapfacs.len())]),
                };
                other.filter(|m| !shown.contains(m) || *m == code).map(|m| (m, Laterality::Both))
            };
            if let Some(g) = given
                && !marked.iter().any(|(m, _)| *m == g.0)
            {
                marked.push(g);
            }
        }
        if self.rng.unit() < self.o.false_positive {
            let extra = hapfacs[self.rng.below(hapfacs.len())];
            if !marked.iter().any(|(m, _)| *m == extra) {
                marked.push((extra, Laterality::Both));
            }
        }
        marked.sort();
        let terms: Vec<String> = marked
            .iter()
            .map(|(m, side)| match side {
                Laterality::Left => format!("L{m}"),
                Laterality::Right => format!("R{m}"),
                Laterality::Both => m.to_string(),
            })
            .collect();
        terms.join("+")
    }

    /// Exp. 3–4: the stimuli of each media × intensity condition (Exp. 4: videos at 100 %
    /// only), each with its believability offset.
    fn conditions(&mut self) -> Vec<Condition> {
        let emotions = EmotionTable::built_in();
        let cells: &[(bool, f64)] = match self.o.design {
            Design::Exp4 => &[(true, 1.0)],
            _ => &[(true, 1.0), (true, 0.5), (false, 1.0), (false, 0.5)],
        };
        let mut conditions = Vec::new();
        let mut n = 0;
        for &(video, intensity) in cells {
            let mut stimuli = Vec::new();
            for e in emotions.iter() {
                for _ in 0..self.o.identities.max(1) {
                    let expression = if intensity == 1.0 { e.expression.to_string() } else { e.expression.scaled(intensity).to_string() };
                    let s = SimStimulus { id: self.rng.id(), expression, emotion: Some(e.label.clone()) };
                    manifest_row(&mut self.manifest, &s, video, EVALUATION_PEOPLE[n % EVALUATION_PEOPLE.len()], intensity, self.o.seed);
                    n += 1;
                    stimuli.push((s, 0.5 * self.rng.normal()));
                }
            }
            conditions.push((video, intensity, stimuli));
        }
        conditions
    }

    /// Exp. 3–4: each rater sees one condition, chooses an emotion and rates believability.
    fn raters(&mut self) {
        let groups: Vec<String> = if self.o.groups.is_empty() { vec!["all".into()] } else { self.o.groups.clone() };
        let conditions = self.conditions();
        let mut pn = 0;
        for (video, intensity, stimuli) in &conditions {
            for _ in 0..self.o.participants {
                pn += 1;
                let pid = format!("p{pn:04}");
                let group_index = pn % groups.len();
                let group = &groups[group_index];
                let shift = if group_index > 0 { self.o.group_difference } else { 0.0 };
                demographics(&mut self.responses, &mut self.rng, &pid, group);
                let leniency = 0.5 * self.rng.normal();
                let mut order: Vec<usize> = (0..stimuli.len()).collect();
                self.rng.shuffle(&mut order);
                let p_correct = if *intensity < 1.0 { self.o.accuracy - 0.1 } else { self.o.accuracy };
                for (trial, &si) in order.iter().enumerate() {
                    let (s, offset) = &stimuli[si];
                    let chosen = self.chosen(s.emotion.as_deref().expect("exp3 stimuli portray an emotion"), p_correct);
                    let rt = 800 + self.rng.below(4000);
                    let place = Some((s.id.as_str(), trial + 1));
                    if self.rng.unit() >= self.o.missing {
                        long_row(&mut self.responses, &pid, group, place, Measure::Emotion, &chosen, Some(rt as u64));
                    }
                    let b = (3.6 + if *video { 0.0 } else { 0.1 } + offset + leniency + 0.6 * self.rng.normal() + shift).round().clamp(1.0, 5.0) as u8;
                    if self.rng.unit() >= self.o.missing {
                        long_row(&mut self.responses, &pid, group, place, Measure::Scale(Scale::Believability), &b.to_string(), None);
                    }
                }
            }
        }
    }

    /// The label a rater chooses for a stimulus showing `shown`.
    fn chosen(&mut self, shown: &str, p_correct: f64) -> String {
        if self.rng.unit() < p_correct {
            return shown.to_string();
        }
        match self.o.confusion {
            Confusion::Similar => SIMILAR_EMOTIONS.iter().find(|(a, _)| *a == shown).map_or("none", |(_, b)| b).to_string(),
            Confusion::Uniform => {
                let others: Vec<&String> = LabelSet::emfacs().labels().iter().filter(|l| *l != shown).collect();
                others[self.rng.below(others.len())].clone()
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::manifest::Manifest;
    use crate::analysis::responses::Responses;

    #[test]
    fn same_seed_same_bytes_and_files_read_back() {
        for design in [Design::Exp1, Design::Exp2, Design::Exp3, Design::Exp4, Design::LaughDescription, Design::LaughMotion] {
            let o = SimOptions { design, seed: 7, participants: 4, missing: 0.05, ..SimOptions::default() };
            let (m1, r1) = simulate(&o);
            let (m2, r2) = simulate(&o);
            assert_eq!((&m1, &r1), (&m2, &r2));
            let other = simulate(&SimOptions { seed: 8, ..o.clone() });
            assert_ne!(r1, other.1);
            let (catalog, emotions) = (Catalog::built_in(), EmotionTable::built_in());
            let manifest = Manifest::from_csv("m.csv", &m1, catalog).unwrap();
            let responses = Responses::from_csv("r.csv", &r1, &manifest, catalog, &emotions).unwrap();
            let expected = match design {
                Design::Exp1 => 49,
                Design::Exp2 => 54,
                Design::Exp3 => 80,
                Design::Exp4 => 20,
                Design::LaughDescription | Design::LaughMotion => 26,
            };
            assert_eq!(manifest.len(), expected);
            assert!(responses.rows > 0);
        }
    }

    #[test]
    fn perfect_coders_score_one() {
        let o = SimOptions { accuracy: 1.0, false_positive: 0.0, ..SimOptions::default() };
        let (m, r) = simulate(&o);
        let (catalog, emotions) = (Catalog::built_in(), EmotionTable::built_in());
        let manifest = Manifest::from_csv("m.csv", &m, catalog).unwrap();
        let responses = Responses::from_csv("r.csv", &r, &manifest, catalog, &emotions).unwrap();
        let report = crate::analysis::coding::analyze(&manifest, &responses, catalog, Default::default()).unwrap();
        assert_eq!(report.micro.f1, 1.0);
        assert!(report.per_au.iter().all(|r| r.alpha.value == Some(1.0)));
    }
}
