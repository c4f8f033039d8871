//! Triangle meshes: vertices, triangles, a gray albedo per vertex, and the bounding sphere that
//! normalises a mesh to the view.
//!
//! The renderer maps every vertex p to (p - centre) / radius, where centre has the x and y of the
//! surface's area-weighted centroid and the z of the middle of the mesh's height, and radius is
//! the largest distance of a vertex from it. The
//! object therefore turns about the vertical (z) axis through its centre and lies inside the unit
//! sphere at every pose, so it fits the frame whichever way it is turned or viewed, and a mesh and
//! any scaled or shifted copy of it give the same images.

use crate::{Error, Result};
use std::path::{Path, PathBuf};

/// Largest OBJ file read, in bytes (refused from its size before it is read).
pub const MAX_OBJ_BYTES: u64 = 1 << 30;
/// Largest mesh accepted, in vertices.
pub const MAX_VERTICES: usize = 10_000_000;
/// Largest mesh accepted, in triangles.
pub const MAX_TRIANGLES: usize = 20_000_000;
/// Albedo of an OBJ mesh that has no vertex colours.
pub const DEFAULT_ALBEDO: f64 = 0.8;

/// A triangle mesh with a gray albedo (reflectance in [0, 1]) at each vertex.
///
/// Shading normals are per vertex: the area-weighted mean of the normals of the triangles that
/// share the vertex, unless given (an OBJ file's own normals).
#[derive(Debug, Clone, PartialEq)]
pub struct Mesh {
    positions: Vec<[f64; 3]>,
    normals: Vec<[f64; 3]>,
    albedo: Vec<f64>,
    triangles: Vec<[u32; 3]>,
    centre: [f64; 3],
    radius: f64,
}

impl Mesh {
    /// A mesh from vertex positions, triangles (indices into `positions`) and one albedo per
    /// vertex. Refuses an empty mesh, non-finite positions, indices out of range, albedo outside
    /// [0, 1] and a mesh whose vertices all coincide.
    pub fn new(positions: Vec<[f64; 3]>, triangles: Vec<[u32; 3]>, albedo: Vec<f64>) -> Result<Self> {
        Self::build(Path::new("<mesh>"), positions, triangles, albedo, None)
    }

    fn build(path: &Path, positions: Vec<[f64; 3]>, triangles: Vec<[u32; 3]>, albedo: Vec<f64>, normals: Option<Vec<[f64; 3]>>) -> Result<Self> {
        let err = |message: String| Error::Mesh { path: path.to_path_buf(), message };
        if positions.is_empty() || triangles.is_empty() {
            return Err(err(format!("the mesh is empty ({} vertices, {} triangles); it needs at least one triangle", positions.len(), triangles.len())));
        }
        if positions.len() > MAX_VERTICES || triangles.len() > MAX_TRIANGLES {
            return Err(err(format!(
                "the mesh has {} vertices and {} triangles; the limits are {MAX_VERTICES} and {MAX_TRIANGLES}",
                positions.len(),
                triangles.len()
            )));
        }
        if let Some(i) = positions.iter().position(|p| p.iter().any(|v| !v.is_finite())) {
            return Err(err(format!("vertex {} has a non-finite coordinate: {:?}", i + 1, positions[i])));
        }
        let n = positions.len();
        if let Some(t) = triangles.iter().position(|t| t.iter().any(|&i| i as usize >= n)) {
            return Err(err(format!(
                "triangle {} refers to vertex {} but the mesh has only {n} vertices",
                t + 1,
                triangles[t].iter().map(|&i| i as u64 + 1).max().unwrap_or(0)
            )));
        }
        if albedo.len() != n {
            return Err(err(format!("{} albedo values for {n} vertices", albedo.len())));
        }
        if let Some(i) = albedo.iter().position(|a| !(0.0..=1.0).contains(a)) {
            return Err(err(format!("albedo of vertex {} is {}, outside [0, 1]", i + 1, albedo[i])));
        }
        let (centre, radius) = bounding_sphere(&positions, &triangles);
        if !(radius > 0.0 && radius.is_finite()) {
            return Err(err(format!("the mesh has no extent (bounding radius {radius}): all its vertices coincide")));
        }
        let normals = match normals {
            Some(v) if v.len() == n && v.iter().all(|p| p.iter().all(|x| x.is_finite())) => v.into_iter().map(normalise).collect(),
            _ => vertex_normals(&positions, &triangles),
        };
        Ok(Mesh { positions, normals, albedo, triangles, centre, radius })
    }

