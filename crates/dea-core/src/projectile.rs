//! Rigid projectile: a rounded core (point = sphere, cylinder = right circular cylinder with
//! rounded edges) moving as a 6-degree-of-freedom rigid body.
//!
//! The surface is the set of points at distance `rounding` from the core, so the distance
//! from a fibre node to the surface is a closed form for both shapes, and the edge radius of
//! a cylinder (which decides shear failure, seed §5.1, §6.2.1) is exact.

use crate::Vec3;
use nalgebra::{Matrix3, UnitQuaternion};
use serde::{Deserialize, Serialize};

/// Shape in the body frame (symmetry axis = body z).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum RigidShape {
    /// sphere of radius [m]
    Sphere { radius: f64 },
    /// right circular cylinder: radius, height and edge radius [m]
    Cylinder { radius: f64, height: f64, edge_radius: f64 },
}

impl RigidShape {
    /// (core radius, core half-height, rounding radius) [m].
    #[inline]
    fn core(&self) -> (f64, f64, f64) {
        match *self {
            RigidShape::Sphere { radius } => (0.0, 0.0, radius),
            RigidShape::Cylinder { radius, height, edge_radius } => (radius - edge_radius, 0.5 * height - edge_radius, edge_radius),
        }
    }

    /// Radius of the smallest sphere about the body origin that holds the shape [m].
    pub fn bounding_radius(&self) -> f64 {
        match *self {
            RigidShape::Sphere { radius } => radius,
            RigidShape::Cylinder { radius, height, .. } => (radius * radius + 0.25 * height * height).sqrt(),
        }
    }

    /// Principal moments of inertia of a solid body of `mass` [kg m^2] (edge rounding ignored).
    pub fn principal_inertia(&self, mass: f64) -> Vec3 {
        match *self {
            RigidShape::Sphere { radius } => Vec3::repeat(0.4 * mass * radius * radius),
            RigidShape::Cylinder { radius, height, .. } => {
                let transverse = mass * (3.0 * radius * radius + height * height) / 12.0;
                Vec3::new(transverse, transverse, 0.5 * mass * radius * radius)
            }
        }
    }

    /// Signed distance from body-frame point `p` to the surface and the outward unit normal
    /// at the closest surface point (body frame).
    #[inline]
    pub fn distance_and_normal(&self, p: &Vec3) -> (f64, Vec3) {
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
    pub shape: RigidShape,
    /// mass [kg]
    pub mass: f64,
    /// principal moments of inertia in the body frame [kg m^2]
    pub principal_inertia: Vec3,
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
    pub fn new(shape: RigidShape, mass: f64, position: Vec3, velocity: Vec3, orientation: UnitQuaternion<f64>) -> Self {
        Self {
            shape,
            mass,
            principal_inertia: shape.principal_inertia(mass),
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
        let inverse_body = Matrix3::from_diagonal(&self.principal_inertia.map(|i| 1.0 / i));
        rotation.matrix() * inverse_body * rotation.matrix().transpose()
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
