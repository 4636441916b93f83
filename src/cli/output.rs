//! Output files: every path checked before any work, every output written whole or not at
//! all, and a failed one not stopping the others.

use super::Failure;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, OnceLock};
use std::time::Instant;
use trussmesh::expr::Expr;
use trussmesh::io::{Encoding, Format, Measure, MeshData, NodeKind, WriteOptions};
use trussmesh::mesher::Metric2;

/// The `--encoding` of this run (set once, before any output is written).
static ENCODING: OnceLock<Encoding> = OnceLock::new();

/// How each output of this run was written, for the "wrote ..." lines.
static WRITTEN: Mutex<Vec<(PathBuf, String)>> = Mutex::new(Vec::new());

/// Sets the encoding of mesh outputs for the rest of the run.
pub fn set_encoding(e: Encoding) {
    let _ = ENCODING.set(e);
}

/// "out.vtu (binary, 45.2 MB in 0.12 s)": an output and how it was written, for the report.
pub fn describe(path: &Path) -> String {
    let log = WRITTEN.lock().unwrap_or_else(|e| e.into_inner());
    match log.iter().rev().find(|(p, _)| p == path) {
        Some((_, how)) => format!("{} ({how})", path.display()),
        None => path.display().to_string(),
    }
}

const PICTURES: [&str; 2] = ["svg", "png"];

/// The lower-case extension of `p` ("" without one).
pub fn extension(p: &Path) -> String {
    p.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase()).unwrap_or_default()
}

/// Checks an output path's extension.
pub fn check_extension(p: &Path) -> Result<(), Failure> {
    if PICTURES.contains(&extension(p).as_str()) {
        return Ok(());
    }
    Format::from_path(p).map(|_| ()).map_err(|_| {
        Failure::bad(format!(
            "unknown output extension in {} (expected .json .vtu .msh .mesh .obj .stl .ply .svg .png)",
            p.display()
        ))
    })
}

/// A file name in `dir` that nothing else uses, for a probe.
fn probe_name(dir: &Path) -> PathBuf {
    dir.join(format!(".trussmesh-probe-{}", std::process::id()))
}

/// Whether a file can be made in the existing directory `dir` (made and removed at once).
fn can_create_in(dir: &Path) -> Result<(), std::io::Error> {
    let probe = probe_name(dir);
    std::fs::OpenOptions::new().write(true).create_new(true).open(&probe)?;
    std::fs::remove_file(&probe)
}

/// Checks that `p` can be written: its extension known, its directory there or creatable,
/// the file writable. Nothing is left behind (the directories are made only when writing).
pub fn check_writable(p: &Path) -> Result<(), Failure> {
    check_extension(p)?;
    let fail = |why: String| Failure::bad(format!("cannot write the output {}: {why}; nothing was done", p.display()));
    if let Ok(m) = std::fs::metadata(p) {
        if m.is_dir() {
            return Err(fail("it is a directory".into()));
        }
        if !m.is_file() {
            // A device or a pipe: opening a pipe would wait for a reader; it is written later.
            return Ok(());
        }
        // An existing file must open for writing (it is not truncated here), and its directory
        // must take the temporary file that replaces it.
        std::fs::OpenOptions::new().write(true).open(p).map_err(|e| fail(e.to_string()))?;
    }
    let parent = match p.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    // The nearest directory that exists: the file, or the directories to make, go there.
    let mut dir = parent.as_path();
    loop {
        match std::fs::metadata(dir) {
            Ok(m) if m.is_dir() => break,
            Ok(_) => return Err(fail(format!("{} is not a directory", dir.display()))),
            Err(_) => match dir.parent() {
                Some(d) if !d.as_os_str().is_empty() => dir = d,
                _ => {
                    dir = Path::new(".");
                    break;
                }
            },
        }
    }
    can_create_in(dir).map_err(|e| {
        if dir == parent {
            fail(format!("no file can be made in {}: {e}", dir.display()))
        } else {
            fail(format!("the directory {} cannot be made in {}: {e}", parent.display(), dir.display()))
        }
    })
}

/// Checks every output (see [`check_writable`]); no outputs is an error too.
pub fn check_all(paths: &[PathBuf]) -> Result<(), Failure> {
    if paths.is_empty() {
        return Err(Failure::bad("no output file: give -o FILE (several allowed)"));
    }
    paths.iter().try_for_each(|p| check_writable(p))
}