    /// The mesh with every vertex moved by `f` (normals recomputed from the new positions), e.g.
    /// rotated or scaled.
    pub fn map_positions(&self, f: impl Fn([f64; 3]) -> [f64; 3]) -> Result<Self> {
        let positions = self.positions.iter().map(|&p| f(p)).collect();
        Self::new(positions, self.triangles.clone(), self.albedo.clone())
    }

    /// Vertex positions, as given.
    pub fn positions(&self) -> &[[f64; 3]] {
        &self.positions
    }

    /// Unit shading normal of each vertex (zero for a vertex of degenerate triangles only).
    pub fn normals(&self) -> &[[f64; 3]] {
        &self.normals
    }

    /// Albedo of each vertex, in [0, 1].
    pub fn albedo(&self) -> &[f64] {
        &self.albedo
    }

    /// Triangles, as indices into [`Mesh::positions`].
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    /// The centre of the normalised view, which the turntable axis passes through: x and y the
    /// area-weighted centroid of the surface, z the middle of the mesh's z range.
    pub fn centre(&self) -> [f64; 3] {
        self.centre
    }

    /// Largest distance of a vertex from [`Mesh::centre`]: the unit of the normalised view.
    pub fn radius(&self) -> f64 {
        self.radius
    }

    /// Reads a Wavefront OBJ file. Its Y axis (the usual "up" of OBJ exporters) becomes the
    /// turntable axis; polygons are triangulated; vertex colours, when present, give the albedo
    /// (their Rec. 601 luma), otherwise it is [`DEFAULT_ALBEDO`]. Normals in the file are used
    /// when every vertex has one.
    pub fn from_obj(path: &Path) -> Result<Self> {
        let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
        if !meta.is_file() {
            return Err(Error::Mesh { path: path.to_path_buf(), message: "not a file".into() });
        }
        if meta.len() > MAX_OBJ_BYTES {
            return Err(Error::Mesh {
                path: path.to_path_buf(),
                message: format!("the file has {} bytes; meshes over {MAX_OBJ_BYTES} bytes are refused", meta.len()),
            });
        }
        let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
        Self::from_obj_bytes(path, &bytes)
    }

