//! The start mesh: the input survey, a body-centred cubic lattice thinned by the size function
//! with surface points projected onto d = 0, the points on sharp features, Delaunay, the carve
//! to the domain and the repair of pinched vertices and edges.

use super::features::crease_points;
use super::options::Options3;
use super::{Ctx, CHUNK};
use crate::geometry::Implicit3;
use crate::mesher::truss::domain::{check_box_boundary, check_input, checked_d, checked_h};
use crate::topology::{TVertexId, TetId, TetMesh, VertexTag};
use crate::Error;
use glam::DVec3;
use rayon::prelude::*;
use slotmap::SecondaryMap;
use smallvec::SmallVec;
use std::collections::HashMap;
use std::time::Instant;

/// Lattice side over target edge length: the BCC Delaunay edges are a and a sqrt(3)/2 long.
const LATTICE: f64 = 1.1;
/// The interior lattice points' offset, in lattice sides (see [`jitter`]).
const LATTICE_JITTER: f64 = 1e-6;
/// Surface start points are at least this many lattice sides (times h) apart.
const SURFACE_GAP: f64 = 0.9;
/// Lattice points deeper than this many lattice sides (times h) are interior start points.
const INTERIOR_DEPTH: f64 = 0.45;

pub(super) fn eval_d(domain: &dyn Implicit3, p: DVec3) -> Result<f64, Error> {
    checked_d(domain.value(p), p)
}

/// The relative size, raised to `floor` where it is not positive (outside the domain, where
/// size functions need not make sense); non-finite values are errors.
pub(super) fn eval_h_floor(opts: &Options3, p: DVec3, floor: f64) -> Result<f64, Error> {
    checked_h(opts.size.as_deref(), p, floor)
}

pub(crate) struct Survey {
    pub(crate) estimated_tets: f64,
    pub(super) h_floor: f64,
}

/// Checks h0, the box, the fixed points, d and h on a sample grid, and the element estimate,
/// before anything large is allocated.
pub(crate) fn survey(domain: &dyn Implicit3, opts: &Options3) -> Result<Survey, Error> {
    let h0 = opts.h0;
    let [lo, hi] = opts.bbox;
    check_input(h0, lo, hi, &opts.fixed)?;
    if !opts.fscale.is_finite() || opts.fscale <= 0.0 || !opts.deltat.is_finite() || opts.deltat <= 0.0 {
        return Err(Error::Invalid(format!(
            "fscale and deltat must be positive and finite, got {} and {}",
            opts.fscale, opts.deltat
        )));
    }
    let ext = hi - lo;
    let n = |e: f64| ((e / h0).ceil() as usize + 1).clamp(8, 96);
    let (nx, ny, nz) = (n(ext.x), n(ext.y), n(ext.z));
    let step = ext / DVec3::new((nx - 1) as f64, (ny - 1) as f64, (nz - 1) as f64);
    let mut inside = 0usize;
    let mut density = 0.0;
    let mut h_floor = f64::INFINITY;
    // Only the side of d = 0 matters here away from it: a sample with nothing within 1.5
    // spacings takes the side of the sample met before it (see `Implicit3::value_near`).
    let reach = 1.5 * step.max_element();
    let mut side = vec![0i8; nx * ny * nz];
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let p = lo + DVec3::new(i as f64, j as f64, k as f64) * step;
                let at = i + nx * (j + ny * k);
                let before = earlier([i, j, k]).map(|[a, b, c]| side[a + nx * (b + ny * c)]).unwrap_or(0);
                let on_box = i == 0 || j == 0 || k == 0 || i == nx - 1 || j == ny - 1 || k == nz - 1;
                let d = match domain.value_near(p, reach) {
                    Some(d) => checked_d(d, p)?,
                    None if before != 0 && !on_box => f64::from(before) * reach,
                    None => eval_d(domain, p)?,
                };
                side[at] = if d < 0.0 { -1 } else { 1 };
                if d < 0.0 && on_box {
                    check_box_boundary(d, domain.gradient(p).length(), p, h0)?;
                }
                if d < 0.0 {
                    let h = eval_h_floor(opts, p, f64::NEG_INFINITY)?;
                    if h <= 0.0 {
                        return Err(Error::BadSize(format!(
                            "the size function is {h} at {p:?} inside the domain; it must be positive"
                        )));
                    }
                    inside += 1;
                    density += 1.0 / (h * h * h);
                    h_floor = h_floor.min(h);
                } else {
                    eval_h_floor(opts, p, 0.0)?;
                }
            }
        }
    }
    if inside == 0 {
        // Cell centres once more before giving up (thin domains).
        let mut found = false;
        'outer: for k in 0..nz - 1 {
            for j in 0..ny - 1 {
                for i in 0..nx - 1 {
                    let p = lo + (DVec3::new(i as f64, j as f64, k as f64) + 0.5) * step;
                    if eval_d(domain, p)? < 0.0 {
                        found = true;
                        break 'outer;
                    }
                }
            }
        }
        if !found {
            return Err(Error::EmptyDomain(format!(
                "the distance function is non-negative at every sample of the box {lo:?} - {hi:?}"
            )));
        }
        inside = 1;
        density = 1.0;
        h_floor = 1.0;
    }
    let _ = inside;
    let cell = step.x * step.y * step.z;
    // About 6.4 tets per node in a good mesh; the BCC start has 2 nodes per (LATTICE h)^3.
    let nodes = density * h_floor.powi(3) * cell * 2.0 / (LATTICE * h0).powi(3);
    let estimated_tets = 6.4 * nodes;
    if estimated_tets > opts.max_elements as f64 {
        return Err(Error::TooManyElements { estimated: estimated_tets as u64, limit: opts.max_elements });
    }
    Ok(Survey { estimated_tets, h_floor })
}

