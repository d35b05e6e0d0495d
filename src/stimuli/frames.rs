//! Frames shared between the entries of one build.
//!
//! In: for every entry about to be rendered, the distinct frames it shows (person, size,
//! expression, style). Out: a store that keeps a rendered frame only while some entry that has not yet
//! finished still shows it, so a still that is also a frame of a clip (Exp. 1's 30/60/90 %
//! stills, Exp. 3's 50/100 % images) or the neutral first frame of every clip of one person is
//! rendered once. Frames that only one entry shows are never kept here.
//!
//! Invariant: the store never changes a picture. A frame is the same bytes whoever renders it
//! (the engine is deterministic), so taking it from the store or rendering it again differ only
//! in time; when two entries need a frame at the same moment both may render it.

use std::collections::{BTreeSet, HashMap};
use std::sync::{Arc, Mutex};

use crate::engine::image::RgbImage;
use crate::engine::Style;

/// What makes two frames the same picture.
#[derive(Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct FrameKey {
    pub identity: String,
    pub size: (u32, u32),
    /// The expression in FACS notation, as the engine renders it.
    pub expression: String,
    /// How the face is drawn (a cartoon frame is another picture than the realistic one).
    pub style: Style,
}

impl FrameKey {
    /// The key of a realistic frame.
    pub fn new(identity: &str, size: (u32, u32), expression: &impl std::fmt::Display) -> FrameKey {
        FrameKey { identity: identity.to_string(), size, expression: expression.to_string(), style: Style::Realistic }
    }

    /// The same frame drawn in `style`.
    pub fn in_style(self, style: Style) -> FrameKey {
        FrameKey { style, ..self }
    }
}

/// Rendered frames that more than one entry of a build shows.
pub struct SharedFrames {
    /// The most bytes of frames kept at once; beyond it, frames are rendered again instead.
    budget: usize,
    state: Mutex<State>,
}

#[derive(Default)]
struct State {
    /// For each shared frame, how many entries have not yet released it.
    remaining: HashMap<FrameKey, usize>,
    kept: HashMap<FrameKey, Arc<RgbImage>>,
    bytes: usize,
}

impl SharedFrames {
    /// A store for entries showing `frames` (one list of distinct frames per entry), keeping
    /// at most `budget` bytes of frames.
    pub fn new(frames: impl IntoIterator<Item = BTreeSet<FrameKey>>, budget: usize) -> SharedFrames {
        let mut remaining: HashMap<FrameKey, usize> = HashMap::new();
        for entry in frames {
            for key in entry {
                *remaining.entry(key).or_default() += 1;
            }
        }
        remaining.retain(|_, users| *users > 1);
        SharedFrames { budget, state: Mutex::new(State { remaining, ..State::default() }) }
    }

    fn state(&self) -> std::sync::MutexGuard<'_, State> {
        // Nothing panics while the lock is held, so a poisoned lock still guards consistent maps.
        self.state.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
    }

    /// The frame, if another entry has rendered it and it is still kept.
    pub fn get(&self, key: &FrameKey) -> Option<Arc<RgbImage>> {
        self.state().kept.get(key).cloned()
    }

    /// Offers a freshly rendered frame: kept if another entry will still show it.
    pub fn offer(&self, key: &FrameKey, image: &Arc<RgbImage>) {
        let mut state = self.state();
        let wanted = state.remaining.get(key).is_some_and(|&users| users > 1);
        if wanted && !state.kept.contains_key(key) && state.bytes + image.data.len() <= self.budget {
            state.bytes += image.data.len();
            state.kept.insert(key.clone(), Arc::clone(image));
        }
    }

    /// An entry is done with `keys`: frames no entry still needs are let go.
    pub fn release<'a>(&self, keys: impl IntoIterator<Item = &'a FrameKey>) {
        let mut state = self.state();
        for key in keys {
            let Some(users) = state.remaining.get_mut(key) else { continue };
            *users -= 1;
            if *users == 0 {
                state.remaining.remove(key);
                if let Some(image) = state.kept.remove(key) {
                    state.bytes -= image.data.len();
                }
            }
        }
    }

    /// Frames kept right now (for tests).
    pub fn kept(&self) -> usize {
        self.state().kept.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn key(expression: &str) -> FrameKey {
        FrameKey::new("wm1", (4, 4), &expression)
    }

    fn image() -> Arc<RgbImage> {
        Arc::new(RgbImage::new(4, 4))
    }

    #[test]
    fn a_frame_is_kept_until_its_last_entry_is_done() {
        let clip: BTreeSet<FrameKey> = ["0", "12@0.5", "12@1"].map(key).into();
        let still: BTreeSet<FrameKey> = ["12@0.5"].map(key).into();
        let other: BTreeSet<FrameKey> = ["0"].map(key).into();
        let store = SharedFrames::new([clip.clone(), still.clone(), other.clone()], usize::MAX);
        for k in &clip {
            store.offer(k, &image());
        }
        assert_eq!(store.kept(), 2, "the neutral and the 50 % frames are shown again; the apex is not");
        store.release(&clip);
        assert!(store.get(&key("12@0.5")).is_some());
        store.release(&still);
        assert!(store.get(&key("12@0.5")).is_none(), "its last entry is done");
        assert!(store.get(&key("0")).is_some());
        store.release(&other);
        assert_eq!(store.kept(), 0);
    }

    #[test]
    fn the_budget_bounds_what_is_kept() {
        let a: BTreeSet<FrameKey> = ["1", "2"].map(key).into();
        let store = SharedFrames::new([a.clone(), a.clone()], image().data.len());
        store.offer(&key("1"), &image());
        store.offer(&key("2"), &image());
        assert_eq!(store.kept(), 1);
        store.release(&a);
        store.release(&a);
        assert_eq!(store.kept(), 0);
    }
}
