//! Figures of the report as SVG strings (plotters' SVG backend, text measured with the bundled
//! DejaVu Sans so layout is identical on every machine, fontconfig or not).

use plotters::coord::Shift;
use plotters::prelude::*;
use std::sync::Once;

const FONT: &str = "sans-serif";

fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        let bytes: &'static [u8] = include_bytes!("../../assets/DejaVuSans.ttf");
        // The bundled font is valid; failing here would be a build defect, not a user error.
        let _ = plotters::style::register_font(FONT, FontStyle::Normal, bytes);
    });
}

type Area<'a> = DrawingArea<SVGBackend<'a>, Shift>;

fn svg(size: (u32, u32), draw: impl FnOnce(&Area<'_>) -> Result<(), String>) -> Result<String, String> {
    register_font();
    let mut buf = String::new();
    {
        let root = SVGBackend::with_string(&mut buf, size).into_drawing_area();
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        draw(&root)?;
        root.present().map_err(|e| e.to_string())?;
    }
    Ok(buf)
}

/// Viridis, sampled at nine points and interpolated linearly; `t` in [0, 1].
pub(crate) fn viridis(t: f64) -> RGBColor {
    const V: [(u8, u8, u8); 9] =
        [(68, 1, 84), (71, 44, 122), (59, 81, 139), (44, 113, 142), (33, 144, 141), (39, 173, 129), (92, 200, 99), (170, 220, 50), (253, 231, 37)];
    let t = if t.is_finite() { t.clamp(0.0, 1.0) } else { 1.0 };
    let x = t * 8.0;
    let i = (x.floor() as usize).min(7);
    let f = x - i as f64;
    let lerp = |a: u8, b: u8| (a as f64 + (b as f64 - a as f64) * f).round() as u8;
    RGBColor(lerp(V[i].0, V[i + 1].0), lerp(V[i].1, V[i + 1].1), lerp(V[i].2, V[i + 1].2))
}

/// A diverging blue-white-red map for signed values; `t` in [-1, 1].
pub(crate) fn diverging(t: f64) -> RGBColor {
    let t = if t.is_finite() { t.clamp(-1.0, 1.0) } else { 0.0 };
    let (r, g, b) = if t < 0.0 {
        let s = -t;
        (1.0 - 0.8 * s, 1.0 - 0.7 * s, 1.0 - 0.25 * s)
    } else {
        (1.0 - 0.25 * t, 1.0 - 0.8 * t, 1.0 - 0.8 * t)
    };
    RGBColor((r * 255.0) as u8, (g * 255.0) as u8, (b * 255.0) as u8)
}

fn colorbar(area: &Area<'_>, vmax: f64, label: &str) -> Result<(), String> {
    let mut chart = ChartBuilder::on(area)
        .margin_top(30)
        .margin_bottom(45)
        .x_label_area_size(0)
        .y_label_area_size(45)
        .build_cartesian_2d(0.0..1.0, 0.0..vmax)
        .map_err(|e| e.to_string())?;
    chart
        .configure_mesh()
        .disable_x_mesh()
        .disable_y_mesh()
        .disable_x_axis()
        .y_desc(label)
        .y_labels(6)
        .label_style((FONT, 12))
        .axis_desc_style((FONT, 13))
        .draw()
        .map_err(|e| e.to_string())?;
    let steps = 64;
    chart
        .draw_series((0..steps).map(|i| {
            let (a, b) = (i as f64 / steps as f64 * vmax, (i + 1) as f64 / steps as f64 * vmax);
            Rectangle::new([(0.0, a), (1.0, b)], viridis((i as f64 + 0.5) / steps as f64).filled())
        }))
        .map_err(|e| e.to_string())?;
    Ok(())
}

/// One axis of a [`heatmap`]: its title and the grid's values along it.
#[derive(Debug, Clone, Copy)]
pub(crate) struct GridAxis<'a> {
    /// The axis title.
    pub desc: &'a str,
    /// The grid's values along the axis, evenly spaced (each cell as wide as the first step).
    pub values: &'a [f64],
}

