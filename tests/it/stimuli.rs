//! Dynamic stimuli and stimulus sets through the real CLI: `facslab render --video/--timeline`
//! and `facslab stimuli build`, on tiny sets (64×64, 0.3-s clips) so they run in seconds.

use std::collections::BTreeMap;
use std::path::Path;

use facslab::engine::identity::IdentityTable;
use facslab::engine::timeline::Timeline;
use facslab::engine::{FrameSettings, render_still};
use facslab::facs::{Activation, AuCode, Catalog, Expression, Intensity, Laterality};
use facslab::stimuli::ManifestRow;

use crate::browser::Browser;
use crate::cli::{facslab, facslab_ok, stderr};

/// A tiny set: an AU clip with its still at the peak, a one-sided combination, an emotion at
/// 50 %, and a CPT sequence; every frame also written as PNG.
const TINY: &str = r#"
name = "tiny"
seed = 99
size = [64, 64]
fps = 30
png_frames = true

[[group]]
name = "AU"
expressions = ["12"]
video_peaks = [1.0]
stills = [1.0, 0.3]
timing = { onset_s = 0.1, apex_s = 0.1, offset_s = 0.1 }
identity = "bf1"

[[group]]
name = "one-sided"
expressions = ["L12C+R14"]
video_peaks = [0.8]
stills = [0.8]
timing = { onset_s = 0.1, apex_s = 0.1, offset_s = 0.1, ramp = "cosine" }
identity = "wm2"

[[group]]
name = "emotion"
emotions = ["surprise"]
stills = [0.5]

[[group]]
name = "cpt"
cpt = ["novelty"]
video_peaks = [1.0]
timing = { onset_s = 0.05, apex_s = 0.05, offset_s = 0.05 }
"#;

fn build(dir: &Path, spec: &str, out: &str) -> Vec<ManifestRow> {
    build_with(dir, spec, out, &["--jobs", "2"])
}

/// Builds `spec` into `dir/out` with more options; returns the manifest rows.
fn build_with(dir: &Path, spec: &str, out: &str, options: &[&str]) -> Vec<ManifestRow> {
    std::fs::write(dir.join("spec.toml"), spec).unwrap();
    facslab_ok(dir, &[&["stimuli", "build", "spec.toml", "-o", out], options].concat());
    manifest_rows(&dir.join(out))
}

fn manifest_rows(set: &Path) -> Vec<ManifestRow> {
    serde_json::from_str(&std::fs::read_to_string(set.join("manifest.json")).unwrap()).unwrap()
}

/// Every file under `root`, relative path → bytes.
fn files(root: &Path) -> BTreeMap<String, Vec<u8>> {
    let mut out = BTreeMap::new();
    let mut stack = vec![root.to_path_buf()];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else {
                let rel = path.strip_prefix(root).unwrap().to_string_lossy().into_owned();
                out.insert(rel, std::fs::read(&path).unwrap());
            }
        }
    }
    out
}

fn rgb(png: &[u8]) -> (u32, u32, Vec<u8>) {
    let decoder = png::Decoder::new(std::io::Cursor::new(png));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    buf.truncate(info.buffer_size());
    (info.width, info.height, buf)
}

#[test]
fn stimuli_same_spec_and_seed_give_identical_bytes_on_any_jobs_and_a_rebuild_skips_everything() {
    let dir = tempfile::tempdir().unwrap();
    let rows = build(dir.path(), TINY, "a");
    // Another directory with the first one's key: the same bytes, the key file included.
    build_with(dir.path(), TINY, "b", &["--jobs", "1", "--dither-key", "a/dither.key"]);
    let (a, b) = (files(&dir.path().join("a")), files(&dir.path().join("b")));
    assert_eq!(a.keys().collect::<Vec<_>>(), b.keys().collect::<Vec<_>>());
    for (name, bytes) in &a {
        assert!(b[name] == *bytes, "{name} differs between two builds");
    }
    // Manifest: exact columns, sha256 of each file, video sizes padded to even.
    let csv = String::from_utf8(a["manifest.csv"].clone()).unwrap();
    assert_eq!(
        csv.lines().next().unwrap(),
        "stimulus_id,media,file,identity,expression,emotion,intensity,onset_s,apex_s,offset_s,frames,fps,width,height,sha256,set_seed,engine_version,dither"
    );
    assert_eq!(rows.len(), 7);
    assert_eq!(csv.lines().count(), 8);
    for row in &rows {
        use sha2::Digest;
        assert_eq!(hex::encode(sha2::Sha256::digest(&a[&row.file])), row.sha256, "{}", row.file);
        assert_eq!(row.set_seed, 99);
        assert_eq!(row.dither.len(), 16, "the key's fingerprint");
    }
    assert!(a.contains_key("dither.key"));
    for row in &rows {
        facslab::facs::Catalog::built_in().parse(&row.expression).unwrap_or_else(|e| panic!("{}: {e}", row.expression));
    }
    let video = rows.iter().find(|r| r.media == facslab::stimuli::Media::Video).unwrap();
    assert_eq!((video.frames, video.fps, video.width, video.height), (Some(9), Some(30), 64, 64));

    // A second build into the same directory renders nothing and changes nothing.
    let out = facslab_ok(dir.path(), &["stimuli", "build", "spec.toml", "-o", "a"]);
    assert!(stderr(&out).contains("(0 rendered, 7 up to date"), "{}", stderr(&out));
    assert_eq!(files(&dir.path().join("a")), a);
    // A damaged media file is noticed (sha256) and rendered again.
    std::fs::write(dir.path().join("a").join(&video.file), b"broken").unwrap();
    let out = facslab_ok(dir.path(), &["stimuli", "build", "spec.toml", "-o", "a"]);
    assert!(stderr(&out).contains("(1 rendered, 6 up to date"), "{}", stderr(&out));
    assert_eq!(files(&dir.path().join("a")), a);
}