    /// As [`Mesh::from_obj`], from the file's bytes already in memory (`path` names it in errors).
    pub fn from_obj_bytes(path: &Path, bytes: &[u8]) -> Result<Self> {
        let err = |message: String| Error::Mesh { path: path.to_path_buf(), message };
        if bytes.len() as u64 > MAX_OBJ_BYTES {
            return Err(err(format!("{} bytes; meshes over {MAX_OBJ_BYTES} bytes are refused", bytes.len())));
        }
        if bytes.iter().all(|b| b.is_ascii_whitespace()) {
            return Err(err("the file is empty: no vertices or faces".into()));
        }
        let (nv, nt) = count_obj(bytes);
        if nv > MAX_VERTICES || nt > MAX_TRIANGLES {
            return Err(err(format!("the file declares {nv} vertices and {nt} triangles; the limits are {MAX_VERTICES} and {MAX_TRIANGLES}")));
        }
        check_face_indices(bytes).map_err(err)?;
        let options = tobj::LoadOptions { triangulate: true, single_index: true, ignore_points: true, ignore_lines: true };
        // Materials are not read: a missing .mtl must not fail the mesh, so the loader declines.
        let (models, _) = tobj::load_obj_buf(&mut std::io::Cursor::new(bytes), &options, |_| Err(tobj::LoadError::OpenFileFailed))
            .map_err(|e| err(format!("not a valid Wavefront OBJ file: {e}")))?;
        let mut positions = Vec::new();
        let mut normals = Vec::new();
        let mut albedo = Vec::new();
        let mut triangles = Vec::new();
        let mut all_normals = true;
        for model in &models {
            let m = &model.mesh;
            let base = positions.len();
            let count = m.positions.len() / 3;
            // OBJ is Y-up; linpose's turntable axis is Z: (x, y, z) -> (x, -z, y), a rotation.
            let yup = |c: &[f32]| [c[0] as f64, -(c[2] as f64), c[1] as f64];
            positions.extend(m.positions.chunks_exact(3).map(yup));
            if m.normals.len() == m.positions.len() {
                normals.extend(m.normals.chunks_exact(3).map(yup));
            } else {
                all_normals = false;
            }
            if m.vertex_color.len() == m.positions.len() {
                albedo.extend(m.vertex_color.chunks_exact(3).map(|c| {
                    let l = 0.299 * c[0] as f64 + 0.587 * c[1] as f64 + 0.114 * c[2] as f64;
                    if l.is_nan() {
                        DEFAULT_ALBEDO
                    } else {
                        l.clamp(0.0, 1.0)
                    }
                }));
            } else {
                albedo.extend(std::iter::repeat_n(DEFAULT_ALBEDO, count));
            }
            for t in m.indices.chunks_exact(3) {
                let offset = |i: u32| u32::try_from(base + i as usize).map_err(|_| err("too many vertices".into()));
                triangles.push([offset(t[0])?, offset(t[1])?, offset(t[2])?]);
            }
        }
        if triangles.is_empty() {
            return Err(err(format!("no faces found ({nv} vertex lines); is this a Wavefront OBJ file with 'f' lines?")));
        }
        Self::build(path, positions, triangles, albedo, all_normals.then_some(normals))
    }
}

/// Counts vertex lines and the triangles the face lines will make, without allocating, so an
/// absurd file is refused before it is parsed.
fn count_obj(bytes: &[u8]) -> (usize, usize) {
    let (mut nv, mut nt) = (0usize, 0usize);
    for line in bytes.split(|&b| b == b'\n') {
        let line = line.trim_ascii_start();
        if line.starts_with(b"v ") || line.starts_with(b"v\t") {
            nv += 1;
        } else if line.starts_with(b"f ") || line.starts_with(b"f\t") {
            let corners = line[1..].split(|b| b.is_ascii_whitespace()).filter(|w| !w.is_empty()).count();
            nt = nt.saturating_add(corners.saturating_sub(2));
        }
    }
    (nv, nt)
}

