//! The AU basis: each Action Unit as ⟨deformation channel, maximum⟩ pairs (data:
//! `stimuli/engine/au_basis.toml`), and HapFACS Eq. 1, which turns an [`Expression`] into the
//! value of every channel on each side of the face.
//!
//! In: a validated expression. Out: [`ChannelValues`], per (channel, side). Invariant: before
//! the pair correctives ([`corrective`], `stimuli/engine/correctives.toml`) are added, a value
//! never exceeds, in magnitude, the smallest maximum of the AUs that drive it (Eq. 1); the same
//! expression always gives the same values.

pub mod corrective;

use std::collections::BTreeMap;
use std::sync::OnceLock;

use serde::Deserialize;

use crate::facs::{AuCode, Catalog, Expression, Laterality};

/// A deformation or appearance channel that AUs drive.
#[derive(Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Channel {
    /// A morph target of the face model (`{ethnic}` is resolved by the identity).
    Target(String),
    JawOpen,
    HeadYaw,
    HeadPitch,
    HeadRoll,
    HeadForward,
    EyesYaw,
    EyesPitch,
    EyesConverge,
    /// An appearance change drawn by the shader (wrinkle, furrow, bulge).
    Shade(String),
    /// A local skin pull (`stimuli/engine/deformers.toml`).
    Pull(String),
    /// A lip turned in about its root (`stimuli/engine/lip_rolls.toml`).
    Roll(String),
}

impl Channel {
    fn parse(text: &str) -> Result<Channel, RigError> {
        if let Some(name) = text.strip_prefix("target:") {
            return Ok(Channel::Target(name.to_string()));
        }
        if let Some(name) = text.strip_prefix("shade:") {
            return Ok(Channel::Shade(name.to_string()));
        }
        if let Some(name) = text.strip_prefix("pull:") {
            return Ok(Channel::Pull(name.to_string()));
        }
        if let Some(name) = text.strip_prefix("roll:") {
            return Ok(Channel::Roll(name.to_string()));
        }
        Ok(match text {
            "jaw.open" => Channel::JawOpen,
            "head.yaw" => Channel::HeadYaw,
            "head.pitch" => Channel::HeadPitch,
            "head.roll" => Channel::HeadRoll,
            "head.forward" => Channel::HeadForward,
            "eyes.yaw" => Channel::EyesYaw,
            "eyes.pitch" => Channel::EyesPitch,
            "eyes.converge" => Channel::EyesConverge,
            other => return Err(RigError::UnknownChannel(other.to_string())),
        })
    }

    /// Rigid channels act on the whole head or both eyes; they have no side.
    pub fn is_rigid(&self) -> bool {
        !matches!(self, Channel::Target(_) | Channel::Shade(_) | Channel::Pull(_) | Channel::Roll(_))
    }
}

/// One side of the face (the person's own).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Side {
    Left,
    Right,
}

impl Side {
    pub const BOTH: [Side; 2] = [Side::Left, Side::Right];
}

