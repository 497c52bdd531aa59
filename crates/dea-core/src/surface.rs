//! Triangle surfaces of meshed projectiles (seed §4.2.1.3, §4.2.2): the closest point of a
//! triangle to a fibre node with the feature it lies on, signed distances by angle-weighted
//! pseudonormals, a grid of cubes that finds the triangles near a node, and the mass
//! properties of the enclosed solid.

use std::collections::HashMap;

use nalgebra::Matrix3;
use rustc_hash::FxHashMap;

use crate::Vec3;

/// Which part of a triangle the closest point lies on: the seed's node-to-surface,
/// node-to-line and node-to-node contact cases (§4.2.2).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Feature {
    /// inside the face
    Face,
    /// on the edge from vertex k to vertex (k + 1) % 3
    Edge(u8),
    /// at vertex k
    Vertex(u8),
}

/// The closest point of triangle (a, b, c) to `p`, its barycentric weights (the area
/// weights that share a contact force over the triangle's nodes, seed 4-1) and its feature.
/// Follows the Voronoi-region tests of Ericson, *Real-Time Collision Detection* §5.1.5.
#[inline(always)]
pub fn closest_point_on_triangle(p: &Vec3, a: &Vec3, b: &Vec3, c: &Vec3) -> (Vec3, [f64; 3], Feature) {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(&ap), ac.dot(&ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return (*a, [1.0, 0.0, 0.0], Feature::Vertex(0));
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(&bp), ac.dot(&bp));
    if d3 >= 0.0 && d4 <= d3 {
        return (*b, [0.0, 1.0, 0.0], Feature::Vertex(1));
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let t = d1 / (d1 - d3);
        return (a + ab * t, [1.0 - t, t, 0.0], Feature::Edge(0));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(&cp), ac.dot(&cp));
    if d6 >= 0.0 && d5 <= d6 {
        return (*c, [0.0, 0.0, 1.0], Feature::Vertex(2));
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let t = d2 / (d2 - d6);
        return (a + ac * t, [1.0 - t, 0.0, t], Feature::Edge(2));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        let t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (b + (c - b) * t, [0.0, 1.0 - t, t], Feature::Edge(1));
    }
    let denominator = 1.0 / (va + vb + vc);
    let (v, w) = (vb * denominator, vc * denominator);
    (a + ab * v + ac * w, [1.0 - v - w, v, w], Feature::Face)
}

/// The point of a surface closest to a query point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePoint {
    /// distance from the surface, negative inside [m]
    pub distance: f64,
    /// outward unit normal of the contact: from the surface point towards an outside query
    /// point (the face normal, the edge's or the vertex's direction alike)
    pub normal: Vec3,
    /// the closest surface point [m]
    pub point: Vec3,
    /// the triangle the point lies on
    pub triangle: u32,
    /// barycentric (area) weights of the point on its triangle (seed 4-1)
    pub weights: [f64; 3],
}

/// A closed, consistently oriented triangle surface in a body frame, ready for contact
/// queries within a fixed reach.
#[derive(Clone, Debug, PartialEq)]
pub struct TriangleSurface {
    /// vertex positions, body frame [m]
    pub vertices: Vec<Vec3>,
    /// vertex indices, counter-clockwise seen from outside
    pub triangles: Vec<[u32; 3]>,
    /// unit outward normal of each triangle
    face_normals: Vec<Vec3>,
    /// a sphere holding each triangle (centre, radius): skips triangles that cannot be
    /// nearer than the best one found
    bounds: Vec<(Vec3, f64)>,
    /// per triangle and edge k (from vertex k to k + 1): the sum of the normals of the two
    /// triangles that share it
    edge_normals: Vec<[Vec3; 3]>,
    /// angle-weighted pseudonormal of each vertex (Bærentzen and Aanæs 2005): its sign test
    /// is exact at vertices and edges, where the face normal is not
    vertex_normals: Vec<Vec3>,
    /// the triangle across each edge k (from vertex k to k + 1)
    across: Vec<[u32; 3]>,
    /// shortest height of each triangle (twice its area over its longest edge) [m]: a point
    /// of the triangle with every barycentric weight `w` is `w` times this from its edges
    shortest_height: Vec<f64>,
    /// the rivals of each triangle ([`Self::find_rivals`]), by `rival_start[t]..rival_start[t + 1]`
    rivals: Vec<u32>,
    rival_start: Vec<u32>,
    /// how far inside a face, and over it, a point must lie for [`Self::closest_near`] to
    /// answer from that face and its rivals alone [m]
    face_margin: f64,
    /// largest distance at which a query finds the surface [m]
    reach: f64,
    /// how far vertices may move from `grid_vertices` before the cubes are rebuilt [m]
    margin: f64,
    grid_vertices: Vec<Vec3>,
    grid: CellGrid,
}

/// Cubes of a fixed edge, each listing the triangles within `reach` of it: a query point
/// then looks in one cube only, so the cost of a query does not grow with the mesh.
#[derive(Clone, Debug, PartialEq)]
struct CellGrid {
    /// cube edge [m]
    cell: f64,
    /// cube -> range of `entries` (Fx hashing: a lookup per candidate node and step, where
    /// SipHash's collision resistance buys nothing)
    cells: FxHashMap<[i32; 3], (u32, u32)>,
    /// triangle indices, nearest the cube's centre first
    entries: Vec<u32>,
    /// one bit per cube of the box of the listed cubes, set for a listed one: most queries
    /// of nodes beyond the reach end here without hashing. The box's lowest cube and its
    /// cubes along each axis; no bits when it holds more than [`MOST_OCCUPANCY_CUBES`].
    occupancy_low: [i32; 3],
    occupancy_size: [u32; 3],
    occupancy: Vec<u64>,
}

/// The most cubes a grid's occupancy bits cover (2 MiB of bits).
const MOST_OCCUPANCY_CUBES: u64 = 1 << 24;

