//! PNG plots a person reads at a glance: heatmaps of tables (error maps) with a logarithmic colour
//! bar, and log-log line charts (error against run time). Drawn with plotters into memory and
//! written atomically; text uses the embedded DejaVu Sans, so nothing depends on installed fonts.

use std::path::Path;
use std::sync::Once;

use plotters::coord::ranged1d::AsRangedCoord;
use plotters::coord::{CoordTranslate, Shift};
use plotters::prelude::*;
use plotters::style::FontStyle;

use crate::error::{Error, Result};
use crate::formats::write_bytes_atomically;

const FONT: &str = "sans-serif";

/// Register the embedded font once per process (plotters keeps a global font table).
fn ensure_font() {
    static REGISTERED: Once = Once::new();
    REGISTERED.call_once(|| {
        plotters::style::register_font(FONT, FontStyle::Normal, dejavu::sans::regular())
            .unwrap_or_else(|_| panic!("the embedded DejaVu Sans is a valid font"));
    });
}

/// One heatmap: `values[i + nx * j]` at column `i` (x) and row `j` (y, drawn upwards).
#[derive(Debug, Clone)]
pub struct Panel {
    pub title: String,
    pub x: (String, f64, f64),
    pub y: (String, f64, f64),
    pub nx: usize,
    pub ny: usize,
    pub values: Vec<f64>,
}

/// A named line of `(x, y)` points.
#[derive(Debug, Clone)]
pub struct Series {
    pub name: String,
    pub points: Vec<(f64, f64)>,
}

fn plot_error(path: &Path, e: impl std::fmt::Display) -> Error {
    Error::format(path, format!("could not draw the plot: {e}"))
}

/// Encode an RGB buffer as PNG and write it atomically.
fn write_png(path: &Path, rgb: Vec<u8>, (width, height): (u32, u32)) -> Result<()> {
    let image = image::RgbImage::from_raw(width, height, rgb).expect("the buffer matches the size");
    let mut bytes = Vec::new();
    image.write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png).map_err(|e| plot_error(path, e))?;
    write_bytes_atomically(path, &bytes)
}

/// A `width x height` picture on white, drawn by `draw` and written as PNG.
fn draw_png(
    path: &Path,
    (width, height): (u32, u32),
    draw: impl FnOnce(&DrawingArea<BitMapBackend<'_>, Shift>) -> Result<()>,
) -> Result<()> {
    ensure_font();
    let mut rgb = vec![255u8; (width * height * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (width, height)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| plot_error(path, e))?;
        draw(&root)?;
        root.present().map_err(|e| plot_error(path, e))?;
    }
    write_png(path, rgb, (width, height))
}

/// A chart's legend, in a box of translucent white at `position`.
fn draw_legend<'a, DB: DrawingBackend + 'a, CT: CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
    path: &Path,
    font_size: u32,
    position: SeriesLabelPosition,
) -> Result<()> {
    chart
        .configure_series_labels()
        .label_font((FONT, font_size))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(position)
        .draw()
        .map_err(|e| plot_error(path, e))
}

type CartesianChart<'a, DB, X, Y> = ChartContext<'a, DB, Cartesian2d<X, Y>>;

/// A titled chart filling `area`, with the margin and x label area of the full-size charts.
fn titled_chart<'a, DB: DrawingBackend, X: AsRangedCoord, Y: AsRangedCoord>(
    area: &'a DrawingArea<DB, Shift>,
    path: &Path,
    (title, title_size): (&str, u32),
    y_label_area: u32,
    (x_range, y_range): (X, Y),
) -> Result<CartesianChart<'a, DB, X::CoordDescType, Y::CoordDescType>> {
    ChartBuilder::on(area)
        .caption(title, (FONT, title_size))
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(y_label_area)
        .build_cartesian_2d(x_range, y_range)
        .map_err(|e| plot_error(path, e))
}

/// Bands in a colour bar.
const COLOUR_BAR_STEPS: usize = 100;

