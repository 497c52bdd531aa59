//! Contact candidates: a cell list with a Verlet skin and full neighbour lists whose pair
//! histories survive rebuilds.
//!
//! Each owned node keeps every partner within `cutoff + skin` (full lists, so no force is
//! ever sent back to a partner's owner). A list is sorted by the partner's global id, which
//! fixes the summation order of contact forces and lets a rebuild carry histories over by a
//! sorted merge.
//!
//! A pair of two owned nodes is evaluated once, at the node of lower gid, which hands its
//! partner the terms (docs/theory.md D13): the pair's history lives in that node's entry, the
//! *upper* part of its row ([`NeighbourList::upper_start`]). Its mirror entry, in the lower
//! part of the partner's row, keeps no history of its own; [`NeighbourList::history`] reads
//! a pair's history from either entry. A pair with a ghost is evaluated at the owned node,
//! from its own entry.

use crate::ids::{FibreId, GlobalNodeId};
use crate::nodes::Nodes;
use crate::{FibreSection, Vec3};

/// A node that moved more than this share of the skin from its reference position takes a
/// new one at a rebuild around moved nodes: the others keep at least three quarters of the
/// skin for the motion still to come ([`NeighbourList::rebuild_around_moved`]).
const MOVED_SHARE_OF_SKIN: f64 = 0.125;

/// The cell of a node a rebuild around moved nodes leaves out of its grid (far from all).
const UNBINNED: u32 = u32::MAX;
/// Cells added on each side of the nodes' box when the contact search's grid is made, so that
/// rebuilds around moved nodes keep it ([`BuildScratch::bin_near`]) while the nodes spread by
/// up to that many cells (a panel's back face bulging by about a millimetre).
const GRID_MARGIN_CELLS: f64 = 4.0;

/// Full neighbour lists in compressed rows with per-pair contact history.
#[derive(Clone, Debug, Default)]
pub struct NeighbourList {
    /// row starts, `n_owned + 1` entries
    pub start: Vec<u32>,
    /// local index of the partner
    pub partner: Vec<u32>,
    /// global id of the partner (sort key, history key)
    pub partner_gid: Vec<GlobalNodeId>,
    /// friction anchor v0 (partner minus node at first touch, 4-13) [m]
    pub anchor: Vec<Vec3>,
    /// stiffness k_s of the friction spring at its last evaluation [N/m]
    pub spring_stiffness: Vec<f64>,
    /// true while the pair overlaps (the anchor is valid)
    pub touching: Vec<bool>,
    /// largest overlap reached (elasto-plastic history) [m]
    pub max_overlap: Vec<f64>,
    /// pairs a rebuild dropped after they had touched, by owned node (row starts,
    /// `n_owned + 1` entries, once built): partner gid ascending and the largest overlap
    /// reached, taken up again if the pair comes back, so the skin cannot change a result
    pub retired_start: Vec<u32>,
    /// the retired pairs' partner gids, ascending within each row
    pub retired_gid: Vec<GlobalNodeId>,
    /// the largest overlap each retired pair reached [m]
    pub retired_max_overlap: Vec<f64>,
    /// per owned row, its first entry whose partner has a higher gid than the node: the
    /// entries from there on are the pairs this row evaluates
    pub upper_start: Vec<u32>,
    /// the entries of owned rows whose partner is a ghost of lower gid, in ascending gid of
    /// the ghost: evaluated where the ghost's row would be in gid order
    pub lower_ghosts: Vec<LowerGhostEntry>,
    /// reference positions of the local nodes (owned, then ghosts): where each was when the
    /// lists were last built around it; the lists hold every pair within reach plus skin at
    /// these positions [m]
    pub reference_position: Vec<Vec3>,
    /// global ids of the local nodes when the lists were built: while they are the present
    /// ones, a partner's local index still names the same node
    reference_gid: Vec<GlobalNodeId>,
    /// Verlet skin [m]
    pub skin: f64,
    /// number of builds so far
    pub builds: u64,
    /// nodes whose rows were searched afresh, summed over the builds so far (all of them at a
    /// full build, the moved ones at a build around moved nodes)
    pub searched_nodes: u64,
    /// nodes held, summed over the builds so far: `searched_nodes / held_nodes` is the share
    /// re-listed per build
    pub held_nodes: u64,
    scratch: BuildScratch,
    motion: RelativeMotion,
}

/// An entry of an owned row whose partner is a ghost of lower gid than the row's node.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LowerGhostEntry {
    /// the owned row before which it is evaluated: the first whose node's gid is above the
    /// ghost's
    pub before_row: u32,
    /// its owned row
    pub row: u32,
    /// the entry
    pub entry: u32,
}

/// A pair's contact history, as seen from one of its nodes.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PairHistory {
    /// friction anchor v0 (partner minus node at first touch, 4-13) [m]
    pub anchor: Vec3,
    /// stiffness k_s of the friction spring at its last evaluation [N/m]
    pub spring_stiffness: f64,
    /// the pair overlapped at its last evaluation
    pub touching: bool,
    /// largest overlap reached [m]
    pub max_overlap: f64,
}

/// Displacements since the last build, boxed by cells twice the list's cell size (of the
/// nodes' positions at the build), to tell whether nodes moved together.
#[derive(Clone, Debug, Default)]
struct RelativeMotion {
    /// the cells; none before the first build
    grid: Option<HashedGrid>,
    /// cell size [m]
    cell: f64,
    /// largest contact distance of two nodes [m]
    cutoff: f64,
    /// each node's slot
    slot: Vec<u32>,
    /// coordinates of the occupied cells
    occupied: Vec<[i64; 3]>,
    /// per slot, the occupied cell last recorded in it (scratch of [`Self::build`])
    recorded: Vec<[i64; 3]>,
    /// per slot, the componentwise least and greatest displacement [m]
    low: Vec<Vec3>,
    high: Vec<Vec3>,
    /// the last check that kept the lists: the largest spread over a block and the largest
    /// displacement then [m]
    passed: Option<(f64, f64)>,
    /// how far any node can have moved since that check [m]
    moved_since: f64,
}

#[derive(Clone, Debug, Default)]
struct BuildScratch {
    /// the grid of the last binning, and each local node's slot in it at the positions binned
    /// (kept by a rebuild around moved nodes, [`Self::bin_near`])
    grid: Option<HashedGrid>,
    slot_of: Vec<u32>,
    cell_of: Vec<u32>,
    cell_start: Vec<u32>,
    cell_fill: Vec<u32>,
    /// a rebuild around moved nodes: one bit per grid slot next to a moved node
    wanted_slots: Vec<u64>,
    cells: CellOrdered,
    stencil: Stencil,
    /// the cell-ordered entries a node's list takes
    hits: Vec<u32>,
    /// per local node, the stamp of the last row that listed it as an old partner
    /// ([`same_partners`])
    mark: Vec<u32>,
    row: Vec<(GlobalNodeId, u32)>,
    start: Vec<u32>,
    partner: Vec<u32>,
    retired_start: Vec<u32>,
    old: OldHistories,
    /// a rebuild around moved nodes ([`NeighbourList::rebuild_around_moved`]): which local
    /// nodes moved, the rows of the moved owned nodes (starts, then partners), and the
    /// partners other owned nodes gain (row starts, then partners)
    moved: Vec<bool>,
    /// per owned node, whether its old row lists a moved node (empty: read the rows instead)
    lists_moved: Vec<bool>,
    fresh_start: Vec<u32>,
    fresh: Vec<(GlobalNodeId, u32)>,
    gained: Vec<(u32, GlobalNodeId, u32)>,
    gained_start: Vec<u32>,
    gained_sorted: Vec<(GlobalNodeId, u32)>,
}

/// Where a build that writes its rows in order stands with the old histories.
#[derive(Clone, Copy, Debug, Default)]
struct Placement {
    /// the old histories were moved out at the first row that changed
    moved: bool,
    /// where the present run of unchanged rows started in the old listed and retired pairs
    run: Option<(usize, usize)>,
}

impl BuildScratch {
    /// Sorts the local nodes into the cells of a grid of side `reach` over `positions` (the
    /// positions the lists are built at), ready for the contact search.
    fn bin(&mut self, nodes: &Nodes, positions: &[Vec3], reach: f64) -> HashedGrid {
        self.bin_near(nodes, positions, reach, None)
    }

    /// [`Self::bin`], but with `near` only the nodes whose cell's slot is next to (or is)
    /// that of a node marked in it: all that a search around the marked nodes can meet.
    /// A rebuild around a few moved nodes then sorts only their surroundings.
    ///
    /// With `near`, `positions` are those of the last binning except at the marked nodes and
    /// at nodes appended since (a rebuild around moved nodes): while the last grid still
    /// covers them without folding, it is kept and only those nodes' slots are taken again.
    /// The lists do not depend on the grid (any cells of side `reach` hold every pair within
    /// it), only the candidates' count does.
    fn bin_near(&mut self, nodes: &Nodes, positions: &[Vec3], reach: f64, near: Option<&[bool]>) -> HashedGrid {
        let (low, high) = bounding_box(positions);
        let slot_of = |grid: &HashedGrid, x: &Vec3| grid.slot(grid.coordinates(x)) as u32;
        // a rebuild around moved nodes keeps the last grid while it covers every node
        let kept = near.zip(self.grid.as_ref()).filter(|(_, last)| {
            self.slot_of.len() <= positions.len() && last.still_fits(positions.len(), low, high, reach)
        });
        let grid = if let Some((marked, last)) = kept {
            let grid = last.clone();
            let known = self.slot_of.len();
            self.slot_of.extend(positions[known..].iter().map(|x| slot_of(&grid, x)));
            for (i, _) in marked.iter().enumerate().filter(|(_, &m)| m) {
                self.slot_of[i] = slot_of(&grid, &positions[i]);
            }
            grid
        } else {
            // memory follows the node count, not the extent, so a fragment flung far away
            // can neither blow up the grid nor crowd every node into a few huge cells; a
            // margin of cells each way lets the next rebuilds around moved nodes keep it
            // while a panel bulges
            let margin = Vec3::repeat(GRID_MARGIN_CELLS * reach);
            let grid = HashedGrid::new(positions.len(), low - margin, high + margin, reach);
            self.slot_of.clear();
            self.slot_of.extend(positions.iter().map(|x| slot_of(&grid, x)));
            self.grid = Some(grid.clone());
            grid
        };
        self.cell_of.clear();
        self.cell_of.extend_from_slice(&self.slot_of);
        if let Some(marked) = near {
            let wanted = &mut self.wanted_slots;
            wanted.clear();
            wanted.resize(grid.slots().div_ceil(64), 0);
            for (x, _) in positions.iter().zip(marked).filter(|(_, &m)| m) {
                grid.mark_around(x, wanted);
            }
            for c in &mut self.cell_of {
                if wanted[*c as usize / 64] & (1 << (*c % 64)) == 0 {
                    *c = UNBINNED;
                }
            }
        }
        count_rows(
            grid.slots(),
            self.cell_of.iter().filter(|&&c| c != UNBINNED).map(|&c| c as usize),
            &mut self.cell_start,
        );
        // nodes and what the scan reads of them in cell order: it streams through memory
        self.cells.fill(nodes, positions, &self.cell_start, &self.cell_of, &mut self.cell_fill);
        self.stencil.cell = None;
        grid
    }

    /// Writes to `hits` the cell-ordered entries within `reach` of local node `i` at
    /// `positions[i]`, its chain neighbours left out.
    fn search(
        &mut self,
        grid: &HashedGrid,
        nodes: &Nodes,
        sections: &[FibreSection],
        positions: &[Vec3],
        i: usize,
        reach: f64,
    ) {
        let x = positions[i];
        let cell = grid.coordinates(&x);
        // consecutive nodes of a fibre often share a cell, and so its candidates
        if self.stencil.cell != Some(cell) {
            self.stencil.find(grid, &self.cell_start, cell);
        }
        let exclusion = chain_exclusion(&sections[nodes.section[i] as usize]);
        self.stencil.within(
            &self.cells,
            &x,
            chain_place(nodes.fibre[i], nodes.along[i]),
            exclusion,
            reach * reach,
            &mut self.hits,
        );
    }

    /// Starts writing new lists here, the old ones and their histories still in place.
    fn start_rows(&mut self) -> Placement {
        self.start.clear();
        self.partner.clear();
        self.retired_start.clear();
        self.start.push(0);
        self.retired_start.push(0);
        Placement::default()
    }

