//! Triangle meshes for scratch holograms: a 3D object whose appearance from each view becomes
//! that view's target image, so the plate shows the object with parallax as a viewer walks past.
//!
//! - [`Mesh`]: vertices and triangles, read from a Wavefront OBJ file ([`Mesh::load_obj`],
//!   [`Mesh::parse_obj`]); every parse error names the file, the 1-based line and what is wrong.
//! - [`Placement`]: how the mesh stands in the plate's world frame (millimetres, the plate in
//!   z = 0, viewers at z > 0): its size, its depth behind the plate and which way it faces.
//! - [`render_object`]: the placed mesh seen by one view's pinhole camera, flat-shaded by one
//!   key light, with 4 x 4 supersampling ([`ObjectImage`]: shade and coverage per pixel).

use std::path::{Path, PathBuf};

mod render;
#[cfg(test)]
mod tests;

pub use render::{render_object, ObjectImage, Placement};

/// A triangle mesh. Units are whatever the file used: [`Placement`] scales them away.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    /// Vertex positions in the file's own axes (OBJ: +Y up, +Z the model's front).
    pub vertices: Vec<[f64; 3]>,
    /// Triangles as 0-based indices into `vertices`.
    pub triangles: Vec<[u32; 3]>,
}

/// An OBJ file that cannot be read or is not a usable mesh. Every message names the file; parse
/// errors also name the 1-based line and what to fix.
#[derive(Debug, thiserror::Error)]
pub enum MeshError {
    #[error("cannot read OBJ file `{path}`: {cause} (check that the file exists and is readable)")]
    Read {
        path: PathBuf,
        /// The OS error (part of the message, so not repeated as a source).
        cause: std::io::Error,
    },
    #[error("`{file}`, line {line}: bad vertex: {msg} (a vertex line is `v x y z` with three finite numbers)")]
    Vertex { file: String, line: usize, msg: String },
    #[error(
        "`{file}`, line {line}: {msg} (OBJ vertex indices start at 1; negative ones count back from \
         the last vertex read so far)"
    )]
    FaceIndex { file: String, line: usize, msg: String },
    #[error(
        "`{file}`, line {line}: bad face: {msg} (a face line is `f a b c ...` with vertex references \
         `a`, `a/t`, `a//n` or `a/t/n`)"
    )]
    FaceSyntax { file: String, line: usize, msg: String },
    #[error("`{file}`, line {line}: a face has {count} vertices; a face needs at least 3")]
    ShortFace { file: String, line: usize, count: usize },
    #[error("`{file}`: the file has no faces: give a mesh, not a point cloud")]
    NoFaces { file: String },
    #[error(
        "`{file}`: the mesh has zero extent (all its vertices are at one point), so it cannot be scaled to a size"
    )]
    Degenerate { file: String },
}

/// A mesh file that cannot be read or is not a usable mesh is a bad input file.
impl scratchart_exit::ExitClass for MeshError {
    fn exit_class(&self) -> Option<scratchart_exit::Class> {
        Some(scratchart_exit::Class::Input)
    }
}

impl Mesh {
    /// Reads an OBJ file; see [`parse_obj`](Self::parse_obj). Bytes that are not UTF-8 (in a
    /// comment or a material name, say) are replaced, not refused.
    pub fn load_obj(path: &Path) -> Result<Mesh, MeshError> {
        let bytes = std::fs::read(path).map_err(|cause| MeshError::Read {
            path: path.to_path_buf(),
            cause,
        })?;
        Mesh::parse_obj(&String::from_utf8_lossy(&bytes), &path.display().to_string())
    }

