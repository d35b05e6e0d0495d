//! The look of a frame around the face: backdrop, lighting preset and colour or greyscale.
//!
//! In: names as written on the command line or in a set spec (`grey`, `black`, `#RRGGBB`,
//! `transparent`; `studio`, `soft`, `dramatic`). Out: [`Look`], read by the shader (lights,
//! backdrop) and by [`super::render_still`] (greyscale, alpha).
//! Invariant: the default look is the studio light on the grey gradient in colour.

use std::fmt;
use std::str::FromStr;

use glam::Vec3;

/// Behind the head.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Backdrop {
    /// A dark grey vertical gradient, lighter at the top.
    #[default]
    Grey,
    Black,
    /// One flat colour (linear RGB), given as sRGB `#RRGGBB`.
    Colour(Vec3),
    /// No backdrop: an RGBA image whose backdrop pixels have alpha 0.
    Transparent,
}

impl Backdrop {
    /// The backdrop on row `y` of an image `height` rows high (black where transparent: the
    /// colour the edges are blended with before alpha is taken out again).
    pub fn colour(self, y: u32, height: u32) -> Vec3 {
        match self {
            Backdrop::Grey => {
                let t = y as f32 / height.max(1) as f32;
                Vec3::new(0.20, 0.21, 0.23).lerp(Vec3::new(0.11, 0.115, 0.125), t)
            }
            Backdrop::Black | Backdrop::Transparent => Vec3::ZERO,
            Backdrop::Colour(c) => c,
        }
    }
}

/// A named lighting set-up.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LightPreset {
    /// Warm key from the viewer's upper left, cool fill, rim light.
    #[default]
    Studio,
    /// Broad, even light with open shadows.
    Soft,
    /// A hard key from the side, little fill, strong rim.
    Dramatic,
}

/// A directional light.
#[derive(Debug, Clone, Copy)]
pub struct Light {
    /// Towards the light.
    pub direction: Vec3,
    pub colour: Vec3,
}

/// The lights of a preset: key (casts shadows and highlights), fill, rim; and the ambient
/// sky/ground terms and the fraction of the key that still reaches shadowed points.
#[derive(Debug, Clone, Copy)]
pub struct Lighting {
    pub lights: [Light; 3],
    pub sky: Vec3,
    pub ground: Vec3,
    pub shadow_floor: f32,
    /// The key light's size: the tangent of its angular radius seen from the face. A shadow's
    /// edge blurs over this times the distance from the caster on each side (the studio's
    /// 0.08: a soft box about 40 cm across at two and a half metres).
    pub key_size: f32,
}

impl LightPreset {
    pub const ALL: [LightPreset; 3] = [LightPreset::Studio, LightPreset::Soft, LightPreset::Dramatic];

    pub fn name(self) -> &'static str {
        match self {
            LightPreset::Studio => "studio",
            LightPreset::Soft => "soft",
            LightPreset::Dramatic => "dramatic",
        }
    }

    pub fn lighting(self) -> Lighting {
        let light = |d: [f32; 3], c: [f32; 3]| Light { direction: Vec3::from(d).normalize(), colour: Vec3::from(c) };
        match self {
            LightPreset::Studio => Lighting {
                lights: [light([-0.5, 0.5, 0.71], [1.3, 1.21, 1.12]), light([0.75, 0.0, 0.65], [0.22, 0.24, 0.28]), light([0.3, 0.6, -0.75], [0.35, 0.35, 0.35])],
                sky: Vec3::new(0.16, 0.17, 0.19),
                ground: Vec3::new(0.07, 0.06, 0.055),
                shadow_floor: 0.15,
                key_size: 0.08,
            },
            LightPreset::Soft => Lighting {
                lights: [light([-0.3, 0.45, 0.85], [0.95, 0.92, 0.88]), light([0.6, 0.1, 0.8], [0.42, 0.43, 0.45]), light([0.2, 0.5, -0.8], [0.2, 0.2, 0.2])],
                sky: Vec3::new(0.26, 0.26, 0.27),
                ground: Vec3::new(0.13, 0.12, 0.11),
                shadow_floor: 0.4,
                key_size: 0.16,
            },
            LightPreset::Dramatic => Lighting {
                lights: [light([-0.85, 0.35, 0.4], [1.75, 1.6, 1.45]), light([0.8, 0.0, 0.6], [0.05, 0.055, 0.065]), light([0.6, 0.5, -0.6], [0.7, 0.72, 0.78])],
                sky: Vec3::new(0.05, 0.05, 0.06),
                ground: Vec3::new(0.02, 0.02, 0.02),
                shadow_floor: 0.04,
                key_size: 0.03,
            },
        }
    }
}