    /// Sorts the new row by partner gid and appends its partners to the lists being built.
    fn take_row(&mut self) {
        self.row.sort_unstable();
        // two columns may share slots of the table: a node can be met twice
        self.row.dedup();
        self.partner.extend(self.row.iter().map(|&(_, j)| j));
    }
}

/// The histories of the old lists from the first row a rebuild changed on, moved out of the
/// lists while their new rows are written in their place.
#[derive(Clone, Debug, Default)]
struct OldHistories {
    /// where the moved listed and retired pairs started in the old lists
    listed_offset: usize,
    retired_offset: usize,
    partner_gid: Vec<GlobalNodeId>,
    anchor: Vec<Vec3>,
    spring_stiffness: Vec<f64>,
    touching: Vec<bool>,
    max_overlap: Vec<f64>,
    retired_gid: Vec<GlobalNodeId>,
    retired_max_overlap: Vec<f64>,
}

impl OldHistories {
    /// Takes the histories of `list` from listed pair `listed` and retired pair `retired` on,
    /// leaving `list` its head. The shorter part is the one copied: the tail out, or, when the
    /// head is shorter, the whole arrays are swapped out and the head copied back.
    fn take_from(&mut self, list: &mut NeighbourList, listed: usize, retired: usize) {
        let whole = 2 * listed < list.partner_gid.len();
        (self.listed_offset, self.retired_offset) = if whole { (0, 0) } else { (listed, retired) };
        fn tail<T: Copy>(to: &mut Vec<T>, from: &mut Vec<T>, at: usize, whole: bool) {
            if whole {
                std::mem::swap(to, from);
                from.clear();
                from.extend_from_slice(&to[..at]);
            } else {
                to.clear();
                to.extend_from_slice(&from[at..]);
                from.truncate(at);
            }
        }
        tail(&mut self.partner_gid, &mut list.partner_gid, listed, whole);
        tail(&mut self.anchor, &mut list.anchor, listed, whole);
        tail(&mut self.spring_stiffness, &mut list.spring_stiffness, listed, whole);
        tail(&mut self.touching, &mut list.touching, listed, whole);
        tail(&mut self.max_overlap, &mut list.max_overlap, listed, whole);
        tail(&mut self.retired_gid, &mut list.retired_gid, retired, whole);
        tail(&mut self.retired_max_overlap, &mut list.retired_max_overlap, retired, whole);
    }

    /// Positions `listed` of the old lists' listed pairs, in the moved arrays.
    fn listed_range(&self, listed: std::ops::Range<usize>) -> std::ops::Range<usize> {
        listed.start - self.listed_offset..listed.end - self.listed_offset
    }

    /// Positions `retired` of the old lists' retired pairs, in the moved arrays.
    fn retired_range(&self, retired: std::ops::Range<usize>) -> std::ops::Range<usize> {
        retired.start - self.retired_offset..retired.end - self.retired_offset
    }

    /// The partners of old row `row` (positions in the old lists).
    fn listed(&self, row: std::ops::Range<usize>) -> &[GlobalNodeId] {
        &self.partner_gid[self.listed_range(row)]
    }

    /// Where the old lists' listed and retired pairs ended.
    fn end(&self) -> (usize, usize) {
        (self.listed_offset + self.partner_gid.len(), self.retired_offset + self.retired_gid.len())
    }
}

/// The nodes in cell order, with what the contact search reads of them, so that the search
/// streams through memory; the coordinates separately, four at a time.
#[derive(Clone, Debug, Default)]
struct CellOrdered {
    /// local index of each entry
    node: Vec<u32>,
    /// coordinates [m], and three entries of padding so that four can be read from any entry
    x: Vec<f64>,
    y: Vec<f64>,
    z: Vec<f64>,
    /// place on the chain ([`chain_place`])
    place: Vec<u64>,
    gid: Vec<GlobalNodeId>,
}

impl CellOrdered {
    /// Sorts the nodes by cell (`cell_of`, whose entries start at `cell_start`; `fill` is
    /// scratch), in local order within a cell.
    fn fill(&mut self, nodes: &Nodes, positions: &[Vec3], cell_start: &[u32], cell_of: &[u32], fill: &mut Vec<u32>) {
        // the entries binned ([`UNBINNED`] nodes are left out)
        let n = *cell_start.last().expect("a grid has slots") as usize;
        self.node.resize(n, 0);
        for coordinate in [&mut self.x, &mut self.y, &mut self.z] {
            coordinate.resize(n + 3, 0.0);
        }
        self.place.resize(n + 3, 0);
        self.gid.resize(n, GlobalNodeId(0));
        fill.clear();
        fill.extend_from_slice(cell_start);
        for (i, &c) in cell_of.iter().enumerate().filter(|(_, &c)| c != UNBINNED) {
            let k = fill[c as usize] as usize;
            self.node[k] = i as u32;
            [self.x[k], self.y[k], self.z[k]] = [positions[i].x, positions[i].y, positions[i].z];
            self.place[k] = chain_place(nodes.fibre[i], nodes.along[i]);
            self.gid[k] = nodes.gid[i];
            fill[c as usize] += 1;
        }
    }
}

/// The candidates of a node: the runs of cell-ordered entries in the 27 cells around its
/// cell, found once for the nodes of a fibre that follow each other in one cell.
#[derive(Clone, Debug, Default)]
struct Stencil {
    /// the cell whose surroundings the runs cover
    cell: Option<[i64; 3]>,
    /// runs of entries (one per column of three cells along z, two where it wraps the table)
    runs: Vec<std::ops::Range<usize>>,
}

impl Stencil {
    /// Finds the runs of the cells around `cell`.
    fn find(&mut self, grid: &HashedGrid, cell_start: &[u32], cell: [i64; 3]) {
        let [cx, cy, cz] = cell;
        self.runs.clear();
        for dx in -1..=1 {
            for dy in -1..=1 {
                // the three cells along z sit in consecutive slots (modulo the table)
                let first = grid.slot([cx + dx, cy + dy, cz - 1]);
                let wrap = (first + 3).saturating_sub(grid.slots());
                for slots in [first..first + 3 - wrap, 0..wrap] {
                    let run = cell_start[slots.start] as usize..cell_start[slots.end] as usize;
                    if !run.is_empty() {
                        self.runs.push(run);
                    }
                }
            }
        }
        self.cell = Some(cell);
    }

    /// Writes to `hits` the cell-ordered entries closer to `x` than the square root of
    /// `reach_squared` and not within `exclusion` places of `place` on its chain (none for a
    /// NaN `x`: a NaN position, caught after the forces, pairs with nothing).
    fn within(
        &self,
        cells: &CellOrdered,
        x: &Vec3,
        place: u64,
        exclusion: u32,
        reach_squared: f64,
        hits: &mut Vec<u32>,
    ) {
        hits.clear();
        if crate::in_avx2_lanes!(self.within_in_lanes(cells, x, place, exclusion, reach_squared, hits)).is_some() {
            return;
        }
        self.within_one_at_a_time(cells, x, place, exclusion, reach_squared, hits);
    }

    /// [`Self::within`], one entry at a time.
    fn within_one_at_a_time(
        &self,
        cells: &CellOrdered,
        x: &Vec3,
        place: u64,
        exclusion: u32,
        reach_squared: f64,
        hits: &mut Vec<u32>,
    ) {
        for k in self.runs.iter().flat_map(|run| run.clone()) {
            let (dx, dy, dz) = (cells.x[k] - x.x, cells.y[k] - x.y, cells.z[k] - x.z);
            if dx * dx + dy * dy + dz * dz < reach_squared && !same_fibre_within(place, cells.place[k], exclusion) {
                hits.push(k as u32);
            }
        }
    }

    /// [`Self::within`], four entries at a time (a run's last group masked to the run), the
    /// hits packed without a branch.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn within_in_lanes(
        &self,
        cells: &CellOrdered,
        x: &Vec3,
        place: u64,
        exclusion: u32,
        reach_squared: f64,
        hits: &mut Vec<u32>,
    ) {
        use crate::lanes::{pack_counting, F4, U4};
        let (px, py, pz, reach_squared) = (F4::splat(x.x), F4::splat(x.y), F4::splat(x.z), F4::splat(reach_squared));
        let (place, exclusion) = (U4::splat(place), U4::splat(exclusion as u64));
        // room for a whole group past the last hit
        hits.resize(self.runs.iter().map(|run| run.len() + 4).sum(), 0);
        let mut count = 0;
        for run in &self.runs {
            // the run and the three entries of padding after it, so that every group reads four
            let (xs, ys, zs, places) = (
                &cells.x[run.start..run.end + 3],
                &cells.y[run.start..run.end + 3],
                &cells.z[run.start..run.end + 3],
                &cells.place[run.start..run.end + 3],
            );
            for offset in (0..run.len()).step_by(4) {
                let (dx, dy, dz) =
                    (F4::load(xs, offset).sub(px), F4::load(ys, offset).sub(py), F4::load(zs, offset).sub(pz));
                let near = dx.mul(dx).add(dy.mul(dy)).add(dz.mul(dz)).lt(reach_squared).bits();
                let linked = U4::load(places, offset).distance_within(place, exclusion).bits();
                let in_run = (1u32 << (run.len() - offset).min(4)) - 1;
                count +=
                    pack_counting((run.start + offset) as u32, near & !linked & in_run, &mut hits[count..count + 4]);
            }
        }
        hits.truncate(count);
    }
}

/// True when the cell-ordered entries `hits` (local indices `cell_node`) that pass `within`
/// are the local nodes `old`, each met once: a row whose partners did not change. `stamp`
/// is odd and above every stamp used earlier in the build, which zeroes `mark` at its start.
fn same_partners(
    mark: &mut [u32],
    stamp: u32,
    old: &[u32],
    hits: &[u32],
    cell_node: &[u32],
    within: impl Fn(usize) -> bool,
) -> bool {
    for &j in old {
        mark[j as usize] = stamp;
    }
    let mut met = 0;
    for &k in hits {
        let j = cell_node[k as usize] as usize;
        if within(j) {
            // a partner met twice, or a new one, leaves `met` short of the hits
            if mark[j] != stamp {
                return false;
            }
            mark[j] = stamp + 1;
            met += 1;
        }
    }
    met == old.len()
}

/// Sets `starts` to the starts of `rows` compressed rows holding one entry in row `r` for
/// each `r` of `row_of`: row `r` is `starts[r]..starts[r + 1]` once they are placed in order.
pub(crate) fn count_rows(rows: usize, row_of: impl IntoIterator<Item = usize>, starts: &mut Vec<u32>) {
    starts.clear();
    starts.resize(rows + 1, 0);
    for r in row_of {
        starts[r + 1] += 1;
    }
    for r in 0..rows {
        starts[r + 1] += starts[r];
    }
}

/// Row `i` of compressed rows with starts `starts` (empty while no row is built).
#[inline]
fn compressed_row(starts: &[u32], i: usize) -> std::ops::Range<usize> {
    match starts.get(i..i + 2) {
        Some(&[first, end]) => first as usize..end as usize,
        _ => 0..0,
    }
}

/// Contact cutoff between two nodes: half the sum of the modified diameters (3-3) [m].
#[inline]
pub fn contact_distance(sections: &[FibreSection], nodes: &Nodes, i: usize, j: usize) -> f64 {
    0.5 * (sections[nodes.section[i] as usize].contact_diameter + sections[nodes.section[j] as usize].contact_diameter)
}

/// Nodes of one fibre closer along the chain than this many positions never form contacts:
/// two contact diameters of arc length (a fibre cannot fold tighter than that).
#[inline]
pub fn chain_exclusion(section: &FibreSection) -> u32 {
    (2.0 * section.contact_diameter / section.element_length).ceil() as u32
}

impl NeighbourList {
    /// Empty lists with a Verlet skin of `skin` [m]; the first build fills them.
    pub fn new(skin: f64) -> Self {
        Self { skin, ..Default::default() }
    }

    /// Pair range of owned node `i`.
    #[inline]
    pub fn row(&self, i: usize) -> std::ops::Range<usize> {
        compressed_row(&self.start, i)
    }

    /// Number of stored pairs (each physical pair appears once per owned endpoint).
    pub fn len(&self) -> usize {
        self.partner.len()
    }

    /// No pair is listed.
    pub fn is_empty(&self) -> bool {
        self.partner.is_empty()
    }

    /// Forgets every pair's contact history, retired ones included: the pairs stay, as if
    /// none had touched yet.
    pub fn forget_history(&mut self) {
        self.anchor.fill(Vec3::zeros());
        self.spring_stiffness.fill(0.0);
        self.touching.fill(false);
        self.max_overlap.fill(0.0);
        self.retired_start.fill(0);
        self.retired_gid.clear();
        self.retired_max_overlap.clear();
    }