/// The cube of edge `cell` [m] that holds `p`.
fn cube_of(p: &Vec3, cell: f64) -> [i32; 3] {
    [p.x, p.y, p.z].map(|v| crate::floor_index(v / cell).clamp(i32::MIN.into(), i32::MAX.into()) as i32)
}

impl CellGrid {
    fn key(&self, p: &Vec3) -> [i32; 3] {
        cube_of(p, self.cell)
    }

    fn new(vertices: &[Vec3], triangles: &[[u32; 3]], reach: f64, cell: f64) -> Self {
        let mut grid = Self {
            cell,
            cells: FxHashMap::default(),
            entries: Vec::new(),
            occupancy_low: [0; 3],
            occupancy_size: [0; 3],
            occupancy: Vec::new(),
        };
        // (cube, distance of the triangle from the cube's centre, triangle): each cube's list
        // runs nearest first, so a query soon has a close triangle to prune the others with
        let mut listed: Vec<([i32; 3], u64, u32)> = Vec::new();
        // a cube lists a triangle when the triangle comes within reach of the cube's
        // circumscribed sphere (a slanted triangle's box holds many cubes it never nears)
        let half_diagonal = 0.5 * cell * 3f64.sqrt();
        for (t, triangle) in triangles.iter().enumerate() {
            let corners = triangle.map(|v| vertices[v as usize]);
            let low = corners[0].inf(&corners[1]).inf(&corners[2]).add_scalar(-reach);
            let high = corners[0].sup(&corners[1]).sup(&corners[2]).add_scalar(reach);
            let (low, high) = (grid.key(&low), grid.key(&high));
            for i in low[0]..=high[0] {
                for j in low[1]..=high[1] {
                    for k in low[2]..=high[2] {
                        let centre = Vec3::new(i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5) * cell;
                        let (q, ..) = closest_point_on_triangle(&centre, &corners[0], &corners[1], &corners[2]);
                        let distance = (q - centre).norm();
                        if distance <= half_diagonal + reach {
                            listed.push(([i, j, k], distance.to_bits(), t as u32));
                        }
                    }
                }
            }
        }
        listed.sort_unstable();
        let mut start = 0;
        while start < listed.len() {
            let key = listed[start].0;
            let end = start + listed[start..].iter().take_while(|(k, ..)| *k == key).count();
            grid.cells.insert(key, (grid.entries.len() as u32, (grid.entries.len() + end - start) as u32));
            grid.entries.extend(listed[start..end].iter().map(|&(.., t)| t));
            start = end;
        }
        let keys = || grid.cells.keys();
        let low = [0, 1, 2].map(|k| keys().map(|c| c[k]).min().unwrap_or(0));
        let size = [0, 1, 2].map(|k| keys().map(|c| (c[k] as i64 - low[k] as i64 + 1) as u64).max().unwrap_or(0));
        if size.iter().product::<u64>() <= MOST_OCCUPANCY_CUBES {
            grid.occupancy_low = low;
            grid.occupancy_size = size.map(|n| n as u32);
            let mut bits = vec![0u64; (size.iter().product::<u64>() as usize).div_ceil(64)];
            for &key in grid.cells.keys() {
                let bit = grid.occupancy_bit(key).expect("a listed cube lies in the box");
                bits[bit / 64] |= 1 << (bit % 64);
            }
            grid.occupancy = bits;
        }
        grid
    }

    /// The bit of cube `key` in the occupancy bits, if it lies in their box.
    #[inline]
    fn occupancy_bit(&self, key: [i32; 3]) -> Option<usize> {
        let mut bit = 0usize;
        for k in (0..3).rev() {
            let offset = (key[k] as i64 - self.occupancy_low[k] as i64) as u64;
            if offset >= self.occupancy_size[k] as u64 {
                return None;
            }
            bit = bit * self.occupancy_size[k] as usize + offset as usize;
        }
        Some(bit)
    }

    #[inline]
    fn near(&self, p: &Vec3) -> &[u32] {
        let key = self.key(p);
        if !self.occupancy.is_empty()
            && self.occupancy_bit(key).is_none_or(|bit| self.occupancy[bit / 64] & (1 << (bit % 64)) == 0)
        {
            return &[];
        }
        self.cells.get(&key).map_or(&[], |&(a, b)| &self.entries[a as usize..b as usize])
    }
}

/// Why a triangle list is not a usable closed surface.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SurfaceError {
    #[error("the surface is not closed or not consistently oriented at the edge from vertex {0} to vertex {1}")]
    /// an edge without its opposite half-edge
    Open(u32, u32),
    #[error("triangle {0} has no area")]
    /// a triangle of zero area
    Degenerate(usize),
    #[error("the enclosed volume is {0} m^3: the normals must point out of the solid")]
    /// the normals point into the solid: the enclosed volume [m^3] is negative
    InsideOut(f64),
    /// The contact search would list the surface in more (cube, triangle) entries than
    /// [`MOST_SEARCH_ENTRIES`]: a surface large against the fibre it meets.
    #[error("its {area:.3e} m^2 of surface would be listed about {entries:.2e} times in the contact search's cubes of {cell:.2e} m (sized by the fibre it meets), about {gigabytes:.1} GB, and at most {most:.2e} listings are made: a smaller projectile, or a thicker fibre")]
    TooLarge {
        /// the surface's area [m^2]
        area: f64,
        /// the listings it would need [-]
        entries: f64,
        /// the search cube's edge [m]
        cell: f64,
        /// the memory they would take [GB]
        gigabytes: f64,
        /// the most listings made [-]
        most: f64,
    },
}

/// The most (cube, triangle) listings the contact search of one surface may make, counted
/// before any is made: 2^27 listings take about 3 GB while they are sorted, where a 0.1 m
/// cube against a 12 um filament would take 24 GB and minutes (issue 34). A 17-grain FSP
/// against the finest shipped fibre needs about 10^6.
pub const MOST_SEARCH_ENTRIES: f64 = (1u64 << 27) as f64;

