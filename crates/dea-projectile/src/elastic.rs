//! Deformable projectile body (seed §4.3): linear-elastic 8-node hexahedra with element-by-
//! element internal forces, co-rotational so that large rotations carry no strain, HRZ
//! lumped masses (4-22 … 4-25) and the explicit stable time step of the mesh.
//!
//! Each element's rotation is the rotation of the polar decomposition of its deformation
//! gradient at the centre, found by the warm-started iteration of Müller et al. (2016);
//! strains are the small strains of the unrotated displacements, integrated with 2 x 2 x 2
//! Gauss points.

use dea_core::Vec3;
use nalgebra::{Matrix3, UnitQuaternion};

use crate::mesh::{trilinear, HexMesh, CORNERS, FACES};

/// An isotropic linear-elastic material.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ElasticMaterial {
    /// [kg/m^3]
    pub density: f64,
    /// [Pa]
    pub youngs_modulus: f64,
    /// [-]
    pub poisson_ratio: f64,
    /// the constitutive model
    pub model: ElasticModel,
}

/// How strain becomes stress.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ElasticModel {
    /// Hooke's law on the small strain of the displacement with the element's rotation taken
    /// out: linear elasticity at any rotation (the seed's linear-elastic body)
    #[default]
    Corotational,
    /// compressible neo-Hookean, `W = mu/2 (I1 - 3) - mu ln J + lambda/2 (ln J)^2`: the same
    /// at small strain, hyperelastic (energy-conserving) at large strain, and an energy
    /// barrier against inversion
    NeoHookean,
}

impl ElasticMaterial {
    /// Lamé's first parameter and the shear modulus [Pa].
    fn lame(&self) -> (f64, f64) {
        let (e, nu) = (self.youngs_modulus, self.poisson_ratio);
        (e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)), e / (2.0 * (1.0 + nu)))
    }

    /// Dilatational wave speed [m/s].
    pub fn wave_speed(&self) -> f64 {
        let (lambda, mu) = self.lame();
        ((lambda + 2.0 * mu) / self.density).sqrt()
    }
}

/// Gauss points of the 2-point rule on [-1, 1].
const GAUSS_2: f64 = 0.577_350_269_189_625_8;

/// What an element needs at its Gauss points: shape-function gradients in the reference
/// configuration and integration weights (weight times Jacobian determinant).
#[derive(Clone, Debug, PartialEq)]
struct ElementData {
    gradients: [[Vec3; 8]; 8],
    weights: [f64; 8],
    /// shape-function gradients at the centre, for the rotation
    centre_gradients: [Vec3; 8],
}

/// Shape-function gradients with respect to the reference coordinates at natural point
/// `(r, s, t)`, and the Jacobian determinant.
fn reference_gradients(corners: &[Vec3; 8], r: f64, s: f64, t: f64) -> ([Vec3; 8], f64) {
    let (_, natural, jacobian) = trilinear(corners, r, s, t);
    let inverse_transpose = jacobian.try_inverse().unwrap_or_else(Matrix3::zeros).transpose();
    (natural.map(|g| inverse_transpose * g), jacobian.determinant())
}

/// Why a mesh cannot be an elastic body.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ElasticError {
    /// A hexahedron is inverted or degenerate.
    #[error("hexahedron {0} is inverted or degenerate at a Gauss point")]
    Inverted(usize),
    /// The material constants are out of range.
    #[error("density, Young's modulus must be positive and Poisson's ratio in [0, 0.5): {0:?}")]
    Material(ElasticMaterial),
}

/// A deformable body of 8-node hexahedra.
#[derive(Clone, Debug, PartialEq)]
pub struct ElasticBody {
    /// reference configuration
    pub mesh: HexMesh,
    /// its elastic constants
    pub material: ElasticMaterial,
    /// current node positions [m]
    pub position: Vec<Vec3>,
    /// [m/s]
    pub velocity: Vec<Vec3>,
    /// HRZ lumped masses [kg]
    pub mass: Vec<f64>,
    /// internal plus external force on each node [N]
    pub force: Vec<Vec3>,
    elements: Vec<ElementData>,
    /// each element's rotation at the last evaluation (the next one's first guess)
    rotations: Vec<UnitQuaternion<f64>>,
}

