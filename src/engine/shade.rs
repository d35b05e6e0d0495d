//! Shading: what each visible point of the head looks like.
//!
//! In: a [`Fragment`] from the rasteriser (position, normal, which vertices and where between
//! them), the [`Posed`] head and the [`Identity`]. Out: linear RGB as the camera records it
//! (exposed, each channel on a soft shoulder below 1: [`recorded`]). The face's painted features
//! (lips, brows, hair, stubble, wrinkles) are functions of the *rest* position of the base mesh,
//! interpolated across each triangle, so they move with the skin when AUs deform it.
//!
//! Appearance channels (`shade:NAME` in the AU basis), each a furrow/bulge height field:
//! `forehead_inner`, `forehead_outer`, `glabella_vertical`, `glabella_horizontal`, `crows_feet`,
//! `lower_lid_bulge`, `nose_wrinkles`, `nasolabial`, `cheek_apple`, `dimple`, `chin_boss`, `lip_press_bulge`;
//! and `lid_raise`, which moves the upper lid's shadow on the eyeball up with a raised lid.
//!
//! Patterns finer than a pixel (hair fibres, the sheen's streaks, brow hairs, the hairline's
//! hairs, the lips' furrows, stubble dots, the painted scalp's streaks) are seen as the pixel
//! averages them: their contrast falls with the number of their cells one pixel spans, worked
//! out from the camera ([`FaceShader::new`]).
//!
//! Light: the key light with its shadow map (whose edges blur with the caster's distance and the
//! light's size, [`ShadowMap`]), fill lights and a sky; skin under and beside the
//! hair gets only the share of the sky and the fill lights the hair leaves it
//! ([`super::hair::HairModel::skin_open`]).
//!
//! Invariant: a pure function of its inputs (no randomness but fixed hashes), so the same frame
//! shades to the same bytes on any thread.

use std::collections::BTreeMap;
use std::sync::{Arc, Mutex, OnceLock};

use glam::{Vec2, Vec3};

use super::asset::{FaceModel, Part};
use super::body::Body;
use super::identity::{HairTexture, Identity};
use super::image::REC709;
use super::hair::{Hair, HairModel, Hairline};
use super::{BODY_PART, HAIR_PART};
use super::look::{Backdrop, Lighting, Look};
use super::subdivide::Blend;
use super::pose::Posed;
use super::camera::{Camera, PixelProjection};
use super::raster::{self, Fragment, RenderOptions, SampleCount, Shader, Triangles};

/// Per-vertex region weights the shader reads.
struct Regions {
    lips: Vec<f32>,
    inside_mouth: Vec<f32>,
    ears: Vec<f32>,
    /// The vertices of the lips' red on the midline, whose movement forward tells how far the
    /// lips stand out in front of the teeth now ([`lips_forward`]).
    lips_midline: Vec<u32>,
    /// Of those, the front of the upper lip's red and of the lower lip's (the lower lip is the
    /// one the jaw-open target lowers, [`jaw_drop`]): how far apart they stand tells how open
    /// the mouth is ([`lips_apart`]).
    lips_edges: [Vec<u32>; 2],
    /// The lips' red in strips across the mouth ([`LIPS_STRIPS`]), each as its upper lip's and
    /// its lower lip's vertices: how far each strip's lips have moved apart tells where a lip
    /// lifts off the teeth beside the midline ([`lips_apart`]).
    lips_strips: Vec<[Vec<u32>; 2]>,
}

/// Per vertex, how far the CC0 jaw-open target lowers it, as a share of the most it lowers
/// any vertex: 1 on the chin and the lower lip, 0 on the upper lip.
fn jaw_drop(model: &FaceModel) -> Vec<f32> {
    let mut drop = vec![0.0; model.rest.len()];
    if let Ok(target) = model.target("faceunits/jawOpen") {
        for (&i, delta) in target.indices.iter().zip(&target.deltas) {
            if let Some(d) = drop.get_mut(i as usize) {
                *d = (-delta.y).max(0.0);
            }
        }
    }
    let most = drop.iter().copied().fold(0.0, f32::max);
    if most > 0.0 {
        drop.iter_mut().for_each(|d| *d /= most);
    }
    drop
}

fn regions(model: &FaceModel) -> &'static Regions {
    static REGIONS: OnceLock<Regions> = OnceLock::new();
    REGIONS.get_or_init(|| {
        let load = |name: &str| model.region(name).expect("the embedded face model has its regions");
        let lips = load("lips");
        let lips_midline: Vec<u32> = (0..lips.len() as u32).filter(|&i| lips[i as usize] > 0.5 && model.rest[i as usize].x.abs() < LIPS_MIDLINE).collect();
        let jaw = jaw_drop(model);
        let front = |lower: bool| lips_midline.iter().copied().filter(|&i| model.rest[i as usize].z > LIPS_FRONT_Z && (jaw[i as usize] >= 0.5) == lower).collect();
        let strip = |centre: f32, lower: bool| -> Vec<u32> {
            (0..lips.len() as u32).filter(|&i| lips[i as usize] > 0.5 && (model.rest[i as usize].x - centre).abs() < LIPS_STRIP_HALF_WIDTH && (jaw[i as usize] >= 0.5) == lower).collect()
        };
        let lips_strips = LIPS_STRIPS.iter().map(|&x| [strip(x, false), strip(x, true)]).filter(|[u, l]| !u.is_empty() && !l.is_empty()).collect();
        Regions { lips, inside_mouth: load("inside_mouth"), ears: load("ears"), lips_edges: [front(false), front(true)], lips_strips, lips_midline }
    })
}

/// The share of the light that reaches a point of the mouth's inside at rest depth `z` with
/// the lips `lips_forward` ([`lips_forward`]) in front of their rest and letting `through` of
/// the light in between them ([`light_through_lips`]): less the deeper it lies behind the lips'
/// opening as it stands now, and all of it a centimetre out in front of it (the tongue put out
/// over the lower lip, AU19, is lit as the lips are).
fn light_inside_mouth(z: f32, lips_forward: f32, through: f32) -> f32 {
    let behind = MOUTH_OPENING_Z + lips_forward - z;
    let opening = MOUTH_OPENING_LIGHT * through;
    if behind >= 0.0 {
        opening * (-behind * 6.0).exp()
    } else {
        opening + (1.0 - opening) * smoothstep(0.0, 0.1, -behind)
    }
}

/// The share of the light the lips let into the mouth when they stand `gap` apart (decimetres,
/// [`lips_apart`]): all of it once they are parted by [`LIPS_OPEN_GAP`], and only
/// [`LIPS_CLOSED_LIGHT`] through the slit of lips at rest (the lips of the CC0 head and its
/// people rest half a millimetre to two apart: a sliver of teeth lit as at the front of a smile
/// read as lips parted).
fn light_through_lips(gap: f32) -> f32 {
    LIPS_CLOSED_LIGHT + (1.0 - LIPS_CLOSED_LIGHT) * smoothstep(LIPS_CLOSED_GAP, LIPS_OPEN_GAP, gap)
}

/// Lips this far apart (decimetres) or less let only [`LIPS_CLOSED_LIGHT`] into the mouth.
const LIPS_CLOSED_GAP: f32 = 0.008;

/// Lips this far apart (decimetres) or more let all the light the opening gets into the mouth.
const LIPS_OPEN_GAP: f32 = 0.04;

/// The share of the light that gets through the slit between lips at rest.
const LIPS_CLOSED_LIGHT: f32 = 0.15;

/// The front half of the lips' red lies forward of this depth at rest (z, decimetres); their
/// inner skin behind it.
const LIPS_FRONT_Z: f32 = 1.52;

/// Where the strips of the lips' red lie across the mouth (rest x, decimetres): the midline, and
/// over the lateral incisors, the canines and the premolars on each side.
const LIPS_STRIPS: [f32; 7] = [-0.18, -0.12, -0.06, 0.0, 0.06, 0.12, 0.18];

/// Half the width of a strip of the lips (decimetres).
const LIPS_STRIP_HALF_WIDTH: f32 = 0.03;

/// How far apart (decimetres) the lips stand now, in the head's own frame: on the midline, the
/// lowest point of the upper lip's front above the highest of the lower lip's (negative where
/// they press over each other), or, where a lip has lifted off the teeth beside the midline
/// more (one side's AU10), the rest gap on the midline and how much farther apart the strip's
/// upper and lower lip have moved, on average, than they rest.
fn lips_apart(model: &FaceModel, posed: &Posed) -> f32 {
    let regions = regions(model);
    let [upper, lower] = &regions.lips_edges;
    let rest_y = |i: &u32| posed.neutral[*i as usize].y;
    let now_y = |i: &u32| rest_y(i) + moved_in_head(posed, *i as usize).y;
    let gap = |y: &dyn Fn(&u32) -> f32| upper.iter().map(y).fold(f32::INFINITY, f32::min) - lower.iter().map(y).fold(f32::NEG_INFINITY, f32::max);
    let (midline_now, midline_rest) = (gap(&now_y), gap(&rest_y));
    if !midline_now.is_finite() {
        return LIPS_OPEN_GAP;
    }
    let mean_raise = |vertices: &[u32]| vertices.iter().map(|&i| moved_in_head(posed, i as usize).y).sum::<f32>() / vertices.len() as f32;
    let parted = regions.lips_strips.iter().map(|[u, l]| mean_raise(u) - mean_raise(l)).fold(0.0, f32::max);
    midline_now.max(midline_rest + parted)
}

/// Where the mouth's opening lies between the lips at rest (rest z, decimetres): the inside of
/// the mouth is dimmed with depth behind it.
const MOUTH_OPENING_Z: f32 = 1.50;

/// The share of the light that reaches the mouth's opening between the lips.
const MOUTH_OPENING_LIGHT: f32 = 0.7;

/// The colour (linear RGB) of the mouth's inner skin at its opening; deeper in it takes its
/// share of [`light_inside_mouth`].
const MOUTH_INTERIOR: Vec3 = Vec3::new(0.16, 0.035, 0.035);

/// How far vertex `v` of `posed` has moved from the person's neutral, in the head's own frame
/// (a turn of the head undone).
fn moved_in_head(posed: &Posed, v: usize) -> Vec3 {
    let now = posed.positions[v];
    posed.head_turn.map_or(now, |turn| turn.undo(now)) - posed.neutral[v]
}

/// How near the midline (decimetres, rest x) a vertex of the lips' red counts as on it.
const LIPS_MIDLINE: f32 = 0.02;

/// How far (decimetres) the lips' red on the midline has moved forward of where it rests, on
/// average, in the head's own frame (pushed out by AU18's pucker or AU22's funnel; 0 where the
/// lips draw back, as in a smile): the teeth and the tongue behind them lie that much deeper
/// inside the mouth, where less light reaches ([`FaceShader::inside_mouth`]).
fn lips_forward(model: &FaceModel, posed: &Posed) -> f32 {
    let midline = &regions(model).lips_midline;
    if midline.is_empty() {
        return 0.0;
    }
    let moved: f32 = midline.iter().map(|&i| moved_in_head(posed, i as usize).z).sum();
    (moved / midline.len() as f32).max(0.0)
}

/// Depth of the head as seen from the key light, for cast shadows (the nose on the cheek, the
/// brow ridge on the eyes, the chin on the neck), and the same at a quarter of the resolution for
/// the wide soft edges of shadows cast from afar (the jaw on the neck, the head on the
/// shoulders): a light of some size blurs a shadow's edge the more, the farther the caster is.
pub struct ShadowMap {
    camera: Camera,
    view: glam::Mat4,
    projection: PixelProjection,
    near: f32,
    distance: Vec<f32>,
    /// One texel per [`COARSE`]² block of `distance`: about the lower median of its depths (the
    /// second nearest of four, of the second nearest of four); `coarse_size` across.
    coarse: Vec<f32>,
    coarse_size: usize,
    /// One texel per [`NEAREST`]² block of `coarse`: the nearest of its depths (`nearest_size`
    /// across), to pass over the coarse filter where it would find nothing.
    nearest: Vec<f32>,
    nearest_size: usize,
    /// A shadow edge's half-width in texels of `distance` per decimetre between caster and
    /// receiver: the key light's size ([`Lighting::key_size`]) over a texel's width.
    spread: f32,
    /// How far in front of a point a caster must be for its edge to blur wider than the fine
    /// filter's (decimetres, at least [`COARSE_BIAS`]): the coarse filter looks for those only.
    far: f32,
}

/// How far the map is seen from, toward the key light (decimetres).
const SHADOW_EYE_DISTANCE: f32 = 60.0;
/// The coarse map's texels are this many of the fine map's across.
const COARSE: usize = 4;
/// The nearest-depth map's texels are this many of the coarse map's across.
const NEAREST: usize = 4;
// Both maps are made by halving twice, the fine map and the coarse one.
const _: () = assert!(COARSE == 1 << 2 && NEAREST == 1 << 2);
/// How far behind the nearest surface a point must lie to be shadowed (decimetres), on the
/// fine map and on the coarse one (whose texels span more of a sloping surface).
const FINE_BIAS: f32 = 0.035;
const COARSE_BIAS: f32 = 0.1;
/// Half-widths of the two filters' edges in fine texels: 1.5 texels of each map.
const FINE_REACH: f32 = 1.5;
const COARSE_REACH: f32 = 1.5 * COARSE as f32;
/// How far off the surface, along its normal, the key light is looked up (decimetres).
const NORMAL_OFFSET: f32 = 0.02;
/// Surfaces whose normal's cosine with the key light's direction is below this take no key
/// light: the wrapped diffuse of the skin's red reaches 0.56 past the terminator, and this
/// leaves a margin for normals interpolated across a triangle.
const FACING_AWAY: f32 = -0.75;

/// The key light reaching a point: `reach` with soft edges; `sharp` from the fine map alone,
/// and `soft` the share the coarse map takes in `reach`.
#[derive(Clone, Copy, Debug, PartialEq)]
struct KeyShadow {
    reach: f32,
    sharp: f32,
    soft: f32,
}

impl Blend for KeyShadow {
    const ZERO: KeyShadow = KeyShadow::DARK;
    fn plus_scaled(self, other: KeyShadow, weight: f32) -> KeyShadow {
        KeyShadow { reach: self.reach + other.reach * weight, sharp: self.sharp + other.sharp * weight, soft: self.soft + other.soft * weight }
    }
}

impl KeyShadow {
    /// Nothing between the point and the light.
    const OPEN: KeyShadow = KeyShadow { reach: 1.0, sharp: 1.0, soft: 0.0 };
    /// No key light at all.
    const DARK: KeyShadow = KeyShadow { reach: 0.0, sharp: 0.0, soft: 0.0 };
}

/// The key light reaching each vertex of one scene item ([`KeyShadow`] by field), for
/// interpolation across its triangles.
#[derive(Debug, Default)]
struct KeyLight {
    reach: Vec<f32>,
    /// `sharp` and `soft` of each vertex.
    edge: Vec<[f32; 2]>,
}

impl KeyLight {
    /// `n` vertices in the open.
    fn open(n: usize) -> KeyLight {
        KeyLight::from_iter(std::iter::repeat_n(KeyShadow::OPEN, n))
    }
}

impl FromIterator<KeyShadow> for KeyLight {
    fn from_iter<I: IntoIterator<Item = KeyShadow>>(shadows: I) -> KeyLight {
        let (reach, edge) = shadows.into_iter().map(|k| (k.reach, [k.sharp, k.soft])).unzip();
        KeyLight { reach, edge }
    }
}

impl ShadowMap {
    /// Renders the depth of `scene` from the key light, aimed at `centre`, for a key light of
    /// size `key_size` ([`Lighting::key_size`]).
    pub fn new(scene: &[Triangles], key_direction: Vec3, key_size: f32, centre: Vec3, size: u32, threads: Option<usize>) -> ShadowMap {
        let camera = Camera {
            eye: Self::eye(key_direction, centre),
            target: centre,
            up: Vec3::Y,
            fov_y_degrees: 3.6,
            width: size,
            height: size,
        };
        let options = RenderOptions { samples_per_pixel: SampleCount::X1, threads, backface_culling: true, shade_per_surface: false };
        let distance = raster::nearest_distances(scene, &camera, &options);
        let (half, half_size) = halve(&distance, size as usize, second_nearest);
        let (coarse, coarse_size) = halve(&half, half_size, second_nearest);
        let (half, half_size) = halve(&coarse, coarse_size, nearest);
        let (nearest_map, nearest_size) = halve(&half, half_size, nearest);
        let texel = 2.0 * SHADOW_EYE_DISTANCE * (camera.fov_y_degrees.to_radians() / 2.0).tan() / size as f32;
        let spread = key_size / texel;
        let far = if spread > 0.0 { (FINE_REACH / spread).max(COARSE_BIAS) } else { f32::INFINITY };
        ShadowMap { view: camera.view(), projection: camera.pixel_projection(), near: camera.near(), camera, distance, coarse, coarse_size, nearest: nearest_map, nearest_size, spread, far }
    }

    /// Where the map is seen from: far out toward the key light from `centre`.
    pub fn eye(key_direction: Vec3, centre: Vec3) -> Vec3 {
        centre + key_direction * SHADOW_EYE_DISTANCE
    }

    /// The key light reaching `position` (0 = in shadow): the edge of a shadow filtered over
    /// 1.5 texels of the fine map on each side, blending into 1.5 texels of the coarse map as
    /// the caster's distance times [`Self::spread`] widens it.
    fn at(&self, position: Vec3) -> KeyShadow {
        let Some((x, y, depth)) = self.texel_point(position) else { return KeyShadow::OPEN };
        let fine = Footprint::new(self.camera.width as usize, x, y);
        let lit = fine.lit(&self.distance, depth, FINE_BIAS);
        let Some((caster, coarse)) = self.far_caster(&fine, lit, (x, y, depth)) else {
            return KeyShadow { reach: lit, sharp: lit, soft: 0.0 };
        };
        let soft = (((depth - caster) * self.spread - FINE_REACH) / (COARSE_REACH - FINE_REACH)).clamp(0.0, 1.0);
        let blurred = coarse.lit(&self.coarse, depth, self.far);
        KeyShadow { reach: lit + (blurred - lit) * soft, sharp: lit, soft }
    }

    /// How far from the light the casters lie that blur the edge at fine texel (`x`, `y`) and
    /// `depth` wider than the fine filter does, with the coarse map's footprint there: those
    /// the fine map sees (`fine`, which lets `lit` through), unless they are nearer than
    /// [`Self::far`] (a near caster keeps its edge sharp); else those only the coarse map sees
    /// (the lit side of a far caster's blurred edge). `None` where the edge stays sharp, before
    /// the coarse footprint is made.
    fn far_caster(&self, fine: &Footprint, lit: f32, (x, y, depth): (f32, f32, f32)) -> Option<(f32, Footprint)> {
        let seen = if lit < 1.0 { fine.blockers(&self.distance, depth, FINE_BIAS) } else { None };
        if seen.is_some_and(|caster| depth - caster < self.far) {
            return None;
        }
        let coarse = self.coarse_footprint(x, y);
        let caster = match seen {
            Some(caster) => caster,
            None if self.casters_near(&coarse, depth) => coarse.blockers(&self.coarse, depth, self.far)?,
            None => return None,
        };
        Some((caster, coarse))
    }

    /// The coarse map's footprint round fine texel (`x`, `y`).
    fn coarse_footprint(&self, x: f32, y: f32) -> Footprint {
        let c = COARSE as f32;
        Footprint::new(self.coarse_size, x / c, y / c)
    }

    /// The key light reaching `position` through the fine map alone (sharp edges).
    fn sharp(&self, position: Vec3) -> f32 {
        match self.texel_point(position) {
            Some((x, y, depth)) => Footprint::new(self.camera.width as usize, x, y).lit(&self.distance, depth, FINE_BIAS),
            None => 1.0,
        }
    }

    /// The key light reaching a surface point at `position` facing `normal` (`key` toward the
    /// light): looked up a little off the surface, so that it does not shadow itself; none
    /// where the surface faces well away from the light (its own bulk shadows it, and even the
    /// wrapped diffuse light stops short of it).
    fn at_surface(&self, position: Vec3, normal: Vec3, key: Vec3) -> KeyShadow {
        if normal.dot(key) < FACING_AWAY {
            return KeyShadow::DARK;
        }
        self.at(position + normal * NORMAL_OFFSET)
    }

    /// Where `position` falls on the maps (fine texels) and its depth from the light; `None`
    /// nearer than the light's near plane.
    fn texel_point(&self, position: Vec3) -> Option<(f32, f32, f32)> {
        let h = self.projection.apply(self.view.transform_point3(position));
        (h.z >= self.near).then(|| (h.x / h.z, h.y / h.z, h.z))
    }

    /// Whether any texel of the coarse map in `footprint` lies in front of `depth` by more
    /// than [`Self::far`], read from [`Self::nearest`] (a few texels, where the footprint
    /// has sixteen): where none does, the coarse filter finds no blocker either.
    fn casters_near(&self, footprint: &Footprint, depth: f32) -> bool {
        let (x0, x1) = (footprint.columns[0] / NEAREST, footprint.columns[3] / NEAREST);
        let (y0, y1) = (footprint.rows[0] / self.coarse_size / NEAREST, footprint.rows[3] / self.coarse_size / NEAREST);
        (y0..=y1).any(|y| (x0..=x1).any(|x| depth > self.nearest[y * self.nearest_size + x] + self.far))
    }
}

/// The 4×4 texels round (`x`, `y`) (texel centres at half-integers) of a square map `size`
/// texels across, with the bilinear weights of percentage-closer filtering (summing to 9).
struct Footprint {
    rows: [usize; 4],
    columns: [usize; 4],
    weights: ([f32; 4], [f32; 4]),
}

impl Footprint {
    #[inline]
    fn new(size: usize, x: f32, y: f32) -> Footprint {
        let last = size as i32 - 1;
        let (fx, fy) = (x - 0.5, y - 0.5);
        let (cx, cy) = (floor_i32(fx), floor_i32(fy));
        let (tx, ty) = (fx - cx as f32, fy - cy as f32);
        let weights = |t: f32| [1.0 - t, 1.0, 1.0, t];
        let texels = |c: i32| std::array::from_fn(|k| (c + k as i32 - 1).clamp(0, last) as usize);
        Footprint { rows: texels(cy).map(|r| r * size), columns: texels(cx), weights: (weights(tx), weights(ty)) }
    }

    /// The weighted share of the texels of `map` that let the light through to a point at
    /// `depth` (it lies no more than `bias` behind them).
    #[inline]
    fn lit(&self, map: &[f32], depth: f32, bias: f32) -> f32 {
        let mut lit = 0.0;
        for (&row, wy) in self.rows.iter().zip(self.weights.1) {
            for (&x, wx) in self.columns.iter().zip(self.weights.0) {
                // Adding 0 leaves the sum as it was: the same value as skipping the texel.
                lit += if depth <= map[row + x] + bias { wx * wy } else { 0.0 };
            }
        }
        lit / 9.0
    }

    /// The weighted mean depth of the texels of `map` that block the light from a point at
    /// `depth`, if any do.
    fn blockers(&self, map: &[f32], depth: f32, bias: f32) -> Option<f32> {
        let (mut weight, mut sum) = (0.0, 0.0);
        for (&row, wy) in self.rows.iter().zip(self.weights.1) {
            for (&x, wx) in self.columns.iter().zip(self.weights.0) {
                let texel = map[row + x];
                if depth > texel + bias {
                    weight += wx * wy;
                    sum += wx * wy * texel;
                }
            }
        }
        (weight > 0.0).then(|| sum / weight)
    }
}

