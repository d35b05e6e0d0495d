//! End to end in a real browser (headless Chromium through WebDriver, see `browser.rs`): a
//! participant goes through a whole study by clicking, as a person would, against the real
//! `facslab serve`; then an admin logs in, sees the participant and exports exactly what was
//! clicked. Also: a reload mid-session, and screenshots of every page at desktop and phone size.
//!
//! Each test skips (returns early) when Chromium or chromedriver is missing, unless
//! `FACSLAB_REQUIRE_BROWSER=1`.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::time::Duration;

use serde_json::Value;

use crate::browser::{Browser, TIMEOUT};
use crate::server::*;

/// A JavaScript string literal.
pub(crate) fn js_str(text: &str) -> String {
    serde_json::to_string(text).unwrap()
}

/// Waits until the browser shows a loaded page whose path ends with `suffix`.
pub(crate) async fn wait_for_page(browser: &Browser, suffix: &str) {
    let js = format!("document.readyState === 'complete' && location.pathname.endsWith({})", js_str(suffix));
    browser.wait_for(&js, TIMEOUT).await;
}

/// The path of the page the browser shows.
pub(crate) async fn path(browser: &Browser) -> String {
    browser.execute("return location.pathname;").await.as_str().unwrap_or_default().to_string()
}

/// The participant's token, from the address of a `/p/{token}/...` page.
async fn token(browser: &Browser) -> String {
    let path = path(browser).await;
    let token = path.split('/').nth(2).unwrap_or_default().to_string();
    assert_eq!(token.len(), 32, "not a participant page: {path}");
    token
}

/// Clicks the label that holds the input `input` (as a participant taps the whole choice).
pub(crate) async fn tap(browser: &Browser, input: &str) {
    browser.click(&format!("label:has(> {input})")).await;
    let checked = browser.execute(&format!("return document.querySelector({}).checked;", js_str(input))).await;
    assert_eq!(checked, true, "tapping the label of {input} did not check it");
}

/// Chooses `value` in the select `css`.
async fn choose(browser: &Browser, css: &str, value: &str) {
    browser.find(css).await.select_by_value(value).await.unwrap_or_else(|e| panic!("choose {value} in {css}: {e}"));
}

/// From the landing page of `slug` to the first trial: start, consent, demographics (when the
/// study asks), instructions. Returns the participant's token.
pub(crate) async fn start_session(browser: &Browser, server: &Server, slug: &str, demographics: bool) -> String {
    browser.goto(&server.url(&format!("/s/{slug}"))).await;
    browser.click("#start").await;
    wait_for_page(browser, "/consent").await;
    let token = token(browser).await;
    browser.click("#agree").await;
    browser.click("#consent").await;
    if demographics {
        wait_for_page(browser, "/demographics").await;
        browser.fill("#age", "29").await;
        choose(browser, "#gender", "female").await;
        choose(browser, "#ethnicity", "mixed").await;
        choose(browser, "#education", "doctorate").await;
        browser.click("#demographics").await;
    }
    wait_for_page(browser, "/instructions").await;
    browser.click("#begin").await;
    wait_for_page(browser, "/trial").await;
    token
}

/// What a trial page shows, as read from the page.
#[derive(Debug, Clone)]
pub(crate) struct TrialView {
    pub(crate) position: i64,
    pub(crate) media: String,
    practice: bool,
    attention: Option<String>,
    progress: String,
    key: String,
}

pub(crate) async fn trial_view(browser: &Browser) -> TrialView {
    let v = browser
        .execute(
            "const f = document.getElementById('trial');
             const a = document.querySelector('.attention');
             return { api: f.dataset.api, media: f.dataset.media, key: f.elements.idempotency_key.value,
                      practice: document.querySelector('.badge') !== null,
                      attention: a ? a.textContent : null,
                      progress: document.querySelector('.bar .progress').textContent };",
        )
        .await;
    let api = v["api"].as_str().unwrap();
    TrialView {
        position: api.rsplit('/').next().unwrap().parse().unwrap(),
        media: v["media"].as_str().unwrap().to_string(),
        practice: v["practice"] == true,
        attention: v["attention"].as_str().map(str::to_string),
        progress: v["progress"].as_str().unwrap().trim().to_string(),
        key: v["key"].as_str().unwrap().to_string(),
    }
}

/// Clicks Next and waits for the next page: another trial view or the done page. Fails at once
/// with the page's message when the answer is refused.
pub(crate) async fn submit(browser: &Browser, view: &TrialView) {
    browser.click("#next").await;
    let js = format!(
        "const f = document.getElementById('trial'); const e = document.querySelector('.error');
         if (document.readyState !== 'complete') return null;
         if (location.pathname.endsWith('/done') || (f !== null && f.elements.idempotency_key.value !== {})) return 'next';
         return e ? 'refused: ' + e.textContent : null;",
        js_str(&view.key)
    );
    let outcome = browser
        .wait_until(TIMEOUT, async |b| match b.client().execute(&js, Vec::new()).await {
            Ok(Value::String(s)) => Ok(s),
            other => Err(format!("trial {} still on screen: {other:?}", view.position)),
        })
        .await;
    assert_eq!(outcome, "next", "trial {}", view.position);
}

