//! The body below the head: the neck continued from the face model's neck cut down into
//! shoulders and the top of the chest, generated (the face model stops at the neck).
//!
//! In: the posed head (its neck-cut loop, in order, and the row of skin vertices above it). Out:
//! [`Body`], a triangle mesh whose first ring is the posed neck-cut loop (so there is no seam or
//! gap), then the neck: rings on curves that leave the cut along the head's own surface (so the
//! neck bends nowhere at the cut, whatever the person's neck or the head's pose), into fixed
//! superellipse cross-sections that widen into the shoulders and run down out of the frame.
//! The shoulders can be raised (`shoulders` in [0, 1]: 0 at rest, 1 a full shrug of about 3.5 cm
//! at the shoulder tops, less at the front and back and none at the frame's bottom), which laughs
//! pulse and breathing heaves (see [`crate::engine::timeline::Timeline::shoulders`]).
//! Invariant: the same posed head and shoulder lift give the same mesh; all rings have the
//! loop's vertex count; a lift of 0 is the rest body, bit for bit; a lift only raises points.

use std::collections::{BTreeMap, BTreeSet};
use std::sync::OnceLock;

use glam::Vec3;

use super::asset::{FaceModel, Part};
use super::identity::Identity;
use super::pose::Posed;

/// One cross-section below the neck cut (decimetres, face-model space).
struct Ring {
    /// Height at the sides of the neck.
    y: f32,
    /// How much higher the back is than the front (the neck cut is tilted).
    tilt: f32,
    /// Half-width (x) and half-depth (z) of the section, and the depth of its centre.
    half_width: f32,
    half_depth: f32,
    centre_z: f32,
    /// How far the outer ends (left and right) drop below `y`: the slope of the shoulders.
    side_drop: f32,
    /// Superellipse exponent: 2 = ellipse, larger = squarer.
    squareness: f32,
}

/// From the shoulders down to below the bottom of the frame (base-mesh heights; each person's
/// rings move with their neck).
const RINGS: [Ring; 5] = [
    Ring { y: 5.53, tilt: 0.02, half_width: 1.30, half_depth: 0.68, centre_z: 0.16, side_drop: 0.26, squareness: 3.4 },
    Ring { y: 5.38, tilt: 0.00, half_width: 1.42, half_depth: 0.72, centre_z: 0.15, side_drop: 0.22, squareness: 3.5 },
    Ring { y: 5.15, tilt: 0.00, half_width: 1.48, half_depth: 0.74, centre_z: 0.15, side_drop: 0.10, squareness: 3.5 },
    Ring { y: 4.75, tilt: 0.00, half_width: 1.50, half_depth: 0.75, centre_z: 0.15, side_drop: 0.00, squareness: 3.5 },
    Ring { y: 3.80, tilt: 0.00, half_width: 1.50, half_depth: 0.75, centre_z: 0.15, side_drop: 0.00, squareness: 3.5 },
];

/// Rings between the neck cut and the first of [`RINGS`]: the neck. Each column of the body
/// (one per loop vertex) leaves the cut along the head's own surface and meets the first ring
/// along the rings' course, on a cubic Hermite curve, so the neck bends nowhere at the cut
/// whatever the person's neck or the head's turn. The neck rings sit at even steps of it.
const NECK_RINGS: usize = 4;

/// The head's neck at the cut may flare outward at most this far per unit of drop.
const MAX_FLARE: f32 = 2.0;

/// The centre of the neck cut in depth, for the angle of each loop vertex around the neck.
const NECK_AXIS_Z: f32 = 0.25;

/// How far a full shrug raises the shoulder tops (decimetres).
const SHRUG_DM: f32 = 0.35;

/// The share of the shrug each ring of [`RINGS`] takes: all at the shoulders, none at the
/// bottom (which stays below the frame). The neck rings take a share of the first ring's lift
/// that grows down the neck.
const SHRUG_BY_RING: [f32; 5] = [1.0, 0.8, 0.5, 0.2, 0.0];

/// The share of the first ring's lift that the top's neckline takes: the neck's height falls
/// evenly along its curve and the neckline crosses the curve's sides about half way down.
const NECKLINE_SHARE: f32 = 0.5;

/// The neck and shoulders of one frame.
#[derive(Debug, Clone)]
pub struct Body {
    /// How far this person's neck sits from the base mesh's (the rings moved with it).
    pub shift: Vec3,
    /// How far the shoulders are raised (0 at rest, 1 a full shrug).
    pub lift: f32,
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
}

