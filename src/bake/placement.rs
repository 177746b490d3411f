//! Where a material's nodes go along `mu`, and the texel coordinate a shader computes from `mu`.
//!
//! Nodes are uniform in `u = sqrt(mu)` (`mu = u^2`), so that they crowd toward grazing views,
//! where Fresnel reflectance and everything built on it turn fastest, and thin out toward the
//! normal, where every quantity is flat in the view angle. But the model is not smooth everywhere:
//! where one of its clamps starts to hold (a lobe's roughness `alpha(g)` reaching 1, its
//! asymmetry's own bounds) a quantity has a kink, and linear interpolation across a kink errs in
//! proportion to the node spacing instead of its square: 1.2e-2 at 128 nodes for a varnished
//! copper, where the smooth parts are within 1e-4; and just past such a kink a quantity may turn
//! far faster than anywhere else. Where a lobe's asymmetry averages its channels' ratios and one
//! channel's energy crosses the threshold below which its ratio counts as 0, the lobe's roughness
//! and GD even jump, and linear interpolation across a jump errs by up to the jump whatever the
//! spacing. So a material's `u` axis is cut into segments ([`place_nodes`], on a grid of the
//! model): at its kinks, so that a node sits on each, shared by the two segments; around its jumps,
//! by a segment of one interval so short that its two nodes are the two sides of the jump; and
//! where its curvature changes, so that each segment's nodes, uniform in `u`, are as dense as its
//! own curvature needs.
//!
//! A shader finds the coordinate of `mu` as `x = u * slope_s + offset_s` for the segment `s`
//! holding `u` (one compare and select per kink): [`NodePlacement::texture_coordinate`] computes
//! it in f32 exactly as the shader does, from the same f32 constants ([`NodePlacement::segments`]).

use std::collections::BTreeMap;

use crate::error::{Error, Result};

/// One stretch of `u` between breaks, uniform in `u`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Segment {
    /// Where it starts and ends in `u = sqrt(mu)`.
    pub u_start: f64,
    pub u_end: f64,
    /// Its first node; its last, `first_node + intervals`, is the next segment's first.
    pub first_node: usize,
    /// Intervals between its nodes (at least 1).
    pub intervals: usize,
    /// Whether the model jumps inside it: then it is one interval no longer than [`JUMP_WIDTH`],
    /// its two nodes the two sides of the jump, and a read inside blends them.
    pub jump: bool,
}

/// The nodes of one material: segments that cover `u` in [0, 1] end to end.
#[derive(Debug, Clone, PartialEq)]
pub struct NodePlacement {
    segments: Vec<Segment>,
}

/// What a shader holds per segment, in f32: where it starts in `u`, and the affine map from `u`
/// to the texel coordinate, `x = u * slope + offset` (the manifest states it as it is here).
pub use tmlut_loader::formats::baked::BakedSegment as SegmentMap;

impl NodePlacement {
    /// `nodes` nodes uniform in `u`.
    pub fn uniform(nodes: usize) -> Self {
        Self::with_breaks(&[], nodes)
    }

    /// `nodes` nodes with one on each break of `breaks` (values of `u` strictly inside (0, 1),
    /// increasing), spaced as evenly as the breaks allow ([`share_out`] without curvature). `nodes`
    /// must exceed `breaks.len() + 1`.
    pub fn with_breaks(breaks: &[f64], nodes: usize) -> Self {
        let lengths: Vec<f64> = segment_ends(breaks).windows(2).map(|w| w[1] - w[0]).collect();
        Self::with_intervals(breaks, &[], &share_out(nodes - 1, &lengths, &vec![0.0; lengths.len()]))
    }

    /// Segments between `breaks` with `intervals` intervals each, those starting at a break of
    /// `jumps` marked as jumps.
    fn with_intervals(breaks: &[f64], jumps: &[f64], intervals: &[usize]) -> Self {
        let ends = segment_ends(breaks);
        let mut first_node = 0;
        let segments = ends
            .windows(2)
            .zip(intervals.iter().copied())
            .map(|(w, intervals)| {
                let jump = jumps.contains(&w[0]);
                let segment = Segment { u_start: w[0], u_end: w[1], first_node, intervals, jump };
                first_node += intervals;
                segment
            })
            .collect();
        NodePlacement { segments }
    }

