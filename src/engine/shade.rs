//! Shading: what each visible point of the head looks like.
//!
//! In: a [`Fragment`] from the rasteriser (position, normal, which vertices and where between
//! them), the [`Posed`] head and the [`Identity`]. Out: linear RGB. The face's painted features
//! (lips, brows, hair, stubble, wrinkles) are functions of the *rest* position of the base mesh,
//! interpolated across each triangle, so they move with the skin when AUs deform it.
//!
//! Appearance channels (`shade:NAME` in the AU basis), each a furrow/bulge height field:
//! `forehead_inner`, `forehead_outer`, `glabella_vertical`, `glabella_horizontal`, `crows_feet`,
//! `lower_lid_bulge`, `nose_wrinkles`, `nasolabial`, `dimple`, `chin_boss`, `lip_press_bulge`.
//!
//! Invariant: a pure function of its inputs (no randomness but fixed hashes), so the same frame
//! shades to the same bytes on any thread.

use std::collections::BTreeMap;
use std::sync::{Arc, Mutex, OnceLock};

use glam::{Vec2, Vec3};

use super::asset::{FaceModel, Part};
use super::identity::Identity;
use super::pose::Posed;
use super::camera::Camera;
use super::raster::{self, Fragment, RenderOptions, SampleCount, Shader, Triangles};

/// Per-vertex region weights the shader reads.
struct Regions {
    lips: Vec<f32>,
    inside_mouth: Vec<f32>,
    ears: Vec<f32>,
}

fn regions(model: &FaceModel) -> &'static Regions {
    static REGIONS: OnceLock<Regions> = OnceLock::new();
    REGIONS.get_or_init(|| {
        let load = |name: &str| model.region(name).expect("the embedded face model has its regions");
        Regions { lips: load("lips"), inside_mouth: load("inside_mouth"), ears: load("ears") }
    })
}

/// A directional light.
struct Light {
    direction: Vec3,
    colour: Vec3,
}

/// The studio: a warm key light from the viewer's upper left, a cool fill, a rim light and a
/// sky/ground ambient term.
fn lights() -> [Light; 3] {
    [
        Light { direction: key_light_direction(), colour: Vec3::new(1.3, 1.21, 1.12) },
        Light { direction: Vec3::new(0.75, 0.0, 0.65).normalize(), colour: Vec3::new(0.22, 0.24, 0.28) },
        Light { direction: Vec3::new(0.3, 0.6, -0.75).normalize(), colour: Vec3::new(0.35, 0.35, 0.35) },
    ]
}

const SKY: Vec3 = Vec3::new(0.16, 0.17, 0.19);
const GROUND: Vec3 = Vec3::new(0.07, 0.06, 0.055);

/// Depth of the head as seen from the key light, for cast shadows (the nose on the cheek, the
/// brow ridge on the eyes, the chin on the neck).
pub struct ShadowMap {
    camera: Camera,
    view: glam::Mat4,
    distance: Vec<f32>,
}

impl ShadowMap {
    /// Renders the depth of `scene` from the key light, aimed at `centre`.
    pub fn new(scene: &[Triangles], centre: Vec3, size: u32, threads: Option<usize>) -> ShadowMap {
        let camera = Camera {
            eye: centre + key_light_direction() * 60.0,
            target: centre,
            up: Vec3::Y,
            fov_y_degrees: 3.6,
            width: size,
            height: size,
        };
        let options = RenderOptions { samples_per_pixel: SampleCount::X1, threads, backface_culling: true, shade_per_surface: false };
        let distance = raster::nearest_distances(scene, &camera, &options);
        ShadowMap { view: camera.view(), camera, distance }
    }

    /// Fraction of the key light reaching `position` (0 = in shadow), softened over a 4×4 texel footprint.
    fn light(&self, position: Vec3) -> f32 {
        let h = self.camera.view_to_homogeneous_pixel(self.view.transform_point3(position));
        if h.z < self.camera.near() {
            return 1.0;
        }
        let p = Vec3::new(h.x / h.z, h.y / h.z, h.z);
        let (w, h) = (self.camera.width as i32, self.camera.height as i32);
        // Bilinear percentage-closer filtering over a 4×4 texel footprint.
        let (fx, fy) = (p.x - 0.5, p.y - 0.5);
        let (cx, cy) = (fx.floor() as i32, fy.floor() as i32);
        let (tx, ty) = (fx - cx as f32, fy - cy as f32);
        let bias = 0.035;
        let mut lit = 0.0;
        for dy in -1..=2 {
            let wy = match dy { -1 => 1.0 - ty, 2 => ty, _ => 1.0 };
            for dx in -1..=2 {
                let wx = match dx { -1 => 1.0 - tx, 2 => tx, _ => 1.0 };
                let (x, y) = ((cx + dx).clamp(0, w - 1), (cy + dy).clamp(0, h - 1));
                if p.z <= self.distance[(y * w + x) as usize] + bias {
                    lit += wx * wy;
                }
            }
        }
        lit / 9.0
    }
}

