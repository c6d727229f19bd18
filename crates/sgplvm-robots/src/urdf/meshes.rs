//! Finding the mesh files a URDF names ([`MeshSearch`]). Published robot descriptions refer to
//! their meshes as paths relative to the URDF file (`meshes/arm.stl`), absolute paths,
//! `file://` URIs, or `package://PKG/rest` — a path inside a ROS package, which ROS tools find
//! through `ROS_PACKAGE_PATH` (ROS 1) or `AMENT_PREFIX_PATH` (ROS 2). A search resolves all
//! four without ROS installed:
//!
//! | URI | where it is looked for |
//! |---|---|
//! | `meshes/arm.stl` | the URDF file's directory |
//! | `/abs/arm.stl`, `file:///abs/arm.stl` | there |
//! | `package://PKG/meshes/arm.stl` (`package:///PKG/…` alike) | for every package path and `ROS_PACKAGE_PATH` entry `DIR`, in order: `DIR` itself when it is `PKG`'s folder, `DIR/PKG`, then `PKG`'s folder up to [`PACKAGE_SEARCH_DEPTH`] levels below `DIR`; then `PREFIX/share/PKG` for every `AMENT_PREFIX_PATH` entry; last, an ancestor of the URDF's directory that is `PKG`'s folder, or a folder `PKG` beside one (up to [`ANCESTOR_LEVELS`] levels up). A package's folder is named `PKG` or, as ROS finds packages whatever their folder's name, holds a `package.xml` whose `<name>` is `PKG` |
//!
//! A URI that cannot be resolved gives a [`MeshMiss`] saying what was tried. Nothing here
//! reads a mesh: that is the caller's business (the physics replay builds convex hulls, the
//! scene writer hands Foxglove `file://` URIs).
//!
//! # Example
//! ```
//! use sgplvm_robots::urdf::MeshSearch;
//!
//! let dir = std::env::temp_dir().join(format!("sgplvm-doc-meshes-{}", std::process::id()));
//! std::fs::create_dir_all(dir.join("share/my_robot/meshes")).unwrap();
//! std::fs::write(dir.join("share/my_robot/meshes/arm.stl"), "solid arm\nendsolid arm\n").unwrap();
//! let search = MeshSearch::new().with_package_path(dir.join("share"));
//! let found = search.resolve("package://my_robot/meshes/arm.stl").unwrap();
//! assert!(found.ends_with("share/my_robot/meshes/arm.stl"));
//! assert!(search.resolve("package://other_robot/arm.stl").is_err());
//! # std::fs::remove_dir_all(&dir).unwrap();
//! ```

use std::ffi::OsStr;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// How many folder levels below a package path (or `ROS_PACKAGE_PATH` entry) are searched for
/// a package folder: a catkin workspace's `src/` holds packages one or two levels down.
pub const PACKAGE_SEARCH_DEPTH: usize = 3;

/// At most this many folders are looked into by one package search, so that a package path
/// pointing at `/` or a home folder costs milliseconds, not minutes.
const MAX_FOLDERS_SEARCHED: usize = 4096;

/// Where the mesh files a URDF names are looked for: the URDF file's directory, explicit
/// package paths and the ROS environment, in this order:
///
/// | URI | where it is looked for |
/// |---|---|
/// | `meshes/arm.stl` | the URDF file's directory |
/// | `/abs/arm.stl`, `file:///abs/arm.stl` | there |
/// | `package://PKG/meshes/arm.stl` | for every package path and `ROS_PACKAGE_PATH` entry `DIR`, in order: `DIR` itself when it is `PKG`'s folder, `DIR/PKG`, then `PKG`'s folder up to [`PACKAGE_SEARCH_DEPTH`] levels below `DIR`; then `PREFIX/share/PKG` for every `AMENT_PREFIX_PATH` entry; last, the URDF directory's ancestors (one that is `PKG`'s folder, or `PKG` beside one). A package's folder is named `PKG` or holds a `package.xml` whose `<name>` is `PKG` |
///
/// The default search knows no directory: it resolves absolute paths and `file://` URIs only.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct MeshSearch {
    /// Directory relative mesh paths are resolved against (the URDF file's).
    urdf_dir: Option<PathBuf>,
    /// Folders holding packages (or packages themselves), searched first, in order.
    package_paths: Vec<PathBuf>,
    /// `ROS_PACKAGE_PATH` entries, searched like `package_paths`, after them.
    ros_package_path: Vec<PathBuf>,
    /// `AMENT_PREFIX_PATH` entries: packages are `PREFIX/share/PKG`.
    ament_prefix_path: Vec<PathBuf>,
}