    pub fn segments(&self) -> &[Segment] {
        &self.segments
    }

    /// Where the segments meet, in `u`: the kinks, the two sides of each jump, and where the
    /// curvature changes.
    pub fn breaks(&self) -> Vec<f64> {
        self.segments[1..].iter().map(|s| s.u_start).collect()
    }

    pub fn nodes(&self) -> usize {
        self.segments.iter().map(|s| s.intervals).sum::<usize>() + 1
    }

    /// `u` of node `k`.
    pub fn node_u(&self, k: usize) -> f64 {
        let s = self.segments.iter().rev().find(|s| s.first_node <= k).expect("node 0 is in the first segment");
        if k >= s.first_node + s.intervals {
            return s.u_end;
        }
        s.u_start + (s.u_end - s.u_start) * (k - s.first_node) as f64 / s.intervals as f64
    }

    /// The view cosine of node `k`: `node_u(k)^2`.
    pub fn node_mu(&self, k: usize) -> f64 {
        self.node_u(k).powi(2)
    }

    /// Each segment's map from `u` to the texel coordinate, in f32: node `k`'s texel centre is
    /// `(k + 0.5) / nodes`.
    pub fn segment_maps(&self) -> Vec<SegmentMap> {
        self.segments.iter().map(|s| self.segment_map(s)).collect()
    }

    fn segment_map(&self, s: &Segment) -> SegmentMap {
        let nodes = self.nodes() as f64;
        let per_u = s.intervals as f64 / (s.u_end - s.u_start);
        SegmentMap {
            u_start: s.u_start as f32,
            slope: (per_u / nodes) as f32,
            offset: ((s.first_node as f64 - s.u_start * per_u + 0.5) / nodes) as f32,
        }
    }

    /// The texel coordinate of view cosine `mu` (clamped to [0, 1]; NaN reads as grazing, as the
    /// model reads it), in f32 as a shader computes it from [`NodePlacement::segment_maps`]: the
    /// last segment whose f32 start `u` reaches.
    pub fn texture_coordinate(&self, mu: f32) -> f32 {
        tmlut_loader::formats::baked::texture_coordinate(&self.segment_maps(), mu)
    }
}

/// 0, then `breaks`, then 1.
fn segment_ends(breaks: &[f64]) -> Vec<f64> {
    std::iter::once(0.0).chain(breaks.iter().copied()).chain(std::iter::once(1.0)).collect()
}

/// `total` intervals shared out among segments of `lengths` and largest curvatures `curvatures`,
/// each at least 1, so that the largest interpolation error, `(length / intervals)^2 curvature
/// / 8` (the bound of linear interpolation), is as small as it can be: each interval in turn to the
/// segment of the largest, curvature counted at least a thousandth of the largest so that flat
/// segments are still spaced evenly (ties to the earlier segment: the share is a function of its
/// inputs alone).
fn share_out(total: usize, lengths: &[f64], curvatures: &[f64]) -> Vec<usize> {
    let floor = 1e-3 * curvatures.iter().fold(0.0f64, |m, &c| m.max(c)) + 1e-300;
    let need = |s: usize, intervals: usize| (lengths[s] / intervals as f64).powi(2) * curvatures[s].max(floor);
    let mut shares = vec![1; lengths.len()];
    for _ in lengths.len()..total {
        let neediest = (0..lengths.len())
            .max_by(|&a, &b| need(a, shares[a]).total_cmp(&need(b, shares[b])).then(b.cmp(&a)))
            .expect("at least one segment");
        shares[neediest] += 1;
    }
    shares
}

/// Most breaks between segments: each costs a shader a compare and two selects. A kink takes one,
/// a jump two.
pub const MAX_BREAKS: usize = 7;

/// The grid the model is read on to place nodes has two points per node interval: the nodes of
/// the uniform placement, always read (a material that needs no break reads no other point), and
/// the midpoints between them, read where the nodes show that the finer grid is needed
/// ([`Grid::needs_midpoints`]): around a kink or a jump, and where the curvature is large enough
/// that where it changes decides where nodes go.
pub const GRID_POINTS_PER_INTERVAL: usize = 2;

