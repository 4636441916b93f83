//! The native half of the `trussmesh` Python package (`trussmesh._core`): the library's three
//! meshers with numpy arrays in and out. The Python half (`trussmesh/__init__.py`) normalises
//! arguments, samples Python functions in batches (see [`grid`]) and wraps the results.
//!
//! A geometry or size argument is either an expression string of the command line's language
//! (compiled and evaluated in Rust) or a `Sampled2` / `Sampled3` grid of a Python function's
//! values. Either way the run itself holds no GIL and calls no Python, except the optional
//! progress callback; it runs on a worker thread while the calling thread waits without the
//! GIL and checks for signals, so that Ctrl-C stops it.

mod grid;

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::time::Duration;

use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyReadonlyArray3, PyUntypedArrayMethods};
use pyo3::exceptions::{PyKeyboardInterrupt, PyOSError, PyRuntimeError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};

use trussmesh::expr::{Expr, ExprImplicit2, ExprImplicit3};
use trussmesh::geometry::project::Projection;
use trussmesh::glam::{DVec2, DVec3};
use trussmesh::mesher::{Metric2, OpCounts, QualityStats, QualityStats3, Report, StopReason, Strategy};
use trussmesh::surface::SurfaceQuality;
use trussmesh::topology::{MeshArrays, VertexTag};
use trussmesh::{Implicit2, Implicit3, Options2, Options3, SurfaceOptions};

use grid::{Grid2, Grid3};

// ============================ errors ============================

/// The library's error as a Python exception: `ValueError` for bad input (with the library's
/// message), `OSError` for files, `RuntimeError` for internal errors.
fn py_err(e: trussmesh::Error) -> PyErr {
    use trussmesh::Error as E;
    match e {
        E::Io { .. } => PyOSError::new_err(e.to_string()),
        E::Internal { .. } => PyRuntimeError::new_err(e.to_string()),
        _ => PyValueError::new_err(e.to_string()),
    }
}

/// Splits at `sep` outside parentheses (the metric's "A;B;C").
fn split_top(s: &str, sep: char) -> Vec<String> {
    let mut out = Vec::new();
    let mut depth = 0i32;
    let mut cur = String::new();
    for c in s.chars() {
        match c {
            '(' => depth += 1,
            ')' => depth -= 1,
            _ => {}
        }
        if c == sep && depth <= 0 {
            out.push(std::mem::take(&mut cur));
        } else {
            cur.push(c);
        }
    }
    out.push(cur);
    out
}

fn parse_expr(what: &str, src: &str, dim: usize) -> PyResult<Expr> {
    let e = Expr::parse(src)
        .map_err(|e| PyValueError::new_err(format!("bad {what} expression, {e}\n{}", e.render(src))))?;
    if dim == 2 && e.uses_z() {
        return Err(PyValueError::new_err(format!("the {what} expression {src:?} uses z in a 2-D run")));
    }
    Ok(e)
}

// ============================ sampled grids ============================

/// A Python function's values on a 2-D grid, interpolated (cubic convolution).
#[pyclass(frozen, module = "trussmesh._core")]
struct Sampled2 {
    grid: Arc<Grid2>,
}

#[pymethods]
impl Sampled2 {
    /// `values` of shape (ny, nx) at `origin + spacing * (i, j)`; the interpolant is made to
    /// take `pin_values` at `pin_points` (the fixed points).
    #[new]
    #[pyo3(signature = (values, origin, spacing, pin_points=None, pin_values=None))]
    fn new(
        values: PyReadonlyArray2<'_, f64>,
        origin: [f64; 2],
        spacing: f64,
        pin_points: Option<PyReadonlyArray2<'_, f64>>,
        pin_values: Option<PyReadonlyArray1<'_, f64>>,
    ) -> PyResult<Self> {
        let shape = values.shape();
        let (ny, nx) = (shape[0], shape[1]);
        let v = values.as_array().iter().copied().collect();
        let mut g = Grid2::new(origin, spacing, nx, ny, v).map_err(PyValueError::new_err)?;
        if let (Some(p), Some(v)) = (pin_points, pin_values) {
            let pts = points2(&p, "pin_points")?;
            let vals: Vec<f64> = v.as_array().iter().copied().collect();
            if vals.len() != pts.len() {
                return Err(PyValueError::new_err("pin_points and pin_values differ in length"));
            }
            g.pin(&pts, &vals);
        }
        Ok(Sampled2 { grid: Arc::new(g) })
    }

