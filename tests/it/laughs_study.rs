//! Seed 004's two rating templates (`studies/laugh-description.toml`, `studies/laugh-motion.toml`)
//! end to end: a set of 26 short videos labelled from the `laughs` label set, half of them in a
//! second style, a participant who answers by clicking in headless Chromium, more participants
//! over HTTP, and `facslab report --study`, whose report gives the means by type and style, the
//! two-way ANOVA (Type II and III) and the Scheffé pairs.
//!
//! The clips are ordinary FACS expressions (one per laugh type, two identities), relabelled in
//! the built set's manifest: the laugh engine is not needed to exercise the platform, and any
//! clip can stand in the "real recording" slot of study 1 (the user supplies those).

use std::collections::BTreeMap;

use crate::browser::Browser;
use crate::cli::facslab_ok;
use crate::browser::TIMEOUT;
use crate::e2e::{path, start_session, submit, tap, trial_view, wait_for_page, watch_to_the_end};
use crate::server::*;

/// One expression per laugh type (the label set's declared order), as the stand-in clips.
const EXPRESSIONS: [&str; 13] = ["6+12+25+27", "6+12+25+26", "6+12+25", "6+12", "12+17+24", "1+4+12", "1+2+5+12+25", "1+2+4+12", "4+6+12", "12+43", "12+14+54", "12+20", "12+25+26"];

/// The laugh types in the `laughs` set's order.
const TYPES: [&str; 13] = [
    "uproarious_laughter",
    "laughter",
    "open_mouthed_smile",
    "closed_mouth_smile",
    "stifled_smile",
    "melancholy_smile",
    "eager_smile",
    "ingratiating_smile",
    "sly_smile",
    "debauched_smile",
    "abashed_smile",
    "false_smile",
    "false_laughter",
];

/// The set: the 13 clips on `wm1` (first style) and on `wf1` (second style), 64 × 64 at 5 fps.
fn spec() -> String {
    let list = EXPRESSIONS.iter().map(|e| format!("\"{e}\"")).collect::<Vec<_>>().join(", ");
    let group = |name: &str, identity: &str| format!("[[group]]\nname = \"{name}\"\nexpressions = [{list}]\nvideo_peaks = [1.0]\ntiming = {{ onset_s = 0.2, apex_s = 0.2, offset_s = 0.2 }}\nidentity = \"{identity}\"\n\n");
    format!("name = \"laughs-test\"\nseed = 14\nsize = [64, 64]\nfps = 5\n\n{}{}", group("first", "wm1"), group("second", "wf1"))
}

/// Relabels the built set: each clip's `emotion` becomes `laughs:<type>` of its expression, and
/// manifest.csv gains the `style` column (`wm1` → `first`, `wf1` → `second`). Returns the
/// (type, style) of each stimulus id.
fn relabel(lab: &Lab, styles: [&str; 2]) -> BTreeMap<String, (String, String)> {
    let set = lab.path().join("set");
    let csv = std::fs::read_to_string(set.join("manifest.csv")).unwrap();
    let mut lines = csv.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| head.iter().position(|h| *h == name).unwrap();
    let (c_id, c_expr, c_emotion, c_identity) = (col("stimulus_id"), col("expression"), col("emotion"), col("identity"));
    let mut out = format!("{},style\n", head.join(","));
    let mut facts = BTreeMap::new();
    for line in lines {
        let mut cells: Vec<String> = line.split(',').map(str::to_string).collect();
        let t = EXPRESSIONS.iter().position(|e| *e == cells[c_expr].replace("@1", "")).unwrap_or_else(|| panic!("unknown clip {line}"));
        let style = if cells[c_identity] == "wm1" { styles[0] } else { styles[1] };
        cells[c_emotion] = format!("laughs:{}", TYPES[t]);
        facts.insert(cells[c_id].clone(), (TYPES[t].to_string(), style.to_string()));
        out.push_str(&format!("{},{style}\n", cells.join(",")));
    }
    std::fs::write(set.join("manifest.csv"), out).unwrap();
    let json = std::fs::read_to_string(set.join("manifest.json")).unwrap();
    let mut rows: Vec<serde_json::Value> = serde_json::from_str(&json).unwrap();
    for row in &mut rows {
        let (t, _) = &facts[row["stimulus_id"].as_str().unwrap()];
        row["emotion"] = format!("laughs:{t}").into();
    }
    std::fs::write(set.join("manifest.json"), serde_json::to_string_pretty(&rows).unwrap()).unwrap();
    assert_eq!(facts.len(), 26);
    facts
}

