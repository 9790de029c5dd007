//! glTF 2.0 input (`.gltf` with external or embedded buffers, or `.glb`) for `tiltfield synth`.
//!
//! What is read: the default scene (else the first) and its node hierarchy with node transforms
//! applied; every mesh primitive in TRIANGLES mode with POSITION, optional NORMAL (else smooth
//! normals from the faces), TEXCOORD_n of the base colour texture, COLOR_0; the material's
//! `baseColorFactor` (multiplied into the vertex colour) and `baseColorTexture` (8-bit images:
//! grey, grey+alpha, RGB, RGBA; treated as sRGB, as glTF specifies), with the sampler's wrap
//! mode (repeat or clamp). Everything else (PBR parameters, lights, animation, skins, morph
//! targets, alpha modes) is ignored: the model is albedo only.
//!
//! Coordinates: glTF is right-handed with +y up, and its cameras look down their local −z with
//! +y up. tiltfield cameras look down +z with +y down, so a glTF camera whose node has world
//! rotation Q and position C becomes the camera with `R = diag(1, −1, −1) · Qᵀ` and centre C.
//! The world frame stays glTF's; `synth` then moves the mesh into the reference camera's frame.
//!
//! Errors name the file and the cause: unreadable or malformed file, a buffer or image that
//! cannot be read (with its URI), unsupported primitive modes (POINTS, LINES, ...), a primitive
//! without positions, orthographic cameras, unsupported texture formats, no triangles at all.

use std::collections::HashMap;
use std::path::Path;

use glam::{DMat3, DMat4, DVec3};

use crate::error::{Error, Result};
use crate::scene::mesh::{MeshScene, MeshTexture, MeshVertex};

/// A camera found in the file, converted to tiltfield's convention.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GltfCamera {
    /// World → camera rotation (x right, y down, z forward).
    pub r: DMat3,
    /// Camera centre in glTF world coordinates.
    pub centre: DVec3,
    /// Vertical field of view in radians.
    pub yfov: f64,
}

/// A loaded glTF scene: the mesh in glTF world coordinates and the first camera, if any.
#[derive(Debug, Clone)]
pub struct GltfScene {
    pub mesh: MeshScene,
    pub camera: Option<GltfCamera>,
}

/// The rotation that turns a glTF camera frame (x right, y up, looking down −z) into
/// tiltfield's (x right, y down, z forward).
pub fn gl_to_cv() -> DMat3 {
    DMat3::from_diagonal(DVec3::new(1.0, -1.0, -1.0))
}

/// Largest glTF file, and largest external buffer or image it names (1 GiB).
const MAX_GLTF_BYTES: u64 = 1 << 30;