/// Problems with the basis table.
#[derive(Debug, thiserror::Error)]
pub enum RigError {
    #[error("the AU basis is not valid TOML: {0}")]
    Toml(#[from] toml::de::Error),
    #[error("unknown channel \"{0}\" in the AU basis")]
    UnknownChannel(String),
    #[error("AU {0} appears twice in the AU basis")]
    Duplicate(AuCode),
    #[error("AU {0} has no entry in the AU basis")]
    Missing(AuCode),
    #[error("pair corrective {0}")]
    Corrective(String),
    #[error("channel \"{channel}\": rise {rise} is not in (0, 4]")]
    Rise { channel: String, rise: f32 },
    #[error("narrow_midline names \"{0}\", which is not a one-sided target of the AU basis")]
    NarrowMidline(String),
}

#[derive(Debug, Clone)]
pub struct ChannelUse {
    pub channel: Channel,
    /// The side of the face a one-sided target belongs to; `None` for symmetric channels.
    pub side: Option<Side>,
    pub max: f32,
    /// How the channel follows the AU's strength: it is driven with `max × strength^rise`
    /// (1, the default, is HapFACS's linear Eq. 1; below 1 the channel leads the AU's lower
    /// levels, e.g. AU19's tongue, which FACS wants in view from A on).
    pub rise: f32,
}

impl ChannelUse {
    /// The channel's value for the AU at `strength` (0..1), before Eq. 1's clamp.
    pub fn value_at(&self, strength: f32) -> f32 {
        let shaped = if self.rise == 1.0 { strength } else { strength.max(0.0).powf(self.rise) };
        shaped * self.max
    }
}

#[derive(Debug, Clone)]
pub struct AuRig {
    /// The L/R prefix gives a direction (AU30), not the side of the face.
    pub direction: bool,
    pub channels: Vec<ChannelUse>,
}

#[derive(Deserialize)]
struct BasisFile {
    #[serde(default)]
    narrow_midline: Vec<String>,
    au: Vec<RawAu>,
}

#[derive(Deserialize)]
struct RawAu {
    code: AuCode,
    #[serde(default)]
    direction: bool,
    channels: Vec<RawChannel>,
}

#[derive(Deserialize)]
struct RawChannel {
    channel: String,
    side: Option<Side>,
    max: f32,
    #[serde(default = "linear")]
    rise: f32,
}

fn linear() -> f32 {
    1.0
}

impl ChannelUse {
    fn from_raw(raw: RawChannel) -> Result<ChannelUse, RigError> {
        let channel = Channel::parse(&raw.channel)?;
        if !(raw.rise.is_finite() && raw.rise > 0.0 && raw.rise <= 4.0) {
            return Err(RigError::Rise { channel: raw.channel, rise: raw.rise });
        }
        Ok(ChannelUse { channel, side: raw.side, max: raw.max, rise: raw.rise })
    }
}

/// The AU → channel table.
#[derive(Debug, Clone)]
pub struct AuBasis {
    rigs: BTreeMap<AuCode, AuRig>,
    /// Channels that belong to one side of the face (declared with `side`).
    one_sided: std::collections::BTreeSet<Channel>,
    /// One-sided targets a one-sided AU blends over the narrow midline band (`narrow_midline`).
    narrow_midline: std::collections::BTreeSet<Channel>,
    /// Pair correctives, added after Eq. 1.
    correctives: Vec<corrective::Corrective>,
}

impl AuBasis {
    /// The table shipped with facslab (`stimuli/engine/au_basis.toml`).
    pub fn built_in() -> &'static AuBasis {
        static BASIS: OnceLock<AuBasis> = OnceLock::new();
        BASIS.get_or_init(|| {
            AuBasis::from_toml(include_str!("../../stimuli/engine/au_basis.toml"))
                .and_then(|basis| basis.with_correctives(include_str!("../../stimuli/engine/correctives.toml")))
                .expect("the built-in AU basis and correctives are valid")
        })
    }

    pub fn from_toml(text: &str) -> Result<AuBasis, RigError> {
        let file: BasisFile = toml::from_str(text)?;
        let mut rigs = BTreeMap::new();
        let mut one_sided = std::collections::BTreeSet::new();
        for raw in file.au {
            let channels = raw.channels.into_iter().map(ChannelUse::from_raw).collect::<Result<Vec<_>, RigError>>()?;
            one_sided.extend(channels.iter().filter(|c| c.side.is_some()).map(|c| c.channel.clone()));
            if rigs.insert(raw.code, AuRig { direction: raw.direction, channels }).is_some() {
                return Err(RigError::Duplicate(raw.code));
            }
        }
        let mut narrow_midline = std::collections::BTreeSet::new();
        for name in file.narrow_midline {
            let channel = Channel::parse(&name)?;
            if !one_sided.contains(&channel) {
                return Err(RigError::NarrowMidline(name));
            }
            narrow_midline.insert(channel);
        }
        Ok(AuBasis { rigs, one_sided, narrow_midline, correctives: Vec::new() })
    }

    /// This basis with the pair correctives of `text` (replacing any it had).
    pub fn with_correctives(mut self, text: &str) -> Result<AuBasis, RigError> {
        let correctives = corrective::from_toml(text, |au| self.rigs.contains_key(&au))?;
        for use_ in correctives.iter().flat_map(|c| &c.channels).filter(|u| u.side.is_some()) {
            self.one_sided.insert(use_.channel.clone());
        }
        self.correctives = correctives;
        Ok(self)
    }

