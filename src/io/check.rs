//! Validity of a mesh as read from a file: what `trussmesh stats` says before any figure, and
//! what `remesh` refuses. A mesh is valid when every cell has positive size and the
//! orientation of its dimension (counter-clockwise triangles in the plane, positive tets), no
//! cell repeats a node or another cell, every facet (edge, face) bounds at most two cells that
//! use it in opposite directions, the cells around every vertex form one fan (no bowtie), and
//! no two cells overlap (the embedding; planar triangles and tets). Surface triangles in space
//! are checked for all but overlaps.

use super::{CellType, MeshData};
use crate::predicates::{orient2d, orient3d, Sign};
use glam::{DVec2, DVec3};
use std::collections::HashMap;

/// The kinds of problem, in the order they are reported.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum ProblemKind {
    /// A cell that uses one node twice.
    RepeatedNode,
    /// A cell of zero area or volume.
    Degenerate,
    /// A cell of the wrong orientation (clockwise, negative).
    Reversed,
    /// A cell given twice (the same nodes in any order).
    Duplicate,
    /// A facet shared by more than two cells (a fin).
    NonManifoldFacet,
    /// Two cells that run a shared facet in the same direction (orientations disagree).
    InconsistentOrientation,
    /// A vertex whose cells form more than one fan (a bowtie).
    NonManifoldVertex,
    /// Two cells whose interiors overlap.
    Overlap,
}

/// One kind of problem: how many, and the first case in words.
#[derive(Clone, Debug, PartialEq)]
pub struct Problem {
    /// The kind.
    pub kind: ProblemKind,
    /// How many cells, facets, vertices or pairs have it.
    pub count: usize,
    /// What is wrong, with the first case: "2 triangles are clockwise (reversed): triangle 0
    /// (nodes 0, 2, 1) ...".
    pub message: String,
}

/// The result of [`check_mesh`]: empty when the mesh is valid.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshCheck {
    /// The problems found, one entry per kind.
    pub problems: Vec<Problem>,
}

impl MeshCheck {
    /// True when no problem was found.
    pub fn is_valid(&self) -> bool {
        self.problems.is_empty()
    }
}

fn plural(n: usize, one: &str, many: &str) -> String {
    if n == 1 {
        format!("1 {one}")
    } else {
        format!("{n} {many}")
    }
}

fn nodes(c: &[usize]) -> String {
    c.iter().map(|v| v.to_string()).collect::<Vec<_>>().join(", ")
}

/// Collects the problems of one kind.
struct Found {
    kind: ProblemKind,
    count: usize,
    first: Option<String>,
}

impl Found {
    fn new(kind: ProblemKind) -> Found {
        Found { kind, count: 0, first: None }
    }
    fn add(&mut self, what: impl FnOnce() -> String) {
        if self.first.is_none() {
            self.first = Some(what());
        }
        self.count += 1;
    }
    fn finish(self, out: &mut Vec<Problem>, describe: impl FnOnce(usize) -> String) {
        if let Some(first) = self.first {
            let message = format!("{}: {first}{}", describe(self.count), if self.count > 1 { ", ..." } else { "" });
            out.push(Problem { kind: self.kind, count: self.count, message });
        }
    }
}