/// Bytes per listing while the search's cubes are built (cube, distance and triangle).
const BYTES_PER_LISTING: f64 = 24.0;

/// How many listings the search of `triangles` makes, from the volume within `reach` plus a
/// cube's half-diagonal of each triangle (Steiner's formula for a flat convex set:
/// `2 h A + (pi/2) P h^2 + (4/3) pi h^3`) over a cube's volume, and how many boxes the
/// rival search bins (counted exactly, each triangle's box in cubes of `rival_cell`), with
/// the surface's area [m^2] the first sum needs anyway. Cheap, and made before either
/// structure is.
fn search_listings(
    vertices: &[Vec3],
    triangles: &[[u32; 3]],
    reach: f64,
    cell: f64,
    rival_cell: f64,
) -> (f64, f64, f64) {
    let h = 0.5 * cell * 3f64.sqrt() + reach;
    let (mut listed, mut binned, mut total_area) = (0.0, 0.0, 0.0);
    for t in triangles {
        let [a, b, c] = t.map(|v| vertices[v as usize]);
        let area = 0.5 * (b - a).cross(&(c - a)).norm();
        let perimeter = (b - a).norm() + (c - b).norm() + (a - c).norm();
        let volume = 2.0 * h * area
            + std::f64::consts::FRAC_PI_2 * perimeter * h * h
            + 4.0 / 3.0 * std::f64::consts::PI * h.powi(3);
        listed += volume / cell.powi(3);
        total_area += area;
        let (low, high) = (cube_of(&a.inf(&b).inf(&c), rival_cell), cube_of(&a.sup(&b).sup(&c), rival_cell));
        binned += (0..3).map(|k| high[k] as f64 - low[k] as f64 + 1.0).product::<f64>();
    }
    (listed, binned, total_area)
}

/// Checks that triangles form a closed, consistently oriented surface: every directed edge
/// appears once and its reverse once. Returns the first offending edge.
pub fn check_closed(triangles: &[[u32; 3]]) -> Result<(), (u32, u32)> {
    let mut directed: HashMap<(u32, u32), u32> = HashMap::new();
    for t in triangles {
        for k in 0..3 {
            *directed.entry((t[k], t[(k + 1) % 3])).or_default() += 1;
        }
    }
    let mut edges: Vec<_> = directed.iter().collect();
    edges.sort_unstable();
    for (&(a, b), &n) in edges {
        if n != 1 || directed.get(&(b, a)) != Some(&1) {
            return Err((a, b));
        }
    }
    Ok(())
}

/// Volume, centroid and inertia of the solid a closed surface encloses, at unit density.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MassProperties {
    /// [m^3]
    pub volume: f64,
    /// [m]
    pub centroid: Vec3,
    /// inertia tensor about the centroid per unit density [m^5]
    pub inertia: Matrix3<f64>,
}

impl MassProperties {
    /// By the divergence theorem: a signed tetrahedron from the origin to every triangle.
    pub fn of_surface(vertices: &[Vec3], triangles: &[[u32; 3]]) -> Self {
        let (mut volume, mut first, mut second) = (0.0, Vec3::zeros(), Matrix3::zeros());
        for t in triangles {
            let [a, b, c] = t.map(|v| vertices[v as usize]);
            let v = a.dot(&b.cross(&c)) / 6.0;
            let sum = a + b + c;
            volume += v;
            first += sum * (v / 4.0);
            // the tetrahedron (0, a, b, c): integral of x x^T = V/20 (sum of v v^T + s s^T)
            second += (a * a.transpose() + b * b.transpose() + c * c.transpose() + sum * sum.transpose()) * (v / 20.0);
        }
        let centroid = first / volume;
        let central = second - centroid * centroid.transpose() * volume;
        Self { volume, centroid, inertia: Matrix3::identity() * central.trace() - central }
    }
}

impl TriangleSurface {
    /// The point of triangle `triangle` at barycentric `weights`, body frame [m]: a material
    /// point that moves with a deforming surface.
    pub fn point_at(&self, triangle: u32, weights: [f64; 3]) -> Vec3 {
        let corners = self.triangles[triangle as usize];
        let v = |k: usize| self.vertices[corners[k] as usize];
        v(0) * weights[0] + v(1) * weights[1] + v(2) * weights[2]
    }

    /// A surface whose queries find triangles within `reach` [m], with cubes of edge `cell`
    /// [m]. Refuses open, inside-out and degenerate surfaces.
    pub fn new(vertices: Vec<Vec3>, triangles: Vec<[u32; 3]>, reach: f64, cell: f64) -> Result<Self, SurfaceError> {
        check_closed(&triangles).map_err(|(a, b)| SurfaceError::Open(a, b))?;
        for (k, t) in triangles.iter().enumerate() {
            let [a, b, c] = t.map(|v| vertices[v as usize]);
            let length = (b - a).cross(&(c - a)).norm();
            if length.is_nan() || length <= 0.0 {
                return Err(SurfaceError::Degenerate(k));
            }
        }
        let volume = MassProperties::of_surface(&vertices, &triangles).volume;
        if volume.is_nan() || volume <= 0.0 {
            return Err(SurfaceError::InsideOut(volume));
        }
        let (listed, binned, area) = search_listings(&vertices, &triangles, reach, cell, RIVAL_REACH * reach);
        let entries = listed.max(binned);
        if !(entries <= MOST_SEARCH_ENTRIES) {
            return Err(SurfaceError::TooLarge {
                area,
                entries,
                cell,
                gigabytes: entries * BYTES_PER_LISTING / 1e9,
                most: MOST_SEARCH_ENTRIES,
            });
        }
        // the triangle across each edge (a closed surface has exactly one)
        let mut owner: HashMap<(u32, u32), u32> = HashMap::new();
        for (k, t) in triangles.iter().enumerate() {
            for e in 0..3 {
                owner.insert((t[e], t[(e + 1) % 3]), k as u32);
            }
        }
        let across = triangles.iter().map(|t| [0, 1, 2].map(|e| owner[&(t[(e + 1) % 3], t[e])])).collect();
        let n = triangles.len();
        let mut surface = Self {
            grid: CellGrid::new(&vertices, &triangles, reach, cell),
            grid_vertices: vertices.clone(),
            vertices,
            triangles,
            face_normals: vec![Vec3::z(); n],
            bounds: vec![(Vec3::zeros(), 0.0); n],
            edge_normals: vec![[Vec3::zeros(); 3]; n],
            vertex_normals: Vec::new(),
            across,
            shortest_height: vec![0.0; n],
            rivals: Vec::new(),
            rival_start: Vec::new(),
            face_margin: 0.0,
            reach,
            margin: 0.0,
        };
        surface.update_geometry();
        let (low, high) = surface
            .vertices
            .iter()
            .fold((Vec3::repeat(f64::INFINITY), Vec3::repeat(f64::NEG_INFINITY)), |(l, h), v| (l.inf(v), h.sup(v)));
        let extent = (high - low).norm();
        surface.find_rivals(PLANE_TOLERANCE * extent);
        // a triangle that is no rival is farther by at least the margin squared in squared
        // distance, which dwarfs what the tolerance and rounding can take off
        surface.face_margin = FACE_MARGIN * (reach * extent).sqrt();
        Ok(surface)
    }