/// A video trial: waits until the video has played to its end, as a patient participant does.
pub(crate) async fn watch_to_the_end(browser: &Browser) {
    browser.wait_for("document.getElementById('stimulus').ended", TIMEOUT).await;
}

/// The emotion a participant picks at `position` (spread over the choices), and the
/// believability rating.
fn emotion_answer(choices: &[String], position: i64) -> (String, String) {
    (choices[position as usize % choices.len()].clone(), ((position % 5) + 1).to_string())
}

/// Answers the emotion trial on screen by clicking; returns the view and the (emotion,
/// believability) clicked. Attention checks are answered as they ask.
async fn answer_emotion_trial(browser: &Browser) -> (TrialView, (String, String)) {
    let view = trial_view(browser).await;
    let choices: Vec<String> = serde_json::from_value(browser.execute("return [...document.querySelectorAll('input[name=emotion]')].map(i => i.value);").await).unwrap();
    let (mut emotion, believability) = emotion_answer(&choices, view.position);
    if let Some(instruction) = &view.attention {
        assert!(instruction.contains("\"Fear\""), "{instruction}");
        emotion = "fear".into();
    }
    if view.media == "video" {
        watch_to_the_end(browser).await;
    }
    tap(browser, &format!("input[name=emotion][value={}]", js_str(&emotion))).await;
    tap(browser, &format!("input[name=believability][value=\"{believability}\"]")).await;
    submit(browser, &view).await;
    (view, (emotion, believability))
}

/// Logs in as the lab's admin in the browser.
async fn admin_login(browser: &Browser, server: &Server) {
    browser.goto(&server.url("/admin/login")).await;
    browser.fill("#username", "alice").await;
    browser.fill("#password", ADMIN_PASSWORD).await;
    browser.click("#login").await;
    wait_for_page(browser, "/admin").await;
}

/// Fetches `url` from inside the page (with the page's cookies) and returns the body.
async fn fetch_text(browser: &Browser, url: &str) -> String {
    let js = format!("return fetch({}, {{ credentials: 'same-origin' }}).then(r => r.ok ? r.text() : 'HTTP ' + r.status);", js_str(url));
    let text = browser.execute(&js).await.as_str().unwrap_or_default().to_string();
    assert!(!text.starts_with("HTTP "), "{url}: {text}");
    text
}

/// The long CSV's trial rows as (stimulus_id, trial, measure, value, rt_ms).
fn long_rows(csv: &str) -> Vec<(String, i64, String, String, String)> {
    let mut lines = csv.lines();
    assert_eq!(lines.next(), Some("participant_id,group,stimulus_id,trial,measure,value,rt_ms"));
    lines
        .map(|l| l.split(',').map(str::to_string).collect::<Vec<_>>())
        .filter(|c| !c[2].is_empty())
        .map(|c| {
            assert_eq!(c.len(), 7, "{c:?}");
            (c[2].clone(), c[3].parse().unwrap(), c[4].clone(), c[5].clone(), c[6].clone())
        })
        .collect()
}

/// Checks the timing of every stored trial in the JSON export: a positive RT everywhere, and
/// `video_ended` true for videos (watched to the end) and absent for images.
fn check_timing(json: &Value, media: &BTreeMap<i64, String>) {
    let trials = json["participants"][0]["trials"].as_array().unwrap();
    assert_eq!(trials.len(), media.len(), "{json}");
    for t in trials {
        let position = t["trial"].as_i64().unwrap() - 1;
        let rt = t["rt_ms"].as_f64().unwrap_or_else(|| panic!("no rt_ms: {t}"));
        assert!(rt > 0.0 && rt < 600_000.0, "{t}");
        assert_eq!(t["load_failed"], false, "{t}");
        match media[&position].as_str() {
            "video" => assert_eq!(t["video_ended"], true, "{t}"),
            _ => assert_eq!(t["video_ended"], Value::Null, "{t}"),
        }
    }
    assert!(media.values().any(|m| m == "video"), "the session had no video trial: {media:?}");
}

const ATTENTION: &str = "[attention]\nmax_failures = 1\nchecks = [{ instruction = \"Check question: whatever this face shows, please choose \\\"Fear\\\".\", measure = \"emotion\", value = \"fear\" }]\n";