/// Why a mesh URI could not be resolved, with what was tried.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum MeshMiss {
    /// The URI names a file where it was looked for, but there is none.
    #[error("mesh \"{uri}\" not found; tried {}", paths(tried))]
    NotFound {
        /// The URI as the URDF gives it.
        uri: String,
        /// Every file path tried, in order.
        tried: Vec<PathBuf>,
    },
    /// A `package://` URI whose package is in none of the search paths.
    #[error(
        "mesh \"{uri}\": package \"{package}\" not found {}",
        if searched.is_empty() {
            "(no package path given: use --package-path DIR, ROS_PACKAGE_PATH or AMENT_PREFIX_PATH)".to_string()
        } else {
            format!("in {}", paths(searched))
        }
    )]
    PackageNotFound {
        /// The URI as the URDF gives it.
        uri: String,
        /// The package's name.
        package: String,
        /// The package paths and prefixes searched, in order.
        searched: Vec<PathBuf>,
    },
    /// A relative path, and no URDF directory to resolve it against (a built-in robot, or one
    /// read from text).
    #[error("mesh \"{uri}\" is a relative path and the URDF file's directory is not known")]
    NoUrdfDirectory {
        /// The URI as the URDF gives it.
        uri: String,
    },
    /// A URI scheme other than `file://` and `package://` (e.g. Gazebo's `model://`).
    #[error("mesh \"{uri}\": URI scheme \"{scheme}\" is not supported; expected a path, file:// or package://")]
    UnsupportedScheme {
        /// The URI as the URDF gives it.
        uri: String,
        /// The scheme, without `://`.
        scheme: String,
    },
    /// The URI is empty, or a `package://` URI without package name or path.
    #[error("mesh \"{uri}\": {problem}")]
    Malformed {
        /// The URI as the URDF gives it.
        uri: String,
        /// What is wrong with it.
        problem: String,
    },
}

impl MeshMiss {
    /// The URI that could not be resolved.
    pub fn uri(&self) -> &str {
        match self {
            MeshMiss::NotFound { uri, .. }
            | MeshMiss::PackageNotFound { uri, .. }
            | MeshMiss::NoUrdfDirectory { uri }
            | MeshMiss::UnsupportedScheme { uri, .. }
            | MeshMiss::Malformed { uri, .. } => uri,
        }
    }
}

/// Up to eight paths, quoted and comma-separated, with the count of the others.
fn paths(list: &[PathBuf]) -> String {
    const SHOWN: usize = 8;
    let mut text = list
        .iter()
        .take(SHOWN)
        .map(|p| format!("\"{}\"", p.display()))
        .collect::<Vec<_>>()
        .join(", ");
    if list.len() > SHOWN {
        let _ = write!(text, " and {} more", list.len() - SHOWN);
    }
    text
}

/// How a mesh URI names its file.
enum Target<'a> {
    /// A path: absolute, or relative to the URDF's directory.
    Path(PathBuf),
    /// `package://package/rest`.
    Package { package: &'a str, rest: &'a str },
}

impl MeshSearch {
    /// A search that knows no directory: absolute paths and `file://` URIs only.
    pub fn new() -> Self {
        MeshSearch::default()
    }

    /// A search resolving relative paths against the directory of the URDF file `urdf`.
    pub fn for_urdf_file(urdf: &Path) -> Self {
        let dir = match urdf.parent() {
            Some(dir) if !dir.as_os_str().is_empty() => dir.to_path_buf(),
            _ => PathBuf::from("."),
        };
        MeshSearch::new().with_urdf_dir(dir)
    }