    /// Lists, for each triangle `t`, its rivals: the triangles within [`RIVAL_REACH`] reaches
    /// of it that could be nearer than `t` to a point over `t`'s face. Any other triangle `u`
    /// lies under `t`'s plane, and a line in that plane parts its shadow from `t` (each to
    /// `tolerance` [m]); then for a point `p` at height `h` over a point `q` of `t` at least
    /// `e` inside its edges, `|p - x|^2 >= h^2 + e^2` (less terms of the tolerance) for every
    /// point `x` of `u`, while `t` is at `h` (theory P10). On a convex surface no triangle
    /// has rivals.
    fn find_rivals(&mut self, tolerance: f64) {
        let n = self.triangles.len();
        let corners: Vec<[Vec3; 3]> = self.triangles.iter().map(|t| t.map(|v| self.vertices[v as usize])).collect();
        // u is no rival of t when it lies under t's plane and a line in that plane has t on
        // one side and u's shadow on the other: one of the six edge lines of the two, if any
        // (two convex polygons apart are parted by an edge line of one of them)
        let no_rival = |t: usize, u: usize| {
            let (own, others, normal) = (&corners[t], &corners[u], self.face_normals[t]);
            let parted = |from: &Vec3, to: &Vec3| {
                let across = (to - from).cross(&normal);
                let length = across.norm();
                if length == 0.0 {
                    return false;
                }
                let side = |x: &Vec3| (x - from).dot(&across) / length;
                let (mine, theirs) = (own.map(|x| side(&x)), others.map(|x| side(&x)));
                (mine.iter().all(|&d| d >= -tolerance) && theirs.iter().all(|&d| d <= tolerance))
                    || (mine.iter().all(|&d| d <= tolerance) && theirs.iter().all(|&d| d >= -tolerance))
            };
            others.iter().all(|x| (x - own[0]).dot(&normal) <= tolerance)
                && (0..3).any(|e| parted(&own[e], &own[(e + 1) % 3]) || parted(&others[e], &others[(e + 1) % 3]))
        };
        // pairs whose bounding boxes come within the rival reach: boxes binned in cubes of
        // that edge, each triangle meeting those in the cubes its box, one cube wider, meets
        let cell = RIVAL_REACH * self.reach;
        let key = |x: &Vec3| cube_of(x, cell);
        let boxes: Vec<(Vec3, Vec3)> =
            corners.iter().map(|c| (c[0].inf(&c[1]).inf(&c[2]), c[0].sup(&c[1]).sup(&c[2]))).collect();
        let mut binned: Vec<([i32; 3], u32)> = Vec::new();
        for (t, (low, high)) in boxes.iter().enumerate() {
            let (low, high) = (key(low), key(high));
            for i in low[0]..=high[0] {
                for j in low[1]..=high[1] {
                    for k in low[2]..=high[2] {
                        binned.push(([i, j, k], t as u32));
                    }
                }
            }
        }
        binned.sort_unstable();
        let mut met = vec![u32::MAX; n];
        let mut rivals: Vec<(u32, u32)> = Vec::new();
        for (t, (low, high)) in boxes.iter().enumerate() {
            let (first, last) = (key(low), key(high));
            let (first, last) = (first.map(|c| c.saturating_sub(1)), last.map(|c| c.saturating_add(1)));
            for i in first[0]..=last[0] {
                for j in first[1]..=last[1] {
                    for k in first[2]..=last[2] {
                        let from = binned.partition_point(|(c, _)| *c < [i, j, k]);
                        for &(_, u) in binned[from..].iter().take_while(|(c, _)| *c == [i, j, k]) {
                            let u = u as usize;
                            if u == t || std::mem::replace(&mut met[u], t as u32) == t as u32 {
                                continue;
                            }
                            let gap = (boxes[u].0 - high).sup(&(low - boxes[u].1)).sup(&Vec3::zeros()).norm();
                            if gap <= cell && !no_rival(t, u) {
                                rivals.push((t as u32, u as u32));
                            }
                        }
                    }
                }
            }
        }
        rivals.sort_unstable();
        crate::neighbour::count_rows(n, rivals.iter().map(|&(t, _)| t as usize), &mut self.rival_start);
        self.rivals = rivals.into_iter().map(|(_, u)| u).collect();
    }

