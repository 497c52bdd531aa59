//! Rigid projectile moving as a 6-degree-of-freedom rigid body: an analytic rounded core
//! (sphere; right circular cylinder with rounded edges) or a closed triangle surface (a
//! generated or imported mesh, seed §4.2.1.3).
//!
//! An analytic surface is the set of points at distance `rounding` from the core, so the
//! distance from a fibre node to it is a closed form and the edge radius of a cylinder (which
//! decides shear failure, seed §5.1, §6.2.1) is exact; a meshed surface resolves its edges
//! with its triangles.

use std::sync::Arc;

use crate::surface::{MassProperties, SurfaceError, SurfacePoint, TriangleSurface};
use crate::Vec3;
use nalgebra::{Matrix3, UnitQuaternion};

/// Shape in the body frame (body origin at the centre of mass; symmetry axis = body z).
#[derive(Clone, Debug, PartialEq)]
pub enum RigidShape {
    /// sphere of radius [m]
    Sphere {
        /// [m]
        radius: f64,
    },
    /// right circular cylinder: radius, height and edge radius [m]
    Cylinder {
        /// [m]
        radius: f64,
        /// [m]
        height: f64,
        /// radius of the rounded edges of both faces [m]
        edge_radius: f64,
    },
    /// closed triangle surface
    Mesh(Arc<MeshShape>),
}

/// A closed triangle surface with the mass properties of the solid it encloses (uniform
/// density), in a body frame whose origin is the centroid.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshShape {
    /// the closed, outward-oriented surface, body frame [m]
    pub surface: TriangleSurface,
    /// inertia tensor about the centroid per unit mass, body frame [m^2]
    pub inertia_per_mass: Matrix3<f64>,
    /// enclosed volume [m^3]
    pub volume: f64,
    /// largest distance of a vertex from the centroid [m]
    pub bounding_radius: f64,
}

impl MeshShape {
    /// Moves the surface's vertices (body frame, same order), as a deformable body does.
    pub fn set_vertices(&mut self, vertices: &[Vec3]) {
        self.surface.set_vertices(vertices);
        self.bounding_radius = vertices.iter().map(Vec3::norm).fold(0.0, f64::max);
    }

    /// The surface of `vertices` and `triangles` (any frame), shifted so that the centroid of
    /// the enclosed solid is the origin; returns it and that centroid in the original frame.
    /// Contact queries find the surface within `reach` [m] through cubes of edge `cell` [m].
    pub fn new(vertices: &[Vec3], triangles: Vec<[u32; 3]>, reach: f64, cell: f64) -> Result<(Self, Vec3), SurfaceError> {
        let properties = MassProperties::of_surface(vertices, &triangles);
        let centroid = properties.centroid;
        let centred: Vec<Vec3> = vertices.iter().map(|v| v - centroid).collect();
        let bounding_radius = centred.iter().map(Vec3::norm).fold(0.0, f64::max);
        let surface = TriangleSurface::new(centred, triangles, reach, cell)?;
        Ok((Self { surface, inertia_per_mass: properties.inertia / properties.volume, volume: properties.volume, bounding_radius }, centroid))
    }
}

impl RigidShape {
    /// (core radius, core half-height, rounding radius) [m].
    #[inline]
    fn core(&self) -> (f64, f64, f64) {
        match *self {
            RigidShape::Sphere { radius } => (0.0, 0.0, radius),
            RigidShape::Cylinder { radius, height, edge_radius } => (radius - edge_radius, 0.5 * height - edge_radius, edge_radius),
            RigidShape::Mesh(_) => unreachable!("a mesh has no analytic core"),
        }
    }

    /// Radius of the smallest sphere about the body origin that holds the shape [m].
    pub fn bounding_radius(&self) -> f64 {
        match *self {
            RigidShape::Sphere { radius } => radius,
            RigidShape::Cylinder { radius, height, .. } => (radius * radius + 0.25 * height * height).sqrt(),
            RigidShape::Mesh(ref mesh) => mesh.bounding_radius,
        }
    }

    /// Inertia tensor of a solid body of `mass` about its centre, body frame [kg m^2] (the
    /// analytic cylinder's edge rounding ignored).
    pub fn inertia(&self, mass: f64) -> Matrix3<f64> {
        match *self {
            RigidShape::Sphere { radius } => Matrix3::from_diagonal_element(0.4 * mass * radius * radius),
            RigidShape::Cylinder { radius, height, .. } => {
                let transverse = mass * (3.0 * radius * radius + height * height) / 12.0;
                Matrix3::from_diagonal(&Vec3::new(transverse, transverse, 0.5 * mass * radius * radius))
            }
            RigidShape::Mesh(ref mesh) => mesh.inertia_per_mass * mass,
        }
    }