/// Checks a mesh (see the module notes). The indices must be in range ([`MeshData::validate`],
/// which every reader runs).
pub fn check_mesh(m: &MeshData) -> MeshCheck {
    let mut problems = Vec::new();
    let n = m.num_cells();
    let (cell, cells) = match m.cell_type {
        CellType::Triangle => ("triangle", "triangles"),
        CellType::Tetra => ("tetrahedron", "tetrahedra"),
    };
    let k = m.cell_type.nodes();
    let pt2 = |i: usize| DVec2::new(m.points[i][0], m.points[i][1]);
    let pt3 = |i: usize| DVec3::from_array(m.points[i]);
    let planar = m.dim == 2 && m.cell_type == CellType::Triangle;

    // Cells one by one: repeated nodes, size and orientation.
    let mut repeated = Found::new(ProblemKind::RepeatedNode);
    let mut degenerate = Found::new(ProblemKind::Degenerate);
    let mut reversed = Found::new(ProblemKind::Reversed);
    let mut skip = vec![false; n];
    for (i, skip) in skip.iter_mut().enumerate() {
        let c = m.cell(i);
        if (0..k).any(|a| (a + 1..k).any(|b| c[a] == c[b])) {
            repeated.add(|| format!("{cell} {i} (nodes {})", nodes(c)));
            *skip = true;
            continue;
        }
        let sign = match m.cell_type {
            CellType::Triangle if planar => orient2d(pt2(c[0]), pt2(c[1]), pt2(c[2])),
            CellType::Triangle => {
                let a = (pt3(c[1]) - pt3(c[0])).cross(pt3(c[2]) - pt3(c[0]));
                if a == DVec3::ZERO {
                    Sign::Zero
                } else {
                    Sign::Positive
                }
            }
            CellType::Tetra => orient3d(pt3(c[0]), pt3(c[1]), pt3(c[2]), pt3(c[3])),
        };
        match sign {
            Sign::Zero => {
                degenerate.add(|| format!("{cell} {i} (nodes {})", nodes(c)));
                *skip = true;
            }
            Sign::Negative => reversed.add(|| format!("{cell} {i} (nodes {})", nodes(c))),
            Sign::Positive => {}
        }
    }
    repeated.finish(&mut problems, |c| {
        format!("{} a node twice", plural(c, &format!("{cell} uses"), &format!("{cells} use")))
    });
    let measure = if m.cell_type == CellType::Tetra { "volume" } else { "area" };
    degenerate.finish(&mut problems, |c| {
        if c == 1 && n == 1 {
            format!("the only {cell} has zero {measure} (it is flat or its nodes coincide)")
        } else if c == n {
            format!("every {cell} has zero {measure} (all {c} are flat or their nodes coincide)")
        } else {
            format!("{} zero {measure}", plural(c, &format!("{cell} has"), &format!("{cells} have")))
        }
    });
    let orientation = if m.cell_type == CellType::Tetra {
        "negatively oriented (det[b-a, c-a, d-a] < 0)"
    } else {
        "clockwise (reversed)"
    };
    reversed.finish(&mut problems, |c| {
        if c == 1 && n == 1 {
            format!("the only {cell} is {orientation}")
        } else if c == n {
            format!("every {cell} is {orientation}: the whole mesh is reversed")
        } else {
            format!("{} {orientation}", plural(c, &format!("{cell} is"), &format!("{cells} are")))
        }
    });

    // Duplicated cells: equal sorted node lists, found by sorting.
    let key_of = |c: &[usize]| {
        let mut k = [usize::MAX; 4];
        k[..c.len()].copy_from_slice(c);
        k[..c.len()].sort_unstable();
        k
    };
    let mut dup = Found::new(ProblemKind::Duplicate);
    let mut order: Vec<([usize; 4], usize)> = (0..n).filter(|&i| !skip[i]).map(|i| (key_of(m.cell(i)), i)).collect();
    order.sort_unstable();
    for w in order.windows(2) {
        if w[0].0 == w[1].0 {
            let (j, i) = (w[0].1, w[1].1);
            dup.add(|| format!("{cell} {i} (nodes {}) repeats {cell} {j}", nodes(m.cell(i))));
            // The copy is left out of the checks below: it is reported once, here.
            skip[i] = true;
        }
    }
    drop(order);
    dup.finish(&mut problems, |c| plural(c, &format!("{cell} is given twice"), &format!("{cells} are given twice")));

    // Facets: how many cells each bounds, and in which directions (sorted, then grouped).
    let facet_name = if m.cell_type == CellType::Tetra { "face" } else { "edge" };
    let mut facets: Vec<([usize; 3], usize, bool)> = Vec::with_capacity((k) * n);
    for (i, &s) in skip.iter().enumerate() {
        if s {
            continue;
        }
        let c = m.cell(i);
        let mut add = |f: &[usize]| {
            let mut key = [usize::MAX; 3];
            key[..f.len()].copy_from_slice(f);
            key[..f.len()].sort_unstable();
            facets.push((key, i, even_permutation(f)));
        };
        // The facets of `cell_facets`, oriented outward, without allocating.
        match m.cell_type {
            CellType::Triangle => {
                add(&[c[0], c[1]]);
                add(&[c[1], c[2]]);
                add(&[c[2], c[0]]);
            }
            CellType::Tetra => {
                add(&[c[1], c[2], c[3]]);
                add(&[c[0], c[3], c[2]]);
                add(&[c[0], c[1], c[3]]);
                add(&[c[0], c[2], c[1]]);
            }
        }
    }
    facets.sort_unstable();
    let mut fin = Found::new(ProblemKind::NonManifoldFacet);
    let mut inconsistent = Found::new(ProblemKind::InconsistentOrientation);
    let shown = |key: &[usize; 3]| nodes(&key.iter().copied().filter(|&v| v != usize::MAX).collect::<Vec<_>>());
    // Pairs of cells joined through a facet, for the fans below.
    let mut joined: Vec<(usize, usize, [usize; 3])> = Vec::new();
    let mut g = 0;
    while g < facets.len() {
        let mut e = g + 1;
        while e < facets.len() && facets[e].0 == facets[g].0 {
            e += 1;
        }
        let users = &facets[g..e];
        let key = &users[0].0;
        if users.len() > 2 {
            let list = users.iter().map(|u| u.1.to_string()).collect::<Vec<_>>().join(", ");
            fin.add(|| format!("{facet_name} ({}) bounds {cells} {list}", shown(key)));
        } else if users.len() == 2 && users[0].2 == users[1].2 {
            inconsistent
                .add(|| format!("{cells} {} and {} share {facet_name} ({})", users[0].1, users[1].1, shown(key)));
        }
        for x in 0..users.len() {
            for y in x + 1..users.len() {
                joined.push((users[x].1, users[y].1, *key));
            }
        }
        g = e;
    }
    drop(facets);
    fin.finish(&mut problems, |c| {
        format!(
            "{} more than two {cells} (a fin)",
            plural(c, &format!("{facet_name} bounds"), &format!("{facet_name}s bound"))
        )
    });
    inconsistent.finish(&mut problems, |c| {
        format!(
            "{} pair{} of {cells} run a shared {facet_name} the same way (their orientations disagree)",
            c,
            if c == 1 { "" } else { "s" }
        )
    });

    // Bowties: the cells around a node must form one fan, joined through facets that hold
    // the node.
    let mut bowtie = Found::new(ProblemKind::NonManifoldVertex);
    for (v, comps) in vertex_fans(m, &skip, &joined) {
        bowtie.add(|| format!("node {v} joins {comps} separate fans of {cells}"));
    }
    bowtie.finish(&mut problems, |c| {
        format!("{} (a bowtie: the mesh is pinched there)", plural(c, "node is not manifold", "nodes are not manifold"))
    });

    // The embedding: no two cells may overlap.
    if planar || m.cell_type == CellType::Tetra {
        let mut overlap = Found::new(ProblemKind::Overlap);
        for (a, b) in overlapping_pairs(m, &skip) {
            overlap
                .add(|| format!("{cell} {a} (nodes {}) and {cell} {b} (nodes {})", nodes(m.cell(a)), nodes(m.cell(b))));
        }
        overlap.finish(&mut problems, |c| {
            format!("{} of {cells} overlap{}", plural(c, "pair", "pairs"), if c == 1 { "s" } else { "" })
        });
    }
    MeshCheck { problems }
}