    /// Drops every listed and retired pair's history, leaving `owned` rows, each empty.
    fn clear_histories(&mut self, owned: usize) {
        self.partner_gid.clear();
        self.anchor.clear();
        self.spring_stiffness.clear();
        self.touching.clear();
        self.max_overlap.clear();
        self.retired_gid.clear();
        self.retired_max_overlap.clear();
        // the old rows' ranges would index the cleared histories: every row empty instead
        for starts in [&mut self.start, &mut self.retired_start] {
            starts.clear();
            starts.resize(owned + 1, 0);
        }
    }

    /// Retired pairs of owned node `i`.
    #[inline]
    pub fn retired_row(&self, i: usize) -> std::ops::Range<usize> {
        compressed_row(&self.retired_start, i)
    }

    /// Rebuilds the lists of all owned nodes against all local nodes at their present
    /// positions, carrying the history of pairs that persist (matched by partner global id).
    pub fn rebuild(&mut self, nodes: &Nodes, sections: &[FibreSection]) {
        let n = nodes.len();
        self.searched_nodes += n as u64;
        self.held_nodes += n as u64;
        let (max_cutoff, coarse_reach) = self.reaches(sections);
        self.reference_position.clear();
        self.reference_position.extend_from_slice(&nodes.position);
        let references = std::mem::take(&mut self.reference_position);
        let mut scratch = std::mem::take(&mut self.scratch);
        let grid = scratch.bin(nodes, &references, coarse_reach);
        let has_history = self.start.len() == nodes.n_owned + 1;
        if !has_history {
            // histories of other rows, if any: none carries over
            self.clear_histories(nodes.n_owned);
        }
        // the same local numbering as at the last build: an old row's local indices can be
        // checked against the candidates directly
        let renumbered = !has_history || self.reference_gid != nodes.gid;
        if !renumbered {
            scratch.mark.clear();
            scratch.mark.resize(n, 0);
        }
        let mut placement = scratch.start_rows();
        for i in 0..nodes.n_owned {
            scratch.search(&grid, nodes, sections, &references, i, coarse_reach);
            let within = |j: usize| self.pair_in_reach(sections, nodes, &references, i, j);
            let old = if has_history { compressed_row(&self.start, i) } else { 0..0 };
            // most rows are what they were (the skin is there for that): such a row needs no
            // sorting, and its histories are copied a run of rows at a time, or not at all
            // before the first change
            let unchanged = if !renumbered
                && same_partners(
                    &mut scratch.mark,
                    2 * i as u32 + 1,
                    &self.partner[old.clone()],
                    &scratch.hits,
                    &scratch.cells.node,
                    within,
                ) {
                scratch.partner.extend_from_slice(&self.partner[old.clone()]);
                true
            } else {
                scratch.row.clear();
                for &k in &scratch.hits {
                    let j = scratch.cells.node[k as usize] as usize;
                    if within(j) {
                        scratch.row.push((scratch.cells.gid[k as usize], j as u32));
                    }
                }
                scratch.take_row();
                self.row_is_old(&scratch, &placement, i)
            };
            self.place_row(&mut scratch, &mut placement, i, unchanged);
        }
        self.finish_build(scratch, placement, nodes, references, max_cutoff, coarse_reach);
    }

    /// Rebuilds the lists around the local nodes that moved more than an eighth of the skin
    /// from their reference positions. Those take their present positions as references; their
    /// rows are built afresh, and the other rows lose them and gain those now within reach.
    /// The lists are then what [`Self::rebuild`] gives with every node at its reference
    /// position, so the checks hold as after it, while the nodes that barely moved keep their
    /// rows unsearched. Ghosts appended after the last build ([`Self::holds_numbering_of`])
    /// count as moved. When the local numbering changed otherwise, or most nodes moved, this
    /// is [`Self::rebuild`].
    pub fn rebuild_around_moved(&mut self, nodes: &Nodes, sections: &[FibreSection]) {
        let mut scratch = std::mem::take(&mut self.scratch);
        scratch.moved.clear();
        scratch
            .moved
            .extend(nodes.position.iter().zip(&self.reference_position).map(|(x, r)| self.moves_reference(x, r)));
        scratch.moved.resize(nodes.len(), true);
        let moved_count = scratch.moved.iter().filter(|&&m| m).count();
        if !self.holds_numbering_of(nodes) || 2 * moved_count > nodes.len() {
            self.scratch = scratch;
            return self.rebuild(nodes, sections);
        }
        let mut references = std::mem::take(&mut self.reference_position);
        references.extend_from_slice(&nodes.position[references.len()..]);
        for (i, _) in scratch.moved.iter().enumerate().filter(|(_, &m)| m) {
            references[i] = nodes.position[i];
        }
        self.rebuild_around_marked(nodes, sections, scratch, references, moved_count);
    }

    /// The rebuild around moved nodes of a rank among several (theory M2), which never falls
    /// back to [`Self::rebuild`], so that every node's reference is the one its owner gives
    /// it: the owned nodes of [`Self::moved_owned`] and the ghosts `moved_ghosts` (local
    /// indices; their owners moved them) take their present positions, and the ghosts
    /// appended since the last build take `appended_references` [m], their owners'
    /// references. Panics when the numbering is not the last build's with those ghosts
    /// appended (the caller's error).
    pub fn rebuild_only_around_moved(
        &mut self,
        nodes: &Nodes,
        sections: &[FibreSection],
        moved_ghosts: &[u32],
        appended_references: &[Vec3],
    ) {
        assert!(
            self.holds_numbering_of(nodes) && self.reference_gid.len() + appended_references.len() == nodes.len(),
            "a rebuild around moved nodes needs the numbering of the last build"
        );
        let mut scratch = std::mem::take(&mut self.scratch);
        let owned = nodes.n_owned;
        scratch.moved.clear();
        scratch.moved.extend(
            nodes.position[..owned].iter().zip(&self.reference_position).map(|(x, r)| self.moves_reference(x, r)),
        );
        scratch.moved.resize(nodes.len(), false);
        for &g in moved_ghosts {
            scratch.moved[g as usize] = true;
        }
        scratch.moved[self.reference_gid.len()..].fill(true);
        let moved_count = scratch.moved.iter().filter(|&&m| m).count();
        let mut references = std::mem::take(&mut self.reference_position);
        references.extend_from_slice(appended_references);
        for (i, _) in scratch.moved[..owned].iter().enumerate().filter(|(_, &m)| m) {
            references[i] = nodes.position[i];
        }
        for &g in moved_ghosts {
            references[g as usize] = nodes.position[g as usize];
        }
        self.rebuild_around_marked(nodes, sections, scratch, references, moved_count);
    }

    /// True when the lists were built for these nodes, or for their leading part (ghosts
    /// appended since keep every earlier local index).
    pub fn holds_numbering_of(&self, nodes: &Nodes) -> bool {
        self.start.len() == nodes.n_owned + 1
            && nodes.gid.len() >= self.reference_gid.len()
            && nodes.gid[..self.reference_gid.len()] == self.reference_gid[..]
            && self.reference_position.len() == self.reference_gid.len()
    }

    /// Whether a node at `position` with reference `reference` takes a new reference at a
    /// rebuild around moved nodes (a NaN position does).
    #[inline]
    fn moves_reference(&self, position: &Vec3, reference: &Vec3) -> bool {
        let threshold = MOVED_SHARE_OF_SKIN * self.skin;
        let squared = (position - reference).norm_squared();
        squared > threshold * threshold || squared.is_nan()
    }

    /// The owned nodes (ascending local index) a rebuild around moved nodes gives new
    /// references, for lists that hold the numbering of `nodes`.
    pub fn moved_owned(&self, nodes: &Nodes) -> Vec<u32> {
        (0..nodes.n_owned)
            .filter(|&i| self.moves_reference(&nodes.position[i], &self.reference_position[i]))
            .map(|i| i as u32)
            .collect()
    }

    /// The rebuild around the nodes marked in `scratch.moved` (`moved_count` of them) at
    /// `references`, the new ones.
    fn rebuild_around_marked(
        &mut self,
        nodes: &Nodes,
        sections: &[FibreSection],
        mut scratch: BuildScratch,
        references: Vec<Vec3>,
        moved_count: usize,
    ) {
        let n = nodes.len();
        self.searched_nodes += moved_count as u64;
        self.held_nodes += n as u64;
        let (max_cutoff, coarse_reach) = self.reaches(sections);
        let moved = std::mem::take(&mut scratch.moved);
        let grid = scratch.bin_near(nodes, &references, coarse_reach, Some(&moved));
        scratch.moved = moved;
        // the moved nodes' surroundings: their own rows, and what the others gain
        scratch.fresh_start.clear();
        scratch.fresh_start.push(0);
        scratch.fresh.clear();
        scratch.gained.clear();
        for j in 0..n {
            if !scratch.moved[j] {
                continue;
            }
            scratch.search(&grid, nodes, sections, &references, j, coarse_reach);
            for &k in &scratch.hits {
                let i = scratch.cells.node[k as usize] as usize;
                if !self.pair_in_reach(sections, nodes, &references, i, j) {
                    continue;
                }
                if j < nodes.n_owned {
                    scratch.fresh.push((scratch.cells.gid[k as usize], i as u32));
                }
                if i < nodes.n_owned && !scratch.moved[i] {
                    scratch.gained.push((i as u32, nodes.gid[j], j as u32));
                }
            }
            if j < nodes.n_owned {
                scratch.fresh_start.push(scratch.fresh.len() as u32);
            }
        }
        // the gained partners by row
        count_rows(nodes.n_owned, scratch.gained.iter().map(|&(i, _, _)| i as usize), &mut scratch.gained_start);
        scratch.gained_sorted.clear();
        scratch.gained_sorted.resize(scratch.gained.len(), (GlobalNodeId(0), 0));
        scratch.cell_fill.clear();
        scratch.cell_fill.extend_from_slice(&scratch.gained_start);
        for &(i, gid, j) in &scratch.gained {
            scratch.gained_sorted[scratch.cell_fill[i as usize] as usize] = (gid, j);
            scratch.cell_fill[i as usize] += 1;
        }
        // the rows that list a moved node: the lists are symmetric among local nodes, so when
        // no ghost that was here at the last build moved, they are the owned old partners of
        // the moved owned nodes, found from those rows alone rather than by reading every row
        let owned = nodes.n_owned;
        let listed_ghost_moved = scratch.moved[owned..self.reference_gid.len()].iter().any(|&m| m);
        scratch.lists_moved.clear();
        if !listed_ghost_moved {
            scratch.lists_moved.resize(owned, false);
            for j in (0..owned).filter(|&j| scratch.moved[j]) {
                for &i in &self.partner[compressed_row(&self.start, j)] {
                    if (i as usize) < owned {
                        scratch.lists_moved[i as usize] = true;
                    }
                }
            }
        }
        let lists_moved = |scratch: &BuildScratch, i: usize, row: &[u32]| {
            if scratch.lists_moved.is_empty() {
                row.iter().any(|&j| scratch.moved[j as usize])
            } else {
                debug_assert_eq!(scratch.lists_moved[i], row.iter().any(|&j| scratch.moved[j as usize]));
                scratch.lists_moved[i]
            }
        };
        let mut placement = scratch.start_rows();
        let mut fresh_row = 0;
        let mut i = 0;
        while i < owned {
            // most rows keep their partners: a run of them is placed at once
            let kept = |scratch: &BuildScratch, i: usize| {
                !scratch.moved[i]
                    && scratch.gained_start[i] == scratch.gained_start[i + 1]
                    && !lists_moved(scratch, i, &self.partner[compressed_row(&self.start, i)])
            };
            if kept(&scratch, i) {
                let first = i;
                while i < owned && kept(&scratch, i) {
                    i += 1;
                }
                self.place_unchanged_rows(&mut scratch, &mut placement, first..i);
                continue;
            }
            let old = compressed_row(&self.start, i);
            let gained = compressed_row(&scratch.gained_start, i);
            let unchanged = if scratch.moved[i] {
                let fresh = compressed_row(&scratch.fresh_start, fresh_row);
                fresh_row += 1;
                scratch.row.clear();
                scratch.row.extend_from_slice(&scratch.fresh[fresh]);
                scratch.take_row();
                self.row_is_old(&scratch, &placement, i)
            } else {
                // the partners that did not move stay, the moved ones are met again as gained
                let listed = self.old_partner_gids(&scratch.old, &placement, old.clone());
                scratch.row.clear();
                scratch.row.extend(
                    self.partner[old.clone()]
                        .iter()
                        .zip(listed)
                        .filter(|(&j, _)| !scratch.moved[j as usize])
                        .map(|(&j, &gid)| (gid, j)),
                );
                scratch.row.extend_from_slice(&scratch.gained_sorted[gained]);
                scratch.take_row();
                self.row_is_old(&scratch, &placement, i)
            };
            self.place_row(&mut scratch, &mut placement, i, unchanged);
            i += 1;
        }
        self.finish_build(scratch, placement, nodes, references, max_cutoff, coarse_reach);
    }

