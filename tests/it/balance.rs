//! Balanced assignment with concurrent participants, some abandoning, on each backend (an
//! SQLite file; a PostgreSQL database when there is a server, [`crate::backends`]).

use crate::backends::{Backend, TestDb, backends};
use facslab::db::Db;
use facslab::db::participants::{SaveTiming, Started};
use facslab::db::studies::StudyStimulus;
use facslab::study::measure::Measure;
use facslab::study::task::Judgement;
use facslab::study::{Answer, StudyDesign};

const DESIGN: &str = r#"
slug = "balance"
title = "Balance"
task = "emotion"
stimuli = "set"
trials_per_participant = 3
ratings_per_stimulus = 6
reservation_minutes = 30
demographics = false
consent = "ok"
instructions = "go"
debrief = "thanks"
"#;

/// An answer choosing "fear" (the emotion studies') or marking AU 1 (the coding studies').
fn answer(measure: Measure) -> Answer {
    let text = if measure == Measure::Emotion { "fear" } else { "1" };
    Answer(vec![Judgement { measure, value: measure.value(text, facslab::facs::Catalog::built_in()).expect("a value") }])
}

/// Runs one participant: completes all trials, or reserves and walks away.
async fn participant(db: Db, design: StudyDesign, study: i64, worker: String, abandons: bool) -> Option<bool> {
    let token = match db.start_participation(study, &design, &design.sources[0], &worker, "{}").await.unwrap() {
        Started::New(token) => token,
        Started::Existing(_) => unreachable!("workers are unique"),
        Started::Full => return None,
    };
    if abandons {
        return Some(false);
    }
    db.give_consent(&token, &design.consent_sha256()).await.unwrap();
    let p = db.participation(&token).await.unwrap().unwrap();
    for trial in db.trials(p.id).await.unwrap() {
        let key = format!("{token}-{}", trial.position);
        db.save_response(&token, trial.position, &key, &answer(design.measures()[0]), SaveTiming::default(), &design).await.unwrap();
    }
    Some(true)
}

#[tokio::test(flavor = "multi_thread")]
async fn balanced_assignment_ends_within_one_rating_of_the_target() {
    for backend in backends() {
        ends_within_one_rating_of_the_target(&backend).await;
    }
}

async fn ends_within_one_rating_of_the_target(backend: &Backend) {
    eprintln!("on {}", backend.name());
    let dir = tempfile::tempdir().unwrap();
    let store = TestDb::new(backend, dir.path());
    let db = Db::open(&store.url.parse::<facslab::db::DbUrl>().unwrap()).await.unwrap();
    let design = StudyDesign::from_toml(DESIGN).unwrap();
    let stimuli: Vec<StudyStimulus> = (0..10)
        .map(|i| StudyStimulus::still(facslab::stimuli::StimulusId::parse(&facslab::stimuli::stimulus_id(1, i)).unwrap()))
        .collect();
    let study = db.create_study(&design, DESIGN, "set", &stimuli, true).await.unwrap();

    let (mut completed, mut abandoned, mut worker) = (0, 0, 0);
    loop {
        // A wave of eight participants arriving together; every third walks away.
        let mut wave = Vec::new();
        for _ in 0..8 {
            worker += 1;
            wave.push(tokio::spawn(participant(db.clone(), design.clone(), study, format!("w{worker}"), worker % 3 == 0)));
        }
        let mut admitted = 0;
        for outcome in wave {
            match outcome.await.unwrap() {
                Some(true) => (completed, admitted) = (completed + 1, admitted + 1),
                Some(false) => (abandoned, admitted) = (abandoned + 1, admitted + 1),
                None => {}
            }
        }
        // The walk-aways' reservations time out, which frees their stimuli.
        db.reap(facslab::db::now_ms() + 31 * 60_000).await.unwrap();
        if admitted == 0 {
            break;
        }
        assert!(worker < 1000, "the study never filled");
    }

    let counts = db.completed_counts(study).await.unwrap();
    assert!(abandoned > 5 && completed >= 20, "completed {completed}, abandoned {abandoned}");
    for (stimulus, n) in &counts {
        assert!((6..=7).contains(n), "{stimulus} ended with {n} ratings (target 6, at most one over): {counts:?}");
    }
    let total: i64 = counts.iter().map(|(_, n)| n).sum();
    assert_eq!(total, completed as i64 * 3, "every completed participant rated three stimuli");
}

/// Entries shown together (`[au_coding] together`): only their leads are assigned and counted,
/// so the balance holds per entry and no stimulus shown beside a lead gets a trial of its own.
#[tokio::test(flavor = "multi_thread")]
async fn balanced_assignment_counts_an_entry_shown_together_once() {
    for backend in backends() {
        counts_an_entry_shown_together_once(&backend).await;
    }
}

async fn counts_an_entry_shown_together_once(backend: &Backend) {
    eprintln!("on {}", backend.name());
    let dir = tempfile::tempdir().unwrap();
    let store = TestDb::new(backend, dir.path());
    let db = Db::open(&store.url.parse::<facslab::db::DbUrl>().unwrap()).await.unwrap();
    let text = DESIGN.replace("task = \"emotion\"", "task = \"au_coding\"").replace("trials_per_participant = 3", "trials_per_participant = 2").replace("ratings_per_stimulus = 6", "ratings_per_stimulus = 4")
        + "[au_coding]\ntogether = true\n";
    let design = StudyDesign::from_toml(&text).unwrap();
    let id = |i| facslab::stimuli::StimulusId::parse(&facslab::stimuli::stimulus_id(2, i)).unwrap();
    // Five entries: a lead and three stills beside it.
    let stimuli: Vec<StudyStimulus> = (0..20)
        .map(|i| StudyStimulus { lead: (i % 4 != 0).then(|| id(i - i % 4)), part: (i % 4) as u32, ..StudyStimulus::still(id(i)) })
        .collect();
    let study = db.create_study(&design, &text, "set", &stimuli, true).await.unwrap();
    let mut leads: Vec<String> = (0..5).map(|e| id(4 * e).to_string()).collect();
    leads.sort();
    let mut completed = 0;
    while let Some(done) = participant(db.clone(), design.clone(), study, format!("c{completed}"), false).await {
        completed += usize::from(done);
        assert!(completed < 100, "the study never filled");
    }
    let counts = db.completed_counts(study).await.unwrap();
    assert_eq!(counts.iter().map(|(s, _)| s.to_string()).collect::<Vec<_>>(), leads);
    assert!(counts.iter().all(|(_, n)| *n == 4), "{counts:?}");
    // Every trial went to a lead: 5 entries × 4 codings, 2 per coder.
    assert_eq!(completed, 10);
}
