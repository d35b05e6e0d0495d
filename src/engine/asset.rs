//! The face model: the vendored CC0 MakeHuman hm08 head extract (`stimuli/face/`, see its
//! PROVENANCE.md), embedded in the binary so that rendering needs no files at run time.
//!
//! In: `head.obj` (parts as `o` blocks, triangles), sparse targets (`index dx dy dz`), per-vertex
//! region weights (`index weight`) and the left/right mirror map. Out: [`FaceModel`] with rest
//! positions, triangles per [`Part`], and lookups for targets and regions by name.
//!
//! Units are decimetres; +y is up, +z points out of the face, +x is the person's left.
//! Invariant: everything here is read-only after loading; the same files give the same model.

use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};

use glam::Vec3;
use include_dir::{Dir, DirEntry, include_dir};

static FACE_DIR: Dir<'static> = include_dir!("$CARGO_MANIFEST_DIR/stimuli/face");

/// Every embedded file's contents by its path under `stimuli/face` (`targets/…/x.target`),
/// indexed once: `include_dir` finds a file by comparing paths entry by entry, which made
/// loading the hundreds of targets a large part of start-up.
fn embedded_files() -> &'static HashMap<&'static str, &'static [u8]> {
    static FILES: OnceLock<HashMap<&'static str, &'static [u8]>> = OnceLock::new();
    FILES.get_or_init(|| {
        let mut files = HashMap::new();
        let mut dirs = vec![&FACE_DIR];
        while let Some(dir) = dirs.pop() {
            for entry in dir.entries() {
                match entry {
                    DirEntry::Dir(sub) => dirs.push(sub),
                    DirEntry::File(file) => {
                        if let Some(path) = file.path().to_str() {
                            files.insert(path, file.contents());
                        }
                    }
                }
            }
        }
        files
    })
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

    /// Thin sheets and open shells (teeth, tongue, lashes), which may be seen from behind; the
    /// skin and the eyeballs are closed surfaces seen from outside (the back of a fold in the
    /// skin is hidden by its front).
    pub fn is_thin(self) -> bool {
        matches!(self, Part::TeethUpper | Part::TeethLower | Part::Tongue | Part::LashesUpper | Part::LashesLower)
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
    targets: Mutex<HashMap<String, Arc<Target>>>,
}

impl FaceModel {
    /// The embedded hm08 head, loaded once per process.
    pub fn embedded() -> &'static FaceModel {
        static MODEL: OnceLock<FaceModel> = OnceLock::new();
        MODEL.get_or_init(|| FaceModel::load().expect("the embedded face model is valid"))
    }

    fn load() -> Result<FaceModel, AssetError> {
        let (rest, parts) = parse_obj(read("head.obj")?)?;
        let mirror = parse_rows("mirror.txt", |_, fields| fields.first().map(|v| *v as u32))?;
        let mut mirror_map: Vec<u32> = (0..rest.len() as u32).collect();
        for (index, partner) in mirror {
            if let Some(slot) = mirror_map.get_mut(index) {
                *slot = partner;
            }
        }
        Ok(FaceModel { rest, parts, mirror: mirror_map, targets: Mutex::new(HashMap::new()) })
    }

    pub fn part(&self, part: Part) -> &PartMesh {
        &self.parts[part as usize]
    }

    /// The morph target `group/name` (e.g. `faceunits/browInnerUp`), parsed on first use.
    pub fn target(&self, name: &str) -> Result<Arc<Target>, AssetError> {
        let mut cache = self.targets.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
        if let Some(target) = cache.get(name) {
            return Ok(Arc::clone(target));
        }
        let file = format!("targets/{name}.target");
        let rows = parse_rows(&file, |_, fields| (fields.len() == 3).then(|| Vec3::new(fields[0], fields[1], fields[2])))?;
        let target = Arc::new(Target {
            indices: rows.iter().map(|(i, _)| *i as u32).collect(),
            deltas: rows.into_iter().map(|(_, d)| d).collect(),
        });
        cache.insert(name.to_string(), Arc::clone(&target));
        Ok(target)
    }

    /// Whether a target named `group/name` exists.
    pub fn has_target(&self, name: &str) -> bool {
        embedded_files().contains_key(format!("targets/{name}.target").as_str())
    }

    /// The vertex indices of the group `name` in `groups.txt` (e.g. `neck_cut_loop`, in order).
    pub fn group(&self, name: &str) -> Result<Vec<u32>, AssetError> {
        let text = read("groups.txt")?;
        let (n, line) = text
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
        let rows = parse_rows(&format!("regions/{name}.txt"), |_, fields| fields.first().copied())?;
        let mut weights = vec![0.0; self.rest.len()];
        for (index, weight) in rows {
            if let Some(slot) = weights.get_mut(index) {
                *slot = weight;
            }
        }
        Ok(weights)
    }
}

