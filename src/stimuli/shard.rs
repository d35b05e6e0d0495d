//! Sharded builds: one stimulus set split over several machines (a Slurm array, a Kubernetes
//! indexed Job) and joined again.
//!
//! In: a validated [`SetSpec`] and a [`Shard`] `K/N` (build), or the shard directories (merge).
//! Out: a shard directory, which is the set's usual layout for its entries plus `shard.json`; or
//! a merged set that is byte for byte the directory a build on one machine writes.
//!
//! Invariants: shard `K/N` holds exactly the entries at positions `p` with `p mod N = K − 1`, so
//! N shards partition the set whatever the machines; a shard records the fingerprint of the whole
//! planned set (every planned manifest row, seed and engine version included) and of its dither
//! key (never the key), and merge joins only shards with one set fingerprint and one key
//! fingerprint, each `K` once, each media file with its recorded sha256; the merged set gets the
//! shards' `dither.key`. Merge writes the manifest last, so a failed merge leaves no manifest.

use std::path::{Path, PathBuf};
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use super::build::{self, BuildError, BuildOptions, BuildSummary, Dithering, sha256_hex, write_atomic};
use super::dither::{DitherKey, KEY_FILE};
use super::manifest::{self, ManifestRow};
use super::spec::SetSpec;

/// The most shards a set may be split into.
pub const MAX_SHARDS: u32 = 100_000;

/// The file that marks a shard directory.
pub const SHARD_FILE: &str = "shard.json";

/// One of `count` parts of a set (`index` counts from 1, as `K/N` is written).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    index: u32,
    count: u32,
}

impl Shard {
    pub fn new(index: u32, count: u32) -> Result<Shard, ShardError> {
        if count == 0 || count > MAX_SHARDS || index == 0 || index > count {
            return Err(ShardError::Spec(format!("{index}/{count}")));
        }
        Ok(Shard { index, count })
    }

