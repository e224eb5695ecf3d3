//! Scatter plots as inline SVG, with real axes: ticks at round numbers (1, 2,
//! 5 × 10ᵏ), a grid, the zero line when zero is in range, each axis labelled
//! with its quantity and unit, and ranges set by the data (a quantity that
//! cannot be negative is not drawn below zero). What the HTML reports draw
//! with; nothing here knows a robot.

use std::fmt::Write as _;

/// One point: where, and its colour value (`None`: the series' colour).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Point {
    /// The abscissa.
    pub x: f64,
    /// The ordinate.
    pub y: f64,
    /// The value the colour scale maps, if any.
    pub value: Option<f64>,
}

/// One series of points, drawn in one colour (or on the colour scale).
#[derive(Clone, Debug)]
pub struct Series {
    /// Its name in the legend.
    pub name: String,
    /// Its colour (`#rrggbb`) when its points have no value.
    pub colour: &'static str,
    /// The radius of its dots, px.
    pub radius: f64,
    /// Its points.
    pub points: Vec<Point>,
}

/// A scatter plot.
#[derive(Clone, Debug)]
pub struct Scatter {
    /// The title above it.
    pub title: String,
    /// The abscissa's label, with its unit.
    pub x_label: String,
    /// The ordinate's label, with its unit.
    pub y_label: String,
    /// The colour scale's label, with its unit (when points carry values).
    pub value_label: String,
    /// The series, drawn in order.
    pub series: Vec<Series>,
    /// Whether one unit of x is one unit of y on the page (a map).
    pub equal_aspect: bool,
    /// Whether y cannot be negative (a length, an RMS): its axis starts at 0.
    pub y_from_zero: bool,
}

/// Round tick positions covering `[lo, hi]`: about `n` of them, at 1, 2 or
/// 5 × 10ᵏ, and the step.
pub fn ticks(lo: f64, hi: f64, n: usize) -> (Vec<f64>, f64) {
    let span = (hi - lo).abs().max(f64::MIN_POSITIVE);
    let raw = span / n.max(1) as f64;
    let magnitude = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * magnitude)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * magnitude);
    let first = (lo / step).ceil() as i64;
    let last = (hi / step).floor() as i64;
    ((first..=last).map(|k| k as f64 * step).collect(), step)
}

/// A tick's label: as many decimals as the step needs.
fn label(v: f64, step: f64) -> String {
    let decimals = (-step.log10().floor()).max(0.0) as usize;
    let s = format!("{v:.decimals$}");
    if s.trim_start_matches('-')
        .chars()
        .all(|c| c == '0' || c == '.')
    {
        "0".into()
    } else {
        s
    }
}

/// The range of `values` padded by 5 % (a unit range around a single value,
/// or values that differ by rounding alone: a torque of 10⁻¹⁷ N·m is none).
fn range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
        (lo.min(v), hi.max(v))
    });
    if !(lo.is_finite() && hi.is_finite()) {
        return (0.0, 1.0);
    }
    if hi - lo <= 1e-12 * lo.abs().max(hi.abs()).max(1.0) {
        let centre = if (0.5 * (lo + hi)).abs() <= 1e-12 {
            0.0
        } else {
            0.5 * (lo + hi)
        };
        return (centre - 0.5, centre + 0.5);
    }
    let pad = 0.05 * (hi - lo);
    (lo - pad, hi + pad)
}

/// A colour from blue (low) through green to red (high) for `t` in 0..1.
fn colour(t: f64) -> String {
    let t = t.clamp(0.0, 1.0);
    let (r, g, b) = if t < 0.5 {
        (0.0, 2.0 * t, 1.0 - 2.0 * t)
    } else {
        (2.0 * t - 1.0, 2.0 - 2.0 * t, 0.0)
    };
    format!(
        "#{:02x}{:02x}{:02x}",
        (r * 220.0) as u8,
        (g * 180.0) as u8,
        (b * 220.0) as u8
    )
}