#[test]
fn stimuli_names_and_ids_reveal_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let rows = build(dir.path(), TINY, "set");
    for row in &rows {
        assert_eq!(row.stimulus_id.len(), 16);
        assert!(row.stimulus_id.chars().all(|c| c.is_ascii_hexdigit()), "{}", row.stimulus_id);
        let ext = if row.media == facslab::stimuli::Media::Video { "mp4" } else { "png" };
        assert_eq!(row.file, format!("media/{}.{ext}", row.stimulus_id));
    }
    for name in files(&dir.path().join("set")).keys() {
        let stem = Path::new(name).file_stem().unwrap().to_string_lossy().into_owned();
        let ok = name.starts_with("manifest.")
            || name == "dither.key"
            || rows.iter().any(|r| name.contains(&r.stimulus_id))
            || stem.chars().all(|c| c.is_ascii_digit());
        assert!(ok, "{name} is not an opaque name");
    }
}

/// The engine's bytes: built without dither, the still is the apex frame itself.
#[test]
fn stimuli_apex_frame_equals_the_still_and_ground_truth_matches_each_frame() {
    let dir = tempfile::tempdir().unwrap();
    let rows = build_with(dir.path(), TINY, "set", &["--no-dither"]);
    let set = dir.path().join("set");
    let catalog = Catalog::built_in();
    // Clips only: a CPT sequence has no single apex.
    for video in rows.iter().filter(|r| r.media == facslab::stimuli::Media::Video && r.emotion != "novelty") {
        let still = rows
            .iter()
            .find(|r| r.media == facslab::stimuli::Media::Image && r.identity == video.identity && r.intensity == video.intensity)
            .unwrap_or_else(|| panic!("no still for {}", video.expression));
        assert_eq!(still.expression, video.expression);
        let apex_frame = ((video.onset_s.unwrap() + video.apex_s.unwrap() / 2.0) * video.fps.unwrap() as f64).round() as usize;
        let frame = std::fs::read(set.join(format!("frames/{}/{apex_frame:06}.png", video.stimulus_id))).unwrap();
        let still_png = std::fs::read(set.join(&still.file)).unwrap();
        assert_eq!(rgb(&frame), rgb(&still_png), "apex frame {apex_frame} of {} differs from its still", video.expression);
    }

    for video in rows.iter().filter(|r| r.media == facslab::stimuli::Media::Video) {
        let id = &video.stimulus_id;
        let timeline = Timeline::from_json(&std::fs::read_to_string(set.join(format!("timelines/{id}.json"))).unwrap()).unwrap();
        let csv = std::fs::read_to_string(set.join(format!("ground_truth/{id}.csv"))).unwrap();
        let mut lines = csv.lines();
        let header: Vec<&str> = lines.next().unwrap().split(',').collect();
        assert_eq!(&header[..2], ["frame", "time_s"]);
        let mut count = 0;
        for (f, line) in lines.enumerate() {
            count += 1;
            let fields: Vec<&str> = line.split(',').collect();
            assert_eq!(fields[0].parse::<usize>().unwrap(), f);
            assert_eq!(fields[1].parse::<f64>().unwrap(), timeline.time_of(f));
            // The CSV's intensities are the timeline's …
            let mut activations = Vec::new();
            for (column, value) in header[2..].iter().zip(&fields[2..]) {
                let value: f64 = value.parse().unwrap();
                let (au, side) = parse_column(column);
                let expected = timeline.values_at(timeline.time_of(f)).into_iter().find(|(c, _)| *c == (au, side)).unwrap().1;
                assert_eq!(value, expected, "{id} frame {f} {column}");
                if value > 0.0 {
                    activations.push(Activation { au, side, intensity: Some(Intensity::Fraction(value)) });
                }
            }
            // … and the frame on disk is the still of exactly those intensities.
            let ordered = order_like(&activations, &timeline);
            let expression = Expression::from_activations(ordered, catalog).unwrap();
            let identity = IdentityTable::built_in().get(&video.identity).unwrap();
            let image = render_still(&expression, identity, FrameSettings { width: 64, height: 64, threads: Some(1), ..Default::default() }).unwrap();
            let frame = std::fs::read(set.join(format!("frames/{id}/{f:06}.png"))).unwrap();
            assert_eq!(rgb(&frame).2, image.data, "{id} frame {f} was not rendered with the ground truth's intensities");
        }
        assert_eq!(Some(count), video.frames);
    }
}

