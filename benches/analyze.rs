//! Analysis throughput: `facslab analyze` end to end (read the manifest and 1,000,000 response
//! rows, compute every statistic, write the report) on a simulated Exp. 3 study. Run with
//! `cargo bench --bench analyze`.

use std::path::{Path, PathBuf};

use facslab::analysis::coding::CodingOptions;
use facslab::analysis::manifest::Manifest;
use facslab::analysis::responses::Responses;
use facslab::analysis::simulate::{Design, SimOptions, simulate};
use facslab::facs::{Catalog, EmotionTable};

fn main() {
    divan::main();
}

/// Participants per condition: 4 conditions × 6,000 raters × (20 stimuli × 2 measures + 4
/// demographic rows) = 1,056,000 rows.
const PARTICIPANTS: usize = 6_000;

struct Files {
    _dir: tempfile::TempDir,
    responses: PathBuf,
    manifest: PathBuf,
    out: PathBuf,
}

fn files() -> Files {
    let dir = tempfile::tempdir().expect("temp dir");
    let options = SimOptions { design: Design::Exp3, participants: PARTICIPANTS, ..SimOptions::default() };
    let (manifest, responses) = simulate(&options);
    let (m, r) = (dir.path().join("manifest.csv"), dir.path().join("responses.csv"));
    std::fs::write(&m, manifest).expect("write manifest");
    std::fs::write(&r, responses).expect("write responses");
    let out = dir.path().join("report");
    Files { responses: r, manifest: m, out, _dir: dir }
}

fn analyze(responses: &Path, manifest_path: &Path, out: &Path) -> u64 {
    let (catalog, emotions) = (Catalog::built_in(), EmotionTable::built_in());
    let manifest = Manifest::read(manifest_path, catalog).expect("manifest");
    let responses_read = Responses::read(responses, &manifest, catalog, &emotions).expect("responses");
    let report = facslab::report::build(&manifest, &responses_read, CodingOptions::default(), responses, manifest_path);
    facslab::report::write(&report, out).expect("report written");
    responses_read.rows
}

#[divan::bench(sample_count = 5, sample_size = 1)]
fn exp3_1m_rows_end_to_end(bencher: divan::Bencher) {
    let f = files();
    assert!(analyze(&f.responses, &f.manifest, &f.out) > 1_000_000);
    bencher.bench(|| analyze(divan::black_box(&f.responses), &f.manifest, &f.out));
}

#[divan::bench(sample_count = 5, sample_size = 1)]
fn exp3_1m_rows_read_only(bencher: divan::Bencher) {
    let f = files();
    let (catalog, emotions) = (Catalog::built_in(), EmotionTable::built_in());
    let manifest = Manifest::read(&f.manifest, catalog).expect("manifest");
    bencher.bench(|| Responses::read(divan::black_box(&f.responses), &manifest, catalog, &emotions).expect("responses").rows);
}