    /// The interpolant and its gradient at the rows of an (n, 2) array.
    fn eval<'py>(&self, py: Python<'py>, points: PyReadonlyArray2<'py, f64>) -> PyResult<Bound<'py, PyTuple>> {
        let pts = points2(&points, "points")?;
        let (mut v, mut g) = (Vec::with_capacity(pts.len()), Vec::with_capacity(2 * pts.len()));
        for p in pts {
            let (val, gr) = self.grid.eval(p);
            v.push(val);
            g.extend([gr.x, gr.y]);
        }
        let n = v.len();
        (PyArray1::from_vec(py, v), PyArray1::from_vec(py, g).reshape([n, 2])?).into_pyobject(py)
    }

    #[getter]
    fn spacing(&self) -> f64 {
        self.grid.spacing()
    }
}

/// A Python function's values on a 3-D grid, interpolated (tricubic convolution).
#[pyclass(frozen, module = "trussmesh._core")]
struct Sampled3 {
    grid: Arc<Grid3>,
}

#[pymethods]
impl Sampled3 {
    /// `values` of shape (nz, ny, nx) at `origin + spacing * (i, j, k)`; see `Sampled2`.
    #[new]
    #[pyo3(signature = (values, origin, spacing, pin_points=None, pin_values=None))]
    fn new(
        values: PyReadonlyArray3<'_, f64>,
        origin: [f64; 3],
        spacing: f64,
        pin_points: Option<PyReadonlyArray2<'_, f64>>,
        pin_values: Option<PyReadonlyArray1<'_, f64>>,
    ) -> PyResult<Self> {
        let shape = values.shape();
        let n = [shape[2], shape[1], shape[0]];
        let v = values.as_array().iter().copied().collect();
        let mut g = Grid3::new(origin, spacing, n, v).map_err(PyValueError::new_err)?;
        if let (Some(p), Some(v)) = (pin_points, pin_values) {
            let pts = points3(&p, "pin_points")?;
            let vals: Vec<f64> = v.as_array().iter().copied().collect();
            if vals.len() != pts.len() {
                return Err(PyValueError::new_err("pin_points and pin_values differ in length"));
            }
            g.pin(&pts, &vals);
        }
        Ok(Sampled3 { grid: Arc::new(g) })
    }

    /// The interpolant and its gradient at the rows of an (n, 3) array.
    fn eval<'py>(&self, py: Python<'py>, points: PyReadonlyArray2<'py, f64>) -> PyResult<Bound<'py, PyTuple>> {
        let pts = points3(&points, "points")?;
        let (mut v, mut g) = (Vec::with_capacity(pts.len()), Vec::with_capacity(3 * pts.len()));
        for p in pts {
            let (val, gr) = self.grid.eval(p);
            v.push(val);
            g.extend(gr.to_array());
        }
        let n = v.len();
        (PyArray1::from_vec(py, v), PyArray1::from_vec(py, g).reshape([n, 3])?).into_pyobject(py)
    }

    #[getter]
    fn spacing(&self) -> f64 {
        self.grid.spacing()
    }
}

fn points2(a: &PyReadonlyArray2<'_, f64>, what: &str) -> PyResult<Vec<DVec2>> {
    let v = a.as_array();
    if v.ncols() != 2 {
        return Err(PyValueError::new_err(format!("{what} must have shape (n, 2), got {:?}", v.shape())));
    }
    Ok(v.rows().into_iter().map(|r| DVec2::new(r[0], r[1])).collect())
}

fn points3(a: &PyReadonlyArray2<'_, f64>, what: &str) -> PyResult<Vec<DVec3>> {
    let v = a.as_array();
    if v.ncols() != 3 {
        return Err(PyValueError::new_err(format!("{what} must have shape (n, 3), got {:?}", v.shape())));
    }
    Ok(v.rows().into_iter().map(|r| DVec3::new(r[0], r[1], r[2])).collect())
}

// ============================ geometries ============================

/// A scalar field of the plane: an expression or a sampled Python function.
#[derive(Clone)]
enum Field2 {
    Expr(ExprImplicit2),
    Grid(Arc<Grid2>),
}