/// The CSV orders columns by AU; the renderer sums in the timeline's order.
fn order_like(activations: &[Activation], timeline: &Timeline) -> Vec<Activation> {
    timeline.channels().iter().filter_map(|&(au, side)| activations.iter().find(|a| a.au == au && a.side == side).copied()).collect()
}

fn parse_column(column: &str) -> (AuCode, Laterality) {
    let body = column.strip_prefix("AU").unwrap().strip_suffix("_r").unwrap();
    let (digits, side) = match body.chars().last().unwrap() {
        'L' => (&body[..body.len() - 1], Laterality::Left),
        'R' => (&body[..body.len() - 1], Laterality::Right),
        _ => (body, Laterality::Both),
    };
    (AuCode(digits.parse().unwrap()), side)
}

#[test]
fn stimuli_timeline_export_and_reload_gives_identical_frames() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    facslab_ok(
        d,
        &[
            "render", "1+L12C", "--video", "--onset", "0.1", "--apex", "0.1", "--offset", "0.1", "--ramp", "smoothstep", "--size", "64x64",
            "--identity", "wf2", "-o", "a.mp4", "--export-timeline", "t.json", "--frames", "fa", "--poster", "pa.png",
        ],
    );
    facslab_ok(d, &["render", "--timeline", "t.json", "-o", "b.mp4", "--frames", "fb", "--poster", "pb.png"]);
    let (fa, fb) = (files(&d.join("fa")), files(&d.join("fb")));
    assert_eq!(fa.len(), 9);
    assert_eq!(fa, fb);
    assert_eq!(std::fs::read(d.join("a.mp4")).unwrap(), std::fs::read(d.join("b.mp4")).unwrap());
    assert_eq!(std::fs::read(d.join("pa.png")).unwrap(), fa["000000.png"]);
    let t = Timeline::from_json(&std::fs::read_to_string(d.join("t.json")).unwrap()).unwrap();
    assert_eq!((t.identity.as_str(), t.size, t.fps, t.tracks.len()), ("wf2", [64, 64], 30, 6));
}

#[test]
fn stimuli_a_3_second_clip_decodes_to_90_bt601_frames() {
    let dir = tempfile::tempdir().unwrap();
    facslab_ok(dir.path(), &["render", "12", "--video", "--size", "63x64", "-o", "v.mp4"]);
    let probe = std::process::Command::new("ffprobe")
        .args(["-v", "error", "-count_frames", "-select_streams", "v:0", "-show_entries"])
        .arg("stream=codec_name,width,height,nb_read_frames,r_frame_rate,color_range,color_space,color_transfer,color_primaries")
        .args(["-of", "default=noprint_wrappers=1", "v.mp4"])
        .current_dir(dir.path())
        .output();
    let Ok(probe) = probe else {
        eprintln!("skipped: ffprobe is not installed (apt-get install ffmpeg)");
        return;
    };
    assert!(probe.status.success(), "{}", String::from_utf8_lossy(&probe.stderr));
    let text = String::from_utf8_lossy(&probe.stdout);
    for expected in [
        "codec_name=h264",
        "width=64",
        "height=64",
        "nb_read_frames=90",
        "r_frame_rate=30/1",
        "color_range=tv",
        "color_space=smpte170m",
        "color_transfer=smpte170m",
        "color_primaries=smpte170m",
    ] {
        assert!(text.lines().any(|l| l == expected), "ffprobe lacks {expected}:\n{text}");
    }
}

