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

#[test]
fn identities_lists_at_least_24_people() {
    let dir = tempfile::tempdir().unwrap();
    let output = facslab_ok(dir.path(), &["identities"]);
    assert!(String::from_utf8_lossy(&output.stdout).lines().count() >= 24);
}

/// A person generated into a file (one with a beard, one with a goatee) renders from that file,
/// without rebuilding facslab; a damaged file fails with the line and the field named.
#[test]
fn people_from_a_file_render_and_bad_files_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let new = ["identities", "new", "--sex", "F", "--age", "44", "--ancestry", "south-asian", "--seed", "5", "-o", "people.toml"];
    let output = facslab_ok(dir.path(), &new);
    assert_eq!(String::from_utf8_lossy(&output.stdout).trim(), "saf5");
    facslab_ok(dir.path(), &["identities", "new", "--sex", "M", "--age", "61", "--ancestry", "hispanic", "--seed", "5", "--beard", "8", "-o", "people.toml"]);
    let too_long = facslab(dir.path(), &["identities", "new", "--sex", "M", "--age", "61", "--ancestry", "hispanic", "--beard", "30", "-o", "more.toml"]);
    assert!(!too_long.status.success() && stderr(&too_long).contains("--beard"), "{}", stderr(&too_long));
    let goatee = ["identities", "new", "--sex", "M", "--age", "35", "--ancestry", "european", "--seed", "2", "--beard", "6", "--beard-style", "goatee", "-o", "people.toml"];
    facslab_ok(dir.path(), &goatee);
    let unknown = facslab(dir.path(), &["identities", "new", "--sex", "M", "--age", "35", "--ancestry", "european", "--beard", "6", "--beard-style", "handlebar", "-o", "more.toml"]);
    assert!(!unknown.status.success() && stderr(&unknown).contains("handlebar") && stderr(&unknown).contains("goatee"), "{}", stderr(&unknown));
    assert!(!dir.path().join("more.toml").exists());
    let listed = facslab_ok(dir.path(), &["identities", "--identities", "people.toml"]);
    let text = String::from_utf8_lossy(&listed.stdout);
    assert!(text.contains("saf5") && text.contains("hlm5") && text.contains("wm1"), "{text}");
    facslab_ok(dir.path(), &["render", "12", "--identities", "people.toml", "--identity", "hlm5", "-o", "p.png", "--size", "64x64"]);
    facslab_ok(dir.path(), &["render", "12", "--identities", "people.toml", "--identity", "eum2", "-o", "g.png", "--size", "64x64"]);
    assert!(dir.path().join("p.png").exists() && dir.path().join("g.png").exists());
    let people = std::fs::read_to_string(dir.path().join("people.toml")).unwrap();
    assert!(people.contains("\nbeard = 8\nbeard_style = \"full\"\n"), "{people}");
    assert!(people.contains("\nbeard = 6\nbeard_style = \"goatee\"\n"), "{people}");
    let broken = people.replacen("age = 61", "age = 610", 1);
    std::fs::write(dir.path().join("bad.toml"), &broken).unwrap();
    let line = 1 + broken.lines().position(|l| l == "age = 610").unwrap();
    let output = facslab(dir.path(), &["render", "12", "--identities", "bad.toml", "--identity", "hlm5", "-o", "bad.png"]);
    assert!(!output.status.success());
    let message = stderr(&output);
    assert!(message.contains(&format!("line {line}")) && message.contains("`age`") && message.contains("hlm5"), "{message}");
    assert!(!dir.path().join("bad.png").exists());
}

fn png_colour_type(path: &std::path::Path) -> u8 {
    let bytes = std::fs::read(path).expect("the image was written");
    bytes[25]
}

#[test]
fn backdrops_lights_and_grayscale_from_the_command_line() {
    let dir = tempfile::tempdir().unwrap();
    let base = |out: &'static str| vec!["render", "6+12", "--identity", "wf2", "--size", "96x96", "-o", out];
    facslab_ok(dir.path(), &[base("cut.png"), vec!["--backdrop", "transparent"]].concat());
    assert_eq!(png_colour_type(&dir.path().join("cut.png")), 6, "RGBA");
    facslab_ok(dir.path(), &[base("grey.png"), vec!["--grayscale", "--light", "dramatic", "--backdrop", "#203040"]].concat());
    assert_eq!(png_colour_type(&dir.path().join("grey.png")), 2, "RGB");
    let output = facslab(dir.path(), &[base("bad.png"), vec!["--backdrop", "plaid"]].concat());
    assert!(!output.status.success() && stderr(&output).contains("plaid"), "{}", stderr(&output));
    facslab_ok(dir.path(), &["sheet", "--set", "aus", "-o", "s.png", "--tile", "32x32", "--backdrop", "black", "--light", "soft", "--grayscale"]);
    let output = facslab(dir.path(), &["sheet", "-o", "t.png", "--tile", "32x32", "--backdrop", "transparent"]);
    assert!(!output.status.success());
}