    /// The mesh of a deformable body's surface (one whose vertices move).
    pub fn deforming_mesh(&self) -> Option<&MeshShape> {
        match self {
            RigidShape::Mesh(mesh) if mesh.surface.deforms() => Some(mesh),
            _ => None,
        }
    }

    /// Support function: the largest `p . direction` over the shape, for a unit `direction`
    /// in the body frame [m] (how far the shape reaches that way from its centre).
    pub fn support(&self, direction: &Vec3) -> f64 {
        match self {
            RigidShape::Mesh(mesh) => mesh.surface.vertices.iter().map(|v| v.dot(direction)).fold(f64::NEG_INFINITY, f64::max),
            _ => {
                let (core_radius, half_height, rounding) = self.core();
                core_radius * direction.xy().norm() + half_height * direction.z.abs() + rounding
            }
        }
    }

    /// Signed distance from body-frame point `p` to the surface and the outward unit normal
    /// at the closest surface point (body frame).
    /// A mesh answers within its reach only; farther points get an infinite distance.
    #[inline]
    pub fn distance_and_normal(&self, p: &Vec3) -> (f64, Vec3) {
        let contact = self.contact_point(p, crate::NONE);
        (contact.distance, contact.normal)
    }

    /// [`Self::distance_and_normal`] with the closest point, and a mesh's triangle and
    /// weights there (an analytic surface has triangle [`crate::NONE`]). `hint`, a mesh
    /// triangle the point was last found over or [`crate::NONE`], may spare the search; the
    /// answer does not depend on it ([`TriangleSurface::closest_near`]).
    #[inline]
    pub fn contact_point(&self, p: &Vec3, hint: u32) -> SurfacePoint {
        if let RigidShape::Mesh(mesh) = self {
            return mesh.surface.closest_near(p, hint).unwrap_or(SurfacePoint { distance: f64::INFINITY, normal: Vec3::z(), point: *p, triangle: crate::NONE, weights: [0.0; 3] });
        }
        let (distance, normal) = self.analytic_distance_and_normal(p);
        SurfacePoint { distance, normal, point: p - normal * distance, triangle: crate::NONE, weights: [0.0; 3] }
    }

    /// Closed-form distance and normal of the sphere and the rounded cylinder.
    #[inline]
    fn analytic_distance_and_normal(&self, p: &Vec3) -> (f64, Vec3) {
        let (core_radius, half_height, rounding) = self.core();
        let radial = (p.x * p.x + p.y * p.y).sqrt();
        let axial = p.z;
        // closest point of the core (a disc-swept segment) in the (radial, axial) half plane
        let q_radial = radial.min(core_radius);
        let q_axial = axial.clamp(-half_height, half_height);
        let (dr, dz) = (radial - q_radial, axial - q_axial);
        let radial_unit = if radial > 0.0 { Vec3::new(p.x / radial, p.y / radial, 0.0) } else { Vec3::x() };
        let outside = (dr * dr + dz * dz).sqrt();
        if outside > 0.0 {
            let normal = radial_unit * (dr / outside) + Vec3::z() * (dz / outside);
            return (outside - rounding, normal);
        }
        // inside the core: leave through the nearest face
        let to_side = core_radius - radial;
        let to_cap = half_height - axial.abs();
        if to_side < to_cap {
            (-to_side - rounding, radial_unit)
        } else {
            (-to_cap - rounding, Vec3::z() * axial.signum())
        }
    }
}

/// Rigid projectile state.
#[derive(Clone, Debug, PartialEq)]
pub struct RigidProjectile {
    /// its geometry, body frame
    pub shape: RigidShape,
    /// mass [kg]
    pub mass: f64,
    /// inertia tensor about the centre of mass, body frame [kg m^2]
    pub inertia: Matrix3<f64>,
    /// its inverse [1/(kg m^2)]
    pub inverse_inertia: Matrix3<f64>,
    /// centre of mass [m]
    pub position: Vec3,
    /// velocity of the centre of mass [m/s]
    pub velocity: Vec3,
    /// body-to-world rotation
    pub orientation: UnitQuaternion<f64>,
    /// angular momentum about the centre of mass, world frame [kg m^2/s]
    pub angular_momentum: Vec3,
    /// contact force on the projectile in this step, world frame [N]
    pub force: Vec3,
    /// contact torque about the centre of mass in this step, world frame [N m]
    pub torque: Vec3,
}

