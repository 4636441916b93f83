//! What every meshing run reports: one [`Report`] for the planar, volume and surface meshers,
//! generic over the quality summary of its elements.

use std::fmt;

/// The quality floor of a triangle mesh (2-D and surfaces): a smallest q below it is a warning
/// of the report.
pub const Q_FLOOR: f64 = 0.3;
/// The quality floor of a tetrahedral mesh, in degrees of the smallest dihedral angle.
pub const DIHEDRAL_FLOOR: f64 = 10.0;

/// Why the force loop of a run stopped.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
#[non_exhaustive]
pub enum StopReason {
    /// The loop did not run (no iteration was asked for).
    #[default]
    NotRun,
    /// Every node moved less than `dptol` times its local size in a step (the seed's test).
    AtRest {
        /// The movement tolerance.
        dptol: f64,
    },
    /// The quality stopped rising.
    QualityPlateau,
    /// The iteration cap was reached; the mesh is still valid, the state the run had (the best
    /// seen, for the surface mesher).
    IterationCap {
        /// The cap.
        max_iter: usize,
    },
}

impl StopReason {
    /// True when the run came to rest or to its quality plateau (not stopped by the cap).
    pub fn converged(&self) -> bool {
        matches!(self, StopReason::AtRest { .. } | StopReason::QualityPlateau)
    }
}

impl fmt::Display for StopReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            StopReason::NotRun => write!(f, "no iteration run"),
            StopReason::AtRest { dptol } => write!(f, "nodes moved less than dptol = {dptol} (relative to h)"),
            StopReason::QualityPlateau => write!(f, "mean quality stopped improving"),
            StopReason::IterationCap { max_iter } => write!(f, "iteration cap of {max_iter} reached"),
        }
    }
}

/// The local operations a run made.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct OpCounts {
    /// Flips: edge flips (2-D, surfaces); 2-3, 3-2 flips, edge removals and boundary edge
    /// flips (3-D).
    pub flips: usize,
    /// Edge splits.
    pub splits: usize,
    /// Edge collapses.
    pub collapses: usize,
    /// Elements squashed against the boundary that were dropped from it (3-D).
    pub removed: usize,
    /// Vertex moves accepted by optimisation-based smoothing and perturbation (3-D).
    pub smoothings: usize,
    /// Node moves undone because they would fold a triangle (surfaces).
    pub undone: usize,
}

/// The stages of the surface mesher's coarse-to-fine run.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SurfaceStages {
    /// Remeshing passes that made the start mesh (split, collapse, flip, smooth).
    pub remesh_passes: usize,
    /// Force iterations on the coarser levels, before their subdivisions (0 without).
    pub coarse_iterations: usize,
    /// The iteration whose mesh was kept (the best by quality).
    pub kept_iteration: usize,
    /// Length-equalising sweeps after the force iteration.
    pub equalize_sweeps: usize,
    /// Wall time of each stage, seconds: the start (marching and curvature), the remeshing
    /// levels with their subdivisions, the force loop, the length equalisation.
    pub stage_seconds: [f64; 4],
}

