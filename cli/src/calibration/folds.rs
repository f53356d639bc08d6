//! The k folds of a cross-validation: every pose in exactly one, repeats of one configuration
//! kept together, drawn once per search from the seed.

use kinecal::Measurement;
use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;

/// Assignment of every pose to one of `k` folds.
#[derive(Clone, Debug, PartialEq)]
pub struct Folds {
    pub k: usize,
    /// Fold of each pose.
    pub of: Vec<usize>,
}

impl Folds {
    /// Deterministic folds for `data` (groups of identical readings stay together).
    pub fn new<const N: usize>(data: &[Measurement<f64, N>], k: usize, seed: u64) -> Self {
        let groups = pose_groups(data);
        let n_groups = groups.iter().copied().max().map_or(0, |g| g + 1);
        let k = k.clamp(2, n_groups.max(2));
        let mut order: Vec<usize> = (0..n_groups).collect();
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed ^ 0x6b69_6e65_6361_6c00);
        order.shuffle(&mut rng);
        let mut fold_of_group = vec![0; n_groups];
        for (pos, g) in order.iter().enumerate() {
            fold_of_group[*g] = pos % k;
        }
        Self {
            k,
            of: groups.iter().map(|g| fold_of_group[*g]).collect(),
        }
    }

    /// Indices of the poses in fold `f` (held out) and of the others (training).
    pub fn split(&self, f: usize) -> (Vec<usize>, Vec<usize>) {
        let test = (0..self.of.len()).filter(|i| self.of[*i] == f).collect();
        let train = (0..self.of.len()).filter(|i| self.of[*i] != f).collect();
        (test, train)
    }
}

/// The poses at `idx`.
pub fn subset<const N: usize>(
    data: &[Measurement<f64, N>],
    idx: &[usize],
) -> Vec<Measurement<f64, N>> {
    idx.iter().map(|&i| data[i]).collect()
}

/// Group poses for cross-validation: poses with identical joint readings get the same id
/// (a repeated pose must not be predicted from its own twin).
pub fn pose_groups<const N: usize>(data: &[Measurement<f64, N>]) -> Vec<usize> {
    let mut ids: std::collections::HashMap<[u64; N], usize> = std::collections::HashMap::new();
    data.iter()
        .map(|m| {
            let next = ids.len();
            *ids.entry(m.q.map(f64::to_bits)).or_insert(next)
        })
        .collect()
}
