//! `trussmesh gallery`: every 2-D seed example meshed, pictured and tabulated.

use super::mesh::{parse_expr, write_output};
use super::stats::compute;
use super::{Cli, Command, Failure};
use clap::{Args, Parser};
use std::path::PathBuf;
use trussmesh::gallery::EXAMPLES;

/// Mesh every 2-D example of the seed into DIR, with DIR/quality.md.
#[derive(Args, Debug)]
pub struct GalleryArgs {
    /// Output directory.
    #[arg(default_value = "out")]
    pub dir: PathBuf,
    /// Only print the `trussmesh mesh` command of every example.
    #[arg(long)]
    pub list: bool,
}

const HEADER: &str = "| example | nodes | triangles | q min | q mean | min angle | size dev | max \\|d\\|/h0 | iterations | seconds | notes |\n|---|---|---|---|---|---|---|---|---|---|---|\n";

/// `trussmesh gallery`.
pub fn run(a: GalleryArgs) -> Result<(), Failure> {
    if a.list {
        for e in EXAMPLES {
            println!("{}", e.command_line());
        }
        return Ok(());
    }
    std::fs::create_dir_all(&a.dir)
        .map_err(|e| Failure::internal(format!("cannot create {}: {e}", a.dir.display())))?;
    let mut table = String::from(HEADER);
    let mut failed: Vec<(String, Failure)> = Vec::new();
    for ex in EXAMPLES {
        eprintln!("meshing {}: {}", ex.name, ex.title);
        match one(&a, ex) {
            Ok(row) => table.push_str(&row),
            Err(f) => {
                table.push_str(&format!(
                    "| {} | failed: {} ||||||||||\n",
                    ex.name,
                    f.message.lines().next().unwrap_or("").replace('|', "\\|")
                ));
                failed.push((ex.name.to_string(), f));
            }
        }
    }
    let md = a.dir.join("quality.md");
    std::fs::write(&md, &table).map_err(|e| Failure::internal(format!("cannot write {}: {e}", md.display())))?;
    print!("{table}");
    match failed.into_iter().next() {
        None => Ok(()),
        Some((name, f)) => Err(Failure {
            code: f.code,
            message: format!("example {name} failed (see {}): {}", md.display(), f.message),
        }),
    }
}

fn one(a: &GalleryArgs, ex: &trussmesh::gallery::Example) -> Result<String, Failure> {
    let outs: Vec<String> = ["vtu", "msh", "json", "svg", "png"]
        .iter()
        .map(|ext| a.dir.join(format!("{}.{ext}", ex.name)).display().to_string())
        .collect();
    let argv = std::iter::once("trussmesh".to_string()).chain(ex.args(&outs));
    let cli = Cli::try_parse_from(argv).map_err(|e| Failure::internal(format!("example {}: {e}", ex.name)))?;
    let Command::Mesh(args) = cli.command else {
        return Err(Failure::internal("example is not a mesh command"));
    };
    let job = args.spec()?.resolve()?;
    let done = job.mesh(true)?;
    for p in &job.outputs {
        write_output(&job, p, &done, &format!("{}: {}", ex.name, ex.title))?;
    }
    let size = parse_expr("--size", ex.size.unwrap_or("1"))?;
    let s = compute(&done.mesh, job.domain.expr().map(|e| (e, ex.implicit)), Some(&size))?;
    let t = s.triangles.clone().unwrap_or(super::stats::TriStats {
        q_min: 0.0,
        q_mean: 0.0,
        q_p1: 0.0,
        q_p5: 0.0,
        q_p50: 0.0,
        angle_min: 0.0,
        angle_max: 0.0,
    });
    let r = &done.report;
    // Anisotropic runs are judged in their metric; internal boundaries by their subdomains.
    let mut notes = String::new();
    if let Some(m) = &r.metric {
        notes = format!(
            "metric: {:.1}% of edges in [0.707, 1.414], metric q min {:.3}, mean {:.3}",
            100.0 * m.in_band,
            m.q_min,
            m.q_mean
        );
    } else if let Some(labels) = &done.mesh.subdomain {
        let n = labels.iter().collect::<std::collections::BTreeSet<_>>().len();
        notes = format!("{n} subdomains");
    }
    Ok(format!(
        "| {} | {} | {} | {:.3} | {:.3} | {:.1} | {:.3} | {:.1e} | {} | {:.2} | {notes} |\n",
        ex.name,
        s.nodes,
        s.cells,
        t.q_min,
        t.q_mean,
        t.angle_min,
        s.size_deviation.unwrap_or(f64::NAN),
        s.boundary_max_abs_d.unwrap_or(f64::NAN) / job.h0,
        r.iterations,
        r.seconds
    ))
}