    pub fn correctives(&self) -> &[corrective::Corrective] {
        &self.correctives
    }

    pub fn get(&self, code: AuCode) -> Option<&AuRig> {
        self.rigs.get(&code)
    }

    /// Every catalog AU must have a rig.
    pub fn check_covers(&self, catalog: &Catalog) -> Result<(), RigError> {
        catalog.iter().find(|u| !self.rigs.contains_key(&u.code)).map_or(Ok(()), |u| Err(RigError::Missing(u.code)))
    }

    /// HapFACS Eq. 1: the value of every channel on each side for `expression`, then the pair
    /// correctives of the AU combinations it shows.
    pub fn channel_values(&self, expression: &Expression) -> Result<ChannelValues, RigError> {
        let mut sums: BTreeMap<(Channel, Side), (f32, f32)> = BTreeMap::new();
        let mut unilateral = std::collections::BTreeSet::new();
        let mut strengths: BTreeMap<(AuCode, Side), f32> = BTreeMap::new();
        for activation in expression.activations() {
            let rig = self.get(activation.au).ok_or(RigError::Missing(activation.au))?;
            let strength = activation.strength() as f32;
            for &side in sides_of(activation.side) {
                let s = strengths.entry((activation.au, side)).or_insert(0.0);
                *s = (*s + strength).min(1.0);
            }
            for (use_, side) in driven(rig, activation.side) {
                if activation.side != Laterality::Both && !rig.direction {
                    unilateral.insert(use_.channel.clone());
                }
                let entry = sums.entry((use_.channel.clone(), side)).or_insert((0.0, f32::INFINITY));
                entry.0 += use_.value_at(strength);
                entry.1 = entry.1.min(use_.max.abs());
            }
        }
        let mut values: BTreeMap<(Channel, Side), f32> =
            sums.into_iter().map(|(key, (sum, limit))| (key, sum.clamp(-limit, limit))).collect();
        for corrective in &self.correctives {
            let one_sided = corrective.weight(&strengths, Side::Left) != corrective.weight(&strengths, Side::Right);
            for (channel, side, value) in corrective.additions(&strengths) {
                if one_sided {
                    unilateral.insert(channel.clone());
                }
                *values.entry((channel, side)).or_insert(0.0) += value;
            }
        }
        Ok(ChannelValues { values, one_sided: self.one_sided.clone(), narrow_midline: self.narrow_midline.clone(), unilateral })
    }
}

/// The sides of the face an activation shows on.
fn sides_of(laterality: Laterality) -> &'static [Side] {
    match laterality {
        Laterality::Both => &Side::BOTH,
        Laterality::Left => &[Side::Left],
        Laterality::Right => &[Side::Right],
    }
}

/// The (channel, side) pairs an AU drives when shown on `laterality`.
fn driven(rig: &AuRig, laterality: Laterality) -> Vec<(&ChannelUse, Side)> {
    let acting: &[Side] = match (rig.direction, laterality) {
        (true, Laterality::Right) => &[Side::Right],
        (true, _) => &[Side::Left],
        (false, Laterality::Both) => &Side::BOTH,
        (false, Laterality::Left) => &[Side::Left],
        (false, Laterality::Right) => &[Side::Right],
    };
    let mut out = Vec::new();
    for use_ in &rig.channels {
        match (rig.direction, use_.side) {
            // A direction picks its own entries and drives them on both sides of the face.
            (true, Some(side)) if acting.contains(&side) => out.extend(Side::BOTH.map(|s| (use_, s))),
            (true, Some(_)) => {}
            (true, None) => out.extend(Side::BOTH.map(|s| (use_, s))),
            (false, Some(side)) if acting.contains(&side) => out.push((use_, side)),
            (false, Some(_)) => {}
            (false, None) => out.extend(acting.iter().map(|&s| (use_, s))),
        }
    }
    out
}

/// Channel values after Eq. 1, per side.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ChannelValues {
    values: BTreeMap<(Channel, Side), f32>,
    one_sided: std::collections::BTreeSet<Channel>,
    /// One-sided targets blended over the narrow midline band.
    narrow_midline: std::collections::BTreeSet<Channel>,
    /// Channels driven by a one-sided activation (their effect is kept to that side).
    unilateral: std::collections::BTreeSet<Channel>,
}

