//! Identities: who is shown. Each identity is data (`stimuli/engine/identities.toml`): sex, age,
//! ancestry, colours and extra shape targets; this module turns it into morph-target weights
//! (MakeHuman's macro blending rule, see `stimuli/face/README.md`) and linear colours.
//!
//! In: TOML. Out: [`Identity`] with [`Identity::shape_weights`] and linear-RGB colours.
//! Invariant: every target an identity names exists in the face model (checked on load).

use std::collections::BTreeMap;
use std::sync::OnceLock;

use glam::Vec3;
use serde::Deserialize;

use super::asset::FaceModel;

/// How far the resting upper lids are lifted (fraction of the eyeWide targets).
const NEUTRAL_LID_LIFT: f32 = 0.3;

/// Problems with an identity table.
#[derive(Debug, thiserror::Error)]
pub enum IdentityError {
    #[error("the identity table is not valid TOML: {0}")]
    Toml(#[from] toml::de::Error),
    #[error("identity \"{id}\": {message}")]
    Invalid { id: String, message: String },
    #[error("unknown identity \"{0}\" (run `facslab identities` for the list)")]
    Unknown(String),
}

/// Weights of the three ancestry groups of the face model's macro shapes (sum to 1).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, Default)]
pub struct Ancestry {
    #[serde(default)]
    pub african: f32,
    #[serde(default)]
    pub asian: f32,
    #[serde(default)]
    pub caucasian: f32,
}

impl Ancestry {
    /// The groups with their names, in the order the face model's files use.
    pub fn named(&self) -> [(&'static str, f32); 3] {
        [("african", self.african), ("asian", self.asian), ("caucasian", self.caucasian)]
    }

    fn normalised(self) -> Option<Ancestry> {
        let sum = self.african + self.asian + self.caucasian;
        let valid = [self.african, self.asian, self.caucasian].iter().all(|w| w.is_finite() && *w >= 0.0);
        (valid && sum > 0.0).then(|| Ancestry { african: self.african / sum, asian: self.asian / sum, caucasian: self.caucasian / sum })
    }
}

#[derive(Deserialize)]
struct RawIdentity {
    id: String,
    description: String,
    sex: f32,
    age: f32,
    ancestry: Ancestry,
    skin: String,
    iris: String,
    hair: String,
    lips: String,
    #[serde(default)]
    stubble: f32,
    #[serde(default)]
    hairline: f32,
    #[serde(default)]
    shape: BTreeMap<String, f32>,
}

#[derive(Deserialize)]
struct IdentityFile {
    identity: Vec<RawIdentity>,
}

/// One person the engine can render.
#[derive(Debug, Clone)]
pub struct Identity {
    pub id: String,
    pub description: String,
    /// 0 = female … 1 = male.
    pub sex: f32,
    pub age: f32,
    pub ancestry: Ancestry,
    /// Linear-RGB albedos.
    pub skin: Vec3,
    pub iris: Vec3,
    pub hair: Vec3,
    pub lips: Vec3,
    pub stubble: f32,
    pub hairline: f32,
    shape: BTreeMap<String, f32>,
}

impl Identity {
    /// Morph targets (`group/name`) and weights that turn the base mesh into this person.
    pub fn shape_weights(&self) -> Vec<(String, f32)> {
        let gender = [("female", 1.0 - self.sex), ("male", self.sex)];
        // MakeHuman age parameter: 0.5 at 25 years, 1.0 at 90.
        let a = (0.5 + (self.age - 25.0) / 130.0).clamp(0.5, 1.0);
        let age = [("young", 1.0 - 2.0 * (a - 0.5)), ("old", 2.0 * (a - 0.5))];
        let mut weights = Vec::new();
        for (race, wr) in self.ancestry.named() {
            for (g, wg) in gender {
                for (t, wt) in age {
                    let w = wr * wg * wt;
                    if w > 0.0 {
                        weights.push((format!("identity/macro/{race}-{g}-{t}"), w));
                    }
                }
            }
        }
        weights.extend(self.shape.iter().map(|(name, w)| (name.clone(), *w)));
        // The base mesh's resting lids sit low over the iris; open them a little for everyone.
        weights.extend(["faceunits/eyeWideLeft", "faceunits/eyeWideRight"].map(|n| (n.to_string(), NEUTRAL_LID_LIFT)));
        weights
    }
}

/// The identities facslab knows.
#[derive(Debug, Clone)]
pub struct IdentityTable {
    identities: Vec<Identity>,
}

impl IdentityTable {
    /// The eight HapFACS evaluation identities (`stimuli/engine/identities.toml`).
    pub fn built_in() -> &'static IdentityTable {
        static TABLE: OnceLock<IdentityTable> = OnceLock::new();
        TABLE.get_or_init(|| {
            IdentityTable::from_toml(include_str!("../../stimuli/engine/identities.toml"), FaceModel::embedded())
                .expect("the built-in identities are valid")
        })
    }

