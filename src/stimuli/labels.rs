//! The label sets a stimulus set declares, kept beside its manifest as `labels/<id>.toml`.
//!
//! A set whose stimuli carry labels of a user's own table (a spec's `label_sets = ["moods.toml"]`,
//! rows labelled `moods:astonished`) carries that table with it, so that everything which opens
//! the set (the analysis reading its manifest, the platform creating and serving a study on it,
//! the report) knows the labels without being told again.
//!
//! In: label-set files (a spec's, or a set directory's `labels/`). Out: the files' tables,
//! registered for the process ([`crate::study::labels::LabelSet::register`]), and the same bytes
//! written into a built set. Invariants: a file is checked for size before it is read
//! ([`MAX_LABEL_FILE_BYTES`]); a file in `labels/` is named after the set it declares; the
//! built-in sets are never written (they are compiled in); the same table in two places is one
//! set, a different table under a taken id is refused naming the file
//! (`stimuli::labels::tests`).

use std::path::{Path, PathBuf};

use crate::study::labels::{LabelSet, LabelTable};

/// The directory of a set that holds its label-set files.
pub const LABELS_DIR: &str = "labels";

/// A label-set file is small text: 13 types with their descriptions are 3 KiB.
pub const MAX_LABEL_FILE_BYTES: u64 = 256 * 1024;

/// The most label-set files one set (or a spec's `label_sets`) may carry.
pub const MAX_FILES: usize = 16;

/// A label-set file that cannot be used: the path and what is wrong.
#[derive(Debug, thiserror::Error)]
#[error("label set file {}: {message}", path.display())]
pub struct LabelFileError {
    pub path: PathBuf,
    pub message: String,
}

fn fail(path: &Path, message: impl Into<String>) -> LabelFileError {
    LabelFileError { path: path.to_path_buf(), message: message.into() }
}

/// A user's label set as it is declared: its table and the file's text (written unchanged into
/// the sets built with it).
#[derive(Debug, Clone, PartialEq)]
pub struct LabelFile {
    pub set: LabelSet,
    pub text: String,
}

/// Reads, checks and registers one label-set file.
pub fn register_file(path: &Path) -> Result<LabelFile, LabelFileError> {
    let size = std::fs::metadata(path).map_err(|e| fail(path, e.to_string()))?.len();
    if size > MAX_LABEL_FILE_BYTES {
        return Err(fail(path, format!("{size} bytes is over the {MAX_LABEL_FILE_BYTES} a label-set file may have")));
    }
    let text = std::fs::read_to_string(path).map_err(|e| fail(path, e.to_string()))?;
    let name = path.file_name().map_or_else(String::new, |n| n.to_string_lossy().into_owned());
    let table = LabelTable::from_toml(&name, &text).map_err(|e| fail(path, e.to_string()))?;
    let set = LabelSet::register(table).map_err(|e| fail(path, e.to_string()))?;
    Ok(LabelFile { set, text })
}

/// Registers every `labels/*.toml` of a set directory (none when it has no `labels/`), in file
/// name order; each file must be named after the set it declares.
pub fn register_set(set_dir: &Path) -> Result<Vec<LabelSet>, LabelFileError> {
    let dir = set_dir.join(LABELS_DIR);
    let entries = match std::fs::read_dir(&dir) {
        Ok(entries) => entries,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(fail(&dir, e.to_string())),
    };
    let mut files: Vec<PathBuf> = Vec::new();
    for entry in entries {
        let path = entry.map_err(|e| fail(&dir, e.to_string()))?.path();
        if path.extension().is_some_and(|x| x == "toml") {
            files.push(path);
        }
        if files.len() > MAX_FILES {
            return Err(fail(&dir, format!("a set carries at most {MAX_FILES} label-set files")));
        }
    }
    files.sort();
    let mut sets = Vec::new();
    for path in files {
        let file = register_file(&path)?;
        let stem = path.file_stem().map_or_else(String::new, |s| s.to_string_lossy().into_owned());
        if stem != file.set.id() {
            return Err(fail(&path, format!("declares the set \"{}\"; a set's label file is named after its set ({}.toml)", file.set.id(), file.set.id())));
        }
        sets.push(file.set);
    }
    Ok(sets)
}

