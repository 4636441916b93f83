//! Surface meshes of implicit surfaces phi(x) = 0 (seed section 3.6.1); rational Bézier
//! patches meshed in space (section 3.6.2) are in [`bezier`].
//!
//! The seed's recipe: the force iteration of the 2-D mesher with nodes moving in space and every
//! node projected back onto phi = 0 after every step, connectivity kept good by local flips in
//! space instead of a Delaunay triangulation. The pipeline, by stage:
//!
//! 1. the start (`start.rs`): marching tetrahedra on a background grid gives a closed,
//!    outward-oriented mesh, made at the coarsest level 2^k h that keeps the topology of the
//!    reference marching and welded into the half-edge engine;
//! 2. density (`density.rs`): remeshing passes (split long, collapse short, valence flips,
//!    tangential smoothing, projection; the isotropic remeshing loop of Botsch and Kobbelt,
//!    2004) bring the node density to h(x), and regular subdivision takes each level to the
//!    next finer one;
//! 3. equilibrium (`equilibrium.rs`): on each level the truss iteration, repulsive bar forces
//!    toward L0 = Fscale h(x) (seed eq. 2.6, Fscale 1.2), moves in the tangent plane,
//!    projection, quality flips, and density control with hysteresis; it stops when the nodes
//!    stop moving, when its quality score stops rising, or at the cap, keeping the best mesh
//!    seen;
//! 4. improvement (`improve.rs`): flips toward quality or valence, and after the last level a
//!    few sweeps that even out the edge lengths themselves;
//! 5. the report ([`report`]): topology, distance to the surface, element quality and sizes.
//!
//! Sizes are uniform or follow the maximum principal curvature with gradient limiting (seed
//! chapter 4), see [`SurfaceSize`]; [`geom`] has what the stages ask of phi (projection,
//! normals, the fold test) and the size field.

pub mod bezier;
mod density;
mod equilibrium;
mod features;
mod from_volume;
pub mod geom;
mod improve;
mod options;
pub mod report;
mod start;

pub use geom::SizeField;
pub use options::{SurfaceOptions, SurfaceSize};
pub use report::SurfaceQuality;

/// The marching-tetrahedra start: the triangulated zero set of phi on a background grid.
pub mod march {
    pub use super::start::{grid_nodes, march, Marched, MAX_GRID_NODES};
}

/// Local operations in space: the engine's checked flip, split and collapse plus the surface
/// conditions the engine cannot know (no fold against grad phi, quality, valence), and the
/// smoothing, equalising and subdivision built on them.
pub mod ops {
    pub use super::density::{apply_band, edge_list, edge_now, relayout, subdivide};
    pub use super::improve::{
        equalize_lengths, flip_pass, move_if_no_fold, move_if_no_fold_g, smooth_tangential, try_flip, FlipGoal,
        FOLD_COS,
    };
    pub use super::start::components;
    pub use crate::mesher::report::OpCounts;
}

use crate::geometry::Implicit3;
use crate::mesher::report::{OpCounts, Report, SurfaceStages};
use crate::mesher::StopReason;
use crate::topology::{FaceId, TriMesh, VertexId, VertexTag};
use crate::Error;
use geom::project;
use glam::DVec3;
use improve::{flip_pass, move_unless_crossing, FlipGoal};
use rayon::prelude::*;

/// A surface mesh and its report.
#[derive(Clone, Debug)]
pub struct SurfaceOutput {
    /// The mesh: closed, counter-clockwise seen from outside (normals along grad phi).
    pub mesh: TriMesh<DVec3>,
    /// The size field used.
    pub size: SizeField,
    /// What happened and the quality figures.
    pub report: Report<SurfaceQuality>,
}

/// A surface meshed with sharp features held whose worst triangle falls below this quality is
/// meshed again without them (the hold has failed somewhere; the smooth pipeline never does
/// worse than this on the surfaces it is tested on).
const HELD_MIN_Q: f64 = 0.1;