    /// The largest contact distance of two nodes, and the reach of the search (plus the skin),
    /// which is also the cell size [m].
    fn reaches(&self, sections: &[FibreSection]) -> (f64, f64) {
        let max_cutoff = sections.iter().map(|s| s.contact_diameter).fold(0.0, f64::max);
        (max_cutoff, max_cutoff + self.skin)
    }

    /// Whether local nodes `i` and `j`, met by the search, are within their own reach (contact
    /// distance plus skin) at `positions`: with one section the search's reach was theirs.
    #[inline]
    fn pair_in_reach(&self, sections: &[FibreSection], nodes: &Nodes, positions: &[Vec3], i: usize, j: usize) -> bool {
        sections.len() == 1 || {
            let reach = contact_distance(sections, nodes, i, j) + self.skin;
            (positions[j] - positions[i]).norm_squared() < reach * reach
        }
    }

    /// The partner gids of old row `old`, wherever the build has put the old histories.
    fn old_partner_gids<'a>(
        &'a self,
        histories: &'a OldHistories,
        placement: &Placement,
        old: std::ops::Range<usize>,
    ) -> &'a [GlobalNodeId] {
        if placement.moved {
            histories.listed(old)
        } else {
            &self.partner_gid[old]
        }
    }

    /// True when the new row of owned node `i` in `scratch.row` has the partners of its old row.
    fn row_is_old(&self, scratch: &BuildScratch, placement: &Placement, i: usize) -> bool {
        let old = compressed_row(&self.start, i);
        old.len() == scratch.row.len()
            && scratch
                .row
                .iter()
                .zip(self.old_partner_gids(&scratch.old, placement, old))
                .all(|(&(gid, _), &listed)| gid == listed)
    }

    /// Places the histories of owned node `i`, whose partners were just appended to
    /// `scratch.partner`: an `unchanged` row keeps its old ones (the histories stay where they
    /// are up to the first row that changed; from there on they are moved to `scratch.old`
    /// and written back a run of rows at a time); a changed row, whose new partners are in
    /// `scratch.row`, merges them.
    fn place_row(&mut self, scratch: &mut BuildScratch, placement: &mut Placement, i: usize, unchanged: bool) {
        let (old, retired) = (compressed_row(&self.start, i), compressed_row(&self.retired_start, i));
        if unchanged {
            self.keep_unchanged_histories(scratch, placement, i..i + 1);
        } else {
            if !placement.moved {
                scratch.old.take_from(self, old.start, retired.start);
                placement.moved = true;
            }
            if let Some(from) = placement.run.take() {
                self.copy_history(&scratch.old, from, (old.start, retired.start));
            }
            self.merge_changed_row(&scratch.old, &scratch.row, old, retired);
            scratch.retired_start.push(self.retired_gid.len() as u32);
        }
        scratch.start.push(scratch.partner.len() as u32);
    }

    /// The histories of the unchanged owned rows `rows` stay where they are: the run of
    /// unchanged rows (once histories have moved) begins at the first of them if not before,
    /// and their retired pairs, not copied yet, are counted in the new retired starts. The
    /// one bookkeeping of [`Self::place_row`] and [`Self::place_unchanged_rows`].
    fn keep_unchanged_histories(
        &self,
        scratch: &mut BuildScratch,
        placement: &mut Placement,
        rows: std::ops::Range<usize>,
    ) {
        // rows past the old table (none on a one-rank rebuild) had no pairs, as in
        // `compressed_row`
        let old_rows = self.retired_start.len().saturating_sub(1);
        let known = rows.start.min(old_rows)..rows.end.min(old_rows);
        let (listed, retired) = if rows.start < old_rows {
            (self.start[rows.start] as usize, self.retired_start[rows.start])
        } else {
            (0, 0)
        };
        if placement.moved {
            placement.run.get_or_insert((listed, retired as usize));
        }
        let new_retired = *scratch.retired_start.last().expect("the retired starts begin with 0");
        if !known.is_empty() {
            let ends = &self.retired_start[known.start + 1..=known.end];
            scratch.retired_start.extend(ends.iter().map(|&s| s - retired + new_retired));
        }
        let last = *scratch.retired_start.last().expect("the retired starts begin with 0");
        scratch.retired_start.extend(std::iter::repeat_n(last, rows.len() - known.len()));
    }

    /// [`Self::place_row`] of each of the owned rows `rows`, none of which changed and whose
    /// old partners stand in the same local numbering: their partners and row starts are
    /// copied as one run.
    fn place_unchanged_rows(
        &mut self,
        scratch: &mut BuildScratch,
        placement: &mut Placement,
        rows: std::ops::Range<usize>,
    ) {
        self.keep_unchanged_histories(scratch, placement, rows.clone());
        let listed = self.start[rows.start];
        let new_listed = scratch.partner.len() as u32;
        scratch.partner.extend_from_slice(&self.partner[listed as usize..self.start[rows.end] as usize]);
        scratch.start.extend(self.start[rows.start + 1..=rows.end].iter().map(|&s| s - listed + new_listed));
    }

    /// Ends a build: the last run of unchanged rows' histories, the new rows, and the
    /// reference positions and numbering the next build and the checks start from.
    fn finish_build(
        &mut self,
        mut scratch: BuildScratch,
        placement: Placement,
        nodes: &Nodes,
        references: Vec<Vec3>,
        max_cutoff: f64,
        coarse_reach: f64,
    ) {
        if let Some(from) = placement.run {
            self.copy_history(&scratch.old, from, scratch.old.end());
        }
        debug_assert_eq!(
            (self.partner_gid.len(), self.retired_gid.len()),
            (scratch.partner.len(), *scratch.retired_start.last().unwrap() as usize)
        );
        std::mem::swap(&mut self.start, &mut scratch.start);
        std::mem::swap(&mut self.partner, &mut scratch.partner);
        std::mem::swap(&mut self.retired_start, &mut scratch.retired_start);
        self.scratch = scratch;
        self.motion.build(&references, max_cutoff, 2.0 * coarse_reach);
        self.reference_position = references;
        self.reference_gid.clear();
        self.reference_gid.extend_from_slice(&nodes.gid);
        self.split_rows(nodes);
        self.builds += 1;
    }

    /// Finds each owned row's upper part and the entries with ghosts of lower gid.
    fn split_rows(&mut self, nodes: &Nodes) {
        let owned = nodes.n_owned;
        // the sweep's order of terms is the gid order only if the rows come in it (D13)
        assert!(
            nodes.gid[..owned].windows(2).all(|pair| pair[0] < pair[1]),
            "owned nodes must be stored in ascending gid"
        );
        self.upper_start.clear();
        self.lower_ghosts.clear();
        for i in 0..owned {
            let row = self.row(i);
            let gid = nodes.gid[i];
            let lower = self.partner_gid[row.clone()].partition_point(|&g| g < gid);
            self.upper_start.push((row.start + lower) as u32);
            for k in row.start..row.start + lower {
                let j = self.partner[k] as usize;
                if j >= owned {
                    let before_row = nodes.gid[..owned].partition_point(|&g| g < nodes.gid[j]);
                    self.lower_ghosts.push(LowerGhostEntry {
                        before_row: before_row as u32,
                        row: i as u32,
                        entry: k as u32,
                    });
                }
            }
        }
        let partner_gid = |e: &LowerGhostEntry| self.partner_gid[e.entry as usize];
        self.lower_ghosts.sort_unstable_by(|a, b| partner_gid(a).cmp(&partner_gid(b)).then(a.row.cmp(&b.row)));
    }

    /// Whether entry `k` of owned row `i` is where its pair is evaluated and its history
    /// kept: not when the partner is owned here with a lower gid (D13).
    #[inline]
    pub fn evaluates(&self, i: usize, k: usize) -> bool {
        (self.partner[k] as usize) >= self.upper_start.len() || k >= self.upper_start[i] as usize
    }

    /// Where the history of entry `k` of owned row `i` is kept: in the entry itself, or, for a
    /// partner owned here with a lower gid, at the mirror entry in the partner's row (then
    /// `true`: seen from the partner).
    fn history_entry(&self, i: usize, k: usize) -> (usize, bool) {
        if self.evaluates(i, k) {
            return (k, false);
        }
        let j = self.partner[k] as usize;
        let upper = self.upper_start[j] as usize..self.start[j + 1] as usize;
        let gid = self.reference_gid[i];
        match self.partner_gid[upper.clone()].binary_search(&gid) {
            Ok(m) => (upper.start + m, true),
            Err(_) => unreachable!(
                "the lists are symmetric: node {} lists {} and is not listed back",
                gid.0, self.partner_gid[k].0
            ),
        }
    }

    /// The contact history of entry `k` of owned row `i`, seen from node `i`.
    pub fn history(&self, i: usize, k: usize) -> PairHistory {
        let (at, mirrored) = self.history_entry(i, k);
        let anchor = self.anchor[at];
        PairHistory {
            anchor: if mirrored { -anchor } else { anchor },
            spring_stiffness: self.spring_stiffness[at],
            touching: self.touching[at],
            max_overlap: self.max_overlap[at],
        }
    }

    /// The retired pairs of every owned row as rows that each evaluated all their pairs would
    /// hold them: row lengths, partner gids and largest overlaps. A pair of two owned nodes
    /// is retired by its node of lower gid, the one that evaluates it; the partner's record
    /// is that one's. So a checkpoint holds the same tables on any rank count.
    pub fn retired_as_full_rows(&self) -> (Vec<u32>, Vec<GlobalNodeId>, Vec<f64>) {
        let owned = self.upper_start.len();
        let gids = &self.reference_gid[..owned];
        let owned_here = |gid: GlobalNodeId| gids.binary_search(&gid).ok();
        // each owned pair's record, handed to the node of higher gid: (row, partner, overlap)
        let mut handed: Vec<(usize, GlobalNodeId, f64)> = (0..owned)
            .flat_map(|j| self.retired_row(j).map(move |r| (j, r)))
            .filter(|&(j, r)| self.retired_gid[r] > gids[j])
            .filter_map(|(j, r)| owned_here(self.retired_gid[r]).map(|i| (i, gids[j], self.retired_max_overlap[r])))
            .collect();
        handed.sort_unstable_by_key(|&(i, gid, _)| (i, gid));
        let (mut lengths, mut partners, mut overlaps) = (Vec::with_capacity(owned), Vec::new(), Vec::new());
        let mut handed = handed.into_iter().peekable();
        for (i, &gid) in gids.iter().enumerate() {
            let start = partners.len();
            // the row's own records, but those of owned partners of lower gid (not kept here)
            let mut own = self
                .retired_row(i)
                .filter(|&r| self.retired_gid[r] > gid || owned_here(self.retired_gid[r]).is_none())
                .peekable();
            loop {
                let next_handed = handed.peek().filter(|h| h.0 == i).map(|h| h.1);
                let next_own = own.peek().map(|&r| self.retired_gid[r]);
                let take_own = match (next_own, next_handed) {
                    (Some(a), Some(b)) => a < b,
                    (Some(_), None) => true,
                    (None, Some(_)) => false,
                    (None, None) => break,
                };
                let (gid, overlap) = if take_own {
                    let r = own.next().expect("peeked");
                    (self.retired_gid[r], self.retired_max_overlap[r])
                } else {
                    let (_, gid, overlap) = handed.next().expect("peeked");
                    (gid, overlap)
                };
                partners.push(gid);
                overlaps.push(overlap);
            }
            lengths.push((partners.len() - start) as u32);
        }
        (lengths, partners, overlaps)
    }

    /// The entries `(row, entry)` of owned rows where a touching pair is evaluated: each pair
    /// of owned nodes once, each pair with a ghost once here.
    pub fn evaluated_touching(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        (0..self.upper_start.len())
            .flat_map(move |i| self.row(i).map(move |k| (i, k)))
            .filter(|&(i, k)| self.evaluates(i, k) && self.touching[k])
    }

    /// Entries of owned rows whose pair touches (a pair of two owned nodes counts twice).
    pub fn touching_entries(&self) -> usize {
        let owned = self.upper_start.len();
        self.evaluated_touching().map(|(_, k)| if (self.partner[k] as usize) < owned { 2 } else { 1 }).sum()
    }

    /// Appends to the lists being built the history of a row that changed, `old` and `retired`
    /// being its listed and retired pairs in the old lists `from` (a gid is in one or the
    /// other), `row` its new partners: a pair still listed carries its history, a retired one
    /// that is back its largest overlap; retired now are the old row's pairs that touched and
    /// are gone, and the retired pairs still gone.
    fn merge_changed_row(
        &mut self,
        from: &OldHistories,
        row: &[(GlobalNodeId, u32)],
        old: std::ops::Range<usize>,
        retired: std::ops::Range<usize>,
    ) {
        let (old, retired) = (from.listed_range(old), from.retired_range(retired));
        let (mut cursor, mut back) = (old.start, retired.start);
        for &(gid, _) in row {
            while cursor < old.end && from.partner_gid[cursor] < gid {
                cursor += 1;
            }
            while back < retired.end && from.retired_gid[back] < gid {
                back += 1;
            }
            let carried = cursor < old.end && from.partner_gid[cursor] == gid;
            let returned = back < retired.end && from.retired_gid[back] == gid;
            self.partner_gid.push(gid);
            self.anchor.push(if carried { from.anchor[cursor] } else { Vec3::zeros() });
            self.spring_stiffness.push(if carried { from.spring_stiffness[cursor] } else { 0.0 });
            self.touching.push(carried && from.touching[cursor]);
            self.max_overlap.push(if carried {
                from.max_overlap[cursor]
            } else if returned {
                from.retired_max_overlap[back]
            } else {
                0.0
            });
        }
        // retired now: the old row's pairs that touched and are gone, and the retired
        // pairs still gone, merged by gid
        let gone = |gid: GlobalNodeId| row.binary_search_by(|probe| probe.0.cmp(&gid)).is_err();
        let (mut a, mut b) = (old.start, retired.start);
        loop {
            let from_list = a < old.end && (b >= retired.end || from.partner_gid[a] < from.retired_gid[b]);
            let (gid, max_overlap) = if from_list {
                a += 1;
                (from.partner_gid[a - 1], from.max_overlap[a - 1])
            } else if b < retired.end {
                b += 1;
                (from.retired_gid[b - 1], from.retired_max_overlap[b - 1])
            } else {
                break;
            };
            if max_overlap > 0.0 && gone(gid) {
                self.retired_gid.push(gid);
                self.retired_max_overlap.push(max_overlap);
            }
        }
    }

    /// Appends to the lists being built the histories of the listed and retired pairs of the
    /// old lists `old` from `start` to `end` (listed, retired): rows that did not change.
    fn copy_history(&mut self, old: &OldHistories, start: (usize, usize), end: (usize, usize)) {
        let (listed, retired) = (old.listed_range(start.0..end.0), old.retired_range(start.1..end.1));
        self.partner_gid.extend_from_slice(&old.partner_gid[listed.clone()]);
        self.anchor.extend_from_slice(&old.anchor[listed.clone()]);
        self.spring_stiffness.extend_from_slice(&old.spring_stiffness[listed.clone()]);
        self.touching.extend_from_slice(&old.touching[listed.clone()]);
        self.max_overlap.extend_from_slice(&old.max_overlap[listed]);
        self.retired_gid.extend_from_slice(&old.retired_gid[retired.clone()]);
        self.retired_max_overlap.extend_from_slice(&old.retired_max_overlap[retired]);
    }

    /// True when the lists still hold every pair of local nodes (owned and ghosts) that can
    /// touch, though a node may have moved more than half the skin: no two nodes that could
    /// have come within contact since the build moved more than the skin relative to each
    /// other. Such nodes were less than the cutoff plus twice the largest displacement apart
    /// at the build, so, while that is below the cell size, in neighbouring cells: the spread
    /// of the displacements over every three by three by three block of cells bounds their
    /// relative motion. Fibres carried along together by a projectile move far and barely
    /// apart, and keep their lists. A node that is on another rank and no ghost here is not
    /// seen: with ghosts, the caller must know by other means that none came within reach
    /// ([`crate::Domain::lists_may_miss_a_pair`]), and the ghosts' positions must be the present ones.
    ///
    /// Between full checks, a check that kept the lists still holds while its spread plus
    /// twice the distance any local node has moved since ([`Self::moved_at_most`]) stays
    /// below the skin: a calm run checks seldom.
    pub fn hold_every_reachable_pair(&mut self, nodes: &Nodes) -> bool {
        let motion = &mut self.motion;
        let Some(grid) = &motion.grid else { return false };
        // built for these nodes
        if nodes.len() != motion.slot.len() {
            return false;
        }
        if let Some((spread, largest)) = motion.passed {
            if spread + 2.0 * motion.moved_since < self.skin
                && motion.cutoff + 2.0 * (largest + motion.moved_since) < motion.cell
            {
                return true;
            }
        }
        motion.passed = None;
        motion.moved_since = 0.0;
        for &cell in &motion.occupied {
            let slot = grid.slot(cell);
            motion.low[slot] = Vec3::repeat(f64::INFINITY);
            motion.high[slot] = Vec3::repeat(f64::NEG_INFINITY);
        }
        let mut largest_squared: f64 = 0.0;
        for ((x, reference), &slot) in nodes.position.iter().zip(&self.reference_position).zip(&motion.slot) {
            let displacement = x - reference;
            largest_squared = largest_squared.max(displacement.norm_squared());
            let slot = slot as usize;
            motion.low[slot] = motion.low[slot].inf(&displacement);
            motion.high[slot] = motion.high[slot].sup(&displacement);
        }
        // a NaN displacement fails this test, and the rebuild that follows reports nothing
        // new: the forces catch it
        let largest = largest_squared.sqrt();
        #[allow(clippy::neg_cmp_op_on_partial_ord)]
        if !(motion.cutoff + 2.0 * largest < motion.cell) {
            return false;
        }
        let mut widest: f64 = 0.0;
        let kept = motion.occupied.iter().all(|&[x, y, z]| {
            let (mut low, mut high) = (Vec3::repeat(f64::INFINITY), Vec3::repeat(f64::NEG_INFINITY));
            for dx in -1..=1 {
                for dy in -1..=1 {
                    for dz in -1..=1 {
                        let slot = grid.slot([x + dx, y + dy, z + dz]);
                        low = low.inf(&motion.low[slot]);
                        high = high.sup(&motion.high[slot]);
                    }
                }
            }
            let spread = (high - low).norm();
            widest = widest.max(spread);
            spread < self.skin
        });
        motion.passed = kept.then_some((widest, largest));
        kept
    }

    /// Records that no local node (ghosts included) moved farther than `distance` in a step [m].
    pub fn moved_at_most(&mut self, distance: f64) {
        self.motion.moved_since += distance;
    }
}

