//! Projectile geometry for the triangle-surface contact of seed chapter 4: 8-node
//! hexahedral meshes, their outer surface as triangles with outward normals (§4.2.1.3), the
//! closest point of a triangle to a fibre node (node-to-surface, node-to-line, node-to-node
//! of §4.2.2), and the HRZ lumped masses of a hexahedron (4-22 … 4-25).
//!
//! Meshes come from a generator (`HexMesh::cylinder`) or a file (Gmsh 4.1, ABAQUS). These
//! are the kernels; the contact search and the rigid and deformable bodies build on them.

pub mod elastic;
pub mod generate;
pub mod import;
pub mod mesh;
