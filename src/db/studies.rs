//! Studies and their stimuli: create from a design and a built set, list, open and close.
//!
//! In: a design's TOML and a built set's manifest. Out: typed rows. A study's status is a
//! [`StudyStatus`], a stimulus's id a [`StimulusId`] and its kind a [`Media`]: each is parsed
//! when read (from the manifest or the database), and a stored value that is none of them is a
//! [`DbError::Internal`] naming it.

use super::{Db, DbError, Fields, now_ms, on_backend};
use crate::stimuli::manifest::{Media, StimulusId};
use crate::study::StudyDesign;

/// Where a study stands: participants can start only while it is open.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum StudyStatus {
    /// Being prepared; no participant can start.
    Draft,
    /// Taking participants.
    Open,
    /// No new participants; the data stay.
    Closed,
}

impl StudyStatus {
    pub const ALL: [StudyStatus; 3] = [StudyStatus::Draft, StudyStatus::Open, StudyStatus::Closed];

    pub fn as_str(self) -> &'static str {
        match self {
            StudyStatus::Draft => "draft",
            StudyStatus::Open => "open",
            StudyStatus::Closed => "closed",
        }
    }

    pub fn parse(text: &str) -> Option<StudyStatus> {
        StudyStatus::ALL.into_iter().find(|s| s.as_str() == text)
    }
}

impl std::fmt::Display for StudyStatus {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.pad(self.as_str())
    }
}

/// A stored value that should be one of a few spellings, parsed, or an internal error naming
/// what it was and where it was read.
pub(crate) fn stored<T>(parsed: Option<T>, what: &str, value: &str) -> Result<T, DbError> {
    let shown: String = value.chars().take(40).collect();
    parsed.ok_or_else(|| DbError::Internal(format!("the database holds an unknown {what} \"{shown}\"")))
}

/// A study as stored.
#[derive(Debug, Clone, serde::Serialize)]
pub struct StudyRow {
    pub id: i64,
    pub slug: String,
    pub title: String,
    pub status: StudyStatus,
    pub set_dir: String,
    /// The set's content hash when the study was made ([`set_sha256`]; `None` for studies made
    /// before it was recorded).
    #[serde(skip)]
    pub set_sha256: Option<String>,
    #[serde(skip)]
    pub spec_toml: String,
}

impl StudyRow {
    /// The design, parsed again from the stored TOML (it was validated on creation), after the
    /// label sets its stimulus set carries are registered (a design may name one of them).
    pub fn design(&self) -> Result<StudyDesign, DbError> {
        crate::stimuli::labels::register_set(std::path::Path::new(&self.set_dir)).map_err(|e| DbError::Internal(format!("study \"{}\": {e}", self.slug)))?;
        StudyDesign::from_toml(&self.spec_toml).map_err(|e| DbError::Internal(format!("stored design of \"{}\" no longer valid: {e}", self.slug)))
    }
}

/// One stimulus a study shows.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct StudyStimulus {
    pub stimulus_id: StimulusId,
    pub media: Media,
    pub file: String,
    pub emotion: String,
    /// The design's arms this stimulus belongs to (`study::arm`; empty without arms).
    pub arms: Vec<String>,
    /// The stimulus whose trial shows this one beside it (`[au_coding] together`); `None`: it
    /// has trials of its own.
    pub lead: Option<StimulusId>,
    /// Its place beside its lead (1-based; 0 for a stimulus without a lead).
    pub part: u32,
    /// A video's frame rate (the length of one frame step).
    pub fps: Option<u32>,
}

impl StudyStimulus {
    /// The still `media/<id>.png` without an emotion label.
    pub fn still(stimulus_id: StimulusId) -> StudyStimulus {
        let file = format!("media/{stimulus_id}.png");
        StudyStimulus { stimulus_id, media: Media::Image, file, emotion: String::new(), arms: Vec::new(), lead: None, part: 0, fps: None }
    }

    /// Whether participants get trials of this stimulus (it is not only shown beside another).
    pub fn has_trials(&self) -> bool {
        self.lead.is_none()
    }
}

/// The ids of the stimuli that have trials, sorted (the wide export's columns).
pub fn trial_stimulus_ids<'a>(stimuli: impl IntoIterator<Item = &'a StudyStimulus>) -> Vec<StimulusId> {
    let mut ids: Vec<StimulusId> = stimuli.into_iter().filter(|s| s.has_trials()).map(|s| s.stimulus_id.clone()).collect();
    ids.sort();
    ids
}