    /// The search for a robot loaded from a URDF file: beside that file
    /// ([`Robot::source`](super::Robot::source) taken as its path), then the ROS environment
    /// ([`MeshSearch::with_env`]). None for a built-in robot (`builtin:NAME`), which has no
    /// meshes.
    pub fn for_robot(robot: &super::Robot) -> Option<Self> {
        let source = robot.source();
        (!source.starts_with("builtin:"))
            .then(|| MeshSearch::for_urdf_file(Path::new(source)).with_env())
    }

    /// Resolves relative paths against `dir`.
    pub fn with_urdf_dir(mut self, dir: impl Into<PathBuf>) -> Self {
        self.urdf_dir = Some(dir.into());
        self
    }

    /// Adds a package path: a folder holding packages (`DIR/PKG`, or deeper) or a package
    /// folder itself. Package paths are searched in the order they were added, before the
    /// ROS environment.
    pub fn with_package_path(mut self, dir: impl Into<PathBuf>) -> Self {
        self.package_paths.push(dir.into());
        self
    }

    /// Adds the entries of a `ROS_PACKAGE_PATH` value (`:`-separated), searched like package
    /// paths, after them.
    pub fn with_ros_package_path(mut self, value: &OsStr) -> Self {
        self.ros_package_path
            .extend(std::env::split_paths(value).filter(|p| !p.as_os_str().is_empty()));
        self
    }

    /// Adds the entries of an `AMENT_PREFIX_PATH` value (`:`-separated): package `PKG` is
    /// `PREFIX/share/PKG`.
    pub fn with_ament_prefix_path(mut self, value: &OsStr) -> Self {
        self.ament_prefix_path
            .extend(std::env::split_paths(value).filter(|p| !p.as_os_str().is_empty()));
        self
    }

    /// Adds `ROS_PACKAGE_PATH` and `AMENT_PREFIX_PATH` from the environment, where set.
    pub fn with_env(self) -> Self {
        let mut search = self;
        if let Some(value) = std::env::var_os("ROS_PACKAGE_PATH") {
            search = search.with_ros_package_path(&value);
        }
        if let Some(value) = std::env::var_os("AMENT_PREFIX_PATH") {
            search = search.with_ament_prefix_path(&value);
        }
        search
    }

    /// The directory relative paths are resolved against, if known.
    pub fn urdf_dir(&self) -> Option<&Path> {
        self.urdf_dir.as_deref()
    }

    /// The file `uri` names, as an absolute path (symbolic links resolved), or what was tried.
    pub fn resolve(&self, uri: &str) -> Result<PathBuf, MeshMiss> {
        let found = match parse_uri(uri)? {
            Target::Path(path) => self.resolve_path(uri, path)?,
            Target::Package { package, rest } => self.resolve_package(uri, package, rest)?,
        };
        Ok(std::fs::canonicalize(&found)
            .or_else(|_| std::path::absolute(&found))
            .unwrap_or(found))
    }

    /// `uri` resolved, as an absolute `file://` URI (see [`file_uri`]).
    pub fn resolve_file_uri(&self, uri: &str) -> Result<String, MeshMiss> {
        self.resolve(uri).map(|p| file_uri(&p))
    }

    /// A path, absolute or relative to the URDF's directory.
    fn resolve_path(&self, uri: &str, path: PathBuf) -> Result<PathBuf, MeshMiss> {
        let full = if path.is_absolute() {
            path
        } else {
            match &self.urdf_dir {
                Some(dir) => dir.join(path),
                None => return Err(MeshMiss::NoUrdfDirectory { uri: uri.into() }),
            }
        };
        if full.is_file() {
            return Ok(full);
        }
        // An absolute path into an installed ROS package on the machine the file was made on
        // (Kinova's Gen3: `file:///root/…/install/kortex_description/share/kortex_description/
        // meshes/…`): looked for as `package://PKG/rest`, as the package it names.
        let mut tried = vec![full.clone()];
        if let Some((package, rest)) = installed_package(&full) {
            match self.resolve_package(uri, &package, &rest) {
                Ok(found) => return Ok(found),
                Err(MeshMiss::NotFound { tried: more, .. }) => tried.extend(more),
                Err(_) => {}
            }
        }
        Err(MeshMiss::NotFound {
            uri: uri.into(),
            tried,
        })
    }

