//! `facslab render`, `identities` and `sheet` from the command line.

use sha2::{Digest, Sha256};

use crate::cli::{facslab, facslab_ok, stderr};

fn sha256(path: &std::path::Path) -> String {
    let bytes = std::fs::read(path).expect("the image was written");
    Sha256::digest(&bytes).iter().map(|b| format!("{b:02x}")).collect()
}

#[test]
fn render_writes_a_png_of_the_requested_size() {
    let dir = tempfile::tempdir().unwrap();
    facslab_ok(dir.path(), &["render", "1+2+4B+L12C+R14", "--identity", "bf1", "-o", "face.png", "--size", "120x100"]);
    let bytes = std::fs::read(dir.path().join("face.png")).unwrap();
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
    // IHDR: width and height, big-endian, at bytes 16..24.
    assert_eq!(u32::from_be_bytes(bytes[16..20].try_into().unwrap()), 120);
    assert_eq!(u32::from_be_bytes(bytes[20..24].try_into().unwrap()), 100);
}

#[test]
fn the_same_command_gives_the_same_bytes_on_one_and_two_threads() {
    let dir = tempfile::tempdir().unwrap();
    let args = |out: &'static str, threads: &'static str| ["render", "6+12+25", "--identity", "wm2", "-o", out, "--threads", threads];
    facslab_ok(dir.path(), &args("a.png", "1"));
    facslab_ok(dir.path(), &args("b.png", "2"));
    facslab_ok(dir.path(), &args("c.png", "1"));
    let a = sha256(&dir.path().join("a.png"));
    assert_eq!(a, sha256(&dir.path().join("b.png")), "1 vs 2 threads");
    assert_eq!(a, sha256(&dir.path().join("c.png")), "run twice");
}

#[test]
fn an_invalid_expression_fails_cleanly_without_output() {
    let dir = tempfile::tempdir().unwrap();
    let output = facslab(dir.path(), &["render", "1+2+99C", "-o", "bad.png"]);
    assert!(!output.status.success());
    let message = stderr(&output);
    assert!(message.contains("99C") && message.contains("column 5"), "{message}");
    assert!(!dir.path().join("bad.png").exists());
}

#[test]
fn an_unknown_identity_fails_cleanly_without_output() {
    let dir = tempfile::tempdir().unwrap();
    let output = facslab(dir.path(), &["render", "12", "--identity", "nobody", "-o", "bad.png"]);
    assert!(!output.status.success());
    assert!(stderr(&output).contains("nobody"), "{}", stderr(&output));
    assert!(!dir.path().join("bad.png").exists());
}

#[test]
fn a_unilateral_prefix_on_a_midline_au_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let output = facslab(dir.path(), &["render", "L26", "-o", "bad.png"]);
    assert!(!output.status.success());
    assert!(stderr(&output).contains("one side"), "{}", stderr(&output));
}

#[test]
fn identities_lists_the_eight_evaluation_people() {
    let dir = tempfile::tempdir().unwrap();
    let output = facslab_ok(dir.path(), &["identities"]);
    let text = String::from_utf8_lossy(&output.stdout);
    for id in ["wm1", "wm2", "bm1", "bm2", "wf1", "wf2", "bf1", "bf2"] {
        assert!(text.lines().any(|l| l.starts_with(id)), "{id} missing from:\n{text}");
    }
}

#[test]
fn sheet_renders_every_au() {
    let dir = tempfile::tempdir().unwrap();
    facslab_ok(dir.path(), &["sheet", "-o", "sheet.png", "--tile", "48x48", "--columns", "10"]);
    let bytes = std::fs::read(dir.path().join("sheet.png")).unwrap();
    let width = u32::from_be_bytes(bytes[16..20].try_into().unwrap());
    let height = u32::from_be_bytes(bytes[20..24].try_into().unwrap());
    // neutral + 54 AUs + 2 × 31 one-sided variants = 117 tiles, 12 rows of 10.
    assert_eq!((width, height), (480, 12 * (48 + 22)));
}
