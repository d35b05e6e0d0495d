//! Identities: who is shown. Each identity is data (`stimuli/engine/identities.toml`, or a file
//! of the same format given at run time): sex, age, ancestry, colours, hair, clothing and extra
//! shape targets; this module turns it into morph-target weights (MakeHuman's macro blending
//! rule, see `stimuli/face/README.md`) and linear colours.
//!
//! In: TOML. Out: [`Identity`] with [`Identity::shape_weights`] and linear-RGB colours; the
//! [`IdentityTable::active`] table (built-in people plus those of one installed file).
//! Invariant: every target an identity names exists in the face model (checked on load); ids
//! are unique within the active table (the per-person caches are keyed by id).

use std::collections::BTreeMap;
use std::sync::{Mutex, OnceLock};

use glam::Vec3;
use serde::Deserialize;

use super::asset::FaceModel;

/// How far the resting upper lids are lifted (fraction of the eyeWide targets).
const NEUTRAL_LID_LIFT: f32 = 0.3;

/// The CC0 female macro targets raise the inner brows and turn the mouth's corners down at
/// rest, so that women looked worried or sad at neutral (MediaPipe read browInnerUp 0.65–0.83);
/// every person is given these two identity targets in proportion to how female the shape
/// is, which levels the brows and the corners (test `the_resting_face_follows_how_female_the_shape_is`;
/// MediaPipe's readings in the README).
const RESTING_FACE: [(&str, f32); 2] = [("identity/eyebrows/eyebrows-angle-down", 0.3), ("identity/mouth/mouth-angles-up", 0.25)];

/// HapFACS's eight evaluation people (two white men, two black men, two white women, two black
/// women): the first eight of the built-in table, and a stimulus set's rotation by default.
pub const EVALUATION_PEOPLE: [&str; 8] = ["wm1", "wm2", "bm1", "bm2", "wf1", "wf2", "bf1", "bf2"];

/// Runs `check` on each of the eight evaluation people and fails with every complaint
/// (`Some(why)`, reported after the person's id) at once.
#[cfg(test)]
pub(crate) fn assert_on_the_eight(mut check: impl FnMut(&Identity) -> Option<String>) {
    let table = IdentityTable::built_in();
    let failures: Vec<String> =
        EVALUATION_PEOPLE.iter().filter_map(|&id| check(table.get(id).expect("a built-in person")).map(|why| format!("{id}: {why}"))).collect();
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The largest identity file read (a few hundred people).
pub const MAX_FILE_BYTES: usize = 1 << 20;

/// The longest beard an identity may have (millimetres): a short full beard, lying on the face.
pub const MAX_BEARD_MM: f32 = 20.0;

/// Problems with an identity table.
#[derive(Debug, thiserror::Error)]
pub enum IdentityError {
    /// The parser's message (line, column and an excerpt) is part of this one, not a source
    /// of it: a report of the error's chain would print it twice.
    #[error("the identity table is not valid TOML: {0}")]
    Toml(toml::de::Error),
    #[error("line {line}: identity \"{id}\", field `{field}`: {message}")]
    Invalid { id: String, field: &'static str, line: usize, message: String },
    #[error("unknown identity \"{0}\" (run `facslab identities` for the list)")]
    Unknown(String),
    #[error("the identity file is {0} bytes; the limit is {MAX_FILE_BYTES}")]
    TooLarge(usize),
    #[error("another identity file is already in use in this process")]
    AlreadyInstalled,
}

/// Weights of the three ancestry groups of the face model's macro shapes (sum to 1).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, Default)]
#[serde(deny_unknown_fields)]
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

/// How long the scalp hair is and how it is worn.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum HairStyle {
    /// Shaved or close-cropped: a shadow of hair on the scalp.
    Cropped,
    Short,
    Medium,
    /// To the shoulders.
    Shoulder,
    /// Below the shoulders.
    Long,
    /// Pulled back into a bun at the back of the head.
    Bun,
    /// Pulled back into a ponytail.
    Ponytail,
}

impl HairStyle {
    pub const ALL: [HairStyle; 7] =
        [HairStyle::Cropped, HairStyle::Short, HairStyle::Medium, HairStyle::Shoulder, HairStyle::Long, HairStyle::Bun, HairStyle::Ponytail];

    pub fn name(self) -> &'static str {
        match self {
            HairStyle::Cropped => "cropped",
            HairStyle::Short => "short",
            HairStyle::Medium => "medium",
            HairStyle::Shoulder => "shoulder",
            HairStyle::Long => "long",
            HairStyle::Bun => "bun",
            HairStyle::Ponytail => "ponytail",
        }
    }
}

