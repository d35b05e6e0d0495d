//! Triangles → samples → pixels: a deterministic, tile-parallel, anti-aliased CPU rasteriser
//! with a visibility buffer.
//!
//! # Pipeline
//! 1. **Setup** (sequential, in scene order): every vertex is transformed once to homogeneous
//!    pixel coordinates `(X, Y, w)` (see [`Camera::view_to_homogeneous_pixel`]). Triangles are
//!    clipped against the near plane and a guard band ([`GUARD_BAND_PX`] pixels around the
//!    image), snapped to fixed point with [`SUBPIXEL_BITS`] fractional bits, culled or
//!    re-wound so that their integer edge functions are ≥ 0 inside, and binned into
//!    [`TILE_SIZE`]² tiles in triangle order.
//! 2. **Raster** (parallel over tiles): each tile keeps, per sample, the depth (1/w, larger is
//!    nearer) and the id of the nearest triangle: a visibility buffer. Coverage uses exact
//!    integer edge functions with the top-left fill rule, so a sample on an edge shared by two
//!    triangles belongs to exactly one of them, whatever the submission order. Each row of a
//!    triangle's box is walked from where its rising edges first pass to the end of the run of
//!    passing pixels; with four samples per pixel on x86-64 the samples are tested side by side
//!    (SSE2), with the same integer and floating-point operations as one at a time. A triangle
//!    of a surface that thins out into fibres ([`Coverage`]) passes only the samples whose
//!    fibre is there, so what lies behind shows between its fibres.
//! 3. **Resolve** (same task): per pixel the covered samples are grouped by triangle (or, with
//!    [`RenderOptions::shade_per_surface`], by continuous surface); each group is shaded
//!    once, at the centroid of its covered samples, with
//!    perspective-correct barycentrics; colours are weighted by coverage, the uncovered samples
//!    take the background, and the sum is converted to 8-bit sRGB once.
//!
//! **Invariant:** no tile reads another tile's results and nothing is reduced across tiles, so
//! the output is byte-identical for any thread count. Each thread keeps its setup vectors and
//! tile buffers between frames (thread-local, emptied before reuse), so only memory, never
//! results, carries over from one frame to the next. Ties in depth go to the triangle that
//! comes first in scene order (scene item, then triangle index), as tiles process triangles in
//! that order and only a strictly nearer sample replaces a stored one.

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use super::camera::Camera;
use super::image::{RgbImage, Srgb8};

/// Fractional bits of the fixed-point screen coordinates (1/256 pixel).
pub const SUBPIXEL_BITS: u32 = 8;
/// Tiles are `TILE_SIZE` × `TILE_SIZE` pixels.
pub const TILE_SIZE: u32 = 64;
/// Triangles are clipped this many pixels outside the image (keeps fixed point in range).
pub const GUARD_BAND_PX: f32 = 2048.0;

const SUB: i64 = 1 << SUBPIXEL_BITS;
const TILE: usize = TILE_SIZE as usize;
const NO_TRIANGLE: u32 = u32::MAX;
const MAX_SAMPLES: usize = 16;
/// Boxes narrower than this many pixels are scanned from their left edge, row by row.
const NARROW_BOX: i32 = 6;
/// A tile's worth of empty samples, to clear the id buffer from.
static NO_TRIANGLES: [u32; TILE * TILE * MAX_SAMPLES] = [NO_TRIANGLE; TILE * TILE * MAX_SAMPLES];

/// One scene item: an indexed triangle mesh in world space. Several make a scene.
///
/// `normals` and `uvs` are per vertex like `positions`, or empty: without normals a fragment
/// gets the geometric face normal (counter-clockwise front), without UVs it gets `(0, 0)`.
#[derive(Clone, Copy, Debug)]
pub struct Triangles<'a> {
    pub positions: &'a [Vec3],
    pub normals: &'a [Vec3],
    pub uvs: &'a [Vec2],
    pub indices: &'a [[u32; 3]],
    /// A label handed to the shader (skin, eye, teeth, …).
    pub part: u16,
    /// Drawn from both sides even with [`RenderOptions::backface_culling`] (thin sheets and open
    /// shells, whose back may be in view).
    pub two_sided: bool,
    /// Per vertex, how much of a surface made of fibres is there ([`Coverage`]), as for
    /// `positions`, or empty (opaque throughout): where it thins out, as at the end of a lock
    /// of hair, what lies behind shows between its fibres.
    pub coverage: &'a [Coverage],
}

/// How much of a surface made of fibres lies at a vertex. A sample on fibre `k` (the integer
/// part of `fibre` there) is covered where `share` (at the pixel's centre) is over the
/// fibre's threshold, a hash of `k` and the scene item in 0..1: so where the share falls along
/// the fibres, they end one by one, each at its own point, and where it is constant a share of
/// that size of them is drawn. Fibres are as wide as `fibre` makes them (a pixel may hold
/// several, each sample on one).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Coverage {
    /// The share of the fibres present: 1 (or more) opaque, 0 (or less) none.
    pub share: f32,
    /// Where the vertex lies across the fibres, counted in fibres.
    pub fibre: f32,
}

/// What the shader sees for one (pixel, triangle) pair.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fragment {
    /// World-space position.
    pub position: Vec3,
    /// Interpolated vertex normal, normalised (not flipped for back faces).
    pub normal: Vec3,
    pub uv: Vec2,
    pub part: u16,
    /// Index of the triangle in its scene item's `indices`.
    pub triangle: u32,
    /// The triangle's vertex indices.
    pub vertex: [u32; 3],
    /// Perspective-correct barycentric coordinates with respect to `vertex`.
    pub barycentric: Vec3,
    /// Unit vector from `position` towards the eye.
    pub view_dir: Vec3,
    pub pixel: (u32, u32),
}

/// Colours fragments and the background, in linear RGB.
pub trait Shader: Sync {
    fn shade(&self, fragment: &Fragment) -> Vec3;
    fn background(&self, x: u32, y: u32) -> Vec3;
}

/// Samples per pixel and their positions (Direct3D's standard multisample patterns, given in
/// 1/16 pixel from the pixel centre; rotated/sparse grids with good edge coverage).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum SampleCount {
    /// One sample at the pixel centre: no anti-aliasing.
    X1,
    /// 4-sample rotated grid.
    X4,
    /// 8 samples.
    X8,
    /// 16 samples.
    #[default]
    X16,
}

impl SampleCount {
    pub fn count(self) -> usize {
        self.offsets_sixteenths().len()
    }

    /// Sample offsets from the pixel centre in 1/16 pixel, x right, y down.
    pub fn offsets_sixteenths(self) -> &'static [(i8, i8)] {
        match self {
            SampleCount::X1 => &[(0, 0)],
            SampleCount::X4 => &[(-2, -6), (6, -2), (-6, 2), (2, 6)],
            SampleCount::X8 => &[(1, -3), (-1, 3), (5, 1), (-3, -5), (-5, 5), (-7, -1), (3, 7), (7, -7)],
            SampleCount::X16 => &[
                (1, 1),
                (-1, -3),
                (-3, 2),
                (4, -1),
                (-5, -2),
                (2, 5),
                (5, 3),
                (3, -5),
                (-2, 6),
                (0, -7),
                (-4, -6),
                (-6, 4),
                (-8, 0),
                (7, -4),
                (6, 7),
                (-7, -8),
            ],
        }
    }

    /// Sample positions inside the pixel in fixed point (1/256 px from the pixel's top-left).
    fn fixed_offsets(self) -> Vec<(i64, i64)> {
        self.offsets_sixteenths()
            .iter()
            .map(|&(dx, dy)| (SUB / 2 + i64::from(dx) * SUB / 16, SUB / 2 + i64::from(dy) * SUB / 16))
            .collect()
    }
}

/// How to render.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RenderOptions {
    pub samples_per_pixel: SampleCount,
    /// `None`: rayon's global pool; `Some(n)`: a pool of `n` threads (`Some(1)` runs on the
    /// calling thread). The output does not depend on it.
    pub threads: Option<usize>,
    /// Drop triangles that are clockwise as seen by the camera (counter-clockwise is front),
    /// except those of [`Triangles::two_sided`] items.
    pub backface_culling: bool,
    /// Shade a pixel once per continuous surface instead of once per triangle: the samples of
    /// neighbouring triangles of one scene item (a vertex in common) are shaded together, with
    /// the triangle that covers most of them. Right for shaders whose output is continuous
    /// across shared vertices (interpolated attributes); silhouettes, folds and separate items
    /// stay anti-aliased as before.
    pub shade_per_surface: bool,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions { samples_per_pixel: SampleCount::X16, threads: None, backface_culling: true, shade_per_surface: false }
    }
}

/// The nearest surface at one sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Index of the scene item.
    pub item: u32,
    /// Index of the triangle in that item.
    pub triangle: u32,
    /// Distance in front of the camera along its axis (view-space −z).
    pub distance: f32,
}

/// The visibility buffer of a frame: the nearest surface at every sample.
#[derive(Clone, Debug, PartialEq)]
pub struct Visibility {
    pub width: u32,
    pub height: u32,
    pub samples_per_pixel: usize,
    /// `samples[(y * width + x) * samples_per_pixel + s]`.
    pub samples: Vec<Option<Hit>>,
}

impl Visibility {
    /// The samples of pixel (`x`, `y`).
    pub fn pixel(&self, x: u32, y: u32) -> &[Option<Hit>] {
        let n = self.samples_per_pixel;
        let i = (y as usize * self.width as usize + x as usize) * n;
        &self.samples[i..i + n]
    }

    /// How many samples of pixel (`x`, `y`) show triangle `triangle` of scene item `item`.
    pub fn coverage(&self, x: u32, y: u32, item: u32, triangle: u32) -> usize {
        self.pixel(x, y).iter().flatten().filter(|h| h.item == item && h.triangle == triangle).count()
    }

    /// How many samples of pixel (`x`, `y`) show any surface.
    pub fn covered(&self, x: u32, y: u32) -> usize {
        self.pixel(x, y).iter().flatten().count()
    }
}

/// Renders `scene` as seen by `camera`.
pub fn render(scene: &[Triangles], camera: &Camera, shader: &impl Shader, options: &RenderOptions) -> RgbImage {
    let setup = Setup::new(scene, camera, options.backface_culling, true);
    let pattern = options.samples_per_pixel.fixed_offsets();
    let tiles = run_tiles(&setup, options.threads, |buffers, tile| {
        let (x0, y0, w, h) = setup.tile_rect(tile);
        rasterize_tile(&setup, tile, &pattern, buffers);
        resolve_tile(&setup, scene, camera, shader, options, &pattern, buffers, x0, y0, w, h)
    });
    let mut image = RgbImage::new(camera.width, camera.height);
    let stride = camera.width as usize * 3;
    for (tile, rgb) in tiles.iter().enumerate() {
        let (x0, y0, w, h) = setup.tile_rect(tile);
        for row in 0..h {
            let dst = (y0 + row) * stride + x0 * 3;
            image.data[dst..dst + w * 3].copy_from_slice(&rgb[row * w * 3..(row + 1) * w * 3]);
        }
    }
    image
}

/// The visibility buffer `render` would resolve (same coverage, same depth tie-breaks).
///
/// Meant for tests and geometry checks (which surface covers a pixel, landmark occlusion):
/// it materialises one `Option<Hit>` per sample, so it is slower than `render` itself.
pub fn visibility(scene: &[Triangles], camera: &Camera, options: &RenderOptions) -> Visibility {
    let samples = gather_samples(scene, camera, options, true, None, |setup, id, depth| {
        let t = &setup.shade[id as usize];
        Some(Hit { item: t.source.item, triangle: t.source.triangle, distance: 1.0 / depth })
    });
    let samples_per_pixel = options.samples_per_pixel.count();
    Visibility { width: camera.width, height: camera.height, samples_per_pixel, samples }
}