    /// Parses the text of an OBJ file; `name` names it in error messages.
    ///
    /// Reads `v x y z [w ...]` lines (numbers after z, a weight or vertex colours, are checked
    /// and ignored) and `f` lines whose vertex references are `a`, `a/t`, `a//n` or `a/t/n`
    /// (only the vertex index is used; positive indices are 1-based, negative ones count back
    /// from the last vertex read so far). Polygons are fan-triangulated from their first vertex.
    /// Everything else (`vn`, `vt`, `o`, `g`, `s`, `usemtl`, `mtllib`, `#` comments, blank lines
    /// and unknown keywords) is ignored, so several objects or groups make one mesh. CRLF line
    /// ends and a UTF-8 byte order mark are accepted.
    ///
    /// Refuses a file without faces and one whose vertices all lie at one point.
    pub fn parse_obj(text: &str, name: &str) -> Result<Mesh, MeshError> {
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let file = || name.to_string();
        let mut vertices: Vec<[f64; 3]> = Vec::new();
        let mut triangles: Vec<[u32; 3]> = Vec::new();
        // Positive indices may refer to vertices defined later in the file: the largest one (and
        // the first line that uses it) is checked at the end.
        let mut largest_ref: Option<(u64, usize)> = None;
        let mut face: Vec<u32> = Vec::new();

        for (k, raw) in text.lines().enumerate() {
            let line = k + 1;
            let content = raw.split('#').next().unwrap_or("");
            let mut tokens = content.split_whitespace();
            match tokens.next() {
                Some("v") => {
                    let mut xyz = [0.0; 3];
                    let mut count = 0;
                    for tok in tokens {
                        let x: f64 = tok.parse().map_err(|_| MeshError::Vertex {
                            file: file(),
                            line,
                            msg: format!("`{tok}` is not a number"),
                        })?;
                        if !x.is_finite() {
                            return Err(MeshError::Vertex {
                                file: file(),
                                line,
                                msg: format!("`{tok}` is not a finite number"),
                            });
                        }
                        if count < 3 {
                            xyz[count] = x;
                        }
                        count += 1;
                    }
                    if count < 3 {
                        return Err(MeshError::Vertex {
                            file: file(),
                            line,
                            msg: format!("{count} coordinates, 3 needed"),
                        });
                    }
                    vertices.push(xyz);
                }
                Some("f") => {
                    face.clear();
                    for tok in tokens {
                        let index = tok.split('/').next().unwrap_or("");
                        let i: i64 = index.parse().map_err(|_| MeshError::FaceSyntax {
                            file: file(),
                            line,
                            msg: format!("`{tok}` does not start with a vertex index"),
                        })?;
                        let resolved = if i > 0 {
                            let Ok(zero_based) = u32::try_from(i - 1) else {
                                return Err(MeshError::FaceIndex {
                                    file: file(),
                                    line,
                                    msg: format!("vertex index {i} is out of range"),
                                });
                            };
                            match largest_ref {
                                Some((m, _)) if m >= i as u64 => {}
                                _ => largest_ref = Some((i as u64, line)),
                            }
                            zero_based
                        } else if i < 0 {
                            let back = i.unsigned_abs();
                            if back > vertices.len() as u64 {
                                return Err(MeshError::FaceIndex {
                                    file: file(),
                                    line,
                                    msg: format!(
                                        "vertex index {i} counts back past the first vertex ({} read so far)",
                                        vertices.len()
                                    ),
                                });
                            }
                            (vertices.len() as u64 - back) as u32
                        } else {
                            return Err(MeshError::FaceIndex {
                                file: file(),
                                line,
                                msg: "vertex index 0 does not exist".to_string(),
                            });
                        };
                        face.push(resolved);
                    }
                    if face.len() < 3 {
                        return Err(MeshError::ShortFace {
                            file: file(),
                            line,
                            count: face.len(),
                        });
                    }
                    for t in 1..face.len() - 1 {
                        triangles.push([face[0], face[t], face[t + 1]]);
                    }
                }
                _ => {}
            }
        }

        let n = vertices.len() as u64;
        if let Some((i, line)) = largest_ref.filter(|&(i, _)| i > n) {
            return Err(MeshError::FaceIndex {
                file: file(),
                line,
                msg: format!("vertex index {i} is out of range: the file has {n} vertices"),
            });
        }
        if triangles.is_empty() {
            return Err(MeshError::NoFaces { file: file() });
        }
        let mesh = Mesh { vertices, triangles };
        let (lo, hi) = mesh.bounds();
        if (0..3).all(|a| hi[a] - lo[a] == 0.0) {
            return Err(MeshError::Degenerate { file: file() });
        }
        Ok(mesh)
    }

    /// The axis-aligned bounding box (min, max) of all vertices, in the mesh's own axes and
    /// units. A mesh without vertices gives ([0, 0, 0], [0, 0, 0]).
    pub fn bounds(&self) -> ([f64; 3], [f64; 3]) {
        let Some(&first) = self.vertices.first() else {
            return ([0.0; 3], [0.0; 3]);
        };
        let (mut lo, mut hi) = (first, first);
        for v in &self.vertices {
            for a in 0..3 {
                lo[a] = lo[a].min(v[a]);
                hi[a] = hi[a].max(v[a]);
            }
        }
        (lo, hi)
    }
}
