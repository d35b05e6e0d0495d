//! A beard as hair cards: short strands rooted where the stubble is painted
//! ([`beard_mask`]: the upper lip, the chin, the jaw and the cheeks above it, never the lips'
//! red or the inside of the mouth, trimmed at a neckline under the jaw) and beyond it on the
//! cheeks and the sideburns, which run up in front of the ears into the scalp's hair, for a
//! full beard; on the upper lip and the chin for a goatee, the upper lip for a moustache
//! ([`grown_mask`]), lying along the skin
//! and growing down it; on the upper lip, down and out from the philtrum, as a moustache
//! grows, and trimmed above the red.
//!
//! In: the face model, the person's beard length and style, the neutral skin (in the head map's space,
//! as the scalp's roots are) and its vertex normals. Out: the roots ([`roots`]) and each
//! strand's points with the skin under each ([`grow`]), which the hair model draws as cards
//! like the scalp's, with the hair's colour, greying and lighting, each row moving with the
//! point of the skin under it (the jaw opens and the lips stretch under the beard), where a
//! scalp strand moves with its root only near the root.
//! Invariants: each row's centre is grown [`CLEARANCE`] out from the closest point of the
//! skin, and no corner of a card lies more than 0.25 mm inside the skin at rest nor 1.25 mm
//! as the face moves (test `engine::hair::beard::tests::beard_cards_lie_outside_the_skin`);
//! the sideburns leave no bare skin in front of the ear below the hairline and never reach the
//! ear (test `the_sideburns_join_the_scalps_hair_and_spare_the_ears`); a goatee and a moustache
//! grow only where they are worn (test `a_goatee_and_a_moustache_grow_where_they_are_worn`);
//! the same person gives the same cards.

use glam::Vec3;

use super::{hash01, roots_on_triangle, smooth, Root, VertexGrid};
use crate::engine::asset::{FaceModel, Part};
use crate::engine::identity::BeardStyle;
use crate::engine::shade::beard_mask;

/// Roots per square decimetre of beard at full [`beard_mask`] (each card a bundle of hairs),
/// fewer by the mask's square toward its edges.
const DENSITY: f32 = 2400.0;
/// Half-width of a beard card at its root (decimetres), before each card's own share.
pub(super) const WIDTH: f32 = 0.005;
/// How far above the skin (decimetres) a card's points lie at least.
pub(super) const CLEARANCE: f32 = 0.004;
/// How far the strand leaves the skin at its root: the share of the skin's normal in its
/// first direction (beard hairs leave the skin at a shallow angle and lie down along it).
const LIFT: f32 = 0.2;
/// How high above the skin a point may stand, as a share of the strand's length so far: the
/// rest is drawn back down onto the skin (a beard lies on the face).
const STAND: f32 = 0.15;
/// Segments drawn per strand (any further rows of a card collapse at its tip).
pub(super) const SEGMENTS: usize = 5;
/// A moustache's hairs reach at most this share of the way from their root to the lips' red.
const TRIMMED: f32 = 0.7;
/// The beard's neckline under the jaw (rest height, decimetres): roots thin out from the
/// second height down to the first.
const NECKLINE: (f32, f32) = (6.1, 6.22);
/// The beard's roots' hash salt (see `SCALP_SALT`).
const BEARD_SALT: u32 = 31;
/// The least beard mask a root is grown at, and the most lip red under it (the lips' region
/// fades out over a few millimetres of skin round the red: at 0.05, the skin under the lower lip
/// stayed bare).
const LEAST_MASK: f32 = 0.4;
const MOST_LIP: f32 = 0.25;
/// The least cosine between the skin a card's point lies on and the skin its previous point
/// lay on (about 70 degrees: the jaw's edge turns less than that from one point to the next).
const SAME_SIDE: f32 = 0.35;
/// How far (decimetres) from a point the centres of the skin triangles it may lie over are
/// looked for (the skin's triangles are at most a few millimetres across).
pub(super) const SKIN_REACH: f32 = 0.06;

/// Where a beard of `style` grows (rest space of the base mesh, 0..1), trimmed at a neckline
/// under the jaw (the stubble's shadow runs on down the throat): a full beard over the stubble's
/// [`beard_mask`] with the cheeks and sideburns; a goatee over the stubble's upper lip and its
/// chin, to a little beyond the mouth's corners (x 0.25 at rest); a moustache over its upper lip.
pub(crate) fn grown_mask(rest: Vec3, style: BeardStyle) -> f32 {
    let stubble = beard_mask(rest);
    let grown = match style {
        BeardStyle::Full => stubble.max(cheeks_and_sideburns(rest)),
        BeardStyle::Goatee => stubble * smooth(0.3, 0.24, rest.x.abs()),
        BeardStyle::Moustache => stubble * smooth(6.66, 6.72, rest.y),
    };
    grown * smooth(NECKLINE.0, NECKLINE.1, rest.y)
}