/// The colour scale of a [`heatmap`]: its colour bar runs from 0 to `vmax`, labelled `unit`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct ColorScale<'a> {
    /// The value of the top colour (the bar's top); 1 when not positive and finite.
    pub vmax: f64,
    /// The colour bar's label.
    pub unit: &'a str,
}

/// A heat map of `values` (row-major, one row of `x.values.len()` per value of `y`) over a
/// regular grid, with a colour bar as `scale` says.
pub(crate) fn heatmap(title: &str, x: GridAxis<'_>, y: GridAxis<'_>, values: &[f64], scale: ColorScale<'_>) -> Result<String, String> {
    let (GridAxis { desc: x_desc, values: xs }, GridAxis { desc: y_desc, values: ys }) = (x, y);
    let ColorScale { vmax, unit } = scale;
    let half = |v: &[f64]| if v.len() > 1 { (v[1] - v[0]) / 2.0 } else { 0.5 };
    let (hx, hy) = (half(xs), half(ys));
    let (x0, x1) = (xs[0] - hx, xs[xs.len() - 1] + hx);
    let (y0, y1) = (ys[0] - hy, ys[ys.len() - 1] + hy);
    let vmax = if vmax > 0.0 && vmax.is_finite() { vmax } else { 1.0 };
    svg((760, 300), |root| {
        let (main, bar) = root.split_horizontally(670);
        let mut chart = ChartBuilder::on(&main)
            .caption(title, (FONT, 16))
            .margin(8)
            .x_label_area_size(40)
            .y_label_area_size(55)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(|e| e.to_string())?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc(x_desc)
            .y_desc(y_desc)
            .x_label_formatter(&|v| format!("{v:.0}"))
            .y_label_formatter(&|v| format!("{v:.0}"))
            .label_style((FONT, 12))
            .axis_desc_style((FONT, 13))
            .draw()
            .map_err(|e| e.to_string())?;
        chart
            .draw_series(ys.iter().enumerate().flat_map(|(r, &y)| {
                xs.iter().enumerate().map(move |(c, &x)| {
                    let v = values[r * xs.len() + c];
                    Rectangle::new([(x - hx, y - hy), (x + hx, y + hy)], viridis(v / vmax).filled())
                })
            }))
            .map_err(|e| e.to_string())?;
        colorbar(&bar, vmax, unit)
    })
}