    /// `rest` inside the first folder of `package` that holds it.
    fn resolve_package(&self, uri: &str, package: &str, rest: &str) -> Result<PathBuf, MeshMiss> {
        let mut tried = Vec::new();
        let mut searched = Vec::new();
        let roots = self.package_paths.iter().chain(&self.ros_package_path);
        for root in roots {
            searched.push(root.clone());
            for dir in package_dirs(root, package) {
                let file = dir.join(rest);
                if file.is_file() {
                    return Ok(file);
                }
                tried.push(file);
            }
        }
        for prefix in &self.ament_prefix_path {
            let dir = prefix.join("share").join(package);
            searched.push(prefix.clone());
            if dir.is_dir() {
                let file = dir.join(rest);
                if file.is_file() {
                    return Ok(file);
                }
                tried.push(file);
            }
        }
        // Last, as urdf-viz and yourdfpy do: the URDF inside its own package
        // (`PKG/urdf/robot.urdf`), or beside it (`DIR/urdf/robot.urdf` and `DIR/PKG`), so that
        // a description as published finds its meshes with no flag and no ROS environment.
        for dir in self.package_ancestors(package) {
            searched.push(dir.clone());
            let file = dir.join(rest);
            if file.is_file() {
                return Ok(file);
            }
            tried.push(file);
        }
        // The same folder found twice (a package path that is the URDF's own package).
        let mut seen = std::collections::HashSet::new();
        tried.retain(|f| seen.insert(f.clone()));
        if tried.is_empty() {
            Err(MeshMiss::PackageNotFound {
                uri: uri.into(),
                package: package.into(),
                searched,
            })
        } else {
            Err(MeshMiss::NotFound {
                uri: uri.into(),
                tried,
            })
        }
    }
}

/// The package and the path inside it of an absolute path into an installed ROS package
/// (`…/share/PKG/rest`, the last `share` folder), if it is one.
fn installed_package(path: &Path) -> Option<(String, String)> {
    let parts: Vec<&str> = path.iter().filter_map(|c| c.to_str()).collect();
    let share = parts.iter().rposition(|&c| c == "share")?;
    let package = parts.get(share + 1)?;
    let rest = parts.get(share + 2..).filter(|r| !r.is_empty())?;
    Some(((*package).to_string(), rest.join("/")))
}

impl MeshSearch {
    /// Folders of `package` among the URDF directory's ancestors: an ancestor that is
    /// `package`'s folder ([`is_package`]), or a folder `package` beside one, up to
    /// [`ANCESTOR_LEVELS`] levels up.
    fn package_ancestors(&self, package: &str) -> Vec<PathBuf> {
        let Some(dir) = &self.urdf_dir else {
            return Vec::new();
        };
        let dir = std::fs::canonicalize(dir).unwrap_or_else(|_| dir.clone());
        let mut found = Vec::new();
        for anc in dir.ancestors().take(ANCESTOR_LEVELS) {
            if is_package(anc, package) {
                found.push(anc.to_path_buf());
            }
            let beside = anc.join(package);
            if beside.is_dir() && !found.contains(&beside) {
                found.push(beside);
            }
        }
        found
    }
}

/// How many of the URDF directory's ancestors (itself included) are searched for a
/// `package://` package when no package path holds it.
pub const ANCESTOR_LEVELS: usize = 6;