impl RigidProjectile {
    /// A projectile of `shape` and `mass` [kg], centre of mass at `position` [m] moving at
    /// `velocity` [m/s], turned by `orientation` (body to world), not spinning and unloaded.
    pub fn new(shape: RigidShape, mass: f64, position: Vec3, velocity: Vec3, orientation: UnitQuaternion<f64>) -> Self {
        let inertia = shape.inertia(mass);
        Self {
            inverse_inertia: inertia.try_inverse().expect("a solid of positive mass has an invertible inertia"),
            inertia,
            shape,
            mass,
            position,
            velocity,
            orientation,
            angular_momentum: Vec3::zeros(),
            force: Vec3::zeros(),
            torque: Vec3::zeros(),
        }
    }

    /// World inverse inertia tensor `R I^-1 R^T` [1/(kg m^2)].
    fn inverse_inertia_world(&self) -> Matrix3<f64> {
        let rotation = self.orientation.to_rotation_matrix();
        rotation.matrix() * self.inverse_inertia * rotation.matrix().transpose()
    }

    /// Angular velocity, world frame [rad/s].
    pub fn angular_velocity(&self) -> Vec3 {
        self.inverse_inertia_world() * self.angular_momentum
    }

    /// Half-step velocity update from the current force and torque.
    pub fn kick(&mut self, half_dt: f64) {
        self.velocity += self.force * (half_dt / self.mass);
        self.angular_momentum += self.torque * half_dt;
    }

    /// Full-step position and orientation update (rotation by the exact exponential of the
    /// half-step angular velocity: free spin conserves angular momentum to round-off).
    pub fn drift(&mut self, dt: f64) {
        self.position += self.velocity * dt;
        let omega = self.angular_velocity();
        self.orientation = UnitQuaternion::from_scaled_axis(omega * dt) * self.orientation;
    }

    /// Kinetic energy, translation plus rotation [J].
    pub fn kinetic_energy(&self) -> f64 {
        0.5 * self.mass * self.velocity.norm_squared() + 0.5 * self.angular_momentum.dot(&self.angular_velocity())
    }

    /// How far any point of the rigid surface can have moved since the body stood at
    /// `position` turned by `orientation`: the centre's displacement plus the bounding radius
    /// times the turn [m].
    pub fn surface_moved_since(&self, position: &Vec3, orientation: &UnitQuaternion<f64>) -> f64 {
        (self.position - position).norm() + self.shape.bounding_radius() * (orientation.inverse() * self.orientation).angle()
    }

    /// World position of a node expressed in the body frame.
    #[inline]
    pub fn to_body(&self, world: &Vec3) -> Vec3 {
        self.orientation.inverse_transform_vector(&(world - self.position))
    }