/// Midpoints are read in a node interval whose curvature (read on the nodes) would err by more
/// than this share of the tolerance at the uniform node spacing.
const MIDPOINT_SHARE: f64 = 0.5;

/// The most a kink's location is off once located ([`locate`]): 1/64 of a grid spacing.
const KINK_STEPS: usize = 7;

/// How closely a jump is located: the width of the segment whose two nodes are its two sides.
/// Far above f32's resolution in `u` (6e-8 at 1), so that the reads at those nodes fall on their
/// own sides, and far below any node spacing.
pub const JUMP_WIDTH: f64 = 1.0 / 65536.0;

/// What reads the model at many points of `u` at once: the values at each.
pub type ReadPoints<'a> = dyn Fn(&[f64]) -> Result<Vec<Vec<f64>>> + Sync + 'a;

/// The model's values read so far, by `u`: each point is read once, however often placement and
/// baking ask for it, and the points asked together are read together (`read` evaluates many at
/// once, computing what they share once).
pub struct Samples<'a> {
    read: &'a ReadPoints<'a>,
    known: BTreeMap<u64, Vec<f64>>,
}

impl<'a> Samples<'a> {
    /// No point read yet; `read(us)` returns the values at each of `us`.
    pub fn new(read: &'a ReadPoints<'a>) -> Self {
        Samples { read, known: BTreeMap::new() }
    }

    /// The values at each of `us` (in [0, 1]), those not yet read read together.
    pub fn at(&mut self, us: &[f64]) -> Result<Vec<Vec<f64>>> {
        let mut missing: Vec<f64> = us.iter().copied().filter(|u| !self.known.contains_key(&u.to_bits())).collect();
        missing.sort_by(f64::total_cmp);
        missing.dedup();
        if !missing.is_empty() {
            let values = (self.read)(&missing)?;
            self.known.extend(missing.iter().map(|u| u.to_bits()).zip(values));
        }
        Ok(us.iter().map(|u| self.known[&u.to_bits()].clone()).collect())
    }

    /// Points read so far.
    pub fn reads(&self) -> usize {
        self.known.len()
    }
}

/// The nodes of a material whose values at `u` (its flattened result at `mu = u^2`) `samples`
/// reads, weighed by `weights` (how much an error in each value counts at that point): `nodes`
/// nodes in at most [`MAX_BREAKS`]` + 1` segments, read on a grid of [`GRID_POINTS_PER_INTERVAL`]
/// points per node interval and, around what the grid shows of a kink or a jump, where
/// [`locate`] reads.
///
/// First the kinks and jumps, the largest first: a break on each kink where linear interpolation
/// across it at the uniform node spacing would err by more than `tolerance` (a quarter of the
/// jump in slope times the spacing), and two breaks around each jump larger than `tolerance`.
/// Then, while the segment of the largest estimated error (its largest curvature, [`share_out`])
/// errs by more than `tolerance`, it is cut where half of its `∫ sqrt(curvature)` lies on either
/// side (the density of nodes that evens out linear interpolation's error goes as the square root
/// of the curvature).
pub fn place_nodes(
    samples: &mut Samples,
    weights: &(dyn Fn(&[f64]) -> Vec<f64> + Sync),
    nodes: usize,
    tolerance: f64,
) -> Result<NodePlacement> {
    if nodes < MAX_BREAKS + 2 {
        return Err(Error::invalid(
            "bake nodes",
            format!("{nodes} is too few: a bake has at least {}", MAX_BREAKS + 2),
        ));
    }
    let spacing = 1.0 / (nodes - 1) as f64;
    let mut grid = Grid::new(GRID_POINTS_PER_INTERVAL * (nodes - 1) + 1);
    grid.read(samples, weights, &(0..grid.points()).step_by(GRID_POINTS_PER_INTERVAL).collect::<Vec<_>>())?;
    let candidates = grid.candidates(spacing, tolerance);
    grid.read(samples, weights, &grid.needs_midpoints(&candidates, tolerance))?;
    let mut breaks = Vec::new();
    let mut jumps = Vec::new();
    for feature in locate(samples, &grid, &candidates, spacing, tolerance)? {
        match feature {
            Feature::Kink(u) if breaks.len() < MAX_BREAKS => breaks.push(u),
            Feature::Jump(left, right) if breaks.len() + 1 < MAX_BREAKS => {
                breaks.extend([left, right]);
                jumps.push(left);
            }
            _ => {}
        }
    }
    breaks.sort_by(f64::total_cmp);
    loop {
        let ends = segment_ends(&breaks);
        let lengths: Vec<f64> = ends.windows(2).map(|w| w[1] - w[0]).collect();
        let curvatures: Vec<f64> = ends.windows(2).map(|w| grid.largest_curvature(w[0], w[1], &breaks)).collect();
        // A jump's segment has no point of the grid inside, so no curvature, and is far shorter
        // than any other: it keeps its one interval.
        let intervals = share_out(nodes - 1, &lengths, &curvatures);
        let errors: Vec<f64> =
            (0..lengths.len()).map(|s| (lengths[s] / intervals[s] as f64).powi(2) * curvatures[s] / 8.0).collect();
        let worst = (0..errors.len()).max_by(|&a, &b| errors[a].total_cmp(&errors[b]).then(b.cmp(&a))).unwrap_or(0);
        let cut = grid.curvature_median(ends[worst], ends[worst + 1], &breaks);
        match cut {
            Some(u) if errors[worst] > tolerance && breaks.len() < MAX_BREAKS => {
                breaks.push(u);
                breaks.sort_by(f64::total_cmp);
            }
            _ => return Ok(NodePlacement::with_intervals(&breaks, &jumps, &intervals)),
        }
    }
}

