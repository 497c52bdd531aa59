//! Built-in projectile meshes: the sphere, the right circular cylinder (RCC) with a rounded
//! striking edge, and the 17-grain fragment-simulating projectile (FSP), as 8-node
//! hexahedra whose nodes lie on the exact (rounded) surface.
//!
//! Cylinders and the FSP are *column meshes*: an O-grid cross-section (a square core and four
//! blocks out to the rim) extruded along the axis, each column running from the shaped nose
//! to the flat rear. The nose is at -z, the direction of flight of an unrotated projectile.
//! Edge fillets are resolved by grading: [`ARC_SEGMENTS`] elements across every fillet arc,
//! the spacing growing geometrically away from it, and the layers fine at the nose.

use std::f64::consts::{FRAC_PI_2, FRAC_PI_4};

use dea_core::Vec3;

use crate::mesh::{Hex, HexMesh, NodeSet};

/// Elements across the arc of a rounded edge.
pub const ARC_SEGMENTS: usize = 4;

/// Ratio of neighbouring element sizes in graded regions.
const GROWTH: f64 = 1.3;

/// Nose of the 17-grain FSP: a right circular cylinder whose nose is cut by two planes
/// symmetric about the axis, leaving a flat across it (seed §4.4.3.2).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FspDimensions {
    /// [m]
    pub diameter: f64,
    /// overall length along the axis [m]
    pub length: f64,
    /// width of the flat left between the two cuts [m]
    pub flat_width: f64,
    /// angle of each cut face to the flat (the plane normal to the axis) [rad]
    pub bevel_angle: f64,
    /// radius of the edges between the flat and the cut faces (seed §6.2.1 edge 1) [m]
    pub flat_edge_radius: f64,
    /// radius of the rim, where the flat and the cut faces meet the side (edges 3 and 2) [m]
    pub rim_edge_radius: f64,
}

impl FspDimensions {
    /// The .22-calibre 17-grain FSP: diameter, length and flat width as commonly quoted from
    /// MIL-DTL-46593B, the 35° cuts of seed §4.4.3.2, the edge radii measured in seed §6.2.1
    /// (docs/theory.md records the sources and what is assumed).
    pub const SEVENTEEN_GRAIN: Self = Self { diameter: 5.46e-3, length: 6.35e-3, flat_width: 1.27e-3, bevel_angle: 35.0 * std::f64::consts::PI / 180.0, flat_edge_radius: 50e-6, rim_edge_radius: 150e-6 };

    /// Depth of the nose surface behind the flat at lateral position `x` (across the cuts)
    /// before the rim is rounded: zero on the flat, a circular arc of the flat-edge radius,
    /// then the cut plane [m].
    fn cut_depth(&self, x: f64) -> f64 {
        let (r, alpha) = (self.flat_edge_radius, self.bevel_angle);
        let half = 0.5 * self.flat_width;
        // the arc is tangent to the flat at `start` and to the cut at `end`
        let tangent = r * (0.5 * alpha).tan();
        let (start, end) = (half - tangent, half - tangent + r * alpha.sin());
        let x = x.abs();
        if x <= start {
            0.0
        } else if x <= end {
            r - (r * r - (x - start) * (x - start)).sqrt()
        } else {
            (x - half) * alpha.tan()
        }
    }

    /// Checks that the shape exists: the flat, its fillets and the rim fit on the face, and
    /// the cuts end before the rear.
    pub fn check(&self) -> Result<(), String> {
        let radius = 0.5 * self.diameter;
        let fillet_end = 0.5 * self.flat_width + self.flat_edge_radius * (self.bevel_angle.sin() - (0.5 * self.bevel_angle).tan());
        if !(self.bevel_angle > 0.0 && self.bevel_angle < FRAC_PI_2) {
            return Err(format!("bevel angle {} rad must lie between 0 and pi/2", self.bevel_angle));
        }
        if self.flat_width <= 2.0 * self.flat_edge_radius * (0.5 * self.bevel_angle).tan() || fillet_end + self.rim_edge_radius >= 0.5 * radius {
            return Err(format!("flat width {} m does not leave room for its edge fillets and the rim on a {} m face", self.flat_width, self.diameter));
        }
        let deepest = self.cut_depth(radius) + self.rim_edge_radius;
        if deepest >= 0.9 * self.length {
            return Err(format!("the cuts reach {deepest} m deep on a {} m long projectile", self.length));
        }
        Ok(())
    }
}

