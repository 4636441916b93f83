//! Fan winding under a vertex move (relocation, and the merge of an edge collapse), decided
//! locally with exact predicates.
//!
//! A move of vertex v to p that keeps every triangle around v positive (exact orient2d) still
//! embeds the mesh wherever the fans are closed:
//!
//! - **v interior.** Its link polygon is unchanged and bounds v's star, a simple polygon. p is
//!   strictly left of every link edge (positivity), i.e. in the polygon's kernel, which is
//!   convex, misses the polygon and holds the old position: the fan's winding number (the
//!   polygon's around p) stays 1.
//! - **A neighbour w across an interior edge w-v.** The two sectors (a, v) and (v, b) of w's
//!   fan turn by angles in (0, pi) each, so their sum lies in (0, 2 pi) and is congruent to the
//!   turn from a to b: it is that turn, independent of where v is. w's total is unchanged.
//!
//! What positivity misses are the open fans at the boundary: v's own fan when v is on the
//! boundary (its first and last rays are not tied to each other, so the sectors can wrap past
//! 2 pi), and the fans of v's two boundary neighbours (the sector with v is the first or last
//! of their open fans, so its angle changes their total). These three fans are checked with
//! [`MeshPoint::fan_winds_once`] (exact): a walk around each vertex, no heap allocation.
//!
//! An edge collapse a -> b with b at `pos` is the same move on the merged vertex: its link is
//! the union of the two links (a simple polygon by the link condition), so a closed merged fan
//! and the closed fans around it cannot fold either; the open fans of the merged vertex and of
//! its boundary neighbours are checked the same way.
//!
//! The fans being right, the moved star can still overlap a far part of the boundary that
//! comes close (a deep notch, a thin gap). The coverage changes only inside the polygon
//! (last, p, first, v_old) (for a collapse, the old path through a and b) between the new boundary path last -> p -> first and the old one,
//! fanned from p into triangles, (p, first, v_old) and (p, v_old, last): it grows only where
//! one of them is positive. When neither is (the move goes inwards) the
//! move is safe. Otherwise the two new boundary edges must not meet any other edge of v's
//! boundary loop (exact segment tests along the loop). In a connected planar mesh each
//! complement component is bordered by one loop, so the rest of the mesh can reach the grown
//! part only across that loop: with the fans, the test is exact. (Another component lying in
//! the grown part is not seen.)
//!
//! Points in space have no plane to wind in: the check passes for them (surface meshers move
//! vertices themselves and check folds by normals and self-intersection).

use super::intersect::segments_meet;
use super::trimesh::{FaceId, HalfEdgeId, MeshPoint, TriMesh, VertexId};
use super::Refusal;
use crate::predicates::{orient2d, Sign};
use glam::DVec2;
use smallvec::SmallVec;

/// A vertex move to check: `gone` and `kept` end as one vertex `kept` at `pos` (the same
/// vertex for a relocation), and the faces `skip` vanish (those of a collapsed edge).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Move<P> {
    pub(crate) gone: VertexId,
    pub(crate) kept: VertexId,
    pub(crate) pos: P,
    pub(crate) skip: [Option<FaceId>; 2],
}

impl<P> Move<P> {
    #[inline]
    fn id(&self, u: VertexId) -> VertexId {
        if u == self.gone {
            self.kept
        } else {
            u
        }
    }
}

/// The open fan of a boundary vertex after a move: whether it turns by less than 2 pi, and its
/// first and last ring vertices.
struct OpenFan {
    ok: bool,
    first: VertexId,
    last: VertexId,
}

/// See the module notes: whether the boundary vertex `kept` at `pos` (loop
/// ... -> first -> [old path] -> last -> ..., whose loop half-edge into `last` is `into_last`)
/// keeps its new boundary edges last-pos and pos-first clear of the rest of its loop. `old`
/// lists the old path's vertices from first's side to last's.
pub(super) fn boundary_move_clear(
    m: &TriMesh<DVec2>,
    old: &[VertexId],
    pos: DVec2,
    first: VertexId,
    last: VertexId,
    into_last: HalfEdgeId,
) -> bool {
    let (pf, pl) = (m.pos(first), m.pos(last));
    // The coverage grows only inside the positive triangles of the fan from pos over the
    // polygon first, old..., last.
    let mut prev = pf;
    let mut grows = false;
    for q in old.iter().map(|&u| m.pos(u)).chain(std::iter::once(pl)) {
        grows |= orient2d(pos, prev, q) == Sign::Positive;
        prev = q;
    }
    if !grows {
        return true;
    }
    // The loop from last back to first; an edge whose box misses a new edge's box cannot meet
    // it (exact comparisons), which spares the predicates on almost every edge.
    let (lo_l, hi_l) = (pl.min(pos), pl.max(pos));
    let (lo_f, hi_f) = (pf.min(pos), pf.max(pos));
    let apart = |lo: DVec2, hi: DVec2, pa: DVec2, pb: DVec2| {
        pa.x.max(pb.x) < lo.x || pa.x.min(pb.x) > hi.x || pa.y.max(pb.y) < lo.y || pa.y.min(pb.y) > hi.y
    };
    let mut h = m.next(into_last);
    let mut left = m.half_edges.len();
    while m.origin(h) != first && left > 0 {
        let (a, b) = (m.origin(h), m.dest(h));
        let (pa, pb) = (m.pos(a), m.pos(b));
        if a != last && b != last && !apart(lo_l, hi_l, pa, pb) && segments_meet(pl, pos, pa, pb) {
            return false;
        }
        if a != first && b != first && !apart(lo_f, hi_f, pa, pb) && segments_meet(pos, pf, pa, pb) {
            return false;
        }
        h = m.next(h);
        left -= 1;
    }
    left > 0
}