/// Whether the facet's node order is an even permutation of its sorted order.
fn even_permutation(f: &[usize]) -> bool {
    let mut inversions = 0;
    for a in 0..f.len() {
        for b in a + 1..f.len() {
            if f[a] > f[b] {
                inversions += 1;
            }
        }
    }
    inversions % 2 == 0
}

/// Vertices whose cells form more than one connected fan, with the number of fans. `joined`
/// lists the pairs of cells that share a facet, with the facet's nodes.
fn vertex_fans(m: &MeshData, skip: &[bool], joined: &[(usize, usize, [usize; 3])]) -> Vec<(usize, usize)> {
    let np = m.points.len();
    // The (node, cell) incidences, grouped by node (CSR).
    let mut start = vec![0usize; np + 1];
    for (i, &s) in skip.iter().enumerate() {
        if !s {
            for &v in m.cell(i) {
                start[v + 1] += 1;
            }
        }
    }
    for v in 0..np {
        start[v + 1] += start[v];
    }
    let mut fill = start.clone();
    let mut cell_of = vec![0usize; start[np]];
    for (i, &s) in skip.iter().enumerate() {
        if !s {
            for &v in m.cell(i) {
                cell_of[fill[v]] = i;
                fill[v] += 1;
            }
        }
    }
    let slot = |v: usize, c: usize| start[v] + cell_of[start[v]..start[v + 1]].iter().position(|&x| x == c).unwrap();
    let mut parent: Vec<usize> = (0..cell_of.len()).collect();
    fn find(p: &mut [usize], mut x: usize) -> usize {
        while p[x] != x {
            p[x] = p[p[x]];
            x = p[x];
        }
        x
    }
    for &(a, b, key) in joined {
        for &v in key.iter().filter(|&&v| v != usize::MAX) {
            let (ra, rb) = (find(&mut parent, slot(v, a)), find(&mut parent, slot(v, b)));
            parent[ra] = rb;
        }
    }
    let mut out = Vec::new();
    for v in 0..np {
        let fans = (start[v]..start[v + 1]).filter(|&x| find(&mut parent, x) == x).count();
        if fans > 1 {
            out.push((v, fans));
        }
    }
    out
}