/// Participation counts of one study, for the dashboard.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct Progress {
    pub reserved: i64,
    pub active: i64,
    pub completed: i64,
    pub abandoned: i64,
    pub withdrawn: i64,
    pub screened_out: i64,
    pub excluded: i64,
    pub responses: i64,
    /// Stimuli with trials of their own: an entry shown together (`[au_coding] together`)
    /// counts once.
    pub stimuli: i64,
}

fn study_row(row: &impl Fields) -> Result<StudyRow, DbError> {
    let status: String = row.get("status");
    Ok(StudyRow {
        id: row.get("id"),
        slug: row.get("slug"),
        title: row.get("title"),
        status: stored(StudyStatus::parse(&status), "study status", &status)?,
        set_dir: row.get("set_dir"),
        set_sha256: row.get("set_sha256"),
        spec_toml: row.get("spec_toml"),
    })
}

fn study_stimulus(row: &impl Fields) -> Result<StudyStimulus, DbError> {
    let (id, media, lead): (String, String, Option<String>) = (row.get(0), row.get(1), row.get(4));
    let id = id.as_str();
    Ok(StudyStimulus {
        stimulus_id: stored(StimulusId::parse(id).ok(), "stimulus id", id)?,
        media: stored(Media::parse(&media), "media kind", &media)?,
        file: row.get(2),
        emotion: row.get(3),
        lead: lead.map(|lead| stored(StimulusId::parse(&lead).ok(), "lead stimulus id", &lead)).transpose()?,
        part: row.get::<i64, _>(5).try_into().map_err(|_| DbError::Internal(format!("stimulus {id} has a negative part")))?,
        fps: row.get::<Option<i64>, _>(6).and_then(|fps| u32::try_from(fps).ok()),
        arms: row.get::<String, _>(7).split_whitespace().map(str::to_string).collect(),
    })
}

impl Db {
    /// Stores a study (as `draft`, or `open` when asked) with the stimuli it shows.
    pub async fn create_study(&self, design: &StudyDesign, spec_toml: &str, set_dir: &str, stimuli: &[StudyStimulus], open: bool) -> Result<i64, DbError> {
        self.store_study(design, spec_toml, (set_dir, None), stimuli, open).await
    }

    /// [`Db::create_study`] over `set` (its directory and, when known, its content hash
    /// [`set_sha256`], which servers check their copy against).
    async fn store_study(&self, design: &StudyDesign, spec_toml: &str, set: (&str, Option<&str>), stimuli: &[StudyStimulus], open: bool) -> Result<i64, DbError> {
        let (set_dir, set_sha256) = set;
        on_backend!(self, b => {
        let mut tx = b.immediate().await?;
        let exists = sqlx::query("SELECT 1 FROM studies WHERE slug = $1").bind(&design.slug).fetch_optional(&mut *tx).await?;
        if exists.is_some() {
            return Err(DbError::Conflict(format!("a study \"{}\" exists already", design.slug)));
        }
        let id: i64 = sqlx::query("INSERT INTO studies (slug, title, spec_toml, set_dir, status, created_at, set_sha256) VALUES ($1, $2, $3, $4, $5, $6, $7) RETURNING id")
            .bind(&design.slug)
            .bind(&design.title)
            .bind(spec_toml)
            .bind(set_dir)
            .bind(if open { StudyStatus::Open } else { StudyStatus::Draft }.as_str())
            .bind(now_ms())
            .bind(set_sha256)
            .fetch_one(&mut *tx)
            .await?
            .get(0);
        for s in stimuli {
            sqlx::query("INSERT INTO stimuli (study_id, stimulus_id, media, file, emotion, lead, part, fps, arms) VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9)")
                .bind(id)
                .bind(s.stimulus_id.as_str())
                .bind(s.media.as_str())
                .bind(&s.file)
                .bind(&s.emotion)
                .bind(s.lead.as_ref().map(StimulusId::as_str))
                .bind(i64::from(s.part))
                .bind(s.fps.map(i64::from))
                .bind(s.arms.join(" "))
                .execute(&mut *tx)
                .await?;
        }
        tx.commit().await?;
        Ok(id)
        })
    }

