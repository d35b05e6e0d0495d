//! facslab studio through the real `facslab studio` process on a loopback port: the render API
//! against `facslab render`, refusals that name the token or field, the live stream, and the
//! editor in headless Chromium.

use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::Duration;

use futures_util::{SinkExt, StreamExt};
use serde_json::{Value, json};
use sha2::{Digest, Sha256};
use tokio_tungstenite::tungstenite::Message;

use crate::browser::{Browser, TIMEOUT};
use crate::cli::facslab_ok;

/// A running `facslab studio`; killed when dropped.
struct Studio {
    child: Child,
    base: String,
}

impl Studio {
    fn start() -> Studio {
        let mut child = Command::new(env!("CARGO_BIN_EXE_facslab"))
            .args(["studio", "--port", "0"])
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .expect("facslab studio starts");
        let mut line = String::new();
        BufReader::new(child.stdout.take().expect("stdout")).read_line(&mut line).expect("a line");
        let base = line.split_whitespace().find(|w| w.starts_with("http://")).expect("the studio prints its address").to_string();
        Studio { child, base }
    }

    fn url(&self, path: &str) -> String {
        format!("{}{}", self.base, path.trim_start_matches('/'))
    }

    async fn post(&self, path: &str, body: &Value) -> reqwest::Response {
        reqwest::Client::new().post(self.url(path)).json(body).send().await.expect("the studio answers")
    }
}