/// A vertical colour bar, captioned `caption`, on the chart `builder` lays out: bands from `lo` to
/// `hi`, band `k` over `[a, b]` in `colour(k, a, b)`, under a y axis to `top`, its labels written
/// by `y_label` where given.
fn draw_colour_bar<DB: DrawingBackend>(
    mut builder: ChartBuilder<'_, '_, DB>,
    path: &Path,
    caption: &str,
    ((lo, hi), top): ((f64, f64), f64),
    y_label: Option<&dyn Fn(&f64) -> String>,
    colour: impl Fn(usize, f64, f64) -> RGBColor,
) -> Result<()> {
    let mut chart =
        builder.caption(caption, (FONT, 12)).build_cartesian_2d(0.0..1.0, lo..top).map_err(|e| plot_error(path, e))?;
    let mut mesh = chart.configure_mesh();
    mesh.disable_x_mesh().disable_x_axis().label_style((FONT, 12));
    if let Some(y_label) = y_label {
        mesh.y_label_formatter(y_label);
    }
    mesh.draw().map_err(|e| plot_error(path, e))?;
    let steps = COLOUR_BAR_STEPS;
    chart
        .draw_series((0..steps).map(|k| {
            let a = lo + (hi - lo) * k as f64 / steps as f64;
            let b = lo + (hi - lo) * (k + 1) as f64 / steps as f64;
            Rectangle::new([(0.0, a), (1.0, b)], colour(k, a, b).filled())
        }))
        .map_err(|e| plot_error(path, e))?;
    Ok(())
}

/// The colour of `log10(v)` on `[lo, hi]` (viridis); zero and negative values are grey, NaN (no
/// value: outside what was computed) white.
fn colour_of(v: f64, lo: f64, hi: f64) -> RGBColor {
    if v.is_nan() {
        return RGBColor(255, 255, 255);
    }
    if v <= 0.0 {
        return RGBColor(150, 150, 150);
    }
    let t = if hi > lo { ((v.log10() - lo) / (hi - lo)).clamp(0.0, 1.0) } else { 0.5 };
    ViridisRGB::get_color(t)
}

/// Heatmaps side by side in a grid of `columns`, sharing one logarithmic colour bar labelled
/// `quantity` (at most six decades, down from the largest value). Values of 0 (exact cells) are
/// drawn grey, NaN (cells without a value, such as those outside a fit's range) white. Grids of more than 16 panels draw them small, without axes: say in `title` what
/// the axes are.
pub fn heatmaps_png(path: &Path, title: &str, quantity: &str, panels: &[Panel], columns: usize) -> Result<()> {
    let columns = columns.clamp(1, panels.len().max(1));
    let rows = panels.len().div_ceil(columns);
    let panel_size = if panels.len() > 16 { 150 } else { 330 };
    let (width, height) = ((columns * panel_size + 150) as u32, (rows * panel_size + 60) as u32);
    let positive: Vec<f64> = panels.iter().flat_map(|p| p.values.iter().copied()).filter(|v| *v > 0.0).collect();
    let lo = positive.iter().copied().fold(f64::INFINITY, f64::min).log10();
    let hi = positive.iter().copied().fold(f64::NEG_INFINITY, f64::max).log10();
    // Six decades below the largest value: a few near-exact cells would otherwise stretch the
    // scale until everything else is one colour. Smaller values take the bottom colour.
    let lo = lo.max(hi - 6.0);
    let (lo, hi) = if positive.is_empty() { (0.0, 0.0) } else { (lo.floor(), hi.ceil().max(lo.floor() + 1.0)) };

    draw_png(path, (width, height), |root| {
        let (header, body) = root.split_vertically(40);
        header.titled(title, (FONT, 20)).map_err(|e| plot_error(path, e))?;
        let (grid, bar) = body.split_horizontally((columns * panel_size) as u32);
        let cells = grid.split_evenly((rows, columns));
        let small = panels.len() > 16;
        for (area, panel) in cells.iter().zip(panels) {
            let mut chart = ChartBuilder::on(area)
                .caption(&panel.title, (FONT, if small { 11 } else { 15 }))
                .margin(if small { 2 } else { 6 })
                .x_label_area_size(if small { 0 } else { 32 })
                .y_label_area_size(if small { 0 } else { 44 })
                .build_cartesian_2d(panel.x.1..panel.x.2, panel.y.1..panel.y.2)
                .map_err(|e| plot_error(path, e))?;
            if !small {
                chart
                    .configure_mesh()
                    .disable_mesh()
                    .x_desc(&panel.x.0)
                    .y_desc(&panel.y.0)
                    .label_style((FONT, 12))
                    .draw()
                    .map_err(|e| plot_error(path, e))?;
            }
            let dx = (panel.x.2 - panel.x.1) / panel.nx as f64;
            let dy = (panel.y.2 - panel.y.1) / panel.ny as f64;
            chart
                .draw_series((0..panel.ny).flat_map(|j| (0..panel.nx).map(move |i| (i, j))).map(|(i, j)| {
                    let x0 = panel.x.1 + i as f64 * dx;
                    let y0 = panel.y.1 + j as f64 * dy;
                    let colour = colour_of(panel.values[i + panel.nx * j], lo, hi);
                    Rectangle::new([(x0, y0), (x0 + dx, y0 + dy)], colour.filled())
                }))
                .map_err(|e| plot_error(path, e))?;
        }
        // The colour bar: log10 of the quantity.
        let mut builder = ChartBuilder::on(&bar);
        builder.margin_top(10).margin_bottom(40).margin_right(10).y_label_area_size(60);
        let bar_title = format!("log10 {quantity}");
        draw_colour_bar(builder, path, &bar_title, ((lo, hi), hi.max(lo + 1.0)), None, |_, a, b| {
            colour_of(10f64.powf(0.5 * (a + b)), lo, hi)
        })?;
        bar.draw(&Text::new("grey: 0 (exact)", (5, (height - 70) as i32), (FONT, 11)))
            .map_err(|e| plot_error(path, e))?;
        if panels.iter().any(|p| p.values.iter().any(|v| v.is_nan())) {
            bar.draw(&Text::new("white: no value", (5, (height - 56) as i32), (FONT, 11)))
                .map_err(|e| plot_error(path, e))?;
        }
        Ok(())
    })
}

