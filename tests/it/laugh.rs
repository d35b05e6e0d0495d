//! Laughs and smiles: `facslab laugh` (list, MP4, determinism, `.anim`, bad input) and the
//! thirteen types on the eight evaluation people in both styles.

use std::path::Path;
use std::process::Command;

use facslab::engine::identity::IdentityTable;
use facslab::engine::image::RgbImage;
use facslab::engine::{self, FrameSettings, Style};
use facslab::facs::Catalog;
use facslab::laugh::{anim, perform, Curves, LaughTable, Take};

use crate::cli::{facslab, facslab_ok, stderr};

/// The eight evaluation people (analysis/validation/calibrate.py EVALUATION_PEOPLE).
const EVALUATION_PEOPLE: [&str; 8] = ["wm1", "wm2", "bm1", "bm2", "wf1", "wf2", "bf1", "bf2"];

fn ffprobe(dir: &Path, file: &str, entries: &str) -> String {
    let out = Command::new("ffprobe")
        .args(["-v", "error", "-count_frames", "-show_entries", entries, "-of", "compact", file])
        .current_dir(dir)
        .output()
        .expect("ffprobe runs (apt-get install ffmpeg)");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn files_in(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    names.sort();
    names
}

#[test]
fn laugh_list_prints_the_thirteen_types_id_first() {
    let dir = tempfile::tempdir().unwrap();
    let out = facslab_ok(dir.path(), &["laugh", "--list"]);
    let text = String::from_utf8(out.stdout).unwrap();
    let ids: Vec<&str> = text.lines().map(|l| l.split_whitespace().next().unwrap()).collect();
    assert_eq!(ids, LaughTable::built_in().ids(), "{text}");
    assert!(text.lines().next().unwrap().contains("Uproarious laughter (laugh, "), "{text}");
    let help = String::from_utf8(facslab_ok(dir.path(), &["laugh", "--help"]).stdout).unwrap();
    assert!(help.contains("Examples:") && help.contains("--style") && help.contains("--anim"), "{help}");
}

/// An MP4 of the take's frame count that ffprobe reads, with its `.anim`, timeline, ground
/// truth and strip; the `.anim` reads back into the curves the library performs.
#[test]
fn laugh_renders_an_mp4_with_its_anim_timeline_ground_truth_and_strip() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let args = ["laugh", "laughter", "--identity", "bf1", "--size", "48x48", "--duration", "1.5", "--seed", "4", "--style", "cartoon"];
    facslab_ok(d, &[&args[..], &["-o", "l.mp4", "--anim", "l.anim", "--export-timeline", "l.json", "--ground-truth", "--strip", "l.png"]].concat());
    let streams = ffprobe(d, "l.mp4", "stream=codec_name,width,height,nb_read_frames");
    assert!(streams.contains("codec_name=h264") && streams.contains("width=48") && streams.contains("nb_read_frames=45"), "{streams}");
    let expected = perform(LaughTable::built_in().get("laughter").unwrap(), &Take { duration_s: Some(1.5), seed: 4, ..Take::default() }).unwrap();
    let file = anim::from_anim(&std::fs::read_to_string(d.join("l.anim")).unwrap()).unwrap();
    assert_eq!(file.header.time_unit, "ntsc");
    assert_eq!(file.to_curves("laughter", Catalog::built_in()).unwrap().tracks, expected.tracks);
    let csv = std::fs::read_to_string(d.join("l.csv")).unwrap();
    assert_eq!(csv.lines().count(), 46, "a header and a row per frame");
    assert!(csv.lines().next().unwrap().contains("AU26_r"));
    let timeline = engine::timeline::Timeline::from_json(&std::fs::read_to_string(d.join("l.json")).unwrap()).unwrap();
    assert_eq!((timeline.frame_count(), timeline.identity.as_str()), (45, "bf1"));
    let strip = std::fs::read(d.join("l.png")).unwrap();
    assert_eq!(&strip[16..24], &[0, 0, 1, 32, 0, 0, 0, 48], "six 48x48 frames side by side (IHDR 288x48)");
    let rendered = facslab::laugh::strip::render_strip(&expected, "bf1", (48, 48), Style::Cartoon).unwrap();
    assert_eq!(strip, rendered.encode_png(), "the strip shows the video's own frames");
}

