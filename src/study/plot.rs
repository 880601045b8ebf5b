//! The study's plots (PNG and SVG, drawn with `plotters`) and the false-colour PNG of
//! `brume compare`.
//!
//! Text needs a font. Plotters is built without font-kit (no fontconfig/freetype): its
//! `ab_glyph` feature rasterises a TrueType file that Brume looks up at run time: `$BRUME_FONT`,
//! then common DejaVu/Liberation/Arial locations. With none found (or `BRUME_FONT=none`) the
//! plots are drawn without any text (axes, lines and bars only) and [`text_available`] says so;
//! the numbers are in the CSV and the tables either way.
use std::error::Error;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;

/// One line of the RMSE-versus-time plot.
#[derive(Clone, Debug)]
pub struct Curve {
    pub label: String,
    /// (seconds, RMSE), increasing time.
    pub points: Vec<(f64, f64)>,
    /// Colour index (configurations that differ only in majorant mode share one).
    pub colour: usize,
    /// Drawn dashed (per-leaf majorants).
    pub dashed: bool,
}

/// One bar of the efficiency chart.
#[derive(Clone, Debug)]
pub struct Bar {
    pub label: String,
    pub value: f64,
    pub colour: usize,
}

type Res<T> = Result<T, Box<dyn Error>>;

const FONT: &str = "sans-serif";

const CANDIDATE_FONTS: &[&str] = &[
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf",
    "/usr/share/fonts/liberation/LiberationSans-Regular.ttf",
    "/System/Library/Fonts/Supplemental/Arial.ttf",
    "/Library/Fonts/Arial.ttf",
    "C:\\Windows\\Fonts\\arial.ttf",
];

/// Registers a TrueType font for plot text once per process; returns the file used, or
/// `None` when plots will be drawn without text.
pub fn text_available() -> Option<&'static Path> {
    static FONT_FILE: OnceLock<Option<PathBuf>> = OnceLock::new();
    FONT_FILE
        .get_or_init(|| {
            let from_env = std::env::var_os("BRUME_FONT");
            if from_env.as_deref() == Some(std::ffi::OsStr::new("none")) {
                return None;
            }
            let candidates = from_env
                .map(PathBuf::from)
                .into_iter()
                .chain(CANDIDATE_FONTS.iter().map(PathBuf::from));
            for path in candidates {
                let Ok(bytes) = std::fs::read(&path) else {
                    continue;
                };
                // plotters keeps registered fonts for the life of the process.
                let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
                if plotters::style::register_font(FONT, FontStyle::Normal, bytes).is_ok() {
                    return Some(path);
                }
            }
            None
        })
        .as_deref()
}

/// Tableau 10 plus grey: distinct in print and for most colour-vision deficiencies.
const PALETTE: [(u8, u8, u8); 11] = [
    (31, 119, 180),
    (255, 127, 14),
    (44, 160, 44),
    (214, 39, 40),
    (148, 103, 189),
    (140, 86, 75),
    (227, 119, 194),
    (127, 127, 127),
    (188, 189, 34),
    (23, 190, 207),
    (0, 0, 0),
];

fn colour(i: usize) -> RGBColor {
    let (r, g, b) = PALETTE[i % PALETTE.len()];
    RGBColor(r, g, b)
}

/// A plot, drawn the same way on every backend on a white area; `text` says whether text can
/// be drawn.
trait Plot {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>, text: bool) -> Res<()>
    where
        DB::ErrorType: 'static;
}

/// A plot's title and what it shows.
struct Titled<'a, T> {
    title: &'a str,
    items: &'a [T],
}

/// Draws `plot` on an SVG and on a PNG next to each other: `stem.svg`, `stem.png`.
fn both(stem: &Path, size: (u32, u32), plot: &impl Plot) -> Result<Vec<PathBuf>, String> {
    let text = text_available().is_some();
    let svg = stem.with_extension("svg");
    let png = stem.with_extension("png");
    draw_on(SVGBackend::new(&svg, size).into_drawing_area(), plot, text)
        .map_err(|e| format!("{}: {e}", svg.display()))?;
    draw_on(
        BitMapBackend::new(&png, size).into_drawing_area(),
        plot,
        text,
    )
    .map_err(|e| format!("{}: {e}", png.display()))?;
    Ok(vec![png, svg])
}