/// A built-in solid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Solid {
    /// a sphere, meshed in hexahedra
    Sphere {
        /// [m]
        radius: f64,
    },
    /// a right circular cylinder, meshed in hexahedra (the analytic shape rounds both
    /// faces' edges; this mesh only the striking one)
    Cylinder {
        /// [m]
        radius: f64,
        /// [m]
        height: f64,
        /// radius of the rounded striking edge [m]
        edge_radius: f64,
    },
    /// the fragment-simulating projectile's shape
    Fsp(FspDimensions),
}

impl Solid {
    /// Its hexahedral mesh, `divisions` elements along a quarter of the rim (or of a great
    /// circle) away from refined edges.
    pub fn mesh(&self, divisions: usize) -> HexMesh {
        match *self {
            Solid::Sphere { radius } => HexMesh::sphere(radius, divisions, divisions.div_ceil(2)),
            Solid::Cylinder { radius, height, edge_radius } => HexMesh::rounded_cylinder(radius, height, edge_radius, divisions),
            Solid::Fsp(ref dimensions) => HexMesh::fsp(dimensions, divisions),
        }
    }
}

/// Rounding of the rim of a column mesh: the depth a quarter-circle fillet of `radius` adds
/// at distance `inset` inside the rim [m].
fn rim_drop(radius: f64, inset: f64) -> f64 {
    // rim nodes may sit a rounding error outside the circle
    let inset = inset.max(0.0);
    if inset >= radius {
        0.0
    } else {
        radius - (radius * radius - (radius - inset) * (radius - inset)).sqrt()
    }
}

/// Points from 0 to `length`: spacing `fine` over the first `fine_zone`, then growing by
/// [`GROWTH`] up to `coarse`; the last interval is stretched to end at `length`.
fn graded(length: f64, fine_zone: f64, fine: f64, coarse: f64) -> Vec<f64> {
    let mut points = vec![0.0];
    let (mut at, mut step) = (0.0, fine.min(coarse));
    while at + 1.5 * step < length {
        at += step;
        points.push(at);
        if at >= fine_zone {
            step = (step * GROWTH).min(coarse);
        }
    }
    points.push(length);
    points
}

/// Cross-section of a column mesh: points in the plane and counter-clockwise quads.
struct Section {
    points: Vec<(f64, f64)>,
    quads: Vec<[u32; 4]>,
}

/// Where the nodes of an O-grid lie.
struct OGrid {
    radius: f64,
    /// half-width of the square core [m]
    core: f64,
    /// node positions across the core in x, ascending from -core to core [m]; the blocks
    /// above and below continue these lines to the rim
    xs: Vec<f64>,
    /// the same in y; the blocks left and right continue them
    ys: Vec<f64>,
    /// lines with |x| below this run straight up to the rim (a feature along x stays
    /// resolved out to the rim) [m]
    straight: f64,
    /// rounded rim: fillet radius [m] (0: sharp)
    rim_radius: f64,
    /// fractions of the remaining length of each block line, from the fillet inwards,
    /// ascending in (0, 1]
    inward: Vec<f64>,
}

impl OGrid {
    /// Rim angle of the line of the upper block through x.
    fn upper_angle(&self, x: f64) -> f64 {
        let keep = self.straight.min(self.core);
        let at = |x: f64| (x / self.radius).acos();
        if x.abs() <= keep {
            at(x)
        } else {
            let corner = if x > 0.0 { FRAC_PI_4 } else { 3.0 * FRAC_PI_4 };
            let edge = at(keep * x.signum());
            edge + (corner - edge) * (x.abs() - keep) / (self.core - keep)
        }
    }

    /// Distances from the rim of the nodes along a block line of `length` [m], ascending.
    fn distances_from_rim(&self, length: f64) -> Vec<f64> {
        let r = self.rim_radius;
        let arcs = if r > 0.0 { ARC_SEGMENTS } else { 0 };
        // even arc lengths over the quarter circle: r (1 - sin phi) from the side wall (phi =
        // pi/2, the rim itself) to the tangent point (phi = 0)
        let mut distances: Vec<f64> = (0..=arcs).map(|k| if k == 0 { 0.0 } else { r * (1.0 - (FRAC_PI_2 * (arcs - k) as f64 / arcs as f64).sin()) }).collect();
        distances.extend(self.inward.iter().map(|f| r + f * (length - r)));
        distances
    }