/// Where the line through `(u[0], v[0])` and `(u[1], v[1])` meets the line through
/// `(u[2], v[2])` and `(u[3], v[3])`, kept within `[u[1], u[2]]`; `None` where the lines are
/// parallel (no kink shows between them).
fn lines_meet(u: [f64; 4], v: [f64; 4]) -> Option<f64> {
    meeting(u, v).map(|meet| meet.clamp(u[1], u[2]))
}

/// Where the two lines of [`lines_meet`] meet, wherever that is.
fn meeting(u: [f64; 4], v: [f64; 4]) -> Option<f64> {
    let left_slope = (v[1] - v[0]) / (u[1] - u[0]);
    let right_slope = (v[3] - v[2]) / (u[3] - u[2]);
    // v[1] + left (x - u[1]) = v[2] + right (x - u[2])
    let meet = (v[2] - v[1] + left_slope * u[1] - right_slope * u[2]) / (left_slope - right_slope);
    meet.is_finite().then_some(meet)
}

/// What the model does at a place where it is not smooth, located on the model itself.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Feature {
    /// Its slope jumps at `u`.
    Kink(f64),
    /// It jumps between these two `u`, at most [`JUMP_WIDTH`] apart.
    Jump(f64, f64),
}

/// Value `c` of the model around a kink or jump: two points on either side, `(u, value)`, the
/// kink or jump between the inner two.
#[derive(Debug, Clone, Copy)]
struct Bracket {
    c: usize,
    /// How much an error in value `c` counts there.
    weight: f64,
    left: [(f64, f64); 2],
    right: [(f64, f64); 2],
}

impl Bracket {
    fn width(&self) -> f64 {
        self.right[0].0 - self.left[1].0
    }

    fn middle(&self) -> f64 {
        0.5 * (self.left[1].0 + self.right[0].0)
    }

    fn slope(side: [(f64, f64); 2]) -> f64 {
        (side[1].1 - side[0].1) / (side[1].0 - side[0].0)
    }

    /// The line through two points of one side, at `u`.
    fn line(side: [(f64, f64); 2], u: f64) -> f64 {
        side[1].1 + Self::slope(side) * (u - side[1].0)
    }