fn key_light_direction() -> Vec3 {
    Vec3::new(-0.5, 0.5, 0.71).normalize()
}

/// Slowly varying painted features and region weights of one skin vertex, interpolated across
/// triangles together.
#[derive(Clone, Copy, Debug, Default)]
struct SkinVertex {
    mottle: f32,
    cheek: f32,
    oily: f32,
    beard: f32,
    hair: f32,
    lips: f32,
    inside_mouth: f32,
}

impl SkinVertex {
    const FIELDS: usize = 7;

    fn to_array(self) -> [f32; Self::FIELDS] {
        [self.mottle, self.cheek, self.oily, self.beard, self.hair, self.lips, self.inside_mouth]
    }

    fn from_array(a: [f32; Self::FIELDS]) -> SkinVertex {
        let [mottle, cheek, oily, beard, hair, lips, inside_mouth] = a;
        SkinVertex { mottle, cheek, oily, beard, hair, lips, inside_mouth }
    }
}

/// The painted features of one person's skin, per skin vertex (they depend only on the rest
/// mesh, stubble and hairline).
struct SkinMaps {
    vertices: Vec<[f32; SkinVertex::FIELDS]>,
}

impl SkinMaps {
    /// The maps of `identity`, computed once per person and shared by every frame.
    fn cached(model: &FaceModel, identity: &Identity) -> Arc<SkinMaps> {
        type Key = (String, u32, u32);
        static CACHE: OnceLock<Mutex<BTreeMap<Key, Arc<SkinMaps>>>> = OnceLock::new();
        let key = (identity.id.clone(), identity.stubble.to_bits(), identity.hairline.to_bits());
        let made: Result<_, std::convert::Infallible> = super::cached(CACHE.get_or_init(Default::default), key, || Ok(SkinMaps::new(model, identity)));
        made.unwrap_or_else(|never| match never {})
    }

    fn new(model: &FaceModel, identity: &Identity) -> SkinMaps {
        let skin = &model.rest[..model.part(Part::Skin).vertices.end as usize];
        let regions = regions(model);
        let vertices = skin
            .iter()
            .enumerate()
            .map(|(i, &p)| {
                SkinVertex {
                    mottle: 1.0 + 0.06 * (fbm(p * 40.0) - 0.5),
                    cheek: blob(Vec2::new(p.x.abs(), p.y), Vec2::new(0.38, 6.95), Vec2::new(0.14, 0.12)),
                    oily: blob(Vec2::new(p.x, p.y), Vec2::new(0.0, 7.3), Vec2::new(0.12, 0.7)),
                    beard: beard_mask(p) * identity.stubble,
                    hair: hair_mask(p, identity.hairline) * (1.0 - regions.ears[i]),
                    lips: regions.lips[i],
                    inside_mouth: regions.inside_mouth[i],
                }
                .to_array()
            })
            .collect();
        SkinMaps { vertices }
    }

    /// The features at a fragment of the skin.
    fn at(&self, f: &Fragment) -> SkinVertex {
        let [a, b, c] = f.vertex.map(|v| self.vertices[v as usize]);
        let w = f.barycentric;
        SkinVertex::from_array(std::array::from_fn(|k| a[k] * w.x + b[k] * w.y + c[k] * w.z))
    }
}

/// The appearance channels active in this frame, with their (left, right) weights.
type ActivePatterns = Vec<(Relief, f32, f32)>;

/// Shades the head for one frame.
pub struct FaceShader<'a> {
    maps: Arc<SkinMaps>,
    /// Fraction of the key light reaching each vertex (1 everywhere without a shadow map).
    key_light: Vec<f32>,
    patterns: ActivePatterns,
    /// The union of the active patterns' boxes: no relief outside it.
    relief_bounds: [f32; 4],
    model: &'a FaceModel,
    posed: &'a Posed,
    identity: &'a Identity,
    lights: [Light; 3],
    /// The backdrop's colour on each image row (a vertical gradient), worked out once.
    backdrop: Vec<Vec3>,
}