/// A surface meshed with sharp features held whose vertex count passes this many times the
/// start's is meshed again without them: the start is made at the target size, so a hold that
/// keeps splitting has failed (the flat ellipsoid x^2 + y^2 + (z/0.001)^2 - 1 at h0 0.1
/// quadrupled its vertices every remeshing pass, 1,286 to 359,318 in ten).
const HELD_GROWTH: usize = 4;

/// The error that sends a runaway held surface back to the smooth pipeline: past a growth
/// budget, not a defect (its text ends up in the report's note on the rounded mesh).
fn held_runaway(start: usize, now: usize) -> Error {
    Error::OverBudget(format!(
        "holding sharp features made the surface grow from {start} to {now} vertices, past {HELD_GROWTH} times the start"
    ))
}

/// Sheets within this many degrees of facing each other are a shell or a gap; at a larger
/// angle (up to `sharp::SHARP_DEG`) they are the two faces of a sharp wedge.
const PARALLEL_DEG: f64 = 20.0;

/// Sheets facing each other closer than two edges: the input asks for a size it cannot be
/// meshed at, and the error says so with the thickness and where; failing that, the two faces
/// of a wedge sharper than `sharp::SHARP_DEG` closer than two edges, named with its angle (a
/// wedge thins to nothing at its edge, so the thickness there is no size to mesh at);
/// `otherwise` when neither is found near the nodes of `m`.
fn too_thin_or(phi: &dyn Implicit3, m: &TriMesh<DVec3>, hmin: f64, tol: f64, otherwise: Error) -> Error {
    let on: Vec<DVec3> = m.vertex_ids().map(|v| m.pos(v)).collect();
    let reach = start::COARSE_ACROSS * hmin;
    if let Some(t) = geom::thinnest(phi, &on, hmin, reach, tol, PARALLEL_DEG) {
        return Error::BadSize(format!(
            "phi = 0 comes back within {:.3e} of itself near ({:.4}, {:.4}, {:.4}): a shell or gap thinner than \
             two edges of the size {hmin:.3e}, across which nodes land on the wrong sheet; \
             mesh with h0 at most {:.3e}",
            t.across,
            t.at.x,
            t.at.y,
            t.at.z,
            0.5 * t.across
        ));
    }
    match geom::thinnest(phi, &on, hmin, reach, tol, crate::mesher::sharp::SHARP_DEG) {
        Some(t) => Error::BadSize(format!(
            "phi = 0 meets itself at a wedge of about {:.0} degrees near ({:.4}, {:.4}, {:.4}) (its faces {:.3e} \
             apart there): a wedge this sharp thins below two edges of the size {hmin:.3e} near its edge, where \
             nodes land on the wrong face; blunt or round the wedge, or mesh the solid with `mesh --dim 3`, \
             which holds it",
            t.angle, t.at.x, t.at.y, t.at.z, t.across
        )),
        None => otherwise,
    }
}

/// Projection tolerance, in units of the smallest size (|phi| / |grad phi|).
const PROJECT_TOL: f64 = 1e-9;

/// Meshes the closed surface phi = 0 inside `opts.bbox` (phi < 0 inside, so normals point
/// along grad phi).
///
/// Sharp edges and corners of phi = 0 are found and held (`features.rs`), cut into the marching
/// start; should holding them leave a surface that fails the final check or has a triangle
/// below quality HELD_MIN_Q, they are cut into the smooth mesh (meshed without them) and held
/// from there (a smooth run that fails its check goes to the 3-D mesh's boundary at once);
/// failing that too, the boundary of the 3-D mesh of the inside when it is fair
/// (`from_volume.rs`, also tried for a held surface with a triangle below 20 degrees), else
/// the smooth mesh is the result, its report saying so. A run refused as too thin (a shell, a
/// gap or a sharp wedge, see `too_thin_or`) takes the 3-D mesh's boundary when it is fair, and
/// is refused otherwise. A
/// geometry that gives its features exactly ([`Implicit3::creases`]: a triangulated surface)
/// is meshed smooth first and its features cut into that mesh; should that fail, they are cut
/// into the marching start, and failing that too the geometry's own triangulation is the start
/// ([`Creases::triangulation`](crate::geometry::Creases::triangulation)), before the 3-D mesh's
/// boundary and then the smooth mesh are the result.
pub fn mesh_surface(phi: &dyn Implicit3, opts: &SurfaceOptions) -> Result<SurfaceOutput, Error> {
    crate::mesher::on_pool(|| mesh_surface_here(phi, opts))
}

