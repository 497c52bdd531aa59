//! 8-node hexahedral meshes: a generator, the outer surface as triangles with outward
//! normals (seed §4.2.1.3), its closure check, and HRZ lumped masses (seed 4-22 … 4-25).

use std::collections::HashMap;

use dea_core::Vec3;

/// Corner nodes of an 8-node hexahedron in VTK order: 0-3 counter-clockwise on the bottom
/// face (seen from above), 4-7 above them.
pub type Hex = [u32; 8];

/// The six faces of a hexahedron as local corners, ordered so that the right-hand normal
/// points out of the element.
const FACES: [[usize; 4]; 6] = [[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6], [3, 0, 4, 7]];

/// A mesh of 8-node hexahedra.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct HexMesh {
    /// node positions in the body frame [m]
    pub nodes: Vec<Vec3>,
    pub hexes: Vec<Hex>,
}

/// The outer surface: triangles of node indices, right-hand normal outward.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Surface {
    pub triangles: Vec<[u32; 3]>,
}

/// Gauss points and weights of the 3-point rule on [-1, 1].
const GAUSS: [(f64, f64); 3] = [(-0.774_596_669_241_483_4, 5.0 / 9.0), (0.0, 8.0 / 9.0), (0.774_596_669_241_483_4, 5.0 / 9.0)];
/// Natural coordinates of the corners, VTK order.
const CORNERS: [[f64; 3]; 8] = [[-1.0, -1.0, -1.0], [1.0, -1.0, -1.0], [1.0, 1.0, -1.0], [-1.0, 1.0, -1.0], [-1.0, -1.0, 1.0], [1.0, -1.0, 1.0], [1.0, 1.0, 1.0], [-1.0, 1.0, 1.0]];

/// Trilinear shape functions and the Jacobian determinant at natural point `(r, s, t)`.
fn shape_and_jacobian(corners: &[Vec3; 8], r: f64, s: f64, t: f64) -> ([f64; 8], f64) {
    let mut n = [0.0; 8];
    let mut jacobian = nalgebra::Matrix3::<f64>::zeros();
    for (k, c) in CORNERS.iter().enumerate() {
        let (a, b, d) = (1.0 + c[0] * r, 1.0 + c[1] * s, 1.0 + c[2] * t);
        n[k] = a * b * d / 8.0;
        let gradient = Vec3::new(c[0] * b * d, c[1] * a * d, c[2] * a * b) / 8.0;
        jacobian += corners[k] * gradient.transpose();
    }
    (n, jacobian.determinant())
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
                            volume += wr * ws * wt * shape_and_jacobian(&corners, r, s, t).1;
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
                        let (n, det) = shape_and_jacobian(&corners, r, s, t);
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
        let mut count: HashMap<[u32; 4], (usize, [u32; 4])> = HashMap::new();
        for hex in &self.hexes {
            for face in FACES {
                let ordered = face.map(|k| hex[k]);
                let mut key = ordered;
                key.sort_unstable();
                count.entry(key).or_insert((0, ordered)).0 += 1;
            }
        }
        let mut faces: Vec<[u32; 4]> = count.into_values().filter(|(n, _)| *n == 1).map(|(_, face)| face).collect();
        faces.sort_unstable();
        Surface { triangles: faces.iter().flat_map(|f| [[f[0], f[1], f[2]], [f[0], f[2], f[3]]]).collect() }
    }

    /// A right circular cylinder along z, centred on the origin, as an O-grid: a square core
    /// of `core` x `core` elements and four blocks of `radial` elements out to the circle,
    /// `layers` elements along the axis. The rim is a polygon of `4 core` vertices on the
    /// circle.
    pub fn cylinder(radius: f64, height: f64, core: usize, radial: usize, layers: usize) -> Self {
        let half = 0.5 * radius;
        // the cross-section's points, shared by position where blocks meet
        let mut plane = NodeSet::new(radius);
        let node = |plane: &mut NodeSet, x: f64, y: f64| plane.node(Vec3::new(x, y, 0.0));
        let mut quads: Vec<[u32; 4]> = Vec::new();
        // core: a square of side `radius`
        let core_point = |i: usize, j: usize| (-half + radius * i as f64 / core as f64, -half + radius * j as f64 / core as f64);
        for i in 0..core {
            for j in 0..core {
                let corners = [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)].map(|(a, b)| {
                    let (x, y) = core_point(a, b);
                    node(&mut plane, x, y)
                });
                quads.push(corners);
            }
        }
        // four blocks from the square's sides to the circle, counter-clockwise
        for side in 0..4 {
            let rotation = side as f64 * std::f64::consts::FRAC_PI_2;
            let (c, s) = (rotation.cos(), rotation.sin());
            let point = |along: usize, out: usize| {
                // the +x side of the square, from (half, -half) to (half, half), and the arc
                // from -45 to 45 degrees, rotated to this side
                let u = along as f64 / core as f64;
                let inner = (half, -half + radius * u);
                let angle = -std::f64::consts::FRAC_PI_4 + std::f64::consts::FRAC_PI_2 * u;
                let outer = (radius * angle.cos(), radius * angle.sin());
                let w = out as f64 / radial as f64;
                let (x, y) = (inner.0 + w * (outer.0 - inner.0), inner.1 + w * (outer.1 - inner.1));
                (c * x - s * y, s * x + c * y)
            };
            for a in 0..core {
                for r in 0..radial {
                    let corners = [(a, r), (a, r + 1), (a + 1, r + 1), (a + 1, r)].map(|(p, q)| {
                        let (x, y) = point(p, q);
                        node(&mut plane, x, y)
                    });
                    quads.push(corners);
                }
            }
        }
        // counter-clockwise quads, extruded along z
        let plane = plane.nodes;
        let per_layer = plane.len() as u32;
        let nodes = (0..=layers)
            .flat_map(|k| {
                let z = -0.5 * height + height * k as f64 / layers as f64;
                plane.iter().map(move |p| Vec3::new(p.x, p.y, z))
            })
            .collect();
        let hexes = (0..layers as u32)
            .flat_map(|k| quads.iter().map(move |q| [q[0], q[1], q[2], q[3]].map(|n| n + k * per_layer)).map(|b| [b[0], b[1], b[2], b[3], b[0] + per_layer, b[1] + per_layer, b[2] + per_layer, b[3] + per_layer]))
            .collect();
        Self { nodes, hexes }
    }
}