#[tokio::test(flavor = "multi_thread")]
async fn e2e_emotion_session_by_clicks_then_the_admin_exports_what_was_clicked() {
    let Some(browser) = Browser::start().await else { return };
    let lab = Lab::new();
    lab.study("emo", &emotion_design("emo", &format!("{ATTENTION}[recruitment]\ncompletion_code = \"E2E-DONE\"\n")));
    let server = lab.serve();

    browser.goto(&server.url("/s/emo")).await;
    assert_eq!(browser.text("h1").await, "Emotion test");
    start_session(&browser, &server, "emo", true).await;

    // Every trial by clicking: 1 practice + 7 stimuli + 1 attention check.
    let mut clicked = BTreeMap::new();
    let mut media = BTreeMap::new();
    let mut kinds = Vec::new();
    let total = 9;
    while path(&browser).await.ends_with("/trial") {
        let k = clicked.len() + 1;
        let (view, answer) = answer_emotion_trial(&browser).await;
        assert_eq!(view.progress, format!("{k} of {total}"));
        assert_eq!(view.practice, k == 1, "only the first trial is practice");
        kinds.push(if view.practice { "practice" } else if view.attention.is_some() { "attention" } else { "trial" });
        media.insert(view.position, view.media.clone());
        clicked.insert(view.position, answer);
    }
    assert_eq!(clicked.len(), total, "{kinds:?}");
    assert_eq!(kinds.iter().filter(|k| **k == "attention").count(), 1, "{kinds:?}");
    wait_for_page(&browser, "/done").await;
    assert_eq!(browser.text("h1").await, "Thank you!");
    assert_eq!(browser.text("#code").await, "E2E-DONE");

    // The admin sees a completed participant ...
    admin_login(&browser, &server).await;
    assert!(browser.text("main table").await.contains("Emotion test"));
    browser.goto(&server.url("/admin/studies/emo")).await;
    let participants: Vec<String> = serde_json::from_value(
        browser.execute("return [...[...document.querySelectorAll('h2')].find(h => h.textContent === 'Participants').nextElementSibling.querySelectorAll('tbody tr')].map(r => r.innerText);").await,
    )
    .unwrap();
    assert_eq!(participants.len(), 1, "{participants:?}");
    assert!(participants[0].contains("completed") && participants[0].contains(&format!("{total} / {total}")), "{participants:?}");

    // ... and the long CSV (the study page's link, fetched with the admin's session) has one row
    // per stimulus and measure, with the values clicked and a response time.
    let href = browser.find("#export-long").await.attr("href").await.unwrap().unwrap();
    let csv = fetch_text(&browser, &href).await;
    let rows = long_rows(&csv);
    let stimuli: BTreeSet<String> = lab.manifest().into_iter().map(|(id, ..)| id).collect();
    let pairs: BTreeSet<(String, String)> = rows.iter().map(|(s, _, m, _, _)| (s.clone(), m.clone())).collect();
    assert_eq!(rows.len(), stimuli.len() * 2, "{csv}");
    assert_eq!(pairs.len(), rows.len(), "a (stimulus, measure) twice: {csv}");
    assert_eq!(pairs.iter().map(|(s, _)| s.clone()).collect::<BTreeSet<_>>(), stimuli);
    for (stimulus, trial, measure, value, rt) in &rows {
        let (emotion, believability) = &clicked[&(trial - 1)];
        let expected = if measure == "emotion" { emotion } else { believability };
        assert_eq!(value, expected, "{stimulus} trial {trial} {measure}");
        assert!(rt.parse::<f64>().is_ok_and(|rt| rt > 0.0), "rt_ms {rt:?} of trial {trial}");
    }
    for demographic in [",age,29,", ",gender,female,", ",ethnicity,mixed,", ",education,doctorate,"] {
        assert!(csv.contains(demographic), "{demographic} missing from\n{csv}");
    }

    // The JSON export has every trial (practice and check too) with its timing.
    let json: Value = serde_json::from_str(&fetch_text(&browser, "/admin/studies/emo/export/responses.json").await).unwrap();
    assert_eq!(json["participants"][0]["state"], "completed");
    check_timing(&json, &media);
    browser.close().await;
}

/// The AUs a coder marks in the i-th trial as (AU, intensity, side), and the FACS notation the
/// export must then hold.
fn coding_plan(i: usize) -> (Vec<(u16, &'static str, &'static str)>, &'static str) {
    match i % 7 {
        0 => (vec![(1, "", ""), (12, "C", "L")], "1+L12C"),
        1 => (vec![(4, "B", "")], "4B"),
        2 => (vec![(6, "D", ""), (12, "D", "")], "6D+12D"),
        3 => (vec![], ""),
        4 => (vec![(14, "A", "R")], "R14A"),
        5 => (vec![(17, "E", ""), (25, "", "")], "17E+25"),
        _ => (vec![(2, "", "R"), (26, "B", "")], "R2+26B"),
    }
}

fn coding_design(slug: &str) -> String {
    format!(
        r#"slug = "{slug}"
title = "Coding test"
task = "au_coding"
group = "coders"
stimuli = "set"
practice_trials = 0
demographics = false
consent = "I agree to take part."
instructions = "Mark every Action Unit you see."
debrief = "Thanks for coding."
[au_coding]
intensity = true
side = true
"#
    )
}