fn mesh_surface_here(phi: &dyn Implicit3, opts: &SurfaceOptions) -> Result<SurfaceOutput, Error> {
    // The size field once for every run below (on a grid from --size auto it may take longer
    // than the meshing); its time counts in the report's.
    let t0 = std::time::Instant::now();
    opts.check()?;
    let size = opts.size_field(phi)?;
    let sized = t0.elapsed().as_secs_f64();
    let mut out = mesh_surface_sized(phi, opts, &size)?;
    out.report.seconds += sized;
    Ok(out)
}

/// [`mesh_surface`] with its size field made.
fn mesh_surface_sized(phi: &dyn Implicit3, opts: &SurfaceOptions, size: &SizeField) -> Result<SurfaceOutput, Error> {
    let trace = trace_held;
    if phi.creases().is_some() {
        // Features given exactly: they are cut into the smooth mesh, whose even triangles cut
        // cleanly (a marching start has bands of nodes projected onto a convex edge, some of
        // them coincident), and the smooth mesh is the fallback.
        let mut invalid = None;
        let smooth = match smooth_run(phi, opts, size, Some(&mut invalid)) {
            Ok(out) => out,
            // A smooth mesh that fails the final check (folded or crossing itself where it
            // rounds a corner) is still a start to cut the features into: holding them often
            // mends it; the other starts follow (a coarse cone's rim, rounded at h0 0.1, folded
            // the smooth mesh beyond mending). The smooth run's error stands if all fail.
            Err(e) => {
                trace(&e);
                // Only a surface that was made and failed the check: other errors (a sheet too
                // thin, a runaway, bad values) would fail again.
                // The 3-D mesh's boundary after that: any closed surface it makes is better
                // than none.
                let held = match invalid {
                    Some(m) => held_fallbacks(phi, opts, size, Some(m)),
                    None => None,
                };
                return match held {
                    Some(out) => Ok(out),
                    None => from_volume::from_volume(
                        phi,
                        opts,
                        size,
                        format!("the surface mesher failed ({e}): this is the boundary of the 3-D mesh of the inside"),
                    )
                    .map_err(|e2| {
                        trace(&e2);
                        e
                    }),
                };
            }
        };
        return Ok(match held_from_smooth(phi, opts, size, smooth) {
            Ok(out) => or_from_input(phi, opts, size, out),
            Err(failed) => {
                let (smooth, e) = *failed;
                trace(&e);
                // The other starts next; the smooth mesh is the last resort.
                held_fallbacks(phi, opts, size, None).unwrap_or_else(|| volume_or_rounded(phi, opts, size, smooth, &e))
            }
        });
    }
    if phi.creases_given() {
        // No features to hold (none, or turned off): none are looked for in the function.
        return smooth_run(phi, opts, size, None);
    }
    let first = match mesh_surface_held(phi, opts, size, true, Start::Marched { top: start::MAX_LEVELS }, None) {
        Err(e @ Error::BadSize(_)) => return fair_volume_or(phi, opts, size, e),
        first => first?,
    };
    let held = match first {
        Ok(out) => Ok(out),
        Err(e) => {
            trace(&e);
            // The features found from phi cut into the smooth mesh instead, whose even
            // triangles cut more cleanly than the marching start's (as for given features).
            let smooth = match smooth_run(phi, opts, size, None) {
                Ok(smooth) => smooth,
                // A part too thin is the input's to change, unless the 3-D mesh's boundary,
                // which holds the sharp edges, makes a fair surface of it: the two faces of a
                // wedge sharper than the facing test's angle (a ball less a box whose faces cut
                // it at 37 to 40 degrees) look like a sheet thinning to nothing at the edge.
                Err(e2 @ Error::BadSize(_)) => return fair_volume_or(phi, opts, size, e2),
                Err(e2) => {
                    trace(&e2);
                    let note =
                        format!("the surface mesher failed ({e2}): this is the boundary of the 3-D mesh of the inside");
                    return from_volume::from_volume(phi, opts, size, note).map_err(|e3| {
                        trace(&e3);
                        e2
                    });
                }
            };
            held_from_smooth(phi, opts, size, smooth).map_err(|failed| {
                let (smooth, e2) = *failed;
                trace(&e2);
                (smooth, e)
            })
        }
    };
    Ok(match held {
        // Features held, but a triangle sharper than the 3-D mesh's boundary would likely give.
        Ok(out) if out.report.feature_points > 0 && out.report.quality.min_angle < from_volume::TRY_BELOW_DEG => {
            let note = format!(
                "the surface held its sharp edges with a smallest angle of {:.1} degrees; this is the boundary of the 3-D mesh of the inside, which holds them too",
                out.report.quality.min_angle
            );
            match from_volume::from_volume(phi, opts, size, note) {
                Ok(mut other)
                    if other.report.quality.min_angle > out.report.quality.min_angle
                        && other.report.quality.inward_faces <= out.report.quality.inward_faces =>
                {
                    other.report.seconds += out.report.seconds;
                    other
                }
                Ok(_) => out,
                Err(e) => {
                    trace(&e);
                    out
                }
            }
        }
        Ok(out) => out,
        Err((smooth, e)) => volume_or_rounded(phi, opts, size, smooth, &e),
    })
}