impl Field2 {
    fn from_py(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Self> {
        if let Ok(s) = obj.extract::<String>() {
            return Ok(Field2::Expr(ExprImplicit2::new(parse_expr(what, &s, 2)?)));
        }
        if let Ok(g) = obj.cast::<Sampled2>() {
            return Ok(Field2::Grid(g.get().grid.clone()));
        }
        Err(PyTypeError::new_err(format!(
            "{what} must be an expression string or a Sampled2 grid, not {}",
            obj.get_type().name()?
        )))
    }
    #[inline]
    fn value(&self, p: DVec2) -> f64 {
        match self {
            Field2::Expr(e) => e.value(p),
            Field2::Grid(g) => g.value(p),
        }
    }
    #[inline]
    fn gradient(&self, p: DVec2) -> DVec2 {
        match self {
            Field2::Expr(e) => e.gradient(p),
            Field2::Grid(g) => g.eval(p).1,
        }
    }
}

/// A field of space: an expression or a sampled Python function.
#[derive(Clone)]
enum Field3 {
    Expr(ExprImplicit3),
    Grid(Arc<Grid3>),
}

impl Field3 {
    fn from_py(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Self> {
        if let Ok(s) = obj.extract::<String>() {
            return Ok(Field3::Expr(ExprImplicit3::new(parse_expr(what, &s, 3)?)));
        }
        if let Ok(g) = obj.cast::<Sampled3>() {
            return Ok(Field3::Grid(g.get().grid.clone()));
        }
        Err(PyTypeError::new_err(format!(
            "{what} must be an expression string or a Sampled3 grid, not {}",
            obj.get_type().name()?
        )))
    }
    #[inline]
    fn value(&self, p: DVec3) -> f64 {
        match self {
            Field3::Expr(e) => e.value(p),
            Field3::Grid(g) => g.value(p),
        }
    }
    #[inline]
    fn value_and_gradient(&self, p: DVec3) -> (f64, DVec3) {
        match self {
            Field3::Expr(e) => e.value_and_gradient(p),
            Field3::Grid(g) => g.eval(p),
        }
    }
}

/// A 2-D geometry that turns to NaN once the run is to stop (Ctrl-C, a raising progress
/// callback): the library then stops with a non-finite-value error at its next evaluation.
#[derive(Clone)]
struct Domain2 {
    field: Field2,
    distance: bool,
    stop: Arc<AtomicBool>,
}

impl Implicit2 for Domain2 {
    #[inline]
    fn value(&self, p: DVec2) -> f64 {
        if self.stop.load(Ordering::Relaxed) {
            return f64::NAN;
        }
        self.field.value(p)
    }
    #[inline]
    fn gradient(&self, p: DVec2) -> DVec2 {
        self.field.gradient(p)
    }
    fn declared_distance(&self) -> Option<bool> {
        (!self.distance).then_some(false)
    }
}

/// The 3-D counterpart of [`Domain2`].
#[derive(Clone)]
struct Domain3 {
    field: Field3,
    distance: bool,
    stop: Arc<AtomicBool>,
}

impl Implicit3 for Domain3 {
    #[inline]
    fn value(&self, p: DVec3) -> f64 {
        if self.stop.load(Ordering::Relaxed) {
            return f64::NAN;
        }
        self.field.value(p)
    }
    #[inline]
    fn gradient(&self, p: DVec3) -> DVec3 {
        self.field.value_and_gradient(p).1
    }
    #[inline]
    fn value_and_gradient(&self, p: DVec3) -> (f64, DVec3) {
        if self.stop.load(Ordering::Relaxed) {
            return (f64::NAN, DVec3::ZERO);
        }
        self.field.value_and_gradient(p)
    }
    fn declared_distance(&self) -> Option<bool> {
        (!self.distance).then_some(false)
    }
}

fn projection(name: Option<String>) -> PyResult<Option<Projection>> {
    Ok(match name.as_deref() {
        None => None,
        Some("auto") => Some(Projection::Auto),
        Some("exact") => Some(Projection::Exact),
        Some("first") => Some(Projection::FirstOrder),
        Some("second") => Some(Projection::SecondOrder),
        Some("newton") => Some(Projection::Newton),
        Some(other) => {
            return Err(PyValueError::new_err(format!(
                "projection must be one of 'auto', 'exact', 'first', 'second', 'newton', not {other:?}"
            )))
        }
    })
}

// ============================ running ============================

/// What a run shares with the calling thread: the stop flag and the first error of the
/// progress callback.
struct RunState {
    stop: Arc<AtomicBool>,
    failure: Arc<Mutex<Option<PyErr>>>,
}

impl RunState {
    fn new() -> Self {
        RunState { stop: Arc::new(AtomicBool::new(false)), failure: Arc::new(Mutex::new(None)) }
    }

