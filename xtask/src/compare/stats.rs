//! The statistics of compare's repeated runs: a time is the median of a (setting, seed)'s
//! repeats, an error the mean over seeds with its standard error across them, and the runs are
//! ordered round-robin over the settings so that a machine's drift falls on all of them alike.
//! The machine the times were taken on is named from /proc/cpuinfo.

/// The median of `values`: the middle value, or the mean of the two middle values of an even
/// count; NaN for none.
pub fn median(values: &[f64]) -> f64 {
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    let n = sorted.len();
    match n {
        0 => f64::NAN,
        _ if n % 2 == 1 => sorted[n / 2],
        _ => 0.5 * (sorted[n / 2 - 1] + sorted[n / 2]),
    }
}

/// The mean of `values` and its standard error s/√n, s² the unbiased sample variance
/// Σ(x − m)²/(n − 1): the spread across independent seeds. The error is 0 for fewer than two
/// values (nothing to measure a spread from) and the mean NaN for none.
pub fn mean_and_standard_error(values: &[f64]) -> (f64, f64) {
    let n = values.len() as f64;
    if values.is_empty() {
        return (f64::NAN, 0.0);
    }
    let mean = values.iter().sum::<f64>() / n;
    if values.len() < 2 {
        return (mean, 0.0);
    }
    let variance = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, (variance / n).sqrt())
}

/// The standard error of the mean difference of two settings' errors seed by seed (`a[i]` and
/// `b[i]` rendered with the same seed): the noise the two share (the reference's, and samples
/// drawn with one seed) cancels in each difference, so this is the error of their comparison.
pub fn paired_standard_error(a: &[f64], b: &[f64]) -> f64 {
    let d: Vec<f64> = a.iter().zip(b).map(|(a, b)| a - b).collect();
    mean_and_standard_error(&d).1
}

/// One render of the measurement: which repeat, which seed (its index) and which setting (its
/// index).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Slot {
    /// The repeat, from 0.
    pub repeat: usize,
    /// The seed's index.
    pub seed: usize,
    /// The setting's index.
    pub job: usize,
}

/// The order of the renders: repeat by repeat, and within one every seed with every setting in
/// turn (round-robin), so each setting's repeats are spread over the whole measurement and a
/// machine that slows down or speeds up (heat, a neighbour's load) shifts every setting's times
/// alike, instead of all of one setting's runs falling in one batch.
pub fn interleaved(jobs: usize, seeds: usize, repeats: usize) -> Vec<Slot> {
    let mut out = Vec::with_capacity(jobs * seeds * repeats);
    for repeat in 0..repeats {
        for seed in 0..seeds {
            for job in 0..jobs {
                out.push(Slot { repeat, seed, job });
            }
        }
    }
    out
}

/// The machine times were taken on, as the report names it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Machine {
    /// The CPU's model name ("unknown CPU" where /proc/cpuinfo does not say).
    pub model: String,
    /// Physical cores (distinct (physical id, core id) pairs; the logical count where the file
    /// has no such fields).
    pub cores: usize,
    /// Logical processors (hardware threads).
    pub logical: usize,
}

impl Machine {
    /// This machine, from /proc/cpuinfo, or from the standard library's count of processors
    /// where that file cannot be read.
    pub fn this() -> Machine {
        let text = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
        let mut m = Machine::from_cpuinfo(&text);
        if m.logical == 0 {
            let n = std::thread::available_parallelism().map_or(1, |n| n.get());
            m.logical = n;
            m.cores = n;
        }
        m
    }