/// The rating a participant over HTTP gives at `position` to a clip of type `t` (read from the
/// description the page shows; the page never names the stimulus), so the ratings vary by type
/// and by participant.
fn rating(participant: usize, position: i64, t: usize, scale: &str) -> u8 {
    (1 + (t % 3) + (participant + position as usize + scale.len()) % 3) as u8
}

/// The type whose declared description the trial page shows.
fn shown_type(page: &str) -> usize {
    let page = page.replace("&#x27;", "'").replace("&#39;", "'").replace("&quot;", "\"").replace("&amp;", "&");
    let laughs = facslab::study::labels::LabelSet::find("laughs").unwrap();
    TYPES.iter().position(|t| page.contains(&laughs.label(t).unwrap().description)).unwrap_or_else(|| panic!("no type's description on the page: {}", page.lines().find(|l| l.contains("description")).unwrap_or("")))
}

/// The positions of the trials a page shows side by side (empty for a page of one trial).
fn screen_positions(page: &str) -> Vec<i64> {
    page.split("data-position=\"").skip(1).map(|rest| rest.split('"').next().unwrap().parse().unwrap()).collect()
}

/// Answers every screen by clicking, checking that each shows a description; returns per screen
/// the description shown and how many videos it showed side by side (1 for a page of one).
/// Screenshots the first screen into `shots` (desktop and phone size).
async fn click_through(browser: &Browser, scales: &[&str], shots: &std::path::Path, name: &str) -> Vec<(String, usize)> {
    let mut shown = Vec::new();
    while path(browser).await.ends_with("/trial") {
        let view = trial_view(browser).await;
        let description = browser.text(".description").await;
        assert!(description.len() > 40, "every laugh trial shows its type's description: {description:?}");
        if shown.is_empty() {
            browser.screenshot(shots.join(format!("{name}-trial-desktop.png"))).await;
            browser.set_window_size(390, 844).await;
            browser.screenshot(shots.join(format!("{name}-trial-phone.png"))).await;
            browser.set_window_size(1280, 900).await;
        }
        assert_eq!(view.media, "video");
        let parts = screen_positions(browser.execute("return document.getElementById('trial').outerHTML;").await.as_str().unwrap());
        if parts.is_empty() {
            watch_to_the_end(browser).await;
        } else {
            assert_eq!(parts[0], view.position, "a screen is saved at its first trial");
            browser.wait_for("[...document.querySelectorAll('video.stimulus')].every(v => v.ended)", TIMEOUT).await;
        }
        let names: Vec<(String, i64)> = if parts.is_empty() { vec![(String::new(), view.position)] } else { parts.iter().map(|p| (format!("@{p}"), *p)).collect() };
        for (suffix, position) in &names {
            for (i, scale) in scales.iter().enumerate() {
                tap(browser, &format!("input[name=\"{scale}{suffix}\"][value=\"{}\"]", (*position as usize + i) % 6)).await;
            }
        }
        submit(browser, &view).await;
        shown.push((description, parts.len().max(1)));
    }
    shown
}

/// The fields of one screen: each scale rated by [`rating`], named by trial when the screen
/// shows several.
fn screen_fields(participant: usize, positions: &[i64], t: usize, scales: &[&str]) -> Vec<(String, String)> {
    let several = positions.len() > 1;
    let name = |scale: &str, p: i64| if several { format!("{scale}@{p}") } else { scale.to_string() };
    positions.iter().flat_map(|&p| scales.iter().map(move |s| (name(s, p), rating(participant, p, t, s).to_string()))).collect()
}