    /// The progress callback as the library takes it: calls `cb(done, total)` with the GIL; an
    /// exception is kept and stops the run.
    fn progress(&self, cb: Py<PyAny>) -> impl Fn(usize, usize) + Send + Sync + 'static {
        let (stop, failure) = (self.stop.clone(), self.failure.clone());
        move |done, total| {
            if stop.load(Ordering::Relaxed) {
                return;
            }
            Python::attach(|py| {
                if let Err(e) = cb.call1(py, (done, total)) {
                    failure.lock().unwrap_or_else(|p| p.into_inner()).get_or_insert(e);
                    stop.store(true, Ordering::SeqCst);
                }
            });
        }
    }

    /// Runs `job` on a worker thread; the calling thread waits without the GIL, checking for
    /// signals every 50 ms (Ctrl-C stops the run and raises `KeyboardInterrupt`).
    fn run<R: Send>(&self, py: Python<'_>, job: impl FnOnce() -> R + Send) -> PyResult<R> {
        struct Done<'a>(&'a (Mutex<bool>, Condvar));
        impl Drop for Done<'_> {
            fn drop(&mut self) {
                *self.0 .0.lock().unwrap_or_else(|p| p.into_inner()) = true;
                self.0 .1.notify_all();
            }
        }
        let done = (Mutex::new(false), Condvar::new());
        let mut interrupt: Option<PyErr> = None;
        let result = std::thread::scope(|s| {
            let worker = std::thread::Builder::new()
                .name("trussmesh".into())
                .stack_size(64 << 20)
                .spawn_scoped(s, || {
                    let _done = Done(&done);
                    job()
                })
                .map_err(|e| PyRuntimeError::new_err(format!("cannot start the meshing thread: {e}")))?;
            loop {
                let finished = py.detach(|| {
                    let g = done.0.lock().unwrap_or_else(|p| p.into_inner());
                    let (g, _) = done
                        .1
                        .wait_timeout_while(g, Duration::from_millis(50), |d| !*d)
                        .unwrap_or_else(|p| p.into_inner());
                    *g
                });
                if finished {
                    break;
                }
                if interrupt.is_none() {
                    if let Err(e) = py.check_signals() {
                        interrupt = Some(e);
                        self.stop.store(true, Ordering::SeqCst);
                    }
                }
            }
            py.detach(|| worker.join())
                .map_err(|_| PyRuntimeError::new_err("internal error (please report): the meshing thread panicked"))
        });
        if let Some(e) = interrupt {
            return Err(e);
        }
        if let Some(e) = self.failure.lock().unwrap_or_else(|p| p.into_inner()).take() {
            return Err(e);
        }
        if self.stop.load(Ordering::SeqCst) {
            return Err(PyKeyboardInterrupt::new_err("meshing stopped"));
        }
        result
    }
}

// ============================ results ============================

fn stop_name(s: &StopReason) -> &'static str {
    match s {
        StopReason::NotRun => "not_run",
        StopReason::AtRest { .. } => "at_rest",
        StopReason::QualityPlateau => "quality_plateau",
        StopReason::IterationCap { .. } => "iteration_cap",
        _ => "other",
    }
}

fn ops_dict<'py>(py: Python<'py>, o: &OpCounts) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("flips", o.flips)?;
    d.set_item("splits", o.splits)?;
    d.set_item("collapses", o.collapses)?;
    d.set_item("removed", o.removed)?;
    d.set_item("smoothings", o.smoothings)?;
    d.set_item("undone", o.undone)?;
    Ok(d)
}

/// A report as a dict; `quality` fills in the quality summary, `summary` is the printed report.
fn report_dict<'py, Q>(
    py: Python<'py>,
    r: &Report<Q>,
    summary: String,
    quality: impl FnOnce(&Bound<'py, PyDict>, &Q) -> PyResult<()>,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("iterations", r.iterations)?;
    d.set_item("converged", r.converged)?;
    d.set_item("stop", stop_name(&r.stop))?;
    d.set_item("stop_text", r.stop.to_string())?;
    d.set_item("seconds", r.seconds)?;
    d.set_item("ops", ops_dict(py, &r.ops)?)?;
    let q = PyDict::new(py);
    quality(&q, &r.quality)?;
    d.set_item("quality", q)?;
    d.set_item("boundary_nodes_off", r.boundary_nodes_off)?;
    d.set_item("internal_nodes_off", r.internal_nodes_off)?;
    d.set_item("feature_points", r.feature_points)?;
    match &r.metric {
        Some(m) => {
            let md = PyDict::new(py);
            md.set_item("edges", m.edges)?;
            md.set_item("in_band", m.in_band)?;
            md.set_item("len_min", m.len_min)?;
            md.set_item("len_mean", m.len_mean)?;
            md.set_item("len_max", m.len_max)?;
            md.set_item("q_min", m.q_min)?;
            md.set_item("q_mean", m.q_mean)?;
            d.set_item("metric", md)?;
        }
        None => d.set_item("metric", py.None())?,
    }
    match &r.stages {
        Some(s) => {
            let sd = PyDict::new(py);
            sd.set_item("remesh_passes", s.remesh_passes)?;
            sd.set_item("coarse_iterations", s.coarse_iterations)?;
            sd.set_item("kept_iteration", s.kept_iteration)?;
            sd.set_item("equalize_sweeps", s.equalize_sweeps)?;
            sd.set_item("stage_seconds", s.stage_seconds.to_vec())?;
            d.set_item("stages", sd)?;
        }
        None => d.set_item("stages", py.None())?,
    }
    d.set_item("summary", summary)?;
    Ok(d)
}