/// A surface the mesher refused as too thin (`e`, a bad size): the boundary of the 3-D mesh of
/// the inside, which holds sharp edges, when it is fair ([`from_volume::fair`]), else `e`. The
/// two faces of a wedge sharper than the facing test's angle (a ball less a box whose faces cut
/// it at 37 to 41 degrees) look like a sheet thinning to nothing at the edge, and the 3-D
/// mesher holds such wedges.
fn fair_volume_or(
    phi: &dyn Implicit3,
    opts: &SurfaceOptions,
    size: &SizeField,
    e: Error,
) -> Result<SurfaceOutput, Error> {
    trace_held(&e);
    let note = format!("the surface mesher failed ({e}): this is the boundary of the 3-D mesh of the inside");
    match from_volume::from_volume(phi, opts, size, note) {
        Ok(out) if from_volume::fair(&out) => Ok(out),
        Ok(_) => Err(e),
        Err(e2) => {
            trace_held(&e2);
            Err(e)
        }
    }
}

/// Runs holding the given features from the starts after the smooth mesh, in turn, until one
/// passes: the invalid smooth mesh `invalid` (if any) with the features cut into it, the
/// marching start with them cut into it, and the geometry's own triangulation (whose edges are
/// the features: a flat cone's 31 degree rim, a wedge thinner than two edges for 0.2 from the
/// rim, rounds into a fold from the other starts). None when every one fails.
fn held_fallbacks(
    phi: &dyn Implicit3,
    opts: &SurfaceOptions,
    size: &SizeField,
    invalid: Option<TriMesh<DVec3>>,
) -> Option<SurfaceOutput> {
    let input = phi.creases().and_then(features::input_start).map(Start::Input);
    let starts = invalid.map(Start::Given).into_iter().chain([Start::Marched { top: start::MAX_LEVELS }]).chain(input);
    for from in starts {
        let input = matches!(from, Start::Input(_));
        match mesh_surface_held(phi, opts, size, true, from, None) {
            // Below the floors, the run from the input's own triangulation may come nearer.
            Ok(Ok(out)) if !input => return Some(or_from_input(phi, opts, size, out)),
            Ok(Ok(out)) => return Some(out),
            Ok(Err(e)) | Err(e) => trace_held(&e),
        }
    }
    None
}

