//! The seed's classic algorithm (section 2.2): rejection-sampled equilateral grid start and a
//! global Delaunay retriangulation (through spade) whenever some node moved more than ttol h0.
//! Kept as the reference the local engine must beat, in tests and benches.

use super::input::{eval_d, eval_h_floor, survey};
use super::truss::{bar_force, RestScale};
use super::{MeshOutput2, Options2, QualityStats, Report, StopReason};
use crate::geometry::project::{project2, Projection};
use crate::geometry::Implicit2;
use crate::testing::Rng;
use crate::topology::{TriMesh, VertexTag};
use crate::Error;
use glam::DVec2;
use spade::{DelaunayTriangulation, Point2, Triangulation};
use std::time::Instant;

const TTOL: f64 = 0.1;

fn triangulate(domain: &dyn Implicit2, p: &[DVec2], geps: f64) -> Result<Vec<[usize; 3]>, Error> {
    // The triangulation merges exactly equal points, which shifts its vertex indices past
    // them: give it each position once (the first index holding it) and map back.
    let mut order: Vec<usize> = (0..p.len()).collect();
    // (+ 0.0 makes -0 and 0 one key.)
    let key = |i: usize| (p[i].x + 0.0, p[i].y + 0.0);
    order.sort_by(|&i, &j| key(i).0.total_cmp(&key(j).0).then(key(i).1.total_cmp(&key(j).1)).then(i.cmp(&j)));
    let mut keep = vec![true; p.len()];
    for w in order.windows(2) {
        if p[w[0]] == p[w[1]] {
            keep[w[1]] = false;
        }
    }
    let uniq: Vec<usize> = (0..p.len()).filter(|&i| keep[i]).collect();
    let pts: Vec<Point2<f64>> = uniq.iter().map(|&i| Point2::new(p[i].x, p[i].y)).collect();
    let t = DelaunayTriangulation::<Point2<f64>>::bulk_load_stable(pts)
        .map_err(|e| Error::internal(format!("spade: {e:?}")))?;
    if t.num_vertices() != uniq.len() {
        return Err(Error::internal("the classic triangulation dropped distinct points"));
    }
    let mut tris = Vec::with_capacity(t.num_inner_faces());
    for f in t.inner_faces() {
        let [a, b, c] = f.vertices().map(|v| uniq[v.fix().index()]);
        let cen = (p[a] + p[b] + p[c]) / 3.0;
        if eval_d(domain, cen)? < -geps {
            tris.push([a, b, c]);
        }
    }
    Ok(tris)
}

