-- A trial that shows several media of one stimulus-set entry (`[au_coding] together = true`):
-- the entry's lead stimulus (its video) has the trial and takes the judgement; each other
-- stimulus of the entry names its lead (`lead`) and its place beside it (`part`, 1-based, stills
-- by rising intensity). A stimulus with a trial of its own has no lead and part 0. Videos keep
-- the set's frame rate (`fps`), which sets the length of one frame step on the trial page.
ALTER TABLE stimuli ADD COLUMN lead TEXT;
ALTER TABLE stimuli ADD COLUMN part INTEGER NOT NULL DEFAULT 0;
ALTER TABLE stimuli ADD COLUMN fps INTEGER;

-- How the participant viewed the trial's media (`study::viewing`: replays, frame steps,
-- playback speeds, time on task), as JSON; NULL for a save without the page script.
ALTER TABLE responses ADD COLUMN viewing TEXT;