/// Where a beard grows (with `beard` > 0).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum BeardStyle {
    /// The upper lip, the chin, the jaw, the cheeks and the sideburns up to the scalp's hair.
    #[default]
    Full,
    /// The upper lip and the chin, joined round the mouth's corners.
    Goatee,
    /// The upper lip alone.
    Moustache,
}

impl BeardStyle {
    pub const ALL: [BeardStyle; 3] = [BeardStyle::Full, BeardStyle::Goatee, BeardStyle::Moustache];

    pub fn name(self) -> &'static str {
        match self {
            BeardStyle::Full => "full",
            BeardStyle::Goatee => "goatee",
            BeardStyle::Moustache => "moustache",
        }
    }
}

/// The curl of the hair.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum HairTexture {
    #[default]
    Straight,
    Wavy,
    Curly,
    /// Tightly coiled (afro-textured).
    Coiled,
}

impl HairTexture {
    pub const ALL: [HairTexture; 4] = [HairTexture::Straight, HairTexture::Wavy, HairTexture::Curly, HairTexture::Coiled];

    pub fn name(self) -> &'static str {
        match self {
            HairTexture::Straight => "straight",
            HairTexture::Wavy => "wavy",
            HairTexture::Curly => "curly",
            HairTexture::Coiled => "coiled",
        }
    }
}

/// Where the hair parts, seen from the person.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum Parting {
    #[default]
    Left,
    Right,
    Centre,
    /// Combed back, no parting.
    None,
}

/// The parting of a person whose file names none: on the left, except for tightly coiled hair,
/// which stands out from the scalp in a mass with no parting line (a parting drew a seam
/// down an afro).
fn default_parting(texture: HairTexture) -> Parting {
    if texture == HairTexture::Coiled { Parting::None } else { Parting::Left }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
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
    /// Millimetres.
    #[serde(default)]
    beard: f32,
    #[serde(default)]
    beard_style: BeardStyle,
    #[serde(default)]
    hair_style: Option<HairStyle>,
    #[serde(default)]
    hair_texture: Option<HairTexture>,
    #[serde(default)]
    hair_grey: Option<f32>,
    #[serde(default)]
    parting: Option<Parting>,
    #[serde(default)]
    top: Option<String>,
    #[serde(default)]
    shape: BTreeMap<String, f32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct IdentityFile {
    identity: Vec<toml::Spanned<RawIdentity>>,
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
    /// The crew-neck top.
    pub top: Vec3,
    pub stubble: f32,
    pub hairline: f32,
    /// The length of a beard's hairs (decimetres; 0 = no beard, the stubble alone).
    pub beard: f32,
    pub beard_style: BeardStyle,
    pub hair_style: HairStyle,
    pub hair_texture: HairTexture,
    /// Fraction of grey hairs, 0..1.
    pub hair_grey: f32,
    pub parting: Parting,
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
        weights.extend(RESTING_FACE.iter().filter(|_| self.sex < 1.0).map(|(name, w)| (name.to_string(), w * (1.0 - self.sex))));
        weights.extend(self.shape.iter().map(|(name, w)| (name.clone(), *w)));
        // The base mesh's resting lids sit low over the iris; open them a little for everyone.
        weights.extend(["faceunits/eyeWideLeft", "faceunits/eyeWideRight"].map(|n| (n.to_string(), NEUTRAL_LID_LIFT)));
        weights
    }

    /// The extra shape targets and weights (as written in the identity file).
    pub fn shape_targets(&self) -> &BTreeMap<String, f32> {
        &self.shape
    }
}

