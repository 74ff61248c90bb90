//! Small synthetic levels built in code, for tests, examples and benchmarks that must run without
//! any map file.

use sightline_formats::level::{Contents, Face, Leaf, Level, LevelPlane, Model, Node, Portal};
use sightline_formats::rle;

/// A level made of a grid of `dims` cubic cells of side `cell` units, starting at the origin.
/// `solid(x, y, z)` says which cells are rock. The tree splits the longest axis in the middle
/// until each leaf is one cell; every open cell is its own cluster, gets one wall face per side
/// that touches rock or the grid's border, and one portal per open neighbour. With `vis`, every
/// cluster's PVS row holds every cluster (a trivially conservative PVS).
pub fn grid_level(
    dims: [usize; 3],
    cell: f32,
    vis: bool,
    solid: impl Fn(usize, usize, usize) -> bool,
) -> Level {
    let mut level = Level { textures: vec!["wall".to_string()], ..Level::default() };
    let index = |x: usize, y: usize, z: usize| (z * dims[1] + y) * dims[0] + x;
    let count = dims[0] * dims[1] * dims[2];
    let is_solid: Vec<bool> =
        (0..count).map(|i| solid(i % dims[0], (i / dims[0]) % dims[1], i / (dims[0] * dims[1]))).collect();
    let mut cluster_of = vec![-1i32; count];
    let mut clusters = 0;
    for (i, s) in is_solid.iter().enumerate() {
        if !s {
            cluster_of[i] = clusters;
            clusters += 1;
        }
    }
    // Leaf i is cell i.
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                let i = index(x, y, z);
                let mins = [x as f32 * cell, y as f32 * cell, z as f32 * cell];
                let maxs = [mins[0] + cell, mins[1] + cell, mins[2] + cell];
                let first_face = level.leaf_faces.len() as u32;
                if !is_solid[i] {
                    for axis in 0..3 {
                        for dir in [-1i64, 1] {
                            let mut c = [x as i64, y as i64, z as i64];
                            c[axis] += dir;
                            let outside = c[axis] < 0 || c[axis] >= dims[axis] as i64;
                            if outside || is_solid[index(c[0] as usize, c[1] as usize, c[2] as usize)] {
                                let face = add_quad(&mut level, mins, maxs, axis, dir < 0);
                                level.faces.push(face);
                                level.leaf_faces.push(level.faces.len() as u32 - 1);
                            }
                        }
                    }
                }
                level.leaves.push(Leaf {
                    contents: if is_solid[i] { Contents::Solid } else { Contents::Empty },
                    cluster: cluster_of[i],
                    mins,
                    maxs,
                    first_face,
                    num_faces: level.leaf_faces.len() as u32 - first_face,
                });
            }
        }
    }
    // Portals between open neighbours: plane faces +axis, into the higher cell (leaves[0]).
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                let lo = index(x, y, z);
                for axis in 0..3 {
                    let mut c = [x, y, z];
                    c[axis] += 1;
                    if c[axis] >= dims[axis] {
                        continue;
                    }
                    let hi = index(c[0], c[1], c[2]);
                    if is_solid[lo] || is_solid[hi] {
                        continue;
                    }
                    let mins = [c[0] as f32 * cell, c[1] as f32 * cell, c[2] as f32 * cell];
                    let maxs = [mins[0] + cell, mins[1] + cell, mins[2] + cell];
                    let face = add_quad(&mut level, mins, maxs, axis, true);
                    level.portals.push(Portal {
                        leaves: [hi as u32, lo as u32],
                        plane: face.plane,
                        first_vertex: face.first_vertex,
                        num_vertices: 4,
                    });
                }
            }
        }
    }
    let root = build(&mut level, [0, 0, 0], dims, cell, &index);
    level.models.push(Model {
        head_node: root,
        mins: [0.0; 3],
        maxs: [dims[0] as f32 * cell, dims[1] as f32 * cell, dims[2] as f32 * cell],
        first_face: 0,
        num_faces: level.faces.len() as u32,
    });
    level.num_clusters = clusters as u32;
    if vis {
        let row = vec![0xffu8; level.row_bytes()];
        for _ in 0..clusters {
            level.pvs_offsets.push(level.pvs_data.len() as u32);
            rle::encode_row(&row, &mut level.pvs_data);
        }
    }
    level
}

/// A wall quad on the `low` (or high) side of the box along `axis`, facing into the box. Adds a
/// plane pair (index `2k` faces `+axis`, `2k + 1` is its flip) and the corners.
fn add_quad(level: &mut Level, mins: [f32; 3], maxs: [f32; 3], axis: usize, low: bool) -> Face {
    let coord = if low { mins[axis] } else { maxs[axis] };
    let mut normal = [0.0; 3];
    normal[axis] = 1.0;
    let plane = level.planes.len() as u32;
    level.planes.push(LevelPlane { normal, dist: coord });
    level.planes.push(LevelPlane { normal: normal.map(|v: f32| -v), dist: -coord });
    let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
    let first_vertex = level.vertices.len() as u32;
    for (a, b) in [(0, 0), (1, 0), (1, 1), (0, 1)] {
        let mut p = [0.0; 3];
        p[axis] = coord;
        p[u] = if a == 0 { mins[u] } else { maxs[u] };
        p[v] = if b == 0 { mins[v] } else { maxs[v] };
        level.vertices.push(p);
    }
    Face { plane: if low { plane } else { plane + 1 }, first_vertex, num_vertices: 4, texture: 0 }
}

/// Split the cell range `lo..hi` (per axis) into a subtree; returns its child code.
fn build(
    level: &mut Level,
    lo: [usize; 3],
    hi: [usize; 3],
    cell: f32,
    index: &dyn Fn(usize, usize, usize) -> usize,
) -> i32 {
    let size = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
    if size.iter().all(|&s| s == 1) {
        return -(index(lo[0], lo[1], lo[2]) as i32) - 1;
    }
    let axis = (0..3).max_by_key(|&a| (size[a], 3 - a)).unwrap_or(0);
    let mid = lo[axis] + size[axis] / 2;
    let mut normal = [0.0; 3];
    normal[axis] = 1.0;
    let plane = level.planes.len() as u32;
    level.planes.push(LevelPlane { normal, dist: mid as f32 * cell });
    let n = level.nodes.len();
    level.nodes.push(Node { plane, children: [0, 0], mins: [0.0; 3], maxs: [0.0; 3] });
    let mut front_lo = lo;
    front_lo[axis] = mid;
    let mut back_hi = hi;
    back_hi[axis] = mid;
    let front = build(level, front_lo, hi, cell, index);
    let back = build(level, lo, back_hi, cell, index);
    level.nodes[n].children = [front, back];
    let mins = lo.map(|v| v as f32 * cell);
    level.nodes[n].mins = mins;
    level.nodes[n].maxs = hi.map(|v| v as f32 * cell);
    n as i32
}
