//! Where a material's nodes go along `mu`, and the texel coordinate a shader computes from `mu`.
//!
//! Nodes are uniform in `u = sqrt(mu)` (`mu = u^2`), so that they crowd toward grazing views,
//! where Fresnel reflectance and everything built on it turn fastest, and thin out toward the
//! normal, where every quantity is flat in the view angle. But the model is not smooth everywhere:
//! where one of its clamps starts to hold (a lobe's roughness `alpha(g)` reaching 1, its
//! asymmetry's own bounds) a quantity has a kink, and linear interpolation across a kink errs in
//! proportion to the node spacing instead of its square: 1.2e-2 at 128 nodes for a varnished
//! copper, where the smooth parts are within 1e-4; and just past such a kink a quantity may turn
//! far faster than anywhere else. So a material's `u` axis is cut into segments ([`place_nodes`],
//! on a fine grid of the model): at its kinks, so that a node sits on each, shared by the two
//! segments, and where its curvature changes, so that each segment's nodes, uniform in `u`, are as
//! dense as its own curvature needs.
//!
//! A shader finds the coordinate of `mu` as `x = u * slope_s + offset_s` for the segment `s`
//! holding `u` (one compare and select per kink): [`NodePlacement::texture_coordinate`] computes
//! it in f32 exactly as the shader does, from the same f32 constants ([`NodePlacement::segments`]).

use rayon::prelude::*;

use crate::error::{Error, Result};

/// One stretch of `u` between kinks, uniform in `u`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Segment {
    /// Where it starts and ends in `u = sqrt(mu)`.
    pub u_start: f64,
    pub u_end: f64,
    /// Its first node; its last, `first_node + intervals`, is the next segment's first.
    pub first_node: usize,
    /// Intervals between its nodes (at least 1).
    pub intervals: usize,
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
        Self::with_intervals(breaks, &share_out(nodes - 1, &lengths, &vec![0.0; lengths.len()]))
    }

    /// Segments between `breaks` with `intervals` intervals each.
    fn with_intervals(breaks: &[f64], intervals: &[usize]) -> Self {
        let ends = segment_ends(breaks);
        let mut first_node = 0;
        let segments = ends
            .windows(2)
            .zip(intervals.iter().copied())
            .map(|(w, intervals)| {
                let segment = Segment { u_start: w[0], u_end: w[1], first_node, intervals };
                first_node += intervals;
                segment
            })
            .collect();
        NodePlacement { segments }
    }

    pub fn segments(&self) -> &[Segment] {
        &self.segments
    }

    /// Where the segments meet, in `u`: the kinks, and where the curvature changes.
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

/// Most breaks between segments: each costs a shader a compare and two selects.
pub const MAX_BREAKS: usize = 7;

/// Points of the fine grid the model is read on to place nodes, per interval between nodes.
pub const FINE_POINTS_PER_INTERVAL: usize = 4;

/// The nodes of a material whose values at `u` are `values(u)` (its flattened result at
/// `mu = u^2`), weighed by `weights` (how much an error in each value counts at that point):
/// `nodes` nodes in at most [`MAX_BREAKS`]` + 1` segments, read on a fine grid of
/// [`FINE_POINTS_PER_INTERVAL`] points per node interval.
///
/// First the kinks: a break on each where linear interpolation across it at the uniform node
/// spacing would err by more than `tolerance` (a quarter of the jump in slope times the spacing),
/// the largest first. Then, while the segment of the largest estimated error (its largest
/// curvature, [`share_out`]) errs by more than `tolerance`, it is cut where half of its
/// `∫ sqrt(curvature)` lies on either side (the density of nodes that evens out linear
/// interpolation's error goes as the square root of the curvature).
pub fn place_nodes(
    values: &(dyn Fn(f64) -> Result<Vec<f64>> + Sync),
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
    let points = FINE_POINTS_PER_INTERVAL * (nodes - 1) + 1;
    let h = 1.0 / (points - 1) as f64;
    let fine: Vec<Vec<f64>> = (0..points).into_par_iter().map(|i| values(i as f64 * h)).collect::<Result<_>>()?;
    let weight: Vec<Vec<f64>> = fine.iter().map(|v| weights(v)).collect();
    let grid = FineGrid { fine: &fine, weight: &weight, h };
    let mut breaks = Vec::new();
    for (u, c) in grid.kinks(1.0 / (nodes - 1) as f64, tolerance) {
        breaks.push(refine_kink(values, u, c, h)?);
    }
    breaks.sort_by(f64::total_cmp);
    loop {
        let ends = segment_ends(&breaks);
        let lengths: Vec<f64> = ends.windows(2).map(|w| w[1] - w[0]).collect();
        let curvatures: Vec<f64> = ends.windows(2).map(|w| grid.largest_curvature(w[0], w[1], &breaks)).collect();
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
            _ => return Ok(NodePlacement::with_intervals(&breaks, &intervals)),
        }
    }
}

/// Where the line through `(u[0], v[0])` and `(u[1], v[1])` meets the line through
/// `(u[2], v[2])` and `(u[3], v[3])`, kept within `[u[1], u[2]]`; `None` where the lines are
/// parallel (no kink shows between them).
fn lines_meet(u: [f64; 4], v: [f64; 4]) -> Option<f64> {
    let left_slope = (v[1] - v[0]) / (u[1] - u[0]);
    let right_slope = (v[3] - v[2]) / (u[3] - u[2]);
    // v[1] + left (x - u[1]) = v[2] + right (x - u[2])
    let meet = (v[2] - v[1] + left_slope * u[1] - right_slope * u[2]) / (left_slope - right_slope);
    meet.is_finite().then(|| meet.clamp(u[1], u[2]))
}

