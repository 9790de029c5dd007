//! Binary little-endian PLY output of point clouds (with an optional polygon, e.g. the refocus
//! plane), readable by MeshLab, CloudCompare and Open3D.
//!
//! Layout written:
//! ```text
//! ply
//! format binary_little_endian 1.0
//! comment …                       (one per entry of `comments`)
//! element vertex N
//! property float x                (world frame: x right, y down, z forward for the built-in
//! property float y                 scenes and HCI data, whose world frame is the centre
//! property float z                 camera's; metres for HCI)
//! property float nx               (unit normal, or 0 0 0 where none was estimated)
//! property float ny
//! property float nz
//! property uchar red              (sRGB-encoded colour)
//! property uchar green
//! property uchar blue
//! property float quality          (MeshLab's per-vertex quality: normal confidence in [0, 1])
//! element face F                  (only when F > 0)
//! property list uchar int vertex_indices
//! end_header
//! ```
//! followed by N vertex records of 31 bytes and F face records.

use std::path::Path;

use crate::error::{Error, Result};

/// One vertex record.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlyVertex {
    pub position: [f32; 3],
    /// Unit normal, or zero where none is known.
    pub normal: [f32; 3],
    /// sRGB-encoded colour.
    pub colour: [u8; 3],
    /// Confidence in [0, 1] (MeshLab "quality").
    pub quality: f32,
}

/// Vertices, polygons (indices into `vertices`) and header comments.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PlyMesh {
    pub vertices: Vec<PlyVertex>,
    pub faces: Vec<Vec<u32>>,
    pub comments: Vec<String>,
}

/// Bytes of one vertex record.
pub const VERTEX_BYTES: usize = 6 * 4 + 3 + 4;

impl PlyMesh {
    /// The encoded file. Errors on a face with an out-of-range index or more than 255 corners.
    pub fn encode(&self) -> Result<Vec<u8>> {
        let mut header = String::from("ply\nformat binary_little_endian 1.0\n");
        for c in &self.comments {
            // A comment ends at the line break; keep each on one line of printable text.
            let clean: String = c
                .chars()
                .map(|ch| if ch.is_control() { ' ' } else { ch })
                .collect();
            header.push_str(&format!("comment {clean}\n"));
        }
        header.push_str(&format!("element vertex {}\n", self.vertices.len()));
        for p in ["x", "y", "z", "nx", "ny", "nz"] {
            header.push_str(&format!("property float {p}\n"));
        }
        for p in ["red", "green", "blue"] {
            header.push_str(&format!("property uchar {p}\n"));
        }
        header.push_str("property float quality\n");
        if !self.faces.is_empty() {
            header.push_str(&format!(
                "element face {}\nproperty list uchar int vertex_indices\n",
                self.faces.len()
            ));
        }
        header.push_str("end_header\n");
        let mut out = header.into_bytes();
        out.reserve(self.vertices.len() * VERTEX_BYTES);
        for v in &self.vertices {
            for c in v.position.iter().chain(v.normal.iter()) {
                out.extend_from_slice(&c.to_le_bytes());
            }
            out.extend_from_slice(&v.colour);
            out.extend_from_slice(&v.quality.to_le_bytes());
        }
        for (i, f) in self.faces.iter().enumerate() {
            if f.len() < 3 || f.len() > 255 {
                return Err(Error::Invalid(format!(
                    "PLY face {i} has {} corners (3 to 255 allowed)",
                    f.len()
                )));
            }
            out.push(f.len() as u8);
            for &k in f {
                if k as usize >= self.vertices.len() {
                    return Err(Error::Invalid(format!(
                        "PLY face {i} refers to vertex {k}, but there are only {}",
                        self.vertices.len()
                    )));
                }
                out.extend_from_slice(&(k as i32).to_le_bytes());
            }
        }
        Ok(out)
    }

    /// Writes the file to `path`.
    pub fn write(&self, path: &Path) -> Result<()> {
        let bytes = self.encode()?;
        crate::io::write_bytes(path, "PLY", &bytes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_and_records_have_the_documented_layout() {
        let mesh = PlyMesh {
            vertices: vec![
                PlyVertex {
                    position: [1.0, -2.0, 3.5],
                    normal: [0.0, 0.0, -1.0],
                    colour: [10, 20, 30],
                    quality: 0.75,
                };
                3
            ],
            faces: vec![vec![0, 1, 2]],
            comments: vec!["two\nlines".into()],
        };
        let bytes = mesh.encode().unwrap();
        let text = String::from_utf8_lossy(&bytes);
        let end = text.find("end_header\n").unwrap() + "end_header\n".len();
        let header = &text[..end];
        assert!(header.starts_with("ply\nformat binary_little_endian 1.0\n"));
        assert!(header.contains("comment two lines\n"));
        assert!(header.contains("element vertex 3\n") && header.contains("element face 1\n"));
        assert_eq!(bytes.len(), end + 3 * VERTEX_BYTES + 1 + 3 * 4);
        let rec = &bytes[end..end + VERTEX_BYTES];
        assert_eq!(f32::from_le_bytes(rec[4..8].try_into().unwrap()), -2.0);
        assert_eq!(&rec[24..27], &[10, 20, 30]);
        assert_eq!(bytes[end + 3 * VERTEX_BYTES], 3);
    }

    #[test]
    fn bad_faces_are_refused() {
        let mut mesh = PlyMesh {
            vertices: vec![
                PlyVertex {
                    position: [0.0; 3],
                    normal: [0.0; 3],
                    colour: [0; 3],
                    quality: 0.0,
                };
                2
            ],
            faces: vec![vec![0, 1, 2]],
            comments: vec![],
        };
        assert!(mesh.encode().unwrap_err().to_string().contains("vertex 2"));
        mesh.faces = vec![vec![0, 1]];
        assert!(mesh.encode().is_err());
        mesh.faces.clear();
        let bytes = mesh.encode().unwrap();
        assert!(!String::from_utf8_lossy(&bytes).contains("element face"));
    }
}