/// Line plots of several named series of (x, y) points, with markers.
pub(crate) fn lines(title: &str, x_desc: &str, y_desc: &str, series: &[(String, Vec<(f64, f64)>)], log_y: bool) -> Result<String, String> {
    let pts = series.iter().flat_map(|(_, s)| s.iter());
    let (mut xmin, mut xmax, mut ymin, mut ymax) = (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
    for &(x, y) in pts.filter(|(x, y)| x.is_finite() && y.is_finite() && (!log_y || *y > 0.0)) {
        xmin = xmin.min(x);
        xmax = xmax.max(x);
        ymin = ymin.min(y);
        ymax = ymax.max(y);
    }
    if !xmin.is_finite() {
        (xmin, xmax, ymin, ymax) = (0.0, 1.0, 0.1, 1.0);
    }
    let padx = ((xmax - xmin) * 0.05).max(1e-9);
    svg((640, 380), |root| {
        let mut b = ChartBuilder::on(root);
        b.caption(title, (FONT, 16)).margin(10).x_label_area_size(40).y_label_area_size(60);
        let colors =
            [RGBColor(31, 119, 180), RGBColor(214, 39, 40), RGBColor(44, 160, 44), RGBColor(148, 103, 189), RGBColor(255, 127, 14), RGBColor(23, 190, 207)];
        macro_rules! body {
            ($chart:expr) => {{
                let mut chart = $chart;
                chart
                    .configure_mesh()
                    .x_desc(x_desc)
                    .y_desc(y_desc)
                    .label_style((FONT, 12))
                    .axis_desc_style((FONT, 13))
                    .light_line_style(RGBColor(235, 235, 235))
                    .draw()
                    .map_err(|e| e.to_string())?;
                for (i, (name, s)) in series.iter().enumerate() {
                    let c = colors[i % colors.len()];
                    let s: Vec<(f64, f64)> = s.iter().copied().filter(|(x, y)| x.is_finite() && y.is_finite() && (!log_y || *y > 0.0)).collect();
                    chart
                        .draw_series(LineSeries::new(s.clone(), c.stroke_width(2)))
                        .map_err(|e| e.to_string())?
                        .label(name.clone())
                        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], c.stroke_width(2)));
                    chart.draw_series(s.iter().map(|&p| Circle::new(p, 3, c.filled()))).map_err(|e| e.to_string())?;
                }
                chart
                    .configure_series_labels()
                    .background_style(WHITE.mix(0.85))
                    .border_style(BLACK)
                    .label_font((FONT, 12))
                    .position(SeriesLabelPosition::UpperRight)
                    .draw()
                    .map_err(|e| e.to_string())?;
            }};
        }
        if log_y {
            let c = b.build_cartesian_2d(xmin - padx..xmax + padx, (ymin * 0.8..ymax * 1.25).log_scale()).map_err(|e| e.to_string())?;
            body!(c);
        } else {
            let pady = ((ymax - ymin) * 0.08).max(1e-9);
            let c = b.build_cartesian_2d(xmin - padx..xmax + padx, (ymin - pady).min(0.0)..ymax + pady).map_err(|e| e.to_string())?;
            body!(c);
        }
        Ok(())
    })
}

/// Empirical cumulative distributions of several named samples of errors.
pub(crate) fn cdf(title: &str, x_desc: &str, series: &[(String, Vec<f64>)], x_max: f64) -> Result<String, String> {
    let curves: Vec<(String, Vec<(f64, f64)>)> = series
        .iter()
        .map(|(n, e)| {
            let mut s = e.clone();
            s.sort_by(f64::total_cmp);
            let k = s.len() as f64;
            let mut pts = vec![(0.0, 0.0)];
            pts.extend(s.iter().enumerate().map(|(i, &v)| (v.min(x_max), (i + 1) as f64 / k)));
            (n.clone(), pts)
        })
        .collect();
    register_font();
    svg((640, 380), |root| {
        let mut chart = ChartBuilder::on(root)
            .caption(title, (FONT, 16))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(0.0..x_max, 0.0..1.02)
            .map_err(|e| e.to_string())?;
        chart
            .configure_mesh()
            .x_desc(x_desc)
            .y_desc("fraction of queries")
            .label_style((FONT, 12))
            .axis_desc_style((FONT, 13))
            .light_line_style(RGBColor(235, 235, 235))
            .draw()
            .map_err(|e| e.to_string())?;
        let colors = [RGBColor(31, 119, 180), RGBColor(214, 39, 40), RGBColor(44, 160, 44), RGBColor(148, 103, 189)];
        for (i, (name, pts)) in curves.iter().enumerate() {
            let c = colors[i % colors.len()];
            chart
                .draw_series(LineSeries::new(pts.clone(), c.stroke_width(2)))
                .map_err(|e| e.to_string())?
                .label(name.clone())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], c.stroke_width(2)));
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font((FONT, 12))
            .position(SeriesLabelPosition::LowerRight)
            .draw()
            .map_err(|e| e.to_string())?;
        Ok(())
    })
}