/// Flat arrays of a mesh, made on the worker thread.
struct Flat {
    dim: usize,
    verts: usize,
    points: Vec<f64>,
    k: usize,
    cells: Vec<i64>,
    labels: Vec<i64>,
    tags: Vec<i8>,
}

/// A vertex tag as a small integer: 0 interior, 1 boundary, 2 fixed, 3 on an internal boundary.
fn tag_code(t: VertexTag) -> i8 {
    match t {
        VertexTag::Interior => 0,
        VertexTag::Boundary => 1,
        VertexTag::Fixed => 2,
        VertexTag::InternalBoundary { .. } => 3,
    }
}

impl Flat {
    fn new<P: Copy, const N: usize, K: Copy>(
        a: MeshArrays<P, N, K>,
        coords: impl Fn(P) -> [f64; 3],
        dim: usize,
        tag: impl Fn(K) -> i8,
    ) -> Self {
        let verts = a.points.len();
        let mut points = Vec::with_capacity(dim * verts);
        for &p in &a.points {
            points.extend_from_slice(&coords(p)[..dim]);
        }
        Flat {
            dim,
            verts,
            points,
            k: N,
            cells: a.cells.iter().flatten().map(|&i| i as i64).collect(),
            labels: a.labels.iter().map(|&l| l as i64).collect(),
            tags: a.keys.iter().map(|&k| tag(k)).collect(),
        }
    }

    /// (points, cells, labels, tags) as numpy arrays; the vectors are handed over, not copied.
    fn into_py<'py>(
        self,
        py: Python<'py>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>, Bound<'py, PyAny>, Bound<'py, PyAny>)> {
        let m = self.labels.len();
        Ok((
            PyArray1::from_vec(py, self.points).reshape([self.verts, self.dim])?.into_any(),
            PyArray1::from_vec(py, self.cells).reshape([m, self.k])?.into_any(),
            PyArray1::from_vec(py, self.labels).into_any(),
            PyArray1::from_vec(py, self.tags).into_any(),
        ))
    }
}

fn q2(d: &Bound<'_, PyDict>, q: &QualityStats) -> PyResult<()> {
    d.set_item("triangles", q.triangles)?;
    d.set_item("vertices", q.vertices)?;
    d.set_item("q_min", q.q_min)?;
    d.set_item("q_mean", q.q_mean)?;
    d.set_item("angle_min", q.angle_min)?;
    d.set_item("angle_max", q.angle_max)?;
    Ok(())
}

fn q3(d: &Bound<'_, PyDict>, q: &QualityStats3) -> PyResult<()> {
    d.set_item("tets", q.tets)?;
    d.set_item("vertices", q.vertices)?;
    d.set_item("rr_min", q.rr_min)?;
    d.set_item("rr_mean", q.rr_mean)?;
    d.set_item("dihedral_min", q.dihedral_min)?;
    d.set_item("dihedral_max", q.dihedral_max)?;
    Ok(())
}

fn qs(d: &Bound<'_, PyDict>, q: &SurfaceQuality) -> PyResult<()> {
    d.set_item("vertices", q.vertices)?;
    d.set_item("triangles", q.triangles)?;
    d.set_item("euler", q.euler)?;
    d.set_item("closed_manifold", q.closed_manifold)?;
    d.set_item("inward_faces", q.inward_faces)?;
    d.set_item("vertex_residual", q.vertex_residual)?;
    d.set_item("centroid_deviation_max", q.centroid_deviation_max)?;
    d.set_item("centroid_deviation_mean", q.centroid_deviation_mean)?;
    d.set_item("angle_min", q.min_angle)?;
    d.set_item("angle_max", q.max_angle)?;
    d.set_item("q_min", q.min_q)?;
    d.set_item("q_mean", q.mean_q)?;
    d.set_item("size_deviation", q.size_deviation)?;
    d.set_item("circumradius_deviation", q.circumradius_deviation)?;
    d.set_item("mean_size_ratio", q.mean_size_ratio)?;
    Ok(())
}