/// Where a full beard grows beyond the stubble's region: the cheeks up to a line rising from
/// the moustache's end (x 0.25, y 6.8) to the sideburn (x 0.64, y 7.0), and the sideburns, up the
/// side of the face in front of the ear to the scalp's hair; neither behind z 0.68, where the ear lies.
fn cheeks_and_sideburns(rest: Vec3) -> f32 {
    let (x, y, z) = (rest.x.abs(), rest.y, rest.z);
    let line = 6.8 + 0.2 * ((x - 0.25) / 0.39).clamp(0.0, 1.0);
    let cheeks = smooth(line + 0.04, line - 0.04, y) * smooth(0.22, 0.3, x) * smooth(6.0, 6.2, y) * smooth(0.68, 0.74, z);
    let sideburns = smooth(0.62, 0.66, x) * smooth(7.7, 7.55, y) * smooth(0.98, 0.88, z) * smooth(0.68, 0.74, z);
    cheeks.max(sideburns)
}

/// Where a beard strand grows, how far (decimetres) its root lies from the lips' red, and how
/// thick the beard is there.
pub(super) struct BeardRoot {
    pub root: Root,
    pub room: f32,
    /// The beard's [`grown_mask`] on the root's triangle.
    pub mask: f32,
}

/// The roots of a beard on the skin `neutral` (head map's space; `model.rest` gives the rest
/// position that the mask reads): sampled by area and mask with fixed hashes, triangle by
/// triangle, as the scalp's are.
pub(super) fn roots(model: &FaceModel, neutral: &[Vec3], style: BeardStyle) -> Vec<BeardRoot> {
    let lips = model.region("lips").unwrap_or_default();
    let mouth = model.region("inside_mouth").unwrap_or_default();
    let red: Vec<Vec3> = lips.iter().zip(neutral).filter(|&(&w, _)| w >= 0.5).map(|(_, &p)| p).collect();
    let mut roots = Vec::new();
    for (t, &[a, b, c]) in model.part(Part::Skin).triangles.iter().enumerate() {
        let [ra, rb, rc] = [a, b, c].map(|v| model.rest[v as usize]);
        let mask = grown_mask((ra + rb + rc) / 3.0, style);
        let most = |weights: &[f32]| [a, b, c].iter().map(|&v| weights.get(v as usize).copied().unwrap_or(0.0)).fold(0.0, f32::max);
        // The mask is drawn on the face's front: the inside of the mouth lies behind it.
        if mask < LEAST_MASK || most(&lips) > MOST_LIP || most(&mouth) > 0.0 {
            continue;
        }
        for root in roots_on_triangle(model, neutral, t, DENSITY * mask * mask, BEARD_SALT, Vec3::Z) {
            let room = red.iter().map(|&p| p.distance(root.position)).fold(f32::INFINITY, f32::min);
            roots.push(BeardRoot { root, room, mask });
        }
    }
    roots
}

/// The skin a beard lies on: its triangles outside the mouth, with the vertices' positions and
/// normals; [`Skin::closest`] finds the skin nearest a point.
pub(super) struct Skin<'a> {
    points: &'a [Vec3],
    normals: &'a [Vec3],
    triangles: Vec<[u32; 3]>,
}

/// The skin's closest point to a point: where it is, the skin's normal there (interpolated
/// from the corners'), and the triangle's corners and the point's weights on them.
struct Closest {
    point: Vec3,
    normal: Vec3,
    corners: [u32; 3],
    weights: Vec3,
}

