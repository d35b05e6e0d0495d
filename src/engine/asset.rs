//! The face model: the vendored CC0 MakeHuman hm08 head extract (`stimuli/face/`, see its
//! PROVENANCE.md), baked into the binary at build time (`build.rs`, formats in
//! [`super::face_text`]) so that rendering needs no files and parses no text at run time.
//!
//! In: the baked head (vertices, parts as triangle lists, mirror rows, sparse targets
//! `index dx dy dz`, region weights `index weight`) and `groups.txt`. Out: [`FaceModel`] with rest
//! positions, triangles per [`Part`], and lookups for targets and regions by name.
//!
//! The tongue is drawn subdivided ([`super::subdivide`]; `build.rs` bakes the map too): its new
//! vertices follow the baked ones, the baked tongue's vertices stay (targets and regions move
//! them) but draw nothing, and [`FaceModel::refine`] works the new ones out from them.
//!
//! Units are decimetres; +y is up, +z points out of the face, +x is the person's left.
//! Invariant: everything here is read-only after loading; the same files give the same model
//! (the numbers are parsed by the same code at build time as they were at run time before, so
//! baking changed no render: `golden::golden_render_hashes`).

use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};

use glam::Vec3;

use super::subdivide::{Blend, Subdivision};

static FACE_BIN: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/face.bin"));
const GROUPS: &str = include_str!("../../stimuli/face/groups.txt");
const MAGIC: &[u8] = b"FACSLAB-FACE-1";

/// A baked row file: its vertex indices and their values, `width` per row, as stored.
#[derive(Debug, Clone, Copy)]
struct BakedRows {
    indices: &'static [u8],
    values: &'static [u8],
}

impl BakedRows {
    fn indices(self) -> impl Iterator<Item = u32> {
        indices(self.indices)
    }

    fn values(self) -> impl Iterator<Item = f32> {
        floats(self.values)
    }
}

/// Walks the baked bytes in the order `build.rs` wrote them.
struct Reader {
    at: usize,
}

impl Reader {
    fn take(&mut self, n: usize) -> Result<&'static [u8], AssetError> {
        let bytes = FACE_BIN.get(self.at..self.at + n).ok_or_else(|| AssetError::Missing(format!("baked face model (truncated at byte {})", self.at)))?;
        self.at += n;
        Ok(bytes)
    }

    fn count(&mut self) -> Result<usize, AssetError> {
        let b = self.take(4)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize)
    }

    fn name(&mut self) -> Result<&'static str, AssetError> {
        let b = self.take(2)?;
        let bytes = self.take(u16::from_le_bytes([b[0], b[1]]) as usize)?;
        std::str::from_utf8(bytes).map_err(|_| AssetError::Missing("baked face model (a name is not UTF-8)".into()))
    }

    fn rows(&mut self, width: usize) -> Result<BakedRows, AssetError> {
        let n = self.count()?;
        Ok(BakedRows { indices: self.take(4 * n)?, values: self.take(4 * n * width)? })
    }

    /// A part's subdivision, as `build.rs` wrote it.
    fn subdivision(&mut self) -> Result<Subdivision, AssetError> {
        let (map, used) = FACE_BIN.get(self.at..).and_then(Subdivision::from_bytes).ok_or_else(|| AssetError::Missing("baked face model (the tongue's subdivision)".into()))?;
        self.at += used;
        Ok(map)
    }

    fn named_rows(&mut self, width: usize) -> Result<HashMap<&'static str, BakedRows>, AssetError> {
        let n = self.count()?;
        (0..n).map(|_| Ok((self.name()?, self.rows(width)?))).collect()
    }
}

fn floats(bytes: &[u8]) -> impl Iterator<Item = f32> + '_ {
    bytes.chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
}

fn indices(bytes: &[u8]) -> impl Iterator<Item = u32> + '_ {
    bytes.chunks_exact(4).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
}

