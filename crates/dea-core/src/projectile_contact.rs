//! Fibre–projectile contact: which owned nodes may touch the projectile (its candidates,
//! refreshed when node and surface together moved a skin), the contact law and friction at
//! each (seed 4-1, 4-4…4-15, the partner a point of the body, or a material point of a
//! deforming surface), and the reactions the projectile feels, summed in gid order.

use nalgebra::UnitQuaternion;

use crate::contact::{ContactGeometry, NormalLaw};
use crate::domain::NodeLedger;
use crate::friction::{FrictionResponse, FrictionSpring};
use crate::nodes::Nodes;
use crate::projectile::{RigidProjectile, RigidShape};
use crate::surface::SurfacePoint;
use crate::{FibreSection, GlobalNodeId, LocalNodeId, Vec3, NONE};

/// Contact history of every node with the projectile (one body, so one entry per node).
#[derive(Clone, Debug, Default)]
pub struct ProjectileContacts {
    /// owned nodes within reach of the projectile at the last build, ascending
    pub candidates: Vec<LocalNodeId>,
    /// the candidates before the last refresh (its scratch)
    previous_candidates: Vec<LocalNodeId>,
    /// friction anchor, body frame: the partner point relative to the node at first touch
    /// ([`FrictionSpring::Anchored`]) or at the last evaluation ([`FrictionSpring::Rotating`]);
    /// the partner is the body origin on a rigid body, the touched material point of a
    /// deforming surface [m]
    pub anchor: Vec<Vec3>,
    /// the friction spring's tangential stretch at the last evaluation, body frame
    /// ([`FrictionSpring::Rotating`]; zero under the seed's anchor) [m]
    pub stretch: Vec<Vec3>,
    /// a deforming surface's material point the friction is anchored to: the triangle and
    /// barycentric weights of the contact point at first touch (docs/theory.md I6)
    pub anchor_triangle: Vec<u32>,
    /// (the weights, one per vertex of the triangle)
    pub anchor_weights: Vec<[f64; 3]>,
    /// stiffness of the friction spring at its last evaluation [N/m]
    pub spring_stiffness: Vec<f64>,
    /// node overlaps the projectile
    pub touching: Vec<bool>,
    /// largest overlap reached [m]
    pub max_overlap: Vec<f64>,
    /// contact force on the node in this step [N]
    pub force_on_node: Vec<Vec3>,
    /// torque of the reaction about the projectile's centre in this step [N m]
    pub torque_on_projectile: Vec<Vec3>,
    /// triangle and barycentric weights of the contact point on a meshed surface
    /// ([`NONE`] on an analytic one): where a deformable body takes the reaction
    pub triangle: Vec<u32>,
    /// (the weights, one per vertex of the triangle)
    pub weights: Vec<[f64; 3]>,
    /// surface vertices (body frame) at the last refresh: a deformable body's surface moves
    pub reference_vertices: Vec<Vec3>,
    /// the owned nodes near enough to the projectile to be worth a look at a refresh
    /// (ascending local index; [`Self::refresh_candidates`]): the others were more than
    /// [`NEIGHBOURHOOD_MARGIN_RADII`] bounding radii beyond its reach when they were last
    /// scanned, and have not closed that gap since
    pub neighbourhood: Vec<u32>,
    /// the projectile's centre when the neighbourhood was scanned, none before a scan [m]
    neighbourhood_centre: Option<Vec3>,
    /// how far beyond the reach the neighbourhood extends [m]
    neighbourhood_margin: f64,
    /// how far any owned node may have moved since the scan: the sum of each step's
    /// largest motion [m]
    neighbourhood_node_travel: f64,
    /// the neighbourhood's positions at the last refresh of the candidates, in its order [m]
    pub node_reference: Vec<Vec3>,
    /// projectile position at the last refresh [m]
    pub reference_position: Vec3,
    /// projectile orientation at the last refresh
    pub reference_orientation: UnitQuaternion<f64>,
    /// per owned node, the last query of a rigid mesh that found it clear of the surface:
    /// how far clear (distance less contact radius; -inf: no such query) [m], the node's
    /// position then [m] and the surface's travel then [m]. While the node and the surface
    /// have moved less than that since, the query cannot find it touching and is skipped.
    clearance: Vec<f64>,
    clearance_position: Vec<Vec3>,
    clearance_travel: Vec<f64>,
    /// how far any point of the projectile's surface has moved since the set-up, summed over
    /// the steps (centre plus bounding radius times the turn) [m], and the projectile's pose
    /// at the last step
    surface_travel: f64,
    travel_pose: Option<(Vec3, UnitQuaternion<f64>)>,
    /// queries skipped so far for nodes known to be clear
    pub skipped_queries: u64,
}

