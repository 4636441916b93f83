//! The meshers' options for a triangulated geometry: the box from the input, and for
//! tetrahedra the input's sharp features held as fixed points.

use super::features::COARSE_WIDTH;
use super::TriSurface;
use crate::mesher::{Options3, SizeFn3};
use crate::surface::SurfaceOptions;
use glam::DVec3;
use std::collections::HashMap;

/// The extra padding of the surface remesher's box, in sizes (see
/// [`TriSurface::surface_options`]).
const SURFACE_PAD: f64 = 0.25;

impl TriSurface {
    /// The bounding box grown by max(h0, 1e-3 of its diagonal) on every side: a box for the
    /// meshers that holds the whole surface with room for the start lattice.
    pub fn padded_box(&self, h0: f64) -> [DVec3; 2] {
        let [lo, hi] = self.bbox;
        let pad = DVec3::splat(h0.max(1e-3 * (hi - lo).length()));
        [lo - pad, hi + pad]
    }

    /// Options of [`crate::mesh_3d`] for the inside of this surface: the padded box, relative
    /// sizes `size` (None: uniform), and with `feature_angle` Some(deg) the points of
    /// [`TriSurface::features`] at that angle held fixed, about one local edge length apart
    /// (h0 times size / the smallest size at an input vertex), in place of the mesher's own search
    /// for sharp edges from d. With None, no sharp edge is held.
    pub fn volume_options(&self, h0: f64, size: Option<SizeFn3>, feature_angle: Option<f64>) -> Options3 {
        let [lo, hi] = self.padded_box(h0);
        let mut o = Options3::uniform(h0, lo, hi).with_sharp_edges(false);
        let smin = match &size {
            Some(h) => {
                self.points.iter().map(|&p| h(p)).filter(|v| *v > 0.0 && v.is_finite()).fold(f64::INFINITY, f64::min)
            }
            None => 1.0,
        };
        if let Some(angle) = feature_angle {
            let spacing = |p: DVec3| match &size {
                Some(h) if smin.is_finite() => h0 * h(p) / smin,
                _ => h0,
            };
            let features = self.features_resolved(angle, Some(&spacing));
            // The sides of each coarse crease (not a feature edge at `angle`): a crease point is
            // held where the facets on both sides are COARSE_WIDTH h wide across it there.
            let cos_max = angle.to_radians().cos();
            let mut sides: HashMap<[usize; 2], Vec<(usize, usize)>> = HashMap::new();
            for (t, tri) in self.tris.iter().enumerate() {
                for k in 0..3 {
                    let (a, b) = (tri[k], tri[(k + 1) % 3]);
                    let key = [a.min(b), a.max(b)];
                    let w = self.neighbors[t][k];
                    let smooth = self.normals.face(t).dot(self.normals.face(w)) >= cos_max;
                    if smooth && features.edges.binary_search(&key).is_ok() {
                        sides.entry(key).or_default().push((t, k));
                    }
                }
            }
            let keep = |q: DVec3, [a, b]: [usize; 2]| {
                let Some(list) = sides.get(&[a.min(b), a.max(b)]) else { return true };
                let limit = COARSE_WIDTH * spacing(q);
                list.iter().all(|&(t, k)| self.width_across(t, k, q, limit) >= limit)
            };
            o = o.with_fixed(features.sample_where(self, &spacing, &keep));
        }
        if let Some(h) = size {
            o.size = Some(h);
        }
        o
    }

    /// Options of [`crate::mesh_surface`] that remesh this surface at edge length `h0`: the
    /// padded box, uniform size.
    ///
    /// The box is padded by SURFACE_PAD h0 more than [`TriSurface::padded_box`], a part of a
    /// size: the marching start's grid begins one of its spacings (h0 times a power of two)
    /// before the box, so whole sizes would put the input's lowest faces on a plane of grid
    /// nodes at every level, where the distance is zero up to rounding and the start marches a
    /// sheet of nodes projected straight down onto the face (regular, but the part's results
    /// were the worst of the offsets measured there).
    pub fn surface_options(&self, h0: f64) -> SurfaceOptions {
        let [lo, hi] = self.padded_box(h0);
        let pad = DVec3::splat(SURFACE_PAD * h0);
        SurfaceOptions::uniform(h0, lo - pad, hi + pad)
    }
}