/// Problems reading the face model (only possible when the vendored files are damaged or a
/// basis table names a target or region that does not exist).
#[derive(Debug, thiserror::Error)]
pub enum AssetError {
    #[error("face model file {0} is missing")]
    Missing(String),
    #[error("face model file {file}, line {line}: {message}")]
    Malformed { file: String, line: usize, message: String },
}

/// The separately shaded pieces of the head.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Part {
    Skin,
    EyeLeft,
    EyeRight,
    TeethUpper,
    TeethLower,
    Tongue,
    LashesUpper,
    LashesLower,
}

impl Part {
    pub const ALL: [Part; 8] = [
        Part::Skin,
        Part::EyeLeft,
        Part::EyeRight,
        Part::TeethUpper,
        Part::TeethLower,
        Part::Tongue,
        Part::LashesUpper,
        Part::LashesLower,
    ];

    fn from_obj_name(name: &str) -> Option<Part> {
        Some(match name {
            "skin" => Part::Skin,
            "eye_l" => Part::EyeLeft,
            "eye_r" => Part::EyeRight,
            "teeth_upper" => Part::TeethUpper,
            "teeth_lower" => Part::TeethLower,
            "tongue" => Part::Tongue,
            "lashes_upper" => Part::LashesUpper,
            "lashes_lower" => Part::LashesLower,
            _ => return None,
        })
    }

    pub fn id(self) -> u16 {
        self as u16
    }

    pub fn from_id(id: u16) -> Option<Part> {
        Part::ALL.get(id as usize).copied()
    }

    /// Thin sheets and open shells (teeth, lashes), which may be seen from behind; the skin, the
    /// eyeballs and the tongue are closed surfaces seen from outside (the back of a fold in the
    /// skin is hidden by its front; the tongue is closed and wound alike throughout:
    /// `tests::the_tongue_is_a_closed_shell_wound_outward`).
    pub fn is_thin(self) -> bool {
        matches!(self, Part::TeethUpper | Part::TeethLower | Part::LashesUpper | Part::LashesLower)
    }
}

impl Blend for Vec3 {
    const ZERO: Vec3 = Vec3::ZERO;
    fn plus_scaled(self, other: Vec3, weight: f32) -> Vec3 {
        self + other * weight
    }
}

/// A sparse morph target: per-vertex offsets in decimetres.
#[derive(Debug, Clone, Default)]
pub struct Target {
    pub indices: Vec<u32>,
    pub deltas: Vec<Vec3>,
}

/// One part's vertices (a contiguous range) and triangles (indices into the whole model).
#[derive(Debug, Clone)]
pub struct PartMesh {
    pub part: Part,
    pub vertices: std::ops::Range<u32>,
    pub triangles: Vec<[u32; 3]>,
}

/// The neutral head: rest positions, parts, mirror map.
#[derive(Debug)]
pub struct FaceModel {
    pub rest: Vec<Vec3>,
    pub parts: Vec<PartMesh>,
    /// For each vertex, its mirror partner across the midline (itself on the midline).
    pub mirror: Vec<u32>,
    target_rows: HashMap<&'static str, BakedRows>,
    region_rows: HashMap<&'static str, BakedRows>,
    targets: Mutex<HashMap<String, Arc<Target>>>,
    lash_roots: OnceLock<LashRoots>,
    /// The parts drawn subdivided (the tongue, [`super::subdivide::TONGUE_STEPS`]).
    subdivided: Vec<Subdivided>,
}

/// A part drawn subdivided: its baked triangles, whose vertices the targets and regions still
/// move and which cast its shadow (a shadow needs no finer outline), and the map from their
/// vertices to the drawn ones.
#[derive(Debug)]
struct Subdivided {
    part: Part,
    baked: Vec<[u32; 3]>,
    map: Subdivision,
}

