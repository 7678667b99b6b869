//! The trade-off plot (PNG): labelled points, axes with ticks, and a
//! highlighted polyline (e.g. a Pareto front), drawn with plotters in the
//! bundled DejaVu Sans (`assets/`, Bitstream Vera licence), so a plot needs
//! no system fonts and shows µ and ×.

use crate::error::{DrawError, Error, PlotError};
use image::RgbImage;
use plotters::prelude::*;

/// One labelled point.
#[derive(Clone, Debug)]
pub struct Point {
    /// x value (data units).
    pub x: f64,
    /// y value (data units).
    pub y: f64,
    /// Label drawn beside the point.
    pub label: String,
    /// Drawn highlighted and joined by the front line.
    pub front: bool,
}

/// Image width and height, pixels.
const W: u32 = 960;
const H: u32 = 640;
/// The font every text is drawn in.
static FONT: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");

/// Registers the bundled font as plotters' `sans-serif` (once per process).
fn register_font() -> Result<(), Error> {
    static ONCE: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    let ok = *ONCE.get_or_init(|| plotters::style::register_font("sans-serif", FontStyle::Normal, FONT).is_ok());
    ok.then_some(()).ok_or(Error::Plot(PlotError::Font))
}

/// Writes a scatter plot of `points` to `path` (PNG), with the front
/// points joined in order of x. Labels sit right of their point (left near
/// the right edge), moved down past labels already drawn.
pub fn scatter(path: &std::path::Path, title: &str, xlabel: &str, ylabel: &str, points: &[Point]) -> Result<(), Error> {
    register_font()?;
    let fin: Vec<&Point> = points.iter().filter(|p| p.x.is_finite() && p.y.is_finite()).collect();
    let (mut x0, mut x1) = fin.iter().fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p.x), b.max(p.x)));
    let (mut y0, mut y1) = fin.iter().fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p.y), b.max(p.y)));
    if fin.is_empty() {
        (x0, x1, y0, y1) = (0.0, 1.0, 0.0, 1.0);
    }
    let (dx, dy) = ((x1 - x0).max(1e-9) * 0.08, (y1 - y0).max(1e-9) * 0.08);
    (x0, x1, y0, y1) = ((x0 - dx).max(0.0), x1 + dx, y0 - dy, y1 + dy);
    let (red, blue) = (RGBColor(210, 40, 40), RGBColor(40, 90, 200));
    let mut buf = vec![0u8; (W * H * 3) as usize];
    let draw = |buf: &mut [u8]| -> Result<(), DrawError> {
        let root = BitMapBackend::with_buffer(buf, (W, H)).into_drawing_area();
        root.fill(&WHITE)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 22))
            .margin(16)
            .x_label_area_size(50)
            .y_label_area_size(70)
            .build_cartesian_2d(x0..x1, y0..y1)?;
        chart
            .configure_mesh()
            .x_desc(xlabel)
            .y_desc(ylabel)
            .label_style(("sans-serif", 15))
            .axis_desc_style(("sans-serif", 17))
            .draw()?;
        let mut front: Vec<&&Point> = fin.iter().filter(|p| p.front).collect();
        front.sort_by(|a, b| a.x.total_cmp(&b.x));
        chart.draw_series(LineSeries::new(front.iter().map(|p| (p.x, p.y)), red.stroke_width(2)))?;
        chart.draw_series(
            fin.iter().map(|p| Circle::new((p.x, p.y), 4, if p.front { red.filled() } else { blue.filled() })),
        )?;
        let mut placed: Vec<(i32, i32, i32, i32)> = Vec::new();
        for p in &fin {
            let font = ("sans-serif", 14).into_font().color(if p.front { &red } else { &blue });
            let (w, h) = root.estimate_text_size(&p.label, &font)?;
            let (w, h) = (w as i32, h as i32);
            let (px, py) = chart.backend_coord(&(p.x, p.y));
            let x = if px + 8 + w > W as i32 - 8 { px - 8 - w } else { px + 8 };
            let mut y = py - h / 2;
            while placed.iter().any(|&(ax, ay, aw, ah)| x < ax + aw && ax < x + w && y < ay + ah && ay < y + h) {
                y += h + 2;
            }
            placed.push((x, y, w, h));
            root.draw(&Text::new(p.label.clone(), (x, y), font))?;
        }
        root.present()?;
        Ok(())
    };
    draw(&mut buf).map_err(|source| PlotError::Draw { path: path.to_path_buf(), source })?;
    let img = RgbImage::from_raw(W, H, buf).ok_or(PlotError::Buffer)?;
    crate::util::atomic::write_png(path, &img).map_err(Error::io(path))
}

/// One panel of [`panels`]: a curve and a reference level.
#[derive(Clone, Debug)]
pub struct Panel {
    /// Title drawn above the panel.
    pub title: String,
    /// The curve's points (x, y), in order of x; non-finite points are left out.
    pub curve: Vec<(f64, f64)>,
    /// A level drawn as a dashed horizontal line (a published figure), if any.
    pub reference: Option<f64>,
}

