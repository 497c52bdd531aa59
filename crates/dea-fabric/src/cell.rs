//! A periodic unit cell of any weave: yarns along x (warp direction) and y (weft direction),
//! each a bundle of digital fibres of one section, every fibre a closed chain over one period
//! of the cell (the node after its last is the image of its first, one period along the
//! yarn). The plain weave ([`crate::weave`]) and the 3-D weaves ([`crate::weave3d`]) build
//! one; [`crate::relax`] relaxes it; its statistics are the micro-geometry of seed §3.3.

use std::ops::Range;

use dea_core::{FibreMaterial, FibreSection, Vec3};

/// Direction of a yarn in the plane of the fabric.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum YarnDirection {
    /// warp, along x
    Warp,
    /// weft, along y
    Weft,
}

/// What a yarn does in its weave.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum YarnRole {
    /// a yarn of a plain weave, interlacing with every crossing yarn
    Plain,
    /// a straight warp-direction yarn of a 3-D weave, between two filler layers
    Stuffer,
    /// a straight weft-direction yarn of a 3-D weave
    Filler,
    /// a warp-direction yarn of a 3-D weave that binds filler layers together
    Binder,
}

impl YarnRole {
    /// Code of the role in cell files.
    pub fn code(self) -> u32 {
        self as u32
    }

    /// The role of a cell-file code.
    pub fn from_code(code: u32) -> Option<Self> {
        [Self::Plain, Self::Stuffer, Self::Filler, Self::Binder].get(code as usize).copied()
    }
}

/// One yarn of a cell.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct CellYarn {
    /// along x (warp) or y (weft)
    pub direction: YarnDirection,
    /// what the yarn does in the weave
    pub role: YarnRole,
    /// digital fibres in the yarn
    pub fibres: usize,
    /// nodes of each of its fibres in one period
    pub nodes_per_period: u32,
}

/// Why a cell's parts do not fit together.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum CellError {
    /// The arrays of the cell do not agree in length.
    #[error("inconsistent sizes: {0}")]
    Sizes(String),
}

/// A periodic unit cell (see the module documentation).
#[derive(Clone, Debug, PartialEq)]
pub struct PeriodicCell {
    /// size of the cell along x and y [m]
    pub period: [f64; 2],
    /// the yarns, in the order of their fibres in `positions`
    pub yarns: Vec<CellYarn>,
    /// section of every digital fibre (nominal element length; the rest lengths are below) [m]
    pub section: FibreSection,
    /// node positions, fibre-major: yarn, fibre, node [m]
    pub positions: Vec<Vec3>,
    /// rest length of every element of each fibre [m]
    pub rest_lengths: Vec<f64>,
    /// rest angle of the bending spring at every node, ordered as `positions` (0 until a
    /// relaxation makes the as-woven shape the springs' rest) [rad]
    pub rest_angles: Vec<f64>,
    /// tension of every digital fibre during relaxation, kept in the relaxed cell [N]
    pub fibre_tension: f64,
    /// yarn of every fibre
    fibre_yarn: Vec<u32>,
    /// first node of every fibre, and the node count at the end
    fibre_start: Vec<usize>,
    /// first fibre of every yarn, and the fibre count at the end
    yarn_start: Vec<usize>,
}

/// The micro-geometry of a cell (seed Table 3-7 compares thickness; §3.3.4 the rest).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct CellStatistics {
    /// node-centre range plus one fibre diameter [m]
    pub thickness_m: f64,
    /// mean fibre path length over the period, minus one [-]
    pub crimp: f64,
    /// mean across-spread of a yarn's fibres plus one diameter [m]
    pub yarn_width_m: f64,
    /// mean vertical spread of a yarn's fibres plus one diameter [m]
    pub yarn_thickness_m: f64,
    /// fibre volume over cell area times thickness [-]
    pub fibre_volume_fraction: f64,
    /// [kg/m^2]
    pub areal_density_kg_m2: f64,
}

impl PeriodicCell {
    /// Assembles a cell, checking that the arrays fit the yarns.
    pub fn new(period: [f64; 2], yarns: Vec<CellYarn>, section: FibreSection, positions: Vec<Vec3>, rest_lengths: Vec<f64>, rest_angles: Vec<f64>, fibre_tension: f64) -> Result<Self, CellError> {
        let mut fibre_yarn = Vec::new();
        let mut fibre_start = vec![0];
        let mut yarn_start = vec![0];
        for (y, yarn) in yarns.iter().enumerate() {
            yarn_start.push(yarn_start[y] + yarn.fibres);
            if yarn.fibres == 0 || yarn.nodes_per_period < 3 {
                return Err(CellError::Sizes(format!("yarn {y} has {} fibres of {} nodes (at least 1 of 3)", yarn.fibres, yarn.nodes_per_period)));
            }
            for _ in 0..yarn.fibres {
                fibre_yarn.push(y as u32);
                fibre_start.push(fibre_start.last().expect("a start") + yarn.nodes_per_period as usize);
            }
        }
        let nodes = *fibre_start.last().expect("a start");
        if positions.len() != nodes || rest_angles.len() != nodes || rest_lengths.len() != fibre_yarn.len() {
            return Err(CellError::Sizes(format!(
                "{} positions and {} rest angles for {nodes} nodes, {} rest lengths for {} fibres",
                positions.len(),
                rest_angles.len(),
                rest_lengths.len(),
                fibre_yarn.len()
            )));
        }
        Ok(Self { period, yarns, section, positions, rest_lengths, rest_angles, fibre_tension, fibre_yarn, fibre_start, yarn_start })
    }

    /// Fibres of the cell.
    pub fn fibres(&self) -> usize {
        self.fibre_yarn.len()
    }

