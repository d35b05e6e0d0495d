-- Every trial save moves a participation's expiry; with the expiry in this index each save also
-- rewrote an index page. The reaper and the load count filter on the expiry after the index.
DROP INDEX participants_by_study_state;
CREATE INDEX participants_by_study_state ON participants (study_id, state);
