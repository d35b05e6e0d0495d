//! Loop subdivision of one part of the head, as a linear map from the head's vertices.
//!
//! In: a part's triangles (indices into the head's vertices, counter-clockwise seen from
//! outside), the index its new vertices start at, and the head's mirror map. Out:
//! [`Subdivision`]: four triangles for each one, over new vertices only, each new vertex a fixed
//! weighted sum of the part's vertices (Loop's rules: a corner moves toward its neighbours, a
//! new vertex on an edge lies at 3/8, 3/8, 1/8, 1/8 of the edge's ends and opposite corners; on
//! an open edge at its midpoint, an open edge's corner at 3/4 of itself and 1/8 of its two
//! neighbours along the edge). The surface is smoothed by drawing it in from its corners, so a
//! convex part comes out a little smaller than its mesh.
//!
//! `build.rs` works the tongue's subdivision out ([`TONGUE_STEPS`]) and bakes it into the face
//! model ([`Subdivision::to_bytes`]); loading reads it back ([`Subdivision::from_bytes`]). This
//! file is compiled into the build script too, so it uses nothing but the standard library.
//!
//! Invariants: the weights of each new vertex sum to 1, so a rigid move of the part moves the
//! subdivided part rigidly; the map is applied after every target, pull and turn, so the new
//! vertices follow whatever moved the old ones; the order of the new vertices and of every sum
//! is fixed by the triangle list (same input, same bytes); a mirror-symmetric part gives a
//! mirror-symmetric subdivision (`mirror` pairs the new vertices).

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::ops::Range;

/// Loop steps the tongue is subdivided by: its 448 triangles drew a polygonal outline (a
/// trapezoid with straight sides) where AU19 puts it out between the lips. (An interpolating
/// butterfly step, which keeps the modelled size, left the tip notched and kinked where the
/// mesh's rim has corners.)
pub const TONGUE_STEPS: usize = 2;

/// Loop subdivision of a part (one or more steps as one map): its new vertices and triangles.
#[derive(Debug, Clone)]
pub struct Subdivision {
    /// The index of the first new vertex; the new vertices follow it without gaps.
    first: u32,
    /// New vertex `i` is the sum over `starts[i]..starts[i + 1]` of `weights[k]` times the
    /// vertex `sources[k]`.
    starts: Vec<u32>,
    sources: Vec<u32>,
    weights: Vec<f32>,
    triangles: Vec<[u32; 3]>,
    /// Each new vertex's mirror partner (itself where the part has no mirror image of it).
    mirror: Vec<u32>,
}

/// An edge, its ends in increasing order.
type Edge = (u32, u32);

fn edge(a: u32, b: u32) -> Edge {
    (a.min(b), a.max(b))
}

/// Who touches whom in a triangle list: each edge's opposite corners (edges in order of first
/// appearance) and each corner's neighbours.
struct Adjacency {
    opposite: HashMap<Edge, Vec<u32>>,
    edges: Vec<Edge>,
    neighbours: BTreeMap<u32, BTreeSet<u32>>,
}

impl Adjacency {
    fn of(triangles: &[[u32; 3]]) -> Adjacency {
        let mut adjacency = Adjacency { opposite: HashMap::new(), edges: Vec::new(), neighbours: BTreeMap::new() };
        for &[a, b, c] in triangles {
            for (u, v, w) in [(a, b, c), (b, c, a), (c, a, b)] {
                let edges = &mut adjacency.edges;
                adjacency.opposite.entry(edge(u, v)).or_insert_with(|| {
                    edges.push(edge(u, v));
                    Vec::new()
                }).push(w);
                adjacency.neighbours.entry(u).or_default().insert(v);
                adjacency.neighbours.entry(v).or_default().insert(u);
            }
        }
        adjacency
    }

    /// The corners opposite edge (u, v) when two triangles share it (a closed edge).
    fn closed(&self, u: u32, v: u32) -> Option<[u32; 2]> {
        match self.opposite.get(&edge(u, v))?.as_slice() {
            [p, q] => Some([*p, *q]),
            _ => None,
        }
    }