    /// Creates a study from a design's TOML text over the built set in `set_dir` (stored as an
    /// absolute path, so the server finds the media whatever its working directory).
    pub async fn create_study_from(&self, spec_toml: &str, set_dir: &std::path::Path, open: bool) -> Result<StudyDesign, DbError> {
        crate::stimuli::labels::register_set(set_dir).map_err(|e| DbError::Invalid(e.to_string()))?;
        let design = StudyDesign::from_toml(spec_toml)?;
        let stimuli = set_stimuli(set_dir, &design)?;
        let hash = set_sha256(set_dir)?;
        let set_dir = std::path::absolute(set_dir).unwrap_or_else(|_| set_dir.to_path_buf());
        self.store_study(&design, spec_toml, (&set_dir.to_string_lossy(), Some(&hash)), &stimuli, open).await?;
        Ok(design)
    }

    pub async fn study_by_slug(&self, slug: &str) -> Result<Option<StudyRow>, DbError> {
        on_backend!(self, b => sqlx::query("SELECT * FROM studies WHERE slug = $1").bind(slug).fetch_optional(&b.reader).await?.map(|r| study_row(&r)).transpose())
    }

    pub async fn study_by_id(&self, id: i64) -> Result<Option<StudyRow>, DbError> {
        on_backend!(self, b => sqlx::query("SELECT * FROM studies WHERE id = $1").bind(id).fetch_optional(&b.reader).await?.map(|r| study_row(&r)).transpose())
    }

    pub async fn studies(&self) -> Result<Vec<StudyRow>, DbError> {
        on_backend!(self, b => sqlx::query("SELECT * FROM studies ORDER BY id").fetch_all(&b.reader).await?.iter().map(study_row).collect())
    }

    pub async fn set_study_status(&self, slug: &str, status: StudyStatus) -> Result<(), DbError> {
        let sql = "UPDATE studies SET status = $1 WHERE slug = $2";
        let done = on_backend!(self, b => sqlx::query(sql).bind(status.as_str()).bind(slug).execute(&b.writer).await?.rows_affected());
        if done == 0 {
            return Err(DbError::NotFound(format!("no study \"{slug}\"")));
        }
        Ok(())
    }

    pub async fn study_stimuli(&self, study_id: i64) -> Result<Vec<StudyStimulus>, DbError> {
        let sql = "SELECT stimulus_id, media, file, emotion, lead, part, fps, arms FROM stimuli WHERE study_id = $1 ORDER BY stimulus_id";
        on_backend!(self, b => sqlx::query(sql).bind(study_id).fetch_all(&b.reader).await?.iter().map(study_stimulus).collect())
    }

    pub async fn progress(&self, study_id: i64) -> Result<Progress, DbError> {
        let mut p = Progress::default();
        let sql = "SELECT state, COUNT(*), SUM(CASE WHEN excluded THEN 1 ELSE 0 END) FROM participants WHERE study_id = $1 GROUP BY state";
        let rows: Vec<(String, i64, i64)> = on_backend!(self, b => sqlx::query_as(sql).bind(study_id).fetch_all(&b.reader).await?);
        for (state, n, excluded) in rows {
            p.excluded += excluded;
            match state.as_str() {
                "reserved" => p.reserved = n,
                "active" => p.active = n,
                "completed" => p.completed = n,
                "abandoned" => p.abandoned = n,
                "withdrawn" => p.withdrawn = n,
                _ => p.screened_out = n,
            }
        }
        let responses = "SELECT COUNT(*) FROM responses r JOIN participants p ON p.id = r.participant_id WHERE p.study_id = $1";
        p.responses = on_backend!(self, b => sqlx::query_scalar(responses).bind(study_id).fetch_one(&b.reader).await?);
        let stimuli = "SELECT COUNT(*) FROM stimuli WHERE study_id = $1 AND lead IS NULL";
        p.stimuli = on_backend!(self, b => sqlx::query_scalar(stimuli).bind(study_id).fetch_one(&b.reader).await?);
        Ok(p)
    }

    /// Completed, non-excluded main-trial responses per stimulus that has trials (for balance
    /// checks and the dashboard).
    pub async fn completed_counts(&self, study_id: i64) -> Result<Vec<(StimulusId, i64)>, DbError> {
        let sql = "SELECT s.stimulus_id, COUNT(r.id) FROM stimuli s
             LEFT JOIN trials t ON t.stimulus_id = s.stimulus_id AND t.kind = 'trial'
                 AND t.participant_id IN (SELECT id FROM participants WHERE study_id = $1 AND state = 'completed' AND NOT excluded)
             LEFT JOIN responses r ON r.participant_id = t.participant_id AND r.position = t.position
             WHERE s.study_id = $1 AND s.lead IS NULL GROUP BY s.stimulus_id ORDER BY s.stimulus_id";
        let rows: Vec<(String, i64)> = on_backend!(self, b => sqlx::query_as(sql).bind(study_id).fetch_all(&b.reader).await?);
        rows.into_iter().map(|(id, n)| Ok((stored(StimulusId::parse(&id).ok(), "stimulus id", &id)?, n))).collect()
    }
}