/// The grid point met just before `[i, j, k]` in a sweep with i fastest (one step back along
/// the first axis that allows it), or `None` for the first point.
fn earlier([i, j, k]: [usize; 3]) -> Option<[usize; 3]> {
    if i > 0 {
        Some([i - 1, j, k])
    } else if j > 0 {
        Some([i, j - 1, k])
    } else if k > 0 {
        Some([i, j, k - 1])
    } else {
        None
    }
}

/// The SplitMix64 output for state `z` (Steele, Lea and Flood 2014), as a number in [0, 1).
pub(super) fn splitmix_unit(z: u64) -> f64 {
    let mut z = z;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
}

/// A deterministic pseudo-random vector in [-1, 1]^3 for index i.
fn jitter(i: u64) -> DVec3 {
    let unit =
        |k: u64| 2.0 * splitmix_unit(i.wrapping_mul(3).wrapping_add(k).wrapping_add(0x9E37_79B9_7F4A_7C15)) - 1.0;
    DVec3::new(unit(0), unit(1), unit(2))
}

/// BCC lattice points inside, thinned by the size function; Delaunay; carve; repair pinches.
pub(super) fn initial_mesh(ctx: &mut Ctx, estimate: f64) -> Result<TetMesh, Error> {
    let opts = ctx.opts;
    let a = LATTICE * opts.h0;
    let [lo, hi] = [opts.bbox[0] - DVec3::splat(ctx.start_shift * a), opts.bbox[1]];
    let n = ((hi - lo) / a).ceil().as_uvec3() + 1;
    let uniform = opts.size.is_none();
    let mut pts: Vec<DVec3> = Vec::with_capacity((estimate / 6.0) as usize + 16);
    // Surface points: lattice points near d = 0 projected onto it, thinned greedily (in lattice
    // order, so deterministically) to SURFACE_GAP lattice sides times h apart. The carved
    // mesh's boundary then starts on the surface instead of a lattice row inside it.
    let gap = SURFACE_GAP * a;
    let mut grid: HashMap<[i64; 3], SmallVec<[DVec3; 4]>> = HashMap::new();
    // Every projected point, before the thinning, for the sharp-edge finder: the thinning keeps
    // the first point near a place in lattice order, and along an edge those can all be points
    // of one face, with the other face's nearest kept row too far away to pair with them (a
    // whole edge of a box went unseen and the mesh beside it folded).
    let mut every: HashMap<[i64; 3], SmallVec<[DVec3; 4]>> = HashMap::new();
    let cell = |p: DVec3| (p / gap).floor().as_i64vec3().to_array();
    // The side of d = 0 each lattice point is on (0: not yet known), for the points far from it.
    let (nx, ny) = (n.x as usize, n.y as usize);
    let mut side = vec![0i8; 2 * nx * ny * n.z as usize];
    let slot = |i: u32, j: u32, k: u32, o: usize| 2 * (i as usize + nx * (j as usize + ny * k as usize)) + o;
    for k in 0..n.z {
        for j in 0..n.y {
            for i in 0..n.x {
                for (o, off) in [0.0, 0.5].into_iter().enumerate() {
                    let p = lo + (DVec3::new(i as f64, j as f64, k as f64) + off) * a;
                    if p.cmpgt(hi).any() {
                        continue;
                    }
                    let h = if uniform { 1.0 } else { ctx.h(p)? };
                    // Exact within `r`; farther, only the side matters (both tests below are
                    // decided by it), and it is the side of a lattice neighbour met before
                    // (at most one side a away, so the segment to it crosses nothing).
                    let r = 1.5 * a * h.max(1.0);
                    let before = if o == 1 {
                        slot(i, j, k, 0)
                    } else {
                        earlier([i, j, k].map(|x| x as usize))
                            .map_or(usize::MAX, |[a, b, c]| slot(a as u32, b as u32, c as u32, 0))
                    };
                    let known = side.get(before).copied().unwrap_or(0);
                    let d = match ctx.approx_dist_near(p, r)? {
                        Some(d) => d,
                        None if known != 0 => f64::from(known) * r,
                        None => ctx.approx_dist(p)?,
                    };
                    side[slot(i, j, k, o)] = if d < 0.0 { -1 } else { 1 };
                    if d < -INTERIOR_DEPTH * a * h {
                        // Seed 2.3: rejection with probability 1 - (h_min / h)^3.
                        if !uniform && ctx.next_f64() > 1.0 / (h * h * h) {
                            continue;
                        }
                        if opts.fixed.iter().any(|f| f.distance(p) < 0.5 * a * h) {
                            continue;
                        }
                        // Moved by a tiny deterministic offset: during the insertion the
                        // lattice forms many cospherical sets, whose insphere tests leave the
                        // floating-point filter for exact arithmetic. Off the lattice by 1e-6
                        // of its side, the start's Delaunay at 10^6 tets takes 0.56 s instead
                        // of 2.0 s. Where the lattice is degenerate the offset picks another
                        // triangulation (a few near-flat tets among them, which the force
                        // loop's swaps remove); the surface and fixed points are not moved.
                        pts.push(p + LATTICE_JITTER * a * jitter(pts.len() as u64));
                    } else if d.abs() < a * h {
                        let Some(q) = ctx.project(p)? else { continue };
                        if opts.sharp_edges {
                            every.entry(cell(q)).or_default().push(q);
                        }
                        let hq = if uniform { 1.0 } else { ctx.h(q)? };
                        let r = gap * hq;
                        let c = cell(q);
                        let reach = (r / gap).ceil() as i64;
                        let mut near = false;
                        'scan: for dz in -reach..=reach {
                            for dy in -reach..=reach {
                                for dx in -reach..=reach {
                                    if let Some(list) = grid.get(&[c[0] + dx, c[1] + dy, c[2] + dz]) {
                                        if list.iter().any(|&x| x.distance(q) < r) {
                                            near = true;
                                            break 'scan;
                                        }
                                    }
                                }
                            }
                        }
                        if near || opts.fixed.iter().any(|f| f.distance(q) < 0.5 * a * hq) {
                            continue;
                        }
                        grid.entry(c).or_default().push(q);
                        pts.push(q);
                    }
                }
            }
        }
    }
    let t_crease = Instant::now();
    let creases = if opts.sharp_edges { crease_points(ctx, &grid, &every, gap)? } else { Vec::new() };
    if ctx.trace {
        eprintln!(
            "start: {} points on sharp edges, held fixed ({:.3} s)",
            creases.len(),
            t_crease.elapsed().as_secs_f64()
        );
    }
    if !creases.is_empty() {
        // Start points near a crease point give way to it, as to a fixed point.
        let near = |p: DVec3| -> Result<bool, Error> {
            let h = if uniform { 1.0 } else { ctx.h(p)? };
            Ok(creases.iter().any(|c| c.distance(p) < 0.5 * a * h))
        };
        let mut kept = Vec::with_capacity(pts.len());
        for p in pts {
            if !near(p)? {
                kept.push(p);
            }
        }
        pts = kept;
        ctx.report.feature_points = creases.len();
        ctx.fixed.extend(creases);
    }
    pts.extend(ctx.fixed.iter().copied());
    if pts.len() < 4 {
        return Err(Error::EmptyDomain(format!(
            "only {} lattice points fall inside the domain at h0 = {}: h0 is too large for it",
            pts.len(),
            opts.h0
        )));
    }
    let (del, _) = TetMesh::delaunay(&pts)?;
    if del.num_tets() as u64 > opts.max_elements {
        return Err(Error::TooManyElements { estimated: del.num_tets() as u64, limit: opts.max_elements });
    }
    let crate::topology::MeshArrays { points, cells: tets, .. } = del.to_arrays();
    drop(del);
    // Seed: keep tets whose centroid is inside by more than geps = 0.1 h0.
    let geps = 0.1 * opts.h0;
    let keep: Vec<bool> = tets
        .par_iter()
        .with_min_len(CHUNK)
        .map(|t| {
            let c = (points[t[0]] + points[t[1]] + points[t[2]] + points[t[3]]) / 4.0;
            // The start points are all inside or on d = 0: a centroid with no surface point
            // nearer than its corners (nor within geps) is inside by more than geps, known
            // without the full (far, slow) distance query.
            let reach = t.iter().map(|&v| points[v].distance(c)).fold(geps, f64::max) * 1.01;
            ctx.approx_dist_near(c, reach).map(|d| d.is_none_or(|d| d < -geps))
        })
        .collect::<Result<_, Error>>()?;
    let mut tets: Vec<[usize; 4]> = tets.into_iter().zip(keep).filter(|x| x.1).map(|x| x.0).collect();
    tets.par_sort_unstable_by_key(|t| (*t.iter().min().expect("four"), *t));
    let mut mesh = repair_pinches(&points, &mut tets)?;
    tag_built_mesh(&mut mesh, &ctx.fixed);
    Ok(mesh)
}