/// Coefficient images (paper Fig. 2) as one PNG: each of `images` (`w` x `h`, row-major,
/// signed) side by side, magnified `scale` times, in a diverging map symmetric about zero with
/// each image on its own scale (blue negative, white zero, red positive).
pub(crate) fn coefficient_png(images: &[&[f64]], w: u32, h: u32, scale: u32) -> Result<Vec<u8>, String> {
    let gap = 6;
    let n = images.len() as u32;
    let (tw, th) = (n * w * scale + (n.saturating_sub(1)) * gap, h * scale);
    let mut canvas = image::RgbImage::from_pixel(tw.max(1), th.max(1), image::Rgb([255, 255, 255]));
    for (k, img) in images.iter().enumerate() {
        let amax = img.iter().fold(0.0f64, |a, &v| a.max(v.abs())).max(1e-300);
        let ox = k as u32 * (w * scale + gap);
        for y in 0..th {
            for x in 0..w * scale {
                let c = diverging(img[((y / scale) * w + x / scale) as usize] / amax);
                canvas.put_pixel(ox + x, y, image::Rgb([c.0, c.1, c.2]));
            }
        }
    }
    let mut out = Vec::new();
    image::DynamicImage::ImageRgb8(canvas).write_to(&mut std::io::Cursor::new(&mut out), image::ImageFormat::Png).map_err(|e| e.to_string())?;
    Ok(out)
}

/// Unseen-view error (y, degrees, log scale) against confidence (x, in [0, 1]) for several named
/// series of (confidence, error) points, one colour each, with the flag threshold `flag_below`
/// drawn as a vertical line and the gross-error bound `gross_deg` as a horizontal one. Points
/// with a non-finite coordinate are left out; errors under the axis' floor (zero included) are
/// drawn on it.
pub(crate) fn confidence_scatter(title: &str, series: &[(String, Vec<(f64, f64)>)], flag_below: f64, gross_deg: f64) -> Result<String, String> {
    let finite = |&&(x, y): &&(f64, f64)| x.is_finite() && y.is_finite();
    let positive: Vec<f64> = series.iter().flat_map(|(_, s)| s.iter().filter(finite).map(|p| p.1).filter(|&y| y > 0.0)).collect();
    let (lo, hi) = positive.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &y| (a.min(y), b.max(y)));
    let (ymin, ymax) = if lo.is_finite() { ((lo * 0.7).min(gross_deg * 0.5), (hi * 1.4).max(gross_deg * 2.0)) } else { (gross_deg * 0.01, gross_deg * 10.0) };
    svg((640, 400), |root| {
        let mut chart = ChartBuilder::on(root)
            .caption(title, (FONT, 16))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(-0.02..1.02, (ymin..ymax).log_scale())
            .map_err(|e| e.to_string())?;
        chart
            .configure_mesh()
            .x_desc("confidence")
            .y_desc("pose error (degrees, log scale)")
            .label_style((FONT, 12))
            .axis_desc_style((FONT, 13))
            .light_line_style(RGBColor(235, 235, 235))
            .draw()
            .map_err(|e| e.to_string())?;
        let grey = RGBColor(110, 110, 110);
        chart
            .draw_series(LineSeries::new(vec![(flag_below, ymin), (flag_below, ymax)], grey.stroke_width(2)))
            .map_err(|e| e.to_string())?
            .label(format!("flagged below {flag_below}"))
            .legend(move |(x, y)| PathElement::new(vec![(x + 9, y - 6), (x + 9, y + 6)], grey.stroke_width(2)));
        chart
            .draw_series(DashedLineSeries::new(vec![(-0.02, gross_deg), (1.02, gross_deg)], 6, 4, grey.stroke_width(1)))
            .map_err(|e| e.to_string())?
            .label(format!("gross: over {gross_deg} degrees"))
            .legend(move |(x, y)| plotters::element::DashedPathElement::new(vec![(x, y), (x + 18, y)], 5, 3, grey.stroke_width(1)));
        let colors =
            [RGBColor(31, 119, 180), RGBColor(214, 39, 40), RGBColor(44, 160, 44), RGBColor(148, 103, 189), RGBColor(255, 127, 14), RGBColor(23, 190, 207)];
        for (i, (name, s)) in series.iter().enumerate() {
            let c = colors[i % colors.len()];
            let pts: Vec<(f64, f64)> = s.iter().filter(finite).map(|&(x, y)| (x.clamp(0.0, 1.0), y.max(ymin))).collect();
            chart
                .draw_series(pts.iter().map(|&p| Circle::new(p, 3, c.mix(0.55).filled())))
                .map_err(|e| e.to_string())?
                .label(name.clone())
                .legend(move |(x, y)| Circle::new((x + 9, y), 4, c.filled()));
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font((FONT, 12))
            .position(SeriesLabelPosition::LowerLeft)
            .draw()
            .map_err(|e| e.to_string())?;
        Ok(())
    })
}