    fn section(&self) -> Section {
        let mut set = NodeSet::new(self.radius);
        let mut quads = Vec::new();
        let mut quad = |set: &mut NodeSet, corners: [(f64, f64); 4]| quads.push(corners.map(|(x, y)| set.node(Vec3::new(x, y, 0.0))));
        for i in 0..self.xs.len() - 1 {
            for j in 0..self.ys.len() - 1 {
                quad(&mut set, [(self.xs[i], self.ys[j]), (self.xs[i + 1], self.ys[j]), (self.xs[i + 1], self.ys[j + 1]), (self.xs[i], self.ys[j + 1])]);
            }
        }
        // a block line from an inner point to the rim at `angle`, as points from the inside out
        let line = |inner: (f64, f64), angle: f64| -> Vec<(f64, f64)> {
            let rim = (self.radius * angle.cos(), self.radius * angle.sin());
            let length = ((rim.0 - inner.0).powi(2) + (rim.1 - inner.1).powi(2)).sqrt();
            let mut points: Vec<(f64, f64)> = self.distances_from_rim(length).iter().map(|s| (rim.0 + (inner.0 - rim.0) * s / length, rim.1 + (inner.1 - rim.1) * s / length)).collect();
            points.reverse();
            points
        };
        // four blocks: (lines, counter-clockwise when the lines run in that order)
        let upper: Vec<_> = self.xs.iter().map(|&x| line((x, self.core), self.upper_angle(x))).collect();
        let lower: Vec<_> = self.xs.iter().rev().map(|&x| line((x, -self.core), -self.upper_angle(x))).collect();
        let right: Vec<_> = self.ys.iter().map(|&y| line((self.core, y), FRAC_PI_4 * y / self.core)).collect();
        let left: Vec<_> = self.ys.iter().rev().map(|&y| line((-self.core, y), std::f64::consts::PI - FRAC_PI_4 * y / self.core)).collect();
        for block in [&upper, &lower] {
            // lines run along the rim's counter-clockwise sense above and below
            for pair in block.windows(2) {
                for k in 0..pair[0].len() - 1 {
                    quad(&mut set, [pair[0][k], pair[1][k], pair[1][k + 1], pair[0][k + 1]]);
                }
            }
        }
        for block in [&right, &left] {
            for pair in block.windows(2) {
                for k in 0..pair[0].len() - 1 {
                    quad(&mut set, [pair[0][k], pair[0][k + 1], pair[1][k + 1], pair[1][k]]);
                }
            }
        }
        let points = set.nodes.iter().map(|p| (p.x, p.y)).collect();
        Section { points, quads }
    }
}

/// Extrudes a section into columns: node k of a column at `bottom + t_k (top - bottom)` for
/// the ascending fractions `layers` from 0 to 1.
fn columns(section: &Section, layers: &[f64], bottom: impl Fn(f64, f64) -> f64, top: impl Fn(f64, f64) -> f64) -> HexMesh {
    let per_layer = section.points.len() as u32;
    let ends: Vec<(f64, f64)> = section.points.iter().map(|&(x, y)| (bottom(x, y), top(x, y))).collect();
    let nodes = layers.iter().flat_map(|&t| section.points.iter().zip(&ends).map(move |(&(x, y), &(low, high))| Vec3::new(x, y, low + t * (high - low)))).collect();
    let hexes = (0..layers.len() as u32 - 1)
        .flat_map(|k| section.quads.iter().map(move |q| q.map(|n| n + k * per_layer)))
        .map(|b| -> Hex { [b[0], b[1], b[2], b[3], b[0] + per_layer, b[1] + per_layer, b[2] + per_layer, b[3] + per_layer] })
        .collect();
    HexMesh { nodes, hexes }
}

/// Symmetric positions from -half to half: `one_side` holds those from 0 to half.
fn mirrored(one_side: &[f64]) -> Vec<f64> {
    one_side.iter().rev().map(|x| -x).chain(one_side.iter().skip(1).copied()).collect()
}