/// A log-log chart of several series with a legend.
pub fn loglog_png(path: &Path, title: &str, x_label: &str, y_label: &str, series: &[Series]) -> Result<()> {
    loglog_labelled_png(path, title, x_label, y_label, series, &[], None)
}

/// [`loglog_png`] with a text beside each point and an optional dashed horizontal guide line.
/// `labels[k][i]` is written just above and right of point `i` of series `k` (missing entries draw
/// nothing); `guide` is `(y, legend name)`, and the y axis is widened to show it.
pub fn loglog_labelled_png(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
    labels: &[Vec<String>],
    guide: Option<(f64, &str)>,
) -> Result<()> {
    let points: Vec<(f64, f64)> =
        series.iter().flat_map(|s| s.points.iter().copied()).filter(|(x, y)| *x > 0.0 && *y > 0.0).collect();
    if points.is_empty() {
        return Err(plot_error(path, "no positive points to draw on logarithmic axes"));
    }
    let range = |values: Vec<f64>| {
        let lo = values.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        (lo / 2.0)..(hi * 2.0)
    };
    let x_range = range(points.iter().map(|p| p.0).collect());
    let guide = guide.filter(|(y, _)| y.is_finite() && *y > 0.0);
    let y_range = range(points.iter().map(|p| p.1).chain(guide.map(|g| g.0)).collect());
    let (width, height) = (900u32, 600u32);
    draw_png(path, (width, height), |root| {
        let axes = (x_range.clone().log_scale(), y_range.log_scale());
        let mut chart = titled_chart(root, path, (title, 20), 70, axes)?;
        chart
            .configure_mesh()
            .x_desc(x_label)
            .y_desc(y_label)
            .label_style((FONT, 13))
            .x_label_formatter(&|v| format!("{v:.0e}"))
            .y_label_formatter(&|v| format!("{v:.0e}"))
            .draw()
            .map_err(|e| plot_error(path, e))?;
        // Dark, distinct colours that read on white (six of Tableau 10).
        const COLOURS: [RGBColor; 6] = [
            RGBColor(31, 119, 180),
            RGBColor(23, 190, 207),
            RGBColor(214, 39, 40),
            RGBColor(255, 127, 14),
            RGBColor(44, 160, 44),
            RGBColor(148, 103, 189),
        ];
        for (k, s) in series.iter().enumerate() {
            let colour = COLOURS.get(k).copied().map_or_else(|| Palette99::pick(k).to_rgba(), |c| c.to_rgba());
            let line: Vec<(f64, f64)> = s.points.iter().copied().filter(|(x, y)| *x > 0.0 && *y > 0.0).collect();
            chart
                .draw_series(LineSeries::new(line.clone(), colour.stroke_width(2)))
                .map_err(|e| plot_error(path, e))?
                .label(&s.name)
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2)));
            chart
                .draw_series(line.iter().map(|&p| Circle::new(p, 4, colour.filled())))
                .map_err(|e| plot_error(path, e))?;
            // Each point's label, in the series' colour, just above and right of its marker.
            let texts = labels.get(k).map(Vec::as_slice).unwrap_or_default();
            let labelled = s.points.iter().zip(texts).filter(|(p, _)| p.0 > 0.0 && p.1 > 0.0);
            chart
                .draw_series(labelled.map(|(&p, text)| {
                    EmptyElement::at(p) + Text::new(text.clone(), (5, -16), (FONT, 11).into_font().color(&colour))
                }))
                .map_err(|e| plot_error(path, e))?;
        }
        if let Some((y, name)) = guide {
            // Dashed: short segments evenly spaced on the logarithmic x axis.
            let (lo, hi) = (x_range.start.ln(), x_range.end.ln());
            let steps = 60;
            let at = |i: usize| ((lo + (hi - lo) * i as f64 / steps as f64).exp(), y);
            let grey = RGBColor(90, 90, 90);
            chart
                .draw_series(
                    (0..steps).step_by(2).map(|i| PathElement::new(vec![at(i), at(i + 1)], grey.stroke_width(1))),
                )
                .map_err(|e| plot_error(path, e))?
                .label(name)
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 8, y)], grey.stroke_width(1)));
        }
        // Labelled charts fall to the right (error against time), so their upper right is taken.
        let position = if labels.is_empty() { SeriesLabelPosition::UpperRight } else { SeriesLabelPosition::LowerLeft };
        draw_legend(&mut chart, path, 14, position)?;
        Ok(())
    })
}

