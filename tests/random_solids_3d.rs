//! The 3-D mesher on families of random solids with sharp edges: axis-aligned boxes of random
//! sides and places, and unions and differences of boxes, balls and cylinders. The start
//! lattice meets each one's edges differently (the two boxes of the meshing region alternate,
//! moving the lattice against the solid), which is where a mesher tuned on a few shapes fails:
//! a box whose whole edge went unseen by the sharp-edge finder came out at 17.3 degrees. Each
//! case prints its row; every mesh must be an embedding.

use glam::DVec3;
use trussmesh::geometry::{difference, union, Ball, Box3, Cylinder, Implicit3, Shape3, Translate};
use trussmesh::mesher::{mesh_3d, pinched_boundary_vertices, MeshOutput3, Options3};
use trussmesh::topology::Level;

/// SplitMix64: the families are the same on every run.
struct Rng(u64);

impl Rng {
    fn unit(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }
    fn point(&mut self, lo: f64, hi: f64) -> DVec3 {
        DVec3::new(self.range(lo, hi), self.range(lo, hi), self.range(lo, hi))
    }
}

const H0: f64 = 0.07;
/// The report warns of tets flatter than this many degrees.
const FLOOR: f64 = 10.0;

/// The region's box for case `i`: two boxes in turn, so the lattice meets the solids at
/// different offsets.
fn region(i: usize) -> f64 {
    if i % 2 == 0 {
        1.0
    } else {
        1.2
    }
}

fn random_box(r: &mut Rng) -> Box3 {
    let (c, a) = (r.point(-0.3, 0.3), r.point(0.15, 0.5));
    Box3::new(c - a, c + a)
}

fn random_part(r: &mut Rng) -> Shape3 {
    let kind = (r.unit() * 3.0) as usize;
    let c = r.point(-0.4, 0.4);
    match kind {
        0 => Shape3::new(Ball::new(c, r.range(0.2, 0.5))),
        1 => Shape3::new(random_box(r)),
        _ => {
            let (rad, half) = (r.range(0.15, 0.4), r.range(0.2, 0.5));
            Shape3::new(Translate::new(Cylinder::new(rad, -half, half), c))
        }
    }
}

/// One to three parts, joined or cut.
fn random_solid(r: &mut Rng) -> Shape3 {
    let mut s = random_part(r);
    for _ in 0..(r.unit() * 3.0) as usize {
        let p = random_part(r);
        s = if r.unit() < 0.65 { Shape3::new(union(s, p)) } else { Shape3::new(difference(s, p)) };
    }
    s
}

fn mesh(domain: &dyn Implicit3, i: usize) -> MeshOutput3 {
    let b = region(i);
    let out = mesh_3d(domain, &Options3::uniform(H0, [-b; 3], [b; 3])).expect("meshing succeeds");
    out.mesh.validate(Level::Geometry).expect("an embedding: every tet positive (exact), no fold");
    out
}

/// The case's row; a boundary pinched at a vertex must be named in the report.
fn row(i: usize, out: &MeshOutput3) -> String {
    let q = &out.report.quality;
    let pinched = pinched_boundary_vertices(&out.mesh).len();
    let said = out.report.notes.iter().any(|n| n.contains("pinched"));
    assert_eq!(pinched > 0, said, "case {i}: {pinched} pinched vertices, report notes {:?}", out.report.notes);
    format!(
        "| {i} | {} | {:.1} | {:.1} | {:.4} | {} | {pinched} | {} | {:.2} |",
        q.tets,
        q.dihedral_min,
        q.dihedral_max,
        q.rr_mean,
        out.report.feature_points,
        out.report.boundary_nodes_off,
        out.report.seconds
    )
}

const HEADER: &str =
    "| case | tets | min dihedral | max dihedral | rr mean | held on edges | pinched vertices | boundary nodes off | seconds |\n\
                      |---|---|---|---|---|---|---|---|---|";

/// Every box keeps dihedral angles of at least 30 degrees (most reach 38.8, the ball's figure).
#[test]
fn random_boxes_keep_30_degrees() {
    let mut r = Rng(0x0062_6f78_6573);
    println!("{HEADER}");
    let mut low = Vec::new();
    for i in 0..12 {
        let out = mesh(&random_box(&mut r), i);
        println!("{}", row(i, &out));
        if out.report.quality.dihedral_min < 30.0 {
            low.push((i, out.report.quality.dihedral_min));
        }
    }
    assert!(low.is_empty(), "boxes below 30 degrees: {low:?}");
}

/// Unions and differences of boxes, balls and cylinders: no mesh has a tet flatter than the
/// report's floor of 10 degrees, the mean of the smallest angles is at least 35 degrees, and
/// no boundary is pinched at a vertex (a carve that would pinch one keeps the tets there).
#[test]
fn random_solids_stay_above_the_floor() {
    let mut r = Rng(0x736f_6c69_6473);
    println!("{HEADER}");
    let (mut low, mut sum, n) = (Vec::new(), 0.0, 12);
    let mut pinched = Vec::new();
    for i in 0..n {
        let out = mesh(&random_solid(&mut r), i);
        println!("{}", row(i, &out));
        if !pinched_boundary_vertices(&out.mesh).is_empty() {
            pinched.push(i);
        }
        let q = out.report.quality.dihedral_min;
        sum += q;
        if q < FLOOR {
            low.push((i, q));
        }
    }
    println!("mean smallest dihedral angle {:.1}", sum / n as f64);
    assert!(low.is_empty(), "solids with tets flatter than the floor: {low:?}");
    assert!(sum / n as f64 >= 35.0, "mean smallest dihedral angle {:.1}", sum / n as f64);
    assert!(pinched.is_empty(), "solids whose boundary is pinched at a vertex: {pinched:?}");
}

