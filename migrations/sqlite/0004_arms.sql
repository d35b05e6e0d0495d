-- Between-subject arms (study::arm): the arms each stimulus belongs to (names separated by
-- spaces; empty when the design has none), and the arm each participation joined.
ALTER TABLE stimuli ADD COLUMN arms TEXT NOT NULL DEFAULT '';
ALTER TABLE participants ADD COLUMN arm TEXT NOT NULL DEFAULT '';