impl ChannelValues {
    pub fn get(&self, channel: &Channel, side: Side) -> f32 {
        self.values.get(&(channel.clone(), side)).copied().unwrap_or(0.0)
    }

    /// A rigid channel's value: the mean of both sides (a one-sided AU16 opens the jaw half).
    pub fn rigid(&self, channel: &Channel) -> f32 {
        (self.get(channel, Side::Left) + self.get(channel, Side::Right)) / 2.0
    }

    /// Whether `channel` applies whole: a one-sided target (an ARKit Left/Right pair member)
    /// driven only by bilateral activations, whose two halves together make the bilateral
    /// movement. Otherwise a channel is blended across the midline by side, so that a
    /// unilateral AU stays on its own side.
    pub fn applies_whole(&self, channel: &Channel) -> bool {
        self.one_sided.contains(channel) && !self.unilateral.contains(channel)
    }

    /// Whether a one-sided AU blends `channel` over the narrow midline band (the basis's
    /// `narrow_midline` list of one-sided targets).
    pub fn narrow_midline(&self, channel: &Channel) -> bool {
        self.narrow_midline.contains(channel)
    }

    /// Every non-rigid channel with its (left, right) values, in a fixed order.
    pub fn sided(&self) -> Vec<(&Channel, f32, f32)> {
        let mut out: Vec<(&Channel, f32, f32)> = Vec::new();
        for ((channel, side), &value) in &self.values {
            if channel.is_rigid() {
                continue;
            }
            if out.last().is_none_or(|(c, _, _)| *c != channel) {
                out.push((channel, 0.0, 0.0));
            }
            let last = out.last_mut().expect("just pushed");
            match side {
                Side::Left => last.1 = value,
                Side::Right => last.2 = value,
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn values(text: &str) -> ChannelValues {
        let expression = Catalog::built_in().parse(text).unwrap();
        AuBasis::built_in().channel_values(&expression).unwrap()
    }

    fn target(name: &str) -> Channel {
        Channel::Target(name.to_string())
    }

    #[test]
    fn every_catalog_au_has_a_rig() {
        AuBasis::built_in().check_covers(Catalog::built_in()).unwrap();
    }

    #[test]
    fn intensity_scales_the_maximum() {
        let v = values("12C");
        assert!((v.get(&target("faceunits/mouthSmileLeft"), Side::Left) - 0.55).abs() < 1e-6);
        assert!((v.get(&target("faceunits/cheekSquintLeft"), Side::Left) - 0.55 * 0.25).abs() < 1e-6);
        assert_eq!(v.get(&target("faceunits/mouthSmileLeft"), Side::Right), 0.0);
    }

    #[test]
    fn eq1_adds_shared_channels_below_the_smallest_maximum() {
        // AU4 drives eyeSquint with max 0.25, AU6 with 0.35: at B (0.3) each, 0.075 + 0.105 = 0.18.
        let v = values("4B+6B");
        assert!((v.get(&target("faceunits/eyeSquintLeft"), Side::Left) - 0.18).abs() < 1e-6);
    }

    #[test]
    fn eq1_clamps_to_the_smallest_maximum() {
        // AU4 (max 0.25) + AU7 (max 1.0) at E: 1.25 is clamped to 0.25.
        let v = values("4+7");
        assert_eq!(v.get(&target("faceunits/eyeSquintLeft"), Side::Left), 0.25);
        // AU41 (max 0.35) + AU44 (0.45) at E: 0.8 is clamped to 0.35.
        assert_eq!(values("41+44").get(&target("faceunits/browDownRight"), Side::Right), 0.35);
    }

    #[test]
    fn eq1_keeps_opposing_signs_within_the_smaller_magnitude() {
        // AU33 puffs (+1.0), AU35 sucks (-0.4): 1.0 - 0.4 = 0.6, clamped to ±0.4.
        let v = values("33+35");
        assert!((v.get(&target("faceunits/cheekPuff"), Side::Left) - 0.4).abs() < 1e-6);
    }

    #[test]
    fn unilateral_aus_drive_their_own_side_only() {
        let v = values("L1");
        let inner = target("faceunits/browInnerUp");
        assert_eq!((v.get(&inner, Side::Left), v.get(&inner, Side::Right)), (1.5, 0.0));
        let v = values("R12");
        assert_eq!(v.get(&target("faceunits/mouthSmileLeft"), Side::Left), 0.0);
        assert_eq!(v.get(&target("faceunits/mouthSmileRight"), Side::Right), 1.0);
    }

    #[test]
    fn a_direction_prefix_picks_the_direction_on_both_sides() {
        let v = values("R30");
        let right = target("faceunits/jawRight");
        assert_eq!((v.get(&right, Side::Left), v.get(&right, Side::Right)), (1.0, 1.0));
        assert_eq!(v.get(&target("faceunits/jawLeft"), Side::Left), 0.0);
    }

    #[test]
    fn rigid_channels_average_the_sides() {
        assert_eq!(values("51").rigid(&Channel::HeadYaw), 30.0);
        assert!(values("0").sided().is_empty());
    }

    #[test]
    fn rise_lets_a_channel_lead_the_lower_levels() {
        // AU19: the tongue with rise 0.45, the jaw with 0.3 (max 10°); E is the maximum either way.
        let tongue = target("faceunits/tongueOut");
        for (level, x) in [("A", 0.15f32), ("B", 0.3), ("C", 0.55), ("D", 0.85)] {
            let v = values(&format!("19{level}"));
            assert!((v.get(&tongue, Side::Left) - x.powf(0.45)).abs() < 1e-6, "19{level}");
            assert!((v.rigid(&Channel::JawOpen) - 10.0 * x.powf(0.3)).abs() < 1e-4, "19{level}");
        }
        assert!((values("19A").get(&tongue, Side::Left) - 0.426).abs() < 1e-3);
        assert!((values("19B").rigid(&Channel::JawOpen) - 6.97).abs() < 1e-2);
        assert_eq!(values("19").get(&tongue, Side::Right), 1.0);
        assert_eq!(values("19").rigid(&Channel::JawOpen), 10.0);
        let au = |rise: &str| format!("[[au]]\ncode = 19\nchannels = [{{ channel = \"jaw.open\", max = 10.0, rise = {rise} }}]\n");
        for bad in ["0.0", "-1.0", "5.0", "nan"] {
            let error = AuBasis::from_toml(&au(bad)).unwrap_err().to_string();
            assert!(error.contains("\"jaw.open\": rise") && error.contains("(0, 4]"), "{bad}: {error}");
        }
        assert!(AuBasis::from_toml(&au("0.5")).is_ok());
    }

    fn corrective(text: &str) -> Result<AuBasis, RigError> {
        AuBasis::from_toml(include_str!("../../stimuli/engine/au_basis.toml")).unwrap().with_correctives(text)
    }

    #[test]
    fn the_pair_correctives_cover_the_combinations_that_fight() {
        let basis = AuBasis::built_in();
        for pair in [[1, 2], [1, 4], [6, 12], [9, 10], [12, 15], [17, 24], [25, 26], [12, 25]] {
            let aus = pair.map(AuCode).to_vec();
            assert!(basis.correctives().iter().any(|c| c.aus == aus), "{pair:?} has no corrective");
        }
    }

    /// AU24 turns full lips in a little with AU28's lip rolls; shown with AU28, the corrective
    /// gives back what Eq. 1's clamp to AU24's maximum takes, so the lips roll in as fully as
    /// with AU28 alone.
    #[test]
    fn lip_press_and_lip_suck_roll_the_lips_fully() {
        for lip in ["lower_lip", "upper_lip"] {
            let roll = Channel::Roll(lip.to_string());
            assert!((values("24").get(&roll, Side::Left) - 0.15).abs() < 1e-6, "{lip}");
            assert!((values("28").get(&roll, Side::Left) - 1.0).abs() < 1e-6, "{lip}");
            assert!((values("24+28").get(&roll, Side::Right) - 1.0).abs() < 1e-6, "{lip}");
        }
    }

    #[test]
    fn every_corrective_target_exists() {
        let model = crate::engine::asset::FaceModel::embedded();
        for use_ in AuBasis::built_in().correctives().iter().flat_map(|c| &c.channels) {
            if let Channel::Target(name) = &use_.channel {
                for group in ["african", "asian", "caucasian"] {
                    let name = name.replace("{ethnic}", group);
                    assert!(model.has_target(&name), "{name}");
                }
            }
        }
    }

    #[test]
    fn a_corrective_acts_only_on_the_sides_showing_all_its_aus() {
        let squint = target("faceunits/cheekSquintLeft");
        // 6+12: Eq. 1 clamps the shared cheek squint to 0.25; the corrective adds 0.75 back.
        assert!((values("6+12").get(&squint, Side::Left) - 1.0).abs() < 1e-6);
        assert!((values("6C+12").get(&squint, Side::Left) - (0.25 + 0.55 * 0.75)).abs() < 1e-6);
        // 12 alone, or 6 on the other side only: no corrective.
        assert_eq!(values("12").get(&squint, Side::Left), 0.25);
        assert_eq!(values("R6+12").get(&squint, Side::Left), 0.25);
        let right = target("faceunits/cheekSquintRight");
        assert!((values("R6+12").get(&right, Side::Right) - 1.0).abs() < 1e-6);
    }

    /// 6+12: the raised cheek and the deepened nasolabial furrow are those of 6 alone or more,
    /// not clamped to 12's smaller share (Eq. 1) or 6's (the furrow).
    #[test]
    fn six_and_twelve_raise_the_cheek_and_deepen_the_furrow_at_least_as_six_alone() {
        let (apple, furrow) = (Channel::Shade("cheek_apple".into()), Channel::Shade("nasolabial".into()));
        for side in Side::BOTH {
            assert!((values("6+12").get(&apple, side) - values("6").get(&apple, side)).abs() < 1e-6);
            assert!((values("6").get(&apple, side) - 1.0).abs() < 1e-6);
            assert!((values("6+12").get(&furrow, side) - 0.9).abs() < 1e-6, "{}", values("6+12").get(&furrow, side));
            assert!(values("6+12").get(&furrow, side) > values("12").get(&furrow, side));
        }
    }

    #[test]
    fn only_one_sided_targets_may_blend_over_the_narrow_midline() {
        let au = "[[au]]\ncode = 10\nchannels = [{ channel = \"target:faceunits/mouthUpperUpLeft\", side = \"left\", max = 1.0 }, { channel = \"shade:nasolabial\", max = 1.0 }]\n";
        let symmetric = format!("narrow_midline = [\"shade:nasolabial\"]\n{au}");
        assert!(matches!(AuBasis::from_toml(&symmetric), Err(RigError::NarrowMidline(_))));
        let sided = format!("narrow_midline = [\"target:faceunits/mouthUpperUpLeft\"]\n{au}");
        assert!(AuBasis::from_toml(&sided).is_ok());
        let l10 = values("L10");
        assert!(l10.narrow_midline(&target("faceunits/mouthUpperUpLeft")));
        assert!(!l10.narrow_midline(&target("faceunits/mouthSmileLeft")));
    }

    #[test]
    fn bad_correctives_are_refused_with_the_reason() {
        let one = "[[corrective]]\naus = [6]\nwhy = \"x\"\nchannels = []\n";
        assert!(corrective(one).unwrap_err().to_string().contains("2..=4 different AUs"));
        let unknown = "[[corrective]]\naus = [6, 99]\nwhy = \"x\"\nchannels = []\n";
        assert!(corrective(unknown).unwrap_err().to_string().contains("AU 99 is not in the basis"));
        let twice = "[[corrective]]\naus = [6, 12]\nwhy = \"x\"\nchannels = []\n[[corrective]]\naus = [12, 6]\nwhy = \"y\"\nchannels = []\n";
        assert!(corrective(twice).unwrap_err().to_string().contains("appears twice"));
        let rigid = "[[corrective]]\naus = [6, 12]\nwhy = \"x\"\nchannels = [{ channel = \"jaw.open\", max = 1.0 }]\n";
        assert!(corrective(rigid).unwrap_err().to_string().contains("rigid channel"));
        let channel = "[[corrective]]\naus = [6, 12]\nwhy = \"x\"\nchannels = [{ channel = \"nope\", max = 1.0 }]\n";
        assert!(matches!(corrective(channel), Err(RigError::UnknownChannel(_))));
        let field = "[[corrective]]\naus = [6, 12]\nwhom = \"x\"\nchannels = []\n";
        assert!(matches!(corrective(field), Err(RigError::Toml(_))));
    }
}
