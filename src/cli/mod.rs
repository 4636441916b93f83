//! The command line: subcommands, errors and exit codes (0 ok, 1 internal failure, 2 bad input).

mod auto_size;
mod budget;
mod diagnose;
mod fields;
pub mod fuzz;
mod gallery;
mod image;
mod kinds;
mod mesh;
mod output;
mod polydom;
mod remesh;
mod sample;
mod scene;
mod stats;
mod surface;
mod surface_stats;
mod trisurf;

use clap::{Parser, Subcommand};
use std::panic::{catch_unwind, AssertUnwindSafe};

/// Exit code of a run that failed through no fault of the input.
pub const EXIT_INTERNAL: i32 = 1;
/// Exit code of bad input (arguments, expressions, files).
pub const EXIT_BAD_INPUT: i32 = 2;

/// A failed run: the exit code and the message for stderr.
#[derive(Debug)]
pub struct Failure {
    pub code: i32,
    pub message: String,
}

impl Failure {
    /// Bad input (exit 2).
    pub fn bad(message: impl Into<String>) -> Self {
        Failure { code: EXIT_BAD_INPUT, message: message.into() }
    }
    /// Internal failure (exit 1).
    pub fn internal(message: impl Into<String>) -> Self {
        Failure { code: EXIT_INTERNAL, message: message.into() }
    }
}

impl From<trussmesh::Error> for Failure {
    fn from(e: trussmesh::Error) -> Self {
        match e {
            trussmesh::Error::Internal { .. } => Failure::internal(e.to_string()),
            // Points print as the user writes them, "(5, 5, 5)", not as the type that holds them.
            _ => Failure::bad(e.to_string().replace("DVec3(", "(").replace("DVec2(", "(")),
        }
    }
}

/// High-quality simplex meshes of implicit geometries.
#[derive(Parser, Debug)]
#[command(name = "trussmesh", version, about, long_about = None)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
    /// Mesh files as text or binary (.vtu and .msh have both; other formats are text): auto
    /// writes binary from 100,000 cells.
    #[arg(long, global = true, value_enum, default_value_t = EncodingArg::Auto)]
    pub encoding: EncodingArg,
}

/// The values of `--encoding`.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum EncodingArg {
    /// Binary from 100,000 cells, text below.
    Auto,
    /// Text numbers.
    Ascii,
    /// Raw little-endian numbers (VTU appended data, Gmsh binary).
    Binary,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Mesh {d < 0} given by expressions, or by a scene file.
    Mesh(mesh::MeshArgs),
    /// Print counts and quality statistics of a mesh file.
    Stats(stats::StatsArgs),
    /// Mesh every 2-D example of the seed into a directory, with a quality table.
    Gallery(gallery::GalleryArgs),
    /// Mesh the bright region of a PNG picture (pixel coordinates, y down).
    Image(image::ImageArgs),
    /// Remesh a 2-D mesh file for a new size field (gradient limited on the old mesh).
    Remesh(remesh::RemeshArgs),
    /// Mesh the closed surface phi(x, y, z) = 0 in space.
    Surface(surface::SurfaceArgs),
}

/// Runs the command line and returns the exit code.
pub fn main() -> i32 {
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            let _ = e.print();
            return e.exit_code();
        }
    };
    std::panic::set_hook(Box::new(|info| {
        // A reader that went away (`trussmesh ... | head`) is not a failure: stop quietly, as
        // tools killed by SIGPIPE do.
        let text = info.to_string();
        if text.contains("failed printing to stdout") && text.contains("Broken pipe") {
            std::process::exit(0);
        }
        eprintln!("error: internal failure (please report): {text}");
    }));
    // On a thread of rayon's pool (see `trussmesh::mesher::on_pool`).
    match catch_unwind(AssertUnwindSafe(|| trussmesh::mesher::on_pool(|| run(cli)))) {
        Ok(Ok(())) => 0,
        Ok(Err(f)) => {
            eprintln!("error: {}", f.message);
            f.code
        }
        Err(_) => EXIT_INTERNAL,
    }
}

fn run(cli: Cli) -> Result<(), Failure> {
    output::set_encoding(match cli.encoding {
        EncodingArg::Auto => trussmesh::io::Encoding::Auto,
        EncodingArg::Ascii => trussmesh::io::Encoding::Ascii,
        EncodingArg::Binary => trussmesh::io::Encoding::Binary,
    });
    match cli.command {
        Command::Mesh(a) => mesh::run(a),
        Command::Stats(a) => stats::run(a),
        Command::Gallery(a) => gallery::run(a),
        Command::Image(a) => image::run(a),
        Command::Remesh(a) => remesh::run(a),
        Command::Surface(a) => surface::run(a),
    }
}