/// Loads `path` (see the module docs).
pub fn load(path: &Path) -> Result<GltfScene> {
    // A folder, FIFO or device is named as such (not "missing"), and nothing is read from it.
    if std::fs::symlink_metadata(path).is_err() {
        return Err(Error::io(
            path,
            std::io::Error::new(std::io::ErrorKind::NotFound, "no such glTF file"),
        ));
    }
    let size = crate::io::check_regular(path, "the glTF scene")?;
    if size > MAX_GLTF_BYTES {
        return Err(Error::bad_file(
            path,
            format!(
                "the glTF scene is {size} bytes, more than the {MAX_GLTF_BYTES} a scene may have"
            ),
        ));
    }
    let ext = crate::io::extension_lower(path);
    if !matches!(ext.as_deref(), Some("gltf") | Some("glb")) {
        return Err(Error::bad_file(
            path,
            "unsupported scene file: expected a .gltf or .glb file, or builtin:NAME",
        ));
    }
    let bad = |m: String| Error::bad_file(path, m);
    check_glb_header(path)?;
    let gltf = gltf::Gltf::open(path).map_err(|e| bad(format!("not a readable glTF file: {e}")))?;
    // glTF requires count ≥ 1; the gltf crate's readers compute `count − 1` unchecked (found
    // by the fuzz harness).
    if let Some(a) = gltf.accessors().find(|a| a.count() == 0) {
        return Err(bad(format!(
            "accessor {} has a count of 0 (glTF requires at least 1)",
            a.index()
        )));
    }
    // An accessor's last byte, `view offset + accessor offset + (count − 1)·stride + size`,
    // must be a number: the crate's readers compute it unchecked and panicked on counts or
    // offsets near the top of usize (found by the second campaign). Accessors that merely
    // reach past their view are named by the readers' checks below.
    for a in gltf.accessors() {
        let Some(view) = a.view() else { continue };
        let stride = view.stride().unwrap_or(a.size());
        let end = (a.count() - 1)
            .checked_mul(stride)
            .and_then(|x| x.checked_add(a.size()))
            .and_then(|x| x.checked_add(a.offset()))
            .and_then(|x| x.checked_add(view.offset()));
        if end.is_none() || view.offset().checked_add(view.length()).is_none() {
            return Err(bad(format!(
                "accessor {} ({} elements of {} bytes from byte {} of buffer view {} at byte {}) \
                 reaches beyond any buffer",
                a.index(),
                a.count(),
                a.size(),
                a.offset(),
                view.index(),
                view.offset()
            )));
        }
    }
    // Check external resources first, so a missing file is named.
    let base = path.parent().unwrap_or(Path::new("."));
    for b in gltf.buffers() {
        if let gltf::buffer::Source::Uri(uri) = b.source() {
            check_uri(path, base, uri, &format!("buffer {}", b.index()))?;
        }
    }
    for i in gltf.images() {
        if let gltf::image::Source::Uri { uri, .. } = i.source() {
            check_uri(path, base, uri, &format!("image {}", i.index()))?;
        }
    }
    let (doc, buffers, images) =
        gltf::import(path).map_err(|e| bad(format!("cannot load its buffers or images: {e}")))?;
    let name = path
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("gltf")
        .to_string();
    let mut mesh = MeshScene::new(&name, [0.0; 3]);
    let mut textures: HashMap<usize, usize> = HashMap::new();
    let mut camera = None;
    let scene = doc.default_scene().or_else(|| doc.scenes().next());
    let Some(scene) = scene else {
        return Err(bad("no scene: the file has no geometry".into()));
    };
    let mut stack: Vec<(gltf::Node, DMat4)> = scene.nodes().map(|n| (n, DMat4::IDENTITY)).collect();
    stack.reverse();
    // glTF node hierarchies are disjoint trees (spec §3.5.3): a node reached twice is a cycle
    // (e.g. a node listing itself as its child) or a shared child, and a cycle would otherwise
    // be traversed until memory runs out.
    let mut visited = vec![false; doc.nodes().len()];
    while let Some((node, parent)) = stack.pop() {
        if std::mem::replace(&mut visited[node.index()], true) {
            return Err(bad(format!(
                "node {} is reached twice: the node hierarchy has a cycle or a node with two \
                 parents, but glTF nodes must form trees",
                node.index()
            )));
        }
        let local = node_matrix(path, &node)?;
        let world = parent * local;
        if let (Some(cam), None) = (node.camera(), camera.as_ref()) {
            camera = Some(convert_camera(path, &cam, world)?);
        }
        if let Some(m) = node.mesh() {
            for (k, prim) in m.primitives().enumerate() {
                let what = format!(
                    "mesh {} ('{}') primitive {k}",
                    m.index(),
                    m.name().unwrap_or("")
                );
                add_primitive(
                    path,
                    &what,
                    &prim,
                    world,
                    &buffers,
                    &images,
                    &mut textures,
                    &mut mesh,
                )?;
            }
        }
        for c in node.children() {
            stack.push((c, world));
        }
    }
    if mesh.triangle_count() == 0 {
        return Err(bad(
            "no triangles: the scene has no triangle geometry".into()
        ));
    }
    Ok(GltfScene { mesh, camera })
}