/// Writes one panel per entry of `panels` to `path` (PNG, up to four
/// panels a row), each a curve in blue with its last point marked and its
/// reference as a dashed red line; the y range holds both.
pub fn panels(path: &std::path::Path, title: &str, panels: &[Panel]) -> Result<(), Error> {
    register_font()?;
    let cols = panels.len().clamp(1, 4);
    let rows = panels.len().div_ceil(cols).max(1);
    let (pw, ph) = (360u32, 280u32);
    let (w, h) = (pw * cols as u32, ph * rows as u32 + 40);
    let (red, blue) = (RGBColor(210, 40, 40), RGBColor(40, 90, 200));
    let mut buf = vec![0u8; (w * h * 3) as usize];
    let draw = |buf: &mut [u8]| -> Result<(), DrawError> {
        let root = BitMapBackend::with_buffer(buf, (w, h)).into_drawing_area();
        root.fill(&WHITE)?;
        let root = root.titled(title, ("sans-serif", 20))?;
        for (area, p) in root.split_evenly((rows, cols)).iter().zip(panels) {
            let pts: Vec<(f64, f64)> =
                p.curve.iter().copied().filter(|(x, y)| x.is_finite() && y.is_finite()).collect();
            let ys = pts.iter().map(|q| q.1).chain(p.reference);
            let (y0, y1) = ys.fold((f64::MAX, f64::MIN), |(a, b), y| (a.min(y), b.max(y)));
            let (y0, y1) = if y0 > y1 { (0.0, 1.0) } else { (y0 - 1.0, y1 + 1.0) };
            let x1 = pts.iter().map(|q| q.0).fold(0.0, f64::max).max(1e-3) * 1.05;
            let mut chart = ChartBuilder::on(area)
                .caption(&p.title, ("sans-serif", 16))
                .margin(10)
                .x_label_area_size(36)
                .y_label_area_size(44)
                .build_cartesian_2d(0.0..x1, y0..y1)?;
            chart
                .configure_mesh()
                .x_desc("minutes")
                .y_desc("PSNR (dB)")
                .label_style(("sans-serif", 12))
                .axis_desc_style(("sans-serif", 13))
                .draw()?;
            if let Some(r) = p.reference {
                chart.draw_series(DashedLineSeries::new([(0.0, r), (x1, r)], 6, 4, red.stroke_width(2)))?;
            }
            chart.draw_series(LineSeries::new(pts.iter().copied(), blue.stroke_width(2)))?;
            chart.draw_series(pts.last().map(|&q| Circle::new(q, 4, blue.filled())))?;
        }
        root.present()?;
        Ok(())
    };
    draw(&mut buf).map_err(|source| PlotError::Draw { path: path.to_path_buf(), source })?;
    let img = RgbImage::from_raw(w, h, buf).ok_or(PlotError::Buffer)?;
    crate::util::atomic::write_png(path, &img).map_err(Error::io(path))
}

/// Marks the points no other point beats on both axes (higher y at lower
/// or equal x, or equal y at lower x).
pub fn pareto(points: &mut [Point]) {
    let snapshot: Vec<(f64, f64)> = points.iter().map(|p| (p.x, p.y)).collect();
    for p in points.iter_mut() {
        p.front = !snapshot.iter().any(|&(x, y)| (x <= p.x && y > p.y) || (x < p.x && y >= p.y));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pareto_front_keeps_undominated_points() {
        let mk = |x, y| Point { x, y, label: String::new(), front: false };
        let mut pts = vec![mk(1.0, 20.0), mk(2.0, 25.0), mk(3.0, 24.0), mk(4.0, 30.0)];
        pareto(&mut pts);
        assert_eq!(pts.iter().map(|p| p.front).collect::<Vec<_>>(), [true, true, false, true]);
    }

    #[test]
    fn scatter_writes_a_png_with_its_points_in_their_colours() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("plot.png");
        let mk = |x, y, front| Point { x, y, label: format!("{x} µs × {y}"), front };
        let pts = [mk(1.0, 20.0, true), mk(2.0, 25.0, true), mk(3.0, 21.0, false), mk(f64::NAN, 1.0, false)];
        scatter(&path, "µ and × in a title", "µs per ray", "PSNR (dB)", &pts).unwrap();
        let img = image::open(&path).unwrap().to_rgb8();
        assert_eq!(img.dimensions(), (W, H));
        let count = |c: [u8; 3]| img.pixels().filter(|p| p.0 == c).count();
        assert!(count([210, 40, 40]) > 100, "the front (red) is drawn");
        assert!(count([40, 90, 200]) > 20, "the other point (blue) is drawn");
    }

    #[test]
    fn panels_draw_each_curve_and_its_reference() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("panels.png");
        let curve = vec![(1.0, 20.0), (2.0, 24.0), (3.0, 25.0)];
        let with = Panel { title: "lego".into(), curve: curve.clone(), reference: Some(32.5) };
        let without = Panel { title: "bird".into(), curve, reference: None };
        panels(&path, "PSNR", std::slice::from_ref(&with)).unwrap();
        let img = image::open(&path).unwrap().to_rgb8();
        let count = |img: &RgbImage, c: [u8; 3]| img.pixels().filter(|p| p.0 == c).count();
        assert!(count(&img, [210, 40, 40]) > 100, "the reference (red) is drawn");
        assert!(count(&img, [40, 90, 200]) > 100, "the curve (blue) is drawn");
        panels(&path, "PSNR", &[without]).unwrap();
        let img = image::open(&path).unwrap().to_rgb8();
        assert_eq!(count(&img, [210, 40, 40]), 0, "no reference, no red");
        panels(&path, "PSNR", &[with.clone(), with.clone(), with.clone(), with.clone(), with]).unwrap();
        assert_eq!(image::open(&path).unwrap().to_rgb8().dimensions(), (4 * 360, 2 * 280 + 40));
    }
}