/// One series of a [`loglog_grid`] panel.
pub(crate) struct LogSeries {
    /// Its name in the legend (series of one name share a legend entry).
    pub name: String,
    /// Its (x, y) points; those with a coordinate not positive and finite are left out.
    pub points: Vec<(f64, f64)>,
    /// Its colour, an index into the report's palette.
    pub color: usize,
    /// A dashed line without markers (a formula) rather than a solid one with markers (measured).
    pub dashed: bool,
}

/// One panel of a [`loglog_grid`]: its title and series.
pub(crate) struct LogPanel {
    /// The title above it.
    pub title: String,
    /// Its series.
    pub series: Vec<LogSeries>,
}

/// One row of a [`loglog_grid`]: panels sharing the y axis.
pub(crate) struct LogRow {
    /// The y axis' title.
    pub y_desc: String,
    /// How a y value is written on the axis.
    pub unit: fn(f64) -> String,
    /// The panels, left to right.
    pub panels: Vec<LogPanel>,
}

/// The report's palette, by index.
const PALETTE: [RGBColor; 6] =
    [RGBColor(31, 119, 180), RGBColor(214, 39, 40), RGBColor(44, 160, 44), RGBColor(148, 103, 189), RGBColor(255, 127, 14), RGBColor(23, 190, 207)];

/// The smallest and largest of `v`'s positive finite values, widened a little (a single value:
/// a factor of 2 each way); (1, 10) when there is none.
fn log_range(v: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = v.filter(|x| x.is_finite() && *x > 0.0).fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| (a.min(x), b.max(x)));
    match (lo.is_finite(), hi > lo) {
        (false, _) => (1.0, 10.0),
        (true, false) => (lo / 2.0, hi * 2.0),
        (true, true) => (lo / 1.3, hi * 1.3),
    }
}

/// Whether `v` is 1, 2 or 5 times a power of ten: the values a log axis labels.
fn round_log(v: f64) -> bool {
    let m = v / 10f64.powf(v.log10().floor());
    [1.0, 2.0, 5.0, 10.0].iter().any(|&k| (m - k).abs() < 1e-6 * k)
}