    /// Normals, pseudonormals and bounding spheres of the current vertices. A triangle that
    /// deformation has collapsed keeps its last normal.
    fn update_geometry(&mut self) {
        let vertices = &self.vertices;
        for (t, normal) in self.triangles.iter().zip(&mut self.face_normals) {
            let [a, b, c] = t.map(|v| vertices[v as usize]);
            let n = (b - a).cross(&(c - a));
            let length = n.norm();
            if length > 0.0 {
                *normal = n / length;
            }
        }
        self.vertex_normals.clear();
        self.vertex_normals.resize(vertices.len(), Vec3::zeros());
        for (k, t) in self.triangles.iter().enumerate() {
            let n = self.face_normals[k];
            for e in 0..3 {
                let (v, next, previous) = (t[e], t[(e + 1) % 3], t[(e + 2) % 3]);
                let (p, q) = (
                    vertices[next as usize] - vertices[v as usize],
                    vertices[previous as usize] - vertices[v as usize],
                );
                self.vertex_normals[v as usize] += n * p.angle(&q);
                self.edge_normals[k][e] = n + self.face_normals[self.across[k][e] as usize];
            }
            let corners = t.map(|v| vertices[v as usize]);
            let centre = (corners[0] + corners[1] + corners[2]) / 3.0;
            self.bounds[k] = (centre, corners.iter().map(|c| (c - centre).norm()).fold(0.0, f64::max));
            let longest = (0..3).map(|e| (corners[(e + 1) % 3] - corners[e]).norm()).fold(0.0, f64::max);
            self.shortest_height[k] = (corners[1] - corners[0]).cross(&(corners[2] - corners[0])).norm() / longest;
        }
    }

    /// Lets the vertices move up to `margin` [m] between rebuilds of the cubes (a deformable
    /// body): the cubes then list triangles within the reach plus the margin.
    pub fn set_margin(&mut self, margin: f64) {
        self.margin = margin;
        // a deforming surface answers by search only
        (self.rivals, self.rival_start) = (Vec::new(), Vec::new());
        self.grid = CellGrid::new(&self.vertices, &self.triangles, self.reach + margin, self.grid.cell);
        self.grid_vertices.clone_from(&self.vertices);
    }

    /// Whether the vertices may move (a margin was set): a deformable body's surface.
    pub fn deforms(&self) -> bool {
        self.margin > 0.0
    }

    /// Moves the vertices (same triangles) and refreshes normals; rebuilds the cubes once a
    /// vertex has moved more than the margin since their last build.
    pub fn set_vertices(&mut self, vertices: &[Vec3]) {
        self.vertices.copy_from_slice(vertices);
        self.update_geometry();
        let moved =
            self.vertices.iter().zip(&self.grid_vertices).map(|(v, g)| (v - g).norm_squared()).fold(0.0, f64::max);
        if moved > self.margin * self.margin {
            self.grid = CellGrid::new(&self.vertices, &self.triangles, self.reach + self.margin, self.grid.cell);
            self.grid_vertices.clone_from(&self.vertices);
        }
    }

    /// The closest surface point to `p` if one lies within the reach (ties go to the lower
    /// triangle index, so the answer does not depend on the order of the search).
    pub fn closest(&self, p: &Vec3) -> Option<SurfacePoint> {
        let mut best: Option<(f64, u32, Vec3, [f64; 3], Feature)> = None;
        // nothing beyond the reach counts; a triangle whose bounding sphere lies farther than
        // the best distance so far is strictly farther, so skipping it changes no answer
        let mut limit = self.reach;
        for &t in self.grid.near(p) {
            let (centre, radius) = self.bounds[t as usize];
            if (p - centre).norm_squared() > (limit + radius) * (limit + radius) {
                continue;
            }
            let [a, b, c] = self.triangles[t as usize].map(|v| self.vertices[v as usize]);
            // nor one whose plane is farther: no point of the triangle is nearer than it (with
            // a margin far above rounding, so a triangle tied with the best is still tested)
            if (p - a).dot(&self.face_normals[t as usize]).abs() > limit * (1.0 + 1e-9) {
                continue;
            }
            let (q, weights, feature) = closest_point_on_triangle(p, &a, &b, &c);
            let squared = (p - q).norm_squared();
            if squared <= self.reach * self.reach
                && best.is_none_or(|(d, u, ..)| squared < d || (squared == d && t < u))
            {
                best = Some((squared, t, q, weights, feature));
                limit = squared.sqrt();
            }
        }
        let (squared, t, point, weights, feature) = best?;
        Some(self.surface_point(p, squared, t, point, weights, feature))
    }

    /// [`Self::closest`], the same answer, found without a search when `p` lies over the
    /// interior of triangle `hint` (say the triangle it was found over a step before) of a
    /// rigid surface (`Self::over_face`). Any `hint` gives the same answer;
    /// [`crate::NONE`] searches.
    #[inline]
    pub fn closest_near(&self, p: &Vec3, hint: u32) -> Option<SurfacePoint> {
        self.over_face(p, hint).unwrap_or_else(|| self.closest(p))
    }

    /// The answer of [`Self::closest`] when `p` lies at least the face margin over the face
    /// of triangle `hint` and inside its edges, and within twice the reach, on a rigid
    /// surface: only that triangle and its rivals can then be nearest, as every other
    /// triangle is farther by the square of the margin or more in squared distance (theory
    /// P10). `None` when `p` is not so placed, or lies within rounding of the reach.
    #[inline]
    fn over_face(&self, p: &Vec3, hint: u32) -> Option<Option<SurfacePoint>> {
        if self.deforms() || hint as usize >= self.triangles.len() {
            return None;
        }
        let t = hint as usize;
        let [a, b, c] = self.triangles[t].map(|v| self.vertices[v as usize]);
        let (q, weights, feature) = closest_point_on_triangle(p, &a, &b, &c);
        let inside_edges =
            weights.iter().fold(f64::INFINITY, |m, &w| m.min(w)) * self.shortest_height[t] >= self.face_margin;
        let height = (p - a).dot(&self.face_normals[t]);
        if feature != Feature::Face || !inside_edges || height < self.face_margin || height > 2.0 * self.reach {
            return None;
        }
        let mut best = ((p - q).norm_squared(), hint, q, weights, feature);
        for &u in &self.rivals[self.rival_start[t] as usize..self.rival_start[t + 1] as usize] {
            let [a, b, c] = self.triangles[u as usize].map(|v| self.vertices[v as usize]);
            let (q, weights, feature) = closest_point_on_triangle(p, &a, &b, &c);
            let squared = (p - q).norm_squared();
            if squared < best.0 || (squared == best.0 && u < best.1) {
                best = (squared, u, q, weights, feature);
            }
        }
        let (squared, u, q, weights, feature) = best;
        let reach_squared = self.reach * self.reach;
        // at the reach itself the search decides (its cubes list by a rounded test)
        if squared < reach_squared * (1.0 - REACH_ROUNDING) {
            Some(Some(self.surface_point(p, squared, u, q, weights, feature)))
        } else if squared > reach_squared * (1.0 + REACH_ROUNDING) {
            Some(None)
        } else {
            None
        }
    }

