//! Small statistics shared by the stages' quality figures.

/// Arithmetic mean; NaN for no values.
pub fn mean(values: &[f64]) -> f64 {
    if values.is_empty() { f64::NAN } else { values.iter().sum::<f64>() / values.len() as f64 }
}

/// Root mean square; NaN for no values.
pub fn rms(values: impl IntoIterator<Item = f64>) -> f64 {
    let (mut s, mut n) = (0.0, 0usize);
    for e in values {
        s += e * e;
        n += 1;
    }
    if n == 0 { f64::NAN } else { (s / n as f64).sqrt() }
}

/// The median (upper median for an even count, as the pipeline has always reported); NaN for
/// no values. NaNs sort last.
pub fn median(mut values: Vec<f64>) -> f64 {
    if values.is_empty() {
        return f64::NAN;
    }
    values.sort_by(f64::total_cmp);
    values[values.len() / 2]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn figures_against_hand_computed_values() {
        assert_eq!(mean(&[1.0, 2.0, 6.0]), 3.0);
        assert!((rms([3.0, 4.0]) - 12.5f64.sqrt()).abs() < 1e-15);
        assert_eq!(median(vec![5.0, 1.0, 3.0]), 3.0);
        assert_eq!(median(vec![4.0, 1.0, 3.0, 2.0]), 3.0);
        assert!(mean(&[]).is_nan() && rms([]).is_nan() && median(vec![]).is_nan());
    }
}
