//! The fields of `mesh`: the domain d and the size h, each an expression in x, y (z) or a grid
//! file, a NumPy `.npy` array (placed by `--origin` and `--spacing`) or a VTK `.vti` image (which
//! carries its own origin and spacing), interpolated (seed section 3.1, example 1 from a grid).

use super::mesh::{constant, split_top};
use super::Failure;
use std::path::Path;
use std::sync::Arc;
use trussmesh::expr::Expr;
use trussmesh::geometry::{Grid2, Grid3, Implicit2, Implicit3};
use trussmesh::glam::{DMat2, DMat3, DVec2, DVec3};
use trussmesh::io::{is_grid_file, read_grid_file};

/// A field given by an expression or by samples on a grid.
#[derive(Clone, Debug)]
pub enum Field {
    /// An expression.
    Expr(Expr),
    /// A 2-D grid read from the file `source`.
    Grid2 { source: String, grid: Arc<Grid2> },
    /// A 3-D grid read from the file `source`.
    Grid3 { source: String, grid: Arc<Grid3> },
}

impl Field {
    /// The value at (x, y, z) (z is ignored by 2-D grids).
    pub fn eval(&self, x: f64, y: f64, z: f64) -> f64 {
        match self {
            Field::Expr(e) => e.eval(x, y, z),
            Field::Grid2 { grid, .. } => grid.value(DVec2::new(x, y)),
            Field::Grid3 { grid, .. } => grid.value(DVec3::new(x, y, z)),
        }
    }
    /// The expression's text or the file's name.
    pub fn source(&self) -> &str {
        match self {
            Field::Expr(e) => e.source(),
            Field::Grid2 { source, .. } | Field::Grid3 { source, .. } => source,
        }
    }
    /// The expression, when the field is one.
    pub fn expr(&self) -> Option<&Expr> {
        match self {
            Field::Expr(e) => Some(e),
            _ => None,
        }
    }
    /// Whether the field depends on z (expressions using z, 3-D grids).
    pub fn uses_z(&self) -> bool {
        match self {
            Field::Expr(e) => e.uses_z(),
            Field::Grid2 { .. } => false,
            Field::Grid3 { .. } => true,
        }
    }
    /// The box a grid's samples cover (min corner, then max corner, `dim` values each).
    pub fn grid_box(&self) -> Option<Vec<f64>> {
        let (lo, hi) = match self {
            Field::Expr(_) => return None,
            Field::Grid2 { grid, .. } => {
                let (nx, ny) = grid.dims();
                let o = grid.origin();
                let h = grid.spacing();
                (vec![o.x, o.y], vec![o.x + h * (nx - 1) as f64, o.y + h * (ny - 1) as f64])
            }
            Field::Grid3 { grid, .. } => {
                let n = grid.dims();
                let o = grid.origin().to_array();
                let h = grid.spacing();
                (o.to_vec(), (0..3).map(|k| o[k] + h * (n[k] - 1) as f64).collect())
            }
        };
        Some([lo, hi].concat())
    }
}

/// Where a `.npy` grid's samples sit: `--origin` and `--spacing`, as text.
#[derive(Clone, Debug, Default)]
pub struct Placement {
    pub origin: Option<String>,
    pub spacing: Option<String>,
}

impl Placement {
    fn given(&self) -> bool {
        self.origin.is_some() || self.spacing.is_some()
    }
    fn resolve(&self, dim: usize) -> Result<(Option<[f64; 3]>, Option<f64>), Failure> {
        let origin = match &self.origin {
            None => None,
            Some(s) => {
                let parts = split_top(s, ',');
                if parts.len() != dim {
                    return Err(Failure::bad(format!(
                        "--origin needs {dim} values for --dim {dim}, got {} ({s:?})",
                        parts.len()
                    )));
                }
                let mut o = [0.0; 3];
                for (k, p) in parts.iter().enumerate() {
                    o[k] = constant("an --origin value", p)?;
                }
                Some(o)
            }
        };
        let spacing = match &self.spacing {
            None => None,
            Some(s) => {
                let h = constant("--spacing", s)?;
                if !(h > 0.0 && h.is_finite()) {
                    return Err(Failure::bad(format!("--spacing must be positive and finite, got {h}")));
                }
                Some(h)
            }
        };
        Ok((origin, spacing))
    }
}