/// The surfaces of the same random solids, with a row each: the smallest angle, the mean q,
/// and whether the sharp edges were held, rounded off, or taken from the 3-D mesh's boundary
/// (`src/mesher/surface/from_volume.rs`: where the surface mesher fails to hold them, or
/// holds them with a triangle below 20 degrees). Returns the surfaces meshed (with their
/// smallest angles) and the cases that failed with another error than a part too thin.
fn surfaces_of_random_solids() -> (Vec<(usize, f64)>, Vec<usize>) {
    use trussmesh::{mesh_surface, Error, SurfaceOptions};
    let mut r = Rng(0x736f_6c69_6473);
    println!("| case | triangles | min angle | mean q | edges | seconds |\n|---|---|---|---|---|---|");
    let (mut meshed, mut failed) = (Vec::new(), Vec::new());
    for i in 0..12 {
        let solid = random_solid(&mut r);
        let b = region(i);
        match mesh_surface(&solid, &SurfaceOptions::uniform(H0, [-b; 3], [b; 3])) {
            Ok(out) => {
                out.mesh.validate_closed_surface().expect("a closed, oriented, manifold surface");
                let q = &out.report.quality;
                let how = match out.report.notes.iter().find(|n| n.contains("3-D mesh") || n.contains("rounds them")) {
                    Some(n) if n.contains("3-D mesh") => "from the 3-D mesh",
                    Some(_) => "rounded",
                    None => "held or none",
                };
                println!(
                    "| {i} | {} | {:.1} | {:.4} | {how} | {:.2} |",
                    q.triangles, q.min_angle, q.mean_q, out.report.seconds
                );
                meshed.push((i, q.min_angle));
            }
            Err(Error::BadSize(m)) => println!("| {i} | - | - | - | too thin: {m} | - |"),
            Err(e) => {
                println!("| {i} | - | - | - | failed: {e} | - |");
                failed.push(i);
            }
        }
    }
    let mean = meshed.iter().map(|x| x.1).sum::<f64>() / meshed.len().max(1) as f64;
    println!("mean smallest angle {mean:.1} over {}", meshed.len());
    (meshed, failed)
}

/// Every surface that comes out is a closed manifold (checked in the helper), and at least 9
/// of the 12 come out.
#[test]
fn surfaces_of_random_solids_are_closed() {
    let (meshed, _) = surfaces_of_random_solids();
    assert!(meshed.len() >= 9, "only {} of 12 surfaces meshed", meshed.len());
}

#[test]
#[ignore = "not reached: case 5 is rounded with a 7.3-degree triangle (holding its edges fails from both starts, \
            and the 3-D mesh's boundary, the fallback, reaches 22.3 degrees but has 2 faces against grad phi)"]
fn surfaces_of_random_solids_all_mesh_above_10_degrees() {
    let (meshed, failed) = surfaces_of_random_solids();
    let low: Vec<_> = meshed.iter().filter(|x| x.1 < FLOOR).collect();
    assert!(failed.is_empty() && low.is_empty(), "failed {failed:?}, below {FLOOR} degrees {low:?}");
}

/// A ball rising out of a box's top face, with a cylinder cut from the box, as a user types it
/// (`mesh --dim 3 --domain EXPR`): the concave crease where the ball leaves the face holds
/// fixed points, and one of them, left with a single flat cap as its only tet, came out at
/// 13.5 degrees (the cap now goes and the free node beside the point takes its place). The
/// ball moves along the crease's plane from case to case.
#[test]
fn balls_rising_out_of_a_box_keep_30_degrees() {
    let dir = std::env::temp_dir().join(format!("trussmesh-balls-out-of-a-box-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    println!("| case | ball centre x | min dihedral | max dihedral |\n|---|---|---|---|");
    let mut low = Vec::new();
    for (i, x) in [0.029, 0.079, -0.041, 0.139].into_iter().enumerate() {
        let domain = format!(
            "dunion(ddiff(dbox(x,y,z,-0.105,0.694,-0.273,0.473,-0.480,0.303),\
             max(sqrt((x+0.184)^2+(y+0.460)^2)-0.424,abs(z-0.316)-0.260)),dsphere(x,y,z,{x},-0.075,0.090,0.464))"
        );
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_trussmesh"))
            .args(["mesh", "--dim", "3", "--domain", &domain, "--h0", "0.07", "--bbox", "-1.2,-1.2,-1.2,1.2,1.2,1.2"])
            .arg("-o")
            .arg(dir.join(format!("b{i}.vtu")))
            .output()
            .expect("runs");
        let text = String::from_utf8_lossy(&out.stdout).to_string() + &String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "case {i}: {text}");
        let angles: Vec<f64> = text
            .split("dihedral angles ")
            .nth(1)
            .expect("the report's angles")
            .split_whitespace()
            .filter_map(|w| w.parse().ok())
            .take(2)
            .collect();
        println!("| {i} | {x} | {:.1} | {:.1} |", angles[0], angles[1]);
        if angles[0] < 30.0 {
            low.push((i, angles[0]));
        }
    }
    assert!(low.is_empty(), "below 30 degrees: {low:?}");
}