#[tokio::test(flavor = "multi_thread")]
async fn e2e_au_coding_session_exports_the_notation_entered() {
    let Some(browser) = Browser::start().await else { return };
    let lab = Lab::new();
    lab.study("code", &coding_design("code"));
    let server = lab.serve();
    start_session(&browser, &server, "code", false).await;

    let mut expected = BTreeMap::new();
    let mut media = BTreeMap::new();
    while path(&browser).await.ends_with("/trial") {
        let view = trial_view(&browser).await;
        assert_eq!(view.progress, format!("{} of 7", expected.len() + 1));
        let (aus, notation) = coding_plan(expected.len());
        if view.media == "video" {
            watch_to_the_end(&browser).await;
        }
        if aus.is_empty() {
            tap(&browser, "input[name=no_aus]").await;
        }
        for (au, intensity, side) in &aus {
            tap(&browser, &format!("input[name=au][value=\"{au}\"]")).await;
            if !intensity.is_empty() {
                choose(&browser, &format!("select[name=intensity_{au}]"), intensity).await;
            }
            if !side.is_empty() {
                choose(&browser, &format!("select[name=side_{au}]"), side).await;
            }
        }
        submit(&browser, &view).await;
        expected.insert(view.position, notation);
        media.insert(view.position, view.media);
    }
    wait_for_page(&browser, "/done").await;
    assert_eq!(browser.text("h1").await, "Thank you!");
    assert_eq!(expected.len(), 7);

    admin_login(&browser, &server).await;
    browser.goto(&server.url("/admin/studies/code")).await;
    let href = browser.find("#export-long").await.attr("href").await.unwrap().unwrap();
    let csv = fetch_text(&browser, &href).await;
    let rows = long_rows(&csv);
    assert_eq!(rows.len(), 7, "{csv}");
    assert_eq!(rows.iter().map(|r| &r.0).collect::<BTreeSet<_>>().len(), 7, "a stimulus twice: {csv}");
    for (stimulus, trial, measure, value, rt) in &rows {
        assert_eq!(measure, "aus");
        assert_eq!(value, expected[&(trial - 1)], "{stimulus} trial {trial}");
        assert!(rt.parse::<f64>().is_ok_and(|rt| rt > 0.0), "rt_ms {rt:?} of trial {trial}");
    }
    let json: Value = serde_json::from_str(&fetch_text(&browser, "/admin/studies/code/export/responses.json").await).unwrap();
    check_timing(&json, &media);
    browser.close().await;
}

#[tokio::test(flavor = "multi_thread")]
async fn e2e_reload_mid_session_continues_at_the_first_unanswered_trial() {
    let Some(browser) = Browser::start().await else { return };
    let lab = Lab::new();
    lab.study("emo", &emotion_design("emo", ATTENTION));
    let server = lab.serve();
    let token = start_session(&browser, &server, "emo", true).await;
    let total = 9;

    let mut answered = Vec::new();
    for _ in 0..3 {
        answered.push(answer_emotion_trial(&browser).await.0.position);
    }
    // Half an answer on the fourth trial, then the participant reopens their link.
    let fourth = trial_view(&browser).await;
    assert_eq!(fourth.progress, format!("4 of {total}"));
    tap(&browser, "input[name=emotion][value=\"anger\"]").await;
    browser.goto(&server.url(&format!("/p/{token}"))).await;
    wait_for_page(&browser, "/trial").await;
    let again = trial_view(&browser).await;
    assert_eq!((again.position, again.progress.as_str()), (fourth.position, format!("4 of {total}").as_str()));
    assert!(!answered.contains(&again.position));
    assert_ne!(again.key, fourth.key, "each view of a trial has its own idempotency key");
    assert_eq!(browser.execute("return document.querySelector('.meter').getAttribute('aria-valuenow');").await, "3");
    // A plain browser reload of the trial page shows the same trial.
    browser.client().refresh().await.unwrap();
    wait_for_page(&browser, "/trial").await;
    assert_eq!(trial_view(&browser).await.progress, format!("4 of {total}"));

    // The rest of the session; every trial is stored once.
    let mut positions = answered.clone();
    while path(&browser).await.ends_with("/trial") {
        positions.push(answer_emotion_trial(&browser).await.0.position);
    }
    wait_for_page(&browser, "/done").await;
    assert_eq!(positions, (0..total as i64).collect::<Vec<_>>());
    admin_login(&browser, &server).await;
    let json: Value = serde_json::from_str(&fetch_text(&browser, "/admin/studies/emo/export/responses.json").await).unwrap();
    let stored: Vec<i64> = json["participants"][0]["trials"].as_array().unwrap().iter().map(|t| t["trial"].as_i64().unwrap() - 1).collect();
    assert_eq!(stored, positions);
    browser.close().await;
}

/// Three stills and a video at the size studies use (the tiny set is too small to judge a page by).
const SCREENSHOT_SET: &str = r#"
name = "screenshots"
seed = 11
size = [485, 480]
fps = 15

[[group]]
name = "stills"
emotions = ["happiness", "surprise", "sadness"]
stills = [1.0]

[[group]]
name = "video"
emotions = ["surprise"]
video_peaks = [1.0]
timing = { onset_s = 0.4, apex_s = 0.4, offset_s = 0.4 }
"#;