impl HexMesh {
    /// A right circular cylinder along z, centred on the origin, as a uniform O-grid: a
    /// square core of `core` x `core` elements and four blocks of `radial` elements out to
    /// the circle, `layers` elements along the axis. The rim is a regular polygon of
    /// `4 core` vertices on the circle.
    pub fn cylinder(radius: f64, height: f64, core: usize, radial: usize, layers: usize) -> Self {
        let uniform = |n: usize, from: f64, to: f64| (0..=n).map(|k| from + (to - from) * k as f64 / n as f64).collect::<Vec<_>>();
        let half = 0.5 * radius;
        let grid = OGrid { radius, core: half, xs: uniform(core, -half, half), ys: uniform(core, -half, half), straight: 0.0, rim_radius: 0.0, inward: uniform(radial, 0.0, 1.0)[1..].to_vec() };
        columns(&grid.section(), &uniform(layers, 0.0, 1.0), |_, _| -0.5 * height, |_, _| 0.5 * height)
    }

    /// A right circular cylinder along z whose striking edge (at -z) is rounded with
    /// `edge_radius`; `divisions` elements along a quarter of the rim away from the fillet.
    /// The rear edge is left sharp: it never meets the fabric.
    pub fn rounded_cylinder(radius: f64, height: f64, edge_radius: f64, divisions: usize) -> Self {
        let coarse = radius / divisions as f64;
        let half = 0.5 * radius;
        let across = mirrored(&graded(half, 0.0, coarse, coarse));
        let grid = OGrid { radius, core: half, xs: across.clone(), ys: across, straight: 0.0, rim_radius: edge_radius, inward: Self::inward(radius, half, edge_radius, coarse) };
        let layers = Self::layers(height, edge_radius, coarse);
        columns(&grid.section(), &layers, |x, y| -0.5 * height + rim_drop(edge_radius, radius - x.hypot(y)), |_, _| 0.5 * height)
    }

    /// The FSP along z with its nose at -z; `divisions` elements along a quarter of the rim
    /// away from the refined edges.
    pub fn fsp(dimensions: &FspDimensions, divisions: usize) -> Self {
        let d = dimensions;
        let radius = 0.5 * d.diameter;
        let coarse = radius / divisions as f64;
        let half = 0.5 * radius;
        // x runs across the cuts: fine over the flat-edge fillet, both ways from its middle
        let arc = d.flat_edge_radius * d.bevel_angle / ARC_SEGMENTS as f64;
        let fillet_width = d.flat_edge_radius * d.bevel_angle.sin();
        let middle = 0.5 * d.flat_width - d.flat_edge_radius * (0.5 * d.bevel_angle).tan() + 0.5 * fillet_width;
        let towards_axis = graded(middle, 0.5 * fillet_width, arc, coarse);
        let outwards = graded(half - middle, 0.5 * fillet_width, arc, coarse);
        let one_side: Vec<f64> = towards_axis.iter().rev().map(|s| middle - s).chain(outwards.iter().skip(1).map(|s| middle + s)).collect();
        let grid = OGrid {
            radius,
            core: half,
            xs: mirrored(&one_side),
            ys: mirrored(&graded(half, 0.0, coarse, coarse)),
            straight: middle + fillet_width,
            rim_radius: d.rim_edge_radius,
            inward: Self::inward(radius, half, d.rim_edge_radius, coarse),
        };
        let layers = Self::layers(d.length, d.flat_edge_radius.min(d.rim_edge_radius), coarse);
        columns(&grid.section(), &layers, |x, y| -0.5 * d.length + d.cut_depth(x) + rim_drop(d.rim_edge_radius, radius - x.hypot(y)), |_, _| 0.5 * d.length)
    }

    /// Inward fractions of a block line beyond the rim fillet: the spacing of the fillet's
    /// widest arc, growing to `coarse`, on the shortest line (the core's corner diagonal).
    fn inward(radius: f64, core: f64, rim_radius: f64, coarse: f64) -> Vec<f64> {
        let shortest = std::f64::consts::SQRT_2 * (radius * FRAC_PI_4.cos() - core);
        let first = rim_radius * (FRAC_PI_2 / ARC_SEGMENTS as f64).sin();
        let rest = shortest - rim_radius;
        graded(rest, 0.0, first.max(0.05 * rest), coarse)[1..].iter().map(|s| s / rest).collect()
    }

