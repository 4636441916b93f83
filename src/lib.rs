//! trussmesh: high-quality simplex meshes of implicit geometries.
//!
//! The mesh is a truss: bars push nodes apart toward lengths set by a size function h(x),
//! nodes that leave the domain d(x) < 0 are projected back, and the connectivity is kept good
//! by local operations (flips, splits, collapses) instead of global retriangulation
//! (Persson's thesis, chapters 2 and 3; the "seed" in comments).
//!
//! # Quick start
//!
//! ```
//! use trussmesh::glam::{DVec2, DVec3};
//! use trussmesh::geometry::Circle;
//! use trussmesh::{mesh_2d, mesh_3d, mesh_surface, Options2, Options3, SurfaceOptions};
//!
//! // Triangles in the unit disk, edges about 0.2 long.
//! let disk = mesh_2d(&Circle::new([0.0, 0.0], 1.0), &Options2::uniform(0.2, [-1.0, -1.0], [1.0, 1.0]))?;
//! assert!(disk.report.quality.q_min > 0.7);
//!
//! // Tetrahedra in the unit ball (a closure is a signed distance).
//! let ball = mesh_3d(&|p: DVec3| p.length() - 1.0, &Options3::uniform(0.4, [-1.1; 3], [1.1; 3]))?;
//! assert!(ball.report.quality.dihedral_min > 5.0);
//!
//! // Surface triangles on the unit sphere.
//! let sphere = mesh_surface(&|p: DVec3| p.length() - 1.0, &SurfaceOptions::uniform(0.3, [-1.2; 3], [1.2; 3]))?;
//! assert_eq!(sphere.mesh.euler_characteristic(), 2);
//!
//! // Every run reports why it stopped, what it did and what it made.
//! println!("{}\n{}\n{}", disk.report, ball.report, sphere.report);
//! # let _ = DVec2::ZERO;
//! # Ok::<(), trussmesh::Error>(())
//! ```
//!
//! Layers, bottom up: [`predicates`] and [`quality`], [`topology`] (the half-edge and
//! tetrahedral engines), [`geometry`] (implicit functions and projections), [`mesher`] (the
//! planar, volume and surface pipelines on one truss), [`io`] and [`expr`] (the command
//! line's expression language).
#![forbid(unsafe_code)]
#![deny(rustdoc::broken_intra_doc_links)]

pub mod error;
pub mod expr;
pub mod gallery;
pub mod geometry;
pub mod io;
pub mod mesher;
pub mod predicates;
pub mod quality;
pub mod size;
pub mod topology;

pub use mesher::surface;

/// The vector types of the API (`DVec2`, `DVec3`), re-exported so that a user needs no glam
/// dependency of a matching version.
pub use glam;

pub use geometry::{Implicit2, Implicit3, LevelSet};
pub use mesher::surface::{mesh_surface, SurfaceOptions};
pub use mesher::{mesh_2d, mesh_3d, MeshOutput, MeshOutput2, MeshOutput3, Options2, Options3, Report, StopReason};
pub use topology::MeshArrays;

#[doc(hidden)]
pub mod testing;

pub use error::Error;

/// The README's Rust examples, compiled and run as doc tests.
#[doc = include_str!("../README.md")]
#[cfg(doctest)]
pub struct ReadmeDoctests;

/// Hash maps and sets keyed by indices in hot paths (building meshes from arrays, carving):
/// foldhash's fast hasher with a fixed seed. The standard SipHash costs several times more per
/// lookup there; the fixed seed keeps every run identical (nothing relies on iteration order).
pub(crate) type FastMap<K, V> = std::collections::HashMap<K, V, foldhash::fast::FixedState>;
