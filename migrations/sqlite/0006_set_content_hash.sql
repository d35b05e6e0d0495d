-- The content hash of a study's stimulus set (`stimuli::manifest::set_sha256`: the SHA-256 of
-- its manifest, which holds every media file's SHA-256), recorded when the study is created, so
-- that a server whose copy of the set differs refuses to serve it. NULL for studies made before.
ALTER TABLE studies ADD COLUMN set_sha256 TEXT;