/// What `uri` names: a path (from a plain path or a `file://` URI) or a package file.
fn parse_uri(uri: &str) -> Result<Target<'_>, MeshMiss> {
    let malformed = |problem: &str| MeshMiss::Malformed {
        uri: uri.into(),
        problem: problem.into(),
    };
    if uri.trim().is_empty() {
        return Err(malformed("empty file name; expected a mesh path or URI"));
    }
    let Some((scheme, rest)) = uri.split_once("://") else {
        return Ok(Target::Path(PathBuf::from(uri)));
    };
    let is_scheme = !scheme.is_empty()
        && scheme
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '+' | '-' | '.'));
    if !is_scheme {
        return Ok(Target::Path(PathBuf::from(uri)));
    }
    match scheme.to_ascii_lowercase().as_str() {
        "file" => {
            // file:///abs, file://localhost/abs; anything else is taken as a path (ROS's
            // resource_retriever does the same with file://relative).
            let path = rest.strip_prefix("localhost").unwrap_or(rest);
            let decoded =
                percent_decode(path).ok_or_else(|| malformed("bad %-escape in the file:// URI"))?;
            if decoded.is_empty() {
                return Err(malformed("file:// without a path"));
            }
            Ok(Target::Path(PathBuf::from(decoded)))
        }
        "package" => {
            // `package:///PKG/rest` (example-robot-data's TALOS) is read as Pinocchio reads it,
            // the path under a package folder: `package://PKG/rest`.
            let rest = rest.trim_start_matches('/');
            let (package, rest) = rest.split_once('/').unwrap_or((rest, ""));
            let rest = rest.trim_start_matches('/');
            if package.is_empty() || rest.is_empty() {
                return Err(malformed(
                    "expected package://PACKAGE/path/to/file with a package name and a path",
                ));
            }
            Ok(Target::Package { package, rest })
        }
        _ => Err(MeshMiss::UnsupportedScheme {
            uri: uri.into(),
            scheme: scheme.into(),
        }),
    }
}

/// The folders of `package` under `root`, in the order they are tried: `root` itself when it
/// is the package's folder ([`is_package`]), `root/package`, then package folders found by a
/// shallow search.
fn package_dirs(root: &Path, package: &str) -> Vec<PathBuf> {
    let mut dirs = Vec::new();
    if is_package(root, package) {
        dirs.push(root.to_path_buf());
    }
    let direct = root.join(package);
    if direct.is_dir() {
        dirs.push(direct);
    }
    for found in shallow_search(root, package) {
        if !dirs.contains(&found) {
            dirs.push(found);
        }
    }
    dirs
}

/// Whether `dir` is the folder of `package`: named so, or (as ROS finds packages, whatever
/// their folder's name) holding a `package.xml` whose `<name>` is `package`.
fn is_package(dir: &Path, package: &str) -> bool {
    dir.is_dir()
        && (dir.file_name() == Some(OsStr::new(package))
            || package_xml_name(dir).as_deref() == Some(package))
}

/// The `<name>` a folder's `package.xml` gives its package, if it has one that says.
fn package_xml_name(dir: &Path) -> Option<String> {
    let text = std::fs::read_to_string(dir.join("package.xml")).ok()?;
    let doc = roxmltree::Document::parse(&text).ok()?;
    let name = doc
        .root_element()
        .children()
        .find(|n| n.has_tag_name("name"))?
        .text()?
        .trim()
        .to_string();
    (!name.is_empty()).then_some(name)
}

/// Package folders (holding a `package.xml`, named `package` or whose `package.xml` names it)
/// at most [`PACKAGE_SEARCH_DEPTH`] levels below `root` (breadth first, names sorted, hidden
/// folders skipped).
fn shallow_search(root: &Path, package: &str) -> Vec<PathBuf> {
    let mut found = Vec::new();
    let mut level = vec![root.to_path_buf()];
    let mut visited = 0usize;
    for _ in 0..PACKAGE_SEARCH_DEPTH {
        let mut next = Vec::new();
        for dir in &level {
            visited += 1;
            if visited > MAX_FOLDERS_SEARCHED {
                return found;
            }
            let Ok(entries) = std::fs::read_dir(dir) else {
                continue;
            };
            let mut children: Vec<PathBuf> = entries
                .filter_map(|e| e.ok())
                .filter(|e| e.file_type().is_ok_and(|t| t.is_dir() || t.is_symlink()))
                .filter(|e| !e.file_name().to_string_lossy().starts_with('.'))
                .map(|e| e.path())
                .filter(|p| p.is_dir())
                .collect();
            children.sort();
            for child in children {
                if child.join("package.xml").is_file() && is_package(&child, package) {
                    found.push(child.clone());
                }
                next.push(child);
            }
        }
        level = next;
    }
    found
}

