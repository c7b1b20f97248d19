//! Heat-map colours for per-vertex error maps.

/// Viridis (perceptually uniform, colour-blind friendly) at 0, 1/8, ..., 1.
const VIRIDIS: [[u8; 3]; 9] = [
    [68, 1, 84],
    [72, 36, 117],
    [59, 82, 139],
    [44, 114, 142],
    [33, 145, 140],
    [40, 174, 128],
    [94, 201, 98],
    [173, 220, 48],
    [253, 231, 37],
];

/// Colour for values that are NaN.
const NAN_COLOR: [u8; 3] = [128, 128, 128];

/// Maps each value (#V) to an RGB colour (#V x 3) on the viridis colormap, piecewise linear
/// over 9 control points: `vmin` (and below) is dark purple, `vmax` (and above) is yellow.
///
/// NaN values are grey. If `vmax <= vmin` (or either is not finite), every non-NaN value gets
/// the low colour.
pub fn heat_colors(values: &[f64], vmin: f64, vmax: f64) -> Vec<[u8; 3]> {
    let range = vmax - vmin;
    let valid = range.is_finite() && range > 0.0;
    values
        .iter()
        .map(|&v| {
            if v.is_nan() {
                return NAN_COLOR;
            }
            let t = if valid {
                ((v - vmin) / range).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let x = t * (VIRIDIS.len() - 1) as f64;
            let k = (x.floor() as usize).min(VIRIDIS.len() - 2);
            let s = x - k as f64;
            let (a, b) = (VIRIDIS[k], VIRIDIS[k + 1]);
            [0, 1, 2].map(|c| (a[c] as f64 + s * (b[c] as f64 - a[c] as f64)).round() as u8)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn endpoints_clamping_and_nan() {
        let c = heat_colors(&[0.0, 1.0, -5.0, 9.0, f64::NAN, 0.5, f64::INFINITY], 0.0, 1.0);
        assert_eq!(c[0], VIRIDIS[0]);
        assert_eq!(c[1], VIRIDIS[8]);
        assert_eq!(c[2], VIRIDIS[0]);
        assert_eq!(c[3], VIRIDIS[8]);
        assert_eq!(c[4], NAN_COLOR);
        assert_eq!(c[5], VIRIDIS[4]);
        assert_eq!(c[6], VIRIDIS[8]);
        assert_eq!(heat_colors(&[3.0], 1.0, 1.0), vec![VIRIDIS[0]]);
        // Halfway between two control points.
        let m = heat_colors(&[1.0 / 16.0], 0.0, 1.0)[0];
        assert_eq!(m, [70, 19, 101]);
    }

    #[test]
    fn lightness_increases() {
        let vals: Vec<f64> = (0..=100).map(|i| i as f64 / 100.0).collect();
        let luma: Vec<f64> = heat_colors(&vals, 0.0, 1.0)
            .iter()
            .map(|c| 0.2126 * c[0] as f64 + 0.7152 * c[1] as f64 + 0.0722 * c[2] as f64)
            .collect();
        assert!(luma.windows(2).all(|w| w[1] >= w[0] - 0.5), "{luma:?}");
    }
}