/// The square map `map` (`size` texels across) at half its resolution: each texel `reduce` of
/// the 2×2 it covers (the last row and column repeated where `size` is odd); and its size.
fn halve(map: &[f32], size: usize, reduce: impl Fn([f32; 4]) -> f32) -> (Vec<f32>, usize) {
    let half = size.div_ceil(2);
    let mut halved = Vec::with_capacity(half * half);
    let row = |y: usize| &map[y.min(size - 1) * size..][..size];
    for y in 0..half {
        let (top, bottom) = (row(2 * y), row(2 * y + 1));
        halved.extend(top.chunks_exact(2).zip(bottom.chunks_exact(2)).map(|(t, b)| reduce([t[0], t[1], b[0], b[1]])));
        if size % 2 == 1 {
            let (t, b) = (top[size - 1], bottom[size - 1]);
            halved.push(reduce([t, t, b, b]));
        }
    }
    (halved, half)
}

/// The second smallest of four depths: the lower median, which keeps a caster's edge about
/// where most of the texels put it.
fn second_nearest([a, b, c, d]: [f32; 4]) -> f32 {
    let (low, high) = (lesser(a, b), greater(a, b));
    let (low2, high2) = (lesser(c, d), greater(c, d));
    lesser(greater(low, low2), lesser(high, high2))
}

fn nearest([a, b, c, d]: [f32; 4]) -> f32 {
    lesser(lesser(a, b), lesser(c, d))
}

/// The smaller and the greater of two depths (never NaN: one instruction each, where
/// `f32::min` and `max` also sort out NaNs).
fn lesser(a: f32, b: f32) -> f32 {
    if a < b { a } else { b }
}

fn greater(a: f32, b: f32) -> f32 {
    if a > b { a } else { b }
}

/// How much a triangle's corners may differ in key light and still be interpolated (a shadow's
/// edge crosses it beyond that).
const SHADOW_EDGE: f32 = 0.02;

/// The key light reaching each hair card vertex, looked up once per row of a card (the two
/// vertices across the strand at one of its points share the value) and only for the rows of
/// cards the camera sees (`seen`, see [`Hair::seen_from`]); 1 elsewhere. Hair has no normal
/// to offset along: the lookup is nudged toward the light (`key`) instead. From the fine map
/// alone: in the hair's depth its own strands, close by, make the shadows.
fn hair_key_light(hair: &Hair, seen: &[[u32; 3]], shadow: &ShadowMap, key: Vec3) -> KeyLight {
    let mut row_seen = vec![false; hair.positions.len() / 2];
    for &[a, b, c] in seen {
        if a != b {
            for v in [a, b, c] {
                row_seen[v as usize / 2] = true;
            }
        }
    }
    let rows = hair.positions.chunks_exact(2).zip(row_seen);
    let light = rows.map(|(pair, seen)| if seen { shadow.sharp((pair[0] + pair[1]) * 0.5 + key * 0.03) } else { 1.0 });
    light.flat_map(|sharp| [KeyShadow { reach: sharp, sharp, soft: 0.0 }; 2]).collect()
}

/// Whether skin with the painted features `painted` shows its pores and lines of age: not
/// under the painted hair and not inside the mouth.
fn shows_pores(painted: &SkinVertex) -> bool {
    painted.hair <= 0.9 && painted.inside_mouth <= 0.5
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
    /// The lid margin: the band of lid thickness between the lash line and the eyeball.
    margin: f32,
    /// 1 on the lower lid, 0 on the upper.
    lower: f32,
    /// The caruncle at the inner corner of the eye.
    caruncle: f32,
    /// Redder zones (nose, ears) and the darker skin around the eyes.
    flush: f32,
    periorbital: f32,
}

impl SkinVertex {
    const FIELDS: usize = 12;
    /// Where [`Self::to_array`] puts the fields read one by one.
    const MOTTLE: usize = 0;
    const PERIORBITAL: usize = 11;

    fn to_array(self) -> [f32; Self::FIELDS] {
        [
            self.mottle,
            self.cheek,
            self.oily,
            self.beard,
            self.hair,
            self.lips,
            self.inside_mouth,
            self.margin,
            self.lower,
            self.caruncle,
            self.flush,
            self.periorbital,
        ]
    }

    fn from_array(a: [f32; Self::FIELDS]) -> SkinVertex {
        let [mottle, cheek, oily, beard, hair, lips, inside_mouth, margin, lower, caruncle, flush, periorbital] = a;
        SkinVertex { mottle, cheek, oily, beard, hair, lips, inside_mouth, margin, lower, caruncle, flush, periorbital }
    }
}

/// The lines a face shows at rest with age (depth at 70 years), from the appearance
/// channels' height fields.
const AGE_LINES: [(&str, f32); 4] = [("crows_feet", 0.45), ("forehead_inner", 0.3), ("forehead_outer", 0.25), ("nasolabial", 0.45)];

/// How far a unit slope of the relief tilts the skin's normal.
const RELIEF_TILT: f32 = 0.006;

/// How far up the eyeball (as the sine of the angle from the gaze) the upper lid's shadow
/// retreats at full `lid_raise`: from the iris's top edge to above it.
const LID_RAISE_SHADOW: f32 = 0.4;

/// The share of the sky and fill lights that reaches the eyeball in its socket.
const EYE_SOCKET_OPEN: f32 = 0.8;

/// How much darker the eyeball is toward the eye's corners, where it turns away under the lids.
const EYE_CORNER_SHADOW: f32 = 0.4;

/// How much darker the neck's skin is right at the top's neckline, in the rib's shadow, and
/// over how many decimetres above it that shadow fades.
const COLLAR_CONTACT_SHADOW: f32 = 0.3;
const COLLAR_CONTACT_DM: f32 = 0.04;

/// The eyeballs of the rest mesh (centre, radius; see `stimuli/face/README.md`), for the lid
/// margins.
const REST_EYE_CENTRE: Vec3 = Vec3::new(0.30777, 7.28414, 1.24535);
const REST_EYE_RADIUS: f32 = 0.14954;

/// Lid margin, lower-lid and caruncle weights of a rest position.
fn lid_features(p: Vec3) -> (f32, f32, f32) {
    let m = Vec3::new(p.x.abs(), p.y, p.z);
    let gap = (m - REST_EYE_CENTRE).length() - REST_EYE_RADIUS;
    let margin = 1.0 - smoothstep(-0.004, 0.006, gap);
    if margin == 0.0 {
        return (0.0, 0.0, 0.0);
    }
    let lower = 1.0 - smoothstep(7.275, 7.295, p.y);
    let caruncle = margin * (1.0 - smoothstep(0.205, 0.228, m.x));
    (margin, lower, caruncle)
}

/// The painted features of one person's skin, per skin vertex (they depend only on the rest
/// mesh, stubble and hairline).
struct SkinMaps {
    vertices: Vec<[f32; SkinVertex::FIELDS]>,
}

impl SkinMaps {
    /// The maps of `identity`, computed once per person and shared by every frame.
    fn cached(model: &FaceModel, identity: &Identity) -> Arc<SkinMaps> {
        type Key = (String, u32, u32, u32, super::identity::BeardStyle);
        static CACHE: OnceLock<Mutex<BTreeMap<Key, Arc<SkinMaps>>>> = OnceLock::new();
        let key = (identity.id.clone(), identity.stubble.to_bits(), identity.hairline.to_bits(), identity.beard.to_bits(), identity.beard_style);
        let made: Result<_, std::convert::Infallible> = super::cached(CACHE.get_or_init(Default::default), key, || Ok(SkinMaps::new(model, identity)));
        made.unwrap_or_else(|never| match never {})
    }

