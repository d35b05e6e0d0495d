//! Bakes the vendored face model (`stimuli/face/`) into one binary file in `OUT_DIR`, which
//! `src/engine/asset.rs` embeds: a render then starts without parsing megabytes of text.
//!
//! Layout (little-endian): the magic `FACSLAB-FACE-1`; the vertices (`u32` count, then `f32`
//! x y z each); the parts (`u32` count; each a name, a `u32` triangle count and `u32` corners);
//! the mirror rows; the targets and the regions (`u32` count; each a name, a `u32` row count,
//! the rows' `u32` vertex indices, then their values as `f32`); the tongue's subdivision
//! (`engine::subdivide::Subdivision::to_bytes`). A name is a `u16` length and UTF-8 bytes.
//! Targets and regions are in path order, so the same files give the same bytes. A malformed
//! file stops the build with its path and line.

use std::fs;
use std::path::{Path, PathBuf};

#[path = "src/engine/face_text.rs"]
mod face_text;
// Only the map's making and writing are used here.
#[allow(dead_code)]
#[path = "src/engine/subdivide.rs"]
mod subdivide;

const MAGIC: &[u8] = b"FACSLAB-FACE-1";

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-changed=src/engine/face_text.rs");
    println!("cargo:rerun-if-changed=src/engine/subdivide.rs");
    println!("cargo:rerun-if-changed=stimuli/face");
    let root = Path::new("stimuli/face");
    let mut out = MAGIC.to_vec();
    let (vertices, tongue) = bake_mesh(root, &mut out);
    let mirror = rows(&root.join("mirror.txt"), 1);
    put_rows(&mut out, &mirror);
    bake_dir(&root.join("targets"), "target", 3, &mut out);
    bake_dir(&root.join("regions"), "txt", 1, &mut out);
    // The tongue's subdivision, its new vertices numbered after the baked ones.
    let mut partners: Vec<u32> = (0..vertices).collect();
    for (index, partner) in &mirror {
        if let (Some(slot), Some(&p)) = (partners.get_mut(*index as usize), partner.first()) {
            *slot = p as u32;
        }
    }
    out.extend(subdivide::Subdivision::steps(subdivide::TONGUE_STEPS, &tongue, vertices, &partners).to_bytes());
    let dest = PathBuf::from(std::env::var("OUT_DIR").expect("cargo sets OUT_DIR")).join("face.bin");
    fs::write(&dest, out).unwrap_or_else(|e| panic!("cannot write {}: {e}", dest.display()));
}

fn text(path: &Path) -> String {
    fs::read_to_string(path).unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()))
}

/// Writes the vertices and parts of `head.obj`; returns the number of vertices and the tongue's
/// triangles.
fn bake_mesh(root: &Path, out: &mut Vec<u8>) -> (u32, Vec<[u32; 3]>) {
    let path = root.join("head.obj");
    let (positions, parts) = face_text::parse_obj(&text(&path)).unwrap_or_else(|(line, message)| panic!("{}, line {line}: {message}", path.display()));
    let tongue = parts.iter().find(|p| p.name == "tongue").map(|p| p.triangles.clone()).unwrap_or_else(|| panic!("{} has no tongue", path.display()));
    put_u32(out, positions.len());
    for v in positions.iter().flatten() {
        out.extend(v.to_le_bytes());
    }
    put_u32(out, parts.len());
    for part in parts {
        put_name(out, &part.name);
        put_u32(out, part.triangles.len());
        for i in part.triangles.iter().flatten() {
            out.extend(i.to_le_bytes());
        }
    }
    (u32::try_from(positions.len()).expect("counts fit in u32"), tongue)
}

fn rows(path: &Path, width: usize) -> Vec<(u32, Vec<f32>)> {
    face_text::parse_rows(&text(path), width).unwrap_or_else(|(line, message)| panic!("{}, line {line}: {message}", path.display()))
}

fn put_rows(out: &mut Vec<u8>, rows: &[(u32, Vec<f32>)]) {
    put_u32(out, rows.len());
    for (index, _) in rows {
        out.extend(index.to_le_bytes());
    }
    for value in rows.iter().flat_map(|(_, values)| values) {
        out.extend(value.to_le_bytes());
    }
}

/// Every `*.extension` file under `dir`, named by its path below `dir` without the extension.
fn bake_dir(dir: &Path, extension: &str, width: usize, out: &mut Vec<u8>) {
    let mut files = Vec::new();
    collect(dir, extension, &mut files);
    files.sort();
    put_u32(out, files.len());
    for path in files {
        let relative = path.strip_prefix(dir).expect("under dir").with_extension("");
        let name: Vec<String> = relative.components().map(|c| c.as_os_str().to_string_lossy().into_owned()).collect();
        put_name(out, &name.join("/"));
        put_rows(out, &rows(&path, width));
    }
}

fn collect(dir: &Path, extension: &str, files: &mut Vec<PathBuf>) {
    let entries = fs::read_dir(dir).unwrap_or_else(|e| panic!("cannot list {}: {e}", dir.display()));
    for entry in entries {
        let path = entry.unwrap_or_else(|e| panic!("cannot list {}: {e}", dir.display())).path();
        if path.is_dir() {
            collect(&path, extension, files);
        } else if path.extension().is_some_and(|e| e == extension) {
            files.push(path);
        }
    }
}

fn put_u32(out: &mut Vec<u8>, n: usize) {
    out.extend(u32::try_from(n).expect("counts fit in u32").to_le_bytes());
}

fn put_name(out: &mut Vec<u8>, name: &str) {
    out.extend(u16::try_from(name.len()).expect("short names").to_le_bytes());
    out.extend(name.as_bytes());
}
