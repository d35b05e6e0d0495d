//! The body below the head: the neck continued from the face model's neck cut down into
//! shoulders and the top of the chest, generated (the face model stops at the neck).
//!
//! In: the posed head (its neck-cut loop, in order). Out: [`Body`], a triangle mesh whose first
//! ring is the posed neck-cut loop (so there is no seam or gap), then rings of superellipse
//! cross-sections that widen from the neck into the shoulders and run down out of the frame.
//! The shoulders can be raised (`shoulders` in [0, 1]: 0 at rest, 1 a full shrug of about 3.5 cm
//! at the shoulder tops, less at the front and back and none at the frame's bottom), which laughs
//! pulse and breathing heaves (see [`crate::engine::timeline::Timeline::shoulders`]).
//! Invariant: the same posed head and shoulder lift give the same mesh; all rings have the
//! loop's vertex count; a lift of 0 is the rest body, bit for bit.

use std::sync::OnceLock;

use glam::Vec3;

use super::asset::FaceModel;
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

/// From the neck down to below the bottom of the frame (base-mesh heights; each person's
/// rings move with their neck).
const RINGS: [Ring; 9] = [
    Ring { y: 5.84, tilt: 0.26, half_width: 0.51, half_depth: 0.45, centre_z: 0.25, side_drop: 0.00, squareness: 2.0 },
    Ring { y: 5.76, tilt: 0.18, half_width: 0.60, half_depth: 0.50, centre_z: 0.23, side_drop: 0.04, squareness: 2.3 },
    Ring { y: 5.69, tilt: 0.10, half_width: 0.85, half_depth: 0.58, centre_z: 0.20, side_drop: 0.12, squareness: 2.8 },
    Ring { y: 5.62, tilt: 0.05, half_width: 1.10, half_depth: 0.64, centre_z: 0.18, side_drop: 0.20, squareness: 3.2 },
    Ring { y: 5.53, tilt: 0.02, half_width: 1.30, half_depth: 0.68, centre_z: 0.16, side_drop: 0.26, squareness: 3.4 },
    Ring { y: 5.38, tilt: 0.00, half_width: 1.42, half_depth: 0.72, centre_z: 0.15, side_drop: 0.22, squareness: 3.5 },
    Ring { y: 5.15, tilt: 0.00, half_width: 1.48, half_depth: 0.74, centre_z: 0.15, side_drop: 0.10, squareness: 3.5 },
    Ring { y: 4.75, tilt: 0.00, half_width: 1.50, half_depth: 0.75, centre_z: 0.15, side_drop: 0.00, squareness: 3.5 },
    Ring { y: 3.80, tilt: 0.00, half_width: 1.50, half_depth: 0.75, centre_z: 0.15, side_drop: 0.00, squareness: 3.5 },
];

/// The centre of the neck cut in depth, for the angle of each loop vertex around the neck.
const NECK_AXIS_Z: f32 = 0.25;

/// How far a full shrug raises the shoulder tops (decimetres).
const SHRUG_DM: f32 = 0.35;

/// The share of the shrug each ring of [`RINGS`] takes: little at the neck, all at the
/// shoulders, none at the bottom (which stays below the frame).
const SHRUG_BY_RING: [f32; 9] = [0.2, 0.45, 0.85, 1.0, 1.0, 0.8, 0.5, 0.2, 0.0];

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
    rings: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
}

