//! Collision meshes in the replay and in self-collision: every `<collision>` `<mesh>` that a
//! [`MeshSearch`] finds is read (STL, COLLADA or OBJ, by `mesh-loader`) and becomes the convex
//! hull of its vertices, scaled by the mesh's `scale`, placed at the collision's `<origin>` in
//! its link, and, where the mesh is concave, convex parts that hold its surface (a hull is the
//! cheapest shape parry tests for contact and never misses a contact the mesh has, but it
//! reports contacts in the mesh's concave places too: an elbow's hull fills its bend). One
//! shape per `<collision>` element, whatever the number of meshes in the file. A mesh that
//! cannot be found, read or made a hull is an [`UncheckedMesh`] of the report: its link is
//! simulated without it.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, OnceLock};
use std::time::Instant;

use rapier3d::geometry::SharedShape;
use rapier3d::glamx::EulerRot;
use rapier3d::math::{Pose, Real, Rotation, Vector};
use rapier3d::parry::transformation::vhacd::{VHACDParameters, VHACD};
use rapier3d_urdf::urdf_rs;
use serde::Serialize;

use super::parts_cache;
use crate::urdf::{MeshSearch, MAX_LENGTH_M};

/// How a Git LFS pointer file begins: a repository cloned without `git lfs` holds these small
/// text files where its meshes should be.
const GIT_LFS_POINTER: &[u8] = b"version https://git-lfs.github.com/spec/";

/// Mesh files larger than this are not read (bytes): 256 MiB, ten times the largest mesh of
/// the published robot descriptions we know.
pub const MAX_MESH_BYTES: u64 = 256 << 20;

/// Why a collision mesh was left out of the replay.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum MeshProblem {
    /// The file was not found (see [`crate::urdf::MeshMiss`]).
    NotFound,
    /// The file could not be read or parsed (I/O error, unknown format, malformed content,
    /// too large).
    Unreadable,
    /// The file was read but gives no usable hull: no vertices, all in a plane, non-finite,
    /// or farther than [`MAX_LENGTH_M`] from the link; or the mesh's scale is unusable.
    Unusable,
}

impl MeshProblem {
    /// A few words for summaries: "not found", "unreadable", "no usable hull".
    pub fn describe(self) -> &'static str {
        match self {
            MeshProblem::NotFound => "not found",
            MeshProblem::Unreadable => "unreadable",
            MeshProblem::Unusable => "no usable hull",
        }
    }
}

/// A collision mesh the replay could not simulate: its link's collisions with it were not
/// checked.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct UncheckedMesh {
    /// The link's URDF name.
    pub link: String,
    /// The mesh's file name as the URDF gives it.
    pub uri: String,
    /// The kind of problem.
    pub problem: MeshProblem,
    /// What went wrong, naming the file (and what was tried, for a file not found).
    pub message: String,
}

/// A `<collision>` `<mesh>` of a link, taken out of the URDF before rapier loads it.
#[derive(Debug, Clone)]
pub(super) struct MeshCollision {
    /// URDF index of the link.
    pub(super) link: usize,
    /// The collision's `<origin>` in the link frame.
    pub(super) origin: urdf_rs::Pose,
    /// The mesh's `filename`.
    pub(super) filename: String,
    /// The mesh's `scale` (1 1 1 when absent).
    pub(super) scale: [f64; 3],
}

/// A collision mesh made a convex hull or, concave, a compound of convex parts, ready to be
/// attached to its link's body.
#[derive(Clone)]
pub(super) struct MeshHull {
    /// URDF index of the link.
    pub(super) link: usize,
    /// Pose of the hull in the link frame.
    pub(super) pose: Pose,
    /// The hull.
    pub(super) shape: SharedShape,
}

/// What became of a URDF's collision meshes.
#[derive(Default)]
pub(super) struct LoadedMeshes {
    /// The hulls, in URDF order.
    pub(super) hulls: Vec<MeshHull>,
    /// The meshes left out, in URDF order.
    pub(super) unchecked: Vec<UncheckedMesh>,
    /// Wall-clock seconds spent finding, reading and hulling.
    pub(super) seconds: f64,
}