/// The floors of a surface holding sharp features: min angle in degrees and mean q (the
/// issue's targets for remeshing input with sharp edges). A result below either is made again
/// from the input's own triangulation, and the better of the two kept.
const HELD_FLOOR_ANGLE: f64 = 30.0;
const HELD_FLOOR_MEAN_Q: f64 = 0.97;

/// `out`, or when it misses the floors above, the run from the geometry's own triangulation
/// if that comes nearer them (the time of both counted): the cut starts and the input's
/// each reach the floors where the other misses them (measured: a 12-gon tube at h0 0.08,
/// 23.8 degrees cut into the smooth mesh against 36.1 from the input's triangulation; a turned
/// box the other way, 35.7 against 30.0).
fn or_from_input(phi: &dyn Implicit3, opts: &SurfaceOptions, size: &SizeField, out: SurfaceOutput) -> SurfaceOutput {
    let q = &out.report.quality;
    if q.min_angle >= HELD_FLOOR_ANGLE && q.mean_q >= HELD_FLOOR_MEAN_Q {
        return out;
    }
    let Some(m) = phi.creases().and_then(features::input_start) else { return out };
    match mesh_surface_held(phi, opts, size, true, Start::Input(m), None) {
        Ok(Ok(mut other)) => {
            let (a, b) = (&other.report.quality, &out.report.quality);
            // How near each comes to the floors (each term 1 at or above its floor), then the
            // min angle.
            let reach = |q: &SurfaceQuality| {
                (q.min_angle / HELD_FLOOR_ANGLE).min(1.0) + (q.mean_q / HELD_FLOOR_MEAN_Q).min(1.0)
            };
            let better = (reach(a), a.min_angle) > (reach(b), b.min_angle);
            if std::env::var_os("TRUSSMESH_TRACE").is_some() {
                eprintln!(
                    "held result below the floors (min angle {:.1}, mean q {:.4}); from the input's own triangulation: {:.1}, {:.4}",
                    b.min_angle, b.mean_q, a.min_angle, a.mean_q
                );
            }
            if better {
                other.report.seconds += out.report.seconds;
                other
            } else {
                let mut out = out;
                out.report.seconds += other.report.seconds;
                out
            }
        }
        Ok(Err(e)) | Err(e) => {
            trace_held(&e);
            out
        }
    }
}

/// With TRUSSMESH_TRACE set, says why a run holding the sharp features failed.
fn trace_held(e: &Error) {
    if std::env::var_os("TRUSSMESH_TRACE").is_some() {
        eprintln!("holding sharp features failed ({e}): the surface is meshed without them");
    }
}

/// The features cut into the smooth mesh `smooth` and held from there (its time counted in), or
/// `smooth` back with the error when holding them fails.
fn held_from_smooth(
    phi: &dyn Implicit3,
    opts: &SurfaceOptions,
    size: &SizeField,
    smooth: SurfaceOutput,
) -> Result<SurfaceOutput, Box<(SurfaceOutput, Error)>> {
    match mesh_surface_held(phi, opts, size, true, Start::Given(smooth.mesh.clone()), None) {
        Ok(Ok(mut out)) => {
            out.report.seconds += smooth.report.seconds;
            Ok(out)
        }
        Ok(Err(e)) | Err(e) => Err(Box::new((smooth, e))),
    }
}

