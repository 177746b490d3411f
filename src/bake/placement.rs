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
/// nodes in at most [`MAX_BREAKS`]` + 1` segments.
///
/// The model is read on the nodes of the uniform placement, where they show a kink or jump
/// ([`Grid::candidates`]) also on the midpoints around it and where their curvature is large
/// ([`Grid::needs_midpoints`]). First the kinks and jumps, the largest first ([`Grid::sharpen`],
/// [`locate`]): a break on each kink where linear interpolation across it at the uniform node
/// spacing would err by more than `tolerance` (a quarter of the jump in slope times the spacing),
/// and two breaks around each jump larger than `tolerance`. Then the curvature, from the grid's
/// second differences and right beside each kink and jump ([`beside_curvatures`]): while the
/// segment of the largest estimated error (its largest curvature, [`share_out`]) errs by more than
/// `tolerance`, it is cut where half of its `∫ sqrt(curvature)` lies on either side (the density
/// of nodes that evens out linear interpolation's error goes as the square root of the
/// curvature).
pub fn place_nodes(
    samples: &mut Samples,
    weights: &(dyn Fn(&[f64]) -> Vec<f64> + Sync),
    nodes: usize,
    tolerance: f64,
) -> Result<NodePlacement> {
    if nodes < MAX_BREAKS + 2 {
        return Err(Error::invalid(
            "bake.nodes",
            format!("{nodes} is too few: a bake has at least {}", MAX_BREAKS + 2),
        ));
    }
    let spacing = 1.0 / (nodes - 1) as f64;
    let mut grid = Grid::new(GRID_POINTS_PER_INTERVAL * (nodes - 1) + 1);
    grid.read(samples, weights, &(0..grid.points()).step_by(GRID_POINTS_PER_INTERVAL).collect::<Vec<_>>())?;
    let candidates = grid.candidates(spacing, tolerance);
    grid.read(samples, weights, &grid.needs_midpoints(&candidates, tolerance))?;
    let candidates = grid.sharpen(&candidates);
    let mut breaks = Vec::new();
    let mut jumps = Vec::new();
    let mut besides = Vec::new();
    for feature in locate(samples, &grid, &candidates, spacing, tolerance)? {
        match feature {
            Feature::Kink(u, beside) if breaks.len() < MAX_BREAKS => {
                breaks.push(u);
                besides.push(beside);
            }
            Feature::Jump(beside) if breaks.len() + 1 < MAX_BREAKS => {
                breaks.extend([beside.left[0], beside.right[0]]);
                jumps.push(beside.left[0]);
                besides.push(beside);
            }
            _ => {}
        }
    }
    breaks.sort_by(f64::total_cmp);
    let mut curvature = grid.curvatures(&breaks);
    curvature.extend(beside_curvatures(samples, weights, &besides, &breaks, grid.h / 2.0)?);
    curvature.sort_by(|a, b| a.0.total_cmp(&b.0));
    let curvature = Curvature { points: curvature };
    let margin = 2.0 * grid.h;
    loop {
        let ends = segment_ends(&breaks);
        let lengths: Vec<f64> = ends.windows(2).map(|w| w[1] - w[0]).collect();
        // A jump's segment has no curvature, and is far shorter than any other: it keeps its
        // one interval.
        let curvatures: Vec<f64> = ends.windows(2).map(|w| curvature.largest(w[0], w[1])).collect();
        let intervals = share_out(nodes - 1, &lengths, &curvatures);
        let errors: Vec<f64> =
            (0..lengths.len()).map(|s| (lengths[s] / intervals[s] as f64).powi(2) * curvatures[s] / 8.0).collect();
        let worst = (0..errors.len()).max_by(|&a, &b| errors[a].total_cmp(&errors[b]).then(b.cmp(&a))).unwrap_or(0);
        let cut = curvature.median(ends[worst], ends[worst + 1], margin);
        match cut {
            Some(u) if errors[worst] > tolerance && breaks.len() < MAX_BREAKS => {
                breaks.push(u);
                breaks.sort_by(f64::total_cmp);
            }
            _ => return Ok(NodePlacement::with_intervals(&breaks, &jumps, &intervals)),
        }
    }
}