impl Scatter {
    /// The plot as an SVG element, `w × h` px.
    pub fn svg(&self, w: f64, h: f64) -> String {
        let points = || self.series.iter().flat_map(|s| s.points.iter());
        // The legend in a line under the title; the colour scale, if any, on
        // the right.
        let scale = points().any(|p| p.value.is_some());
        let (left, right, top, bottom) = (70.0, if scale { 110.0 } else { 16.0 }, 48.0, 48.0);
        let (mut x0, mut x1) = range(points().map(|p| p.x));
        let (mut y0, mut y1) = range(points().map(|p| p.y));
        if self.y_from_zero {
            y0 = 0.0;
            y1 = y1.max(f64::MIN_POSITIVE);
        }
        let (pw, ph) = (w - left - right, h - top - bottom);
        if self.equal_aspect {
            // One scale for both: the larger span per pixel wins.
            let per = ((x1 - x0) / pw).max((y1 - y0) / ph);
            let (cx, cy) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
            (x0, x1) = (cx - 0.5 * per * pw, cx + 0.5 * per * pw);
            (y0, y1) = (cy - 0.5 * per * ph, cy + 0.5 * per * ph);
        }
        let sx = |x: f64| left + (x - x0) / (x1 - x0) * pw;
        let sy = |y: f64| top + ph - (y - y0) / (y1 - y0) * ph;
        let mut s = String::new();
        let _ = write!(
            s,
            r##"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}" role="img"><title>{t}</title><rect width="{w}" height="{h}" fill="#fff"/><text x="{cx}" y="20" text-anchor="middle" font-size="14">{t}</text>"##,
            t = self.title,
            cx = left + pw / 2.0,
        );
        let (xt, xs) = ticks(x0, x1, 6);
        let (yt, ys) = ticks(y0, y1, 6);
        for x in &xt {
            let _ = write!(
                s,
                r##"<line x1="{p:.1}" y1="{top}" x2="{p:.1}" y2="{b:.1}" stroke="{c}"/><text x="{p:.1}" y="{ty:.1}" font-size="11" text-anchor="middle">{l}</text>"##,
                p = sx(*x),
                b = top + ph,
                c = if *x == 0.0 { "#888" } else { "#e6e6e6" },
                ty = top + ph + 15.0,
                l = label(*x, xs),
            );
        }
        for y in &yt {
            let _ = write!(
                s,
                r##"<line x1="{left}" y1="{p:.1}" x2="{r:.1}" y2="{p:.1}" stroke="{c}"/><text x="{tx:.1}" y="{ty:.1}" font-size="11" text-anchor="end">{l}</text>"##,
                p = sy(*y),
                r = left + pw,
                c = if *y == 0.0 { "#888" } else { "#e6e6e6" },
                tx = left - 6.0,
                ty = sy(*y) + 4.0,
                l = label(*y, ys),
            );
        }
        let _ = write!(
            s,
            r##"<rect x="{left}" y="{top}" width="{pw:.1}" height="{ph:.1}" fill="none" stroke="#333"/><text x="{cx:.1}" y="{xl:.1}" font-size="12" text-anchor="middle">{xlab}</text><text transform="translate(16 {cy:.1}) rotate(-90)" font-size="12" text-anchor="middle">{ylab}</text>"##,
            cx = left + pw / 2.0,
            xl = h - 10.0,
            xlab = self.x_label,
            cy = top + ph / 2.0,
            ylab = self.y_label,
        );
        let (v0, v1) = range(points().filter_map(|p| p.value));
        let v0 = v0.max(0.0);
        for series in &self.series {
            for p in &series.points {
                let fill = p.value.map_or(series.colour.to_string(), |v| {
                    colour((v - v0) / (v1 - v0).max(f64::MIN_POSITIVE))
                });
                let _ = write!(
                    s,
                    r#"<circle cx="{:.1}" cy="{:.1}" r="{}" fill="{fill}" fill-opacity="0.8"/>"#,
                    sx(p.x),
                    sy(p.y),
                    series.radius
                );
            }
        }
        // The legend: each series in a line under the title.
        let mut lx = left;
        for series in &self.series {
            let _ = write!(
                s,
                r#"<circle cx="{lx}" cy="34" r="4" fill="{}"/><text x="{}" y="38" font-size="11">{}</text>"#,
                series.colour,
                lx + 8.0,
                series.name
            );
            lx += 16.0 + 6.5 * series.name.chars().count() as f64;
        }
        let lx = left + pw + 12.0;
        if scale {
            let (yb, height) = (top + 60.0, 100.0);
            for i in 0..20 {
                let t = 1.0 - i as f64 / 19.0;
                let _ = write!(
                    s,
                    r#"<rect x="{lx}" y="{:.1}" width="12" height="5.2" fill="{}"/>"#,
                    yb + height * i as f64 / 20.0,
                    colour(t)
                );
            }
            let _ = write!(
                s,
                r#"<text x="{}" y="{}" font-size="11">{v1:.4}</text><text x="{}" y="{}" font-size="11">{v0:.4}</text><text x="{lx}" y="{}" font-size="11">{}</text>"#,
                lx + 16.0,
                yb + 8.0,
                lx + 16.0,
                yb + height,
                yb + height + 16.0,
                self.value_label
            );
        }
        s.push_str("</svg>");
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Ticks fall on round numbers within the range, about as many as asked.
    #[test]
    fn ticks_are_round_numbers_within_the_range() {
        let (t, step) = ticks(-0.37, 1.42, 6);
        assert_eq!(step, 0.5);
        assert_eq!(t, vec![0.0, 0.5, 1.0]);
        let (t, step) = ticks(0.0012, 0.0093, 5);
        assert_eq!(step, 0.002);
        assert_eq!(t.len(), 4);
        assert_eq!(label(0.004, step), "0.004");
        assert_eq!(label(-0.0, 0.5), "0");
    }
}