impl ProjectileContacts {
    /// Owned node `i` is out of contact with the projectile this step.
    pub fn release(&mut self, i: usize) {
        self.touching[i] = false;
        self.force_on_node[i].fill(0.0);
        self.torque_on_projectile[i].fill(0.0);
    }

    /// True when an owned node may have come within contact of the projectile without being
    /// a candidate: node and projectile surface together moved more than the skin since the
    /// last refresh. The surface moved no more than the centre plus the turn times the
    /// shape's reach.
    pub fn refresh_due(&self, projectile: Option<&RigidProjectile>, nodes: &Nodes, skin: f64) -> bool {
        let Some(projectile) = projectile else { return false };
        let contacts = self;
        if !contacts.neighbourhood_holds(projectile) {
            return true;
        }
        let mut surface = projectile.surface_moved_since(&contacts.reference_position, &contacts.reference_orientation);
        if let Some(mesh) = projectile.shape.deforming_mesh() {
            // a deformable body's surface also moves against its frame
            surface += mesh
                .surface
                .vertices
                .iter()
                .zip(&contacts.reference_vertices)
                .map(|(v, r)| (v - r).norm_squared())
                .fold(0.0, f64::max)
                .sqrt();
        }
        // a node outside the neighbourhood is out of reach (`neighbourhood_holds`)
        let node = contacts
            .node_reference
            .iter()
            .zip(&contacts.neighbourhood)
            .map(|(r, &i)| (nodes.position[i as usize] - r).norm_squared())
            .fold(0.0, f64::max)
            .sqrt();
        node + surface > skin
    }

    /// Records that no owned node moved farther than `distance` in a step [m].
    pub fn nodes_moved_at_most(&mut self, distance: f64) {
        self.neighbourhood_node_travel += distance;
    }

    /// True while no owned node outside the neighbourhood can have come within the
    /// projectile's bounding radius plus reach of its centre: it was `margin` beyond that
    /// at the scan, and it and the centre have since closed less than that between them.
    fn neighbourhood_holds(&self, projectile: &RigidProjectile) -> bool {
        self.neighbourhood_centre.is_some_and(|centre| {
            self.neighbourhood_node_travel + (projectile.position - centre).norm() < self.neighbourhood_margin
        })
    }

