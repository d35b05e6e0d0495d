//! The cartoon style: the same posed geometry drawn flat-toned, with outlines and simplified
//! eyes (seed 004's second avatar, so one curve set drives both styles).
//!
//! In: the scene items of a frame (posed head, body, hair), the camera, the person and the
//! look. Out: an [`RgbImage`] of the frame's size.
//!
//! Stages, each plain data to the next:
//! 1. **Tones** ([`CartoonShader`] through [`raster::render`]): every surface takes one flat
//!    colour per region (skin, lips, mouth, brows, hair, lash line, top, teeth, tongue), lit in
//!    two bands by the key light (lit where `n·l` > [`TERMINATOR`], else [`SHADE`] of it);
//!    eyes are a white ball with a solid dark iris disc and one catchlight, unlit.
//! 2. **Regions**: the same shader without the bands gives each region's plain colour (the
//!    mouth, teeth and tongue as one region).
//! 3. **Depth**: [`raster::nearest_distances`] at one sample per pixel.
//! 4. **Outlines**: a pixel is on an outline where a neighbour's region colour differs by more
//!    than [`REGION_STEP`] or its depth by more than [`DEPTH_STEP`] (silhouettes, the jaw over
//!    the neck, lips, brows, eyes); the line is widened to about 1/240 of the image height.
//!
//! Invariant: a pure function of its inputs, with the rasteriser's tile invariant, so the
//! same frame gives the same bytes on any number of threads; the realistic path is untouched.

use std::str::FromStr;

use glam::Vec3;

use super::asset::Part;
use super::body::Body;
use super::camera::Camera;
use super::identity::Identity;
use super::image::RgbImage;
use super::look::Look;
use super::pose::Posed;
use super::raster::{self, Fragment, RenderOptions, SampleCount, Shader, Triangles};
use super::shade::{below_neckline, SkinPaint};
use super::{BODY_PART, HAIR_PART};

/// How a face is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash, PartialOrd, Ord, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Style {
    /// The shaded, textured face (the engine's own).
    #[default]
    Realistic,
    /// Flat tones, outlines, simplified eyes.
    Cartoon,
}

impl Style {
    pub const ALL: [Style; 2] = [Style::Realistic, Style::Cartoon];

    pub fn name(self) -> &'static str {
        match self {
            Style::Realistic => "realistic",
            Style::Cartoon => "cartoon",
        }
    }
}

impl std::fmt::Display for Style {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// A style name that is not known.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("style \"{0}\" is not realistic or cartoon")]
pub struct StyleError(pub String);

impl FromStr for Style {
    type Err = StyleError;
    fn from_str(text: &str) -> Result<Style, StyleError> {
        Style::ALL.into_iter().find(|s| s.name() == text).ok_or_else(|| StyleError(text.chars().take(24).collect()))
    }
}

/// `n·l` of the key light above which a surface takes the lit tone.
pub const TERMINATOR: f32 = 0.12;
/// The shaded tone as a fraction of the lit one (linear light).
pub const SHADE: f32 = 0.55;
/// Region colours that differ by more than this (sum of the sRGB channel differences) are
/// separated by an outline.
pub const REGION_STEP: u32 = 48;
/// Depths that differ by more than this (decimetres) are separated by an outline.
pub const DEPTH_STEP: f32 = 0.3;
/// The inside of the mouth.
const MOUTH: Vec3 = Vec3::new(0.22, 0.03, 0.04);
/// The outline's colour (sRGB).
const INK: [u8; 3] = [28, 20, 22];

/// Renders one cartoon frame of `scene` (the items of [`super::Scene`]).
pub(crate) fn render(scene: &[Triangles], camera: &Camera, parts: Parts, threads: Option<usize>) -> RgbImage {
    let options = RenderOptions { samples_per_pixel: SampleCount::X4, threads, backface_culling: true, shade_per_surface: true };
    let toned = raster::render(scene, camera, &CartoonShader { parts, banded: true }, &options);
    let regions = raster::render(scene, camera, &CartoonShader { parts, banded: false }, &options);
    let depth_options = RenderOptions { samples_per_pixel: SampleCount::X1, ..options };
    let depth = raster::nearest_distances(scene, camera, &depth_options);
    let width = (camera.height as f32 / 240.0).round().max(1.0) as i32;
    ink(toned, &edges(&regions, &depth), width)
}

/// What the cartoon shader draws from.
#[derive(Clone, Copy)]
pub(crate) struct Parts<'a> {
    pub posed: &'a Posed,
    pub identity: &'a Identity,
    pub body: &'a Body,
    pub look: Look,
    /// The image height (the backdrop's gradient spans it).
    pub height: u32,
    pub paint: &'a SkinPaint<'a>,
}

/// Flat tones per region; with `banded`, two bands of key light.
struct CartoonShader<'a> {
    parts: Parts<'a>,
    banded: bool,
}