/// Nodes shared by position, the way block-structured generators join their blocks.
struct NodeSet {
    scale: f64,
    index: HashMap<(i64, i64, i64), u32>,
    nodes: Vec<Vec3>,
}

impl NodeSet {
    fn new(scale: f64) -> Self {
        Self { scale, index: HashMap::new(), nodes: Vec::new() }
    }

    fn node(&mut self, x: Vec3) -> u32 {
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

impl Surface {
    /// Checks that the surface is closed and consistently oriented: every edge belongs to
    /// exactly two triangles that run along it in opposite directions. Returns the first
    /// offending edge.
    pub fn check_closed(&self) -> Result<(), (u32, u32)> {
        let mut directed: HashMap<(u32, u32), u32> = HashMap::new();
        for t in &self.triangles {
            for k in 0..3 {
                *directed.entry((t[k], t[(k + 1) % 3])).or_default() += 1;
            }
        }
        for (&(a, b), &n) in &directed {
            if n != 1 || directed.get(&(b, a)) != Some(&1) {
                return Err((a, b));
            }
        }
        Ok(())
    }

    /// Enclosed volume by the divergence theorem: positive when the normals point out [m^3].
    pub fn enclosed_volume(&self, nodes: &[Vec3]) -> f64 {
        self.triangles.iter().map(|t| nodes[t[0] as usize].dot(&nodes[t[1] as usize].cross(&nodes[t[2] as usize])) / 6.0).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
            assert_eq!(surface.check_closed(), Ok(()));
            assert!((surface.enclosed_volume(&mesh.nodes) - volume).abs() < 1e-12 * volume, "normals point out");
            // a hole makes it open
            let mut open = surface.clone();
            open.triangles.pop();
            assert!(open.check_closed().is_err());
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
            assert_eq!(surface.check_closed(), Ok(()));
            let volume: f64 = volumes.iter().sum();
            assert!((surface.enclosed_volume(&mesh.nodes) - volume).abs() < 1e-12 * volume, "normals point out");
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