/// A problem and its message.
type Failure = (MeshProblem, String);

/// The vertices and triangles of a mesh file (every mesh of it, the triangles indexing the
/// joined vertices), shared between collisions naming it.
type MeshData = Arc<(Vec<[f32; 3]>, Vec<[u32; 3]>)>;

/// Finds, reads and hulls every mesh of `meshes` (links named by `links`); a mesh is simulated
/// as its convex parts where it has more than one, as self-collision checks it in retargeting,
/// but on the links `carried` (parts held still on a moving arm: a hand's fingers, which touch
/// each other all the time and are cheaper in contact as hulls).
pub(super) fn load(
    meshes: &[MeshCollision],
    links: &[urdf_rs::Link],
    search: &MeshSearch,
    carried: &[bool],
) -> LoadedMeshes {
    let started = Instant::now();
    let mut loaded = LoadedMeshes::default();
    let mut files: HashMap<PathBuf, Result<MeshData, Failure>> = HashMap::new();
    let mut found = Vec::new();
    for mesh in meshes {
        let link_name = links.get(mesh.link).map_or("", |l| l.name.as_str());
        let shapes = search
            .resolve(&mesh.filename)
            .map_err(|miss| (MeshProblem::NotFound, miss.to_string()))
            .and_then(|path| {
                let mesh_data = files
                    .entry(path.clone())
                    .or_insert_with(|| read_mesh(&path))
                    .clone()?;
                shapes_of(&mesh_data, mesh.scale)
                    .map_err(|why| (MeshProblem::Unusable, format!("{}: {why}", path.display())))
            });
        match shapes {
            Ok(shapes) => {
                let split = !carried.get(mesh.link).copied().unwrap_or(true);
                found.push((mesh, shapes, split));
            }
            Err((problem, message)) => loaded.unchecked.push(UncheckedMesh {
                link: link_name.to_string(),
                uri: mesh.filename.clone(),
                problem,
                message,
            }),
        }
    }
    let split: Vec<&MeshShapes> = found.iter().filter(|f| f.2).map(|f| &f.1).collect();
    decompose_all(&split);
    for (mesh, shapes, split) in found {
        let parts = if split {
            shapes.convex_parts()
        } else {
            Arc::from([])
        };
        let shape = if parts.is_empty() {
            shapes.hull
        } else {
            SharedShape::compound(parts.iter().map(|p| (Pose::IDENTITY, p.clone())).collect())
        };
        loaded.hulls.push(MeshHull {
            link: mesh.link,
            pose: pose_of(&mesh.origin),
            shape,
        });
    }
    loaded.seconds = started.elapsed().as_secs_f64();
    loaded
}

/// A collision mesh as the self-collision model uses it: its convex hull (the cheapest shape to
/// check), its own triangles (what is true, for proving a pair apart once) and, made when first
/// asked for, convex parts that follow its concave places (what is checked where the hull is
/// too coarse).
#[derive(Clone)]
pub struct MeshShapes {
    /// The convex hull of the mesh's vertices.
    pub hull: SharedShape,
    /// The mesh's triangles as a triangle mesh; `None` when the file has no usable triangles
    /// (then the hull stands for it).
    pub surface: Option<SharedShape>,
    /// The convex parts, decomposed once and shared by every clone.
    parts: Arc<OnceLock<Arc<[SharedShape]>>>,
}

/// Voxels along the longest side of a mesh's box when it is split into convex parts, and how
/// deep (a share of that side) a part's concave places may be: a coarse split, a few parts a
/// mesh, tight where a hull is not (a forearm's hull fills the bend of an elbow; its parts do
/// not). Each part is the hull of the mesh's own triangles within it (not of voxels), so the
/// parts hold the whole surface. Chosen on seven published robots (PR2, Fetch, Valkyrie, G1,
/// TIAGo Pro, ergoCub, iCub) for their retargeting on the shipped captured motion and its speed:
/// 32 voxels and 1 % cost 30–60 % more time for the same figures within 0.5°.
const DECOMPOSITION_RESOLUTION: u32 = 24;
/// See [`DECOMPOSITION_RESOLUTION`].
const DECOMPOSITION_CONCAVITY: Real = 0.03;