/// The curvature right beside each kink and jump, where a clamp's release turns fastest and the
/// grid's second differences, which must not reach across it, say nothing: on each side, from the
/// value and slope read nearest it (`Beside`) and one read `reach` farther, `f'' = 2 (f(x) -
/// f(u) - f'(u) (x - u)) / (x - u)^2`, the mean over that stretch, standing for it. A stretch that
/// would reach another break is shortened to half the way.
fn beside_curvatures(
    samples: &mut Samples,
    weights: &(dyn Fn(&[f64]) -> Vec<f64> + Sync),
    besides: &[Beside],
    breaks: &[f64],
    reach: f64,
) -> Result<Vec<(f64, f64, f64)>> {
    let room = |u: f64, toward: f64| {
        let other = breaks.iter().filter(|&&b| (b - u) * toward > 0.0).map(|&b| (b - u).abs()).fold(f64::MAX, f64::min);
        reach.min(0.5 * other).min(if toward > 0.0 { 1.0 - u } else { u })
    };
    let sides: Vec<([f64; 2], f64)> = besides
        .iter()
        .flat_map(|b| [(b.left, -room(b.left[0], -1.0)), (b.right, room(b.right[0], 1.0))])
        .filter(|&(_, d)| d.abs() > 0.0)
        .collect();
    let us: Vec<f64> = sides.iter().flat_map(|&(side, d)| [side[0], side[1], side[0] + d]).collect();
    let values = samples.at(&us)?;
    Ok(sides
        .iter()
        .zip(values.chunks(3))
        .map(|(&(side, d), v)| {
            let (near, step, far) = (&v[0], &v[1], &v[2]);
            let weight = weights(near);
            let curvature = (0..near.len())
                .map(|c| {
                    let slope = (step[c] - near[c]) / (side[1] - side[0]);
                    (2.0 * (far[c] - near[c] - slope * d) / (d * d)).abs() * weight[c]
                })
                .fold(0.0f64, f64::max);
            (side[0] + d / 2.0, d.abs(), curvature)
        })
        .collect())
}

/// The model's curvature where it has been read: `(u, the share of u it stands for, the weighed
/// |f''| of its largest value)`, in increasing `u`.
struct Curvature {
    points: Vec<(f64, f64, f64)>,
}

impl Curvature {
    /// The points strictly inside `(a, b)`.
    fn within(&self, a: f64, b: f64) -> impl Iterator<Item = &(f64, f64, f64)> {
        self.points.iter().filter(move |p| p.0 > a && p.0 < b)
    }

    /// The largest curvature inside `(a, b)`.
    fn largest(&self, a: f64, b: f64) -> f64 {
        self.within(a, b).map(|p| p.2).fold(0.0, f64::max)
    }

    /// The point of `(a, b)` with half of its `∫ sqrt(curvature)` on either side, kept `margin`
    /// from either end; `None` where the stretch is too short to cut or flat.
    fn median(&self, a: f64, b: f64, margin: f64) -> Option<f64> {
        if b - a <= 2.0 * margin {
            return None;
        }
        let total: f64 = self.within(a, b).map(|&(_, du, c)| c.sqrt() * du).sum();
        let mut sum = 0.0;
        let median = self.within(a, b).find(|&&(_, du, c)| {
            sum += c.sqrt() * du;
            sum >= total / 2.0
        })?;
        (total > 0.0).then_some(median.0.clamp(a + margin, b - margin))
    }
}

/// What the model does at a place where it is not smooth, located on the model itself.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Feature {
    /// Its slope jumps at `u`.
    Kink(f64, Beside),
    /// It jumps between its two sides, at most [`JUMP_WIDTH`] apart.
    Jump(Beside),
}

/// The points read on either side of a kink or jump nearest it, each with the point a slope step
/// farther from it: `[nearest, farther]`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Beside {
    left: [f64; 2],
    right: [f64; 2],
}

/// One side of a kink or jump: its point nearest the other side and the slope there.
#[derive(Debug, Clone, Copy)]
struct Side {
    u: f64,
    value: f64,
    slope: f64,
}

impl Side {
    /// The side's tangent line at `u`.
    fn line(&self, u: f64) -> f64 {
        self.value + self.slope * (u - self.u)
    }
}

/// Value `c` of the model around a kink or jump, which lies between the two sides.
#[derive(Debug, Clone, Copy)]
struct Bracket {
    c: usize,
    /// How much an error in value `c` counts there.
    weight: f64,
    left: Side,
    right: Side,
}

impl Bracket {
    fn width(&self) -> f64 {
        self.right.u - self.left.u
    }

    fn middle(&self) -> f64 {
        0.5 * (self.left.u + self.right.u)
    }

