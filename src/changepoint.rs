//! Change points in a performance series: E-Divisive (Matteson & James,
//! "A Nonparametric Approach for Multiple Change Point Analysis of
//! Multivariate Data", JASA 109(505), 2014), the method MongoDB's signal
//! processing and Apache Otava (ex-Hunter) run over their performance
//! histories.
//!
//! A split τ of x₀…x₍ₙ₋₁₎ into A = x[..τ] and B = x[τ..] is scored by the
//! energy distance between the two samples (α = 1):
//!
//!   Q(τ) = m·k/(m + k) · ( 2/(m·k) Σ|a − b| − 1/C(m,2) Σ|a − a'| − 1/C(k,2) Σ|b − b'| )
//!
//! with m = |A|, k = |B|. The best split is kept when a permutation test says
//! its score is unlikely under "no change" (the series shuffled, a fixed seed
//! so a history always gives the same answer), and each side is searched
//! again (bisection), until no significant split is left. Unlike a median ±
//! MAD window, it finds the run where a level shifted even when every value
//! stays inside the window's noise band, and it does not flag one outlier.

/// What the search needs.
#[derive(Clone, Copy, Debug)]
pub struct Options {
    /// Fewest points on either side of a change (at least 2).
    pub min_segment: usize,
    /// Significance level of the permutation test.
    pub alpha: f64,
    /// Shuffles per test (p-value resolution 1/(permutations + 1)).
    pub permutations: u32,
    /// Seed of the shuffles: the same series always gives the same answer.
    pub seed: u64,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            min_segment: 3,
            alpha: 0.01,
            permutations: 199,
            seed: 0x7a6e_6761_7465,
        }
    }
}

/// One change point: the index of the first value of the new level.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ChangePoint {
    pub index: usize,
    /// The split's energy score Q(τ).
    pub score: f64,
    /// The permutation test's p-value.
    pub p_value: f64,
    /// Mean after / mean before, within the segment the split was found in.
    pub ratio: f64,
}

/// The change points of `series` (NaN and infinite values are ignored, as
/// if absent), in index order.
pub fn e_divisive(series: &[f64], opts: &Options) -> Vec<ChangePoint> {
    let finite: Vec<(usize, f64)> = series
        .iter()
        .copied()
        .enumerate()
        .filter(|(_, v)| v.is_finite())
        .collect();
    let values: Vec<f64> = finite.iter().map(|&(_, v)| v).collect();
    let min_segment = opts.min_segment.max(2);
    let mut rng = SplitMix64(opts.seed);
    let mut found = Vec::new();
    let mut pending = vec![(0usize, values.len())];
    while let Some((lo, hi)) = pending.pop() {
        let segment = &values[lo..hi];
        let Some((tau, score)) = best_split(segment, min_segment) else {
            continue;
        };
        // The permutation test: how often a shuffle of this segment scores
        // at least as high at its own best split.
        // It stops as soon as enough shuffles have scored that high for the
        // p-value to exceed alpha whatever the rest do (the decision is the
        // one all the shuffles would give): a segment of noise, which is
        // most series and every segment left beside a shift, then costs a
        // handful of shuffles instead of all of them.
        let p_of = |at_least: u32| (at_least + 1) as f64 / (opts.permutations + 1) as f64;
        let mut shuffled = segment.to_vec();
        let mut at_least = 0u32;
        for _ in 0..opts.permutations {
            rng.shuffle(&mut shuffled);
            if best_split(&shuffled, min_segment).is_some_and(|(_, s)| s >= score) {
                at_least += 1;
                if p_of(at_least) > opts.alpha {
                    break;
                }
            }
        }
        let p_value = p_of(at_least);
        if p_value > opts.alpha {
            continue;
        }
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
        found.push(ChangePoint {
            index: finite[lo + tau].0,
            score,
            p_value,
            ratio: mean(&segment[tau..]) / mean(&segment[..tau]),
        });
        pending.push((lo, lo + tau));
        pending.push((lo + tau, hi));
    }
    found.sort_by_key(|c| c.index);
    found
}