    /// Keep the point `(u, v)` between the sides on the side it belongs to: the side whose line it
    /// lies far nearer; where neither is far nearer (a kink with a stretch of large curvature
    /// beside it, where the farther side's line is off), the side that puts the kink where the
    /// lines through the new point meet: the kink lies between `u` and the right side where the
    /// line through the left side's nearer point and `u` meets the right side's line there, and
    /// between the left side and `u` where the left side's line meets the line through `u` and the
    /// right side's nearer point there.
    fn narrow(&mut self, u: f64, v: f64) {
        let (to_left, to_right) = ((v - Self::line(self.left, u)).abs(), (v - Self::line(self.right, u)).abs());
        let [(a, fa), (b, fb)] = self.left;
        let [(c, fc), (d, fd)] = self.right;
        let kink_right = meeting([b, u, c, d], [fb, v, fc, fd]).is_some_and(|k| k > u && k < c);
        let kink_left = meeting([a, b, u, c], [fa, fb, v, fc]).is_some_and(|k| k > b && k < u);
        let on_left = if to_left <= to_right / 4.0 || to_right <= to_left / 4.0 || kink_left == kink_right {
            to_left <= to_right
        } else {
            kink_right
        };
        if on_left {
            self.left = [self.left[1], (u, v)];
        } else {
            self.right = [(u, v), self.right[0]];
        }
    }

    /// The weighed gap between the two sides' lines at the middle: a jump's size; for a kink, its
    /// jump in slope times at most half the width.
    fn gap(&self) -> f64 {
        let u = self.middle();
        (Self::line(self.right, u) - Self::line(self.left, u)).abs() * self.weight
    }

    /// The weighed jump in slope.
    fn slope_jump(&self) -> f64 {
        (Self::slope(self.right) - Self::slope(self.left)).abs() * self.weight
    }

    fn kink(&self) -> f64 {
        let [a, b, c, d] = [self.left[0], self.left[1], self.right[0], self.right[1]];
        lines_meet([a.0, b.0, c.0, d.0], [a.1, b.1, c.1, d.1]).unwrap_or_else(|| self.middle())
    }
}

/// Each candidate of [`Grid::candidates`] located on the model, by bisection between the two
/// nodes of the uniform placement around it: the midpoint is read and kept on the side it belongs
/// to ([`Bracket::narrow`]), [`KINK_STEPS`] times for every candidate, and on to [`JUMP_WIDTH`] for
/// those whose sides still lie more than `tolerance` apart. Then each side's line is drawn afresh
/// through the side's nearer point and one read as far again beyond it, so that neither is off by
/// the curvature of a stretch the bisection left long ago. A jump is what is still more than
/// `tolerance` apart; a kink lies where the sides' lines meet, kept if its interpolation error at
/// the node spacing `spacing` would exceed `tolerance` (where the model is smooth, the fresh lines
/// have nearly the same slope). The candidates are bisected side by side, one read of each per
/// step, in their order.
fn locate(
    samples: &mut Samples,
    grid: &Grid,
    candidates: &[(usize, usize)],
    spacing: f64,
    tolerance: f64,
) -> Result<Vec<Feature>> {
    let step = GRID_POINTS_PER_INTERVAL;
    let point = |i: usize, c: usize| (grid.u(i), grid.value(i, c));
    let mut brackets: Vec<Bracket> = candidates
        .iter()
        .map(|&(i, c)| Bracket {
            c,
            weight: grid.weight(i - step, c).max(grid.weight(i + step, c)),
            left: [point(i - 2 * step, c), point(i - step, c)],
            right: [point(i + step, c), point(i + 2 * step, c)],
        })
        .collect();
    let kink_width = 2.0 * spacing / (1 << KINK_STEPS) as f64;
    let unsettled = |b: &Bracket| b.width() > kink_width * 1.5 || (b.width() > JUMP_WIDTH && b.gap() > tolerance);
    loop {
        let open: Vec<usize> = (0..brackets.len()).filter(|&k| unsettled(&brackets[k])).collect();
        if open.is_empty() {
            break;
        }
        let middles: Vec<f64> = open.iter().map(|&k| brackets[k].middle()).collect();
        for ((&k, u), values) in open.iter().zip(&middles).zip(samples.at(&middles)?) {
            let c = brackets[k].c;
            brackets[k].narrow(*u, values[c]);
        }
    }
    let beyond: Vec<f64> = brackets
        .iter()
        .flat_map(|b| [(b.left[1].0 - b.width()).max(0.0), (b.right[0].0 + b.width()).min(1.0)])
        .collect();
    let values = samples.at(&beyond)?;
    for (k, b) in brackets.iter_mut().enumerate() {
        b.left[0] = (beyond[2 * k], values[2 * k][b.c]);
        b.right[1] = (beyond[2 * k + 1], values[2 * k + 1][b.c]);
    }
    Ok(brackets
        .iter()
        .filter_map(|b| {
            if b.gap() > tolerance {
                Some(Feature::Jump(b.left[1].0, b.right[0].0))
            } else {
                (b.slope_jump() * spacing / 4.0 > tolerance).then(|| Feature::Kink(b.kink()))
            }
        })
        .collect())
}