    /// Keep the point `(u, value)`, where the model's slope is `slope`, on the side it belongs to.
    /// Beside a kink, the side whose slope is nearer its own: the two differ by the kink's jump
    /// in slope however near it `u` lies, while a point just past a kink lies nearly on the far
    /// side's tangent, and the near side's is off by the curvature beside the kink (a clamp's
    /// release turns fastest right past it). Where the sides' tangents lie farther apart at `u` than
    /// any kink between them could put them (a jump), the side whose tangent it lies nearer.
    fn narrow(&mut self, u: f64, value: f64, slope: f64) {
        let (on_left_line, on_right_line) = (self.left.line(u), self.right.line(u));
        let kink_gap = (self.right.slope - self.left.slope).abs() * self.width() / 2.0;
        let jump = (on_right_line - on_left_line).abs() > 2.0 * kink_gap;
        let on_left = if jump {
            (value - on_left_line).abs() <= (value - on_right_line).abs()
        } else {
            (slope - self.left.slope).abs() <= (slope - self.right.slope).abs()
        };
        // Beside a jump the slope is read across it where the jump lies within the step: the side
        // keeps its own.
        let kept = if on_left { self.left.slope } else { self.right.slope };
        let side = Side { u, value, slope: if jump { kept } else { slope } };
        if on_left {
            self.left = side;
        } else {
            self.right = side;
        }
    }

    /// The weighed gap between the two sides' tangents at the middle: a jump's size; for a kink,
    /// its jump in slope times at most half the width.
    fn gap(&self) -> f64 {
        let u = self.middle();
        (self.right.line(u) - self.left.line(u)).abs() * self.weight
    }

    /// The weighed jump in slope.
    fn slope_jump(&self) -> f64 {
        (self.right.slope - self.left.slope).abs() * self.weight
    }

    /// Where the sides' tangents meet, kept within the bracket.
    fn kink(&self) -> f64 {
        let meet = (self.right.value - self.left.value + self.left.slope * self.left.u
            - self.right.slope * self.right.u)
            / (self.left.slope - self.right.slope);
        if meet.is_finite() { meet.clamp(self.left.u, self.right.u) } else { self.middle() }
    }
}

/// The share of a bracket's width between the two points a slope is read from: small, so that
/// the two seldom lie on either side of the kink (a slope read across it mixes both sides'), and a
/// misread one puts the kink no farther off than this.
const SLOPE_STEP: f64 = 1.0 / 1024.0;