fn bounding_box(points: &[Vec3]) -> (Vec3, Vec3) {
    if points.is_empty() {
        (Vec3::zeros(), Vec3::zeros())
    } else {
        crate::bounding_box(points.iter().copied())
    }
}

impl RelativeMotion {
    /// Cells of size `cell` over the local nodes' reference positions.
    fn build(&mut self, positions: &[Vec3], cutoff: f64, cell: f64) {
        (self.grid, self.passed) = (None, None);
        if positions.is_empty() {
            return;
        }
        let (low, high) = bounding_box(positions);
        // a few dozen nodes share a cell: a small table
        let grid = HashedGrid::new(positions.len() / 32, low, high, cell);
        self.slot.clear();
        self.occupied.clear();
        self.low.clear();
        self.low.resize(grid.slots(), Vec3::repeat(f64::INFINITY));
        self.high.clear();
        self.high.resize(grid.slots(), Vec3::repeat(f64::NEG_INFINITY));
        // every occupied cell once, in the order the nodes meet them: a slot remembers the last
        // cell recorded in it (a cell that folded onto another's slot is recorded again when
        // they alternate, and its block checked twice: the same verdict). Not a sort of the
        // cells met: that, and the run detection before it, were half this pass.
        self.recorded.clear();
        self.recorded.resize(grid.slots(), [i64::MIN; 3]);
        for x in positions {
            let cell = grid.coordinates(x);
            let slot = grid.slot(cell);
            self.slot.push(slot as u32);
            if self.recorded[slot] != cell {
                self.recorded[slot] = cell;
                self.occupied.push(cell);
            }
        }
        (self.cutoff, self.cell, self.grid) = (cutoff, cell, Some(grid));
    }
}

/// A cell grid folded into a table of `slots()` entries: cell (x, y, z) lives in slot
/// `x s_x + y s_y + z` modulo the table, with strides from the bounding box, so neighbouring
/// cells stay close in memory as in a dense grid and the cells of a column along z are
/// consecutive. The table holds at most a few slots per node: when the box is huge (a
/// fragment flung far away) distant cells share slots, which costs extra candidates, never
/// a missed pair.
#[derive(Clone, Debug)]
struct HashedGrid {
    low: Vec3,
    inverse_cell: f64,
    stride_x: u64,
    stride_y: u64,
    mask: usize,
    /// cells along x, y and z of the box it was made for, and the node count
    cells: [u64; 3],
    nodes: usize,
}

impl HashedGrid {
    fn new(nodes: usize, low: Vec3, high: Vec3, cell: f64) -> Self {
        let extent = |k: usize| (((high[k] - low[k]) / cell).floor().min(1e9) as u64) + 3;
        let cells = [extent(0), extent(1), extent(2)];
        let dense = cells[0].saturating_mul(cells[1]).saturating_mul(cells[2]) as usize;
        let slots = dense.clamp(2 * nodes, 8 * nodes.max(8)).next_power_of_two();
        Self {
            low,
            inverse_cell: 1.0 / cell,
            stride_x: cells[1] * cells[2],
            stride_y: cells[2],
            mask: slots - 1,
            cells,
            nodes,
        }
    }

    /// Whether this grid serves `nodes` nodes within `low`…`high` [m] in cells of side `cell`
    /// [m] as one made for them would: same cell, every node in its own dense cell (none
    /// folded onto another's) and a table for about as many nodes.
    fn still_fits(&self, nodes: usize, low: Vec3, high: Vec3, cell: f64) -> bool {
        let inside = |x: &Vec3| {
            let c = self.coordinates(x);
            (0..3).all(|k| c[k] >= 0 && (c[k] as u64) < self.cells[k])
        };
        self.inverse_cell == 1.0 / cell
            && (self.nodes..=self.nodes + self.nodes / 8).contains(&nodes)
            && self.mask + 1
                >= self.cells[0].saturating_mul(self.cells[1]).saturating_mul(self.cells[2]).min(2 * nodes as u64)
                    as usize
            && inside(&low)
            && inside(&high)
    }

    fn slots(&self) -> usize {
        self.mask + 1
    }

    #[inline]
    fn coordinates(&self, x: &Vec3) -> [i64; 3] {
        let c = |k: usize| crate::floor_index((x[k] - self.low[k]) * self.inverse_cell);
        [c(0), c(1), c(2)]
    }

    /// Sets in `bits` (one a slot) the slots of the cell of `x` and of its 26 neighbours.
    #[inline]
    fn mark_around(&self, x: &Vec3, bits: &mut [u64]) {
        let [cx, cy, cz] = self.coordinates(x);
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    let slot = self.slot([cx + dx, cy + dy, cz + dz]);
                    bits[slot / 64] |= 1 << (slot % 64);
                }
            }
        }
    }

    #[inline]
    fn slot(&self, [x, y, z]: [i64; 3]) -> usize {
        let linear = (x as u64)
            .wrapping_mul(self.stride_x)
            .wrapping_add((y as u64).wrapping_mul(self.stride_y))
            .wrapping_add(z as u64);
        linear as usize & self.mask
    }
}

/// Cubes of side a hair over a reach, laid over a box that two ranks both know, to tell
/// which nodes of one lie next to nodes of the other without sending them: two points closer
/// than the reach lie in the same cube or in neighbouring ones (the hair keeps rounding from
/// putting them two cubes apart).
#[derive(Clone, Debug, PartialEq)]
pub struct SharedCubes {
    low: Vec3,
    side: f64,
    dims: [usize; 3],
}