    /// The answer for `p` whose closest point, at `squared` distance, is `point` of triangle
    /// `t` at `weights` on `feature`: signed by the feature's pseudonormal.
    #[inline]
    fn surface_point(
        &self,
        p: &Vec3,
        squared: f64,
        t: u32,
        point: Vec3,
        weights: [f64; 3],
        feature: Feature,
    ) -> SurfacePoint {
        let pseudonormal = match feature {
            Feature::Face => self.face_normals[t as usize],
            Feature::Edge(k) => self.edge_normals[t as usize][k as usize],
            Feature::Vertex(k) => self.vertex_normals[self.triangles[t as usize][k as usize] as usize],
        };
        let offset = p - point;
        let distance = squared.sqrt();
        let outside = offset.dot(&pseudonormal) >= 0.0;
        let normal = if distance > 0.0 {
            offset * (if outside { 1.0 } else { -1.0 } / distance)
        } else {
            pseudonormal.normalize()
        };
        SurfacePoint { distance: if outside { distance } else { -distance }, normal, point, triangle: t, weights }
    }
}

/// How far (relative to the surface's extent) a triangle may lie above another's plane, or
/// inside one of its edge lines, and be no rival of it: coplanar triangles, to rounding.
const PLANE_TOLERANCE: f64 = 1e-12;
/// The face margin of [`TriangleSurface::closest_near`] relative to the geometric mean of the
/// reach and the surface's extent: its square is 10^3 times the squared-distance error that
/// [`PLANE_TOLERANCE`] allows (`2 (2 reach + margin) tolerance` at heights up to twice the
/// reach) and 10^7 times the rounding of a squared distance.
const FACE_MARGIN: f64 = 1e-4;
/// How many reaches apart two triangles may be and still be rivals: a point within twice
/// the reach of one triangle, and nearer to another, is within three reaches of both.
const RIVAL_REACH: f64 = 3.0;
/// Relative band around the squared reach in which [`TriangleSurface::closest_near`] leaves
/// the answer to the search.
const REACH_ROUNDING: f64 = 1e-9;

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    pub(super) fn random_vector(rng: &mut impl Rng, scale: f64) -> Vec3 {
        Vec3::new(rng.random_range(-scale..scale), rng.random_range(-scale..scale), rng.random_range(-scale..scale))
    }

    /// The closest of a dense sample of the triangle's points.
    fn brute_force(p: &Vec3, a: &Vec3, b: &Vec3, c: &Vec3) -> f64 {
        let n = 200;
        let mut best = f64::INFINITY;
        for i in 0..=n {
            for j in 0..=n - i {
                let (u, v) = (i as f64 / n as f64, j as f64 / n as f64);
                best = best.min((a + (b - a) * u + (c - a) * v - p).norm());
            }
        }
        best
    }

    #[test]
    fn closest_point_matches_brute_force_on_random_triangles() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(17);
        let mut features = std::collections::BTreeSet::new();
        for _ in 0..300 {
            let (a, b, c) = (random_vector(&mut rng, 1.0), random_vector(&mut rng, 1.0), random_vector(&mut rng, 1.0));
            let p = random_vector(&mut rng, 2.0);
            let (q, weights, feature) = closest_point_on_triangle(&p, &a, &b, &c);
            features.insert(format!("{feature:?}").chars().next().unwrap());
            // the point is the weighted vertices, the weights a partition of unity in [0, 1]
            assert!((a * weights[0] + b * weights[1] + c * weights[2] - q).norm() < 1e-12);
            assert!(
                (weights.iter().sum::<f64>() - 1.0).abs() < 1e-12
                    && weights.iter().all(|&w| (-1e-12..=1.0 + 1e-12).contains(&w))
            );
            // no sampled point is closer (the sample spacing bounds the error)
            let (exact, sampled) = ((q - p).norm(), brute_force(&p, &a, &b, &c));
            let spacing = ((b - a).norm() + (c - a).norm()) / 200.0;
            assert!(exact <= sampled + 1e-12 && sampled - exact <= spacing, "{exact} vs {sampled}");
            // the feature agrees with the weights
            match feature {
                Feature::Face => assert!(weights.iter().all(|&w| w > 0.0)),
                Feature::Edge(k) => assert_eq!(weights[(k as usize + 2) % 3], 0.0),
                Feature::Vertex(k) => assert_eq!(weights[k as usize], 1.0),
            }
        }
        assert_eq!(features.len(), 3, "faces, edges and vertices all occur: {features:?}");
    }

    #[test]
    fn points_above_the_face_project_straight_down() {
        let (a, b, c) = (Vec3::zeros(), Vec3::x(), Vec3::y());
        let (q, weights, feature) = closest_point_on_triangle(&Vec3::new(0.25, 0.25, 3.0), &a, &b, &c);
        assert_eq!(feature, Feature::Face);
        assert!((q - Vec3::new(0.25, 0.25, 0.0)).norm() < 1e-15);
        assert!((weights[0] - 0.5).abs() < 1e-15);
        assert_eq!(closest_point_on_triangle(&Vec3::new(2.0, -1.0, 0.0), &a, &b, &c).2, Feature::Vertex(1));
        assert_eq!(closest_point_on_triangle(&Vec3::new(0.8, 0.8, 0.3), &a, &b, &c).2, Feature::Edge(1));
    }
}