/// Holding the sharp features failed from every start: the 3-D mesh's boundary holds them, and
/// is the result when its triangles are fair (none below TRY_BELOW_DEG degrees, none facing
/// inward); the smooth mesh, rounding them, is the last resort.
fn volume_or_rounded(
    phi: &dyn Implicit3,
    opts: &SurfaceOptions,
    size: &SizeField,
    smooth: SurfaceOutput,
    e: &Error,
) -> SurfaceOutput {
    let note = format!(
        "the surface has sharp edges, holding them failed ({e}): this is the boundary of the 3-D mesh of the inside, which holds them"
    );
    match from_volume::from_volume(phi, opts, size, note) {
        Ok(mut other) if from_volume::fair(&other) => {
            other.report.seconds += smooth.report.seconds;
            other
        }
        Ok(_) => rounded(smooth, e),
        Err(e2) => {
            trace_held(&e2);
            rounded(smooth, e)
        }
    }
}

/// A mesh made without the sharp features that holding failed on, its report saying so.
fn rounded(mut out: SurfaceOutput, e: &Error) -> SurfaceOutput {
    out.report.notes.push(format!("the surface has sharp edges, but holding them failed ({e}): this mesh rounds them"));
    out
}

/// About how many vertices a mesh of the surface of `m` at the sizes of `size` has: two
/// triangles per vertex, each of area sqrt 3 / 4 h^2 at the size at its centroid.
fn expected_vertices(m: &TriMesh<DVec3>, size: &SizeField) -> usize {
    let triangles: f64 = m
        .face_ids()
        .map(|f| {
            let [a, b, c] = m.face_vertices(f).map(|v| m.pos(v));
            let h = size.at((a + b + c) / 3.0);
            0.5 * (b - a).cross(c - a).length() / (0.25 * 3f64.sqrt() * h * h)
        })
        .sum();
    (0.5 * triangles) as usize
}

/// Where a run starts: a given mesh (its features cut into it) or the marching start made at
/// no coarser level than `top`.
enum Start {
    Given(TriMesh<DVec3>),
    /// The geometry's own labelled triangulation ([`features::input_start`]), used as it is.
    Input(TriMesh<DVec3>),
    Marched {
        top: u32,
    },
}

/// A run without sharp features from the marching start, made again from the next finer start
/// while the finished surface fails the final check: a coarse grid can march a pleat near a
/// sharp corner, nodes that cannot be projected without folding a triangle, which no later
/// stage unfolds (a turned box started at 4 h crossed itself there). The last invalid surface
/// is left in `invalid` when given.
fn smooth_run(
    phi: &dyn Implicit3,
    opts: &SurfaceOptions,
    size: &SizeField,
    invalid: Option<&mut Option<TriMesh<DVec3>>>,
) -> Result<SurfaceOutput, Error> {
    let mut top = start::MAX_LEVELS;
    loop {
        let mut failed = None;
        match mesh_surface_held(phi, opts, size, false, Start::Marched { top }, Some(&mut failed)) {
            Ok(Ok(out)) => return Ok(out),
            Ok(Err(e)) | Err(e) => match failed {
                // The start was coarser than the reference level: a finer one next.
                Some((_, level)) if level > 0 && level <= top => top = level - 1,
                Some((m, _)) => {
                    if let Some(slot) = invalid {
                        *slot = Some(m);
                    }
                    return Err(e);
                }
                None => return Err(e),
            },
        }
    }
}