/// An RGB picture (8 bits per channel, rows top first) with a title, for [`images_png`].
#[derive(Debug, Clone)]
pub struct Picture {
    pub title: String,
    pub width: u32,
    pub height: u32,
    pub rgb: Vec<u8>,
}

/// A linear colour bar from 0 to `max` (viridis), labelled `label`.
#[derive(Debug, Clone)]
pub struct ColourBar {
    pub label: String,
    pub max: f64,
}

/// The viridis colour of `t` in [0, 1].
pub fn viridis(t: f64) -> [u8; 3] {
    let c = ViridisRGB::get_color(t.clamp(0.0, 1.0));
    [c.0, c.1, c.2]
}

/// Pictures side by side under a title, each captioned, with an optional colour bar at the right.
pub fn images_png(path: &Path, title: &str, pictures: &[Picture], bar: Option<&ColourBar>) -> Result<()> {
    let gap = 12u32;
    let picture_width: u32 = pictures.iter().map(|p| p.width + gap).sum::<u32>() + gap;
    let bar_width = if bar.is_some() { 110 } else { 0 };
    let tallest = pictures.iter().map(|p| p.height).max().unwrap_or(0);
    let (width, height) = (picture_width + bar_width, tallest + 80);
    draw_png(path, (width, height), |root| {
        root.draw(&Text::new(title.to_string(), (gap as i32, 8), (FONT, 17))).map_err(|e| plot_error(path, e))?;
        let mut x = gap;
        for picture in pictures {
            root.draw(&Text::new(picture.title.clone(), (x as i32, 36), (FONT, 14)))
                .map_err(|e| plot_error(path, e))?;
            for j in 0..picture.height {
                for i in 0..picture.width {
                    let k = 3 * (i + picture.width * j) as usize;
                    let colour = RGBColor(picture.rgb[k], picture.rgb[k + 1], picture.rgb[k + 2]);
                    root.draw_pixel(((x + i) as i32, (60 + j) as i32), &colour).map_err(|e| plot_error(path, e))?;
                }
            }
            x += picture.width + gap;
        }
        if let Some(bar) = bar {
            let area = root.margin(60, 20, picture_width as i32, 10);
            let mut builder = ChartBuilder::on(&area);
            builder.y_label_area_size(62);
            let label = |v: &f64| format!("{v:.1e}");
            draw_colour_bar(builder, path, &bar.label, ((0.0, bar.max), bar.max), Some(&label), |k, _, _| {
                let [r, g, bl] = viridis((k as f64 + 0.5) / COLOUR_BAR_STEPS as f64);
                RGBColor(r, g, bl)
            })?;
        }
        Ok(())
    })
}