/// For every lash vertex (upper and lower cards, both eyes), the skin vertex nearest to it at
/// rest: the lash's root on the lid margin, which moves it when a lid moves and whose normal,
/// light and paint the skin seen between the lash clumps takes.
#[derive(Debug)]
pub struct LashRoots {
    /// The first lash vertex; `nearest` is indexed from it.
    first: u32,
    nearest: Vec<u32>,
}

impl LashRoots {
    /// The root of lash vertex `v` (vertex 0 for a vertex that is not a lash's).
    pub fn of(&self, v: u32) -> u32 {
        v.checked_sub(self.first).and_then(|i| self.nearest.get(i as usize)).copied().unwrap_or(0)
    }

    /// The nearest of `skin` (`x` and index, sorted by `x`) to `p`, the lowest index of equally
    /// near ones: walks outward from `p`'s `x` until the gap in `x` alone is larger than the
    /// best distance found.
    fn nearest(skin: &[(f32, u32)], rest: &[Vec3], p: Vec3) -> u32 {
        let start = skin.partition_point(|&(x, _)| x < p.x);
        let (mut best, mut best_v) = (f32::INFINITY, 0u32);
        let mut consider = |(x, v): (f32, u32)| {
            if (x - p.x).powi(2) > best {
                return false;
            }
            let d = rest[v as usize].distance_squared(p);
            if d < best || (d == best && v < best_v) {
                (best, best_v) = (d, v);
            }
            true
        };
        let mut right = skin[start..].iter();
        let mut left = skin[..start].iter().rev();
        let (mut go_right, mut go_left) = (true, true);
        while go_right || go_left {
            go_right = go_right && right.next().is_some_and(|&entry| consider(entry));
            go_left = go_left && left.next().is_some_and(|&entry| consider(entry));
        }
        best_v
    }

    fn new(model: &FaceModel) -> LashRoots {
        let (upper, lower) = (&model.part(Part::LashesUpper).vertices, &model.part(Part::LashesLower).vertices);
        let (first, last) = (upper.start.min(lower.start), upper.end.max(lower.end));
        let mut skin: Vec<(f32, u32)> = model.part(Part::Skin).vertices.clone().map(|v| (model.rest[v as usize].x, v)).collect();
        skin.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let nearest = (first..last).map(|lash| Self::nearest(&skin, &model.rest, model.rest[lash as usize])).collect();
        LashRoots { first, nearest }
    }
}