/// The split of `x` with the highest Q(τ), each side at least `min_segment`
/// long; None when `x` is too short. O(n²) from prefix sums of |xᵢ − xⱼ|.
fn best_split(x: &[f64], min_segment: usize) -> Option<(usize, f64)> {
    let n = x.len();
    if n < 2 * min_segment {
        return None;
    }
    // within[t] = Σ_{i<j<t} |xᵢ − xⱼ|; to_left[j][t] is not stored: the cross
    // sum is total − within(A) − within(B), so three prefix tables suffice.
    let mut within_prefix = vec![0.0f64; n + 1];
    for t in 1..=n {
        let add: f64 = (0..t - 1).map(|i| (x[i] - x[t - 1]).abs()).sum();
        within_prefix[t] = within_prefix[t - 1] + add;
    }
    let mut within_suffix = vec![0.0f64; n + 1];
    for t in (0..n).rev() {
        let add: f64 = (t + 1..n).map(|j| (x[t] - x[j]).abs()).sum();
        within_suffix[t] = within_suffix[t + 1] + add;
    }
    let total = within_prefix[n];
    let mut best: Option<(usize, f64)> = None;
    for tau in min_segment..=n - min_segment {
        let (m, k) = (tau as f64, (n - tau) as f64);
        let (aa, bb) = (within_prefix[tau], within_suffix[tau]);
        let ab = total - aa - bb;
        let e = 2.0 * ab / (m * k) - aa / (m * (m - 1.0) / 2.0) - bb / (k * (k - 1.0) / 2.0);
        let q = m * k / (m + k) * e;
        if best.is_none_or(|(_, s)| q > s) {
            best = Some((tau, q));
        }
    }
    best
}

/// SplitMix64 (Steele, Lea & Flood 2014): the permutation test's shuffles,
/// seeded, so a history's change points never change between calls.
struct SplitMix64(u64);

impl SplitMix64 {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Fisher–Yates.
    fn shuffle(&mut self, v: &mut [f64]) {
        for i in (1..v.len()).rev() {
            let j = (self.next() % (i as u64 + 1)) as usize;
            v.swap(i, j);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Deterministic noise in [−1, 1).
    fn noise(n: usize, seed: u64) -> Vec<f64> {
        let mut r = SplitMix64(seed);
        (0..n)
            .map(|_| (r.next() >> 11) as f64 / (1u64 << 52) as f64 - 1.0)
            .collect()
    }

    #[test]
    fn a_level_shift_is_found_at_its_run() {
        // 40 runs at 10 ms ± 0.3, then 40 at 10.6 ms ± 0.3: no value is
        // more than 10 % over the earlier median, the regression window's
        // floor (`[performance] min_relative`), so it flags none of them.
        let e = noise(80, 1);
        let series: Vec<f64> = (0..80)
            .map(|i| if i < 40 { 10.0 } else { 10.6 } + 0.3 * e[i])
            .collect();
        let found = e_divisive(&series, &Options::default());
        assert_eq!(found.len(), 1, "{found:?}");
        assert!((38..=42).contains(&found[0].index), "{found:?}");
        assert!(found[0].ratio > 1.04 && found[0].ratio < 1.08, "{found:?}");
        assert!(found[0].p_value <= 0.01);
    }

    #[test]
    fn two_shifts_are_both_found() {
        let e = noise(90, 2);
        let level = |i: usize| match i {
            0..30 => 5.0,
            30..60 => 8.0,
            _ => 6.0,
        };
        let series: Vec<f64> = (0..90).map(|i| level(i) + 0.5 * e[i]).collect();
        let idx: Vec<usize> = e_divisive(&series, &Options::default())
            .iter()
            .map(|c| c.index)
            .collect();
        assert_eq!(idx.len(), 2, "{idx:?}");
        assert!(
            (28..=32).contains(&idx[0]) && (58..=62).contains(&idx[1]),
            "{idx:?}"
        );
    }

    #[test]
    fn noise_alone_and_one_outlier_find_nothing() {
        for seed in 3..13 {
            let series: Vec<f64> = noise(60, seed).iter().map(|e| 10.0 + e).collect();
            assert!(
                e_divisive(&series, &Options::default()).is_empty(),
                "seed {seed}"
            );
        }
        let mut spike: Vec<f64> = noise(60, 20).iter().map(|e| 10.0 + 0.2 * e).collect();
        spike[30] = 25.0;
        assert!(e_divisive(&spike, &Options::default()).is_empty());
    }

    #[test]
    fn short_and_non_finite_series_are_handled() {
        assert!(e_divisive(&[], &Options::default()).is_empty());
        assert!(e_divisive(&[1.0, 2.0, 3.0], &Options::default()).is_empty());
        let mut s: Vec<f64> = (0..40).map(|i| if i < 20 { 1.0 } else { 3.0 }).collect();
        s.insert(10, f64::NAN);
        s.insert(0, f64::INFINITY);
        let found = e_divisive(&s, &Options::default());
        assert_eq!(found.len(), 1, "{found:?}");
        // Indices are the series' own: two non-finite values come before.
        assert_eq!(found[0].index, 22);
    }

    #[test]
    fn the_same_series_gives_the_same_answer() {
        let e = noise(50, 9);
        let s: Vec<f64> = (0..50)
            .map(|i| if i < 25 { 1.0 } else { 1.3 } + 0.2 * e[i])
            .collect();
        assert_eq!(
            e_divisive(&s, &Options::default()),
            e_divisive(&s, &Options::default())
        );
    }
}