/// A chart on `area`: with text, its title and axis label areas (`y_labels` pixels wide for
/// the y axis); without, thin margins.
fn chart_on<'a, 'b, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, Shift>,
    title: &str,
    text: bool,
    y_labels: u32,
) -> ChartBuilder<'a, 'b, DB> {
    let mut b = ChartBuilder::on(area);
    b.margin(12);
    if text {
        b.caption(title, (FONT, 20))
            .x_label_area_size(45)
            .y_label_area_size(y_labels);
    } else {
        b.x_label_area_size(4).y_label_area_size(4);
    }
    b
}

/// Fills `root` white, draws `plot` and writes the file.
fn draw_on<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    plot: &impl Plot,
    text: bool,
) -> Res<()>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    plot.draw(&root, text)?;
    root.present()?;
    Ok(())
}

/// RMSE against time on log-log axes, one line per configuration (per-leaf majorants dashed),
/// with a `1/sqrt(t)` line for the Monte Carlo rate through the geometric mean of the final
/// points. Writes `stem.png` and `stem.svg`.
pub fn rmse_vs_time(stem: &Path, title: &str, curves: &[Curve]) -> Result<Vec<PathBuf>, String> {
    both(
        stem,
        (1200, 650),
        &Titled {
            title,
            items: curves,
        },
    )
}

impl Plot for Titled<'_, Curve> {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>, text: bool) -> Res<()>
    where
        DB::ErrorType: 'static,
    {
        let (title, curves) = (self.title, self.items);
        let pts = || {
            curves
                .iter()
                .flat_map(|c| c.points.iter())
                .filter(|(t, r)| *t > 0.0 && *r > 0.0 && t.is_finite() && r.is_finite())
        };
        let (mut t0, mut t1, mut r0, mut r1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for &(t, r) in pts() {
            t0 = t0.min(t);
            t1 = t1.max(t);
            r0 = r0.min(r);
            r1 = r1.max(r);
        }
        if t0 > t1 {
            (t0, t1, r0, r1) = (0.1, 1.0, 0.1, 1.0);
        }
        // A diverging configuration (e.g. weighted delta with b < 1 at high albedo, whose weights
        // grow geometrically) would squash every other curve: the axis stops at 100x the median
        // final RMSE and such curves run along the top, marked "off scale" in the legend.
        let mut finals: Vec<(f64, f64)> = curves
            .iter()
            .filter_map(|c| c.points.last().copied())
            .filter(|p| p.0 > 0.0 && p.1 > 0.0 && p.1.is_finite())
            .collect();
        finals.sort_by(|a, b| a.1.total_cmp(&b.1));
        let median = finals.get(finals.len() / 2).copied();
        let cap = median.map_or(f64::INFINITY, |m| 100.0 * m.1);
        let r1 = r1.min(cap);
        let r0 = r0.min(r1 / 10.0);
        let (t0, t1, r0, r1) = (t0 / 1.2, t1 * 1.2, r0 / 1.3, r1 * 1.3);
        let off_scale = |c: &Curve| c.points.iter().any(|p| p.1 > r1);
        let (plot, legend) = root.split_horizontally(760);
        let mut b = chart_on(&plot, title, text, 70);
        let mut chart = b.build_cartesian_2d((t0..t1).log_scale(), (r0..r1).log_scale())?;
        let mut mesh = chart.configure_mesh();
        if text {
            mesh.x_desc("rendering time (s)")
                .y_desc("RMSE vs reference")
                .label_style((FONT, 14))
                .axis_desc_style((FONT, 16))
                .x_label_formatter(&|v| crate::study::report::sig(*v))
                .y_label_formatter(&|v| format!("{v:.1e}"));
            mesh.draw()?;
        } else {
            // Plotters' mesh lays out label text even with no labels: draw a frame instead.
            drop(mesh);
            frame(chart.plotting_area())?;
        }
        for c in curves {
            let style = colour(c.colour).stroke_width(2);
            let points = c
                .points
                .iter()
                .filter(|(t, r)| *t > 0.0 && *r > 0.0)
                .map(|&(t, r)| (t, r.min(r1)));
            if c.dashed {
                chart.draw_series(DashedLineSeries::new(points, 8, 5, style))?;
            } else {
                chart.draw_series(LineSeries::new(points, style))?;
            }
        }
        // The Monte Carlo rate, through the final point of median RMSE.
        if let Some((gt, gr)) = median {
            let line = [t0 * 1.2, t1 / 1.2].map(|t| (t, gr * (gt / t).sqrt()));
            chart.draw_series(DashedLineSeries::new(line, 3, 4, BLACK.stroke_width(1)))?;
        }
        if text {
            // Legend beside the plot: one row per curve.
            legend.fill(&WHITE)?;
            let row = 22;
            let style = TextStyle::from((FONT, 14)).pos(plotters::style::text_anchor::Pos::new(
                plotters::style::text_anchor::HPos::Left,
                plotters::style::text_anchor::VPos::Center,
            ));
            let mut y = 40;
            for c in curves {
                let s = colour(c.colour).stroke_width(2);
                let seg = vec![(10, y), (50, y)];
                if c.dashed {
                    legend.draw(&DashedPathElement::new(seg, 8, 5, s))?;
                } else {
                    legend.draw(&PathElement::new(seg, s))?;
                }
                let label = if off_scale(c) {
                    format!("{} (off scale)", c.label)
                } else {
                    c.label.clone()
                };
                legend.draw(&Text::new(label, (60, y), style.clone()))?;
                y += row;
            }
            legend.draw(&DashedPathElement::new(
                vec![(10, y), (50, y)],
                3,
                4,
                BLACK.stroke_width(1),
            ))?;
            legend.draw(&Text::new("1/sqrt(t)", (60, y), style.clone()))?;
        }
        Ok(())
    }
}