/// The distance of the nearest surface at every sample (`+∞` where there is none), laid out
/// like [`Visibility::samples`]: a depth map, e.g. for shadows.
pub fn nearest_distances(scene: &[Triangles], camera: &Camera, options: &RenderOptions) -> Vec<f32> {
    gather_samples(scene, camera, options, false, f32::INFINITY, |_, _, depth| 1.0 / depth)
}

/// Rasterises `scene` and maps every covered sample's (triangle id, depth) through `value`,
/// `empty` elsewhere; returns the values in image order (`(y * width + x) * n + sample`).
/// `value` may look at the setup's shading data only `with_shading`.
fn gather_samples<T: Copy + Send + Sync>(
    scene: &[Triangles],
    camera: &Camera,
    options: &RenderOptions,
    with_shading: bool,
    empty: T,
    value: impl Fn(&Setup, u32, f32) -> T + Sync,
) -> Vec<T> {
    let setup = Setup::new(scene, camera, options.backface_culling, with_shading);
    let pattern = options.samples_per_pixel.fixed_offsets();
    let n = pattern.len();
    let tiles = run_tiles(&setup, options.threads, |buffers, tile| {
        let (_, _, w, h) = setup.tile_rect(tile);
        rasterize_tile(&setup, tile, &pattern, buffers);
        let mut out = Vec::with_capacity(w * h * n);
        for row in 0..h {
            let base = row * TILE * n;
            let ids = &buffers.id[base..base + w * n];
            let depths = &buffers.depth[base..base + w * n];
            out.extend(ids.iter().zip(depths).map(|(&id, &depth)| if id == NO_TRIANGLE { empty } else { value(&setup, id, depth) }));
        }
        out
    });
    let (width, height) = (camera.width as usize, camera.height as usize);
    let mut samples = vec![empty; width * height * n];
    for (tile, values) in tiles.iter().enumerate() {
        let (x0, y0, w, h) = setup.tile_rect(tile);
        for row in 0..h {
            let dst = ((y0 + row) * width + x0) * n;
            samples[dst..dst + w * n].copy_from_slice(&values[row * w * n..(row + 1) * w * n]);
        }
    }
    samples
}

// ---------------------------------------------------------------------------------------------
// Setup: transform, clip, snap, bin.

/// Hot per-triangle data for the raster loop.
#[derive(Clone, Copy, Debug)]
struct RasterTri {
    /// Edge k (opposite vertex k): `E = a·x + b·y + c` on fixed-point sample positions; the
    /// sample is covered iff `E ≥ 0` for all three (the fill-rule bias is folded into `c`).
    a: [i64; 3],
    b: [i64; 3],
    c: [i64; 3],
    /// Inclusive pixel bounds, clamped to the image: x0, y0, x1, y1.
    bbox: [i32; 4],
    /// Depth plane: `1/w = z0 + zx·(x − ox) + zy·(y − oy)` in pixel units.
    z0: f32,
    zx: f32,
    zy: f32,
    ox: f32,
    oy: f32,
    /// Index of its [`Fade`] in [`Setup::fade`], or [`OPAQUE`].
    fade: u32,
}

/// [`RasterTri::fade`] of a triangle that covers every sample it passes over.
const OPAQUE: u32 = u32::MAX;

/// How a triangle with a corner's [`Coverage::share`] under 1 thins out, as planes over the
/// image in pixel units from the triangle's first corner (`ox`, `oy`): the share
/// `a0 + ax·(x − ox) + ay·(y − oy)` and the fibre `base + f0 + fx·(x − ox) + fy·(y − oy)`
/// (`base` the integer part of the first corner's fibre, so that the plane keeps its
/// precision on fibres counted in the hundreds of thousands).
#[derive(Clone, Copy, Debug)]
struct Fade {
    a0: f32,
    ax: f32,
    ay: f32,
    base: i64,
    f0: f32,
    fx: f32,
    fy: f32,
    salt: u32,
    /// `mix32(salt)`: the hash of the fibre's high 32 bits (0 for all but huge fibres) with
    /// the salt.
    salt_hash: u32,
}

impl Fade {
    /// Of the samples of pixel (`px`, `py`) whose bit is set in `candidates` (those at
    /// `offsets`, pixel units from the pixel's corner), those where triangle `t`'s fibre is
    /// there: the samples a thin triangle does not cover are not looked at.
    #[inline]
    fn kept<const N: usize>(&self, t: &RasterTri, px: i32, py: i32, offsets: &[(f32, f32); N], candidates: u32) -> u32 {
        let (dx, dy) = (px as f32 - t.ox, py as f32 - t.oy);
        let share = self.a0 + self.ax * (dx + 0.5) + self.ay * (dy + 0.5);
        if share >= 1.0 {
            return candidates;
        }
        if share.is_nan() || share <= 0.0 {
            return 0;
        }
        let corner = self.f0 + self.fx * dx + self.fy * dy;
        // The threshold's 24 bits against the share scaled by 2²⁴ (both exact in f32): the same
        // test as `fibre_threshold(fibre) < share`, without a division.
        let scaled = share * 16_777_216.0;
        let mut mask = 0;
        for (s, &(ox, oy)) in offsets.iter().enumerate() {
            if candidates >> s & 1 == 0 {
                continue;
            }
            let fibre = self.base + floor_to_i64(corner + self.fx * ox + self.fy * oy);
            let high = (fibre >> 32) as u32;
            let salt = if high == 0 { self.salt_hash } else { mix32(high ^ self.salt) };
            if ((mix32(fibre as u32 ^ salt) >> 8) as f32) < scaled {
                mask |= 1 << s;
            }
        }
        mask
    }
}