/// The same arguments give the same bytes; another seed or style gives others; `--curves`
/// plays a curve set of the type.
#[test]
fn laugh_is_deterministic_and_plays_curves() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let run_at = |size: &str, name: &str, extra: &[&str]| {
        facslab_ok(d, &[&["laugh", "false_smile", "--size", size, "-o", name][..], extra].concat());
        std::fs::read(d.join(name)).unwrap()
    };
    let run = |name: &str, extra: &[&str]| run_at("32x32", name, extra);
    let a = run("a.mp4", &["--duration", "0.6", "--anim", "a.anim"]);
    assert_eq!(a, run("b.mp4", &["--duration", "0.6"]));
    // Another seed gives another take; at 32x32 two takes may round to the same pixels, so the
    // videos are compared at 64x64.
    run("c.mp4", &["--duration", "0.6", "--seed", "2", "--anim", "c.anim"]);
    assert_ne!(std::fs::read(d.join("a.anim")).unwrap(), std::fs::read(d.join("c.anim")).unwrap());
    let larger = |seed: &str| run_at("64x64", &format!("s{seed}.mp4"), &["--duration", "0.6", "--seed", seed]);
    assert_ne!(larger("1"), larger("2"));
    assert_ne!(a, run("d.mp4", &["--duration", "0.6", "--style", "cartoon"]));
    let curves = anim::from_anim(&std::fs::read_to_string(d.join("a.anim")).unwrap()).unwrap().to_curves("false_smile", Catalog::built_in()).unwrap();
    std::fs::write(d.join("c.json"), curves.to_json()).unwrap();
    assert_eq!(a, run("e.mp4", &["--curves", "c.json"]), "the take's own curves play back to the same video");
}

#[test]
fn laugh_bad_input_is_named_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let other = perform(LaughTable::built_in().get("sly_smile").unwrap(), &Take::default()).unwrap();
    std::fs::write(d.join("sly.json"), other.to_json()).unwrap();
    std::fs::write(d.join("broken.json"), "{\"format\": \"facslab-curves/1\"").unwrap();
    let before = files_in(d);
    let cases: [(&[&str], &str); 9] = [
        (&["giggle"], "laugh type `giggle` is not one of: uproarious_laughter, laughter,"),
        (&["laughter", "--duration", "25"], "duration 25 s is out of range (0.5..=20 s)"),
        (&["laughter", "--intensity", "1.5"], "intensity 1.5 is out of range (0, 1]"),
        (&["laughter", "--fps", "90"], "frame rate 90 is out of range (1..=60 fps)"),
        (&["laughter", "--style", "anime"], "style \"anime\" is not realistic or cartoon"),
        (&["laughter", "--identity", "nobody"], "nobody"),
        (&["laughter", "--curves", "sly.json"], "holds curves of type `sly_smile`, not `laughter`"),
        (&["laughter", "--curves", "broken.json"], "the curves are not valid JSON"),
        (&["laughter", "--curves", "missing.json"], "missing.json"),
    ];
    for (args, message) in cases {
        let out = facslab(d, &[&["laugh"], args, &["--size", "32x32", "-o", "x.mp4", "--anim", "x.anim"]].concat());
        assert!(!out.status.success(), "{args:?} succeeded");
        assert!(stderr(&out).contains(message), "{args:?}: {}", stderr(&out));
    }
    let out = facslab(d, &["laugh", "laughter", "-o", "x.mov"]);
    assert!(stderr(&out).contains("output x.mov must end in .mp4"), "{}", stderr(&out));
    assert_eq!(files_in(d), before, "nothing written on failure");
}