#[test]
fn stimuli_bad_specs_fail_before_rendering_and_name_the_entry() {
    let dir = tempfile::tempdir().unwrap();
    let good = "name = \"bad\"\nseed = 1\nsize = [32, 32]\n[[group]]\nname = \"fine\"\nexpressions = [\"1\"]\nstills = [1]\n";
    let cases = [
        ("[[group]]\nname = \"combos\"\nexpressions = [\"1+2\", \"4+99\"]\nstills = [1]\n", "group 2 \"combos\", item 2 (\"4+99\")", "AU 99 is not in the catalog"),
        ("[[group]]\nname = \"clips\"\nexpressions = [\"12\"]\nvideo_peaks = [1]\ntiming = { onset_s = 1.0, apex_s = -0.5, offset_s = 1.0 }\n", "group 2 \"clips\"", "negative"),
        ("[[group]]\nname = \"strong\"\nexpressions = [\"12\"]\nvideo_peaks = [1.2]\n", "group 2 \"strong\"", "1.2 is outside [0, 1]"),
        ("[[group]]\nname = \"who\"\nexpressions = [\"12\"]\nstills = [1]\nidentity = \"wm9\"\n", "group 2 \"who\"", "identity \"wm9\" is not known"),
    ];
    for (i, (group, entry, message)) in cases.iter().enumerate() {
        let spec = format!("spec{i}.toml");
        std::fs::write(dir.path().join(&spec), format!("{good}{group}")).unwrap();
        let out_dir = format!("out{i}");
        let output = facslab(dir.path(), &["stimuli", "build", &spec, "-o", &out_dir]);
        assert!(!output.status.success(), "case {i} built");
        let err = stderr(&output);
        assert!(err.contains(entry) && err.contains(message), "case {i}: {err}");
        assert!(!dir.path().join(&out_dir).exists(), "case {i} wrote files before failing");
        let check = facslab(dir.path(), &["stimuli", "check", &spec]);
        assert!(!check.status.success() && stderr(&check).contains(entry));
    }
}

#[test]
fn stimuli_shipped_specs_validate() {
    let dir = tempfile::tempdir().unwrap();
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("stimuli/sets");
    for (name, expected) in [
        ("exp1.toml", "exp1: 196 stimuli (49 videos, 147 images)"),
        ("exp2.toml", "exp2: 108 stimuli (54 videos, 54 images)"),
        ("exp3.toml", "exp3: 40 stimuli (20 videos, 20 images)"),
        ("cpt.toml", "cpt: 7 stimuli (7 videos, 0 images)"),
        ("demo.toml", "demo: 10 stimuli (2 videos, 8 images)"),
        ("laughs.toml", "laughs: 26 stimuli (26 videos, 0 images)"),
    ] {
        let out = facslab_ok(dir.path(), &["stimuli", "check", root.join(name).to_str().unwrap()]);
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(text.starts_with(expected), "{name}: {text}");
    }
}

/// Acceptance: the MP4 plays to the end in headless Chromium (`<video>` fires `ended`, and its
/// duration is the clip's 0.9 s). Real time through WebDriver: virtual time (`--dump-dom`) did not
/// reliably deliver `ended` on a loaded machine.
#[tokio::test(flavor = "multi_thread")]
async fn stimuli_mp4_plays_to_the_end_in_headless_chromium() {
    let Some(browser) = Browser::start().await else { return };
    let dir = tempfile::tempdir().unwrap();
    facslab_ok(dir.path(), &["render", "12", "--video", "--onset", "0.3", "--apex", "0.3", "--offset", "0.3", "--size", "63x64", "-o", "v.mp4"]);
    let page = r#"<!doctype html><html><body><div id="status">loading</div>
<video id="v" src="v.mp4" muted playsinline autoplay></video>
<script>
const v = document.getElementById('v'), s = document.getElementById('status');
v.addEventListener('ended', () => { s.textContent = 'ended duration=' + v.duration; });
v.addEventListener('error', () => { s.textContent = 'error ' + (v.error && v.error.code); });
['loadedmetadata', 'playing', 'timeupdate'].forEach(n => v.addEventListener(n, () => {
  if (!s.textContent.startsWith('ended')) s.textContent = n + ' t=' + v.currentTime; }));
v.play().catch(e => { s.textContent = 'play failed ' + e; });
</script></body></html>"#;
    std::fs::write(dir.path().join("play.html"), page).unwrap();
    // A loaded machine can starve Chromium's media pipeline at the last frame (seen once in
    // CI: currentTime reached 0.9 and `ended` never came); load the page again up to three
    // times, 20 s each, before calling it a failure.
    let url = format!("file://{}", dir.path().join("play.html").display());
    let mut statuses = Vec::new();
    for _ in 0..3 {
        browser.goto(&url).await;
        let deadline = std::time::Instant::now() + std::time::Duration::from_secs(20);
        let mut status = String::new();
        while std::time::Instant::now() < deadline {
            status = browser.text("#status").await;
            if status == "ended duration=0.9" {
                browser.close().await;
                return;
            }
            tokio::time::sleep(std::time::Duration::from_millis(100)).await;
        }
        statuses.push(status);
    }
    browser.close().await;
    panic!("the video did not play to the end; last status of each try: {statuses:?}");
}

