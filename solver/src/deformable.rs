//! A deformable projectile (seed §4.3): elastic hexahedra integrated on rank 0, which every
//! step sends the surface to all ranks and takes back the contact reactions.
//!
//! Every rank sees the body as a meshed rigid projectile whose frame translates with the
//! centre of mass (no rotation: the surface itself carries the body's rotation and
//! deformation). Rank 0 replaces that proxy's motion by the body's: it kicks and drifts the
//! nodes, fills the proxy with the centre of mass and mean velocity, and shares each
//! reaction over the three vertices of its triangle by the barycentric weights (seed 4-1).

use dea_core::projectile::RigidProjectile;
use dea_core::projectile_contact::Reaction;
use dea_core::{Vec3, NONE};
use dea_projectile::elastic::{ElasticBody, ElasticError, ElasticMaterial, ElasticModel};
use dea_projectile::mesh::{compact, HexMesh};

/// The body, on rank 0.
pub struct DeformableProjectile {
    /// the elastic body and its state
    pub body: ElasticBody,
    /// body node of each surface vertex
    pub node_of_vertex: Vec<u32>,
    /// surface triangles over the vertices
    pub triangles: Vec<[u32; 3]>,
    /// strain energy at the last force evaluation [J]
    pub strain_energy: f64,
    /// the first element found inverted (the run stops at the next step, on every rank)
    pub inverted: Option<usize>,
    /// steps of the body per step of the run: its smallest elements may need a shorter step
    /// than the fibres (theory P9); 1 unless set
    pub substeps: u32,
}

impl DeformableProjectile {
    /// The mesh at rest (body frame) of `mass` [kg]: its density is the mass over the volume.
    pub fn new(
        mesh: HexMesh,
        mass: f64,
        youngs_modulus: f64,
        poisson_ratio: f64,
        model: ElasticModel,
    ) -> Result<Self, ElasticError> {
        let volume: f64 = mesh.volumes().iter().sum();
        let (_, node_of_vertex, triangles) = compact(&mesh.nodes, &mesh.surface().triangles);
        let material = ElasticMaterial { density: mass / volume, youngs_modulus, poisson_ratio, model };
        Ok(Self {
            body: ElasticBody::new(mesh, material)?,
            node_of_vertex,
            triangles,
            strain_energy: 0.0,
            inverted: None,
            substeps: 1,
        })
    }

    /// Stable time step of the body with fibres pressing on its surface [s]: each surface
    /// node's frequency adds to the elements' highest one the contact stiffness
    /// `stiffness_per_area` [N/m^3] (a layer of fibre nodes at design strain) times its
    /// share of the surface (a third of each triangle it belongs to). Without it a soft
    /// body's light surface nodes ring against the stiff contacts.
    pub fn stable_time_step(&self, stiffness_per_area: f64) -> f64 {
        let elastic = 2.0 / self.body.stable_time_step();
        2.0 / (elastic * elastic + self.contact_frequency_squared(stiffness_per_area)).sqrt()
    }

    /// The stable step of the surface nodes on the contact stiffness alone [s]: the bound
    /// on the run's step when the body subcycles (its elements then take their own).
    pub fn contact_time_step(&self, stiffness_per_area: f64) -> f64 {
        2.0 / self.contact_frequency_squared(stiffness_per_area).sqrt()
    }

    /// Highest squared frequency of a surface node on the contact stiffness [1/s^2].
    fn contact_frequency_squared(&self, stiffness_per_area: f64) -> f64 {
        let mut area = vec![0.0; self.node_of_vertex.len()];
        for t in &self.triangles {
            let [a, b, c] = t.map(|v| self.body.position[self.node_of_vertex[v as usize] as usize]);
            let third = (b - a).cross(&(c - a)).norm() / 6.0;
            t.iter().for_each(|&v| area[v as usize] += third);
        }
        self.node_of_vertex
            .iter()
            .zip(&area)
            .map(|(&n, a)| stiffness_per_area * a / self.body.mass[n as usize])
            .fold(0.0, f64::max)
    }

    /// Surface vertices relative to `centre` into `surface` [m].
    pub fn surface_from(&self, centre: &Vec3, surface: &mut Vec<Vec3>) {
        surface.clear();
        surface.extend(self.node_of_vertex.iter().map(|&n| self.body.position[n as usize] - centre));
    }

    /// Places the body at rest shape, turned and moved like `proxy` about its centre of
    /// mass, every node with the proxy's velocity.
    pub fn launch(&mut self, proxy: &RigidProjectile) {
        let (centre, _) = self.body.centre_of_mass();
        for (x, v) in self.body.position.iter_mut().zip(&mut self.body.velocity) {
            *x = proxy.position + proxy.orientation * (*x - centre);
            *v = proxy.velocity;
        }
    }

    /// Sets the proxy's position and velocity to the body's centre of mass and mean
    /// velocity, and `surface` to the surface relative to that centre.
    pub fn fill_proxy(&self, proxy: &mut RigidProjectile, surface: &mut Vec<Vec3>) {
        let (centre, velocity) = self.body.centre_of_mass();
        proxy.position = centre;
        proxy.velocity = velocity;
        self.surface_from(&centre, surface);
    }

    /// Internal forces of the current shape plus the reactions (ascending global id), each
    /// shared over its triangle's vertices; returns the total contact force [N].
    pub fn forces(&mut self, reactions: &[Reaction]) -> Vec3 {
        match self.body.internal_forces() {
            Ok(energy) => self.strain_energy = energy,
            Err(element) => self.inverted = self.inverted.or(Some(element)),
        }
        let mut total = Vec3::zeros();
        for r in reactions {
            if r.triangle == NONE {
                continue;
            }
            let triangle = self.triangles[r.triangle as usize];
            for (k, w) in r.weights.iter().enumerate() {
                self.body.force[self.node_of_vertex[triangle[k] as usize] as usize] += r.force * *w;
            }
            total += r.force;
        }
        total
    }
}