/// What a run knows beyond the mesh, for its outputs.
#[derive(Default, Clone, Copy)]
pub struct Extras<'a> {
    /// What pictures are coloured by (None: q, or the smallest dihedral angle for tetrahedra).
    pub measure: Option<&'a Measure>,
    /// The kind of every node, for the .vtu point data (None: interior or boundary from the
    /// boundary facets).
    pub node_kind: Option<&'a [NodeKind]>,
}

/// The bytes of one output (a mesh file, or a picture for .svg and .png) and its encoding's
/// name. `--encoding binary` applies to the formats that have a binary form; the others are
/// text whatever it says.
fn render(
    path: &Path,
    mesh: &MeshData,
    title: &str,
    extras: Extras,
) -> Result<(Vec<u8>, &'static str), trussmesh::Error> {
    let by = || extras.measure.cloned().unwrap_or_else(|| Measure::default_for(mesh));
    match extension(path).as_str() {
        "svg" => Ok((trussmesh::io::svg_bytes_by(mesh, title, &by())?, "picture")),
        "png" => Ok((trussmesh::io::png_bytes_by(mesh, title, &by(), 1200)?, "picture")),
        _ => {
            let format = Format::from_path(path)?;
            let mut encoding = ENCODING.get().copied().unwrap_or_default();
            if !format.has_binary() {
                encoding = Encoding::Ascii;
            }
            let how = if encoding.is_binary(mesh.num_cells()) { "binary" } else { "text" };
            let opts = WriteOptions { encoding, node_kind: extras.node_kind };
            Ok((trussmesh::io::write_mesh_bytes_with(mesh, format, opts)?, how))
        }
    }
}

/// The metric quality of a planar mesh for the metric "A;B;C" given as three expressions:
/// what pictures of anisotropic meshes are coloured by.
pub fn metric_measure(mesh: &MeshData, abc: &[Expr; 3]) -> Measure {
    Measure::metric_q(mesh, &|p| {
        let [a, b, c] = abc.each_ref().map(|e| e.eval(p.x, p.y, 0.0));
        Metric2::new(a, b, c)
    })
}

/// Writes one output whole or not at all, making its directory.
pub fn write_one_by(path: &Path, mesh: &MeshData, title: &str, extras: Extras) -> Result<(), Failure> {
    let start = Instant::now();
    let (bytes, how) = render(path, mesh, title, extras)?;
    if let Some(dir) = path.parent() {
        if !dir.as_os_str().is_empty() {
            std::fs::create_dir_all(dir)
                .map_err(|e| Failure::internal(format!("cannot create the directory {}: {e}", dir.display())))?;
        }
    }
    trussmesh::io::write_file(path, &bytes).map_err(|e| match e {
        trussmesh::Error::Io { message, .. } => {
            Failure::internal(format!("cannot write the output {}: {message}", path.display()))
        }
        e => e.into(),
    })?;
    let mb = bytes.len() as f64 / 1e6;
    let how = format!("{how}, {mb:.2} MB in {:.3} s", start.elapsed().as_secs_f64());
    WRITTEN.lock().unwrap_or_else(|e| e.into_inner()).push((path.to_path_buf(), how));
    Ok(())
}

/// Writes every output; one that fails does not stop the others, and the error names each
/// failed one (and the ones written).
pub fn write_all(paths: &[PathBuf], mesh: &MeshData, title: &str) -> Result<(), Failure> {
    write_all_by(paths, mesh, title, Extras::default())
}

/// [`write_all`] with what the run knows beyond the mesh.
pub fn write_all_by(paths: &[PathBuf], mesh: &MeshData, title: &str, extras: Extras) -> Result<(), Failure> {
    let mut failed: Vec<Failure> = Vec::new();
    let mut written = Vec::new();
    for p in paths {
        match write_one_by(p, mesh, title, extras) {
            Ok(()) => written.push(p.display().to_string()),
            Err(f) => failed.push(f),
        }
    }
    if failed.is_empty() {
        return Ok(());
    }
    let code = failed.iter().map(|f| f.code).max().unwrap_or(super::EXIT_INTERNAL);
    let mut message = failed.iter().map(|f| f.message.as_str()).collect::<Vec<_>>().join("\nerror: ");
    if written.is_empty() {
        message.push_str("\nno output was written");
    } else {
        message.push_str(&format!("\nthe other outputs were written: {}", written.join(", ")));
    }
    Err(Failure { code, message })
}