/// The share (0..1) over which fibre `fibre` of the scene item salted `salt` is drawn
/// ([`Fade::kept`] works it out the same way, a step at a time).
#[cfg(test)]
fn fibre_threshold(fibre: i64, salt: u32) -> f32 {
    let h = mix32((fibre as u32) ^ mix32(((fibre >> 32) as u32) ^ salt));
    (h >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// `x.floor() as i64` without a call into libm (x86-64's baseline has no rounding
/// instruction): truncation, one less where that rounded a negative number up. NaN gives 0.
#[inline(always)]
fn floor_to_i64(x: f32) -> i64 {
    let t = x as i64;
    if (t as f32) > x {
        t - 1
    } else {
        t
    }
}

/// A 32-bit integer hash with good avalanche (every input bit flips about half the output
/// bits).
fn mix32(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^ (x >> 16)
}

/// Which triangle of the scene a (possibly clipped) piece comes from.
#[derive(Clone, Copy, Debug)]
struct Source {
    item: u32,
    triangle: u32,
    /// The triangle's vertex indices, kept here so that shading and the grouping of a pixel's
    /// samples need not look them up in the scene item again.
    vertex: [u32; 3],
}

/// Cold per-triangle data for shading.
#[derive(Clone, Copy, Debug)]
struct ShadeTri {
    /// The scene triangle this (possibly clipped) piece comes from.
    source: Source,
    /// Perspective weights of the corners at pixel position (x, y): corner k's weight is
    /// `max(0, weight[k][0]·x + weight[k][1]·y + weight[k][2])` (its screen-space barycentric
    /// coordinate, up to a common factor, times its 1/w), over the snapped corners of the
    /// (possibly clipped) triangle.
    weight: [[f64; 3]; 3],
    /// Barycentric coordinates of each corner with respect to the original triangle.
    bary: [Vec3; 3],
}

struct Setup {
    raster: Vec<RasterTri>,
    /// The fades of the triangles that thin out ([`RasterTri::fade`]).
    fade: Vec<Fade>,
    shade: Vec<ShadeTri>,
    width: usize,
    height: usize,
    tiles_x: usize,
    tiles_y: usize,
    /// Triangle ids of tile t: `bin_ids[bin_start[t]..bin_start[t + 1]]`, in scene order.
    bin_start: Vec<usize>,
    bin_ids: Vec<u32>,
    /// Whether `shade` is filled (else it stays empty).
    with_shading: bool,
    /// Working space of `new` and `bin`, kept only to be handed back for the next frame.
    scratch: SetupScratch,
}

/// The setup's working vectors, kept (not freed) between frames; each is cleared where it is
/// filled.
#[derive(Default)]
struct SetupScratch {
    homogeneous: Vec<Vec3>,
    codes: Vec<u8>,
    snapped: Vec<[i64; 2]>,
    pairs: Vec<(u32, u32)>,
    next: Vec<usize>,
}

/// A setup's vectors as the last frame on this thread left them (with their capacity).
/// A frame's setup needs a few megabytes; taking fresh memory from the system for every frame
/// costs about a tenth of the frame in page faults, so each thread keeps one set.
#[derive(Default)]
struct SetupStorage {
    raster: Vec<RasterTri>,
    fade: Vec<Fade>,
    shade: Vec<ShadeTri>,
    bin_start: Vec<usize>,
    bin_ids: Vec<u32>,
    scratch: SetupScratch,
}

thread_local! {
    static SETUP_STORAGE: std::cell::Cell<SetupStorage> = std::cell::Cell::default();
}

impl Drop for Setup {
    /// Hands the vectors back to this thread for its next frame.
    fn drop(&mut self) {
        let storage = SetupStorage {
            raster: emptied(&mut self.raster),
            fade: emptied(&mut self.fade),
            shade: emptied(&mut self.shade),
            bin_start: emptied(&mut self.bin_start),
            bin_ids: emptied(&mut self.bin_ids),
            scratch: std::mem::take(&mut self.scratch),
        };
        // During thread teardown the slot may be gone; the vectors are then simply freed.
        let _ = SETUP_STORAGE.try_with(|slot| slot.set(storage));
    }
}

/// Takes `v`'s buffer, emptied.
fn emptied<T>(v: &mut Vec<T>) -> Vec<T> {
    let mut v = std::mem::take(v);
    v.clear();
    v
}

#[derive(Clone, Copy, Debug)]
struct ClipVertex {
    h: Vec3,
    bary: Vec3,
}

/// Signed distances of a homogeneous pixel point to the clip planes (≥ 0 inside).
fn plane_distances(h: Vec3, near: f32, width: f32, height: f32) -> [f32; 5] {
    [
        h.z - near,
        h.x + GUARD_BAND_PX * h.z,
        (width + GUARD_BAND_PX) * h.z - h.x,
        h.y + GUARD_BAND_PX * h.z,
        (height + GUARD_BAND_PX) * h.z - h.y,
    ]
}

fn outcode(h: Vec3, near: f32, width: f32, height: f32) -> u8 {
    plane_distances(h, near, width, height)
        .iter()
        .enumerate()
        .fold(0, |code, (i, &d)| if d >= 0.0 { code } else { code | 1 << i })
}

impl Setup {
    /// `with_shading`: also work out what shading needs ([`ShadeTri`]); a depth-only pass
    /// (shadows) goes without.
    fn new(scene: &[Triangles], camera: &Camera, backface_culling: bool, with_shading: bool) -> Setup {
        assert!(camera.width > 0 && camera.height > 0, "camera image size must be positive");
        assert!(camera.width <= 16_384 && camera.height <= 16_384, "camera image size must be at most 16384");
        let view = camera.view();
        let near = camera.near();
        let projection = camera.pixel_projection();
        let (wf, hf) = (camera.width as f32, camera.height as f32);
        // A nested setup on this thread (none today) would find the slot empty and allocate.
        let storage = SETUP_STORAGE.try_with(|slot| slot.take()).unwrap_or_default();
        let mut setup = Setup {
            raster: storage.raster,
            fade: storage.fade,
            shade: storage.shade,
            width: camera.width as usize,
            height: camera.height as usize,
            tiles_x: camera.width.div_ceil(TILE_SIZE) as usize,
            tiles_y: camera.height.div_ceil(TILE_SIZE) as usize,
            bin_start: storage.bin_start,
            bin_ids: storage.bin_ids,
            with_shading,
            scratch: SetupScratch::default(),
        };
        let SetupScratch { mut homogeneous, mut codes, mut snapped, pairs, next } = storage.scratch;
        let total: usize = scene.iter().map(|t| t.indices.len()).sum();
        setup.raster.reserve(total);
        setup.shade.reserve(total);
        for (item, tris) in scene.iter().enumerate() {
            let n = tris.positions.len();
            assert!(
                tris.normals.is_empty() || tris.normals.len() == n,
                "scene item {item}: {} normals for {n} positions",
                tris.normals.len()
            );
            assert!(
                tris.uvs.is_empty() || tris.uvs.len() == n,
                "scene item {item}: {} uvs for {n} positions",
                tris.uvs.len()
            );
            assert!(
                tris.coverage.is_empty() || tris.coverage.len() == n,
                "scene item {item}: {} coverages for {n} positions",
                tris.coverage.len()
            );
            // Items often share one vertex array (the parts of a mesh): transform it once.
            let shares_previous = item > 0 && std::ptr::eq(scene[item - 1].positions, tris.positions);
            if !shares_previous {
                homogeneous.clear();
                homogeneous
                    .extend(tris.positions.iter().map(|&p| projection.apply(view.transform_point3(p))));
                codes.clear();
                codes.extend(homogeneous.iter().map(|&h| outcode(h, near, wf, hf)));
                // Snapped once per vertex for the triangles that need no clipping (only
                // those read it; outside the clip volume the value is meaningless).
                snapped.clear();
                snapped.extend(homogeneous.iter().zip(&codes).map(|(&h, &code)| if code == 0 { snap(h) } else { [0, 0] }));
            }
            let backface_culling = backface_culling && !tris.two_sided;
            for (t, idx) in tris.indices.iter().enumerate() {
                let [i0, i1, i2] = idx.map(|i| i as usize);
                assert!(
                    i0 < n && i1 < n && i2 < n,
                    "scene item {item}, triangle {t}: index out of range {idx:?} ({n} vertices)"
                );
                let (c0, c1, c2) = (codes[i0], codes[i1], codes[i2]);
                if c0 & c1 & c2 != 0 || (i0 == i1 && i1 == i2) {
                    continue; // entirely outside one plane, or a point (hidden hair is given so)
                }
                let source = Source { item: item as u32, triangle: t as u32, vertex: *idx };
                if c0 | c1 | c2 == 0 {
                    // No clipping (most triangles): the corners' snapped points and depths as
                    // they are.
                    let q = [snapped[i0], snapped[i1], snapped[i2]];
                    let w = [homogeneous[i0].z, homogeneous[i1].z, homogeneous[i2].z];
                    setup.emit(q, w, [Vec3::X, Vec3::Y, Vec3::Z], source, tris.coverage, backface_culling);
                } else {
                    let corners = [
                        ClipVertex { h: homogeneous[i0], bary: Vec3::X },
                        ClipVertex { h: homogeneous[i1], bary: Vec3::Y },
                        ClipVertex { h: homogeneous[i2], bary: Vec3::Z },
                    ];
                    let (poly, len) = clip_polygon(corners, near, wf, hf);
                    for k in 1..len.saturating_sub(1) {
                        let corners = [poly[0], poly[k], poly[k + 1]];
                        let (q, w, bary) = (corners.map(|c| snap(c.h)), corners.map(|c| c.h.z), corners.map(|c| c.bary));
                        setup.emit(q, w, bary, source, tris.coverage, backface_culling);
                    }
                }
            }
        }
        setup.scratch = SetupScratch { homogeneous, codes, snapped, pairs, next };
        setup.bin();
        setup
    }

    /// Orients and stores one (possibly clipped) triangle, unless it is culled. `q`: the corners
    /// snapped to fixed point ([`snap`]); `w`: their homogeneous w; `bary`: their barycentric
    /// coordinates with respect to the original triangle; `source`: that triangle; `coverage`:
    /// its item's ([`Triangles::coverage`]). Inlined, so that the culled half of a closed mesh
    /// costs no call.
    #[inline(always)]
    fn emit(&mut self, q: [[i64; 2]; 3], w: [f32; 3], bary: [Vec3; 3], source: Source, coverage: &[Coverage], backface_culling: bool) {
        let area2 = (q[1][0] - q[0][0]) * (q[2][1] - q[0][1]) - (q[1][1] - q[0][1]) * (q[2][0] - q[0][0]);
        // With y down, a triangle that is counter-clockwise as seen by the viewer has area2 < 0.
        if area2 < 0 {
            self.store(swap_last(q), swap_last(w), swap_last(bary), source, coverage);
        } else if area2 > 0 && !backface_culling {
            self.store(q, w, bary, source, coverage);
        }
    }

    /// Stores one triangle whose corners `q` (as for [`Self::emit`]) run so that its edge
    /// functions are positive inside.
    fn store(&mut self, q: [[i64; 2]; 3], w: [f32; 3], bary: [Vec3; 3], source: Source, coverage: &[Coverage]) {
        let min_x = q.iter().map(|p| p[0]).min().unwrap();
        let max_x = q.iter().map(|p| p[0]).max().unwrap();
        let min_y = q.iter().map(|p| p[1]).min().unwrap();
        let max_y = q.iter().map(|p| p[1]).max().unwrap();
        // Sample offsets lie in [0, SUB) within their pixel.
        let bbox = [
            min_x.div_euclid(SUB).max(0) as i32,
            min_y.div_euclid(SUB).max(0) as i32,
            max_x.div_euclid(SUB).min(self.width as i64 - 1) as i32,
            max_y.div_euclid(SUB).min(self.height as i64 - 1) as i32,
        ];
        if bbox[0] > bbox[2] || bbox[1] > bbox[3] {
            return;
        }
        let mut a = [0i64; 3];
        let mut b = [0i64; 3];
        let mut c = [0i64; 3];
        for k in 0..3 {
            let (pi, pj) = (q[(k + 1) % 3], q[(k + 2) % 3]);
            a[k] = pi[1] - pj[1];
            b[k] = pj[0] - pi[0];
            c[k] = -(a[k] * pi[0] + b[k] * pi[1]);
            // Top-left rule: samples exactly on an edge belong to the triangle only if the edge
            // is a left edge (interior to its right) or a horizontal top edge (interior below).
            let top_left = a[k] > 0 || (a[k] == 0 && b[k] > 0);
            if !top_left {
                c[k] -= 1;
            }
        }
        let p = q.map(|p| [p[0] as f64 / SUB as f64, p[1] as f64 / SUB as f64]);
        let inv_w = w.map(|z| 1.0 / f64::from(z));
        let (d1x, d1y) = (p[1][0] - p[0][0], p[1][1] - p[0][1]);
        let (d2x, d2y) = (p[2][0] - p[0][0], p[2][1] - p[0][1]);
        let det = d1x * d2y - d1y * d2x;
        let (dz1, dz2) = (inv_w[1] - inv_w[0], inv_w[2] - inv_w[0]);
        let zx = (dz1 * d2y - dz2 * d1y) / det;
        let zy = (dz2 * d1x - dz1 * d2x) / det;
        // A plane through the corners' values (as the depth's): its slopes in x and y.
        let slopes = |v: [f64; 3]| {
            let (d1, d2) = (v[1] - v[0], v[2] - v[0]);
            (((d1 * d2y - d2 * d1y) / det) as f32, ((d2 * d1x - d1 * d2x) / det) as f32)
        };
        let fade = match corner_coverage(coverage, source.vertex, bary) {
            Some(corners) => {
                let (ax, ay) = slopes(corners.map(|c| f64::from(c.share)));
                let base = f64::from(corners[0].fibre).floor();
                let (fx, fy) = slopes(corners.map(|c| f64::from(c.fibre)));
                let f0 = (f64::from(corners[0].fibre) - base) as f32;
                self.fade.push(Fade { a0: corners[0].share, ax, ay, base: base as i64, f0, fx, fy, salt: source.item, salt_hash: mix32(source.item) });
                self.fade.len() as u32 - 1
            }
            None => OPAQUE,
        };
        self.raster.push(RasterTri {
            a,
            b,
            c,
            bbox,
            z0: inv_w[0] as f32,
            zx: zx as f32,
            zy: zy as f32,
            ox: p[0][0] as f32,
            oy: p[0][1] as f32,
            fade,
        });
        if !self.with_shading {
            return;
        }
        // Corner k's screen barycentric is the edge function of the opposite edge (i → j).
        let weight = std::array::from_fn(|k| {
            let (pi, pj) = (p[(k + 1) % 3], p[(k + 2) % 3]);
            let (dx, dy) = (pj[0] - pi[0], pj[1] - pi[1]);
            [-dy * inv_w[k], dx * inv_w[k], (dy * pi[0] - dx * pi[1]) * inv_w[k]]
        });
        self.shade.push(ShadeTri { source, weight, bary });
    }

    /// Fills the per-tile triangle lists, each in scene order.
    fn bin(&mut self) {
        let tile_count = self.tiles_x * self.tiles_y;
        let mut pairs = emptied(&mut self.scratch.pairs);
        pairs.reserve(self.raster.len() * 2);
        let ts = TILE_SIZE as i32;
        for (id, t) in self.raster.iter().enumerate() {
            let [x0, y0, x1, y1] = t.bbox;
            let (tx0, ty0, tx1, ty1) = (x0 / ts, y0 / ts, x1 / ts, y1 / ts);
            let single = tx0 == tx1 && ty0 == ty1;
            for ty in ty0..=ty1 {
                for tx in tx0..=tx1 {
                    if !single && !t.may_touch_rect(tx * ts, ty * ts, (tx + 1) * ts, (ty + 1) * ts) {
                        continue;
                    }
                    pairs.push(((ty as usize * self.tiles_x + tx as usize) as u32, id as u32));
                }
            }
        }
        // Counting sort by tile, stable, so every list stays in scene order.
        let mut start = emptied(&mut self.bin_start);
        start.resize(tile_count + 1, 0);
        for &(tile, _) in &pairs {
            start[tile as usize + 1] += 1;
        }
        for i in 0..tile_count {
            start[i + 1] += start[i];
        }
        let mut next = emptied(&mut self.scratch.next);
        next.extend_from_slice(&start);
        let mut ids = emptied(&mut self.bin_ids);
        ids.resize(pairs.len(), 0);
        for &(tile, id) in &pairs {
            ids[next[tile as usize]] = id;
            next[tile as usize] += 1;
        }
        self.bin_start = start;
        self.bin_ids = ids;
        self.scratch.pairs = pairs;
        self.scratch.next = next;
    }

    fn tile_count(&self) -> usize {
        self.tiles_x * self.tiles_y
    }

    /// Pixel rectangle of a tile: x0, y0, width, height.
    fn tile_rect(&self, tile: usize) -> (usize, usize, usize, usize) {
        let (x0, y0) = ((tile % self.tiles_x) * TILE, (tile / self.tiles_x) * TILE);
        (x0, y0, TILE.min(self.width - x0), TILE.min(self.height - y0))
    }
}

impl RasterTri {
    /// False when some edge excludes every point of the pixel rectangle [x0, x1) × [y0, y1).
    fn may_touch_rect(&self, x0: i32, y0: i32, x1: i32, y1: i32) -> bool {
        let (fx0, fy0, fx1, fy1) = (x0 as i64 * SUB, y0 as i64 * SUB, x1 as i64 * SUB, y1 as i64 * SUB);
        (0..3).all(|k| {
            let x = if self.a[k] > 0 { fx1 } else { fx0 };
            let y = if self.b[k] > 0 { fy1 } else { fy0 };
            self.a[k] * x + self.b[k] * y + self.c[k] >= 0
        })
    }
}

/// The coverage at the corners of a (possibly clipped) piece of the scene's triangle
/// `vertex`, whose corners have barycentric coordinates `bary` with respect to it, from its
/// item's `coverage` (per vertex, or empty), when some vertex's share is under 1; `None` for
/// an opaque triangle.
fn corner_coverage(coverage: &[Coverage], vertex: [u32; 3], bary: [Vec3; 3]) -> Option<[Coverage; 3]> {
    if coverage.is_empty() {
        return None;
    }
    let at = vertex.map(|i| coverage[i as usize]);
    if at.iter().all(|c| c.share >= 1.0) {
        return None;
    }
    let (share, fibre) = (Vec3::from(at.map(|c| c.share)), Vec3::from(at.map(|c| c.fibre)));
    Some(bary.map(|b| Coverage { share: b.dot(share), fibre: b.dot(fibre) }))
}

/// The three corners of a triangle in the other order (the first kept, the others swapped).
fn swap_last<T>([a, b, c]: [T; 3]) -> [T; 3] {
    [a, c, b]
}

/// A homogeneous pixel point `(X, Y, w)` in fixed-point pixel coordinates.
fn snap(h: Vec3) -> [i64; 2] {
    let inv = 1.0 / h.z;
    [round_to_i64(h.x * inv * SUB as f32), round_to_i64(h.y * inv * SUB as f32)]
}

/// `x.round() as i64` (halves away from zero) without a call into libm: adding one half in
/// f64 is exact for every f32, and the truncation then rounds. Inputs are within the guard band.
fn round_to_i64(x: f32) -> i64 {
    let magnitude = (f64::from(x).abs() + 0.5) as i64;
    if x < 0.0 { -magnitude } else { magnitude }
}

/// Sutherland–Hodgman against the five clip planes. Intersections are always computed from the
/// inside end of an edge, so two triangles sharing an edge get bit-identical new vertices.
fn clip_polygon(corners: [ClipVertex; 3], near: f32, width: f32, height: f32) -> ([ClipVertex; 9], usize) {
    let zero = ClipVertex { h: Vec3::ZERO, bary: Vec3::ZERO };
    let mut poly = [zero; 9];
    poly[..3].copy_from_slice(&corners);
    let mut len = 3;
    for plane in 0..5 {
        let dist = |v: &ClipVertex| plane_distances(v.h, near, width, height)[plane];
        let mut out = [zero; 9];
        let mut out_len = 0;
        for i in 0..len {
            let (cur, next) = (poly[i], poly[(i + 1) % len]);
            let (dc, dn) = (dist(&cur), dist(&next));
            if dc >= 0.0 {
                out[out_len] = cur;
                out_len += 1;
            }
            if (dc >= 0.0) != (dn >= 0.0) {
                let (inside, outside, di, d_o) = if dc >= 0.0 { (cur, next, dc, dn) } else { (next, cur, dn, dc) };
                let t = di / (di - d_o);
                out[out_len] = ClipVertex {
                    h: inside.h + (outside.h - inside.h) * t,
                    bary: inside.bary + (outside.bary - inside.bary) * t,
                };
                out_len += 1;
            }
        }
        poly = out;
        len = out_len;
        if len < 3 {
            return (poly, 0);
        }
    }
    (poly, len)
}

// ---------------------------------------------------------------------------------------------
// Raster and resolve, one tile at a time.

/// Per-thread scratch for one tile: depth (1/w) and triangle id per sample.
struct TileBuffers {
    depth: Vec<f32>,
    id: Vec<u32>,
}

impl TileBuffers {
    fn new() -> Self {
        TileBuffers { depth: vec![0.0; TILE * TILE * MAX_SAMPLES], id: vec![NO_TRIANGLE; TILE * TILE * MAX_SAMPLES] }
    }
}

/// Runs `f` on every tile, in parallel unless `threads == Some(1)`, returning results in tile
/// order. Each call sees only its own tile, so the results do not depend on scheduling.
fn run_tiles<T: Send>(setup: &Setup, threads: Option<usize>, f: impl Fn(&mut TileBuffers, usize) -> T + Sync) -> Vec<T> {
    let n = setup.tile_count();
    let parallel = || (0..n).into_par_iter().map(|t| with_tile_buffers(|b| f(b, t))).collect::<Vec<T>>();
    match threads {
        Some(1) => with_tile_buffers(|buffers| (0..n).map(|t| f(buffers, t)).collect()),
        Some(count) => match rayon::ThreadPoolBuilder::new().num_threads(count).build() {
            Ok(pool) => pool.install(parallel),
            // No threads to be had: the global pool gives the same bytes.
            Err(_) => parallel(),
        },
        None => parallel(),
    }
}

thread_local! {
    /// Each thread's tile buffers, kept between tiles and frames.
    static TILE_BUFFERS: std::cell::Cell<Option<TileBuffers>> = const { std::cell::Cell::new(None) };
}

/// Runs `f` with this thread's tile buffers (fresh ones if they are in use or gone).
fn with_tile_buffers<T>(f: impl FnOnce(&mut TileBuffers) -> T) -> T {
    let mut buffers = TILE_BUFFERS.try_with(std::cell::Cell::take).ok().flatten().unwrap_or_else(TileBuffers::new);
    let out = f(&mut buffers);
    let _ = TILE_BUFFERS.try_with(|slot| slot.set(Some(buffers)));
    out
}

/// Fills the tile's visibility buffer (layout: `(row * TILE + col) * n + sample`).
fn rasterize_tile(setup: &Setup, tile: usize, pattern: &[(i64, i64)], buffers: &mut TileBuffers) {
    match pattern.len() {
        1 => rasterize_tile_n::<1>(setup, tile, pattern, buffers),
        4 => rasterize_tile_n::<4>(setup, tile, pattern, buffers),
        8 => rasterize_tile_n::<8>(setup, tile, pattern, buffers),
        16 => rasterize_tile_n::<16>(setup, tile, pattern, buffers),
        n => unreachable!("unsupported sample count {n}"),
    }
}

fn rasterize_tile_n<const N: usize>(setup: &Setup, tile: usize, pattern: &[(i64, i64)], buffers: &mut TileBuffers) {
    let (tx0, ty0, tw, th) = setup.tile_rect(tile);
    let used = TILE * TILE * N;
    let depth = &mut buffers.depth[..used];
    let ids = &mut buffers.id[..used];
    depth.fill(0.0);
    // A copy, not a fill: the fill of a non-zero value is a scalar loop.
    ids.copy_from_slice(&NO_TRIANGLES[..used]);
    let pattern: &[(i64, i64); N] = pattern.try_into().expect("pattern length matches N");
    let offsets_px: [(f32, f32); N] =
        std::array::from_fn(|s| (pattern[s].0 as f32 / SUB as f32, pattern[s].1 as f32 / SUB as f32));
    let mut target = TileTarget { depth, ids, x0: tx0, y0: ty0, x1: (tx0 + tw - 1) as i32, y1: (ty0 + th - 1) as i32 };
    let samples = Samples { pattern, offsets_px };
    for &id in &setup.bin_ids[setup.bin_start[tile]..setup.bin_start[tile + 1]] {
        let t = &setup.raster[id as usize];
        // Two copies of the loop: the opaque triangles' has no fibre test at all.
        match t.fade {
            OPAQUE => draw_triangle::<N, false>(t, id, None, &samples, &mut target),
            fade => draw_thinning_triangle(t, id, &setup.fade[fade as usize], &samples, &mut target),
        }
    }
}

/// [`draw_triangle`] for a triangle that thins out, kept out of the tile's loop: inlined there
/// too, it made the opaque triangles' copy of the loop slower.
#[inline(never)]
fn draw_thinning_triangle<const N: usize>(t: &RasterTri, id: u32, fade: &Fade, samples: &Samples<N>, tile: &mut TileTarget) {
    draw_triangle::<N, true>(t, id, Some(fade), samples, tile);
}

/// One tile's visibility buffer being drawn, and the pixel rectangle it covers (inclusive).
struct TileTarget<'a> {
    depth: &'a mut [f32],
    ids: &'a mut [u32],
    x0: usize,
    y0: usize,
    x1: i32,
    y1: i32,
}

/// The sample pattern: offsets from a pixel's top-left corner in fixed point and in pixels.
struct Samples<'a, const N: usize> {
    pattern: &'a [(i64, i64); N],
    offsets_px: [(f32, f32); N],
}