    /// True when the entry at `position` (0-based, in spec order) belongs to this shard.
    pub fn holds(self, position: usize) -> bool {
        position % self.count as usize == (self.index - 1) as usize
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

impl FromStr for Shard {
    type Err = ShardError;

    fn from_str(text: &str) -> Result<Shard, ShardError> {
        let shown = || text.chars().take(24).collect::<String>();
        let (k, n) = text.trim().split_once('/').ok_or_else(|| ShardError::Spec(shown()))?;
        let (k, n) = (k.trim().parse().map_err(|_| ShardError::Spec(shown()))?, n.trim().parse().map_err(|_| ShardError::Spec(shown()))?);
        Shard::new(k, n).map_err(|_| ShardError::Spec(shown()))
    }
}

/// Why a shard could not be built or shards could not be merged.
#[derive(Debug, thiserror::Error)]
pub enum ShardError {
    #[error("`{0}` is not a shard: write K/N with 1 <= K <= N <= {MAX_SHARDS}, e.g. 3/8")]
    Spec(String),
    #[error(transparent)]
    Build(#[from] BuildError),
    #[error("{}: not a shard directory (no {SHARD_FILE}; build it with `stimuli build … --shard K/N`)", .0.display())]
    NotAShard(PathBuf),
    #[error("{}: {SHARD_FILE} is not valid: {}", .0.display(), .1)]
    BadRecord(PathBuf, String),
    #[error("{} and {} come from different sets: {what} differs ({a} vs {b})", .first.display(), .other.display())]
    Mismatch { first: PathBuf, other: PathBuf, what: &'static str, a: String, b: String },
    #[error("shard {} is given twice ({} and {})", .2, .0.display(), .1.display())]
    Twice(PathBuf, PathBuf, String),
    #[error("shards missing: {0} (every K from 1 to N is needed)")]
    Missing(String),
    #[error("{}: {}", .0.display(), .1)]
    Content(PathBuf, String),
    #[error("{}: the output directory is not empty; merge into a new directory", .0.display())]
    OutputNotEmpty(PathBuf),
    #[error("shard {0}: the parts of one set share one dither key; give it with --dither-key FILE (make one with `facslab stimuli key -o FILE`), or build every part with --no-dither")]
    NeedsKey(Shard),
    #[error("{}: its {KEY_FILE} is not the key {SHARD_FILE} records (fingerprint {recorded})", .dir.display())]
    WrongKey { dir: PathBuf, recorded: String },
}

/// What `shard.json` records.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ShardRecord {
    /// `K/N`.
    shard: String,
    set: String,
    seed: u64,
    engine_version: String,
    /// SHA-256 of the whole set's planned manifest (every row, sha256 left empty).
    plan_sha256: String,
    /// The stimulus ids of the whole set, in spec order.
    ids: Vec<String>,
    /// The fingerprint of the dither key (empty without dither); never the key.
    #[serde(default)]
    dither: String,
}

/// Builds shard `shard` of `spec` into `out` and records it in `shard.json`. The parts of a set
/// must share a key, so a shard is dithered only with a given key ([`Dithering::Key`]) or not at all.
pub fn build_shard(spec: &SetSpec, shard: Shard, out: &Path, options: &BuildOptions) -> Result<BuildSummary, ShardError> {
    let dither = match &options.dither {
        Dithering::SetKey => return Err(ShardError::NeedsKey(shard)),
        Dithering::Key(key) => key.fingerprint(),
        Dithering::Off => String::new(),
    };
    let plan = build::plan(spec, &dither);
    let record = ShardRecord {
        shard: shard.to_string(),
        set: spec.name.clone(),
        seed: spec.seed,
        engine_version: build::ENGINE_VERSION.to_string(),
        plan_sha256: sha256_hex(manifest::to_json(&plan).as_bytes()),
        ids: plan.iter().map(|row| row.stimulus_id.clone()).collect(),
        dither,
    };
    let part = SetSpec {
        entries: spec.entries.iter().enumerate().filter(|(p, _)| shard.holds(*p)).map(|(_, e)| e.clone()).collect(),
        ..spec.clone()
    };
    let summary = build::build(&part, out, options)?;
    let json = serde_json::to_string_pretty(&record).map_err(|e| ShardError::BadRecord(out.to_path_buf(), e.to_string()))?;
    write_atomic(&out.join(SHARD_FILE), format!("{json}\n").as_bytes())?;
    Ok(summary)
}

/// A shard directory read back: its record and manifest rows.
struct ReadShard {
    dir: PathBuf,
    shard: Shard,
    record: ShardRecord,
    rows: Vec<ManifestRow>,
}

fn read_shard(dir: &Path) -> Result<ReadShard, ShardError> {
    let text = std::fs::read_to_string(dir.join(SHARD_FILE)).map_err(|_| ShardError::NotAShard(dir.to_path_buf()))?;
    let record: ShardRecord = serde_json::from_str(&text).map_err(|e| ShardError::BadRecord(dir.to_path_buf(), e.to_string()))?;
    let shard: Shard = record.shard.parse().map_err(|e: ShardError| ShardError::BadRecord(dir.to_path_buf(), e.to_string()))?;
    let manifest_path = dir.join("manifest.json");
    let text = std::fs::read_to_string(&manifest_path).map_err(|e| ShardError::Content(manifest_path.clone(), e.to_string()))?;
    let rows = manifest::from_json(&text).map_err(|e| ShardError::Content(manifest_path, e.to_string()))?;
    Ok(ReadShard { dir: dir.to_path_buf(), shard, record, rows })
}

/// Checks that the shards come from one set and together hold every part once; returns them
/// ordered by `K`.
fn check_complete(mut shards: Vec<ReadShard>) -> Result<Vec<ReadShard>, ShardError> {
    let Some(first) = shards.first() else { return Err(ShardError::Missing("all (no directory given)".into())) };
    let (first_dir, first_record, count) = (first.dir.clone(), first.record.clone(), first.shard.count);
    for other in &shards[1..] {
        let r = &other.record;
        let differs = [
            ("the set name", &first_record.set, &r.set),
            ("the engine version", &first_record.engine_version, &r.engine_version),
            ("the dither key (its fingerprint; build every part with the same --dither-key)", &first_record.dither, &r.dither),
            ("the planned set (spec or seed)", &first_record.plan_sha256, &r.plan_sha256),
        ]
        .into_iter()
        .map(|(what, a, b)| (what, a.clone(), b.clone()))
        .chain([("the seed", first_record.seed.to_string(), r.seed.to_string())])
        .chain([("the number of shards N", count.to_string(), other.shard.count.to_string())])
        .find(|(_, a, b)| a != b);
        if let Some((what, a, b)) = differs {
            return Err(ShardError::Mismatch { first: first_dir, other: other.dir.clone(), what, a, b });
        }
    }
    shards.sort_by_key(|s| s.shard.index);
    for pair in shards.windows(2) {
        if pair[0].shard == pair[1].shard {
            return Err(ShardError::Twice(pair[0].dir.clone(), pair[1].dir.clone(), pair[0].shard.to_string()));
        }
    }
    let missing: Vec<String> =
        (1..=count).filter(|k| !shards.iter().any(|s| s.shard.index == *k)).take(20).map(|k| format!("{k}/{count}")).collect();
    if !missing.is_empty() {
        return Err(ShardError::Missing(missing.join(", ")));
    }
    Ok(shards)
}

/// Checks that a shard holds exactly its part of the set, each media file with its sha256.
fn check_contents(shard: &ReadShard) -> Result<(), ShardError> {
    let expected: Vec<&String> = shard.record.ids.iter().enumerate().filter(|(p, _)| shard.shard.holds(*p)).map(|(_, id)| id).collect();
    let held: Vec<&String> = shard.rows.iter().map(|r| &r.stimulus_id).collect();
    if expected != held {
        return Err(ShardError::Content(
            shard.dir.join("manifest.json"),
            format!("holds {} stimuli, but shard {} of this set has {}", held.len(), shard.shard, expected.len()),
        ));
    }
    for row in &shard.rows {
        if !manifest::is_media_path(&row.file) {
            return Err(ShardError::Content(shard.dir.join("manifest.json"), format!("stimulus {}: file `{}` is not under media/", row.stimulus_id, row.file)));
        }
        if row.dither != shard.record.dither {
            return Err(ShardError::Content(shard.dir.join("manifest.json"), format!("stimulus {} was dithered with another key than {SHARD_FILE} records", row.stimulus_id)));
        }
        let path = shard.dir.join(&row.file);
        let bytes = std::fs::read(&path).map_err(|e| ShardError::Content(path.clone(), e.to_string()))?;
        if sha256_hex(&bytes) != row.sha256 {
            return Err(ShardError::Content(path, "its sha256 differs from the manifest's: the shard is damaged or was changed".into()));
        }
    }
    Ok(())
}

/// The dither key a shard holds, checked against the fingerprint its record holds (`None` for a
/// shard built without dither).
fn shard_key(shard: &ReadShard) -> Result<Option<DitherKey>, ShardError> {
    if shard.record.dither.is_empty() {
        return Ok(None);
    }
    let key = DitherKey::read(&shard.dir.join(KEY_FILE)).map_err(BuildError::from)?;
    if key.fingerprint() != shard.record.dither {
        return Err(ShardError::WrongKey { dir: shard.dir.clone(), recorded: shard.record.dither.clone() });
    }
    Ok(Some(key))
}

/// What a merge did.
#[derive(Debug, Clone, PartialEq)]
pub struct MergeSummary {
    pub shards: usize,
    pub stimuli: usize,
    pub files: usize,
}

/// Joins complete shards of one set into `out` (which must be empty or absent).
pub fn merge(dirs: &[PathBuf], out: &Path) -> Result<MergeSummary, ShardError> {
    if std::fs::read_dir(out).is_ok_and(|mut entries| entries.next().is_some()) {
        return Err(ShardError::OutputNotEmpty(out.to_path_buf()));
    }
    let shards = check_complete(dirs.iter().map(|d| read_shard(d)).collect::<Result<_, _>>()?)?;
    shards.iter().try_for_each(check_contents)?;
    let key = shards.iter().map(shard_key).collect::<Result<Vec<_>, _>>()?.into_iter().next().flatten();
    let mut files = 0;
    for shard in &shards {
        files += copy_set_files(&shard.dir, out)?;
    }
    if let Some(key) = key {
        key.write(&out.join(KEY_FILE)).map_err(BuildError::from)?;
    }
    let order: std::collections::HashMap<String, usize> =
        shards[0].record.ids.iter().enumerate().map(|(position, id)| (id.clone(), position)).collect();
    let mut rows: Vec<ManifestRow> = shards.into_iter().flat_map(|s| s.rows).collect();
    rows.sort_by_key(|row| order.get(&row.stimulus_id).copied());
    write_atomic(&out.join("manifest.csv"), manifest::to_csv(&rows).as_bytes())?;
    write_atomic(&out.join("manifest.json"), manifest::to_json(&rows).as_bytes())?;
    Ok(MergeSummary { shards: dirs.len(), stimuli: rows.len(), files })
}

/// The directories of a set's layout whose files are copied by a merge (the manifests are
/// written anew, the dither key is written from the checked key; `shard.json` stays behind).
const SET_DIRS: [&str; 6] = ["media", "posters", "ground_truth", "timelines", "frames", crate::stimuli::labels::LABELS_DIR];

/// Copies a shard's set files into `out`, each through a temporary name; returns how many.
fn copy_set_files(shard: &Path, out: &Path) -> Result<usize, ShardError> {
    let mut count = 0;
    for dir in SET_DIRS {
        let from = shard.join(dir);
        if from.is_dir() {
            count += copy_tree(&from, &out.join(dir))?;
        }
    }
    Ok(count)
}

fn copy_tree(from: &Path, to: &Path) -> Result<usize, ShardError> {
    let io = |path: &Path, e: std::io::Error| ShardError::Content(path.to_path_buf(), e.to_string());
    std::fs::create_dir_all(to).map_err(|e| io(to, e))?;
    let mut entries: Vec<PathBuf> =
        std::fs::read_dir(from).map_err(|e| io(from, e))?.map(|e| e.map(|e| e.path())).collect::<Result<_, _>>().map_err(|e| io(from, e))?;
    entries.sort();
    let mut count = 0;
    for path in entries {
        let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        if name.starts_with('.') {
            continue; // a partial file of an interrupted build
        }
        if path.is_dir() {
            count += copy_tree(&path, &to.join(&name))?;
        } else {
            let bytes = std::fs::read(&path).map_err(|e| io(&path, e))?;
            write_atomic(&to.join(&name), &bytes)?;
            count += 1;
        }
    }
    Ok(count)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_parse_from_k_slash_n_and_refuse_the_rest() {
        assert_eq!("3/8".parse::<Shard>().ok(), Some(Shard { index: 3, count: 8 }));
        assert_eq!(" 1 / 1 ".parse::<Shard>().ok(), Some(Shard { index: 1, count: 1 }));
        for bad in ["0/4", "5/4", "4", "a/4", "1/0", "1/100001", "-1/4"] {
            let err = bad.parse::<Shard>().unwrap_err();
            assert!(err.to_string().starts_with(&format!("`{bad}` is not a shard")), "{bad}: {err}");
        }
        let long = "9".repeat(5000);
        assert!(format!("{long}/1").parse::<Shard>().unwrap_err().to_string().len() < 120, "the message quotes a short excerpt");
    }

    #[test]
    fn n_shards_partition_the_positions() {
        for count in 1..=7u32 {
            for position in 0..50usize {
                let holders = (1..=count).filter(|k| Shard::new(*k, count).is_ok_and(|s| s.holds(position))).count();
                assert_eq!(holders, 1, "position {position} with {count} shards");
            }
        }
    }
}