/// Largest magnitude of a vertex coordinate after the node transforms: beyond it f32 depth and
/// the automatic camera placement lose all precision, so such a mesh describes nothing.
const MAX_COORDINATE: f64 = 1e9;

/// A node's local transform, refusing what is not a transform: non-finite numbers, a rotation
/// quaternion that is not of unit length (a zero quaternion collapses the subtree to a point).
fn node_matrix(path: &Path, node: &gltf::Node) -> Result<DMat4> {
    if let gltf::scene::Transform::Decomposed { rotation, .. } = node.transform() {
        let norm = rotation
            .iter()
            .map(|&q| q as f64 * q as f64)
            .sum::<f64>()
            .sqrt();
        let unit = (norm - 1.0).abs() < 1e-2;
        if !unit {
            return Err(Error::bad_file(
                path,
                format!(
                    "node {}: the rotation quaternion {rotation:?} has length {norm:.3e}, not 1",
                    node.index()
                ),
            ));
        }
    }
    let m = DMat4::from_cols_array_2d(&node.transform().matrix().map(|c| c.map(f64::from)));
    if !m.is_finite() || DMat3::from_mat4(m).determinant().abs() < 1e-30 {
        return Err(Error::bad_file(
            path,
            format!(
                "node {}: its transform is not finite or collapses the geometry (zero scale)",
                node.index()
            ),
        ));
    }
    Ok(m)
}

/// A binary glTF's header must declare a length that covers at least the header and fits the
/// file: the gltf crate subtracts the header size from it unchecked (found by the fuzz
/// harness: a declared length of 0 overflows).
fn check_glb_header(path: &Path) -> Result<()> {
    use std::io::Read;
    let mut head = [0u8; 12];
    let file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let n = file
        .take(12)
        .read(&mut head)
        .map_err(|e| Error::io(path, e))?;
    if n < 12 || &head[..4] != b"glTF" {
        return Ok(());
    }
    let declared = u32::from_le_bytes([head[8], head[9], head[10], head[11]]) as u64;
    let size = std::fs::metadata(path)
        .map_err(|e| Error::io(path, e))?
        .len();
    if !(12..=size).contains(&declared) {
        return Err(Error::bad_file(
            path,
            format!(
                "not a readable glTF file: its binary header declares {declared} bytes, but the \
                 file has {size} (a header alone is 12)"
            ),
        ));
    }
    Ok(())
}

/// A non-data URI must name a readable file next to the glTF file.
fn check_uri(path: &Path, base: &Path, uri: &str, what: &str) -> Result<()> {
    if uri.starts_with("data:") {
        return Ok(());
    }
    let file = base.join(uri.replace("%20", " "));
    // Only regular files: a FIFO or device named by a URI would block the import or read
    // without end.
    let why = match std::fs::metadata(&file) {
        Err(e) => e.to_string(),
        Ok(m) if !m.is_file() => format!("it is {}, not a regular file", crate::io::kind_of(&m)),
        Ok(m) if m.len() > MAX_GLTF_BYTES => {
            format!("it has {} bytes, more than {MAX_GLTF_BYTES}", m.len())
        }
        Ok(_) => return Ok(()),
    };
    Err(Error::bad_file(
        path,
        format!("{what} refers to '{uri}', which cannot be read: {why}"),
    ))
}

fn convert_camera(path: &Path, cam: &gltf::Camera, world: DMat4) -> Result<GltfCamera> {
    let yfov = match cam.projection() {
        gltf::camera::Projection::Perspective(p) => p.yfov() as f64,
        gltf::camera::Projection::Orthographic(_) => {
            return Err(Error::bad_file(
                path,
                format!(
                    "camera {} is orthographic; only perspective cameras are supported",
                    cam.index()
                ),
            ))
        }
    };
    let m3 = DMat3::from_mat4(world);
    let q = DMat3::from_cols(
        m3.x_axis.normalize_or_zero(),
        m3.y_axis.normalize_or_zero(),
        m3.z_axis.normalize_or_zero(),
    );
    if !(yfov > 0.0 && yfov < std::f64::consts::PI) || (q.determinant() - 1.0).abs() > 1e-3 {
        return Err(Error::bad_file(
            path,
            format!(
                "camera {} has an invalid field of view or a non-rigid node transform",
                cam.index()
            ),
        ));
    }
    Ok(GltfCamera {
        r: gl_to_cv() * q.transpose(),
        centre: world.w_axis.truncate(),
        yfov,
    })
}