/// The identities facslab knows.
#[derive(Debug, Clone)]
pub struct IdentityTable {
    identities: Vec<Identity>,
}

/// The file installed with [`IdentityTable::install`]: its text and the table it gave.
static INSTALLED: Mutex<Option<(String, &'static IdentityTable)>> = Mutex::new(None);

impl IdentityTable {
    /// The shipped people (`stimuli/engine/identities.toml`): the eight HapFACS evaluation
    /// identities first, then more of other ancestries and ages.
    pub fn built_in() -> &'static IdentityTable {
        static TABLE: OnceLock<IdentityTable> = OnceLock::new();
        TABLE.get_or_init(|| {
            IdentityTable::from_toml(include_str!("../../stimuli/engine/identities.toml"), FaceModel::embedded())
                .expect("the built-in identities are valid")
        })
    }

    /// The people every command renders: the built-in ones plus those of the installed file.
    pub fn active() -> &'static IdentityTable {
        match *INSTALLED.lock().unwrap_or_else(|p| p.into_inner()) {
            Some((_, table)) => table,
            None => IdentityTable::built_in(),
        }
    }

    /// Adds the people of an identity file (TOML `text`) to the active table for the rest of
    /// the process. Their ids must differ from the built-in ones. Installing the same text
    /// again is allowed; a different file is refused.
    pub fn install(text: &str) -> Result<&'static IdentityTable, IdentityError> {
        let mut installed = INSTALLED.lock().unwrap_or_else(|p| p.into_inner());
        if let Some((previous, table)) = installed.as_ref() {
            return if previous == text { Ok(table) } else { Err(IdentityError::AlreadyInstalled) };
        }
        let extra = IdentityTable::from_toml(text, FaceModel::embedded())?;
        let mut identities = IdentityTable::built_in().identities.clone();
        for identity in extra.identities {
            if identities.iter().any(|i| i.id == identity.id) {
                let line = 1 + text.find(&format!("\"{}\"", identity.id)).map_or(0, |at| text[..at].matches('\n').count());
                return Err(IdentityError::Invalid { id: identity.id, field: "id", line, message: "is already a built-in identity".into() });
            }
            identities.push(identity);
        }
        let table: &'static IdentityTable = Box::leak(Box::new(IdentityTable { identities }));
        *installed = Some((text.to_string(), table));
        Ok(table)
    }

    pub fn from_toml(text: &str, model: &FaceModel) -> Result<IdentityTable, IdentityError> {
        if text.len() > MAX_FILE_BYTES {
            return Err(IdentityError::TooLarge(text.len()));
        }
        let file: IdentityFile = toml::from_str(text).map_err(IdentityError::Toml)?;
        let mut identities: Vec<Identity> = Vec::new();
        for spanned in file.identity {
            let span = spanned.span();
            // The span covers the `[[identity]]` header; the block runs to the next header.
            let rest = &text[span.start..];
            let block = rest.get(1..).and_then(|r| r.find("\n[[")).map_or(rest, |end| &rest[..end + 1]);
            let line_of = |field: &str| field_line(text, span.start, block, field);
            let identity = validate(spanned.into_inner(), model, &line_of)?;
            if identities.iter().any(|i| i.id == identity.id) {
                return Err(IdentityError::Invalid { line: line_of("id"), id: identity.id, field: "id", message: "appears twice".into() });
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

/// The 1-based line of `field = …` inside one identity's block (which starts at byte `start`
/// of `text`), or the block's first line when the field is not written out.
fn field_line(text: &str, start: usize, block: &str, field: &str) -> usize {
    let mut offset = 0;
    let mut found = 0;
    for line in block.split_inclusive('\n') {
        let key = line.trim_start().split(['=', ' ', '\t']).next().unwrap_or_default();
        if key == field {
            found = offset;
            break;
        }
        offset += line.len();
    }
    1 + text[..start + found].matches('\n').count()
}

fn validate(raw: RawIdentity, model: &FaceModel, line_of: &dyn Fn(&str) -> usize) -> Result<Identity, IdentityError> {
    let fail = |field: &'static str, message: String| IdentityError::Invalid { id: raw.id.clone(), field, line: line_of(field), message };
    if raw.id.is_empty() || raw.id.len() > 40 || !raw.id.chars().all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_') {
        return Err(fail("id", "an id is 1 to 40 letters, digits, '-' and '_'".into()));
    }
    if raw.description.len() > 200 {
        return Err(fail("description", "is longer than 200 characters".into()));
    }
    if !(0.0..=1.0).contains(&raw.sex) {
        return Err(fail("sex", format!("sex {} is outside 0 (female) .. 1 (male)", raw.sex)));
    }
    if !(18.0..=90.0).contains(&raw.age) {
        return Err(fail("age", format!("age {} is outside 18..90", raw.age)));
    }
    let ancestry = raw.ancestry.normalised().ok_or_else(|| fail("ancestry", "ancestry weights must be non-negative and not all zero".into()))?;
    if raw.shape.len() > 64 {
        return Err(fail("shape", "more than 64 shape targets".into()));
    }
    for (name, weight) in &raw.shape {
        if !model.has_target(name) || !name.starts_with("identity/") {
            return Err(fail("shape", format!("shape target \"{}\" is not an identity target of the face model", excerpt(name))));
        }
        if !weight.is_finite() || weight.abs() > 2.0 {
            return Err(fail("shape", format!("shape weight {weight} for \"{name}\" is outside -2..2")));
        }
    }
    let ranges = [
        ("stubble", raw.stubble, 0.0..=1.0),
        ("hairline", raw.hairline, -0.3..=0.3),
        ("beard", raw.beard, 0.0..=MAX_BEARD_MM),
        ("hair_grey", raw.hair_grey.unwrap_or(0.0), 0.0..=1.0),
    ];
    for (field, value, range) in ranges {
        if !range.contains(&value) {
            return Err(fail(field, format!("{value} is outside {}..{}", range.start(), range.end())));
        }
    }
    let colour = |field: &'static str, text: &str| {
        parse_hex(text).ok_or_else(|| fail(field, format!("\"{}\" is not an sRGB hex colour like \"#c99a82\"", excerpt(text))))
    };
    let male = raw.sex > 0.5;
    let top = match &raw.top {
        Some(text) => colour("top", text)?,
        None => default_top(&raw.id),
    };
    Ok(Identity {
        skin: colour("skin", &raw.skin)?,
        iris: colour("iris", &raw.iris)?,
        hair: colour("hair", &raw.hair)?,
        lips: colour("lips", &raw.lips)?,
        top,
        hair_style: raw.hair_style.unwrap_or(if male { HairStyle::Short } else { HairStyle::Shoulder }),
        hair_texture: raw.hair_texture.unwrap_or_default(),
        hair_grey: raw.hair_grey.unwrap_or(0.0),
        parting: raw.parting.unwrap_or_else(|| default_parting(raw.hair_texture.unwrap_or_default())),
        id: raw.id,
        description: raw.description,
        sex: raw.sex,
        age: raw.age,
        ancestry,
        stubble: raw.stubble,
        hairline: raw.hairline,
        beard: raw.beard / 100.0,
        beard_style: raw.beard_style,
        shape: raw.shape,
    })
}

/// At most 40 characters of `text`, for messages.
fn excerpt(text: &str) -> String {
    let mut short: String = text.chars().take(40).collect();
    if short.len() < text.len() {
        short.push('…');
    }
    short
}

/// A plain top colour picked by the id, for identities that do not name one.
fn default_top(id: &str) -> Vec3 {
    const TOPS: [&str; 6] = ["#3b4a5c", "#5a5a5e", "#2f3e35", "#6b4f45", "#2b2b33", "#46526b"];
    let sum = id.bytes().fold(0usize, |a, b| a.wrapping_mul(31).wrapping_add(b as usize));
    parse_hex(TOPS[sum % TOPS.len()]).unwrap_or(Vec3::splat(0.05))
}

/// `#rrggbb` (sRGB) → linear RGB.
pub fn parse_hex(text: &str) -> Option<Vec3> {
    let hex = text.strip_prefix('#')?;
    if hex.len() != 6 || !hex.is_ascii() {
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
    fn the_shipped_people() {
        let table = IdentityTable::built_in();
        assert!(table.iter().count() >= 24);
        let first: Vec<&str> = table.iter().take(8).map(|i| i.id.as_str()).collect();
        assert_eq!(first, ["wm1", "wm2", "bm1", "bm2", "wf1", "wf2", "bf1", "bf2"]);
        let men = table.iter().take(8).filter(|i| i.sex > 0.5).count();
        let african = table.iter().take(8).filter(|i| i.ancestry.african > 0.5).count();
        assert_eq!((men, african), (4, 4));
        assert!(matches!(table.get("nobody"), Err(IdentityError::Unknown(_))));
    }

    /// Every person's shape carries the resting-face targets in proportion to how female it is;
    /// the four evaluation women, who had them written in their shapes, keep the totals they
    /// had (wf1 and wf2 0.3 and 0.25, bf1 and bf2 0.35 and 0.4).
    #[test]
    fn the_resting_face_follows_how_female_the_shape_is() {
        let total = |identity: &Identity, name: &str| identity.shape_weights().iter().filter(|(n, _)| n == name).map(|(_, w)| *w).sum::<f32>();
        let [brows, corners] = RESTING_FACE.map(|(name, _)| name);
        let table = IdentityTable::built_in();
        for (id, want) in [("wf1", [0.3, 0.25]), ("wf2", [0.3, 0.25]), ("bf1", [0.35, 0.4]), ("bf2", [0.35, 0.4]), ("wm1", [0.0, 0.0]), ("hlm2", [0.0, 0.0])] {
            let identity = table.get(id).unwrap();
            let got = [total(identity, brows), total(identity, corners)];
            assert!(got.iter().zip(want).all(|(g, w)| (g - w).abs() < 1e-6), "{id}: {got:?}, want {want:?}");
        }
        for identity in table.iter().filter(|i| i.sex == 0.0 && !["bf1", "bf2"].contains(&i.id.as_str())) {
            assert_eq!([total(identity, brows), total(identity, corners)], [0.3, 0.25], "{}", identity.id);
        }
        let halfway = IdentityTable::from_toml(&GOOD.replace("sex = 1", "sex = 0.5"), FaceModel::embedded()).unwrap();
        let x = halfway.get("x").unwrap();
        assert_eq!([total(x, brows), total(x, corners)], [0.15, 0.125]);
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

    const GOOD: &str = "[[identity]]\nid = \"x\"\ndescription = \"\"\nsex = 1\nage = 30\nancestry = { asian = 1 }\nskin = \"#000000\"\niris = \"#000000\"\nhair = \"#000000\"\nlips = \"#000000\"\n";

    #[test]
    fn bad_identities_are_named_with_field_and_line() {
        let text = GOOD.replace("sex = 1", "sex = 3");
        let err = IdentityTable::from_toml(&text, FaceModel::embedded()).unwrap_err().to_string();
        assert!(err.contains("\"x\"") && err.contains("`sex`") && err.contains("line 4"), "{err}");
        // The second person's bad colour is found on its own line.
        let two = format!("# people\n{GOOD}\n{}", GOOD.replace("\"x\"", "\"y\"").replace("lips = \"#000000\"", "lips = \"red\""));
        let err = IdentityTable::from_toml(&two, FaceModel::embedded()).unwrap_err().to_string();
        assert!(err.contains("line 22") && err.contains("`lips`") && err.contains("\"y\""), "{err}");
        let unknown = GOOD.replace("lips", "lipz");
        let err = IdentityTable::from_toml(&unknown, FaceModel::embedded()).unwrap_err();
        // The parser's message is in the error's own, and not again as its source.
        assert!(std::error::Error::source(&err).is_none(), "{err:?}");
        let err = err.to_string();
        assert!(err.contains("lipz") && err.contains("line 10"), "{err}");
        let style = format!("{GOOD}hair_style = \"mohawk\"\n");
        let err = IdentityTable::from_toml(&style, FaceModel::embedded()).unwrap_err().to_string();
        assert!(err.contains("mohawk") && err.contains("line 11"), "{err}");
        let handlebar = format!("{GOOD}beard = 8\nbeard_style = \"handlebar\"\n");
        let err = IdentityTable::from_toml(&handlebar, FaceModel::embedded()).unwrap_err().to_string();
        assert!(err.contains("handlebar") && err.contains("line 12"), "{err}");
        let long_beard = format!("{GOOD}beard = 25\n");
        let err = IdentityTable::from_toml(&long_beard, FaceModel::embedded()).unwrap_err().to_string();
        assert!(err.contains("`beard`") && err.contains("line 11") && err.contains("25 is outside 0..20"), "{err}");
    }

    /// A beard is written in millimetres and kept in decimetres, none by default; its style by
    /// name, full by default.
    #[test]
    fn a_beard_is_read_in_millimetres() {
        let table = IdentityTable::from_toml(&format!("{GOOD}beard = 8\n"), FaceModel::embedded()).unwrap();
        assert!((table.get("x").unwrap().beard - 0.08).abs() < 1e-7);
        assert_eq!(IdentityTable::from_toml(GOOD, FaceModel::embedded()).unwrap().get("x").unwrap().beard, 0.0);
        for style in BeardStyle::ALL {
            let text = format!("{GOOD}beard = 8\nbeard_style = \"{}\"\n", style.name());
            assert_eq!(IdentityTable::from_toml(&text, FaceModel::embedded()).unwrap().get("x").unwrap().beard_style, style);
        }
        assert_eq!(IdentityTable::from_toml(GOOD, FaceModel::embedded()).unwrap().get("x").unwrap().beard_style, BeardStyle::Full);
    }

    #[test]
    fn defaults_and_new_fields() {
        let text = format!("{GOOD}hair_style = \"bun\"\nhair_texture = \"coiled\"\nhair_grey = 0.5\nparting = \"centre\"\ntop = \"#ffffff\"\n");
        let table = IdentityTable::from_toml(&text, FaceModel::embedded()).unwrap();
        let x = table.get("x").unwrap();
        assert_eq!((x.hair_style, x.hair_texture, x.parting), (HairStyle::Bun, HairTexture::Coiled, Parting::Centre));
        assert_eq!((x.hair_grey, x.top), (0.5, Vec3::ONE));
        let plain = IdentityTable::from_toml(GOOD, FaceModel::embedded()).unwrap();
        assert_eq!(plain.get("x").unwrap().hair_style, HairStyle::Short);
        assert_eq!(plain.get("x").unwrap().parting, Parting::Left);
        // Coiled hair has no parting unless the file names one.
        let coiled = format!("{GOOD}hair_texture = \"coiled\"\n");
        let coiled = IdentityTable::from_toml(&coiled, FaceModel::embedded()).unwrap();
        assert_eq!(coiled.get("x").unwrap().parting, Parting::None);
    }
}