    /// The machine /proc/cpuinfo's text describes: one block per logical processor, each with
    /// `model name`, `physical id` and `core id` lines (ARM kernels leave out the last two and
    /// may name no model).
    pub fn from_cpuinfo(text: &str) -> Machine {
        let field = |line: &str, name: &str| {
            line.split_once(':')
                .filter(|(k, _)| k.trim() == name)
                .map(|(_, v)| v.trim().to_string())
        };
        let mut model = None;
        let mut logical = 0;
        let mut cores = std::collections::BTreeSet::new();
        let mut physical = String::new();
        for line in text.lines() {
            if field(line, "processor").is_some() {
                logical += 1;
            } else if let Some(m) = field(line, "model name") {
                model.get_or_insert(m);
            } else if let Some(p) = field(line, "physical id") {
                physical = p;
            } else if let Some(c) = field(line, "core id") {
                cores.insert((physical.clone(), c));
            }
        }
        Machine {
            model: model.unwrap_or_else(|| "unknown CPU".into()),
            cores: if cores.is_empty() {
                logical
            } else {
                cores.len()
            },
            logical,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Medians of odd and even counts, in any order, and of none. Every value is a sum of at
    /// most two values exactly representable in binary, halved: exact, so compared with ==.
    #[test]
    fn the_median_is_the_middle_value_or_the_mean_of_the_two() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[5.0, 1.0, 100.0, 2.0]), 3.5);
        assert_eq!(median(&[7.25]), 7.25);
        // One slow outlier among five repeats moves the median not at all.
        assert_eq!(median(&[1.0, 1.5, 1.25, 9.0, 1.125]), 1.25);
        assert!(median(&[]).is_nan());
    }

    /// Known answers: 1, 2, 3, 4 have mean 2.5, sample variance (2.25 + 0.25 + 0.25 + 2.25)/3
    /// = 5/3, so SE = √(5/12); 2, 4 have mean 3, variance 2, SE = 1. A few additions and one
    /// square root of numbers near 1: within 4 ulps, so 1e-15 relative. One value or none has
    /// no spread (SE 0).
    #[test]
    fn mean_and_standard_error_across_seeds() {
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-15 * b.abs();
        let (m, se) = mean_and_standard_error(&[1.0, 2.0, 3.0, 4.0]);
        assert!(
            close(m, 2.5) && close(se, (5.0f64 / 12.0).sqrt()),
            "{m} {se}"
        );
        let (m, se) = mean_and_standard_error(&[4.0, 2.0]);
        assert!(close(m, 3.0) && close(se, 1.0), "{m} {se}");
        assert_eq!(mean_and_standard_error(&[0.5]), (0.5, 0.0));
        let (m, se) = mean_and_standard_error(&[]);
        assert!(m.is_nan() && se == 0.0);
    }

    /// The paired error sees only the differences' spread: two settings whose errors move
    /// together across seeds (a shared offset of 0, 10, 20) differ by 1, 2, 3, whose SE is
    /// √(1/3) (variance 1, n = 3), where the unpaired errors' SEs are near 6 each. Exact to a
    /// few ulps (1e-15 relative).
    #[test]
    fn the_paired_error_cancels_the_noise_two_settings_share() {
        let a = [1.0, 12.0, 23.0];
        let b = [0.0, 10.0, 20.0];
        let se = paired_standard_error(&a, &b);
        let want = (1.0f64 / 3.0).sqrt();
        assert!((se - want).abs() <= 1e-15 * want, "{se}");
        assert!(mean_and_standard_error(&a).1 > 5.0);
    }

    /// Every (repeat, seed, setting) appears exactly once; within a repeat and a seed the
    /// settings follow each other in turn, and a setting's repeats are a whole round apart
    /// (seeds × settings renders), so no two renders of one (setting, seed) are adjacent.
    #[test]
    fn the_order_is_round_robin_over_the_settings() {
        let (jobs, seeds, repeats) = (3, 2, 4);
        let order = interleaved(jobs, seeds, repeats);
        assert_eq!(order.len(), jobs * seeds * repeats);
        let mut seen = std::collections::BTreeSet::new();
        for s in &order {
            assert!(seen.insert((s.repeat, s.seed, s.job)), "{s:?} twice");
        }
        assert_eq!(
            &order[..4],
            &[
                Slot {
                    repeat: 0,
                    seed: 0,
                    job: 0
                },
                Slot {
                    repeat: 0,
                    seed: 0,
                    job: 1
                },
                Slot {
                    repeat: 0,
                    seed: 0,
                    job: 2
                },
                Slot {
                    repeat: 0,
                    seed: 1,
                    job: 0
                },
            ]
        );
        for (i, s) in order.iter().enumerate() {
            let next = order[i + 1..]
                .iter()
                .position(|t| t.seed == s.seed && t.job == s.job);
            if s.repeat + 1 < repeats {
                assert_eq!(next, Some(jobs * seeds - 1), "{s:?}");
            } else {
                assert_eq!(next, None, "{s:?}");
            }
        }
    }

    /// Two sockets of two cores with two threads each: 8 logical processors, 4 physical cores
    /// (core ids repeat across sockets, so cores are told apart by (physical id, core id));
    /// the first model name is the machine's. A file without core ids counts logical ones.
    #[test]
    fn the_machine_is_read_from_cpuinfo() {
        let mut text = String::new();
        for (i, (p, c)) in [(0, 0), (0, 1), (1, 0), (1, 1)]
            .iter()
            .flat_map(|pc| [pc, pc])
            .enumerate()
        {
            text.push_str(&format!(
                "processor\t: {i}\nmodel name\t: Intel(R) Xeon(R) CPU @ 2.60GHz\n\
                 physical id\t: {p}\ncore id\t\t: {c}\n\n"
            ));
        }
        let m = Machine::from_cpuinfo(&text);
        assert_eq!(m.model, "Intel(R) Xeon(R) CPU @ 2.60GHz");
        assert_eq!((m.cores, m.logical), (4, 8));
        let arm = Machine::from_cpuinfo("processor\t: 0\nBogoMIPS\t: 50\n\nprocessor\t: 1\n");
        assert_eq!(
            arm,
            Machine {
                model: "unknown CPU".into(),
                cores: 2,
                logical: 2
            }
        );
        assert!(Machine::this().logical >= 1);
    }
}