    /// Corner `v`'s new place as weights of corners: of valence n, (1 − nβ) of itself and β of
    /// each neighbour (β = 3/16 for n = 3, else 3/(8n)); on an open edge, 3/4 of itself and 1/8
    /// of its two neighbours along it; where more than two open edges meet, where it is.
    fn corner_row(&self, v: u32) -> Vec<(u32, f32)> {
        let around = &self.neighbours[&v];
        let along_open: Vec<u32> = around.iter().copied().filter(|&w| self.closed(v, w).is_none()).collect();
        match along_open.as_slice() {
            [] => {
                let n = around.len() as f32;
                let beta = if around.len() == 3 { 3.0 / 16.0 } else { 3.0 / (8.0 * n) };
                std::iter::once((v, 1.0 - n * beta)).chain(around.iter().map(|&w| (w, beta))).collect()
            }
            [p, q] => vec![(v, 0.75), (*p, 0.125), (*q, 0.125)],
            _ => vec![(v, 1.0)],
        }
    }

    /// The new vertex on edge (a, b) as weights of corners: 3/8 of its ends and 1/8 of the two
    /// corners opposite it; on an open edge, its midpoint.
    fn edge_row(&self, (a, b): Edge) -> Vec<(u32, f32)> {
        match self.closed(a, b) {
            Some([c, d]) => vec![(a, 0.375), (b, 0.375), (c, 0.125), (d, 0.125)],
            None => vec![(a, 0.5), (b, 0.5)],
        }
    }
}