impl ElasticBody {
    /// The mesh at rest, with its HRZ masses.
    pub fn new(mesh: HexMesh, material: ElasticMaterial) -> Result<Self, ElasticError> {
        let m = material;
        if !(m.density > 0.0 && m.youngs_modulus > 0.0 && (0.0..0.5).contains(&m.poisson_ratio)) {
            return Err(ElasticError::Material(material));
        }
        let mut elements = Vec::with_capacity(mesh.hexes.len());
        for (e, hex) in mesh.hexes.iter().enumerate() {
            let corners = hex.map(|k| mesh.nodes[k as usize]);
            let mut data = ElementData { gradients: [[Vec3::zeros(); 8]; 8], weights: [0.0; 8], centre_gradients: reference_gradients(&corners, 0.0, 0.0, 0.0).0 };
            for (g, c) in CORNERS.iter().enumerate() {
                let (gradients, determinant) = reference_gradients(&corners, c[0] * GAUSS_2, c[1] * GAUSS_2, c[2] * GAUSS_2);
                if determinant.is_nan() || determinant <= 0.0 {
                    return Err(ElasticError::Inverted(e));
                }
                data.gradients[g] = gradients;
                data.weights[g] = determinant;
            }
            elements.push(data);
        }
        let n = mesh.nodes.len();
        Ok(Self {
            position: mesh.nodes.clone(),
            velocity: vec![Vec3::zeros(); n],
            mass: mesh.hrz_masses(material.density),
            force: vec![Vec3::zeros(); n],
            rotations: vec![UnitQuaternion::identity(); mesh.hexes.len()],
            elements,
            mesh,
            material,
        })
    }

    /// Sets `force` to the internal forces of the current positions and returns the strain
    /// energy [J], or the first element whose deformation gradient at the centre has no
    /// positive determinant (inverted, or not finite). External forces are added afterwards.
    pub fn internal_forces(&mut self) -> Result<f64, usize> {
        let (lambda, mu) = self.material.lame();
        self.force.iter_mut().for_each(|f| *f = Vec3::zeros());
        let mut energy = 0.0;
        for (e, hex) in self.mesh.hexes.iter().enumerate() {
            let data = &self.elements[e];
            let current = hex.map(|k| self.position[k as usize]);
            let reference = hex.map(|k| self.mesh.nodes[k as usize]);
            let deformation = (0..8).fold(Matrix3::zeros(), |f, a| f + current[a] * data.centre_gradients[a].transpose());
            let volume_ratio = deformation.determinant();
            if volume_ratio.is_nan() || volume_ratio <= 0.0 {
                return Err(e);
            }
            if self.material.model == ElasticModel::NeoHookean {
                energy += neo_hookean_forces(hex, &current, data, lambda, mu, &mut self.force).ok_or(e)?;
                continue;
            }
            let rotation = polar_rotation(&deformation, self.rotations[e]);
            self.rotations[e] = rotation;
            // displacements with the element's rotation and its centroid's motion taken out
            let (centre, reference_centre) = (current.iter().sum::<Vec3>() / 8.0, reference.iter().sum::<Vec3>() / 8.0);
            let local: [Vec3; 8] = std::array::from_fn(|a| rotation.inverse_transform_vector(&(current[a] - centre)) - (reference[a] - reference_centre));
            let mut local_force = [Vec3::zeros(); 8];
            for g in 0..8 {
                let gradient = (0..8).fold(Matrix3::zeros(), |h, a| h + local[a] * data.gradients[g][a].transpose());
                let strain = 0.5 * (gradient + gradient.transpose());
                let stress = Matrix3::identity() * (lambda * strain.trace()) + strain * (2.0 * mu);
                energy += 0.5 * stress.dot(&strain) * data.weights[g];
                for (force, gradient) in local_force.iter_mut().zip(&data.gradients[g]) {
                    *force -= stress * gradient * data.weights[g];
                }
            }
            for a in 0..8 {
                self.force[hex[a] as usize] += rotation * local_force[a];
            }
        }
        Ok(energy)
    }

