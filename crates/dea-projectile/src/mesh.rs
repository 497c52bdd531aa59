//! 8-node hexahedral meshes: a generator, the outer surface as triangles with outward
//! normals (seed §4.2.1.3), its closure check, and HRZ lumped masses (seed 4-22 … 4-25).

use std::collections::HashMap;

use dea_core::Vec3;

/// Corner nodes of an 8-node hexahedron in VTK order: 0-3 counter-clockwise on the bottom
/// face (seen from above), 4-7 above them.
pub type Hex = [u32; 8];

/// The six faces of a hexahedron as local corners, ordered so that the right-hand normal
/// points out of the element.
pub(crate) const FACES: [[usize; 4]; 6] = [[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6], [3, 0, 4, 7]];

/// A mesh of 8-node hexahedra.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct HexMesh {
    /// node positions in the body frame [m]
    pub nodes: Vec<Vec3>,
    /// the hexahedra
    pub hexes: Vec<Hex>,
}

/// The outer surface: triangles of node indices, right-hand normal outward.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Surface {
    /// node indices of each triangle, counter-clockwise seen from outside
    pub triangles: Vec<[u32; 3]>,
}

/// Gauss points and weights of the 3-point rule on [-1, 1].
const GAUSS: [(f64, f64); 3] = [(-0.774_596_669_241_483_4, 5.0 / 9.0), (0.0, 8.0 / 9.0), (0.774_596_669_241_483_4, 5.0 / 9.0)];
/// Natural coordinates of the corners, VTK order.
pub(crate) const CORNERS: [[f64; 3]; 8] = [[-1.0, -1.0, -1.0], [1.0, -1.0, -1.0], [1.0, 1.0, -1.0], [-1.0, 1.0, -1.0], [-1.0, -1.0, 1.0], [1.0, -1.0, 1.0], [1.0, 1.0, 1.0], [-1.0, 1.0, 1.0]];

/// Trilinear shape functions, their gradients in natural coordinates and the Jacobian
/// `dx/d(r, s, t)` at natural point `(r, s, t)`.
pub(crate) fn trilinear(corners: &[Vec3; 8], r: f64, s: f64, t: f64) -> ([f64; 8], [Vec3; 8], nalgebra::Matrix3<f64>) {
    let (mut n, mut natural) = ([0.0; 8], [Vec3::zeros(); 8]);
    let mut jacobian = nalgebra::Matrix3::<f64>::zeros();
    for (k, c) in CORNERS.iter().enumerate() {
        let (a, b, d) = (1.0 + c[0] * r, 1.0 + c[1] * s, 1.0 + c[2] * t);
        n[k] = a * b * d / 8.0;
        natural[k] = Vec3::new(c[0] * b * d, c[1] * a * d, c[2] * a * b) / 8.0;
        jacobian += corners[k] * natural[k].transpose();
    }
    (n, natural, jacobian)
}

impl HexMesh {
    fn corners(&self, hex: &Hex) -> [Vec3; 8] {
        hex.map(|k| self.nodes[k as usize])
    }

    /// Volume of every element (3-point Gauss quadrature, exact for trilinear elements) [m^3].
    pub fn volumes(&self) -> Vec<f64> {
        self.hexes
            .iter()
            .map(|hex| {
                let corners = self.corners(hex);
                let mut volume = 0.0;
                for &(r, wr) in &GAUSS {
                    for &(s, ws) in &GAUSS {
                        for &(t, wt) in &GAUSS {
                            volume += wr * ws * wt * trilinear(&corners, r, s, t).2.determinant();
                        }
                    }
                }
                volume
            })
            .collect()
    }