/// Panels on log-log axes, in rows sharing their y axis (each row's own range) and all sharing
/// the x axis, with one legend under them for every series name.
pub(crate) fn loglog_grid(x_desc: &str, rows: &[LogRow]) -> Result<String, String> {
    let cols = rows.iter().map(|r| r.panels.len()).max().unwrap_or(0).max(1);
    let positive = |p: &&(f64, f64)| p.0.is_finite() && p.0 > 0.0 && p.1.is_finite() && p.1 > 0.0;
    let all = || rows.iter().flat_map(|r| r.panels.iter().flat_map(|p| p.series.iter().flat_map(|s| s.points.iter().filter(positive))));
    let (x0, x1) = log_range(all().map(|p| p.0));
    let mut legend: Vec<(&str, usize, bool)> = Vec::new();
    for s in rows.iter().flat_map(|r| r.panels.iter().flat_map(|p| p.series.iter())) {
        if !legend.iter().any(|l| l.0 == s.name) {
            legend.push((&s.name, s.color, s.dashed));
        }
    }
    let per_color = legend.iter().map(|l| legend.iter().filter(|k| k.1 == l.1).count()).max().unwrap_or(0);
    let (panel_w, panel_h, legend_h) = (380u32, 310u32, 22 * per_color as u32 + 16);
    svg((panel_w * cols as u32, panel_h * rows.len() as u32 + legend_h), |root| {
        let (grid, key) = root.split_vertically(panel_h * rows.len() as u32);
        let areas = grid.split_evenly((rows.len(), cols));
        for (ri, row) in rows.iter().enumerate() {
            let (y0, y1) = log_range(row.panels.iter().flat_map(|p| p.series.iter().flat_map(|s| s.points.iter().filter(positive).map(|p| p.1))));
            for (ci, panel) in row.panels.iter().enumerate() {
                let mut chart = ChartBuilder::on(&areas[ri * cols + ci])
                    .caption(&panel.title, (FONT, 14))
                    .margin(8)
                    .x_label_area_size(38)
                    .y_label_area_size(62)
                    .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
                    .map_err(|e| e.to_string())?;
                chart
                    .configure_mesh()
                    .x_desc(x_desc)
                    .y_desc(&row.y_desc)
                    .x_label_formatter(&|v| if round_log(*v) { format!("{v:.0}") } else { String::new() })
                    .y_label_formatter(&|v| if round_log(*v) { (row.unit)(*v) } else { String::new() })
                    .max_light_lines(0)
                    .label_style((FONT, 11))
                    .axis_desc_style((FONT, 12))
                    .bold_line_style(RGBColor(230, 230, 230))
                    .draw()
                    .map_err(|e| e.to_string())?;
                for s in &panel.series {
                    let c = PALETTE[s.color % PALETTE.len()];
                    let mut pts: Vec<(f64, f64)> = s.points.iter().filter(positive).copied().collect();
                    pts.sort_by(|a, b| a.0.total_cmp(&b.0));
                    if s.dashed {
                        chart.draw_series(DashedLineSeries::new(pts, 6, 4, c.stroke_width(2))).map_err(|e| e.to_string())?;
                    } else {
                        chart.draw_series(LineSeries::new(pts.clone(), c.stroke_width(1))).map_err(|e| e.to_string())?;
                        chart.draw_series(pts.iter().map(|&p| Circle::new(p, 4, c.filled()))).map_err(|e| e.to_string())?;
                    }
                }
            }
        }
        // The legend: a column per colour.
        let style = (FONT, 12).into_font().color(&BLACK);
        let mut colors: Vec<usize> = Vec::new();
        for l in &legend {
            if !colors.contains(&l.1) {
                colors.push(l.1);
            }
        }
        let width = (panel_w as i32 * cols as i32 - 40) / colors.len().max(1) as i32;
        for (i, (name, color, dashed)) in legend.iter().enumerate() {
            let c = PALETTE[color % PALETTE.len()];
            let (col, row) = (colors.iter().position(|k| k == color).unwrap_or(0), legend[..i].iter().filter(|l| l.1 == *color).count());
            let (x, y) = (20 + col as i32 * width, 12 + row as i32 * 22);
            if *dashed {
                key.draw(&plotters::element::DashedPathElement::new(vec![(x, y), (x + 28, y)], 6, 4, c.stroke_width(2))).map_err(|e| e.to_string())?;
            } else {
                key.draw(&PathElement::new(vec![(x, y), (x + 28, y)], c.stroke_width(1))).map_err(|e| e.to_string())?;
                key.draw(&Circle::new((x + 14, y), 4, c.filled())).map_err(|e| e.to_string())?;
            }
            key.draw(&Text::new(name.to_string(), (x + 36, y - 7), style.clone())).map_err(|e| e.to_string())?;
        }
        Ok(())
    })
}