    /// The explicit stable time step: the smallest element's characteristic length (volume
    /// over largest face area) over the dilatational wave speed [s].
    pub fn stable_time_step(&self) -> f64 {
        let volumes = self.mesh.volumes();
        let length = self
            .mesh
            .hexes
            .iter()
            .zip(&volumes)
            .map(|(hex, volume)| {
                let largest = FACES
                    .iter()
                    .map(|f| {
                        let p = f.map(|k| self.position[hex[k] as usize]);
                        0.5 * (p[2] - p[0]).cross(&(p[3] - p[1])).norm()
                    })
                    .fold(0.0, f64::max);
                volume / largest
            })
            .fold(f64::INFINITY, f64::min);
        length / self.material.wave_speed()
    }

    /// Words of everything a restart needs: positions, velocities and forces (3 per node
    /// each), and each element's last rotation (4, the next one's first guess).
    pub fn state_words(&self) -> Vec<f64> {
        let vectors = self.position.iter().chain(&self.velocity).chain(&self.force).flat_map(|v| [v.x, v.y, v.z]);
        vectors.chain(self.rotations.iter().flat_map(|q| q.quaternion().coords.data.0[0])).collect()
    }

    /// Inverse of [`Self::state_words`]; `None` when the words do not fit this mesh.
    pub fn set_state_words(&mut self, words: &[f64]) -> Option<()> {
        let n = self.position.len();
        if words.len() != 9 * n + 4 * self.rotations.len() {
            return None;
        }
        let vector = |k: usize| Vec3::new(words[3 * k], words[3 * k + 1], words[3 * k + 2]);
        for i in 0..n {
            self.position[i] = vector(i);
            self.velocity[i] = vector(n + i);
            self.force[i] = vector(2 * n + i);
        }
        for (e, q) in self.rotations.iter_mut().enumerate() {
            let w = &words[9 * n + 4 * e..9 * n + 4 * e + 4];
            *q = UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(w[3], w[0], w[1], w[2]));
        }
        Some(())
    }

    /// Centre of mass [m] and mean velocity [m/s], summed in node order.
    pub fn centre_of_mass(&self) -> (Vec3, Vec3) {
        let total: f64 = self.mass.iter().sum();
        let first: Vec3 = self.mass.iter().zip(&self.position).map(|(m, x)| x * *m).sum();
        (first / total, self.momentum() / total)
    }

    /// [J]
    pub fn kinetic_energy(&self) -> f64 {
        self.mass.iter().zip(&self.velocity).map(|(m, v)| 0.5 * m * v.norm_squared()).sum()
    }

    /// Total momentum [kg m/s].
    pub fn momentum(&self) -> Vec3 {
        self.mass.iter().zip(&self.velocity).map(|(m, v)| v * *m).sum()
    }

    /// Angular momentum about the origin [kg m^2/s].
    pub fn angular_momentum(&self) -> Vec3 {
        self.mass.iter().zip(&self.velocity).zip(&self.position).map(|((m, v), x)| x.cross(&(v * *m))).sum()
    }

    /// Half-step velocity update from `force`.
    pub fn kick(&mut self, half_dt: f64) {
        for ((v, f), m) in self.velocity.iter_mut().zip(&self.force).zip(&self.mass) {
            *v += f * (half_dt / m);
        }
    }

    /// Full-step position update.
    pub fn drift(&mut self, dt: f64) {
        for (x, v) in self.position.iter_mut().zip(&self.velocity) {
            *x += v * dt;
        }
    }
}

/// Adds the compressible neo-Hookean forces of one element to `force` and returns its strain
/// energy, or `None` where a Gauss point is inverted.
fn neo_hookean_forces(hex: &crate::mesh::Hex, current: &[Vec3; 8], data: &ElementData, lambda: f64, mu: f64, force: &mut [Vec3]) -> Option<f64> {
    let mut energy = 0.0;
    for g in 0..8 {
        let deformation = (0..8).fold(Matrix3::zeros(), |f, a| f + current[a] * data.gradients[g][a].transpose());
        let volume_ratio = deformation.determinant();
        if volume_ratio.is_nan() || volume_ratio <= 0.0 {
            return None;
        }
        let log_ratio = volume_ratio.ln();
        let inverse_transpose = deformation.try_inverse()?.transpose();
        // first Piola-Kirchhoff stress
        let stress = (deformation - inverse_transpose) * mu + inverse_transpose * (lambda * log_ratio);
        energy += (0.5 * mu * (deformation.norm_squared() - 3.0) - mu * log_ratio + 0.5 * lambda * log_ratio * log_ratio) * data.weights[g];
        for (a, gradient) in data.gradients[g].iter().enumerate() {
            force[hex[a] as usize] -= stress * gradient * data.weights[g];
        }
    }
    Some(energy)
}