/// Refuses a face corner whose vertex, texture or normal index refers to nothing: tobj 4.0.5
/// computes `index * 3 + 2` unchecked for texture and normal indices, which overflows (a panic in
/// debug builds) for an index far out of range, e.g. `f 1/-2 ...` with no texture coordinates.
/// Indices are 1-based; negative ones count back from the last element defined before the face.
fn check_face_indices(bytes: &[u8]) -> std::result::Result<(), String> {
    const KINDS: [(&str, &str); 3] = [("vertex", "vertices"), ("texture coordinate", "texture coordinates"), ("normal", "normals")];
    let kind_of = |line: &[u8]| match line.split(|b| b.is_ascii_whitespace()).next() {
        Some(b"v") => Some(0),
        Some(b"vt") => Some(1),
        Some(b"vn") => Some(2),
        _ => None,
    };
    let mut total = [0i64; 3];
    for (n, line) in bytes.split(|&b| b == b'\n').enumerate() {
        let line = line.trim_ascii_start();
        if let Some(k) = kind_of(line) {
            // A vertex line whose numbers do not parse is named here, before any face that
            // counts on it.
            let values: Vec<&[u8]> = line.split(|b| b.is_ascii_whitespace()).skip(1).filter(|w| !w.is_empty()).collect();
            let numeric = values.iter().all(|w| std::str::from_utf8(w).ok().and_then(|t| t.parse::<f64>().ok()).is_some());
            if !numeric || values.len() < if k == 1 { 1 } else { 3 } {
                return Err(format!("line {}: not a valid Wavefront OBJ {} line: '{}'", n + 1, KINDS[k].0, String::from_utf8_lossy(line).trim_end()));
            }
            total[k] += 1;
        }
    }
    let mut so_far = [0i64; 3];
    for (n, line) in bytes.split(|&b| b == b'\n').enumerate() {
        let line = line.trim_ascii_start();
        if let Some(k) = kind_of(line) {
            so_far[k] += 1;
            continue;
        }
        if !(line.starts_with(b"f ") || line.starts_with(b"f\t")) {
            continue;
        }
        for corner in line[1..].split(|b| b.is_ascii_whitespace()).filter(|w| !w.is_empty()) {
            for (k, index) in corner.split(|&b| b == b'/').enumerate().take(3) {
                // What tobj cannot parse it refuses itself.
                let Some(i) = std::str::from_utf8(index).ok().and_then(|t| t.parse::<i64>().ok()) else { continue };
                let ok = if i < 0 { i >= -so_far[k] } else { i >= 1 && i <= total[k] };
                if !ok {
                    let have = if i < 0 { so_far[k] } else { total[k] };
                    return Err(format!(
                        "line {}: a face refers to {} {i}, but {have} {} are defined{}",
                        n + 1,
                        KINDS[k].0,
                        KINDS[k].1,
                        if i < 0 { " before it" } else { "" }
                    ));
                }
            }
        }
    }
    Ok(())
}

