//! Failures of `mesh` rewritten in the user's terms (a domain thinner than h0, a relative size
//! that grows past the domain, an h0 too large for it).

use super::mesh::{round_sig, show_point, sig, Job};
use super::sample::DomainSample;
use super::Failure;

impl Job {
    /// Rewrites a mesher's failure in the user's terms where its message cannot know them.
    pub(super) fn diagnose(&self, f: Failure) -> Failure {
        if f.code != super::EXIT_BAD_INPUT {
            return f;
        }
        let empty = f.message.starts_with("empty domain: no triangle of the initial mesh")
            || f.message.contains("lattice points fall inside the domain");
        let coplanar = f.message.contains("the points are coplanar");
        if !(empty || coplanar) {
            return f;
        }
        // Every start node inside lies in one plane: the domain is flat at h0's resolution.
        let flat = || {
            Failure::bad(format!(
                "the start mesh's nodes inside the domain all lie in one plane: the domain is thinner than h0 = {} \
                 across (or smaller than h0), so no tetrahedron fits in it; give a smaller --h0",
                self.h0
            ))
        };
        let s = DomainSample::new(self);
        if s.inside == 0 {
            return if coplanar { flat() } else { f };
        }
        let axes = ["x", "y", "z"];
        // A domain thinner than h0 along an axis: no element fits across it.
        for (k, axis) in axes.iter().enumerate().take(self.dim) {
            let thick = s.hi[k] - s.lo[k] + s.step[k];
            if thick < self.h0 {
                return Failure::bad(format!(
                    "the domain is about {} across along {}, less than h0 = {}: no {} fits across it; give an --h0 \
                     below {}",
                    sig(thick),
                    axis,
                    self.h0,
                    if self.dim == 3 { "tetrahedron" } else { "triangle" },
                    sig(thick / 2.0)
                ));
            }
        }
        if let Some(size) = &self.size {
            let ratio = s.h_max / s.h_min;
            let extent = (0..self.dim).map(|k| s.hi[k] - s.lo[k] + s.step[k]).fold(0.0f64, f64::max);
            if ratio.is_finite() && self.h0 * ratio > extent / 2.0 {
                let p = show_point(&s.h_max_at[..self.dim].iter().map(|&x| round_sig(x)).collect::<Vec<_>>());
                return Failure::bad(format!(
                    "--size {:?} grows from {} to {} inside the domain (at {p}): sizes are relative, so the elements \
                     there would be {} x h0 = {} across, more than half the domain ({} across), and the start mesh \
                     misses the domain; bound the size's ratio (such as min({}, R)) or lower --h0",
                    size.source(),
                    sig(s.h_min),
                    sig(s.h_max),
                    sig(ratio),
                    sig(self.h0 * ratio),
                    sig(extent),
                    size.source()
                ));
            }
        }
        if empty {
            let extent = (0..self.dim).map(|k| s.hi[k] - s.lo[k] + s.step[k]).fold(f64::INFINITY, f64::min);
            return Failure::bad(format!(
                "h0 = {} is too large for the domain, which is about {} across at its narrowest: give an --h0 below {}",
                self.h0,
                sig(extent),
                sig(extent / 3.0)
            ));
        }
        if coplanar {
            return flat();
        }
        f
    }
}