/// The kink of value `c` found near `u` on the fine grid of spacing `h`, located more closely: the
/// meeting of the lines through two points on either side, at a quarter of the spacing before,
/// three times over (to `h / 64`), each time about the last estimate.
fn refine_kink(values: &(dyn Fn(f64) -> Result<Vec<f64>> + Sync), u: f64, c: usize, h: f64) -> Result<f64> {
    let mut estimate = u;
    let mut step = h / 4.0;
    for _ in 0..3 {
        let at = [-2.0, -1.0, 1.0, 2.0].map(|k| (estimate + k * step).clamp(0.0, 1.0));
        let mut v = [0.0; 4];
        for (v, &u) in v.iter_mut().zip(&at) {
            *v = values(u)?[c];
        }
        match lines_meet(at, v) {
            Some(meet) => estimate = meet,
            None => break,
        }
        step /= 4.0;
    }
    Ok(estimate)
}

/// The model's values on the fine grid, with their weights.
struct FineGrid<'a> {
    fine: &'a [Vec<f64>],
    weight: &'a [Vec<f64>],
    h: f64,
}

impl FineGrid<'_> {
    /// `|f(i-1) - 2 f(i) + f(i+1)| / h` of value `c`, weighed.
    fn second(&self, i: usize, c: usize) -> f64 {
        let f = self.fine;
        (f[i - 1][c] - 2.0 * f[i][c] + f[i + 1][c]).abs() / self.h * self.weight[i][c]
    }

    /// The kinks whose interpolation error at node spacing `spacing` would exceed `tolerance`,
    /// at most [`MAX_BREAKS`], the largest first, none within two node spacings of another or of
    /// an end: where each lies to within a grid spacing, and the value that shows it most.
    fn kinks(&self, spacing: f64, tolerance: f64) -> Vec<(f64, usize)> {
        // A kink between grid points i and i + 1 shows in the second difference at both (the
        // jump in slope), a smooth stretch as h f'' at every point: the second difference two
        // points away on either side, where a kink does not reach, is the curvature's share, and
        // only what exceeds it counts.
        let jump = |i: usize, c: usize| (self.second(i, c) - self.second(i - 2, c).max(self.second(i + 2, c))).max(0.0);
        let (points, channels) = (self.fine.len(), self.fine[0].len());
        let mut candidates: Vec<(f64, usize, usize)> = (3..points - 3)
            .map(|i| {
                let (c, j) =
                    (0..channels).map(|c| (c, jump(i, c))).fold((0, 0.0), |m, x| if x.1 > m.1 { x } else { m });
                (j, i, c)
            })
            .collect();
        candidates.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        let mut kinks: Vec<(f64, usize)> = Vec::new();
        for (jump, i, c) in candidates {
            // Linear interpolation across a kink errs by up to a quarter of the jump in slope
            // times the node spacing.
            if kinks.len() == MAX_BREAKS || jump * spacing / 4.0 <= tolerance {
                break;
            }
            let u = self.kink_near(i, c);
            if u < 2.0 * spacing || u > 1.0 - 2.0 * spacing || kinks.iter().any(|k| (k.0 - u).abs() < 2.0 * spacing) {
                continue;
            }
            kinks.push((u, c));
        }
        kinks
    }

    /// Where the kink near grid point `i` of value `c` lies: the meeting of the line through the
    /// two points before it and the line through the two after, kept within the points around `i`.
    fn kink_near(&self, i: usize, c: usize) -> f64 {
        let (fine, h) = (self.fine, self.h);
        let i = i.clamp(2, fine.len() - 3);
        let points = [i - 2, i - 1, i + 1, i + 2];
        lines_meet(points.map(|j| j as f64 * h), points.map(|j| fine[j][c])).unwrap_or(i as f64 * h)
    }

    /// The weighed curvature `|f''|` at each grid point strictly inside `(a, b)` and two points
    /// clear of every break (a kink's own jump is not curvature), with the point's `u`.
    fn curvatures(&self, a: f64, b: f64, breaks: &[f64]) -> Vec<(f64, f64)> {
        let (points, channels, h) = (self.fine.len(), self.fine[0].len(), self.h);
        (1..points - 1)
            .map(|i| (i as f64 * h, i))
            .filter(|&(u, _)| u > a && u < b && breaks.iter().chain([&0.0, &1.0]).all(|k| (u - k).abs() > 2.0 * h))
            .map(|(u, i)| (u, (0..channels).map(|c| self.second(i, c) / h).fold(0.0f64, f64::max)))
            .collect()
    }

    fn largest_curvature(&self, a: f64, b: f64, breaks: &[f64]) -> f64 {
        self.curvatures(a, b, breaks).iter().map(|&(_, c)| c).fold(0.0, f64::max)
    }

    /// The point of `(a, b)` with half of the segment's `∫ sqrt(curvature)` on either side, at
    /// least four grid points from either end; `None` where the segment is too short to cut.
    fn curvature_median(&self, a: f64, b: f64, breaks: &[f64]) -> Option<f64> {
        let margin = 4.0 * self.h;
        if b - a <= 2.0 * margin {
            return None;
        }
        let curvatures = self.curvatures(a, b, breaks);
        let total: f64 = curvatures.iter().map(|&(_, c)| c.sqrt()).sum();
        let mut sum = 0.0;
        let median = curvatures.iter().find(|&&(_, c)| {
            sum += c.sqrt();
            sum >= total / 2.0
        })?;
        (total > 0.0).then_some(median.0.clamp(a + margin, b - margin))
    }
}