/// Splits every one of `meshes` into its convex parts (see [`MeshShapes::convex_parts`]) on
/// every core: tens of milliseconds a mesh, and a humanoid has dozens.
pub fn decompose_all(meshes: &[&MeshShapes]) {
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    std::thread::scope(|scope| {
        for t in 0..threads.min(meshes.len()) {
            scope.spawn(move || {
                for mesh in meshes.iter().skip(t).step_by(threads) {
                    mesh.convex_parts();
                }
            });
        }
    });
}

impl MeshShapes {
    /// A mesh's hull and triangles (no triangles: the hull stands for the mesh).
    pub fn new(hull: SharedShape, surface: Option<SharedShape>) -> MeshShapes {
        MeshShapes {
            hull,
            surface,
            parts: Arc::default(),
        }
    }

    /// Convex parts whose union holds the mesh's surface, tighter than its hull where the mesh
    /// is concave (an approximate convex decomposition, V-HACD as parry has it; tens of
    /// milliseconds a mesh, the first time): empty when the mesh has no triangles or is one
    /// part, its hull.
    pub fn convex_parts(&self) -> Arc<[SharedShape]> {
        self.parts
            .get_or_init(|| {
                let Some(mesh) = self.surface.as_ref().and_then(|s| s.as_trimesh()) else {
                    return Arc::from([]);
                };
                let params = VHACDParameters {
                    resolution: DECOMPOSITION_RESOLUTION,
                    concavity: DECOMPOSITION_CONCAVITY,
                    ..VHACDParameters::default()
                };
                // Kept on disk between runs (`parts_cache`): the split is most of a start.
                let settings = format!("{DECOMPOSITION_RESOLUTION} {DECOMPOSITION_CONCAVITY}");
                let kept = parts_cache::folder().map(|dir| {
                    let key =
                        parts_cache::key(settings.as_bytes(), mesh.vertices(), mesh.indices());
                    (dir, key)
                });
                let points = match kept
                    .as_ref()
                    .and_then(|(dir, key)| parts_cache::read(dir, key))
                {
                    Some(points) => Ok(points),
                    None => crate::panics::catch(|| {
                        VHACD::decompose(&params, mesh.vertices(), mesh.indices(), true)
                            .compute_exact_convex_hulls(mesh.vertices(), mesh.indices())
                            .into_iter()
                            .map(|(points, _)| points)
                            .collect::<Vec<_>>()
                    })
                    .inspect(|points| {
                        if let Some((dir, key)) = &kept {
                            parts_cache::write(dir, key, points);
                        }
                    }),
                };
                let parts = points.map(|points| {
                    points
                        .iter()
                        .filter_map(|p| convex_hull(p))
                        .collect::<Vec<_>>()
                });
                match parts {
                    Ok(parts) if parts.len() > 1 => Arc::from(parts),
                    _ => Arc::from([]),
                }
            })
            .clone()
    }
}

/// The collision mesh `filename` (as the URDF names it) scaled by `scale`, found through
/// `search`, as its hull and its triangles; what went wrong, naming the file, when it cannot
/// be had.
pub fn mesh_shapes(
    search: &MeshSearch,
    filename: &str,
    scale: [f64; 3],
) -> Result<MeshShapes, String> {
    let path = search.resolve(filename).map_err(|miss| miss.to_string())?;
    let mesh_data = read_mesh(&path).map_err(|(_, message)| message)?;
    shapes_of(&mesh_data, scale).map_err(|why| format!("{}: {why}", path.display()))
}