    /// Layer fractions from the nose (t = 0) to the rear: `fine` thick at the nose, growing to
    /// `coarse`.
    fn layers(length: f64, fine: f64, coarse: f64) -> Vec<f64> {
        graded(length, 0.0, fine, coarse).iter().map(|z| z / length).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use dea_core::surface::{check_closed, MassProperties};

    /// The exact FSP nose: depth behind the flat, whether rounded or not.
    fn fsp_nose(d: &FspDimensions, x: f64, y: f64) -> f64 {
        -0.5 * d.length + d.cut_depth(x) + rim_drop(d.rim_edge_radius, 0.5 * d.diameter - x.hypot(y))
    }

    #[test]
    fn fsp_mesh_is_closed_positive_and_its_nose_lies_on_the_rounded_surface() {
        let d = FspDimensions::SEVENTEEN_GRAIN;
        d.check().unwrap();
        let mesh = HexMesh::fsp(&d, 6);
        let volumes = mesh.volumes();
        assert!(volumes.iter().all(|&v| v > 0.0), "every element has positive volume");
        let surface = mesh.surface();
        assert_eq!(check_closed(&surface.triangles), Ok(()));
        let volume: f64 = volumes.iter().sum();
        let properties = MassProperties::of_surface(&mesh.nodes, &surface.triangles);
        assert!((properties.volume - volume).abs() < 1e-3 * volume, "normals point out: {} vs {volume}", properties.volume);
        // symmetric about x = 0 and y = 0
        assert!(properties.centroid.xy().norm() < 1e-9 * d.diameter);
        // the nose nodes lie on the exact surface, and every rounded edge gets its arcs
        let mut on_flat_fillet = 0;
        let mut on_rim_fillet = 0;
        for p in &mesh.nodes {
            if p.z < 0.0 && (p.z - fsp_nose(&d, p.x, p.y)).abs() < 1e-15 {
                let x = p.x.abs() - 0.5 * d.flat_width;
                if x.abs() < d.flat_edge_radius * 0.3 && p.y.abs() < 0.1 * d.diameter {
                    on_flat_fillet += 1;
                }
                let inset = 0.5 * d.diameter - p.x.hypot(p.y);
                if inset > 0.0 && inset < d.rim_edge_radius && p.x.abs() < 1e-12 {
                    on_rim_fillet += 1;
                }
            }
        }
        assert!(on_flat_fillet >= 2 * ARC_SEGMENTS, "{on_flat_fillet} nodes on the flat-edge fillets near the axis");
        assert!(on_rim_fillet >= 2 * (ARC_SEGMENTS - 1), "{on_rim_fillet} nodes inside the rim fillet on x = 0");
        // the cut geometry: the volume lies between the uncut cylinder and the sharp-edged cut
        let cylinder = std::f64::consts::PI * 0.25 * d.diameter * d.diameter * d.length;
        assert!(volume < cylinder && volume > 0.9 * cylinder, "{volume} vs {cylinder}");
    }

    #[test]
    fn a_meshed_sphere_answers_like_the_analytic_one_within_its_chords() {
        use dea_core::projectile::{MeshShape, RigidShape};
        use rand::{Rng, SeedableRng};
        let radius = 2.78e-3;
        let mesh = Solid::Sphere { radius }.mesh(8);
        let (vertices, triangles) = mesh.boundary();
        // the widest chord's sagitta bounds how far the facets lie inside the sphere
        let edge = |t: &[u32; 3], k: usize| (vertices[t[k] as usize] - vertices[t[(k + 1) % 3] as usize]).norm();
        let longest = triangles.iter().flat_map(|t| (0..3).map(move |k| edge(t, k))).fold(0.0, f64::max);
        let sagitta = radius - (radius * radius - 0.25 * longest * longest).sqrt();
        let reach = 20e-6;
        let (shape, centroid) = MeshShape::new(&vertices, triangles, reach, 40e-6).unwrap();
        assert!(centroid.norm() < 1e-9 * radius);
        let meshed = RigidShape::Mesh(std::sync::Arc::new(shape));
        let exact = RigidShape::Sphere { radius };
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let mut found = 0;
        for _ in 0..2000 {
            let direction = Vec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0)).normalize();
            let p = direction * (radius + rng.random_range(-reach..reach));
            let (d_exact, n_exact) = exact.distance_and_normal(&p);
            let (d_mesh, n_mesh) = meshed.distance_and_normal(&p);
            if d_mesh.is_finite() {
                found += 1;
                assert!(d_mesh >= d_exact - 1e-12 && d_mesh <= d_exact + 1.5 * sagitta, "{d_mesh} vs {d_exact} (sagitta {sagitta})");
                assert!(n_mesh.dot(&n_exact) > 0.95, "normals agree");
            } else {
                assert!(d_exact + sagitta > reach - 1e-12, "{d_exact}: within reach but not found");
            }
        }
        assert!(found > 1000, "{found}");
        // the inertia of a solid sphere, to the volume deficit of the inscribed polyhedron
        let inertia = meshed.inertia(1.0);
        assert!((inertia[(0, 0)] / (0.4 * radius * radius) - 1.0).abs() < 0.03, "{inertia}");
        // each quad split along one diagonal leaves the facets without mirror symmetry: a
        // product of inertia of order 1e-4 remains
        assert!(inertia[(0, 1)].abs() < 1e-3 * inertia[(0, 0)], "{inertia}");
    }

    #[test]
    fn the_meshed_fsp_answers_the_same_with_any_hint() {
        use dea_core::projectile::{MeshShape, RigidShape};
        use rand::{Rng, SeedableRng};
        // the default case's mesh, reach and cubes: its rounded edges are not quite convex
        // (facets fold in by up to about half a micrometre), so some triangles have rivals
        let (vertices, triangles) = Solid::Fsp(FspDimensions::SEVENTEEN_GRAIN).mesh(6).boundary();
        let (reach, cell) = (94.2e-6, 163.3e-6);
        let (shape, _) = MeshShape::new(&vertices, triangles, reach, cell).unwrap();
        let fsp = RigidShape::Mesh(std::sync::Arc::new(shape));
        let RigidShape::Mesh(mesh) = &fsp else { unreachable!("built as a mesh") };
        let surface = &mesh.surface;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(23);
        let mut jitter = |scale: f64| Vec3::new(rng.random_range(-scale..scale), rng.random_range(-scale..scale), rng.random_range(-scale..scale));
        let mut found = 0;
        for k in 0..60_000 {
            let p = surface.vertices[k * 7919 % surface.vertices.len()] + jitter(3.0 * reach);
            let searched = fsp.contact_point(&p, dea_core::NONE);
            let nearby = fsp.contact_point(&(p + jitter(0.1 * reach)), dea_core::NONE).triangle;
            for hint in [searched.triangle, nearby, (k * 104_729 % surface.triangles.len()) as u32] {
                assert_eq!(fsp.contact_point(&p, hint), searched, "{p:?}, hint {hint}");
            }
            found += searched.distance.is_finite() as usize;
        }
        assert!(found > 20_000, "{found}");
    }

    #[test]
    fn the_fsp_cut_profile_is_smooth_at_the_fillet_ends() {
        let d = FspDimensions::SEVENTEEN_GRAIN;
        let tangent = d.flat_edge_radius * (0.5 * d.bevel_angle).tan();
        let (start, end) = (0.5 * d.flat_width - tangent, 0.5 * d.flat_width - tangent + d.flat_edge_radius * d.bevel_angle.sin());
        let h = 1e-9;
        for (x, slope) in [(start, 0.0), (end, d.bevel_angle.tan())] {
            let numerical = (d.cut_depth(x + h) - d.cut_depth(x - h)) / (2.0 * h);
            // a jump in value would show as a huge slope, a kink as the wrong one
            assert!((numerical - slope).abs() < 1e-4, "slope at {x}: {numerical} vs {slope}");
        }
    }

    #[test]
    fn rounded_cylinder_converges_to_the_exact_volume() {
        let (radius, height, edge) = (1.7e-3, 3.7e-3, 50e-6);
        // the volume of a cylinder with one rounded edge: the fillet removes (1 - pi/4) r^2
        // of the section, swept at its centroid's radius (Pappus)
        let corner = (1.0 - std::f64::consts::FRAC_PI_4) * edge * edge;
        let centroid = radius - edge * (10.0 - 3.0 * std::f64::consts::PI) / (12.0 - 3.0 * std::f64::consts::PI);
        let exact = std::f64::consts::PI * radius * radius * height - std::f64::consts::TAU * centroid * corner;
        let mut previous = f64::INFINITY;
        for divisions in [4, 8, 16] {
            let mesh = HexMesh::rounded_cylinder(radius, height, edge, divisions);
            let volumes = mesh.volumes();
            assert!(volumes.iter().all(|&v| v > 0.0));
            assert_eq!(check_closed(&mesh.surface().triangles), Ok(()));
            let error = (exact - volumes.iter().sum::<f64>()) / exact;
            assert!(error > 0.0 && error < previous, "{divisions}: {error}");
            previous = error;
        }
        assert!(previous < 2e-3, "{previous}");
    }
}