/// Pairs of cells (a < b) whose interiors overlap, found through a grid of buckets and a
/// separating-axis test that counts touching (a shared node, edge or face) as apart.
fn overlapping_pairs(m: &MeshData, skip: &[bool]) -> Vec<(usize, usize)> {
    let dim = if m.cell_type == CellType::Tetra { 3 } else { 2 };
    let live: Vec<usize> = (0..m.num_cells()).filter(|&i| !skip[i]).collect();
    if live.len() < 2 {
        return Vec::new();
    }
    let corners = |i: usize| -> Vec<DVec3> { m.cell(i).iter().map(|&v| DVec3::from_array(m.points[v])).collect() };
    let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    let mut mean = 0.0;
    for &i in &live {
        let c = corners(i);
        let (a, b) = c.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(a, b), p| (a.min(*p), b.max(*p)));
        lo = lo.min(a);
        hi = hi.max(b);
        mean += (b - a).max_element();
    }
    mean /= live.len() as f64;
    let span = hi - lo;
    // About one cell per bucket, at most 4 buckets per cell.
    let cell = mean.max(span.max_element() / (4.0 * live.len() as f64).powf(1.0 / dim as f64)).max(1e-300);
    let dims: Vec<usize> = (0..dim).map(|k| ((span[k] / cell).floor() as usize + 1).min(1 << 20)).collect();
    let bucket = |p: DVec3, k: usize| (((p[k] - lo[k]) / cell).floor().max(0.0) as usize).min(dims[k] - 1);
    let mut buckets: HashMap<[usize; 3], Vec<usize>> = HashMap::new();
    let mut boxes = vec![(DVec3::ZERO, DVec3::ZERO); m.num_cells()];
    for &i in &live {
        let c = corners(i);
        let (a, b) = c.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(a, b), p| (a.min(*p), b.max(*p)));
        boxes[i] = (a, b);
        let (ia, ib): (Vec<usize>, Vec<usize>) = (0..dim).map(|k| (bucket(a, k), bucket(b, k))).unzip();
        let z = if dim == 3 { ia[2]..=ib[2] } else { 0..=0 };
        for bz in z {
            for by in ia[1]..=ib[1] {
                for bx in ia[0]..=ib[0] {
                    buckets.entry([bx, by, bz]).or_default().push(i);
                }
            }
        }
    }
    let mut pairs = Vec::new();
    let mut keys: Vec<&[usize; 3]> = buckets.keys().collect();
    keys.sort_unstable();
    for key in keys {
        let list = &buckets[key];
        for (x, &a) in list.iter().enumerate() {
            for &b in &list[x + 1..] {
                let (pa, pb) = (boxes[a], boxes[b]);
                // Each pair once: in the bucket of the lower corner of the boxes' intersection.
                let low = pa.0.max(pb.0);
                if (0..dim).any(|k| bucket(low, k) != key[k]) {
                    continue;
                }
                if (0..dim).any(|k| pa.1[k] <= pb.0[k] || pb.1[k] <= pa.0[k]) {
                    continue;
                }
                if cells_overlap(&corners(a), &corners(b), dim) {
                    pairs.push((a.min(b), a.max(b)));
                }
            }
        }
    }
    pairs.sort_unstable();
    pairs
}