/// The emotion study of the screenshots, worded as a lab would.
const SCREENSHOT_DESIGN: &str = r#"slug = "faces"
title = "Faces and feelings"
task = "emotion"
group = "raters"
stimuli = "set"
practice_trials = 1
consent = """
This study is run by the Face Perception Lab. You will see computer-generated faces and say which emotion each one shows, and how believable it looks. It takes about ten minutes.
Taking part is voluntary. You may stop at any time with the Withdraw button at the top of the page; your answers are then not used.
Your answers are stored without your name and are used for research only.
"""
instructions = """
For each face, choose the emotion it shows (or "None of these") and say how believable the expression is, from 1 (not at all) to 5 (very).
The first face is for practice. Some faces move: watch them to the end.
"""
debrief = "Thank you for taking part! The faces were made by a computer from descriptions of facial muscle movements; we compare what people see in them with what they were made to show."
[emotion]
believability = true
[recruitment]
completion_code = "FPL-7Q2X"
"#;

/// Viewport sizes of the screenshots: a desktop and a phone (CSS pixels).
const SIZES: [(&str, u32, u32); 2] = [("desktop", 1280, 900), ("phone", 390, 844)];

/// Takes the screenshots of one page at every size, checking as it goes that the page has no
/// horizontal scrolling and that every control is large enough to tap (at least 24 px, WCAG
/// 2.5.8; the participant controls are 44 px).
struct Shots {
    dir: PathBuf,
    taken: Vec<PathBuf>,
}

impl Shots {
    async fn page(&mut self, browser: &Browser, name: &str) {
        for (size, width, height) in SIZES {
            browser.set_window_size(width, height).await;
            // Layout settles, then scroll to the top as a page opens.
            browser.execute("window.scrollTo(0, 0); return document.fonts.ready.then(() => true);").await;
            tokio::time::sleep(Duration::from_millis(150)).await;
            let layout = browser
                .execute(
                    "const targets = [...document.querySelectorAll('button, a, select, summary, input:not([type=hidden]):not([type=radio]):not([type=checkbox]), label:has(input[type=radio]), label:has(input[type=checkbox])')]
                       .filter(e => e.getClientRects().length > 0)
                       .filter(e => !(e.matches('a') && e.closest('p, td, .text, .hint')));
                     const small = targets.filter(e => { const r = e.getBoundingClientRect(); return r.height < 24 || r.width < 24; })
                       .map(e => e.outerHTML.slice(0, 100));
                     return { overflow: document.documentElement.scrollWidth - document.documentElement.clientWidth, small: small };",
                )
                .await;
            assert!(layout["overflow"].as_i64().unwrap() <= 0, "{name} scrolls sideways at {size} size: {layout}");
            assert_eq!(layout["small"], serde_json::json!([]), "{name} at {size} size has controls under 24 px");
            let file = self.dir.join(format!("{name}-{size}.png"));
            browser.screenshot(&file).await;
            self.taken.push(file);
        }
        browser.set_window_size(SIZES[0].1, SIZES[0].2).await;
    }

    /// On a phone the face leaves room for the answers: it takes at most about a third of the
    /// screen (still large enough to judge), and the first answer choice is on the first screen.
    async fn check_trial_fits_a_phone(&self, browser: &Browser, name: &str) {
        let (_, width, height) = SIZES[1];
        browser.set_window_size(width, height).await;
        browser.execute("window.scrollTo(0, 0); return true;").await;
        let fit = browser
            .execute(
                "const face = document.getElementById('stimulus').getBoundingClientRect();
                 const first = document.querySelector('.questions .choice, .questions .scale label').getBoundingClientRect();
                 return { face: face.height, first_answer: first.bottom, height: window.innerHeight };",
            )
            .await;
        let face = fit["face"].as_f64().unwrap();
        let height = fit["height"].as_f64().unwrap();
        assert!((200.0..=0.36 * height).contains(&face), "{name}: the face is {face} px high on a {height} px phone screen: {fit}");
        assert!(fit["first_answer"].as_f64().unwrap() < height, "{name}: the first answer is below the first phone screen: {fit}");
        browser.set_window_size(SIZES[0].1, SIZES[0].2).await;
    }
}

/// A PNG that shows something: the expected size and more than a handful of colours.
fn check_png(path: &Path) {
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(path).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut pixels = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut pixels).unwrap();
    let size = if path.to_string_lossy().contains("-phone") { (390, 844) } else { (1280, 900) };
    assert_eq!((info.width, info.height), size, "{}", path.display());
    let channels = info.line_size / info.width as usize;
    let colours: BTreeSet<&[u8]> = pixels[..info.buffer_size()].chunks(channels).collect();
    assert!(colours.len() > 64, "{}: only {} colours", path.display(), colours.len());
    assert!(std::fs::metadata(path).unwrap().len() > 8 * 1024, "{}: a tiny PNG", path.display());
}

/// Moves the participant on (over HTTP, no clicking) until the trial on screen satisfies `want`.
async fn skip_to(browser: &Browser, server: &Server, token: &str, mut want: impl FnMut(&TrialView) -> bool) -> TrialView {
    let http = client();
    loop {
        browser.goto(&server.url(&format!("/p/{token}/trial"))).await;
        wait_for_page(browser, "/trial").await;
        let view = trial_view(browser).await;
        if want(&view) {
            return view;
        }
        let answer = if view.attention.is_some() { "fear" } else { "happiness" };
        let (status, ack) = save(&http, server, token, view.position, &format!("skip-{token}-{}", view.position), &[("emotion", answer), ("believability", "4")]).await;
        assert_eq!(status, 200, "{ack}");
    }
}