    /// Chooses the owned nodes within the skin of touching the projectile's surface (a mesh
    /// finds them through its cubes, whose reach covers the contact radius plus the skin),
    /// and those a mesh cannot place: beyond its reach yet within its box, which may lie
    /// deep inside the body (a node the projectile swallowed, as a clamped edge is under a
    /// projectile wider than the panel's free span). Such a node is out of contact while the
    /// mesh cannot reach it, but it may come within reach from inside without a skin of
    /// motion, so it stays a candidate. A node that is not a candidate then lies a skin or
    /// more outside and cannot touch before the next refresh, so the choice and its timing
    /// never change a result: each rank refreshes on its own.
    pub fn refresh_candidates(
        &mut self,
        projectile: Option<&RigidProjectile>,
        nodes: &Nodes,
        sections: &[FibreSection],
        skin: f64,
    ) {
        let Some(projectile) = projectile else { return };
        let contacts = self;
        let max_contact_radius = sections.iter().map(|s| 0.5 * s.contact_diameter).fold(0.0, f64::max);
        let reach = max_contact_radius + skin;
        let bounding = projectile.shape.bounding_radius() + reach;
        // the body-frame box of a mesh: every point inside the body lies in it
        let mesh_box = match &projectile.shape {
            RigidShape::Mesh(mesh) => Some(crate::bounding_box(mesh.surface.vertices.iter().copied())),
            _ => None,
        };
        let unplaced_may_be_inside =
            |body: &Vec3| mesh_box.is_some_and(|(low, high)| (0..3).all(|k| body[k] >= low[k] && body[k] <= high[k]));
        // a deforming body's bounding radius changes: it looks at every node each time
        if projectile.shape.deforming_mesh().is_some() || !contacts.neighbourhood_holds(projectile) {
            let margin = if projectile.shape.deforming_mesh().is_some() {
                0.0
            } else {
                NEIGHBOURHOOD_MARGIN_RADII * projectile.shape.bounding_radius()
            };
            let scan = bounding + margin;
            contacts.neighbourhood.clear();
            contacts.neighbourhood.extend((0..nodes.n_owned as u32).filter(|&i| {
                margin == 0.0 || (nodes.position[i as usize] - projectile.position).norm_squared() < scan * scan
            }));
            contacts.neighbourhood_centre = Some(projectile.position);
            contacts.neighbourhood_margin = margin;
            contacts.neighbourhood_node_travel = 0.0;
        }
        // the last refresh's candidates, kept to release those that leave (no allocation)
        std::mem::swap(&mut contacts.candidates, &mut contacts.previous_candidates);
        contacts.candidates.clear();
        for &i in &contacts.neighbourhood {
            let i = i as usize;
            let x = nodes.position[i];
            let near = (x - projectile.position).norm_squared() < bounding * bounding && {
                let body = projectile.to_body(&x);
                let distance = projectile.shape.contact_point(&body, contacts.triangle[i]).distance;
                distance < reach || (distance == f64::INFINITY && unplaced_may_be_inside(&body))
            };
            if near {
                contacts.candidates.push(LocalNodeId::of(i));
            }
        }
        // a node leaving the candidate set is out of contact
        for k in 0..contacts.previous_candidates.len() {
            let i = contacts.previous_candidates[k];
            if contacts.candidates.binary_search(&i).is_err() {
                contacts.release(i.index());
            }
        }
        contacts.node_reference.clear();
        contacts.node_reference.extend(contacts.neighbourhood.iter().map(|&i| nodes.position[i as usize]));
        contacts.reference_position = projectile.position;
        contacts.reference_orientation = projectile.orientation;
        contacts.reference_vertices.clear();
        if let Some(mesh) = projectile.shape.deforming_mesh() {
            contacts.reference_vertices.extend_from_slice(&mesh.surface.vertices);
        }
    }

    /// Geometry of the contact of fibre node `i` with the projectile surface: overlap, outward
    /// normal (body frame), body-frame position, and the contact geometry of the law.
    #[inline]
    pub fn geometry(
        &self,
        projectile: &RigidProjectile,
        nodes: &Nodes,
        sections: &[FibreSection],
        i: usize,
    ) -> (f64, SurfacePoint, Vec3, ContactGeometry) {
        let section = &sections[nodes.section[i] as usize];
        let body = projectile.to_body(&nodes.position[i]);
        // the triangle it was last in contact with: the same answer, often without a search
        let point = projectile.shape.contact_point(&body, self.triangle[i]);
        let geometry = ContactGeometry::new(0.5 * section.diameter, section.element_length, section.diameter);
        (0.5 * section.contact_diameter - point.distance, point, body, geometry)
    }