impl<P: MeshPoint> TriMesh<P> {
    /// The outgoing half-edges of `v`, clockwise from its `out`, without allocating.
    #[inline]
    fn around(&self, v: VertexId) -> impl Iterator<Item = HalfEdgeId> + '_ {
        let start = self.vertices[v].out;
        let mut x = Some(start);
        let mut left = self.half_edges.len();
        std::iter::from_fn(move || {
            let cur = x?;
            let n = self.next(self.twin(cur));
            left = left.saturating_sub(1);
            x = (n != start && left > 0).then_some(n);
            Some(cur)
        })
    }

    /// The fan of the boundary vertex `w` after the move `mv` (`w` may be `mv.kept`, whose
    /// fan then joins the fans of `kept` and `gone`); `None` when it is no single open fan.
    fn open_fan_after(&self, w: VertexId, mv: &Move<P>) -> Option<OpenFan> {
        let mut sectors: SmallVec<[(VertexId, VertexId); 16]> = SmallVec::new();
        let centres = if w == mv.kept { [mv.kept, mv.gone] } else { [w, w] };
        for (i, &c) in centres.iter().enumerate() {
            if i == 1 && c == centres[0] {
                break;
            }
            for h in self.around(c) {
                if let Some(f) = self.face_of(h) {
                    if !mv.skip.contains(&Some(f)) {
                        sectors.push((mv.id(self.dest(h)), mv.id(self.dest(self.next(h)))));
                    }
                }
            }
        }
        // One open fan: exactly one sector starts where none ends, and one ends where none starts.
        let mut starts = sectors.iter().filter(|s| !sectors.iter().any(|t| t.1 == s.0));
        let mut ends = sectors.iter().filter(|s| !sectors.iter().any(|t| t.0 == s.1));
        let (first, last) = (starts.next()?.0, ends.next()?.1);
        if starts.next().is_some() || ends.next().is_some() {
            return Some(OpenFan { ok: false, first, last });
        }
        let at = |u: VertexId| if u == mv.kept { mv.pos } else { self.pos(u) };
        let ok = P::fan_winds_once(at(w), sectors.iter().map(|&(b, c)| (at(b), at(c))), Some(at(first)));
        Some(OpenFan { ok, first, last })
    }

    /// The fan part of a move's check (relocation or collapse), once every triangle that
    /// survives around the moved vertex is known to stay positive: refuses a move that would
    /// fold an open fan or lay the moved star over another part of its boundary loop (see
    /// the module notes; closed fans cannot fold).
    pub(crate) fn check_move_fans(&self, mv: &Move<P>) -> Result<(), Refusal> {
        let boundary = |u: VertexId| self.face_of(self.vertices[u].out).is_none();
        if !boundary(mv.kept) && !boundary(mv.gone) {
            return Ok(());
        }
        let fan = self.open_fan_after(mv.kept, mv).ok_or(Refusal::WouldFold)?;
        if !fan.ok {
            return Err(Refusal::WouldFold);
        }
        // The boundary neighbours (a superset of those whose fans change: across an interior
        // edge a neighbour's total turn stays).
        for c in [mv.kept, mv.gone] {
            for h in self.around(c) {
                let w = self.dest(h);
                if w != mv.kept && w != mv.gone && boundary(w) && !self.open_fan_after(w, mv).is_some_and(|f| f.ok) {
                    return Err(Refusal::WouldFold);
                }
            }
            if mv.gone == mv.kept {
                break;
            }
        }
        // The old boundary path from first to last, and the loop half-edge into last.
        let mut old: SmallVec<[VertexId; 2]> = SmallVec::new();
        let mut into_last = None;
        for c in [mv.kept, mv.gone] {
            let out = self.vertices[c].out;
            if boundary(c) && !old.contains(&c) {
                old.push(c);
                if self.dest(out) == fan.last {
                    into_last = Some(out);
                }
            }
        }
        // The loop runs first -> (old path) -> last.
        if old.len() == 2 && self.dest(self.vertices[old[0]].out) != old[1] {
            old.swap(0, 1);
        }
        let into_last = into_last.ok_or(Refusal::WouldFold)?;
        if !P::boundary_move_clear(self, &old, mv.pos, fan.first, fan.last, into_last) {
            return Err(Refusal::WouldFold);
        }
        Ok(())
    }
}