/// Everything about a frame that is not the face itself.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Look {
    pub backdrop: Backdrop,
    pub light: LightPreset,
    /// Black-and-white output (luminance of the colour image, Rec. 709 weights, in linear light).
    pub grayscale: bool,
}

impl Look {
    /// The look named by optional backdrop and light names (absent: the defaults, grey and
    /// studio), as set specs and the studio's render requests give them.
    pub fn parse(backdrop: Option<&str>, light: Option<&str>, grayscale: bool) -> Result<Look, LookError> {
        let defaults = Look::default();
        Ok(Look {
            backdrop: backdrop.map(str::parse).transpose()?.unwrap_or(defaults.backdrop),
            light: light.map(str::parse).transpose()?.unwrap_or(defaults.light),
            grayscale,
        })
    }
}

/// A backdrop or light name that is not known.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LookError {
    #[error("backdrop \"{0}\" is not grey, black, transparent or a colour like #808080")]
    Backdrop(String),
    #[error("light \"{0}\" is not studio, soft or dramatic")]
    Light(String),
}

fn excerpt(text: &str) -> String {
    text.chars().take(40).collect()
}

impl FromStr for Backdrop {
    type Err = LookError;

    fn from_str(text: &str) -> Result<Backdrop, LookError> {
        match text {
            "grey" | "gray" => Ok(Backdrop::Grey),
            "black" => Ok(Backdrop::Black),
            "transparent" => Ok(Backdrop::Transparent),
            _ => {
                let lower = text.to_ascii_lowercase();
                super::identity::parse_hex(&lower).map(Backdrop::Colour).ok_or_else(|| LookError::Backdrop(excerpt(text)))
            }
        }
    }
}

impl fmt::Display for Backdrop {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Backdrop::Grey => f.write_str("grey"),
            Backdrop::Black => f.write_str("black"),
            Backdrop::Transparent => f.write_str("transparent"),
            Backdrop::Colour(c) => {
                let [r, g, b] = [c.x, c.y, c.z].map(super::image::linear_to_srgb8);
                write!(f, "#{r:02x}{g:02x}{b:02x}")
            }
        }
    }
}

impl FromStr for LightPreset {
    type Err = LookError;

    fn from_str(text: &str) -> Result<LightPreset, LookError> {
        LightPreset::ALL.into_iter().find(|l| l.name() == text).ok_or_else(|| LookError::Light(excerpt(text)))
    }
}

impl fmt::Display for LightPreset {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_parse_and_print_back() {
        for text in ["grey", "black", "transparent", "#1a2b3c"] {
            assert_eq!(text.parse::<Backdrop>().unwrap().to_string(), text);
        }
        assert_eq!("#1A2B3C".parse::<Backdrop>().unwrap().to_string(), "#1a2b3c");
        for preset in LightPreset::ALL {
            assert_eq!(preset.name().parse::<LightPreset>().unwrap(), preset);
        }
        assert!(matches!("white".parse::<Backdrop>(), Err(LookError::Backdrop(_))));
        assert!(matches!("#12345".parse::<Backdrop>(), Err(LookError::Backdrop(_))));
        assert!(matches!("noon".parse::<LightPreset>(), Err(LookError::Light(_))));
    }

    #[test]
    fn the_studio_preset_is_the_default_and_keys_are_unit_vectors() {
        assert_eq!(Look::default().light, LightPreset::Studio);
        for preset in LightPreset::ALL {
            for light in preset.lighting().lights {
                assert!((light.direction.length() - 1.0).abs() < 1e-5);
            }
        }
    }
}