/// Runs the classic strategy.
pub(crate) fn run(domain: &dyn Implicit2, opts: &Options2) -> Result<MeshOutput2, Error> {
    let t0 = Instant::now();
    let floor = survey(domain, opts)?.h_floor;
    let (distance, gradient_survey) = crate::geometry::decide2(domain, opts.bbox[0], opts.bbox[1]);
    let decided = crate::geometry::Declared { inner: domain, distance };
    let domain: &dyn Implicit2 = &decided;
    let h0 = opts.h0;
    let geps = 1e-3 * h0;
    let [lo, hi] = opts.bbox;
    let mut rng = Rng::new(opts.seed);
    // 1. Equilateral grid, keep d < geps, reject with probability 1 - (hmin / h)^2.
    let mut p: Vec<DVec2> = Vec::new();
    let dy = h0 * 3f64.sqrt() / 2.0;
    let ny = ((hi.y - lo.y) / dy).floor() as usize + 1;
    let nx = ((hi.x - lo.x) / h0).floor() as usize + 1;
    for j in 0..ny {
        for i in 0..nx {
            let shift = if j % 2 == 1 { h0 / 2.0 } else { 0.0 };
            let q = DVec2::new(lo.x + i as f64 * h0 + shift, lo.y + j as f64 * dy);
            if eval_d(domain, q)? < geps {
                p.push(q);
            }
        }
    }
    let hs: Vec<f64> = p.iter().map(|&q| eval_h_floor(opts, q, floor)).collect::<Result<_, _>>()?;
    let hmin = hs.iter().copied().fold(f64::INFINITY, f64::min);
    let mut kept: Vec<DVec2> = opts.fixed.clone();
    for (q, h) in p.iter().zip(&hs) {
        if rng.f64() < (hmin / h).powi(2) {
            kept.push(*q);
        }
    }
    let nfix = opts.fixed.len();
    let mut p = kept;
    if p.len() < 3 {
        return Err(Error::EmptyDomain("fewer than three grid points inside the domain".into()));
    }
    let projection = match opts.projection {
        Projection::Auto if domain.is_distance() => Projection::Exact,
        Projection::Auto => Projection::FirstOrder,
        x => x,
    };
    let mut pold = vec![DVec2::splat(f64::INFINITY); p.len()];
    let mut bars: Vec<[usize; 2]> = Vec::new();
    let mut report = Report { gradient_survey, level_set: !distance, ..Report::default() };
    let mut iter = 0;
    let mut stop = StopReason::IterationCap { max_iter: opts.max_iter };
    while iter < opts.max_iter {
        iter += 1;
        if let Some(cb) = &opts.progress {
            cb(iter, opts.max_iter);
        }
        // 3. Retriangulate when something moved far.
        let moved = p.iter().zip(&pold).map(|(a, b)| a.distance(*b)).fold(0.0, f64::max);
        if moved > TTOL * h0 {
            pold = p.clone();
            let tris = triangulate(domain, &p, geps)?;
            let mut set = std::collections::BTreeSet::new();
            for t in &tris {
                for k in 0..3 {
                    let (a, b) = (t[k], t[(k + 1) % 3]);
                    set.insert((a.min(b), a.max(b)));
                }
            }
            bars = set.into_iter().map(|(a, b)| [a, b]).collect();
            report.ops.flips += 1;
        }
        // 6. Forces (seed eq. 2.5, 2.6).
        let mut rest = RestScale::new(2);
        let mut hb = Vec::with_capacity(bars.len());
        for b in &bars {
            let h = eval_h_floor(opts, (p[b[0]] + p[b[1]]) * 0.5, floor)?;
            rest.add(p[b[0]].distance_squared(p[b[1]]), h);
            hb.push(h);
        }
        let scale = rest.scale(opts.fscale);
        let mut f = vec![DVec2::ZERO; p.len()];
        for (b, h) in bars.iter().zip(&hb) {
            let d = p[b[0]] - p[b[1]];
            let fv = bar_force(d, d.length(), h * scale);
            f[b[0]] += fv;
            f[b[1]] -= fv;
        }
        for x in f.iter_mut().take(nfix) {
            *x = DVec2::ZERO;
        }
        let mut max_move: f64 = 0.0;
        for i in 0..p.len() {
            p[i] += opts.deltat * f[i];
        }
        // 7. Outside points back to the boundary.
        for i in 0..p.len() {
            let d = eval_d(domain, p[i])?;
            if d > 0.0 {
                if let Ok(q) = project2(domain, p[i], projection, 1e-9 * h0, 20) {
                    p[i] = q;
                }
            } else if d < -geps {
                max_move = max_move.max(opts.deltat * f[i].length() / h0);
            }
        }
        // 8. Termination.
        if max_move < opts.dptol {
            stop = StopReason::AtRest { dptol: opts.dptol };
            break;
        }
    }
    // Final triangulation; drop unused points; inverted or flat triangles cannot occur in a
    // Delaunay triangulation but zero-area ones can at exact collinearity: drop them.
    let mut tris: Vec<[usize; 3]> = triangulate(domain, &p, geps)?
        .into_iter()
        .filter(|t| crate::predicates::orient2d(p[t[0]], p[t[1]], p[t[2]]) == crate::predicates::Sign::Positive)
        .collect();
    // Dropping outside triangles can pinch the boundary at a vertex: keep its largest fan.
    for _ in 0..64 {
        let pinched = super::planar::pinched_vertices(p.len(), &tris);
        if pinched.is_empty() {
            break;
        }
        tris = super::planar::drop_small_fans(&tris, &pinched, p.len());
    }
    let mut map = vec![usize::MAX; p.len()];
    let mut pts = Vec::new();
    for t in &tris {
        for &i in t {
            if map[i] == usize::MAX {
                map[i] = pts.len();
                pts.push(p[i]);
            }
        }
    }
    let tri: Vec<[usize; 3]> = tris.iter().map(|t| [map[t[0]], map[t[1]], map[t[2]]]).collect();
    let (mut mesh, ids) =
        TriMesh::from_arrays(&pts, &tri).map_err(|e| Error::internal(format!("classic result: {e}")))?;
    for v in ids {
        if mesh.is_boundary_vertex(v) {
            mesh.set_tag(v, VertexTag::Boundary);
        }
    }
    if let Err(e) = mesh.validate(crate::topology::Level::Geometry) {
        return Err(Error::broken("the finished mesh is invalid", e));
    }
    report.stopped(iter, stop);
    report.seconds = t0.elapsed().as_secs_f64();
    report.quality = QualityStats::of(&mesh);
    Ok(MeshOutput2 { mesh, report })
}