/// Draws triangle `t` (id `id`) into the tile: each covered sample nearer than the one stored
/// takes its depth and id. With `FADE`, only the samples whose fibre `fade` has are covered.
/// Inlined where it is called: the opaque triangles' copy in the tile's loop (a call per
/// triangle and tile cost more than the copy), the thinning triangles' in
/// [`draw_thinning_triangle`].
#[inline(always)]
fn draw_triangle<const N: usize, const FADE: bool>(t: &RasterTri, id: u32, fade: Option<&Fade>, samples: &Samples<N>, tile: &mut TileTarget) {
    let (pattern, offsets_px) = (samples.pattern, &samples.offsets_px);
    let TileTarget { depth: tile_depth, ids: tile_ids, x0: tx0, y0: ty0, x1: tx1, y1: ty1 } = tile;
    let (tx0, ty0) = (*tx0, *ty0);
    let x0 = t.bbox[0].max(tx0 as i32);
    let y0 = t.bbox[1].max(ty0 as i32);
    let x1 = t.bbox[2].min(*tx1);
    let y1 = t.bbox[3].min(*ty1);
    if x0 > x1 || y0 > y1 {
        return;
    }
    // Edge value at each sample relative to the pixel's top-left corner.
    let mut off = [[0i64; N]; 3];
    let mut off_min = [i64::MAX; 3];
    let mut off_max = [i64::MIN; 3];
    for k in 0..3 {
        for s in 0..N {
            let o = t.a[k] * pattern[s].0 + t.b[k] * pattern[s].1;
            off[k][s] = o;
            off_min[k] = off_min[k].min(o);
            off_max[k] = off_max[k].max(o);
        }
    }
    let z_off: [f32; N] = std::array::from_fn(|s| t.zx * offsets_px[s].0 + t.zy * offsets_px[s].1);
    #[cfg(target_arch = "x86_64")]
    let quad = (N == 4).then(|| four_samples::Quad::new(&off, &z_off));
    let step_x = [t.a[0] * SUB, t.a[1] * SUB, t.a[2] * SUB];
    let step_y = [t.b[0] * SUB, t.b[1] * SUB, t.b[2] * SUB];
    // Edge values at the top-left corner of the box's first pixel in the current row (exact
    // integers, so stepping gives the same values as working them out per row).
    let (fx, fy) = (i64::from(x0) * SUB, i64::from(y0) * SUB);
    let mut row_start: [i64; 3] = std::array::from_fn(|k| t.a[k] * fx + t.b[k] * fy + t.c[k]);
    for py in y0..=y1 {
        let mut e = row_start;
        for k in 0..3 {
            row_start[k] += step_y[k];
        }
        // In a narrow box a pixel's test costs less than finding where the run starts.
        let skip = if x1 - x0 < NARROW_BOX { 0 } else { run_start(&e, &off_max, &step_x) };
        if skip > i64::from(x1 - x0) {
            continue;
        }
        if skip > 0 {
            for k in 0..3 {
                e[k] += skip * step_x[k];
            }
        }
        let z_row = t.zy * (py as f32 - t.oy);
        let row_base = (py as usize - ty0) * TILE;
        // Past the run's end nothing else in the row passes.
        let mut in_run = false;
        for px in x0 + skip as i32..=x1 {
            let (e0, e1, e2) = (e[0], e[1], e[2]);
            e[0] += step_x[0];
            e[1] += step_x[1];
            e[2] += step_x[2];
            if (e0 + off_max[0]) | (e1 + off_max[1]) | (e2 + off_max[2]) < 0 {
                if in_run {
                    break;
                }
                continue; // no sample of this pixel is inside
            }
            in_run = true;
            let z_pixel = t.z0 + (t.zx * (px as f32 - t.ox) + z_row);
            let base = (row_base + px as usize - tx0) * N;
            let depth = &mut tile_depth[base..base + N];
            let ids = &mut tile_ids[base..base + N];
            #[cfg(target_arch = "x86_64")]
            if let Some(quad) = &quad {
                let inside = quad.inside([e0, e1, e2]);
                // Only samples this triangle would win need their fibre looked up (hair hanging
                // behind the neck and the other hair is most of a thinning surface's samples).
                let kept = match fade {
                    Some(fade) if FADE => match inside & quad.nearer(depth, z_pixel) {
                        0 => 0,
                        wins => fade.kept(t, px, py, offsets_px, wins as u32) as i32,
                    },
                    _ => inside,
                };
                quad.depth_test(depth, ids, z_pixel, id, kept);
                continue;
            }
            let kept = match fade {
                Some(fade) if FADE => fade.kept(t, px, py, offsets_px, u32::MAX),
                _ => u32::MAX,
            };
            if !FADE && (e0 + off_min[0]) | (e1 + off_min[1]) | (e2 + off_min[2]) >= 0 {
                for s in 0..N {
                    let z = z_pixel + z_off[s];
                    if z > depth[s] {
                        depth[s] = z;
                        ids[s] = id;
                    }
                }
            } else {
                for s in 0..N {
                    if kept >> s & 1 == 1 && (e0 + off[0][s]) | (e1 + off[1][s]) | (e2 + off[2][s]) >= 0 {
                        let z = z_pixel + z_off[s];
                        if z > depth[s] {
                            depth[s] = z;
                            ids[s] = id;
                        }
                    }
                }
            }
        }
    }
}