/// A screen of two trials is stored whole or not at all: half its answers are refused naming
/// the missing field, a save at its second trial is refused, and neither stores anything.
async fn a_screen_is_saved_whole(http: &reqwest::Client, server: &Server, token: &str, positions: &[i64], fields: &[(&str, &str)]) {
    let (status, body) = save(http, server, token, positions[0], &format!("half-{token}"), &fields[..1]).await;
    assert_eq!(status, 422, "{body}");
    assert!(body["error"].as_str().unwrap_or_default().contains(&format!("@{}", positions[1])), "the missing answer is named: {body}");
    let (status, body) = save(http, server, token, positions[1], &format!("second-{token}"), &fields[1..]).await;
    assert_eq!(status, 409, "{body}");
    assert!(body["error"].as_str().unwrap_or_default().contains(&format!("shown beside trial {}", positions[0])), "{body}");
    assert_eq!(current_position(http, server, token).await, Some(positions[0]), "nothing of the screen was stored");
}

/// Participants over HTTP: each answers its screens with [`rating`] of the stimulus shown.
async fn http_participants(server: &Server, slug: &str, scales: &[&str], count: usize) {
    let http = client();
    for p in 0..count {
        let token = start(&http, server, slug, &[]).await;
        consent_and_demographics(&http, server, &token).await;
        while let Some(position) = current_position(&http, server, &token).await {
            let page = http.get(server.url(&format!("/p/{token}/trial"))).send().await.unwrap().text().await.unwrap();
            let t = shown_type(&page);
            let parts = screen_positions(&page);
            let positions = if parts.is_empty() { vec![position] } else { parts };
            let values = screen_fields(p, &positions, t, scales);
            let fields: Vec<(&str, &str)> = values.iter().map(|(s, v)| (s.as_str(), v.as_str())).collect();
            if p == 0 && positions.len() == 2 {
                a_screen_is_saved_whole(&http, server, &token, &positions, &fields).await;
            }
            let (status, ack) = save(&http, server, &token, position, &format!("k-{token}-{position}"), &fields).await;
            assert_eq!(status, 200, "{ack}");
            let (status, again) = save(&http, server, &token, position, &format!("k-{token}-{position}"), &fields).await;
            assert_eq!((status, again["saved"].as_str()), (200, Some("repeated")), "a repeated save of the screen is recognised: {again}");
        }
    }
}

/// `facslab report --study` into `out`; returns the report's styles tables as text.
fn report(lab: &Lab, slug: &str, out: &str) -> (String, String, String) {
    facslab_ok(lab.path(), &["report", "--study", slug, "--db", &lab.db, "-o", out]);
    let read = |f: &str| std::fs::read_to_string(lab.path().join(out).join(f)).unwrap_or_else(|e| panic!("{f}: {e}"));
    (read("styles_means.csv"), read("styles_anova.csv"), read("styles_scheffe.csv"))
}

/// Checks the ANOVA file has, per scale, Type II and Type III rows of the three terms with F and p.
fn check_anova(anova: &str, scales: &[&str]) {
    for scale in scales {
        for ty in ["II", "III"] {
            for term in ["style", "label", "style:label"] {
                let row = anova.lines().find(|l| l.starts_with(&format!("{scale},{ty},{term},"))).unwrap_or_else(|| panic!("no {scale} {ty} {term} row:\n{anova}"));
                let cells: Vec<&str> = row.split(',').collect();
                assert!(cells[5].parse::<f64>().is_ok() && cells[6].parse::<f64>().is_ok_and(|p| (0.0..=1.0).contains(&p)), "{row}");
            }
        }
    }
}