/// The AV1 fallback (cargo feature `av1`): decodes to every frame, tagged BT.601 limited range.
#[cfg(feature = "av1")]
#[test]
fn stimuli_av1_fallback_decodes_to_every_frame() {
    let dir = tempfile::tempdir().unwrap();
    facslab_ok(dir.path(), &["render", "12", "--video", "--onset", "0.3", "--apex", "0.3", "--offset", "0.3", "--size", "63x64", "--codec", "av1", "-o", "a.mp4"]);
    let Ok(probe) = std::process::Command::new("ffprobe")
        .args(["-v", "error", "-count_frames", "-show_entries", "stream=codec_name,width,nb_read_frames,color_range,color_space", "-of", "default=nw=1", "a.mp4"])
        .current_dir(dir.path())
        .output()
    else {
        eprintln!("skipped: ffprobe is not installed (apt-get install ffmpeg)");
        return;
    };
    let text = String::from_utf8_lossy(&probe.stdout);
    for expected in ["codec_name=av1", "width=64", "nb_read_frames=27", "color_range=tv", "color_space=smpte170m"] {
        assert!(text.lines().any(|l| l == expected), "ffprobe lacks {expected}:\n{text}");
    }
}

/// A set built as shards on several machines and merged is the set one machine builds, byte for
/// byte: the shipped demo set in two shards.
#[test]
fn stimuli_demo_set_built_in_two_shards_and_merged_equals_the_one_machine_build() {
    let dir = tempfile::tempdir().unwrap();
    let spec = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/stimuli/sets/demo.toml")).unwrap();
    std::fs::write(dir.path().join("demo.toml"), &spec).unwrap();
    facslab_ok(dir.path(), &["stimuli", "key", "-o", "demo.key"]);
    facslab_ok(dir.path(), &["stimuli", "build", "demo.toml", "-o", "whole", "--dither-key", "demo.key"]);
    let one = facslab_ok(dir.path(), &["stimuli", "build", "demo.toml", "-o", "part1", "--shard", "1/2", "--jobs", "1", "--dither-key", "demo.key"]);
    assert!(stderr(&one).contains("demo shard 1/2: 5 stimuli"), "{}", stderr(&one));
    facslab_ok(dir.path(), &["stimuli", "build", "demo.toml", "-o", "part2", "--shard", "2/2", "--dither-key", "demo.key"]);
    let record = std::fs::read_to_string(dir.path().join("part2/shard.json")).unwrap();
    let key = std::fs::read_to_string(dir.path().join("demo.key")).unwrap();
    assert!(!record.contains(key.trim()), "shard.json records the key's fingerprint only:\n{record}");
    // Given in either order.
    facslab_ok(dir.path(), &["stimuli", "merge", "part2", "part1", "-o", "merged"]);
    let (whole, merged) = (files(&dir.path().join("whole")), files(&dir.path().join("merged")));
    assert_eq!(whole.keys().collect::<Vec<_>>(), merged.keys().collect::<Vec<_>>());
    for (name, bytes) in &whole {
        assert!(merged[name] == *bytes, "{name} differs between the merged shards and the one-machine build");
    }
    assert_eq!(whole.len(), 10 + 2 * 3 + 2 + 1, "10 media, 3 side files per video, 2 manifests, the key");
    assert_eq!(merged["dither.key"], key.as_bytes(), "the merged set keeps the shards' key");
}