#[allow(clippy::too_many_arguments)]
fn add_primitive(
    path: &Path,
    what: &str,
    prim: &gltf::Primitive,
    world: DMat4,
    buffers: &[gltf::buffer::Data],
    images: &[gltf::image::Data],
    textures: &mut HashMap<usize, usize>,
    mesh: &mut MeshScene,
) -> Result<()> {
    let bad = |m: String| Error::bad_file(path, format!("{what}: {m}"));
    if prim.mode() != gltf::mesh::Mode::Triangles {
        return Err(bad(format!(
            "unsupported primitive mode {:?}; only TRIANGLES is supported",
            prim.mode()
        )));
    }
    let reader = prim.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
    let Some(position_accessor) = prim.get(&gltf::Semantic::Positions) else {
        return Err(bad("no POSITION attribute".into()));
    };
    // The reader yields nothing (or stops early) when an accessor does not fit its buffer, so
    // counts are compared with what the accessors declare: nothing is dropped silently.
    let positions: Vec<[f32; 3]> = reader
        .read_positions()
        .ok_or_else(|| {
            bad(format!(
                "the POSITION accessor {} lies outside its buffer or has no buffer view",
                position_accessor.index()
            ))
        })?
        .collect();
    if positions.len() != position_accessor.count() {
        return Err(bad(format!(
            "the POSITION accessor {} declares {} vertices but its buffer holds {}",
            position_accessor.index(),
            position_accessor.count(),
            positions.len()
        )));
    }
    let indices: Vec<u32> = match (prim.indices(), reader.read_indices()) {
        (Some(a), Some(i)) => {
            let i: Vec<u32> = i.into_u32().collect();
            if i.len() != a.count() {
                return Err(bad(format!(
                    "the index accessor {} declares {} indices but its buffer holds {}",
                    a.index(),
                    a.count(),
                    i.len()
                )));
            }
            i
        }
        (Some(a), None) => {
            return Err(bad(format!(
                "the index accessor {} lies outside its buffer or has no buffer view",
                a.index()
            )))
        }
        _ => (0..positions.len() as u32).collect(),
    };
    if indices.iter().any(|&i| i as usize >= positions.len()) {
        return Err(bad("an index points past the vertex data".into()));
    }
    if indices.len() % 3 != 0 {
        return Err(bad(format!(
            "{} indices (or vertices) is not a multiple of three: not a list of triangles",
            indices.len()
        )));
    }
    let material = prim.material();
    let pbr = material.pbr_metallic_roughness();
    let factor = pbr.base_color_factor();
    let info = pbr.base_color_texture();
    let uv_set = info.as_ref().map_or(0, |t| t.tex_coord());
    let uvs: Option<Vec<[f32; 2]>> = reader
        .read_tex_coords(uv_set)
        .map(|t| t.into_f32().collect());
    let colors: Option<Vec<[f32; 4]>> = reader.read_colors(0).map(|c| c.into_rgba_f32().collect());
    let normals: Option<Vec<[f32; 3]>> = reader.read_normals().map(|n| n.collect());
    let texture = match (&info, &uvs) {
        (Some(info), Some(_)) => Some(mesh_texture(info, images, textures, mesh).map_err(bad)?),
        _ => None,
    };
    // Normals transform with the inverse transpose of the linear part.
    let m3 = DMat3::from_mat4(world);
    let normal_matrix = m3.inverse().transpose();
    let world_pos: Vec<DVec3> = positions
        .iter()
        .map(|p| world.transform_point3(DVec3::from(p.map(f64::from))))
        .collect();
    if let Some(p) = world_pos
        .iter()
        .find(|p| !(p.is_finite() && p.abs().max_element() <= MAX_COORDINATE))
    {
        return Err(bad(format!(
            "a vertex lies at ({:.3e}, {:.3e}, {:.3e}), beyond ±{MAX_COORDINATE:e}: not a \
             usable mesh",
            p.x, p.y, p.z
        )));
    }
    let world_normals: Vec<DVec3> = match &normals {
        Some(n) if n.len() == positions.len() => n
            .iter()
            .map(|v| (normal_matrix * DVec3::from(v.map(f64::from))).normalize_or_zero())
            .collect(),
        _ => smooth_normals(&world_pos, &indices),
    };
    let vertices: Vec<MeshVertex> = (0..positions.len())
        .map(|i| {
            let c = colors
                .as_ref()
                .and_then(|c| c.get(i).copied())
                .unwrap_or([1.0; 4]);
            MeshVertex {
                position: world_pos[i].as_vec3().to_array(),
                normal: world_normals[i].as_vec3().to_array(),
                uv: uvs
                    .as_ref()
                    .and_then(|u| u.get(i).copied())
                    .unwrap_or([0.0; 2]),
                color: std::array::from_fn(|k| c[k] * factor[k]),
            }
        })
        .collect();
    mesh.push(&vertices, &indices, texture);
    Ok(())
}