impl SharedCubes {
    /// Cubes over the box from `low` to `high` for points closer than `reach`; none when the
    /// box is empty or would take more than `most` cubes.
    pub fn new(low: Vec3, high: Vec3, reach: f64, most: usize) -> Option<Self> {
        let side = reach * (1.0 + 1e-9);
        let extent = high - low;
        if !(extent.min() >= 0.0 && side > 0.0) {
            return None;
        }
        let dims = [0, 1, 2].map(|k| (extent[k] / side).floor().min(1e12) as usize + 1);
        let cubes = dims.iter().try_fold(1usize, |total, &d| total.checked_mul(d))?;
        (cubes <= most).then_some(Self { low, side, dims })
    }

    /// The cube of `x`, if `x` lies in the box.
    pub fn cube(&self, x: &Vec3) -> Option<usize> {
        let mut index = 0;
        for k in 0..3 {
            let c = ((x[k] - self.low[k]) / self.side).floor();
            if !(c >= 0.0 && c < self.dims[k] as f64) {
                return None;
            }
            index = index * self.dims[k] + c as usize;
        }
        Some(index)
    }

    /// The cubes that hold a point of `points`, as bits in words of 64.
    pub fn occupied<'a>(&self, points: impl Iterator<Item = &'a Vec3>) -> Vec<u64> {
        let mut bits = vec![0u64; self.dims.iter().product::<usize>().div_ceil(64)];
        for c in points.filter_map(|x| self.cube(x)) {
            bits[c / 64] |= 1 << (c % 64);
        }
        bits
    }

    /// For each cube, whether it is or touches a cube set in `occupied` ([`Self::occupied`]).
    pub fn next_to(&self, occupied: &[u64]) -> Vec<bool> {
        let [nx, ny, nz] = self.dims;
        let mut near = vec![false; nx * ny * nz];
        for c in (0..nx * ny * nz).filter(|&c| occupied.get(c / 64).is_some_and(|w| w >> (c % 64) & 1 == 1)) {
            let (x, y, z) = (c / (ny * nz), c / nz % ny, c % nz);
            for i in x.saturating_sub(1)..(x + 2).min(nx) {
                for j in y.saturating_sub(1)..(y + 2).min(ny) {
                    for k in z.saturating_sub(1)..(z + 2).min(nz) {
                        near[(i * ny + j) * nz + k] = true;
                    }
                }
            }
        }
        near
    }
}

/// For each candidate point, whether it lies closer than `reach` to any target point: which
/// nodes another rank sends are within contact reach of this rank's own nodes.
///
/// The larger of the two sets is first cut, one lookup a point, to the cells next to the
/// smaller's ([`CellsNextTo`]): when two ranks' regions interleave, most of a rank's nodes
/// lie far from the few another sends, and binning or querying them all would cost the most.
pub fn within_reach_of_any(targets: &[Vec3], candidates: &[Vec3], reach: f64) -> Vec<bool> {
    let mut found = vec![false; candidates.len()];
    if targets.is_empty() || candidates.is_empty() {
        return found;
    }
    // cells a hair over the reach: two points closer than it lie in the same cell or in
    // neighbouring ones whatever the rounding
    let cell = reach * (1.0 + 1e-9);
    let (targets, queried): (std::borrow::Cow<[Vec3]>, Vec<usize>) = if targets.len() <= candidates.len() {
        let next_to_targets = CellsNextTo::new(targets, cell);
        (targets.into(), (0..candidates.len()).filter(|&i| next_to_targets.holds(&candidates[i])).collect())
    } else {
        let next_to_candidates = CellsNextTo::new(candidates, cell);
        (
            targets.iter().filter(|x| next_to_candidates.holds(x)).copied().collect::<Vec<_>>().into(),
            (0..candidates.len()).collect(),
        )
    };
    if targets.is_empty() || queried.is_empty() {
        return found;
    }
    let (low, high) = bounding_box(&targets);
    let grid = HashedGrid::new(targets.len(), low, high, cell);
    let slot_of: Vec<usize> = targets.iter().map(|x| grid.slot(grid.coordinates(x))).collect();
    let mut start = Vec::new();
    count_rows(grid.slots(), slot_of.iter().copied(), &mut start);
    let mut fill = start.clone();
    let mut sorted = vec![Vec3::zeros(); targets.len()];
    for (x, &c) in targets.iter().zip(&slot_of) {
        sorted[fill[c] as usize] = *x;
        fill[c] += 1;
    }
    for i in queried {
        let x = &candidates[i];
        let [cx, cy, cz] = grid.coordinates(x);
        found[i] = (-1..=1).any(|dx| {
            (-1..=1).any(|dy| {
                (-1..=1).any(|dz| {
                    let c = grid.slot([cx + dx, cy + dy, cz + dz]);
                    sorted[start[c] as usize..start[c + 1] as usize]
                        .iter()
                        .any(|t| (t - x).norm_squared() < reach * reach)
                })
            })
        });
    }
    found
}

/// The cells of a grid over some points that hold one of them or touch one that does: a
/// point outside them is farther than a cell from every one of the points. Cells folded onto
/// one slot of the table share its mark, which lets a far point through, never stops a near
/// one; a point beyond the grid's box by more than a cell is stopped outright.
struct CellsNextTo {
    grid: HashedGrid,
    /// one bit per slot
    marked: Vec<u64>,
}

impl CellsNextTo {
    /// The cells of side `cell` [m] next to `points` (not empty).
    fn new(points: &[Vec3], cell: f64) -> Self {
        let (low, high) = bounding_box(points);
        let grid = HashedGrid::new(points.len(), low, high, cell);
        let mut marked = vec![0u64; grid.slots().div_ceil(64)];
        for x in points {
            grid.mark_around(x, &mut marked);
        }
        Self { grid, marked }
    }

    /// Whether `x` lies in a cell next to one of the points (or in a folded cell that shares
    /// such a cell's slot).
    #[inline]
    fn holds(&self, x: &Vec3) -> bool {
        let c = self.grid.coordinates(x);
        // the points' cells run from 0 to `cells - 3` along each axis (the grid's box is theirs)
        if (0..3).any(|k| c[k] < -1 || c[k] > self.grid.cells[k] as i64 - 2) {
            return false;
        }
        let slot = self.grid.slot(c);
        self.marked[slot / 64] & (1 << (slot % 64)) != 0
    }
}

/// A node's place on its chain: its fibre in the high half, its position along it in the low
/// half, so that places of one fibre differ by their distance along it and places of two
/// fibres by at least 2^31 (a fibre holds fewer than 2^31 nodes).
#[inline]
fn chain_place(fibre: FibreId, along: u32) -> u64 {
    debug_assert!(along < 1 << 31);
    (fibre.0 as u64) << 32 | along as u64
}

/// True when two chain places lie on one fibre within `exclusion` (below 2^31) positions of
/// each other.
#[inline]
fn same_fibre_within(place: u64, other: u64, exclusion: u32) -> bool {
    (other.wrapping_sub(place) as i64).unsigned_abs() <= exclusion as u64
}