/// Shards that do not make one set are refused, with the reason, and nothing is merged.
#[test]
fn stimuli_merge_refuses_shards_that_do_not_make_one_set() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("spec.toml"), TINY).unwrap();
    std::fs::write(dir.path().join("other.toml"), TINY.replace("seed = 99", "seed = 100")).unwrap();
    facslab_ok(dir.path(), &["stimuli", "key", "-o", "one.key"]);
    facslab_ok(dir.path(), &["stimuli", "key", "-o", "another.key"]);
    let parts = [("spec.toml", "s1", "1/3", "one.key"), ("spec.toml", "s2", "2/3", "one.key"), ("spec.toml", "s3", "3/3", "one.key"), ("other.toml", "o2", "2/3", "one.key"), ("spec.toml", "k2", "2/3", "another.key")];
    for (spec, out, shard, key) in parts {
        facslab_ok(dir.path(), &["stimuli", "build", spec, "-o", out, "--shard", shard, "--dither-key", key]);
    }
    facslab_ok(dir.path(), &["stimuli", "build", "spec.toml", "-o", "whole"]);
    let refused = |args: &[&str], reason: &str| {
        let out = facslab(dir.path(), args);
        assert!(!out.status.success(), "facslab {args:?} should fail");
        assert!(stderr(&out).contains(reason), "facslab {args:?}: expected {reason:?} in\n{}", stderr(&out));
    };
    refused(&["stimuli", "merge", "s1", "s3", "-o", "m"], "shards missing: 2/3");
    refused(&["stimuli", "merge", "s1", "s2", "s2", "s3", "-o", "m"], "shard 2/3 is given twice");
    refused(&["stimuli", "merge", "s1", "o2", "s3", "-o", "m"], "come from different sets");
    refused(&["stimuli", "merge", "s1", "k2", "s3", "-o", "m"], "the dither key (its fingerprint; build every part with the same --dither-key) differs");
    refused(&["stimuli", "build", "spec.toml", "-o", "x", "--shard", "1/3"], "the parts of one set share one dither key");
    refused(&["stimuli", "key", "-o", "one.key"], "exists already");
    refused(&["stimuli", "merge", "s1", "s2", "whole", "-o", "m"], "not a shard directory");
    refused(&["stimuli", "merge", "s1", "s2", "s3", "-o", "whole"], "not empty");
    refused(&["stimuli", "build", "spec.toml", "-o", "x", "--shard", "4/3"], "`4/3` is not a shard");
    assert!(!dir.path().join("m").join("manifest.json").exists(), "a refused merge writes no manifest");

    // A shard whose key file was swapped for another key is refused.
    std::fs::copy(dir.path().join("another.key"), dir.path().join("s3/dither.key")).unwrap();
    refused(&["stimuli", "merge", "s1", "s2", "s3", "-o", "m"], "is not the key shard.json records");
    std::fs::copy(dir.path().join("one.key"), dir.path().join("s3/dither.key")).unwrap();
    // A damaged file in a shard is found by its sha256.
    let rows: Vec<ManifestRow> = serde_json::from_str(&std::fs::read_to_string(dir.path().join("s2/manifest.json")).unwrap()).unwrap();
    std::fs::write(dir.path().join("s2").join(&rows[0].file), b"damaged").unwrap();
    refused(&["stimuli", "merge", "s1", "s2", "s3", "-o", "m"], "sha256 differs");
    assert!(!dir.path().join("m").join("manifest.json").exists());
}

/// A spec may add people from a file and set the look; a transparent backdrop gives RGBA
/// stills, grayscale grey ones, and a video with a transparent backdrop is refused.
#[test]
fn stimuli_spec_people_from_a_file_and_the_look() {
    let dir = tempfile::tempdir().unwrap();
    facslab_ok(dir.path(), &["identities", "new", "--sex", "F", "--age", "30", "--ancestry", "east-asian", "--seed", "3", "-o", "people.toml"]);
    let spec = "name = \"look\"\nseed = 4\nsize = [48, 48]\nidentities_file = \"people.toml\"\nidentities = [\"eaf3\"]\nbackdrop = \"transparent\"\nlight = \"soft\"\n[[group]]\nname = \"s\"\nexpressions = [\"12\"]\nstills = [1]\n";
    let rows = build(dir.path(), spec, "clear");
    assert_eq!(rows.len(), 1);
    assert_eq!(rows[0].identity, "eaf3");
    assert!(rows[0].engine_version.contains("backdrop-transparent") && rows[0].engine_version.contains("light-soft"));
    let png = std::fs::read(dir.path().join("clear").join(&rows[0].file)).unwrap();
    assert_eq!(png[25], 6, "an RGBA PNG");
    let grey = spec.replace("backdrop = \"transparent\"", "grayscale = true");
    let rows = build(dir.path(), &grey, "grey");
    let (_, _, pixels) = rgb(&std::fs::read(dir.path().join("grey").join(&rows[0].file)).unwrap());
    assert!(pixels.chunks(3).all(|p| p[0] == p[1] && p[1] == p[2]), "grey stills");
    let video = spec.replace("stills = [1]", "video_peaks = [1]");
    std::fs::write(dir.path().join("video.toml"), video).unwrap();
    let output = facslab(dir.path(), &["stimuli", "check", "video.toml"]);
    assert!(!output.status.success() && stderr(&output).contains("transparent"), "{}", stderr(&output));
}