/// Frame `frame` of `curves` on `identity` at 64×64 in `style`.
fn frame_of(curves: &Curves, identity: &str, frame: usize, style: Style) -> RgbImage {
    let timeline = curves.to_timeline(identity, (64, 64));
    let expression = timeline.frame_expression(frame, Catalog::built_in()).unwrap();
    let person = IdentityTable::built_in().get(identity).unwrap();
    engine::render_still(&expression, person, FrameSettings { width: 64, height: 64, threads: Some(1), style, ..Default::default() }).unwrap()
}

/// The frame where the AUs add up to most (the apex of a smile, the widest pulse of a laugh).
fn apex(curves: &Curves) -> usize {
    (0..curves.frame_count())
        .max_by(|&a, &b| {
            let sum = |f: usize| curves.tracks.iter().map(|t| t.values[f]).sum::<f64>();
            sum(a).total_cmp(&sum(b))
        })
        .unwrap()
}

/// Mean absolute difference of two images per channel, 0-255.
fn difference(a: &RgbImage, b: &RgbImage) -> f64 {
    a.data.iter().zip(&b.data).map(|(&x, &y)| x.abs_diff(y) as f64).sum::<f64>() / a.data.len() as f64
}

/// Least mean change (0-255 per channel, 64×64) of an apex frame from rest, and between the
/// apex frames of two types on one person.
const MOVED: f64 = 0.2;
const APART: f64 = 0.25;

/// Acceptance 1: every type renders on every evaluation person in both styles, its apex
/// differs from the person at rest, and the types differ from each other.
#[test]
fn every_laugh_type_renders_on_every_evaluation_person_in_both_styles() {
    let table = LaughTable::built_in();
    let takes: Vec<Curves> = table.iter().map(|t| perform(t, &Take { fps: 10, ..Take::default() }).unwrap()).collect();
    // The smallest change from rest and the smallest difference between two types, per style.
    let mut least = Vec::new();
    for style in Style::ALL {
        let (mut moved_min, mut apart_min) = ((f64::INFINITY, String::new()), (f64::INFINITY, String::new()));
        for person in EVALUATION_PEOPLE {
            let apexes: Vec<RgbImage> = takes.iter().map(|c| frame_of(c, person, apex(c), style)).collect();
            let rest = frame_of(&takes[0], person, 0, style);
            for (curves, image) in takes.iter().zip(&apexes) {
                let moved = difference(image, &rest);
                if moved < moved_min.0 {
                    moved_min = (moved, format!("{} on {person}", curves.laugh_type));
                }
            }
            for i in 0..apexes.len() {
                for j in i + 1..apexes.len() {
                    let apart = difference(&apexes[i], &apexes[j]);
                    if apart < apart_min.0 {
                        apart_min = (apart, format!("{} and {} on {person}", takes[i].laugh_type, takes[j].laugh_type));
                    }
                }
            }
        }
        eprintln!("{style}: least change from rest {:.3} ({}), least difference between types {:.3} ({})", moved_min.0, moved_min.1, apart_min.0, apart_min.1);
        least.push((style, moved_min, apart_min));
    }
    for (style, moved, apart) in least {
        assert!(moved.0 > MOVED, "{style}: {} moves the face by only {:.3}", moved.1, moved.0);
        assert!(apart.0 > APART, "{style}: {} differ by only {:.3}", apart.1, apart.0);
    }
}

/// The docs' frame strips (docs/laughs.md): every type in both styles on wf1 and bm1, seed 1,
/// 240×240. Run `cargo test --features polars --test it laugh_docs_strips -- --ignored` to
/// remake them after changing the table or the styles.
#[test]
#[ignore]
fn laugh_docs_strips() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/laughs");
    std::fs::create_dir_all(&root).unwrap();
    for person in ["wf1", "bm1"] {
        for laugh in LaughTable::built_in().iter() {
            let curves = perform(laugh, &Take::default()).unwrap();
            for style in Style::ALL {
                let strip = facslab::laugh::strip::render_strip(&curves, person, (240, 240), style).unwrap();
                std::fs::write(root.join(format!("{}_{style}_{person}.png", laugh.id)), strip.encode_png()).unwrap();
            }
        }
    }
}
