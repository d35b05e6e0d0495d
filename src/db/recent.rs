//! A bounded in-memory map of recently used entries, for facts that never change once written
//! (which study a participation token belongs to).
//!
//! Two generations: entries go into the current one; when it holds `capacity` entries it
//! becomes the previous one and the older generation is dropped. A hit in the previous
//! generation moves the entry back to the current one, so entries in use stay and at most
//! `2 × capacity` are kept.

use std::collections::HashMap;
use std::hash::Hash;

#[derive(Debug)]
pub(crate) struct Recent<K, V> {
    current: HashMap<K, V>,
    previous: HashMap<K, V>,
    capacity: usize,
}

impl<K: Hash + Eq, V: Clone> Recent<K, V> {
    pub(crate) fn new(capacity: usize) -> Recent<K, V> {
        Recent { current: HashMap::new(), previous: HashMap::new(), capacity: capacity.max(1) }
    }

    pub(crate) fn get<Q>(&mut self, key: &Q) -> Option<V>
    where
        K: std::borrow::Borrow<Q>,
        Q: Hash + Eq + ?Sized,
    {
        if let Some(value) = self.current.get(key) {
            return Some(value.clone());
        }
        let (key, value) = self.previous.remove_entry(key)?;
        self.insert(key, value.clone());
        Some(value)
    }

    pub(crate) fn insert(&mut self, key: K, value: V) {
        if self.current.len() >= self.capacity {
            self.previous = std::mem::take(&mut self.current);
        }
        self.current.insert(key, value);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keeps_entries_in_use_and_at_most_twice_the_capacity() {
        let mut recent = Recent::new(2);
        recent.insert("a", 1);
        recent.insert("b", 2);
        recent.insert("c", 3);
        // "a" and "b" are the previous generation now; using "a" brings it back.
        assert_eq!(recent.get("a"), Some(1));
        recent.insert("d", 4);
        recent.insert("e", 5);
        assert_eq!(recent.get("b"), None, "unused, so dropped");
        assert_eq!(recent.get("a"), Some(1));
        assert_eq!(recent.get("e"), Some(5));
        assert!(recent.current.len() + recent.previous.len() <= 4);
    }
}