/// The report of a meshing run: why it stopped, what it did, and the quality of the result
/// (`Q`: [`QualityStats`](super::QualityStats) for triangles,
/// [`QualityStats3`](super::QualityStats3) for tetrahedra,
/// [`SurfaceQuality`](super::surface::SurfaceQuality) for surfaces). `Display` prints it.
#[derive(Clone, Debug, Default)]
#[non_exhaustive]
pub struct Report<Q> {
    /// Force iterations done (on the finest level, for surfaces).
    pub iterations: usize,
    /// True when the movement tolerance or the quality plateau ended the run; false when the
    /// iteration cap did (the mesh is still valid).
    pub converged: bool,
    /// Why the force loop stopped.
    pub stop: StopReason,
    /// Wall time in seconds.
    pub seconds: f64,
    /// The local operations made.
    pub ops: OpCounts,
    /// Quality of the result.
    pub quality: Q,
    /// Boundary nodes left farther than 1e-3 h0 from d = 0 (0 in a good run).
    pub boundary_nodes_off: usize,
    /// Internal-boundary nodes left farther than 1e-3 h0 from d_I = 0 (0 in a good run).
    pub internal_nodes_off: usize,
    /// Points on sharp features found from d and held fixed (2-D corners; 3-D points on edges
    /// and corners), besides the given fixed points.
    pub feature_points: usize,
    /// With a metric (2-D): metric edge lengths and metric quality of the result.
    pub metric: Option<super::metric::MetricStats>,
    /// For surfaces: the stages of the run.
    pub stages: Option<SurfaceStages>,
    /// 2-D: when the iteration cap ended the force loop and an earlier state had a higher
    /// smallest quality than the last one, the iteration of that state, which the run
    /// finished from (the best mesh so far, as `max_iter` promises).
    pub kept_iteration: Option<usize>,
    /// How the domain was taken (2-D, 3-D): `Some` when the mesher decided between a signed
    /// distance and a level set by sampling |grad d| over the box (the geometry declared
    /// neither), `None` when the geometry declared it.
    pub gradient_survey: Option<crate::geometry::GradientSurvey>,
    /// True when the domain was meshed as a level set (first-order projection, d / |grad d|
    /// as the distance), declared or decided.
    pub level_set: bool,
    /// What the run changed or doubts about its input (a part of the domain below the
    /// resolution dropped, ...), one sentence each; printed as warnings.
    pub notes: Vec<String>,
    /// 2-D: the parts of the domain left out because the requested size there is wider than
    /// they are (one point of each and the element size there); see `mesh_2d`, which meshes
    /// such a domain again with the size capped by the local feature size.
    pub dropped_by_size: Vec<([f64; 2], f64)>,
}

impl<Q> Report<Q> {
    /// The same report with its quality summary mapped by `f` (e.g. dropped, to hold reports
    /// of runs of every dimension together).
    pub fn map_quality<R>(self, f: impl FnOnce(Q) -> R) -> Report<R> {
        Report {
            iterations: self.iterations,
            converged: self.converged,
            stop: self.stop,
            seconds: self.seconds,
            ops: self.ops,
            quality: f(self.quality),
            boundary_nodes_off: self.boundary_nodes_off,
            internal_nodes_off: self.internal_nodes_off,
            feature_points: self.feature_points,
            metric: self.metric,
            stages: self.stages,
            kept_iteration: self.kept_iteration,
            gradient_survey: self.gradient_survey,
            level_set: self.level_set,
            notes: self.notes,
            dropped_by_size: self.dropped_by_size,
        }
    }

    /// Records how the force loop ended.
    pub(crate) fn stopped(&mut self, iterations: usize, stop: StopReason) {
        self.iterations = iterations;
        self.converged = stop.converged();
        self.stop = stop;
    }

    /// The warnings of the run, one line each (empty for a good run).
    pub(crate) fn warnings(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let (Some(s), true) = (&self.gradient_survey, self.level_set) {
            write!(
                f,
                "\nthe domain is a level set, not a signed distance (|grad d| {:.3} to {:.3} near d = 0): projected by gradient steps",
                s.grad_min, s.grad_max
            )?;
        }
        for n in &self.notes {
            write!(f, "\nwarning: {n}")?;
        }
        if self.boundary_nodes_off > 0 {
            write!(
                f,
                "\nwarning: {} boundary nodes are off the boundary (more than 1e-3 h0)",
                self.boundary_nodes_off
            )?;
        }
        if self.internal_nodes_off > 0 {
            write!(
                f,
                "\nwarning: {} internal-boundary nodes are off their curve (more than 1e-3 h0)",
                self.internal_nodes_off
            )?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_cap_is_not_convergence() {
        assert!(StopReason::AtRest { dptol: 1e-3 }.converged());
        assert!(StopReason::QualityPlateau.converged());
        assert!(!StopReason::IterationCap { max_iter: 10 }.converged());
        let mut r: Report<()> = Report::default();
        r.stopped(10, StopReason::IterationCap { max_iter: 10 });
        assert!(!r.converged);
        assert_eq!(r.stop.to_string(), "iteration cap of 10 reached");
    }
}