/// Where [`write_set`] puts a user's label set in a set directory.
pub fn file_in(set_dir: &Path, set: LabelSet) -> PathBuf {
    set_dir.join(LABELS_DIR).join(format!("{}.toml", set.id()))
}

/// Writes the user's label sets a set's stimuli are labelled with into `out/labels/`.
pub fn write_set(out: &Path, files: &[LabelFile]) -> Result<(), crate::stimuli::BuildError> {
    if files.is_empty() {
        return Ok(());
    }
    let dir = out.join(LABELS_DIR);
    std::fs::create_dir_all(&dir).map_err(|source| crate::stimuli::BuildError::Io { path: dir.clone(), source })?;
    for file in files {
        crate::stimuli::build::write_atomic(&file_in(out, file.set), file.text.as_bytes())?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const MOODS: &str = "id = \"tempers\"\nname = \"Tempers\"\n[[label]]\nid = \"astonished\"\nname = \"Astonished\"\n[[label]]\nid = \"content\"\nname = \"Content\"\n";

    #[test]
    fn a_sets_label_files_are_registered_by_name_and_checked() {
        let dir = tempfile::tempdir().expect("temp dir");
        assert_eq!(register_set(dir.path()).unwrap(), Vec::new(), "a set without labels/ declares none");
        std::fs::create_dir(dir.path().join(LABELS_DIR)).unwrap();
        std::fs::write(dir.path().join("labels/tempers.toml"), MOODS).unwrap();
        let sets = register_set(dir.path()).unwrap();
        assert_eq!(sets.iter().map(|s| s.id()).collect::<Vec<_>>(), ["tempers"]);
        assert_eq!(LabelSet::find("tempers").unwrap().labels(), ["astonished", "content"]);

        std::fs::write(dir.path().join("labels/other.toml"), MOODS).unwrap();
        let e = register_set(dir.path()).unwrap_err().to_string();
        assert!(e.contains("other.toml") && e.contains("named after its set (tempers.toml)"), "{e}");
        std::fs::remove_file(dir.path().join("labels/other.toml")).unwrap();

        std::fs::write(dir.path().join("labels/tempers.toml"), MOODS.replace("Content", "Pleased")).unwrap();
        let e = register_set(dir.path()).unwrap_err().to_string();
        assert!(e.contains("tempers.toml") && e.contains("already declared"), "a different table under a taken id: {e}");
    }

    #[test]
    fn label_files_over_the_limit_or_broken_are_refused_naming_the_file() {
        let dir = tempfile::tempdir().expect("temp dir");
        let big = dir.path().join("big.toml");
        std::fs::write(&big, vec![b'#'; MAX_LABEL_FILE_BYTES as usize + 1]).unwrap();
        let e = register_file(&big).unwrap_err().to_string();
        assert!(e.contains("big.toml") && e.contains("262145 bytes is over the 262144"), "{e}");
        let bad = dir.path().join("bad.toml");
        std::fs::write(&bad, "id = \"bad\"\nname = \"Bad\"\n[[label]]\nid = \"a\"\nname = \"\"\n").unwrap();
        let e = register_file(&bad).unwrap_err().to_string();
        assert!(e.contains("bad.toml") && e.contains("label[1] (a): name must not be empty"), "{e}");
    }

    #[test]
    fn a_written_label_file_is_the_declared_text() {
        let dir = tempfile::tempdir().expect("temp dir");
        let source = dir.path().join("feelings.toml");
        std::fs::write(&source, MOODS.replace("tempers", "feelings")).unwrap();
        let file = register_file(&source).unwrap();
        let out = dir.path().join("set");
        write_set(&out, std::slice::from_ref(&file)).unwrap();
        assert_eq!(std::fs::read_to_string(file_in(&out, file.set)).unwrap(), file.text);
        assert_eq!(register_set(&out).unwrap(), vec![file.set]);
    }
}
