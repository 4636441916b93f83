use super::*;
use proptest::prelude::*;

proptest! {
    /// The square-root-free bound never passes a triangle below the repair threshold.
    #[test]
    fn repair_bound_is_safe(c in prop::array::uniform6(-1.0f64..1.0)) {
        let [a, b, c] = [DVec2::new(c[0], c[1]), DVec2::new(c[2], c[3]), DVec2::new(c[4], c[5])];
        if surely_not_below_repair(a, b, c) {
            prop_assert!(crate::quality::triangle_q([a, b, c]) >= Q_REPAIR);
        }
    }
}

#[test]
fn repair_bound_passes_good_triangles_and_not_slivers() {
    let eq = [DVec2::ZERO, DVec2::X, DVec2::new(0.5, 0.75f64.sqrt())];
    assert!(surely_not_below_repair(eq[0], eq[1], eq[2]));
    let sliver = [DVec2::ZERO, DVec2::X, DVec2::new(0.5, 1e-3)];
    assert!(crate::quality::triangle_q(sliver) < Q_REPAIR);
    assert!(!surely_not_below_repair(sliver[0], sliver[1], sliver[2]));
}

/// The iteration cap returns a mesh at least as good, by the smallest quality, as every state
/// the force loop met before it (issue: the cap kept the last state, not the best).
#[test]
fn iteration_cap_returns_the_best_state_met() {
    use crate::geometry::{Circle, Difference, Rectangle};
    let domain = Difference::new(Rectangle::new([-1.0, -1.0], [1.0, 1.0]), Circle::new([0.0, 0.0], 0.4));
    println!("| cap | kept iteration | best state q min | returned q min |");
    println!("|---|---|---|---|");
    let mut restored = 0;
    for cap in [20, 40, 60, 80, 120, 160, 240] {
        let opts = Options2::uniform(0.1, [-1.0, -1.0], [1.0, 1.0])
            .with_size(|p: DVec2| (4.0 * p.length() - 1.0).min(2.0))
            .with_fixed(vec![[-1.0, -1.0], [-1.0, 1.0], [1.0, -1.0], [1.0, 1.0]])
            .with_max_iter(cap);
        best::OFFERED.with(|o| o.borrow_mut().clear());
        let out = run(&domain, &opts).expect("meshing");
        let offered = best::OFFERED.with(|o| o.borrow().clone());
        let best_q = offered.iter().map(|s| s.1).fold(f64::NEG_INFINITY, f64::max);
        let q = out.report.quality.q_min;
        println!("| {cap} | {:?} | {best_q:.4} | {q:.4} |", out.report.kept_iteration);
        assert!(!offered.is_empty(), "cap {cap}: no state offered");
        if out.report.converged {
            continue;
        }
        restored += out.report.kept_iteration.is_some() as usize;
        assert!(q >= best_q, "cap {cap}: returned q min {q:.4} below the best state met {best_q:.4}");
        assert!(out.report.to_string().contains("best state") == out.report.kept_iteration.is_some());
    }
    println!("{restored} capped runs finished from an earlier state");
}

/// A lattice disk of radius 1 and spacing `h` (Delaunay of the lattice points inside).
fn lattice_disk(h: f64) -> TriMesh<DVec2> {
    let mut pts = Vec::new();
    let rows = (1.0 / (h * 0.75f64.sqrt())).ceil() as i64;
    for j in -rows..=rows {
        let y = j as f64 * h * 0.75f64.sqrt();
        let shift = if j % 2 == 0 { 0.0 } else { 0.5 * h };
        let cols = (1.0 / h).ceil() as i64 + 1;
        for i in -cols..=cols {
            let p = DVec2::new(i as f64 * h + shift, y);
            if p.length() < 1.0 {
                pts.push(p);
            }
        }
    }
    TriMesh::delaunay(&pts).expect("lattice").0
}

