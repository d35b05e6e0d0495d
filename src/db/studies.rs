//! Studies and their stimuli: create from a design and a built set, list, open and close.

use sqlx::Row;

use super::{Db, DbError, now_ms};
use crate::study::StudyDesign;

/// A study as stored.
#[derive(Debug, Clone, serde::Serialize)]
pub struct StudyRow {
    pub id: i64,
    pub slug: String,
    pub title: String,
    pub status: String,
    pub set_dir: String,
    #[serde(skip)]
    pub spec_toml: String,
}

impl StudyRow {
    /// The design, parsed again from the stored TOML (it was validated on creation).
    pub fn design(&self) -> Result<StudyDesign, DbError> {
        StudyDesign::from_toml(&self.spec_toml).map_err(|e| DbError::Internal(format!("stored design of \"{}\" no longer valid: {e}", self.slug)))
    }
}

/// One stimulus a study shows.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct StudyStimulus {
    pub stimulus_id: String,
    pub media: String,
    pub file: String,
    pub emotion: String,
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
    pub stimuli: i64,
}

fn study_row(row: sqlx::sqlite::SqliteRow) -> StudyRow {
    StudyRow {
        id: row.get("id"),
        slug: row.get("slug"),
        title: row.get("title"),
        status: row.get("status"),
        set_dir: row.get("set_dir"),
        spec_toml: row.get("spec_toml"),
    }
}

impl Db {
    /// Stores a study (as `draft`, or `open` when asked) with the stimuli it shows.
    pub async fn create_study(&self, design: &StudyDesign, spec_toml: &str, set_dir: &str, stimuli: &[StudyStimulus], open: bool) -> Result<i64, DbError> {
        let mut tx = self.immediate().await?;
        let exists = sqlx::query("SELECT 1 FROM studies WHERE slug = ?").bind(&design.slug).fetch_optional(&mut *tx).await?;
        if exists.is_some() {
            return Err(DbError::Conflict(format!("a study \"{}\" exists already", design.slug)));
        }
        let id: i64 = sqlx::query("INSERT INTO studies (slug, title, spec_toml, set_dir, status, created_at) VALUES (?, ?, ?, ?, ?, ?) RETURNING id")
            .bind(&design.slug)
            .bind(&design.title)
            .bind(spec_toml)
            .bind(set_dir)
            .bind(if open { "open" } else { "draft" })
            .bind(now_ms())
            .fetch_one(&mut *tx)
            .await?
            .get(0);
        for s in stimuli {
            sqlx::query("INSERT INTO stimuli (study_id, stimulus_id, media, file, emotion) VALUES (?, ?, ?, ?, ?)")
                .bind(id)
                .bind(&s.stimulus_id)
                .bind(&s.media)
                .bind(&s.file)
                .bind(&s.emotion)
                .execute(&mut *tx)
                .await?;
        }
        tx.commit().await?;
        Ok(id)
    }

    /// Creates a study from a design's TOML text over the built set in `set_dir` (stored as an
    /// absolute path, so the server finds the media whatever its working directory).
    pub async fn create_study_from(&self, spec_toml: &str, set_dir: &std::path::Path, open: bool) -> Result<StudyDesign, DbError> {
        let design = StudyDesign::from_toml(spec_toml)?;
        let stimuli = set_stimuli(set_dir, design.media)?;
        let set_dir = std::path::absolute(set_dir).unwrap_or_else(|_| set_dir.to_path_buf());
        self.create_study(&design, spec_toml, &set_dir.to_string_lossy(), &stimuli, open).await?;
        Ok(design)
    }

    pub async fn study_by_slug(&self, slug: &str) -> Result<Option<StudyRow>, DbError> {
        Ok(sqlx::query("SELECT * FROM studies WHERE slug = ?").bind(slug).fetch_optional(&self.reader).await?.map(study_row))
    }

    pub async fn study_by_id(&self, id: i64) -> Result<Option<StudyRow>, DbError> {
        Ok(sqlx::query("SELECT * FROM studies WHERE id = ?").bind(id).fetch_optional(&self.reader).await?.map(study_row))
    }

    pub async fn studies(&self) -> Result<Vec<StudyRow>, DbError> {
        Ok(sqlx::query("SELECT * FROM studies ORDER BY id").fetch_all(&self.reader).await?.into_iter().map(study_row).collect())
    }

