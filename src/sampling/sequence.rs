//! Sample points: Owen-scrambled Sobol points (Burley 2020, "Practical hash-based Owen
//! scrambling", JCGT 9(4), through the `sobol_burley` crate) split into independently scrambled
//! replicates.
//!
//! Every cell of a table uses the same point set. Each cell's estimate is still an unbiased
//! randomised quasi-Monte Carlo estimate, the replicates still give honest error bars, the error
//! varies smoothly across the table instead of as cell-to-cell noise, and the points (and their
//! trigonometry) are computed once rather than once per cell. The points depend on the seed alone,
//! never on which thread uses them.

use crate::error::{Error, Result};
use crate::sampling::DiskPoint;
use rayon::prelude::*;

/// `sobol_burley` yields at most 2^16 points per scramble; past that a release build returns
/// unspecified values. Larger counts use several independently seeded scrambles (replicates).
pub const MAX_POINTS_PER_REPLICATE: u32 = 1 << 16;

/// How a cell's samples are drawn: `replicates` independent scrambles of `points` each.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SamplePlan {
    pub replicates: u32,
    pub points: u32,
}

impl SamplePlan {
    /// A plan for `total` samples in at least `min_replicates` scrambles: the points per replicate
    /// are the largest power of two that fits, at most 2^16. `total` must be a power of two (Sobol
    /// points are balanced only in power-of-two prefixes).
    pub fn new(total: u64, min_replicates: u32) -> Result<Self> {
        if total < 2 || !total.is_power_of_two() {
            return Err(Error::invalid(
                "samples",
                format!(
                    "{total} samples; use a power of two from 2 to 2^32 (Sobol points balance in power-of-two prefixes)"
                ),
            ));
        }
        if total > 1 << 32 {
            return Err(Error::invalid("samples", format!("{total} samples; at most 2^32 per cell")));
        }
        let min_replicates = min_replicates.max(1).next_power_of_two() as u64;
        let points = (total / min_replicates).clamp(1, MAX_POINTS_PER_REPLICATE as u64);
        Ok(SamplePlan { replicates: (total / points) as u32, points: points as u32 })
    }

    pub fn total(&self) -> u64 {
        self.replicates as u64 * self.points as u64
    }
}

/// A 32-bit scramble seed for replicate `replicate` of stream `stream` in a run seeded with
/// `seed`: a SplitMix64 finaliser (Steele, Lea, Flood 2014) over the three, so that neighbouring
/// streams and replicates get unrelated scrambles.
pub fn scramble_seed(seed: u64, stream: u64, replicate: u32) -> u32 {
    let mut z = seed
        .wrapping_mul(0x9E37_79B9_7F4A_7C15)
        .wrapping_add(stream.wrapping_mul(0xBF58_476D_1CE4_E5B9))
        .wrapping_add((replicate as u64).wrapping_mul(0x94D0_49BB_1331_11EB))
        .wrapping_add(0x2545_F491_4F6C_DD1D);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z ^ (z >> 32)) as u32
}

/// Point `index` (below 2^16) of the two-dimensional Owen-scrambled Sobol sequence with scramble
/// `scramble`, in [0, 1)^2.
pub fn sobol_point_2d(index: u32, scramble: u32) -> [f64; 2] {
    debug_assert!(index < MAX_POINTS_PER_REPLICATE);
    [sobol_burley::sample(index, 0, scramble) as f64, sobol_burley::sample(index, 1, scramble) as f64]
}

/// The disk points of one replicate in structure-of-arrays form, f32.
#[derive(Debug, Clone, Default)]
pub struct DiskPointsF32 {
    pub x: Vec<f32>,
    pub y: Vec<f32>,
    pub half_chord: Vec<f32>,
}

/// The disk points of a sample plan, replicate after replicate, drawn for one seed.
#[derive(Debug, Clone)]
pub struct PointSet {
    plan: SamplePlan,
    seed: u64,
    points: Vec<DiskPoint>,
    /// The same points in f32 structure-of-arrays form, one entry per replicate, for the fast path.
    points_f32: Vec<DiskPointsF32>,
}

impl PointSet {
    pub fn new(plan: SamplePlan, seed: u64) -> Self {
        // Replicates in parallel (a reference set of 2^20 points is 16 of them); each point depends
        // on its index and scramble alone, and the collection keeps replicate order.
        let points = (0..plan.replicates)
            .into_par_iter()
            .flat_map_iter(|replicate| {
                let scramble = scramble_seed(seed, 0, replicate);
                (0..plan.points).map(move |index| DiskPoint::from_unit_square(sobol_point_2d(index, scramble)))
            })
            .collect::<Vec<DiskPoint>>();
        let points_f32 = points
            .par_chunks(plan.points as usize)
            .map(|replicate| DiskPointsF32 {
                x: replicate.iter().map(|p| p.x as f32).collect(),
                y: replicate.iter().map(|p| p.y as f32).collect(),
                half_chord: replicate.iter().map(|p| p.half_chord as f32).collect(),
            })
            .collect();
        PointSet { plan, seed, points, points_f32 }
    }

    /// The points of each replicate in turn, in f32 structure-of-arrays form.
    pub fn replicates_f32(&self) -> &[DiskPointsF32] {
        &self.points_f32
    }

    pub fn plan(&self) -> SamplePlan {
        self.plan
    }

    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// The points of each replicate in turn.
    pub fn replicates(&self) -> impl Iterator<Item = &[DiskPoint]> {
        self.points.chunks(self.plan.points as usize)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plans_split_large_counts_into_replicates() {
        assert_eq!(SamplePlan::new(1 << 22, 1).unwrap(), SamplePlan { replicates: 64, points: 1 << 16 });
        assert_eq!(SamplePlan::new(1024, 4).unwrap(), SamplePlan { replicates: 4, points: 256 });
        assert_eq!(SamplePlan::new(1024, 3).unwrap(), SamplePlan { replicates: 4, points: 256 });
        assert_eq!(SamplePlan::new(2, 8).unwrap(), SamplePlan { replicates: 2, points: 1 });
        let err = SamplePlan::new(1000, 1).unwrap_err().to_string();
        assert!(err.contains("samples") && err.contains("power of two"), "{err}");
    }

    #[test]
    fn scramble_seeds_differ_between_cells_and_replicates() {
        let mut seen = std::collections::HashSet::new();
        for cell in 0..64 {
            for replicate in 0..16 {
                assert!(seen.insert(scramble_seed(7, cell, replicate)));
            }
        }
        assert_ne!(scramble_seed(1, 0, 0), scramble_seed(2, 0, 0));
    }

    #[test]
    fn sobol_points_are_stratified() {
        // Any power-of-two prefix of a (scrambled) Sobol sequence puts exactly one point in each
        // of 16 x 16 elementary intervals of 256 points.
        let mut counts = [[0u32; 16]; 16];
        for i in 0..256 {
            let [x, y] = sobol_point_2d(i, 12345);
            counts[(x * 16.0) as usize][(y * 16.0) as usize] += 1;
        }
        assert!(counts.iter().flatten().all(|&c| c == 1), "{counts:?}");
    }
}