fn fixed_points2(fixed: Option<PyReadonlyArray2<'_, f64>>) -> PyResult<Vec<DVec2>> {
    match fixed {
        Some(a) => points2(&a, "fixed points"),
        None => Ok(Vec::new()),
    }
}

fn fixed_points3(fixed: Option<PyReadonlyArray2<'_, f64>>) -> PyResult<Vec<DVec3>> {
    match fixed {
        Some(a) => points3(&a, "fixed points"),
        None => Ok(Vec::new()),
    }
}

// ============================ the meshers ============================

/// A metric argument: "A;B;C" expressions or a tuple of three fields.
fn metric2(obj: &Bound<'_, PyAny>) -> PyResult<[Field2; 3]> {
    let parts: Vec<Field2> = if let Ok(s) = obj.extract::<String>() {
        let p = split_top(&s, ';');
        if p.len() != 3 {
            return Err(PyValueError::new_err(format!(
                "metric needs three expressions \"A;B;C\" for M = [[A, B], [B, C]], got {}",
                p.len()
            )));
        }
        p.iter()
            .zip(["metric A", "metric B", "metric C"])
            .map(|(e, w)| Ok(Field2::Expr(ExprImplicit2::new(parse_expr(w, e, 2)?))))
            .collect::<PyResult<_>>()?
    } else {
        let items: Vec<Bound<'_, PyAny>> = obj.extract()?;
        if items.len() != 3 {
            return Err(PyValueError::new_err(format!("metric needs three fields (A, B, C), got {}", items.len())));
        }
        items.iter().map(|o| Field2::from_py(o, "metric")).collect::<PyResult<_>>()?
    };
    let [a, b, c]: [Field2; 3] = parts.try_into().map_err(|_| PyValueError::new_err("metric needs three fields"))?;
    Ok([a, b, c])
}

/// Meshes {d < 0} in the plane with triangles. Returns (points, triangles, labels, vertex tags,
/// report).
#[pyfunction]
#[pyo3(signature = (domain, h0, bbox, *, size=None, fixed=None, implicit=false, internal=None, metric=None,
    max_iter=None, seed=None, fscale=None, deltat=None, dptol=None, projection=None, strategy=None,
    max_elements=None, sharp_corners=true, progress=None))]
#[allow(clippy::too_many_arguments)]
fn mesh_2d<'py>(
    py: Python<'py>,
    domain: &Bound<'py, PyAny>,
    h0: f64,
    bbox: [f64; 4],
    size: Option<&Bound<'py, PyAny>>,
    fixed: Option<PyReadonlyArray2<'py, f64>>,
    implicit: bool,
    internal: Option<&Bound<'py, PyAny>>,
    metric: Option<&Bound<'py, PyAny>>,
    max_iter: Option<usize>,
    seed: Option<u64>,
    fscale: Option<f64>,
    deltat: Option<f64>,
    dptol: Option<f64>,
    projection: Option<String>,
    strategy: Option<String>,
    max_elements: Option<u64>,
    sharp_corners: bool,
    progress: Option<Py<PyAny>>,
) -> PyResult<Bound<'py, PyTuple>> {
    let state = RunState::new();
    let geom = Domain2 { field: Field2::from_py(domain, "domain")?, distance: !implicit, stop: state.stop.clone() };
    let mut o = Options2::uniform(h0, [bbox[0], bbox[1]], [bbox[2], bbox[3]]).with_fixed(fixed_points2(fixed)?);
    if let Some(s) = size {
        let h = Field2::from_py(s, "size")?;
        o = o.with_size(move |p| h.value(p));
    }
    if let Some(i) = internal {
        o = o.with_internal(Domain2 {
            field: Field2::from_py(i, "internal")?,
            distance: !implicit,
            stop: state.stop.clone(),
        });
    }
    if let Some(m) = metric {
        let [a, b, c] = metric2(m)?;
        o = o.with_metric(move |p| Metric2::new(a.value(p), b.value(p), c.value(p)));
    }
    if let Some(n) = max_iter {
        o = o.with_max_iter(n);
    }
    if let Some(s) = seed {
        o = o.with_seed(s);
    }
    if let Some(v) = fscale {
        o = o.with_fscale(v);
    }
    if let Some(v) = deltat {
        o = o.with_deltat(v);
    }
    if let Some(v) = dptol {
        o = o.with_dptol(v);
    }
    if let Some(p) = self::projection(projection)? {
        o = o.with_projection(p);
    }
    match strategy.as_deref() {
        None | Some("local") => {}
        Some("global") | Some("global_delaunay") => o = o.with_strategy(Strategy::GlobalDelaunay),
        Some(other) => {
            return Err(PyValueError::new_err(format!("strategy must be 'local' or 'global', not {other:?}")))
        }
    }
    if let Some(n) = max_elements {
        o = o.with_max_elements(n);
    }
    if let Some(cb) = progress {
        o = o.with_progress(state.progress(cb));
    }
    o = o.with_sharp_corners(sharp_corners);
    let done = state.run(py, || {
        trussmesh::mesh_2d(&geom, &o).map(|out| {
            let summary = out.report.to_string();
            let mesh = &out.mesh;
            let flat = Flat::new(mesh.to_arrays(), |p: DVec2| [p.x, p.y, 0.0], 2, |k| tag_code(mesh.tag(k)));
            (flat, out.report, summary)
        })
    })?;
    let (flat, report, summary) = done.map_err(py_err)?;
    let (p, t, l, f) = flat.into_py(py)?;
    let r = report_dict(py, &report, summary, q2)?;
    (p, t, l, f, r).into_pyobject(py)
}