impl Subdivision {
    /// One Loop step over `triangles`, numbering the new vertices from `first`. `mirror` pairs
    /// the head's vertices across the midline (indices at or past its end pair with
    /// themselves).
    pub fn once(triangles: &[[u32; 3]], first: u32, mirror: &[u32]) -> Subdivision {
        let adjacency = Adjacency::of(triangles);
        let corners: Vec<u32> = adjacency.neighbours.keys().copied().collect();
        let edges = &adjacency.edges;
        let even: HashMap<u32, u32> = corners.iter().enumerate().map(|(i, &v)| (v, first + i as u32)).collect();
        let odd_first = first + corners.len() as u32;
        let odd: HashMap<Edge, u32> = edges.iter().enumerate().map(|(i, &e)| (e, odd_first + i as u32)).collect();
        let rows = corners.iter().map(|&v| adjacency.corner_row(v)).chain(edges.iter().map(|&e| adjacency.edge_row(e)));

        let triangles = triangles
            .iter()
            .flat_map(|&[a, b, c]| {
                let (ab, bc, ca) = (odd[&edge(a, b)], odd[&edge(b, c)], odd[&edge(c, a)]);
                let (a, b, c) = (even[&a], even[&b], even[&c]);
                [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
            })
            .collect();
        let partner = |v: u32| mirror.get(v as usize).copied().unwrap_or(v);
        let mirror = corners
            .iter()
            .map(|&v| even.get(&partner(v)))
            .chain(edges.iter().map(|&(a, b)| odd.get(&edge(partner(a), partner(b)))))
            .enumerate()
            .map(|(i, found)| found.copied().unwrap_or(first + i as u32))
            .collect();

        let mut starts = vec![0u32];
        let (mut sources, mut weights) = (Vec::new(), Vec::new());
        for row in rows {
            for (v, w) in row {
                sources.push(v);
                weights.push(w);
            }
            starts.push(sources.len() as u32);
        }
        Subdivision { first, starts, sources, weights, triangles, mirror }
    }

    /// `steps` Loop steps (at least one; 0 panics) over `triangles` as one map from the part's
    /// vertices: the new vertices are those of the last step, numbered from `first`; the steps
    /// between leave no vertices behind.
    pub fn steps(steps: usize, triangles: &[[u32; 3]], first: u32, mirror: &[u32]) -> Subdivision {
        assert!(steps >= 1, "a subdivision takes at least one step");
        let mut done = Subdivision::once(triangles, first, mirror);
        for _ in 1..steps {
            // The partners of the vertices before `first` (themselves where `mirror` ends
            // sooner), then those of the steps' vertices so far.
            let mut mirror = mirror.to_vec();
            mirror.extend(mirror.len() as u32..first);
            mirror.truncate(first as usize);
            mirror.extend_from_slice(&done.mirror);
            let next = Subdivision::once(&done.triangles, done.vertices().end, &mirror);
            done = done.then(&next);
        }
        done
    }

    /// `next` (a step over this one's triangles, its vertices numbered after this one's) made
    /// into one map from this one's sources, its vertices renumbered from this one's `first`.
    fn then(&self, next: &Subdivision) -> Subdivision {
        let shift = next.first - self.first;
        let renumber = |v: u32| v - shift;
        let mut starts = vec![0u32];
        let (mut sources, mut weights) = (Vec::new(), Vec::new());
        for span in next.starts.windows(2) {
            // Sorted by source, so that every sum is taken in the same order.
            let mut row: BTreeMap<u32, f32> = BTreeMap::new();
            for k in span[0] as usize..span[1] as usize {
                let inner = (next.sources[k] - self.first) as usize;
                for j in self.starts[inner] as usize..self.starts[inner + 1] as usize {
                    *row.entry(self.sources[j]).or_insert(0.0) += next.weights[k] * self.weights[j];
                }
            }
            for (v, w) in row {
                sources.push(v);
                weights.push(w);
            }
            starts.push(sources.len() as u32);
        }
        Subdivision {
            first: self.first,
            starts,
            sources,
            weights,
            triangles: next.triangles.iter().map(|t| t.map(renumber)).collect(),
            mirror: next.mirror.iter().map(|&v| renumber(v)).collect(),
        }
    }

    /// The new vertices' indices.
    pub fn vertices(&self) -> Range<u32> {
        self.first..self.first + self.mirror.len() as u32
    }

    /// The subdivided part's triangles (over the new vertices only).
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    /// Each new vertex's mirror partner, in the order of [`Self::vertices`].
    pub fn mirror(&self) -> &[u32] {
        &self.mirror
    }

    /// The map as little-endian bytes: `first`, the number of new vertices n, their n + 1 row
    /// starts, the number of terms, the terms' sources and weights, the number of triangles and
    /// their corners, and the n mirror partners (all `u32` but the weights, `f32`).
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = Vec::new();
        let mut put = |v: u32| out.extend(v.to_le_bytes());
        put(self.first);
        put(self.mirror.len() as u32);
        self.starts.iter().for_each(|&v| put(v));
        put(self.sources.len() as u32);
        self.sources.iter().for_each(|&v| put(v));
        self.weights.iter().for_each(|&w| put(w.to_bits()));
        put(self.triangles.len() as u32);
        self.triangles.iter().flatten().for_each(|&v| put(v));
        self.mirror.iter().for_each(|&v| put(v));
        out
    }

    /// A map written by [`Self::to_bytes`] at the start of `bytes`, and how many bytes it took;
    /// `None` if they are cut short or do not hold a well-formed map (rows that do not follow
    /// one another, a source at or past the new vertices, a corner outside them).
    pub fn from_bytes(bytes: &[u8]) -> Option<(Subdivision, usize)> {
        let mut at: usize = 0;
        let mut take = |n: usize| -> Option<Vec<u32>> {
            let words = bytes.get(at..at.checked_add(n.checked_mul(4)?)?)?;
            at += 4 * n;
            Some(words.chunks_exact(4).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect())
        };
        let [first, count] = take(2)?[..] else { return None };
        let starts = take(count as usize + 1)?;
        let terms = take(1)?[0] as usize;
        let sources = take(terms)?;
        let weights: Vec<f32> = take(terms)?.into_iter().map(f32::from_bits).collect();
        let corners = take(1)?[0] as usize;
        let triangles: Vec<[u32; 3]> = take(corners.checked_mul(3)?)?.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
        let mirror = take(count as usize)?;
        let end = first.checked_add(count)?;
        let rows_follow = starts.first() == Some(&0) && starts.windows(2).all(|w| w[0] <= w[1]) && starts.last() == Some(&(terms as u32));
        let inside = |v: &u32| (first..end).contains(v);
        let well_formed = rows_follow && sources.iter().all(|&v| v < first) && triangles.iter().flatten().all(inside) && mirror.iter().all(inside);
        well_formed.then_some((Subdivision { first, starts, sources, weights, triangles, mirror }, at))
    }