    /// Sets `draft`, `open` or `closed`.
    pub async fn set_study_status(&self, slug: &str, status: &str) -> Result<(), DbError> {
        let done = sqlx::query("UPDATE studies SET status = ? WHERE slug = ?").bind(status).bind(slug).execute(&self.writer).await?;
        if done.rows_affected() == 0 {
            return Err(DbError::NotFound(format!("no study \"{slug}\"")));
        }
        Ok(())
    }

    pub async fn study_stimuli(&self, study_id: i64) -> Result<Vec<StudyStimulus>, DbError> {
        let rows = sqlx::query("SELECT stimulus_id, media, file, emotion FROM stimuli WHERE study_id = ? ORDER BY stimulus_id")
            .bind(study_id)
            .fetch_all(&self.reader)
            .await?;
        Ok(rows
            .into_iter()
            .map(|r| StudyStimulus { stimulus_id: r.get(0), media: r.get(1), file: r.get(2), emotion: r.get(3) })
            .collect())
    }

    pub async fn progress(&self, study_id: i64) -> Result<Progress, DbError> {
        let mut p = Progress::default();
        let rows = sqlx::query("SELECT state, COUNT(*), SUM(excluded) FROM participants WHERE study_id = ? GROUP BY state")
            .bind(study_id)
            .fetch_all(&self.reader)
            .await?;
        for row in rows {
            let (state, n, excluded): (String, i64, i64) = (row.get(0), row.get(1), row.get(2));
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
        p.responses = sqlx::query("SELECT COUNT(*) FROM responses r JOIN participants p ON p.id = r.participant_id WHERE p.study_id = ?")
            .bind(study_id)
            .fetch_one(&self.reader)
            .await?
            .get(0);
        p.stimuli = sqlx::query("SELECT COUNT(*) FROM stimuli WHERE study_id = ?").bind(study_id).fetch_one(&self.reader).await?.get(0);
        Ok(p)
    }

    /// Completed, non-excluded main-trial responses per stimulus (for balance checks and the dashboard).
    pub async fn completed_counts(&self, study_id: i64) -> Result<Vec<(String, i64)>, DbError> {
        let rows = sqlx::query(
            "SELECT s.stimulus_id, COUNT(r.id) FROM stimuli s
             LEFT JOIN trials t ON t.stimulus_id = s.stimulus_id AND t.kind = 'trial'
                 AND t.participant_id IN (SELECT id FROM participants WHERE study_id = ?1 AND state = 'completed' AND excluded = 0)
             LEFT JOIN responses r ON r.participant_id = t.participant_id AND r.position = t.position
             WHERE s.study_id = ?1 GROUP BY s.stimulus_id ORDER BY s.stimulus_id",
        )
        .bind(study_id)
        .fetch_all(&self.reader)
        .await?;
        Ok(rows.into_iter().map(|r| (r.get(0), r.get(1))).collect())
    }
}

/// The stimuli of a built set (its `manifest.json`) that a design admits, checked to exist.
pub fn set_stimuli(set_dir: &std::path::Path, media: crate::study::design::MediaFilter) -> Result<Vec<StudyStimulus>, DbError> {
    let manifest = set_dir.join("manifest.json");
    let text = std::fs::read_to_string(&manifest).map_err(|e| DbError::NotFound(format!("{}: {e} (build the set first: facslab stimuli build SPEC -o DIR)", manifest.display())))?;
    let rows: Vec<crate::stimuli::manifest::ManifestRow> = serde_json::from_str(&text).map_err(|e| DbError::Invalid(format!("{}: {e}", manifest.display())))?;
    let mut stimuli = Vec::new();
    for row in rows.into_iter().filter(|r| media.admits(&r.media)) {
        let relative = std::path::Path::new(&row.file);
        if !crate::stimuli::manifest::is_media_path(&row.file) {
            let shown: String = row.file.chars().take(80).collect();
            return Err(DbError::Invalid(format!("{}: stimulus {}: file `{shown}` is not in the set's media/ directory", manifest.display(), row.stimulus_id)));
        }
        if !set_dir.join(relative).is_file() {
            return Err(DbError::NotFound(format!("{}: the file of stimulus {} is missing: {}", manifest.display(), row.stimulus_id, row.file)));
        }
        stimuli.push(StudyStimulus { stimulus_id: row.stimulus_id, media: row.media, file: row.file, emotion: row.emotion });
    }
    if stimuli.is_empty() {
        return Err(DbError::Invalid(format!("{}: no stimuli of the media this study asks for", manifest.display())));
    }
    Ok(stimuli)
}
