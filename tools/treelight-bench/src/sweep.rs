//! Parameter sweeps. A setting's SAH cost is one draw from a rough landscape: on Sibenik, moving k_u
//! by 0.01 moves IncrU's cost, and everything built on it, by up to ±0.15. So the bench can build a
//! method once per value of a range and summarise the draws, instead of reading one of them.

/// Most values a sweep may take: a typo in the step should not start a day-long run.
pub const MAX_VALUES: usize = 1000;

/// The values `from, from + step, …` up to `to` (inclusive, within a thousandth of a step) of a
/// sweep written `FROM:TO:STEP`.
pub fn parse_range(spec: &str) -> Result<Vec<f32>, String> {
    let bad =
        |why: &str| format!("sweep '{spec}': {why} (expected FROM:TO:STEP, e.g. 0.06:0.14:0.005)");
    let parts: Vec<&str> = spec.split(':').collect();
    let [from, to, step] = parts[..] else {
        return Err(bad("not three numbers"));
    };
    let num = |s: &str| {
        s.trim()
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| bad(&format!("'{s}' is not a finite number")))
    };
    let (from, to, step) = (num(from)?, num(to)?, num(step)?);
    if step <= 0.0 {
        return Err(bad("the step must be positive"));
    }
    if to < from {
        return Err(bad("TO is below FROM"));
    }
    // Counted once and each value computed from the start, so rounding does not pile up.
    let steps = ((to - from) / step + 1e-3).floor();
    if steps + 1.0 > MAX_VALUES as f64 {
        return Err(bad(&format!("more than {MAX_VALUES} values")));
    }
    Ok((0..=steps as usize)
        .map(|i| (from + i as f64 * step) as f32)
        .collect())
}

/// What a set of draws says: their count, mean, the standard error of the mean (none for a
/// single draw), and their range.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Summary {
    /// Number of draws.
    pub n: usize,
    /// Their mean.
    pub mean: f64,
    /// Standard error of the mean, from the sample standard deviation; `None` for one draw.
    pub std_err: Option<f64>,
    /// Smallest draw.
    pub min: f64,
    /// Largest draw.
    pub max: f64,
}

/// Summarises `xs`; `None` when there are none.
pub fn summarize(xs: &[f64]) -> Option<Summary> {
    let n = xs.len();
    if n == 0 {
        return None;
    }
    let mean = xs.iter().sum::<f64>() / n as f64;
    let std_err = (n > 1).then(|| {
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
        (var / n as f64).sqrt()
    });
    Some(Summary {
        n,
        mean,
        std_err,
        min: xs.iter().copied().fold(f64::INFINITY, f64::min),
        max: xs.iter().copied().fold(f64::NEG_INFINITY, f64::max),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_include_both_ends_without_drift() {
        let v = parse_range("0.06:0.14:0.005").unwrap();
        assert_eq!(v.len(), 17);
        assert_eq!(v[0], 0.06);
        assert!((v[16] - 0.14).abs() < 1e-6, "{}", v[16]);
        assert!((v[8] - 0.10).abs() < 1e-6, "{}", v[8]);
        assert_eq!(parse_range("0.1:0.1:0.01").unwrap(), vec![0.1]);
        // A range that ends between steps stops at the last value below TO.
        assert_eq!(parse_range("0:1:0.4").unwrap(), vec![0.0, 0.4, 0.8]);
    }

    #[test]
    fn bad_ranges_say_what_is_wrong() {
        for (spec, why) in [
            ("0.1:0.2", "three numbers"),
            ("0.1:0.2:0.01:4", "three numbers"),
            ("a:0.2:0.01", "'a' is not a finite number"),
            ("0.1:NaN:0.01", "'NaN' is not a finite number"),
            ("0.1:inf:0.01", "'inf' is not a finite number"),
            ("0.1:0.2:0", "step must be positive"),
            ("0.1:0.2:-0.01", "step must be positive"),
            ("0.2:0.1:0.01", "TO is below FROM"),
            ("0:1:0.0001", "more than 1000 values"),
        ] {
            let e = parse_range(spec).unwrap_err();
            assert!(e.contains(why) && e.contains(spec), "{spec}: {e}");
        }
    }

    #[test]
    fn summaries_of_known_samples() {
        assert_eq!(summarize(&[]), None);
        let one = summarize(&[2.5]).unwrap();
        assert_eq!((one.n, one.mean, one.std_err), (1, 2.5, None));
        let s = summarize(&[1.0, 2.0, 3.0, 4.0]).unwrap();
        assert_eq!((s.n, s.mean, s.min, s.max), (4, 2.5, 1.0, 4.0));
        // Sample variance 5/3, so the standard error is sqrt(5/3/4).
        assert!((s.std_err.unwrap() - (5.0f64 / 12.0).sqrt()).abs() < 1e-12);
    }
}