/// A mesh's vertices and triangles scaled by `scale`, as its hull and triangle mesh, or why the
/// mesh is unusable.
fn shapes_of(mesh_data: &MeshData, scale: [f64; 3]) -> Result<MeshShapes, String> {
    let (vertices, triangles) = (&mesh_data.0, &mesh_data.1);
    let hull = hull_of(vertices, scale)?;
    // The hull has checked the scaled vertices (finite, within reach).
    let points: Vec<Vector> = vertices
        .iter()
        .map(|v| {
            Vector::new(
                (f64::from(v[0]) * scale[0]) as Real,
                (f64::from(v[1]) * scale[1]) as Real,
                (f64::from(v[2]) * scale[2]) as Real,
            )
        })
        .collect();
    let in_range = triangles
        .iter()
        .all(|t| t.iter().all(|&i| (i as usize) < points.len()));
    let surface = (in_range && !triangles.is_empty())
        .then(|| {
            crate::panics::catch(|| SharedShape::trimesh(points, triangles.clone()).ok())
                .ok()
                .flatten()
        })
        .flatten();
    Ok(MeshShapes::new(hull, surface))
}

/// A URDF `<origin>` as a rapier pose (`rpy` fixed-axis: `Rz(yaw) Ry(pitch) Rx(roll)`, as
/// rapier3d-urdf places primitives).
fn pose_of(origin: &urdf_rs::Pose) -> Pose {
    let (xyz, rpy) = (origin.xyz.0, origin.rpy.0);
    Pose::from_parts(
        Vector::new(xyz[0] as Real, xyz[1] as Real, xyz[2] as Real),
        Rotation::from_euler(
            EulerRot::ZYX,
            rpy[2] as Real,
            rpy[1] as Real,
            rpy[0] as Real,
        ),
    )
}

/// Every vertex and triangle of the mesh file `path`; the format is told by the extension
/// (`.stl`, `.dae`, `.obj`, any case), else by the content.
fn read_mesh(path: &Path) -> Result<MeshData, Failure> {
    let shown = path.display();
    let unreadable = |why: String| (MeshProblem::Unreadable, format!("{shown}: {why}"));
    let size = std::fs::metadata(path)
        .map_err(|e| unreadable(e.to_string()))?
        .len();
    if size > MAX_MESH_BYTES {
        return Err(unreadable(format!(
            "{size} bytes; expected a mesh file of at most {MAX_MESH_BYTES} bytes"
        )));
    }
    let bytes = std::fs::read(path).map_err(|e| unreadable(e.to_string()))?;
    if bytes.starts_with(GIT_LFS_POINTER) {
        return Err(unreadable(
            "a Git LFS pointer, not the mesh: the repository keeps its meshes in Git LFS (`git lfs pull` in the clone fetches them)".into(),
        ));
    }
    let extension = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let loader = mesh_loader::Loader::default();
    // The parsers are third-party code reading untrusted files: a panic is a malformed file.
    let parsed = crate::panics::catch(|| match extension.as_deref() {
        Some("stl") => loader.load_stl_from_slice(&bytes, path),
        Some("dae") => loader.load_collada_from_slice(&bytes, path),
        // Materials (.mtl) do not matter for collisions: none is read.
        Some("obj") => loader.load_obj_from_slice_with_reader(&bytes, path, |_| {
            Err(std::io::Error::from(std::io::ErrorKind::NotFound))
        }),
        _ => loader.load_from_slice(&bytes, path),
    });
    // A binary STL whose 80-byte header happens to begin with "solid" (as many exporters write
    // it) is taken for ASCII by the reader and fails; its size tells it apart (84 bytes and 50
    // a triangle), so it is read again with the header blanked.
    let parsed = match parsed {
        Ok(Err(_)) if is_binary_stl(&bytes) => {
            let mut blanked = bytes.clone();
            blanked[..80].fill(0);
            crate::panics::catch(|| loader.load_stl_from_slice(&blanked, path))
        }
        other => other,
    };
    let scene = match parsed {
        Ok(Ok(scene)) => scene,
        Ok(Err(e)) => {
            return Err(unreadable(format!(
                "{} (expected an STL, COLLADA or OBJ mesh)",
                crate::panics::one_line(&e.to_string())
            )))
        }
        Err(panic) => {
            return Err(unreadable(format!(
                "the mesh reader failed on it: {}",
                crate::panics::one_line(&panic)
            )))
        }
    };
    let mut vertices: Vec<[f32; 3]> = Vec::new();
    let mut triangles: Vec<[u32; 3]> = Vec::new();
    for mesh in &scene.meshes {
        let offset = vertices.len() as u32;
        vertices.extend(mesh.vertices.iter().copied());
        triangles.extend(
            mesh.faces
                .iter()
                .map(|f| f.map(|i| i.saturating_add(offset))),
        );
    }
    Ok(Arc::new((vertices, triangles)))
}