fn template(model: &FaceModel) -> &'static Template {
    static TEMPLATE: OnceLock<Template> = OnceLock::new();
    TEMPLATE.get_or_init(|| {
        let loop_vertices = model.group("neck_cut_loop").expect("the embedded face model has its neck cut loop");
        let n = loop_vertices.len();
        let mut rings = Vec::with_capacity(n * RINGS.len());
        for ring in &RINGS {
            for &v in &loop_vertices {
                let p = model.rest[v as usize];
                rings.push(ring_point(ring, (p.x).atan2(p.z - NECK_AXIS_Z)));
            }
        }
        let mut triangles = Vec::with_capacity(2 * n * RINGS.len());
        for r in 0..RINGS.len() as u32 {
            for j in 0..n as u32 {
                let k = (j + 1) % n as u32;
                let (a, b) = (r * n as u32 + j, r * n as u32 + k);
                let (c, d) = (a + n as u32, b + n as u32);
                // Ring r is above ring r + 1; counter-clockwise seen from outside.
                triangles.push([a, c, d]);
                triangles.push([a, d, b]);
            }
        }
        Template { loop_vertices, rings, triangles }
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
    /// The body under `posed`: the posed neck-cut loop on top of the fixed rings, the shoulders
    /// raised by `lift` (0 at rest to 1, a full shrug).
    pub fn new(model: &FaceModel, posed: &Posed, identity: &Identity, lift: f32) -> Body {
        let t = template(model);
        let mut positions: Vec<Vec3> = t.loop_vertices.iter().map(|&v| posed.positions[v as usize]).collect();
        // Narrower shoulders for women; the rings under the neck take the neck's own size
        // (a thick neck would otherwise step in below the cut) and pass into the shoulders.
        let shoulders = 0.88 + 0.12 * identity.sex;
        let n = t.loop_vertices.len();
        // The rings follow the person's neck: the shift of the loop's centre from the base mesh.
        let centre = |p: &[Vec3]| t.loop_vertices.iter().map(|&v| p[v as usize]).sum::<Vec3>() / n as f32;
        let shift = centre(&posed.neutral) - centre(&model.rest);
        let shift = Vec3::new(0.0, shift.y, shift.z);
        let neck = neck_size(&t.loop_vertices, &posed.neutral) / neck_size(&t.loop_vertices, &model.rest);
        positions.extend(t.rings.iter().enumerate().map(|(i, &p)| {
            let widen = ((i / n) as f32 / 4.0).min(1.0);
            let across = neck.x + (shoulders - neck.x) * widen;
            let deep = neck.y + (1.0 - neck.y) * widen;
            Vec3::new(p.x * across, p.y + shrug(i / n, p.x, lift), NECK_AXIS_Z + (p.z - NECK_AXIS_Z) * deep) + shift
        }));
        let normals = vertex_normals(&positions, &t.triangles);
        // The top ring takes the head's own normals, so the shading is continuous across the cut.
        let mut normals = normals;
        for (slot, &v) in normals.iter_mut().zip(&t.loop_vertices) {
            *slot = posed.normals[v as usize];
        }
        Body { shift, lift, positions, normals, triangles: t.triangles.clone() }
    }

    /// How far the shrug has raised the top's neckline at `x` across (the fabric rises with the
    /// shoulders: the neckline lies about where the third ring runs).
    pub fn neckline_rise(&self, x: f32) -> f32 {
        shrug(2, x, self.lift)
    }
}

/// How far the shrug raises a point of ring `ring` at `x` across: the shoulder tops (the sides)
/// fully, the front and back of the chest half as far.
fn shrug(ring: usize, x: f32, lift: f32) -> f32 {
    if lift == 0.0 {
        return 0.0;
    }
    let side = (x.abs() / RINGS[ring].half_width).min(1.0);
    lift * SHRUG_DM * SHRUG_BY_RING[ring] * (0.5 + 0.5 * side * side)
}

/// The neck cut's width (x) and depth (y) among `positions`.
fn neck_size(loop_vertices: &[u32], positions: &[Vec3]) -> glam::Vec2 {
    let (mut low, mut high) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
    for &v in loop_vertices {
        low = low.min(positions[v as usize]);
        high = high.max(positions[v as usize]);
    }
    glam::Vec2::new(high.x - low.x, high.z - low.z)
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
        let front = rise[4 * n..5 * n].iter().copied().fold(f32::MAX, f32::min);
        assert!((0.5 * SHRUG_DM - 1e-4..0.6 * SHRUG_DM).contains(&front), "the chest's front rises about half as far: {front}");
        assert!(rest.positions.iter().zip(&up.positions).all(|(a, b)| a.x == b.x && a.z == b.z), "a shrug only lifts");
    }
}