impl Drop for Studio {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn sha(bytes: &[u8]) -> String {
    hex::encode(Sha256::digest(bytes))
}

#[tokio::test(flavor = "multi_thread")]
async fn studio_render_api_gives_the_bytes_facslab_render_writes() {
    let studio = Studio::start();
    let dir = tempfile::tempdir().unwrap();
    facslab_ok(dir.path(), &["render", "1+2+L12C", "--identity", "wf1", "--size", "160x160", "-o", "cli.png"]);
    let response = studio.post("/api/v1/render", &json!({ "expression": "1+2+L12C", "identity": "wf1", "size": "160x160" })).await;
    assert_eq!(response.status(), 200);
    assert_eq!(response.headers()["content-type"], "image/png");
    let api = response.bytes().await.unwrap();
    assert!(api == std::fs::read(dir.path().join("cli.png")).unwrap(), "the API's PNG differs from facslab render's");

    // With a look: the same bytes as the CLI's options.
    facslab_ok(dir.path(), &["render", "12", "--identity", "bm1", "--size", "64x64", "--backdrop", "black", "--light", "dramatic", "--grayscale", "-o", "look.png"]);
    let body = json!({ "expression": "12", "identity": "bm1", "size": "64x64", "backdrop": "black", "light": "dramatic", "grayscale": true });
    let api = studio.post("/api/v1/render", &body).await.bytes().await.unwrap();
    assert!(api == std::fs::read(dir.path().join("look.png")).unwrap(), "the API's PNG with a look differs from facslab render's");

    // The catalog the page is built from has every AU.
    let catalog: Value = reqwest::get(studio.url("/api/v1/catalog")).await.unwrap().json().await.unwrap();
    assert_eq!(catalog["aus"].as_array().unwrap().len(), facslab::facs::Catalog::built_in().len());

    // Refusals name what is wrong.
    let bad = studio.post("/api/v1/render", &json!({ "expression": "1+2+L99+26" })).await;
    assert_eq!(bad.status(), 422);
    let bad: Value = bad.json().await.unwrap();
    assert_eq!((bad["field"].as_str(), bad["token"].as_str(), bad["column"].as_u64()), (Some("expression"), Some("L99"), Some(5)), "{bad}");
    let big = studio.post("/api/v1/render", &json!({ "expression": "12", "size": "5000x5000" })).await;
    assert_eq!(big.status(), 422);
    assert_eq!(big.json::<Value>().await.unwrap()["field"], "size");
    let garbled = reqwest::Client::new().post(studio.url("/api/v1/render")).body("{not json").send().await.unwrap();
    assert_eq!(garbled.status(), 400);
    let huge = studio.post("/api/v1/render", &json!({ "timeline": { "duration_s": 1e12, "tracks": [] } })).await;
    assert_eq!(huge.status(), 422, "a 1e12-second timeline is refused before rendering");
}

#[tokio::test(flavor = "multi_thread")]
async fn studio_timeline_export_and_video_render_match_the_cli() {
    let studio = Studio::start();
    let dir = tempfile::tempdir().unwrap();
    let args = ["render", "6+12", "--video", "--onset", "0.1", "--apex", "0.1", "--offset", "0.1", "--ramp", "cosine"];
    let rest = ["--identity", "bf1", "--size", "64x64", "--export-timeline", "t.json", "-o", "cli.mp4", "--frames", "frames"];
    facslab_ok(dir.path(), &[&args[..], &rest[..]].concat());
    let timing = json!({ "onset_s": 0.1, "apex_s": 0.1, "offset_s": 0.1, "ramp": "cosine" });
    let clip = json!({ "expression": "6+12", "identity": "bf1", "size": "64x64", "timing": timing });
    let timeline = studio.post("/api/v1/timeline", &clip).await.text().await.unwrap();
    assert_eq!(timeline, std::fs::read_to_string(dir.path().join("t.json")).unwrap());

    let timeline: Value = serde_json::from_str(&timeline).unwrap();
    let video = studio.post("/api/v1/render", &json!({ "timeline": timeline })).await;
    assert_eq!(video.headers()["content-type"], "video/mp4");
    assert!(video.bytes().await.unwrap() == std::fs::read(dir.path().join("cli.mp4")).unwrap(), "the API's MP4 differs");
    let frame = studio.post("/api/v1/render", &json!({ "timeline": timeline, "frame": 4 })).await.bytes().await.unwrap();
    assert!(frame == std::fs::read(dir.path().join("frames/000004.png")).unwrap(), "frame 4 differs from the CLI's");
    let past = studio.post("/api/v1/render", &json!({ "timeline": timeline, "frame": 9 })).await;
    assert_eq!(past.json::<Value>().await.unwrap()["field"], "frame");
}

#[tokio::test(flavor = "multi_thread")]
async fn studio_stream_answers_100_updates_in_order_once_each() {
    let studio = Studio::start();
    let ws_url = studio.url("/api/v1/stream").replacen("http://", "ws://", 1);
    let (mut socket, _) = tokio_tungstenite::connect_async(&ws_url).await.expect("a WebSocket");
    let expression = |seq: u64| format!("12@{:.2}+L2@{:.2}", (seq % 10) as f64 / 10.0, (seq % 7) as f64 / 7.0);
    // Sent all at once: the server answers each, in order.
    for seq in 0..100u64 {
        let update = json!({ "seq": seq, "expression": expression(seq), "identity": "wm2", "size": "64x64" });
        socket.send(Message::text(update.to_string())).await.unwrap();
    }
    let bad = json!({ "seq": 100, "expression": "12+12" });
    socket.send(Message::text(bad.to_string())).await.unwrap();
    let mut frames = Vec::new();
    while frames.len() < 101 {
        match tokio::time::timeout(Duration::from_secs(120), socket.next()).await.expect("an answer in time") {
            Some(Ok(Message::Binary(bytes))) => frames.push((u64::from_be_bytes(bytes[..8].try_into().unwrap()), bytes[8..].to_vec())),
            Some(Ok(Message::Text(text))) => {
                let refusal: Value = serde_json::from_str(&text).unwrap();
                assert_eq!(refusal["seq"], 100, "{refusal}");
                assert_eq!(refusal["token"], "12", "{refusal}");
                frames.push((100, Vec::new()));
            }
            Some(Ok(_)) => {}
            other => panic!("the stream ended early: {other:?}"),
        }
    }
    let seqs: Vec<u64> = frames.iter().map(|(seq, _)| *seq).collect();
    assert_eq!(seqs, (0..=100).collect::<Vec<_>>(), "every update answered once, in order");
    for seq in [0u64, 37, 99] {
        let body = json!({ "expression": expression(seq), "identity": "wm2", "size": "64x64" });
        let png = studio.post("/api/v1/render", &body).await.bytes().await.unwrap();
        assert!(frames[seq as usize].1 == png, "frame {seq} of the stream differs from the render API's");
    }
    assert_ne!(frames[1].1, frames[2].1, "different updates give different frames");
}

/// The editor: sliders for every AU, notation and sliders in step, a live preview that follows
/// the newest pose, and an exported clip that `facslab render --timeline` reproduces.
#[tokio::test(flavor = "multi_thread")]
async fn studio_editor_works_in_a_real_browser() {
    let Some(browser) = Browser::start().await else { return };
    let studio = Studio::start();
    browser.goto(&studio.base).await;
    browser.wait_for("document.body.dataset.ready === '1' && document.getElementById('image').dataset.expression === '0'", TIMEOUT).await;
    let sliders = browser.execute("return document.querySelectorAll('.au input[type=range]').length;").await;
    assert_eq!(sliders, json!(facslab::facs::Catalog::built_in().len()));
    let neutral = pixel_sum(&browser).await;

    // A click on a slider's middle moves it to 0.5: the notation follows, and so does the face.
    browser.click("#au-12").await;
    browser.wait_for("document.getElementById('notation').value === '12@0.5'", TIMEOUT).await;
    browser.wait_for("document.getElementById('image').dataset.expression === '12@0.5'", TIMEOUT).await;
    assert_ne!(pixel_sum(&browser).await, neutral, "the picture changed with the slider");

    // Typed notation moves the sliders and the side menus.
    browser.fill("#notation", "1+2+L12C").await;
    browser.wait_for("document.getElementById('image').dataset.expression === '1+2+L12C'", TIMEOUT).await;
    let sliders = browser
        .execute("return ['1', '2', '12', '4'].map(c => document.getElementById('au-' + c).value).concat([document.querySelector('[data-code=\"12\"] .side').value]);")
        .await;
    assert_eq!(sliders, json!(["1", "1", "0.55", "0", "L"]));
    assert!(browser.execute("return location.hash;").await.as_str().unwrap().contains("e=1%2B2%2BL12C"), "the URL keeps the face");

    // A bad token is shown where it is.
    browser.fill("#notation", "1+2+99").await;
    browser.wait_for("!document.getElementById('notation-error').hidden", TIMEOUT).await;
    assert!(browser.text("#notation-error").await.contains("\"99\" at column 5"));

    // Undo brings the last committed face back.
    browser.fill("#notation", "4+7").await;
    browser.execute("document.getElementById('notation').dispatchEvent(new Event('change')); document.getElementById('notation').blur(); return true;").await;
    browser.click("#undo").await;
    browser.wait_for("document.getElementById('notation').value !== '4+7'", TIMEOUT).await;

    // The exported clip: the timeline JSON re-renders through the CLI to the bytes the page's MP4 has.
    browser.fill("#notation", "6+12").await;
    browser.execute("const s = document.getElementById('size'); s.value = '242x240'; s.dispatchEvent(new Event('change'));
                     for (const id of ['onset', 'apex', 'offset']) document.getElementById(id).value = '0.2'; return true;").await;
    browser.click("#make-clip").await;
    browser.wait_for("!document.getElementById('clip').hidden", TIMEOUT).await;
    let timeline = browser.execute("return fetch(document.getElementById('download-timeline').href).then(r => r.text());").await;
    browser.click("#make-mp4").await;
    browser.wait_for("!document.getElementById('download-mp4').hidden", Duration::from_secs(180)).await;
    let page_sha = browser
        .execute("return fetch(document.getElementById('download-mp4').href).then(r => r.arrayBuffer()).then(b => crypto.subtle.digest('SHA-256', b))
                  .then(d => [...new Uint8Array(d)].map(x => x.toString(16).padStart(2, '0')).join(''));")
        .await;
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("t.json"), timeline.as_str().unwrap()).unwrap();
    facslab_ok(dir.path(), &["render", "--timeline", "t.json", "-o", "cli.mp4"]);
    assert_eq!(page_sha, json!(sha(&std::fs::read(dir.path().join("cli.mp4")).unwrap())), "the page's MP4 = facslab render --timeline");

    screenshots(&browser, &studio).await;
    browser.close().await;
}

/// The timeline editor: a two-AU clip laid out one after the other, a handle dragged and a time
/// typed, scrubbed and played with frames from the server; the exported JSON re-renders through
/// `facslab render --timeline` to the page's frame and MP4; a bad value is named by track and
/// field; the URL keeps the tracks; a CPT sequence loads as `Timeline::sequence` builds it.
#[tokio::test(flavor = "multi_thread")]
async fn studio_timeline_editor_builds_scrubs_plays_and_exports_a_sequential_clip() {
    let Some(browser) = Browser::start().await else { return };
    let studio = Studio::start();
    browser.goto(&format!("{}#e=1%2B12C&p=wf1&s=242x240", studio.base)).await;
    browser.wait_for("document.body.dataset.ready === '1' && document.getElementById('image').dataset.expression === '1+12C'", TIMEOUT).await;
    browser.execute("for (const id of ['onset', 'apex', 'offset']) document.getElementById(id).value = '0.2'; return true;").await;
    browser.click("#make-clip").await;
    browser.wait_for("document.querySelectorAll('#tracks .track').length === 2", TIMEOUT).await;
    browser.click("#sequential").await;
    let starts = browser.execute("return [...document.querySelectorAll('.track input.time[data-handle=\"0\"]')].map(i => i.value);").await;
    assert_eq!(starts, json!(["0", "0.6"]), "one after the other");

    // Type a time (AU 12's apex ends at 1.1 s) and drag a handle (AU 1's offset ends 0.1 s sooner).
    browser.fill(".track[data-row=\"1\"] input.time[data-handle=\"2\"]", "1.1").await;
    let dx = browser.execute("const lane = document.querySelector('.track[data-row=\"0\"] svg.lane'); return -(0.1 / 2) * (lane.clientWidth - 20);").await;
    browser.drag(".track[data-row=\"0\"] .handle[data-handle=\"3\"]", dx.as_f64().unwrap(), 0.0).await;
    browser.wait_for("document.querySelector('.track[data-row=\"0\"] input.time[data-handle=\"3\"]').value === '0.5'", TIMEOUT).await;
    let timeline = browser.execute("return fetch(document.getElementById('download-timeline').href).then(r => r.text());").await;
    let timeline = timeline.as_str().unwrap().to_string();
    let parsed = facslab::engine::timeline::Timeline::from_json(&timeline).unwrap();
    let spans: Vec<(u16, f64, f64, f64, f64)> = parsed.tracks.iter().map(|t| (t.au.0, t.start_intensity, t.end_intensity, t.start_s, t.end_s)).collect();
    assert_eq!(spans, [
        (1, 0.0, 1.0, 0.0, 0.2), (1, 1.0, 1.0, 0.2, 0.4), (1, 1.0, 0.0, 0.4, 0.5),
        (12, 0.0, 0.55, 0.6, 0.8), (12, 0.55, 0.55, 0.8, 1.1), (12, 0.55, 0.0, 1.1, 1.2),
    ]);
    assert_eq!((parsed.fps, parsed.duration_s, parsed.identity.as_str(), parsed.size, parsed.frame_count()), (30, 1.2, "wf1", [242, 240], 36));

    // Scrub: frame 0 is neutral, frame 27 (0.9 s) has AU 12 at its apex; the page's frame is the
    // CLI's frame of the exported JSON.
    let scrub_to = |frame: usize| format!("const s = document.getElementById('scrub'); s.value = '{frame}'; s.dispatchEvent(new Event('input')); return true;");
    browser.execute(&scrub_to(0)).await;
    browser.wait_for("document.getElementById('image').dataset.frame === '0' && document.getElementById('image').complete", TIMEOUT).await;
    let first = pixel_sum(&browser).await;
    browser.execute(&scrub_to(27)).await;
    browser.wait_for("document.getElementById('image').dataset.frame === '27' && document.getElementById('image').complete", TIMEOUT).await;
    assert_ne!(pixel_sum(&browser).await, first, "the picture changed with the scrub");
    let frame_sha = browser.execute(&format!("return {SHA_OF}(document.getElementById('image').src);")).await;
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("t.json"), &timeline).unwrap();
    facslab_ok(dir.path(), &["render", "--timeline", "t.json", "-o", "cli.mp4", "--frames", "frames"]);
    assert_eq!(frame_sha, json!(sha(&std::fs::read(dir.path().join("frames/000027.png")).unwrap())), "the page's frame 27 = the CLI's");
    browser.click("#make-mp4").await;
    browser.wait_for("!document.getElementById('download-mp4').hidden", Duration::from_secs(180)).await;
    let mp4_sha = browser.execute(&format!("return {SHA_OF}(document.getElementById('download-mp4').href);")).await;
    assert_eq!(mp4_sha, json!(sha(&std::fs::read(dir.path().join("cli.mp4")).unwrap())), "the page's MP4 = facslab render --timeline");

    // A bad peak: the server's refusal names the track and field, and the page marks them.
    browser.fill(".track[data-row=\"1\"] input.peak", "1.5").await;
    browser.wait_for("!document.getElementById('timeline-error').hidden", TIMEOUT).await;
    let error = browser.text("#timeline-error").await;
    assert!(error.starts_with("Track 2 (AU12), peak: end intensity 1.5 is outside [0, 1]"), "{error}");
    let marked = browser.execute("return document.querySelector('.track[data-row=\"1\"] input.peak').classList.contains('invalid');").await;
    assert_eq!(marked, json!(true));
    browser.fill(".track[data-row=\"1\"] input.peak", "0.55").await;
    browser.wait_for("document.getElementById('timeline-error').hidden", TIMEOUT).await;

    // Play from the start: frames one after another up to the last, then it stops.
    browser.execute(&scrub_to(0)).await;
    browser.click("#play").await;
    browser.wait_for("document.getElementById('image').dataset.frame === '35' && document.getElementById('play').textContent === 'Play'", TIMEOUT).await;
    eprintln!("play: {}", browser.text("#status").await);

    // The URL keeps the tracks: opening it again gives the same timeline.
    let hash = browser.execute("return location.hash;").await;
    assert!(hash.as_str().unwrap().contains("tl="), "{hash}");
    browser.goto("about:blank").await;
    browser.goto(&format!("{}{}", studio.base, hash.as_str().unwrap())).await;
    browser.wait_for("document.body.dataset.ready === '1' && document.querySelectorAll('#tracks .track').length === 2", TIMEOUT).await;
    let again = browser.execute("return fetch(document.getElementById('download-timeline').href).then(r => r.text());").await;
    assert_eq!(again.as_str().unwrap(), timeline, "the link reproduces the timeline");

    // A CPT sequence loads as the set builder's `Timeline::sequence` (HapFACS timing after the reload).
    browser.execute("const c = document.getElementById('cpt'); c.value = 'novelty'; c.dispatchEvent(new Event('change')); return true;").await;
    browser.wait_for("document.querySelectorAll('#tracks .track').length === 7", TIMEOUT).await;
    let novelty = browser.execute("return fetch(document.getElementById('download-timeline').href).then(r => r.text());").await;
    let steps: Vec<_> = ["1+2+5", "4+7+26+38"].iter().map(|s| facslab::facs::Catalog::built_in().parse(s).unwrap()).collect();
    let expected = facslab::engine::timeline::Timeline::sequence(&steps, Default::default(), 30, "wf1", (242, 240));
    assert_eq!(facslab::engine::timeline::Timeline::from_json(novelty.as_str().unwrap()).unwrap(), expected);

    timeline_screenshots(&browser, &scrub_to(135)).await;
    browser.close().await;
}

/// Undo and redo over timeline edits (a drag is one step, a number edit one, a layout switch
/// one), then importing timeline JSON: a file with one bad field is refused naming its track and
/// field, a good file shows its tracks and renders a frame, an exported timeline pasted back
/// gives the same editor state and the same export, and a valid timeline the editor cannot
/// show is refused with the reason.
#[tokio::test(flavor = "multi_thread")]
async fn studio_timeline_edits_undo_and_redo_and_timelines_import() {
    let Some(browser) = Browser::start().await else { return };
    let studio = Studio::start();
    browser.goto(&format!("{}#e=1%2B12C&p=wf1&s=242x240", studio.base)).await;
    browser.wait_for("document.body.dataset.ready === '1' && document.getElementById('image').dataset.expression === '1+12C'", TIMEOUT).await;
    let steps = async || browser.execute("return [state.history.length, timelineParam()];").await;
    browser.execute("for (const id of ['onset', 'apex', 'offset']) document.getElementById(id).value = '0.2'; return true;").await;
    let start = steps().await;
    browser.click("#make-clip").await;
    browser.wait_for("document.querySelectorAll('#tracks .track').length === 2", TIMEOUT).await;
    let made = steps().await;
    browser.click("#sequential").await;
    let sequential = steps().await;
    browser.execute("const f = document.querySelector('.track[data-row=\"1\"] input.time[data-handle=\"2\"]'); f.value = '1.1';
                     f.dispatchEvent(new Event('input', { bubbles: true })); f.dispatchEvent(new Event('change', { bubbles: true })); return true;").await;
    let typed = steps().await;
    let dx = browser.execute("const lane = document.querySelector('.track[data-row=\"0\"] svg.lane'); return -(0.1 / 2) * (lane.clientWidth - 20);").await;
    browser.drag(".track[data-row=\"0\"] .handle[data-handle=\"3\"]", dx.as_f64().unwrap(), 0.0).await;
    browser.wait_for("document.querySelector('.track[data-row=\"0\"] input.time[data-handle=\"3\"]').value === '0.5'", TIMEOUT).await;
    let dragged = steps().await;
    let count = |v: &Value| v[0].as_u64().unwrap();
    assert_eq!([&made, &sequential, &typed, &dragged].map(count), [1, 2, 3, 4].map(|k| count(&start) + k), "one step per edit, the drag's moves included");
    for (button, expected) in [("#undo", &typed), ("#undo", &sequential), ("#undo", &made), ("#redo", &sequential), ("#redo", &typed), ("#redo", &dragged)] {
        browser.click(button).await;
        assert_eq!(steps().await[1], expected[1], "after {button}");
    }
    let edited = browser.execute("return [...document.querySelectorAll('.track input.time')].map(i => i.value);").await;
    assert_eq!(edited, json!(["0", "0.2", "0.4", "0.5", "0.6", "0.8", "1.1", "1.2"]), "redo shows the edited times");
    let export = "return fetch(document.getElementById('download-timeline').href).then(r => r.text());";
    let exported = browser.execute(export).await.as_str().unwrap().to_string();

    // A file with one bad field: refused, naming the track and the field; the editor is untouched.
    let dir = tempfile::tempdir().unwrap();
    let mut bad: Value = serde_json::from_str(&exported).unwrap();
    bad["tracks"][4]["end_intensity"] = json!(1.5);
    std::fs::write(dir.path().join("bad.json"), bad.to_string()).unwrap();
    browser.upload("#import-file", &dir.path().join("bad.json")).await;
    browser.wait_for("!document.getElementById('import-result').hidden", TIMEOUT).await;
    let refusal = browser.text("#import-result").await;
    assert!(refusal.starts_with("bad.json refused: track 5, field end_intensity: end intensity 1.5 is outside [0, 1]"), "{refusal}");
    assert_eq!(steps().await, dragged, "a refused import changes nothing");

    // A good file: a CPT sequence as the set builder makes it, at 24 fps; its tracks are shown and a frame renders.
    let sequence: Vec<_> = ["1+2+5", "4+7+26+38"].iter().map(|s| facslab::facs::Catalog::built_in().parse(s).unwrap()).collect();
    let good = facslab::engine::timeline::Timeline::sequence(&sequence, Default::default(), 24, "bm1", (485, 480));
    std::fs::write(dir.path().join("novelty.json"), good.to_json()).unwrap();
    browser.upload("#import-file", &dir.path().join("novelty.json")).await;
    browser.wait_for("document.querySelectorAll('#tracks .track').length === 7 && document.getElementById('image').dataset.frame !== undefined && document.getElementById('image').complete", TIMEOUT).await;
    assert!(browser.text("#import-result").await.starts_with("Imported novelty.json: 7 tracks, 6 s at 24 fps, bm1, 485x480."));
    let reexported = browser.execute(export).await;
    assert_eq!(facslab::engine::timeline::Timeline::from_json(reexported.as_str().unwrap()).unwrap(), good, "the imported file is what the editor exports");
    assert_eq!(pixel_sum_is_a_face(&browser).await, json!(true), "the frame rendered");
    import_screenshot(&browser).await;

    // The import is one step; the timeline exported before, pasted back, gives the same editor and the same export.
    browser.click("#undo").await;
    assert_eq!(steps().await[1], dragged[1], "undo takes the import back");
    browser.execute("document.querySelector('.tl-import details').open = true; return true;").await;
    browser.execute(&format!("document.getElementById('import-text').value = {}; return true;", serde_json::to_string(&good.to_json()).unwrap())).await;
    browser.click("#import-paste").await;
    browser.wait_for("document.querySelectorAll('#tracks .track').length === 7", TIMEOUT).await;
    browser.execute(&format!("document.getElementById('import-text').value = {}; return true;", serde_json::to_string(&exported).unwrap())).await;
    browser.click("#import-paste").await;
    browser.wait_for("document.querySelectorAll('#tracks .track').length === 2", TIMEOUT).await;
    assert_eq!(steps().await[1], dragged[1], "the re-imported export is the same editor state");
    assert_eq!(browser.execute(export).await.as_str().unwrap(), exported, "and exports the same bytes");

    // A valid timeline that is not onset/apex/offset triples: refused with the reason.
    let ramp = json!({ "duration_s": 1, "tracks": [{ "au": 12, "start_intensity": 0, "end_intensity": 1, "start_s": 0, "end_s": 1 }] });
    browser.execute(&format!("document.getElementById('import-text').value = {}; return true;", serde_json::to_string(&ramp.to_string()).unwrap())).await;
    browser.click("#import-paste").await;
    browser.wait_for("document.getElementById('import-result').textContent.includes('cannot be edited here')", TIMEOUT).await;
    assert!(browser.text("#import-result").await.contains("timeline tracks 1–1 (AU12) are not one editor track"));
    assert_eq!(steps().await[1], dragged[1]);
    browser.close().await;
}

/// Whether the preview holds a picture with more than one colour (a rendered face, not a blank).
async fn pixel_sum_is_a_face(browser: &Browser) -> Value {
    browser
        .execute("const img = document.getElementById('image'); const c = document.createElement('canvas');
                  c.width = img.naturalWidth; c.height = img.naturalHeight; const g = c.getContext('2d'); g.drawImage(img, 0, 0);
                  const d = g.getImageData(0, 0, c.width, c.height).data; return d.some((v, i) => v !== d[i % 4]);")
        .await
}

/// The studio just after a timeline import, at desktop size, scrolled to the timeline.
async fn import_screenshot(browser: &Browser) {
    let temp = tempfile::tempdir().unwrap();
    let dir = std::env::var_os("FACSLAB_SCREENSHOTS").map(PathBuf::from).unwrap_or_else(|| temp.path().to_path_buf());
    browser.set_window_size(1280, 900).await;
    browser.execute("document.activeElement.blur(); const top = document.querySelector('.tl-tools').getBoundingClientRect().top + scrollY;
                     window.scrollTo(0, top - document.querySelector('.views').offsetHeight - 8); return true;").await;
    tokio::time::sleep(Duration::from_millis(300)).await;
    browser.screenshot(dir.join("studio-import-desktop.png")).await;
}

/// A JavaScript function of a URL giving the SHA-256 (hex) of what it holds.
const SHA_OF: &str = "((url) => fetch(url).then(r => r.arrayBuffer()).then(b => crypto.subtle.digest('SHA-256', b)).then(d => [...new Uint8Array(d)].map(x => x.toString(16).padStart(2, '0')).join('')))";

/// The timeline editor with a CPT sequence loaded, at desktop and phone size.
async fn timeline_screenshots(browser: &Browser, scrub: &str) {
    let temp = tempfile::tempdir().unwrap();
    let dir = std::env::var_os("FACSLAB_SCREENSHOTS").map(PathBuf::from).unwrap_or_else(|| temp.path().to_path_buf());
    browser.execute("const s = document.getElementById('size'); s.value = '485x480'; s.dispatchEvent(new Event('change')); return true;").await;
    browser.wait_for("document.getElementById('image').naturalWidth === 485 && document.getElementById('image').dataset.frame === undefined", TIMEOUT).await;
    browser.execute(scrub).await;
    browser.wait_for("document.getElementById('image').dataset.frame === '135' && document.getElementById('image').naturalWidth === 485", TIMEOUT).await;
    for (size, width, height) in [("desktop", 1280, 900), ("phone", 390, 844)] {
        browser.set_window_size(width, height).await;
        let below_the_face = "document.activeElement.blur(); const top = document.querySelector('.tl-tools').getBoundingClientRect().top + scrollY;
                              window.scrollTo(0, top - document.querySelector('.views').offsetHeight - 8); return true;";
        browser.execute(below_the_face).await;
        tokio::time::sleep(Duration::from_millis(300)).await;
        let overflow = browser.execute("return document.documentElement.scrollWidth - document.documentElement.clientWidth;").await;
        assert!(overflow.as_i64().unwrap() <= 0, "the timeline editor scrolls sideways at {size} size");
        browser.screenshot(dir.join(format!("studio-timeline-{size}.png"))).await;
    }
}

/// The sum of the preview's pixels (changes when the face does).
async fn pixel_sum(browser: &Browser) -> Value {
    browser
        .execute("const img = document.getElementById('image'); const c = document.createElement('canvas');
                  c.width = img.naturalWidth; c.height = img.naturalHeight; const g = c.getContext('2d'); g.drawImage(img, 0, 0);
                  return g.getImageData(0, 0, c.width, c.height).data.reduce((a, b) => a + b, 0);")
        .await
}

/// The studio with a prototype loaded, at desktop and phone size (`FACSLAB_SCREENSHOTS=DIR`
/// keeps them; `docs/screenshots/` has the committed ones).
async fn screenshots(browser: &Browser, studio: &Studio) {
    let temp = tempfile::tempdir().unwrap();
    let dir = std::env::var_os("FACSLAB_SCREENSHOTS").map(PathBuf::from).unwrap_or_else(|| temp.path().to_path_buf());
    browser.goto(&format!("{}#e=6%2B12%2B25&p=wf1&s=485x480&n=1", studio.base)).await;
    browser.wait_for("document.getElementById('image').dataset.expression === '6+12+25' && document.getElementById('caption-compare').textContent === 'wf1: 0' && document.getElementById('image-compare').complete", TIMEOUT).await;
    for (size, width, height) in [("desktop", 1280, 900), ("phone", 390, 844)] {
        browser.set_window_size(width, height).await;
        browser.execute("document.activeElement.blur(); window.scrollTo(0, 0); document.querySelector('.controls').scrollTop = 0; return true;").await;
        tokio::time::sleep(Duration::from_millis(300)).await;
        let overflow = browser.execute("return document.documentElement.scrollWidth - document.documentElement.clientWidth;").await;
        assert!(overflow.as_i64().unwrap() <= 0, "the studio scrolls sideways at {size} size");
        browser.screenshot(dir.join(format!("studio-{size}.png"))).await;
    }
}

/// Runs `program args…` in `dir`, or returns `None` (printing `skipped: …`) when the program or
/// the module it needs is missing and `FACSLAB_REQUIRE_TOOLS` is not `1`.
fn run_example(dir: &std::path::Path, program: &str, probe: &[&str], args: &[&str]) -> Option<std::process::Output> {
    let available = Command::new(program).args(probe).output().is_ok_and(|o| o.status.success());
    if !available {
        let message = format!("{program} {} failed (python3 -m pip install websockets; Node.js 20.10 or later)", probe.join(" "));
        assert!(std::env::var("FACSLAB_REQUIRE_TOOLS").as_deref() != Ok("1"), "FACSLAB_REQUIRE_TOOLS=1, but {message}");
        eprintln!("skipped: {message}");
        return None;
    }
    Some(Command::new(program).args(args).current_dir(dir).output().expect("the example runs"))
}

/// The client examples in docs/examples/ run against a real studio and get what they ask for.
#[tokio::test(flavor = "multi_thread")]
async fn studio_client_examples_run() {
    let studio = Studio::start();
    let dir = tempfile::tempdir().unwrap();
    let examples = concat!(env!("CARGO_MANIFEST_DIR"), "/docs/examples");
    let python = format!("{examples}/studio_client.py");
    let node = format!("{examples}/studio_client.mjs");
    let runs = [
        ("python3", vec!["-c", "import websockets.sync.client"], vec![python.as_str(), studio.base.as_str(), "py"], ("6+12", "wf1")),
        ("node", vec!["--experimental-websocket", "-e", "if (typeof WebSocket !== 'function') process.exit(1)"], vec!["--experimental-websocket", node.as_str(), studio.base.as_str(), "js"], ("1+2+5B+26", "bm1")),
    ];
    for (program, probe, args, (expression, person)) in runs {
        let Some(output) = run_example(dir.path(), program, &probe, &args) else { continue };
        assert!(output.status.success(), "{program} example failed:\n{}{}", String::from_utf8_lossy(&output.stdout), String::from_utf8_lossy(&output.stderr));
        let out = dir.path().join(args.last().unwrap());
        let frames = std::fs::read_dir(&out).unwrap().filter(|e| e.as_ref().unwrap().file_name().to_string_lossy().starts_with("stream-")).count();
        assert_eq!(frames, 11, "{program}: one frame per update");
        facslab_ok(dir.path(), &["render", expression, "--identity", person, "-o", "cli.png"]);
        assert!(std::fs::read(out.join("still.png")).unwrap() == std::fs::read(dir.path().join("cli.png")).unwrap(), "{program}: still differs");
    }
}

#[tokio::test(flavor = "multi_thread")]
async fn studio_in_the_study_server_is_behind_the_admin_login() {
    let (_lab, server, http) = crate::server::emotion_lab("emo", "");
    // Anonymous: the page sends to the login, the API refuses.
    let page = http.get(server.url("/admin/studio/")).send().await.unwrap();
    assert_eq!((page.status().as_u16(), crate::server::location(&page)), (303, "/admin/login".to_string()));
    let body = json!({ "expression": "1+2+L12C", "identity": "wf1", "size": "96x96" });
    let anonymous = http.post(server.url("/admin/studio/api/v1/render")).json(&body).send().await.unwrap();
    assert_eq!(anonymous.status(), 401);
    // Logged in: the admin pages link to it; the page, its script and the render API, with the
    // bytes `facslab render` writes.
    let cookie = crate::server::admin_cookie(&http, &server).await;
    let dashboard = http.get(server.url("/admin")).header("cookie", &cookie).send().await.unwrap().text().await.unwrap();
    assert!(dashboard.contains("href=\"/admin/studio/\""), "{dashboard}");
    let page = http.get(server.url("/admin/studio/")).header("cookie", &cookie).send().await.unwrap();
    assert_eq!(page.status(), 200);
    let csp = page.headers()["content-security-policy"].to_str().unwrap().to_string();
    assert!(csp.contains("blob:"), "the studio's own policy (previews are blob: URLs): {csp}");
    assert!(page.text().await.unwrap().contains("studio.js"));
    let script = http.get(server.url("/admin/studio/studio.js")).header("cookie", &cookie).send().await.unwrap();
    assert_eq!(script.status(), 200);
    let png = http.post(server.url("/admin/studio/api/v1/render")).header("cookie", &cookie).json(&body).send().await.unwrap();
    assert_eq!(png.status(), 200);
    let dir = tempfile::tempdir().unwrap();
    facslab_ok(dir.path(), &["render", "1+2+L12C", "--identity", "wf1", "--size", "96x96", "-o", "cli.png"]);
    assert!(png.bytes().await.unwrap() == std::fs::read(dir.path().join("cli.png")).unwrap(), "the mounted studio's PNG differs from facslab render's");
}