/// The index in `mesh.textures` of the base colour texture `info` (its image in its wrapping
/// mode), added on first use; `textures` maps image and mode to the index.
fn mesh_texture(
    info: &gltf::texture::Info,
    images: &[gltf::image::Data],
    textures: &mut HashMap<usize, usize>,
    mesh: &mut MeshScene,
) -> std::result::Result<usize, String> {
    let tex = info.texture();
    let image_index = tex.source().index();
    let repeat = tex.sampler().wrap_s() != gltf::texture::WrappingMode::ClampToEdge;
    let key = image_index * 2 + repeat as usize;
    if let Some(&i) = textures.get(&key) {
        return Ok(i);
    }
    let data = images
        .get(image_index)
        .ok_or_else(|| format!("image {image_index} is missing"))?;
    let rgba = to_rgba8(data).ok_or_else(|| {
        format!(
            "image {image_index} has the unsupported format {:?} (8-bit images only)",
            data.format
        )
    })?;
    mesh.textures.push(MeshTexture {
        width: data.width,
        height: data.height,
        rgba,
        repeat,
        name: format!("glTF image {image_index}"),
    });
    textures.insert(key, mesh.textures.len() - 1);
    Ok(mesh.textures.len() - 1)
}

/// Smooth normals: area-weighted face normals of the triangles `indices` summed per vertex.
fn smooth_normals(positions: &[DVec3], indices: &[u32]) -> Vec<DVec3> {
    let mut acc = vec![DVec3::ZERO; positions.len()];
    for tri in indices.chunks_exact(3) {
        let [a, b, c] = [0, 1, 2].map(|k| positions[tri[k] as usize]);
        let n = (b - a).cross(c - a);
        for &k in tri {
            acc[k as usize] += n;
        }
    }
    acc.into_iter().map(|n| n.normalize_or_zero()).collect()
}

/// 8-bit glTF image data → RGBA8 (grey expands to RGB).
fn to_rgba8(data: &gltf::image::Data) -> Option<Vec<u8>> {
    use gltf::image::Format;
    let p = &data.pixels;
    let out: Vec<u8> = match data.format {
        Format::R8G8B8A8 => p.clone(),
        Format::R8G8B8 => p
            .chunks_exact(3)
            .flat_map(|c| [c[0], c[1], c[2], 255])
            .collect(),
        Format::R8G8 => p
            .chunks_exact(2)
            .flat_map(|c| [c[0], c[0], c[0], c[1]])
            .collect(),
        Format::R8 => p.iter().flat_map(|&c| [c, c, c, 255]).collect(),
        _ => return None,
    };
    (out.len() == data.width as usize * data.height as usize * 4).then_some(out)
}