/// The loop and the fixed rings below it, which do not depend on the pose.
struct Template {
    loop_vertices: Vec<u32>,
    /// For each loop vertex, the skin vertex next above it (the head's neck leads into the cut
    /// along the line between them).
    above: Vec<u32>,
    /// The points of [`RINGS`], ring after ring, one per loop vertex.
    rings: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
}

fn template(model: &FaceModel) -> &'static Template {
    static TEMPLATE: OnceLock<Template> = OnceLock::new();
    TEMPLATE.get_or_init(|| {
        let loop_vertices = model.group("neck_cut_loop").expect("the embedded face model has its neck cut loop");
        let n = loop_vertices.len() as u32;
        let mut rings = Vec::with_capacity(n as usize * RINGS.len());
        for ring in &RINGS {
            for &v in &loop_vertices {
                let p = model.rest[v as usize];
                rings.push(ring_point(ring, (p.x).atan2(p.z - NECK_AXIS_Z)));
            }
        }
        let below_the_loop = (NECK_RINGS + RINGS.len()) as u32;
        let mut triangles = Vec::with_capacity(2 * (n * below_the_loop) as usize);
        for r in 0..below_the_loop {
            for j in 0..n {
                let k = (j + 1) % n;
                let (a, b) = (r * n + j, r * n + k);
                let (c, d) = (a + n, b + n);
                // Ring r is above ring r + 1; counter-clockwise seen from outside.
                triangles.push([a, c, d]);
                triangles.push([a, d, b]);
            }
        }
        let above = vertices_above(model, &loop_vertices);
        Template { loop_vertices, above, rings, triangles }
    })
}

/// The point of `ring` at angle `theta` around the neck (0 = front, +π/2 = the person's left).
fn ring_point(ring: &Ring, theta: f32) -> Vec3 {
    let (s, c) = theta.sin_cos();
    let e = 2.0 / ring.squareness;
    let x = ring.half_width * s.signum() * s.abs().powf(e);
    let z = ring.centre_z + ring.half_depth * c.signum() * c.abs().powf(e);
    let y = ring.y - ring.tilt * 0.5 * c - ring.side_drop * s.abs().powf(2.5);
    Vec3::new(x, y, z)
}

impl Body {
    /// The body under `posed`: the posed neck-cut loop, the neck curving from it into the
    /// fixed rings of the shoulders, the shoulders raised by `lift` (0 at rest to 1, a full
    /// shrug).
    pub fn new(model: &FaceModel, posed: &Posed, identity: &Identity, lift: f32) -> Body {
        let t = template(model);
        let n = t.loop_vertices.len();
        // Narrower shoulders for women.
        let shoulders = 0.88 + 0.12 * identity.sex;
        // The rings follow the person's neck: the shift of the loop's centre from the base mesh.
        let centre = |p: &[Vec3]| t.loop_vertices.iter().map(|&v| p[v as usize]).sum::<Vec3>() / n as f32;
        let shift = centre(&posed.neutral) - centre(&model.rest);
        let shift = Vec3::new(0.0, shift.y, shift.z);
        let mut positions: Vec<Vec3> = t.loop_vertices.iter().map(|&v| posed.positions[v as usize]).collect();
        positions.resize(n * (1 + NECK_RINGS), Vec3::ZERO);
        positions.extend(t.rings.iter().map(|&p| Vec3::new(p.x * shoulders, p.y, p.z) + shift));
        for (j, &v) in t.loop_vertices.iter().enumerate() {
            let up = posed.positions[t.above[j] as usize] - posed.positions[v as usize];
            grow_the_neck(&mut positions, n, j, up);
        }
        // The shrug lifts the rings and, down the neck's curve, a growing share of the first
        // ring's lift: it only lifts, so the neck keeps its shape.
        for (i, p) in positions.iter_mut().enumerate().skip(n) {
            let (ring, j) = (i / n, i % n);
            let x = t.rings[j].x;
            p.y += match ring.checked_sub(NECK_RINGS + 1) {
                Some(fixed) => shrug(fixed, t.rings[fixed * n + j].x, lift),
                None => ring as f32 / (NECK_RINGS + 1) as f32 * shrug(0, x, lift),
            };
        }
        let mut normals = vertex_normals(&positions, &t.triangles);
        // The top ring takes the head's own normals, so the shading is continuous across the cut.
        for (slot, &v) in normals.iter_mut().zip(&t.loop_vertices) {
            *slot = posed.normals[v as usize];
        }
        Body { shift, lift, positions, normals, triangles: t.triangles.clone() }
    }