/// Each candidate of [`Grid::sharpen`] located on the model, by bisection between the two grid
/// points around it: the midpoint and a point [`SLOPE_STEP`] of the width beyond it are read, for
/// the value and slope there, and the midpoint kept on its side ([`Bracket::narrow`]),
/// [`KINK_STEPS`] times for every candidate, and on to [`JUMP_WIDTH`] for those whose sides'
/// tangents still lie more than `tolerance` apart. Then each side's slope is read afresh, looking
/// away from the other side. A jump is what is still more than `tolerance` apart; a kink lies where
/// the sides' tangents meet, kept if its interpolation error at the node spacing `spacing` would
/// exceed `tolerance` (where the model is smooth, the two sides' slopes are nearly the same). The
/// candidates are bisected side by side, their reads of each step read together, in their order.
fn locate(
    samples: &mut Samples,
    grid: &Grid,
    candidates: &[(usize, usize)],
    spacing: f64,
    tolerance: f64,
) -> Result<Vec<Feature>> {
    // On the grid, a side's slope is the one between its two nodes nearest the candidate.
    let side = |near: usize, far: usize, c: usize| Side {
        u: grid.u(near),
        value: grid.value(near, c),
        slope: (grid.value(near, c) - grid.value(far, c)) / (grid.u(near) - grid.u(far)),
    };
    let mut brackets: Vec<Bracket> = candidates
        .iter()
        .map(|&(i, c)| Bracket {
            c,
            weight: grid.weight(i - 1, c).max(grid.weight(i + 1, c)),
            left: side(i - 1, i - 2, c),
            right: side(i + 1, i + 2, c),
        })
        .collect();
    let kink_width = 2.0 * grid.h / (1 << KINK_STEPS) as f64;
    let unsettled = |b: &Bracket| b.width() > kink_width * 1.5 || (b.width() > JUMP_WIDTH && b.gap() > tolerance);
    loop {
        let open: Vec<usize> = (0..brackets.len()).filter(|&k| unsettled(&brackets[k])).collect();
        if open.is_empty() {
            break;
        }
        let us: Vec<f64> = open
            .iter()
            .flat_map(|&k| {
                let (u, w) = (brackets[k].middle(), brackets[k].width());
                [u, u + SLOPE_STEP * w]
            })
            .collect();
        let values = samples.at(&us)?;
        for (j, &k) in open.iter().enumerate() {
            let c = brackets[k].c;
            let (u, beyond) = (us[2 * j], us[2 * j + 1]);
            let (value, next) = (values[2 * j][c], values[2 * j + 1][c]);
            brackets[k].narrow(u, value, (next - value) / (beyond - u));
        }
    }
    // A side the bisection never moved holds the grid's slope over a node spacing, off by the
    // curvature there: each side's slope is read afresh, looking away from the other side.
    let besides: Vec<Beside> = brackets
        .iter()
        .map(|b| {
            let step = SLOPE_STEP * b.width();
            Beside { left: [b.left.u, (b.left.u - step).max(0.0)], right: [b.right.u, (b.right.u + step).min(1.0)] }
        })
        .collect();
    let us: Vec<f64> = besides.iter().flat_map(|b| [b.left[1], b.right[1]]).collect();
    let values = samples.at(&us)?;
    for ((b, beside), v) in brackets.iter_mut().zip(&besides).zip(values.chunks(2)) {
        b.left.slope = (b.left.value - v[0][b.c]) / (beside.left[0] - beside.left[1]);
        b.right.slope = (v[1][b.c] - b.right.value) / (beside.right[1] - beside.right[0]);
    }
    Ok(brackets
        .iter()
        .zip(besides)
        .filter_map(|(b, beside)| {
            if b.gap() > tolerance {
                Some(Feature::Jump(beside))
            } else {
                (b.slope_jump() * spacing / 4.0 > tolerance).then(|| Feature::Kink(b.kink(), beside))
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
    /// [`MAX_BREAKS`], the largest first: at each point the value where it shows most, none
    /// within two node spacings of another or of an end.
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

    /// Each candidate of [`Grid::candidates`] (on the nodes) moved to the grid point beside it, and
    /// the value, where a kink or jump shows most on the grid read around it (its midpoints): on
    /// the nodes, a value whose curvature changes fast may show more than another's kink in the
    /// next interval (a top albedo's beside a lobe's roughness leaving its clamp), but a kink's
    /// second difference shrinks as the spacing, curvature's as its square.
    fn sharpen(&self, candidates: &[(usize, usize)]) -> Vec<(usize, usize)> {
        let excess = |j: usize, c: usize| {
            (self.second(j, 1, c) - self.second(j - 2, 1, c).max(self.second(j + 2, 1, c))).max(0.0)
        };
        candidates
            .iter()
            .map(|&(i, c)| {
                let around = (i - 1..=i + 1).filter(|&j| (j - 3..=j + 3).all(|k| self.read_at(k)));
                around
                    .flat_map(|j| (0..self.channels()).map(move |d| (j, d)))
                    .map(|(j, d)| (excess(j, d), j, d))
                    .fold((0.0, i, c), |best, x| if x.0 > best.0 { x } else { best })
            })
            .map(|(_, j, d)| (j, d))
            .collect()
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
    /// The weighed curvature `|f''|` at each read point, from its second difference over its
    /// nearest read neighbours at equal distance (a midpoint's nodes; a node's midpoints where
    /// read, else its neighbouring nodes) where that reaches no break (a kink's own jump in slope is
    /// not curvature), with the point's `u` and its share of `u` (half the distance between the
    /// read points on either side).
    fn curvatures(&self, breaks: &[f64]) -> Vec<(f64, f64, f64)> {
        let last = self.points() - 1;
        let read: Vec<usize> = (0..=last).filter(|&i| self.read_at(i)).collect();
        read.windows(3)
            .filter_map(|w| {
                let i = w[1];
                let u = self.u(i);
                let s = if self.read_at(i - 1) && self.read_at(i + 1) { 1 } else { GRID_POINTS_PER_INTERVAL };
                let reach = s as f64 * self.h;
                let clear = i >= s && i + s <= last && breaks.iter().all(|k| (u - k).abs() >= reach);
                clear.then(|| {
                    let curvature =
                        (0..self.channels()).map(|c| self.second(i, s, c)).fold(0.0f64, f64::max) / reach.powi(2);
                    (u, 0.5 * (self.u(w[2]) - self.u(w[0])), curvature)
                })
            })
            .collect()
    }
}
