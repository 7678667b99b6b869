//! A small scatter-plot writer (PNG) with a built-in 3×5 bitmap font, so
//! plots need no system fonts: axes with ticks, labelled points, and a
//! highlighted polyline (e.g. a Pareto front).

use image::{Rgb, RgbImage};

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

const W: u32 = 960;
const H: u32 = 640;
const LEFT: u32 = 90;
const RIGHT: u32 = 30;
const TOP: u32 = 40;
const BOTTOM: u32 = 70;
const SCALE: u32 = 2;

/// 3×5 glyphs, rows top to bottom, 3 bits each (bit 2 = left column).
fn glyph(c: char) -> [u8; 5] {
    match c.to_ascii_lowercase() {
        '0' => [7, 5, 5, 5, 7],
        '1' => [2, 6, 2, 2, 7],
        '2' => [7, 1, 7, 4, 7],
        '3' => [7, 1, 3, 1, 7],
        '4' => [5, 5, 7, 1, 1],
        '5' => [7, 4, 7, 1, 7],
        '6' => [7, 4, 7, 5, 7],
        '7' => [7, 1, 1, 2, 2],
        '8' => [7, 5, 7, 5, 7],
        '9' => [7, 5, 7, 1, 7],
        'a' => [2, 5, 7, 5, 5],
        'b' => [6, 5, 6, 5, 6],
        'c' => [3, 4, 4, 4, 3],
        'd' => [6, 5, 5, 5, 6],
        'e' => [7, 4, 6, 4, 7],
        'f' => [7, 4, 6, 4, 4],
        'g' => [3, 4, 5, 5, 3],
        'h' => [5, 5, 7, 5, 5],
        'i' => [7, 2, 2, 2, 7],
        'j' => [1, 1, 1, 5, 2],
        'k' => [5, 5, 6, 5, 5],
        'l' => [4, 4, 4, 4, 7],
        'm' => [5, 7, 7, 5, 5],
        'n' => [6, 5, 5, 5, 5],
        'o' => [2, 5, 5, 5, 2],
        'p' => [6, 5, 6, 4, 4],
        'q' => [2, 5, 5, 6, 3],
        'r' => [6, 5, 6, 5, 5],
        's' => [3, 4, 2, 1, 6],
        't' => [7, 2, 2, 2, 2],
        'u' => [5, 5, 5, 5, 7],
        'v' => [5, 5, 5, 5, 2],
        'w' => [5, 5, 7, 7, 5],
        'x' => [5, 5, 2, 5, 5],
        'y' => [5, 5, 2, 2, 2],
        'z' => [7, 1, 2, 4, 7],
        '.' => [0, 0, 0, 0, 2],
        ',' => [0, 0, 0, 2, 4],
        '-' => [0, 0, 7, 0, 0],
        '+' => [0, 2, 7, 2, 0],
        '/' => [1, 1, 2, 4, 4],
        ':' => [0, 2, 0, 2, 0],
        '=' => [0, 7, 0, 7, 0],
        '(' => [1, 2, 2, 2, 1],
        ')' => [4, 2, 2, 2, 4],
        '%' => [5, 1, 2, 4, 5],
        'µ' => [5, 5, 5, 6, 4],
        _ => [0; 5],
    }
}

fn put(img: &mut RgbImage, x: i64, y: i64, c: Rgb<u8>) {
    if x >= 0 && y >= 0 && (x as u32) < img.width() && (y as u32) < img.height() {
        img.put_pixel(x as u32, y as u32, c);
    }
}

/// Draws `text` with its top-left corner at (x, y).
fn text(img: &mut RgbImage, x: i64, y: i64, s: &str, c: Rgb<u8>) {
    let mut cx = x;
    for ch in s.chars() {
        for (r, bits) in glyph(ch).iter().enumerate() {
            for col in 0..3 {
                if bits & (4 >> col) != 0 {
                    for dy in 0..SCALE as i64 {
                        for dx in 0..SCALE as i64 {
                            put(img, cx + col * SCALE as i64 + dx, y + r as i64 * SCALE as i64 + dy, c);
                        }
                    }
                }
            }
        }
        cx += 4 * SCALE as i64;
    }
}