impl<'a> FaceShader<'a> {
    pub fn new(model: &'a FaceModel, posed: &'a Posed, identity: &'a Identity, height: u32) -> FaceShader<'a> {
        let patterns: ActivePatterns = PATTERNS
            .iter()
            .filter_map(|(name, pattern)| {
                let (l, r) = posed.appearance.get(*name).copied()?;
                (l != 0.0 || r != 0.0).then_some((*pattern, l, r))
            })
            .collect();
        let relief_bounds = patterns.iter().fold([f32::INFINITY, f32::NEG_INFINITY, f32::INFINITY, f32::NEG_INFINITY], |u, (r, _, _)| {
            let b = r.bounds;
            [u[0].min(b[0]), u[1].max(b[1]), u[2].min(b[2]), u[3].max(b[3])]
        });
        let maps = SkinMaps::cached(model, identity);
        let key_light = vec![1.0; posed.positions.len()];
        let backdrop = (0..height).map(|y| backdrop_colour(y, height)).collect();
        FaceShader { maps, key_light, patterns, relief_bounds, model, posed, identity, lights: lights(), backdrop }
    }

    /// Casts the key light's shadows from `shadow`, looked up once per vertex (offset along the
    /// normal so that surfaces do not shadow themselves) and interpolated across triangles.
    pub fn with_shadows(self, shadow: &ShadowMap) -> FaceShader<'a> {
        let key_light = self.posed.positions.iter().zip(&self.posed.normals).map(|(&p, &n)| shadow.light(p + n * 0.02)).collect();
        FaceShader { key_light, ..self }
    }

    fn interpolate(&self, values: &[f32], f: &Fragment) -> f32 {
        let [a, b, c] = f.vertex.map(|v| values[v as usize]);
        a * f.barycentric.x + b * f.barycentric.y + c * f.barycentric.z
    }

    fn rest(&self, f: &Fragment) -> Vec3 {
        let [a, b, c] = f.vertex.map(|v| self.model.rest[v as usize]);
        a * f.barycentric.x + b * f.barycentric.y + c * f.barycentric.z
    }

    /// How much a point at rest `x` belongs to the person's left side (1) or right side (0).
    fn left_weight(x: f32) -> f32 {
        smoothstep(-0.03, 0.03, x)
    }

    /// Total furrow/bulge height at a rest position (decimetres × pattern depth).
    fn relief(&self, p: Vec3) -> f32 {
        let [x0, x1, y0, y1] = self.relief_bounds;
        let x = p.x.abs();
        if x < x0 || x > x1 || p.y < y0 || p.y > y1 {
            return 0.0;
        }
        let mirrored = Vec2::new(p.x.abs(), p.y);
        let l = Self::left_weight(p.x);
        self.patterns.iter().map(|(relief, left, right)| (left * l + right * (1.0 - l)) * relief.at(mirrored)).sum()
    }

    fn lit(&self, f: &Fragment, normal: Vec3, albedo: Vec3, wrap: f32, specular: f32, shininess: f32) -> Vec3 {
        let view = f.view_dir;
        let ambient = SKY.lerp(GROUND, (0.5 - 0.5 * normal.y).clamp(0.0, 1.0));
        let mut colour = albedo * ambient;
        let key_reaches = self.interpolate(&self.key_light, f);
        for (n, light) in self.lights.iter().enumerate() {
            let reach = if n == 0 { 0.15 + 0.85 * key_reaches } else { 1.0 };
            let n_dot_l = normal.dot(light.direction);
            // Wrapped diffuse lets light bleed past the terminator, red most (subsurface look).
            let wrapped = Vec3::new(
                ((n_dot_l + wrap * 1.6) / (1.0 + wrap * 1.6)).max(0.0),
                ((n_dot_l + wrap) / (1.0 + wrap)).max(0.0),
                ((n_dot_l + wrap * 0.8) / (1.0 + wrap * 0.8)).max(0.0),
            );
            colour += albedo * light.colour * wrapped * reach;
            // Only the key light is bright enough to give a visible highlight.
            if n == 0 && n_dot_l > 0.0 && specular != 0.0 {
                let half = (light.direction + view).normalize();
                let fresnel = 0.04 + 0.96 * (1.0 - view.dot(half).max(0.0)).powi(5);
                let lobe = lobe_power(normal.dot(half).max(0.0), shininess) * (shininess + 8.0) / 25.0;
                colour += light.colour * specular * fresnel * lobe * n_dot_l * reach;
            }
        }
        colour
    }