impl CartoonShader<'_> {
    fn toned(&self, f: &Fragment, colour: Vec3) -> Vec3 {
        if !self.banded {
            return colour;
        }
        let key = self.parts.look.light.lighting().lights[0].direction;
        if f.normal.dot(key) > TERMINATOR { colour } else { colour * SHADE }
    }

    fn skin(&self, f: &Fragment) -> Vec3 {
        let identity = self.parts.identity;
        let paint = self.parts.paint.at(f);
        let colour = if paint.inside_mouth > 0.5 {
            return MOUTH;
        } else if paint.lash_line > 0.5 {
            return Vec3::splat(0.02);
        } else if paint.brow > 0.4 || paint.hair > 0.5 {
            identity.hair * if paint.brow > 0.4 { 0.6 } else { 1.0 }
        } else if paint.lips > 0.5 {
            identity.lips * Vec3::new(1.1, 0.85, 0.85)
        } else {
            identity.skin * 1.1
        };
        self.toned(f, colour)
    }

    /// A white ball, a solid dark iris disc and one catchlight up and to the side.
    fn eye(&self, f: &Fragment, side: usize) -> Vec3 {
        let eye = self.parts.posed.eyes[side];
        let d = (f.position - eye.centre).normalize();
        if d.dot(eye.gaze) > 0.80 {
            let right = eye.up.cross(eye.gaze);
            let glint = (eye.gaze + 0.35 * eye.up + 0.25 * right).normalize();
            return if d.dot(glint) > 0.985 { Vec3::splat(1.0) } else { self.parts.identity.iris * 0.25 };
        }
        Vec3::new(0.92, 0.92, 0.90)
    }

    fn body(&self, f: &Fragment) -> Vec3 {
        let identity = self.parts.identity;
        let colour = if below_neckline(Some(self.parts.body), f.position) < 0.0 { identity.skin * 1.1 } else { identity.top };
        self.toned(f, colour)
    }
}

impl Shader for CartoonShader<'_> {
    fn shade(&self, f: &Fragment) -> Vec3 {
        let identity = self.parts.identity;
        match f.part {
            BODY_PART => return self.body(f),
            HAIR_PART => return self.toned(f, identity.hair.lerp(Vec3::splat(0.55), 0.6 * identity.hair_grey)),
            _ => {}
        }
        match Part::from_id(f.part) {
            Some(Part::Skin) | None => self.skin(f),
            Some(Part::EyeLeft) => self.eye(f, 0),
            Some(Part::EyeRight) => self.eye(f, 1),
            // In the regions pass the mouth is one region, so teeth and tongue get no outlines.
            Some(Part::TeethUpper | Part::TeethLower | Part::Tongue) if !self.banded => MOUTH,
            Some(Part::TeethUpper | Part::TeethLower) => Vec3::new(0.85, 0.84, 0.78),
            Some(Part::Tongue) => Vec3::new(0.5, 0.12, 0.13),
            Some(Part::LashesUpper) => Vec3::splat(0.02),
            Some(Part::LashesLower) => self.toned(f, identity.skin * 1.1),
        }
    }

    fn background(&self, _x: u32, y: u32) -> Vec3 {
        self.parts.look.backdrop.colour(y, self.parts.height)
    }
}

/// The outline mask: pixels whose right or lower neighbour lies across a region or depth step.
fn edges(regions: &RgbImage, depth: &[f32]) -> Vec<bool> {
    let (w, h) = (regions.width as usize, regions.height as usize);
    let mut mask = vec![false; w * h];
    let differs = |a: usize, b: usize| {
        let (pa, pb) = (&regions.data[a * 3..a * 3 + 3], &regions.data[b * 3..b * 3 + 3]);
        let step: u32 = pa.iter().zip(pb).map(|(&x, &y)| x.abs_diff(y) as u32).sum();
        let (da, db) = (depth[a], depth[b]);
        let deep = if da.is_finite() && db.is_finite() { (da - db).abs() > DEPTH_STEP } else { da.is_finite() != db.is_finite() };
        step > REGION_STEP || deep
    };
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            for j in [(x + 1 < w).then_some(i + 1), (y + 1 < h).then_some(i + w)].into_iter().flatten() {
                if differs(i, j) {
                    // The line lies on the nearer surface.
                    let nearer = if depth[j] < depth[i] { j } else { i };
                    mask[nearer] = true;
                }
            }
        }
    }
    mask
}

/// Draws the outline mask, widened to `width` pixels, in ink over `image`.
fn ink(mut image: RgbImage, mask: &[bool], width: i32) -> RgbImage {
    let (w, h) = (image.width as i32, image.height as i32);
    let reach = -((width - 1) / 2)..=width / 2;
    for y in 0..h {
        for x in 0..w {
            let near = reach.clone().any(|dy| {
                reach.clone().any(|dx| {
                    let (nx, ny) = (x + dx, y + dy);
                    nx >= 0 && ny >= 0 && nx < w && ny < h && mask[(ny * w + nx) as usize]
                })
            });
            if near {
                image.set_pixel(x as u32, y as u32, INK);
            }
        }
    }
    image
}