    /// HRZ lumped nodal masses for density `density` [kg/m^3] (seed 4-22 … 4-25): the
    /// diagonal of each element's consistent mass matrix, scaled so the element's mass is
    /// kept, summed over the elements of each node [kg].
    pub fn hrz_masses(&self, density: f64) -> Vec<f64> {
        let mut masses = vec![0.0; self.nodes.len()];
        for hex in &self.hexes {
            let corners = self.corners(hex);
            let (mut diagonal, mut mass) = ([0.0; 8], 0.0);
            for &(r, wr) in &GAUSS {
                for &(s, ws) in &GAUSS {
                    for &(t, wt) in &GAUSS {
                        let (n, _, jacobian) = trilinear(&corners, r, s, t);
                        let det = jacobian.determinant();
                        let weight = density * wr * ws * wt * det;
                        mass += weight;
                        for k in 0..8 {
                            diagonal[k] += weight * n[k] * n[k];
                        }
                    }
                }
            }
            let scale = mass / diagonal.iter().sum::<f64>();
            for k in 0..8 {
                masses[hex[k] as usize] += scale * diagonal[k];
            }
        }
        masses
    }

    /// The faces no two elements share, split into two triangles each, normals outward.
    pub fn surface(&self) -> Surface {
        Surface { triangles: outer_triangles(&self.hexes, &[]) }
    }

    /// The outer surface with only the vertices it uses: positions and triangles.
    pub fn boundary(&self) -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let (vertices, _, triangles) = compact(&self.nodes, &self.surface().triangles);
        (vertices, triangles)
    }
}

/// The faces of hexahedra and tetrahedra that no two elements share, as triangles (a quad
/// split into two), right-hand normals out of their element; sorted, so the result does not
/// depend on hashing.
pub fn outer_triangles(hexes: &[Hex], tetrahedra: &[[u32; 4]]) -> Vec<[u32; 3]> {
    let mut count: HashMap<Vec<u32>, (usize, Vec<u32>)> = HashMap::new();
    let mut add = |face: Vec<u32>| {
        let mut key = face.clone();
        key.sort_unstable();
        count.entry(key).or_insert((0, face)).0 += 1;
    };
    for hex in hexes {
        for face in FACES {
            add(face.iter().map(|&k| hex[k]).collect());
        }
    }
    for tet in tetrahedra {
        for face in TETRAHEDRON_FACES {
            add(face.iter().map(|&k| tet[k]).collect());
        }
    }
    let mut faces: Vec<Vec<u32>> = count.into_values().filter(|(n, _)| *n == 1).map(|(_, face)| face).collect();
    faces.sort_unstable();
    faces.iter().flat_map(|f| if f.len() == 4 { vec![[f[0], f[1], f[2]], [f[0], f[2], f[3]]] } else { vec![[f[0], f[1], f[2]]] }).collect()
}

/// Faces of a tetrahedron whose corners 1, 2, 3 turn counter-clockwise seen from corner 0's
/// opposite side (positive volume), right-hand normals out.
const TETRAHEDRON_FACES: [[usize; 3]; 4] = [[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]];

/// Triangles over `nodes` renumbered onto the vertices they use, in order of first use:
/// the positions and the node of each vertex, and the renumbered triangles.
pub fn compact(nodes: &[Vec3], triangles: &[[u32; 3]]) -> (Vec<Vec3>, Vec<u32>, Vec<[u32; 3]>) {
    let mut index = vec![u32::MAX; nodes.len()];
    let mut vertices = Vec::new();
    let mut node_of_vertex = Vec::new();
    let triangles = triangles
        .iter()
        .map(|t| {
            t.map(|n| {
                if index[n as usize] == u32::MAX {
                    index[n as usize] = vertices.len() as u32;
                    vertices.push(nodes[n as usize]);
                    node_of_vertex.push(n);
                }
                index[n as usize]
            })
        })
        .collect();
    (vertices, node_of_vertex, triangles)
}

/// Nodes shared by position, the way block-structured generators join their blocks.
pub(crate) struct NodeSet {
    scale: f64,
    index: HashMap<(i64, i64, i64), u32>,
    pub(crate) nodes: Vec<Vec3>,
}

impl NodeSet {
    pub(crate) fn new(scale: f64) -> Self {
        Self { scale, index: HashMap::new(), nodes: Vec::new() }
    }

    pub(crate) fn node(&mut self, x: Vec3) -> u32 {
        let key = |v: f64| (v / self.scale * 1e9).round() as i64;
        let nodes = &mut self.nodes;
        *self.index.entry((key(x.x), key(x.y), key(x.z))).or_insert_with(|| {
            nodes.push(x);
            (nodes.len() - 1) as u32
        })
    }
}