    fn shade_skin(&self, f: &Fragment) -> Vec3 {
        let rest = self.rest(f);
        let identity = self.identity;
        let painted = self.maps.at(f);
        let lips = smoothstep(0.3, 0.7, painted.lips);
        let mouth = painted.inside_mouth;

        // Surface relief: wrinkles and furrows as a bump map in rest space.
        let mut normal = f.normal;
        let mut crease = 0.0;
        let h = if self.patterns.is_empty() { 0.0 } else { self.relief(rest) };
        if h != 0.0 {
            let e = 0.003;
            let gx = (self.relief(rest + Vec3::X * e) - h) / e;
            let gy = (self.relief(rest + Vec3::Y * e) - h) / e;
            normal = (normal - 0.006 * (gx * Vec3::X + gy * Vec3::Y)).normalize();
            crease = (-h).max(0.0);
        }

        // Albedo: skin with mottling, cheeks, lips, stubble, brows, hair, mouth interior. Each
        // layer is blended in only where it is present (blending by 0 leaves the value as it is).
        let mut albedo = identity.skin * painted.mottle;
        let cheek = painted.cheek;
        if cheek != 0.0 {
            albedo = albedo.lerp(albedo * Vec3::new(1.08, 0.9, 0.88), 0.5 * cheek);
        }
        if lips != 0.0 {
            albedo = albedo.lerp(identity.lips, lips);
        }
        let beard = painted.beard * (1.0 - lips);
        if beard > 0.0 {
            let dots = smoothstep(0.4, 0.8, value_noise(rest * 260.0));
            albedo = albedo.lerp(identity.hair * 0.6 + identity.skin * 0.25, beard * (0.35 + 0.5 * dots));
        }
        let hair = painted.hair;
        if hair > 0.0 {
            let hair_albedo = identity.hair * (0.75 + 0.5 * strands(rest));
            albedo = albedo.lerp(hair_albedo, hair);
        }
        let brow = brow_mask(rest);
        if brow != 0.0 {
            albedo = albedo.lerp(identity.hair * 0.8, brow);
        }
        if crease != 0.0 {
            albedo *= 1.0 - 0.15 * crease.min(1.0);
        }
        let oily = painted.oily;
        let specular = (0.35 + 0.35 * oily) * (1.0 - hair) * (1.0 - 0.8 * brow) + 0.6 * lips;
        let shininess = 18.0 + 30.0 * lips;
        let mut colour = self.lit(f, normal, albedo, 0.35 * (1.0 - hair), specular, shininess);
        // The mouth interior is dark, more so the deeper it lies behind the lips.
        if mouth > 0.0 {
            let depth = (1.52 - rest.z).max(0.0);
            let interior = Vec3::new(0.16, 0.035, 0.035) * (-depth * 7.0).exp();
            colour = colour.lerp(interior, (mouth * 1.5).min(1.0));
        }
        // The neck fades into the background above the cut, like a vignetted portrait.
        let fade = smoothstep(5.86, 6.18, rest.y);
        if fade == 1.0 { colour } else { colour.lerp(self.background(f.pixel.0, f.pixel.1), 1.0 - fade) }
    }

    fn shade_eye(&self, f: &Fragment, side: usize) -> Vec3 {
        let eye = self.posed.eyes[side];
        let d = (f.position - eye.centre).normalize();
        let angle = d.dot(eye.gaze).clamp(-1.0, 1.0).acos();
        let right = eye.up.cross(eye.gaze);
        let around = d.dot(right).atan2(d.dot(eye.up));
        let iris_edge = 0.52;
        let pupil = 0.19;
        let sclera = Vec3::new(0.80, 0.76, 0.72).lerp(Vec3::new(0.75, 0.55, 0.50), smoothstep(0.9, 1.5, angle));
        let fibres = 0.75 + 0.5 * value_noise(Vec3::new(around * 14.0, angle * 30.0, 0.0));
        let iris = self.identity.iris * fibres * (1.0 - 0.55 * smoothstep(iris_edge - 0.12, iris_edge, angle));
        let mut albedo = sclera.lerp(iris, 1.0 - smoothstep(iris_edge - 0.015, iris_edge + 0.015, angle));
        albedo = albedo.lerp(Vec3::splat(0.01), 1.0 - smoothstep(pupil - 0.02, pupil + 0.01, angle));
        // The upper lid shades the top of the eyeball.
        let lid_shadow = 1.0 - 0.45 * smoothstep(0.1, 0.7, d.dot(eye.up));
        let colour = self.lit(f, d, albedo * lid_shadow, 0.1, 0.0, 1.0);
        colour + self.cornea_highlight(d, f.view_dir) * self.interpolate(&self.key_light, f)
    }

    fn cornea_highlight(&self, normal: Vec3, view: Vec3) -> Vec3 {
        let key = &self.lights[0];
        let half = (key.direction + view).normalize();
        key.colour * 0.9 * normal.dot(half).max(0.0).powf(600.0)
    }