/// The normalisation centre and the largest vertex distance from it. The centre's x and y are
/// the area-weighted centroid of the surface, its z the middle of the z range: both turn with
/// the mesh about z (so a pre-rotated mesh is framed as the rotated one) and neither depends on
/// how finely a part is tessellated. A mesh of degenerate triangles only uses its bounding box.
fn bounding_sphere(positions: &[[f64; 3]], triangles: &[[u32; 3]]) -> ([f64; 3], f64) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in positions {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let (mut area, mut sx, mut sy) = (0.0, 0.0, 0.0);
    for t in triangles {
        let [a, b, c] = t.map(|i| positions[i as usize]);
        let n = cross(sub(b, a), sub(c, a));
        let w = dot(n, n).sqrt();
        area += w;
        sx += w * ((a[0] + b[0] + c[0]) / 3.0);
        sy += w * ((a[1] + b[1] + c[1]) / 3.0);
    }
    let (cx, cy) =
        if area > 0.0 && (sx / area).is_finite() && (sy / area).is_finite() { (sx / area, sy / area) } else { ((lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0) };
    let centre = [cx, cy, (lo[2] + hi[2]) / 2.0];
    let r2 = positions.iter().map(|p| dot(sub(*p, centre), sub(*p, centre))).fold(0.0, f64::max);
    (centre, r2.sqrt())
}

/// Area-weighted vertex normals (the cross product's length is twice the triangle's area).
fn vertex_normals(positions: &[[f64; 3]], triangles: &[[u32; 3]]) -> Vec<[f64; 3]> {
    let mut acc = vec![[0.0; 3]; positions.len()];
    for t in triangles {
        let [a, b, c] = t.map(|i| positions[i as usize]);
        let n = cross(sub(b, a), sub(c, a));
        for &i in t {
            let v = &mut acc[i as usize];
            for k in 0..3 {
                v[k] += n[k];
            }
        }
    }
    acc.into_iter().map(normalise).collect()
}

pub(crate) fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

pub(crate) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub(crate) fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

/// `v / |v|`, or zero for a zero vector.
pub(crate) fn normalise(v: [f64; 3]) -> [f64; 3] {
    let l = dot(v, v).sqrt();
    if l > 0.0 {
        [v[0] / l, v[1] / l, v[2] / l]
    } else {
        [0.0; 3]
    }
}

/// Path used in errors for a mesh not read from a file.
pub(crate) fn builtin_path(name: &str) -> PathBuf {
    PathBuf::from(format!("<built-in {name}>"))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn obj_err(text: &str) -> String {
        Mesh::from_obj_bytes(Path::new("t.obj"), text.as_bytes()).unwrap_err().to_string()
    }

    #[test]
    fn reads_a_quad_as_two_triangles_y_up() {
        let m = Mesh::from_obj_bytes(Path::new("q.obj"), b"v 0 0 0\nv 1 0 0\nv 1 2 0\nv 0 2 0\nf 1 2 3 4\n").unwrap();
        assert_eq!(m.triangles().len(), 2);
        // OBJ y (2) became the turntable axis z.
        assert_eq!(m.positions()[2], [1.0, 0.0, 2.0]);
        assert_eq!(m.albedo(), &[DEFAULT_ALBEDO; 4]);
    }

    #[test]
    fn bad_obj_inputs_name_the_problem() {
        assert!(obj_err("").contains("empty"), "{}", obj_err(""));
        assert!(obj_err("v 0 0 0\nv 1 0 0\nv 0 1 0\n").contains("no faces"));
        assert!(obj_err("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n").contains("refers to vertex 7"), "{}", obj_err("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n"));
        let nan = obj_err("v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n");
        assert!(nan.contains("non-finite") || nan.contains("parse"), "{nan}");
        assert!(obj_err("v 0 0 x\nf 1 1 1\n").contains("not a valid Wavefront OBJ"));
        assert!(obj_err("v 1 1 1\nv 1 1 1\nv 1 1 1\nf 1 2 3\n").contains("no extent"));
        let missing = Mesh::from_obj(Path::new("/nonexistent/duck.obj")).unwrap_err().to_string();
        assert!(missing.contains("/nonexistent/duck.obj"), "{missing}");
    }

    #[test]
    fn face_indices_out_of_range_are_refused_by_line() {
        // Found by fuzzing: a relative texture index before any texture coordinate overflowed
        // inside tobj.
        let e = obj_err("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1/-2 1 2\n");
        assert!(e.contains("line 4") && e.contains("texture coordinate -2"), "{e}");
        let e = obj_err("v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//9223372036854775807\n");
        assert!(e.contains("normal 9223372036854775807"), "{e}");
        let e = obj_err("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n");
        assert!(e.contains("vertex 0"), "{e}");
        assert!(Mesh::from_obj_bytes(Path::new("t.obj"), b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf -3/-1 -2/1 -1/1\n").is_ok());
    }

    #[test]
    fn absurd_meshes_are_refused_before_parsing() {
        let mut text = String::from("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3");
        // A single face line with ever so many corners declares MAX_TRIANGLES+ triangles.
        text.push_str(&" 1".repeat(MAX_TRIANGLES));
        let e = obj_err(&text);
        assert!(e.contains("limits"), "{e}");
    }

    #[test]
    fn new_checks_indices_albedo_and_finiteness() {
        let p = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let e = Mesh::new(p.clone(), vec![[0, 1, 3]], vec![0.5; 3]).unwrap_err().to_string();
        assert!(e.contains("refers to vertex 4"), "{e}");
        let e = Mesh::new(p.clone(), vec![[0, 1, 2]], vec![0.5, 2.0, 0.5]).unwrap_err().to_string();
        assert!(e.contains("outside [0, 1]"), "{e}");
        let e = Mesh::new(vec![[0.0, f64::NAN, 0.0]; 3], vec![[0, 1, 2]], vec![0.5; 3]).unwrap_err().to_string();
        assert!(e.contains("non-finite"), "{e}");
        let m = Mesh::new(p, vec![[0, 1, 2]], vec![0.5; 3]).unwrap();
        assert_eq!(m.normals()[0], [0.0, 0.0, 1.0]);
        assert_eq!(m.centre(), [1.0 / 3.0, 1.0 / 3.0, 0.0]);
    }
}