/// Meshes {d < 0} in space with tetrahedra. Returns (points, tets, labels, vertex tags, report).
#[pyfunction]
#[pyo3(signature = (domain, h0, bbox, *, size=None, fixed=None, implicit=false, max_iter=None, seed=None,
    fscale=None, deltat=None, dptol=None, projection=None, max_elements=None, polish_rounds=None,
    sharp_edges=true, progress=None))]
#[allow(clippy::too_many_arguments)]
fn mesh_3d<'py>(
    py: Python<'py>,
    domain: &Bound<'py, PyAny>,
    h0: f64,
    bbox: [f64; 6],
    size: Option<&Bound<'py, PyAny>>,
    fixed: Option<PyReadonlyArray2<'py, f64>>,
    implicit: bool,
    max_iter: Option<usize>,
    seed: Option<u64>,
    fscale: Option<f64>,
    deltat: Option<f64>,
    dptol: Option<f64>,
    projection: Option<String>,
    max_elements: Option<u64>,
    polish_rounds: Option<usize>,
    sharp_edges: bool,
    progress: Option<Py<PyAny>>,
) -> PyResult<Bound<'py, PyTuple>> {
    let state = RunState::new();
    let geom = Domain3 { field: Field3::from_py(domain, "domain")?, distance: !implicit, stop: state.stop.clone() };
    let mut o = Options3::uniform(h0, [bbox[0], bbox[1], bbox[2]], [bbox[3], bbox[4], bbox[5]])
        .with_fixed(fixed_points3(fixed)?);
    if let Some(s) = size {
        let h = Field3::from_py(s, "size")?;
        o = o.with_size(move |p| h.value(p));
    }
    if let Some(n) = max_iter {
        o = o.with_max_iter(n);
    }
    if let Some(s) = seed {
        o = o.with_seed(s);
    }
    if let Some(v) = fscale {
        o = o.with_fscale(v);
    }
    if let Some(v) = deltat {
        o = o.with_deltat(v);
    }
    if let Some(v) = dptol {
        o = o.with_dptol(v);
    }
    if let Some(p) = self::projection(projection)? {
        o = o.with_projection(p);
    }
    if let Some(n) = max_elements {
        o = o.with_max_elements(n);
    }
    if let Some(n) = polish_rounds {
        o = o.with_polish_rounds(n);
    }
    if let Some(cb) = progress {
        o = o.with_progress(state.progress(cb));
    }
    o = o.with_sharp_edges(sharp_edges);
    let done = state.run(py, || {
        trussmesh::mesh_3d(&geom, &o).map(|out| {
            let summary = out.report.to_string();
            let mesh = &out.mesh;
            let flat = Flat::new(mesh.to_arrays(), |p: DVec3| p.to_array(), 3, |k| tag_code(mesh.tag(k)));
            (flat, out.report, summary)
        })
    })?;
    let (flat, report, summary) = done.map_err(py_err)?;
    let (p, t, l, f) = flat.into_py(py)?;
    let r = report_dict(py, &report, summary, q3)?;
    (p, t, l, f, r).into_pyobject(py)
}