    fn shade_mouth_part(&self, f: &Fragment, base: Vec3, specular: f32) -> Vec3 {
        let rest = self.rest(f);
        // Inside the mouth little light arrives: dim everything, and more with depth.
        let depth = (1.50 - rest.z).max(0.0);
        let colour = self.lit(f, f.normal, base, 0.2, specular, 40.0);
        colour * 0.7 * (-depth * 6.0).exp()
    }

    /// Lower lashes are sparse and short: mostly the lid's own tone, a little darker.
    fn shade_skin_tone_lash(&self, f: &Fragment) -> Vec3 {
        let albedo = self.identity.skin.lerp(self.identity.hair, 0.12) * 0.85;
        self.lit(f, f.normal, albedo, 0.3, 0.0, 1.0)
    }

    /// The eye sockets' own shading for the eyeball parts depends on which eye it is.
    fn eye_index(part: Part) -> usize {
        if part == Part::EyeLeft { 0 } else { 1 }
    }
}

impl Shader for FaceShader<'_> {
    fn shade(&self, f: &Fragment) -> Vec3 {
        match Part::from_id(f.part) {
            Some(Part::Skin) | None => self.shade_skin(f),
            Some(part @ (Part::EyeLeft | Part::EyeRight)) => self.shade_eye(f, Self::eye_index(part)),
            Some(Part::TeethUpper | Part::TeethLower) => {
                // Gaps between teeth: narrow dark lines at each tooth's edge across the arch.
                let x = self.rest(f).x.abs();
                let widths = [0.0, 0.08, 0.14, 0.2, 0.26];
                let gap = widths.iter().map(|&w| (-((x - w) / 0.004).powi(2)).exp()).fold(0.0, f32::max);
                let enamel = Vec3::new(0.70, 0.66, 0.56) * (1.0 - 0.55 * gap);
                self.shade_mouth_part(f, enamel, 0.5)
            }
            Some(Part::Tongue) => self.shade_mouth_part(f, Vec3::new(0.45, 0.12, 0.12), 0.3),
            Some(Part::LashesUpper) => self.identity.hair * 0.3 + Vec3::splat(0.012),
            Some(Part::LashesLower) => self.shade_skin_tone_lash(f),
        }
    }

    fn background(&self, _x: u32, y: u32) -> Vec3 {
        let height = self.backdrop.len() as u32;
        self.backdrop.get(y as usize).copied().unwrap_or_else(|| backdrop_colour(y, height))
    }
}

/// The backdrop on row `y` of an image `height` rows high: lighter at the top.
fn backdrop_colour(y: u32, height: u32) -> Vec3 {
    let t = y as f32 / height.max(1) as f32;
    Vec3::new(0.20, 0.21, 0.23).lerp(Vec3::new(0.11, 0.115, 0.125), t)
}

// ---- painted features (rest space, decimetres; x is the person's left) ----

/// `x^e` for a specular lobe: a whole exponent up to 64 (the skin's 18, the mouth's 40) by
/// repeated multiplication, within 10⁻⁵ of `powf` relative to the value (far below a colour
/// step) and without its cost; others by `powf`.
fn lobe_power(x: f32, e: f32) -> f32 {
    let whole = e as i32;
    if whole as f32 == e && (1..=64).contains(&whole) { x.powi(whole) } else { x.powf(e) }
}