    /// How far the shrug has raised the top's neckline at `x` across (the fabric rises with the
    /// shoulders, the neckline about half as far as the first ring below the neck).
    pub fn neckline_rise(&self, x: f32) -> f32 {
        NECKLINE_SHARE * shrug(0, x, self.lift)
    }
}

/// For each of `loop_vertices`, its skin neighbour highest above it at rest (the next row up).
fn vertices_above(model: &FaceModel, loop_vertices: &[u32]) -> Vec<u32> {
    let on_loop: BTreeSet<u32> = loop_vertices.iter().copied().collect();
    let mut best: BTreeMap<u32, u32> = BTreeMap::new();
    for tri in &model.part(Part::Skin).triangles {
        for &v in tri.iter().filter(|v| on_loop.contains(v)) {
            for &w in tri.iter().filter(|w| !on_loop.contains(w)) {
                let slot = best.entry(v).or_insert(w);
                if model.rest[w as usize].y > model.rest[*slot as usize].y {
                    *slot = w;
                }
            }
        }
    }
    loop_vertices.iter().map(|v| best.get(v).copied().unwrap_or(*v)).collect()
}

/// Fills column `j` of the neck rings: the cubic Hermite curve from the loop vertex, leaving
/// it along the head's surface (`up` runs from the loop vertex to the one above it), to the
/// first fixed ring, meeting it along the column's course down to the second. The curve's
/// height falls evenly; where the head's surface gives no direction down, the neck leaves
/// straight towards the first ring.
fn grow_the_neck(positions: &mut [Vec3], n: usize, j: usize, up: Vec3) {
    let first = (NECK_RINGS + 1) * n + j;
    let (start, end, below) = (positions[j], positions[first], positions[first + n]);
    let drop = start.y - end.y;
    // Each tangent's run across per unit of drop, scaled to the whole drop.
    let across = |d: Vec3, per: f32| (Vec3::new(d.x, 0.0, d.z) / per).clamp_length_max(MAX_FLARE) * drop;
    let chord = end - start;
    let leave = if up.y > 1e-3 && drop > 0.0 { across(-up, up.y) - Vec3::Y * drop } else { chord };
    let meet = if end.y > below.y && drop > 0.0 { across(below - end, end.y - below.y) - Vec3::Y * drop } else { chord };
    for ring in 1..=NECK_RINGS {
        let s = ring as f32 / (NECK_RINGS + 1) as f32;
        let (s2, s3) = (s * s, s * s * s);
        positions[ring * n + j] =
            start * (2.0 * s3 - 3.0 * s2 + 1.0) + leave * (s3 - 2.0 * s2 + s) + end * (3.0 * s2 - 2.0 * s3) + meet * (s3 - s2);
    }
}

/// How far the shrug raises a point of ring `ring` of [`RINGS`] at `x` across: the shoulder
/// tops (the sides) fully, the front and back of the chest half as far.
fn shrug(ring: usize, x: f32, lift: f32) -> f32 {
    if lift == 0.0 {
        return 0.0;
    }
    let side = (x.abs() / RINGS[ring].half_width).min(1.0);
    lift * SHRUG_DM * SHRUG_BY_RING[ring] * (0.5 + 0.5 * side * side)
}