/// A black frame around a drawing area (the text-free stand-in for the mesh).
fn frame<DB: DrawingBackend, C: plotters::coord::CoordTranslate>(
    area: &DrawingArea<DB, C>,
) -> Res<()>
where
    DB::ErrorType: 'static,
{
    let (w, h) = area.dim_in_pixel();
    let base = area.strip_coord_spec();
    base.draw(&Rectangle::new(
        [(0, 0), (w as i32 - 1, h as i32 - 1)],
        BLACK.stroke_width(1),
    ))?;
    Ok(())
}

/// Horizontal bars of efficiency `1/(time x MSE)`, one per configuration. Writes `stem.png`
/// and `stem.svg`.
pub fn efficiency_bars(stem: &Path, title: &str, bars: &[Bar]) -> Result<Vec<PathBuf>, String> {
    let h = 120 + 28 * bars.len() as u32;
    both(stem, (1000, h), &Titled { title, items: bars })
}

impl Plot for Titled<'_, Bar> {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>, text: bool) -> Res<()>
    where
        DB::ErrorType: 'static,
    {
        let (title, bars) = (self.title, self.items);
        let n = bars.len().max(1) as i32;
        let max = bars
            .iter()
            .map(|b| b.value)
            .filter(|v| v.is_finite())
            .fold(0.0f64, f64::max)
            .max(1e-300);
        let mut b = chart_on(root, title, text, 330);
        let mut chart =
            b.build_cartesian_2d(0.0..max * 1.08, (0..(n - 1).max(1)).into_segmented())?;
        let mut mesh = chart.configure_mesh();
        mesh.disable_y_mesh();
        let labels: Vec<String> = bars.iter().map(|b| b.label.clone()).collect();
        let fmt = |v: &SegmentValue<i32>| match v {
            SegmentValue::CenterOf(i) | SegmentValue::Exact(i) => {
                labels.get(*i as usize).cloned().unwrap_or_default()
            }
            SegmentValue::Last => String::new(),
        };
        if text {
            mesh.x_desc("efficiency 1/(time x MSE)  (higher is better)")
                .label_style((FONT, 14))
                .axis_desc_style((FONT, 16))
                .y_labels(bars.len())
                .y_label_formatter(&fmt)
                .x_label_formatter(&|v| format!("{v:.2e}"));
            mesh.draw()?;
        } else {
            drop(mesh);
            frame(chart.plotting_area())?;
        }
        chart.draw_series(bars.iter().enumerate().map(|(i, b)| {
            let v = if b.value.is_finite() { b.value } else { 0.0 };
            let mut r = Rectangle::new(
                [
                    (0.0, SegmentValue::Exact(i as i32)),
                    (v, SegmentValue::Exact(i as i32 + 1)),
                ],
                colour(b.colour).filled(),
            );
            r.set_margin(3, 3, 0, 0);
            r
        }))?;
        Ok(())
    }
}

/// Writes RGB8 pixels (row-major) as a PNG.
pub fn write_rgb8_png(path: &Path, width: u32, height: u32, px: &[[u8; 3]]) -> Result<(), String> {
    let root = BitMapBackend::new(path, (width, height)).into_drawing_area();
    let err = |e: &dyn std::fmt::Display| format!("{}: {e}", path.display());
    for (i, p) in px.iter().enumerate() {
        let (x, y) = ((i as u32 % width) as i32, (i as u32 / width) as i32);
        root.draw_pixel((x, y), &RGBColor(p[0], p[1], p[2]))
            .map_err(|e| err(&e))?;
    }
    root.present().map_err(|e| err(&e))
}