/// [`mesh_surface`], holding sharp features when `sharp`, from `from`. The inner error is a
/// finished surface that fails the final check with features held. A smooth surface that fails
/// it is left in `invalid` when given, with the level its start was made at.
fn mesh_surface_held(
    phi: &dyn Implicit3,
    opts: &SurfaceOptions,
    size: &SizeField,
    sharp: bool,
    from: Start,
    invalid: Option<&mut Option<(TriMesh<DVec3>, u32)>>,
) -> Result<Result<SurfaceOutput, Error>, Error> {
    let start = std::time::Instant::now();
    let size = size.clone();
    let hmin = size.min();
    let tol = PROJECT_TOL * hmin;
    let (mut m, levels, held) = match from {
        Start::Given(mut g) => {
            if !features::imprint(&mut g, phi, hmin, tol)? {
                return Ok(Err(Error::internal("the given features could not be cut into the start")));
            }
            (g, 0, true)
        }
        Start::Input(g) => (g, 0, true),
        Start::Marched { top } => start::start_mesh(phi, opts.bbox, hmin, tol, sharp, top)?,
    };
    // The growth allowed is counted from the vertices the size asks for when the start is
    // coarser (the input's own triangulation: a cone of 18 vertices).
    let start_vertices = m.num_vertices().max(expected_vertices(&m, &size));
    let mut report: Report<SurfaceQuality> = Report::default();
    let mut st = SurfaceStages::default();
    let stages = levels as usize + 3;
    let tick = |done: usize| {
        if let Some(cb) = &opts.progress {
            cb(done, stages);
        }
    };
    tick(1);
    st.stage_seconds[0] = start.elapsed().as_secs_f64();
    let mut clock = st.stage_seconds[0];
    let mut lap = |st: &mut SurfaceStages, k: usize| {
        let now = start.elapsed().as_secs_f64();
        st.stage_seconds[k] += now - clock;
        clock = now;
    };
    let mut counts = OpCounts::default();
    let mut kept = 0;
    for level in (0..=levels).rev() {
        let level_size = size.scaled((1u32 << level) as f64);
        // The coarsest level gets the remeshing passes and a force loop run to its plateau; each
        // finer level, made by subdivision, inherits its quality: remeshing passes on the levels
        // above the finest, and a short loop on each to relax what the projected midpoints
        // disturbed. On the finest level passes and long loops would cost the most and add
        // little (measured on the unit sphere, see docs/surface.md).
        let coarsest = level == levels;
        let passes = if level > 0 || coarsest { density::REMESH_PASSES } else { 0 };
        for pass in 0..passes + density::CROWDED_PASSES {
            // The passes at the sizes, then while the mesh is still crowded, passes at the
            // sizes its count implies.
            let crowded = if pass < passes {
                None
            } else {
                match density::against_crowding(&m, &level_size, expected_vertices(&m, &level_size)) {
                    Some(s) => Some(s),
                    None => break,
                }
            };
            density::remesh_pass(&mut m, phi, crowded.as_ref().unwrap_or(&level_size), tol, &mut counts)?;
            st.remesh_passes += 1;
            if held && m.num_vertices() > HELD_GROWTH * start_vertices + 1000 {
                return Ok(Err(held_runaway(start_vertices, m.num_vertices())));
            }
        }
        counts.flips += flip_pass(&mut m, phi, FlipGoal::Quality, 10);
        lap(&mut st, 1);
        let patience = equilibrium::patience(coarsest, levels);
        let run = equilibrium::force_loop(m, phi, &level_size, opts, tol, patience, &mut counts)?;
        if let Some((from, to)) = run.runaway {
            if held {
                return Ok(Err(held_runaway(from, to)));
            }
            let e = Error::BadSize(format!(
                "the surface mesh ran away at the size {:.3e} (from {from} to {to} vertices in one force loop)",
                level_size.min()
            ));
            return Err(too_thin_or(phi, &run.mesh, hmin, tol, e));
        }
        m = run.mesh;
        counts.undone += run.undone;
        if held && m.num_vertices() > HELD_GROWTH * start_vertices + 1000 {
            return Ok(Err(held_runaway(start_vertices, m.num_vertices())));
        }
        if level == 0 {
            let stop = if run.converged {
                StopReason::AtRest { dptol: opts.dptol }
            } else if run.plateau {
                StopReason::QualityPlateau
            } else {
                StopReason::IterationCap { max_iter: opts.max_iter }
            };
            report.stopped(run.iterations, stop);
            kept = run.kept;
        } else {
            st.coarse_iterations += run.iterations;
        }
        lap(&mut st, 2);
        if level > 0 {
            counts.splits += density::subdivide(&mut m, phi, tol)?;
            m = density::relayout(&m)?;
        }
        tick(stages - 1 - level as usize);
    }
    // The truss equilibrium balances forces; a few sweeps then even out the lengths themselves.
    st.equalize_sweeps += improve::equalize(&mut m, phi, &size, opts.dptol, tol)?;
    lap(&mut st, 3);
    tick(stages);
    // Final projection to the tight tolerance (the loop already projects every step).
    let ids: Vec<VertexId> = m.vertex_ids().collect();
    let mesh = &m;
    let finals: Vec<DVec3> = ids
        .par_iter()
        .map(|&v| match mesh.tag(v) {
            VertexTag::Interior => project(phi, mesh.pos(v), 1e-3 * tol),
            VertexTag::InternalBoundary { .. } => {
                let p = mesh.pos(v);
                // A vertex whose curve is not found near it (mislabelled by the cut) is projected
                // as any other: it must end on phi = 0 all the same.
                match features::held_target(mesh, phi, v, DVec3::ZERO, size.at(p), 1e-3 * tol)? {
                    Some((q, _)) => Ok(q),
                    None => project(phi, p, 1e-3 * tol),
                }
            }
            _ => Ok(mesh.pos(v)),
        })
        .collect::<Result<_, Error>>()?;
    let given = phi.creases().is_some();
    for (&v, &p) in ids.iter().zip(&finals) {
        // Unchecked for folds (the steps are within the tolerance the loop projected to), but
        // with given features not where a curve vertex's step onto its curve would cross the
        // faces beside it.
        if given {
            move_unless_crossing(&mut m, v, p);
        } else {
            m.set_pos_unchecked(v, p);
        }
    }
    // A curve vertex the last step put onto its curve can leave a triangle with all three
    // corners on the curve flat (the arc's sagitta across a chord): flips mend it.
    if held {
        counts.flips += flip_pass(&mut m, phi, FlipGoal::Quality, 10);
    }
    // The promise of a level-set surface: closed, oriented, manifold, not self-intersecting.
    if let Err(e) = m.validate_closed_surface() {
        if std::env::var_os("TRUSSMESH_TRACE").is_some() {
            if let Some(f) = m.face_ids().find(|f| format!("{:?}", slotmap::Key::data(f)) == e.at) {
                let corners = m.face_vertices(f).map(|v| (m.pos(v), m.tag(v)));
                eprintln!("the finished surface fails at face {}: {corners:?}", e.at);
            }
        }
        let e = Error::broken("the finished surface is invalid", e);
        if held {
            return Ok(Err(e));
        }
        let e = too_thin_or(phi, &m, hmin, tol, e);
        if let Some(slot) = invalid {
            *slot = Some((m, levels));
        }
        return Err(e);
    }
    st.kept_iteration = kept;
    report.stages = Some(st);
    report.ops = counts;
    report.quality = SurfaceQuality::measure(&m, phi, &size);
    if held {
        report.feature_points = m.vertex_ids().filter(|&v| m.tag(v) != VertexTag::Interior).count();
    }
    if held && report.quality.min_q < HELD_MIN_Q {
        if std::env::var_os("TRUSSMESH_TRACE").is_some() {
            let q = |f: FaceId| crate::quality::triangle_q3(m.face_vertices(f).map(|v| m.pos(v)));
            if let Some(f) = m.face_ids().min_by(|&a, &b| q(a).total_cmp(&q(b))) {
                let corners = m.face_vertices(f).map(|v| (m.pos(v), m.tag(v)));
                eprintln!("the held surface's worst triangle, q {:.3}: {corners:?}", q(f));
            }
        }
        return Ok(Err(Error::internal(format!(
            "holding sharp features left a triangle of quality {:.3}",
            report.quality.min_q
        ))));
    }
    report.seconds = start.elapsed().as_secs_f64();
    Ok(Ok(SurfaceOutput { mesh: m, size, report }))
}