#[tokio::test(flavor = "multi_thread")]
async fn e2e_screenshots_of_every_page() {
    let Some(browser) = Browser::start().await else { return };
    let temp = tempfile::tempdir().unwrap();
    let dir = std::env::var_os("FACSLAB_SCREENSHOTS").map(PathBuf::from).unwrap_or_else(|| temp.path().to_path_buf());
    std::fs::create_dir_all(&dir).unwrap();
    let lab = Lab::with_set(SCREENSHOT_SET);
    lab.study("faces", &format!("{SCREENSHOT_DESIGN}{ATTENTION}"));
    lab.study("coding", &coding_design("coding").replace("title = \"Coding test\"", "title = \"FACS coding\""));
    let server = lab.serve();
    let mut shots = Shots { dir: dir.clone(), taken: Vec::new() };

    // The participant pages of the emotion study, in order.
    browser.goto(&server.url("/s/faces")).await;
    shots.page(&browser, "01-landing").await;
    browser.click("#start").await;
    wait_for_page(&browser, "/consent").await;
    let token = token(&browser).await;
    shots.page(&browser, "02-consent").await;
    browser.click("#agree").await;
    browser.click("#consent").await;
    wait_for_page(&browser, "/demographics").await;
    shots.page(&browser, "03-demographics").await;
    browser.fill("#age", "29").await;
    browser.click("#demographics").await;
    wait_for_page(&browser, "/instructions").await;
    shots.page(&browser, "04-instructions").await;
    // The withdraw confirmation (not confirmed: "Go back").
    browser.click(".bar .withdraw").await;
    wait_for_page(&browser, "/withdraw").await;
    shots.page(&browser, "08-withdraw").await;
    browser.click("main a.button").await;
    wait_for_page(&browser, "/instructions").await;

    // A main image trial with an answer chosen and a main video trial (held at its apex),
    // whichever comes first in the plan; other trials are answered over HTTP on the way, the
    // attention check as it asks.
    let mut seen = BTreeSet::new();
    while seen.len() < 2 {
        let view = skip_to(&browser, &server, &token, |v| {
            !v.practice && v.attention.is_none() && !seen.contains(&v.media)
        })
        .await;
        if view.media == "video" {
            browser.wait_for("document.getElementById('stimulus').readyState >= 2", TIMEOUT).await;
            browser.execute("const v = document.getElementById('stimulus'); v.pause(); v.currentTime = 0.6; return true;").await;
            browser.wait_for("!document.getElementById('stimulus').seeking", TIMEOUT).await;
            shots.check_trial_fits_a_phone(&browser, "video trial").await;
            shots.page(&browser, "06-trial-video").await;
        } else {
            browser.wait_for("document.getElementById('stimulus').complete", TIMEOUT).await;
            tap(&browser, "input[name=emotion][value=\"happiness\"]").await;
            tap(&browser, "input[name=believability][value=\"4\"]").await;
            shots.check_trial_fits_a_phone(&browser, "image trial").await;
            shots.page(&browser, "05-trial-image").await;
        }
        seen.insert(view.media.clone());
        let http = client();
        let (status, _) = save(&http, &server, &token, view.position, &format!("shot-{token}-{}", view.position), &[("emotion", "happiness"), ("believability", "4")]).await;
        assert_eq!(status, 200);
    }

    // The rest of the study, then the debrief with the completion code.
    let http = client();
    while let Some(position) = current_position(&http, &server, &token).await {
        let page = http.get(server.url(&format!("/p/{token}/trial"))).send().await.unwrap().text().await.unwrap();
        let emotion = if page.contains("class=\"attention\"") { "fear" } else { "surprise" };
        let (status, _) = save(&http, &server, &token, position, &format!("rest-{token}-{position}"), &[("emotion", emotion), ("believability", "3")]).await;
        assert_eq!(status, 200);
    }
    browser.goto(&server.url(&format!("/p/{token}/done"))).await;
    assert_eq!(browser.text("h1").await, "Thank you!");
    assert_eq!(browser.text("#code").await, "FPL-7Q2X");
    shots.page(&browser, "09-done").await;

    // An AU-coding trial with two AUs marked.
    start_session(&browser, &server, "coding", false).await;
    browser.wait_for("document.getElementById('stimulus').complete || document.getElementById('stimulus').readyState >= 2", TIMEOUT).await;
    tap(&browser, "input[name=au][value=\"1\"]").await;
    choose(&browser, "select[name=intensity_1]", "B").await;
    tap(&browser, "input[name=au][value=\"12\"]").await;
    choose(&browser, "select[name=intensity_12]", "C").await;
    choose(&browser, "select[name=side_12]", "L").await;
    shots.check_trial_fits_a_phone(&browser, "AU-coding trial").await;
    shots.page(&browser, "07-trial-coding").await;
    // On a phone the face stays in view while the coder scrolls down the checklist.
    browser.set_window_size(SIZES[1].1, SIZES[1].2).await;
    browser.execute("document.querySelector('input[name=au][value=\"25\"]').scrollIntoView({ block: 'end' }); return true;").await;
    tokio::time::sleep(Duration::from_millis(150)).await;
    let face = browser.execute("const r = document.getElementById('stimulus').getBoundingClientRect(); return [r.top, r.bottom, window.scrollY];").await;
    assert!(face[2].as_f64().unwrap() > 800.0 && face[0].as_f64().unwrap() >= 0.0 && face[1].as_f64().unwrap() < 400.0, "the face scrolled away: {face}");
    let scrolled = dir.join("07-trial-coding-scrolled-phone.png");
    browser.screenshot(&scrolled).await;
    shots.taken.push(scrolled);
    browser.set_window_size(SIZES[0].1, SIZES[0].2).await;

    // The admin pages.
    browser.goto(&server.url("/admin/login")).await;
    shots.page(&browser, "10-admin-login").await;
    admin_login(&browser, &server).await;
    shots.page(&browser, "11-admin-dashboard").await;
    browser.goto(&server.url("/admin/studies/faces")).await;
    shots.page(&browser, "12-admin-study").await;

    assert_eq!(shots.taken.len(), 12 * SIZES.len() + 1);
    for file in &shots.taken {
        check_png(file);
    }
    browser.close().await;
}