fn read(file: &str) -> Result<&'static str, AssetError> {
    embedded_files().get(file).and_then(|bytes| std::str::from_utf8(bytes).ok()).ok_or_else(|| AssetError::Missing(file.to_string()))
}

/// Reads `index value…` rows; `convert` turns the values after the index into a row value.
fn parse_rows<T>(file: &str, convert: impl Fn(usize, &[f32]) -> Option<T>) -> Result<Vec<(usize, T)>, AssetError> {
    let text = read(file)?;
    let mut rows = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let malformed = |message: &str| AssetError::Malformed { file: file.to_string(), line: n + 1, message: message.to_string() };
        let mut fields = line.split_whitespace();
        let index: usize = fields.next().and_then(|f| f.parse().ok()).ok_or_else(|| malformed("expected a vertex index"))?;
        let values: Vec<f32> = fields.map(str::parse).collect::<Result<_, _>>().map_err(|_| malformed("expected numbers"))?;
        let value = convert(index, &values).ok_or_else(|| malformed("wrong number of values"))?;
        rows.push((index, value));
    }
    Ok(rows)
}

fn parse_obj(text: &str) -> Result<(Vec<Vec3>, Vec<PartMesh>), AssetError> {
    let mut positions = Vec::new();
    let mut parts: Vec<PartMesh> = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let malformed = |message: String| AssetError::Malformed { file: "head.obj".into(), line: n + 1, message };
        let mut fields = line.split_whitespace();
        match fields.next() {
            Some("v") => {
                let xyz: Vec<f32> = fields.map(str::parse).collect::<Result<_, _>>().map_err(|e| malformed(format!("{e}")))?;
                let [x, y, z] = xyz[..] else { return Err(malformed("a vertex needs three coordinates".into())) };
                positions.push(Vec3::new(x, y, z));
            }
            Some("o") => {
                let name = fields.next().unwrap_or_default();
                let part = Part::from_obj_name(name).ok_or_else(|| malformed(format!("unknown part {name}")))?;
                parts.push(PartMesh { part, vertices: 0..0, triangles: Vec::new() });
            }
            Some("f") => {
                let corners: Vec<u32> = fields
                    .map(|f| f.split('/').next().and_then(|v| v.parse::<u32>().ok()).map(|v| v - 1))
                    .collect::<Option<_>>()
                    .ok_or_else(|| malformed("bad face".into()))?;
                let [a, b, c] = corners[..] else { return Err(malformed("faces must be triangles".into())) };
                let part = parts.last_mut().ok_or_else(|| malformed("face before any part".into()))?;
                part.triangles.push([a, b, c]);
            }
            _ => {}
        }
    }
    // Each part's vertices are one contiguous block: the span of its triangles' corners.
    for part in &mut parts {
        let corners = part.triangles.iter().flatten();
        let start = corners.clone().min().copied().unwrap_or(0);
        let end = corners.max().map_or(0, |m| m + 1);
        part.vertices = start..end;
    }
    parts.sort_by_key(|p| p.part);
    if parts.iter().map(|p| p.part).ne(Part::ALL) {
        return Err(AssetError::Malformed { file: "head.obj".into(), line: 0, message: "expected one block per part".into() });
    }
    Ok((positions, parts))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_embedded_head_has_every_part() {
        let model = FaceModel::embedded();
        assert!(model.rest.len() > 4000);
        for part in Part::ALL {
            assert!(!model.part(part).triangles.is_empty(), "{part:?} has no triangles");
        }
        let n = model.rest.len() as u32;
        assert_eq!(model.part(Part::Skin).vertices, 0..4284);
        assert_eq!(model.part(Part::LashesLower).vertices.end, n);
        assert!(model.parts.iter().flat_map(|p| p.triangles.iter().flatten()).all(|&i| i < n));
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