fn line(img: &mut RgbImage, (x0, y0): (i64, i64), (x1, y1): (i64, i64), c: Rgb<u8>) {
    let n = (x1 - x0).abs().max((y1 - y0).abs()).max(1);
    for k in 0..=n {
        put(img, x0 + (x1 - x0) * k / n, y0 + (y1 - y0) * k / n, c);
    }
}

/// Writes a scatter plot of `points` to `path` (PNG), with the front
/// points joined in order of x.
pub fn scatter(
    path: &std::path::Path,
    title: &str,
    xlabel: &str,
    ylabel: &str,
    points: &[Point],
) -> Result<(), String> {
    let mut img = RgbImage::from_pixel(W, H, Rgb([255, 255, 255]));
    let (black, grey, blue, red) = (Rgb([0, 0, 0]), Rgb([200, 200, 200]), Rgb([40, 90, 200]), Rgb([210, 40, 40]));
    let fin: Vec<&Point> = points.iter().filter(|p| p.x.is_finite() && p.y.is_finite()).collect();
    let (mut x0, mut x1) = fin.iter().fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p.x), b.max(p.x)));
    let (mut y0, mut y1) = fin.iter().fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p.y), b.max(p.y)));
    if fin.is_empty() {
        (x0, x1, y0, y1) = (0.0, 1.0, 0.0, 1.0);
    }
    let (dx, dy) = ((x1 - x0).max(1e-9) * 0.08, (y1 - y0).max(1e-9) * 0.08);
    (x0, x1, y0, y1) = ((x0 - dx).max(0.0), x1 + dx, y0 - dy, y1 + dy);
    let (pw, ph) = ((W - LEFT - RIGHT) as f64, (H - TOP - BOTTOM) as f64);
    let px = |x: f64| LEFT as i64 + ((x - x0) / (x1 - x0) * pw) as i64;
    let py = |y: f64| (TOP as f64 + ph - (y - y0) / (y1 - y0) * ph) as i64;
    for k in 0..=5 {
        let (xv, yv) = (x0 + (x1 - x0) * k as f64 / 5.0, y0 + (y1 - y0) * k as f64 / 5.0);
        line(&mut img, (px(xv), TOP as i64), (px(xv), (H - BOTTOM) as i64), grey);
        line(&mut img, (LEFT as i64, py(yv)), ((W - RIGHT) as i64, py(yv)), grey);
        text(&mut img, px(xv) - 16, (H - BOTTOM) as i64 + 8, &format!("{xv:.0}"), black);
        text(&mut img, 8, py(yv) - 5, &format!("{yv:.2}"), black);
    }
    line(&mut img, (LEFT as i64, (H - BOTTOM) as i64), ((W - RIGHT) as i64, (H - BOTTOM) as i64), black);
    line(&mut img, (LEFT as i64, TOP as i64), (LEFT as i64, (H - BOTTOM) as i64), black);
    text(&mut img, LEFT as i64, 10, title, black);
    text(&mut img, (W / 2) as i64 - 60, (H - 30) as i64, xlabel, black);
    text(&mut img, 8, TOP as i64 - 22, ylabel, black);
    let mut front: Vec<&&Point> = fin.iter().filter(|p| p.front).collect();
    front.sort_by(|a, b| a.x.total_cmp(&b.x));
    for w in front.windows(2) {
        line(&mut img, (px(w[0].x), py(w[0].y)), (px(w[1].x), py(w[1].y)), red);
    }
    let mut placed: Vec<(i64, i64, i64, i64)> = Vec::new();
    for p in &fin {
        let c = if p.front { red } else { blue };
        for d in -3..=3 {
            for e in -3..=3 {
                put(&mut img, px(p.x) + d, py(p.y) + e, c);
            }
        }
        // place the label right of the point (left near the edge), moving
        // down past labels already drawn
        let w = p.label.chars().count() as i64 * 4 * SCALE as i64;
        let lh = 6 * SCALE as i64;
        let x = if px(p.x) + 7 + w > W as i64 { px(p.x) - 7 - w } else { px(p.x) + 7 };
        let mut y = py(p.y) - 12;
        while placed.iter().any(|&(ax, ay, aw, ah)| x < ax + aw && ax < x + w && y < ay + ah && ay < y + lh) {
            y += lh + 2;
        }
        placed.push((x, y, w, lh));
        text(&mut img, x, y, &p.label, c);
    }
    crate::atomic::write_png(path, &img).map_err(|e| format!("{}: cannot write PNG: {e}", path.display()))
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
}