    /// Body-frame vector expressed in the world frame.
    #[inline]
    pub fn to_world_vector(&self, body: &Vec3) -> Vec3 {
        self.orientation.transform_vector(body)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_distance_is_centre_distance_minus_radius() {
        let shape = RigidShape::Sphere { radius: 2.0 };
        let (d, n) = shape.distance_and_normal(&Vec3::new(3.0, 4.0, 0.0));
        assert!((d - 3.0).abs() < 1e-15);
        assert!((n - Vec3::new(0.6, 0.8, 0.0)).norm() < 1e-15);
    }

    #[test]
    fn cylinder_distance_matches_brute_force_on_the_rounded_surface() {
        let shape = RigidShape::Cylinder { radius: 1.0, height: 1.5, edge_radius: 0.2 };
        // sample the surface densely: it is the 0.2 offset of the core cylinder r=0.8, h/2=0.55
        let mut surface = Vec::new();
        for a in 0..48 {
            let phi = a as f64 * std::f64::consts::TAU / 48.0;
            let (c, s) = (phi.cos(), phi.sin());
            for k in 0..=40 {
                let t = k as f64 / 40.0;
                surface.push(Vec3::new(c * 1.0, s * 1.0, -0.55 + 1.1 * t)); // side
                surface.push(Vec3::new(c * 0.8 * t, s * 0.8 * t, 0.75)); // top cap
                surface.push(Vec3::new(c * 0.8 * t, s * 0.8 * t, -0.75)); // bottom cap
                let e = t * std::f64::consts::FRAC_PI_2;
                surface.push(Vec3::new(c * (0.8 + 0.2 * e.cos()), s * (0.8 + 0.2 * e.cos()), 0.55 + 0.2 * e.sin())); // top edge
                surface.push(Vec3::new(c * (0.8 + 0.2 * e.cos()), s * (0.8 + 0.2 * e.cos()), -0.55 - 0.2 * e.sin())); // bottom edge
            }
        }
        for p in [Vec3::new(1.5, 0.2, 0.1), Vec3::new(0.3, 0.1, 1.4), Vec3::new(1.1, 0.0, 0.9), Vec3::new(-0.7, 0.6, -1.0)] {
            let (d, n) = shape.distance_and_normal(&p);
            let brute = surface.iter().map(|s| (s - p).norm()).fold(f64::INFINITY, f64::min);
            assert!((d - brute).abs() < 0.01, "{p:?}: {d} vs {brute}");
            // the closest surface point along the normal lies on the surface
            let (on_surface, _) = shape.distance_and_normal(&(p - n * d));
            assert!(on_surface.abs() < 1e-12);
        }
        // inside points have negative distance
        assert!(shape.distance_and_normal(&Vec3::new(0.0, 0.0, 0.6)).0 < 0.0);
    }

    #[test]
    fn a_meshed_body_has_its_tensor_and_spins_freely_about_its_centroid() {
        // a box turned off its axes: a full inertia tensor in the body frame
        let (a, b, c) = (1.5e-3, 1.0e-3, 0.5e-3);
        let (vertices, triangles) = crate::surface::boxed(a, b, c);
        let turn = nalgebra::Rotation3::from_scaled_axis(Vec3::new(0.4, 0.1, -0.3));
        let offset = Vec3::new(1e-3, -2e-3, 3e-3);
        let moved: Vec<Vec3> = vertices.iter().map(|v| turn * v + offset).collect();
        let (mesh, centroid) = MeshShape::new(&moved, triangles, 1e-4, 1e-4).unwrap();
        assert!((centroid - offset).norm() < 1e-15);
        let mass = 2.0e-3;
        let body_tensor = Matrix3::from_diagonal(&Vec3::new(b * b + c * c, a * a + c * c, a * a + b * b)) * (mass / 3.0);
        let expected = turn.matrix() * body_tensor * turn.matrix().transpose();
        let shape = RigidShape::Mesh(Arc::new(mesh));
        assert!((shape.inertia(mass) - expected).norm() < 1e-12 * expected.norm());
        // support: the farthest corner along the direction
        let direction = Vec3::new(0.0, 0.0, -1.0);
        let farthest = vertices.iter().map(|v| (turn * v).dot(&direction)).fold(f64::MIN, f64::max);
        assert!((shape.support(&direction) - farthest).abs() < 1e-15);
        // torque-free: angular momentum exactly, energy to the integrator's accuracy
        let mut body = RigidProjectile::new(shape, mass, Vec3::zeros(), Vec3::new(3.0, 0.0, -50.0), UnitQuaternion::from_scaled_axis(Vec3::new(0.2, 0.0, 0.1)));
        // about 10^4 rad/s: some two radians over the run
        body.angular_momentum = Vec3::new(6e-6, -3e-6, 9e-6);
        let (momentum, energy) = (body.angular_momentum, body.kinetic_energy());
        for _ in 0..20000 {
            body.kick(5e-9);
            body.drift(1e-8);
            body.kick(5e-9);
        }
        assert_eq!(body.angular_momentum, momentum);
        assert_eq!(body.velocity, Vec3::new(3.0, 0.0, -50.0));
        assert!((body.kinetic_energy() - energy).abs() < 1e-6 * energy, "{} vs {energy}", body.kinetic_energy());
    }

    #[test]
    fn free_spin_conserves_angular_momentum_and_energy() {
        let shape = RigidShape::Cylinder { radius: 1.7e-3, height: 3.7e-3, edge_radius: 5e-5 };
        let mut body = RigidProjectile::new(shape, 2.592e-4, Vec3::zeros(), Vec3::new(0.0, 0.0, -50.0), UnitQuaternion::identity());
        body.angular_momentum = Vec3::new(1e-7, 3e-8, 2e-7);
        let momentum = body.angular_momentum;
        let energy = body.kinetic_energy();
        for _ in 0..10000 {
            body.kick(5e-9);
            body.drift(1e-8);
            body.kick(5e-9);
        }
        assert_eq!(body.angular_momentum, momentum);
        assert!((body.velocity.z + 50.0).abs() == 0.0);
        assert!((body.kinetic_energy() - energy).abs() < 1e-6 * energy, "{} vs {energy}", body.kinetic_energy());
    }
}