/// Whether `bytes` have the size of a binary STL: an 80-byte header, a little-endian triangle
/// count and 50 bytes a triangle.
fn is_binary_stl(bytes: &[u8]) -> bool {
    bytes.len() >= 84
        && bytes[80..84]
            .try_into()
            .map(u32::from_le_bytes)
            .is_ok_and(|n| bytes.len() as u64 == 84 + 50 * u64::from(n))
}

/// The convex hull of `vertices` scaled by `scale`, or why there is none.
fn hull_of(vertices: &[[f32; 3]], scale: [f64; 3]) -> Result<SharedShape, String> {
    if !scale
        .iter()
        .all(|s| s.is_finite() && *s != 0.0 && s.abs() <= MAX_LENGTH_M)
    {
        return Err(format!(
            "scale {scale:?}; expected non-zero factors of at most {MAX_LENGTH_M} in size"
        ));
    }
    if vertices.is_empty() {
        return Err("no vertices".into());
    }
    let mut points = Vec::with_capacity(vertices.len());
    for v in vertices {
        let p = [
            f64::from(v[0]) * scale[0],
            f64::from(v[1]) * scale[1],
            f64::from(v[2]) * scale[2],
        ];
        if !p.iter().all(|x| x.is_finite() && x.abs() <= MAX_LENGTH_M) {
            return Err(format!(
                "vertex {p:?} (scaled) is not finite or beyond {MAX_LENGTH_M} m"
            ));
        }
        points.push(Vector::new(p[0] as Real, p[1] as Real, p[2] as Real));
    }
    let span = bounding_diameter(&points);
    let hull = crate::panics::catch(|| {
        convex_hull(&points).map(|shape| {
            // parry returns a flat polyhedron for points in a plane: no solid.
            let volume = shape.mass_properties(1.0).mass();
            (shape, volume)
        })
    });
    match hull {
        Ok(Some((shape, volume))) if volume.is_finite() && volume > 1e-9 * span.powi(3) => {
            Ok(shape)
        }
        Ok(Some(_)) => Err(format!(
            "its {} vertices span no volume (all in a plane or a line); expected a solid",
            points.len()
        )),
        Ok(None) => Err(format!(
            "no convex hull could be made of its {} vertices (parry's quickhull gave none)",
            points.len()
        )),
        Err(panic) => Err(format!(
            "the convex hull failed: {}",
            crate::panics::one_line(&panic)
        )),
    }
}

/// The convex hull of `points`, each distinct point once: parry's quickhull gives none for
/// a mesh whose triangles repeat their shared corners (ABB's YuMi `coarse/link_3.stl`: 23,424
/// vertices, 3,776 distinct), which every STL file does.
fn convex_hull(points: &[Vector]) -> Option<SharedShape> {
    let mut distinct = points.to_vec();
    distinct.sort_unstable_by(|a, b| {
        a.x.total_cmp(&b.x)
            .then(a.y.total_cmp(&b.y))
            .then(a.z.total_cmp(&b.z))
    });
    distinct.dedup();
    SharedShape::convex_hull(&distinct)
}

/// The diagonal of the points' bounding box.
fn bounding_diameter(points: &[Vector]) -> Real {
    let (mut lo, mut hi) = (Vector::splat(Real::MAX), Vector::splat(Real::MIN));
    for p in points {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    (hi - lo).length()
}