/// How many pixels along a row to skip before the first one some sample of which may pass all
/// three edges: each edge's test is monotonic along the row, so the pixels that pass all three
/// form one run, which starts where the last edge that rises along the row passes. `e`: the
/// edge values at the row's first pixel's corner; `off_max`: each edge's largest sample
/// offset; `step_x`: each edge's step from one pixel to the next.
#[inline(always)]
fn run_start(e: &[i64; 3], off_max: &[i64; 3], step_x: &[i64; 3]) -> i64 {
    let mut skip = 0;
    for k in 0..3 {
        let lead = e[k] + off_max[k];
        // Only an edge that fails here and rises along the row can delay the run (the
        // division, the costly part, only for such an edge).
        if lead < 0 && step_x[k] > 0 {
            skip = skip.max((step_x[k] - 1 - lead) / step_x[k]);
        }
    }
    skip
}

/// The four-sample case of the raster loop on SSE2 (part of every x86-64 processor): the
/// samples' edge tests and depth tests side by side, without a branch per sample. Same integer
/// and floating-point operations as the scalar loop, so the same visibility buffer.
#[cfg(target_arch = "x86_64")]
mod four_samples {
    use std::arch::x86_64::*;

    /// One triangle's per-sample constants.
    pub struct Quad {
        /// Edge k's value at samples (0, 1) and (2, 3), relative to the pixel's corner.
        off: [[__m128i; 2]; 3],
        /// Depth offset of each sample from the pixel's corner.
        z_off: __m128,
    }

    impl Quad {
        pub fn new<const N: usize>(off: &[[i64; N]; 3], z_off: &[f32; N]) -> Quad {
            assert_eq!(N, 4, "four samples per pixel");
            // SAFETY (here and below): SSE2 is part of every x86-64 processor, so its
            // intrinsics are always available; none of these touch memory.
            unsafe {
                Quad {
                    off: off.map(|o| [_mm_set_epi64x(o[1], o[0]), _mm_set_epi64x(o[3], o[2])]),
                    z_off: _mm_set_ps(z_off[3], z_off[2], z_off[1], z_off[0]),
                }
            }
        }

        /// Bit s set when sample s is inside all three edges, whose values at the pixel's
        /// corner are `e`: the sign bit of `(e0 + off0) | (e1 + off1) | (e2 + off2)` is clear.
        #[inline(always)]
        pub fn inside(&self, e: [i64; 3]) -> i32 {
            // SAFETY: SSE2 only, no memory access.
            unsafe {
                let mut lo = _mm_setzero_si128();
                let mut hi = _mm_setzero_si128();
                for (k, &ek) in e.iter().enumerate() {
                    let ek = _mm_set1_epi64x(ek);
                    lo = _mm_or_si128(lo, _mm_add_epi64(ek, self.off[k][0]));
                    hi = _mm_or_si128(hi, _mm_add_epi64(ek, self.off[k][1]));
                }
                let outside = _mm_movemask_pd(_mm_castsi128_pd(lo)) | (_mm_movemask_pd(_mm_castsi128_pd(hi)) << 2);
                !outside & 0b1111
            }
        }

        /// Bit s set where sample s's depth `z_pixel + z_off[s]` is nearer (larger) than the
        /// one stored in `depth`: the samples [`Quad::depth_test`] could change.
        #[inline(always)]
        pub fn nearer(&self, depth: &[f32], z_pixel: f32) -> i32 {
            let depth: &[f32; 4] = match depth.try_into() {
                Ok(d) => d,
                Err(_) => unreachable!("a pixel has four samples"),
            };
            // SAFETY: SSE/SSE2 only; the pointer comes from a reference to a four-element array,
            // which the unaligned load stays within.
            unsafe {
                let z = _mm_add_ps(_mm_set1_ps(z_pixel), self.z_off);
                _mm_movemask_ps(_mm_cmpgt_ps(z, _mm_loadu_ps(depth.as_ptr())))
            }
        }

        /// Where `inside` has bit s and sample s's depth `z_pixel + z_off[s]` is nearer (larger)
        /// than the stored one, stores that depth and `id`.
        #[inline(always)]
        pub fn depth_test(&self, depth: &mut [f32], ids: &mut [u32], z_pixel: f32, id: u32, inside: i32) {
            let (depth, ids): (&mut [f32; 4], &mut [u32; 4]) = match (depth.try_into(), ids.try_into()) {
                (Ok(d), Ok(i)) => (d, i),
                _ => unreachable!("a pixel has four samples"),
            };
            // SAFETY: SSE2 only; both pointers come from references to four-element arrays,
            // which the unaligned loads and stores stay within.
            unsafe {
                let stored = _mm_loadu_ps(depth.as_ptr());
                let z = _mm_add_ps(_mm_set1_ps(z_pixel), self.z_off);
                let bits = _mm_set_epi32(8, 4, 2, 1);
                let lanes = _mm_cmpeq_epi32(_mm_and_si128(_mm_set1_epi32(inside), bits), bits);
                let nearer = _mm_and_ps(_mm_cmpgt_ps(z, stored), _mm_castsi128_ps(lanes));
                // Stored back unconditionally: cheaper than a branch that hidden surfaces make
                // hard to predict.
                _mm_storeu_ps(depth.as_mut_ptr(), _mm_or_ps(_mm_and_ps(nearer, z), _mm_andnot_ps(nearer, stored)));
                let nearer = _mm_castps_si128(nearer);
                let old = _mm_loadu_si128(ids.as_ptr().cast());
                let new = _mm_or_si128(_mm_and_si128(nearer, _mm_set1_epi32(id as i32)), _mm_andnot_si128(nearer, old));
                _mm_storeu_si128(ids.as_mut_ptr().cast(), new);
            }
        }
    }
}

/// The distinct surfaces among one pixel's samples, in order of first appearance: for each,
/// the triangle id to shade, how many samples it covers and the sum of their offsets.
struct PixelGroups {
    id: [u32; MAX_SAMPLES],
    count: [u32; MAX_SAMPLES],
    sx: [i64; MAX_SAMPLES],
    sy: [i64; MAX_SAMPLES],
    /// Samples of the group's own triangle `id` (less than `count` after merging).
    own: [u32; MAX_SAMPLES],
    len: usize,
}

impl PixelGroups {
    fn new() -> PixelGroups {
        let zero = [0; MAX_SAMPLES];
        PixelGroups { id: zero, count: zero, sx: [0; MAX_SAMPLES], sy: [0; MAX_SAMPLES], own: zero, len: 0 }
    }

    /// Groups a pixel's samples by triangle (replacing what was there).
    fn group_by_triangle(&mut self, ids: &[u32], pattern: &[(i64, i64)]) {
        let groups = self;
        groups.len = 0;
        for (&id, &(ox, oy)) in ids.iter().zip(pattern) {
            let g = match groups.id[..groups.len].iter().position(|&g| g == id) {
                Some(g) => g,
                None => {
                    let g = groups.len;
                    groups.id[g] = id;
                    groups.count[g] = 0;
                    groups.own[g] = 0;
                    groups.sx[g] = 0;
                    groups.sy[g] = 0;
                    groups.len += 1;
                    groups.len - 1
                }
            };
            groups.count[g] += 1;
            groups.own[g] += 1;
            groups.sx[g] += ox;
            groups.sy[g] += oy;
        }
    }

    /// Merges the groups of triangles that belong to one continuous surface (same scene item,
    /// a vertex in common) into the group that covers most samples (the first of equals).
    fn merge_connected(&mut self, connected: impl Fn(u32, u32) -> bool) {
        let mut g = 1;
        while g < self.len {
            let id = self.id[g];
            match (0..g).find(|&k| connected(self.id[k], id)) {
                Some(k) => {
                    if self.own[g] > self.own[k] {
                        self.id[k] = id;
                        self.own[k] = self.own[g];
                    }
                    self.count[k] += self.count[g];
                    self.sx[k] += self.sx[g];
                    self.sy[k] += self.sy[g];
                    self.remove(g);
                }
                None => g += 1,
            }
        }
    }

    fn remove(&mut self, g: usize) {
        for k in g..self.len - 1 {
            self.id[k] = self.id[k + 1];
            self.count[k] = self.count[k + 1];
            self.sx[k] = self.sx[k + 1];
            self.sy[k] = self.sy[k + 1];
            self.own[k] = self.own[k + 1];
        }
        self.len -= 1;
    }
}

impl Setup {
    /// Whether triangles `a` and `b` (ids into `shade`) are neighbours on one mesh: the same
    /// scene item and at least one vertex in common (pieces of one clipped triangle included).
    fn connected(&self, a: u32, b: u32) -> bool {
        if a == NO_TRIANGLE || b == NO_TRIANGLE {
            return false;
        }
        let (ta, tb) = (&self.shade[a as usize].source, &self.shade[b as usize].source);
        if ta.item != tb.item {
            return false;
        }
        ta.vertex.iter().any(|v| tb.vertex.contains(v))
    }
}

/// Shades the tile's pixels from its visibility buffer; returns `w * h * 3` sRGB bytes.
#[allow(clippy::too_many_arguments)]
fn resolve_tile(
    setup: &Setup,
    scene: &[Triangles],
    camera: &Camera,
    shader: &impl Shader,
    options: &RenderOptions,
    pattern: &[(i64, i64)],
    buffers: &TileBuffers,
    x0: usize,
    y0: usize,
    w: usize,
    h: usize,
) -> Vec<u8> {
    let n = pattern.len();
    let inv_n = 1.0 / n as f32;
    let mut out = Vec::with_capacity(w * h * 3);
    let full_sx: i64 = pattern.iter().map(|p| p.0).sum();
    let full_sy: i64 = pattern.iter().map(|p| p.1).sum();
    let full_count = n as f64 * SUB as f64;
    let srgb = Srgb8::new();
    let mut groups = PixelGroups::new();
    // The last colour encoded and its bytes: runs of one colour (the backdrop) encode once.
    let mut last: Option<(Vec3, [u8; 3])> = None;
    for row in 0..h {
        for col in 0..w {
            let (px, py) = ((x0 + col) as u32, (y0 + row) as u32);
            let base = (row * TILE + col) * n;
            let ids = &buffers.id[base..base + n];
            let first = ids[0];
            let colour = if ids.iter().all(|&id| id == first) {
                // One surface (or none) over the whole pixel: the common case. Same arithmetic
                // as the general path below with a single group of `n` samples.
                let c = if first == NO_TRIANGLE {
                    shader.background(px, py)
                } else {
                    let x = f64::from(px) + full_sx as f64 / full_count;
                    let y = f64::from(py) + full_sy as f64 / full_count;
                    shader.shade(&fragment(&setup.shade[first as usize], scene, camera, x, y, (px, py)))
                };
                Vec3::ZERO + c * (n as f32 * inv_n)
            } else {
                groups.group_by_triangle(ids, pattern);
                if options.shade_per_surface {
                    groups.merge_connected(|a, b| setup.connected(a, b));
                }
                let mut colour = Vec3::ZERO;
                for g in 0..groups.len {
                    let weight = groups.count[g] as f32 * inv_n;
                    let c = if groups.id[g] == NO_TRIANGLE {
                        shader.background(px, py)
                    } else {
                        let count = f64::from(groups.count[g]) * SUB as f64;
                        let x = f64::from(px) + groups.sx[g] as f64 / count;
                        let y = f64::from(py) + groups.sy[g] as f64 / count;
                        let fragment = fragment(&setup.shade[groups.id[g] as usize], scene, camera, x, y, (px, py));
                        shader.shade(&fragment)
                    };
                    colour += c * weight;
                }
                colour
            };
            let bytes = match last {
                Some((c, bytes)) if c == colour => bytes,
                _ => [srgb.encode(colour.x), srgb.encode(colour.y), srgb.encode(colour.z)],
            };
            last = Some((colour, bytes));
            out.extend_from_slice(&bytes);
        }
    }
    out
}