#[tokio::test(flavor = "multi_thread")]
async fn e2e_laugh_templates_run_in_the_browser_and_report_anova_and_scheffe() {
    let Some(browser) = Browser::start().await else { return };
    let shots = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("laugh-study");
    std::fs::create_dir_all(&shots).unwrap();
    let shipped = |f: &str| std::fs::read_to_string(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("studies").join(f)).unwrap();
    for (template, styles, scales) in [("laugh-motion.toml", ["realistic", "cartoon"], &["q1", "q2"][..]), ("laugh-description.toml", ["real", "realistic"], &["description_match"][..])] {
        let lab = Lab::with_set(&spec());
        let facts = relabel(&lab, styles);
        assert_eq!(facts.values().filter(|(_, s)| s == styles[1]).count(), 13, "half the clips in the second style");
        let design = shipped(template);
        let slug = design.lines().find_map(|l| l.strip_prefix("slug = ")).unwrap().trim_matches('"').to_string();
        lab.study(&slug, &design);
        let server = lab.serve();
        start_session(&browser, &server, &slug, true).await;
        let shown = click_through(&browser, scales, &shots, &slug).await;
        let trials: usize = shown.iter().map(|(_, n)| n).sum();
        assert_eq!(trials, if slug == "laugh-motion" { 26 } else { 14 }, "{slug}: trials per participant");
        if slug == "laugh-description" {
            let types: std::collections::BTreeSet<&String> = shown.iter().map(|(d, _)| d).collect();
            assert_eq!(types.len(), 7, "seven whole types");
            assert!(shown.iter().all(|(_, n)| *n == 2), "a type's two videos on one screen: {shown:?}");
        } else {
            assert!(shown.iter().all(|(_, n)| *n == 1), "laugh-motion shows one video per screen");
        }
        wait_for_page(&browser, "/done").await;
        http_participants(&server, &slug, scales, 7).await;
        let (means, anova, scheffe) = report(&lab, &slug, "report");
        for t in TYPES {
            for style in styles {
                assert!(means.lines().any(|l| l.contains(&format!(",{t},{style},"))), "{slug}: no mean of {t} {style}:\n{means}");
            }
        }
        check_anova(&anova, scales);
        let pairs = scheffe.lines().filter(|l| l.contains(",yes,") || l.contains(",no,")).count();
        assert_eq!(pairs, scales.len() * 325, "{slug}: every pair of the 26 cells per scale:\n{}", &scheffe[..scheffe.len().min(2000)]);
        browser.goto(&format!("file://{}", lab.path().join("report/report.html").display())).await;
        browser.screenshot(shots.join(format!("{slug}-report.png"))).await;
        assert!(browser.text("body").await.contains("Two-way ANOVA: style × label"), "{slug}: the report page shows the ANOVA");
    }
    eprintln!("screenshots in {}", shots.display());
    browser.close().await;
}

/// Study 1's screens on every database: half a screen is refused naming the missing score, a
/// save at the second video's trial is refused, neither stores anything, a repeated screen is
/// recognised, and each participant completes with seven screens (PostgreSQL runs the same steps,
/// one transaction per request).
#[tokio::test(flavor = "multi_thread")]
async fn laughs_study_side_by_side_screens_are_stored_whole_on_every_backend() {
    let design = std::fs::read_to_string(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("studies/laugh-description.toml")).unwrap();
    for backend in crate::backends::backends() {
        let lab = Lab::with_set_on(&spec(), &backend);
        relabel(&lab, ["real", "realistic"]);
        lab.study("laugh-description", &design);
        let server = lab.serve();
        http_participants(&server, "laugh-description", &["description_match"], 2).await;
        let (means, _, _) = report(&lab, "laugh-description", "report");
        // Per type and style (scale,label,style,column,n,mean,sd): two participants, 7 screens of 2.
        let cell = |l: &&str| {
            let cells: Vec<&str> = l.split(',').collect();
            TYPES.contains(&cells[1]) && ["real", "realistic"].contains(&cells[2])
        };
        let ratings: usize = means.lines().filter(cell).map(|l| l.split(',').nth(4).unwrap().parse::<usize>().unwrap()).sum();
        assert_eq!(ratings, 2 * 14, "{}: every screen stored as two ratings:\n{means}", backend.name());
    }
}