/// The coder's video on screen, as (currentTime, paused, playbackRate, seeking, duration).
async fn video_state(browser: &Browser) -> (f64, bool, f64, bool, f64) {
    let v = browser.execute("const v = document.getElementById('stimulus'); return [v.currentTime, v.paused, v.playbackRate, v.seeking, v.duration];").await;
    (v[0].as_f64().unwrap(), v[1] == true, v[2].as_f64().unwrap(), v[3] == true, v[4].as_f64().unwrap_or(0.0))
}

/// Steps one frame with `how` (a click or a key) and checks that the video is paused, one
/// frame (1/`fps` s) from `from`, on a frame; returns the new time.
async fn step_frame(browser: &Browser, how: StepBy<'_>, from: f64, fps: f64, direction: f64) -> f64 {
    match how {
        StepBy::Click(css) => browser.click(css).await,
        StepBy::Key(css, key) => browser.find(css).await.send_keys(key).await.unwrap_or_else(|e| panic!("key {key} on {css}: {e}")),
    }
    let expected = from + direction / fps;
    let js = format!("const v = document.getElementById('stimulus'); return !v.seeking && Math.abs(v.currentTime - {expected}) < 1e-6;");
    browser.wait_for(&format!("(function () {{ {js} }})()"), TIMEOUT).await;
    let (time, paused, ..) = video_state(browser).await;
    assert!(paused, "stepping a frame pauses the video");
    assert!(((time - from).abs() * fps - 1.0).abs() < 1e-6, "moved from {from} to {time}, not one frame at {fps} fps");
    time
}

/// How a frame step is asked for.
#[derive(Clone, Copy)]
enum StepBy<'a> {
    Click(&'a str),
    /// A key typed with the focus on the element `css` (a button, as a coder tabbing through).
    Key(&'a str, &'a str),
}