    /// Works out the new vertices' values in `values` (positions, or anything that varies
    /// linearly over the surface) from the ones they are made of. `values` holds at least
    /// [`Self::vertices`]`.end` of them.
    pub fn apply<T: Blend>(&self, values: &mut [T]) {
        for (i, span) in self.starts.windows(2).enumerate() {
            let (from, to) = (span[0] as usize, span[1] as usize);
            let value = self.sources[from..to].iter().zip(&self.weights[from..to]).fold(T::ZERO, |sum, (&v, &w)| sum.plus_scaled(values[v as usize], w));
            values[self.first as usize + i] = value;
        }
    }
}

/// A value a subdivision can carry to its new vertices: a weighted sum of others.
pub trait Blend: Copy {
    const ZERO: Self;
    /// `self + other * weight`.
    fn plus_scaled(self, other: Self, weight: f32) -> Self;
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// A regular octahedron, counter-clockwise from outside.
    fn octahedron() -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let points = vec![Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z];
        let triangles = vec![[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]];
        (points, triangles)
    }

    fn subdivided(points: &[Vec3], step: &Subdivision) -> Vec<Vec3> {
        let mut all = points.to_vec();
        all.resize(step.vertices().end as usize, Vec3::ZERO);
        step.apply(&mut all);
        all
    }

    /// Four triangles for each, every edge of the new closed mesh shared by exactly two of them
    /// in opposite directions (still closed and consistently wound), and the weights of every new
    /// vertex summing to 1.
    #[test]
    fn a_closed_mesh_stays_closed_and_wound_alike() {
        let (points, triangles) = octahedron();
        let step = Subdivision::once(&triangles, points.len() as u32, &[]);
        assert_eq!(step.triangles().len(), 32);
        assert_eq!(step.vertices(), 6..24, "6 moved corners and 12 edge points");
        let mut directed = BTreeMap::new();
        for &[a, b, c] in step.triangles() {
            for (u, v) in [(a, b), (b, c), (c, a)] {
                assert!(step.vertices().contains(&u));
                *directed.entry((u, v)).or_insert(0) += 1;
            }
        }
        for (&(u, v), &n) in &directed {
            assert_eq!(n, 1, "edge {u}-{v} used twice in one direction");
            assert_eq!(directed.get(&(v, u)), Some(&1), "edge {u}-{v} has no twin");
        }
        for span in step.starts.windows(2) {
            let sum: f32 = step.weights[span[0] as usize..span[1] as usize].iter().sum();
            assert!((sum - 1.0).abs() < 1e-6, "weights sum to {sum}");
        }
    }

    /// Loop's rules on the octahedron by hand: a corner (valence 4, β = 3/32) moves to
    /// (1 − 4β) = 5/8 of itself (the neighbours cancel); the edge point of 0-2 lies at 3/8 of
    /// x and y plus 1/8 of z and −z (which cancel): 0.375 (1, 1, 0).
    #[test]
    fn the_octahedron_rounds_by_loops_rules() {
        let (points, triangles) = octahedron();
        let all = subdivided(&points, &Subdivision::once(&triangles, 6, &[]));
        assert!(all[6].distance(Vec3::new(0.625, 0.0, 0.0)) < 1e-6, "{}", all[6]);
        assert!(all[12].distance(Vec3::new(0.375, 0.375, 0.0)) < 1e-6, "{}", all[12]);
    }

    /// On an open edge the new points keep to the edge: a lone triangle's edge points are the
    /// midpoints, its corners move to 3/4 of themselves and 1/8 of each neighbour along it.
    #[test]
    fn open_edges_stay_on_their_outline() {
        let points = vec![Vec3::ZERO, Vec3::X, Vec3::Y];
        let all = subdivided(&points, &Subdivision::once(&[[0, 1, 2]], 3, &[]));
        assert!(all[3].distance(Vec3::new(0.125, 0.125, 0.0)) < 1e-6, "{}", all[3]);
        assert!(all[6].distance(Vec3::new(0.5, 0.0, 0.0)) < 1e-6, "{}", all[6]);
    }

    /// Two steps taken as one map put every vertex where the two steps one after the other do
    /// (to float rounding), over 128 triangles, with no vertex of the first step left behind.
    #[test]
    fn two_steps_as_one_match_the_steps_in_turn() {
        let (points, triangles) = octahedron();
        let one = Subdivision::once(&triangles, 6, &[1, 0, 2, 3, 4, 5]);
        let after_one = subdivided(&points, &one);
        let two = Subdivision::once(one.triangles(), one.vertices().end, &[]);
        let in_turn = subdivided(&after_one, &two);
        let both = Subdivision::steps(2, &triangles, 6, &[1, 0, 2, 3, 4, 5]);
        assert_eq!(both.vertices(), 6..6 + two.vertices().len() as u32);
        assert_eq!(both.triangles().len(), 128);
        let at_once = subdivided(&points, &both);
        for (i, v) in two.vertices().enumerate() {
            let (a, b) = (in_turn[v as usize], at_once[6 + i]);
            assert!(a.distance(b) < 1e-6, "vertex {i}: {a} in turn, {b} at once");
        }
        for (&[a, b, c], &[x, y, z]) in two.triangles().iter().zip(both.triangles()) {
            let shift = two.vertices().start - 6;
            assert_eq!([a - shift, b - shift, c - shift], [x, y, z]);
        }
        for (i, &partner) in both.vertices().zip(both.mirror()) {
            let (p, q) = (at_once[i as usize], at_once[partner as usize]);
            assert!(p.distance(q * Vec3::new(-1.0, 1.0, 1.0)) < 1e-6, "{i} {p} / {partner} {q}");
        }
    }

    /// The bytes give back the same map, and cut short or with a source out of range they are
    /// refused.
    #[test]
    fn the_map_comes_back_from_its_bytes() {
        let (_, triangles) = octahedron();
        let map = Subdivision::steps(2, &triangles, 6, &[1, 0, 2, 3, 4, 5]);
        let bytes = map.to_bytes();
        let (back, used) = Subdivision::from_bytes(&bytes).expect("well-formed");
        assert_eq!(used, bytes.len());
        assert_eq!((back.first, &back.starts, &back.sources, &back.triangles, &back.mirror), (map.first, &map.starts, &map.sources, &map.triangles, &map.mirror));
        assert!(back.weights.iter().zip(&map.weights).all(|(a, b)| a.to_bits() == b.to_bits()));
        assert!(Subdivision::from_bytes(&bytes[..bytes.len() - 1]).is_none());
        let mut bad = bytes.clone();
        let source_at = 4 * (2 + map.starts.len() + 1);
        bad[source_at..source_at + 4].copy_from_slice(&6u32.to_le_bytes());
        assert!(Subdivision::from_bytes(&bad).is_none(), "a source among the new vertices");
    }

    /// A mirror-symmetric mesh (the octahedron across x = 0: vertices 0 and 1 swap) gives new
    /// vertices whose partners are their mirror images, and the map is an involution.
    #[test]
    fn the_mirror_carries_over() {
        let (points, triangles) = octahedron();
        let step = Subdivision::once(&triangles, 6, &[1, 0, 2, 3, 4, 5]);
        let all = subdivided(&points, &step);
        for (i, &partner) in step.vertices().zip(step.mirror()) {
            let (p, q) = (all[i as usize], all[partner as usize]);
            assert!(p.distance(q * Vec3::new(-1.0, 1.0, 1.0)) < 1e-6, "{i} {p} / {partner} {q}");
            assert_eq!(step.mirror()[(partner - 6) as usize], i);
        }
    }
}