/// Tags a mesh built from arrays: vertices on boundary faces `Boundary`, the fixed points
/// `Fixed`. Returns how many fixed points it holds.
pub(super) fn tag_built_mesh(m: &mut TetMesh, fixed: &[DVec3]) -> usize {
    m.tag_boundary_vertices();
    let mut found = 0;
    for v in m.vertex_ids().collect::<Vec<_>>() {
        if fixed.contains(&m.pos(v)) {
            m.set_tag(v, VertexTag::Fixed);
            found += 1;
        }
    }
    found
}

/// Builds the mesh from the kept tets, dropping the smaller side wherever tets meet only at a
/// vertex or only along an edge, so that the boundary is a 2-manifold, and every tet around an
/// edge whose ring winds more than once, so that the mesh is an embedding.
pub(super) fn repair_pinches(points: &[DVec3], tets: &mut Vec<[usize; 4]>) -> Result<TetMesh, Error> {
    for _round in 0..64 {
        if tets.is_empty() {
            return Err(Error::EmptyDomain("no tetrahedron has its centroid inside the domain".into()));
        }
        // Compact the used points.
        let mut map = vec![usize::MAX; points.len()];
        let mut used = Vec::new();
        for t in tets.iter() {
            for &i in t {
                if map[i] == usize::MAX {
                    map[i] = used.len();
                    used.push(points[i]);
                }
            }
        }
        let local: Vec<[usize; 4]> = tets.iter().map(|t| t.map(|i| map[i])).collect();
        let (m, ids) = TetMesh::from_arrays(&used, &local)?;
        let tet_ids: Vec<TetId> = m.tet_ids().collect();
        let mut index: SecondaryMap<TetId, usize> = SecondaryMap::with_capacity(tet_ids.len());
        for (k, &t) in tet_ids.iter().enumerate() {
            index.insert(t, k);
        }
        let mut count = vec![0u32; used.len()];
        for t in &local {
            for &i in t {
                count[i] += 1;
            }
        }
        let mut drop = vec![false; local.len()];
        let mut any = false;
        // Star sizes in parallel; the few pinched vertices are handled in order.
        let short: Vec<usize> = {
            let mesh = &m;
            (0..ids.len())
                .into_par_iter()
                .with_min_len(1024)
                .filter(|&i| mesh.vertex_tets(ids[i]).len() < count[i] as usize)
                .collect()
        };
        for i in short {
            any = true;
            let star = m.vertex_tets(ids[i]);
            let small_is_walked = 2 * star.len() <= count[i] as usize;
            for (k, t) in local.iter().enumerate() {
                if t.contains(&i) && (star.iter().any(|&s| index[s] == k) == small_is_walked) {
                    drop[k] = true;
                }
            }
        }
        if !any {
            // Edges with more than two boundary faces: tets meeting only along the edge.
            let mut bcount: HashMap<(TVertexId, TVertexId), (u32, TetId, usize)> = HashMap::new();
            for (t, f) in m.boundary_faces() {
                let fv = m.face_vertices(t, f);
                for k in 0..3 {
                    let (x, y) = (fv[k], fv[(k + 1) % 3]);
                    let e = bcount.entry((x.min(y), x.max(y))).or_insert((0, t, f));
                    e.0 += 1;
                }
            }
            let mut bad: Vec<((TVertexId, TVertexId), TetId)> =
                bcount.into_iter().filter(|(_, c)| c.0 > 2).map(|(e, c)| (e, c.1)).collect();
            bad.sort();
            for ((x, y), t) in bad {
                any = true;
                let (i, j) = (m.local_index(t, x).expect("edge"), m.local_index(t, y).expect("edge"));
                let shell = m.edge_shell(t, i, j);
                let all: Vec<usize> = (0..local.len())
                    .filter(|&k| {
                        let tv = tet_ids[k];
                        m.tet(tv).v.contains(&x) && m.tet(tv).v.contains(&y)
                    })
                    .collect();
                let small_is_walked = 2 * shell.tets.len() <= all.len();
                for k in all {
                    if shell.tets.iter().any(|&s| index[s] == k) == small_is_walked {
                        drop[k] = true;
                    }
                }
            }
        }
        if !any {
            // Folded edges: the Delaunay of the start's near-lattice points can leave needle
            // tets by the boundary whose positive tets wind more than once around an edge (a
            // start that fails the embedding check from its first step); every tet of such a
            // ring goes.
            for (t, i, j) in crate::topology::embedding::folded_edges(&m) {
                any = true;
                for s in m.edge_shell(t, i, j).tets {
                    drop[index[s]] = true;
                }
            }
        }
        if !any {
            return Ok(m);
        }
        let mut k = 0;
        tets.retain(|_| {
            k += 1;
            !drop[k - 1]
        });
    }
    Err(Error::internal("the carved start mesh keeps pinched vertices"))
}