impl FaceModel {
    /// The embedded hm08 head, loaded once per process.
    pub fn embedded() -> &'static FaceModel {
        static MODEL: OnceLock<FaceModel> = OnceLock::new();
        MODEL.get_or_init(|| FaceModel::load().expect("the embedded face model is valid"))
    }

    fn load() -> Result<FaceModel, AssetError> {
        let mut reader = Reader { at: 0 };
        if reader.take(MAGIC.len())? != MAGIC {
            return Err(AssetError::Missing("baked face model (wrong magic)".into()));
        }
        let n = reader.count()?;
        let rest: Vec<Vec3> = floats(reader.take(12 * n)?).collect::<Vec<_>>().chunks_exact(3).map(Vec3::from_slice).collect();
        let parts = read_parts(&mut reader)?;
        let mirror_rows = reader.rows(1)?;
        let mut mirror: Vec<u32> = (0..rest.len() as u32).collect();
        for (index, partner) in mirror_rows.indices().zip(mirror_rows.values()) {
            if let Some(slot) = mirror.get_mut(index as usize) {
                *slot = partner as u32;
            }
        }
        let target_rows = reader.named_rows(3)?;
        let region_rows = reader.named_rows(1)?;
        let tongue = reader.subdivision()?;
        let mut model =
            FaceModel { rest, parts, mirror, target_rows, region_rows, targets: Mutex::new(HashMap::new()), lash_roots: OnceLock::new(), subdivided: Vec::new() };
        model.subdivide(Part::Tongue, tongue)?;
        Ok(model)
    }

    /// Replaces `part`'s triangles by those of `map`, a subdivision of them, on new vertices
    /// appended to the model (rest positions and mirror partners included).
    fn subdivide(&mut self, part: Part, map: Subdivision) -> Result<(), AssetError> {
        if map.vertices().start as usize != self.rest.len() {
            return Err(AssetError::Missing(format!("baked face model ({part:?}'s subdivision does not follow the vertices)")));
        }
        self.rest.resize(map.vertices().end as usize, Vec3::ZERO);
        map.apply(&mut self.rest);
        self.mirror.extend_from_slice(map.mirror());
        let mesh = &mut self.parts[part as usize];
        mesh.vertices = map.vertices();
        let baked = std::mem::replace(&mut mesh.triangles, map.triangles().to_vec());
        self.subdivided.push(Subdivided { part, baked, map });
        Ok(())
    }

    /// Works out the subdivided parts' vertices in `values` (the model's vertices posed or
    /// shaped, or a value per vertex that varies linearly over the surface) from the baked
    /// vertices they are made of: called after everything that sets those.
    pub fn refine<T: Blend>(&self, values: &mut [T]) {
        for subdivided in &self.subdivided {
            subdivided.map.apply(values);
        }
    }

    /// How many vertices were baked: those past them are the ones [`Self::refine`] works out.
    pub fn baked_vertices(&self) -> usize {
        self.subdivided.iter().map(|s| s.map.vertices().start as usize).min().unwrap_or(self.rest.len())
    }

    /// The triangles that cast `part`'s shadow: the baked ones of a subdivided part, else the
    /// ones drawn.
    pub fn casting_triangles(&self, part: Part) -> &[[u32; 3]] {
        self.subdivided.iter().find(|s| s.part == part).map_or(&self.part(part).triangles, |s| &s.baked)
    }

    pub fn part(&self, part: Part) -> &PartMesh {
        &self.parts[part as usize]
    }

    /// Each lash vertex's root on the lid margin (worked out on first use).
    pub fn lash_roots(&self) -> &LashRoots {
        self.lash_roots.get_or_init(|| LashRoots::new(self))
    }

    /// The morph target `group/name` (e.g. `faceunits/browInnerUp`), unpacked on first use.
    pub fn target(&self, name: &str) -> Result<Arc<Target>, AssetError> {
        let mut cache = self.targets.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
        if let Some(target) = cache.get(name) {
            return Ok(Arc::clone(target));
        }
        let rows = self.target_rows.get(name).ok_or_else(|| AssetError::Missing(format!("targets/{name}.target")))?;
        let deltas: Vec<f32> = rows.values().collect();
        let target = Arc::new(Target { indices: rows.indices().collect(), deltas: deltas.chunks_exact(3).map(Vec3::from_slice).collect() });
        cache.insert(name.to_string(), Arc::clone(&target));
        Ok(target)
    }

    /// Whether a target named `group/name` exists.
    pub fn has_target(&self, name: &str) -> bool {
        self.target_rows.contains_key(name)
    }

    /// The vertex indices of the group `name` in `groups.txt` (e.g. `neck_cut_loop`, in order).
    pub fn group(&self, name: &str) -> Result<Vec<u32>, AssetError> {
        let (n, line) = GROUPS
            .lines()
            .enumerate()
            .find(|(_, line)| line.split_once(':').is_some_and(|(key, _)| key.trim() == name))
            .ok_or_else(|| AssetError::Missing(format!("groups.txt group {name}")))?;
        let (_, list) = line.split_once(':').unwrap_or_default();
        let indices: Vec<u32> = list.split_whitespace().map(str::parse).collect::<Result<_, _>>().map_err(|_| AssetError::Malformed {
            file: "groups.txt".into(),
            line: n + 1,
            message: "expected vertex indices".into(),
        })?;
        if indices.iter().any(|&i| i as usize >= self.rest.len()) {
            return Err(AssetError::Malformed { file: "groups.txt".into(), line: n + 1, message: "vertex index out of range".into() });
        }
        Ok(indices)
    }

    /// Dense per-vertex weights of the region `name` (`lips`, `bone-jaw`, …), 0 where unlisted.
    pub fn region(&self, name: &str) -> Result<Vec<f32>, AssetError> {
        let rows = self.region_rows.get(name).ok_or_else(|| AssetError::Missing(format!("regions/{name}.txt")))?;
        let mut weights = vec![0.0; self.rest.len()];
        for (index, weight) in rows.indices().zip(rows.values()) {
            if let Some(slot) = weights.get_mut(index as usize) {
                *slot = weight;
            }
        }
        Ok(weights)
    }
}