/// The content hash of a built set: the SHA-256 of its `manifest.json`, which holds the SHA-256
/// of every media file.
pub fn set_sha256(set_dir: &std::path::Path) -> Result<String, DbError> {
    let manifest = set_dir.join("manifest.json");
    let bytes = std::fs::read(&manifest).map_err(|e| DbError::NotFound(format!("{}: {e}", manifest.display())))?;
    Ok(crate::stimuli::build::sha256_hex(&bytes))
}

/// Checks that `set_dir` holds the set a study was made with (`recorded`, its [`set_sha256`]):
/// the manifest has that hash, and each of `files` (the study's media, relative to the set) has
/// the SHA-256 its manifest row records. A copy that differs is a [`DbError::Conflict`] saying
/// which file, so a server never shows other media than the study's.
pub fn check_set_copy(set_dir: &std::path::Path, recorded: &str, files: &[&str]) -> Result<(), DbError> {
    let differs = |what: String| DbError::Conflict(format!("this server's copy of the stimulus set in {} differs from the set the study was made with: {what}; copy the set again", set_dir.display()));
    let here = set_sha256(set_dir)?;
    if here != recorded {
        return Err(differs(format!("its manifest.json has SHA-256 {here}, the study recorded {recorded}")));
    }
    let (_, rows) = set_manifest(set_dir)?;
    for row in rows.iter().filter(|r| files.contains(&r.file.as_str())) {
        let bytes = std::fs::read(set_dir.join(&row.file)).map_err(|e| differs(format!("{}: {e}", row.file)))?;
        if crate::stimuli::build::sha256_hex(&bytes) != row.sha256 {
            return Err(differs(format!("{} is not the file its manifest describes (SHA-256)", row.file)));
        }
    }
    Ok(())
}

/// The rows of a built set's `manifest.json`, with the file's path for messages.
pub(crate) fn set_manifest(set_dir: &std::path::Path) -> Result<(std::path::PathBuf, Vec<crate::stimuli::manifest::ManifestRow>), DbError> {
    let manifest = set_dir.join("manifest.json");
    let text = std::fs::read_to_string(&manifest).map_err(|e| DbError::NotFound(format!("{}: {e} (build the set first: facslab stimuli build SPEC -o DIR)", manifest.display())))?;
    let rows = serde_json::from_str(&text).map_err(|e| DbError::Invalid(format!("{}: {e}", manifest.display())))?;
    Ok((manifest, rows))
}

/// The stimuli of a built set (its `manifest.json`) that a design admits, checked to exist; with
/// `[au_coding] together`, each names the lead of its entry ([`crate::study::entry`]).
pub fn set_stimuli(set_dir: &std::path::Path, design: &crate::study::StudyDesign) -> Result<Vec<StudyStimulus>, DbError> {
    let (manifest, rows) = set_manifest(set_dir)?;
    let rows: Vec<_> = rows.into_iter().filter(|r| design.admits(r.media, r.intensity)).collect();
    let mut stimuli = Vec::new();
    for row in &rows {
        let id = StimulusId::parse(&row.stimulus_id).map_err(|e| DbError::Invalid(format!("{}: {e}", manifest.display())))?;
        let relative = std::path::Path::new(&row.file);
        if !crate::stimuli::manifest::is_media_path(&row.file) {
            let shown: String = row.file.chars().take(80).collect();
            return Err(DbError::Invalid(format!("{}: stimulus {}: file `{shown}` is not in the set's media/ directory", manifest.display(), row.stimulus_id)));
        }
        if !set_dir.join(relative).is_file() {
            return Err(DbError::NotFound(format!("{}: the file of stimulus {} is missing: {}", manifest.display(), row.stimulus_id, row.file)));
        }
        let fps = row.fps.filter(|_| row.media == Media::Video);
        let arms = design.arms.iter().filter(|a| a.admits(row.media, row.intensity)).map(|a| a.name.clone()).collect();
        stimuli.push(StudyStimulus { stimulus_id: id, media: row.media, file: row.file.clone(), emotion: row.emotion.clone(), arms, lead: None, part: 0, fps });
    }
    if stimuli.is_empty() {
        return Err(DbError::Invalid(format!("{}: no stimuli of the media this study asks for", manifest.display())));
    }
    if design.rating.side_by_side {
        check_screens(&stimuli).map_err(|e| DbError::Invalid(format!("{}: {e}", manifest.display())))?;
    }
    if crate::study::entry::together(design) {
        let places = crate::study::entry::places(&rows).map_err(|e| DbError::Invalid(format!("{}: {e}", manifest.display())))?;
        for (i, place) in places.into_iter().enumerate() {
            if let crate::study::entry::Place::Beside { lead, part } = place {
                stimuli[i].lead = Some(stimuli[lead].stimulus_id.clone());
                stimuli[i].part = part;
            }
        }
    }
    if let Some(empty) = design.arms.iter().find(|a| !stimuli.iter().any(|s| s.arms.contains(&a.name))) {
        return Err(DbError::Invalid(format!("{}: arm \"{}\" admits none of the study's stimuli (check its media and intensities)", manifest.display(), empty.name)));
    }
    Ok(stimuli)
}