    /// Yarn of fibre `fibre`.
    pub fn fibre_yarn(&self, fibre: usize) -> usize {
        self.fibre_yarn[fibre] as usize
    }

    /// First fibre of yarn `yarn`.
    pub fn yarn_first_fibre(&self, yarn: usize) -> usize {
        self.yarn_start[yarn]
    }

    /// Indices of the nodes of fibre `fibre` in `positions`.
    pub fn fibre_nodes(&self, fibre: usize) -> Range<usize> {
        self.fibre_start[fibre]..self.fibre_start[fibre + 1]
    }

    /// Direction of fibre `fibre`.
    pub fn direction(&self, fibre: usize) -> YarnDirection {
        self.yarns[self.fibre_yarn(fibre)].direction
    }

    /// The cell's size along a direction [m].
    pub fn period_along(&self, direction: YarnDirection) -> f64 {
        match direction {
            YarnDirection::Warp => self.period[0],
            YarnDirection::Weft => self.period[1],
        }
    }

    /// Translation from a fibre's last node to the image of its first node [m].
    pub fn closure(&self, fibre: usize) -> Vec3 {
        match self.direction(fibre) {
            YarnDirection::Warp => Vec3::new(self.period[0], 0.0, 0.0),
            YarnDirection::Weft => Vec3::new(0.0, self.period[1], 0.0),
        }
    }

    /// Position of node `k` of cell fibre `fibre` [m].
    pub fn position(&self, fibre: usize, k: u32) -> Vec3 {
        self.positions[self.fibre_start[fibre] + k as usize]
    }

    /// The cell's micro-geometry.
    pub fn statistics(&self, material: &FibreMaterial) -> CellStatistics {
        CellStatistics {
            thickness_m: self.thickness(),
            crimp: self.crimp(),
            yarn_width_m: self.yarn_width(),
            yarn_thickness_m: self.yarn_thickness(),
            fibre_volume_fraction: self.fibre_volume_fraction(),
            areal_density_kg_m2: self.areal_density(material),
        }
    }

    /// Lowest and highest node centre [m].
    pub fn z_range(&self) -> (f64, f64) {
        self.positions.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), p| (l.min(p.z), h.max(p.z)))
    }

    /// Thickness of the fabric: node-centre range plus one fibre diameter (the surfaces of the
    /// outermost fibres) [m].
    pub fn thickness(&self) -> f64 {
        let (low, high) = self.z_range();
        high - low + self.section.diameter
    }

    /// Mean crimp of the fibres: path length over one period / period - 1 [-].
    pub fn crimp(&self) -> f64 {
        let total: f64 = (0..self.fibres()).map(|f| self.fibre_length(f) / self.period_along(self.direction(f))).sum();
        total / self.fibres() as f64 - 1.0
    }

    /// Mean crimp of the fibres of the yarns of one role (`None` when the cell has none) [-].
    pub fn crimp_of(&self, role: YarnRole) -> Option<f64> {
        let fibres: Vec<usize> = (0..self.fibres()).filter(|&f| self.yarns[self.fibre_yarn(f)].role == role).collect();
        (!fibres.is_empty()).then(|| fibres.iter().map(|&f| self.fibre_length(f) / self.period_along(self.direction(f))).sum::<f64>() / fibres.len() as f64 - 1.0)
    }

    /// Mean width of the yarns: the largest across-spread of a yarn's fibre centres at a node
    /// station plus one diameter, averaged over stations and yarns [m].
    pub fn yarn_width(&self) -> f64 {
        self.section_extent(|direction, p| match direction {
            YarnDirection::Warp => p.y,
            YarnDirection::Weft => p.x,
        })
    }

    /// Mean thickness of the yarns, measured like [`Self::yarn_width`] in z [m].
    pub fn yarn_thickness(&self) -> f64 {
        self.section_extent(|_, p| p.z)
    }

    fn section_extent(&self, coordinate: impl Fn(YarnDirection, &Vec3) -> f64) -> f64 {
        let (mut total, mut stations) = (0.0, 0usize);
        for (y, yarn) in self.yarns.iter().enumerate() {
            let first = self.yarn_start[y];
            for k in 0..yarn.nodes_per_period {
                let values = (first..first + yarn.fibres).map(|f| coordinate(yarn.direction, &self.position(f, k)));
                let (low, high) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| (l.min(v), h.max(v)));
                total += high - low;
            }
            stations += yarn.nodes_per_period as usize;
        }
        total / stations as f64 + self.section.diameter
    }

    /// Rest length of the fibres of the cell, all elements [m].
    fn material_length(&self) -> f64 {
        (0..self.fibres()).map(|f| self.rest_lengths[f] * self.fibre_nodes(f).len() as f64).sum()
    }

    /// Fibre volume fraction of the layer: fibre volume over cell area times thickness [-].
    pub fn fibre_volume_fraction(&self) -> f64 {
        self.section.area * self.material_length() / (self.period[0] * self.period[1] * self.thickness())
    }

    /// Mass of one cell over its area [kg/m^2].
    pub fn areal_density(&self, material: &FibreMaterial) -> f64 {
        material.density * self.section.area * self.material_length() / (self.period[0] * self.period[1])
    }

    /// Length of cell fibre `fibre` over one period, node to node [m].
    pub fn fibre_length(&self, fibre: usize) -> f64 {
        let nodes = self.fibre_nodes(fibre);
        let image = self.positions[nodes.start] + self.closure(fibre);
        nodes.clone().map(|i| (if i + 1 == nodes.end { image } else { self.positions[i + 1] } - self.positions[i]).norm()).sum()
    }
}