/// The parts, each's vertices the contiguous span of its triangles' corners, in [`Part`] order.
fn read_parts(reader: &mut Reader) -> Result<Vec<PartMesh>, AssetError> {
    let malformed = |message: String| AssetError::Malformed { file: "head.obj".into(), line: 0, message };
    let mut parts = Vec::new();
    for _ in 0..reader.count()? {
        let name = reader.name()?;
        let part = Part::from_obj_name(name).ok_or_else(|| malformed(format!("unknown part {name}")))?;
        let corners: Vec<u32> = {
            let n = reader.count()?;
            indices(reader.take(12 * n)?)
        }.collect();
        let triangles: Vec<[u32; 3]> = corners.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
        let start = corners.iter().min().copied().unwrap_or(0);
        let end = corners.iter().max().map_or(0, |m| m + 1);
        parts.push(PartMesh { part, vertices: start..end, triangles });
    }
    parts.sort_by_key(|p| p.part);
    if parts.iter().map(|p| p.part).ne(Part::ALL) {
        return Err(malformed("expected one block per part".into()));
    }
    Ok(parts)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The sorted walk finds the same root as comparing every skin vertex, and the roots of
    /// the upper lashes lie on the lid, within a centimetre and a half of their lashes.
    #[test]
    fn lash_roots_are_the_nearest_skin_vertices() {
        let model = FaceModel::embedded();
        let skin = model.part(Part::Skin).vertices.clone();
        let roots = model.lash_roots();
        for part in [Part::LashesUpper, Part::LashesLower] {
            for v in model.part(part).vertices.clone() {
                let p = model.rest[v as usize];
                let distance = |s: u32| model.rest[s as usize].distance_squared(p);
                let brute = skin.clone().min_by(|&a, &b| distance(a).total_cmp(&distance(b)).then(a.cmp(&b))).unwrap();
                assert_eq!(roots.of(v), brute, "lash vertex {v}");
                assert!(distance(brute).sqrt() < 0.15, "lash vertex {v} is {} dm from its root", distance(brute).sqrt());
            }
        }
        assert_eq!(roots.of(0), 0);
    }

    #[test]
    fn the_embedded_head_has_every_part() {
        let model = FaceModel::embedded();
        assert!(model.rest.len() > 4000);
        for part in Part::ALL {
            assert!(!model.part(part).triangles.is_empty(), "{part:?} has no triangles");
        }
        let n = model.rest.len() as u32;
        assert_eq!(model.part(Part::Skin).vertices, 0..4284);
        // The baked vertices end with the lashes; the subdivided tongue's follow them.
        assert_eq!(model.part(Part::LashesLower).vertices.end, 5040);
        assert_eq!(model.part(Part::Tongue).vertices.end, n);
        assert_eq!(model.part(Part::Tongue).triangles.len(), 448 * 4usize.pow(crate::engine::subdivide::TONGUE_STEPS as u32));
        assert!(model.parts.iter().flat_map(|p| p.triangles.iter().flatten()).all(|&i| i < n));
    }

    /// Every edge of the (subdivided) tongue is walked once each way by its two triangles, and
    /// the volume it encloses is positive: a closed shell whose triangles turn counter-clockwise
    /// seen from outside, so the camera never sees the back of one that is not hidden.
    #[test]
    fn the_tongue_is_a_closed_shell_wound_outward() {
        let model = FaceModel::embedded();
        let tongue = &model.part(Part::Tongue).triangles;
        let mut directed = std::collections::BTreeMap::new();
        for &[a, b, c] in tongue {
            for edge in [(a, b), (b, c), (c, a)] {
                *directed.entry(edge).or_insert(0) += 1;
            }
        }
        for (&(u, v), &n) in &directed {
            assert!(n == 1 && directed.get(&(v, u)) == Some(&1), "edge {u}-{v}: {n} one way, {:?} back", directed.get(&(v, u)));
        }
        let p = |i: u32| model.rest[i as usize];
        let volume: f32 = tongue.iter().map(|&[a, b, c]| p(a).dot(p(b).cross(p(c))) / 6.0).sum();
        assert!(volume > 0.04, "the tongue encloses {volume} dm³");
    }

    /// The angles between neighbouring triangles' faces over a part's edges, in degrees, largest
    /// first.
    fn folds(rest: &[Vec3], triangles: &[[u32; 3]]) -> Vec<f32> {
        let normal = |&[a, b, c]: &[u32; 3]| {
            let p = |i: u32| rest[i as usize];
            (p(b) - p(a)).cross(p(c) - p(a)).normalize()
        };
        let mut beside: HashMap<(u32, u32), Vec<Vec3>> = HashMap::new();
        for t in triangles {
            let [a, b, c] = *t;
            for (u, v) in [(a, b), (b, c), (c, a)] {
                beside.entry((u.min(v), u.max(v))).or_default().push(normal(t));
            }
        }
        let mut folds: Vec<f32> = beside.values().filter(|n| n.len() == 2).map(|n| n[0].dot(n[1]).clamp(-1.0, 1.0).acos().to_degrees()).collect();
        folds.sort_by(|a, b| b.total_cmp(a));
        folds
    }

    /// The drawn tongue has no sharp fold: its two Loop steps bring the largest angle between
    /// neighbouring faces from over 100° on the baked mesh (112°, at the rim of its tip, where
    /// AU19 puts it out between the lips) under 40° (37.6°), and the ninth decile under a quarter
    /// of the baked mesh's (9.9° against 42.6°).
    #[test]
    fn the_drawn_tongue_has_no_sharp_folds() {
        let model = FaceModel::embedded();
        let baked = folds(&model.rest, model.casting_triangles(Part::Tongue));
        let drawn = folds(&model.rest, &model.part(Part::Tongue).triangles);
        let decile = |f: &[f32]| f[f.len() / 10];
        println!("folds: baked largest {:.1}°, ninth decile {:.1}°; drawn {:.1}°, {:.1}°", baked[0], decile(&baked), drawn[0], decile(&drawn));
        assert!(baked[0] > 100.0, "the baked tongue's sharpest fold is {:.1}°", baked[0]);
        assert!(drawn[0] < 40.0, "the drawn tongue folds by {:.1}°", drawn[0]);
        assert!(decile(&drawn) < decile(&baked) / 4.0, "ninth decile {:.1}° against {:.1}°", decile(&drawn), decile(&baked));
    }

    #[test]
    fn mirror_is_an_involution() {
        let model = FaceModel::embedded();
        for (i, &partner) in model.mirror.iter().enumerate() {
            assert_eq!(model.mirror[partner as usize] as usize, i);
        }
    }

    #[test]
    fn targets_and_regions_load() {
        let model = FaceModel::embedded();
        let smile = model.target("faceunits/mouthSmileLeft").unwrap();
        assert!(smile.indices.len() > 100);
        assert!(model.target("faceunits/noSuchThing").is_err());
        let lips = model.region("lips").unwrap();
        assert!(lips.iter().any(|&w| w > 0.9));
    }
}