impl HexMesh {
    /// A sphere of radius `radius` centred on the origin, as a cube-sphere O-grid: an inner
    /// cube of `core`^3 elements and six blocks of `radial` layers out to the surface, whose
    /// nodes lie on the sphere.
    pub fn sphere(radius: f64, core: usize, radial: usize) -> Self {
        let half = 0.35 * radius;
        let mut set = NodeSet::new(radius);
        let mut hexes: Vec<Hex> = Vec::new();
        let grid = |i: usize| -half + 2.0 * half * i as f64 / core as f64;
        let mut add = |set: &mut NodeSet, corners: [Vec3; 8]| {
            let hex = corners.map(|x| set.node(x));
            hexes.push(hex);
        };
        for i in 0..core {
            for j in 0..core {
                for k in 0..core {
                    let p = |a: usize, b: usize, c: usize| Vec3::new(grid(i + a), grid(j + b), grid(k + c));
                    add(&mut set, [p(0, 0, 0), p(1, 0, 0), p(1, 1, 0), p(0, 1, 0), p(0, 0, 1), p(1, 0, 1), p(1, 1, 1), p(0, 1, 1)]);
                }
            }
        }
        // six shell blocks: a cube face grid pushed out to the sphere layer by layer
        for axis in 0..3 {
            for sign in [-1.0, 1.0] {
                let point = |a: usize, b: usize, layer: usize| {
                    let mut q = Vec3::zeros();
                    q[axis] = sign * half;
                    q[(axis + 1) % 3] = grid(a);
                    q[(axis + 2) % 3] = grid(b);
                    let w = layer as f64 / radial as f64;
                    q + (q.normalize() * radius - q) * w
                };
                for a in 0..core {
                    for b in 0..core {
                        for layer in 0..radial {
                            let inner = [point(a, b, layer), point(a + 1, b, layer), point(a + 1, b + 1, layer), point(a, b + 1, layer)];
                            let outer = [point(a, b, layer + 1), point(a + 1, b, layer + 1), point(a + 1, b + 1, layer + 1), point(a, b + 1, layer + 1)];
                            // the base runs counter-clockwise seen from the outside on the
                            // positive faces; on the negative ones the layers swap places
                            let corners = if sign > 0.0 { [inner[0], inner[1], inner[2], inner[3], outer[0], outer[1], outer[2], outer[3]] } else { [outer[0], outer[1], outer[2], outer[3], inner[0], inner[1], inner[2], inner[3]] };
                            add(&mut set, corners);
                        }
                    }
                }
            }
        }
        Self { nodes: set.nodes, hexes }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use dea_core::surface::{check_closed, MassProperties};

    fn enclosed_volume(mesh: &HexMesh, surface: &Surface) -> f64 {
        MassProperties::of_surface(&mesh.nodes, &surface.triangles).volume
    }

    #[test]
    fn cylinder_volume_surface_and_orientation_are_exact() {
        let (radius, height) = (1.7e-3, 3.7e-3);
        for (core, radial, layers) in [(2, 1, 1), (4, 3, 5), (8, 4, 6)] {
            let mesh = HexMesh::cylinder(radius, height, core, radial, layers);
            // the rim is a regular polygon of 4 core vertices: its area times the height
            let sides = 4.0 * core as f64;
            let polygon = 0.5 * sides * radius * radius * (std::f64::consts::TAU / sides).sin();
            let volumes = mesh.volumes();
            assert!(volumes.iter().all(|&v| v > 0.0), "every element has positive volume");
            let volume: f64 = volumes.iter().sum();
            assert!((volume - polygon * height).abs() < 1e-12 * volume, "{volume} vs {}", polygon * height);
            let surface = mesh.surface();
            assert_eq!(check_closed(&surface.triangles), Ok(()));
            assert!((enclosed_volume(&mesh, &surface) - volume).abs() < 1e-12 * volume, "normals point out");
            // a hole makes it open
            let mut open = surface.clone();
            open.triangles.pop();
            assert!(check_closed(&open.triangles).is_err());
        }
    }

    #[test]
    fn sphere_is_closed_lies_on_its_radius_and_converges_in_volume() {
        let radius: f64 = 2.78e-3;
        let exact = 4.0 / 3.0 * std::f64::consts::PI * radius.powi(3);
        let mut previous_error = f64::INFINITY;
        for (core, radial) in [(2, 2), (4, 3), (8, 5)] {
            let mesh = HexMesh::sphere(radius, core, radial);
            let volumes = mesh.volumes();
            assert!(volumes.iter().all(|&v| v > 0.0), "every element has positive volume ({core}, {radial})");
            let surface = mesh.surface();
            assert_eq!(check_closed(&surface.triangles), Ok(()));
            let volume: f64 = volumes.iter().sum();
            assert!((enclosed_volume(&mesh, &surface) - volume).abs() < 1e-12 * volume, "normals point out");
            for t in &surface.triangles {
                for &n in t {
                    assert!((mesh.nodes[n as usize].norm() - radius).abs() < 1e-12 * radius, "surface nodes lie on the sphere");
                }
            }
            // an inscribed polyhedron: a little small, and closer with every refinement
            let error = (exact - volume) / exact;
            assert!(error > 0.0 && error < previous_error, "{core}: {error}");
            previous_error = error;
        }
        // 384 faces of a cube-sphere: within 2 %, the deficit of an inscribed polyhedron
        assert!(previous_error < 0.02, "{previous_error}");
    }

    #[test]
    fn tetrahedra_and_hexahedra_share_one_outer_surface() {
        // a unit cube as one hexahedron, and as five tetrahedra (positive volume each)
        let cube = HexMesh { nodes: CORNERS.iter().map(|c| Vec3::new(c[0], c[1], c[2]) * 0.5).collect(), hexes: vec![[0, 1, 2, 3, 4, 5, 6, 7]] };
        let tetrahedra = [[0, 1, 3, 4], [1, 2, 3, 6], [1, 3, 4, 6], [1, 5, 6, 4], [3, 4, 6, 7]];
        for t in &tetrahedra {
            let [a, b, c, d] = t.map(|k| cube.nodes[k as usize]);
            assert!((b - a).cross(&(c - a)).dot(&(d - a)) > 0.0, "{t:?} is positive");
        }
        for triangles in [outer_triangles(&cube.hexes, &[]), outer_triangles(&[], &tetrahedra)] {
            assert_eq!(check_closed(&triangles), Ok(()));
            assert!((MassProperties::of_surface(&cube.nodes, &triangles).volume - 1.0).abs() < 1e-15);
        }
        assert_eq!(outer_triangles(&[], &tetrahedra).len(), 12, "inner faces cancel");
        // compacting drops the unused nodes and keeps the shape
        let mut padded = cube.clone();
        padded.nodes.insert(0, Vec3::new(9.0, 9.0, 9.0));
        padded.hexes[0] = padded.hexes[0].map(|n| n + 1);
        let (vertices, triangles) = padded.boundary();
        assert_eq!(vertices.len(), 8);
        assert!((MassProperties::of_surface(&vertices, &triangles).volume - 1.0).abs() < 1e-15);
    }

    #[test]
    fn hrz_masses_keep_the_element_mass_and_split_a_brick_evenly() {
        let density = 7850.0;
        let mesh = HexMesh::cylinder(2e-3, 1e-3, 3, 2, 2);
        let masses = mesh.hrz_masses(density);
        let total: f64 = masses.iter().sum();
        let volume: f64 = mesh.volumes().iter().sum();
        assert!((total - density * volume).abs() < 1e-12 * total);
        assert!(masses.iter().all(|&m| m > 0.0));
        // a rectangular brick: eight equal corners
        let brick = HexMesh {
            nodes: CORNERS.iter().map(|c| Vec3::new(c[0] * 1.0, c[1] * 2.0, c[2] * 0.5)).collect(),
            hexes: vec![[0, 1, 2, 3, 4, 5, 6, 7]],
        };
        let masses = brick.hrz_masses(1.0);
        // volume 2 x 4 x 1 = 8 at unit density: one each
        assert!(masses.iter().all(|&m| (m - 1.0).abs() < 1e-12), "{masses:?}");
    }
}