/// Whether `text` (a `--domain` or `--size` value) names a grid file.
pub fn is_grid(text: &str) -> bool {
    is_grid_file(text)
}

/// `--domain` or `--size` (`flag`) as a field: a grid file (.npy placed by `place`, .vti by
/// itself) or an expression.
pub fn load(flag: &str, text: &str, dim: usize, place: &Placement) -> Result<Field, Failure> {
    if !is_grid(text) {
        return super::mesh::parse_expr(flag, text).map(Field::Expr);
    }
    let file = text.trim();
    let fail = |e: trussmesh::Error| match e {
        // The message starts with the file's name.
        trussmesh::Error::Invalid(m) => Failure::bad(format!("{flag} {m}; nothing was done")),
        e => Failure::bad(format!("{flag} {file}: {e}; nothing was done")),
    };
    let g = read_grid_file(Path::new(file)).map_err(fail)?;
    if g.dim != dim {
        return Err(Failure::bad(format!(
            "{flag} {file} is a {}-D grid ({:?} samples) but --dim is {dim}{}",
            g.dim,
            &g.dims[..g.dim],
            if g.dim == 3 { "; give --dim 3" } else { "" }
        )));
    }
    let vti = file.to_ascii_lowercase().ends_with(".vti");
    if vti && place.given() {
        return Err(Failure::bad(format!(
            "{flag} {file}: a .vti image gives its own origin and spacing; --origin and --spacing are for .npy grids"
        )));
    }
    let (origin, spacing) = place.resolve(dim)?;
    if !vti && spacing.is_none() {
        return Err(Failure::bad(format!(
            "{flag} {file}: a .npy array has no spacing; give --spacing H (and --origin, default 0)"
        )));
    }
    let source = file.to_string();
    Ok(if dim == 2 {
        Field::Grid2 { source, grid: Arc::new(g.to_grid2(origin, spacing, file).map_err(fail)?) }
    } else {
        Field::Grid3 { source, grid: Arc::new(g.to_grid3(origin, spacing, file).map_err(fail)?) }
    })
}

/// A field as the 2-D mesher's domain: declared neither a distance nor a level set, so the
/// mesher decides from its gradient (as for expressions).
pub struct Field2(pub Field);

impl Implicit2 for Field2 {
    fn value(&self, p: DVec2) -> f64 {
        self.0.eval(p.x, p.y, 0.0)
    }
    fn gradient(&self, p: DVec2) -> DVec2 {
        match &self.0 {
            Field::Expr(e) => {
                let (_, g) = e.eval_grad(p.x, p.y, 0.0);
                DVec2::new(g[0], g[1])
            }
            Field::Grid2 { grid, .. } => grid.gradient(p),
            Field::Grid3 { grid, .. } => grid.gradient(p.extend(0.0)).truncate(),
        }
    }
    fn hessian(&self, p: DVec2) -> Option<DMat2> {
        match &self.0 {
            Field::Grid2 { grid, .. } => grid.hessian(p),
            _ => None,
        }
    }
    /// Not claimed (as an expression without --implicit).
    fn is_distance(&self) -> bool {
        false
    }
    fn declared_distance(&self) -> Option<bool> {
        None
    }
}

/// [`Field2`] in 3-D.
pub struct Field3(pub Field);

impl Implicit3 for Field3 {
    fn value(&self, p: DVec3) -> f64 {
        self.0.eval(p.x, p.y, p.z)
    }
    fn gradient(&self, p: DVec3) -> DVec3 {
        self.value_and_gradient(p).1
    }
    fn value_and_gradient(&self, p: DVec3) -> (f64, DVec3) {
        match &self.0 {
            Field::Expr(e) => {
                let (v, g) = e.eval_grad(p.x, p.y, p.z);
                (v, DVec3::from_array(g))
            }
            Field::Grid3 { grid, .. } => (grid.value(p), grid.gradient(p)),
            Field::Grid2 { grid, .. } => (grid.value(p.truncate()), grid.gradient(p.truncate()).extend(0.0)),
        }
    }
    fn hessian(&self, p: DVec3) -> Option<DMat3> {
        match &self.0 {
            Field::Grid3 { grid, .. } => grid.hessian(p),
            _ => None,
        }
    }
    /// Not claimed (as an expression without --implicit).
    fn is_distance(&self) -> bool {
        false
    }
    fn declared_distance(&self) -> Option<bool> {
        None
    }
}