/// Interpolates the triangle's attributes at pixel position (`x`, `y`) (perspective-correct).
/// Inlined into the resolve loop: the fragment is then built where the shader reads it,
/// without a call and a copy per shaded pixel.
#[inline(always)]
fn fragment(t: &ShadeTri, scene: &[Triangles], camera: &Camera, x: f64, y: f64, pixel: (u32, u32)) -> Fragment {
    let wts = t.weight.map(|[a, b, c]| (a * x + b * y + c).max(0.0));
    let sum = wts[0] + wts[1] + wts[2];
    let b = if sum > 0.0 && sum.is_finite() {
        let per_sum = 1.0 / sum;
        wts.map(|w| w * per_sum)
    } else {
        [1.0 / 3.0; 3]
    };
    let bary = t.bary[0] * b[0] as f32 + t.bary[1] * b[1] as f32 + t.bary[2] * b[2] as f32;
    let Source { item, triangle, vertex } = t.source;
    let tris = &scene[item as usize];
    let [i0, i1, i2] = vertex.map(|i| i as usize);
    let pos = tris.positions;
    let position = pos[i0] * bary.x + pos[i1] * bary.y + pos[i2] * bary.z;
    let face_normal = || (pos[i1] - pos[i0]).cross(pos[i2] - pos[i0]).normalize_or_zero();
    let normal = if tris.normals.is_empty() {
        face_normal()
    } else {
        let nm = tris.normals;
        let n = (nm[i0] * bary.x + nm[i1] * bary.y + nm[i2] * bary.z).normalize_or_zero();
        if n == Vec3::ZERO { face_normal() } else { n }
    };
    let uv = if tris.uvs.is_empty() {
        Vec2::ZERO
    } else {
        tris.uvs[i0] * bary.x + tris.uvs[i1] * bary.y + tris.uvs[i2] * bary.z
    };
    Fragment {
        position,
        normal,
        uv,
        part: tris.part,
        triangle,
        vertex,
        barycentric: bary,
        view_dir: (camera.eye - position).normalize_or_zero(),
        pixel,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sha2::{Digest, Sha256};

    const S: u32 = 64;

    /// Looks down −z at the z = 0 plane, where one world unit is one pixel.
    fn camera(size: u32) -> Camera {
        Camera {
            eye: Vec3::new(0.0, 0.0, size as f32 / 2.0),
            target: Vec3::ZERO,
            up: Vec3::Y,
            fov_y_degrees: 90.0,
            width: size,
            height: size,
        }
    }

    /// World point at pixel coordinates (`x`, `y`) of [`camera`]`(S)`, at height `z`.
    fn pix(x: f32, y: f32, z: f32) -> Vec3 {
        Vec3::new(x - S as f32 / 2.0, S as f32 / 2.0 - y, z)
    }

    fn item<'a>(positions: &'a [Vec3], indices: &'a [[u32; 3]], part: u16) -> Triangles<'a> {
        Triangles { positions, normals: &[], uvs: &[], indices, part, two_sided: false, coverage: &[] }
    }

    fn opts(samples: SampleCount) -> RenderOptions {
        RenderOptions { samples_per_pixel: samples, threads: Some(1), backface_culling: false, shade_per_surface: false }
    }

    /// Colour by part: 0 white, 1 red, 2 green; black background.
    struct PartShader;
    impl Shader for PartShader {
        fn shade(&self, f: &Fragment) -> Vec3 {
            match f.part {
                0 => Vec3::ONE,
                1 => Vec3::X,
                _ => Vec3::Y,
            }
        }
        fn background(&self, _: u32, _: u32) -> Vec3 {
            Vec3::ZERO
        }
    }

    /// Colours by triangle index plus part (even red, odd green) and counts its calls.
    struct TriangleShader(std::sync::atomic::AtomicUsize);
    impl Shader for TriangleShader {
        fn shade(&self, f: &Fragment) -> Vec3 {
            self.0.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            if (f.triangle + u32::from(f.part)).is_multiple_of(2) { Vec3::X } else { Vec3::Y }
        }
        fn background(&self, _: u32, _: u32) -> Vec3 {
            Vec3::ZERO
        }
    }

    /// A quad split along its diagonal into two triangles: one item (shared vertices) or two.
    #[test]
    fn shading_per_surface_joins_neighbours_and_keeps_other_edges() {
        let positions = [pix(8.0, 8.0, 0.0), pix(56.0, 8.0, 0.0), pix(56.0, 56.0, 0.0), pix(8.0, 56.0, 0.0)];
        let quad = [[0, 1, 2], [0, 2, 3]];
        let (first, second) = ([[0u32, 1, 2]], [[0u32, 2, 3]]);
        let render_with = |scene: &[Triangles], per_surface: bool| {
            let shader = TriangleShader(Default::default());
            let options = RenderOptions { shade_per_surface: per_surface, ..opts(SampleCount::X4) };
            let image = render(scene, &camera(S), &shader, &options);
            let pixels: Vec<[u8; 3]> = image.data.chunks(3).map(|p| [p[0], p[1], p[2]]).collect();
            let blended = pixels.iter().filter(|p| p[0] > 0 && p[1] > 0).count();
            let covered = pixels.iter().filter(|p| p[0] > 0 || p[1] > 0).count();
            (blended, covered, shader.0.into_inner())
        };
        let one_item = [item(&positions, &quad, 0)];
        let (blended, covered, calls) = render_with(&one_item, false);
        assert!(blended > 40, "per triangle, the diagonal is anti-aliased ({blended} pixels)");
        assert!(calls > covered);
        let (blended, covered, calls) = render_with(&one_item, true);
        assert_eq!(blended, 0, "per surface, each pixel is shaded once");
        assert_eq!(calls, covered, "one call per covered pixel");
        let two_items = [item(&positions, &first, 0), item(&positions, &second, 1)];
        let (blended, _, _) = render_with(&two_items, true);
        assert!(blended > 40, "separate items stay anti-aliased against each other ({blended} pixels)");
    }

    /// The SSE2 four-sample test stores exactly what the scalar per-sample loop stores.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn four_samples_side_by_side_match_one_at_a_time() {
        let mut rng = Lcg(11);
        let mut int = |range: f32| ((rng.next_f32() - 0.5) * range) as i64;
        for case in 0..2000u32 {
            let off: [[i64; 4]; 3] = std::array::from_fn(|_| std::array::from_fn(|_| int(2.0e6)));
            let e: [i64; 3] = std::array::from_fn(|_| int(4.0e6));
            let z_off: [f32; 4] = std::array::from_fn(|s| off[0][s] as f32 * 1e-7);
            let z_pixel = int(100.0) as f32 * 0.01;
            let stored: [f32; 4] = std::array::from_fn(|s| (off[1][s] % 100) as f32 * 0.01);
            let (mut depth, mut ids) = (stored, [7u32, 8, 9, 10]);
            let quad = four_samples::Quad::new(&off, &z_off);
            quad.depth_test(&mut depth, &mut ids, z_pixel, case, quad.inside(e));
            let (mut want_depth, mut want_ids) = (stored, [7u32, 8, 9, 10]);
            for s in 0..4 {
                let z = z_pixel + z_off[s];
                if (e[0] + off[0][s]) | (e[1] + off[1][s]) | (e[2] + off[2][s]) >= 0 && z > want_depth[s] {
                    want_depth[s] = z;
                    want_ids[s] = case;
                }
            }
            assert_eq!((depth.map(f32::to_bits), ids), (want_depth.map(f32::to_bits), want_ids), "case {case}");
        }
    }

    #[test]
    fn rounding_to_integers_matches_the_standard_library() {
        let mut rng = Lcg(7);
        let halves = (-40..40).map(|i| i as f32 * 0.5);
        let near_halves = (-40..40).flat_map(|i| {
            let h = i as f32 * 0.5;
            [f32::from_bits(h.to_bits() + 1), f32::from_bits(h.to_bits().saturating_sub(1))]
        });
        let random = (0..10_000).map(|_| (rng.next_f32() - 0.5) * 2.0e6);
        for x in halves.chain(near_halves).chain(random) {
            assert_eq!(round_to_i64(x), x.round() as i64, "{x}");
        }
    }

    /// Uses every fragment attribute, so interpolation changes show up in hashes.
    struct Busy;
    impl Shader for Busy {
        fn shade(&self, f: &Fragment) -> Vec3 {
            let light = Vec3::new(0.3, 0.5, 0.8).normalize();
            let lambert = f.normal.dot(light).abs();
            let tint = Vec3::new(
                0.2 + 0.8 * f.uv.x.fract().abs(),
                0.2 + 0.1 * f32::from(f.part % 7),
                0.3 + 0.5 * (f.position.z * 0.05).sin().abs(),
            );
            tint * (0.2 + 0.8 * lambert) * (0.5 + 0.5 * f.view_dir.z.abs())
        }
        fn background(&self, x: u32, y: u32) -> Vec3 {
            Vec3::new(x as f32 / 200.0, 0.1, y as f32 / 200.0)
        }
    }

    /// Knuth's MMIX LCG.
    struct Lcg(u64);
    impl Lcg {
        fn next_f32(&mut self) -> f32 {
            self.0 = self.0.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            (self.0 >> 40) as f32 / (1u64 << 24) as f32
        }
    }

    struct Mesh {
        positions: Vec<Vec3>,
        normals: Vec<Vec3>,
        uvs: Vec<Vec2>,
        indices: Vec<[u32; 3]>,
    }

    /// `count` random triangles scattered over a `w` × `h` image of a perspective camera.
    fn random_mesh(seed: u64, count: usize, spread: f32) -> Mesh {
        let mut rng = Lcg(seed);
        let mut mesh = Mesh { positions: vec![], normals: vec![], uvs: vec![], indices: vec![] };
        for t in 0..count {
            let centre = Vec3::new(
                (rng.next_f32() - 0.5) * spread,
                (rng.next_f32() - 0.5) * spread,
                (rng.next_f32() - 0.5) * spread * 0.5,
            );
            for _ in 0..3 {
                let p = centre + (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5) * spread * 0.3;
                mesh.positions.push(p);
                mesh.normals.push(Vec3::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5, 1.0).normalize());
                mesh.uvs.push(Vec2::new(rng.next_f32() * 3.0, rng.next_f32()));
            }
            let i = 3 * t as u32;
            mesh.indices.push([i, i + 1, i + 2]);
        }
        mesh
    }

    fn random_scene_camera(width: u32, height: u32) -> Camera {
        Camera {
            eye: Vec3::new(3.0, 2.0, 30.0),
            target: Vec3::ZERO,
            up: Vec3::Y,
            fov_y_degrees: 35.0,
            width,
            height,
        }
    }

    #[test]
    fn single_triangle_covers_the_expected_pixels() {
        // Right angle at (10, 10), hypotenuse x + y = 60.
        let positions = [pix(10.0, 10.0, 0.0), pix(50.0, 10.0, 0.0), pix(10.0, 50.0, 0.0)];
        let indices = [[0, 1, 2]];
        let scene = [item(&positions, &indices, 0)];
        let vis = visibility(&scene, &camera(S), &opts(SampleCount::X16));
        assert_eq!(vis.coverage(20, 20, 0, 0), 16);
        assert_eq!(vis.coverage(10, 10, 0, 0), 16, "left and top edges are included");
        assert_eq!(vis.covered(9, 20), 0);
        assert_eq!(vis.covered(20, 9), 0);
        assert_eq!(vis.covered(45, 45), 0);
        assert_eq!(vis.covered(5, 5), 0);
        let on_edge = vis.covered(29, 30);
        assert!(on_edge > 0 && on_edge < 16, "diagonal pixel partly covered: {on_edge}");
        // Centre samples: exactly the pixels whose centre is inside.
        let vis1 = visibility(&scene, &camera(S), &opts(SampleCount::X1));
        for y in 0..S {
            for x in 0..S {
                let (cx, cy) = (x as f32 + 0.5, y as f32 + 0.5);
                let inside = cx > 10.0 && cy > 10.0 && cx + cy < 60.0;
                assert_eq!(vis1.covered(x, y) == 1, inside, "pixel ({x}, {y})");
            }
        }
        let hit = vis.pixel(20, 20)[0].unwrap();
        assert!((hit.distance - 32.0).abs() < 1e-3, "{hit:?}");
    }

    #[test]
    fn backface_culling_drops_clockwise_triangles() {
        let cw = [pix(10.0, 10.0, 0.0), pix(50.0, 10.0, 0.0), pix(10.0, 50.0, 0.0)];
        let ccw = [cw[0], cw[2], cw[1]];
        let indices = [[0, 1, 2]];
        let culling = RenderOptions { backface_culling: true, ..opts(SampleCount::X4) };
        assert_eq!(visibility(&[item(&cw, &indices, 0)], &camera(S), &culling).covered(20, 20), 0);
        assert_eq!(visibility(&[item(&ccw, &indices, 0)], &camera(S), &culling).covered(20, 20), 4);
        // A two-sided item keeps its back faces; the culled one beside it does not.
        let sheet = Triangles { two_sided: true, ..item(&cw, &indices, 1) };
        let hits = visibility(&[item(&cw, &indices, 0), sheet], &camera(S), &culling);
        assert_eq!(hits.coverage(20, 20, 1, 0), 4);
        assert_eq!(hits.coverage(20, 20, 0, 0), 0);
    }

    #[test]
    fn shared_edges_leave_no_gap_and_no_double_coverage() {
        // A jittered 6 × 6 grid of quads over pixels [8, 56)², border vertices on the grid.
        let n = 6;
        let mut rng = Lcg(7);
        let mut positions = vec![];
        for j in 0..=n {
            for i in 0..=n {
                let border = i == 0 || j == 0 || i == n || j == n;
                let jitter = |r: &mut Lcg| if border { 0.0 } else { (r.next_f32() - 0.5) * 5.3 };
                let (x, y) = (8.0 + 8.0 * i as f32 + jitter(&mut rng), 8.0 + 8.0 * j as f32 + jitter(&mut rng));
                positions.push(pix(x, y, 0.0));
            }
        }
        let mut indices = vec![];
        for j in 0..n {
            for i in 0..n {
                let v = |i: u32, j: u32| j * (n + 1) + i;
                let (a, b, c, d) = (v(i, j), v(i + 1, j), v(i + 1, j + 1), v(i, j + 1));
                indices.push([a, d, c]);
                indices.push([a, c, b]);
            }
        }
        let o = opts(SampleCount::X16);
        let mut count = vec![0u8; (S * S * 16) as usize];
        for t in 0..indices.len() {
            let vis = visibility(&[item(&positions, &indices[t..t + 1], 0)], &camera(S), &o);
            for (c, hit) in count.iter_mut().zip(&vis.samples) {
                *c += hit.is_some() as u8;
            }
        }
        for y in 0..S {
            for x in 0..S {
                for s in 0..16 {
                    let c = count[((y * S + x) * 16 + s) as usize];
                    let inside = (8..56).contains(&x) && (8..56).contains(&y);
                    assert_eq!(c, inside as u8, "pixel ({x}, {y}) sample {s}");
                }
            }
        }
        // Rendered together in one colour, the seams are invisible.
        let img = render(&[item(&positions, &indices, 0)], &camera(S), &PartShader, &o);
        for y in 8..56 {
            for x in 8..56 {
                assert_eq!(img.pixel(x, y), [255; 3], "pixel ({x}, {y})");
            }
        }
        // Two colours: coverage of the two sides adds up to one along the diagonal.
        let quad = [pix(8.0, 8.0, 0.0), pix(56.0, 8.0, 0.0), pix(56.0, 56.0, 0.0), pix(8.0, 56.0, 0.0)];
        let (upper, lower) = ([[0u32, 2, 1]], [[0u32, 3, 2]]);
        let scene = [item(&quad, &upper, 1), item(&quad, &lower, 2)];
        let vis = visibility(&scene, &camera(S), &o);
        for i in 8..56 {
            assert_eq!(vis.coverage(i, i, 0, 0) + vis.coverage(i, i, 1, 0), 16);
            assert!(vis.coverage(i, i, 0, 0) > 0 && vis.coverage(i, i, 1, 0) > 0);
        }
    }

    /// A square over the whole image of [`camera`]`(S)` at height `z`: two triangles.
    fn square(z: f32) -> ([Vec3; 4], [[u32; 3]; 2]) {
        let s = S as f32;
        ([pix(0.0, 0.0, z), pix(s, 0.0, z), pix(s, s, z), pix(0.0, s, z)], [[0, 1, 2], [0, 2, 3]])
    }

    /// The share of the samples of `pixels` that show scene item `item`.
    fn share_shown(vis: &Visibility, item: u32, pixels: impl Iterator<Item = (u32, u32)>) -> f64 {
        let (mut shown, mut all) = (0, 0);
        for (x, y) in pixels {
            shown += vis.pixel(x, y).iter().flatten().filter(|h| h.item == item).count();
            all += vis.samples_per_pixel;
        }
        shown as f64 / all as f64
    }

    /// The coverage of [`square`]'s corners: `share` at each, fibres running down the image,
    /// `per_pixel` of them to a pixel across it.
    fn fibres_down(share: [f32; 4], per_pixel: f32) -> [Coverage; 4] {
        let across = [0.0, 1.0, 1.0, 0.0].map(|x: f32| x * S as f32 * per_pixel);
        std::array::from_fn(|k| Coverage { share: share[k], fibre: across[k] })
    }

    #[test]
    fn a_thinning_surface_draws_its_share_of_fibres_each_whole_along_its_length() {
        let (corners, quad) = square(0.0);
        let cam = camera(S);
        for samples in [SampleCount::X4, SampleCount::X16] {
            for share in [0.3f32, 0.5, 0.8] {
                // Fibres about a fifteenth of a pixel wide: 979 across the square.
                let coverage = fibres_down([share; 4], 15.3);
                let vis = visibility(&[Triangles { coverage: &coverage, ..item(&corners, &quad, 0) }], &cam, &opts(samples));
                let all = (0..S).flat_map(|y| (0..S).map(move |x| (x, y)));
                let shown = share_shown(&vis, 0, all);
                assert!((shown - f64::from(share)).abs() < 0.05, "{samples:?}, share {share}: {shown:.4}");
                // A fibre runs down the whole square: every row covers the same samples.
                for y in 1..S {
                    for x in 0..S {
                        let covered = |y| vis.pixel(x, y).iter().map(Option::is_some).collect::<Vec<_>>();
                        assert_eq!(covered(y), covered(0), "{samples:?}, pixel ({x}, {y})");
                    }
                }
            }
        }
    }

    #[test]
    fn fibres_end_one_by_one_where_the_share_falls_and_layers_let_each_other_through() {
        let (corners, quad) = square(0.0);
        let cam = camera(S);
        // All fibres at the top, none at the bottom: each row shows about the share at its
        // centre, and a fibre that has ended does not start again further down.
        let ramp = fibres_down([1.0, 1.0, 0.0, 0.0], 15.3);
        let vis = visibility(&[Triangles { coverage: &ramp, ..item(&corners, &quad, 0) }], &cam, &opts(SampleCount::X4));
        for y in 0..S {
            let expected = 1.0 - (f64::from(y) + 0.5) / f64::from(S);
            let shown = share_shown(&vis, 0, (0..S).map(|x| (x, y)));
            assert!((shown - expected).abs() < 0.06, "row {y}: {shown:.3}, expected {expected:.3}");
        }
        for x in 0..S {
            for s in 0..4 {
                let ended = (0..S).position(|y| vis.pixel(x, y)[s].is_none()).unwrap_or(S as usize);
                assert!((ended..S as usize).all(|y| vis.pixel(x, y as u32)[s].is_none()), "pixel column {x}, sample {s}");
            }
        }
        // Two layers showing half their fibres each, one just behind the other (their fibres
        // falling on the same samples): the far one shows through the near one's gaps (each
        // item draws its own fibres), so together they cover about three quarters, not a half.
        let (far, _) = square(-0.002);
        let half = fibres_down([0.5; 4], 15.3);
        let scene = [Triangles { coverage: &half, ..item(&corners, &quad, 0) }, Triangles { coverage: &half, ..item(&far, &quad, 1) }];
        let vis = visibility(&scene, &cam, &opts(SampleCount::X4));
        let all = || (0..S).flat_map(|y| (0..S).map(move |x| (x, y)));
        let (near, behind) = (share_shown(&vis, 0, all()), share_shown(&vis, 1, all()));
        assert!((near - 0.5).abs() < 0.05 && (near + behind - 0.75).abs() < 0.05, "near {near:.3}, together {:.3}", near + behind);
    }

    /// The raster's fibre test, worked out a step at a time, is the fibre's threshold against
    /// the share; fibres are numbered by the floor of their coordinate, negative ones too.
    #[test]
    fn the_fibre_test_is_the_fibres_threshold_against_the_share() {
        let t = RasterTri { a: [0; 3], b: [0; 3], c: [0; 3], bbox: [0; 4], z0: 0.0, zx: 0.0, zy: 0.0, ox: 0.0, oy: 0.0, fade: 0 };
        let mut checked = 0;
        for (k, base) in [0i64, 7, 123_456, -3, 1 << 33, -(1 << 33)].into_iter().enumerate() {
            for step in 0..400 {
                let (f0, share) = (step as f32 * 0.37 - 20.0, (step % 97) as f32 / 96.0);
                let fade = Fade { a0: share, ax: 0.0, ay: 0.0, base, f0, fx: 0.0, fy: 0.0, salt: k as u32, salt_hash: mix32(k as u32) };
                let fibre = base + f64::from(f0).floor() as i64;
                let expected = share >= 1.0 || (share > 0.0 && fibre_threshold(fibre, k as u32) < share);
                assert_eq!(fade.kept(&t, 0, 0, &[(0.0, 0.0)], 1) == 1, expected, "base {base}, f0 {f0}, share {share}");
                assert_eq!(fade.kept(&t, 0, 0, &[(0.0, 0.0)], 0), 0, "a sample not asked about is not kept");
                checked += usize::from(expected);
            }
        }
        assert!(checked > 600, "{checked} of 2,400 fibres drawn");
        for x in [0.0f32, 0.5, -0.5, -1.0, -1.5, 2.999_999_8, -2.999_999_8, 1e10, -1e10, f32::NAN] {
            assert_eq!(floor_to_i64(x), x.floor() as i64, "{x}");
        }
    }

    #[test]
    fn full_coverage_draws_as_an_opaque_surface() {
        let (corners, quad) = square(0.0);
        let cam = camera(S);
        let opaque = visibility(&[item(&corners, &quad, 0)], &cam, &opts(SampleCount::X4));
        let full = fibres_down([1.0; 4], 16.0);
        let covered = visibility(&[Triangles { coverage: &full, ..item(&corners, &quad, 0) }], &cam, &opts(SampleCount::X4));
        assert_eq!(opaque, covered);
    }

    #[test]
    fn nearer_triangle_wins_regardless_of_order() {
        let far = [pix(5.0, 5.0, 0.0), pix(5.0, 40.0, 0.0), pix(40.0, 5.0, 0.0)];
        let near = [pix(20.0, 20.0, 3.0), pix(20.0, 60.0, 3.0), pix(60.0, 20.0, 3.0)];
        let both: Vec<Vec3> = far.iter().chain(&near).copied().collect();
        let o = opts(SampleCount::X4);
        let cam = camera(S);
        let (x, y) = (25, 25);
        for order in [[[0u32, 1, 2], [3, 4, 5]], [[3, 4, 5], [0, 1, 2]]] {
            let vis = visibility(&[item(&both, &order, 0)], &cam, &o);
            let near_index = if order[0][0] == 3 { 0 } else { 1 };
            assert_eq!(vis.coverage(x, y, 0, near_index), 4, "order {order:?}");
            assert_eq!(vis.coverage(10, 10, 0, 1 - near_index), 4);
        }
        let tri = [[0u32, 1, 2]];
        for (a, b, near_item) in [(&far, &near, 1), (&near, &far, 0)] {
            let vis = visibility(&[item(a, &tri, 0), item(b, &tri, 1)], &cam, &o);
            assert_eq!(vis.coverage(x, y, near_item, 0), 4);
        }
        // Exact ties go to the first in scene order.
        let twice = [[0u32, 1, 2], [0, 1, 2]];
        let vis = visibility(&[item(&far, &twice, 0)], &cam, &o);
        assert_eq!(vis.coverage(10, 10, 0, 0), 4);
        let vis = visibility(&[item(&far, &tri, 0), item(&far, &tri, 1)], &cam, &o);
        assert_eq!(vis.coverage(10, 10, 0, 0), 4);
    }

    #[test]
    fn thin_layers_resolve_without_z_fighting() {
        // A tilted surface and a copy 0.005 units nearer (1/6400 of the distance), drawn in
        // both orders: the nearer copy must win at every sample.
        let base = [pix(2.0, 2.0, -6.0), pix(62.0, 4.0, 5.0), pix(3.0, 62.0, 9.0)];
        let lifted = base.map(|p| p + Vec3::new(0.0, 0.0, 0.005));
        let tri = [[0u32, 1, 2]];
        let o = opts(SampleCount::X16);
        for (first, second, near_item) in [(&base, &lifted, 1), (&lifted, &base, 0)] {
            let vis = visibility(&[item(first, &tri, 0), item(second, &tri, 0)], &camera(S), &o);
            let hits: Vec<_> = vis.samples.iter().flatten().collect();
            assert!(hits.len() > 20_000);
            assert!(hits.iter().all(|h| h.item == near_item), "z-fighting with near item {near_item}");
        }
    }

    /// White where the fragment lies on the plane y = −1 and projects back onto the pixel's
    /// sample centroid (perspective-correct interpolation), red otherwise.
    struct FloorCheck(Camera);
    impl Shader for FloorCheck {
        fn shade(&self, f: &Fragment) -> Vec3 {
            let p = self.0.project(f.position).unwrap_or(Vec3::splat(-1e9));
            let (cx, cy) = (f.pixel.0 as f32 + 0.5, f.pixel.1 as f32 + 0.5);
            let ok = (f.position.y + 1.0).abs() < 1e-3 && (p.x - cx).abs() < 0.02 && (p.y - cy).abs() < 0.02;
            if ok { Vec3::ONE } else { Vec3::X }
        }
        fn background(&self, _: u32, _: u32) -> Vec3 {
            Vec3::ZERO
        }
    }

    #[test]
    fn triangles_crossing_the_near_plane_are_clipped() {
        let cam = Camera {
            eye: Vec3::ZERO,
            target: Vec3::new(0.0, 0.0, -1.0),
            up: Vec3::Y,
            fov_y_degrees: 60.0,
            width: S,
            height: S,
        };
        // A floor from 10 behind the camera to 100 in front of it.
        let floor = [
            Vec3::new(-50.0, -1.0, 10.0),
            Vec3::new(50.0, -1.0, 10.0),
            Vec3::new(50.0, -1.0, -100.0),
            Vec3::new(-50.0, -1.0, -100.0),
        ];
        let indices = [[0u32, 1, 2], [0, 2, 3]];
        let scene = [item(&floor, &indices, 0)];
        let o = RenderOptions { backface_culling: true, ..opts(SampleCount::X1) };
        let vis = visibility(&scene, &cam, &o);
        // The far edge's horizon is at y ≈ 32.55: below it floor, above it nothing.
        for x in [0, 20, 32, 63] {
            for y in 0..S {
                assert_eq!(vis.covered(x, y) == 1, y >= 33, "pixel ({x}, {y})");
            }
        }
        // Bottom row: the ray through y = 63.5 meets the floor at distance 1 / tan(30°)·32/31.5.
        let expected = 1.0 / (30f32.to_radians().tan() * 31.5 / 32.0);
        let hit = vis.pixel(32, 63)[0].unwrap();
        assert!((hit.distance - expected).abs() < 1e-3 * expected, "{hit:?} vs {expected}");
        let img = render(&scene, &cam, &FloorCheck(cam), &o);
        for y in 33..S {
            for x in 0..S {
                assert_eq!(img.pixel(x, y), [255; 3], "pixel ({x}, {y})");
            }
        }
        // Entirely behind the camera: nothing.
        let behind = floor.map(|p| Vec3::new(p.x, p.y, p.z.abs() + 1.0));
        let vis = visibility(&[item(&behind, &indices, 0)], &cam, &opts(SampleCount::X4));
        assert!(vis.samples.iter().all(Option::is_none));
    }

    #[test]
    fn huge_triangles_are_clipped_to_the_guard_band() {
        let positions = [pix(-1e6, -1e6, 0.0), pix(1e6, -1e6, 0.0), pix(0.0, 1e6, 0.0)];
        let indices = [[0u32, 1, 2]];
        let vis = visibility(&[item(&positions, &indices, 0)], &camera(S), &opts(SampleCount::X4));
        assert!((0..S).all(|y| (0..S).all(|x| vis.covered(x, y) == 4)));
    }

    #[test]
    fn output_is_byte_identical_for_any_thread_count() {
        let mesh = random_mesh(42, 400, 14.0);
        let fades: Vec<Coverage> = (0..mesh.positions.len()).map(|i| Coverage { share: (i % 7) as f32 / 6.0, fibre: i as f32 * 3.7 }).collect();
        let scene = [
            Triangles {
                positions: &mesh.positions,
                normals: &mesh.normals,
                uvs: &mesh.uvs,
                indices: &mesh.indices[..200],
                part: 3,
                two_sided: false,
                coverage: &[],
            },
            Triangles {
                positions: &mesh.positions,
                normals: &mesh.normals,
                uvs: &mesh.uvs,
                indices: &mesh.indices[200..],
                part: 5,
                two_sided: false,
                // Half of the scene thins out, so that the fades' samples are compared too.
                coverage: &fades,
            },
        ];
        let cam = random_scene_camera(173, 131);
        let png = |threads| {
            let o = RenderOptions { samples_per_pixel: SampleCount::X8, threads, backface_culling: false, shade_per_surface: false };
            render(&scene, &cam, &Busy, &o).encode_png()
        };
        let one = png(Some(1));
        assert_eq!(one, png(Some(2)));
        assert_eq!(one, png(Some(3)));
        assert_eq!(one, png(None));
        let vis = |threads| visibility(&scene, &cam, &RenderOptions { threads, ..RenderOptions::default() });
        assert_eq!(vis(Some(1)), vis(Some(2)));
        assert!(vis(None).samples.iter().flatten().count() > 10_000, "the scene covers the image");
    }

    #[test]
    fn golden_image_hash() {
        let mesh = random_mesh(2024, 60, 12.0);
        let scene = [Triangles {
            positions: &mesh.positions,
            normals: &mesh.normals,
            uvs: &mesh.uvs,
            indices: &mesh.indices,
            part: 1,
            two_sided: false,
            coverage: &[],
        }];
        let cam = random_scene_camera(64, 48);
        let o = RenderOptions { samples_per_pixel: SampleCount::X16, threads: None, backface_culling: false, shade_per_surface: false };
        let png = render(&scene, &cam, &Busy, &o).encode_png();
        let hex: String = Sha256::digest(&png).iter().map(|b| format!("{b:02x}")).collect();
        // Changes only when the rasteriser's output changes on purpose: then update it here.
        assert_eq!(hex, "9ce686fd252cfb56a919de65075df71cc4c985ac8e342919133a4cd4abef4739");
    }

    /// White where the fragment's fields agree with each other, red otherwise.
    struct FieldCheck<'a>(&'a [Vec3], &'a [Vec2], &'a [[u32; 3]]);
    impl Shader for FieldCheck<'_> {
        fn shade(&self, f: &Fragment) -> Vec3 {
            let b = f.barycentric;
            let v = self.2[f.triangle as usize];
            let at = |i: usize| self.0[v[i] as usize];
            let uv = |i: usize| self.1[v[i] as usize];
            let ok = v == f.vertex
                && f.part == 9
                && b.min_element() >= 0.0
                && (b.element_sum() - 1.0).abs() < 1e-5
                && (at(0) * b.x + at(1) * b.y + at(2) * b.z - f.position).length() < 1e-3
                && (uv(0) * b.x + uv(1) * b.y + uv(2) * b.z - f.uv).length() < 1e-5
                && (f.normal.length() - 1.0).abs() < 1e-5
                && (f.view_dir - (Vec3::new(0.0, 0.0, 32.0) - f.position).normalize()).length() < 1e-5;
            if ok { Vec3::ONE } else { Vec3::X }
        }
        fn background(&self, _: u32, _: u32) -> Vec3 {
            Vec3::ZERO
        }
    }

    #[test]
    fn fragments_carry_consistent_attributes() {
        let positions = [pix(4.0, 4.0, 0.0), pix(60.0, 8.0, -20.0), pix(12.0, 60.0, 10.0), pix(58.0, 58.0, 5.0)];
        let uvs = [Vec2::ZERO, Vec2::X, Vec2::Y, Vec2::ONE];
        let indices = [[0u32, 2, 1], [1, 2, 3]];
        let scene = [Triangles { positions: &positions, normals: &[], uvs: &uvs, indices: &indices, part: 9, two_sided: false, coverage: &[] }];
        let img = render(&scene, &camera(S), &FieldCheck(&positions, &uvs, &indices), &opts(SampleCount::X16));
        assert!(img.data.chunks(3).all(|p| p[1] == p[0]), "some fragment failed its checks");
        assert!(img.data.chunks(3).filter(|p| p[0] == 255).count() > 1500);
    }

    #[test]
    fn non_finite_vertices_do_not_panic() {
        let positions = [pix(4.0, 4.0, 0.0), Vec3::new(f32::NAN, 0.0, 0.0), pix(12.0, 60.0, f32::INFINITY)];
        let indices = [[0u32, 1, 2], [0, 2, 1]];
        let scene = [item(&positions, &indices, 0)];
        render(&scene, &camera(S), &PartShader, &RenderOptions::default());
    }

    #[test]
    fn anti_aliasing_blends_along_edges() {
        let positions = [pix(4.0, 4.0, 0.0), pix(60.0, 20.0, 0.0), pix(10.0, 60.0, 0.0)];
        let indices = [[0u32, 1, 2]];
        let scene = [item(&positions, &indices, 0)];
        let count_grey = |samples| {
            let img = render(&scene, &camera(S), &PartShader, &opts(samples));
            img.data.chunks(3).filter(|p| p[0] > 0 && p[0] < 255).count()
        };
        assert_eq!(count_grey(SampleCount::X1), 0);
        for samples in [SampleCount::X4, SampleCount::X8, SampleCount::X16] {
            assert!(count_grey(samples) > 60, "{samples:?}: {}", count_grey(samples));
        }
        // 16 samples give finer steps than 4.
        let levels = |samples| {
            let img = render(&scene, &camera(S), &PartShader, &opts(samples));
            let mut v = img.data.to_vec();
            v.sort();
            v.dedup();
            v.len()
        };
        assert!(levels(SampleCount::X16) > levels(SampleCount::X4));
    }
}