/// Separating axes: two convex cells are apart when their projections onto some axis (an
/// edge normal in 2-D; a face normal or a cross product of edges in 3-D) overlap by no more
/// than rounding.
fn cells_overlap(a: &[DVec3], b: &[DVec3], dim: usize) -> bool {
    let mut axes: Vec<DVec3> = Vec::new();
    let edges = |c: &[DVec3]| -> Vec<DVec3> {
        let mut e = Vec::new();
        for x in 0..c.len() {
            for y in x + 1..c.len() {
                e.push(c[y] - c[x]);
            }
        }
        e
    };
    let (ea, eb) = (edges(a), edges(b));
    if dim == 2 {
        for e in ea.iter().chain(&eb) {
            axes.push(DVec3::new(-e.y, e.x, 0.0));
        }
    } else {
        for c in [a, b] {
            for f in [[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]] {
                axes.push((c[f[1]] - c[f[0]]).cross(c[f[2]] - c[f[0]]));
            }
        }
        for x in &ea {
            for y in &eb {
                axes.push(x.cross(*y));
            }
        }
    }
    let scale = a.iter().chain(b).fold(0.0f64, |s, p| s.max(p.abs().max_element())).max(1e-300);
    for axis in axes {
        let len = axis.length();
        if len.is_nan() || len <= 1e-12 * scale * scale {
            continue;
        }
        let u = axis / len;
        let range = |c: &[DVec3]| {
            c.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), p| (l.min(p.dot(u)), h.max(p.dot(u))))
        };
        let ((la, ha), (lb, hb)) = (range(a), range(b));
        let depth = ha.min(hb) - la.max(lb);
        if depth <= 1e-9 * scale {
            return false;
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tri(points: &[[f64; 2]], cells: &[[usize; 3]]) -> MeshData {
        MeshData {
            dim: 2,
            cell_type: CellType::Triangle,
            points: points.iter().map(|p| [p[0], p[1], 0.0]).collect(),
            cells: cells.iter().flatten().copied().collect(),
            subdomain: None,
        }
    }

    const SQUARE: [[f64; 2]; 4] = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];

    fn kinds(m: &MeshData) -> Vec<ProblemKind> {
        check_mesh(m).problems.iter().map(|p| p.kind).collect()
    }

    #[test]
    fn a_good_square_passes_and_each_fault_is_named() {
        assert_eq!(kinds(&tri(&SQUARE, &[[0, 1, 2], [0, 2, 3]])), vec![]);
        let r = check_mesh(&tri(&SQUARE, &[[0, 2, 1], [0, 2, 3]]));
        assert_eq!(r.problems[0].kind, ProblemKind::Reversed);
        assert!(r.problems[0].message.starts_with("1 triangle is clockwise (reversed): triangle 0 (nodes 0, 2, 1)"));
        assert!(kinds(&tri(&SQUARE, &[[0, 1, 2], [0, 2, 3], [2, 0, 3]])).contains(&ProblemKind::Duplicate));
        // Two triangles on the same side of their shared edge.
        let folded = tri(&[[0.0, 0.0], [1.0, 0.0], [0.5, 1.0], [0.5, 0.5]], &[[0, 1, 2], [0, 1, 3]]);
        assert!(kinds(&folded).contains(&ProblemKind::Overlap), "{:?}", check_mesh(&folded));
        assert!(kinds(&folded).contains(&ProblemKind::InconsistentOrientation));
    }

    #[test]
    fn touching_cells_do_not_overlap() {
        // A fan of 8 triangles around the centre of a square: every pair touches.
        let mut p = vec![[0.5, 0.5]];
        let mut cells = Vec::new();
        for k in 0..8 {
            let a = std::f64::consts::TAU * k as f64 / 8.0;
            p.push([0.5 + a.cos(), 0.5 + a.sin()]);
            cells.push([0, 1 + k, 1 + (k + 1) % 8]);
        }
        assert!(check_mesh(&tri(&p, &cells)).is_valid(), "{:?}", check_mesh(&tri(&p, &cells)));
    }
}
