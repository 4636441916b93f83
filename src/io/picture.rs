//! Pictures of meshes.
use super::MeshData;
use crate::Error;
use std::path::Path;
/// SVG picture.
pub fn write_svg(_path: &Path, _mesh: &MeshData, _title: &str) -> Result<(), Error> {
    Err(Error::Internal("todo".into()))
}
/// PNG picture.
pub fn write_png(
    _path: &Path,
    _mesh: &MeshData,
    _title: &str,
    _width_px: u32,
) -> Result<(), Error> {
    Err(Error::Internal("todo".into()))
}
