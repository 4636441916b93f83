//! `--size auto`: the automatic size function of seed chapter 4 on the command line, with the
//! same parameter names in `mesh` and `surface`: `--per-radian K` (elements per radian of
//! boundary curvature), `--across N` (elements across narrow regions: gaps, slabs),
//! `--gradient G` (neighbouring sizes differ by at most a factor 1 + G) and `--hmax H`.

use super::Failure;
use clap::Args;
use glam::{DVec2, DVec3};
use std::sync::{Arc, OnceLock};
use trussmesh::geometry::{Grid2, Grid3, Implicit2, Implicit3};
use trussmesh::size::{auto_size_2d, auto_size_3d, SizeParams};

/// The automatic size's parameters (flags of `mesh`).
#[derive(Args, Debug, Default, Clone)]
pub struct AutoSizeArgs {
    /// With --size auto: elements per radian of boundary curvature, h = 1/(K |kappa|)
    /// [default: 2].
    #[arg(long, value_name = "K", allow_hyphen_values = true)]
    pub per_radian: Option<f64>,
    /// With --size auto: elements across narrow regions (gaps, slabs), h = 2 lfs / N
    /// [default: 4].
    #[arg(long, value_name = "N", allow_hyphen_values = true)]
    pub across: Option<f64>,
    /// With --size auto: gradient limit G, neighbouring sizes within a factor 1 + G
    /// [default: 0.3].
    #[arg(long, value_name = "G", allow_hyphen_values = true)]
    pub gradient: Option<f64>,
    /// With --size auto: the largest size [default: 10 h0].
    #[arg(long, value_name = "H", allow_hyphen_values = true)]
    pub hmax: Option<f64>,
}

/// Whether `--size` asks for the automatic size.
pub fn is_auto(size: Option<&str>) -> bool {
    size.is_some_and(|s| s.trim().eq_ignore_ascii_case("auto"))
}

/// The grid cap: nodes of the size grid (spacing h0 / 2) in 2-D and in 3-D.
const MAX_NODES: [f64; 2] = [2.0e7, 6.0e6];

/// A checked automatic size: its parameters, and its grid once computed.
pub struct Auto {
    pub params: SizeParams,
    grid2: OnceLock<Arc<Grid2>>,
    grid3: OnceLock<Arc<Grid3>>,
}

impl AutoSizeArgs {
    fn given(&self) -> bool {
        self.per_radian.is_some() || self.across.is_some() || self.gradient.is_some() || self.hmax.is_some()
    }

    /// The checked parameters for smallest size `h0`; `auto` says whether `--size auto` was
    /// given (the flags without it are refused).
    pub fn resolve(&self, auto: bool, h0: f64) -> Result<Option<Auto>, Failure> {
        if !auto {
            if self.given() {
                return Err(Failure::bad("--per-radian, --across, --gradient and --hmax go with --size auto"));
            }
            return Ok(None);
        }
        let k = self.per_radian.unwrap_or(2.0);
        let n = self.across.unwrap_or(4.0);
        let g = self.gradient.unwrap_or(0.3);
        let hmax = self.hmax.unwrap_or(10.0 * h0);
        if !(k >= 0.0 && k.is_finite()) {
            return Err(Failure::bad(format!("--per-radian {k} must be a finite number >= 0 (0 turns it off)")));
        }
        if !(n >= 0.0 && n.is_finite()) {
            return Err(Failure::bad(format!("--across {n} must be a finite number >= 0 (0 turns it off)")));
        }
        if !(g > 0.0 && g.is_finite()) {
            return Err(Failure::bad(format!("--gradient {g} must be positive and finite (0.3 is usual)")));
        }
        if !(hmax > h0 && hmax.is_finite()) {
            return Err(Failure::bad(format!("--hmax {hmax} must be finite and larger than --h0 {h0}")));
        }
        let params = SizeParams { k, r: 0.5 * n, g, hmin: h0, hmax, ..SizeParams::default() };
        Ok(Some(Auto { params, grid2: OnceLock::new(), grid3: OnceLock::new() }))
    }
}

/// The grid's box: `lo`..`hi` padded by two spacings, and its node count.
fn padded(lo: &[f64], hi: &[f64], step: f64) -> (Vec<f64>, Vec<f64>, f64) {
    let lo: Vec<f64> = lo.iter().map(|x| x - 2.0 * step).collect();
    let hi: Vec<f64> = hi.iter().map(|x| x + 2.0 * step).collect();
    let nodes = lo.iter().zip(&hi).map(|(a, b)| ((b - a) / step).ceil() + 1.0).product();
    (lo, hi, nodes)
}

fn too_many(nodes: f64, cap: f64, h0: f64) -> Failure {
    Failure::bad(format!(
        "--size auto samples the domain on a grid of spacing h0/2 = {}: {} nodes, more than {}; give a larger --h0 \
         or a smaller --bbox",
        h0 / 2.0,
        super::budget::count(nodes),
        super::budget::count(cap)
    ))
}

impl Auto {
    /// The 2-D size grid over the box (computed once).
    pub fn grid2(&self, domain: &dyn Implicit2, lo: [f64; 2], hi: [f64; 2]) -> Result<Arc<Grid2>, Failure> {
        if let Some(g) = self.grid2.get() {
            return Ok(g.clone());
        }
        let step = 0.5 * self.params.hmin;
        let (lo, hi, nodes) = padded(&lo, &hi, step);
        if nodes > MAX_NODES[0] {
            return Err(too_many(nodes, MAX_NODES[0], self.params.hmin));
        }
        let g = auto_size_2d(domain, [DVec2::new(lo[0], lo[1]), DVec2::new(hi[0], hi[1])], step, &self.params)?;
        Ok(self.grid2.get_or_init(|| Arc::new(g)).clone())
    }

    /// The 3-D size grid over the box (computed once).
    pub fn grid3(&self, domain: &dyn Implicit3, lo: [f64; 3], hi: [f64; 3]) -> Result<Arc<Grid3>, Failure> {
        if let Some(g) = self.grid3.get() {
            return Ok(g.clone());
        }
        let step = 0.5 * self.params.hmin;
        let (lo, hi, nodes) = padded(&lo, &hi, step);
        if nodes > MAX_NODES[1] {
            return Err(too_many(nodes, MAX_NODES[1], self.params.hmin));
        }
        let b = [DVec3::new(lo[0], lo[1], lo[2]), DVec3::new(hi[0], hi[1], hi[2])];
        let g = auto_size_3d(domain, b, step, &self.params)?;
        Ok(self.grid3.get_or_init(|| Arc::new(g)).clone())
    }

    /// The grids computed so far (for the mesher options).
    pub fn ready2(&self) -> Option<Arc<Grid2>> {
        self.grid2.get().cloned()
    }

    /// See [`Auto::ready2`].
    pub fn ready3(&self) -> Option<Arc<Grid3>> {
        self.grid3.get().cloned()
    }
}