/// Decodes `%XX` escapes; None for a bad escape or bytes that are not UTF-8.
fn percent_decode(text: &str) -> Option<String> {
    let bytes = text.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let hex = std::str::from_utf8(bytes.get(i + 1..i + 3)?).ok()?;
            out.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}

/// The `file://` URI of the absolute path `path`: `file:///dir/a%20b.stl` (bytes other than
/// letters, digits, `-._~/` are %-escaped).
pub fn file_uri(path: &Path) -> String {
    let text = path.to_string_lossy();
    let mut uri = String::with_capacity(text.len() + 8);
    uri.push_str("file://");
    if !text.starts_with('/') {
        uri.push('/');
    }
    for b in text.bytes() {
        if b.is_ascii_alphanumeric() || matches!(b, b'-' | b'.' | b'_' | b'~' | b'/') {
            uri.push(b as char);
        } else {
            let _ = write!(uri, "%{b:02X}");
        }
    }
    uri
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicUsize, Ordering};

    /// A fresh, empty temporary folder.
    fn scratch(tag: &str) -> PathBuf {
        static N: AtomicUsize = AtomicUsize::new(0);
        let n = N.fetch_add(1, Ordering::Relaxed);
        let dir =
            std::env::temp_dir().join(format!("sgplvm-meshes-{tag}-{}-{n}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir.canonicalize().unwrap()
    }

    fn touch(path: &Path) {
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, b"solid x\nendsolid x\n").unwrap();
    }

    #[test]
    fn relative_absolute_and_file_uris() {
        let dir = scratch("paths");
        touch(&dir.join("robot/meshes/arm.stl"));
        touch(&dir.join("with space/hand.stl"));
        let search = MeshSearch::for_urdf_file(&dir.join("robot/robot.urdf"));
        let arm = dir.join("robot/meshes/arm.stl");
        assert_eq!(search.resolve("meshes/arm.stl").unwrap(), arm);
        assert_eq!(search.resolve(arm.to_str().unwrap()).unwrap(), arm);
        let uri = file_uri(&arm);
        assert!(uri.starts_with("file:///"), "{uri}");
        assert_eq!(search.resolve(&uri).unwrap(), arm);
        let hand = dir.join("with space/hand.stl");
        let hand_uri = file_uri(&hand);
        assert!(hand_uri.contains("with%20space"), "{hand_uri}");
        assert_eq!(search.resolve(&hand_uri).unwrap(), hand);
        let localhost = format!("file://localhost{}", arm.display());
        assert_eq!(search.resolve(&localhost).unwrap(), arm);
        // A miss says where it looked.
        match search.resolve("meshes/leg.stl") {
            Err(MeshMiss::NotFound { tried, .. }) => {
                assert_eq!(tried, vec![dir.join("robot/meshes/leg.stl")])
            }
            other => panic!("{other:?}"),
        }
        // Without a URDF directory a relative path cannot be resolved.
        assert!(matches!(
            MeshSearch::new().resolve("meshes/arm.stl"),
            Err(MeshMiss::NoUrdfDirectory { .. })
        ));
        assert_eq!(MeshSearch::new().resolve(&uri).unwrap(), arm);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn an_absolute_path_into_another_machine_s_install_is_looked_for_as_its_package() {
        // Kinova's Gen3 as published: `file:///root/c3pzero_ws/install/kortex_description/
        // share/kortex_description/meshes/…`, the maker's build machine.
        let dir = scratch("installed");
        let urdf = dir.join("kortex_description/robots/gen3.urdf");
        touch(&urdf);
        touch(&dir.join("kortex_description/package.xml"));
        let mesh = dir.join("kortex_description/meshes/arms/gen3/base_link.STL");
        touch(&mesh);
        let uri = "file:///root/ws/install/kortex_description/share/kortex_description/meshes/arms/gen3/base_link.STL";
        let search = MeshSearch::for_urdf_file(&urdf);
        assert_eq!(search.resolve(uri).unwrap(), mesh);
        // Not there either: every place tried is named, the path as given first.
        let gone = uri.replace("base_link", "shoulder_link");
        match search.resolve(&gone) {
            Err(MeshMiss::NotFound { tried, .. }) => {
                assert_eq!(tried[0], Path::new(&gone["file://".len()..]));
                assert!(
                    tried.contains(&mesh.with_file_name("shoulder_link.STL")),
                    "{tried:?}"
                );
            }
            other => panic!("{other:?}"),
        }
        assert_eq!(installed_package(Path::new("/opt/ros/share/pkg")), None);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn packages_from_package_paths_in_order() {
        let dir = scratch("packages");
        touch(&dir.join("first/robot_description/meshes/arm.stl"));
        touch(&dir.join("second/robot_description/meshes/arm.stl"));
        touch(&dir.join("second/robot_description/meshes/leg.stl"));
        let search = MeshSearch::new()
            .with_package_path(dir.join("first"))
            .with_package_path(dir.join("second"));
        let uri = "package://robot_description/meshes/arm.stl";
        assert_eq!(
            search.resolve(uri).unwrap(),
            dir.join("first/robot_description/meshes/arm.stl")
        );
        // Found in the second path when the first's package lacks the file.
        assert_eq!(
            search
                .resolve("package://robot_description/meshes/leg.stl")
                .unwrap(),
            dir.join("second/robot_description/meshes/leg.stl")
        );
        // Three slashes, as example-robot-data's TALOS writes them: the same file.
        assert_eq!(
            search
                .resolve("package:///robot_description/meshes/leg.stl")
                .unwrap(),
            dir.join("second/robot_description/meshes/leg.stl")
        );
        // A package path may be the package folder itself.
        let direct = MeshSearch::new().with_package_path(dir.join("second/robot_description"));
        assert_eq!(
            direct.resolve(uri).unwrap(),
            dir.join("second/robot_description/meshes/arm.stl")
        );
        match search.resolve("package://robot_description/meshes/head.stl") {
            Err(e @ MeshMiss::NotFound { .. }) => {
                let MeshMiss::NotFound { tried, .. } = &e else {
                    unreachable!()
                };
                assert_eq!(tried.len(), 2, "{e}");
                assert!(e.to_string().contains("head.stl"), "{e}");
            }
            other => panic!("{other:?}"),
        }
        match search.resolve("package://other/meshes/arm.stl") {
            Err(MeshMiss::PackageNotFound {
                package, searched, ..
            }) => {
                assert_eq!(package, "other");
                assert_eq!(searched.len(), 2);
            }
            other => panic!("{other:?}"),
        }
        let none = MeshSearch::new().resolve(uri).unwrap_err();
        assert!(none.to_string().contains("--package-path"), "{none}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_urdf_inside_its_package_finds_its_meshes_with_no_path_given() {
        let dir = scratch("inside");
        // PKG/urdf/robot.urdf and PKG/meshes/arm.stl, as description packages are published.
        touch(&dir.join("share/arm_description/meshes/arm.stl"));
        touch(&dir.join("share/other/meshes/leg.stl"));
        let search = MeshSearch::for_urdf_file(&dir.join("share/arm_description/urdf/robot.urdf"));
        let found = search
            .resolve("package://arm_description/meshes/arm.stl")
            .unwrap();
        assert!(
            found.ends_with("share/arm_description/meshes/arm.stl"),
            "{found:?}"
        );
        // A package beside an ancestor (share/other) is found too.
        assert!(search.resolve("package://other/meshes/leg.stl").is_ok());
        // A package that is nowhere near names what was searched.
        let e = search.resolve("package://nowhere/x.stl").unwrap_err();
        assert!(matches!(e, MeshMiss::PackageNotFound { .. }), "{e}");
        // Package paths come first.
        touch(&dir.join("first/arm_description/meshes/arm.stl"));
        let first = MeshSearch::for_urdf_file(&dir.join("share/arm_description/urdf/robot.urdf"))
            .with_package_path(dir.join("first"));
        assert!(first
            .resolve("package://arm_description/meshes/arm.stl")
            .unwrap()
            .starts_with(std::fs::canonicalize(dir.join("first")).unwrap()));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn ros_package_path_finds_nested_packages_with_package_xml() {
        let dir = scratch("ros");
        // A catkin workspace: src/<repository>/<package>/package.xml.
        let package = dir.join("ws/src/robots-repo/arm_description");
        touch(&package.join("meshes/arm.dae"));
        std::fs::write(package.join("package.xml"), "<package/>").unwrap();
        // A folder of the same name without package.xml is not a package.
        touch(&dir.join("ws/src/notes/arm_description/meshes/arm.dae"));
        let value = std::env::join_paths([dir.join("nowhere"), dir.join("ws/src")]).unwrap();
        let search = MeshSearch::new().with_ros_package_path(&value);
        assert_eq!(
            search
                .resolve("package://arm_description/meshes/arm.dae")
                .unwrap(),
            package.join("meshes/arm.dae")
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_package_is_found_by_its_package_xml_whatever_its_folder_s_name() {
        // As Galaxea publishes its R1: the package `r1_v2_1_0` in a folder `R1`.
        let dir = scratch("named");
        let package = dir.join("repo/R1");
        touch(&package.join("meshes/arm.STL"));
        std::fs::write(
            package.join("package.xml"),
            "<?xml version=\"1.0\"?>\n<package format=\"2\">\n  <name> r1_v2_1_0 </name>\n  <version>1.0.0</version>\n</package>\n",
        )
        .unwrap();
        let uri = "package://r1_v2_1_0/meshes/arm.STL";
        let want = std::fs::canonicalize(package.join("meshes/arm.STL")).unwrap();
        // The package folder itself, the folder holding it, or no path at all (the URDF inside).
        for search in [
            MeshSearch::new().with_package_path(&package),
            MeshSearch::new().with_package_path(dir.join("repo")),
            MeshSearch::for_urdf_file(&package.join("urdf/r1.urdf")),
        ] {
            assert_eq!(search.resolve(uri).unwrap(), want, "{search:?}");
        }
        // Another package's name is not this one.
        let other = MeshSearch::new().with_package_path(&package);
        assert!(other.resolve("package://r1_v2_2_0/meshes/arm.STL").is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn ament_prefix_path_is_prefix_share_package() {
        let dir = scratch("ament");
        touch(&dir.join("install/share/arm_description/meshes/arm.obj"));
        let value = std::env::join_paths([dir.join("opt"), dir.join("install")]).unwrap();
        let search = MeshSearch::new().with_ament_prefix_path(&value);
        assert_eq!(
            search
                .resolve("package://arm_description/meshes/arm.obj")
                .unwrap(),
            dir.join("install/share/arm_description/meshes/arm.obj")
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn unusable_uris_are_typed_misses() {
        let search = MeshSearch::new();
        assert!(matches!(
            search.resolve("model://robot/meshes/a.stl"),
            Err(MeshMiss::UnsupportedScheme { ref scheme, .. }) if scheme == "model"
        ));
        for uri in [
            "",
            "package://",
            "package://pkg",
            "package:///",
            "package:///pkg",
        ] {
            assert!(
                matches!(search.resolve(uri), Err(MeshMiss::Malformed { .. })),
                "{uri}"
            );
        }
        assert!(matches!(
            search.resolve("file:///bad%zzescape"),
            Err(MeshMiss::Malformed { .. })
        ));
        let miss = search.resolve("model://x/y.stl").unwrap_err();
        assert_eq!(miss.uri(), "model://x/y.stl");
    }
}