    /// The friction of touching node `i` whose partner lies at `relative` (body frame, [m])
    /// under the contact's normal force and stiffness, its history updated: the seed's fixed
    /// anchor or the rotating spring.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    fn friction(
        &mut self,
        i: usize,
        spring: FrictionSpring,
        relative: Vec3,
        normal: Vec3,
        normal_force: f64,
        normal_stiffness: f64,
        mu: f64,
    ) -> FrictionResponse {
        spring.evaluate(
            relative,
            normal,
            &mut self.anchor[i],
            &mut self.stretch[i],
            &mut self.spring_stiffness[i],
            normal_force,
            normal_stiffness,
            mu,
        )
    }

    /// The friction spring's stored energy of touching node `i` (as `Self::friction` would
    /// find it, without changing the history) [J].
    #[allow(clippy::too_many_arguments)]
    pub fn friction_stored(
        &self,
        i: usize,
        spring: FrictionSpring,
        relative: Vec3,
        normal: Vec3,
        normal_force: f64,
        normal_stiffness: f64,
        mu: f64,
    ) -> f64 {
        let (mut anchor, mut stretch, mut stiffness) = (self.anchor[i], self.stretch[i], self.spring_stiffness[i]);
        let response = spring.evaluate(
            relative,
            normal,
            &mut anchor,
            &mut stretch,
            &mut stiffness,
            normal_force,
            normal_stiffness,
            mu,
        );
        response.stored
    }

    /// The partner point of touching node `i`'s friction relative to the node, body frame:
    /// the body origin of a rigid body (its frame turns with it); on a deforming surface,
    /// which moves against that frame, the material point it is anchored to [m]. `body` is
    /// the node's body-frame position [m].
    #[inline]
    pub fn friction_partner(&self, projectile: &RigidProjectile, i: usize, body: &Vec3) -> Vec3 {
        match projectile.shape.deforming_mesh() {
            Some(mesh) => mesh.surface.point_at(self.anchor_triangle[i], self.anchor_weights[i]) - body,
            None => -body,
        }
    }

    /// Fibre–projectile contact and friction (seed 4-1, 4-4…4-15) on the candidate nodes,
    /// with the normal `law`, the fibre–projectile friction coefficient `mu` [-] and its
    /// `spring` (how the friction spring keeps its stretch): adds each
    /// node's force to `nodes.force`, its contact stiffness to `contact_stiffness` [N/m] and
    /// its dissipation to `ledger`, and keeps the force and the reaction's torque for
    /// [`Self::reactions`].
    #[allow(clippy::too_many_arguments)]
    pub fn add_forces(
        &mut self,
        projectile: &RigidProjectile,
        nodes: &mut Nodes,
        sections: &[FibreSection],
        law: NormalLaw,
        mu: f64,
        spring: FrictionSpring,
        ledger: &mut NodeLedger,
        contact_stiffness: &mut [f64],
    ) {
        // a rigid mesh's query is costly: it is skipped for a node known to be clear
        let skips = matches!(projectile.shape, RigidShape::Mesh(_)) && projectile.shape.deforming_mesh().is_none();
        let contacts = &mut *self;
        if skips {
            if let Some((position, orientation)) = contacts.travel_pose {
                contacts.surface_travel += projectile.surface_moved_since(&position, &orientation);
            }
            contacts.travel_pose = Some((projectile.position, projectile.orientation));
        }
        for c in 0..self.candidates.len() {
            let i = self.candidates[c].index();
            let contacts = &mut *self;
            // the signed distance moves no faster than the node and the surface together
            if skips
                && contacts.clearance[i]
                    - (nodes.position[i] - contacts.clearance_position[i]).norm()
                    - (contacts.surface_travel - contacts.clearance_travel[i])
                    > CLEARANCE_MARGIN
            {
                contacts.release(i);
                contacts.skipped_queries += 1;
                continue;
            }
            let (overlap, point, body, geometry) = self.geometry(projectile, nodes, sections, i);
            let normal = point.normal;
            let contacts = &mut *self;
            if overlap <= 0.0 {
                if skips {
                    // a node beyond the mesh's reach may be deep inside: it is not known clear
                    contacts.clearance[i] = if overlap.is_finite() { -overlap } else { f64::NEG_INFINITY };
                    contacts.clearance_position[i] = nodes.position[i];
                    contacts.clearance_travel[i] = contacts.surface_travel;
                }
                contacts.release(i);
                continue;
            }
            let previous_max = contacts.max_overlap[i];
            let (response, max_overlap) = law.evaluate(&geometry, overlap, previous_max);
            if max_overlap > previous_max {
                ledger.plastic_dissipated[i] +=
                    law.dissipated(&geometry, max_overlap) - law.dissipated(&geometry, previous_max);
                contacts.max_overlap[i] = max_overlap;
            }
            // the partner of the fibre pairs: the body origin of a rigid body (its frame turns
            // with it); on a deforming surface, which moves against that frame, the material
            // point touched first, found again by its triangle and weights
            let deforming = projectile.shape.deforming_mesh();
            if !contacts.touching[i] && deforming.is_some() {
                contacts.anchor_triangle[i] = point.triangle;
                contacts.anchor_weights[i] = point.weights;
            }
            let relative = contacts.friction_partner(projectile, i, &body);
            let mut force_body = normal * response.force;
            if !contacts.touching[i] {
                contacts.touching[i] = true;
                contacts.anchor[i] = relative;
                contacts.stretch[i] = Vec3::zeros();
                contacts.spring_stiffness[i] = mu * response.stiffness;
            } else if mu > 0.0 {
                let friction = contacts.friction(i, spring, relative, normal, response.force, response.stiffness, mu);
                force_body += friction.force;
                ledger.friction_dissipated[i] += friction.dissipated;
                if let (Some(mesh), true) = (deforming, friction.dissipated > 0.0) {
                    // after a slip, anchor to the material point under the node now (where
                    // the reaction acts), keeping the spring's elastic stretch
                    let under = mesh.surface.point_at(point.triangle, point.weights) - body;
                    contacts.anchor[i] += under - relative;
                    contacts.anchor_triangle[i] = point.triangle;
                    contacts.anchor_weights[i] = point.weights;
                }
            }
            let force = projectile.to_world_vector(&force_body);
            let surface_point = nodes.position[i]
                - projectile.to_world_vector(&normal)
                    * (0.5 * sections[nodes.section[i] as usize].contact_diameter - overlap);
            contacts.force_on_node[i] = force;
            contacts.triangle[i] = point.triangle;
            contacts.weights[i] = point.weights;
            contact_stiffness[i] += response.stiffness;
            contacts.torque_on_projectile[i] = (surface_point - projectile.position).cross(&(-force));
            nodes.force[i] += force;
        }
    }

    /// Reaction records of the owned nodes touching the projectile, ascending global id
    /// (candidates are owned nodes, whose local order is gid order): the force on the
    /// projectile and its torque about the projectile's centre [N], [N m].
    pub fn reactions<'a>(&'a self, nodes: &'a Nodes) -> impl Iterator<Item = Reaction> + 'a {
        let contacts = self;
        contacts.candidates.iter().map(|i| i.index()).filter(|&i| contacts.touching[i]).map(|i| Reaction {
            gid: nodes.gid[i],
            force: -contacts.force_on_node[i],
            torque: contacts.torque_on_projectile[i],
            triangle: contacts.triangle[i],
            weights: contacts.weights[i],
        })
    }
}