/// The model's values on the grid `u = i h` of [`GRID_POINTS_PER_INTERVAL`] points per node
/// interval, with their weights, where read.
struct Grid {
    h: f64,
    values: Vec<Option<Vec<f64>>>,
    weights: Vec<Option<Vec<f64>>>,
}

impl Grid {
    /// `points` points from 0 to 1, none read.
    fn new(points: usize) -> Self {
        Grid { h: 1.0 / (points - 1) as f64, values: vec![None; points], weights: vec![None; points] }
    }

    fn points(&self) -> usize {
        self.values.len()
    }

    /// `u` of point `i`: `i / (points - 1)`, so that node `k` of the uniform placement,
    /// `k / (nodes - 1)`, is point `G k` to the bit (the same correctly rounded quotient).
    fn u(&self, i: usize) -> f64 {
        i as f64 / (self.points() - 1) as f64
    }

    /// Read the points `indices` not read yet.
    fn read(
        &mut self,
        samples: &mut Samples,
        weights: &(dyn Fn(&[f64]) -> Vec<f64> + Sync),
        indices: &[usize],
    ) -> Result<()> {
        let us: Vec<f64> = indices.iter().map(|&i| self.u(i)).collect();
        for (&i, values) in indices.iter().zip(samples.at(&us)?) {
            self.weights[i] = Some(weights(&values));
            self.values[i] = Some(values);
        }
        Ok(())
    }

    /// Value `c` at point `i`, which must have been read.
    fn value(&self, i: usize, c: usize) -> f64 {
        self.values[i].as_ref().expect("a point read")[c]
    }

    fn weight(&self, i: usize, c: usize) -> f64 {
        self.weights[i].as_ref().expect("a point read")[c]
    }

    fn read_at(&self, i: usize) -> bool {
        self.values.get(i).is_some_and(Option::is_some)
    }

    fn channels(&self) -> usize {
        self.values[0].as_ref().map_or(0, Vec::len)
    }

    /// The weighed `|f(i - s) - 2 f(i) + f(i + s)|` of value `c`: the second difference at point
    /// `i` with a step of `s` points.
    fn second(&self, i: usize, s: usize, c: usize) -> f64 {
        (self.value(i - s, c) - 2.0 * self.value(i, c) + self.value(i + s, c)).abs() * self.weight(i, c)
    }

    /// Points (on the nodes of the uniform placement) and values where a kink or jump shows whose
    /// interpolation error at the node spacing `spacing` may exceed `tolerance`, at most
    /// [`MAX_BREAKS`], the largest first, none within two node spacings of another or of an end.
    fn candidates(&self, spacing: f64, tolerance: f64) -> Vec<(usize, usize)> {
        // On the nodes, a kink between two nodes shows in the second difference at both (the jump
        // in slope times up to the spacing), a jump as the jump itself, a smooth stretch as
        // spacing^2 f'' at every node: the second difference two nodes away on either side, where
        // neither reaches, is the curvature's share, and only what exceeds it counts. Linear
        // interpolation across a kink errs by up to a quarter of the jump in slope times the node
        // spacing, and across a jump by up to the jump.
        let step = GRID_POINTS_PER_INTERVAL;
        let excess = |i: usize, c: usize| {
            (self.second(i, step, c) - self.second(i - 2 * step, step, c).max(self.second(i + 2 * step, step, c)))
                .max(0.0)
        };
        let mut candidates: Vec<(f64, usize, usize)> = (3 * step..self.points() - 3 * step)
            .step_by(step)
            .map(|i| {
                let (c, e) = (0..self.channels())
                    .map(|c| (c, excess(i, c)))
                    .fold((0, 0.0), |m, x| if x.1 > m.1 { x } else { m });
                // A kink's error is at least a quarter of its excess, a jump's up to all of it.
                (e, i, c)
            })
            .collect();
        candidates.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        let mut chosen: Vec<(usize, usize)> = Vec::new();
        for (error, i, c) in candidates {
            if chosen.len() == MAX_BREAKS || error <= tolerance {
                break;
            }
            let near = |v: f64| (v - self.u(i)).abs() < 2.0 * spacing;
            if near(0.0) || near(1.0) || chosen.iter().any(|&(j, _)| near(self.u(j))) {
                continue;
            }
            chosen.push((i, c));
        }
        chosen
    }