impl<'a> Skin<'a> {
    /// The skin of `model` at `points` (skin vertices), whose vertex normals are `normals`.
    pub(super) fn new(model: &FaceModel, points: &'a [Vec3], normals: &'a [Vec3]) -> Skin<'a> {
        let mouth = model.region("inside_mouth").unwrap_or_default();
        let in_mouth = |v: u32| mouth.get(v as usize).is_some_and(|&w| w > 0.0);
        let triangles = model.part(Part::Skin).triangles.iter().copied().filter(|t| !t.iter().any(|&v| in_mouth(v))).collect();
        Skin { points, normals, triangles }
    }

    /// The triangles' centres, for a grid to find them by.
    pub(super) fn centres(&self) -> Vec<Vec3> {
        self.triangles.iter().map(|t| t.iter().map(|&v| self.points[v as usize]).sum::<Vec3>() / 3.0).collect()
    }

    /// The closest point to `p` on the skin facing the way `facing` does (within
    /// [`SAME_SIDE`]: the skin a card lies on, not the far side of a fold), among the
    /// triangles whose centres lie within [`SKIN_REACH`] of `p` (`grid` over [`Self::centres`]).
    fn closest(&self, p: Vec3, facing: Vec3, grid: &VertexGrid) -> Option<Closest> {
        let mut best: Option<(f32, usize, Closest)> = None;
        grid.near_segment(p, p, SKIN_REACH, |t, _| {
            let corners = self.triangles[t];
            let [a, b, c] = corners.map(|v| v as usize);
            let (q, weights) = closest_on_triangle(p, [self.points[a], self.points[b], self.points[c]]);
            let normal = (self.normals[a] * weights.x + self.normals[b] * weights.y + self.normals[c] * weights.z).normalize_or_zero();
            let d = p.distance_squared(q);
            let closer = best.as_ref().is_none_or(|(bd, bt, _)| d < *bd || (d == *bd && t < *bt));
            if closer && normal.dot(facing) > SAME_SIDE {
                best = Some((d, t, Closest { point: q, normal, corners, weights }));
            }
        });
        best.map(|(_, _, closest)| closest)
    }

    /// `p` moved along the skin's normal at its closest point to between `low` and `high`
    /// above it, and the skin there; `p` as it is and `fallback` where no skin lies near.
    fn kept_between(&self, p: Vec3, low: f32, high: f32, fallback: Under, grid: &VertexGrid) -> (Vec3, Under) {
        let Some(Closest { point, normal, corners, weights }) = self.closest(p, fallback.normal, grid) else { return (p, fallback) };
        let height = (p - point).dot(normal);
        (p + normal * (height.clamp(low, high) - height), Under { normal, corners, weights })
    }
}

/// The point of triangle `[a, b, c]` closest to `p`, and its barycentric weights.
fn closest_on_triangle(p: Vec3, [a, b, c]: [Vec3; 3]) -> (Vec3, Vec3) {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return (a, Vec3::X);
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return (b, Vec3::Y);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return (a + ab * v, Vec3::new(1.0 - v, v, 0.0));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return (c, Vec3::Z);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return (a + ac * w, Vec3::new(1.0 - w, 0.0, w));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (b + (c - b) * w, Vec3::new(0.0, 1.0 - w, w));
    }
    let denom = 1.0 / (va + vb + vc);
    let (v, w) = (vb * denom, vc * denom);
    (a + ab * v + ac * w, Vec3::new(1.0 - v - w, v, w))
}

/// The skin under a point of a beard's card: its normal (the card lies flat against it), and
/// the skin triangle's corners and the point's weights on them (it moves with that point).
#[derive(Clone, Copy)]
pub(super) struct Under {
    pub normal: Vec3,
    pub corners: [u32; 3],
    pub weights: Vec3,
}

/// The points of beard strand `n` from `beard_root`, `length` long (decimetres), `rows` in all
/// (the first [`SEGMENTS`] + 1 drawn along the skin, any further ones collapsed at the tip),
/// and the skin under each.
pub(super) fn grow(beard_root: &BeardRoot, n: u32, length: f32, rows: usize, skin: &Skin, grid: &VertexGrid) -> (Vec<Vec3>, Vec<Under>) {
    let root = &beard_root.root;
    // A little shorter toward the beard's edges, where it also thins out.
    let edge = 0.7 + 0.3 * smooth(LEAST_MASK, 0.8, beard_root.mask);
    let length = length * edge * (0.75 + 0.5 * hash01(n, 34, 0));
    // A moustache is trimmed above the lips' red (over it, and over the teeth when the lip
    // rises, it hides what the mouth does).
    let length = if moustache(root.rest) > 0.0 { length.min(TRIMMED * beard_root.room) } else { length };
    // Each strand bends sideways along the skin its own way (beard hair is never straight).
    let bend = (hash01(n, 36, 0) - 0.5) * 0.5;
    let drawn = SEGMENTS.min(rows - 1);
    let step = length / drawn as f32;
    let mut direction = (along_skin(root, n) + root.normal * LIFT).normalize();
    let at_root = Under { normal: root.normal, corners: [root.vertex; 3], weights: Vec3::new(1.0, 0.0, 0.0) };
    let (start, under) = skin.kept_between(root.position, CLEARANCE, CLEARANCE, at_root, grid);
    let (mut points, mut unders) = (vec![start], vec![under]);
    for k in 1..=drawn {
        // Hairs curve down a little more as they grow, and to their own side.
        let (last, under) = (points[points.len() - 1], unders[unders.len() - 1]);
        direction = (direction + Vec3::NEG_Y * 0.2 + under.normal.cross(direction) * bend).normalize();
        let high = CLEARANCE + STAND * step * k as f32;
        let (next, under) = skin.kept_between(last + direction * step, CLEARANCE, high, under, grid);
        direction = (next - last).normalize_or(direction);
        points.push(next);
        unders.push(under);
    }
    let (tip, under) = (points[points.len() - 1], unders[unders.len() - 1]);
    points.resize(rows, tip);
    unders.resize(rows, under);
    (points, unders)
}