/// The margin by which a skipped query's node must be clear of the surface [m], far above
/// the rounding of a distance and far below any contact's overlap.
const CLEARANCE_MARGIN: f64 = 1e-12;

/// The reaction of one fibre node on the projectile.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reaction {
    /// the fibre node's global id
    pub gid: GlobalNodeId,
    /// contact force on the projectile [N]
    pub force: Vec3,
    /// its torque about the projectile's centre [N m]
    pub torque: Vec3,
    /// triangle of a meshed surface the force acts on ([`NONE`]: analytic) and the
    /// barycentric weights that share it over the triangle's vertices (seed 4-1)
    pub triangle: u32,
    /// (the weights, one per vertex of `triangle`)
    pub weights: [f64; 3],
}

/// How far beyond its reach the projectile's neighbourhood extends, in bounding radii: a
/// rescan of every owned node is due once nodes and projectile together closed that gap,
/// and the refreshes in between look at the neighbourhood only. A speed parameter: the candidates, and so the results, do not
/// depend on it.
pub const NEIGHBOURHOOD_MARGIN_RADII: f64 = 1.0;

/// Sum of reactions given in ascending global id: the order that makes the projectile's
/// load independent of the partition (each rank's records are merged by gid first).
pub fn sum_reactions(reactions: impl Iterator<Item = Reaction>) -> (Vec3, Vec3) {
    reactions.fold((Vec3::zeros(), Vec3::zeros()), |(f, t), r| (f + r.force, t + r.torque))
}

impl ProjectileContacts {
    /// The history of `owned` nodes, none in contact.
    pub fn new(owned: usize) -> Self {
        Self {
            anchor: vec![Vec3::zeros(); owned],
            stretch: vec![Vec3::zeros(); owned],
            spring_stiffness: vec![0.0; owned],
            touching: vec![false; owned],
            max_overlap: vec![0.0; owned],
            force_on_node: vec![Vec3::zeros(); owned],
            torque_on_projectile: vec![Vec3::zeros(); owned],
            triangle: vec![NONE; owned],
            weights: vec![[0.0; 3]; owned],
            anchor_triangle: vec![NONE; owned],
            anchor_weights: vec![[0.0; 3]; owned],
            clearance: vec![f64::NEG_INFINITY; owned],
            clearance_position: vec![Vec3::zeros(); owned],
            clearance_travel: vec![0.0; owned],
            ..Default::default()
        }
    }