    pub fn from_toml(text: &str, model: &FaceModel) -> Result<IdentityTable, IdentityError> {
        let file: IdentityFile = toml::from_str(text)?;
        let mut identities: Vec<Identity> = Vec::new();
        for raw in file.identity {
            let identity = validate(raw, model)?;
            if identities.iter().any(|i| i.id == identity.id) {
                return Err(IdentityError::Invalid { id: identity.id, message: "appears twice".into() });
            }
            identities.push(identity);
        }
        Ok(IdentityTable { identities })
    }

    pub fn get(&self, id: &str) -> Result<&Identity, IdentityError> {
        self.identities.iter().find(|i| i.id == id).ok_or_else(|| IdentityError::Unknown(id.to_string()))
    }

    pub fn iter(&self) -> impl Iterator<Item = &Identity> {
        self.identities.iter()
    }
}

fn validate(raw: RawIdentity, model: &FaceModel) -> Result<Identity, IdentityError> {
    let fail = |message: String| IdentityError::Invalid { id: raw.id.clone(), message };
    if raw.id.is_empty() || !raw.id.chars().all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_') {
        return Err(fail("an id is letters, digits, '-' and '_'".into()));
    }
    if !(0.0..=1.0).contains(&raw.sex) {
        return Err(fail(format!("sex {} is outside 0 (female) .. 1 (male)", raw.sex)));
    }
    if !(18.0..=90.0).contains(&raw.age) {
        return Err(fail(format!("age {} is outside 18..90", raw.age)));
    }
    let ancestry = raw.ancestry.normalised().ok_or_else(|| fail("ancestry weights must be non-negative and not all zero".into()))?;
    for (name, weight) in &raw.shape {
        if !model.has_target(name) || !name.starts_with("identity/") {
            return Err(fail(format!("shape target \"{name}\" is not an identity target of the face model")));
        }
        if !weight.is_finite() || weight.abs() > 2.0 {
            return Err(fail(format!("shape weight {weight} for \"{name}\" is outside -2..2")));
        }
    }
    let colour = |field: &str, text: &str| parse_hex(text).ok_or_else(|| fail(format!("{field} \"{text}\" is not an sRGB hex colour like \"#c99a82\"")));
    Ok(Identity {
        skin: colour("skin", &raw.skin)?,
        iris: colour("iris", &raw.iris)?,
        hair: colour("hair", &raw.hair)?,
        lips: colour("lips", &raw.lips)?,
        id: raw.id,
        description: raw.description,
        sex: raw.sex,
        age: raw.age,
        ancestry,
        stubble: raw.stubble.clamp(0.0, 1.0),
        hairline: raw.hairline,
        shape: raw.shape,
    })
}

/// `#rrggbb` (sRGB) → linear RGB.
fn parse_hex(text: &str) -> Option<Vec3> {
    let hex = text.strip_prefix('#')?;
    if hex.len() != 6 {
        return None;
    }
    let channel = |i: usize| u8::from_str_radix(&hex[i..i + 2], 16).ok().map(|v| srgb_to_linear(v as f32 / 255.0));
    Some(Vec3::new(channel(0)?, channel(2)?, channel(4)?))
}

fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_eight_hapfacs_identities() {
        let table = IdentityTable::built_in();
        assert_eq!(table.iter().count(), 8);
        let men = table.iter().filter(|i| i.sex > 0.5).count();
        let african = table.iter().filter(|i| i.ancestry.african > 0.5).count();
        assert_eq!((men, african), (4, 4));
        assert!(matches!(table.get("nobody"), Err(IdentityError::Unknown(_))));
    }

    #[test]
    fn macro_weights_follow_the_blending_rule() {
        let wm1 = IdentityTable::built_in().get("wm1").unwrap();
        let weights = wm1.shape_weights();
        let young: f32 = weights.iter().filter(|(n, _)| n == "identity/macro/caucasian-male-young").map(|(_, w)| *w).sum();
        // age 30: a = 0.5 + 5/130, young = 1 - 2(a - 0.5) = 1 - 10/130.
        assert!((young - (1.0 - 10.0 / 130.0)).abs() < 1e-6);
        assert!(weights.iter().all(|(n, _)| !n.contains("female")));
    }

    #[test]
    fn bad_identities_are_named() {
        let text = "[[identity]]\nid = \"x\"\ndescription = \"\"\nsex = 3\nage = 30\nancestry = { asian = 1 }\nskin = \"#000000\"\niris = \"#000000\"\nhair = \"#000000\"\nlips = \"#000000\"\n";
        let err = IdentityTable::from_toml(text, FaceModel::embedded()).unwrap_err().to_string();
        assert!(err.contains("\"x\"") && err.contains("sex"), "{err}");
    }
}