#[tokio::test(flavor = "multi_thread")]
async fn e2e_coder_steps_frames_replays_and_slows_the_video_and_the_export_says_so() {
    let Some(browser) = Browser::start().await else { return };
    // The Exp. 1 shape at the study's frame size (two AUs, so it builds fast).
    let set = crate::study::EXP1_SHAPE.replace("size = [64, 64]", "size = [485, 480]").replace(r#"["1", "4", "R14"]"#, r#"["1", "12"]"#);
    let lab = Lab::with_set(&set);
    lab.study("exp1", include_str!("../../studies/exp1-coders.toml"));
    let server = lab.serve();
    start_session(&browser, &server, "exp1", true).await;
    let view = trial_view(&browser).await;
    assert_eq!(view.media, "video");
    assert_eq!(browser.execute("return document.querySelectorAll('.beside img').length;").await, 3);
    let fps: f64 = browser.find("#stimulus").await.attr("data-fps").await.unwrap().unwrap().parse().unwrap();
    assert_eq!(fps, 10.0);

    // A patient coder watches the clip to its end, then steps back three frames and forward one.
    watch_to_the_end(&browser).await;
    let (end, ..) = video_state(&browser).await;
    browser.click("#step-back").await;
    browser.wait_for("!document.getElementById('stimulus').seeking && document.getElementById('stimulus').currentTime < document.getElementById('stimulus').duration", TIMEOUT).await;
    let (on_frame, paused, ..) = video_state(&browser).await;
    assert!(paused && on_frame < end && ((on_frame * fps) - (on_frame * fps).round()).abs() < 1e-6, "{on_frame} of {end}");
    let back = step_frame(&browser, StepBy::Key("#step-back", ","), on_frame, fps, -1.0).await;
    let back = step_frame(&browser, StepBy::Click("#step-back"), back, fps, -1.0).await;
    let forward = step_frame(&browser, StepBy::Key("#step-forward", "."), back, fps, 1.0).await;
    assert!(forward > back);
    entry_screenshots(&browser).await;

    // Half speed, then replay by button and by key: it plays from the start at 0.5×.
    browser.click(".speed[data-speed=\"0.5\"]").await;
    assert_eq!(browser.find(".speed[data-speed=\"0.5\"]").await.attr("aria-pressed").await.unwrap().as_deref(), Some("true"));
    browser.click("#replay").await;
    browser.wait_for("!document.getElementById('stimulus').paused && document.getElementById('stimulus').playbackRate === 0.5", TIMEOUT).await;
    browser.find("#replay").await.send_keys("r").await.unwrap();
    browser.wait_for("!document.getElementById('stimulus').paused && document.getElementById('stimulus').currentTime < 0.3", TIMEOUT).await;
    let (.., rate, _, _) = video_state(&browser).await;
    assert_eq!(rate, 0.5);

    // AU 1 was marked for the screenshots.
    assert_eq!(browser.execute("return document.querySelector('input[name=au][value=\"1\"]').checked;").await, true);
    submit(&browser, &view).await;
    let stored = stored_trial(&browser, &server, view.position).await;
    let viewing = &stored["viewing"];
    assert_eq!((viewing["replays"].as_u64(), viewing["frame_steps"].as_u64()), (Some(2), Some(4)), "{stored}");
    assert_eq!(viewing["speeds"], serde_json::json!([1.0, 0.5]), "{stored}");
    let (time_on_task, rt) = (viewing["time_on_task_ms"].as_f64().unwrap(), stored["rt_ms"].as_f64().unwrap());
    assert!(time_on_task > 500.0 && time_on_task <= rt + 0.1, "time on task {time_on_task} ms, rt {rt} ms: {stored}");
    assert_eq!(stored["answers"], serde_json::json!([["aus", "1"]]));
    assert_eq!(stored["shown"].as_array().unwrap().len(), 4, "{stored}");
    browser.close().await;
}

/// The stored trial at `position` of the study's only participant, from the admin's JSON export
/// (every participation, so one still going counts).
async fn stored_trial(browser: &Browser, server: &Server, position: i64) -> Value {
    let participant = token(browser).await;
    admin_login(browser, server).await;
    let json: Value = serde_json::from_str(&fetch_text(browser, "/admin/studies/exp1/export/responses.json?scope=all").await).unwrap();
    let trials = json["participants"][0]["trials"].as_array().unwrap_or_else(|| panic!("no trials for {participant}: {json}"));
    trials.iter().find(|t| t["trial"].as_i64() == Some(position + 1)).cloned().unwrap_or_else(|| panic!("trial {position} not stored: {json}"))
}

/// Screenshots of the Exp. 1 trial (video held on a frame, stills beside it, AU 1 marked) at
/// desktop and phone size, into `FACSLAB_SCREENSHOTS` when set; on a phone the video and its
/// stills stay in view while the coder scrolls down the checklist.
async fn entry_screenshots(browser: &Browser) {
    let temp = tempfile::tempdir().unwrap();
    let dir = std::env::var_os("FACSLAB_SCREENSHOTS").map(PathBuf::from).unwrap_or_else(|| temp.path().to_path_buf());
    let mut shots = Shots { dir: dir.clone(), taken: Vec::new() };
    browser.wait_for("[...document.querySelectorAll('.beside img')].every(i => i.complete && i.naturalWidth > 0)", TIMEOUT).await;
    tap(browser, "input[name=au][value=\"1\"]").await;
    shots.page(browser, "13-trial-entry").await;
    browser.set_window_size(SIZES[1].1, SIZES[1].2).await;
    let first = browser.execute("return document.querySelector('.questions .choice').getBoundingClientRect().bottom;").await;
    assert!(first.as_f64().unwrap() < SIZES[1].2 as f64, "the first AU is below the first phone screen: {first}");
    browser.execute("document.querySelector('input[name=au][value=\"25\"]').scrollIntoView({ block: 'end' }); return true;").await;
    tokio::time::sleep(Duration::from_millis(150)).await;
    let seen = browser
        .execute(
            "const rect = e => e.getBoundingClientRect();
             const all = [document.getElementById('stimulus'), ...document.querySelectorAll('.beside img'), document.getElementById('step-forward')];
             return { scrolled: window.scrollY, top: Math.min(...all.map(e => rect(e).top)), bottom: Math.max(...all.map(e => rect(e).bottom)), stills: rect(document.querySelector('.beside img')).height };",
        )
        .await;
    let (top, bottom) = (seen["top"].as_f64().unwrap(), seen["bottom"].as_f64().unwrap());
    assert!(seen["scrolled"].as_f64().unwrap() > 800.0 && top >= 0.0 && bottom < 0.5 * SIZES[1].2 as f64, "the face scrolled away or covers the list: {seen}");
    assert!(seen["stills"].as_f64().unwrap() >= 60.0, "stills too small to code: {seen}");
    let scrolled = dir.join("13-trial-entry-scrolled-phone.png");
    browser.screenshot(&scrolled).await;
    shots.taken.push(scrolled);
    browser.execute("window.scrollTo(0, 0); return true;").await;
    browser.set_window_size(SIZES[0].1, SIZES[0].2).await;
    for file in &shots.taken {
        check_png(file);
    }
}