/// The rotation of the polar decomposition of `deformation`, by the iteration of Müller,
/// Bender, Chentanez and Macklin (2016) started from `guess`: exact for a rotation, robust
/// for inverted and degenerate gradients, and cheap when warm-started.
fn polar_rotation(deformation: &Matrix3<f64>, guess: UnitQuaternion<f64>) -> UnitQuaternion<f64> {
    let mut rotation = guess;
    for _ in 0..20 {
        let r = rotation.to_rotation_matrix();
        let r = r.matrix();
        let mut numerator = Vec3::zeros();
        let mut denominator = 0.0;
        for k in 0..3 {
            let (column, target) = (r.column(k).into_owned(), deformation.column(k).into_owned());
            numerator += column.cross(&target);
            denominator += column.dot(&target);
        }
        let omega = numerator / (denominator.abs() + 1e-12 * deformation.norm());
        let angle = omega.norm();
        if angle < 1e-15 {
            break;
        }
        rotation = UnitQuaternion::from_scaled_axis(omega) * rotation;
        rotation.renormalize();
    }
    rotation
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::Hex;

    /// A block of nx x ny x nz bricks of size (a, b, c), interior nodes moved by `jitter` so
    /// that no element is a parallelepiped.
    fn block(nx: usize, ny: usize, nz: usize, size: Vec3, jitter: f64) -> HexMesh {
        let index = |i: usize, j: usize, k: usize| (i + (nx + 1) * (j + (ny + 1) * k)) as u32;
        let mut nodes = Vec::new();
        for k in 0..=nz {
            for j in 0..=ny {
                for i in 0..=nx {
                    let interior = i > 0 && i < nx && j > 0 && j < ny && k > 0 && k < nz;
                    let wobble = if interior { jitter * Vec3::new(((i * 7 + j * 3 + k) % 5) as f64 - 2.0, ((i + j * 5 + k * 3) % 5) as f64 - 2.0, ((i * 3 + j + k * 7) % 5) as f64 - 2.0) } else { Vec3::zeros() };
                    nodes.push(Vec3::new(size.x * i as f64 / nx as f64, size.y * j as f64 / ny as f64, size.z * k as f64 / nz as f64) + wobble);
                }
            }
        }
        let mut hexes: Vec<Hex> = Vec::new();
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    hexes.push([index(i, j, k), index(i + 1, j, k), index(i + 1, j + 1, k), index(i, j + 1, k), index(i, j, k + 1), index(i + 1, j, k + 1), index(i + 1, j + 1, k + 1), index(i, j + 1, k + 1)]);
                }
            }
        }
        HexMesh { nodes, hexes }
    }

    fn steel(youngs_modulus: f64, poisson_ratio: f64) -> ElasticMaterial {
        ElasticMaterial { density: 7689.0, youngs_modulus, poisson_ratio, model: ElasticModel::Corotational }
    }

    const MODELS: [ElasticModel; 2] = [ElasticModel::Corotational, ElasticModel::NeoHookean];

    #[test]
    fn patch_test_a_uniform_strain_leaves_interior_nodes_in_equilibrium() {
        for model in MODELS {
            patch_test(model);
        }
    }

    fn patch_test(model: ElasticModel) {
        let size = Vec3::new(2e-3, 1e-3, 1.5e-3);
        let mesh = block(3, 3, 3, size, 0.04e-3);
        let material = ElasticMaterial { model, ..steel(2.09e11, 0.3) };
        let mut body = ElasticBody::new(mesh, material).unwrap();
        // a small uniform strain (symmetric gradient: no rotation)
        let strain = Matrix3::new(1e-4, 2e-5, 0.0, 2e-5, -5e-5, 3e-5, 0.0, 3e-5, 8e-5);
        for (x, x0) in body.position.iter_mut().zip(&body.mesh.nodes) {
            *x = x0 + strain * x0;
        }
        let energy = body.internal_forces().unwrap();
        let (lambda, mu) = material.lame();
        let stress = Matrix3::identity() * (lambda * strain.trace()) + strain * (2.0 * mu);
        let volume = size.x * size.y * size.z;
        let scale = stress.norm() * size.y * size.z;
        let on_boundary = |x: &Vec3| x.x.abs() < 1e-12 || (x.x - size.x).abs() < 1e-12 || x.y.abs() < 1e-12 || (x.y - size.y).abs() < 1e-12 || x.z.abs() < 1e-12 || (x.z - size.z).abs() < 1e-12;
        for (x0, f) in body.mesh.nodes.iter().zip(&body.force) {
            if !on_boundary(x0) {
                assert!(f.norm() < 1e-9 * scale, "interior node at {x0:?} has force {f:?}");
            }
        }
        // the face x = size.x carries the traction sigma n over its area (to the strain's
        // square for the neo-Hookean law, which is linear only in the limit)
        let tolerance = if model == ElasticModel::Corotational { 1e-9 } else { 1e-3 };
        let face: Vec3 = body.mesh.nodes.iter().zip(&body.force).filter(|(x, _)| (x.x - size.x).abs() < 1e-12).map(|(_, f)| *f).sum();
        let traction = -stress * Vec3::x() * (size.y * size.z);
        assert!((face - traction).norm() < tolerance * scale, "{model:?}: {face:?} vs {traction:?}");
        assert!((energy - 0.5 * stress.dot(&strain) * volume).abs() < tolerance * energy, "{model:?}");
    }

    #[test]
    fn a_rigid_rotation_carries_no_force_and_a_rotated_strain_the_rotated_forces() {
        for model in MODELS {
            rotation_test(model);
        }
    }

    fn rotation_test(model: ElasticModel) {
        let mesh = block(2, 2, 2, Vec3::new(1e-3, 1e-3, 1e-3), 0.05e-3);
        let mut body = ElasticBody::new(mesh, ElasticMaterial { model, ..steel(2.09e11, 0.3) }).unwrap();
        let turn = UnitQuaternion::from_scaled_axis(Vec3::new(1.2, -0.4, 0.7));
        let strain = Matrix3::new(1e-3, 0.0, 2e-4, 0.0, -5e-4, 0.0, 2e-4, 0.0, 3e-4);
        body.internal_forces().unwrap();
        let reference = body.mesh.nodes.clone();
        for (x, x0) in body.position.iter_mut().zip(&reference) {
            *x = turn * x0 + Vec3::new(1.0, 2.0, 3.0);
        }
        let energy = body.internal_forces().unwrap();
        let largest = body.force.iter().map(|f| f.norm()).fold(0.0, f64::max);
        assert!(largest < 1e-3 && energy.abs() < 1e-15, "a rigid motion: {largest} N, {energy} J");
        // strained, then rotated: the forces of the strained state, rotated
        for (x, x0) in body.position.iter_mut().zip(&reference) {
            *x = x0 + strain * x0;
        }
        let unrotated_energy = body.internal_forces().unwrap();
        let unrotated = body.force.clone();
        for (x, x0) in body.position.iter_mut().zip(&reference) {
            *x = turn * (x0 + strain * x0);
        }
        let rotated_energy = body.internal_forces().unwrap();
        let scale = unrotated.iter().map(|f| f.norm()).fold(0.0, f64::max);
        for (f, g) in body.force.iter().zip(&unrotated) {
            assert!((f - turn * g).norm() < 1e-6 * scale);
        }
        assert!((rotated_energy - unrotated_energy).abs() < 1e-6 * unrotated_energy);
    }

    #[test]
    fn a_free_bar_rings_at_its_first_axial_frequency() {
        for model in MODELS {
            bar_test(model);
        }
    }

    fn bar_test(model: ElasticModel) {
        // a free-free bar, Poisson's ratio zero: one-dimensional axial waves, f1 = c / 2L
        let (length, side) = (20e-3, 1e-3);
        let mesh = block(40, 1, 1, Vec3::new(length, side, side), 0.0);
        let material = ElasticMaterial { model, ..steel(2.09e11, 0.0) };
        let mut body = ElasticBody::new(mesh, material).unwrap();
        let wave_speed = (material.youngs_modulus / material.density).sqrt();
        let period = 2.0 * length / wave_speed;
        // the first mode's velocity field
        for (v, x) in body.velocity.iter_mut().zip(&body.mesh.nodes) {
            *v = Vec3::new((std::f64::consts::PI * x.x / length).cos(), 0.0, 0.0);
        }
        let dt = 0.9 * body.stable_time_step();
        assert!(dt < length / 40.0 / wave_speed * 1.0001, "the step respects the element's transit time");
        let end = body.mesh.nodes.iter().position(|x| x.x == 0.0).unwrap();
        let momentum = body.momentum();
        let mut energy = body.kinetic_energy();
        body.internal_forces().unwrap();
        let (mut time, mut previous, mut crossings) = (0.0, body.velocity[end].x, Vec::new());
        while crossings.len() < 5 {
            body.kick(0.5 * dt);
            body.drift(dt);
            let strain_energy = body.internal_forces().unwrap();
            body.kick(0.5 * dt);
            time += dt;
            let now = body.velocity[end].x;
            if previous * now < 0.0 {
                crossings.push(time - dt * now / (now - previous));
            }
            previous = now;
            energy = energy.max(body.kinetic_energy() + strain_energy);
        }
        // zero crossings of the end's velocity every half period
        let measured = 2.0 * (crossings[4] - crossings[0]) / 4.0;
        assert!((measured / period - 1.0).abs() < 0.005, "period {measured} vs {period}");
        assert!((body.momentum() - momentum).norm() < 1e-12 * body.mass.iter().sum::<f64>(), "momentum kept");
        assert!((body.kinetic_energy() + body.internal_forces().unwrap() - energy).abs() < 0.01 * energy, "energy kept");
    }

    #[test]
    fn a_neo_hookean_block_squashed_by_a_third_rings_without_gaining_energy() {
        let size = Vec3::new(1e-3, 1e-3, 1e-3);
        let mut body = ElasticBody::new(block(3, 3, 3, size, 0.0), ElasticMaterial { model: ElasticModel::NeoHookean, ..steel(2.09e7, 0.3) }).unwrap();
        let reference = body.mesh.nodes.clone();
        for (x, x0) in body.position.iter_mut().zip(&reference) {
            *x = Vec3::new(x0.x, x0.y, x0.z * 0.67);
        }
        // a step well below the limit: central difference's bounded energy error, of order
        // (omega dt)^2, then stays far below the tolerance
        let dt = 0.05 * body.stable_time_step();
        let mut strain = body.internal_forces().unwrap();
        let start = strain;
        let mut lowest_strain = strain;
        for _ in 0..20000 {
            body.kick(0.5 * dt);
            body.drift(dt);
            strain = body.internal_forces().unwrap();
            body.kick(0.5 * dt);
            lowest_strain = lowest_strain.min(strain);
        }
        assert!(lowest_strain < 0.5 * start, "it rang: {lowest_strain} of {start}");
        let total = body.kinetic_energy() + strain;
        assert!((total / start - 1.0).abs() < 0.01, "energy {total} vs {start}");
    }

    #[test]
    fn an_inverted_element_is_reported() {
        let mut body = ElasticBody::new(block(2, 1, 1, Vec3::new(2e-3, 1e-3, 1e-3), 0.0), steel(2.09e7, 0.3)).unwrap();
        assert!(body.internal_forces().is_ok());
        // push the middle layer of nodes past the far end: the first element turns inside out
        for x in body.position.iter_mut() {
            if (x.x - 1e-3).abs() < 1e-12 {
                x.x = -0.5e-3;
            }
        }
        assert_eq!(body.internal_forces(), Err(0));
    }

    #[test]
    fn hrz_masses_of_the_body_sum_to_its_mass() {
        let mesh = block(3, 2, 2, Vec3::new(3e-3, 2e-3, 1e-3), 0.1e-3);
        let body = ElasticBody::new(mesh, steel(2.09e9, 0.3)).unwrap();
        let mass: f64 = body.mass.iter().sum();
        assert!((mass - 7689.0 * 6e-9).abs() < 1e-12 * mass);
        let mut inverted = block(1, 1, 1, Vec3::new(1.0, 1.0, 1.0), 0.0);
        inverted.hexes[0].swap(0, 4);
        assert_eq!(ElasticBody::new(inverted, steel(1.0, 0.3)), Err(ElasticError::Inverted(0)));
    }
}