    fn new(model: &FaceModel, identity: &Identity) -> SkinMaps {
        let skin = &model.rest[..model.part(Part::Skin).vertices.end as usize];
        let regions = regions(model);
        let hairline = Hairline::of(identity);
        // Under a beard the skin is dark with the hairs' roots, whatever the stubble.
        let roots = |p: Vec3| if identity.beard > 0.0 { BEARD_ROOTS * super::hair::beard::grown_mask(p, identity.beard_style) } else { 0.0 };
        let vertices = skin
            .iter()
            .enumerate()
            .map(|(i, &p)| {
                let (margin, lower, caruncle) = lid_features(p);
                SkinVertex {
                    mottle: 1.0 + 0.06 * (fbm(p * 40.0) - 0.5),
                    cheek: blob(Vec2::new(p.x.abs(), p.y), Vec2::new(0.38, 6.95), Vec2::new(0.14, 0.12)),
                    oily: blob(Vec2::new(p.x, p.y), Vec2::new(0.0, 7.3), Vec2::new(0.12, 0.7)),
                    beard: (beard_mask(p) * identity.stubble).max(roots(p)),
                    hair: hair_mask(p, hairline).max(SCALP_FRINGE_SHARE * hair_mask(p, hairline.lowered(SCALP_FRINGE))) * (1.0 - regions.ears[i]),
                    lips: regions.lips[i],
                    inside_mouth: regions.inside_mouth[i],
                    margin,
                    lower,
                    caruncle,
                    flush: blob(Vec2::new(p.x, p.y), Vec2::new(0.0, 6.98), Vec2::new(0.13, 0.2)) * smoothstep(1.35, 1.5, p.z) + 0.8 * regions.ears[i],
                    periorbital: blob(Vec2::new(p.x.abs(), p.y), Vec2::new(0.29, 7.2), Vec2::new(0.17, 0.09)) * (1.0 - margin),
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

/// How a surface takes the light: wrapped diffuse (light past the terminator), a specular
/// lobe's strength and exponent, the share of the sky and the fill lights that reaches it
/// (1 in the open; the key light's share is its shadow map's), whether it is living tissue,
/// under which scattered light carries red into a cast shadow's edge ([`key_share`]; not the
/// top's fabric), and the colour of the light left in a cast shadow on it (`bounce`, see
/// [`skin_bounce`]; white but on the skin).
#[derive(Clone, Copy, Debug)]
struct Surface {
    wrap: f32,
    specular: f32,
    shininess: f32,
    open: f32,
    tissue: bool,
    bounce: Vec3,
}

/// The key light's share in each channel where `reaches` of it passes a cast shadow's edge,
/// with `floor` (per channel) left where none does: light scattered under the skin carries red
/// furthest into the shadow and green a little, blue not, the more the wider the surface's
/// `wrap`. Fully lit points take all of it, fully shadowed ones the floor.
fn key_share(floor: Vec3, reaches: f32, wrap: f32) -> Vec3 {
    let edge = wrap * reaches * (1.0 - reaches);
    Vec3::splat(reaches) + floor * (1.0 - reaches) + Vec3::new(SHADOW_EDGE_RED * edge, SHADOW_EDGE_GREEN * edge, 0.0)
}

/// How far red and green reach into a cast shadow's edge, per unit of wrap: at the middle of
/// the skin's edges (wrap 0.35) red is lit 0.15 and green 0.035 more than blue.
const SHADOW_EDGE_RED: f32 = 1.7;
const SHADOW_EDGE_GREEN: f32 = 0.4;

/// Furrows and bulges drawn as a bump on the skin: the appearance patterns present, each with
/// its weights on the person's (left, right) side, and the union of their boxes (no relief
/// outside it).
struct ReliefSet {
    patterns: Vec<(Relief, f32, f32)>,
    bounds: [f32; 4],
}

impl ReliefSet {
    /// The patterns of [`PATTERNS`] whose weights `weights(name)` gives are not both zero, in
    /// that order.
    fn new(weights: impl Fn(&str) -> (f32, f32)) -> ReliefSet {
        let patterns: Vec<(Relief, f32, f32)> = PATTERNS
            .iter()
            .filter_map(|(name, pattern)| {
                let (l, r) = weights(name);
                (l != 0.0 || r != 0.0).then_some((*pattern, l, r))
            })
            .collect();
        let bounds = patterns.iter().fold([f32::INFINITY, f32::NEG_INFINITY, f32::INFINITY, f32::NEG_INFINITY], |u, (r, _, _)| {
            let b = r.bounds;
            [u[0].min(b[0]), u[1].max(b[1]), u[2].min(b[2]), u[3].max(b[3])]
        });
        ReliefSet { patterns, bounds }
    }

    /// The AUs' patterns (a posed head's `appearance` channels), and the same with the lines
    /// of age at rest of a person `age` (0 at 28 years, 1 at 70) added: an AU that deepens an
    /// age line adds to that line's weight, so each furrow is worked out once per point.
    fn of(appearance: &BTreeMap<String, (f32, f32)>, age: f32) -> (ReliefSet, ReliefSet) {
        let au = |name: &str| appearance.get(name).copied().unwrap_or((0.0, 0.0));
        let aged = |name: &str| {
            let (l, r) = au(name);
            let line = AGE_LINES.iter().find(|(n, _)| *n == name).map_or(0.0, |(_, depth)| depth * age);
            (l + line, r + line)
        };
        (ReliefSet::new(au), ReliefSet::new(aged))
    }

    /// The height at rest position `p` (decimetres × pattern depth).
    fn height(&self, p: Vec3) -> f32 {
        let [x0, x1, y0, y1] = self.bounds;
        let x = p.x.abs();
        if x < x0 || x > x1 || p.y < y0 || p.y > y1 {
            return 0.0;
        }
        let mirrored = Vec2::new(x, p.y);
        let l = FaceShader::left_weight(p.x);
        self.patterns.iter().map(|(relief, left, right)| (left * l + right * (1.0 - l)) * relief.at(mirrored)).sum()
    }

    /// The height at `p` and its slope along rest x and y (over 0.3 mm), or `None` where the
    /// skin is flat.
    fn bump(&self, p: Vec3) -> Option<(f32, Vec2)> {
        if self.patterns.is_empty() {
            return None;
        }
        let h = self.height(p);
        if h == 0.0 {
            return None;
        }
        let e = 0.003;
        let gx = (self.height(p + Vec3::X * e) - h) / e;
        let gy = (self.height(p + Vec3::Y * e) - h) / e;
        Some((h, Vec2::new(gx, gy)))
    }
}

/// The tongue's albedo (linear RGB).
const TONGUE: Vec3 = Vec3::new(0.45, 0.12, 0.12);
/// Papillae per decimetre on the tongue (each about half a millimetre).
const PAPILLAE_PER_DM: f32 = 200.0;
/// Half the width of the groove down the middle of the tongue's back (decimetres).
const TONGUE_GROOVE_HALF_WIDTH: f32 = 0.02;

/// The median groove of the tongue's back at rest `x` (decimetres from the midline): its depth
/// (1 on the floor, a Gaussian across) and how far its wall turns the surface's normal along x.
/// The walls slope as the depth does (the normal turns toward the midline by the depth's slope),
/// so the turn is 0 on the floor and at most [`TONGUE_GROOVE_TILT`] halfway up each wall: a soft
/// furrow, with no crease where the two halves meet.
fn tongue_groove(x: f32) -> (f32, f32) {
    let across = x / TONGUE_GROOVE_HALF_WIDTH;
    let depth = (-across * across).exp();
    // d(depth)/d(across) = -2·across·depth, at most √(2/e) ≈ 0.858 in size.
    let slope = -2.0 * across * depth / (2.0 / std::f32::consts::E).sqrt();
    (depth, TONGUE_GROOVE_TILT * slope)
}

/// The largest turn of the normal by the tongue's median groove (along x, per unit normal).
const TONGUE_GROOVE_TILT: f32 = 0.3;

/// Shades the head for one frame.
pub struct FaceShader<'a> {
    maps: Arc<SkinMaps>,
    /// The key light reaching each vertex (1 everywhere without a shadow map).
    key_light: KeyLight,
    /// The generated neck and shoulders, and the key light reaching each of their vertices.
    body: Option<&'a Body>,
    body_key_light: KeyLight,
    /// The hair cards, and the key light reaching each of their vertices.
    hair: Option<&'a Hair>,
    /// The hair's triangles the camera sees (hidden ones degenerate).
    hair_seen: &'a [[u32; 3]],
    hair_key_light: KeyLight,
    /// The key light's shadow map, looked up per pixel where a shadow's edge crosses a triangle.
    shadow: Option<&'a ShadowMap>,
    /// The AUs' furrows and bulges, drawn where the skin shows no lines of age (under the
    /// painted hair and inside the mouth).
    relief: ReliefSet,
    /// The same with the lines of age at rest, drawn elsewhere on the skin.
    aged_relief: ReliefSet,
    model: &'a FaceModel,
    posed: &'a Posed,
    identity: &'a Identity,
    /// The person's hairline, worked out once (the painted scalp's parting reads it).
    hairline: Hairline,
    /// Whether the person's hair lies combed ([`super::hair::lies_combed`]: its cards on the
    /// scalp are lit along the comb, [`super::hair::comb_at`]), worked out once; free curls
    /// and coils keep their own directions, and the scalp between them stays lit as skin.
    combed: bool,
    /// The pigment of the person's scalp hair, greyed as it is ([`hair_pigment`]), worked
    /// out once: the painted scalp reads it on every fragment it covers.
    scalp_pigment: Vec3,
    lighting: Lighting,
    backdrop_kind: Backdrop,
    /// The backdrop's colour on each image row, worked out once.
    backdrop: Vec<Vec3>,
    /// Where the camera is, and the width of a pixel per unit of distance from it: how much
    /// of a surface one pixel spans.
    eye: Vec3,
    pixel_angle: f32,
    /// The colour of the light left in a cast shadow on the skin ([`skin_bounce`]).
    skin_bounce: Vec3,
    /// How far the lips stand forward of their rest now ([`lips_forward`]).
    lips_forward: f32,
    /// The share of the light the lips let into the mouth now ([`light_through_lips`]).
    through_lips: f32,
}

/// The colour of the light that reaches a cast shadow on the skin of colour `skin` (linear):
/// much of it is the key light thrown back by the lit skin around (the nose's lit side onto the
/// cheek in its shadow) and scattered under the skin, so it takes the skin's hue at the
/// luminance of white. A shadow on the skin then reads as darker skin, not as a grey patch
/// under the cool fill.
fn skin_bounce(skin: Vec3) -> Vec3 {
    let luminance = skin.dot(Vec3::from(REC709));
    if luminance > 0.0 { skin / luminance } else { Vec3::ONE }
}

impl<'a> FaceShader<'a> {
    pub fn new(model: &'a FaceModel, posed: &'a Posed, identity: &'a Identity, look: &Look, camera: &Camera) -> FaceShader<'a> {
        let (relief, aged_relief) = ReliefSet::of(&posed.appearance, smoothstep(28.0, 70.0, identity.age));
        let maps = SkinMaps::cached(model, identity);
        let key_light = KeyLight::open(posed.positions.len());
        let height = camera.height;
        let backdrop = (0..height).map(|y| look.backdrop.colour(y, height)).collect();
        let (eye, pixel_angle) = (camera.eye, camera.pixel_angle());
        let lighting = look.light.lighting();
        let (body, body_key_light, hair, hair_key_light) = (None, KeyLight::default(), None, KeyLight::default());
        let backdrop_kind = look.backdrop;
        let hairline = Hairline::of(identity);
        let (combed, scalp_pigment) = (super::hair::lies_combed(identity), hair_pigment(identity, identity.hair_grey));
        FaceShader { maps, key_light, body, body_key_light, hair, hair_seen: &[], hair_key_light, shadow: None, relief, aged_relief, model, posed, identity, hairline, combed, scalp_pigment, lighting, backdrop_kind, backdrop, eye, pixel_angle, skin_bounce: skin_bounce(identity.skin), lips_forward: lips_forward(model, posed), through_lips: light_through_lips(lips_apart(model, posed)) }
    }

    /// Casts the key light's shadows from `shadow`, looked up once per vertex (offset along the
    /// normal so that surfaces do not shadow themselves) and interpolated across triangles whose
    /// corners agree; on skin and body triangles a shadow's edge crosses (corners that differ),
    /// looked up per pixel, so the edge follows the shadow, not the mesh.
    pub fn with_shadows(self, shadow: &'a ShadowMap) -> FaceShader<'a> {
        let key = self.lighting.lights[0].direction;
        let looked_up = |positions: &[Vec3], normals: &[Vec3]| positions.iter().zip(normals).map(|(&p, &n)| shadow.at_surface(p, n, key)).collect::<Vec<_>>();
        // A subdivided part's drawn vertices take the light its baked ones are looked up for.
        let mut head = looked_up(&self.posed.positions[..self.model.baked_vertices()], &self.posed.normals);
        head.resize(self.posed.positions.len(), KeyShadow::DARK);
        self.model.refine(&mut head);
        let key_light = head.into_iter().collect();
        let body_key_light = self.body.map_or_else(KeyLight::default, |body| looked_up(&body.positions, &body.normals).into_iter().collect());
        let hair_key_light = self.hair.map_or_else(KeyLight::default, |hair| hair_key_light(hair, self.hair_seen, shadow, key));
        FaceShader { key_light, body_key_light, hair_key_light, shadow: Some(shadow), ..self }
    }

    /// The fraction of the key light reaching fragment `f` of the skin or body. Where the fine
    /// map's values at the corners differ, the fine map is looked up at the pixel and takes the
    /// place of their interpolation in the part of the reach it makes (all of it where the edge
    /// is sharp, none where the coarse map blurs it).
    fn key_reach(&self, f: &Fragment) -> f32 {
        let light = self.key_light_of(f.part);
        let w = f.barycentric;
        let mix = |v: [f32; 3]| v[0] * w.x + v[1] * w.y + v[2] * w.z;
        let reach = mix(f.vertex.map(|v| light.reach[v as usize]));
        let [a, b, c] = f.vertex.map(|v| light.edge[v as usize]);
        match self.shadow {
            Some(shadow) if a[0].max(b[0]).max(c[0]) - a[0].min(b[0]).min(c[0]) > SHADOW_EDGE => {
                let (sharp, soft) = (mix([a[0], b[0], c[0]]), mix([a[1], b[1], c[1]]));
                (reach + (shadow.sharp(f.position + f.normal * NORMAL_OFFSET) - sharp) * (1.0 - soft)).clamp(0.0, 1.0)
            }
            _ => reach,
        }
    }

    /// The key light reaching fragment `f`, looked up at the pixel on both maps, for parts
    /// drawn with few triangles that shadows cross: interpolated from the corners of the
    /// teeth's arch, the upper lip's soft shadow darkened one triangle of a tooth and not the
    /// rest. The teeth take a few hundred fragments of a frame, so the lookups cost little.
    fn key_reach_at_pixel(&self, f: &Fragment) -> f32 {
        match self.shadow {
            Some(shadow) => shadow.at_surface(f.position, f.normal, self.lighting.lights[0].direction).reach,
            None => self.key_reach(f),
        }
    }

    /// Shades hair cards too (scene part [`HAIR_PART`]), of which the camera sees `seen`
    /// ([`Hair::seen_from`]).
    pub fn with_hair(self, hair: &'a Hair, seen: &'a [[u32; 3]]) -> FaceShader<'a> {
        FaceShader { hair_key_light: KeyLight::open(hair.positions.len()), hair: Some(hair), hair_seen: seen, ..self }
    }

    /// The key light reaching each vertex of the scene item `part`.
    fn key_light_of(&self, part: u16) -> &KeyLight {
        match part {
            BODY_PART => &self.body_key_light,
            HAIR_PART => &self.hair_key_light,
            _ => &self.key_light,
        }
    }

    /// Shades the generated neck and shoulders too (scene part [`BODY_PART`]).
    pub fn with_body(self, body: &'a Body) -> FaceShader<'a> {
        FaceShader { body_key_light: KeyLight::open(body.positions.len()), body: Some(body), ..self }
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

    fn lit(&self, f: &Fragment, normal: Vec3, albedo: Vec3, wrap: f32, specular: f32, shininess: f32) -> Vec3 {
        self.lit_reached(f, normal, albedo, Surface { wrap, specular, shininess, open: 1.0, tissue: true, bounce: Vec3::ONE }, self.key_reach(f))
    }

    /// [`Self::lit`] with the fraction of the key light reaching `f` already known.
    fn lit_reached(&self, f: &Fragment, normal: Vec3, albedo: Vec3, surface: Surface, key_reaches: f32) -> Vec3 {
        let Surface { wrap, specular, shininess, open, tissue, bounce } = surface;
        let view = f.view_dir;
        let Lighting { lights, sky, ground, shadow_floor, .. } = &self.lighting;
        let ambient = sky.lerp(*ground, (0.5 - 0.5 * normal.y).clamp(0.0, 1.0));
        let mut colour = albedo * ambient * open;
        // Wrapped diffuse lets light bleed past the terminator, red most (subsurface look).
        let wraps = Vec3::new(wrap * 1.6, wrap, wrap * 0.8);
        let per_wrap = Vec3::ONE / (Vec3::ONE + wraps);
        for (n, light) in lights.iter().enumerate() {
            let reach = if n == 0 { key_share(*shadow_floor * bounce, key_reaches, if tissue { wrap } else { 0.0 }) } else { Vec3::splat(open) };
            let n_dot_l = normal.dot(light.direction);
            let wrapped = ((Vec3::splat(n_dot_l) + wraps) * per_wrap).max(Vec3::ZERO);
            colour += albedo * light.colour * wrapped * reach;
            // Only the key light is bright enough to give a visible highlight.
            if n == 0 && n_dot_l > 0.0 && specular != 0.0 {
                let half = (light.direction + view).normalize();
                let fresnel = 0.04 + 0.96 * (1.0 - view.dot(half).max(0.0)).powi(5);
                let lobe = lobe_power(normal.dot(half).max(0.0), shininess) * (shininess + 8.0) / 25.0;
                colour += light.colour * specular * fresnel * lobe * n_dot_l * reach.z;
            }
        }
        colour
    }

    fn shade_skin(&self, f: &Fragment) -> Vec3 {
        let rest = self.rest(f);
        // Painted patterns finer than a pixel are seen as it averages them.
        let pixel = self.pixel_width(f.position);
        let identity = self.identity;
        let mut painted = self.maps.at(f);
        painted.hair = hairline_hairs(rest, painted.hair.max(self.under_hair(f)), self.hairline_texture(), pixel);
        let lips = smoothstep(0.3, 0.7, painted.lips);
        let mouth = painted.inside_mouth;

        // Surface relief: wrinkles and furrows (the AUs', and the lines of age at rest where
        // pores show too) as a bump map in rest space.
        let mut normal = f.normal;
        let mut crease = 0.0;
        let relief = if shows_pores(&painted) { &self.aged_relief } else { &self.relief };
        if let Some((h, slope)) = relief.bump(rest) {
            normal = (normal - RELIEF_TILT * slope.extend(0.0)).normalize();
            crease = (-h).max(0.0);
        }

        // Micro relief: pores, stronger on the nose and cheeks.
        let pores = self.pores(rest, &painted, &mut normal);
        let lip_crease = if lips > 0.0 { lip_lines(rest, lips, pixel, &mut normal) } else { 0.0 };

        // Albedo: skin with mottling, colour zones, lips, stubble, brows, hair, lid margins.
        // Each layer is blended in only where it is present (blending by 0 leaves the value).
        let mut albedo = identity.skin * painted.mottle * (1.0 - 0.05 * pores);
        let cheek = painted.cheek;
        if cheek != 0.0 {
            albedo = albedo.lerp(albedo * Vec3::new(1.08, 0.9, 0.88), 0.5 * cheek);
        }
        if painted.flush != 0.0 {
            albedo = albedo.lerp(albedo * Vec3::new(1.1, 0.86, 0.85), 0.55 * painted.flush.min(1.0));
        }
        if painted.periorbital != 0.0 {
            albedo = albedo.lerp(albedo * Vec3::new(0.84, 0.8, 0.84), 0.6 * painted.periorbital);
        }
        if lips != 0.0 {
            // The vermilion border: a thin lighter line where lip meets skin.
            let border = 1.0 + 0.18 * (1.0 - (2.0 * lips - 1.0).abs()) * smoothstep(0.05, 0.3, painted.lips);
            albedo = albedo.lerp(identity.lips, lips) * border * (1.0 - 0.1 * lip_crease);
        }
        let beard = painted.beard * (1.0 - lips);
        if beard > 0.0 {
            let dots = smoothstep(0.4, 0.8, seen_over(value_noise(rest * 260.0), 260.0 * pixel));
            // Under a beard's cards the roots stand close, greying as the beard does: little
            // skin shows between them.
            let (hair, least, dotted) = if identity.beard > 0.0 {
                (hair_pigment(identity, identity.hair_grey * 0.35), 0.8, 0.2)
            } else {
                (identity.hair, 0.35, 0.5)
            };
            albedo = albedo.lerp(hair * 0.6 + identity.skin * 0.25, beard * (least + dotted * dots));
        }
        let hair = painted.hair;
        // The painted scalp, worked out once: its albedo here, its lighting as hair below.
        let scalp = (hair > 0.0).then(|| scalp_paint(identity, self.hairline, self.scalp_pigment, rest, pixel));
        if let Some(paint) = &scalp {
            albedo = albedo.lerp(paint.over(albedo), hair);
        }
        let brow = brow_mask(rest, pixel);
        if brow != 0.0 {
            albedo = albedo.lerp(brow_colour(identity), brow);
        }
        let margin = painted.margin;
        let mut wet = 0.0;
        if margin != 0.0 {
            // Lid thickness: pinker, moist skin; on the lower lid a wet line; the caruncle red.
            let pink = albedo * Vec3::new(1.05, 0.72, 0.72);
            albedo = albedo.lerp(pink, 0.7 * margin);
            albedo = albedo.lerp(Vec3::new(0.55, 0.2, 0.2), 0.8 * painted.caruncle);
            wet = margin * (0.35 + 0.65 * painted.lower).max(painted.caruncle);
            // The upper lash line is dark.
            albedo *= 1.0 - 0.55 * margin * (1.0 - painted.lower) * (1.0 - painted.caruncle);
        }
        if crease != 0.0 {
            albedo *= 1.0 - 0.15 * crease.min(1.0);
        }
        let oily = painted.oily;
        // Matte cheeks, an oilier T-zone, pores break up the highlight; wet lids shine.
        let specular = (0.16 + 0.3 * oily) * (1.0 - 0.35 * pores) * (1.0 - hair) * (1.0 - brow) + 0.5 * lips * (1.0 - 0.6 * lip_crease) + 1.2 * wet;
        let shininess = 16.0 + 24.0 * lips + 48.0 * wet.min(1.0);
        let reach = self.key_reach(f);
        let open = self.hair_skin_value(f, |hair| &hair.skin_open, 1.0);
        let surface = Surface { wrap: 0.35 * (1.0 - hair), specular, shininess, open, tissue: true, bounce: self.skin_bounce };
        let mut colour = self.lit_reached(f, normal, albedo, surface, reach);
        colour += self.subsurface_bleed(normal, albedo, reach) * (1.0 - hair);
        if let Some(paint) = scalp.filter(|_| hair > 0.85 && self.hair.is_some() && self.combed) {
            let as_hair = self.scalp_lit_as_hair(f, rest, &paint, reach);
            // Only where the hair is whole: its soft fringe over the skin stays lit as skin (lit
            // as hair, it was a pale haze over the forehead).
            colour = colour.lerp(as_hair, smoothstep(0.85, 1.0, hair) * (1.0 - paint.parting));
        }
        // The mouth interior is dark, more so the deeper it lies behind the lips' opening (as
        // the teeth and the tongue are: a pucker puts it deeper).
        if mouth > 0.0 {
            let interior = MOUTH_INTERIOR * (self.inside_mouth(rest) / MOUTH_OPENING_LIGHT);
            colour = colour.lerp(interior, (mouth * 1.5).min(1.0));
        }
        colour
    }

    /// How much of the hair cards lying on the skin covers skin fragment `f`
    /// ([`super::hair::HairModel::skin_cover`]); 0 without hair.
    fn under_hair(&self, f: &Fragment) -> f32 {
        self.hair_skin_value(f, |hair| &hair.skin_cover, 0.0)
    }

    /// One of the hair model's per-skin-vertex `values` at skin fragment `f`, or `without`
    /// where there is no hair.
    fn hair_skin_value(&self, f: &Fragment, values: impl Fn(&HairModel) -> &[f32], without: f32) -> f32 {
        match self.hair {
            Some(hair) => {
                let values = values(&hair.model);
                let [a, b, c] = f.vertex.map(|v| values.get(v as usize).copied().unwrap_or(without));
                a * f.barycentric.x + b * f.barycentric.y + c * f.barycentric.z
            }
            None => without,
        }
    }

    /// Pores, as a bump on `normal` where they show ([`shows_pores`]). Returns the pore depth
    /// (0..1).
    fn pores(&self, rest: Vec3, painted: &SkinVertex, normal: &mut Vec3) -> f32 {
        if !shows_pores(painted) {
            return 0.0;
        }
        let face = 1.0 - painted.lips;
        let strength = face * (0.5 + 0.5 * (painted.cheek + painted.flush + painted.oily).min(1.0));
        let q = rest * 150.0;
        let (pore, slope) = value_noise_and_slope(q);
        let bump = (slope * BUMP_OF_SLOPE).extend(0.0) * (0.9 * strength);
        *normal = (*normal - bump).normalize();
        smoothstep(0.55, 0.9, pore) * strength
    }

    /// Light that scattered under the skin: a red glow along the key light's terminator.
    /// `reach`: the fraction of the key light reaching the point ([`Self::key_reach`]).
    fn subsurface_bleed(&self, normal: Vec3, albedo: Vec3, reach: f32) -> Vec3 {
        let key = &self.lighting.lights[0];
        let n_dot_l = normal.dot(key.direction);
        let edge = (1.0 - (n_dot_l - 0.05).abs() * 4.0).max(0.0);
        if edge == 0.0 {
            return Vec3::ZERO;
        }
        albedo * key.colour * Vec3::new(0.16, 0.035, 0.02) * edge * (0.3 + 0.7 * reach)
    }

    /// Hair: Kajiya–Kay lighting of the strand direction (diffuse across the strand, two
    /// highlights along it, the second tinted by the hair, both in streaks), fine fibres across
    /// each card, darker near the roots and inside the volume.
    fn shade_hair(&self, f: &Fragment, hair: &Hair) -> Vec3 {
        let model = &hair.model;
        let strand = (f.triangle / model.triangles_per_strand) as usize;
        let tone = model.strand_tone.get(strand).copied().unwrap_or(1.0);
        // Greying: white fibres among pigmented ones, which themselves lose some colour. A fibre
        // is far thinner than a pixel, so a white one is seen mixed with its neighbours: a third
        // of its own whiteness, the rest its strand's share of white (pure white fibres on dark
        // hair read as scribbles, half-white ones as hard stripes).
        let share = model.strand_grey.get(strand).copied().unwrap_or(0.0);
        // The patterns across the card are as fine as a pixel or finer: each is seen as the
        // pixel averages it (sampled at the pixel's centre, fibres read as broken dashes).
        let span = self.card_span(f, hair);
        let grey = 0.35 * model.fibre_grey_over(strand, f.uv.x, span) + 0.65 * share;
        let pigment = hair_pigment(self.identity, grey);
        // Fine, low-contrast variation across the card (strong contrast between neighbouring
        // fibres and dark roots read as hard stripes, a card as a plank).
        let fibre_noise = value_noise(Vec3::new(f.uv.x * FIBRE_NOISE_ACROSS, f.uv.y * 4.0, strand as f32 * FIBRE_NOISE_PER_STRAND));
        let fibres = 0.85 + 0.15 * seen_over(fibre_noise, FIBRE_NOISE_ACROSS * span);
        let rooted = 0.8 + 0.2 * smoothstep(0.0, 0.3, f.uv.y);
        // The highlights break into streaks along the strand (fibres catching the light
        // together), so that a card's sheen does not end at its edges as a lit plank.
        let streak_noise = value_noise(Vec3::new(f.uv.x * HIGHLIGHT_STREAKS_ACROSS, f.uv.y * 3.0, strand as f32 * STREAK_NOISE_PER_STRAND));
        let streaks = 0.35 + 1.3 * seen_over(streak_noise, HIGHLIGHT_STREAKS_ACROSS * span);
        let look = HairLook { albedo: pigment * tone * fibres * rooted, pigment, fibres, streaks, rooted };
        self.lit_hair(&look, f.normal, f.view_dir, self.interpolate(&self.hair_key_light.reach, f))
    }

    /// How much of its card's width (1 = all of it) one pixel spans at hair fragment `f`: the
    /// pixel's width at that distance against the card's width there across the line of
    /// sight. Over 1 toward the tips, where the card narrows to a point.
    fn card_span(&self, f: &Fragment, hair: &Hair) -> f32 {
        let [a, b, c] = f.vertex.map(|v| hair.row_width_seen(v as usize / 2, f.view_dir));
        let card = a * f.barycentric.x + b * f.barycentric.y + c * f.barycentric.z;
        self.pixel_width(f.position) / card.max(1e-6)
    }

    /// How wide (decimetres) a pixel is at `position`, across the line of sight.
    fn pixel_width(&self, position: Vec3) -> f32 {
        self.pixel_angle * (position - self.eye).length()
    }

    /// Hair of `look` running along `tangent`, seen along `view`, reached by `key_reaches` of
    /// the key light: Kajiya–Kay diffuse across the strand and two highlights along it.
    fn lit_hair(&self, look: &HairLook, tangent: Vec3, view: Vec3, key_reaches: f32) -> Vec3 {
        let HairLook { albedo, pigment, fibres, streaks, rooted } = *look;
        // Coils scatter light every way along a strand: tightly coiled hair has little sheen.
        let sheen = if self.identity.hair_texture == HairTexture::Coiled { 0.3 } else { 1.0 };
        let Lighting { lights, sky, ground, shadow_floor, .. } = &self.lighting;
        let mut colour = albedo * sky.lerp(*ground, 0.5) * 1.2;
        for (n, light) in lights.iter().enumerate() {
            let reach = if n == 0 { shadow_floor + (1.0 - shadow_floor) * key_reaches } else { 1.0 };
            let t_l = tangent.dot(light.direction);
            // Light scattered between fibres evens the diffuse term out a little: cards at
            // slightly different angles differ less in tone (they read as planks otherwise).
            let diffuse = 0.3 + 0.45 * (1.0 - t_l * t_l).max(0.0).sqrt();
            colour += albedo * light.colour * diffuse * reach;
            if n == 0 {
                let half = (light.direction + view).normalize();
                let t_h = tangent.dot(half);
                let along = (1.0 - t_h * t_h).max(0.0).sqrt();
                let primary = lobe_power(along, HAIR_LOBES[0]) * 0.072 * sheen * streaks;
                let secondary = lobe_power(along, HAIR_LOBES[1]) * 0.12 * fibres * sheen * streaks;
                // The surface sheen takes a little of the hair's own hue (a white sheen over
                // all of a lit side of brown hair read as grey hair).
                let hue = pigment / pigment.max_element().max(1e-4);
                let sheen_colour = Vec3::splat(1.0 - PRIMARY_HUE) + hue * PRIMARY_HUE;
                colour += light.colour * (sheen_colour * primary + pigment * 2.0 * secondary) * reach * rooted;
            }
        }
        colour
    }

    /// The texture the hairline's strokes are drawn in: combed hair's (curls pulled taut
    /// included) are long and straight, free curls' and coils' short.
    fn hairline_texture(&self) -> HairTexture {
        if self.combed { HairTexture::Straight } else { self.identity.hair_texture }
    }

    /// The painted scalp `paint` at skin fragment `f` (rest position `rest`, reached by `reach`
    /// of the key light) lit as hair combed along the scalp there, as the cards over it are: lit
    /// as skin it was darker and redder than they are, and showed between their ends in steps.
    fn scalp_lit_as_hair(&self, f: &Fragment, rest: Vec3, paint: &ScalpPaint, reach: f32) -> Vec3 {
        let look = HairLook { albedo: paint.hair, pigment: self.scalp_pigment, fibres: 0.92, streaks: paint.streaks, rooted: 0.9 };
        let comb = super::hair::comb_at(self.identity, rest);
        let tangent = (comb - f.normal * comb.dot(f.normal)).normalize_or(comb);
        self.lit_hair(&look, tangent, f.view_dir, reach)
    }

    /// The neck below the cut and the crew-neck top over the shoulders. The neckline's edge is
    /// spread over a pixel's width (the two sides weighted by how much of the pixel each
    /// covers), as the raster smooths a triangle's edge: drawn at one point, it was stair-stepped.
    fn shade_body(&self, f: &Fragment) -> Vec3 {
        let below = below_neckline(self.body, f.position);
        let half = 0.5 * self.pixel_width(f.position);
        let reach = self.key_reach(f);
        if below <= -half {
            return self.shade_neck(f, below, reach);
        }
        if below >= half {
            return self.shade_top(f, below, reach);
        }
        self.shade_neck(f, below, reach).lerp(self.shade_top(f, below, reach), (below + half) / (2.0 * half))
    }

    /// The bare neck, `below` the neckline (negative), reached by `reach` of the key light: the
    /// skin next to the top's rib lies in its shadow, which fades over the few millimetres the
    /// rib stands off the skin.
    fn shade_neck(&self, f: &Fragment, below: f32, reach: f32) -> Vec3 {
        let p = f.position;
        let contact = 1.0 - COLLAR_CONTACT_SHADOW * (1.0 - smoothstep(0.0, COLLAR_CONTACT_DM, -below));
        let albedo = self.identity.skin * (1.0 + 0.06 * (fbm(p * 40.0) - 0.5)) * contact;
        let skin = Surface { wrap: 0.35, specular: 0.25, shininess: 18.0, open: 1.0, tissue: true, bounce: self.skin_bounce };
        self.lit_reached(f, f.normal, albedo, skin, reach)
    }

    /// The crew-neck top, `below` the neckline, reached by `reach` of the key light: a ribbed
    /// band along the neckline that rolls over towards the neck, knit, soft folds.
    fn shade_top(&self, f: &Fragment, below: f32, reach: f32) -> Vec3 {
        let p = f.position;
        let below = below.max(0.0);
        let rib = 1.0 - smoothstep(0.05, 0.06, below);
        let stripes = 0.5 + 0.5 * (p.x * 260.0 + p.z * 260.0).sin();
        let weave = value_noise(p * 300.0);
        // Soft folds: a low-frequency wobble of the normal.
        let fold = Vec3::new(value_noise(p * Vec3::new(6.0, 3.0, 6.0)) - 0.5, 0.0, value_noise(p * Vec3::new(6.0, 3.0, 6.0) + 9.0) - 0.5);
        let mut normal = (f.normal + 0.25 * fold).normalize();
        if rib > 0.0 {
            normal = (normal + Vec3::new(0.0, 0.35 * (1.0 - 2.0 * smoothstep(0.0, 0.06, below)), 0.0) * rib).normalize();
        }
        let texture = 0.93 + 0.07 * weave - 0.08 * rib * stripes;
        let fabric = Surface { wrap: 0.25, specular: 0.04, shininess: 8.0, open: 1.0, tissue: false, bounce: Vec3::ONE };
        self.lit_reached(f, normal, self.identity.top * texture, fabric, reach)
    }

    fn shade_eye(&self, f: &Fragment, side: usize) -> Vec3 {
        let eye = self.posed.eyes[side];
        let d = (f.position - eye.centre).normalize();
        let right = eye.up.cross(eye.gaze);
        // The iris lies behind the cornea: seen at an angle its pattern shifts away from the
        // viewer (parallax), which gives it depth.
        let tilt = f.view_dir - eye.gaze * f.view_dir.dot(eye.gaze);
        let seen = (d - tilt * 0.06 * smoothstep(0.0, 0.6, d.dot(eye.gaze))).normalize();
        let angle = seen.dot(eye.gaze).clamp(-1.0, 1.0).acos();
        let around = seen.dot(right).atan2(seen.dot(eye.up));
        let iris_edge = 0.52;
        let pupil = 0.19;
        // An off-white, a little warm, redder toward the corners (paper white read as stickers).
        let sclera = Vec3::new(0.70, 0.65, 0.60).lerp(Vec3::new(0.68, 0.48, 0.44), smoothstep(0.8, 1.45, angle));
        let fibres = 0.7 + 0.6 * value_noise(Vec3::new(around * 14.0, angle * 30.0, side as f32 * 7.0));
        // Iris: a lighter collarette around the pupil, radial fibres, a dark limbal ring.
        let collarette = 1.0 + 0.35 * (1.0 - smoothstep(0.0, 0.08, (angle - 0.29).abs()));
        let limbal = 1.0 - 0.7 * smoothstep(iris_edge - 0.1, iris_edge - 0.01, angle);
        let iris = self.identity.iris * fibres * collarette * limbal;
        let mut albedo = sclera.lerp(iris, 1.0 - smoothstep(iris_edge - 0.01, iris_edge + 0.03, angle));
        albedo = albedo.lerp(Vec3::splat(0.008), 1.0 - smoothstep(pupil - 0.02, pupil + 0.01, angle));
        // The upper lid and lashes shade the top of the eyeball; the eye sits in its socket.
        // A raised upper lid (AU5, `lid_raise`) takes its shadow up with it, so the sclera
        // above the iris shows white.
        let up = d.dot(eye.up) - LID_RAISE_SHADOW * self.lid_raise(side);
        let lid_shadow = (1.0 - 0.6 * smoothstep(0.0, 0.45, up)) * (1.0 - EYE_CORNER_SHADOW * smoothstep(0.55, 1.0, d.dot(right).abs()));
        // The socket, lids and brow leave the eyeball a narrow view of the sky and fill lights.
        let surface = Surface { wrap: 0.1, specular: 0.0, shininess: 1.0, open: EYE_SOCKET_OPEN, tissue: true, bounce: Vec3::ONE };
        let colour = self.lit_reached(f, d, albedo * lid_shadow, surface, self.key_reach(f));
        colour + self.cornea_highlight(d, f.view_dir) * self.interpolate(&self.key_light.reach, f)
    }

    /// The `lid_raise` weight on eye `side` (0 = the person's left).
    fn lid_raise(&self, side: usize) -> f32 {
        self.posed.appearance.get("lid_raise").map_or(0.0, |(left, right)| if side == 0 { *left } else { *right })
    }

    /// Reflections on the wet cornea: the key light as a small bright catchlight, the fill as
    /// a faint one.
    fn cornea_highlight(&self, normal: Vec3, view: Vec3) -> Vec3 {
        let [key, fill, _] = &self.lighting.lights;
        let reflect = |l: &super::look::Light, power: f32, strength: f32| {
            let half = (l.direction + view).normalize();
            l.colour * strength * normal.dot(half).max(0.0).powf(power)
        };
        reflect(key, 900.0, 1.6) + reflect(fill, 300.0, 0.5)
    }

    /// The tongue: as dim as the mouth around it where it lies inside, and lit as the lips
    /// are where the expression has pushed it out between them (AU19), so its depth is taken
    /// where it is now in the head, not where it rests. Its surface is moist (a sharp sheen),
    /// rough with papillae finer than a millimetre, with a shallow groove down the middle of
    /// its back, and its edges, where it turns from the viewer, a deeper red.
    fn shade_tongue(&self, f: &Fragment) -> Vec3 {
        let rest = self.rest(f);
        let q = rest * PAPILLAE_PER_DM;
        let (papilla, slope) = value_noise_and_slope(q);
        let mut normal = (f.normal - (slope * BUMP_OF_SLOPE * 0.6).extend(0.0)).normalize();
        // The median groove, on the back where it faces up.
        let (groove, tilt) = tongue_groove(rest.x);
        let back = smoothstep(0.2, 0.6, f.normal.y);
        let groove = groove * back;
        normal = (normal + Vec3::X * (tilt * back)).normalize();
        let cells = self.pixel_width(f.position) * PAPILLAE_PER_DM;
        let speckle = seen_over(papilla, cells);
        let facing = f.normal.dot(f.view_dir).abs();
        let albedo = TONGUE * (0.85 + 0.3 * speckle) * (1.0 - 0.15 * groove) * Vec3::new(1.0, 0.7 + 0.3 * facing, 0.7 + 0.3 * facing);
        self.lit(f, normal, albedo, 0.3, 0.45, 60.0) * self.inside_mouth(self.tongue_now(f, rest))
    }

    /// Where tongue fragment `f` (at rest `rest`) is now in the head's own frame: its rest
    /// position moved as the pose moved its corners.
    fn tongue_now(&self, f: &Fragment, rest: Vec3) -> Vec3 {
        let moved = f.vertex.map(|v| moved_in_head(self.posed, v as usize));
        let w = f.barycentric;
        rest + moved[0] * w.x + moved[1] * w.y + moved[2] * w.z
    }

    /// Inside the mouth little light arrives: everything dimmed, and more with depth behind
    /// the lips as they stand now (`rest`: the point in rest space): lips pushed forward in a
    /// pucker leave the teeth deeper in the mouth's shadow, and lips at rest let little light
    /// in through the slit between them.
    fn inside_mouth(&self, rest: Vec3) -> f32 {
        light_inside_mouth(rest.z, self.lips_forward, self.through_lips)
    }

    /// Teeth: enamel is translucent, so a tooth in the lip's shadow still glows with the light
    /// it takes in below the shadow's edge and from the lips around it (about half the key light
    /// reaches it).
    /// For the same reason it is dimmed less than the rest of the mouth (ENAMEL_GLOW): at the
    /// front of a smile the teeth are about as bright as the lit skin, not grey.
    fn shade_teeth(&self, f: &Fragment, row: &TeethRow) -> Vec3 {
        let rest = self.rest(f);
        let reach = 0.45 + 0.55 * self.key_reach_at_pixel(f);
        let surface = Surface { wrap: 0.2, specular: 0.5, shininess: 40.0, open: 1.0, tissue: true, bounce: Vec3::ONE };
        // The arch is a few flat facets: its normals turn half toward the viewer, so that a
        // tooth reads as one rounded surface, not as a lit and a dark facet. Each tooth's face
        // is convex across the arch: its normal turns toward the next tooth on either side.
        let normal = tooth_normal((f.normal + f.view_dir).normalize_or(f.normal), rest.x);
        let albedo = teeth_albedo(rest, row);
        self.lit_reached(f, normal, albedo, surface, reach) * self.inside_mouth(rest) * ENAMEL_GLOW
    }

    /// Lashes: the lash cards are drawn as clumps of lashes, dense at the lid margin and
    /// tapering to points toward their tips, short at the inner corner and long from the middle
    /// of the lid outward; between the clumps the lid's skin behind them shows. Clumps narrower than
    /// a pixel blend into their mean cover instead of flickering.
    fn shade_lashes(&self, f: &Fragment, lashes: &Lashes) -> Vec3 {
        let rest = self.rest(f);
        let m = Vec3::new(rest.x.abs(), rest.y, rest.z);
        let from_eye = m - REST_EYE_CENTRE;
        let out = (from_eye.length() - REST_EYE_RADIUS).max(0.0);
        // 0 at the inner corner, 1 at the outer, by the angle around the eye.
        let around = (1.0 - from_eye.y.atan2(from_eye.x).abs() / std::f32::consts::PI).clamp(0.0, 1.0);
        let at = around * lashes.clumps;
        let clump = at.floor();
        let jitter = 0.75 + 0.25 * hash(clump as i32, lashes.seed, (rest.x > 0.0) as i32);
        let length = lashes.length * (0.45 + 0.55 * smoothstep(0.0, 0.5, around)) * (1.0 - 0.3 * smoothstep(0.85, 1.0, around)) * jitter;
        let along = out / length;
        let pixel = 3.1 / self.backdrop.len().max(1) as f32;
        let spacing = (lashes.arc / lashes.clumps).max(1e-4);
        let soft = (pixel / spacing).clamp(0.05, 0.5);
        let width = (lashes.root_width * (1.0 - along)).max(0.0);
        let across = (at - clump - 0.5).abs();
        let clumped = width.min(1.0) * (1.0 - smoothstep(0.5 * width - soft, 0.5 * width + soft, across));
        let mean = width.min(1.0);
        let seen = clumped + (mean - clumped) * smoothstep(0.25, 0.5, soft);
        let cover = lashes.density * seen.max(1.0 - smoothstep(0.4 * lashes.band, lashes.band, out));
        let skin = self.lid_behind_lashes(f);
        let lash = self.identity.hair * 0.3 + Vec3::splat(0.012);
        skin.lerp(lash, cover.clamp(0.0, 1.0))
    }

    /// The lid skin behind a lash fragment, shaded with the normal, light and paint of the
    /// skin vertices it lies on (so that the skin between the clumps matches the lid around).
    fn lid_behind_lashes(&self, f: &Fragment) -> Vec3 {
        let roots = self.model.lash_roots();
        let behind = f.vertex.map(|v| roots.of(v) as usize);
        let w = [f.barycentric.x, f.barycentric.y, f.barycentric.z];
        let mix = |value: &dyn Fn(usize) -> f32| (0..3).map(|k| w[k] * value(behind[k])).sum::<f32>();
        let normal = (0..3).fold(Vec3::ZERO, |n, k| n + self.posed.normals[behind[k]] * w[k]).normalize_or(f.normal);
        let reach = mix(&|v| self.key_light.reach[v]);
        let paint = |field: usize| mix(&|v| self.maps.vertices[v][field]);
        let mut albedo = self.identity.skin * paint(SkinVertex::MOTTLE);
        albedo = albedo.lerp(albedo * Vec3::new(0.84, 0.8, 0.84), 0.6 * paint(SkinVertex::PERIORBITAL));
        let surface = Surface { wrap: 0.35, specular: 0.16, shininess: 16.0, open: 1.0, tissue: true, bounce: self.skin_bounce };
        self.lit_reached(f, normal, albedo, surface, reach)
    }

    /// The eye sockets' own shading for the eyeball parts depends on which eye it is.
    fn eye_index(part: Part) -> usize {
        if part == Part::EyeLeft { 0 } else { 1 }
    }
}

/// How far the body point `p` lies below the top's neckline (negative: bare neck). The
/// neckline is lower at the front than at the back.
pub(crate) fn below_neckline(body: Option<&Body>, p: Vec3) -> f32 {
    // The cosine of the angle around the neck from the front, cos(atan2(x, z)) = z / |(x, z)|.
    let (x, z) = (p.x, p.z - 0.25);
    let r = (x * x + z * z).sqrt();
    let around = if r > 0.0 { z / r } else { 1.0 };
    let shift = body.map_or(0.0, |b| b.shift.y + b.neckline_rise(p.x));
    let neckline = 5.64 + shift + 0.09 * (1.0 - around);
    neckline - p.y
}

/// The painted regions of a skin fragment, as other styles than the realistic one draw them
/// (each a weight in [0, 1]).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Paint {
    pub lips: f32,
    pub inside_mouth: f32,
    /// Scalp hair painted on the skin.
    pub hair: f32,
    pub brow: f32,
    /// The upper lid's lash line.
    pub lash_line: f32,
}

/// One person's painted skin, looked up per fragment.
pub(crate) struct SkinPaint<'a> {
    maps: Arc<SkinMaps>,
    model: &'a FaceModel,
}

impl<'a> SkinPaint<'a> {
    pub(crate) fn new(model: &'a FaceModel, identity: &Identity) -> SkinPaint<'a> {
        SkinPaint { maps: SkinMaps::cached(model, identity), model }
    }

    pub(crate) fn at(&self, f: &Fragment) -> Paint {
        let painted = self.maps.at(f);
        let [a, b, c] = f.vertex.map(|v| self.model.rest[v as usize]);
        let rest = a * f.barycentric.x + b * f.barycentric.y + c * f.barycentric.z;
        let lash_line = painted.margin * (1.0 - painted.lower) * (1.0 - painted.caruncle);
        Paint { lips: painted.lips, inside_mouth: painted.inside_mouth, hair: painted.hair, brow: brow_band(rest), lash_line }
    }
}

impl Shader for FaceShader<'_> {
    /// The light leaving the surface at `f`, as the camera records it ([`recorded`]).
    fn shade(&self, f: &Fragment) -> Vec3 {
        recorded(self.light_leaving(f))
    }

    fn background(&self, _x: u32, y: u32) -> Vec3 {
        let height = self.backdrop.len() as u32;
        self.backdrop.get(y as usize).copied().unwrap_or_else(|| self.backdrop_kind.colour(y, height))
    }
}

/// The camera's exposure: the share of the light leaving a surface that it records. The
/// studio light sums to about 1.2 on skin turned to the camera (key, fill and sky, warmest in
/// red); at 0.85 the lit face's median records at about the skin colour its identity names.
const EXPOSURE: f32 = 0.85;

/// Where the camera's response to a channel starts to roll off (linear; sRGB 231 of 255). Below
/// it a channel is recorded as it is.
const FILM_KNEE: f32 = 0.8;

/// A surface's light (linear RGB, unbounded) as the camera records it: scaled by [`EXPOSURE`],
/// then each channel up to [`FILM_KNEE`] as it is and above it on a soft shoulder toward 1
/// (`k + (v − k) / (1 + (v − k) / (1 − k))`, which meets the line at the knee with its slope and
/// never reaches 1). Each channel rolls off on its own, so where only the red of light skin
/// reaches the shoulder, its green and blue keep the skin's fine relief at full contrast.
///
/// Before, light skin in the studio light clipped: the red channel reached 250 over 24–63 % of
/// the face on nine of the 24 people, which flattened the forehead and cheeks into one pale
/// tone. The backdrop is not recorded through it (a `#RRGGBB` backdrop keeps its colour).
fn recorded(colour: Vec3) -> Vec3 {
    let exposed = colour * EXPOSURE;
    if exposed.max_element() <= FILM_KNEE {
        return exposed;
    }
    let shoulder = |v: f32| {
        if v <= FILM_KNEE {
            return v;
        }
        let over = v - FILM_KNEE;
        FILM_KNEE + over / (1.0 + over / (1.0 - FILM_KNEE))
    };
    Vec3::new(shoulder(exposed.x), shoulder(exposed.y), shoulder(exposed.z))
}

impl FaceShader<'_> {
    /// The light leaving the surface at `f` (linear RGB, unbounded).
    fn light_leaving(&self, f: &Fragment) -> Vec3 {
        if f.part == BODY_PART {
            return self.shade_body(f);
        }
        if let (HAIR_PART, Some(hair)) = (f.part, self.hair) {
            return self.shade_hair(f, hair);
        }
        match Part::from_id(f.part) {
            Some(Part::Skin) | None => self.shade_skin(f),
            Some(part @ (Part::EyeLeft | Part::EyeRight)) => self.shade_eye(f, Self::eye_index(part)),
            Some(Part::TeethUpper) => self.shade_teeth(f, &UPPER_TEETH),
            Some(Part::TeethLower) => self.shade_teeth(f, &LOWER_TEETH),
            Some(Part::Tongue) => self.shade_tongue(f),
            Some(Part::LashesUpper) => self.shade_lashes(f, &UPPER_LASHES),
            Some(Part::LashesLower) => self.shade_lashes(f, &LOWER_LASHES),
        }
    }
}

// ---- painted features (rest space, decimetres; x is the person's left) ----

/// How a lid's lashes are drawn on its lash card (rest space, decimetres).
struct Lashes {
    /// Clumps along the lid, and the lid's arc length they share.
    clumps: f32,
    arc: f32,
    /// The longest lashes' length out from the eyeball, and the width of the band along the lid
    /// margin where the lashes' roots cover the card whole.
    length: f32,
    band: f32,
    /// A clump's width at its root (share of the spacing), and how dark the lashes cover.
    root_width: f32,
    density: f32,
    seed: i32,
}

const UPPER_LASHES: Lashes = Lashes { clumps: 22.0, arc: 0.42, length: 0.085, band: 0.016, root_width: 2.6, density: 1.0, seed: 11 };
const LOWER_LASHES: Lashes = Lashes { clumps: 18.0, arc: 0.36, length: 0.05, band: 0.008, root_width: 0.7, density: 0.55, seed: 29 };

/// Where one tooth meets the next across the arch, from the midline out (the central incisor
/// 8 mm wide, the others 6 mm).
const TOOTH_EDGES: [f32; 6] = [0.0, 0.08, 0.14, 0.2, 0.26, 0.32];

/// A row of teeth: its biting edge at rest, from the midline back along the arch (x, y;
/// decimetres: the front row of its mesh, rising toward the back teeth), and which way its gum
/// lies from it in y (up for the upper teeth, down for the lower).
struct TeethRow {
    edge: [Vec2; 7],
    toward_gum: f32,
}

const UPPER_TEETH: TeethRow = TeethRow {
    edge: [
        Vec2::new(0.0, 6.600),
        Vec2::new(0.089, 6.604),
        Vec2::new(0.174, 6.620),
        Vec2::new(0.221, 6.640),
        Vec2::new(0.254, 6.657),
        Vec2::new(0.284, 6.676),
        Vec2::new(0.311, 6.704),
    ],
    toward_gum: 1.0,
};
const LOWER_TEETH: TeethRow = TeethRow {
    edge: [
        Vec2::new(0.0, 6.593),
        Vec2::new(0.091, 6.596),
        Vec2::new(0.177, 6.612),
        Vec2::new(0.222, 6.631),
        Vec2::new(0.256, 6.649),
        Vec2::new(0.284, 6.665),
        Vec2::new(0.306, 6.694),
    ],
    toward_gum: -1.0,
};

/// How much less than the rest of the mouth's inside the teeth are dimmed.
const ENAMEL_GLOW: f32 = 1.25;

/// Enamel (linear RGB): off-white, thinning to a translucent bluish grey at the biting edge,
/// yellower toward the neck, where the dentine shows through.
const ENAMEL: Vec3 = Vec3::new(0.84, 0.80, 0.70);
const INCISAL_EDGE: Vec3 = Vec3::new(0.55, 0.58, 0.62);
const GUM: Vec3 = Vec3::new(0.60, 0.22, 0.22);

/// How far above the biting edge (toward the gum, decimetres) the enamel turns translucent, the
/// gap between teeth opens into a notch, and the gum's scalloped line lies between two teeth
/// and over a tooth's middle.
const TRANSLUCENT_EDGE: f32 = 0.018;
const NOTCH: f32 = 0.02;
const GUM_LINE: [f32; 2] = [0.095, 0.11];

/// The height of `edge` (a line of points by x) at `x`, linearly between its points.
fn edge_height(edge: &[Vec2], x: f32) -> f32 {
    let last = edge[edge.len() - 1];
    edge.windows(2).find(|w| x < w[1].x).map_or(last.y, |w| w[0].y + (w[1].y - w[0].y) * ((x - w[0].x) / (w[1].x - w[0].x)).max(0.0))
}

/// Enamel at rest position `rest` on the teeth of `row`: off-white, each tooth rounded
/// (a little darker toward its sides, where its surface turns away) with a narrow soft gap to the
/// next that opens into a dark notch at the biting edge, where the enamel is translucent;
/// yellower toward the neck, and the gum above the upper teeth (below the lower), its line
/// arching over each tooth.
fn teeth_albedo(rest: Vec3, row: &TeethRow) -> Vec3 {
    let x = rest.x.abs();
    let across = tooth_across(rest.x);
    let rounded = 1.0 - 0.22 * (2.0 * across - 1.0).powi(4);
    let from_edge = (row.toward_gum * (rest.y - edge_height(&row.edge, x))).max(0.0);
    let notch = 1.0 - smoothstep(0.0, NOTCH, from_edge);
    let gap_width = 0.0035 + 0.006 * notch;
    let gap = TOOTH_EDGES.iter().map(|&e| (-((x - e) / gap_width).powi(2)).exp()).fold(0.0, f32::max);
    let enamel = (ENAMEL * rounded)
        .lerp(INCISAL_EDGE, 0.5 * (1.0 - smoothstep(0.0, TRANSLUCENT_EDGE, from_edge)))
        .lerp(ENAMEL * Vec3::new(0.97, 0.9, 0.76), smoothstep(0.04, 0.1, from_edge));
    let gum_line = GUM_LINE[0] + (GUM_LINE[1] - GUM_LINE[0]) * (1.0 - (2.0 * across - 1.0).powi(2));
    let gum = smoothstep(gum_line - 0.004, gum_line + 0.004, from_edge);
    enamel.lerp(GUM, gum) * (1.0 - (0.4 + 0.4 * notch) * gap * (1.0 - gum))
}

/// Where across its tooth a point of the teeth at rest `x` lies: 0 at the edge toward the
/// midline, 1 at the edge away from it ([`TOOTH_EDGES`]).
fn tooth_across(x: f32) -> f32 {
    let x = x.abs();
    let tooth = TOOTH_EDGES.windows(2).find(|w| x < w[1]).unwrap_or(&TOOTH_EDGES[4..]);
    ((x - tooth[0]) / (tooth[1] - tooth[0])).clamp(0.0, 1.0)
}

/// How far a tooth's normal turns along the arch at its sides (the tangent of the angle): a
/// tooth's face is convex, lit more on the side toward the light.
const TOOTH_CONVEXITY: f32 = 1.0;

/// The normal of a tooth's convex face at rest `x` on the arch whose flat normal is `facing`:
/// turned along the arch toward the midline on the tooth's inner half and away from it on its
/// outer half, by up to 45 degrees at its sides.
fn tooth_normal(facing: Vec3, x: f32) -> Vec3 {
    let outward = Vec3::Y.cross(facing).normalize_or_zero() * x.signum();
    (facing + outward * (TOOTH_CONVEXITY * (2.0 * tooth_across(x) - 1.0))).normalize_or(facing)
}

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

/// Brows: a tapered arch above each eye ([`brow_point`]) filled with hairs ([`brow_hairs`])
/// seen by a pixel `pixel` decimetres wide; the skin shows between them. How much of the skin
/// the brow covers (0..1).
fn brow_mask(rest: Vec3, pixel: f32) -> f32 {
    let Some(brow) = brow_point(rest) else { return 0.0 };
    let hairs = brow_hairs(Vec2::new(rest.x.abs(), rest.y), &brow, pixel);
    (brow.density * (0.66 + 0.42 * smoothstep(0.2, 0.8, hairs))).min(1.0)
}

/// The brow's hairs at `p` (mirrored rest space, x ≥ 0) on `brow`, 0..1 around a mean of 0.5:
/// strokes of noise stretched along the hairs, which grow up and out at the head, out along the
/// body (the lower ones a little up, the upper ones a little down, meeting along the middle)
/// and out and a little down at the tail; seen by a pixel `pixel` decimetres wide.
fn brow_hairs(p: Vec2, brow: &BrowPoint, pixel: f32) -> f32 {
    // Strokes along hairs at `angle` (radians up from outward).
    let strokes = |angle: f32, seed: f32| {
        let (sin, cos) = angle.sin_cos();
        let (along, across) = (p.x * cos + p.y * sin, p.y * cos - p.x * sin);
        let noise = value_noise(Vec3::new(across * BROW_STROKES_ACROSS, along * BROW_STROKES_ALONG, seed));
        seen_over(noise, BROW_STROKES_ACROSS * pixel)
    };
    let t = brow.along;
    let (head, tail) = (1.0 - smoothstep(0.06, 0.3, t), smoothstep(0.55, 0.85, t));
    let mut hairs = 0.0;
    if head > 0.0 {
        hairs += head * strokes(BROW_HAIR_ANGLES[0], 0.5);
    }
    if head + tail < 1.0 {
        let upper = smoothstep(-0.3, 0.5, brow.across);
        let body = (1.0 - upper) * strokes(BROW_HAIR_ANGLES[1], 3.5) + upper * strokes(BROW_HAIR_ANGLES[2], 6.5);
        hairs += (1.0 - head - tail) * body;
    }
    if tail > 0.0 {
        hairs += tail * strokes(BROW_HAIR_ANGLES[3], 9.5);
    }
    hairs
}

/// How much of the scalp hair's greying the brows show: brows keep their pigment longer than the
/// scalp hair (at 0.6 of it, greying people's brows read as a flat light-grey band).
const BROW_GREYING: f32 = 0.3;

/// The brows' colour: the hair's pigment (as [`hair_pigment`] greys it) with a share
/// [`BROW_GREYING`] of its greying, a little darker (the hairs shade one another).
fn brow_colour(identity: &Identity) -> Vec3 {
    hair_pigment(identity, BROW_GREYING * identity.hair_grey) * 0.8
}

/// Which way brow hairs grow (radians up from outward): at the head, the body's lower and upper
/// hairs, and the tail.
const BROW_HAIR_ANGLES: [f32; 4] = [1.15, 0.3, -0.05, -0.15];

/// Cells of the brow's hair strokes across and along a hair, per decimetre: hairs lie in
/// bundles about 0.5 mm apart and 5 mm long.
const BROW_STROKES_ACROSS: f32 = 200.0;
const BROW_STROKES_ALONG: f32 = 20.0;

/// Where a rest point lies on its side's brow.
struct BrowPoint {
    /// 0 at the head (beside the nose), 1 at the tail.
    along: f32,
    /// 0 on the brow's centre line, ±1 at its edges (positive above).
    across: f32,
    /// How much hair grows there (0..1): full along the body, thinning at a ragged outline,
    /// soft and sparser toward the head, tapering at the tail.
    density: f32,
}

/// The brow at `rest`, or `None` off it.
fn brow_point(rest: Vec3) -> Option<BrowPoint> {
    // The brow's centre line stays within [7.405, 7.51] and its half-width below 0.036, so
    // beyond 1.25 half-widths of that band (with a margin) there is no brow: skip the rest.
    if rest.z < 1.1 || !(7.35..=7.57).contains(&rest.y) {
        return None;
    }
    let x = rest.x.abs();
    let t_raw = (x - 0.075) / 0.44;
    if !(-0.05..=1.05).contains(&t_raw) {
        return None;
    }
    let t = t_raw.clamp(0.0, 1.0);
    let (centre, half) = brow_line(t);
    let across = (rest.y - centre) / half;
    // Beyond 1.25 half-widths the outline is zero whatever its raggedness (at most 0.25).
    if across.abs() > 1.25 {
        return None;
    }
    let ragged = value_noise(Vec3::new(x * 60.0, rest.y * 60.0, 2.5));
    let body = 1.0 - smoothstep(0.5, 1.0 + 0.25 * ragged, across.abs());
    let ends = smoothstep(-0.04, 0.16, t_raw + 0.05 * (ragged - 0.5)) * (1.0 - smoothstep(0.9, 1.04, t));
    let density = (body * ends * (0.8 + 0.2 * smoothstep(0.05, 0.3, t))).clamp(0.0, 1.0);
    Some(BrowPoint { along: t, across, density })
}

/// The brow's centre line (rest height) and half its width at `t` along it (0 at the head, 1
/// at the tail): an arch that narrows toward the tail.
fn brow_line(t: f32) -> (f32, f32) {
    let centre = 7.44 + 0.07 * (std::f32::consts::PI * t.powf(0.7)).sin() - 0.035 * t;
    (centre, 0.030 * (1.0 - 0.55 * t) + 0.006)
}

/// The brow's outline filled flat, without its hairs (the cartoon's brows).
fn brow_band(rest: Vec3) -> f32 {
    brow_point(rest).map_or(0.0, |brow| brow.density)
}

/// The painted scalp hair reaches this far (decimetres) below the hairline the roots grow
/// from, at this share of full cover: strands lying over the hairline leave no slivers of bare
/// forehead between them and the hair, and the hairline is soft.
const SCALP_FRINGE: f32 = 0.05;
const SCALP_FRINGE_SHARE: f32 = 0.85;

/// The painted hair's cover where it thins out toward the bare skin (`cover` between 0 and 1,
/// at the hairline and the fringe under the cards' roots): fine hairs growing up out of the
/// skin instead of an even wash, the sparser the thinner the cover: straight and wavy hairs as
/// strokes, curly ones shorter, coiled ones as tight specks. A pixel `pixel` decimetres wide
/// sees their mean, about `cover`. Full cover and bare skin stay as they are.
fn hairline_hairs(rest: Vec3, cover: f32, texture: HairTexture, pixel: f32) -> f32 {
    if cover <= 0.0 || cover >= 1.0 {
        return cover;
    }
    // Across the hairs: around the head (decimetres of arc at the hairline), so that the
    // strokes run up the forehead and the temples alike.
    let around = rest.x.atan2(rest.z - super::hair::HEAD_CENTRE.z) * 0.8;
    // The hairs lean out from the middle of the forehead, down and back at the temples, each
    // lock a little its own way: the strokes are sheared by that lean about the hairline.
    let lean = HAIRLINE_FAN * (around / HAIRLINE_FAN_REACH).clamp(-1.0, 1.0) + HAIRLINE_WAVE * (2.0 * value_noise(Vec3::new(around * 12.0, 1.5, 7.5)) - 1.0);
    let HairlineStrokes { across: across_cells, along, contrast } = hairline_strokes(texture);
    let across = (around + lean * (rest.y - super::hair::scalp_line(rest))) * across_cells;
    // Each few hairs start and end at heights of their own: strokes on the noise's lattice rows
    // alone all end on the same lines, a comb's teeth across the forehead.
    let stagger = 1.5 * value_noise(Vec3::new(across * 0.37, 3.5, 5.5));
    let at = Vec3::new(across, rest.y * along + stagger, 11.5);
    let strokes = seen_over(value_noise(at), across_cells * pixel);
    let thinning = 4.0 * cover * (1.0 - cover);
    (cover + contrast * thinning * (strokes - 0.5)).clamp(0.0, 1.0)
}

/// How far (radians, about) the hairline's hairs lean out from upright at the temples and
/// beyond, where they reach that lean (decimetres of arc round the head from the middle of the
/// forehead), and how far each lock's hairs lean their own way.
const HAIRLINE_FAN: f32 = 0.45;
const HAIRLINE_FAN_REACH: f32 = 0.6;
const HAIRLINE_WAVE: f32 = 0.12;

/// The hairline's hair strokes in one texture: cells per decimetre across the hairs (which grow
/// up out of the forehead and temples) and along them, and how far a stroke moves the cover
/// from its mean where the cover is one half.
struct HairlineStrokes {
    across: f32,
    along: f32,
    contrast: f32,
}

/// Straight and wavy hairs about 0.25 mm apart and 4 mm long, soft: the fine hairs of a
/// hairline (0.4 mm apart, 7 mm long and at 1.6 times the contrast, at 970×960 they read as a
/// band of bristles hanging from the hair); curled ones 0.4 mm apart and 2 mm long, coiled ones
/// specks 0.4 by 0.6 mm, at the contrast that keeps them distinct (finer, a pixel at 970×960
/// sees them as a haze).
fn hairline_strokes(texture: HairTexture) -> HairlineStrokes {
    match texture {
        HairTexture::Straight | HairTexture::Wavy => HairlineStrokes { across: 400.0, along: 24.0, contrast: 1.2 },
        HairTexture::Curly => HairlineStrokes { across: 250.0, along: 50.0, contrast: 1.6 },
        HairTexture::Coiled => HairlineStrokes { across: 250.0, along: 160.0, contrast: 1.6 },
    }
}

/// Scalp hair (painted under the hair cards): see [`Hairline`].
fn hair_mask(rest: Vec3, hairline: Hairline) -> f32 {
    hairline.mask(rest, value_noise(rest * 90.0))
}

/// The stubble painted under a beard's cards (0..1, as an identity's `stubble`).
const BEARD_ROOTS: f32 = 1.0;

/// Beard shadow: jaw, chin and upper lip, below the cheeks; the beard's cards grow here too.
pub(crate) fn beard_mask(rest: Vec3) -> f32 {
    let x = rest.x.abs();
    if rest.z < 0.6 {
        return 0.0;
    }
    let upper_lip = blob(Vec2::new(x, rest.y), Vec2::new(0.0, 6.78), Vec2::new(0.22, 0.08));
    let jaw_top = 6.85 - 0.35 * (x / 0.7).powi(2);
    let jaw = smoothstep(jaw_top + 0.05, jaw_top - 0.08, rest.y) * smoothstep(6.0, 6.2, rest.y);
    upper_lip.max(jaw)
}

/// The fine furrows of the lips' red, running up and down across it about 1.7 mm apart: a
/// bump on `normal` across them, weighed by `lips` (how much of the red is here). Returns how
/// deep in a furrow the point lies (0..1, for its shade and its broken sheen); a pixel `pixel`
/// decimetres wide sees the furrows as it averages them. The furrows fan out from the middle of
/// the mouth (upright where the lips meet, leaning outward away from it, more toward the
/// corners), their spacing and course wander, and they break along their length: on a lattice
/// in plain x they stood in an even row, like a bar code.
fn lip_lines(rest: Vec3, lips: f32, pixel: f32, normal: &mut Vec3) -> f32 {
    let q = Vec3::new(lip_lines_across(rest) * LIP_LINES_ACROSS, rest.y * LIP_LINES_ALONG, rest.z * LIP_LINES_ALONG);
    let (n, slope) = value_noise_and_slope(q);
    // Finer than a pixel, the furrows fade into the red's mean.
    let seen = fainter(LIP_LINES_ACROSS * pixel).recip();
    *normal = (*normal - Vec3::X * (slope.x * BUMP_OF_SLOPE * 1.2 * lips * seen)).normalize();
    // A furrow where the noise crosses its middle: lines running along the stretch.
    (1.0 - smoothstep(0.0, 0.15, (n - 0.5).abs())) * lips * seen
}

/// Where `rest` lies across the lips' furrows (decimetres at the line where the lips meet): x
/// fanned out from the middle of the mouth, wandering.
fn lip_lines_across(rest: Vec3) -> f32 {
    let wander = LIP_LINES_WANDER * (2.0 * value_noise(Vec3::new(rest.x * 30.0, rest.y * 10.0, 5.0)) - 1.0);
    rest.x * LIP_LINES_FAN / ((rest.y - lips_meet()).abs() + LIP_LINES_FAN) + wander
}

/// Cells of the lip furrows' noise per decimetre: across them (about 1.7 mm apart) and along
/// them, up and down the red.
const LIP_LINES_ACROSS: f32 = 60.0;
const LIP_LINES_ALONG: f32 = 8.0;

/// Where the lips meet at rest (y, decimetres): where the upper lip begins, as its lip roll
/// declares it (`stimuli/engine/lip_rolls.toml`).
fn lips_meet() -> f32 {
    static MEET: OnceLock<f32> = OnceLock::new();
    *MEET.get_or_init(|| super::pose::LipRoll::named("upper_lip").expect("the built-in lip rolls have the upper lip").between[0])
}

/// How far beyond the line where the lips meet ([`lips_meet`], decimetres) lies the point the
/// lips' furrows fan out from: a furrow at x leans outward by x / (its distance from the
/// meeting line + this).
const LIP_LINES_FAN: f32 = 0.4;

/// How far (decimetres) the lips' furrows wander from an even spacing, over a few millimetres.
const LIP_LINES_WANDER: f32 = 0.006;

/// Cells of fibre noise across one hair card: the tone of bundles of fibres.
const FIBRE_NOISE_ACROSS: f32 = 13.5;

/// What a bit of hair looks like before it is lit: its albedo, its pigment (tinting the
/// second highlight), and the fibre, streak and root factors of [`FaceShader::lit_hair`].
#[derive(Clone, Copy)]
struct HairLook {
    albedo: Vec3,
    pigment: Vec3,
    fibres: f32,
    streaks: f32,
    rooted: f32,
}

/// Cells of highlight streaks across one hair card (coarser than the fibre noise: bundles of
/// fibres catch the light together).
const HIGHLIGHT_STREAKS_ACROSS: f32 = 0.7 * FIBRE_NOISE_ACROSS;

/// How far apart (in noise cells) neighbouring strands' fibre and streak patterns lie: steps that
/// never bring a strand back onto the lattice another one took. Seeds, not the golden ratio and
/// e, which they happen to round to.
const FIBRE_NOISE_PER_STRAND: f32 = 1.618;
#[allow(clippy::approx_constant)]
const STREAK_NOISE_PER_STRAND: f32 = 2.718;

/// The exponents of the hair's two highlights (Kajiya–Kay): broad enough that neighbouring
/// cards at slightly different angles share a highlight (at 48 and 12 each card lit up or
/// not on its own, a patchwork of planks over the crown).
const HAIR_LOBES: [f32; 2] = [20.0, 8.0];

/// How much of the hair's own hue (its pigment at full brightness) the primary highlight takes:
/// 0 a white sheen, 1 the pigment's hue.
const PRIMARY_HUE: f32 = 0.6;

/// The pigment of `identity`'s hair with `grey` (0..1) of it white: the pigmented fibres of
/// greying hair lose some of their colour too, and the white ones are mixed in as light
/// scattered among the fibres sees them ([`mix_fibres`]).
fn hair_pigment(identity: &Identity, grey: f32) -> Vec3 {
    let faded = identity.hair.lerp(Vec3::splat(identity.hair.dot(Vec3::splat(1.0 / 3.0))), 0.4 * identity.hair_grey);
    if grey <= 0.0 {
        return faded;
    }
    mix_fibres(faded, WHITE_HAIR, grey)
}

/// White hair (linear RGB): a mass of unpigmented fibres.
const WHITE_HAIR: Vec3 = Vec3::new(0.4, 0.4, 0.38);

/// The colour of a mass of fibres, `share` of them of a kind whose mass is coloured `b` and the
/// rest of one coloured `a`. Light that enters hair is scattered from fibre to fibre before it
/// comes out, and among dark fibres most of it is absorbed on the way: a tenth of white fibres
/// in black hair lightens it far less than a tenth of the way to white. So the fibres are mixed
/// by how much of the light each scattering keeps (its albedo ω), channel by channel, and the
/// mass's colour R follows from that as for a deep layer of isotropic scatterers:
/// R = (1 − s) / (1 + s), s = √(1 − ω).
fn mix_fibres(a: Vec3, b: Vec3, share: f32) -> Vec3 {
    let albedo = |r: f32| {
        let s = (1.0 - r.clamp(0.0, 0.99)) / (1.0 + r.clamp(0.0, 0.99));
        1.0 - s * s
    };
    let mass = |w: f32| {
        let s = (1.0 - w).max(0.0).sqrt();
        (1.0 - s) / (1.0 + s)
    };
    let mixed = |x: f32, y: f32| mass(albedo(x) + (albedo(y) - albedo(x)) * share.clamp(0.0, 1.0));
    Vec3::new(mixed(a.x, b.x), mixed(a.y, b.y), mixed(a.z, b.z))
}

/// The scalp where hair grows, painted as the hair seen between and under the cards.
#[derive(Clone, Copy)]
struct ScalpPaint {
    /// The hair's colour (greying included), a little darker, in fine streaks along the comb
    /// direction (sideways from the parting over the front of the head, down behind).
    hair: Vec3,
    /// The highlights' streaks there (as [`HIGHLIGHT_STREAKS_ACROSS`] on a card).
    streaks: f32,
    /// How much of the scalp's own skin shows (a thin line where straight hair parts).
    parting: f32,
}

/// The scalp in a parting: the skin's albedo dimmed by the hair standing on both sides of it.
const PARTING_SKIN: f32 = 0.7;
/// How far a parting wanders from its line (decimetres, over a few millimetres along it).
const PARTING_WANDER: f32 = 0.004;
/// How much of a parting the hairs crossing it hide where they cross.
const PARTING_CROSSED: f32 = 0.45;

/// The painted scalp at `rest` of `identity`, whose hairline is `hairline` and whose scalp
/// hair's pigment is `pigment` ([`hair_pigment`] at the person's greying).
fn scalp_paint(identity: &Identity, hairline: Hairline, pigment: Vec3, rest: Vec3, pixel: f32) -> ScalpPaint {
    let parting = super::hair::parting_x(identity.parting);
    // How far the hair over this point is combed sideways (from the parting) rather than back.
    let sideways = if parting.is_some() { smoothstep(0.0, 0.7, rest.z) } else { 0.0 };
    let across = |back: f32, side: f32| back + (side - back) * sideways;
    let cells = Vec3::new(across(220.0, 12.0), across(12.0, 90.0), across(30.0, 220.0));
    let q = rest * cells;
    // The streaks run along the comb, and a pixel spans most of them across it.
    let spanned = cells.max_element() * pixel;
    let hair = pigment * (0.63 + 0.35 * seen_over(value_noise(q), spanned));
    let streaks = 0.35 + 1.3 * seen_over(value_noise(q * 0.7 + Vec3::splat(7.0)), 0.7 * spanned);
    let curled = matches!(identity.hair_texture, HairTexture::Curly | HairTexture::Coiled);
    let parting = parting.filter(|_| !curled).map_or(0.0, |x| parting_shown(x, hairline, rest, pixel));
    ScalpPaint { hair, streaks, parting }
}

/// How much of the scalp's own skin shows at `rest` in a parting along `x`: a thin line
/// over the top of the head. A parting is not ruled: it wanders a little from side to side,
/// and hairs from either side cross it here and there (drawn straight and even, it read as a
/// seam).
fn parting_shown(x: f32, hairline: Hairline, rest: Vec3, pixel: f32) -> f32 {
    let half = super::hair::PARTING_HALF_WIDTH;
    if (rest.x - x).abs() >= half + PARTING_WANDER || rest.z <= 0.2 {
        return 0.0;
    }
    let along = Vec3::new(0.0, rest.y, rest.z);
    let wander = PARTING_WANDER * (2.0 * value_noise(along * 15.0) - 1.0);
    let line = (1.0 - smoothstep(0.5 * half, half, (rest.x - x - wander).abs())) * smoothstep(0.2, 0.6, rest.z);
    if line == 0.0 {
        return 0.0;
    }
    let crossed = 1.0 - PARTING_CROSSED * smoothstep(0.3, 0.7, seen_over(value_noise(along * 50.0 + Vec3::X * 7.0), 50.0 * pixel));
    // The parting runs through the hair, not beyond the roots into the painted fringe.
    0.75 * line * crossed * hairline.mask(rest, 0.5)
}

impl ScalpPaint {
    /// The painted scalp's albedo over `skin`: the hair, with the parting's line of skin.
    /// Gaps between cards show hair, not skin.
    fn over(&self, skin: Vec3) -> Vec3 {
        self.hair.lerp(skin * PARTING_SKIN, self.parting)
    }
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

const PATTERNS: [(&str, Relief); 13] = [
    ("forehead_inner", Relief { pattern: forehead_inner, bounds: [0.0, 0.32, 7.6, 8.05] }),
    ("forehead_outer", Relief { pattern: forehead_outer, bounds: [0.08, 0.6, 7.55, 8.0] }),
    ("glabella_vertical", Relief { pattern: glabella_vertical, bounds: [0.0, 0.16, 7.35, 7.65] }),
    ("glabella_horizontal", Relief { pattern: glabella_horizontal, bounds: [0.0, 0.12, 7.29, 7.44] }),
    ("crows_feet", Relief { pattern: crows_feet, bounds: [0.45, 0.64, 7.18, 7.42] }),
    ("lower_lid_bulge", Relief { pattern: lower_lid_bulge, bounds: [0.14, 0.47, 7.08, 7.22] }),
    ("nose_wrinkles", Relief { pattern: nose_wrinkles, bounds: [0.0, 0.17, 7.14, 7.36] }),
    ("nasolabial", Relief { pattern: nasolabial, bounds: [0.09, 0.4, 6.5, 7.0] }),
    ("cheek_apple", Relief { pattern: cheek_apple, bounds: [0.15, 0.45, 6.84, 7.1] }),
    ("dimple", Relief { pattern: dimple, bounds: [0.22, 0.36, 6.52, 6.71] }),
    ("chin_boss", Relief { pattern: chin_boss, bounds: [0.0, 0.2, 6.2, 6.52] }),
    ("lip_press_bulge", Relief { pattern: lip_press_bulge, bounds: [0.0, 0.24, 6.41, 6.8] }),
    ("cheek_hollow", Relief { pattern: cheek_hollow, bounds: [0.44, 0.68, 6.57, 6.83] }),
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
    (p - segment_nearest(p, a, b).0).length_squared()
}

/// The point of the segment from `a` to `b` nearest `p`, and how far along it that point lies
/// (0 at `a`, 1 at `b`).
fn segment_nearest(p: Vec2, a: Vec2, b: Vec2) -> (Vec2, f32) {
    let ab = b - a;
    let t = ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0);
    (a + ab * t, t)
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

/// AU4's vertical furrows between the brows, one on each side of the midline. They are laid
/// out at rest ([`GLABELLA_FURROW`]) where the corrugator's pull and the brows' targets draw
/// them to at E: medial of the brow heads, whose skin moves most, so that they stand upright
/// beside the midline (drawn 3.5 mm out at the foot, they met in a V at the nose's root).
fn glabella_vertical(p: Vec2) -> f32 {
    let [bottom, top] = GLABELLA_FURROW;
    1.2 * groove(segment_distance(p, bottom, top), 0.012)
}

/// Where AU4's furrow on the person's left runs at rest, from its foot to its top (rest-space
/// x and y, decimetres).
pub(crate) const GLABELLA_FURROW: [Vec2; 2] = [Vec2::new(0.115, 7.42), Vec2::new(0.075, 7.58)];

/// AU41's wrinkle across the root of the nose, level when the procerus draws the skin between
/// the brows down. It is laid out at rest ([`NOSE_ROOT_WRINKLE`]) where the pull and the brows'
/// targets draw a level line from, lower toward its ends: the pull draws the midline down most
/// (drawn level at rest, the wrinkle bent into a V pointing down the nose).
fn glabella_horizontal(p: Vec2) -> f32 {
    1.5 * groove(polyline_distance(p, &NOSE_ROOT_WRINKLE), 0.011)
}

/// Where AU41's wrinkle runs at rest, from the midline to its end on the person's left
/// (rest-space x and y, decimetres).
pub(crate) const NOSE_ROOT_WRINKLE: [Vec2; 4] =
    [Vec2::new(0.0, 7.37), Vec2::new(0.025, 7.350), Vec2::new(0.05, 7.339), Vec2::new(0.065, 7.334)];

fn crows_feet(p: Vec2) -> f32 {
    let origin = Vec2::new(0.485, 7.29);
    // Unit directions at -0.45, -0.15, 0.15 and 0.45 rad from the horizontal: the furrows.
    const FAN: [Vec2; 4] = [
        Vec2::new(0.900_447, -0.434_966),
        Vec2::new(0.988_771, -0.149_438),
        Vec2::new(0.988_771, 0.149_438),
        Vec2::new(0.900_447, 0.434_966),
    ];
    // At -0.3, 0 and 0.3 rad, between them: the skin the furrows bunch.
    const BUNCHED: [Vec2; 3] = [Vec2::new(0.955_336, -0.295_520), Vec2::X, Vec2::new(0.955_336, 0.295_520)];
    // Deepest at the eye's corner, fading toward the temple.
    let line = |dir: Vec2, width: f32| {
        let (nearest, along) = segment_nearest(p, origin + dir * 0.02, origin + dir * 0.11);
        (1.0 - 0.5 * along) * groove((p - nearest).length(), width)
    };
    let furrows: f32 = FAN.iter().map(|&dir| line(dir, 0.011)).sum();
    let bunched: f32 = BUNCHED.iter().map(|&dir| 0.35 * line(dir, 0.012)).sum();
    furrows - bunched
}

fn lower_lid_bulge(p: Vec2) -> f32 {
    let bulge = blob(p, Vec2::new(0.30, 7.165), Vec2::new(0.12, 0.035));
    bulge * 0.8 + 0.6 * groove(polyline_distance(p, &[Vec2::new(0.2, 7.135), Vec2::new(0.3, 7.125), Vec2::new(0.41, 7.15)]), 0.008)
}

/// AU35's hollow between cheekbone and jaw, where `cheek_suck` (deformers.toml) draws the skin
/// in: the dip itself is in the mesh; drawn here as well, it shades the dip's slopes and darkens
/// its floor, which the studio light alone barely shows on the side it lights.
fn cheek_hollow(p: Vec2) -> f32 {
    -2.5 * blob(p, Vec2::new(0.56, 6.70), Vec2::new(0.12, 0.13))
}

fn nose_wrinkles(p: Vec2) -> f32 {
    let span = 1.0 - smoothstep(0.08, 0.15, p.x);
    let lines: f32 = [7.20, 7.25, 7.30].iter().map(|&y| groove(p.y - (y - 0.6 * p.x * p.x), 0.011)).sum();
    span * lines
}

/// The nasolabial furrow from beside the nose's wing to beyond the mouth's corner: the upper
/// lip's skin slopes gently into it, and on its cheek side the cheek's mass rises steeply from
/// it into a rounded ridge (deepened, as AU6, AU10, AU11 and AU12 deepen it, the cheek bulges
/// over the furrow). Along its ends the ridge fades in and out; across the line through each
/// end the two sides blend over 2 mm, so the furrow has no seam.
fn nasolabial(p: Vec2) -> f32 {
    const FOLD: [Vec2; 4] = [Vec2::new(0.15, 6.94), Vec2::new(0.20, 6.82), Vec2::new(0.25, 6.70), Vec2::new(0.285, 6.58)];
    let (d, across, along) = polyline_across(p, &FOLD);
    let cheek = smoothstep(-0.01, 0.01, across);
    let furrow = 1.3 * groove(d, 0.024 - 0.01 * cheek);
    if cheek == 0.0 || d >= 0.2 {
        return furrow;
    }
    let span = smoothstep(0.0, 0.2, along) * (1.0 - smoothstep(0.75, 1.0, along));
    let ridge = d / 0.025 * (1.0 - d / 0.025).exp();
    furrow + 0.8 * cheek * span * ridge
}

/// The nearest point of the polyline `points` to `p`: its distance, how far `p` lies across
/// the polyline's direction there (positive to its left, y up: the cheek's side of a furrow
/// drawn down and out on the face's left half; zero on the lines through its ends along it),
/// and how far along the polyline it lies (0 at its first point, 1 at its last).
fn polyline_across(p: Vec2, points: &[Vec2]) -> (f32, f32, f32) {
    let segments = points.len().saturating_sub(1).max(1) as f32;
    let mut best = (f32::INFINITY, 0, 0.0, p);
    for (i, w) in points.windows(2).enumerate() {
        let (nearest, t) = segment_nearest(p, w[0], w[1]);
        let d2 = (p - nearest).length_squared();
        if d2 < best.0 {
            best = (d2, i, t, nearest);
        }
    }
    let (d2, i, t, nearest) = best;
    let across = match points.get(i..i + 2) {
        Some(&[a, b]) => (b - a).normalize().perp_dot(p - nearest),
        _ => 0.0,
    };
    (d2.sqrt(), across, (i as f32 + t) / segments)
}

/// AU6's raised cheek: the infraorbital triangle's skin and fat bunched up into a rounded mass
/// below the lower lid's furrow, above and beside the nasolabial furrow.
fn cheek_apple(p: Vec2) -> f32 {
    3.0 * blob(p, Vec2::new(0.30, 6.97), Vec2::new(0.14, 0.11))
}

/// AU14's dimpler: the tucked corner (the mouth's corner lies at x 0.25, y 6.615 at rest) sinks
/// into a small pit, the skin drawn in beside it bunches, and beyond that bulge a crescent
/// furrow curves round the corner from above it to below it, open toward the mouth.
fn dimple(p: Vec2) -> f32 {
    let crescent = [Vec2::new(0.283, 6.655), Vec2::new(0.292, 6.63), Vec2::new(0.293, 6.605), Vec2::new(0.285, 6.578)];
    let pit = 0.6 * groove((p - Vec2::new(0.262, 6.616)).length(), 0.01);
    let bunched = 0.35 * blob(p, Vec2::new(0.274, 6.617), Vec2::new(0.014, 0.03));
    pit + bunched + groove(polyline_distance(p, &crescent), 0.01)
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

/// A lattice point's hashed value in [0, 1].
fn hash(x: i32, y: i32, z: i32) -> f32 {
    hash_whole(x, y, z) * HASH_SCALE
}

/// A lattice point's hashed value as a whole number from 0 to 2²⁴ − 1 (exact in an `f32`):
/// noise blends these and scales the blend once, not each corner.
#[inline]
fn hash_whole(x: i32, y: i32, z: i32) -> f32 {
    let [fx, fy, fz] = HASH_AXES;
    let mut h = (x as u32).wrapping_mul(fx) ^ (y as u32).wrapping_mul(fy) ^ (z as u32).wrapping_mul(fz);
    h ^= h >> 13;
    h = h.wrapping_mul(HASH_MIX);
    h ^= h >> 15;
    // A 24-bit value converts exactly through `i32` (one instruction; from `u32` it is several).
    (h & 0x00ff_ffff) as i32 as f32
}

/// [`hash_whole`]'s factors: one per lattice axis, and one that mixes the bits of their
/// products' exclusive or.
const HASH_AXES: [u32; 3] = [0x8da6_b343, 0xd816_3841, 0xcb1a_b31f];
const HASH_MIX: u32 = 0x5bd1_e995;

/// Scales [`hash_whole`]'s values (and blends of them) to [0, 1]: 2²⁴ − 1 times it is exactly 1.
const HASH_SCALE: f32 = 1.0 / 16_777_215.0;

/// [`hash_whole`] at the eight corners of the lattice cell whose lowest corner is (x, y, z),
/// corner (dx, dy, dz) at index `dx + 2 dy + 4 dz`, one corner at a time: the reference the
/// side-by-side version ([`corner_hashes`]) matches.
#[cfg(any(test, not(target_arch = "x86_64")))]
fn cell_corners(x: i32, y: i32, z: i32) -> [f32; 8] {
    std::array::from_fn(|k| hash_whole(x.wrapping_add((k & 1) as i32), y.wrapping_add((k >> 1 & 1) as i32), z.wrapping_add((k >> 2) as i32)))
}

/// The noise's cells on SSE2 (part of every x86-64 processor): four corners' hashes side by
/// side, with the same integer operations as [`hash_whole`] (a 32-bit multiply taken as the low
/// half of two 64-bit ones, SSE2 having no 32-bit multiply) and the same exact conversion, and
/// their blends with the same floating-point operations lane by lane as the scalar ones.
#[cfg(target_arch = "x86_64")]
mod corner_hashes {
    use std::arch::x86_64::*;

    /// The eight corners as [`super::cell_corners`] gives them.
    #[cfg(test)]
    pub fn of_cell(x: i32, y: i32, z: i32) -> [f32; 8] {
        let (low, high) = halves(x, y, z);
        let ([a, b, c, d], [e, f, g, h]) = (lanes(low), lanes(high));
        [a, b, c, d, e, f, g, h]
    }

    /// [`super::blend_corners`] of the cell's corners at `s` (the same operations lane by
    /// lane, so the same value bit for bit), without storing the corners.
    pub fn blend_of_cell(x: i32, y: i32, z: i32, s: glam::Vec3) -> f32 {
        let (low, high) = halves(x, y, z);
        let (_, across) = along_x(low, high, s.x);
        // SAFETY: SSE2 only, no memory access.
        let along_y = unsafe {
            // Lanes x00, x10, x01, x11 → (x00, x01) toward (x10, x11).
            let from = _mm_shuffle_ps(across, across, 0b00_00_10_00);
            let to = _mm_shuffle_ps(across, across, 0b00_00_11_01);
            _mm_add_ps(from, _mm_mul_ps(_mm_sub_ps(to, from), _mm_set1_ps(s.y)))
        };
        let [y0, y1, _, _] = lanes(along_y);
        y0 + (y1 - y0) * s.z
    }

    /// [`super::blend_and_rises`] of the cell at `s`, side by side (the same operations lane
    /// by lane, so the same values bit for bit).
    pub fn blend_and_rises_of_cell(x: i32, y: i32, z: i32, s: glam::Vec3) -> (f32, f32, f32) {
        let (low, high) = halves(x, y, z);
        let (rise_x, across) = along_x(low, high, s.x);
        // SAFETY: SSE2 only, no memory access.
        let (rise_y, along_y) = unsafe {
            // Lanes (blend across x, rise along x) at dy = 0, each at dz = 0 and 1, toward the
            // same at dy = 1.
            let from = _mm_shuffle_ps(across, rise_x, 0b10_00_10_00);
            let to = _mm_shuffle_ps(across, rise_x, 0b11_01_11_01);
            let rise_y = _mm_sub_ps(to, from);
            (rise_y, _mm_add_ps(from, _mm_mul_ps(rise_y, _mm_set1_ps(s.y))))
        };
        let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
        let ([value_0, value_1, slope_x_0, slope_x_1], [slope_y_0, slope_y_1, _, _]) = (lanes(along_y), lanes(rise_y));
        (lerp(value_0, value_1, s.z), lerp(slope_x_0, slope_x_1, s.z), lerp(slope_y_0, slope_y_1, s.z))
    }

    /// Per (dy, dz) = (0, 0), (1, 0), (0, 1), (1, 1): the rise from dx = 0 to dx = 1, and the
    /// blend between them at `sx`.
    #[inline(always)]
    fn along_x(low: __m128, high: __m128, sx: f32) -> (__m128, __m128) {
        // SAFETY: SSE2 only, no memory access.
        unsafe {
            let from = _mm_shuffle_ps(low, high, 0b10_00_10_00);
            let to = _mm_shuffle_ps(low, high, 0b11_01_11_01);
            let rise = _mm_sub_ps(to, from);
            (rise, _mm_add_ps(from, _mm_mul_ps(rise, _mm_set1_ps(sx))))
        }
    }

    /// The four lanes of `v`, first lane first.
    #[inline(always)]
    fn lanes(v: __m128) -> [f32; 4] {
        let mut out = [0.0f32; 4];
        // SAFETY: SSE2 only; the store writes the four floats of `out`.
        unsafe { _mm_storeu_ps(out.as_mut_ptr(), v) };
        out
    }

    /// The hashes of the cell's corners with dz = 0 and with dz = 1, each in lanes (dx, dy) =
    /// (0, 0), (1, 0), (0, 1), (1, 1).
    #[inline(always)]
    fn halves(x: i32, y: i32, z: i32) -> (__m128, __m128) {
        let along = |v: i32, factor: u32| [(v as u32).wrapping_mul(factor), (v.wrapping_add(1) as u32).wrapping_mul(factor)];
        let [fx, fy, fz] = super::HASH_AXES;
        let ([x0, x1], [y0, y1], [z0, z1]) = (along(x, fx), along(y, fy), along(z, fz));
        // SAFETY: SSE2 is part of every x86-64 processor, so its intrinsics are always
        // available; none of these touch memory.
        unsafe {
            // `_mm_set_epi32` takes the last lane first.
            let xy = _mm_xor_si128(_mm_set_epi32(x1 as i32, x0 as i32, x1 as i32, x0 as i32), _mm_set_epi32(y1 as i32, y1 as i32, y0 as i32, y0 as i32));
            (finish(_mm_xor_si128(xy, _mm_set1_epi32(z0 as i32))), finish(_mm_xor_si128(xy, _mm_set1_epi32(z1 as i32))))
        }
    }

    /// The rest of [`super::hash_whole`] on four lanes.
    #[inline(always)]
    unsafe fn finish(h: __m128i) -> __m128 {
        // SAFETY (callers): SSE2 only, no memory access.
        unsafe {
            let h = _mm_xor_si128(h, _mm_srli_epi32(h, 13));
            let h = multiply_low(h, super::HASH_MIX);
            let h = _mm_xor_si128(h, _mm_srli_epi32(h, 15));
            _mm_cvtepi32_ps(_mm_and_si128(h, _mm_set1_epi32(0x00ff_ffff)))
        }
    }

    /// The low 32 bits of each lane times `factor`, as `u32::wrapping_mul`.
    #[inline(always)]
    unsafe fn multiply_low(h: __m128i, factor: u32) -> __m128i {
        // SAFETY (callers): SSE2 only, no memory access.
        unsafe {
            let f = _mm_set1_epi32(factor as i32);
            let even = _mm_mul_epu32(h, f);
            let odd = _mm_mul_epu32(_mm_srli_epi64(h, 32), f);
            // The low halves of the 64-bit products, back in lane order 0, 1, 2, 3.
            _mm_unpacklo_epi32(_mm_shuffle_epi32(even, 0b00_00_10_00), _mm_shuffle_epi32(odd, 0b00_00_10_00))
        }
    }
}

/// `x.floor() as i32` without a call into libm (the baseline x86-64 target has no rounding
/// instruction); the same value for every `x` whose floor fits in an `i32`.
#[inline]
fn floor_i32(x: f32) -> i32 {
    let t = truncate_i32(x);
    t - i32::from((t as f32) > x)
}

/// `x` rounded toward zero, for every `x` that fits in an `i32` (others give some `i32`): on
/// x86-64 one instruction, without the saturating checks of `as i32`.
#[inline]
fn truncate_i32(x: f32) -> i32 {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: SSE is part of every x86-64 processor; the conversion touches no memory.
    unsafe {
        use std::arch::x86_64::{_mm_cvttss_si32, _mm_set_ss};
        _mm_cvttss_si32(_mm_set_ss(x))
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        x as i32
    }
}

/// The lattice cell of `p` (its lowest corner) and the smoothed position inside it.
#[inline]
fn lattice(p: Vec3) -> ([i32; 3], Vec3) {
    let (cell, t) = lattice_offset(p);
    (cell, smoothed(t))
}

/// The lattice cell of `p` (its lowest corner) and the position inside it (0..1 each way).
#[inline]
fn lattice_offset(p: Vec3) -> ([i32; 3], Vec3) {
    let (x, y, z) = (floor_i32(p.x), floor_i32(p.y), floor_i32(p.z));
    ([x, y, z], p - Vec3::new(x as f32, y as f32, z as f32))
}

/// A position inside a cell eased with a smoothstep, so the blend has no kinks at the cell's
/// faces.
#[inline]
fn smoothed(t: Vec3) -> Vec3 {
    t * t * (Vec3::splat(3.0) - 2.0 * t)
}

/// Trilinear blend of a cell's corner values, `corner(dx, dy, dz)` with each offset 0 or 1.
#[cfg(any(test, not(target_arch = "x86_64")))]
#[inline]
fn blend_corners(s: Vec3, corner: impl Fn(usize, usize, usize) -> f32) -> f32 {
    let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
    let x00 = lerp(corner(0, 0, 0), corner(1, 0, 0), s.x);
    let x10 = lerp(corner(0, 1, 0), corner(1, 1, 0), s.x);
    let x01 = lerp(corner(0, 0, 1), corner(1, 0, 1), s.x);
    let x11 = lerp(corner(0, 1, 1), corner(1, 1, 1), s.x);
    lerp(lerp(x00, x10, s.y), lerp(x01, x11, s.y), s.z)
}

/// Trilinear value noise in [0, 1].
fn value_noise(p: Vec3) -> f32 {
    #[cfg(target_arch = "x86_64")]
    {
        let ([x, y, z], s) = lattice(p);
        corner_hashes::blend_of_cell(x, y, z, s) * HASH_SCALE
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        value_noise_scalar(p)
    }
}

/// [`value_noise`] one corner at a time: the reference the side-by-side version matches.
#[cfg(any(test, not(target_arch = "x86_64")))]
fn value_noise_scalar(p: Vec3) -> f32 {
    let ([x, y, z], s) = lattice(p);
    let corners = cell_corners(x, y, z);
    blend_corners(s, |dx, dy, dz| corners[dx + 2 * dy + 4 * dz]) * HASH_SCALE
}

/// `value_noise` at `p` (the same value bit for bit) and its slopes along x and y, per lattice
/// cell, from the same eight corners: the gradient of a bump without working the noise out
/// again beside `p`.
fn value_noise_and_slope(p: Vec3) -> (f32, Vec2) {
    let ([x, y, z], t) = lattice_offset(p);
    let s = smoothed(t);
    let ds = 6.0 * t * (Vec3::ONE - t);
    #[cfg(target_arch = "x86_64")]
    let (value, along_x, along_y) = corner_hashes::blend_and_rises_of_cell(x, y, z, s);
    #[cfg(not(target_arch = "x86_64"))]
    let (value, along_x, along_y) = blend_and_rises(&cell_corners(x, y, z), s);
    (value * HASH_SCALE, Vec2::new(ds.x * along_x, ds.y * along_y) * HASH_SCALE)
}

/// The blend of a cell's `corners` (see [`cell_corners`]) at `s`, and the rises of the blend
/// along x and along y within the cell (before the smoothstep's slope), one corner at a time:
/// the reference the side-by-side version matches.
#[cfg(any(test, not(target_arch = "x86_64")))]
fn blend_and_rises(cell: &[f32; 8], s: Vec3) -> (f32, f32, f32) {
    let c = |dx: usize, dy: usize, dz: usize| cell[dx + 2 * dy + 4 * dz];
    let value = blend_corners(s, c);
    let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
    // Along x: the four x-edges' rises, blended across y and z.
    let rise = |dy: usize, dz: usize| c(1, dy, dz) - c(0, dy, dz);
    let along_x = lerp(lerp(rise(0, 0), rise(1, 0), s.y), lerp(rise(0, 1), rise(1, 1), s.y), s.z);
    // Along y: the rise between the x-blends at y and y + 1, blended across z.
    let across = |dy: usize, dz: usize| lerp(c(0, dy, dz), c(1, dy, dz), s.x);
    let along_y = lerp(across(1, 0) - across(0, 0), across(1, 1) - across(0, 1), s.z);
    (value, along_x, along_y)
}

/// What the bumps of pores and lip furrows take of the noise's slope: 0.334 of it, the
/// root-mean-square of the step over 0.35 of a cell they were first drawn with (measured over
/// 20,000 points by `pore_slopes_are_as_steep_as_the_steps_they_replace`).
const BUMP_OF_SLOPE: f32 = 0.334;

/// A value `noise` seen by a pixel that spans `cells` of the noise's lattice cells: the pixel
/// averages them, so the contrast about the mean (0.5) falls as 1/√cells (the spread of a mean
/// of that many independent cells); a pixel within one cell sees the value itself.
fn seen_over(noise: f32, cells: f32) -> f32 {
    if cells <= 1.0 { noise } else { 0.5 + (noise - 0.5) / fainter(cells) }
}

/// How many times fainter a pattern's contrast is to a pixel spanning `cells` of its cells:
/// √cells, or 1 for a cell or less.
fn fainter(cells: f32) -> f32 {
    cells.max(1.0).sqrt()
}

/// Two octaves of value noise in [0, 1].
fn fbm(p: Vec3) -> f32 {
    0.65 * value_noise(p) + 0.35 * value_noise(p * 2.03 + Vec3::splat(17.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A map of `casters` seen from straight above (+z), `key_size` as the light's size.
    fn map_from_above(casters: &[[Vec3; 4]], key_size: f32) -> ShadowMap {
        let positions: Vec<Vec3> = casters.iter().flatten().copied().collect();
        let indices: Vec<[u32; 3]> = (0..casters.len() as u32).flat_map(|q| [[4 * q, 4 * q + 1, 4 * q + 2], [4 * q, 4 * q + 2, 4 * q + 3]]).collect();
        let scene = [Triangles { positions: &positions, normals: &[], uvs: &[], indices: &indices, part: 0, two_sided: false, coverage: &[] }];
        ShadowMap::new(&scene, Vec3::Z, key_size, Vec3::ZERO, 288, Some(1))
    }

    /// A rectangle at height `z` over x in `x`, y in −2..2, facing up.
    fn sheet(x: [f32; 2], z: f32) -> [Vec3; 4] {
        [Vec3::new(x[0], -2.0, z), Vec3::new(x[1], -2.0, z), Vec3::new(x[1], 2.0, z), Vec3::new(x[0], 2.0, z)]
    }

    /// The key light across the edge of the shadow a sheet over x < 0 at `height` casts on the
    /// floor (z = 0), every 0.002 dm from x = −0.4 to 0.4, and the width of its edge: from where
    /// a tenth of the light arrives to where nine tenths do.
    fn shadow_edge(height: f32, key_size: f32) -> (Vec<f32>, f32) {
        let map = map_from_above(&[sheet([-2.0, 2.0], 0.0), sheet([-2.0, 0.0], height)], key_size);
        let xs: Vec<f32> = (0..=400).map(|i| i as f32 * 0.002 - 0.4).collect();
        let reach: Vec<f32> = xs.iter().map(|&x| map.at_surface(Vec3::new(x, 0.0, 0.0), Vec3::Z, Vec3::Z).reach).collect();
        let first = |level: f32| xs[reach.iter().position(|&r| r >= level).expect("the floor is lit beyond the edge")];
        let width = first(0.9) - first(0.1);
        (reach, width)
    }

    #[test]
    fn a_shadow_edge_widens_with_the_casters_distance_and_the_lights_size() {
        // The fine map's texel is 1.31 mm; its filter spans ±1.5 texels, the coarse one ±6.
        let (near, near_width) = shadow_edge(0.1, 0.08);
        let (_, point_width) = shadow_edge(1.0, 0.0);
        let (_, middle_width) = shadow_edge(0.5, 0.08);
        let (far, far_width) = shadow_edge(1.0, 0.08);
        assert!((0.02..0.05).contains(&near_width), "a caster a centimetre away keeps a sharp edge: {near_width} dm");
        assert_eq!(near_width, point_width, "a point light keeps every edge sharp");
        // A light 0.08 wide seen from 1 dm blurs the edge over ±0.08 dm, capped at the coarse
        // filter's ±6 texels (0.079 dm): from a tenth to nine tenths about 0.8 of that width.
        assert!((0.10..0.16).contains(&far_width), "a caster 1 dm away blurs its edge: {far_width} dm");
        assert!(far_width >= 3.0 * near_width, "{far_width} against {near_width}");
        assert!(near_width < middle_width && middle_width < far_width, "{near_width} < {middle_width} < {far_width}");
        for reach in [&near, &far] {
            assert!(reach.windows(2).all(|w| w[1] >= w[0] - 1e-6), "the light rises steadily across the edge");
            assert!(reach[0] < 0.01 && reach[400] > 0.99, "dark under the sheet, lit beyond: {} {}", reach[0], reach[400]);
            assert!((0.4..0.6).contains(&reach[200]), "half the light at the edge itself: {}", reach[200]);
        }
    }

    #[test]
    fn where_the_nearest_map_sees_no_caster_the_coarse_filter_finds_none() {
        // Tiles at heights of their own over a floor: casters at every distance.
        let mut casters = vec![sheet([-2.0, 2.0], 0.0)];
        let mut seed = 12345u32;
        let mut next = || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 8) as f32 / (1u32 << 24) as f32
        };
        for _ in 0..300 {
            let (x, y, z, size) = (next() * 3.6 - 1.8, next() * 3.6 - 1.8, next() * 1.5, 0.02 + next() * 0.2);
            casters.push([Vec3::new(x, y, z), Vec3::new(x + size, y, z), Vec3::new(x + size, y + size, z), Vec3::new(x, y + size, z)]);
        }
        let map = map_from_above(&casters, 0.08);
        let (mut passed_over, mut found) = (0, 0);
        for _ in 0..20_000 {
            let position = Vec3::new(next() * 3.8 - 1.9, next() * 3.8 - 1.9, next() * 1.5);
            let (x, y, depth) = map.texel_point(position).expect("in front of the light");
            let coarse = map.coarse_footprint(x, y);
            let blocker = coarse.blockers(&map.coarse, depth, map.far);
            if !map.casters_near(&coarse, depth) {
                assert_eq!(blocker, None, "at {position}");
                passed_over += 1;
            }
            found += usize::from(blocker.is_some());
        }
        assert!(passed_over > 2_000 && found > 2_000, "both cases occur: {passed_over} passed over, {found} found");
    }

    /// Fibres mixed as scattered light sees them: no white gives the hair's own colour and all
    /// white gives white; more white is lighter; a tenth of white fibres lightens black hair
    /// (0.008 linear) by at most 0.6 of the step the mean of the colours would take (0.54: to
    /// 0.029, not 0.047), and blond hair (0.3) by at least 0.8 of it (0.85), as light fibres let
    /// most of the scattered light out either way.
    #[test]
    fn white_fibres_lighten_dark_hair_less_than_their_share() {
        let (black, blond) = (Vec3::splat(0.008), Vec3::splat(0.3));
        for hair in [black, blond] {
            assert!((mix_fibres(hair, WHITE_HAIR, 0.0) - hair).abs().max_element() < 1e-6);
            assert!((mix_fibres(hair, WHITE_HAIR, 1.0) - WHITE_HAIR).abs().max_element() < 1e-6);
            let steps: Vec<f32> = (0..=10).map(|k| mix_fibres(hair, WHITE_HAIR, k as f32 / 10.0).x).collect();
            assert!(steps.windows(2).all(|w| w[1] > w[0]), "{steps:?}");
        }
        let step = |hair: Vec3| (mix_fibres(hair, WHITE_HAIR, 0.1).x - hair.x) / (0.1 * (WHITE_HAIR.x - hair.x));
        assert!(step(black) <= 0.6, "black hair: {:.3} of the mean's step", step(black));
        assert!(step(blond) >= 0.8, "blond hair: {:.3} of the mean's step", step(blond));
    }

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

    /// Points on both sides of zero and of cell faces, as pores see them.
    fn noise_points(count: usize) -> impl Iterator<Item = Vec3> {
        (0..count).map(|i| Vec3::new(i as f32 * 0.173 - 300.0, i as f32 * -0.291 + 500.0, (i % 97) as f32 * 0.61 - 20.0))
    }

    #[test]
    fn noise_slopes_are_the_noise_value_and_its_gradient() {
        // A step of 1/1024 is exact at these magnitudes (one of 1e-3 is rounded by up to 6 %).
        let e = 1.0 / 1024.0;
        for q in noise_points(4000) {
            let (n, slope) = value_noise_and_slope(q);
            assert_eq!(n.to_bits(), value_noise(q).to_bits(), "{q}");
            let central = |axis: Vec3| {
                let at = |d: f32| f64::from(value_noise(q + axis * d));
                ((at(e) - at(-e)) / (2.0 * f64::from(e))) as f32
            };
            for (got, want, axis) in [(slope.x, central(Vec3::X), "x"), (slope.y, central(Vec3::Y), "y")] {
                assert!((got - want).abs() < 0.01, "{q} {axis}: slope {got}, central difference {want}");
            }
        }
    }

    /// The bumps keep the strength they were drawn with as steps over 0.35 of a cell: the
    /// root-mean-square of `BUMP_OF_SLOPE` times the slope is within 2 % of that of the steps.
    #[test]
    fn pore_slopes_are_as_steep_as_the_steps_they_replace() {
        let (mut steps, mut slopes) = (0.0f64, 0.0f64);
        for q in noise_points(20_000) {
            let (n, slope) = value_noise_and_slope(q);
            steps += f64::from(value_noise(q + Vec3::X * 0.35) - n).powi(2) + f64::from(value_noise(q + Vec3::Y * 0.35) - n).powi(2);
            slopes += f64::from(slope.x * BUMP_OF_SLOPE).powi(2) + f64::from(slope.y * BUMP_OF_SLOPE).powi(2);
        }
        let ratio = (slopes / steps).sqrt();
        assert!((ratio - 1.0).abs() < 0.02, "root-mean-square of the slopes over that of the steps: {ratio:.4}");
    }

    /// A cast shadow's edge on skin is warmer than its lit and its shadowed sides: in its middle
    /// red is lit 0.15 and green 0.035 more than blue (a grey edge read as a painted shadow);
    /// points fully lit take all the key light, fully shadowed ones the floor, and surfaces
    /// without wrap the same share in every channel.
    #[test]
    fn a_cast_shadows_edge_on_skin_is_warmer() {
        let (skin, floor) = (0.35, Vec3::splat(0.2));
        assert_eq!(key_share(floor, 0.0, skin), floor);
        assert_eq!(key_share(floor, 1.0, skin), Vec3::ONE);
        let middle = key_share(floor, 0.5, skin);
        assert!((middle.x - middle.z - 0.149).abs() < 0.002 && (middle.y - middle.z - 0.035).abs() < 0.002, "{middle}");
        assert!((middle.z - 0.6).abs() < 1e-6, "{middle}");
        assert_eq!(key_share(floor, 0.5, 0.0), Vec3::splat(0.6));
        let warmth = |r: f32| key_share(floor, r, skin).x - key_share(floor, r, skin).z;
        assert!(warmth(0.25) < warmth(0.5) && warmth(0.75) < warmth(0.5), "warmest in the middle of the edge");
    }

    /// Teeth read as teeth: the enamel at the biting edge is bluer than mid-crown (blue over red
    /// up by at least a tenth), the gap between two incisors opens into a notch at the edge (at
    /// most half as bright there as 5 mm up the same gap), and 12 mm above the edge of the upper
    /// teeth, over a tooth's middle as between two teeth, lies the pink gum (red at least twice
    /// green); the lower teeth mirror it, the gum below.
    #[test]
    fn teeth_have_a_translucent_edge_notches_and_gums() {
        for (upper, row) in [(true, &UPPER_TEETH), (false, &LOWER_TEETH)] {
            let at = |x: f32, from_edge: f32| teeth_albedo(Vec3::new(x, edge_height(&row.edge, x) + row.toward_gum * from_edge, 1.45), row);
            let blueness = |c: Vec3| c.z / c.x;
            let (edge_enamel, crown) = (at(0.04, 0.002), at(0.04, 0.05));
            assert!(blueness(edge_enamel) >= 1.1 * blueness(crown), "upper {upper}: edge {edge_enamel}, crown {crown}");
            let (notch, gap) = (at(0.08, 0.001), at(0.08, 0.05));
            assert!(notch.element_sum() <= 0.5 * gap.element_sum(), "upper {upper}: notch {notch}, gap {gap}");
            for x in [0.04, 0.08] {
                let gum = at(x, 0.12);
                assert!(gum.x >= 2.0 * gum.y, "upper {upper}: at x {x} 12 mm from the edge {gum}");
            }
            assert!(at(0.04, 0.08).y >= 0.7 * crown.y, "upper {upper}: enamel up to the gum");
        }
    }

    /// The camera: colours whose channels stay under the knee once exposed are recorded exposed,
    /// bit for bit; above it each channel rolls off on its own (continuous, with the exposure's
    /// slope at the knee and less above, rising, under 1 however bright), so a channel under the knee keeps
    /// its value and the channels keep their order; the figures are the curve's: 1.0 → 0.84,
    /// 2.0 → 0.963 64, and light skin's red of 1.3 (which clipped) → 0.920 79.
    #[test]
    fn the_camera_records_bright_light_on_a_soft_shoulder_channel_by_channel() {
        let channel = |v: f32| recorded(Vec3::splat(v)).x;
        for v in [0.0, 0.1, 0.35, 0.9] {
            let c = Vec3::new(v, 0.6 * v, 0.45 * v);
            assert_eq!(recorded(c), c * EXPOSURE, "{c} was not recorded as exposed");
        }
        assert!((channel(1.0) - 0.84).abs() < 1e-6 && (channel(2.0) - 0.963_636_4).abs() < 1e-6, "{} {}", channel(1.0), channel(2.0));
        let e = 1e-3;
        let at_knee = FILM_KNEE / EXPOSURE;
        assert!((channel(at_knee + e) - (at_knee + e) * EXPOSURE).abs() < 1e-5, "a step at the knee: {}", channel(at_knee + e));
        let mut last = FILM_KNEE;
        for i in 1..=400 {
            let v = at_knee + i as f32 * 0.05;
            let (now, slope) = (channel(v), (channel(v + e) - channel(v - e)) / (2.0 * e));
            assert!(now > last && now < 1.0 && slope < EXPOSURE + 1e-3, "at {v}: {now} after {last}, slope {slope}");
            last = now;
        }
        let skin = Vec3::new(1.3, 0.78, 0.55);
        let seen = recorded(skin);
        assert_eq!([seen.y, seen.z], [0.78 * EXPOSURE, 0.55 * EXPOSURE], "{skin}'s green and blue under the knee");
        assert!(seen.x > seen.y && (seen.x - 0.920_792).abs() < 1e-5, "{skin}'s red recorded at {}", seen.x);
    }

    /// The tongue's median groove is a soft furrow: its floor does not turn the normal (a crease
    /// there drew a dark seam down a wide-open mouth), the turn is continuous across the midline
    /// (within 0.002 either side of it at a thousandth of a millimetre; the crease jumped by 0.6),
    /// is the depth's own slope (checked by finite differences), peaks at 0.3 halfway up each
    /// wall (within 0.001, at ±w/√2) turning toward the midline, and is gone 3 half-widths out.
    #[test]
    fn the_tongues_groove_is_a_soft_furrow_with_no_crease() {
        let w = TONGUE_GROOVE_HALF_WIDTH;
        assert_eq!(tongue_groove(0.0), (1.0, 0.0));
        let (left, right) = (tongue_groove(-1e-5).1, tongue_groove(1e-5).1);
        assert!((left - right).abs() < 0.002, "the turn jumps from {left} to {right} across the midline");
        let peak = tongue_groove(w / 2f32.sqrt()).1;
        assert!((peak + TONGUE_GROOVE_TILT).abs() < 1e-3, "the wall turns the normal by {peak}");
        assert!((tongue_groove(-w / 2f32.sqrt()).1 - TONGUE_GROOVE_TILT).abs() < 1e-3);
        let steps: Vec<f32> = (-40..=40).map(|i| i as f32 * w / 10.0).collect();
        let h = 1e-4 * w;
        for &x in &steps {
            let (depth, tilt) = tongue_groove(x);
            let slope = (tongue_groove(x + h).0 - tongue_groove(x - h).0) / (2.0 * h) * w;
            let expected = TONGUE_GROOVE_TILT * slope / (2.0 / std::f32::consts::E).sqrt();
            assert!((tilt - expected).abs() < 2e-3, "at {x}: turn {tilt}, slope {expected}");
            assert!(tilt * x <= 0.0, "at {x} the wall turns away from the midline");
            if x.abs() >= 3.0 * w {
                assert!(depth < 2e-4 && tilt.abs() < 1e-3, "at {x}: depth {depth}, turn {tilt}");
            }
        }
    }

    /// AU18's pucker and AU22's funnel push the lips forward (at least 5 mm on the midline, on
    /// each of the eight), and the teeth behind them, as bright in a pucker as at the front of
    /// a smile before, take at most 0.6 of the light they take at rest; a smile (6+12+25) leaves
    /// the lips where they are (within 1 mm) and the teeth as lit (within 5 %). The tongue's
    /// tip, put out over the lower lip at 19E, takes all the light (it took 0.7 before), and
    /// at rest at most half.
    #[test]
    fn the_light_inside_the_mouth_follows_the_lips_and_the_tongue() {
        let model = FaceModel::embedded();
        let teeth = model.part(Part::TeethUpper).vertices.clone();
        let front = teeth.map(|i| model.rest[i as usize].z).fold(f32::MIN, f32::max);
        let tongue = model.part(Part::Tongue).vertices.clone();
        let at_rest = light_inside_mouth(front, 0.0, 1.0);
        crate::engine::identity::assert_on_the_eight(|identity| {
            let posed = |expression: &str| {
                let expression = crate::facs::Catalog::built_in().parse(expression).unwrap();
                crate::engine::pose_expression(&expression, identity).unwrap()
            };
            let forward = |expression: &str| lips_forward(model, &posed(expression));
            let mut failures = Vec::new();
            for pushed in ["18E", "22E"] {
                let ahead = forward(pushed);
                let light = light_inside_mouth(front, ahead, 1.0);
                if ahead < 0.05 || light > 0.6 * at_rest {
                    failures.push(format!("{pushed}: lips {ahead:.3} dm forward, teeth lit {light:.3} against {at_rest:.3} at rest"));
                }
            }
            let smile = forward("6+12+25");
            if smile > 0.01 || light_inside_mouth(front, smile, 1.0) < 0.95 * at_rest {
                failures.push(format!("6+12+25: lips {smile:.3} dm forward"));
            }
            for (expression, least, most) in [("19E", 1.0, 1.0), ("0", 0.0, 0.5)] {
                let posed = posed(expression);
                let tip = tongue.clone().map(|v| model.rest[v as usize].z + moved_in_head(&posed, v as usize).z).fold(f32::MIN, f32::max);
                let light = light_inside_mouth(tip, lips_forward(model, &posed), 1.0);
                if !(least..=most).contains(&light) {
                    failures.push(format!("{expression}: the tongue's tip at rest z {tip:.3} lit {light:.3}"));
                }
            }
            (!failures.is_empty()).then(|| failures.join("; "))
        });
    }

    /// The lips let light into the mouth as they part: lips at rest let in at most 0.4 of it on
    /// every shipped person (they rest 0.5–1.8 mm apart; a sliver of teeth as bright as at the
    /// front of a smile read as lips parted, AU25), AU25 lets in more at each level from A to E,
    /// and a smile with the lips parted (6+12+25), AU25 at D and E, AU26 and AU27 at E and one
    /// side's AU10 at E (the upper lip lifted off the teeth beside the midline; measured on the
    /// midline alone, the teeth under it were dark and MediaPipe's mouthUpperUp fell from about
    /// +0.6 to +0.05) let in all of it, so the teeth of a broad smile are lit as before.
    #[test]
    fn the_lips_let_light_into_the_mouth_as_they_part() {
        assert_eq!(light_through_lips(0.0), LIPS_CLOSED_LIGHT);
        assert_eq!(light_through_lips(-0.02), LIPS_CLOSED_LIGHT);
        assert_eq!(light_through_lips(LIPS_OPEN_GAP), 1.0);
        let model = FaceModel::embedded();
        let mut failures = Vec::new();
        for identity in crate::engine::identity::IdentityTable::built_in().iter() {
            let through = |expression: &str| {
                let expression = crate::facs::Catalog::built_in().parse(expression).unwrap();
                light_through_lips(lips_apart(model, &crate::engine::pose_expression(&expression, identity).unwrap()))
            };
            let rest = through("0");
            let ramp: Vec<f32> = ["25A", "25B", "25C", "25D", "25E"].map(through).into();
            let open = ["6+12+25", "25D", "25E", "26E", "27E", "L10E", "R10E"].map(through);
            if rest > 0.4 || ramp.windows(2).any(|w| w[1] < w[0]) || ramp[0] < rest || open.iter().any(|&o| o < 1.0) {
                failures.push(format!("{}: rest {rest:.2}, 25A-E {ramp:.2?}, open {open:.2?}", identity.id));
            }
        }
        assert!(failures.is_empty(), "{}", failures.join("\n"));
    }

    /// A tooth's face is convex across the arch: at the middle of the left central incisor the
    /// normal faces as the arch does, toward its inner side it turns to the midline and toward
    /// its outer side away from it, by 40 to 45 degrees at the sides; the right side mirrors it.
    #[test]
    fn a_tooths_face_turns_toward_its_neighbours() {
        let middle = tooth_normal(Vec3::Z, 0.04);
        assert!((middle - Vec3::Z).length() < 1e-6, "{middle}");
        for x in [0.001, 0.079, -0.001, -0.079] {
            let n = tooth_normal(Vec3::Z, x);
            let outward = n.x * x.signum();
            let toward_outer_side = x.abs() > 0.04;
            assert_eq!(outward > 0.0, toward_outer_side, "at x {x}: {n}");
            let degrees = n.dot(Vec3::Z).acos().to_degrees();
            assert!((40.0..=45.0).contains(&degrees), "at x {x}: {degrees} degrees");
        }
    }

    /// The teeth take the key light at the pixel, not from the corners of the arch: its few
    /// triangles are large against the upper lip's soft shadow, and interpolated from their
    /// corners, a corner in the shadow darkened a triangle of a tooth and not the rest of it
    /// (wm1's 6+12+25 at 970×960). On the upper teeth of wm1's broad smile, lit by the key
    /// light past the head's own skin and teeth, a fragment is shaded the same whatever light
    /// its corners got (with the corners' light it failed); the light there varies, so the
    /// lookup matters: at most 0.6 in the lip's shadow, at least 0.9 in the open (0 and 1).
    #[test]
    fn the_teeth_are_lit_at_the_pixel_not_from_the_arch_corners() {
        let model = FaceModel::embedded();
        let identity = crate::engine::identity::IdentityTable::built_in().get("wm1").unwrap();
        let expression = crate::facs::Catalog::built_in().parse("6+12+25").unwrap();
        let posed = crate::engine::pose_expression(&expression, identity).unwrap();
        let camera = crate::engine::portrait_camera(posed.anchor, 485, 480);
        let look = Look::default();
        let lighting = look.light.lighting();
        let key = lighting.lights[0].direction;
        let parts = [Part::Skin, Part::TeethUpper];
        let scene: Vec<Triangles> = parts.iter().map(|&part| Triangles { positions: &posed.positions, normals: &posed.normals, uvs: &[], indices: model.casting_triangles(part), part: part.id(), two_sided: false, coverage: &[] }).collect();
        let map = ShadowMap::new(&scene, key, lighting.key_size, posed.anchor, 1024, Some(1));
        let mut shader = FaceShader::new(model, &posed, identity, &look, &camera).with_shadows(&map);
        let fragments: Vec<Fragment> = model.part(Part::TeethUpper).triangles.iter().enumerate().flat_map(|(i, &vertex)| {
            let corners = vertex.map(|v| posed.positions[v as usize]);
            let normals = vertex.map(|v| posed.normals[v as usize]);
            [Vec3::splat(1.0 / 3.0), Vec3::new(0.6, 0.2, 0.2), Vec3::new(0.2, 0.6, 0.2), Vec3::new(0.2, 0.2, 0.6)].map(|w| {
                let position = corners[0] * w.x + corners[1] * w.y + corners[2] * w.z;
                let normal = (normals[0] * w.x + normals[1] * w.y + normals[2] * w.z).normalize();
                let view_dir = (camera.eye - position).normalize();
                Fragment { position, normal, uv: Vec2::ZERO, part: Part::TeethUpper.id(), triangle: i as u32, vertex, barycentric: w, view_dir, pixel: (0, 0) }
            })
        }).filter(|f| f.normal.dot(f.view_dir) > 0.3).collect();
        let reaches: Vec<f32> = fragments.iter().map(|f| shader.key_reach_at_pixel(f)).collect();
        let (least, most) = reaches.iter().fold((f32::MAX, f32::MIN), |(l, m), &r| (l.min(r), m.max(r)));
        assert!(least <= 0.6 && most >= 0.9, "the key light on the teeth from {least:.3} to {most:.3}");
        let shaded = |shader: &FaceShader| fragments.iter().map(|f| shader.shade_teeth(f, &UPPER_TEETH)).collect::<Vec<_>>();
        let before = shaded(&shader);
        for v in model.part(Part::TeethUpper).vertices.clone() {
            (shader.key_light.reach[v as usize], shader.key_light.edge[v as usize]) = (0.0, [0.0, 0.0]);
        }
        assert_eq!(shaded(&shader), before, "the teeth's shading read the light at the arch's corners");
    }

    /// The light left in a cast shadow on the skin has the skin's hue at the luminance of white
    /// (under the cool fill a shadow on the nose's side read as a grey patch): the same ratios
    /// of red to green to blue as the skin, luminance 1; white for a grey skin; and the floor
    /// it colours leaves the key light's share in the open at 1.
    #[test]
    fn a_cast_shadow_on_skin_keeps_the_skins_hue() {
        for skin in [Vec3::new(0.62, 0.36, 0.26), Vec3::new(0.2, 0.09, 0.05)] {
            let bounce = skin_bounce(skin);
            assert!((bounce.dot(Vec3::from(REC709)) - 1.0).abs() < 1e-5, "{bounce}");
            assert!((bounce.x / bounce.z - skin.x / skin.z).abs() < 1e-4 && (bounce.y / bounce.z - skin.y / skin.z).abs() < 1e-4, "{bounce}");
            assert_eq!(key_share(0.15 * bounce, 1.0, 0.35), Vec3::ONE);
        }
        assert!((skin_bounce(Vec3::splat(0.3)) - Vec3::ONE).abs().max_element() < 1e-5);
        assert_eq!(skin_bounce(Vec3::ZERO), Vec3::ONE);
    }

    #[test]
    fn the_neckline_is_lower_at_the_front_than_at_the_back() {
        let front = below_neckline(None, Vec3::new(0.0, 5.6, 1.0));
        let back = below_neckline(None, Vec3::new(0.0, 5.6, -0.5));
        let side = below_neckline(None, Vec3::new(0.75, 5.6, 0.25));
        assert!((front - 0.04).abs() < 1e-5, "{front}");
        assert!((back - 0.22).abs() < 1e-5, "{back}");
        assert!((side - 0.13).abs() < 1e-5, "{side}");
    }

    /// The scalp under grey hair is painted grey (not in the pigment alone, a dark hole at the
    /// parting), and straight hair shows a thin line of scalp where it parts, which the hairs
    /// cross here and there; curls show none.
    #[test]
    fn the_painted_scalp_is_the_hairs_colour_with_a_thin_parting() {
        let table = crate::engine::identity::IdentityTable::built_in();
        let grey = table.get("hlf2").unwrap().clone();
        let top = Vec3::new(0.4, 8.3, 0.6);
        let skin = Vec3::new(0.8, 0.6, 0.5);
        let luma = |c: Vec3| c.dot(Vec3::splat(1.0 / 3.0));
        assert!(luma(scalp_paint(&grey, Hairline::of(&grey), hair_pigment(&grey, grey.hair_grey), top, 0.0).over(skin)) > 0.5 * luma(hair_pigment(&grey, grey.hair_grey)));
        assert!(luma(hair_pigment(&grey, grey.hair_grey)) > 1.3 * luma(grey.hair));
        let mut straight = table.get("wf1").unwrap().clone();
        // Along 2 cm of the parting (wf1 parts in the middle) and 1.8 mm beside it.
        let along: Vec<Vec3> = (0..80).map(|k| Vec3::new(0.0, 8.3, 0.7 + 0.0025 * k as f32)).collect();
        let beside = Vec3::X * 3.0 * crate::engine::hair::PARTING_HALF_WIDTH;
        let paint = |identity: &Identity, at: Vec3| scalp_paint(identity, Hairline::of(identity), hair_pigment(identity, identity.hair_grey), at, 0.0);
        let from_scalp = |identity: &Identity, shift: Vec3| {
            along.iter().map(|&at| paint(identity, at + shift).over(skin).distance(skin * PARTING_SKIN)).sum::<f32>() / along.len() as f32
        };
        assert!(from_scalp(&straight, Vec3::ZERO) < 0.5 * from_scalp(&straight, beside));
        // Hairs cross it here and there: the scalp shows more in some places than in others.
        let shown: Vec<f32> = along.iter().map(|&at| paint(&straight, at).parting).collect();
        let (least, most) = shown.iter().fold((f32::MAX, f32::MIN), |(l, m), &v| (l.min(v), m.max(v)));
        assert!(most - least >= 0.25, "the parting shows {least}..{most}");
        straight.hair_texture = HairTexture::Curly;
        assert!(from_scalp(&straight, Vec3::ZERO) > 0.3);
    }

    #[test]
    fn brows_sit_above_the_eyes_and_not_on_the_forehead() {
        assert!(brow_band(Vec3::new(0.3, 7.50, 1.4)) > 0.9);
        assert!(brow_band(Vec3::new(-0.3, 7.50, 1.4)) > 0.9);
        assert_eq!(brow_band(Vec3::new(0.3, 7.8, 1.4)), 0.0);
        assert_eq!(brow_band(Vec3::new(0.0, 7.5, 1.5)), 0.0);
        assert_eq!(brow_mask(Vec3::new(0.3, 7.8, 1.4), 0.003), 0.0);
    }

    /// Greying brows keep more of their pigment than the scalp hair: on everyone whose hair is
    /// half grey or more, the brows are under 0.4 of the brightness of the hair's greyed pigment
    /// (brows lerped to a light grey at 0.6 of the hair's greying read about 0.6 of it).
    #[test]
    fn greying_brows_keep_their_pigment_longer_than_the_hair() {
        let bright = |c: Vec3| c.dot(Vec3::from(REC709));
        let mut greying = 0;
        for identity in crate::engine::identity::IdentityTable::built_in().iter().filter(|i| i.hair_grey >= 0.5) {
            let (brows, hair) = (bright(brow_colour(identity)), bright(hair_pigment(identity, identity.hair_grey)));
            assert!(brows < 0.4 * hair, "{}: brows {brows:.3}, greyed hair {hair:.3}", identity.id);
            greying += 1;
        }
        assert!(greying >= 4, "the shipped people include greying ones ({greying})");
    }

    /// The brow's hairs are strokes along the way they grow: on a patch of the head, of the
    /// body below and above its middle, and of the tail, the hairs' pattern varies least along
    /// its growth (the structure tensor of its gradient: the direction across which it varies
    /// least lies within 0.15 rad of the growth, and it varies at least twice as much across).
    /// A pixel many strokes wide sees their mean: the spread falls to under a third.
    #[test]
    fn brow_hairs_run_the_way_they_grow() {
        let patches = [(0.02, 0.0, BROW_HAIR_ANGLES[0]), (0.45, -0.8, BROW_HAIR_ANGLES[1]), (0.45, 0.9, BROW_HAIR_ANGLES[2]), (0.95, 0.0, BROW_HAIR_ANGLES[3])];
        for (along, across, grows) in patches {
            let x = 0.075 + 0.44 * along;
            let (c, half) = brow_line(along);
            let brow = BrowPoint { along, across, density: 1.0 };
            let origin = Vec2::new(x, c + across * half);
            let close = Grain::of(|p| brow_hairs(p, &brow, 0.0), origin, 0.0004);
            println!("brow along {along}, across {across}: hairs run {:.3} rad (grown at {grows}), variation across/along {:.1}", close.runs, close.anisotropy);
            assert!(close.off(grows) < 0.15, "along {along}, across {across}: the hairs run {:.2} rad, grown at {grows}", close.runs);
            assert!(close.anisotropy >= 2.0, "along {along}, across {across}: variation across/along {:.1}", close.anisotropy);
            let far = Grain::of(|p| brow_hairs(p, &brow, 0.05), origin, 0.0004);
            assert!(far.spread < close.spread / 3.0, "along {along}: spread {} seen from far, {} close", far.spread, close.spread);
        }
    }

    /// Which way a pattern runs over a patch of 41 × 41 points `h` apart around `origin` (the
    /// structure tensor of its finite-difference gradients) and how much it varies.
    struct Grain {
        /// The direction of least variation (radians from +x).
        runs: f64,
        /// Variation across the grain over variation along it.
        anisotropy: f64,
        /// Standard deviation of the values.
        spread: f32,
    }

    impl Grain {
        fn of(pattern: impl Fn(Vec2) -> f32, origin: Vec2, h: f32) -> Grain {
            let e = h / 8.0;
            let (mut jxx, mut jxy, mut jyy) = (0.0f64, 0.0f64, 0.0f64);
            let mut values = Vec::new();
            for i in -20..=20 {
                for j in -20..=20 {
                    let p = origin + Vec2::new(i as f32, j as f32) * h;
                    let v = pattern(p);
                    let gx = f64::from((pattern(p + Vec2::X * e) - v) / e);
                    let gy = f64::from((pattern(p + Vec2::Y * e) - v) / e);
                    (jxx, jxy, jyy) = (jxx + gx * gx, jxy + gx * gy, jyy + gy * gy);
                    values.push(v);
                }
            }
            let runs = 0.5 * (2.0 * jxy).atan2(jxx - jyy) + std::f64::consts::FRAC_PI_2;
            let root = ((jxx - jyy).powi(2) + 4.0 * jxy * jxy).sqrt();
            let (most, least) = (0.5 * (jxx + jyy + root), 0.5 * (jxx + jyy - root));
            let mean = values.iter().sum::<f32>() / values.len() as f32;
            let spread = (values.iter().map(|x| (x - mean).powi(2)).sum::<f32>() / values.len() as f32).sqrt();
            Grain { runs, anisotropy: most / least.max(1e-12), spread }
        }

        /// How far (radians, 0..π/2) the grain runs from the direction `angle`.
        fn off(&self, angle: f32) -> f64 {
            let off = (self.runs - f64::from(angle)).rem_euclid(std::f64::consts::PI);
            off.min(std::f64::consts::PI - off)
        }
    }

    /// Where the painted hair thins out toward the forehead it is drawn as hairs: straight hairs
    /// as strokes (at least 3× more variation across them than along) running up the middle of
    /// the forehead (within 0.15 rad of vertical), leaning out beside it, the two sides alike,
    /// and down and back at the temple (0.2–0.6 rad from upright; all upright, they read as a
    /// comb's teeth), coiled hairs as specks without a strong grain (under 3×); the mean cover
    /// stays where it was (within 0.05), a pixel many hairs wide sees under a third of the
    /// spread, and bare skin and full cover are left alone.
    #[test]
    fn the_hairline_is_drawn_as_hairs() {
        let up = std::f32::consts::FRAC_PI_2;
        for (texture, x, z) in [(HairTexture::Straight, 0.1, 1.1), (HairTexture::Wavy, 0.0, 1.1), (HairTexture::Coiled, 0.1, 1.1)] {
            for cover in [0.25, 0.5, 0.75] {
                let at = |p: Vec2, pixel: f32| hairline_hairs(Vec3::new(p.x, p.y, z), cover, texture, pixel);
                let origin = Vec2::new(x, 8.0);
                let close = Grain::of(|p| at(p, 0.0), origin, 0.002);
                println!("{texture:?} cover {cover}: spread {:.3}, runs {:.3} rad, across/along {:.1}", close.spread, close.runs, close.anisotropy);
                // The mean over a patch of hundreds of hairs (1 mm across, 5 mm up).
                let wide: Vec<f32> = (0..100).flat_map(|i| (0..100).map(move |j| (i, j))).map(|(i, j)| at(origin + Vec2::new(i as f32 * 0.001, j as f32 * 0.005), 0.0)).collect();
                let mean = wide.iter().sum::<f32>() / wide.len() as f32;
                assert!((mean - cover).abs() <= 0.05, "{texture:?}: mean cover {mean} for {cover}");
                if texture == HairTexture::Coiled {
                    assert!(close.anisotropy < 3.0, "coiled hairs are specks, not strokes: {:.1}", close.anisotropy);
                } else {
                    assert!(close.off(up) < 0.15, "{texture:?}: the hairs run {:.2} rad", close.runs);
                    assert!(close.anisotropy >= 3.0, "{texture:?}: variation across/along {:.1}", close.anisotropy);
                }
                let far = Grain::of(|p| at(p, 0.05), origin, 0.002);
                assert!(far.spread < close.spread / 3.0, "{texture:?}: spread {} seen from far, {} close", far.spread, close.spread);
            }
            // At the temple the hairs run down and back (the patch lies in the plane x = 0.75,
            // its first axis along z, forward: a run below upright climbs forward).
            let temple = Grain::of(|p| hairline_hairs(Vec3::new(0.75, p.y, p.x), 0.5, texture, 0.0), Vec2::new(0.6, 7.8), 0.002);
            // Beside the middle of the forehead they lean out, each side its own way.
            let side = |x: f32| Grain::of(|p| hairline_hairs(Vec3::new(p.x, p.y, 1.2), 0.5, texture, 0.0), Vec2::new(x, 7.95), 0.002);
            let (left, right) = (side(0.3), side(-0.3));
            println!("{texture:?}: temple {:.3} rad, forehead left {:.3}, right {:.3}", temple.runs, left.runs, right.runs);
            if texture != HairTexture::Coiled {
                let back = up as f64 - temple.runs;
                assert!((0.2..0.6).contains(&back) && temple.anisotropy >= 3.0, "{texture:?} at the temple: {:.2} rad, {:.1}", temple.runs, temple.anisotropy);
                let (out_left, out_right) = (left.runs - up as f64, up as f64 - right.runs);
                assert!(out_left > 0.05 && out_right > 0.05 && (out_left - out_right).abs() < 0.15, "{texture:?} beside the forehead's middle: {out_left:.2} and {out_right:.2} rad out");
            }
            assert_eq!(hairline_hairs(Vec3::new(x, 8.0, z), 0.0, texture, 0.0), 0.0);
            assert_eq!(hairline_hairs(Vec3::new(x, 8.0, z), 1.0, texture, 0.0), 1.0);
        }
    }

    /// The hairline's hairs start and end at heights of their own: across hundreds of
    /// columns of hairs, the strokes' spread is about the same at every height within a
    /// stroke's length: within a quarter (1.14 measured). Strokes ending on shared rows made
    /// those rows a comb's edge, the spread there 1.38 times that between them.
    #[test]
    fn the_hairline_hairs_end_at_heights_of_their_own() {
        let columns = 600;
        let spread_at = |y: f32| {
            let values: Vec<f32> = (0..columns).map(|i| hairline_hairs(Vec3::new(-0.3 + 0.001 * i as f32, y, 1.1), 0.5, HairTexture::Straight, 0.0)).collect();
            let mean = values.iter().sum::<f32>() / columns as f32;
            (values.iter().map(|v| (v - mean).powi(2)).sum::<f32>() / columns as f32).sqrt()
        };
        let cell = 1.0 / hairline_strokes(HairTexture::Straight).along;
        let spreads: Vec<f32> = (0..16).map(|k| spread_at(8.0 + cell * k as f32 / 16.0)).collect();
        let (low, high) = spreads.iter().fold((f32::MAX, f32::MIN), |(l, h), &s| (l.min(s), h.max(s)));
        println!("spreads {low:.4} {high:.4} ratio {:.3}", high / low);
        assert!(high <= 1.25 * low, "spread of the strokes {low:.3}..{high:.3} over a stroke's length");
    }

    /// The lips' red carries fine furrows running up and down it, fanning out from the middle
    /// of the mouth: the furrow pattern varies least within 0.15 rad of the fan's direction
    /// (upright at the middle, leaning 0.29 rad outward 15 mm from it, on the upper lip) and at
    /// least 3× as much across as along; its furrows are not evenly spaced (along 2 cm of the
    /// lower lip the widest of its noise's cells is wider than the narrowest by at least a third
    /// of their mean width; on a lattice in plain x they were all 1.7 mm); it bends the
    /// normal sideways only; a pixel a dozen furrows wide sees under a third of their spread;
    /// off the red nothing changes.
    #[test]
    fn lip_lines_run_up_and_down_the_red() {
        for origin in [Vec2::new(0.05, 6.62), Vec2::new(-0.15, 6.7), Vec2::new(0.15, 6.52)] {
            let furrows = |p: Vec2, pixel: f32| lip_lines(Vec3::new(p.x, p.y, 1.5), 1.0, pixel, &mut { Vec3::Z });
            let close = Grain::of(|p| furrows(p, 0.0), origin, 0.002);
            let lean = origin.x * (origin.y - lips_meet()).signum() / ((origin.y - lips_meet()).abs() + LIP_LINES_FAN);
            let fan = 1.0f32.atan2(lean);
            println!("lip lines at {origin}: run {:.3} rad (the fan {fan:.3}), across/along {:.1}, spread {:.3}", close.runs, close.anisotropy, close.spread);
            assert!(close.off(fan) < 0.15, "the furrows run {:.2} rad, the fan {fan:.2}", close.runs);
            assert!(close.anisotropy >= 3.0, "variation across/along {:.1}", close.anisotropy);
            let far = Grain::of(|p| furrows(p, 0.2), origin, 0.002);
            assert!(far.spread < close.spread / 3.0, "spread {} seen from far, {} close", far.spread, close.spread);
            let bent: Vec<Vec3> = (0..200)
                .map(|i| {
                    let mut normal = Vec3::Z;
                    lip_lines(Vec3::new(origin.x + i as f32 * 0.0005, origin.y, 1.5), 1.0, 0.0, &mut normal);
                    normal
                })
                .collect();
            assert!(bent.iter().all(|n| n.y.abs() < 1e-6 && (n.length() - 1.0).abs() < 1e-5));
            assert!(bent.iter().any(|n| n.x.abs() > 0.05), "the furrows hardly bend the normal");
            let mut normal = Vec3::Z;
            assert_eq!(lip_lines(Vec3::new(origin.x, origin.y, 1.5), 0.0, 0.0, &mut normal), 0.0);
            assert_eq!(normal, Vec3::Z);
        }
        // Where the furrows' noise crosses from one lattice cell to the next, along 2 cm of the
        // lower lip: not an even row.
        let cell = |i: usize| (lip_lines_across(Vec3::new(-0.1 + i as f32 * 0.0001, 6.55, 1.5)) * LIP_LINES_ACROSS).floor();
        let steps: Vec<f32> = (1..2000).filter(|&i| cell(i) != cell(i - 1)).map(|i| i as f32 * 0.0001).collect();
        let gaps: Vec<f32> = steps.windows(2).map(|w| w[1] - w[0]).collect();
        let mean = gaps.iter().sum::<f32>() / gaps.len() as f32;
        let (least, most) = gaps.iter().fold((f32::MAX, f32::MIN), |(l, m), &g| (l.min(g), m.max(g)));
        println!("{} cells along 2 cm, {least:.4}..{most:.4} dm wide, {mean:.4} on average", steps.len());
        assert!(gaps.len() >= 8 && most - least >= mean / 3.0, "cells {gaps:?}");
    }

    /// The eight corners of a cell hash side by side as [`hash_whole`] hashes each, bit for
    /// bit, in cells anywhere (negative, large, at the ends of `i32`, where `x + 1` wraps), and
    /// the noise and its slopes are those of the blends one corner at a time.
    #[test]
    fn cell_corners_are_the_corners_hashes() {
        let mut cells: Vec<[i32; 3]> = vec![[0, 0, 0], [-1, -1, -1], [i32::MAX, i32::MIN, -7], [i32::MIN, i32::MAX, i32::MAX]];
        cells.extend((0..2000).map(|i: i32| [i.wrapping_mul(7919) - 5000, i.wrapping_mul(-104_729), i.wrapping_mul(1_299_709)]));
        for [x, y, z] in cells {
            let corners = cell_corners(x, y, z);
            for (k, corner) in corners.iter().enumerate() {
                let (dx, dy, dz) = ((k & 1) as i32, (k >> 1 & 1) as i32, (k >> 2) as i32);
                let expected = hash_whole(x.wrapping_add(dx), y.wrapping_add(dy), z.wrapping_add(dz));
                assert_eq!(corner.to_bits(), expected.to_bits(), "cell ({x}, {y}, {z}), corner {k}");
            }
            #[cfg(target_arch = "x86_64")]
            assert_eq!(corner_hashes::of_cell(x, y, z).map(f32::to_bits), corners.map(f32::to_bits), "cell ({x}, {y}, {z})");
        }
        // The noise and its slopes are those of the blends one corner at a time, bit for bit.
        for p in noise_points(5000) {
            assert_eq!(value_noise(p).to_bits(), value_noise_scalar(p).to_bits(), "{p}");
            let ([x, y, z], t) = lattice_offset(p);
            let (value, along_x, along_y) = blend_and_rises(&cell_corners(x, y, z), smoothed(t));
            let ds = 6.0 * t * (Vec3::ONE - t);
            let (n, slope) = value_noise_and_slope(p);
            assert_eq!(n.to_bits(), (value * HASH_SCALE).to_bits(), "{p}");
            assert_eq!(slope.x.to_bits(), (ds.x * along_x * HASH_SCALE).to_bits(), "{p}");
            assert_eq!(slope.y.to_bits(), (ds.y * along_y * HASH_SCALE).to_bits(), "{p}");
        }
    }

    /// Across the middle of the nasolabial furrow (at rest x 0.20, y 6.82, running down and out
    /// along (0.05, −0.12)), the lip's side slopes into it over about 3 mm and the cheek's side
    /// rises out of it within 1.5 mm into a ridge that stands above the surrounding skin; beyond
    /// each end of the furrow the two sides meet without a step.
    #[test]
    fn the_cheek_bulges_over_the_nasolabial_furrow_and_its_ends_have_no_seam() {
        let (middle, across) = (Vec2::new(0.20, 6.82), Vec2::new(0.12, 0.05).normalize());
        let at = |mm: f32| nasolabial(middle + across * (mm / 100.0));
        let bottom = at(0.0);
        assert!(bottom < -1.25, "the furrow's bottom is {bottom}");
        assert!(at(-1.5) < 0.5 * bottom, "the lip's side 1.5 mm in is still {} of {bottom}", at(-1.5));
        assert!(at(1.5) > 0.5 * bottom + 0.5, "the cheek's side 1.5 mm out is {}", at(1.5));
        let ridge = at(2.5);
        assert!(ridge > 0.5, "the cheek's ridge 2.5 mm out stands {ridge}");
        assert!(ridge > at(-2.5) + 1.0 && ridge > at(8.0) + 0.2, "and above the skin beside it: {ridge}, {}, {}", at(-2.5), at(8.0));
        // The lines through each end, along the furrow's direction there: a step across them
        // would be a seam.
        for (end, along) in [(Vec2::new(0.15, 6.94), Vec2::new(-0.05, 0.12)), (Vec2::new(0.285, 6.58), Vec2::new(0.035, -0.12))] {
            let (along, normal) = (along.normalize(), along.normalize().perp());
            for beyond in [0.005f32, 0.01, 0.02, 0.04] {
                let on_line = end + along * beyond;
                let step = (nasolabial(on_line + normal * 1e-4) - nasolabial(on_line - normal * 1e-4)).abs();
                assert!(step < 0.02, "a step of {step} across the line {beyond} dm beyond {end}");
            }
        }
    }

    /// AU6's cheek: a mound whose top lies below the lower lid, highest at its centre and gone
    /// by the lid's furrow above and the mouth's corner below.
    #[test]
    fn the_raised_cheek_is_a_mound_below_the_lower_lid() {
        let top = cheek_apple(Vec2::new(0.30, 6.97));
        assert!(top > 2.9, "the cheek's top stands {top}");
        assert!(cheek_apple(Vec2::new(0.30, 7.04)) < 0.6 * top && cheek_apple(Vec2::new(0.40, 6.97)) < 0.6 * top);
        for (x, y) in [(0.30, 7.125), (0.25, 6.615), (0.10, 6.97)] {
            assert_eq!(cheek_apple(Vec2::new(x, y)), 0.0, "at ({x}, {y})");
        }
    }

    /// Every appearance channel the AU basis or a corrective drives is drawn: a pattern of its
    /// name exists (or it is `lid_raise`, the eyeball's lid shadow).
    #[test]
    fn every_appearance_channel_the_basis_drives_is_drawn() {
        use crate::engine::rig::{AuBasis, Channel};
        let basis = AuBasis::built_in();
        let catalog = crate::facs::Catalog::built_in();
        let rigs = catalog.iter().filter_map(|unit| basis.get(unit.code)).flat_map(|rig| &rig.channels);
        let correctives = basis.correctives().iter().flat_map(|c| &c.channels);
        let mut names: Vec<&str> = rigs.chain(correctives).filter_map(|u| match &u.channel { Channel::Shade(name) => Some(name.as_str()), _ => None }).collect();
        names.sort_unstable();
        names.dedup();
        assert!(names.contains(&"cheek_apple"), "{names:?}");
        for name in names {
            assert!(name == "lid_raise" || PATTERNS.iter().any(|(n, _)| *n == name), "shade:{name} draws nothing");
        }
    }

    /// The lines of age at rest are the AUs' furrows deepened: the aged relief is the AUs'
    /// relief plus the lines' own (each pattern worked out once with the summed weight), and a
    /// person younger than 28 has no lines.
    #[test]
    fn lines_of_age_add_to_the_aus_furrows() {
        let appearance: BTreeMap<String, (f32, f32)> =
            [("crows_feet", (0.8, 0.0)), ("nasolabial", (0.5, 0.5)), ("dimple", (0.0, 0.7))].map(|(n, w)| (n.to_string(), w)).into();
        let age = 0.6;
        let (au, aged) = ReliefSet::of(&appearance, age);
        let (_, lines) = ReliefSet::of(&BTreeMap::new(), age);
        assert_eq!((au.patterns.len(), lines.patterns.len(), aged.patterns.len()), (3, 4, 5));
        let weights = |set: &ReliefSet| set.patterns.iter().map(|&(_, l, r)| (l, r)).collect::<Vec<_>>();
        // In the order of PATTERNS: forehead_inner, forehead_outer, crows_feet, nasolabial, dimple.
        let expected = [(0.18, 0.18), (0.15, 0.15), (0.8 + 0.27, 0.27), (0.5 + 0.27, 0.5 + 0.27), (0.0, 0.7)];
        for ((l, r), (el, er)) in weights(&aged).into_iter().zip(expected) {
            assert!((l - el).abs() < 1e-6 && (r - er).abs() < 1e-6, "weights ({l}, {r}), expected ({el}, {er})");
        }
        let mut deepest_line: f32 = 0.0;
        for x in -70..=70 {
            for y in 640..=810 {
                let p = Vec3::new(x as f32 * 0.01, y as f32 * 0.01, 1.3);
                let (a, l, both) = (au.height(p), lines.height(p), aged.height(p));
                assert!((both - (a + l)).abs() <= 1e-5 * (1.0 + a.abs() + l.abs()), "at {p}: {both} for {a} + {l}");
                deepest_line = deepest_line.min(l);
            }
        }
        assert!(deepest_line < -0.2, "the lines of age are drawn: deepest {deepest_line}");
        let (young_au, young_aged) = ReliefSet::of(&appearance, 0.0);
        assert_eq!(weights(&young_aged), weights(&young_au), "no lines before 28");
    }

    #[test]
    fn patterns_are_furrows_where_expected() {
        assert!(nasolabial(Vec2::new(0.20, 6.82)) < -1.0);
        assert!(nasolabial(Vec2::new(0.0, 7.5)).abs() < 1e-3);
        assert!(forehead_inner(Vec2::new(0.0, 7.72)) < -0.9);
    }

    #[test]
    fn crows_feet_are_furrows_that_fade_toward_the_temple_with_skin_bunched_between() {
        let origin = Vec2::new(0.485, 7.29);
        let at = |angle: f32, r: f32| crows_feet(origin + Vec2::new(angle.cos(), angle.sin()) * r);
        for angle in [-0.45, -0.15, 0.15, 0.45] {
            let (near, far) = (at(angle, 0.03), at(angle, 0.10));
            assert!(near < -0.5, "the furrow at {angle} rad is {near} near the corner");
            assert!(far < -0.1 && far > 0.7 * near, "and fades toward the temple: {far} against {near}");
        }
        for angle in [-0.3f32, 0.0, 0.3] {
            let (between, beside) = (at(angle, 0.08), at(angle - 0.15, 0.08).max(at(angle + 0.15, 0.08)));
            assert!(between > beside + 0.25, "the skin between the furrows at {angle} rad stands {between} over {beside}");
        }
        for r in [0.2, 0.25] {
            assert!(at(0.0, r).abs() < 1e-3, "the crow's feet reach {r} dm from the corner: {}", at(0.0, r));
        }
    }

    /// AU14's dimple is a crescent round the mouth's corner (x 0.25, y 6.615 at rest), not a dot
    /// beside it: its furrow is at least half deep 4 mm above, 4 mm lateral and 3.5 mm below the
    /// corner's level on the curve, the skin between the corner and the furrow bunches up, and
    /// it fades out within 2 cm.
    #[test]
    fn the_dimple_is_a_crescent_round_the_mouths_corner() {
        for (x, y) in [(0.283, 6.655), (0.293, 6.615), (0.285, 6.58)] {
            let depth = dimple(Vec2::new(x, y));
            assert!(depth < -0.5, "the furrow at ({x}, {y}) is {depth}");
        }
        assert!(dimple(Vec2::new(0.274, 6.617)) > 0.1, "the bunched skin reads {}", dimple(Vec2::new(0.274, 6.617)));
        for (x, y) in [(0.45, 6.615), (0.28, 6.43), (0.28, 6.8)] {
            assert!(dimple(Vec2::new(x, y)).abs() < 1e-3, "the dimple reaches ({x}, {y})");
        }
    }
}