/// How much of the moustache (the upper lip, above the mouth's corners) a root at `rest` is in.
fn moustache(rest: Vec3) -> f32 {
    smooth(6.7, 6.76, rest.y)
}

/// The direction along the skin a strand at `root` first grows: down the face, out from the
/// middle (on the upper lip, more out than down), each strand turned a little its own way;
/// under the chin, where down runs into the skin, back toward the neck.
fn along_skin(root: &Root, n: u32) -> Vec3 {
    let x = root.rest.x;
    let out = x.signum() * smooth(0.0, 0.12, x.abs()) * (0.25 + 0.75 * moustache(root.rest));
    let wanted = Vec3::new(out, -1.0, 0.1);
    let normal = root.normal;
    let flat = wanted - normal * wanted.dot(normal);
    let flat = if flat.length() > 0.3 { flat } else { Vec3::NEG_Z - normal * normal.dot(Vec3::NEG_Z) };
    let flat = flat.normalize_or(Vec3::NEG_Y);
    // A turn of up to ±20 degrees about the normal, strand by strand.
    let turn = (hash01(n, 35, 0) - 0.5) * 0.7;
    let side = normal.cross(flat);
    (flat * turn.cos() + side * turn.sin()).normalize_or(flat)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::engine::hair::HairModel;
    use crate::engine::identity::{Identity, IdentityTable};

    /// `id` with a beard `mm` millimetres long.
    fn bearded(id: &str, mm: f32) -> Identity {
        let mut identity = IdentityTable::built_in().get(id).unwrap().clone();
        (identity.id, identity.beard) = (format!("{id}-beard-{mm}"), mm / 100.0);
        identity
    }

    /// The beard's cards lie on the skin, not in it: measured along the skin's normal at the
    /// closest point of the skin, no corner of a card lies more than 0.25 mm inside it at rest
    /// (the rows' centres are grown [`CLEARANCE`] out; a corner half a card's width aside dips
    /// where the skin is hollow) nor more than 1.25 mm with the jaw dropped, the lips
    /// stretched or the chin raised, since each row moves with the point of the skin under it
    /// (moving with the nearest skin vertex, rows sank 4.7 mm into the chin at AU27), on four
    /// men of different faces.
    #[test]
    fn beard_cards_lie_outside_the_skin() {
        let model = FaceModel::embedded();
        let skin_end = model.part(Part::Skin).vertices.end as usize;
        let mut failures = Vec::new();
        for id in ["wm1", "bm1", "mem1", "eam1"] {
            let identity = bearded(id, 12.0);
            for (expression, least) in [("0", -0.0025), ("27", -0.0125), ("6+12+25", -0.0125), ("17+24", -0.0125)] {
                let expression = crate::facs::Catalog::built_in().parse(expression).unwrap();
                let posed = crate::engine::pose_expression(&expression, &identity).unwrap();
                let hair = HairModel::cached(model, &identity, &posed.neutral).posed(model, &posed);
                let beard = hair.model.beard_vertices();
                let skin = Skin::new(model, &posed.positions[..skin_end], &posed.normals[..skin_end]);
                let centres = skin.centres();
                let grid = VertexGrid::new(&centres, SKIN_REACH);
                // These expressions leave the head where it is: the skin under a row faces as
                // it did when the card was grown.
                let lowest = beard
                    .iter()
                    .filter_map(|&v| {
                        let (p, under) = (hair.positions[v], hair.model.rows[v / 2].lies_on?);
                        skin.closest(p, under, &grid).map(|c| (p - c.point).dot(c.normal))
                    })
                    .fold(f32::INFINITY, f32::min);
                println!("{id} {expression}: {} beard vertices, the lowest {:.3} mm above the skin", beard.len(), lowest * 100.0);
                if beard.len() < 5_000 || lowest < least {
                    failures.push(format!("{id} {expression}: {} vertices, lowest {lowest}", beard.len()));
                }
            }
        }
        assert!(failures.is_empty(), "{}", failures.join("\n"));
    }

    /// No beard, no beard cards: the hair of a person without one is the same cards, to the
    /// bit, as before beards existed (the scalp's cards come first and are grown alone).
    #[test]
    fn a_beard_adds_cards_after_the_scalps() {
        let model = FaceModel::embedded();
        let shaven = IdentityTable::built_in().get("wm1").unwrap();
        let posed = crate::engine::pose_expression(&crate::facs::Expression::neutral(), shaven).unwrap();
        let without = HairModel::new(model, shaven, &posed.neutral);
        // The same person (the id seeds the hairline's pattern), with a beard.
        let mut bearded = shaven.clone();
        bearded.beard = 0.08;
        let with = HairModel::new(model, &bearded, &posed.neutral);
        assert!(without.beard_vertices().is_empty());
        let n = without.positions.len();
        assert!(with.positions[..n] == without.positions[..], "the scalp's cards changed");
        assert!(with.beard_vertices() == (n..with.positions.len()).collect::<Vec<_>>(), "the beard's cards come last");
        assert!(with.positions.len() > n + 5_000, "{} beard vertices", with.positions.len() - n);
    }

    /// A full beard runs up the sideburns into the scalp's hair: in front of the ear, no skin
    /// between the jaw and the hairline is bare of both (on the men whose hairlines sit lowest
    /// and highest), and the beard never grows on the ear.
    #[test]
    fn the_sideburns_join_the_scalps_hair_and_spare_the_ears() {
        let model = FaceModel::embedded();
        let ears = model.region("ears").unwrap();
        let skin = || model.part(Part::Skin).vertices.clone().map(|v| v as usize);
        let on_ears: Vec<usize> = skin().filter(|&v| ears[v] >= 0.5).collect();
        assert!(on_ears.len() > 100, "{} ear vertices", on_ears.len());
        let grown_on_ears: Vec<_> = on_ears.iter().map(|&v| model.rest[v]).filter(|&p| BeardStyle::ALL.iter().any(|&style| grown_mask(p, style) > 0.0)).collect();
        assert!(grown_on_ears.is_empty(), "beard on the ears at {grown_on_ears:?}");
        let band: Vec<Vec3> = skin()
            .map(|v| model.rest[v])
            .filter(|p| (0.62..0.72).contains(&p.x.abs()) && (0.74..0.88).contains(&p.z) && (6.6..7.8).contains(&p.y))
            .collect();
        assert!(band.len() > 30, "{} vertices in front of the ears", band.len());
        for id in ["wm1", "mem2", "eam2", "bm2"] {
            let hairline = crate::engine::hair::Hairline::of(IdentityTable::built_in().get(id).unwrap());
            let bare: Vec<_> = band.iter().filter(|&&p| grown_mask(p, BeardStyle::Full) < 0.5 && hairline.mask(p, 0.5) < 0.5).collect();
            assert!(bare.is_empty(), "{id}: bare skin between the sideburn and the hair at {bare:?}");
        }
    }

    /// A goatee grows on the upper lip and the chin, no root further out than a little beyond
    /// the mouth's corners (x 0.25 at rest), and a moustache on the upper lip alone, no root
    /// below y 6.65 (the mouth's corners lie at y 6.615): each a share of a full beard's roots.
    #[test]
    fn a_goatee_and_a_moustache_grow_where_they_are_worn() {
        let model = FaceModel::embedded();
        let grown = |style| roots(model, &model.rest, style);
        let (full, goatee, moustache) = (grown(BeardStyle::Full), grown(BeardStyle::Goatee), grown(BeardStyle::Moustache));
        let widest = goatee.iter().map(|r| r.root.rest.x.abs()).fold(0.0, f32::max);
        let lowest = moustache.iter().map(|r| r.root.rest.y).fold(f32::INFINITY, f32::min);
        println!("roots: full {}, goatee {} (widest x {widest:.3}), moustache {} (lowest y {lowest:.3})", full.len(), goatee.len(), moustache.len());
        assert!(widest <= 0.31, "a goatee's root at x {widest}");
        assert!(lowest >= 6.65, "a moustache's root at y {lowest}");
        assert!(goatee.len() >= 300 && 3 * goatee.len() <= full.len(), "{} goatee roots of {}", goatee.len(), full.len());
        assert!(moustache.len() >= 100 && 2 * moustache.len() <= goatee.len(), "{} moustache roots", moustache.len());
    }
}
