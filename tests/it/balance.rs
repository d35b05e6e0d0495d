//! Balanced assignment on a real SQLite file with concurrent participants, some abandoning.

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
        let fear = Measure::Emotion.value("fear", facslab::facs::Catalog::built_in()).expect("a label");
        let answer = Answer(vec![Judgement { measure: Measure::Emotion, value: fear }]);
        let key = format!("{token}-{}", trial.position);
        db.save_response(&token, trial.position, &key, &answer, SaveTiming::default(), &design).await.unwrap();
    }
    Some(true)
}

#[tokio::test(flavor = "multi_thread")]
async fn balanced_assignment_ends_within_one_rating_of_the_target() {
    let dir = tempfile::tempdir().unwrap();
    let db = Db::open(&dir.path().join("balance.db")).await.unwrap();
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
