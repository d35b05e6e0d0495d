//! Determinism: SHA-256 of fixed renders, kept in `tests/golden/renders.sha256`.
//!
//! Any change to the engine's output shows up here. When a change is meant (a better shader, a
//! tuned AU), regenerate the list with `FACSLAB_UPDATE_GOLDEN=1 cargo test --test it golden`
//! and say why in the commit.

use facslab::engine::identity::IdentityTable;
use facslab::engine::{FrameSettings, render_still};
use facslab::facs::Catalog;
use sha2::{Digest, Sha256};

const LIST: &str = "tests/golden/renders.sha256";

/// (expression, identity, width, height): a spread of AUs, sides, intensities and people.
const CASES: &[(&str, &str, u32, u32)] = &[
    ("0", "wm1", 485, 480),
    ("6+12+25", "wf1", 485, 480),
    ("1+2+5B+26", "bm1", 242, 240),
    ("4+5+7+24", "bf2", 242, 240),
    ("L12C+R14", "wm2", 160, 160),
    ("12@0.42+53+64", "bf1", 160, 160),
    ("9+15+16", "bm2", 160, 160),
    ("43+51+61", "wf2", 160, 160),
    // Skin folds over itself under the eyes here: the hidden back of the fold must stay hidden.
    ("1+2+5B+6+12+25", "wm1", 485, 480),
];

fn render_hash(expression: &str, identity: &str, width: u32, height: u32) -> String {
    let expression = Catalog::built_in().parse(expression).expect("valid expression");
    let identity = IdentityTable::built_in().get(identity).expect("known identity");
    let image = render_still(&expression, identity, FrameSettings { width, height, threads: None, ..Default::default() }).expect("renders");
    Sha256::digest(image.encode_png()).iter().map(|b| format!("{b:02x}")).collect()
}

#[test]
fn golden_render_hashes() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(LIST);
    let lines: Vec<String> = CASES
        .iter()
        .map(|&(e, i, w, h)| format!("{} {e} {i} {w}x{h}", render_hash(e, i, w, h)))
        .collect();
    let actual = lines.join("\n") + "\n";
    if std::env::var_os("FACSLAB_UPDATE_GOLDEN").is_some() {
        std::fs::write(&path, &actual).expect("write the golden list");
        return;
    }
    let expected = std::fs::read_to_string(&path).unwrap_or_default();
    assert_eq!(actual, expected, "render hashes changed; if intended, regenerate with FACSLAB_UPDATE_GOLDEN=1 (see {LIST})");
}