/// A line of a linear chart: a colour, and whether it is drawn dashed or as markers only.
#[derive(Debug, Clone)]
pub struct Line {
    pub name: String,
    pub points: Vec<(f64, f64)>,
    pub colour: [u8; 3],
    pub style: LineStyle,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LineStyle {
    Solid,
    Dashed,
    Markers,
}

/// A chart with linear axes over `x_range` and `y_range` and a legend.
pub fn lines_png(
    path: &Path,
    title: &str,
    (x_label, x_range): (&str, std::ops::Range<f64>),
    (y_label, y_range): (&str, std::ops::Range<f64>),
    lines: &[Line],
) -> Result<()> {
    let (width, height) = (900u32, 600u32);
    draw_png(path, (width, height), |root| {
        let mut chart = titled_chart(root, path, (title, 18), 60, (x_range, y_range))?;
        chart
            .configure_mesh()
            .x_desc(x_label)
            .y_desc(y_label)
            .label_style((FONT, 13))
            .draw()
            .map_err(|e| plot_error(path, e))?;
        for line in lines {
            let colour = RGBColor(line.colour[0], line.colour[1], line.colour[2]);
            let style = colour.stroke_width(2);
            let drawn = match line.style {
                LineStyle::Solid => chart.draw_series(LineSeries::new(line.points.clone(), style)),
                LineStyle::Dashed => {
                    // Every other segment: a dashed line plotters' bitmap backend draws everywhere.
                    let segments: Vec<PathElement<(f64, f64)>> =
                        line.points.windows(2).step_by(2).map(|w| PathElement::new(vec![w[0], w[1]], style)).collect();
                    chart.draw_series(segments)
                }
                LineStyle::Markers => {
                    chart.draw_series(line.points.iter().map(|&p| Circle::new(p, 3, colour.filled())))
                }
            }
            .map_err(|e| plot_error(path, e))?;
            let legend_style = line.style;
            drawn.label(&line.name).legend(move |(x, y)| match legend_style {
                LineStyle::Markers => PathElement::new(vec![(x + 8, y), (x + 10, y)], colour.stroke_width(5)),
                _ => PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2)),
            });
        }
        draw_legend(&mut chart, path, 13, SeriesLabelPosition::LowerLeft)?;
        Ok(())
    })
}