/// A laughs group: each type performed in each style, labelled from the laughs label set, the
/// style named in the manifest; the two styles of one take move the same AUs but look different.
#[test]
fn stimuli_laugh_groups_perform_each_type_in_each_style_and_name_both() {
    let dir = tempfile::tempdir().unwrap();
    let spec = "name = \"l\"\nseed = 4\nsize = [48, 48]\nfps = 10\nidentities = [\"wm1\"]\n[[group]]\nname = \"laughs\"\nlaughs = [\"laughter\", \"false_smile\"]\nstyles = [\"realistic\", \"cartoon\"]\nvideo_peaks = [1]\n";
    let rows = build(dir.path(), spec, "set");
    let seen: Vec<(&str, &str)> = rows.iter().map(|r| (r.emotion.as_str(), r.style.as_str())).collect();
    assert_eq!(seen, [("laughs:laughter", "realistic"), ("laughs:laughter", "cartoon"), ("laughs:false_smile", "realistic"), ("laughs:false_smile", "cartoon")]);
    assert!(rows.iter().all(|r| r.media == facslab::stimuli::Media::Video && r.frames.unwrap_or(0) > 20), "{rows:?}");
    assert!(rows[0].expression.contains("12@") && rows[0].expression.contains("26@"), "laughter opens the jaw: {}", rows[0].expression);
    let csv = std::fs::read_to_string(dir.path().join("set/manifest.csv")).unwrap();
    assert!(csv.lines().next().unwrap().ends_with(",style"), "{csv}");
    let bytes = |r: &ManifestRow| std::fs::read(dir.path().join("set").join(&r.file)).unwrap();
    assert_ne!(bytes(&rows[0]), bytes(&rows[1]), "the cartoon take is drawn differently");
    let timeline = |r: &ManifestRow| std::fs::read(dir.path().join("set/timelines").join(format!("{}.json", r.stimulus_id))).unwrap();
    assert_eq!(timeline(&rows[0]), timeline(&rows[1]), "both styles play the same take");
    assert_ne!(timeline(&rows[0]), timeline(&rows[2]), "each type its own take");
    for (what, bad) in [("not a laugh type", "laughs = [\"giggle\"]"), ("styles", "laughs = \"all\"\nstyles = [\"sketch\"]"), ("performed videos only", "laughs = \"all\"\nstills = [1]"), ("remove aus, expressions, emotions, cpt, labelled", "laughs = \"all\"\nlabelled = [{ label = \"happiness\", expression = \"6+12\" }]")] {
        std::fs::write(dir.path().join("bad.toml"), spec.replace("laughs = [\"laughter\", \"false_smile\"]\nstyles = [\"realistic\", \"cartoon\"]", bad)).unwrap();
        let output = facslab(dir.path(), &["stimuli", "check", "bad.toml"]);
        assert!(!output.status.success() && stderr(&output).contains(what), "{bad}: {}", stderr(&output));
    }
}

/// Stills of two people and a short clip, small enough to render again and again.
const KEYED: &str = r#"
name = "keyed"
seed = 5
size = [48, 48]
fps = 10

[[group]]
name = "stills"
expressions = ["12", "1+2+L12C"]
stills = [1.0, 0.5]
identity = "wf1"

[[group]]
name = "clip"
expressions = ["6+12"]
video_peaks = [1.0]
timing = { onset_s = 0.1, apex_s = 0.1, offset_s = 0.1 }
identity = "bm1"
"#;

fn sha256(bytes: &[u8]) -> String {
    use sha2::Digest;
    hex::encode(sha2::Sha256::digest(bytes))
}

/// What anyone with facslab renders for a manifest row: `facslab render` of its expression and
/// person at its size (a clip: of the set's own timeline, the closest public re-render there is).
pub fn public_render(dir: &Path, set: &Path, row: &ManifestRow, name: &str) -> Vec<u8> {
    if row.media == facslab::stimuli::Media::Video {
        let timeline = set.join(format!("timelines/{}.json", row.stimulus_id));
        let out = format!("{name}.mp4");
        facslab_ok(dir, &["render", "--timeline", timeline.to_str().unwrap(), "-o", &out]);
        return std::fs::read(dir.join(out)).unwrap();
    }
    let (size, out) = (format!("{}x{}", row.width, row.height), format!("{name}.png"));
    facslab_ok(dir, &["render", &row.expression, "--identity", &row.identity, "--size", &size, "-o", &out]);
    std::fs::read(dir.join(out)).unwrap()
}

/// A set's media, posters and key (what dithering touches), relative path → bytes.
fn dithered_files(set: &Path) -> BTreeMap<String, Vec<u8>> {
    files(set).into_iter().filter(|(name, _)| name.starts_with("media/") || name.starts_with("posters/") || name == "dither.key").collect()
}