/// Meshes the closed surface phi = 0 with triangles. Returns (points, triangles, report).
#[pyfunction]
#[pyo3(signature = (phi, h0, bbox, *, curvature=None, implicit=true, max_iter=None, fscale=None, deltat=None,
    dptol=None, progress=None))]
#[allow(clippy::too_many_arguments)]
fn mesh_surface<'py>(
    py: Python<'py>,
    phi: &Bound<'py, PyAny>,
    h0: f64,
    bbox: [f64; 6],
    curvature: Option<(f64, f64, f64)>,
    implicit: bool,
    max_iter: Option<usize>,
    fscale: Option<f64>,
    deltat: Option<f64>,
    dptol: Option<f64>,
    progress: Option<Py<PyAny>>,
) -> PyResult<Bound<'py, PyTuple>> {
    let state = RunState::new();
    let geom = Domain3 { field: Field3::from_py(phi, "phi")?, distance: !implicit, stop: state.stop.clone() };
    let mut o = SurfaceOptions::uniform(h0, [bbox[0], bbox[1], bbox[2]], [bbox[3], bbox[4], bbox[5]]);
    if let Some((k, g, hmax)) = curvature {
        o = o.with_curvature(k, g, hmax);
    }
    if let Some(n) = max_iter {
        o = o.with_max_iter(n);
    }
    if let Some(v) = fscale {
        o = o.with_fscale(v);
    }
    if let Some(v) = deltat {
        o = o.with_deltat(v);
    }
    if let Some(v) = dptol {
        o = o.with_dptol(v);
    }
    if let Some(cb) = progress {
        o = o.with_progress(state.progress(cb));
    }
    let done = state.run(py, || {
        trussmesh::mesh_surface(&geom, &o).map(|out| {
            let summary = out.report.to_string();
            let flat = Flat::new(out.mesh.to_arrays(), |p: DVec3| p.to_array(), 3, |_| 1);
            (flat, out.report, summary)
        })
    })?;
    let (flat, report, summary) = done.map_err(py_err)?;
    let (p, t, _, _) = flat.into_py(py)?;
    let r = report_dict(py, &report, summary, qs)?;
    (p, t, r).into_pyobject(py)
}

/// Checks h0, the box and the fixed points as the 2-D mesher does, before anything is sampled:
/// raises the library's `ValueError`.
#[pyfunction]
#[pyo3(signature = (h0, bbox, fixed=None))]
fn check_2d(h0: f64, bbox: [f64; 4], fixed: Option<PyReadonlyArray2<'_, f64>>) -> PyResult<()> {
    // A domain with no inside: valid input ends in the empty-domain error, found after the
    // checks of h0, the box and the fixed points and before any mesh is made.
    let o = Options2::uniform(h0, [bbox[0], bbox[1]], [bbox[2], bbox[3]]).with_fixed(fixed_points2(fixed)?);
    match trussmesh::mesh_2d(&|_: DVec2| 1.0, &o) {
        Err(trussmesh::Error::EmptyDomain(_)) => Ok(()),
        Err(e) => Err(py_err(e)),
        Ok(_) => Ok(()),
    }
}

/// Checks h0, the box and the fixed points as the 3-D mesher does (see `check_2d`).
#[pyfunction]
#[pyo3(signature = (h0, bbox, fixed=None))]
fn check_3d(h0: f64, bbox: [f64; 6], fixed: Option<PyReadonlyArray2<'_, f64>>) -> PyResult<()> {
    let o = Options3::uniform(h0, [bbox[0], bbox[1], bbox[2]], [bbox[3], bbox[4], bbox[5]])
        .with_fixed(fixed_points3(fixed)?)
        .with_max_iter(0);
    match trussmesh::mesh_3d(&|_: DVec3| 1.0, &o) {
        Err(trussmesh::Error::EmptyDomain(_)) => Ok(()),
        Err(e) => Err(py_err(e)),
        Ok(_) => Ok(()),
    }
}

/// The native module.
#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Sampled2>()?;
    m.add_class::<Sampled3>()?;
    m.add_function(wrap_pyfunction!(mesh_2d, m)?)?;
    m.add_function(wrap_pyfunction!(mesh_3d, m)?)?;
    m.add_function(wrap_pyfunction!(mesh_surface, m)?)?;
    m.add_function(wrap_pyfunction!(check_2d, m)?)?;
    m.add_function(wrap_pyfunction!(check_3d, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