/// True when `j` is a chain neighbour of `i` that the contact search must skip.
pub fn is_excluded(nodes: &Nodes, sections: &[FibreSection], i: usize, j: usize) -> bool {
    same_fibre_within(
        chain_place(nodes.fibre[i], nodes.along[i]),
        chain_place(nodes.fibre[j], nodes.along[j]),
        chain_exclusion(&sections[nodes.section[i] as usize]),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures::uniform;
    use crate::ids::FibreId;
    use crate::material::{FibreMaterial, InertiaModel};

    /// Asserts that `list` holds what a full build with every node at its reference lists.
    fn assert_lists_a_full_build_at_the_references(
        list: &NeighbourList,
        nodes: &Nodes,
        sections: &[FibreSection],
        round: usize,
    ) {
        let mut at_references = nodes.clone();
        at_references.position = list.reference_position.clone();
        let mut full = NeighbourList::new(list.skin);
        full.rebuild(&at_references, sections);
        assert_eq!(
            (&list.start, &list.partner, &list.partner_gid),
            (&full.start, &full.partner, &full.partner_gid),
            "round {round}"
        );
    }

    fn random_cloud(n: usize, seed: u64) -> (Nodes, Vec<FibreSection>) {
        let material = FibreMaterial::kevlar_km2();
        let section = FibreSection::new(&material, 1e-9, 18e-6, InertiaModel::None {}.with_friction(0.3));
        let mut nodes = Nodes::default();
        let mut next = uniform(seed);
        for k in 0..n {
            let x = Vec3::new(next(), next(), next()) * 4e-4;
            nodes.push(
                GlobalNodeId(k as u64 * 3),
                x,
                Vec3::zeros(),
                1.0,
                FibreId((k / 10) as u32),
                (k % 10) as u32,
                0,
                false,
                k % 10 == 9,
            );
        }
        nodes.n_owned = n;
        nodes.link_chains();
        (nodes, vec![section])
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn the_lanes_find_the_candidates_one_at_a_time_finds() {
        if !crate::dispatch::Compilation::Avx2.runs() {
            return;
        }
        let mut next = uniform(11);
        let n = 256;
        let mut cells = CellOrdered {
            node: (0..n as u32).collect(),
            gid: (0..n as u64).map(GlobalNodeId).collect(),
            ..Default::default()
        };
        for _ in 0..n + 3 {
            cells.x.push(next());
            cells.y.push(next());
            cells.z.push(next());
            // three fibres, places along them close to the node's
            cells.place.push(chain_place(FibreId((3.0 * next()) as u32), 10 + (7.0 * next()) as u32));
        }
        cells.x[17] = f64::NAN;
        // runs of every length modulo four, one at the end of the entries
        let stencil = Stencil { cell: None, runs: vec![0..5, 9..23, 30..31, 40..46, 57..150, 201..256] };
        let place = chain_place(FibreId(1), 14);
        let mut found = 0;
        for x in [Vec3::new(0.5, 0.5, 0.5), Vec3::new(0.1, 0.9, 0.3), Vec3::new(f64::NAN, 0.5, 0.5)] {
            let (mut one_at_a_time, mut in_lanes) = (Vec::new(), Vec::new());
            stencil.within_one_at_a_time(&cells, &x, place, 2, 0.2, &mut one_at_a_time);
            crate::in_avx2_lanes!(stencil.within_in_lanes(&cells, &x, place, 2, 0.2, &mut in_lanes))
                .expect("AVX2 is present");
            assert_eq!(in_lanes, one_at_a_time, "from {x:?}");
            assert!(one_at_a_time.iter().all(|&k| stencil.runs.iter().any(|run| run.contains(&(k as usize)))));
            found += one_at_a_time.len();
        }
        let mut near = Vec::new();
        stencil.within_one_at_a_time(&cells, &Vec3::new(0.5, 0.5, 0.5), place, 0, 0.2, &mut near);
        let mut linked = Vec::new();
        stencil.within_one_at_a_time(&cells, &Vec3::new(0.5, 0.5, 0.5), place, 2, 0.2, &mut linked);
        assert!(
            found > 5 && linked.len() < near.len(),
            "the test finds candidates ({found}) and leaves out chain neighbours"
        );
    }

    #[test]
    fn chain_places_tell_fibres_apart_at_any_distance_along() {
        let far = (1 << 31) - 1;
        assert!(same_fibre_within(chain_place(FibreId(4), far), chain_place(FibreId(4), far - 3), 3));
        assert!(!same_fibre_within(chain_place(FibreId(4), far), chain_place(FibreId(5), 0), far));
        assert!(!same_fibre_within(chain_place(FibreId(u32::MAX), 0), chain_place(FibreId(0), far), far));
        assert!(!same_fibre_within(chain_place(FibreId(4), 10), chain_place(FibreId(4), 14), 3));
    }

    #[test]
    fn retired_tables_are_checkpointed_as_full_rows_hold_them() {
        // gids 0, 3, …, 87, all owned; gids 1 and 100 are nodes elsewhere
        let (nodes, sections) = random_cloud(30, 4);
        let mut list = NeighbourList::new(5e-6);
        list.rebuild(&nodes, &sections);
        let g = |k: u64| GlobalNodeId(k);
        // row by row: a pair of owned nodes keeps its record at its node of lower gid; the
        // partner's record, if any, is stale (this sweep never reads it)
        let rows: Vec<Vec<(GlobalNodeId, f64)>> = (0..30)
            .map(|i| match i {
                2 => vec![(g(15), 1e-7)],
                3 => vec![(g(100), 4e-7)],
                4 => vec![(g(21), 2e-7)],
                7 => vec![(g(1), 3e-7), (g(12), 5e-8)],
                9 => vec![(g(24), 6e-8)],
                _ => vec![],
            })
            .collect();
        list.retired_start = std::iter::once(0)
            .chain(rows.iter().scan(0, |total, row| {
                *total += row.len() as u32;
                Some(*total)
            }))
            .collect();
        list.retired_gid = rows.iter().flatten().map(|r| r.0).collect();
        list.retired_max_overlap = rows.iter().flatten().map(|r| r.1).collect();
        let (lengths, partners, overlaps) = list.retired_as_full_rows();
        let mut expected: Vec<Vec<(GlobalNodeId, f64)>> = vec![vec![]; 30];
        expected[2] = vec![(g(15), 1e-7)];
        expected[5] = vec![(g(6), 1e-7)];
        expected[3] = vec![(g(100), 4e-7)];
        expected[4] = vec![(g(21), 2e-7)];
        expected[7] = vec![(g(1), 3e-7), (g(12), 2e-7)];
        let mut at = 0;
        for (i, &length) in lengths.iter().enumerate() {
            let row: Vec<_> = (at..at + length as usize).map(|r| (partners[r], overlaps[r])).collect();
            assert_eq!(row, expected[i], "row {i}");
            at += length as usize;
        }
        assert_eq!(at, partners.len());
    }

    #[test]
    fn cell_list_finds_exactly_the_brute_force_pairs_sorted_by_gid() {
        let (nodes, sections) = random_cloud(600, 9);
        let mut list = NeighbourList::new(5e-6);
        list.rebuild(&nodes, &sections);
        for i in 0..nodes.n_owned {
            let mut expected: Vec<GlobalNodeId> = (0..nodes.len())
                .filter(|&j| j != i && !is_excluded(&nodes, &sections, i, j))
                .filter(|&j| {
                    (nodes.position[j] - nodes.position[i]).norm()
                        < contact_distance(&sections, &nodes, i, j) + list.skin
                })
                .map(|j| nodes.gid[j])
                .collect();
            expected.sort();
            assert_eq!(list.partner_gid[list.row(i)], expected[..], "node {i}");
        }
        assert!(!list.is_empty());
    }

    #[test]
    fn a_node_flung_far_away_neither_breaks_nor_slows_the_search() {
        let (mut nodes, sections) = random_cloud(600, 5);
        let mut list = NeighbourList::new(5e-6);
        list.rebuild(&nodes, &sections);
        let before: Vec<Vec<GlobalNodeId>> = (1..nodes.n_owned)
            .map(|i| list.partner_gid[list.row(i)].iter().copied().filter(|&g| g != nodes.gid[0]).collect())
            .collect();
        nodes.position[0] = Vec3::new(1e3, -2e3, 5e2);
        list.rebuild(&nodes, &sections);
        assert_eq!(list.row(0).len(), 0);
        for i in 1..nodes.n_owned {
            assert_eq!(list.partner_gid[list.row(i)], before[i - 1][..], "node {i}");
        }
    }

    #[test]
    fn lists_kept_through_motion_together_still_hold_every_touching_pair() {
        let (reference, sections) = random_cloud(600, 5);
        let mut list = NeighbourList::new(5e-6);
        let mut stream = uniform(77);
        let mut next = move || stream() - 0.5;
        let (mut kept_beyond_plain_rule, mut refused, mut refused_later) = (0, 0, 0);
        for trial in 0..60 {
            let mut nodes = reference.clone();
            list.rebuild(&nodes, &sections);
            // nodes carried by a common translation of up to three skins plus a jitter of
            // up to half a skin: all of them, or those of one half-space
            let carried = Vec3::new(next(), next(), next()) * 6.0 * list.skin;
            let scale = list.skin * (next() + 0.5);
            // a cut on a boundary of the check's cells (twice the list's) moves whole cells
            // past each other
            let cell = 2.0 * (sections[0].contact_diameter + list.skin);
            let low = reference.position.iter().fold(f64::INFINITY, |low, x| low.min(x.x));
            let cut = match trial % 4 {
                0 | 2 => f64::INFINITY,
                1 => 4e-4 * (0.25 + 0.5 * (next() + 0.5)),
                _ => low + cell * (2 + trial % 5) as f64,
            };
            for x in &mut nodes.position {
                let jitter = Vec3::new(next(), next(), next()) * scale;
                *x += if x.x < cut { carried + jitter } else { jitter };
            }
            let largest =
                nodes.position.iter().zip(&list.reference_position).map(|(x, r)| (x - r).norm()).fold(0.0, f64::max);
            if !list.hold_every_reachable_pair(&nodes) {
                refused += 1;
                continue;
            }
            kept_beyond_plain_rule += (2.0 * largest > list.skin) as usize;
            let every_touching_pair_listed = |list: &NeighbourList, nodes: &Nodes, stage: &str| {
                for i in 0..nodes.n_owned {
                    for j in (0..nodes.len()).filter(|&j| j != i && !is_excluded(nodes, &sections, i, j)) {
                        if (nodes.position[j] - nodes.position[i]).norm() < contact_distance(&sections, nodes, i, j) {
                            assert!(
                                list.partner_gid[list.row(i)].contains(&nodes.gid[j]),
                                "trial {trial}, {stage}: touching pair {i}-{j} not listed"
                            );
                        }
                    }
                }
            };
            every_touching_pair_listed(&list, &nodes, "first check");
            // then steps that move the nodes apart, each no farther than it says: the check
            // that kept the lists answers from its bound until the bound runs out
            for step in 0..8 {
                let move_by = 0.1 * list.skin;
                for (k, x) in nodes.position.iter_mut().enumerate() {
                    *x += Vec3::new(if k % 2 == 0 { move_by } else { -move_by }, 0.0, 0.0);
                }
                list.moved_at_most(move_by);
                if !list.hold_every_reachable_pair(&nodes) {
                    refused_later += 1;
                    break;
                }
                every_touching_pair_listed(&list, &nodes, &format!("step {step}"));
            }
        }
        assert!(
            kept_beyond_plain_rule > 5 && refused > 5 && refused_later > 5,
            "kept {kept_beyond_plain_rule}, refused {refused}, refused later {refused_later}"
        );
    }

    #[test]
    fn shared_cubes_mark_every_point_within_reach_of_the_other_set() {
        let mut next = uniform(11);
        let reach = 0.1;
        let (low, high) = (Vec3::new(-0.3, -0.2, 0.0), Vec3::new(0.4, 0.5, 0.25));
        let cubes = SharedCubes::new(low, high, reach, 10_000).unwrap();
        // points on both sides of the box's faces, and pairs placed just inside the reach
        let point = |next: &mut dyn FnMut() -> f64| {
            Vec3::new(-0.35 + 0.8 * next(), -0.25 + 0.8 * next(), -0.05 + 0.35 * next())
        };
        let theirs: Vec<Vec3> = (0..60).map(|_| point(&mut next)).collect();
        let mut ours: Vec<Vec3> = (0..400).map(|_| point(&mut next)).collect();
        ours.extend(
            theirs
                .iter()
                .map(|t| t + Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5).normalize() * (reach * (1.0 - 1e-12))),
        );
        let near = cubes.next_to(&cubes.occupied(theirs.iter()));
        let (mut within, mut marked) = (0, 0);
        for x in &ours {
            let inside = (0..3).all(|k| x[k] >= low[k] && x[k] <= high[k]);
            let close =
                theirs.iter().any(|t| (0..3).all(|k| t[k] >= low[k] && t[k] <= high[k]) && (t - x).norm() < reach);
            let flagged = cubes.cube(x).is_some_and(|c| near[c]);
            if inside && close {
                within += 1;
                assert!(flagged, "{x:?} lies within reach of a point in the box but its cube is not marked");
            }
            marked += flagged as usize;
        }
        assert!(within > 20, "the test meets pairs within reach ({within})");
        assert!(marked < ours.len(), "the cubes rule some points out ({marked} of {})", ours.len());
        // a box too large for the allowance gets no cubes, and so does an empty one
        assert!(SharedCubes::new(low, high, reach, 100).is_none());
        assert!(SharedCubes::new(high, low, reach, 10_000).is_none());
    }

    #[test]
    fn reach_filter_matches_brute_force() {
        let (nodes, _) = random_cloud(500, 11);
        let reach = 3e-5;
        // either set the larger (each is then cut to the cells next to the other), and a
        // larger set mostly far from the smaller (the cloud's half beyond a plane, shifted)
        let far = |points: &[Vec3]| -> Vec<Vec3> {
            points.iter().map(|x| if x.x > 2e-4 { x + Vec3::new(3e-4, 0.0, 0.0) } else { *x }).collect()
        };
        for split in [200, 300, 40, 460] {
            let (first, second) = nodes.position.split_at(split);
            for (targets, candidates) in
                [(first.to_vec(), second.to_vec()), (far(first), second.to_vec()), (first.to_vec(), far(second))]
            {
                let found = within_reach_of_any(&targets, &candidates, reach);
                for (c, &hit) in candidates.iter().zip(&found) {
                    assert_eq!(hit, targets.iter().any(|t| (t - c).norm() < reach), "split {split}, candidate {c:?}");
                }
                assert!(found.iter().any(|&h| h) && found.iter().any(|&h| !h), "split {split}");
            }
        }
        let (targets, candidates) = nodes.position.split_at(200);
        // a pair a hair inside the reach, along an axis and a diagonal, is found
        for direction in [Vec3::new(1.0, 0.0, 0.0), Vec3::new(1.0, 1.0, 1.0).normalize()] {
            let near = targets[7] + direction * reach * (1.0 - 1e-12);
            assert_eq!(within_reach_of_any(targets, &[near], reach), vec![true]);
            assert!(within_reach_of_any(&[near], targets, reach)[7]);
        }
        // a point far outside the other set's box (folded onto the same slots) is not hit,
        // as a candidate or as a target
        let distant = [Vec3::new(1.0, 1.0, 1.0)];
        assert_eq!(within_reach_of_any(targets, &distant, reach), vec![false]);
        assert!(within_reach_of_any(&distant, candidates, reach).iter().all(|&h| !h));
    }

    #[test]
    fn a_row_is_unchanged_only_when_its_candidates_are_its_old_partners_each_met_once() {
        // candidates k name local nodes 10 + k
        let cell_node: Vec<u32> = (10..20).collect();
        let mut mark = vec![0; 20];
        let everyone = |_: usize| true;
        let mut stamp = 1;
        let mut same = |old: &[u32], hits: &[u32], within: &dyn Fn(usize) -> bool| {
            stamp += 2;
            same_partners(&mut mark, stamp, old, hits, &cell_node, within)
        };
        assert!(same(&[12, 15, 11], &[5, 1, 2], &everyone));
        assert!(same(&[], &[], &everyone));
        assert!(!same(&[12, 15, 11], &[5, 1], &everyone), "a partner gone");
        assert!(!same(&[12, 15], &[5, 1, 2], &everyone), "a partner new");
        assert!(!same(&[12, 15, 11], &[5, 1, 5], &everyone), "a partner met twice, another gone");
        assert!(!same(&[12, 15], &[5, 2, 5], &everyone), "a partner met twice");
        assert!(same(&[12, 15], &[5, 1, 2], &|j: usize| j != 11), "a candidate out of the pair's own reach");
        assert!(!same(&[12, 15, 11], &[5, 1, 2], &|j: usize| j != 11));
    }

    #[test]
    fn a_rebuild_keeps_unchanged_histories_and_follows_renumbered_ghosts() {
        let (cloud, sections) = random_cloud(600, 13);
        // the last third are ghosts
        let local = |order: &mut dyn Iterator<Item = usize>| {
            let mut nodes = Nodes::default();
            for k in order {
                nodes.push(
                    cloud.gid[k],
                    cloud.position[k],
                    Vec3::zeros(),
                    1.0,
                    cloud.fibre[k],
                    cloud.along[k],
                    0,
                    false,
                    cloud.last[k],
                );
            }
            nodes.n_owned = 400;
            nodes.link_chains();
            nodes
        };
        let nodes = local(&mut (0..600));
        let mut list = NeighbourList::new(5e-6);
        list.rebuild(&nodes, &sections);
        for k in 0..list.len() {
            list.max_overlap[k] = list.partner_gid[k].0 as f64 + 0.5;
            list.touching[k] = k % 3 == 0;
            list.anchor[k] = Vec3::repeat(k as f64);
        }
        let histories = |list: &NeighbourList| {
            (
                list.start.clone(),
                list.partner_gid.clone(),
                list.anchor.clone(),
                list.touching.clone(),
                list.max_overlap.clone(),
                list.retired_gid.clone(),
            )
        };
        let before = histories(&list);
        list.rebuild(&nodes, &sections);
        assert_eq!(histories(&list), before, "nothing moved: every row and history as it was");
        // the same nodes with the ghosts in reverse order: the same pairs, partners at their
        // new local indices
        let reversed = local(&mut (0..400).chain((400..600).rev()));
        list.rebuild(&reversed, &sections);
        assert_eq!(histories(&list), before);
        assert!(list.partner.iter().zip(&list.partner_gid).all(|(&j, &gid)| reversed.gid[j as usize] == gid));
        assert!(list.partner.iter().any(|&j| j >= 400), "ghosts are partners");
        // a node near the end of the owned ones leaves: the rows before the first changed
        // one keep their histories in place, those after carry theirs over
        let mut moved = reversed.clone();
        let leaving = (300..400).max_by_key(|&i| list.row(i).len()).unwrap();
        moved.position[leaving] += Vec3::new(1.0, 0.0, 0.0);
        list.rebuild(&moved, &sections);
        assert_eq!(list.row(leaving).len(), 0);
        let (mut changed, mut kept) = (0, 0);
        for i in 0..moved.n_owned {
            let row = list.row(i);
            let old = before.0[i] as usize..before.0[i + 1] as usize;
            if list.partner_gid[row.clone()] == before.1[old.clone()] {
                kept += 1;
                assert_eq!(
                    (&list.anchor[row.clone()], &list.max_overlap[row]),
                    (&before.2[old.clone()], &before.4[old]),
                    "row {i}"
                );
            } else {
                changed += 1;
                assert!(row.clone().all(|k| list.max_overlap[k] == list.partner_gid[k].0 as f64 + 0.5), "row {i}");
                assert!(list.retired_row(i).len() > 0, "row {i} retires its pair with the node that left");
            }
        }
        assert!(changed > 1 && kept > 300, "{changed} changed, {kept} kept");
    }

    #[test]
    fn a_rebuild_around_moved_nodes_lists_what_a_full_build_at_the_references_lists() {
        let (cloud, sections) = random_cloud(600, 21);
        // the last third are ghosts
        let mut nodes = Nodes::default();
        for k in 0..600 {
            nodes.push(
                cloud.gid[k],
                cloud.position[k],
                Vec3::zeros(),
                1.0,
                cloud.fibre[k],
                cloud.along[k],
                0,
                false,
                cloud.last[k],
            );
        }
        nodes.n_owned = 400;
        nodes.link_chains();
        let mut list = NeighbourList::new(5e-6);
        list.rebuild(&nodes, &sections);
        // each pair's history names the pair
        let key = |list: &NeighbourList, nodes: &Nodes, i: usize, k: usize| {
            (nodes.gid[i].0 * 1000 + list.partner_gid[k].0) as f64
        };
        let mut next = uniform(5);
        let (mut partial, mut unsearched) = (0, 0);
        for round in 0..40 {
            let mut listed = std::collections::HashSet::new();
            for i in 0..nodes.n_owned {
                for k in list.row(i) {
                    list.max_overlap[k] = key(&list, &nodes, i, k);
                    list.anchor[k] = Vec3::repeat(list.max_overlap[k]);
                    list.touching[k] = true;
                    listed.insert((nodes.gid[i], list.partner_gid[k]));
                }
            }
            // a few nodes move far, the others creep
            for x in &mut nodes.position {
                let scale = if next() < 0.05 { 4e-6 } else { 3e-7 };
                *x += Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5) * scale;
            }
            let old_references = list.reference_position.clone();
            list.rebuild_around_moved(&nodes, &sections);
            let kept = old_references.iter().zip(&list.reference_position).filter(|(a, b)| a == b).count();
            if kept > 0 {
                partial += 1;
                unsearched += kept;
            }
            assert!(
                nodes
                    .position
                    .iter()
                    .zip(&list.reference_position)
                    .all(|(x, r)| (x - r).norm() <= MOVED_SHARE_OF_SKIN * list.skin),
                "round {round}"
            );
            assert_lists_a_full_build_at_the_references(&list, &nodes, &sections, round);
            for i in 0..nodes.n_owned {
                for k in list.row(i) {
                    let pair = (nodes.gid[i], list.partner_gid[k]);
                    if listed.contains(&pair) {
                        assert_eq!(
                            (list.max_overlap[k], list.anchor[k], list.touching[k]),
                            (key(&list, &nodes, i, k), Vec3::repeat(key(&list, &nodes, i, k)), true),
                            "round {round}: {pair:?} keeps its history"
                        );
                    } else {
                        // new, or back from retirement with its largest overlap only
                        assert!(list.max_overlap[k] == 0.0 || list.max_overlap[k] == key(&list, &nodes, i, k));
                        assert!(!list.touching[k] && list.anchor[k] == Vec3::zeros());
                    }
                }
            }
        }
        assert!(
            partial > 30 && unsearched > 30 * 300,
            "{partial} partial rebuilds, {unsearched} nodes kept their references"
        );
    }

    #[test]
    fn a_rebuild_of_one_rank_among_several_lists_what_a_full_build_at_the_owners_references_lists() {
        // 600 nodes: 300 owned, 150 ghosts at first, 150 more appended over the rounds; a
        // ghost's reference is its owner's, moved only when its owner says so
        let (cloud, sections) = random_cloud(600, 33);
        let node = |nodes: &mut Nodes, k: usize, x: Vec3| {
            nodes.push(cloud.gid[k], x, Vec3::zeros(), 1.0, cloud.fibre[k], cloud.along[k], 0, false, cloud.last[k])
        };
        let mut nodes = Nodes::default();
        for k in 0..450 {
            node(&mut nodes, k, cloud.position[k]);
        }
        nodes.n_owned = 300;
        nodes.link_chains();
        let mut list = NeighbourList::new(5e-6);
        list.rebuild(&nodes, &sections);
        let mut next = uniform(8);
        let mut appended_total = 0;
        for round in 0..30 {
            for x in &mut nodes.position {
                let scale = if next() < 0.05 { 4e-6 } else { 3e-7 };
                *x += Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5) * scale;
            }
            // the owners move some ghosts (those they see beyond an eighth of the skin, and
            // a few more: an owner's present position is the ghost's)
            let moved_ghosts: Vec<u32> = (nodes.n_owned..nodes.len())
                .filter(|&g| {
                    (nodes.position[g] - list.reference_position[g]).norm() > 0.125 * list.skin || next() < 0.02
                })
                .map(|g| g as u32)
                .collect();
            // five ghosts come, with references their owners gave them some time ago
            let mut appended = Vec::new();
            for k in nodes.len()..(nodes.len() + 5).min(600) {
                let reference = cloud.position[k] + Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5) * 5e-7;
                node(&mut nodes, k, cloud.position[k]);
                appended.push(reference);
            }
            appended_total += appended.len();
            nodes.link_chains();
            let moved_owned = list.moved_owned(&nodes);
            let old = list.reference_position.clone();
            list.rebuild_only_around_moved(&nodes, &sections, &moved_ghosts, &appended);
            // the references are the owners'
            for i in 0..nodes.len() {
                let expected = if i >= old.len() {
                    appended[i - old.len()]
                } else if moved_owned.binary_search(&(i as u32)).is_ok()
                    || moved_ghosts.binary_search(&(i as u32)).is_ok()
                {
                    nodes.position[i]
                } else {
                    old[i]
                };
                assert_eq!(list.reference_position[i], expected, "round {round}, node {i}");
            }
            assert_lists_a_full_build_at_the_references(&list, &nodes, &sections, round);
        }
        assert_eq!(appended_total, 150);
    }

    #[test]
    fn a_rebuild_for_another_owned_count_starts_afresh() {
        // owned nodes are fixed per rank today; lists rebuilt for another owned count must
        // still carry nothing over and be the lists a new one builds, for fewer owned nodes
        // and for more
        let (mut nodes, sections) = random_cloud(400, 7);
        let mut list = NeighbourList::new(5e-6);
        list.rebuild(&nodes, &sections);
        for k in 0..list.len() {
            list.max_overlap[k] = 1.0;
            list.touching[k] = true;
        }
        list.retired_gid.push(GlobalNodeId(3));
        list.retired_max_overlap.push(1.0);
        *list.retired_start.last_mut().unwrap() += 1;
        for owned in [300, 400] {
            nodes.n_owned = owned;
            list.rebuild(&nodes, &sections);
            let mut fresh = NeighbourList::new(5e-6);
            fresh.rebuild(&nodes, &sections);
            assert_eq!(
                (&list.start, &list.partner, &list.partner_gid),
                (&fresh.start, &fresh.partner, &fresh.partner_gid)
            );
            assert!(list.max_overlap.iter().all(|&m| m == 0.0) && !list.touching.iter().any(|&t| t), "{owned}");
            assert!(list.retired_gid.is_empty() && list.retired_start.iter().all(|&s| s == 0), "{owned}");
            for k in 0..list.len() {
                list.max_overlap[k] = 1.0;
            }
        }
    }

    #[test]
    fn histories_survive_a_rebuild_by_global_id() {
        let (mut nodes, sections) = random_cloud(400, 3);
        let mut list = NeighbourList::new(5e-6);
        list.rebuild(&nodes, &sections);
        for k in 0..list.len() {
            list.max_overlap[k] = list.partner_gid[k].0 as f64;
            list.touching[k] = true;
        }
        // move one node away so its pairs vanish, then rebuild
        nodes.position[0] += Vec3::new(1.0, 0.0, 0.0);
        list.rebuild(&nodes, &sections);
        assert_eq!(list.row(0).len(), 0);
        for k in 0..list.len() {
            assert_eq!(list.max_overlap[k], list.partner_gid[k].0 as f64, "history follows the partner");
            assert!(list.touching[k]);
        }
        // the dropped pairs are retired on both sides; when the node comes back they take
        // up their largest overlap again (not their friction: they stopped touching)
        let returning: Vec<GlobalNodeId> = list.retired_gid[list.retired_row(0)].to_vec();
        assert!(!returning.is_empty() && returning.windows(2).all(|g| g[0] < g[1]));
        assert!(list.retired_max_overlap[list.retired_row(0)].iter().zip(&returning).all(|(&m, g)| m == g.0 as f64));
        // another node leaves: the rows around it change, the others are copied a run of
        // rows at a time, their retired pairs with them; then it comes back
        let before = list.clone();
        let leaving = (1..nodes.n_owned).max_by_key(|&i| list.row(i).len()).unwrap();
        nodes.position[leaving] += Vec3::new(1.0, 0.0, 0.0);
        list.rebuild(&nodes, &sections);
        let mut changed = 0;
        for i in 0..nodes.n_owned {
            if list.partner_gid[list.row(i)] == before.partner_gid[before.row(i)] {
                assert_eq!(list.retired_gid[list.retired_row(i)], before.retired_gid[before.retired_row(i)]);
                assert_eq!(
                    list.retired_max_overlap[list.retired_row(i)],
                    before.retired_max_overlap[before.retired_row(i)]
                );
            } else {
                changed += 1;
                assert!(
                    list.retired_row(i).len() > before.retired_row(i).len(),
                    "row {i} retires its pair with the node that left"
                );
            }
        }
        assert!(changed > 1 && changed < 50, "{changed}");
        nodes.position[leaving] -= Vec3::new(1.0, 0.0, 0.0);
        list.rebuild(&nodes, &sections);
        assert_eq!(
            (&list.start, &list.partner_gid, &list.retired_start, &list.retired_gid),
            (&before.start, &before.partner_gid, &before.retired_start, &before.retired_gid)
        );
        assert_eq!((&list.max_overlap, &list.retired_max_overlap), (&before.max_overlap, &before.retired_max_overlap));
        nodes.position[0] -= Vec3::new(1.0, 0.0, 0.0);
        list.rebuild(&nodes, &sections);
        assert_eq!(list.partner_gid[list.row(0)], returning[..]);
        for k in list.row(0) {
            assert_eq!(list.max_overlap[k], list.partner_gid[k].0 as f64);
            assert!(!list.touching[k] && list.anchor[k] == Vec3::zeros());
        }
        assert!(list.retired_gid.is_empty(), "nothing is retired once every pair is back");
        for i in 1..nodes.n_owned {
            for k in list.row(i) {
                assert_eq!(list.max_overlap[k], list.partner_gid[k].0 as f64, "the partners kept theirs too");
            }
        }
        list.forget_history();
        assert!(list.max_overlap.iter().all(|&m| m == 0.0) && list.retired_row(0).is_empty());
    }
}