/// Acceptance: a set's media do not equal a public re-render, differ from the engine's pixels by
/// at most one level per channel, and are reproduced exactly by the same key; `--no-dither`
/// gives the public bytes; the manifest's sha256 is the file's, and the rebuild check never keeps
/// files of another key.
#[test]
fn stimuli_dither_hides_media_from_a_public_re_render_and_the_same_key_reproduces_them() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let keyed = build(d, KEYED, "keyed");
    let plain = build_with(d, KEYED, "plain", &["--no-dither"]);
    assert!(!d.join("plain/dither.key").exists(), "--no-dither writes no key");
    assert_eq!(keyed.len(), 5);
    for (k, p) in keyed.iter().zip(&plain) {
        let (kb, pb) = (std::fs::read(d.join("keyed").join(&k.file)).unwrap(), std::fs::read(d.join("plain").join(&p.file)).unwrap());
        assert_eq!((sha256(&kb), sha256(&pb)), (k.sha256.clone(), p.sha256.clone()), "the manifest's sha256 is the file's true hash");
        assert_eq!((k.dither.len(), p.dither.as_str()), (16, ""));
        let public = public_render(d, &d.join("plain"), p, &format!("public-{}", p.stimulus_id));
        assert!(pb == public, "{} {}: the --no-dither file is the public render", p.expression, p.media);
        assert!(kb != public, "{} {}: the dithered file equals the public render", k.expression, k.media);
    }
    // Stills and posters: at most one level per channel from the engine's pixels, and not zero everywhere.
    let video = keyed.iter().find(|r| r.media == facslab::stimuli::Media::Video).unwrap();
    let mut pictures: Vec<String> = keyed.iter().filter(|r| r.media == facslab::stimuli::Media::Image).map(|r| r.file.clone()).collect();
    pictures.push(format!("posters/{}.png", video.stimulus_id));
    for file in &pictures {
        let (k, p) = (rgb(&std::fs::read(d.join("keyed").join(file)).unwrap()), rgb(&std::fs::read(d.join("plain").join(file)).unwrap()));
        assert_eq!((k.0, k.1), (p.0, p.1));
        let steps: Vec<u8> = k.2.iter().zip(&p.2).map(|(a, b)| a.abs_diff(*b)).collect();
        assert!(steps.iter().all(|&s| s <= 1), "{file}: a channel moved by {}", steps.iter().max().unwrap());
        let moved = steps.iter().filter(|&&s| s == 1).count();
        assert!(moved > steps.len() / 8, "{file}: only {moved} of {} channels moved", steps.len());
    }

    // The same key reproduces the bytes: again into the same directory (nothing to do) and into another one.
    let before = files(&d.join("keyed"));
    let again = facslab_ok(d, &["stimuli", "build", "spec.toml", "-o", "keyed"]);
    assert!(stderr(&again).contains("(0 rendered, 5 up to date"), "{}", stderr(&again));
    assert_eq!(files(&d.join("keyed")), before);
    std::fs::remove_dir_all(d.join("keyed/media")).unwrap();
    let again = facslab_ok(d, &["stimuli", "build", "spec.toml", "-o", "keyed"]);
    assert!(stderr(&again).contains("(5 rendered, 0 up to date"), "{}", stderr(&again));
    assert_eq!(files(&d.join("keyed")), before, "rendered again with the kept key: the same bytes");
    build_with(d, KEYED, "copy", &["--dither-key", "keyed/dither.key"]);
    assert_eq!(files(&d.join("copy")), before);

    // Another key: every picture differs, and the up-to-date check keeps nothing of the old key.
    facslab_ok(d, &["stimuli", "key", "-o", "other.key"]);
    let switched = facslab_ok(d, &["stimuli", "build", "spec.toml", "-o", "copy", "--dither-key", "other.key"]);
    assert!(stderr(&switched).contains("(5 rendered, 0 up to date"), "{}", stderr(&switched));
    let (old, new) = (dithered_files(&d.join("keyed")), dithered_files(&d.join("copy")));
    assert_eq!(old.len(), new.len());
    for (name, bytes) in &old {
        assert!(new[name] != *bytes, "{name} is the same with another key");
    }
    assert_eq!(new["dither.key"], std::fs::read(d.join("other.key")).unwrap());
    let undithered = facslab_ok(d, &["stimuli", "build", "spec.toml", "-o", "copy", "--no-dither"]);
    assert!(stderr(&undithered).contains("(5 rendered, 0 up to date"), "{}", stderr(&undithered));
    assert_eq!(dithered_files(&d.join("copy")).into_iter().filter(|(n, _)| n != "dither.key").collect::<BTreeMap<_, _>>(),
        dithered_files(&d.join("plain")));
}

/// A key file that is not a key is refused before anything is built, naming the file and not quoting it.
#[test]
fn stimuli_a_bad_dither_key_file_is_refused_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("spec.toml"), KEYED).unwrap();
    std::fs::write(dir.path().join("short.key"), "0123456789abcdef\n").unwrap();
    let out = facslab(dir.path(), &["stimuli", "build", "spec.toml", "-o", "set", "--dither-key", "short.key"]);
    assert!(!out.status.success());
    let err = stderr(&out);
    assert!(err.contains("short.key: not a dither key: it has 16 hex digits, a key has 64") && !err.contains("0123456789abcdef"), "{err}");
    assert!(!dir.path().join("set").exists(), "nothing was built");
    let both = facslab(dir.path(), &["stimuli", "build", "spec.toml", "-o", "set", "--dither-key", "short.key", "--no-dither"]);
    assert!(!both.status.success() && stderr(&both).contains("cannot be used with"), "{}", stderr(&both));
}