    /// Forgets every contact (a shot starting afresh): the candidates are due for a refresh.
    pub fn forget(&mut self) {
        self.touching.fill(false);
        self.max_overlap.fill(0.0);
        self.node_reference.clear();
        self.neighbourhood_centre = None;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures::uniform;
    use crate::material::{FibreMaterial, InertiaModel};
    use crate::{FibreId, GlobalNodeId};

    /// The candidates a scan of every owned node chooses (the refresh before the
    /// neighbourhood): what the neighbourhood's refresh must choose.
    fn every_node_within_reach(projectile: &RigidProjectile, nodes: &Nodes, reach: f64) -> Vec<LocalNodeId> {
        let bounding = projectile.shape.bounding_radius() + reach;
        (0..nodes.n_owned)
            .filter(|&i| {
                let x = nodes.position[i];
                (x - projectile.position).norm_squared() < bounding * bounding
                    && projectile.shape.contact_point(&projectile.to_body(&x), NONE).distance < reach
            })
            .map(LocalNodeId::of)
            .collect()
    }

    #[test]
    fn the_neighbourhood_refresh_chooses_what_a_scan_of_every_node_chooses() {
        let material = FibreMaterial::kevlar_km2();
        let sections = vec![FibreSection::new(&material, 1e-9, 18e-6, InertiaModel::None {}.with_friction(0.3))];
        let skin = 4e-6;
        let reach = 0.5 * sections[0].contact_diameter + skin;
        // a 3 mm sphere falling through a slab of 20,000 nodes 12 mm wide, some of them fast
        let mut next = uniform(17);
        let mut nodes = Nodes::default();
        for k in 0..20_000 {
            let x = Vec3::new(next() - 0.5, next() - 0.5, 0.1 * (next() - 0.5)) * 12e-3;
            nodes.push(GlobalNodeId(k), x, Vec3::zeros(), 1.0, FibreId(k as u32), 0, 0, false, true);
        }
        nodes.n_owned = nodes.len();
        let velocities: Vec<Vec3> = (0..nodes.len())
            .map(|_| {
                let fast = if next() < 0.01 { 2e-5 } else { 5e-7 };
                Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5) * fast
            })
            .collect();
        let mut projectile = RigidProjectile::new(
            RigidShape::Sphere { radius: 1.5e-3 },
            1e-3,
            Vec3::new(0.0, 0.0, 2.0e-3),
            Vec3::zeros(),
            UnitQuaternion::identity(),
        );
        let mut contacts = ProjectileContacts::new(nodes.len());
        let (mut refreshes, mut scans, mut largest) = (0, 0, 0);
        for step in 0..1500 {
            // the nodes drift, the projectile falls 2 um a step
            let mut moved: f64 = 0.0;
            for (x, v) in nodes.position.iter_mut().zip(&velocities) {
                *x += v;
                moved = moved.max(v.norm());
            }
            contacts.nodes_moved_at_most(moved);
            projectile.position.z -= 2e-6;
            let centre_before = contacts.neighbourhood_centre;
            if contacts.refresh_due(Some(&projectile), &nodes, skin) {
                contacts.refresh_candidates(Some(&projectile), &nodes, &sections, skin);
                refreshes += 1;
                scans += usize::from(contacts.neighbourhood_centre != centre_before);
                let every = every_node_within_reach(&projectile, &nodes, reach);
                assert_eq!(contacts.candidates, every, "step {step}");
                largest = largest.max(every.len());
            }
            // whether due or not, every node within contact is a candidate
            let contact = 0.5 * sections[0].contact_diameter;
            let touching = every_node_within_reach(&projectile, &nodes, contact);
            assert!(touching.iter().all(|i| contacts.candidates.binary_search(i).is_ok()), "step {step}");
        }
        // the slab was struck, and the neighbourhood spared most refreshes a full scan
        assert!(largest > 100, "{largest} candidates at most");
        assert!(refreshes > 500 && scans > 1 && 20 * scans < refreshes, "{refreshes} refreshes, {scans} scans");
        assert!(contacts.neighbourhood.len() < nodes.len() / 4, "{} nodes near", contacts.neighbourhood.len());
    }
}