/// How many of `stimuli` each label (the manifest's `emotion`) has.
pub fn stimuli_per_label<'a>(stimuli: impl IntoIterator<Item = &'a StudyStimulus>) -> std::collections::BTreeMap<&'a str, usize> {
    let mut per_label = std::collections::BTreeMap::new();
    for s in stimuli {
        *per_label.entry(s.emotion.as_str()).or_default() += 1;
    }
    per_label
}

/// With `[rating] side_by_side`, each label's stimuli fit on one screen.
fn check_screens(stimuli: &[StudyStimulus]) -> Result<(), String> {
    let max = crate::study::screen::MAX_SIDE_BY_SIDE;
    match stimuli_per_label(stimuli).into_iter().find(|(_, n)| *n > max) {
        Some((label, n)) => Err(format!("label \"{}\" has {n} stimuli, more than the {max} that [rating] side_by_side shows on one screen", crate::study::excerpt(label, 64))),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[tokio::test]
    async fn stored_values_that_are_none_of_the_spellings_are_named() {
        let dir = tempfile::tempdir().expect("temp dir");
        let db = Db::open(&dir.path().join("studies.db")).await.expect("database");
        let rows = "PRAGMA ignore_check_constraints = ON;
             INSERT INTO studies (id, slug, title, spec_toml, set_dir, status, created_at) VALUES (1, 'old', 'Old', '', 'set', 'paused', 0);
             INSERT INTO stimuli (study_id, stimulus_id, media, file, emotion) VALUES (1, 's01', 'image', 'media/s01.png', '');
             PRAGMA ignore_check_constraints = OFF;";
        sqlx::raw_sql(rows).execute(&db.sqlite().writer).await.expect("rows");
        let status = db.study_by_slug("old").await.expect_err("an unknown status");
        assert!(matches!(&status, DbError::Internal(m) if m.contains("unknown study status \"paused\"")), "{status}");
        let id = db.study_stimuli(1).await.expect_err("an unknown stimulus id");
        assert!(matches!(&id, DbError::Internal(m) if m.contains("unknown stimulus id \"s01\"")), "{id}");
    }

    #[test]
    fn a_label_with_more_stimuli_than_a_screen_shows_is_refused_by_name() {
        let stimulus = |i: usize, label: &str| StudyStimulus { emotion: label.to_string(), ..StudyStimulus::still(StimulusId::parse(&crate::stimuli::stimulus_id(1, i)).expect("id")) };
        let mut stimuli: Vec<StudyStimulus> = (0..4).map(|i| stimulus(i, "laughs:laughter")).collect();
        stimuli.push(stimulus(4, "laughs:sly_smile"));
        assert_eq!(check_screens(&stimuli), Ok(()), "four on one screen");
        stimuli.push(stimulus(5, "laughs:laughter"));
        let e = check_screens(&stimuli).expect_err("five of one label");
        assert!(e.contains("label \"laughs:laughter\" has 5 stimuli, more than the 4"), "{e}");
    }

    #[test]
    fn statuses_have_one_spelling() {
        for status in StudyStatus::ALL {
            assert_eq!(StudyStatus::parse(status.as_str()), Some(status));
            assert_eq!(serde_json::to_value(status).expect("json"), status.as_str());
        }
        assert_eq!(StudyStatus::parse("paused"), None);
        assert_eq!(format!("{:<7}|", StudyStatus::Open), "open   |");
    }
}