/// Area-weighted vertex normals.
fn vertex_normals(positions: &[Vec3], triangles: &[[u32; 3]]) -> Vec<Vec3> {
    let mut normals = vec![Vec3::ZERO; positions.len()];
    for &[a, b, c] in triangles {
        let (pa, pb, pc) = (positions[a as usize], positions[b as usize], positions[c as usize]);
        let n = (pb - pa).cross(pc - pa);
        for v in [a, b, c] {
            normals[v as usize] += n;
        }
    }
    normals.into_iter().map(|n| n.normalize_or(Vec3::Y)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::engine::identity::IdentityTable;

    #[test]
    fn the_body_starts_at_the_neck_cut_and_faces_outward() {
        let model = FaceModel::embedded();
        let identity = IdentityTable::built_in().get("wf1").unwrap();
        let posed = crate::engine::pose_expression(&crate::facs::Expression::neutral(), identity).unwrap();
        let body = Body::new(model, &posed, identity, 0.0);
        let loop_vertices = model.group("neck_cut_loop").unwrap();
        assert_eq!(loop_vertices.len(), 42);
        for (j, &v) in loop_vertices.iter().enumerate() {
            assert_eq!(body.positions[j], posed.positions[v as usize]);
        }
        // Every triangle faces away from the body's vertical axis.
        for &[a, b, c] in &body.triangles {
            let (pa, pb, pc) = (body.positions[a as usize], body.positions[b as usize], body.positions[c as usize]);
            let centre = (pa + pb + pc) / 3.0;
            let outward = Vec3::new(centre.x, 0.0, centre.z - 0.2);
            assert!((pb - pa).cross(pc - pa).dot(outward) > 0.0, "triangle {a} {b} {c} faces inward: {pa} {pb} {pc}");
        }
        // Shoulders: well wider than the neck cut (half-width 0.5).
        let widest = body.positions.iter().map(|p| p.x.abs()).fold(0.0, f32::max);
        assert!(widest > 1.25, "{widest}");
    }

    #[test]
    fn a_shrug_raises_the_shoulder_tops_and_leaves_the_neck_cut_and_the_bottom() {
        let model = FaceModel::embedded();
        let identity = IdentityTable::built_in().get("wm1").unwrap();
        let posed = crate::engine::pose_expression(&crate::facs::Expression::neutral(), identity).unwrap();
        let (rest, up) = (Body::new(model, &posed, identity, 0.0), Body::new(model, &posed, identity, 1.0));
        let n = model.group("neck_cut_loop").unwrap().len();
        let rise: Vec<f32> = rest.positions.iter().zip(&up.positions).map(|(a, b)| b.y - a.y).collect();
        assert!(rise[..n].iter().all(|&r| r == 0.0), "the neck cut stays on the head");
        assert!(rise[rise.len() - n..].iter().all(|&r| r == 0.0), "the bottom ring stays below the frame");
        let top = rise.iter().copied().fold(0.0, f32::max);
        assert!((top - SHRUG_DM).abs() < 1e-4, "the shoulder tops rise a full {SHRUG_DM} dm: {top}");
        let first = (NECK_RINGS + 1) * n;
        let front = rise[first..first + n].iter().copied().fold(f32::MAX, f32::min);
        assert!((0.5 * SHRUG_DM - 1e-4..0.6 * SHRUG_DM).contains(&front), "the chest's front rises about half as far: {front}");
        assert!(rest.positions.iter().zip(&up.positions).all(|(a, b)| a.x == b.x && a.z == b.z), "a shrug only lifts");
    }

    /// The largest bend (degrees) between successive segments of each column, running from
    /// the head's row above the cut through the cut and the neck to the first fixed ring:
    /// at the throat's front (within 60° of straight ahead) and elsewhere around the neck.
    fn largest_bends(body: &Body, posed: &Posed, model: &FaceModel) -> (f32, f32) {
        let t = template(model);
        let n = t.loop_vertices.len();
        let (mut front, mut elsewhere) = (0.0f32, 0.0f32);
        for (j, (&v, &above)) in t.loop_vertices.iter().zip(&t.above).enumerate() {
            let mut column = vec![posed.positions[above as usize]];
            column.extend((0..=NECK_RINGS + 1).map(|r| body.positions[r * n + j]));
            let bend = column.windows(3).map(|w| (w[1] - w[0]).angle_between(w[2] - w[1]).to_degrees()).fold(0.0, f32::max);
            let rest = model.rest[v as usize];
            let slot = if rest.x.atan2(rest.z - NECK_AXIS_Z).abs() < 60f32.to_radians() { &mut front } else { &mut elsewhere };
            *slot = slot.max(bend);
        }
        (front, elsewhere)
    }

    /// The neck leaves the cut along the head's surface, on all 24 people and with the head
    /// turned, tilted, raised and lowered. When its rings flared off on their own, the neck
    /// showed a corner at the cut (bends of up to 47° on the sides at rest) and a fold under
    /// the throat (up to 166°); now the worst are about 27° and 77° (the chin down on the chest).
    #[test]
    fn the_neck_runs_on_from_the_head_without_a_crease() {
        let model = FaceModel::embedded();
        let catalog = crate::facs::Catalog::built_in();
        let (mut front, mut elsewhere) = ((0.0f32, String::new()), (0.0f32, String::new()));
        for identity in IdentityTable::built_in().iter() {
            for notation in ["0", "51E", "52E", "53E", "54E", "55E"] {
                let posed = crate::engine::pose_expression(&catalog.parse(notation).unwrap(), identity).unwrap();
                let body = Body::new(model, &posed, identity, 0.0);
                let (f, e) = largest_bends(&body, &posed, model);
                let label = format!("{} {notation}", identity.id);
                if f > front.0 {
                    front = (f, label.clone());
                }
                if e > elsewhere.0 {
                    elsewhere = (e, label);
                }
            }
        }
        assert!(front.0 < 90.0 && elsewhere.0 < 30.0, "largest bends: throat {front:?}, elsewhere {elsewhere:?}");
    }
}