/// Box [-a, a] x [-b, b] x [-c, c]: 8 vertices, 12 triangles, normals out.
#[cfg(test)]
pub(crate) fn boxed(a: f64, b: f64, c: f64) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let vertices = (0..8)
        .map(|k| {
            Vec3::new(if k & 1 == 0 { -a } else { a }, if k & 2 == 0 { -b } else { b }, if k & 4 == 0 { -c } else { c })
        })
        .collect();
    let quads = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
    let triangles = quads.iter().flat_map(|q: &[u32; 4]| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]).collect();
    (vertices, triangles)
}

#[cfg(test)]
mod surface_tests {
    use super::tests::random_vector;
    use super::*;
    use crate::NONE;
    use rand::{Rng, SeedableRng};

    #[test]
    fn grid_queries_match_brute_force_and_sign_by_pseudonormals() {
        let (a, b, c) = (1.0, 0.6, 0.3);
        let (vertices, triangles) = boxed(a, b, c);
        let reach = 0.25;
        let surface = TriangleSurface::new(vertices.clone(), triangles.clone(), reach, 0.07).unwrap();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let (mut inside, mut outside, mut missed) = (0, 0, 0);
        for _ in 0..20000 {
            let p = Vec3::new(rng.random_range(-1.3..1.3), rng.random_range(-0.9..0.9), rng.random_range(-0.6..0.6));
            // the box's own signed distance
            let q = p.abs() - Vec3::new(a, b, c);
            let exact = if q.max() > 0.0 { q.sup(&Vec3::zeros()).norm() } else { q.max() };
            let brute = triangles
                .iter()
                .map(|t| {
                    (p - closest_point_on_triangle(
                        &p,
                        &vertices[t[0] as usize],
                        &vertices[t[1] as usize],
                        &vertices[t[2] as usize],
                    )
                    .0)
                        .norm()
                })
                .fold(f64::INFINITY, f64::min);
            assert!((exact.abs() - brute).abs() < 1e-12);
            match surface.closest(&p) {
                Some(found) => {
                    assert!((found.distance - exact).abs() < 1e-12, "{p:?}: {} vs {exact}", found.distance);
                    assert!((found.normal.norm() - 1.0).abs() < 1e-12);
                    // the normal leads from the surface point to an outside point
                    assert!((found.point + found.normal * found.distance - p).norm() < 1e-12);
                    if found.distance < 0.0 {
                        inside += 1
                    } else {
                        outside += 1
                    }
                }
                None => {
                    assert!(brute > reach, "{p:?} is within reach ({brute}) but was not found");
                    missed += 1;
                }
            }
        }
        assert!(inside > 100 && outside > 100 && missed > 100, "{inside} {outside} {missed}");
    }

    /// An octahedron subdivided `levels` times onto the unit sphere, each vertex's radius
    /// scaled by `1 + bump` times a random number in [-1, 1]: a closed surface with concave
    /// edges wherever a vertex sits lower than its neighbours.
    fn bumpy_sphere(levels: usize, bump: f64, seed: u64) -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let mut vertices = vec![Vec3::x(), -Vec3::x(), Vec3::y(), -Vec3::y(), Vec3::z(), -Vec3::z()];
        let mut triangles: Vec<[u32; 3]> =
            vec![[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]];
        for _ in 0..levels {
            let mut middle: HashMap<(u32, u32), u32> = HashMap::new();
            let mut split = |a: u32, b: u32, vertices: &mut Vec<Vec3>| {
                *middle.entry((a.min(b), a.max(b))).or_insert_with(|| {
                    vertices.push(((vertices[a as usize] + vertices[b as usize]) * 0.5).normalize());
                    (vertices.len() - 1) as u32
                })
            };
            triangles = triangles
                .iter()
                .flat_map(|&[a, b, c]| {
                    let (ab, bc, ca) =
                        (split(a, b, &mut vertices), split(b, c, &mut vertices), split(c, a, &mut vertices));
                    [[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]
                })
                .collect();
        }
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        for v in &mut vertices {
            *v *= 1.0 + bump * rng.random_range(-1.0..1.0);
        }
        (vertices, triangles)
    }

    #[test]
    fn an_answer_over_a_face_is_the_searched_answer_on_convex_and_bumpy_surfaces() {
        let reach = 0.12;
        let (box_vertices, box_triangles) = boxed(1.0, 0.6, 0.3);
        let meshes = [
            ("box", box_vertices, box_triangles),
            ("sphere", bumpy_sphere(3, 0.0, 1).0, bumpy_sphere(3, 0.0, 1).1),
            ("bumpy sphere", bumpy_sphere(3, 0.04, 2).0, bumpy_sphere(3, 0.04, 2).1),
        ];
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        for (name, vertices, triangles) in meshes {
            let surface = TriangleSurface::new(vertices, triangles, reach, 0.05).unwrap();
            let n = surface.triangles.len() as u32;
            // a convex surface has no rivals; the bumpy one has, and needs them
            assert_eq!(surface.rivals.is_empty(), name != "bumpy sphere", "{name}: {} rivals", surface.rivals.len());
            let (mut found, mut beyond, mut rival_won) = (0, 0, 0);
            for _ in 0..40_000 {
                // near a random vertex, inside or out, up to three reaches away
                let v = surface.vertices[rng.random_range(0..surface.vertices.len())];
                let p = v + random_vector(&mut rng, 3.0 * reach);
                let searched = surface.closest(&p);
                // hints: the answer, the answer for a point nearby (a node a step later), any
                // triangle, none
                let nearby = surface.closest(&(p + random_vector(&mut rng, 0.1 * reach))).map_or(NONE, |s| s.triangle);
                for hint in [searched.map_or(NONE, |s| s.triangle), nearby, rng.random_range(0..n), NONE] {
                    assert_eq!(surface.closest_near(&p, hint), searched, "{name}: {p:?}, hint {hint}");
                    match surface.over_face(&p, hint) {
                        Some(Some(answer)) => {
                            found += 1;
                            rival_won += (answer.triangle != hint) as usize;
                        }
                        Some(None) => beyond += 1,
                        None => {}
                    }
                }
            }
            assert!(found > 5_000 && beyond > 100, "{name}: {found} answered over a face, {beyond} beyond the reach");
            assert_eq!(rival_won > 50, name == "bumpy sphere", "{name}: a rival was nearest {rival_won} times");
        }
    }

