//! Which pairs of a robot's links are never checked against each other, one rule for
//! retargeting's collision model and the physics replay: neighbours in the tree
//! ([`neighbour_matrix`]) and the model's own closeness at rest ([`own_closeness`]).

/// Link `link`'s chain up to its root, itself first (`parent_of`: each link's parent joint
/// and link).
fn chain(parent_of: &[Option<(usize, usize)>], link: usize) -> Vec<usize> {
    let mut chain = vec![link];
    while let Some((_, parent)) = parent_of[*chain.last().unwrap_or(&link)] {
        chain.push(parent);
    }
    chain
}

/// The tree path between two links of chains `ca` and `cb` ([`chain`]): the links strictly
/// between and the links below their lowest common ancestor (each the child of one joint on
/// the path); `None` for links of different trees.
fn tree_path(ca: &[usize], cb: &[usize]) -> Option<(Vec<usize>, Vec<usize>)> {
    let (ia, ib) = ca
        .iter()
        .enumerate()
        .find_map(|(ia, l)| cb.iter().position(|m| m == l).map(|ib| (ia, ib)))?;
    let mut between: Vec<usize> = ca.get(1..ia).unwrap_or(&[]).to_vec();
    between.extend_from_slice(cb.get(1..ib).unwrap_or(&[]));
    if ia > 0 && ib > 0 {
        between.push(ca[ia]);
    }
    let below = ca[..ia].iter().chain(&cb[..ib]).copied().collect();
    Some((between, below))
}

/// Which pairs of links are neighbours, never checked against each other (`n × n`, row-major):
/// links whose tree path holds at most one movable joint (links joined by fixed joints are one
/// body, as in MoveIt's adjacent pairs), or whose links strictly between have no shape.
/// `parent_of` gives each link's parent joint and link, `movable` whether a joint moves.
pub(crate) fn neighbour_matrix(
    parent_of: &[Option<(usize, usize)>],
    movable: impl Fn(usize) -> bool,
    has_shape: &[bool],
) -> Vec<bool> {
    let n = parent_of.len();
    let chains: Vec<Vec<usize>> = (0..n).map(|l| chain(parent_of, l)).collect();
    let mut matrix = vec![false; n * n];
    for a in 0..n {
        matrix[a * n + a] = true;
        for b in (a + 1)..n {
            let Some((between, below)) = tree_path(&chains[a], &chains[b]) else {
                continue; // different trees: not neighbours
            };
            let shapeless_between = between.iter().all(|&l| !has_shape[l]);
            let moving = below
                .iter()
                .filter(|&&l| parent_of[l].is_some_and(|(j, _)| movable(j)))
                .count();
            if shapeless_between || moving <= 1 {
                matrix[a * n + b] = true;
                matrix[b * n + a] = true;
            }
        }
    }
    matrix
}

/// Whether links `a` and `b`, their shapes `distance` apart at rest, are the model's own
/// closeness, never checked: touching there (within [`TOUCHING_M`]), or nearer than [`DESIGNED_CLEARANCE_M`] with
/// at most [`DESIGNED_CLEARANCE_JOINTS`] movable joints between them (a joint's housing next
/// to the next link's, a clearance the joints keep and approximate shapes cannot tell). The
/// one rule of retargeting's collision model and the physics replay.
pub(crate) fn own_closeness(
    parent_of: &[Option<(usize, usize)>],
    movable: impl Fn(usize) -> bool,
    (a, b): (usize, usize),
    distance: f64,
) -> bool {
    if distance <= TOUCHING_M {
        return true;
    }
    if distance >= DESIGNED_CLEARANCE_M {
        return false;
    }
    tree_path(&chain(parent_of, a), &chain(parent_of, b)).is_some_and(|(_, below)| {
        below
            .iter()
            .filter(|&&l| parent_of[l].is_some_and(|(j, _)| movable(j)))
            .count()
            <= DESIGNED_CLEARANCE_JOINTS
    })
}

/// Two shapes this near at rest touch, as far as convex parts in single precision tell, metres:
/// Galbot's wrist camera, whose own collision meshes cross its forearm's by 1–4 mm at rest
/// (three wrist joints between), measured 0.5 mm apart on the parts and then held the arm
/// still wherever the wrist turned.
pub(crate) const TOUCHING_M: f64 = 0.001;

/// Below this distance at rest, two links at most [`DESIGNED_CLEARANCE_JOINTS`] apart are the
/// model's own closeness, metres.
pub(crate) const DESIGNED_CLEARANCE_M: f64 = 0.01;

/// At most this many movable joints between two links near at rest make their closeness the
/// model's own ([`own_closeness`]).
const DESIGNED_CLEARANCE_JOINTS: usize = 2;