    /// The midpoints to read: those of the two node intervals on either side of each candidate,
    /// and of every node interval whose curvature on the nodes (at either end) would err by more
    /// than [`MIDPOINT_SHARE`] of `tolerance` at the uniform node spacing.
    fn needs_midpoints(&self, candidates: &[(usize, usize)], tolerance: f64) -> Vec<usize> {
        let step = GRID_POINTS_PER_INTERVAL;
        let last = self.points() - 1;
        // The weighed spacing^2 |f''| / 8 at node i, from the second difference over the nodes
        // (at the ends, that of the node next to it).
        let error = |i: usize| {
            let i = i.clamp(step, last - step);
            (0..self.channels()).map(|c| self.second(i, step, c)).fold(0.0f64, f64::max) / 8.0
        };
        (0..last)
            .step_by(step)
            .filter(|&i| {
                let near_candidate = candidates.iter().any(|&(j, _)| i + 2 * step > j && i < j + 2 * step);
                near_candidate || error(i).max(error(i + step)) > MIDPOINT_SHARE * tolerance
            })
            .flat_map(|i| (1..step).map(move |j| i + j))
            .collect()
    }

    /// The weighed curvature `|f''|` at each read point strictly inside `(a, b)`, from its second
    /// difference over its nearest read neighbours at equal distance (a midpoint's nodes; a node's
    /// midpoints where read, else its neighbouring nodes) where that reaches no break (a kink's own
    /// jump in slope is not curvature), with the point's `u` and its share of `u` (half the
    /// distance between the read points on either side).
    fn curvatures(&self, a: f64, b: f64, breaks: &[f64]) -> Vec<(f64, f64, f64)> {
        let last = self.points() - 1;
        let read: Vec<usize> = (0..=last).filter(|&i| self.read_at(i)).collect();
        read.windows(3)
            .filter_map(|w| {
                let i = w[1];
                let u = self.u(i);
                let s = if self.read_at(i - 1) && self.read_at(i + 1) { 1 } else { GRID_POINTS_PER_INTERVAL };
                let reach = s as f64 * self.h;
                let clear = u > a && u < b && i >= s && i + s <= last && breaks.iter().all(|k| (u - k).abs() >= reach);
                clear.then(|| {
                    let curvature =
                        (0..self.channels()).map(|c| self.second(i, s, c)).fold(0.0f64, f64::max) / reach.powi(2);
                    (u, 0.5 * (self.u(w[2]) - self.u(w[0])), curvature)
                })
            })
            .collect()
    }

    fn largest_curvature(&self, a: f64, b: f64, breaks: &[f64]) -> f64 {
        self.curvatures(a, b, breaks).iter().map(|&(_, _, c)| c).fold(0.0, f64::max)
    }

    /// The point of `(a, b)` with half of the segment's `∫ sqrt(curvature)` on either side, at
    /// least four grid points from either end; `None` where the segment is too short to cut.
    fn curvature_median(&self, a: f64, b: f64, breaks: &[f64]) -> Option<f64> {
        let margin = 4.0 * self.h;
        if b - a <= 2.0 * margin {
            return None;
        }
        let curvatures = self.curvatures(a, b, breaks);
        let total: f64 = curvatures.iter().map(|&(_, du, c)| c.sqrt() * du).sum();
        let mut sum = 0.0;
        let median = curvatures.iter().find(|&&(_, du, c)| {
            sum += c.sqrt() * du;
            sum >= total / 2.0
        })?;
        (total > 0.0).then_some(median.0.clamp(a + margin, b - margin))
    }
}