    #[test]
    fn a_deforming_surface_answers_like_one_built_afresh() {
        let (vertices, triangles) = boxed(1.0, 0.6, 0.3);
        let (reach, margin) = (0.2, 0.05);
        let mut moving = TriangleSurface::new(vertices.clone(), triangles.clone(), reach, 0.07).unwrap();
        moving.set_margin(margin);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
        for step in 1..=30 {
            // a growing shear and a drift: the cubes are rebuilt now and then
            let moved: Vec<Vec3> =
                vertices.iter().map(|v| v + Vec3::new(0.01 * step as f64 * v.z, 0.004 * step as f64, 0.0)).collect();
            moving.set_vertices(&moved);
            let fresh = TriangleSurface::new(moved, triangles.clone(), reach, 0.07).unwrap();
            for _ in 0..300 {
                let p =
                    Vec3::new(rng.random_range(-1.5..1.5), rng.random_range(-0.9..1.0), rng.random_range(-0.6..0.6));
                assert_eq!(moving.closest(&p), fresh.closest(&p), "step {step}, {p:?}");
            }
        }
    }

    #[test]
    fn mass_properties_of_a_moved_box_are_the_analytic_ones() {
        let (a, b, c) = (0.5, 0.2, 0.1);
        let (vertices, triangles) = boxed(a, b, c);
        let rotation = nalgebra::Rotation3::from_scaled_axis(Vec3::new(0.3, -0.7, 0.2));
        let shift = Vec3::new(1.0, 2.0, -3.0);
        let moved: Vec<Vec3> = vertices.iter().map(|v| rotation * v + shift).collect();
        let properties = MassProperties::of_surface(&moved, &triangles);
        let volume = 8.0 * a * b * c;
        assert!((properties.volume - volume).abs() < 1e-14);
        assert!((properties.centroid - shift).norm() < 1e-12);
        let (x, y, z) = (2.0 * a, 2.0 * b, 2.0 * c);
        let principal =
            Matrix3::from_diagonal(&Vec3::new(y * y + z * z, x * x + z * z, x * x + y * y)) * (volume / 12.0);
        let expected = rotation.matrix() * principal * rotation.matrix().transpose();
        assert!(
            (properties.inertia - expected).norm() < 1e-12 * expected.norm(),
            "{:?} vs {expected:?}",
            properties.inertia
        );
    }

    #[test]
    fn open_inside_out_and_degenerate_surfaces_are_refused() {
        let (vertices, mut triangles) = boxed(1.0, 1.0, 1.0);
        let flipped: Vec<[u32; 3]> = triangles.iter().map(|t| [t[0], t[2], t[1]]).collect();
        assert!(
            matches!(TriangleSurface::new(vertices.clone(), flipped, 0.1, 0.1), Err(SurfaceError::InsideOut(v)) if v < 0.0)
        );
        let mut flat = vertices.clone();
        flat.iter_mut().for_each(|v| v.z = 0.0);
        assert!(matches!(TriangleSurface::new(flat, triangles.clone(), 0.1, 0.1), Err(SurfaceError::Degenerate(_))));
        triangles.pop();
        assert!(matches!(TriangleSurface::new(vertices, triangles, 0.1, 0.1), Err(SurfaceError::Open(..))));
    }

    #[test]
    fn the_search_listings_are_estimated_before_they_are_made() {
        // a box turned off the axes (slanted faces) and an axis-aligned one: the estimate
        // is within a factor of two of the listings the grid makes
        let (vertices, triangles) = boxed(0.5, 0.3, 0.2);
        let turn = nalgebra::Rotation3::from_euler_angles(0.3, 0.5, 0.7);
        for vertices in [vertices.clone(), vertices.iter().map(|v| turn * v).collect()] {
            let (reach, cell) = (0.02, 0.03);
            let (listed, ..) = search_listings(&vertices, &triangles, reach, cell, RIVAL_REACH * reach);
            let made = CellGrid::new(&vertices, &triangles, reach, cell).entries.len() as f64;
            assert!((0.5..2.0).contains(&(listed / made)), "estimated {listed}, made {made}");
        }
        // a 0.1 m box against a 12 um filament (reach and cube of the contact search): about
        // 10^9 listings, refused at once instead of taking tens of GB
        let tiny = 12e-6;
        let (vertices, triangles) = boxed(0.05, 0.05, 0.05);
        let started = std::time::Instant::now();
        let refused = TriangleSurface::new(vertices.clone(), triangles.clone(), 0.75 * tiny, 1.3 * tiny);
        match refused {
            Err(SurfaceError::TooLarge { entries, gigabytes, .. }) => {
                assert!(entries > 1e8 && gigabytes > 1.0, "{entries} {gigabytes}");
            }
            other => panic!("not refused: {other:?}"),
        }
        assert!(started.elapsed().as_secs_f64() < 1.0, "the refusal comes before the work");
        // a 17-grain FSP's size (a 5.5 mm box) against the same filament is accepted
        let small: Vec<Vec3> = vertices.iter().map(|v| v * 0.055).collect();
        assert!(TriangleSurface::new(small, triangles, 0.75 * tiny, 1.3 * tiny).is_ok());
    }
}