/// The held core of a large uniform mesh (see `held`): its vertices lie more than `rings`
/// edges from the boundary and from the fixed vertices, and the band's arrays are closed:
/// every band vertex has its whole star in them, and the core vertices next to the band come
/// in as fixed nodes.
#[test]
fn held_core_leaves_the_band_whole() {
    let mut m = lattice_disk(0.01);
    let centre = m.vertex_ids().min_by(|&a, &b| m.pos(a).length().total_cmp(&m.pos(b).length())).unwrap();
    m.set_tag(centre, VertexTag::Fixed);
    let rings = 10;
    let core = held::HeldCore::find(&m, rings).expect("a core");
    assert!(!core.held.contains_key(centre));
    // Depth from the boundary and the fixed vertex, by relaxing every vertex against its
    // neighbours until nothing changes (independent of the breadth-first walk of `find`).
    let mut depth: SecondaryMap<VertexId, usize> = m
        .vertex_ids()
        .map(|v| (v, if m.is_boundary_vertex(v) || m.tag(v) == VertexTag::Fixed { 0 } else { usize::MAX }))
        .collect();
    let mut changed = true;
    while changed {
        changed = false;
        for v in m.vertex_ids() {
            let best = m.neighbours(v).iter().map(|&w| depth[w].saturating_add(1)).min().unwrap_or(usize::MAX);
            if best < depth[v] {
                depth[v] = best;
                changed = true;
            }
        }
    }
    for v in m.vertex_ids() {
        assert_eq!(core.held.contains_key(v), depth[v] > rings, "depth {}", depth[v]);
    }
    let snap = Snapshot::build_band(&m, &core.held);
    println!(
        "{} vertices: {} held, {} in the band, {} in the halo",
        m.num_vertices(),
        core.held.len(),
        snap.n_band,
        snap.ids.len() - snap.n_band
    );
    assert_eq!(snap.n_band, m.num_vertices() - core.held.len());
    for (i, &v) in snap.ids.iter().enumerate() {
        let ring = &snap.adj[snap.adj_start[i] as usize..snap.adj_start[i + 1] as usize];
        if i < snap.n_band {
            assert!(!core.held.contains_key(v));
            assert_eq!(ring.len(), m.valence(v), "band vertex {i}: its whole ring");
            assert_eq!(snap.vt.of(i).len(), m.vertex_faces(v).len(), "band vertex {i}: its whole fan");
            assert_eq!(snap.kind[i], NodeKind::of(m.tag(v)));
        } else {
            assert!(core.held.contains_key(v));
            assert_eq!(snap.kind[i], NodeKind::Fixed, "halo vertex {i} is held");
            assert!(ring.iter().all(|&j| (j as usize) < snap.n_band), "halo vertex {i}: only its band edges");
            assert_eq!(depth[v], rings + 1);
        }
    }
    // Each triangle once, every one with a band corner.
    let mut seen = std::collections::HashSet::new();
    for (t, &f) in snap.tris.iter().zip(&snap.tri_faces) {
        assert!(seen.insert(f));
        assert!(t.iter().any(|&i| (i as usize) < snap.n_band));
    }
}

/// A large uniform mesh holds its core, and the iteration cap still returns the best state
/// met, read from the whole mesh.
#[test]
fn iteration_cap_returns_the_best_state_with_a_held_core() {
    use crate::geometry::Circle;
    for cap in [30, 90] {
        let opts = Options2::uniform(0.006, [-1.0, -1.0], [1.0, 1.0]).with_max_iter(cap);
        best::OFFERED.with(|o| o.borrow_mut().clear());
        let out = run(&Circle::new([0.0, 0.0], 1.0), &opts).expect("meshing");
        let offered = best::OFFERED.with(|o| o.borrow().clone());
        let best_q = offered.iter().map(|s| s.1).fold(f64::NEG_INFINITY, f64::max);
        let q = out.report.quality.q_min;
        println!(
            "cap {cap}: {} triangles, kept iteration {:?}, best state q min {best_q:.4}, returned {q:.4}",
            out.report.quality.triangles, out.report.kept_iteration
        );
        assert!(out.report.quality.triangles > 100_000);
        assert!(!offered.is_empty());
        out.mesh.validate(Level::Geometry).expect("a valid mesh");
        assert!(q >= best_q, "cap {cap}: returned q min {q:.4} below the best state met {best_q:.4}");
    }
}

/// The band is widened once a vertex of its inner rim has moved RIM_DRIFT in all, summed over
/// rebuilds of the arrays (the bound survives them), and a wider core holds fewer vertices.
#[test]
fn held_core_notices_moves_at_its_rim() {
    let m = lattice_disk(0.01);
    let mut core = held::HeldCore::find(&m, 10).expect("a core");
    let snap = Snapshot::build_band(&m, &core.held);
    let mut p: Vec<DVec2> = snap.ids.iter().map(|&v| m.pos(v)).collect();
    core.track_rim(&snap, &p);
    let limit = 1e-3;
    assert!(!core.reached(&p, limit));
    // A boundary vertex moves far: not the rim.
    let outer = (0..snap.n_band).find(|&i| m.is_boundary_vertex(snap.ids[i])).unwrap();
    p[outer] += DVec2::new(5.0 * limit, 0.0);
    assert!(!core.reached(&p, limit));
    // A rim vertex (next to the halo) moves 0.6 of the limit, twice across a rebuild.
    let rim = (0..snap.n_band)
        .find(|&i| {
            snap.adj[snap.adj_start[i] as usize..snap.adj_start[i + 1] as usize]
                .iter()
                .any(|&j| j as usize >= snap.n_band)
        })
        .unwrap();
    p[rim] += DVec2::new(0.6 * limit, 0.0);
    assert!(!core.reached(&p, limit));
    core.fold_rim(&p);
    core.track_rim(&snap, &p);
    p[rim] += DVec2::new(0.0, 0.6 * limit);
    assert!(core.reached(&p, limit), "the moves before the rebuild count");
    let wider = held::HeldCore::find(&m, 20).expect("a core");
    assert!(wider.held.len() < core.held.len());
}