/// A histogram of `counts` over equal bins spanning `range`, counts on a logarithmic axis when
/// `log_counts` (empty bins then draw nothing), with vertical lines at `marks` (`(legend name,
/// x, colour)`) and a legend naming those with a name.
pub fn histogram_png(
    path: &Path,
    title: &str,
    x_label: &str,
    range: (f64, f64),
    counts: &[usize],
    log_counts: bool,
    marks: &[(String, f64, [u8; 3])],
) -> Result<()> {
    let (width, height) = (900u32, 600u32);
    let (lo, hi) = range;
    let top = counts.iter().copied().max().unwrap_or(1).max(1) as f64;
    let width_of_bin = (hi - lo) / counts.len().max(1) as f64;
    let bar_colour = RGBColor(70, 110, 170);
    draw_png(path, (width, height), |root| {
        let (header, body) = root.split_vertically(50);
        header.titled(title, (FONT, 15)).map_err(|e| plot_error(path, e))?;
        macro_rules! draw {
            ($chart:expr, $base:expr) => {{
                let mut chart = $chart;
                chart
                    .configure_mesh()
                    .x_desc(x_label)
                    .y_desc(if log_counts { "count (log scale)" } else { "count" })
                    .y_label_formatter(&|v| format!("{v:.0}"))
                    .label_style((FONT, 13))
                    .draw()
                    .map_err(|e| plot_error(path, e))?;
                chart
                    .draw_series(counts.iter().enumerate().filter(|(_, c)| **c > 0).map(|(k, &c)| {
                        let x0 = lo + k as f64 * width_of_bin;
                        Rectangle::new([(x0, $base), (x0 + width_of_bin, c as f64)], bar_colour.filled())
                    }))
                    .map_err(|e| plot_error(path, e))?;
                for (name, x, colour) in marks {
                    let colour = RGBColor(colour[0], colour[1], colour[2]);
                    let drawn = chart
                        .draw_series(std::iter::once(PathElement::new(
                            vec![(*x, $base), (*x, top * if log_counts { 3.0 } else { 1.1 })],
                            colour.stroke_width(2),
                        )))
                        .map_err(|e| plot_error(path, e))?;
                    if !name.is_empty() {
                        drawn
                            .label(name)
                            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2)));
                    }
                }
                if !marks.is_empty() {
                    draw_legend(&mut chart, path, 13, SeriesLabelPosition::UpperRight)?;
                }
            }};
        }
        if log_counts {
            draw!(
                ChartBuilder::on(&body)
                    .margin(15)
                    .x_label_area_size(45)
                    .y_label_area_size(70)
                    .build_cartesian_2d(lo..hi, (0.5..top * 3.0).log_scale())
                    .map_err(|e| plot_error(path, e))?,
                0.5
            );
        } else {
            draw!(
                ChartBuilder::on(&body)
                    .margin(15)
                    .x_label_area_size(45)
                    .y_label_area_size(70)
                    .build_cartesian_2d(lo..hi, 0.0..top * 1.1)
                    .map_err(|e| plot_error(path, e))?,
                0.0
            );
        }
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn decoded(path: &Path) -> image::RgbImage {
        image::open(path).unwrap().to_rgb8()
    }

    #[test]
    fn heatmap_and_chart_are_valid_pngs_with_colour() {
        let dir = tempfile::tempdir().unwrap();
        let panel = Panel {
            title: "test".into(),
            x: ("mu".into(), 0.0, 1.0),
            y: ("alpha".into(), 0.0, 1.0),
            nx: 4,
            ny: 3,
            values: (0..12).map(|i| if i == 0 { 0.0 } else { 10f64.powi(-(i % 5) - 2) }).collect(),
        };
        let heatmap = dir.path().join("map.png");
        heatmaps_png(&heatmap, "standard error", "s.e.", &[panel.clone(), panel], 2).unwrap();
        let image = decoded(&heatmap);
        assert!(image.width() > 600 && image.height() > 300);
        // Not a blank canvas: viridis colours and the grey of exact cells are there.
        let colours: std::collections::HashSet<[u8; 3]> = image.pixels().map(|p| p.0).collect();
        assert!(colours.len() > 20 && colours.contains(&[150, 150, 150]), "{} colours", colours.len());

        let chart = dir.path().join("chart.png");
        let series = vec![
            Series { name: "fast".into(), points: vec![(0.1, 1e-3), (0.2, 5e-4), (0.4, 2e-4)] },
            Series { name: "per-cell".into(), points: vec![(10.0, 1e-3), (20.0, 5e-4)] },
        ];
        loglog_png(&chart, "error against time", "wall time (s)", "RMS error", &series).unwrap();
        assert_eq!(decoded(&chart).dimensions(), (900, 600));
        let err = loglog_png(&chart, "t", "x", "y", &[]).unwrap_err().to_string();
        assert!(err.contains("no positive points"), "{err}");
    }
}