fn smoothstep(edge0: f32, edge1: f32, x: f32) -> f32 {
    // Outside the edges the ramp below is exactly 0 or 1 (rounding is monotonic); most points
    // of a face are, so they skip its division.
    let (below, above) = if edge0 < edge1 { (x <= edge0, x >= edge1) } else { (x >= edge0, x <= edge1) };
    if below {
        return 0.0;
    }
    if above {
        return 1.0;
    }
    let t = ((x - edge0) / (edge1 - edge0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// A soft elliptical blob: 1 at `centre`, 0 beyond `radii`.
fn blob(p: Vec2, centre: Vec2, radii: Vec2) -> f32 {
    let d = ((p - centre) / radii).length();
    1.0 - smoothstep(0.0, 1.0, d)
}

/// Brows: a tapered arch above each eye, drawn as hair strands.
fn brow_mask(rest: Vec3) -> f32 {
    if rest.z < 1.1 {
        return 0.0;
    }
    // The brow's centre line stays within [7.405, 7.51] and its half-width below 0.036, so
    // beyond 1.25 half-widths of that band (with a margin) the mask is zero: skip the rest.
    if !(7.35..=7.57).contains(&rest.y) {
        return 0.0;
    }
    let x = rest.x.abs();
    let t = (x - 0.075) / 0.44;
    if !(-0.02..=1.05).contains(&t) {
        return 0.0;
    }
    let t_raw = t;
    let t = t.clamp(0.0, 1.0);
    let centre = 7.44 + 0.07 * (std::f32::consts::PI * t.powf(0.7)).sin() - 0.035 * t;
    let half = 0.030 * (1.0 - 0.55 * t) + 0.006;
    let across = (rest.y - centre) / half;
    // Beyond 1.25 half-widths the body below is zero whatever the strand noise (at most 1).
    if across.abs() > 1.25 {
        return 0.0;
    }
    // Strands lean outward and upward near the head of the brow, outward along the tail.
    let strand = value_noise(Vec3::new((x - rest.y * (0.9 - 0.8 * t)) * 300.0, rest.y * 20.0, 0.5));
    let body = 1.0 - smoothstep(0.55, 1.0 + 0.25 * strand, across.abs());
    let ends = smoothstep(0.0, 0.1, t_raw + 0.02 * (strand - 0.5)) * (1.0 - smoothstep(0.9, 1.04, t));
    (body * ends * (0.75 + 0.35 * strand)).clamp(0.0, 1.0)
}

/// Scalp hair: above a hairline that runs high over the forehead and low at the nape.
fn hair_mask(rest: Vec3, raise: f32) -> f32 {
    let x = rest.x.abs();
    // Hairline height as a smooth function of depth: high over the forehead, down over the
    // temples and ears, low at the nape.
    let front = 8.02 + 2.4 * (x - 0.35).max(0.0).powi(2);
    let profile = [(0.0, 6.75), (0.35, 7.25), (0.85, 7.6), (1.15, front)];
    let z = rest.z.clamp(0.0, 1.15);
    let line = profile
        .windows(2)
        .find(|w| z <= w[1].0)
        .map_or(front, |w| {
            let t = smoothstep(w[0].0, w[1].0, z);
            w[0].1 + (w[1].1 - w[0].1) * t
        });
    let edge = 0.025 + 0.02 * value_noise(rest * 90.0);
    smoothstep(line + raise - edge, line + raise + edge, rest.y)
}

/// Beard shadow: jaw, chin and upper lip, below the cheeks.
fn beard_mask(rest: Vec3) -> f32 {
    let x = rest.x.abs();
    if rest.z < 0.6 {
        return 0.0;
    }
    let upper_lip = blob(Vec2::new(x, rest.y), Vec2::new(0.0, 6.78), Vec2::new(0.22, 0.08));
    let jaw_top = 6.85 - 0.35 * (x / 0.7).powi(2);
    let jaw = smoothstep(jaw_top + 0.05, jaw_top - 0.08, rest.y) * smoothstep(6.0, 6.2, rest.y);
    upper_lip.max(jaw)
}

/// Fine streaks along the hair's flow (back and down).
fn strands(rest: Vec3) -> f32 {
    value_noise(Vec3::new(rest.x * 220.0, rest.y * 12.0, rest.z * 30.0))
}

// ---- furrows and bulges: height fields in mirrored rest space (x ≥ 0) ----

type Pattern = fn(Vec2) -> f32;

/// A pattern with the box (mirrored rest space: x min, x max, y min, y max) outside which it
/// is zero to within rounding, so most fragments skip it.
#[derive(Clone, Copy)]
struct Relief {
    pattern: Pattern,
    bounds: [f32; 4],
}

impl Relief {
    fn at(&self, p: Vec2) -> f32 {
        let [x0, x1, y0, y1] = self.bounds;
        if p.x < x0 || p.x > x1 || p.y < y0 || p.y > y1 { 0.0 } else { (self.pattern)(p) }
    }
}

const PATTERNS: [(&str, Relief); 11] = [
    ("forehead_inner", Relief { pattern: forehead_inner, bounds: [0.0, 0.32, 7.6, 8.05] }),
    ("forehead_outer", Relief { pattern: forehead_outer, bounds: [0.08, 0.6, 7.55, 8.0] }),
    ("glabella_vertical", Relief { pattern: glabella_vertical, bounds: [0.0, 0.1, 7.35, 7.62] }),
    ("glabella_horizontal", Relief { pattern: glabella_horizontal, bounds: [0.0, 0.12, 7.32, 7.44] }),
    ("crows_feet", Relief { pattern: crows_feet, bounds: [0.45, 0.64, 7.18, 7.42] }),
    ("lower_lid_bulge", Relief { pattern: lower_lid_bulge, bounds: [0.14, 0.47, 7.08, 7.22] }),
    ("nose_wrinkles", Relief { pattern: nose_wrinkles, bounds: [0.0, 0.17, 7.14, 7.36] }),
    ("nasolabial", Relief { pattern: nasolabial, bounds: [0.09, 0.35, 6.5, 7.0] }),
    ("dimple", Relief { pattern: dimple, bounds: [0.22, 0.34, 6.56, 6.68] }),
    ("chin_boss", Relief { pattern: chin_boss, bounds: [0.0, 0.2, 6.2, 6.52] }),
    ("lip_press_bulge", Relief { pattern: lip_press_bulge, bounds: [0.0, 0.24, 6.41, 6.8] }),
];

/// A groove of unit depth along a line at distance `d`, with half-width `w`: a Gaussian
/// profile, taken as flat beyond six half-widths (where it is below 3·10⁻¹⁶).
fn groove(d: f32, w: f32) -> f32 {
    let s = (d / w).powi(2);
    if s > 36.0 { 0.0 } else { -(-s).exp() }
}

fn segment_distance(p: Vec2, a: Vec2, b: Vec2) -> f32 {
    segment_distance_squared(p, a, b).sqrt()
}

fn segment_distance_squared(p: Vec2, a: Vec2, b: Vec2) -> f32 {
    let ab = b - a;
    let t = ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0);
    (p - (a + ab * t)).length_squared()
}

/// The distance to the nearest segment: one square root of the smallest squared distance,
/// the same value as the smallest distance (the square root is correctly rounded, so monotonic).
fn polyline_distance(p: Vec2, points: &[Vec2]) -> f32 {
    points.windows(2).map(|w| segment_distance_squared(p, w[0], w[1])).fold(f32::INFINITY, f32::min).sqrt()
}

fn forehead_inner(p: Vec2) -> f32 {
    let span = 1.0 - smoothstep(0.14, 0.30, p.x);
    let lines: f32 = [7.72, 7.80, 7.89].iter().map(|&y| groove(p.y - (y + 0.1 * p.x * p.x), 0.013)).sum();
    span * lines
}

fn forehead_outer(p: Vec2) -> f32 {
    let span = smoothstep(0.10, 0.22, p.x) * (1.0 - smoothstep(0.45, 0.58, p.x));
    let lines: f32 = [7.69, 7.77, 7.86].iter().map(|&y| groove(p.y - (y - 0.25 * (p.x - 0.3).powi(2)), 0.013)).sum();
    span * lines
}

fn glabella_vertical(p: Vec2) -> f32 {
    let d = segment_distance(p, Vec2::new(0.035, 7.40), Vec2::new(0.05, 7.57));
    1.2 * groove(d, 0.012)
}

fn glabella_horizontal(p: Vec2) -> f32 {
    let d = segment_distance(p, Vec2::new(0.0, 7.37), Vec2::new(0.075, 7.39));
    groove(d, 0.010)
}

fn crows_feet(p: Vec2) -> f32 {
    let origin = Vec2::new(0.485, 7.29);
    // Unit directions at -0.45, -0.15, 0.15 and 0.45 rad from the horizontal.
    const FAN: [Vec2; 4] = [
        Vec2::new(0.900_447, -0.434_966),
        Vec2::new(0.988_771, -0.149_438),
        Vec2::new(0.988_771, 0.149_438),
        Vec2::new(0.900_447, 0.434_966),
    ];
    FAN.iter()
        .map(|dir| segment_distance(p, origin + *dir * 0.02, origin + *dir * 0.11))
        .map(|d| 0.8 * groove(d, 0.009))
        .sum()
}

fn lower_lid_bulge(p: Vec2) -> f32 {
    let bulge = blob(p, Vec2::new(0.30, 7.165), Vec2::new(0.12, 0.035));
    bulge * 0.8 + 0.6 * groove(polyline_distance(p, &[Vec2::new(0.2, 7.135), Vec2::new(0.3, 7.125), Vec2::new(0.41, 7.15)]), 0.008)
}

fn nose_wrinkles(p: Vec2) -> f32 {
    let span = 1.0 - smoothstep(0.08, 0.15, p.x);
    let lines: f32 = [7.20, 7.25, 7.30].iter().map(|&y| groove(p.y - (y - 0.6 * p.x * p.x), 0.011)).sum();
    span * lines
}

fn nasolabial(p: Vec2) -> f32 {
    let fold = [Vec2::new(0.15, 6.94), Vec2::new(0.20, 6.82), Vec2::new(0.25, 6.70), Vec2::new(0.285, 6.58)];
    1.3 * groove(polyline_distance(p, &fold), 0.024)
}

fn dimple(p: Vec2) -> f32 {
    1.2 * groove((p - Vec2::new(0.28, 6.62)).length(), 0.016)
}

fn chin_boss(p: Vec2) -> f32 {
    let area = blob(p, Vec2::new(0.0, 6.33), Vec2::new(0.15, 0.09));
    let dimples = value_noise(Vec3::new(p.x * 45.0, p.y * 45.0, 3.0)) - 0.5;
    area * dimples * 0.6 + groove(polyline_distance(p, &[Vec2::new(0.0, 6.45), Vec2::new(0.12, 6.47)]), 0.012)
}

fn lip_press_bulge(p: Vec2) -> f32 {
    blob(p, Vec2::new(0.0, 6.755), Vec2::new(0.2, 0.03)) + blob(p, Vec2::new(0.0, 6.46), Vec2::new(0.18, 0.03))
}

// ---- deterministic noise ----

fn hash(x: i32, y: i32, z: i32) -> f32 {
    let mut h = (x as u32).wrapping_mul(0x8da6_b343) ^ (y as u32).wrapping_mul(0xd816_3841) ^ (z as u32).wrapping_mul(0xcb1a_b31f);
    h ^= h >> 13;
    h = h.wrapping_mul(0x5bd1_e995);
    h ^= h >> 15;
    (h & 0x00ff_ffff) as f32 / 16_777_215.0
}

/// `x.floor() as i32` without a call into libm (the baseline x86-64 target has no rounding
/// instruction); the same value for every `x` whose floor fits in an `i32`.
#[inline]
fn floor_i32(x: f32) -> i32 {
    let t = x as i32;
    t - i32::from((t as f32) > x)
}

/// Trilinear value noise in [0, 1].
fn value_noise(p: Vec3) -> f32 {
    let (x, y, z) = (floor_i32(p.x), floor_i32(p.y), floor_i32(p.z));
    let t = p - Vec3::new(x as f32, y as f32, z as f32);
    let s = t * t * (Vec3::splat(3.0) - 2.0 * t);
    let corner = |dx, dy, dz| hash(x + dx, y + dy, z + dz);
    let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
    let x00 = lerp(corner(0, 0, 0), corner(1, 0, 0), s.x);
    let x10 = lerp(corner(0, 1, 0), corner(1, 1, 0), s.x);
    let x01 = lerp(corner(0, 0, 1), corner(1, 0, 1), s.x);
    let x11 = lerp(corner(0, 1, 1), corner(1, 1, 1), s.x);
    lerp(lerp(x00, x10, s.y), lerp(x01, x11, s.y), s.z)
}

/// Two octaves of value noise in [0, 1].
fn fbm(p: Vec3) -> f32 {
    0.65 * value_noise(p) + 0.35 * value_noise(p * 2.03 + Vec3::splat(17.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lobe_power_agrees_with_powf() {
        for e in [18.0, 40.0, 18.0 + 30.0 * 0.37, 1.0] {
            for i in 0..=1000 {
                let x = i as f32 / 1000.0;
                let (fast, reference) = (lobe_power(x, e), x.powf(e));
                // Relative to the value, except far below anything a colour can show.
                assert!((fast - reference).abs() <= 1e-5 * reference + 1e-30, "{x}^{e}: {fast} vs {reference}");
            }
        }
    }

    #[test]
    fn noise_is_deterministic_and_bounded() {
        let p = Vec3::new(1.234, -5.6, 7.89);
        assert_eq!(value_noise(p), value_noise(p));
        for i in 0..1000 {
            let v = value_noise(Vec3::new(i as f32 * 0.37, i as f32 * -0.11, 0.5));
            assert!((0.0..=1.0).contains(&v));
        }
    }

    #[test]
    fn brows_sit_above_the_eyes_and_not_on_the_forehead() {
        assert!(brow_mask(Vec3::new(0.3, 7.50, 1.4)) > 0.5);
        assert!(brow_mask(Vec3::new(-0.3, 7.50, 1.4)) > 0.5);
        assert_eq!(brow_mask(Vec3::new(0.3, 7.8, 1.4)), 0.0);
        assert_eq!(brow_mask(Vec3::new(0.0, 7.5, 1.5)), 0.0);
    }

    #[test]
    fn patterns_are_furrows_where_expected() {
        assert!(nasolabial(Vec2::new(0.20, 6.82)) < -1.0);
        assert!(nasolabial(Vec2::new(0.0, 7.5)).abs() < 1e-3);
        assert!(forehead_inner(Vec2::new(0.0, 7.72)) < -0.9);
    }
}
